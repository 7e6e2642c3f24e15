"""Fig. 4.10: the ch. 4 planners applied to the dynamic model, for three values of alpha.

The gains are designed on the kinematic model exactly as for Fig. 4.8 (4-robot
non-square system, T = 1.5 s, ``K_bar = I_10``, ``D = diag(I_4, 4 I_6)``, weighted
2-norm, ``q^0`` = 80 deg, ``q^r`` = 60 deg), but the robot velocities are applied to the
Lagrangian model (4.10) through the velocity-tracking force
``F = -alpha (p_dot - u) + F_g(q)`` (4.11) with gravity compensation
(:class:`netcosim.plants.flycrane.input_modes.VelocityTrackingPlant`), starting at rest.
Theorem 4.4.1: for large alpha the closed loop behaves like the kinematic one; for
small alpha the time-scale separation is lost and convergence is not guaranteed.

The thesis does not give its alpha values; we use 0.3, 3 and 30 N s/m (robot mass
1.03 kg: velocity time constants ~3.4 s, 0.34 s and 0.034 s against T = 1.5 s).  The
plant is integrated with LSODA (rtol 1e-8, atol 1e-10) between samples; the smallest
cable tension at each sample is recorded (a negative value means the taut-cable model
has become invalid).

Also draws Fig. 4.4 (Sec. 4.3, the physical meaning of the projection (4.4)): from
``q^r`` with the velocity ``q_dot_0`` of :data:`PROJECTION_QDOT0` (cable angles
opening, platform rising and moving along x), the robots are given the constant
``u = A_{q0} q_dot_0``; it is feasible at the start and leaves ``Im A_q`` as the angles
grow, and the robot velocities ``p_dot = A_q q_dot`` then follow the projection
``u_q = A_q A_q^+ u`` instead of ``u`` (alpha = 30 N s/m, 2 s, before the cable angles
reach the singular configuration near 110 deg).

Run ``python -m netcosim.experiments.ch4_fig4_10`` (``--quick``: 10 samples, 16 Monte-Carlo
samples).  Writes ``fig4_4.png``, ``fig4_10.png``, ``samples.parquet``, ``summary.parquet`` and
``collisions.parquet`` (closest robot-robot approach per run, along the dense trajectory).
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from netcosim.controllers.planner import OfflineGain, OnlineGain, WeightedNorm, sampled_velocity
from netcosim.controllers.planner.clearance import trajectory_clearance
from netcosim.controllers.planner.gain_design import design_nonsquare, estimate_mu
from netcosim.experiments.ch4_fig4_8_9 import KBAR, WEIGHTS, T, setting
from netcosim.plants.flycrane.input_modes import VelocityTrackingPlant

ALPHAS = (0.3, 3.0, 30.0)


def simulate_dynamic(sys_, plant, q0, q_ref, gain, norm, n_samples, trace: list | None = None, trace_dt: float = 0.1):
    """Sampled planner on the velocity-tracking dynamic plant; one row per sample.

    *trace*: a list to which ``(t, q)`` pairs are appended every *trace_dt* seconds
    (from the integrator's dense output; the integration itself is the same)."""
    x = plant.initial_state(q0)
    rows = []
    m = sys_.m
    for h in range(n_samples + 1):
        q = x[:m]
        err = norm(q - q_ref)
        if h == n_samples:
            rows.append((h, h * T, np.nan, err, float(np.linalg.norm(x[m:])), np.nan))
            if trace is not None:
                trace.append((h * T, q.copy()))
            break
        k, _ = gain(sys_, q, q_ref, T, KBAR, norm)
        u = sampled_velocity(sys_, q, q_ref, k, KBAR)
        rows.append((h, h * T, k, err, float(np.linalg.norm(x[m:])), plant.min_tension(x, u)))
        sol = solve_ivp(lambda t, y: plant.f(t, y, u, None), (0.0, T), x, method="LSODA", rtol=1e-8, atol=1e-10,
                        dense_output=trace is not None)
        if sol.status != 0:
            raise RuntimeError(f"dynamic plant integration failed at sample {h}: {sol.message}")
        if trace is not None:
            n_tr = int(round(T / trace_dt))
            trace.extend((h * T + j * T / n_tr, sol.sol(j * T / n_tr)[:m]) for j in range(n_tr))
        x = sol.y[:, -1]
    return pd.DataFrame(rows, columns=["h", "t", "k", "err", "qdot_norm", "min_tension"])


def _max_ratio(err, floor=1e-7):
    e0, e1 = err[:-1], err[1:]
    keep = e0 > floor
    return float((e1[keep] / e0[keep]).max())


def run(quick: bool = False, seed: int = 0, clearance: list | None = None):
    """Both strategies for each alpha; returns ``(samples, summary)``.  *clearance*: a
    list that receives one row per run with the closest robot-robot approach along the
    dense trajectory (0.1 s grid, :func:`trajectory_clearance`)."""
    sys_, q_ref, q0s = setting()
    q0 = q0s["q2"]
    norm = WeightedNorm(WEIGHTS, 2)
    est = estimate_mu(sys_, q_ref, 1.05 * norm(q0 - q_ref), n_samples=16 if quick else 200, kbar=KBAR,
                      norm=norm, seed=seed)
    d = design_nonsquare(est.mu_hat, KBAR)
    n_samples = 10 if quick else 30
    rows, summ, clear = [], [], []
    for alpha in ALPHAS:
        plant = VelocityTrackingPlant(sys_, alpha)
        for strategy, gain in (("offline", OfflineGain(d.gain(T))), ("online", OnlineGain())):
            trace: list = []
            df = simulate_dynamic(sys_, plant, q0, q_ref, gain, norm, n_samples, trace=trace)
            ca = trajectory_clearance(sys_, [t for t, _ in trace], [q for _, q in trace])
            clear.append(dict(alpha=alpha, strategy=strategy, **ca.as_row()))
            df.insert(0, "strategy", strategy)
            df.insert(0, "alpha", alpha)
            rows.append(df)
            summ.append(dict(alpha=alpha, strategy=strategy, mu_hat=est.mu_hat, rho=d.rho,
                             final_err=float(df.err.iloc[-1]), max_err_late=float(df.err.iloc[-4:].max()),
                             # per-sample ratio, above the integrator's noise floor (1e-7)
                             max_contraction=_max_ratio(df.err.values),
                             min_tension=float(np.nanmin(df.min_tension))))
    if clearance is not None:
        clearance.extend(clear)
    return pd.concat(rows, ignore_index=True), pd.DataFrame(summ)


#: Fig. 4.4: initial q_dot (cable angles in rad/s, platform in m/s and rad/s).
PROJECTION_QDOT0 = np.concatenate([np.radians([25.0, 15.0, 20.0, 10.0]), [0.1, 0.0, 0.2, 0.0, 0.0, 0.0]])


def projection_run(alpha: float = 30.0, duration: float = 2.0, n: int = 201) -> pd.DataFrame:
    """Fig. 4.4: constant ``u = A_{q0} q_dot_0`` [m/s] applied through (4.11) from
    ``q^r`` moving at :data:`PROJECTION_QDOT0`; one row per instant (``n`` over
    *duration* s): ``t``, the robot velocities ``pdot_i`` and ``uq_i`` (i over the
    n = 12 coordinates, m/s), ``dist_u = ||p_dot - u||``, ``dist_uq = ||p_dot - u_q||``
    and ``infeasible = ||u - u_q||`` (the part of u outside Im A_q), all in m/s."""
    sys_, q_ref, _ = setting()
    m = sys_.m
    u = sys_.jacobian(q_ref) @ PROJECTION_QDOT0
    plant = VelocityTrackingPlant(sys_, alpha)
    ts = np.linspace(0.0, duration, n)
    sol = solve_ivp(lambda t, y: plant.f(t, y, u, None), (0.0, duration), plant.initial_state(q_ref, PROJECTION_QDOT0),
                    t_eval=ts, method="LSODA", rtol=1e-8, atol=1e-10)
    if sol.status != 0:
        raise RuntimeError(f"Fig. 4.4 integration failed: {sol.message}")
    rows = []
    for i, t in enumerate(sol.t):
        q, qd = sol.y[:m, i], sol.y[m:, i]
        A = sys_.jacobian(q)
        pdot, uq = A @ qd, A @ (np.linalg.pinv(A) @ u)
        rows.append(dict(t=float(t), **{f"pdot_{j}": v for j, v in enumerate(pdot)},
                         **{f"uq_{j}": v for j, v in enumerate(uq)}, **{f"u_{j}": v for j, v in enumerate(u)},
                         dist_u=float(np.linalg.norm(pdot - u)), dist_uq=float(np.linalg.norm(pdot - uq)),
                         infeasible=float(np.linalg.norm(u - uq))))
    return pd.DataFrame(rows)


def plot_projection(df: pd.DataFrame, path: str) -> None:
    """Fig. 4.4: robot 1's velocity against u and u_q, and the distances."""
    fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for j, c in zip(range(3), ("C0", "C1", "C2")):
        axes[0].plot(df.t, df[f"pdot_{j}"], c, label=f"p_dot_1,{'xyz'[j]}")
        axes[0].plot(df.t, df[f"u_{j}"], c, ls=":", lw=1)
        axes[0].plot(df.t, df[f"uq_{j}"], c, ls="--", lw=1)
    axes[0].set_ylabel("robot 1 velocity [m/s]\n(dotted u, dashed u_q)")
    axes[0].legend(fontsize=8)
    axes[1].plot(df.t, df.dist_u, label="||p_dot - u||")
    axes[1].plot(df.t, df.dist_uq, label="||p_dot - u_q||")
    axes[1].plot(df.t, df.infeasible, "k:", label="||u - u_q|| (u outside Im A_q)")
    axes[1].set_xlabel("t [s]")
    axes[1].set_ylabel("[m/s]")
    axes[1].legend(fontsize=8)
    axes[0].set_title("Fig. 4.4: unfeasible u, p_dot -> u_q (alpha = 30 N s/m)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(outdir: str = "results/ch4_fig4_10", quick: bool = False) -> pd.DataFrame:
    """Run, save ``fig4_10.png`` and Parquet files; return the summary."""
    os.makedirs(outdir, exist_ok=True)
    clear: list = []
    samples, summary = run(quick, clearance=clear)
    samples.to_parquet(os.path.join(outdir, "samples.parquet"))
    summary.to_parquet(os.path.join(outdir, "summary.parquet"))
    pd.DataFrame(clear).to_parquet(os.path.join(outdir, "collisions.parquet"))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for alpha in ALPHAS:
        for strategy, style in (("offline", "o-"), ("online", "s--")):
            d = samples[(samples.alpha == alpha) & (samples.strategy == strategy)]
            ax.semilogy(d.t, np.maximum(d.err, 1e-16), style, ms=3, label=f"alpha = {alpha:g}, {strategy}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("||D (q - q_r)||_2")
    ax.set_title("Fig. 4.10: dynamic model (4.10)-(4.11), T = 1.5 s")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig4_10.png"), dpi=120)
    plt.close(fig)
    plot_projection(projection_run(), os.path.join(outdir, "fig4_4.png"))
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch4_fig4_10").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick))
