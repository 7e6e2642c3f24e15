"""A trace table's rows and how they are kept: :class:`Recorder` (one table: its columns,
its storage mode, its transform to the reported frame) and the sink components append
to.  :class:`~netcosim.trace.Trace` holds the recorders of a run; this module holds
what one table does with its rows (``keep`` in memory up to :data:`DEFAULT_MEMORY`
then in a temporary file, ``off``, ``ring``, ``window``, ``stream`` to Parquet) and how
it reads them back (column by column from :class:`~netcosim.columns.ColumnStore`).
"""

from __future__ import annotations

import os
from collections import deque
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

from . import validate
from .columns import ColumnStore
from .errors import ConfigurationError
from .timebase import TICKS_PER_SECOND

if TYPE_CHECKING:  # pandas is imported on first use: a simulation does not need it
    import pandas as pd

#: Storage modes of a table (see :meth:`Trace.configure`).
MODES = ("keep", "off", "ring", "window", "stream")
#: Default number of rows per Parquet file in ``stream`` mode.
DEFAULT_ROW_GROUP = 50_000
#: Name pattern of the Parquet files a streamed table writes into its directory.
PART_NAME = "part-{:06d}.parquet"
#: Default memory budget of a ``keep``-mode table: bytes of encoded rows held in memory
#: before the older ones move to a temporary file (``configure(..., memory=...)``).
#: 4 MiB: a one-hour 802.11b soak runs in 75 MB and reads back in 452 MB (16 MiB: 172
#: and 522 MB); a run whose tables pass 4 MiB pays for the writes (0.9 % CPU on 10
#: periodic tasks over 100 s against no limit; docs/architecture.md, "Default bound").
DEFAULT_MEMORY = 4 * 2 ** 20


#: ``().count(row)`` is a C-level call that ignores its argument: the ``off`` mode's append.
_discard = ().count


def _positive_int(value, what: str) -> int:
    return validate.integer(value, what, lo=1, kind="a positive integer")


#: The most rows a ``mode="ring"`` table may be asked to hold (2**40: far beyond any memory,
#: but a bound, so ``rows=2**70`` is refused naming it rather than overflowing).
MAX_RING_ROWS = 2**40


class Sink:
    """The stable object components append rows to: ``rec.rows.append(row)``.

    Components keep a reference to it (or fetch it per call); :meth:`Trace.configure`
    swaps what :attr:`append` does, never the object, so no reference goes stale.
    ``append`` is a single bound-method call: ``list.append`` in ``keep`` mode,
    ``deque.append`` with ``maxlen`` in ``ring`` mode, a C no-op in ``off`` mode, a
    small function in ``window``/``stream`` mode or with decimation.

    :attr:`tail` is the list ``append`` appends to in ``keep`` mode without decimation
    (the newest rows of the :class:`~netcosim.columns.ColumnStore`, not yet encoded;
    always the same list for one store), None otherwise: a producer whose own row is
    ``tail[-1]`` (checked by identity) may overwrite it with a row standing for it and
    the next one (the network tables, :mod:`netcosim.network.tracing`).
    """

    __slots__ = ("append", "extend", "tail", "_rec")

    def __init__(self, rec: "Recorder"):
        self._rec = rec
        self.append: Callable[[tuple], object] = rec._buf.append
        #: ``extend(rows)``: append several rows (an iterable of tuples) at once, as ``append`` would
        self.extend: Callable[[list], object] = rec._buf.extend
        #: the keep mode's list of newest rows (see above); None in the other modes
        self.tail: list | None = rec._buf._tail if type(rec._buf) is ColumnStore else None

    def replace(self, old: tuple, new: tuple) -> None:
        """Overwrite the row *old* (the very object appended earlier) with *new*.

        Used for "one row per instant" tables (the network schedule overwrites a state
        that lasted zero time).  If *old* is no longer held in memory (dropped by the
        ring or the window, written to Parquet, cleared) *new* is appended instead.
        """
        if not self._swap(old, new):
            self.append(new)

    def _swap(self, old: tuple, new: tuple) -> bool:
        """Overwrite the held row *old* (by identity) with *new*; False when it is not held."""
        buf = self._rec._buf
        if type(buf) is ColumnStore:
            return buf.replace(old, new)
        for i in range(len(buf) - 1, -1, -1):
            if buf[i] is old:
                buf[i] = new  # type: ignore[index]  # a list or a deque here
                return True
        return False

    def __len__(self) -> int:
        """Rows held in memory now."""
        return len(self._rec._buf)

    def __iter__(self):
        return iter(self._rec._buf)

    def __getitem__(self, i):
        return self._rec._buf[i]


class Recorder:
    """One table: a fixed tuple of column names and its rows, stored according to a mode.

    ``rows`` is the :class:`Sink` components append to.  ``time`` names the column the
    ``window`` mode measures (``None``: the table has no time and cannot be windowed),
    ``time_unit`` is ``"ticks"`` (integer picoseconds) or ``"s"``.  ``key`` names the
    columns that identify one signal, for decimation (``every``).

    ``name``: the table's name in the trace; ``columns``: the stored columns' names;
    ``categorical``: the columns reported as pandas categories; ``transform``: a function
    turning the stored frame into the reported one (None: reported as stored);
    ``clock``: returns the current simulation time (ticks), for the ``window`` mode
    (None: the latest stored time stands for now); ``dtypes``: one column type per
    column for the columnar store (None entries, or None: found from the values);
    ``keeps_categories``: the transform gives the categorical columns back unchanged;
    ``identity``: stored columns of objects coded by identity (see :meth:`Trace.table
    <netcosim.trace.Trace.table>`); ``instant``: the key of one row per key and instant in
    the modes other than keep (:attr:`instant`).
    """

    __slots__ = ("name", "columns", "rows", "categorical", "dtypes", "providers", "transform", "time_index",
                 "time_scale", "key_index", "mode", "options", "memory", "keeps_categories", "identity", "_buf",
                 "carry", "instant", "_clock",
                 "_window", "_stream", "_counts", "_latest")

    def __init__(self, name: str, columns: Sequence[str], categorical: Iterable[str] = (),
                 transform=None, *, time: str | None = "time", time_unit: str = "ticks",
                 key: Sequence[str] = (), clock: Callable[[], int] | None = None,
                 dtypes: Sequence[str | None] | None = None, keeps_categories: bool = False,
                 identity: Sequence[str] = (), instant: Callable[[tuple], Any] | None = None):
        self.name = name
        #: stored columns of objects coded by identity that the transform accepts as a pandas
        #: Categorical of the objects (see :meth:`Trace.table`)
        self.identity = tuple(identity)
        #: the transform gives the categorical columns' values back unchanged (it may drop
        #: rows): a table read back from disk hands them to it as pandas categoricals
        self.keeps_categories = keeps_categories or transform is None
        self.columns = tuple(columns)
        #: the producers' promise of column types for the columnar store (see
        #: :class:`~netcosim.columns.ColumnStore`); None: found from the values
        self.dtypes = tuple(dtypes) if dtypes is not None else None
        #: categorical columns: a stored one without a declared dtype is coded in the store,
        #: and every one in the reported frame is a pandas ``category``
        self.categorical = tuple(categorical)
        #: callables returning rows that describe the current state (e.g. unfinished
        #: jobs); evaluated each time the table is read, never stored.
        self.providers: list = []
        #: optional function turning the stored frame into the reported one
        self.transform = transform
        #: optional ``carry(rows) -> rows``: the rows stored in ``keep`` mode as the other modes
        #: store them, one per reported row (a table whose keep mode stores one row for
        #: several, e.g. the network tables); applied to the rows carried out of keep mode
        self.carry: Callable[[list], list] | None = None
        #: optional ``instant(row) -> key``: one row per key and instant in the modes other
        #: than ``keep``: a row whose key and time are those of its key's latest row replaces
        #: that row (:meth:`Sink.replace`; the network schedule).  ``keep`` mode stores every
        #: row (the table's transform then keeps an instant's last one).
        self.instant = instant
        validate.choice(time_unit, f"table {name!r}: time_unit", ("ticks", "s"))
        self.time_index = self.columns.index(time) if time is not None and time in self.columns else None
        #: stored time units per second
        self.time_scale = TICKS_PER_SECOND if time_unit == "ticks" else 1.0
        self.key_index = tuple(self.columns.index(k) for k in key) if key else ()
        self._clock = clock
        #: keep mode's memory budget (bytes of encoded rows; None: no limit)
        self.memory: int | None = DEFAULT_MEMORY
        self._buf: list | deque | ColumnStore = self._column_store()
        self._window: int | float | None = None      # stored-unit width of the window
        self._stream: _Stream | None = None      # _Stream in stream mode
        self._counts: dict = {}  # decimation counters per key
        self._latest = None      # latest stored time seen (window mode, no clock)
        self.mode = "keep"
        self.options: dict = {}
        self.rows = Sink(self)

    def _column_store(self) -> ColumnStore:
        coded = [i for i, c in enumerate(self.columns)
                 if c in self.categorical and (self.dtypes is None or self.dtypes[i] is None)]
        return ColumnStore(len(self.columns), categorical=coded, dtypes=self.dtypes, memory=self.memory)

    def append(self, row: tuple) -> None:
        """Add one *row* (a tuple in the table's column order; times in the table's stored unit) under
        the table's storage mode."""
        self.rows.append(row)

    def __len__(self) -> int:
        """Rows held: in memory plus, in stream mode, already written to Parquet."""
        n = len(self._buf)
        if self._stream is not None:
            n += self._stream.written
        return n

    # -- configuration --------------------------------------------------------------
    def configure(self, mode: str = "keep", *, rows=None, seconds=None, every=1, path=None,
                  row_group=DEFAULT_ROW_GROUP, overwrite: bool = False, memory=DEFAULT_MEMORY) -> None:
        """Set how this table stores rows: ``mode`` (``"keep"``, ``"off"``, ``"ring"``,
        ``"window"``, ``"stream"``), ``rows`` (ring size), ``seconds`` (the window width in s),
        ``every`` (decimation per signal), ``path`` and ``row_group`` (stream directory and
        rows per file), ``overwrite`` (delete an earlier stream's files), ``memory`` (keep
        mode's budget, bytes; None: no limit); see :meth:`Trace.configure
        <netcosim.trace.Trace.configure>`."""
        w = f"trace table {self.name!r}"
        if not isinstance(mode, str) or mode not in MODES:
            raise ConfigurationError(f"{w}: unknown mode {mode!r}; choose one of {MODES}")
        given = {"rows": rows, "seconds": seconds, "path": path}
        needed = {"ring": "rows", "window": "seconds", "stream": "path"}.get(mode)
        for opt, value in given.items():
            if value is not None and opt != needed:
                raise ConfigurationError(f"{w}: option {opt}={value!r} does not apply to mode={mode!r}")
        if needed is not None and given[needed] is None:
            raise ConfigurationError(f"{w}: mode={mode!r} needs {needed}=..., got None")
        every = _positive_int(every, f"{w}: every")
        if every > 1:
            if not self.key_index:
                raise ConfigurationError(f"{w}: every={every!r} needs a per-signal table (signals); "
                                         f"this table has no signal key")
            if mode == "off":
                raise ConfigurationError(f"{w}: every={every!r} does not apply to mode='off'")
        row_group = _positive_int(row_group, f"{w}: row_group")
        if memory is not None:
            memory = _positive_int(memory, f"{w}: memory (bytes, or None for no limit)")
        if mode == "ring":
            rows = validate.integer(rows, f"{w}: rows", lo=1, hi=MAX_RING_ROWS,
                                    kind="a positive integer <= 2**40 (MAX_RING_ROWS)")
        window = None
        if mode == "window":
            if self.time_index is None:
                raise ConfigurationError(f"{w}: has no time column, so mode='window' cannot apply")
            ticks = validate.duration(seconds, f"{w}: seconds", positive=True, kind="positive")
            window = ticks if self.time_scale == TICKS_PER_SECOND else ticks / TICKS_PER_SECOND
        stream = None
        if mode == "stream":
            stream = _Stream(self, path, row_group, overwrite)

        # Everything valid: switch.  Rows held in memory carry over, within the new bounds;
        # rows already written by an earlier stream stay in their files.
        old = list(self._buf)
        if self.mode == "keep" and mode != "keep" and self.carry is not None:
            old = self.carry(old)
        self.mode = mode
        self.memory = memory
        self.options = {k: v for k, v in dict(rows=rows, seconds=seconds, every=every, path=path,
                                                   row_group=row_group).items()
                        if v is not None and (k != "every" or v != 1) and (k != "row_group" or mode == "stream")}
        if mode == "keep" and memory != DEFAULT_MEMORY:
            self.options["memory"] = memory
        self._window, self._stream, self._latest = window, stream, None
        if every == 1:
            self._counts = {}
        if mode == "ring":
            self._buf = deque(maxlen=rows)
        elif mode == "window":
            self._buf = deque()
        elif mode == "keep":
            self._buf = self._column_store()
        else:
            self._buf = []
        store = self._make_store()
        self.rows.append = append = self._decimator(store, every) if every > 1 else store
        if self.instant is not None and mode not in ("keep", "off"):
            self.rows.append = append = self._one_per_instant(append, old)
        self.rows.tail = self._buf._tail if append is store and type(self._buf) is ColumnStore else None
        if append is store and mode in ("keep", "ring"):
            self.rows.extend = self._buf.extend
        elif mode == "off":
            self.rows.extend = _discard
        else:
            def extend(rows):
                for r in rows:
                    append(r)
            self.rows.extend = extend
        if mode != "off":
            for r in old:
                store(r)

    def _make_store(self) -> Callable[[tuple], object]:
        mode, buf = self.mode, self._buf
        if mode == "off":
            return _discard
        if mode in ("keep", "ring"):
            return buf.append
        if mode == "window":
            ti, width, rec = self.time_index, self._window, self

            def window_append(row, buf=buf):
                buf.append(row)
                t = row[ti]
                latest = rec._latest
                if latest is None or t > latest:
                    rec._latest = latest = t
                # the clock is at least the latest row time: dropping rows older than
                # (latest - width) never drops a row the window still shows
                if buf[0][ti] < latest - width:
                    cut = latest - width
                    while buf and buf[0][ti] < cut:
                        buf.popleft()
            return window_append
        stream = self._stream
        assert stream is not None
        limit = stream.row_group

        def stream_append(row, buf=buf):
            buf.append(row)
            if len(buf) >= limit:
                stream.flush()
        return stream_append

    def _one_per_instant(self, append, carried: list):
        """*append* with :attr:`instant`'s rule: a row of the same key and time as that key's
        latest row replaces it (as :meth:`Sink.replace`: appended when that row is no longer
        held).  The latest rows start as those of *carried* (the rows held before the switch)."""
        key, ti, swap = self.instant, self.time_index, self.rows._swap
        assert key is not None and ti is not None
        latest: dict = {key(r): r for r in carried}

        def one_per_instant(row):
            k = key(row)
            prev = latest.get(k)
            latest[k] = row
            if prev is None or prev[ti] != row[ti] or not swap(prev, row):
                append(row)
        return one_per_instant

    def _decimator(self, store, every: int):
        counts, ki = self._counts, self.key_index

        def decimate(row):
            key = tuple(row[i] for i in ki)
            n = counts.get(key, 0)
            counts[key] = n + 1
            if n % every == 0:
                store(row)
        return decimate

    def clear(self) -> None:
        """Drop every row recorded so far; appending goes on in the same mode.

        Safe at any instant: components keep appending to the same sink, providers
        (unfinished jobs) still report, decimation keeps its phase, and in stream mode
        the files written so far are deleted (the directory stays, later files are valid).
        """
        self._buf.clear()
        self._latest = None
        if self._stream is not None:
            self._stream.clear()

    # -- reading --------------------------------------------------------------------
    def _current_time(self):
        """Current time in stored units: the simulation clock if known, else the latest row."""
        if self._clock is not None:
            now = self._clock()
            return now if self.time_scale == TICKS_PER_SECOND else now / TICKS_PER_SECOND
        return self._latest

    def frame(self) -> pd.DataFrame:
        """The table as a DataFrame (a fresh copy every call)."""
        import pandas as pd
        buf = self._buf
        if type(buf) is ColumnStore and self.mode == "keep":
            # built column by column from the encoded chunks (and the temporary file): no
            # tuple per row, so reading needs about the memory of the frame itself
            cats = [i for i, c in enumerate(self.columns) if c in self.categorical] if self.keeps_categories else []
            ident = [i for i, c in enumerate(self.columns) if c in self.identity]
            df = buf.frame(self.columns, [r for p in self.providers for r in p()], categories=cats, identity=ident)
            rows_read = len(df)
            if self.transform is not None:
                df = self.transform(df)
            for c in self.categorical:
                if c in df.columns:
                    col = df[c]
                    if not isinstance(col.dtype, pd.CategoricalDtype):
                        df[c] = col.astype("category")
                    elif len(df) != rows_read:
                        # categories as astype("category") makes them: those left after the transform
                        # (without a dropped row, the read's categories are exactly the ones used)
                        df[c] = col.cat.remove_unused_categories()
            return df
        if self.mode == "off":
            rows: list = []
        else:
            rows = list(self._buf)
            if self.providers:
                rows += [r for p in self.providers for r in p()]
            if self.mode == "window" and rows:
                ti = self.time_index
                now = self._current_time()
                if now is None:
                    now = max(r[ti] for r in rows)
                cut = now - self._window
                rows = [r for r in rows if r[ti] >= cut]
        df = self._stored_frame(rows)
        if self._stream is not None and self._stream.parts:
            written = self._stream.read()
            df = pd.concat([written, df], ignore_index=True) if len(df) else written
        for c in self.categorical:
            if c in df.columns:
                df[c] = df[c].astype("category")
        return df

    def _stored_frame(self, rows) -> pd.DataFrame:
        import pandas as pd
        df = pd.DataFrame.from_records(rows, columns=list(self.columns))
        if self.transform is not None:
            df = self.transform(df)
        return df


class _Stream:
    """Parquet output of one table: one file of ``row_group`` rows per flush in *path*."""

    def __init__(self, rec: Recorder, path, row_group: int, overwrite: bool):
        w = f"trace table {rec.name!r}"
        try:
            import pyarrow  # noqa: F401
            import pyarrow.parquet  # noqa: F401
        except ImportError as exc:  # pragma: no cover - pyarrow is a dependency
            raise ConfigurationError(f"{w}: mode='stream' needs pyarrow ({exc})") from None
        validate.path(path, f"{w}: path", kind="a directory path (str or os.PathLike)")
        validate.boolean(overwrite, f"{w}: overwrite")
        p = Path(path)
        if p.exists() and not p.is_dir():
            raise ConfigurationError(f"{w}: stream path {str(p)!r} exists and is not a directory")
        try:
            p.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigurationError(f"{w}: cannot create stream directory {str(p)!r}: {exc.strerror}") from None
        if not os.access(p, os.W_OK):
            raise ConfigurationError(f"{w}: stream directory {str(p)!r} is not writable")
        old = sorted(p.glob("part-*.parquet"))
        if old:
            if not overwrite:
                raise ConfigurationError(f"{w}: stream directory {str(p)!r} already holds {len(old)} Parquet "
                                         f"file(s) ({old[0].name}, ...); pass overwrite=True or another path")
            for f in old:
                f.unlink()
        self.rec, self.path, self.row_group = rec, p, row_group
        self.parts: list[Path] = []
        self.written = 0
        self._next = 0

    def flush(self) -> None:
        """Write the rows held in memory as one Parquet file and forget them."""
        import pandas as pd
        import pyarrow as pa
        import pyarrow.parquet as pq
        rec = self.rec
        buf = rec._buf
        if not buf:
            return
        rows = list(buf)
        df = rec._stored_frame(rows)
        for c in df.columns:
            if isinstance(df[c].dtype, pd.CategoricalDtype):   # a transform's names: written as plain strings
                df[c] = df[c].astype(object)
        f = self.path / PART_NAME.format(self._next)
        tmp = f.with_suffix(".parquet.tmp")
        pq.write_table(pa.Table.from_pandas(df, preserve_index=False), tmp)
        os.replace(tmp, f)  # a part file is either complete or absent
        self._next += 1
        self.parts.append(f)
        self.written += len(rows)
        buf.clear()

    def read(self) -> pd.DataFrame:
        import pandas as pd
        import pyarrow.parquet as pq
        frames = [pq.read_table(f).to_pandas() for f in self.parts]
        return pd.concat(frames, ignore_index=True)

    def clear(self) -> None:
        for f in self.parts:
            f.unlink(missing_ok=True)
        self.parts = []
        self.written = 0
