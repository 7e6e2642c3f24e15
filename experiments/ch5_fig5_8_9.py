"""Figs. 5.8 and 5.9: the four tracking strategies of Table 5.1 in the realistic environment of Fig. 5.6.

As in the thesis, the strategies run in a "realistic environment"
(:class:`netcosim.controllers.planner.sikm_environment.RealisticEnvironment`): the dynamic
Fly-crane (4.10) (3 robots, edge 1 m, cables 1.5 m) driven through the robots'
velocity-tracking controllers (4.11) (alpha = 30 N s/m), MoCap measurements at 120 Hz
with Gaussian noise sigma_2 = 0.003 on every coordinate, and an unscented Kalman filter
(filterpy) whose estimate the SIKM controller reads every T.  The reference stresses
every coordinate except the y translation (as in Sec. 5.5): with ``omega = 2 pi / 30 s``,

    alpha_i(t) = 75 deg + 8 deg sin(omega t + 2 pi i / 3),
    x_V = 0.5 + 0.3 sin(omega t),  y_V = 0.5,  z_V = 0.5 + 0.15 (1 - cos(omega t)),
    phi_V = 15 deg sin(omega t),  theta_V = 5 deg sin(2 omega t),  psi_V = 5 deg sin(omega t + 1).

The start is off the reference by ``||e(0)|| = 0.05``, at rest.

Offline gain (strategy 2): ``theta = (mu, alpha, gamma1, gamma2)`` is estimated by the
QP (5.27) from one-period samples of law (5.15) in the same environment (several (k, T)
pairs, initial errors in a ball of radius 0.05, the law applied to a noisy MoCap sample,
the error norms taken on the true configuration as a simulator offers); then
``k_OFF = k_o(T; theta_hat)`` (Prop. 5.4.4) when T is inside the stability set, else
strategy 2 is skipped (the x of Table 5.2: the fitted ``tau_CR`` decides).  The thesis's
``theta = (0.02, 0.13, 0.1, 0.2)`` and a fit with the error norms read on MoCap samples
(what the rig offers) are reported beside it.  Online gains ``k_ON = tau_o(e_h)/T`` (5.12).

Fig. 5.8: q(t) for strategies 1, 2, 4 at T = 1.5 s; Fig. 5.9a: ``||e(t)||`` for all four
at T = 1.5 s; Fig. 5.9b (full run only): the tracking-error norm of each strategy
averaged over T in {0.5, 0.75, 1.5, 4} s; Fig. 5.9 (noise, ``fig5_9_noise.png``):
q(t) under strategy 2 at (k, T) = (1.28 1/s, 0.75 s) for MoCap noise sigma_1 = 0.01
and sigma_2 = 0.003.

Run ``python -m netcosim.experiments.ch5_fig5_8_9`` (``--quick``: 21 s horizon, 12 s for the noise
figure, fewer QP samples, T = 1.5 s only; the full run takes minutes).  Writes
``fig5_8.png``, ``fig5_9a.png``, ``fig5_9_noise.png`` (and ``fig5_9b.png``),
``dense.parquet``, ``samples.parquet``, ``theta.parquet``, ``summary.parquet``,
``noise.parquet``.
"""

from __future__ import annotations

import math
import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim.controllers.planner.sikm import (
    TABLE_5_1,
    SIKMParams,
    Trajectory,
    estimate_parameters,
    in_stability_set,
    optimal_offline_gain,
    tau_critical,
)
from netcosim.controllers.planner.sikm_environment import RealisticEnvironment
from netcosim.plants.flycrane.configurations import thesis_flycrane

OMEGA = 2 * math.pi / 30.0
D2R = math.pi / 180
#: MoCap noise of the thesis (Fig. 5.9 caption): sigma_2 for Figs. 5.8/5.9a-b, sigma_1 for the comparison.
SIGMA_2, SIGMA_1 = 0.003, 0.01
#: Fig. 5.9 (noise): strategy 2 at (k, T) = (1.28 1/s, 0.75 s).
NOISE_K, NOISE_T = 1.28, 0.75
#: Sec. 5.5: the thesis's estimate (mu, alpha, gamma1, gamma2) and its tau_CR.
THESIS_THETA = SIKMParams(0.02, 0.13, 0.1, 0.2)
#: Window over which strategies 1 and 2 are compared "in the first seconds" (s).
EARLY = 6.0
E0 = 0.05 * np.array([1.0, -1.0, 1.0, 0.5, -0.5, 0.5, 0.3, -0.3, 0.3]) / np.linalg.norm(
    [1.0, -1.0, 1.0, 0.5, -0.5, 0.5, 0.3, -0.3, 0.3])


def reference(sys_) -> Trajectory:
    """The reference ``(q_r(t), q_r_dot(t))`` described in the module docstring."""
    q0 = sys_.q_nominal.copy()
    ph = 2 * math.pi * np.arange(3) / 3
    w = OMEGA

    def q(t):
        d = np.zeros(9)
        d[:3] = 8 * D2R * np.sin(w * t + ph)
        d[3] = 0.3 * math.sin(w * t)
        d[5] = 0.15 * (1 - math.cos(w * t))
        d[6] = 15 * D2R * math.sin(w * t)
        d[7] = 5 * D2R * math.sin(2 * w * t)
        d[8] = 5 * D2R * math.sin(w * t + 1)
        return q0 + d

    def qd(t):
        d = np.zeros(9)
        d[:3] = 8 * D2R * w * np.cos(w * t + ph)
        d[3] = 0.3 * w * math.cos(w * t)
        d[5] = 0.15 * w * math.sin(w * t)
        d[6] = 15 * D2R * w * math.cos(w * t)
        d[7] = 5 * D2R * 2 * w * math.cos(2 * w * t)
        d[8] = 5 * D2R * w * math.cos(w * t + 1)
        return d

    return Trajectory(q, qd)


def estimate_theta(sys_, tr, quick: bool, env: RealisticEnvironment, seed: int = 0, errors: str = "truth"):
    """QP (5.27) on one-period samples of law (5.15) in *env* (error norms from *errors*:
    "truth" or "mocap"); returns ``(theta_hat, samples)``."""
    Ts = (0.5, 1.0, 1.5) if quick else (0.25, 0.5, 0.75, 1.0, 1.5, 2.0)
    pairs = [(c / T, T) for T in Ts for c in (0.6, 1.0, 1.4)]
    starts = np.linspace(0, 30, 3 if quick else 8, endpoint=False)
    df = env.interval_samples(sys_, tr, pairs, starts, radius=0.05, n_per=1 if quick else 3, seed=seed,
                              errors=errors)
    return estimate_parameters(df.k, df["T"], df.e_h, df.e_next), df


def _theta_row(source, p, n):
    return dict(source=source, mu=p.mu, alpha=p.alpha, gamma1=p.gamma1, gamma2=p.gamma2, tau_CR=tau_critical(p),
                n_samples=n)


def run(quick: bool = False, seed: int = 0):
    sys_ = thesis_flycrane(cable_length=1.5)
    tr = reference(sys_)
    env = RealisticEnvironment(noise_std=SIGMA_2)
    print("  estimating theta = (mu, alpha, gamma1, gamma2) by the QP (5.27)", flush=True)
    theta, qp_samples = estimate_theta(sys_, tr, quick, env, seed)
    theta_m, _ = estimate_theta(sys_, tr, quick, env, seed, errors="mocap")
    duration = 21.0 if quick else 60.0
    periods = (1.5,) if quick else (0.5, 0.75, 1.5, 4.0)
    dense_all, samp_all, summ = [], [], []
    q0 = tr(0.0)[0] + E0
    for T in periods:
        try:
            k_off = optimal_offline_gain(T, theta)
        except ValueError:
            k_off = None
        for s, strat in TABLE_5_1.items():
            print(f"  T = {T} s, strategy {s} ({strat.label}): {duration} s of tracking", flush=True)
            if strat.gain == "offline" and k_off is None:
                summ.append(dict(T=T, strategy=s, k_off=np.nan, feasible=False, mean_err=np.nan,
                                 early_err=np.nan, final_err=np.nan))
                continue
            samples, dense = env.track(sys_, tr, q0, T, duration, strat, k_off=k_off,
                                       params=theta if strat.gain == "offline" else None, seed=seed + 1, n_dense=6)
            for df in (samples, dense):
                df.insert(0, "strategy", s)
                df.insert(0, "T", T)
            dense_all.append(dense)
            samp_all.append(samples)
            late = dense[dense.t >= duration / 2]
            summ.append(dict(T=T, strategy=s, k_off=np.nan if k_off is None else k_off, feasible=True,
                             mean_err=float(dense.err.mean()), early_err=float(dense[dense.t <= EARLY].err.mean()),
                             final_err=float(late.err.max())))
    th = pd.DataFrame([_theta_row("thesis", THESIS_THETA, np.nan),
                       _theta_row("environment, true errors", theta, len(qp_samples)),
                       _theta_row("environment, MoCap errors", theta_m, len(qp_samples))])
    th["k_NOISE_in_stability_set"] = [in_stability_set(NOISE_K, NOISE_T, p) for p in (THESIS_THETA, theta, theta_m)]
    noise = []
    for sigma in (SIGMA_2, SIGMA_1):
        print(f"  Fig. 5.9: strategy 2 at (k, T) = ({NOISE_K}, {NOISE_T}), MoCap noise {sigma}", flush=True)
        _, dense = RealisticEnvironment(noise_std=sigma).track(sys_, tr, q0, NOISE_T, 12.0 if quick else 60.0, 2,
                                                               k_off=NOISE_K, seed=seed + 2, n_dense=6)
        dense.insert(0, "sigma", sigma)
        noise.append(dense)
    return (pd.concat(dense_all, ignore_index=True), pd.concat(samp_all, ignore_index=True), th,
            pd.DataFrame(summ), pd.concat(noise, ignore_index=True), sys_)


def _plot_q(axes, names, sys_, runs):
    """q(t) on a 3x3 grid: load position, load attitude, cable angles (the thesis's layout)."""
    for j, ax in enumerate(axes.T.ravel()):
        idx = [3, 4, 5, 6, 7, 8, 0, 1, 2][j]
        scale = 180 / math.pi if sys_.coordinate_is_angle[idx] else 1.0
        ref = runs[0][1]
        ax.plot(ref.t, ref[f"qr{idx}"] * scale, "k", lw=1, label="reference")
        for label, d, st in runs:
            ax.plot(d.t, d[f"q{idx}"] * scale, st, label=label)
        ax.set_ylabel(names[idx] + (" [deg]" if scale != 1 else " [m]"))
    axes[0, 0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")


def plot_noise(noise, sys_, outdir):
    """Fig. 5.9 (noise): q(t) under strategy 2 at (1.28, 0.75) for the two MoCap noise levels."""
    fig, axes = plt.subplots(3, 3, figsize=(12, 8), sharex=True)
    runs = [(f"sigma = {sg}", noise[noise.sigma == sg], st) for sg, st in ((SIGMA_2, "-"), (SIGMA_1, "--"))]
    _plot_q(axes, sys_.coordinate_names, sys_, runs)
    fig.suptitle(f"Fig. 5.9: strategy 2, (k, T) = ({NOISE_K}, {NOISE_T}), MoCap noise {SIGMA_2} vs {SIGMA_1}")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_9_noise.png"), dpi=110)
    plt.close(fig)


def plot(dense, summary, sys_, outdir, quick):
    names = sys_.coordinate_names
    d15 = dense[dense["T"] == 1.5]
    fig, axes = plt.subplots(3, 3, figsize=(12, 8), sharex=True)
    _plot_q(axes, names, sys_, [(TABLE_5_1[k].label, d15[d15.strategy == k], st)
                                for k, st in ((1, "-"), (2, "--"), (4, ":")) if (d15.strategy == k).any()])
    fig.suptitle("Fig. 5.8: dynamic Fly-crane, velocity-tracking robots, MoCap + UKF, T = 1.5 s")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_8.png"), dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for s in TABLE_5_1:
        d = d15[d15.strategy == s]
        if len(d):
            ax.semilogy(d.t, np.maximum(d.err, 1e-16), label=TABLE_5_1[s].label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("||q(t) - q_r(t)||")
    ax.set_title("Fig. 5.9a: tracking error, T = 1.5 s")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_9a.png"), dpi=110)
    plt.close(fig)
    if not quick:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for s in TABLE_5_1:
            d = dense[dense.strategy == s]
            feas = summary[(summary.strategy == s) & summary.feasible]["T"].tolist()
            d = d[d["T"].isin(feas)]
            if len(d):
                grid = np.linspace(0, d.t.max(), 400)
                mean = np.mean([np.interp(grid, g.t, g.err) for _, g in d.groupby("T")], axis=0)
                ax.semilogy(grid, np.maximum(mean, 1e-16), label=f"{TABLE_5_1[s].label} (T in {feas})")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("mean over T of ||e(t)||")
        ax.set_title("Fig. 5.9b")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "fig5_9b.png"), dpi=110)
        plt.close(fig)


def main(outdir: str = "results/ch5_fig5_8_9", quick: bool = False) -> pd.DataFrame:
    """Run, save figures and Parquet; return the per-(T, strategy) summary."""
    os.makedirs(outdir, exist_ok=True)
    dense, samples, theta, summary, noise, sys_ = run(quick)
    dense.to_parquet(os.path.join(outdir, "dense.parquet"))
    samples.to_parquet(os.path.join(outdir, "samples.parquet"))
    theta.to_parquet(os.path.join(outdir, "theta.parquet"))
    summary.to_parquet(os.path.join(outdir, "summary.parquet"))
    noise.to_parquet(os.path.join(outdir, "noise.parquet"))
    plot(dense, summary, sys_, outdir, quick)
    plot_noise(noise, sys_, outdir)
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch5_fig5_8_9").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick))
        print(pd.read_parquet(os.path.join(a.outdir, "theta.parquet")))
