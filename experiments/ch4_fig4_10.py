"""Fig. 4.10: the ch. 4 planners applied to the dynamic model, for three values of alpha.

The gains are designed on the kinematic model exactly as for Fig. 4.8 (4-robot
non-square system, T = 1.5 s, ``K_bar = I_10``, ``D = diag(I_4, 4 I_6)``, weighted
2-norm, ``q^0`` = 80 deg, ``q^r`` = 60 deg), but the robot velocities are applied to the
Lagrangian model (4.10) through the velocity-tracking force
``F = -alpha (p_dot - u) + F_g(q)`` (4.11) with gravity compensation
(:class:`plants.flycrane.input_modes.VelocityTrackingPlant`), starting at rest.
Theorem 4.4.1: for large alpha the closed loop behaves like the kinematic one; for
small alpha the time-scale separation is lost and convergence is not guaranteed.

The thesis does not give its alpha values; we use 0.3, 3 and 30 N s/m (robot mass
1.03 kg: velocity time constants ~3.4 s, 0.34 s and 0.034 s against T = 1.5 s).  The
plant is integrated with LSODA (rtol 1e-8, atol 1e-10) between samples; the smallest
cable tension at each sample is recorded (a negative value means the taut-cable model
has become invalid).

Run ``python -m experiments.ch4_fig4_10`` (``--quick``: 10 samples, 16 Monte-Carlo
samples).  Writes ``fig4_10.png``, ``samples.parquet``, ``summary.parquet``.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from controllers.planner import OfflineGain, OnlineGain, WeightedNorm, sampled_velocity
from controllers.planner.gain_design import design_nonsquare, estimate_mu
from experiments.ch4_fig4_8_9 import KBAR, T, WEIGHTS, setting
from plants.flycrane.input_modes import VelocityTrackingPlant

ALPHAS = (0.3, 3.0, 30.0)


def simulate_dynamic(sys_, plant, q0, q_ref, gain, norm, n_samples):
    """Sampled planner on the velocity-tracking dynamic plant; one row per sample."""
    x = plant.initial_state(q0)
    rows = []
    m = sys_.m
    for h in range(n_samples + 1):
        q = x[:m]
        err = norm(q - q_ref)
        if h == n_samples:
            rows.append((h, h * T, np.nan, err, float(np.linalg.norm(x[m:])), np.nan))
            break
        k, _ = gain(sys_, q, q_ref, T, KBAR, norm)
        u = sampled_velocity(sys_, q, q_ref, k, KBAR)
        rows.append((h, h * T, k, err, float(np.linalg.norm(x[m:])), plant.min_tension(x, u)))
        sol = solve_ivp(lambda t, y: plant.f(t, y, u, None), (0.0, T), x, method="LSODA", rtol=1e-8, atol=1e-10)
        if sol.status != 0:
            raise RuntimeError(f"dynamic plant integration failed at sample {h}: {sol.message}")
        x = sol.y[:, -1]
    return pd.DataFrame(rows, columns=["h", "t", "k", "err", "qdot_norm", "min_tension"])


def _max_ratio(err, floor=1e-7):
    e0, e1 = err[:-1], err[1:]
    keep = e0 > floor
    return float((e1[keep] / e0[keep]).max())


def run(quick: bool = False, seed: int = 0):
    sys_, q_ref, q0s = setting()
    q0 = q0s["q2"]
    norm = WeightedNorm(WEIGHTS, 2)
    est = estimate_mu(sys_, q_ref, 1.05 * norm(q0 - q_ref), n_samples=16 if quick else 200, kbar=KBAR,
                      norm=norm, seed=seed)
    d = design_nonsquare(est.mu_hat, KBAR)
    n_samples = 10 if quick else 30
    rows, summ = [], []
    for alpha in ALPHAS:
        plant = VelocityTrackingPlant(sys_, alpha)
        for strategy, gain in (("offline", OfflineGain(d.gain(T))), ("online", OnlineGain())):
            df = simulate_dynamic(sys_, plant, q0, q_ref, gain, norm, n_samples)
            df.insert(0, "strategy", strategy)
            df.insert(0, "alpha", alpha)
            rows.append(df)
            summ.append(dict(alpha=alpha, strategy=strategy, mu_hat=est.mu_hat, rho=d.rho,
                             final_err=float(df.err.iloc[-1]), max_err_late=float(df.err.iloc[-4:].max()),
                             # per-sample ratio, above the integrator's noise floor (1e-7)
                             max_contraction=_max_ratio(df.err.values),
                             min_tension=float(np.nanmin(df.min_tension))))
    return pd.concat(rows, ignore_index=True), pd.DataFrame(summ)


def main(outdir: str = "results/ch4_fig4_10", quick: bool = False) -> pd.DataFrame:
    """Run, save ``fig4_10.png`` and Parquet files; return the summary."""
    os.makedirs(outdir, exist_ok=True)
    samples, summary = run(quick)
    samples.to_parquet(os.path.join(outdir, "samples.parquet"))
    summary.to_parquet(os.path.join(outdir, "summary.parquet"))
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
    return summary


if __name__ == "__main__":
    from experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch4_fig4_10").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick))
