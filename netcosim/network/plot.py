"""Network schedule plot: one row per node, a staircase of its state, with a legend.

Each node's row spans ``[row, row + 1)``; its staircase sits at ``row + level`` with the
levels of :data:`NETWORK_STATES`: idle at the bottom (``row``),
then receiving, waiting (frames queued, backing off or awaiting an ACK) and sending at
the top.  The time spent in each non-idle state is also shaded in that state's colour
(:data:`STATE_COLOURS`), so an idle node is an empty, flat row.  With the ``frames``
table the plot marks every lost frame (a red cross on the row of the node where it was
lost) and every retransmission (an orange triangle on the sender's row where the
attempt starts).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..plot import check_columns, check_image_path, plot_staircases, save
from ..view.segments import NETWORK_COLOURS, NETWORK_STATES, frame_markers, state_intervals

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["NETWORK_STATES", "STATE_COLOURS", "LOST_LABEL", "RETRANSMISSION_LABEL", "plot_network_schedule"]

#: Fill colour of each non-idle network state (idle is not shaded; :data:`netcosim.view.segments.NETWORK_COLOURS`).
STATE_COLOURS = NETWORK_COLOURS
#: Legend labels of the two kinds of markers.
LOST_LABEL = "frame lost"
RETRANSMISSION_LABEL = "retransmission"


def _shade(ax, df, row_of, t0, t1) -> None:
    """Fill each node's non-idle intervals inside ``[t0, t1]`` from its row to its level."""
    labels = df["node"].astype(str).to_numpy()
    times = df["time"].to_numpy(dtype=float)
    states = df["state"].astype(str).to_numpy()
    for lab, row in row_of.items():
        sel = labels == lab
        # (start, end, state) intervals clipped to the window
        for a, b, s in zip(*state_intervals(times[sel], states[sel], t1)):
            a, b = max(a, t0), min(b, t1)
            if b <= a or s not in STATE_COLOURS:
                continue
            ax.fill_between((a, b), row, row + NETWORK_STATES[s], color=STATE_COLOURS[s], alpha=0.35, lw=0)


def plot_network_schedule(schedule: pd.DataFrame, *, network: str | None = None, nodes: Sequence[str] | None = None,
                          t_range=None, frames: pd.DataFrame | None = None, ax=None,
                          path: str | Path | None = None, title: str | None = None):
    """Draw ``sim.trace.frame("network_schedule")`` as one staircase per node, with a legend.

    ``schedule``: that table (columns ``time``, ``network``, ``node``, ``state``).

    ``network`` selects one network (needed if the table holds several); ``nodes``
    orders the rows (top first; default order of appearance); ``t_range = (t0, t1)``
    in seconds.  ``frames`` (the ``frames`` table) adds a marker for every ``lost`` row
    inside the window (label :data:`LOST_LABEL`, at the row of the node where the frame
    was lost, the sender's row if that node is not drawn) and for every retransmission,
    an ``attempt_start`` with ``attempt > 1`` (label :data:`RETRANSMISSION_LABEL`, on the
    sender's row).  ``ax``: the matplotlib axes to draw on (None: a new figure);
    ``title``: the axes' title (None: none).  ``path`` saves a PNG.  Returns the axes.
    """
    check_columns(schedule, ("time", "network", "node", "state"), "schedule")
    check_image_path(path)
    df = schedule
    if network is not None:
        df = df[df["network"] == network]
    elif df["network"].nunique() > 1:
        raise ValueError(f"schedule holds several networks {sorted(df['network'].unique())}; pass network=")
    if df.empty:
        raise ValueError("empty network schedule: nothing to plot (did the simulation run?)")
    ax, row_of, (t0, t1) = plot_staircases(df, "node", NETWORK_STATES, order=nodes, t_range=t_range, ax=ax,
                                           what="node")
    for line in ax.get_lines():
        line.set_color("black")
        line.set_linewidth(0.9)
    _shade(ax, df, row_of, t0, t1)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    handles: list = [Patch(color=STATE_COLOURS[s], alpha=0.35, label=s)
               for s in sorted(STATE_COLOURS, key=NETWORK_STATES.__getitem__, reverse=True)]
    handles.append(Line2D([], [], color="black", lw=0.9, label="idle (baseline)"))
    top = NETWORK_STATES["sending"]
    if frames is not None:
        fr = frames
        if network is not None:
            fr = fr[fr["network"] == network]
        lost, rt = frame_markers(fr, t0, t1)
        where = [n if n in row_of else s for n, s in zip(lost["node"].astype(str), lost["src"].astype(str))]
        ys = [row_of.get(n, np.nan) + top for n in where]
        ax.plot(lost["time"].to_numpy(dtype=float), ys, "x", color="red", ms=7, mew=1.5, label=LOST_LABEL)
        ys = [row_of.get(s, np.nan) + top for s in rt["src"].astype(str)]
        ax.plot(rt["time"].to_numpy(dtype=float), ys, "^", color="darkorange", ms=5, label=RETRANSMISSION_LABEL)
        handles += ax.get_lines()[-2:]
    ax.set_yticks([r + 0.5 for r in range(len(row_of))], sorted(row_of, key=row_of.__getitem__))
    ax.set_ylim(-0.1, len(row_of))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="small")
    ax.set_title(title or "network schedule")
    save(ax, path)
    return ax
