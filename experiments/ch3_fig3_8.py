"""Fig. 3.8: offline (3.25) vs online (3.26) sampled planner on the 3-robot Fly-crane.

Setting of Sec. 3.5: platform edge 1 m, cables 1.5 m, T = 0.01 s,
``q_V^r = (0.5, 0.5, 0.5 m, 0, 0, 0)``, cable angles 75 deg.  ``mu_hat*`` is estimated by
Monte-Carlo sampling (3.19) of a small ball (r1 = 0.08) and a large one (r2 = 0.5);
the offline gain ``k* = tau_o_bar(mu_hat)/T`` uses the ball that contains the initial
condition: ``q_1(0)`` with ``||e|| < r1`` and ``q_2(0)`` with ``r1 < ||e|| < r2``.

Also draws the gain design of Sec. 3.4.1 it uses: Fig. 3.5 (``g(tau; mu)`` of (3.20) in
the three scenarios mu < 1/2, 1/2 <= mu < 1, mu >= 1, with ``tau_s_bar`` and
``tau_o_bar``) and Fig. 3.6 (``tau_s_bar(mu)`` (3.21), ``tau_o_bar(mu)`` (3.23),
``rho(mu)`` (3.24)).

Run ``python -m netcosim.experiments.ch3_fig3_8`` (``--quick`` for a fast check).  Writes
``fig3_5.png``, ``fig3_6.png``, ``fig3_8.png``, ``samples.parquet`` (one row per sample,
strategy and case), ``summary.parquet`` and ``collisions.parquet`` (closest robot-robot
approach per run, between the samples) under *outdir*.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim.controllers.planner import OfflineGain, OnlineGain, simulate_sampled
from netcosim.controllers.planner.gain_design import design, estimate_mu, g_square, rho, tau_o_bar, tau_s_bar
from netcosim.plants.flycrane.configurations import thesis_flycrane

T = 0.01
RADII = {"small": 0.08, "large": 0.5}
#: Direction of the initial errors (cable angles in rad, platform position in m, Euler
#: angles in rad), scaled to 0.06 (inside r1) and 0.4 (between r1 and r2).
DIRECTION = np.array([1.0, -1.0, 0.5, 0.5, -0.5, 0.8, 0.3, -0.3, 0.2])
INITIAL_NORMS = {"small": 0.06, "large": 0.4}
TOL = 1e-6


def run(quick: bool = False, n_mu: int | None = None, seed: int = 0):
    """Compute the two cases; returns ``(samples, summary)`` DataFrames."""
    sys_ = thesis_flycrane(cable_length=1.5)
    q_ref = sys_.q_nominal
    n_mu = n_mu or (60 if quick else 300)
    rows, summ = [], []
    for case, r in RADII.items():
        est = estimate_mu(sys_, q_ref, r, n_samples=n_mu, seed=seed)
        d = design(est.mu_hat)
        e0 = INITIAL_NORMS[case] * DIRECTION / np.linalg.norm(DIRECTION)
        for strategy, gain in (("offline", OfflineGain(d.gain(T))), ("online", OnlineGain())):
            df = simulate_sampled(sys_, q_ref + e0, q_ref, T, gain, n_samples=400, tol=TOL)
            df.insert(0, "strategy", strategy)
            df.insert(0, "case", case)
            rows.append(df)
            reached = df.index[df.err < TOL]
            summ.append(dict(case=case, radius=r, mu_hat=est.mu_hat, n_mu_samples=est.n, tau_s_bar=d.tau_s,
                             tau_o_bar=d.tau_o, rho=d.rho, k_offline=d.gain(T), strategy=strategy,
                             e0=float(np.linalg.norm(e0)),
                             samples_to_tol=int(df.h[reached[0]]) if len(reached) else -1,
                             max_contraction=float((df.err.values[1:] / df.err.values[:-1]).max())))
    return pd.concat(rows, ignore_index=True), pd.DataFrame(summ)


#: The three scenarios of Fig. 3.5, one value of mu each.
SCENARIOS = {"mu < 1/2": 0.3, "1/2 <= mu < 1": 0.75, "mu >= 1": 1.5}


def design_curves(mu_max: float = 3.0, n: int = 301) -> pd.DataFrame:
    """Fig. 3.6: ``tau_s_bar``, ``tau_o_bar`` and ``rho`` (dimensionless flow times and
    contraction) on a grid of ``mu`` from 0 to *mu_max*."""
    mus = np.linspace(0.0, mu_max, n)
    return pd.DataFrame(dict(mu=mus, tau_s_bar=[tau_s_bar(m) for m in mus],
                             tau_o_bar=[tau_o_bar(m) for m in mus], rho=[rho(m) for m in mus]))


def plot_design(path35: str, path36: str) -> None:
    """Figs. 3.5 and 3.6 from the closed forms of Sec. 3.4.1."""
    tau = np.linspace(0.0, 2.2, 441)
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), sharey=True)
    for ax, (name, mu) in zip(axes, SCENARIOS.items()):
        ax.plot(tau, g_square(tau, mu), "b", label="g(tau; mu)")
        ax.axhline(1.0, color="k", lw=0.5)
        ts, to = tau_s_bar(mu), tau_o_bar(mu)
        ax.plot([ts], [1.0], "ro", label=f"tau_s_bar = {ts:.3f}")
        ax.plot([to], [rho(mu)], "gs", label=f"tau_o_bar = {to:.3f}, rho = {rho(mu):.3f}")
        ax.set_title(f"{name} (mu = {mu:g})")
        ax.set_xlabel("tau")
        ax.set_ylim(0, 2.0)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("g(tau; mu) = |1 - tau| + mu tau^2")
    fig.suptitle("Fig. 3.5: g(tau; mu) in the three scenarios")
    fig.tight_layout()
    fig.savefig(path35, dpi=120)
    plt.close(fig)
    c = design_curves()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(c.mu, c.tau_s_bar, "r", label="tau_s_bar(mu) (3.21)")
    ax.plot(c.mu, c.tau_o_bar, "g", label="tau_o_bar(mu) (3.23)")
    ax.plot(c.mu, c.rho, "b", label="rho(mu) (3.24)")
    ax.axhline(1.0, color="k", lw=0.5)
    ax.set_xlabel("mu")
    ax.set_title("Fig. 3.6: stability bound, optimal flow time, contraction")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path36, dpi=120)
    plt.close(fig)


def plot(samples: pd.DataFrame, summary: pd.DataFrame, path: str) -> None:
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex="col")
    for j, case in enumerate(RADII):
        mu = summary[summary.case == case].mu_hat.iloc[0]
        for strategy, style in (("offline", "o-"), ("online", "s--")):
            d = samples[(samples.case == case) & (samples.strategy == strategy)]
            axes[0, j].semilogy(d.t, d.err, style, ms=3, label=strategy)
            axes[1, j].plot(d.t[:-1], d.k[:-1], style, ms=3, label=strategy)
        axes[0, j].set_title(f"r = {RADII[case]}: mu_hat* = {mu:.3f}")
        axes[0, j].set_ylabel("||q - q_r||")
        axes[1, j].set_ylabel("gain k [1/s]")
        axes[1, j].axhline(1 / T, color="k", lw=0.5)
        axes[1, j].set_xlabel("t [s]")
        axes[0, j].legend()
    fig.suptitle("Fig. 3.8: offline (3.25) vs online (3.26), Fly-crane, T = 0.01 s")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def clearance(samples: pd.DataFrame) -> pd.DataFrame:
    """Closest robot-robot approach of each run, between the samples too (square system:
    straight segments in closed form, :func:`netcosim.controllers.planner.clearance.sampled_clearance`)."""
    from netcosim.controllers.planner.clearance import sampled_clearance
    sys_ = thesis_flycrane(cable_length=1.5)
    return pd.DataFrame([dict(case=c, strategy=s, **sampled_clearance(sys_, d, T).as_row())
                         for (c, s), d in samples.groupby(["case", "strategy"], sort=False)])


def main(outdir: str = "results/ch3_fig3_8", quick: bool = False) -> pd.DataFrame:
    """Run, save ``fig3_8.png``, ``samples.parquet``, ``summary.parquet``,
    ``collisions.parquet`` (closest robot-robot approach per run); return the summary."""
    os.makedirs(outdir, exist_ok=True)
    samples, summary = run(quick)
    samples.to_parquet(os.path.join(outdir, "samples.parquet"))
    summary.to_parquet(os.path.join(outdir, "summary.parquet"))
    clearance(samples).to_parquet(os.path.join(outdir, "collisions.parquet"))
    plot(samples, summary, os.path.join(outdir, "fig3_8.png"))
    plot_design(os.path.join(outdir, "fig3_5.png"), os.path.join(outdir, "fig3_6.png"))
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch3_fig3_8").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick))
