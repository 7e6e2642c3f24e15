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
error time series); then the figures: fig4_11.png (one seed), fig4_11_band.png (median
and 10-90 % band across seeds), figA_2.png, figA_3.png (20 % loss), figA_4.png,
figA_5.png (schedules), figA_6.png (gains), cost_vs_loss.png and summary.parquet.

Run ``python -m experiments.flycrane_network`` (``--quick``: 3 losses x 3 seeds,
15 s).  ``--seeds N`` sets the number of seeds.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
import pandas as pd

from controllers.planner.networked import FlyCraneNetworkConfig, FlyCraneRun, run

#: Loss probabilities of Fig. 4.11.
FIG_LOSSES = (0.0, 0.3, 0.7)
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
    return FlyCraneNetworkConfig(seed=int(seed), **kw)


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
    frame losses (one per frame and receiver that missed it); ``messages_lost``.
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


def run_grid(losses=GRID_LOSSES, seeds: int = 20, strategies=STRATEGIES, horizon: float = HORIZON,
             out: str | None = None, progress: bool = True, **fixed):
    """The sweep loss x strategy x seeds.  Uses ``netcosim.sweep.run_sweep`` when it
    exists (results under *out*), else a loop in this process.  Returns ``(runs, error)``:
    one row per run (params, ``seed``, metrics) and the long error table (params,
    ``seed``, ``t``, ``norm_e``)."""
    grid = {"loss": list(losses), "strategy": list(strategies)}
    base = {"horizon": horizon, **fixed}
    try:
        from netcosim.sweep import run_sweep
    except ImportError:
        run_sweep = None
    if run_sweep is not None:
        res = run_sweep(lambda p, s: scenario({**base, **p}, s), grid=grid, seeds=seeds, out=out,
                        progress=progress)
        return res.runs, res.table("error")
    rows, errs = [], []
    points = [(loss, st, s) for loss in grid["loss"] for st in grid["strategy"] for s in range(seeds)]
    it = points
    if progress:
        from tqdm import tqdm
        it = tqdm(points, desc="flycrane sweep", unit="run")
    for loss, st, s in it:
        res = scenario({**base, "loss": loss, "strategy": st}, s)
        err = res.pop("error")
        rows.append({"loss": loss, "strategy": st, "seed": s, **res})
        errs.append(err.assign(loss=loss, strategy=st, seed=s))
    runs, error = pd.DataFrame(rows), pd.concat(errs, ignore_index=True)
    if out is not None:
        os.makedirs(out, exist_ok=True)
        runs.to_parquet(os.path.join(out, "runs.parquet"))
        error.to_parquet(os.path.join(out, "error.parquet"))
    return runs, error


def summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Cost per loss and strategy: median and 10/90 % quantiles of ``iae`` and
    ``t_settle``, the number of runs and of diverged runs, the mean measured message loss."""
    g = runs.groupby(["strategy", "loss"])
    return pd.DataFrame({
        "runs": g.size(), "diverged": g["diverged"].sum().astype(int),
        "iae_median": g["iae"].median(), "iae_q10": g["iae"].quantile(0.1), "iae_q90": g["iae"].quantile(0.9),
        "t_settle_median": g["t_settle"].median(), "t_settle_q10": g["t_settle"].quantile(0.1),
        "t_settle_q90": g["t_settle"].quantile(0.9), "msg_loss": g["msg_loss"].mean()}).reset_index()
