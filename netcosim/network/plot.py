"""TrueTime-style network schedule plot.

One row per node; the staircase sits at ``row + 0.5`` while the node sends,
``row + 0.25`` while it waits (frames queued, backing off or awaiting an ACK),
``row + 0.125`` while it receives a frame addressed to it, and ``row`` when idle
(levels in :data:`~netcosim.network.base.NETWORK_STATES`).  Lost frames can be marked.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..plot import plot_staircases, save
from .base import NETWORK_STATES

if TYPE_CHECKING:
    import pandas as pd


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
    ax, row_of, (t0, t1) = plot_staircases(df, "node", NETWORK_STATES, order=nodes, t_range=t_range, ax=ax,
                                           what="node")
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
    ax.set_title(title or "network schedule (high = sending, medium = waiting, low = idle)")
    save(ax, path)
    return ax
