"""TrueTime-style network schedule plot.

One row per node; the staircase sits at ``row + 0.5`` while the node sends,
``row + 0.25`` while it waits (frames queued, backing off or awaiting an ACK),
``row + 0.125`` while it receives a frame addressed to it, and ``row`` when idle
(levels in :data:`~netcosim.network.base.NETWORK_STATES`).  Lost frames can be marked.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg", force=False)
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from .base import NETWORK_STATES  # noqa: E402


def plot_network_schedule(schedule: pd.DataFrame, *, network: str | None = None, nodes: Sequence[str] | None = None,
                          t_range=None, frames: pd.DataFrame | None = None, ax=None,
                          path: str | Path | None = None, title: str | None = None):
    """Draw ``sim.trace.frame("network_schedule")`` as one staircase per node.

    ``network`` selects one network (needed if the table holds several); ``nodes``
    orders the rows (top first; default order of appearance); ``t_range = (t0, t1)``
    in seconds; ``frames`` (the ``frames`` table) adds a red cross at the sender's row
    for every frame lost.  ``path`` saves a PNG.  Returns the axes.
    """
    df = schedule
    if network is not None:
        df = df[df["network"] == network]
    elif df["network"].nunique() > 1:
        raise ValueError(f"schedule holds several networks {sorted(df['network'].unique())}; pass network=")
    if df.empty:
        raise ValueError("empty network schedule: nothing to plot (did the simulation run?)")
    order = list(nodes) if nodes is not None else list(dict.fromkeys(df["node"].astype(str)))
    t0, t1 = t_range if t_range is not None else (float(df["time"].min()), float(df["time"].max()))
    if not t1 > t0:
        t1 = t0 + 1e-9
    if ax is None:
        fig, ax = plt.subplots(figsize=(10, 0.8 + 0.6 * len(order)))
    row_of = {}
    for row, node in enumerate(reversed(order)):
        row_of[node] = row
        sel = df[df["node"].astype(str) == node]
        if sel.empty:
            raise KeyError(f"no node {node!r} in the network schedule; have {sorted(set(df['node'].astype(str)))}")
        times = sel["time"].to_numpy(dtype=float)
        levels = row + sel["state"].astype(str).map(NETWORK_STATES).to_numpy(dtype=float)
        before = times <= t0
        start_level = levels[before][-1] if before.any() else row
        inside = (times > t0) & (times < t1)
        ts = np.concatenate(([t0], times[inside], [t1]))
        ls = np.concatenate(([start_level], levels[inside], [levels[inside][-1] if inside.any() else start_level]))
        ax.step(ts, ls, where="post", lw=1.2)
    if frames is not None:
        fr = frames
        if network is not None:
            fr = fr[fr["network"] == network]
        lost = fr[(fr["event"] == "lost") & (fr["time"] >= t0) & (fr["time"] <= t1)]
        xs = lost["time"].to_numpy(dtype=float)
        ys = [row_of.get(str(s), np.nan) + 0.5 for s in lost["src"].astype(str)]
        if len(xs):
            ax.plot(xs, ys, "x", color="red", ms=6, label="frame lost")
            ax.legend(loc="upper right")
    ax.set_yticks([r + 0.25 for r in range(len(order))])
    ax.set_yticklabels(list(reversed(order)))
    ax.set_xlim(t0, t1)
    ax.set_xlabel("time [s]")
    ax.set_title(title or "network schedule (high = sending, medium = waiting, low = idle)")
    ax.grid(axis="x", alpha=0.3)
    if path is not None:
        ax.figure.tight_layout()
        ax.figure.savefig(path, dpi=120)
        plt.close(ax.figure)
    return ax
