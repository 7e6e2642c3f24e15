"""The networked Fly-crane over lossy 802.11b (thesis §4.6.1, Fig. 4.11, appendix A).

Four robots carry a load (the non-square system of Fig. 4.3a, m = 10, n = 12) from
cable angles 80 deg to 60 deg; the ch. 4 planners run as tasks on five nodes (the load
and four robots) that talk over one IEEE 802.11b network at 1.2 Mbit/s, T = 1.5 s, on
the dynamic model (4.10) with velocity tracking (4.11), alpha = 30 N s/m.  Offline
strategy: the load broadcasts its pose, each robot computes its velocity with the
offline gain and keeps it on a loss.  Online strategy: the load computes all velocities
with the online gain and broadcasts them; a watchdog on each robot zeroes its velocity
when the last message is older than T (checked every 0.2 s).

The sweep: packet loss probability 0..0.9 (step 0.1, which holds Fig. 4.11's 0, 0.3,
0.7) x seeds x {offline, online}, into DIR/dataset (Parquet, one row per run, and the
error time series); 40 more seeds (another root seed) at 30 % and 70 % loss into
DIR/dataset_fig4_11, so that each loss step of Fig. 4.11 (0 -> 30 %, 30 -> 70 %) gets a
verdict from 20 + 40 runs (0 % loss is deterministic): the bootstrap interval of the
difference of the median cost (loss_steps.parquet); then the figures: fig4_11.png (per
strategy the per-time median of ||q - q^r|| and its 10-90 % band over the seeds, the
verdicts in the titles), fig4_11_seed0.png (one seed, as the thesis's figure),
figA_2.png, figA_3.png (20 % loss), figA_4.png, figA_5.png (schedules), figA_6.png
(gains), cost_vs_loss.png, summary.parquet (the grid's runs) and collisions.parquet
(closest robot-robot approach per strategy and loss, over all runs); timeline_online_loss20.html
and timeline_offline_loss20.html: the interactive timelines of Figs. A.4/A.5's runs (tasks,
frames, signals, watchdog firings; open from disk in a browser, needs Bokeh).

Run ``python -m netcosim.experiments.flycrane_network`` (``--quick``: 3 losses x 3 seeds,
15 s, no extra seeds).  ``--seeds N`` sets the number of seeds of the grid,
``--verdict-seeds N`` the extra ones.
"""

from __future__ import annotations

import functools
import math
import os
from typing import Any

import numpy as np
import pandas as pd

from netcosim.controllers.planner.clearance import trajectory_clearance
from netcosim.controllers.planner.networked import FlyCraneNetworkConfig, FlyCraneRun, run
from netcosim.plants.flycrane.configurations import four_robot_nonsquare

#: Loss probabilities of Fig. 4.11.
FIG_LOSSES = (0.0, 0.3, 0.7)
#: The loss steps of Fig. 4.11 whose cost increase :func:`loss_steps` judges.
LOSS_STEPS = ((0.0, 0.3), (0.3, 0.7))
#: Extra seeds per (strategy, loss) at these losses for the verdict of Fig. 4.11 (root seed
#: :data:`VERDICT_ROOT_SEED`, so other seeds than the grid's); 0 loss is deterministic (no
#: random draw without loss: the grid's runs are identical) and needs none.
VERDICT_LOSSES, VERDICT_SEEDS, VERDICT_ROOT_SEED = (0.3, 0.7), 40, 1
#: The finer grid of the sweep.
GRID_LOSSES = tuple(round(0.1 * i, 1) for i in range(10))
STRATEGIES = ("offline", "online")
#: ``||e|| <`` this counts as converged (rad and m).
SETTLE_TOL = 1e-2
#: Horizon of the sweep runs (s): 30 periods, as Fig. 4.10.
HORIZON = 45.0
#: Grid of the per-run error table (s).
ERROR_DT = 0.3
#: Keys of ``params`` that :func:`scenario` passes on to :class:`FlyCraneNetworkConfig`.
PARAMS = ("loss", "strategy", "messaging", "plant", "alpha", "data_rate", "horizon", "d_reading", "k_offline")


def config_of(params: dict, seed: int) -> FlyCraneNetworkConfig:
    """The :class:`FlyCraneNetworkConfig` of one sweep point: ``params`` holds ``loss``
    and ``strategy`` and optionally ``messaging``, ``plant``, ``alpha``, ``data_rate``,
    ``horizon`` (default :data:`HORIZON`), ``d_reading``, ``k_offline``; unknown keys raise."""
    from netcosim.errors import ConfigurationError
    unknown = sorted(set(params) - set(PARAMS))
    if unknown:
        raise ConfigurationError(f"unknown scenario parameter(s) {unknown}; known: {list(PARAMS)}")
    if "loss" not in params or "strategy" not in params:
        raise ConfigurationError(f"scenario parameters need 'loss' and 'strategy', got {sorted(params)}")
    kw = {k: (v.item() if hasattr(v, "item") else v) for k, v in params.items()}
    kw.setdefault("horizon", HORIZON)
    # a sweep run keeps only the traces its metrics read (time series and frames)
    return FlyCraneNetworkConfig(seed=int(seed), schedules=False, **kw)


@functools.lru_cache(maxsize=1)
def _system():
    """The Fly-crane of the runs (built once per process)."""
    return four_robot_nonsquare()


def metrics(r: FlyCraneRun) -> dict:
    """Scalar metrics of one run.

    ``iae``: the cost, ``integral of ||q - q^r||_2 dt`` over the horizon (trapezoid on
    the ``sample_dt`` grid; rad s), ``inf`` if the plant failed; ``t_settle`` (s): the
    first time from which ``||e|| < 1e-2`` until the horizon, ``inf`` if the run ends
    above it; ``final_e``: ``||e||`` at the horizon; ``max_e``; ``diverged``: the plant
    failed or ``||e||`` ends above its initial value; ``msg_loss_robot1..4`` and
    ``msg_loss``: measured fraction of the load's messages each robot (all robots)
    did not receive; ``messages``: messages the load sent; ``frames_sent``:
    transmissions on the air (retransmissions included, ACKs not); ``frames_lost``:
    frame losses (one per frame and receiver that missed it); ``messages_lost``;
    ``min_distance`` [m]: the closest robot-robot approach along the run (its
    ``sample_dt`` grid, chord error bounded) and ``below_safety`` whether it comes
    below :data:`~netcosim.plants.flycrane.collisions.SAFETY_DISTANCE`.
    """
    e = r.norm_e
    failed = r.failure is not None
    below = e < SETTLE_TOL
    if len(e) and below[-1] and not failed:
        above = np.flatnonzero(~below)
        t_settle = float(r.t[above[-1] + 1]) if len(above) else float(r.t[0])
    else:
        t_settle = math.inf
    iae = math.inf if failed else float(np.trapezoid(e, r.t))
    fr = r.frames
    ev = fr["event"].astype(str)
    out = {"iae": iae, "t_settle": t_settle, "final_e": float(e[-1]), "max_e": float(e.max()),
           "diverged": bool(failed or e[-1] > e[0]), "messages": int(r.messages["sent"].iloc[0]),
           "frames_sent": int((ev == "attempt_start").sum()), "frames_lost": int((ev == "lost").sum()),
           "messages_lost": int((r.messages["sent"] - r.messages["received"]).sum()),
           "failure": r.failure or ""}
    for name, loss in zip(r.messages["robot"], r.messages["loss"]):
        out[f"msg_loss_{name}"] = float(loss)
    ca = trajectory_clearance(_system(), r.t, r.q)
    out["min_distance"], out["below_safety"] = ca.distance, ca.below_safety
    out["msg_loss"] = float(out["messages_lost"] / max(1, 4 * out["messages"]))
    return out


def error_table(r: FlyCraneRun, dt: float = ERROR_DT) -> pd.DataFrame:
    """``t`` (s), ``norm_e`` on a grid of *dt* seconds (decimated from the run's grid)."""
    step = max(1, int(round(dt / r.config.sample_dt)))
    return pd.DataFrame({"t": r.t[::step], "norm_e": r.norm_e[::step]})


def scenario(params: dict, seed: int) -> dict:
    """One sweep run: ``params`` as :func:`config_of`, ``seed`` the simulation seed.
    Returns :func:`metrics` plus ``error``: :func:`error_table` (a DataFrame)."""
    r = run(config_of(params, seed))
    out: dict[str, Any] = metrics(r)
    out["error"] = error_table(r)
    return out


scenario.params = set(PARAMS)  # type: ignore[attr-defined]  # the sweep engine checks the grid against it
# ...and every case before any run starts (a negative loss stops the sweep with its reason)
scenario.validate = lambda params: config_of(params, 0)  # type: ignore[attr-defined]


def run_grid(losses=GRID_LOSSES, seeds: int = 20, strategies=STRATEGIES, horizon: float = HORIZON,
             out: str | None = None, progress: bool = True, workers: int = 1, root_seed: int = 0, **fixed):
    """The sweep loss x strategy x seeds on :func:`netcosim.sweep.run_sweep` (one
    process with ``workers=1``, else a pool of ``workers`` processes: the same tables
    either way, each run's seed derived from its case and seed index); ``fixed``: further
    :data:`PARAMS` held constant.  ``out``: the sweep's Parquet dataset (resumable).
    ``root_seed``: the sweep's root seed (another root seed, other seeds for the same cases).
    Returns ``(runs, error)``: one row per run (parameters, ``seed_index``, ``seed``,
    :func:`metrics`, ``status``) and the long error table (parameters, ``seed_index``,
    ``seed``, ``t``, ``norm_e``)."""
    from netcosim.sweep import run_sweep
    grid = {"loss": [float(x) for x in losses], "strategy": list(strategies), "horizon": [float(horizon)],
            **{k: [v] for k, v in fixed.items()}}
    res = run_sweep(scenario, grid, seeds, executor="serial" if workers <= 1 else "pool", workers=workers,
                    out=out, quiet=not progress, root_seed=root_seed)
    return res.runs, res.table("error")


def summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Cost per loss and strategy: median and 10/90 % quantiles (nearest order statistic,
    so runs that never settle count as ``inf``) of ``iae`` and ``t_settle``, the number
    of runs and of diverged runs, the mean measured message loss, and ``run_errors``:
    runs the sweep recorded as failed (an exception or a timeout; left out of the rest)."""
    ok = runs[runs["status"] == "ok"] if "status" in runs else runs
    failed = (runs.groupby(["strategy", "loss"])["status"].apply(lambda s: int((s != "ok").sum()))
              if "status" in runs else None)
    g = ok.groupby(["strategy", "loss"])

    def qs(col, p):  # nearest order statistic: defined with inf values (never inf - inf)
        return g[col].quantile(p, interpolation="nearest")
    return pd.DataFrame({
        "runs": g.size(), "diverged": g["diverged"].sum().astype(int),
        "iae_median": qs("iae", 0.5), "iae_q10": qs("iae", 0.1), "iae_q90": qs("iae", 0.9),
        "t_settle_median": qs("t_settle", 0.5), "t_settle_q10": qs("t_settle", 0.1),
        "t_settle_q90": qs("t_settle", 0.9), "msg_loss": g["msg_loss"].mean(),
        "run_errors": failed if failed is not None else 0}).reset_index()


def loss_steps(runs: pd.DataFrame, steps=LOSS_STEPS, n_boot: int = 4000, level: float = 0.95,
               seed: int = 0) -> pd.DataFrame:
    """The verdict of Fig. 4.11 per loss step and strategy: does the cost ``iae`` grow from
    loss ``a`` to loss ``b``?  The difference of the median iae (b minus a, rad s) with its
    percentile bootstrap interval at *level* (*n_boot* resamples of each loss's runs, drawn
    with replacement, numpy generator seeded by *seed*; medians interpolated).  ``verdict``:
    ``"worse"`` when the interval lies above 0, ``"better"`` below 0, else
    ``"unresolved"``.  Also the runs per loss, the median ``final_e`` (||e|| at the horizon)
    at each loss and the fraction of runs at ``b`` cheaper than the median run at ``a``.
    Runs with a non-finite cost (a failed plant) count as larger than any finite one."""
    ok = runs[runs["status"] == "ok"] if "status" in runs else runs
    rng = np.random.default_rng(seed)
    lo_q, hi_q = (1 - level) / 2, 1 - (1 - level) / 2
    rows = []
    for st in STRATEGIES:
        for a, b in steps:
            ca = ok[(ok["strategy"] == st) & np.isclose(ok["loss"], a)]
            cb = ok[(ok["strategy"] == st) & np.isclose(ok["loss"], b)]
            if ca.empty or cb.empty:
                continue
            xa, xb = (np.nan_to_num(c["iae"].to_numpy(float), posinf=1e300) for c in (ca, cb))
            ia = rng.integers(0, xa.size, (n_boot, xa.size))
            ib = rng.integers(0, xb.size, (n_boot, xb.size))
            d = np.median(xb[ib], axis=1) - np.median(xa[ia], axis=1)
            lo, hi = float(np.quantile(d, lo_q)), float(np.quantile(d, hi_q))
            rows.append(dict(strategy=st, loss_from=a, loss_to=b, runs_from=len(ca), runs_to=len(cb),
                             iae_median_from=float(np.median(xa)), iae_median_to=float(np.median(xb)),
                             diff=float(np.median(xb) - np.median(xa)), ci_lo=lo, ci_hi=hi, level=level,
                             verdict="worse" if lo > 0 else ("better" if hi < 0 else "unresolved"),
                             final_e_median_from=float(ca["final_e"].median()),
                             final_e_median_to=float(cb["final_e"].median()),
                             cheaper_fraction=float(np.mean(xb < np.median(xa)))))
    return pd.DataFrame(rows)


# ---------------------------------------------------------------- figures

def _semilogy(ax, t, e, *args, **kw):
    return ax.semilogy(t, np.maximum(e, 1e-16), *args, **kw)


STYLE = {"offline": "-", "online": "--"}
COLORS = {0.0: "tab:blue", 0.3: "tab:orange", 0.7: "tab:red"}


def fig_4_11(results: dict, path=None):
    """Fig. 4.11, one seed: ``||q - q^r||`` against t for each (loss, strategy).
    *results* maps ``(loss, strategy)`` to a :class:`FlyCraneRun`.  Returns the axes."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (loss, st), r in sorted(results.items()):
        _semilogy(ax, r.t, r.norm_e, STYLE.get(st, "-"), color=COLORS.get(loss), label=f"{st}, loss {loss:.0%}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("||q - q^r||_2")
    ax.set_title(f"Fig. 4.11: 802.11b broadcast, seed {next(iter(results.values())).config.seed}")
    ax.legend(fontsize=8)
    _save(fig, path)
    return ax


def fig_4_11_band(error: pd.DataFrame, losses=FIG_LOSSES, path=None, q=(0.1, 0.9), steps: pd.DataFrame | None = None):
    """Fig. 4.11 across seeds, one panel per strategy: the per-time median of ``||q - q^r||``
    and its ``q`` inter-quantile band over the seeds for each loss, from the long error
    table (``loss``, ``strategy``, ``seed``, ``t``, ``norm_e``); with *steps*
    (:func:`loss_steps`) each panel's title states the verdict of each loss step.
    Returns the axes."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    for ax, st in zip(axes, STRATEGIES):
        for loss in losses:
            d = error[np.isclose(error["loss"], loss) & (error["strategy"] == st)]
            if d.empty:
                continue
            g = d.groupby("t")["norm_e"]
            med, lo, hi = g.median(), g.quantile(q[0]), g.quantile(q[1])
            n = d["seed"].nunique()
            _semilogy(ax, med.index, med.values, STYLE[st], color=COLORS.get(loss),
                      label=f"loss {loss:.0%}: median of {n} seeds")
            ax.fill_between(med.index, np.maximum(lo.values, 1e-16), np.maximum(hi.values, 1e-16),
                            color=COLORS.get(loss), alpha=0.2, lw=0)
        title = f"{st}: median and {q[0]:.0%}-{q[1]:.0%} band over seeds"
        if steps is not None:
            for r in steps[steps["strategy"] == st].itertuples():
                title += (f"\n{r.loss_from:.0%}->{r.loss_to:.0%}: median iae {r.diff:+.2f} "
                          f"[{r.ci_lo:+.2f}, {r.ci_hi:+.2f}] ({r.level:.0%} CI): {r.verdict}")
        ax.set_title(title, fontsize=8)
        ax.set_xlabel("t (s)")
        ax.legend(fontsize=7)
    axes[0].set_ylabel("||q - q^r||_2")
    fig.suptitle("Fig. 4.11: error norm against time, 802.11b broadcast")
    fig.tight_layout()
    _save(fig, path)
    return axes


def fig_a_2(results: dict, path=None):
    """Fig. A.2: the cable angles alpha_i (deg) of each strategy (*results*: strategy ->
    :class:`FlyCraneRun`).  Returns the axes."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, sharex=True, figsize=(8, 5.5))
    for i, ax in enumerate(axes.flat):
        for st, r in results.items():
            ax.plot(r.t, r.alpha[:, i], STYLE[st], label=st)
        ax.axhline(np.degrees(next(iter(results.values())).q_ref[i]), color="k", lw=0.5)
        ax.set_ylabel(f"alpha_{i + 1} (deg)")
    axes[0, 0].legend()
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    fig.suptitle(f"Fig. A.2: cable angles, loss {next(iter(results.values())).config.loss:.0%}")
    _save(fig, path)
    return axes


def fig_a_3(results: dict, path=None):
    """Fig. A.3: the load pose q_V (x, y, z in m; roll, pitch, yaw in deg) of each
    strategy.  Returns the axes."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 3, sharex=True, figsize=(10, 5.5))
    names = ("x (m)", "y (m)", "z (m)", "roll (deg)", "pitch (deg)", "yaw (deg)")
    for j, ax in enumerate(axes.flat):
        for st, r in results.items():
            ax.plot(r.t, r.q_V[:, j], STYLE[st], label=st)
        ax.set_ylabel(names[j])
    axes[0, 0].legend()
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    fig.suptitle(f"Fig. A.3: load pose, loss {next(iter(results.values())).config.loss:.0%}")
    _save(fig, path)
    return axes


def fig_schedules(r, t_range=(2.9, 4.9), path=None, title=None):
    """Figs. A.4 (online) / A.5 (offline): close-up of the robots' kernels, the load's
    kernel and the network schedule (lost frames marked).  Returns the three axes."""
    import matplotlib.pyplot as plt

    from netcosim.network.plot import plot_network_schedule
    from netcosim.plot import plot_schedule
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), gridspec_kw={"height_ratios": [3, 1, 2]})
    sch = r.schedule
    robots = sch[sch["node"].astype(str) != "pivot"]
    plot_schedule(robots, t_range=t_range, ax=axes[0], title="robots' kernels (high = running, low = idle)")
    plot_schedule(sch, node="pivot", t_range=t_range, ax=axes[1], title="load (platform) kernel")
    plot_network_schedule(r.network_schedule, network="wlan", t_range=t_range, frames=r.frames, ax=axes[2])
    fig.suptitle(title or f"{r.config.strategy} strategy, loss {r.config.loss:.0%}")
    fig.tight_layout()
    _save(fig, path)
    return axes


def fig_a_6(results: dict, path=None):
    """Fig. A.6: the gains k (1/s) each strategy used at each period.  Returns the axes."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    for st, r in results.items():
        g = r.gains.drop_duplicates("t") if st == "offline" else r.gains
        ax.step(g["t"], g["k"], STYLE[st], where="post", label=f"{st} gain")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("k (1/s)")
    ax.set_title("Fig. A.6: offline vs online gain")
    ax.legend()
    _save(fig, path)
    return ax


def fig_cost(runs: pd.DataFrame, cost: str = "iae", path=None):
    """The summary: *cost* against loss per strategy, median and 10-90 % band across
    seeds, each run a dot, diverged runs as red crosses.  Returns the axes."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for st in STRATEGIES:
        d = runs[runs["strategy"] == st]
        if d.empty:
            continue
        finite = d[np.isfinite(d[cost])]
        g = finite.groupby("loss")[cost]
        line, = ax.plot(g.median().index, g.median().values, "o" + STYLE[st], label=f"{st} (median)")
        ax.fill_between(g.median().index, g.quantile(0.1).values, g.quantile(0.9).values, color=line.get_color(),
                        alpha=0.2, lw=0)
        ax.plot(finite["loss"], finite[cost], ".", color=line.get_color(), ms=2, alpha=0.5)
        div = d[d["diverged"]]
        if len(div):
            y = np.where(np.isfinite(div[cost]), div[cost], np.nanmax(finite[cost]) if len(finite) else 1.0)
            ax.plot(div["loss"], y, "x", color="red", ms=6, label=f"{st}: diverged")
    ax.set_yscale("log")
    ax.set_xlabel("packet loss probability")
    ax.set_ylabel({"iae": "integral of ||q - q^r|| dt (rad s)", "t_settle": "time to ||e|| < 1e-2 (s)"}.get(cost, cost))
    ax.set_title("cost against loss")
    ax.legend(fontsize=8)
    _save(fig, path)
    return ax


def _save(fig, path) -> None:
    if path is not None:
        import matplotlib.pyplot as plt
        fig.savefig(path, dpi=110)
        plt.close(fig)


# ---------------------------------------------------------------- main

#: Default sweep size and the --quick one: (losses, seeds, horizon s).
DEFAULT_SIZE = (GRID_LOSSES, 20, HORIZON)
QUICK_SIZE = (FIG_LOSSES, 3, 15.0)


def fig_view(r, path, t_range=(2.9, 4.9), title: str | None = None):
    """The run's interactive timeline (:mod:`netcosim.view`): the kernels' tasks, the WLAN's
    frames and busy medium, ``||q - q^r||`` on the sample grid and the gains the tasks
    computed, the watchdog firings marked; opened at *t_range* (s), the
    window of Figs. A.4/A.5.  Returns the path, or None (with a note) without Bokeh."""
    try:
        from netcosim.view import view
    except ImportError:     # pragma: no cover - netcosim.view itself has no third-party import
        return None
    import importlib.util
    if importlib.util.find_spec("bokeh") is None:
        print("  (no interactive timeline: pip install 'netcosim[view]' for Bokeh)")
        return None
    grid = [pd.DataFrame({"time": r.t, "source": "run", "signal": "norm_e", "value": r.norm_e})]
    logged = r.signals if r.signals is not None else pd.DataFrame(columns=["time", "source", "signal", "value"])
    logged = logged.astype({"source": str, "signal": str})
    signals = pd.concat(grid + [logged], ignore_index=True)
    gains = logged[logged["signal"] == "k"]
    chosen = ["run.norm_e"] + [f"{s}.k" for s in dict.fromkeys(gains["source"])]
    tables = {"schedule": r.schedule, "jobs": r.jobs, "frames": r.frames, "network_schedule": r.network_schedule,
              "signals": signals}
    return view(tables, path, signals=chosen, t_range=t_range,
                title=title or f"Fly-crane over 802.11b: {r.config.strategy} strategy, loss {r.config.loss:.0%}")


def figures(runs: pd.DataFrame, error: pd.DataFrame, outdir: str, horizon: float = HORIZON, seed: int = 0,
            steps: pd.DataFrame | None = None) -> None:
    """Run the single-seed cases and write every figure into *outdir* (*error*: the runs'
    error tables for Fig. 4.11's band; *steps*: its verdicts, :func:`loss_steps`)."""
    one = {(loss, st): run(FlyCraneNetworkConfig(strategy=st, loss=loss, seed=seed, horizon=horizon))
           for loss in FIG_LOSSES for st in STRATEGIES}
    fig_4_11_band(error, path=os.path.join(outdir, "fig4_11.png"), steps=steps)
    fig_4_11(one, os.path.join(outdir, "fig4_11_seed0.png"))
    at20 = {st: run(FlyCraneNetworkConfig(strategy=st, loss=0.2, seed=seed, horizon=horizon)) for st in STRATEGIES}
    fig_a_2(at20, os.path.join(outdir, "figA_2.png"))
    fig_a_3(at20, os.path.join(outdir, "figA_3.png"))
    fig_schedules(at20["online"], path=os.path.join(outdir, "figA_4.png"),
                  title="Fig. A.4: online strategy, loss 20 %")
    fig_schedules(at20["offline"], path=os.path.join(outdir, "figA_5.png"),
                  title="Fig. A.5: offline strategy, loss 20 %")
    fig_a_6(at20, os.path.join(outdir, "figA_6.png"))
    for st in STRATEGIES:   # the interactive timelines beside the PNGs (docs/viewer.md)
        fig_view(at20[st], os.path.join(outdir, f"timeline_{st}_loss20.html"))
    fig_cost(runs, "iae", os.path.join(outdir, "cost_vs_loss.png"))


def collisions(runs: pd.DataFrame) -> pd.DataFrame:
    """Per strategy and loss: runs, the smallest closest robot-robot approach over them
    (``min_distance``, m) and how many come below the safety distance."""
    g = runs.groupby(["strategy", "loss"])
    return pd.DataFrame({"runs": g.size(), "min_distance": g["min_distance"].min(),
                         "below_safety": g["below_safety"].sum()}).reset_index()


def main(outdir: str = "results/flycrane_network", quick: bool = False, seeds: int | None = None,
         workers: int = 2, verdict_seeds: int | None = None) -> pd.DataFrame:
    """The sweep into ``outdir/dataset`` (Parquet), the figures and ``summary.parquet``;
    then :data:`VERDICT_SEEDS` (or *verdict_seeds*; none with *quick*) more seeds at
    :data:`VERDICT_LOSSES` into ``outdir/dataset_fig4_11`` and the verdict of each loss step
    of Fig. 4.11 over all runs at its losses into ``loss_steps.parquet``.  Returns the
    summary (cost per loss and strategy, the grid's runs)."""
    losses, n_seeds, horizon = QUICK_SIZE if quick else DEFAULT_SIZE
    n_seeds = seeds or n_seeds
    n_extra = (0 if quick else VERDICT_SEEDS) if verdict_seeds is None else verdict_seeds
    os.makedirs(outdir, exist_ok=True)
    runs, error = run_grid(losses, n_seeds, horizon=horizon, out=os.path.join(outdir, "dataset"), workers=workers)
    summ = summary(runs)
    summ.to_parquet(os.path.join(outdir, "summary.parquet"))
    fig_runs, fig_error = runs, error
    if n_extra > 0:
        more, more_error = run_grid(VERDICT_LOSSES, n_extra, horizon=horizon, workers=workers,
                                    out=os.path.join(outdir, "dataset_fig4_11"), root_seed=VERDICT_ROOT_SEED)
        fig_runs = pd.concat([runs, more], ignore_index=True)
        fig_error = pd.concat([error, more_error], ignore_index=True)
    steps = loss_steps(fig_runs)
    steps.to_parquet(os.path.join(outdir, "loss_steps.parquet"))
    collisions(fig_runs).to_parquet(os.path.join(outdir, "collisions.parquet"))
    figures(runs, fig_error, outdir, horizon, steps=steps)
    return summ


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    ap = experiment_parser(__doc__, "results/flycrane_network")
    ap.add_argument("--seeds", type=int, default=None, help="seeds per (loss, strategy) (default 20; quick 3)")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--verdict-seeds", type=int, default=None, help="extra seeds per strategy at 30 %% and 70 %% "
                    f"loss for the verdict of Fig. 4.11 (default {VERDICT_SEEDS}; quick 0)")
    a = ap.parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick, a.seeds, a.workers, a.verdict_seeds))
        print(pd.read_parquet(os.path.join(a.outdir, "loss_steps.parquet")))
