"""A cable breaks during the Fly-crane's manoeuvre: which configurations still carry the load?

Beyond the thesis (its future work, §6.3): "if for example one cable breaks the system
could not be able to sustain the load anymore ... there exist rectangular
configurations which can transport the load (ch. 4).  It would be interesting to
analyse for which of these configurations the system would be still able to perform
the task."

Configurations: N = 3, 4, 5, 6 robots, each on two cables (1.5 m) to one edge of a
regular N-gon platform (edge 1 m): N = 3 is the Fly-crane of B.1 (square, n = m = 9),
N = 4 the ch. 4 system of Fig. 4.3a (n = 12, m = 10), N = 5, 6 its larger rectangular
relatives (:func:`netcosim.plants.flycrane.configurations.two_cable_polygon`).  Task:
the manoeuvre of §4.6.1 (cable angles 80 -> 60 deg, platform at rest at the origin,
level), the ch. 4 offline planner (T = 1.5 s, K_bar = I, D = diag(I, 4 I), gain designed
as Fig. 4.8) on the dynamic model (4.10) with velocity tracking (4.11), alpha = 30 N s/m,
as Fig. 4.10.  At ``t_b`` one cable breaks (a hybrid event: the integration stops at
``t_b``, the state is mapped to the post-break chart, :mod:`netcosim.plants.flycrane.cable_break`);
the robots keep their command until the next sample, from which the planner uses the
post-break model (the break is detected at once) with the same gain and the same goal
(robot positions and platform pose).

Outcome of a run: ``slack`` when a remaining cable cannot be kept taut even with the
best internal forces of the robots (the load is no longer carried as modelled; the run
stops there), ``diverged`` if the integration fails, else ``finishes`` when
``||D (q - q^r)||_2 < 1e-2`` at the end of the horizon (30 periods, 45 s) and
``holds`` when the load is carried but the goal not reached.  The analytic statics of
the goal configuration (:func:`netcosim.plants.flycrane.cable_break.static_balance`) is
reported beside each run.  By the dihedral symmetry of the platform and of the
manoeuvre every cable of a configuration is equivalent; the full run breaks every cable
anyway (a check of that symmetry), ``--quick`` only cable r1a.

Writes ``runs.parquet`` (one row per configuration x cable x break time, plus the
no-break runs), ``statics.parquet``, ``trajectory.parquet`` (the run of the figure),
``collisions.parquet`` (closest robot-robot approach per run), ``outcomes.png`` (matrix
configuration x broken cable) and ``trajectory.png``.
Run ``python -m netcosim.experiments.flycrane_cable_break`` (``--quick``: cable r1a only,
two break times).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from netcosim.controllers.planner import WeightedNorm, sampled_velocity
from netcosim.controllers.planner.gain_design import design_nonsquare, estimate_mu
from netcosim.plants.flycrane.cable_break import (
    CableBreak,
    PostBreakDynamics,
    cables,
    configuration_after_break,
    state_after_break,
    static_balance,
    system_after_break,
)
from netcosim.plants.flycrane.collisions import min_pairwise_distance
from netcosim.plants.flycrane.configurations import four_robot_nonsquare, two_cable_polygon
from netcosim.plants.flycrane.input_modes import VelocityTrackingPlant

#: Numbers of robots of the configurations.
ROBOTS = (3, 4, 5, 6)
#: Sampling period [s], velocity-tracking gain [N s/m], periods, as Fig. 4.10.
T, ALPHA, N_SAMPLES = 1.5, 30.0, 30
#: Start and goal cable angles [deg] (§4.6.1).
START_DEG, GOAL_DEG = 80.0, 60.0
#: Weight of the pose coordinates in D (D = diag(I, 4 I_6)).
POSE_WEIGHT = 4.0
#: Break times [s] (inside periods 1, 3 and 9 of the manoeuvre).
BREAK_TIMES = (0.75, 3.75, 12.75)
#: ``||D (q - q^r)||_2`` below this at the end counts as finished.
FINISH_TOL = 1e-2
#: Grid [s] on which tensions and robot positions are checked.
CHECK_DT = 0.05


def weights(system) -> np.ndarray:
    """Diagonal of D: 1 for each robot coordinate, :data:`POSE_WEIGHT` for the pose."""
    return np.array([1.0] * (system.m - 6) + [POSE_WEIGHT] * 6)


def configuration(n_robots: int):
    """``(system, q0, q_ref)`` of the configuration with *n_robots* robots."""
    sys_ = four_robot_nonsquare() if n_robots == 4 else two_cable_polygon(n_robots)
    return sys_, sys_.q_from([START_DEG] * sys_.N, [0] * 6), sys_.q_from([GOAL_DEG] * sys_.N, [0] * 6)


def offline_gain(system, q0, q_ref, n_mu: int, seed: int = 0) -> float:
    """The ch. 4 offline gain ``tau_o_bar / T`` for this configuration (as Fig. 4.8)."""
    kbar = np.ones(system.m)
    nrm = WeightedNorm(weights(system), 2)
    est = estimate_mu(system, q_ref, 1.05 * nrm(q0 - q_ref), n_samples=n_mu, kbar=kbar, norm=nrm, seed=seed)
    return design_nonsquare(est.mu_hat, kbar).gain(T)


class _Phase:
    """The model in force: the intact plant before the break, the post-break one after."""

    def __init__(self, system, q_ref, plant):
        self.system, self.q_ref, self.plant = system, q_ref, plant
        self.kbar = np.ones(system.m)
        self.norm = WeightedNorm(weights(system), 2)

    def f(self, t, x, u):
        return self.plant.f(t, x, u, None) if isinstance(self.plant, VelocityTrackingPlant) else self.plant.f(t, x, u)

    def min_tension(self, x, u) -> tuple[float, float]:
        """(minimum-norm allocation, best allocation) smallest tension [N]."""
        if isinstance(self.plant, VelocityTrackingPlant):
            t = self.plant.min_tension(x, u)
            return t, t
        t0 = float(self.plant.tensions(x, u).min())
        return t0, self.plant.best_min_tension(x, u)[0]


def simulate(n_robots: int, brk: CableBreak | None, k: float, n_samples: int = N_SAMPLES, alpha: float = ALPHA,
             check_dt: float = CHECK_DT, record: bool = False):
    """One run; returns ``(row, trajectory)``: the summary dict and (if *record*) a
    DataFrame of ``t``, ``err``, ``t_min``, ``t_min_best``, ``z_V`` and robot positions
    on the check grid (else None).  Pre-break, each period is integrated exactly as
    Fig. 4.10 (LSODA, rtol 1e-8, atol 1e-10 over ``[0, T]``)."""
    sys0, q0, q_ref0 = configuration(n_robots)
    phase = _Phase(sys0, q_ref0, VelocityTrackingPlant(sys0, alpha))
    x = phase.plant.initial_state(q0)
    broken = False
    t_min = t_best = np.inf
    slack_t, outcome, failure = np.nan, None, ""
    grid_t, grid_p, traj = [], [], []
    errs = []

    def check(tt, xx, u):
        nonlocal t_min, t_best
        a, b = phase.min_tension(xx, u)
        t_min, t_best = min(t_min, a), min(t_best, b)
        m = phase.system.m
        grid_t.append(tt)
        grid_p.append(phase.system.h(xx[:m]))
        if record:
            traj.append(dict(t=tt, err=phase.norm(xx[:m] - phase.q_ref), t_min=a, t_min_best=b,
                             z_V=xx[m - 4], broken=broken,
                             **{f"p{j}": v for j, v in enumerate(grid_p[-1])}))
        return b

    n_check = int(round(T / check_dt))
    for h in range(n_samples + 1):
        m = phase.system.m
        q = x[:m]
        errs.append(phase.norm(q - phase.q_ref))
        if h == n_samples:
            check(h * T, x, np.zeros(phase.system.n))
            break
        u = sampled_velocity(phase.system, q, phase.q_ref, k, phase.kbar)
        pieces = [(0.0, T)]
        if brk is not None and not broken and h * T <= brk.time < (h + 1) * T:
            pieces = [(0.0, brk.time - h * T), (brk.time - h * T, T)]
        for j, (a, b) in enumerate(pieces):
            if j == 1:  # the hybrid event: the cable breaks
                sys1 = system_after_break(sys0, brk.robot, brk.cable)
                x = state_after_break(sys0, sys1, x)
                phase = _Phase(sys1, configuration_after_break(sys0, sys1, q_ref0), PostBreakDynamics(sys1, alpha))
                broken = True
            if b - a <= 0:
                continue
            ts = h * T + np.array([a + (b - a) * i / max(1, round((b - a) / check_dt)) for i in
                                   range(int(max(1, round((b - a) / check_dt))))])
            try:
                sol = solve_ivp(lambda t, y: phase.f(t, y, u), (a, b), x, method="LSODA", rtol=1e-8, atol=1e-10,
                                dense_output=True)
            except Exception as exc:  # singular chart, non-finite dynamics
                outcome, failure = "diverged", f"{type(exc).__name__}: {exc}"
                break
            if sol.status != 0:
                outcome, failure = "diverged", sol.message
                break
            for tt in ts:
                if check(tt, sol.sol(tt - h * T), u) < 0.0 and broken:
                    outcome, slack_t = "slack", tt
                    break
            if outcome:
                break
            x = sol.y[:, -1]
        if outcome:
            break
    del n_check
    final_err = errs[-1] if outcome is None else np.nan
    if outcome is None:
        outcome = "finishes" if final_err < FINISH_TOL else "holds"
    ca = min_pairwise_distance(np.array(grid_t), np.array(grid_p), chord_error=None) if len(grid_t) > 1 else None
    row = dict(robots=n_robots, cable="none" if brk is None else brk.label,
               t_break=np.nan if brk is None else brk.time, outcome=outcome, final_err=final_err,
               t_slack=slack_t, min_tension=t_min, min_tension_best=t_best, failure=failure,
               **({} if ca is None else ca.as_row()))
    return row, (pd.DataFrame(traj) if record else None)
