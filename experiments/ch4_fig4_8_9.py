"""Figs. 4.8 and 4.9: offline vs online planner on the 4-robot non-square system.

Setting of Sec. 4.6: four robots on a square platform (n = 12, m = 10), T = 1.5 s,
``K_bar = I_10``, ``D = diag(I_4, 4 I_6)`` applied to the error (``||e||_D = ||D e||_p``),
the weighted 2-norm (Fig. 4.8) and inf-norm (Fig. 4.9).  Reference
``q^r = (60, 60, 60, 60 deg, 0, 0, 0 m, 0, 0, 0)``; two initial conditions: ``q_1``
with cable angles 65 deg (close) and ``q_2`` with 80 deg (the ``q^0`` of Sec. 4.6.1).

For each norm and initial condition, ``mu_hat*`` (4.27) is estimated on the ball
whose radius is 1.05 times the initial error, ``tau_o_bar`` and ``rho`` come from the
numerical minimisation of ``g`` (4.29), the offline gain is ``tau_o_bar / T`` and the
online gain ``tau_o(e_h) / T`` (4.30).

D has two readings (:func:`netcosim.controllers.planner.networked.d_weights`, docs/flycrane_network.md):
``--d-reading literal`` (default) weighs pose errors 4 as printed, which under the
definition ``D_V = I / d_V^2`` of (4.8) means ``d_V = 1/2`` and violates (4.9);
``--d-reading assumption`` takes the d of (4.9) as (1, 1, 1, 1, 4, ..., 4), i.e.
``D = diag(I_4, I_6 / 16)``.

Also draws the offline design of Sec. 4.5.1: Fig. 4.6 (the pieces
``|1 - tau k_i| / d_i^2`` of (4.29) and their maximum) and Fig. 4.7 (the same plus
``mu tau^2``, i.e. ``g(tau; mu)``, with ``tau_s_bar`` and ``tau_o_bar``).  With this
experiment's ``K_bar = I`` every piece is the same line, so the figures use the
illustrative :data:`KBAR_EXAMPLE`, :data:`D_EXAMPLE`, :data:`MU_EXAMPLE` (the thesis
draws them without values).

Run ``python -m netcosim.experiments.ch4_fig4_8_9`` (``--quick`` for fewer Monte-Carlo samples).
Writes ``fig4_6.png``, ``fig4_7.png``, ``fig4_8.png``, ``fig4_9.png``,
``samples.parquet``, ``summary.parquet``, ``collisions.parquet`` (closest robot-robot
approach per run, between the samples too).
"""

from __future__ import annotations

import math
import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim.controllers.planner import OfflineGain, OnlineGain, WeightedNorm, simulate_sampled
from netcosim.controllers.planner.gain_design import design_nonsquare, estimate_mu, g_nonsquare
from netcosim.controllers.planner.networked import D_READINGS, d_weights
from netcosim.plants.flycrane.configurations import four_robot_nonsquare

T = 1.5
KBAR = np.ones(10)
WEIGHTS = (1.0,) * 4 + (4.0,) * 6
INITIAL_DEG = {"q1": 65.0, "q2": 80.0}
REFERENCE_DEG = 60.0
TOL = 1e-8


def setting():
    """``(system, q_ref, {name: q0})`` of Sec. 4.6."""
    sys_ = four_robot_nonsquare()
    q_ref = sys_.q_from([REFERENCE_DEG] * 4, [0] * 6)
    q0 = {k: sys_.q_from([v] * 4, [0] * 6) for k, v in INITIAL_DEG.items()}
    return sys_, q_ref, q0


def run(quick: bool = False, n_mu: int | None = None, seed: int = 0, d_reading: str = "literal"):
    """All four (norm, initial condition) pairs with D read as *d_reading*; returns ``(samples, summary)``."""
    sys_, q_ref, q0s = setting()
    weights = d_weights(d_reading)
    n_mu = n_mu or (30 if quick else 200)
    rows, summ = [], []
    for pname, p in (("2", 2), ("inf", math.inf)):
        nrm = WeightedNorm(weights, p)
        for ic, q0 in q0s.items():
            r = 1.05 * nrm(q0 - q_ref)
            est = estimate_mu(sys_, q_ref, r, n_samples=n_mu, kbar=KBAR, norm=nrm, seed=seed)
            d = design_nonsquare(est.mu_hat, KBAR)
            for strategy, gain in (("offline", OfflineGain(d.gain(T))), ("online", OnlineGain())):
                df = simulate_sampled(sys_, q0, q_ref, T, gain, kbar=KBAR, norm=nrm, n_samples=200, tol=TOL)
                df.insert(0, "strategy", strategy)
                df.insert(0, "initial", ic)
                df.insert(0, "norm", pname)
                rows.append(df)
                c = df.err.values[1:] / df.err.values[:-1]
                summ.append(dict(norm=pname, initial=ic, radius=r, mu_hat=est.mu_hat, tau_s_bar=d.tau_s,
                                 tau_o_bar=d.tau_o, rho=d.rho, k_offline=d.gain(T), strategy=strategy,
                                 samples_to_tol=int(df.h.iloc[-1]) if df.err.iloc[-1] < TOL else -1,
                                 max_contraction=float(c.max())))
    return pd.concat(rows, ignore_index=True), pd.DataFrame(summ)


#: Figs. 4.6/4.7: diagonal of K_bar [1/s, per unit flow time], weights d_i >= 1 of (4.9), mu.
KBAR_EXAMPLE = (0.5, 1.0, 2.0)
D_EXAMPLE = (1.0, 1.2, 1.5)
MU_EXAMPLE = 0.3


def g_pieces(tau, mu: float = MU_EXAMPLE, kbar=KBAR_EXAMPLE, d=D_EXAMPLE) -> pd.DataFrame:
    """Figs. 4.6/4.7 on the grid *tau* (flow time): columns ``tau``, ``piece_i`` =
    ``|1 - tau k_i| / d_i^2``, ``max`` of the pieces and ``g = max + mu tau^2`` ((4.29)
    as printed, ``form="thesis"``)."""
    tau = np.asarray(tau, dtype=float)
    k, dd = np.asarray(kbar, dtype=float), np.asarray(d, dtype=float)
    pieces = np.abs(1.0 - np.multiply.outer(tau, k)) / dd ** 2
    df = pd.DataFrame({f"piece_{i}": pieces[:, i] for i in range(k.size)})
    df.insert(0, "tau", tau)
    df["max"] = pieces.max(axis=1)
    df["g"] = g_nonsquare(tau, mu, k, dd, form="thesis")
    return df


def plot_design(path46: str, path47: str) -> None:
    """Figs. 4.6 and 4.7 for the illustrative K_bar, d and mu."""
    tau = np.linspace(0.0, 2.5, 501)
    df = g_pieces(tau)
    des = design_nonsquare(MU_EXAMPLE, KBAR_EXAMPLE, D_EXAMPLE, form="thesis")
    pieces = [c for c in df.columns if c.startswith("piece_")]
    for path, fig_no, extra in ((path46, "4.6", 0.0), (path47, "4.7", 1.0)):
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
        for i, c in enumerate(pieces):
            ax.plot(tau, df[c] + extra * MU_EXAMPLE * tau ** 2, lw=0.8, ls="--",
                    label=f"k = {KBAR_EXAMPLE[i]:g}, d = {D_EXAMPLE[i]:g}")
        if extra:
            ax.plot(tau, df.g, "k", lw=2, label=f"g(tau; mu = {MU_EXAMPLE:g}) (maximum)")
            ax.plot([des.tau_o], [des.rho], "gs", label=f"tau_o_bar = {des.tau_o:.3f}, rho = {des.rho:.3f}")
            ax.plot([des.tau_s], [1.0], "ro", label=f"tau_s_bar = {des.tau_s:.3f}")
            ax.axhline(1.0, color="k", lw=0.5)
            ax.set_title("Fig. 4.7: |1 - tau k_i| / d_i^2 + mu tau^2 and the maximum")
        else:
            ax.plot(tau, df["max"], "k", lw=2, label="maximum")
            ax.set_title("Fig. 4.6: |1 - tau k_i| / d_i^2 and the maximum")
        ax.set_xlabel("tau")
        ax.set_ylim(0, 1.6)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)


def plot(samples: pd.DataFrame, pname: str, path: str, title: str) -> None:
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for ic in INITIAL_DEG:
        for strategy, style in (("offline", "o-"), ("online", "s--")):
            d = samples[(samples.norm == pname) & (samples.initial == ic) & (samples.strategy == strategy)]
            ax.semilogy(d.t, d.err, style, ms=3, label=f"{ic}, {strategy}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"||D (q - q_r)||_{pname}")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def clearance(samples: pd.DataFrame) -> pd.DataFrame:
    """Closest robot-robot approach of each run between the samples: the non-square
    kinematic model ``p_dot = Pi_q u_h`` re-integrated with dense output (16 points per
    period, chord error bounded), :func:`netcosim.controllers.planner.clearance.sampled_clearance`."""
    from netcosim.controllers.planner.clearance import sampled_clearance
    sys_ = four_robot_nonsquare()
    return pd.DataFrame([dict(norm=n, initial=i, strategy=s, **sampled_clearance(sys_, d, T).as_row())
                         for (n, i, s), d in samples.groupby(["norm", "initial", "strategy"], sort=False)])


def main(outdir: str = "results/ch4_fig4_8_9", quick: bool = False, d_reading: str = "literal") -> pd.DataFrame:
    """Run, save the figures and Parquet files; return the summary (D read as *d_reading*)."""
    os.makedirs(outdir, exist_ok=True)
    samples, summary = run(quick, d_reading=d_reading)
    samples.to_parquet(os.path.join(outdir, "samples.parquet"))
    summary.to_parquet(os.path.join(outdir, "summary.parquet"))
    clearance(samples).to_parquet(os.path.join(outdir, "collisions.parquet"))
    plot(samples, "2", os.path.join(outdir, "fig4_8.png"), f"Fig. 4.8: weighted 2-norm, K_bar = I, D ({d_reading})")
    plot(samples, "inf", os.path.join(outdir, "fig4_9.png"), "Fig. 4.9: weighted inf-norm")
    plot_design(os.path.join(outdir, "fig4_6.png"), os.path.join(outdir, "fig4_7.png"))
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    ap = experiment_parser(__doc__, "results/ch4_fig4_8_9")
    ap.add_argument("--d-reading", choices=D_READINGS, default="literal",
                    help="how D = diag(I4, 4 I6) is read (default: literal)")
    a = ap.parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick, a.d_reading))
