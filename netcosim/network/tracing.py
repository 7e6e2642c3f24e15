"""The network trace tables: their columns, the short rows the networks store, how the
stored rows are read back, and the ``network`` plot (registered by every network on its
simulation's trace).

``frames``: one row per frame event, ``network_schedule``: the interfaces' states; see
:mod:`netcosim.network.base` for the events and states.

Stored rows and reported rows
-----------------------------
The networks store short rows of integers on the hot path (as the kernel's tables do,
:mod:`netcosim.kernel.tables`): times in ticks and *codes* instead of names --

``frames``            :data:`FRAME_RAW`: ``time`` (ticks), ``key`` (the frame's id and the
                      code of its network, sender and destination names, fixed per frame:
                      :meth:`NetworkNames.key`), ``what`` (the code of the event, node and
                      outcome names, :meth:`NetworkNames.what`), ``attempt``, ``bits`` and
                      ``backoff`` (NaN where not applicable);
``network_schedule``  :data:`SCHEDULE_RAW`: ``time`` (ticks) and one code for the network,
                      the node and the state.

The names behind the codes are held by :class:`NetworkNames` (one per trace, shared by
every network of the simulation, each name once), which is also the tables' transform:
reading a table turns the codes into the reported columns (:data:`FRAME_COLUMNS`,
:data:`SCHEDULE_COLUMNS`, names as pandas categoricals, times in seconds, NaN where not
applicable), the same frames value for value as rows of names would give.  A row of
integers only is what the columnar store encodes fastest (one typed array per column, no
string lookups) and holds in 8 bytes a value; the names cost nothing per row.

In the default ``keep`` mode one stored ``frames`` row may stand for two reported rows of
one frame and instant (:meth:`NetworkNames.two`): ``created`` and ``queued`` (a frame
queued as it is sent), ``attempt_end`` and a ``delivered`` appended right after it (merged
in place: the table's newest row, :attr:`Sink.tail <netcosim.recorder.Sink.tail>`,
checked by identity).  Reading, and leaving ``keep`` mode
(:meth:`NetworkNames.carry_frames`), makes them the two rows; the other modes store one
row per reported row.  A ``network_schedule`` row is one state change; in ``keep`` mode
every change is appended (reading keeps a node's last state of an instant), the other
modes keep one row per node and instant (:attr:`Recorder.instant
<netcosim.recorder.Recorder.instant>`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from ..readback import categorical_from_codes, ticks_as_seconds
from ..timebase import RESOLUTION

#: Columns of the ``frames`` table as reported.
FRAME_COLUMNS = ("time", "network", "frame", "event", "src", "dst", "node", "attempt", "outcome",
                 "bits", "backoff")
#: Columns of the ``network_schedule`` table as reported.
SCHEDULE_COLUMNS = ("time", "network", "node", "state")
#: Columns of the ``frames`` table as stored (see the module docstring).
FRAME_RAW = ("time", "key", "what", "attempt", "bits", "backoff")
#: What the stored ``frames`` columns hold (the columnar store's promise, see
#: :class:`~netcosim.columns.ColumnStore`): integers, the attempt one byte (a chunk with an
#: attempt of 256 or more is stored in 8 bytes a value), ``bits`` and ``backoff`` as
#: doubles (NaN: not applicable; integers exact to 2**53, as the reported float64 column
#: holds them).
FRAME_DTYPES = ("int", "int", "int", "uint8", "float", "float")
#: Bits of a frame's ``key`` holding its link code (:meth:`NetworkNames.key`): at most
#: 2**24 distinct (network, sender, destination) per trace, frame ids below 2**39.
LINK_BITS = 24
#: Columns of the ``network_schedule`` table as stored: time (ticks) and
#: ``4 * pair + state`` (:meth:`NetworkNames.pair`, :data:`STATES`).
SCHEDULE_RAW = ("time", "code")
#: The network states in the order of their stored codes (0 to 3).
STATES = ("idle", "waiting", "sending", "receiving")

_UNSET = object()


if TYPE_CHECKING:
    import pandas as pd

    from ..recorder import Recorder
    from ..trace import Trace


class _Codes(dict):
    """name -> code; an unknown name gets the next code (``codes[name]`` is one dict lookup)."""

    __slots__ = ("names",)

    def __init__(self, names: list):
        super().__init__()
        self.names = names

    def __missing__(self, name):
        code = self[name] = len(self.names)
        self.names.append(name)
        return code


class NetworkNames:
    """The names behind the codes of one trace's network rows, and the transforms that read
    the rows back (see the module docstring).

    ``code[name]`` is a name's code (new names get the next one); :meth:`link` and
    :meth:`pair` code the fixed parts of a frame (network, sender, destination) and of a
    schedule row (network, node).  Codes only grow: a code stays valid for the whole run,
    also after :meth:`~netcosim.trace.Trace.clear`."""

    def __init__(self) -> None:
        #: code -> name
        self.names: list = []
        #: name -> code (``code[name]``; an unknown name is added)
        self.code = _Codes(self.names)
        #: link code -> (network, src, dst) name codes, and back
        self.links: list[tuple[int, int, int]] = []
        self._links: dict[tuple[int, int, int], int] = {}
        #: what code -> (event, node, outcome) name codes, and back
        self.whats: list[tuple[int, int, int]] = []
        self._whats: dict[tuple[int, int, int], int] = {}
        #: what code -> the what code of the second row it stands for (:meth:`two`), -1: none
        self.then: list[int] = []
        self._twos: dict[tuple[int, int], int] = {}
        self._first: dict[int, int] = {}
        #: pair code -> (network, node) name codes, and back
        self.pairs: list[tuple[int, int]] = []
        self._pairs: dict[tuple[int, int], int] = {}

    def link(self, network: str, src: str, dst: str) -> int:
        """The code of the frames sent on *network* from *src* to *dst* (names; ``"*"``: broadcast)."""
        key = (self.code[network], self.code[src], self.code[dst])
        c = self._links.get(key)
        if c is None:
            c = len(self.links)
            if c >> LINK_BITS:
                from ..errors import ConfigurationError
                raise ConfigurationError(f"the frames trace codes at most 2**{LINK_BITS} (network, sender, "
                                         f"destination) links; {network!r} {src!r} -> {dst!r} is one more")
            self._links[key] = c
            self.links.append(key)
        return c

    def key(self, frame_id: int, network: str, src: str, dst: str) -> int:
        """The stored ``key`` of frame *frame_id* sent on *network* from *src* to *dst*:
        ``frame_id << LINK_BITS | link``."""
        return frame_id << LINK_BITS | self.link(network, src, dst)

    def what(self, event: str, node: str, outcome: str) -> int:
        """The stored ``what`` code of an *event* row at *node* with *outcome* (names)."""
        code = self.code
        key = (code[event], code[node], code[outcome])
        c = self._whats.get(key)
        if c is None:
            c = self._whats[key] = len(self.whats)
            self.whats.append(key)
            self.then.append(-1)
        return c

    def row_codes(self, node: str) -> dict[str, int]:
        """The ``what`` codes of the fixed rows at the node named *node*:
        ``created``, ``queued``, ``attempt_start``, ``ok`` and ``sent`` (``attempt_end`` with
        that outcome), ``delivered``."""
        w = self.what
        codes = {"created": w("created", node, ""), "queued": w("queued", node, ""),
                 "attempt_start": w("attempt_start", node, ""), "ok": w("attempt_end", node, "ok"),
                 "sent": w("attempt_end", node, "sent"), "delivered": w("delivered", node, "")}
        codes["created+queued"] = self.two(codes["created"], codes["queued"])
        return codes

    def two(self, first: int, second: int) -> int:
        """The ``what`` code of one stored row standing for two reported rows at the same
        instant: the *first* (``what`` code) with the row's ``bits``, then the *second* with
        the row's ``backoff`` as its ``bits`` (both with ``backoff`` NaN).  The fixed rows'
        ``created+queued``: a frame queued as it is sent, in ``keep`` mode; an
        ``attempt_end`` and the frame's ``delivered`` right after it
        (:meth:`~netcosim.network.lifecycle.FrameLifecycle._hand_over`)."""
        key = (first, second)
        c = self._twos.get(key)
        if c is None:
            c = self._twos[key] = len(self.whats)
            self.whats.append(self.whats[first])
            self.then.append(second)
            self._first[c] = first
        return c

    # -- leaving keep mode -------------------------------------------------------------
    def carry_frames(self, rows: list) -> list:
        """Stored frame rows as the modes other than ``keep`` store them: a row standing
        for two (:meth:`two`) as the two rows."""
        out = []
        then, first, nan = self.then, self._first, math.nan
        for r in rows:
            second = then[r[2]]
            if second < 0:
                out.append(r)
            else:
                out.append((r[0], r[1], first[r[2]], r[3], r[4], nan))
                out.append((r[0], r[1], second, r[3], r[5], nan))
        return out

    @staticmethod
    def carry_schedule(rows: list) -> list:
        """Stored schedule rows as the modes other than ``keep`` store them: one row per node
        and instant, at the first one's place with the last one's state."""
        out: list = []
        last: dict[int, tuple[int, int]] = {}     # pair -> (time, index in out) of its latest row
        for r in rows:
            pair = r[1] >> 2
            prev = last.get(pair)
            if prev is not None and prev[0] == r[0]:
                out[prev[1]] = r
            else:
                last[pair] = (r[0], len(out))
                out.append(r)
        return out

    def pair(self, network: str, node: str) -> int:
        """The code of *node* on *network* in the schedule rows (a row stores ``4 * pair + state``)."""
        key = (self.code[network], self.code[node])
        c = self._pairs.get(key)
        if c is None:
            c = self._pairs[key] = len(self.pairs)
            self.pairs.append(key)
        return c

    def state_codes(self, network: str, node: str) -> dict[str, int]:
        """The stored code of each state of *node* on *network* (:data:`STATES`)."""
        base = 4 * self.pair(network, node)
        return {s: base + k for k, s in enumerate(STATES)}

    # -- reading ---------------------------------------------------------------------
    def _labels(self, codes, names=None):
        """A column of names from their codes: a categorical as ``astype("category")`` makes
        it (sorted categories, only those used), or the names as objects where one is not a
        string (the recorder then makes the categorical)."""
        import numpy as np
        names = self.names if names is None else names
        cat = categorical_from_codes(codes, names)
        if cat is not None:
            return cat
        labels = np.empty(len(names), dtype=object)
        labels[:] = list(names)
        return labels[codes]

    def frames_frame(self, df: pd.DataFrame) -> pd.DataFrame:
        """The stored frame rows *df* (:data:`FRAME_RAW`) as reported (:data:`FRAME_COLUMNS`)."""
        import numpy as np
        import pandas as pd
        if not len(df):
            empty = _empty(df, FRAME_COLUMNS)
            for c, dtype in (("frame", "int64"), ("attempt", "int64"), ("bits", "float64"), ("backoff", "float64")):
                empty[c] = empty[c].astype(dtype)
            return empty
        key = _ints(df["key"])
        codes = _ints(df["what"])
        bits, backoff, attempt = _floats(df["bits"]), _floats(df["backoff"]), _ints(df["attempt"])
        ticks = df[["time"]]
        then = np.asarray(self.then, dtype=np.int64)[codes]
        two = then >= 0
        if two.any():       # rows standing for two (:meth:`two`): each made two
            at = np.repeat(np.arange(len(codes)), 1 + two)
            second = np.zeros(len(at), dtype=bool)
            second[np.cumsum(1 + two)[two] - 1] = True
            key, attempt, ticks = key[at], attempt[at], pd.DataFrame({"time": ticks["time"].to_numpy()[at]})
            codes = codes[at]
            codes[second] = then[at][second]
            bits, backoff = bits[at], backoff[at]
            bits[second] = backoff[second]
            backoff[:] = np.where(two[at], np.nan, backoff)
            del at, second
        del then, two
        link = np.asarray(self.links, dtype=np.int64).reshape(-1, 3)[key & ((1 << LINK_BITS) - 1)]
        what = np.asarray(self.whats, dtype=np.int64).reshape(-1, 3)[codes]
        del codes
        cols: dict[str, Any] = {"time": ticks_as_seconds(ticks, "time", multiply=RESOLUTION)["time"]}
        cols["network"] = self._labels(link[:, 0])
        cols["frame"] = key >> LINK_BITS
        cols["event"] = self._labels(what[:, 0])
        cols["src"] = self._labels(link[:, 1])
        cols["dst"] = self._labels(link[:, 2])
        del link, key
        cols["node"] = self._labels(what[:, 1])
        cols["attempt"] = attempt
        cols["outcome"] = self._labels(what[:, 2])
        del what
        cols["bits"] = bits
        cols["backoff"] = backoff
        return pd.DataFrame(cols, columns=list(FRAME_COLUMNS), copy=False)

    def schedule_frame(self, df: pd.DataFrame) -> pd.DataFrame:
        """The stored network-schedule rows *df* (:data:`SCHEDULE_RAW`) as reported: one row per
        (network, node) and instant, where the state changed (time in s, names as
        categoricals).

        An interface that changes state several times in one instant stores a row per
        change (in ``keep`` mode; the other modes overwrite the instant's row): the rows of
        one instant become one, at the place of the first with the state of the last; a
        row whose state is that of the same node's previous row (a change that returned
        to the previous state within the instant) is dropped."""
        import numpy as np
        import pandas as pd
        if not len(df):
            return _empty(df, SCHEDULE_COLUMNS)
        code = _ints(df["code"])
        ticks = _ints(df["time"])
        pos, state = collapse_instants(code >> 2, ticks, code & 3)
        pair = code[pos] >> 2
        del code
        parts = np.asarray(self.pairs, dtype=np.int64).reshape(-1, 2)[pair]
        seconds = ticks_as_seconds(pd.DataFrame({"time": ticks[pos]}), "time", multiply=RESOLUTION)["time"]
        return pd.DataFrame({"time": seconds, "network": self._labels(parts[:, 0]),
                             "node": self._labels(parts[:, 1]), "state": self._labels(state, STATES)},
                            columns=list(SCHEDULE_COLUMNS), copy=False)


def collapse_instants(key, time, state):
    """``(rows, states)``: the rows kept of a schedule stored as *key* (one per node), *time*
    (integer ticks) and *state* (integer arrays in stored order), and their states.  The consecutive rows of
    one key at one time become one, at the first one's place with the last one's state;
    then a row whose state is that of its key's previous row is dropped (each key's first
    row is kept).  *rows* are indices into the arrays, increasing."""
    import numpy as np
    order = np.argsort(key, kind="stable")
    k, t = key[order], time[order]
    first_of_key = np.ones(len(k), dtype=bool)
    first_of_key[1:] = k[1:] != k[:-1]
    start = first_of_key.copy()
    start[1:] |= t[1:] != t[:-1]
    begin = np.flatnonzero(start)
    del t, k
    last = np.empty_like(begin)
    last[:-1] = begin[1:] - 1
    last[-1] = len(order) - 1
    runs = state[order[last]]
    repeat = np.zeros(len(begin), dtype=bool)
    repeat[1:] = (runs[1:] == runs[:-1]) & ~first_of_key[begin[1:]]
    rows = order[begin[~repeat]]
    states = runs[~repeat]
    back = np.argsort(rows, kind="stable")
    return rows[back], states[back]


def _empty(df: pd.DataFrame, columns) -> pd.DataFrame:
    """The reported frame of no rows: *columns* of the type the store gives an empty stored
    column (the recorder makes the name columns categoricals of it), ``time`` float."""
    import pandas as pd
    dtype = df.dtypes.iloc[0] if len(df.columns) else object
    empty = pd.DataFrame({c: pd.Series([], dtype=dtype) for c in columns})
    empty["time"] = empty["time"].astype(float)
    return empty


def _ints(col):
    """A stored column of integers as an int64 array (it is one unless a chunk fell back to objects)."""
    import numpy as np
    v = col.to_numpy()
    return v if v.dtype == np.int64 else np.asarray(v, dtype=np.int64)


def _floats(col):
    """A stored ``bits``/``backoff`` column as float64 (as ``astype``; it is one unless a
    chunk fell back to objects)."""
    import numpy as np
    v = col.to_numpy()
    return v if v.dtype == np.float64 else col.astype("float64").to_numpy()


def network_tables(trace: Trace) -> tuple[NetworkNames, Recorder, Recorder]:
    """The names and the ``frames`` and ``network_schedule`` tables of *trace* (created by
    the first network of a simulation, shared by the others)."""
    if "frames" in trace.tables:
        frames = trace.recorder("frames")
        names = getattr(frames.transform, "__self__", None)
        if not isinstance(names, NetworkNames):
            raise TypeError(f"trace table 'frames' was not created by a network: {frames.columns}")
        return names, frames, trace.recorder("network_schedule")
    names = NetworkNames()
    frames = trace.table("frames", FRAME_RAW, categorical=("network", "event", "src", "dst", "node", "outcome"),
                         transform=names.frames_frame, dtypes=FRAME_DTYPES)
    sched = trace.table("network_schedule", SCHEDULE_RAW, categorical=("network", "node", "state"),
                        transform=names.schedule_frame, dtypes=("int",) * len(SCHEDULE_RAW), instant=_node_of)
    frames.carry, sched.carry = names.carry_frames, names.carry_schedule
    return names, frames, sched


def _node_of(row: tuple) -> int:
    """The (network, node) pair code of a stored schedule row: one row per pair and instant."""
    return row[1] >> 2


def _plot_network(trace, frames: Any = _UNSET, **options):
    """``Trace.plot("network")``: :func:`~netcosim.network.plot.plot_network_schedule` of the
    ``network_schedule`` table, with the ``frames`` table's losses and retransmissions."""
    from .plot import plot_network_schedule
    if frames is _UNSET:
        frames = trace.frame("frames")
    return plot_network_schedule(trace.frame("network_schedule"), frames=frames, **options)
