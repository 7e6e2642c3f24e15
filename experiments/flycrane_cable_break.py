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
from netcosim.plants.flycrane.attachments import TwoCable
from netcosim.plants.flycrane.cable_break import (
    CableBreak,
    PostBreakDynamics,
    cable_labels,
    cables,
    configuration_after_break,
    platform_rotation,
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
#: A released (slack) cable counts as taut again once its robot is this much [m] farther
#: from its anchor than its length.
RETIGHTEN_TOL = 1e-4
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
        self.labels = cable_labels(system)

    def f(self, t, x, u):
        return self.plant.f(t, x, u, None) if isinstance(self.plant, VelocityTrackingPlant) else self.plant.f(t, x, u)

    def min_tension(self, x, u) -> tuple[float, float, str]:
        """(minimum-norm allocation, best allocation) smallest tension [N] and, when
        the latter is negative, the labels of the cables that go slack."""
        if isinstance(self.plant, VelocityTrackingPlant):
            ts = self.plant.tensions(x, u)
            return float(ts.min()), float(ts.min()), self.labels[int(np.argmin(ts))] if ts.min() < 0 else ""
        t0 = float(self.plant.tensions(x, u).min())
        best, ts = self.plant.best_min_tension(x, u)
        low = ",".join(self.labels[j] for j in self.plant.bottleneck(x, u)) if best < 0 else ""
        return t0, best, low


def _split_at(label: str) -> tuple[int, int]:
    return int(label[1:-1]) - 1, "ab".index(label[-1])


def simulate(n_robots: int, brk: CableBreak | None, k: float, n_samples: int = N_SAMPLES, alpha: float = ALPHA,
             check_dt: float = CHECK_DT, record: bool = False, cascade: bool = False):
    """One run; returns ``(row, trajectory)``: the summary dict and (if *record*) a
    DataFrame of ``t``, ``err``, ``t_min``, ``t_min_best``, ``z_V`` and robot positions
    on the check grid (else None).  Pre-break, each period is integrated exactly as
    Fig. 4.10 (LSODA, rtol 1e-8, atol 1e-10 over ``[0, T]``).

    *cascade*: when a remaining cable of a two-cable robot goes slack, go on with that
    cable released (the robot on its other cable, as after a break) instead of stopping;
    the released cable is watched: once its robot is as far from its anchor as its
    length it would tighten again, which is not modelled, and the run stops there
    (``after_slack = "retightens"``).  The row then also holds ``after_slack`` (the
    outcome of the continued run) and ``t_retighten``."""
    sys0, q0, q_ref0 = configuration(n_robots)
    phase = _Phase(sys0, q_ref0, VelocityTrackingPlant(sys0, alpha))
    x = phase.plant.initial_state(q0)
    broken = False
    t_min = t_best = np.inf
    slack_t, slack_cable, outcome, failure = np.nan, "", None, ""
    after, t_retighten, released = None, np.nan, None
    grid_t, grid_p, traj = [], [], []
    errs = []

    def check(tt, xx, u):
        nonlocal t_min, t_best, slack_cable
        a, b, lowest = phase.min_tension(xx, u)
        t_min, t_best = min(t_min, a), min(t_best, b)
        if b < 0.0 and broken and not slack_cable:
            slack_cable = lowest
        m = phase.system.m
        if grid_t and tt <= grid_t[-1]:  # the instant of a switch, already on the grid
            return b
        grid_t.append(tt)
        grid_p.append(phase.system.h(xx[:m]))
        if record:
            traj.append(dict(t=tt, err=phase.norm(xx[:m] - phase.q_ref), t_min=a, t_min_best=b,
                             z_V=xx[m - 4], broken=broken,
                             **{f"p{j}": v for j, v in enumerate(grid_p[-1])}))
        return b

    def released_stretch(xx) -> float:
        """Distance robot - anchor of the released cable minus its length [m]."""
        j, c = released
        m = phase.system.m
        qq = xx[:m]
        R = platform_rotation(phase.system, qq)
        att0 = sys0.attachments[j]
        anchor = qq[list(phase.system.pivot_cols)][:3] + R @ att0.anchors[c]
        return float(np.linalg.norm(phase.system.h(qq)[list(phase.system.rows[j])] - anchor) - att0.lengths[c])

    for h in range(n_samples + 1):
        m = phase.system.m
        q = x[:m]
        errs.append(phase.norm(q - phase.q_ref))
        if h == n_samples:
            check(h * T, x, np.zeros(phase.system.n))
            break
        u = sampled_velocity(phase.system, q, phase.q_ref, k, phase.kbar)
        a = 0.0
        while a < T and not (outcome and after):
            b = T
            breaking = brk is not None and not broken and h * T <= brk.time < (h + 1) * T
            if breaking and brk.time - h * T > a:
                b = brk.time - h * T
            elif breaking:  # the hybrid event: the cable breaks
                sys1 = system_after_break(sys0, brk.robot, brk.cable)
                x = state_after_break(sys0, sys1, x)
                phase = _Phase(sys1, configuration_after_break(sys0, sys1, q_ref0), PostBreakDynamics(sys1, alpha))
                broken = True
            n_grid = int(max(1, round((b - a) / check_dt)))
            ts = h * T + np.array([a + (b - a) * i / n_grid for i in range(n_grid)])
            try:
                sol = solve_ivp(lambda t, y: phase.f(t, y, u), (a, b), x, method="LSODA", rtol=1e-8, atol=1e-10,
                                dense_output=True)
            except Exception as exc:  # singular chart, non-finite dynamics
                sol, fail = None, f"{type(exc).__name__}: {exc}"
            if sol is None or sol.status != 0:
                fail = fail if sol is None else sol.message
                if outcome:
                    after = "diverged"
                else:
                    outcome = "diverged"
                failure = fail
                break
            stop = None
            for tt in ts:
                xx = sol.sol(tt - h * T)
                if released is not None and released_stretch(xx) > RETIGHTEN_TOL:
                    after, t_retighten = "retightens", tt
                    break
                if check(tt, xx, u) < 0.0 and broken:
                    if outcome:  # a second cable goes slack
                        after = "slack"
                        break
                    outcome, slack_t = "slack", tt
                    low = slack_cable.split(",")[0]
                    j, c = _split_at(low)
                    if not cascade or not isinstance(phase.system.attachments[j], TwoCable):
                        after = "stopped"
                        break
                    sys2 = system_after_break(phase.system, j, c)
                    x = state_after_break(phase.system, sys2, xx)
                    phase = _Phase(sys2, configuration_after_break(phase.system, sys2, phase.q_ref),
                                   PostBreakDynamics(sys2, alpha))
                    released, stop = (j, c), tt - h * T
                    break
            if after:
                break
            if stop is not None:
                a = stop
                continue
            x = sol.y[:, -1]
            a = b
        if after:
            break
    final_err = errs[-1] if (outcome is None or after is None) else np.nan
    if outcome is None:
        outcome = "finishes" if final_err < FINISH_TOL else "holds"
    elif after is None:
        after = "finishes" if final_err < FINISH_TOL else "holds"
    ca = min_pairwise_distance(np.array(grid_t), np.array(grid_p), chord_error=None) if len(grid_t) > 1 else None
    row = dict(robots=n_robots, cable="none" if brk is None else brk.label,
               t_break=np.nan if brk is None else brk.time, outcome=outcome,
               final_err=np.nan if outcome in ("slack", "diverged") else final_err,
               t_slack=slack_t, slack_cable=slack_cable, min_tension=t_min, min_tension_best=t_best, failure=failure,
               **({} if ca is None else ca.as_row()))
    if cascade:
        row.update(after_slack=after or "", final_err_after_slack=final_err if after else np.nan,
                   t_retighten=t_retighten)
    return row, (pd.DataFrame(traj) if record else None)


def statics(n_robots: int) -> list[dict]:
    """The analytic statics at the goal: intact and after each cable's break."""
    sys0, _, q_ref = configuration(n_robots)
    rows = []
    sb = static_balance(sys0, q_ref)
    rows.append(dict(robots=n_robots, cable="none", cables_left=len(cables(sys0)), feasible=sb.feasible,
                     margin=sb.margin, residual=sb.residual, holds=sb.holds))
    for i, c in cables(sys0):
        sys1 = system_after_break(sys0, i, c)
        sb = static_balance(sys1, configuration_after_break(sys0, sys1, q_ref))
        zero = [cable_labels(sys1)[j] for j in sb.forced_slack]
        rows.append(dict(robots=n_robots, cable=CableBreak(i, c, 0.0).label, cables_left=len(cables(sys1)),
                         feasible=sb.feasible, margin=sb.margin, residual=sb.residual, holds=sb.holds,
                         forced_slack=",".join(zero)))
    return rows


def run(quick: bool = False, robots=ROBOTS, break_times=None, n_mu: int | None = None):
    """All runs; returns ``(runs, statics)`` DataFrames."""
    n_mu = n_mu or (16 if quick else 200)
    break_times = break_times or (BREAK_TIMES[::2] if quick else BREAK_TIMES)
    rows, stat = [], []
    for N in robots:
        sys0, q0, q_ref = configuration(N)
        k = offline_gain(sys0, q0, q_ref, n_mu)
        stat += statics(N)
        row, _ = simulate(N, None, k)
        rows.append(dict(row, k=k))
        which = [(0, 0)] if quick else cables(sys0)
        for i, c in which:
            for tb in break_times:
                row, _ = simulate(N, CableBreak(i, c, tb), k)
                rows.append(dict(row, k=k))
    return pd.DataFrame(rows), pd.DataFrame(stat)


#: Colours of the outcomes in the matrix figure.
OUTCOME_COLOURS = {"finishes": "#2ca02c", "holds": "#ffbf00", "slack": "#d62728", "diverged": "#555555"}


def plot_outcomes(runs: pd.DataFrame, path: str) -> None:
    """Matrix configuration x broken cable (one sub-row per break time), coloured by outcome."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    br = runs[runs.cable != "none"]
    times = sorted(br.t_break.unique())
    labels = sorted(br.cable.unique(), key=lambda s: (int(s[1:-1]), s[-1]))
    ylab, grid = [], []
    code = {k: i for i, k in enumerate(OUTCOME_COLOURS)}
    for N in sorted(br.robots.unique()):
        for tb in times:
            ylab.append(f"N = {N}, t_b = {tb:g} s")
            line = []
            for lab in labels:
                d = br[(br.robots == N) & (br.t_break == tb) & (br.cable == lab)]
                line.append(code[d.outcome.iloc[0]] if len(d) else np.nan)
            grid.append(line)
    from matplotlib.colors import ListedColormap
    fig, ax = plt.subplots(figsize=(1.2 + 0.45 * len(labels), 1.2 + 0.32 * len(ylab)))
    ax.imshow(np.array(grid, dtype=float), cmap=ListedColormap(list(OUTCOME_COLOURS.values())), vmin=-0.5,
              vmax=len(OUTCOME_COLOURS) - 0.5, aspect="auto")
    ax.set_xticks(range(len(labels)), labels, fontsize=7, rotation=90)
    ax.set_yticks(range(len(ylab)), ylab, fontsize=7)
    ax.set_xlabel("broken cable (robot, anchor)")
    ax.legend(handles=[Patch(color=c, label=k) for k, c in OUTCOME_COLOURS.items()], fontsize=7,
              loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title("Cable break during the 80 -> 60 deg manoeuvre: outcome", fontsize=9)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_trajectories(trajs: dict, path: str) -> None:
    """Error, smallest best tension and platform height of a few runs."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 7), sharex=True)
    for name, d in trajs.items():
        axes[0].semilogy(d.t, np.maximum(d.err, 1e-12), label=name)
        axes[1].plot(d.t, d.t_min_best, label=name)
        axes[2].plot(d.t, d.z_V, label=name)
    axes[0].set_ylabel("||D (q - q^r)||_2")
    axes[1].axhline(0.0, color="k", lw=0.5)
    axes[1].set_ylabel("smallest tension,\nbest allocation [N]")
    axes[2].set_ylabel("platform z_V [m]")
    axes[2].set_xlabel("t [s]")
    axes[0].legend(fontsize=7)
    axes[0].set_title("One cable (r1a) breaks at t_b = 3.75 s", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def trajectories(robots=ROBOTS, t_break: float = BREAK_TIMES[1], n_mu: int = 16) -> dict:
    """Recorded runs of cable r1a breaking at *t_b* for each configuration."""
    out = {}
    for N in robots:
        sys0, q0, q_ref = configuration(N)
        k = offline_gain(sys0, q0, q_ref, n_mu)
        _, traj = simulate(N, CableBreak(0, 0, t_break), k, record=True)
        out[f"N = {N}"] = traj
    return out


def main(outdir: str = "results/flycrane_cable_break", quick: bool = False) -> pd.DataFrame:
    """Run, write the tables and figures; return the runs table."""
    os.makedirs(outdir, exist_ok=True)
    runs, stat = run(quick)
    runs.to_parquet(os.path.join(outdir, "runs.parquet"))
    stat.to_parquet(os.path.join(outdir, "statics.parquet"))
    col = ["robots", "cable", "t_break", "min_distance", "t_min_distance", "pair_a", "pair_b",
           "min_distance_at_samples", "chord_error", "safety_distance", "below_safety"]
    runs[col].to_parquet(os.path.join(outdir, "collisions.parquet"))
    plot_outcomes(runs, os.path.join(outdir, "outcomes.png"))
    trajs = trajectories(n_mu=16 if quick else 200)
    pd.concat([d.assign(run=k) for k, d in trajs.items()], ignore_index=True).to_parquet(
        os.path.join(outdir, "trajectory.parquet"))
    plot_trajectories(trajs, os.path.join(outdir, "trajectory.png"))
    return runs


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/flycrane_cable_break").parse_args()
    with pd.option_context("display.width", 220, "display.max_columns", 30):
        r = main(a.outdir, a.quick)
        print(r[["robots", "cable", "t_break", "outcome", "final_err", "t_slack", "slack_cable", "min_tension",
                 "min_tension_best", "min_distance", "below_safety"]].to_string())
