"""Thesis ch. 2, §2.6.2: landing of the tethered UAV on a 30° slope.

Runs, on the simulation model with landers (1 cm, see
:data:`netcosim.controllers.landing.SIM_PARAMS`) and optionally the wind of §2.6.1:

* ``ideal``: NMPC alone and the two-layer controller (2LC) as the thesis built it
  (the NMPC started from the whole measured state at every sample, low-level poles at
  -120 rad/s), without and with wind, with zero computation times (the thesis's
  Simulink setting) -- Fig. 2.8–2.13; plus two named variants for comparison
  (:data:`netcosim.controllers.landing.SCHEMES`): the reference start
  (``2lcref``) and the project's former default (``2lcformer``: (f_R, τ_R) from the
  plan, poles at -60 rad/s);
* ``delay``: the 2LC variants and NMPC alone with a fixed NMPC computation delay of
  0, 0.1, 0.5, 1 and 2 ms (calm and wind);
* ``scheduled``: the same controllers as netcosim tasks on one node whose NMPC job
  costs the RTI computation's solve times recorded once by a calibration run and
  replayed job by job (``experiments/data/ch2_nmpc_cpu_times.csv``; 100 µs per
  low-level job, 20 µs context switches): NMPC alone, the 2LC in the thesis's scheme,
  the reference start and the former default, and (full run) the reference-start 2LC
  on two nodes over a 1 Mbit/s link; then the thesis's scheme and the former default
  with the recording replayed from several offsets (``solve_time_band.parquet``);
  (full run) the peak cable stress over vehicle mass and cable length
  (``cable_sweep.parquet``).  The replay makes every run give the same numbers on any
  host; :func:`calibrate`
  re-records the table on this host (wall-clock solve times, not reproducible) for
  whoever wants their own machine's.

Writes PNG figures and Parquet tables to *outdir* and returns the metrics table.
Also draws Fig. 2.5 (the sigmoid (2.11)).  Run ``python -m netcosim.experiments.ch2_landing``.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from netcosim.controllers.landing import (
    SCHEME_LABELS,
    SCHEMES,
    SIM_PARAMS,
    LandingConfig,
    LandingTiming,
    landing_metrics,
    run_landing,
    sigmoid,
)
from netcosim.experiments._ch2_sweeps import (  # noqa: F401
    CALIBRATION,
    CONTEXT_SWITCH,
    DELAYS,
    FL_EXEC,
    THESIS_RECORDING,
    cable_stress_sweep,
    delay_sweep,
    gain_sweep,
    recorded_timing,
    solve_time_band,
    wind_deviation,
)
from netcosim.plot import plot_schedule  # noqa: E402

DEG = 180.0 / math.pi
COLORS = {"nmpc": "tab:blue", "2lc": "tab:red"}
LABELS = {"nmpc": "NMPC", "2lc": "2LC"}
#: The former default of the project, a named variant: the plan start with -60 rad/s poles.
FORMER = "2LC former default (plan, -60 rad/s)"


def _scheduled_runs(timing_for, duration: float, quick: bool) -> dict:
    """The scheduled runs, each with the timing ``timing_for(name)``."""
    runs = {
        "NMPC alone": lambda t: run_landing("nmpc", duration=duration, timing=t),
        "2LC (NMPC from measurement)": lambda t: run_landing("2lc", duration=duration, timing=t,
                                                             **SCHEMES["thesis"]),
        "2LC (NMPC from reference)": lambda t: run_landing("2lc", duration=duration, timing=t,
                                                           **SCHEMES["reference"]),
    }
    timings = {name: timing_for(name) for name in runs}
    # the former default replays the thesis scheme's recording (same NMPC, same start)
    runs[FORMER] = lambda t: run_landing("2lc", duration=duration, timing=t, **SCHEMES["former_default"])
    timings[FORMER] = timing_for(THESIS_RECORDING)
    if not quick:
        timings["2LC on two nodes (1 Mbit/s link)"] = timing_for("2LC on two nodes (1 Mbit/s link)")
        runs["2LC on two nodes (1 Mbit/s link)"] = lambda t: run_landing("2lc", duration=duration, timing=t,
                                                                         topology="two_nodes", **SCHEMES["reference"])
    return {name: fn(timings[name]) for name, fn in runs.items()}


def calibrate(path: str | Path = CALIBRATION, duration: float = 1.5) -> pd.DataFrame:
    """Record the wall-clock RTI solve times of every scheduled run on this host and
    write them to *path* (CSV, columns ``run, phase, index, wall, cpu``).

    The recording depends on this host's speed and load (run it on a quiet machine);
    the runs that replay it do not.
    """
    import warnings

    from netcosim.cputime import NonReproducibleWarning
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonReproducibleWarning)
        measured = LandingTiming(nmpc_exec="measured", cpu_factor=1.0, fl_exec=FL_EXEC,
                                 context_switch=CONTEXT_SWITCH)
        runs = _scheduled_runs(lambda name: measured, duration, quick=False)
    runs.pop(FORMER)  # replays the thesis scheme's recording
    table = pd.concat([r.cpu_times.assign(run=name) for name, r in runs.items()], ignore_index=True)
    table = table[["run", "phase", "index", "wall", "cpu"]]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(path, index=False, float_format="%.17g")
    return table


def _bounds(ax, lo=None, hi=None):
    for v in (lo, hi):
        if v is not None:
            ax.axhline(v, color="gold", lw=1.5)


def _figure_angles(runs, path, title):
    """Fig. 2.8/2.11: φ, ϑ and their rates of every run in *runs* (controller -> run)."""
    fig, axes = plt.subplots(2, 2, figsize=(11, 6), sharex=True)
    for i, (c, run) in enumerate(runs.items()):
        run.plot(axes, label=LABELS[c], targets=i == 0, wind=i == 0, linestyle="--" if c == "nmpc" else "-",
                 color=COLORS[c])
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _figure_inputs(runs, path, title):
    p = SIM_PARAMS
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for c, run in runs.items():
        s = run.signals
        ls = "--" if c == "nmpc" else "-"
        axes[0].plot(s["time"], s["f_R"], ls, color=COLORS[c], label=LABELS[c])
        axes[1].plot(s["time"], s["tau_R"], ls, color=COLORS[c], label=LABELS[c])
    _bounds(axes[0], 0.0, p.f_R_max)
    _bounds(axes[1], -p.tau_R_max, p.tau_R_max)
    axes[0].set_ylabel("thrust $f_R$ [N]")
    axes[1].set_ylabel("torque $\\tau_R$ [N·m]")
    axes[1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _figure_constraints(runs, path, title):
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for c, run in runs.items():
        s = run.signals
        ls = "--" if c == "nmpc" else "-"
        axes[0].plot(s["time"], s["d_PG1"] * 1e3, ls, color=COLORS[c], label=f"$d_{{PG1}}$ {LABELS[c]}")
        axes[1].plot(s["time"], s["d_PG2"] * 1e3, ls, color=COLORS[c], label=f"$d_{{PG2}}$ {LABELS[c]}")
        axes[2].plot(s["time"], s["f_L"], ls, color=COLORS[c], label=f"$f_L$ {LABELS[c]}")
    _bounds(axes[0], 0.0)
    _bounds(axes[1], 0.0)
    _bounds(axes[2], 0.0, SIM_PARAMS.f_L_max)
    axes[0].set_ylabel("propeller 1 – ground [mm]")
    axes[1].set_ylabel("propeller 2 – ground [mm]")
    axes[2].set_ylabel("cable stress [N]")
    axes[2].set_xlabel("time [s]")
    for ax in axes[:2]:
        ax.set_yscale("symlog", linthresh=10.0)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _figure_scheduled(runs, path):
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for name, run in runs.items():
        s = run.signals
        axes[0].plot(s["time"], s["phi"] * DEG, label=name)
        axes[1].plot(s["time"], s["d_PG2"] * 1e3, label=name)
    axes[0].axhline(-30, color="gold", lw=1.5)
    _bounds(axes[1], 0.0)
    axes[0].set_ylabel("elevation φ [deg]")
    axes[1].set_ylabel("$d_{PG2}$ [mm]")
    axes[1].set_yscale("symlog", linthresh=10.0)
    axes[1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    fig.suptitle("Landing with the recorded NMPC solve times as CPU time (one node, 500 Hz FL above 100 Hz NMPC)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _figure_delay(sweep: pd.DataFrame, path) -> None:
    """d_PG min (calm and wind) and the wind-induced deviation against the NMPC delay."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    colors = {"thesis": "tab:red", "plan": "tab:orange", "former_default": "tab:purple", "reference": "tab:green",
              "nmpc": "tab:blue", "slow_gains": "tab:brown"}
    for scheme in sweep["scheme"].unique():
        color, label = colors[scheme], SCHEME_LABELS[scheme]
        for wind, ls in ((False, "-"), (True, "--")):
            d = sweep[(sweep["scheme"] == scheme) & (sweep["wind"] == wind)]
            axes[0].plot(d["delay"] * 1e3, d["d_PG_min"] * 1e3, ls, marker="o", color=color,
                         label=f"{label}, {'wind' if wind else 'calm'}")
        d = sweep[(sweep["scheme"] == scheme) & sweep["wind"]]
        axes[1].plot(d["delay"] * 1e3, d["wind_deviation"], marker="o", color=color, label=label)
    axes[0].axhline(0.0, color="gold", lw=1.5)
    axes[0].set_yscale("symlog", linthresh=1.0)
    axes[0].set_ylabel("min propeller–ground distance $d_{PG}$ [mm]")
    axes[1].set_yscale("log")
    axes[1].set_ylabel("wind-induced deviation (RMS) [deg]")
    for ax in axes:
        ax.set_xlabel("NMPC computation delay [ms]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=7, framealpha=0.6)
    fig.suptitle("The 2LC variants against the NMPC computation delay (fixed budget, one node)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _figure_sigmoid(path) -> None:
    """Fig. 2.5: the weight h(φ) of (2.11) with the OCP's γ = 19 and φ_lim = -0.24 rad."""
    cfg = LandingConfig()
    phi = np.linspace(-math.radians(40.0), math.radians(10.0), 401)
    h = np.array([float(sigmoid(p, cfg.gamma, cfg.phi_lim)) for p in phi])
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(phi, h, color="tab:blue")
    ax.axvline(cfg.phi_lim, color="gray", ls=":", label=f"$\\varphi_{{lim}}$ = {cfg.phi_lim} rad, h = 1/2")
    ax.axvline(-SIM_PARAMS.alpha, color="gold", lw=1.5, label="$\\varphi^*$ = $-\\alpha$")
    ax.set_xlabel("elevation φ [rad]")
    ax.set_ylabel("h(φ)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"Sigmoid (2.11), γ = {cfg.gamma:g}, $\\varphi_{{lim}}$ = {cfg.phi_lim} rad (cf. Fig. 2.5)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _tidy(name, run):
    s = run.to_pandas()
    s.insert(0, "run", name)
    return s


def _ideal_runs(duration: float) -> dict:
    """NMPC alone, the 2LC (thesis scheme), the reference-start 2LC (``2lcref``) and
    the former default (``2lcformer``), without and with wind, zero computation times."""
    runs = {}
    for wind in (False, True):
        for c, kw in (("nmpc", {}), ("2lc", SCHEMES["thesis"]), ("2lcref", SCHEMES["reference"]),
                      ("2lcformer", SCHEMES["former_default"])):
            name = f"ideal_{c}_{'wind' if wind else 'calm'}"
            print(f"  ch2_landing: {name} ({duration} s simulated)", flush=True)
            runs[name] = run_landing("nmpc" if c == "nmpc" else "2lc", wind=wind, duration=duration, **kw)
    return runs


def _figures(out: Path, calm: dict, windy: dict, scheduled: dict) -> None:
    _figure_angles(calm, out / "fig2_8_angles.png", "Landing without wind (cf. Fig. 2.8)")
    _figure_inputs(calm, out / "fig2_9_inputs.png", "Inputs without wind (cf. Fig. 2.9)")
    _figure_constraints(calm, out / "fig2_10_constraints.png",
                        "Propeller–ground distances and cable stress (cf. Fig. 2.10)")
    _figure_angles(windy, out / "fig2_11_wind_angles.png", "Landing under wind (cf. Fig. 2.11)")
    _figure_inputs(windy, out / "fig2_12_wind_inputs.png", "Inputs under wind (cf. Fig. 2.12)")
    _figure_constraints(windy, out / "fig2_13_wind_constraints.png", "Constraints under wind (cf. Fig. 2.13)")
    _figure_scheduled(scheduled, out / "scheduled_landing.png")
    plot_schedule(scheduled["2LC (NMPC from measurement)"].schedule, node="onboard", tasks=["fl", "nmpc"],
                  t_range=(0.0, 0.05), path=out / "schedule_2lc.png",
                  title="2LC on one node: 500 Hz FL (top) preempts the 100 Hz NMPC (recorded solve times)")


def _metrics(runs: dict) -> pd.DataFrame:
    """:func:`landing_metrics` of every run, plus the wind and response-time comparisons."""
    metrics = pd.DataFrame([dict(landing_metrics(run), run=name) for name, run in runs.items()]).set_index("run")
    # wind-induced deviation: RMS over the run of (run with wind - run without), degrees
    for c in ("nmpc", "2lc", "2lcref", "2lcformer"):
        metrics.loc[f"ideal_{c}_wind", "wind_deviation"] = wind_deviation(runs[f"ideal_{c}_calm"],
                                                                          runs[f"ideal_{c}_wind"])
    for c in ("2lc", "2lcref", "2lcformer"):
        w = f"ideal_{c}_wind"
        metrics.loc[w, "rms_ratio_2lc_over_nmpc"] = metrics.loc[w, "rms"] / metrics.loc["ideal_nmpc_wind", "rms"]
        metrics.loc[w, "wind_deviation_ratio"] = (metrics.loc[w, "wind_deviation"]
                                                  / metrics.loc["ideal_nmpc_wind", "wind_deviation"])
    for sched in ("scheduled_2LC (NMPC from measurement)", "scheduled_2LC (NMPC from reference)",
                  "scheduled_" + FORMER):
        jobs = runs[sched].jobs
        nm = jobs[jobs["task"] == "nmpc"]
        metrics.loc[sched, "nmpc_response_median"] = float(nm["response_time"].median())
        metrics.loc[sched, "nmpc_response_max"] = float(nm["response_time"].max())
    return metrics


#: the NMPC steps' wall-clock columns (s of this machine), written to ``nmpc_wall_clock.parquet``
WALL_CLOCK_COLUMNS = ("t_feedback", "t_prepare")


def _write_tables(out: Path, runs: dict, scheduled: dict, metrics: pd.DataFrame, sweep: pd.DataFrame,
                  band: pd.DataFrame) -> None:
    pd.concat([_tidy(n, r) for n, r in runs.items()], ignore_index=True).to_parquet(out / "signals.parquet")
    # the solver's wall-clock times depend on the host: kept apart, so that nmpc_steps.parquet
    # holds only what a run with the same seed reproduces bit for bit
    steps = pd.concat([r.steps.assign(run=n) for n, r in runs.items()], ignore_index=True)
    steps.drop(columns=list(WALL_CLOCK_COLUMNS)).to_parquet(out / "nmpc_steps.parquet")
    steps[["run", "time", *WALL_CLOCK_COLUMNS]].to_parquet(out / "nmpc_wall_clock.parquet")
    pd.concat([r.jobs.assign(run=n) for n, r in runs.items()], ignore_index=True).to_parquet(out / "jobs.parquet")
    # the CPU times every scheduled run charged: replaying them reproduces the run exactly
    pd.concat([r.cpu_times.assign(run=n) for n, r in scheduled.items()],
              ignore_index=True).to_parquet(out / "cpu_times.parquet")
    metrics.reset_index().to_parquet(out / "metrics.parquet")
    sweep.to_parquet(out / "delay_sweep.parquet")
    band.to_parquet(out / "solve_time_band.parquet")


def _print_summary(metrics: pd.DataFrame, sweep: pd.DataFrame, band: pd.DataFrame) -> None:
    cols = ["t_settle", "phi_final", "theta_final", "rms", "f_R_max", "f_L_min", "f_L_max", "d_PG_min",
            "n_fallback"]
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(metrics[cols].round(4).to_string())
        for c in ("2lc", "2lcref", "2lcformer"):
            w = metrics.loc[f"ideal_{c}_wind"]
            print(f"wind, {c}: RMS (deg) NMPC {metrics.loc['ideal_nmpc_wind', 'rms']:.4f}, 2LC {w['rms']:.4f}, "
                  f"ratio {w['rms_ratio_2lc_over_nmpc']:.4f}; wind-induced deviation NMPC "
                  f"{metrics.loc['ideal_nmpc_wind', 'wind_deviation']:.4f}, 2LC {w['wind_deviation']:.4f}, "
                  f"ratio {w['wind_deviation_ratio']:.3f}")
        print("\ndelay sweep (fixed NMPC computation delay):")
        cols = ["delay", "scheme", "wind", "t_settle", "d_PG_min", "f_L_max", "wind_deviation", "wind_ratio"]
        print(sweep[[c for c in cols if c in sweep]].round(4).to_string(index=False))
        print("\nrecorded solve times replayed from several offsets (d_PG_min [m], f_L_max [N]):")
        print(band.groupby("scheme")[["d_PG_min", "f_L_max", "t_settle"]].agg(["min", "max"]).round(4).to_string())


def main(outdir: str | Path = "results/ch2", quick: bool = False) -> pd.DataFrame:
    """Run the ch. 2 landing experiments; write figures and Parquet tables to *outdir*."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    duration = 1.0 if quick else 1.5
    runs = _ideal_runs(duration)
    print("  ch2_landing: delay sweep", flush=True)
    names = (("thesis", "2lc"), ("reference", "2lcref"), ("former_default", "2lcformer"), ("nmpc", "nmpc"))
    ideal = {(scheme, wind): runs[f"ideal_{c}_{'wind' if wind else 'calm'}"]
             for scheme, c in names for wind in (False, True)}
    sweep = delay_sweep((0.0, 0.002) if quick else DELAYS, duration,
                        ("thesis", "former_default", "nmpc") if quick else
                        ("thesis", "plan", "slow_gains", "former_default", "reference", "nmpc"), ideal)
    print("  ch2_landing: recorded solve times from several offsets", flush=True)
    band = solve_time_band(offsets=(0, 75) if quick else tuple(range(0, 150, 15)), duration=duration)
    print("  ch2_landing: scheduled runs (recorded NMPC solve times)", flush=True)
    scheduled = _scheduled_runs(recorded_timing, duration, quick)
    print("  ch2_landing: figures and tables", flush=True)
    for name, run in scheduled.items():
        runs["scheduled_" + name] = run
    calm = {c: runs[f"ideal_{c}_calm"] for c in ("nmpc", "2lc")}
    windy = {c: runs[f"ideal_{c}_wind"] for c in ("nmpc", "2lc")}
    _figures(out, calm, windy, scheduled)
    _figure_delay(sweep, out / "delay_sweep.png")
    _figure_sigmoid(out / "fig2_5_sigmoid.png")
    metrics = _metrics(runs)
    _write_tables(out, runs, scheduled, metrics, sweep, band)
    if not quick:
        print("  ch2_landing: cable stress over m_B and l (calm, 3/1 N and 1/0.3 N wind)", flush=True)
        cable_stress_sweep().to_parquet(out / "cable_sweep.parquet")
    _print_summary(metrics, sweep, band)
    return metrics


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    ap = experiment_parser(__doc__, "results/ch2",
                           quick="1 s landings instead of 1.5 s; delays 0 and 2 ms (thesis scheme, former "
                                 "default, NMPC alone); 2 replay offsets; no two-node run")
    ap.add_argument("--calibrate", action="store_true",
                    help=f"re-record the NMPC solve times on this host into {CALIBRATION} (wall clock: "
                         "run on a quiet machine) instead of running the experiment")
    ap.add_argument("--cable-sweep", action="store_true",
                    help="print the 2LC's peak cable stress over vehicle mass and cable length "
                         "(docs/nmpc.md) instead of running the experiment")
    ap.add_argument("--gain-sweep", action="store_true",
                    help="print the thesis scheme's d_PG and f_L against the low-level pole (docs/nmpc.md, "
                         "\"Low-level gains\") instead of running the experiment")
    a = ap.parse_args()
    if a.cable_sweep:
        print(cable_stress_sweep().round(4).to_string(index=False))
    elif a.gain_sweep:
        print(gain_sweep().round(5).to_string(index=False))
    elif a.calibrate:
        t = calibrate()
        print(t.groupby(["run", "phase"])["cpu"].describe()[["count", "50%", "max"]].to_string())
        print(f"-> {CALIBRATION}")
    else:
        main(a.outdir, a.quick)
