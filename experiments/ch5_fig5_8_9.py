"""Figs. 5.8 and 5.9: the four tracking strategies of Table 5.1 in the realistic environment of Fig. 5.6.

As in the thesis, the strategies run in a "realistic environment"
(:class:`netcosim.controllers.planner.sikm_environment.RealisticEnvironment`): the dynamic
Fly-crane (4.10) (3 robots, edge 1 m, cables 1.5 m) driven through the robots'
velocity-tracking controllers (4.11) (alpha = 30 N s/m), MoCap measurements at 120 Hz
with Gaussian noise sigma_2 = 0.003 on every coordinate, and an unscented Kalman filter
(filterpy) whose estimate the SIKM controller reads every T.  The reference stresses
every coordinate except the y translation (as in Sec. 5.5): with ``omega = 2 pi / 30 s``
(:data:`REFERENCE_PERIOD`),

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
``theta = (0.02, 0.13, 0.1, 0.2)``, a fit with the error norms read on MoCap samples
(what the rig offers) and a fit along a 3x faster reference (10 s period; a variant:
the thesis does not print its reference's speed) are reported beside it, each fit with
a 95 % bootstrap interval over resampled sample sets (``theta.parquet``: ``<name>_lo``,
``<name>_hi``; the resamples in ``theta_bootstrap.parquet``).  Online gains
``k_ON = tau_o(e_h)/T`` (5.12).

Table 5.2 runs: every strategy at T = 0.5, 0.75, 1.5 s; at T = 4 s strategies 1 and 3
(strategy 2 when T < tau_CR of the fitted theta, strategy 4 dropped as in the thesis).
Strategy 2 runs with both gains: ``k_o(T; theta_hat)`` (= 1/T here, Prop. 5.4.4) and, as
the variant ``k_rule="printed"``, the printed gains of Table 5.2 (2, 1.28, 0.67 1/s).

Fig. 5.8: q(t) for strategies 1, 2, 4 at T = 1.5 s; Fig. 5.9a: ``||e(t)||`` for all four
at T = 1.5 s; Fig. 5.9b (``fig5_9b.png``, lines in ``fig5_9b.parquet``): the
tracking-error norm of each strategy averaged over T, every line over the same periods
(0.5, 0.75, 1.5 s; dotted: 1 and 3 over all four); Fig. 5.9 (noise,
``fig5_9_noise.png``): q(t) under strategy 2 at (k, T) = (1.28 1/s, 0.75 s) for MoCap
noise sigma_1 = 0.01 and sigma_2 = 0.003.

Run ``python -m netcosim.experiments.ch5_fig5_8_9`` (``--quick``: 9 s horizons at T = 0.75
and 1.5 s, 12 s for the noise figure, 27 QP samples per fit; the full run, 60 s horizons
and 432 QP samples per fit, takes about 10 minutes on a loaded 2-core machine).  Writes
``fig5_8.png``, ``fig5_9a.png``, ``fig5_9b.png``, ``fig5_9_noise.png``,
``dense.parquet``, ``samples.parquet``, ``theta.parquet``, ``theta_bootstrap.parquet``,
``qp_samples.parquet``, ``summary.parquet``, ``fig5_9b.parquet``, ``noise.parquet``.
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
    bootstrap_parameters,
    estimate_parameters,
    in_stability_set,
    optimal_offline_gain,
    tau_critical,
)
from netcosim.controllers.planner.sikm_environment import RealisticEnvironment
from netcosim.plants.flycrane.configurations import thesis_flycrane

#: Period of the reference (s) of Figs. 5.8/5.9 (the thesis does not print it).
REFERENCE_PERIOD = 30.0
#: The faster reference of the theta_hat variant (s): 3x faster, 9x the acceleration.
FAST_REFERENCE_PERIOD = 10.0
OMEGA = 2 * math.pi / REFERENCE_PERIOD
D2R = math.pi / 180
#: MoCap noise of the thesis (Fig. 5.9 caption): sigma_2 for Figs. 5.8/5.9a-b, sigma_1 for the comparison.
SIGMA_2, SIGMA_1 = 0.003, 0.01
#: Fig. 5.9 (noise): strategy 2 at (k, T) = (1.28 1/s, 0.75 s).
NOISE_K, NOISE_T = 1.28, 0.75
#: Sec. 5.5: the thesis's estimate (mu, alpha, gamma1, gamma2) and its tau_CR.
THESIS_THETA = SIKMParams(0.02, 0.13, 0.1, 0.2)
#: Table 5.2 as printed: T (s) -> offline gain k_off (1/s) of strategy 2 (the "printed k" variant).
PRINTED_K = {0.5: 2.0, 0.75: 1.28, 1.5: 0.67}
#: Table 5.2's x for strategy 4: not run at T = 4 s ("the error norm increases too much").
DROPPED = {(4.0, 4)}
#: Window over which strategies 1 and 2 are compared "in the first seconds" (s).
EARLY = 6.0
#: Confidence level of the bootstrap intervals of theta_hat and tau_CR, and resamples (full, quick).
LEVEL, N_BOOT, N_BOOT_QUICK = 0.95, 500, 200
E0 = 0.05 * np.array([1.0, -1.0, 1.0, 0.5, -0.5, 0.5, 0.3, -0.3, 0.3]) / np.linalg.norm(
    [1.0, -1.0, 1.0, 0.5, -0.5, 0.5, 0.3, -0.3, 0.3])


def reference(sys_, period: float = REFERENCE_PERIOD) -> Trajectory:
    """The reference ``(q_r(t), q_r_dot(t))`` described in the module docstring, with
    ``omega = 2 pi / period`` (*period* in s, default :data:`REFERENCE_PERIOD`)."""
    if not period > 0:
        raise ValueError(f"reference period must be a positive number of seconds, got {period!r}")
    q0 = sys_.q_nominal.copy()
    ph = 2 * math.pi * np.arange(3) / 3
    w = 2 * math.pi / period

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


def theta_samples(sys_, tr, quick: bool, env: RealisticEnvironment, seed: int = 0,
                  period: float = REFERENCE_PERIOD):
    """One-period samples of law (5.15) in *env* along *tr* (a reference of *period* s):
    (k, T) = (c/T, T) for c in (0.6, 1, 1.4), T in (0.5, 1, 1.5) s (quick) or (0.25 ... 2)
    s, starts spread over one reference period, initial errors in the ball of radius 0.05.
    Both the true and the MoCap error norms (``errors="both"``)."""
    Ts = (0.5, 1.0, 1.5) if quick else (0.25, 0.5, 0.75, 1.0, 1.5, 2.0)
    pairs = [(c / T, T) for T in Ts for c in (0.6, 1.0, 1.4)]
    starts = np.linspace(0, period, 3 if quick else 8, endpoint=False)
    return env.interval_samples(sys_, tr, pairs, starts, radius=0.05, n_per=1 if quick else 3, seed=seed,
                                errors="both")


def fit(samples, errors: str = "truth") -> SIKMParams:
    """QP (5.27) on :func:`theta_samples` with the true ("truth") or MoCap ("mocap") error norms."""
    suffix = "" if errors == "truth" else "_mocap"
    return estimate_parameters(samples.k, samples["T"], samples["e_h" + suffix], samples["e_next" + suffix])


def estimate_theta(sys_, tr, quick: bool, env: RealisticEnvironment, seed: int = 0, errors: str = "truth"):
    """QP (5.27) on one-period samples of law (5.15) in *env* (error norms from *errors*:
    "truth" or "mocap"); returns ``(theta_hat, samples)``."""
    df = theta_samples(sys_, tr, quick, env, seed)
    return fit(df, errors), df


def _theta_row(source, p, n, boot=None):
    row = dict(source=source, mu=p.mu, alpha=p.alpha, gamma1=p.gamma1, gamma2=p.gamma2, tau_CR=tau_critical(p),
               n_samples=n)
    lo, hi = (1 - LEVEL) / 2, 1 - (1 - LEVEL) / 2
    for c in ("mu", "alpha", "gamma1", "gamma2", "tau_CR"):
        row[c + "_lo"] = np.nan if boot is None else float(boot[c].quantile(lo))
        row[c + "_hi"] = np.nan if boot is None else float(boot[c].quantile(hi))
    return row


def theta_table(sys_, quick: bool, env: RealisticEnvironment, seed: int = 0):
    """theta_hat from the QP (5.27), each with its bootstrap interval (:data:`LEVEL`, over
    resampled sample sets): true and MoCap error norms along the reference of Figs. 5.8/5.9,
    and true norms along the faster reference (:data:`FAST_REFERENCE_PERIOD`), beside the
    thesis's theta.  Returns ``(table, samples, bootstrap)``; *table* has one row per
    ``source`` with ``mu, alpha, gamma1, gamma2, tau_CR``, their ``_lo``/``_hi`` bounds
    and ``n_samples``; *bootstrap* one row per resample and source."""
    nb = N_BOOT_QUICK if quick else N_BOOT
    rows, boots, samples = [_theta_row("thesis", THESIS_THETA, np.nan)], [], None
    for period in (REFERENCE_PERIOD, FAST_REFERENCE_PERIOD):
        print(f"  estimating theta = (mu, alpha, gamma1, gamma2) by the QP (5.27), {period:g} s reference",
              flush=True)
        df = theta_samples(sys_, reference(sys_, period), quick, env, seed, period)
        cases = (("environment, true errors", "truth"), ("environment, MoCap errors", "mocap")) \
            if period == REFERENCE_PERIOD else ((f"environment, true errors, {period:g} s reference", "truth"),)
        for source, errors in cases:
            sfx = "" if errors == "truth" else "_mocap"
            b = bootstrap_parameters(df.k, df["T"], df["e_h" + sfx], df["e_next" + sfx], n_boot=nb, seed=seed)
            rows.append(_theta_row(source, fit(df, errors), len(df), b))
            boots.append(b.assign(source=source))
        if period == REFERENCE_PERIOD:
            samples = df
    return pd.DataFrame(rows), samples, pd.concat(boots, ignore_index=True)


def one_period_error(samples) -> float:
    """``||e(T)||``: the true error norm at the first sample after the start."""
    return float(samples.loc[samples.h == 1, "err"].iloc[0])


def run(quick: bool = False, seed: int = 0):
    sys_ = thesis_flycrane(cable_length=1.5)
    tr = reference(sys_)
    env = RealisticEnvironment(noise_std=SIGMA_2)
    th, qp_samples, boot = theta_table(sys_, quick, env, seed)
    fitted = th.set_index("source").loc["environment, true errors"]
    theta = SIKMParams(*(float(fitted[c]) for c in ("mu", "alpha", "gamma1", "gamma2")))
    duration = 9.0 if quick else 60.0
    periods = (0.75, 1.5) if quick else (0.5, 0.75, 1.5, 4.0)
    dense_all, samp_all, summ = [], [], []
    q0 = tr(0.0)[0] + E0
    for T in periods:
        try:
            k_off = optimal_offline_gain(T, theta)
        except ValueError:
            k_off = None
        cases = [(s, "online" if strat.gain == "online" else "k_o(T; theta_hat)", k_off)
                 for s, strat in TABLE_5_1.items()]
        if T in PRINTED_K:
            cases.append((2, "printed", PRINTED_K[T]))
        for s, rule, k in cases:
            strat = TABLE_5_1[s]
            row = dict(T=T, strategy=s, k_rule=rule, k_off=np.nan if k is None or rule == "online" else k,
                       feasible=not (rule != "online" and k is None), run=False, mean_err=np.nan,
                       early_err=np.nan, final_err=np.nan, err_one_period=np.nan)
            if not row["feasible"] or (T, s) in DROPPED:
                summ.append(row)      # the x of Table 5.2: outside the stability set, or dropped
                continue
            print(f"  T = {T} s, strategy {s} ({strat.label}, k: {rule}): {duration} s of tracking", flush=True)
            samples, dense = env.track(sys_, tr, q0, T, duration, strat, k_off=k,
                                       params=theta if rule == "k_o(T; theta_hat)" else None, seed=seed + 1,
                                       n_dense=6)
            for df in (samples, dense):
                df.insert(0, "k_rule", rule)
                df.insert(0, "strategy", s)
                df.insert(0, "T", T)
            dense_all.append(dense)
            samp_all.append(samples)
            late = dense[dense.t >= duration / 2]
            row.update(run=True, mean_err=float(dense.err.mean()), early_err=float(dense[dense.t <= EARLY].err.mean()),
                       final_err=float(late.err.max()), err_one_period=one_period_error(samples))
            summ.append(row)
    th["k_NOISE_in_stability_set"] = [in_stability_set(NOISE_K, NOISE_T, SIKMParams(*r))
                                      for r in th[["mu", "alpha", "gamma1", "gamma2"]].itertuples(index=False)]
    noise = []
    for sigma in (SIGMA_2, SIGMA_1):
        print(f"  Fig. 5.9: strategy 2 at (k, T) = ({NOISE_K}, {NOISE_T}), MoCap noise {sigma}", flush=True)
        _, dense = RealisticEnvironment(noise_std=sigma).track(sys_, tr, q0, NOISE_T, 12.0 if quick else 60.0, 2,
                                                               k_off=NOISE_K, seed=seed + 2, n_dense=6)
        dense.insert(0, "sigma", sigma)
        noise.append(dense)
    return (pd.concat(dense_all, ignore_index=True), pd.concat(samp_all, ignore_index=True), th,
            pd.DataFrame(summ), pd.concat(noise, ignore_index=True), sys_, boot, qp_samples)


def line_label(strategy: int, k_rule: str) -> str:
    """The Fig. 5.9b line of a (strategy, gain rule): ``"1"``..``"4"``, ``"2 (printed k)"``."""
    return f"{strategy}" + (" (printed k)" if k_rule == "printed" else "")


def fig5_9b_lines(dense, summary, n_grid: int = 400) -> pd.DataFrame:
    """The lines of Fig. 5.9b: for each strategy (and strategy 2 with the printed k of
    Table 5.2) the mean over T of ``||e(t)||`` (each run interpolated on a common grid of
    *n_grid* points), averaged over the **same** periods for every line (those at which
    every line ran: 0.5, 0.75, 1.5 s in the full run), ``periods="common"``; and, for the
    lines that also ran at larger T (1 and 3 at 4 s, as Table 5.2), the mean over all
    their periods, ``periods="all"``.  Columns: ``line, periods, T_set, t, err``."""
    ran = summary[summary["run"]]
    sets = {line_label(s, r): set(g["T"]) for (s, r), g in ran.groupby(["strategy", "k_rule"])}
    common = sorted(set.intersection(*sets.values()))
    grid = np.linspace(0.0, float(dense.t.max()), n_grid)
    out = []
    for (s, r), d in dense.groupby(["strategy", "k_rule"]):
        label = line_label(s, r)
        for which, Ts in (("common", common), ("all", sorted(sets[label]))):
            if which == "all" and Ts == common:
                continue
            runs = [np.interp(grid, g.t, g.err) for T, g in d.groupby("T") if T in Ts]
            out.append(pd.DataFrame(dict(line=label, periods=which, T_set=", ".join(f"{T:g}" for T in Ts), t=grid,
                                         err=np.mean(runs, axis=0))))
    return pd.concat(out, ignore_index=True)


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


def plot(dense, summary, sys_, outdir, lines):
    names = sys_.coordinate_names
    d15 = dense[(dense["T"] == 1.5) & (dense.k_rule != "printed")]
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
    fig, ax = plt.subplots(figsize=(8, 5))
    colors = {"1": "tab:blue", "2": "tab:orange", "2 (printed k)": "tab:brown", "3": "tab:green", "4": "tab:red"}
    for (label, which), g in lines.groupby(["line", "periods"], sort=False):
        ax.semilogy(g.t, np.maximum(g.err, 1e-16), "-" if which == "common" else ":", color=colors.get(label),
                    label=f"{label}: mean over T = {g.T_set.iloc[0]} s")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("mean over T of ||e(t)||")
    ax.set_title("Fig. 5.9b: solid, every line over the same periods; 2 with k_o = 1/T and the printed k")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_9b.png"), dpi=110)
    plt.close(fig)


def main(outdir: str = "results/ch5_fig5_8_9", quick: bool = False) -> pd.DataFrame:
    """Run, save figures and Parquet; return the per-(T, strategy, k rule) summary."""
    os.makedirs(outdir, exist_ok=True)
    dense, samples, theta, summary, noise, sys_, boot, qp_samples = run(quick)
    lines = fig5_9b_lines(dense, summary)
    for name, df in (("dense", dense), ("samples", samples), ("theta", theta), ("theta_bootstrap", boot),
                     ("qp_samples", qp_samples), ("summary", summary), ("noise", noise), ("fig5_9b", lines)):
        df.to_parquet(os.path.join(outdir, f"{name}.parquet"))
    plot(dense, summary, sys_, outdir, lines)
    plot_noise(noise, sys_, outdir)
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch5_fig5_8_9").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick))
        print(pd.read_parquet(os.path.join(a.outdir, "theta.parquet")))
