"""The network trace tables: their columns, how their stored rows are read back, and the
``network`` plot (registered by every network on its simulation's trace).

``frames``: one row per frame event, ``network_schedule``: the interfaces' states; see
:mod:`netcosim.network.base` for the events and states.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..readback import ticks_as_seconds
from ..timebase import RESOLUTION

FRAME_COLUMNS = ("time", "network", "frame", "event", "src", "dst", "node", "attempt", "outcome",
                 "bits", "backoff")
SCHEDULE_COLUMNS = ("time", "network", "node", "state")

_UNSET = object()


if TYPE_CHECKING:
    import pandas as pd


def _frames_frame(df: pd.DataFrame) -> pd.DataFrame:
    if not len(df):
        df["time"] = df["time"].astype(float)
    else:
        df = ticks_as_seconds(df, "time", multiply=RESOLUTION)
    for c, dtype in (("frame", "int64"), ("attempt", "int64"), ("bits", "float64"), ("backoff", "float64")):
        if df[c].dtype != dtype:
            df[c] = df[c].astype(dtype)
    return df


def _schedule_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Stored network-schedule rows as reported: a same-instant change that returned to
    the previous state leaves a repeated row per (network, node), dropped; time in s."""
    import pandas as pd
    if not len(df):
        df["time"] = df["time"].astype(float)
        return df
    keep = _first_of_runs(df)
    if keep is not None:
        if not keep.all():
            # column by column, each dropped from df as it is filtered: one column's copy at a time
            cols = {c: df.pop(c)[keep].reset_index(drop=True) for c in list(df.columns)}
            df = pd.DataFrame(cols, copy=False)
    else:       # names as objects (a table not read back column by column)
        prev = df.groupby(["network", "node"], sort=False)["state"].shift()
        df = df[df["state"] != prev].reset_index(drop=True)
    return ticks_as_seconds(df, "time", multiply=RESOLUTION)


def _first_of_runs(df: pd.DataFrame):
    """Rows whose state differs from the previous row of the same (network, node) (True
    for each one's first row), from the categoricals' codes in blocks of rows; None
    unless the three columns are categoricals."""
    import numpy as np
    import pandas as pd
    cols = [df[c] for c in ("network", "node", "state")]
    if not all(isinstance(c.dtype, pd.CategoricalDtype) for c in cols):
        return None
    net, node, state = (c.cat.codes.to_numpy() for c in cols)
    width = len(cols[1].cat.categories) + 1
    keep = np.ones(len(df), dtype=bool)
    last: dict[int, int] = {}
    block = 1 << 20
    for i in range(0, len(df), block):
        key = net[i:i + block].astype(np.int32) * width + node[i:i + block]
        st = state[i:i + block]
        for k in np.flatnonzero(np.bincount(key)):
            pos = np.flatnonzero(key == k)
            s = st[pos]
            prev = np.empty_like(s)
            prev[0] = last.get(int(k), -1)
            prev[1:] = s[:-1]
            keep[i + pos[s == prev]] = False
            last[int(k)] = int(s[-1])
    return keep


def _plot_network(trace, frames: Any = _UNSET, **options):
    """``Trace.plot("network")``: :func:`~netcosim.network.plot.plot_network_schedule` of the
    ``network_schedule`` table, with the ``frames`` table's losses and retransmissions."""
    from .plot import plot_network_schedule
    if frames is _UNSET:
        frames = trace.frame("frames")
    return plot_network_schedule(trace.frame("network_schedule"), frames=frames, **options)
