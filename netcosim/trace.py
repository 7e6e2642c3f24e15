"""Columnar recorders that turn a run into tidy pandas DataFrames.

A :class:`Trace` holds named :class:`Recorder` tables.  Appending a row is one call of
a bound method (a plain ``list.append`` in the default mode, cheap on the hot path);
the DataFrame is built only when asked.  Every table reports times in seconds
(float), under the column ``time``; hot-path tables may store integer ticks and
convert when the frame is built (``transform``).

Standard tables:

``signals``   ``time, source, signal, value``  -- plant logs and ``ctx.log``
``schedule``  ``time, node, task, state``       -- every task state change
``jobs``      one row per finished (or killed) job with its statistics

A Trace itself creates only ``signals``; the components register their own tables with
:meth:`Trace.table`: the kernel ``schedule`` and ``jobs`` (:mod:`netcosim.kernel.tables`,
registered when the :class:`~netcosim.Simulation` is built), each network ``frames`` and
``network_schedule`` (:mod:`netcosim.network.base`).

Memory
------
By default every table keeps every row (``mode="keep"``), in memory up to
:data:`DEFAULT_MEMORY` (4 MiB of encoded rows per table) and beyond it in a temporary
file of columnar chunks, read back when the table is read: a long run's memory stays
bounded, its disk use grows.  :meth:`Trace.configure` (one table) and
:meth:`Trace.configure_all` (every table, including those created later) choose, at any
time, also mid-run:

==========  ========================================================================
``keep``    every row (the default; ``memory=None``: all of them in memory)
``off``     no rows at all
``ring``    the last ``rows`` rows
``window``  the rows whose time lies in the last ``seconds`` of simulated time
``stream``  rows written to Parquet files in ``path`` every ``row_group`` rows; only
            the unwritten rows stay in memory; reading the table returns both
==========  ========================================================================

and, for tables with a per-signal key (``signals``), ``every=k`` keeps every k-th
sample of each ``(source, signal)`` (the 1st, the (k+1)-th, ...) before the mode
applies.  See ``docs/architecture.md``, section "Traces and memory".
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

from . import validate
from .columns import ColumnStore
from .errors import ConfigurationError, ConfigurationTypeError, NetcosimError, TraceWriteError
from .recorder import DEFAULT_MEMORY, DEFAULT_ROW_GROUP, Recorder, _positive_int

if TYPE_CHECKING:  # pandas is imported on first use: a simulation does not need it
    import pandas as pd
class UnknownSignalError(NetcosimError, KeyError):
    """:meth:`Trace.signal` was asked for a source or a signal that was not logged; the
    message lists what was (a :class:`KeyError`, so ``except KeyError`` still catches it)."""

    def __str__(self) -> str:
        # KeyError quotes its argument like a key; this one is a sentence
        return str(self.args[0]) if self.args else ""


def _closest(name: str, names: Sequence[str]) -> list[str]:
    """Names of *names* that *name* probably meant: those ending in ``.name`` (``"y"`` ->
    ``"y.y"``), then close spellings."""
    import difflib
    tail = [n for n in names if n.rsplit(".", 1)[-1] == name]
    return tail + [n for n in difflib.get_close_matches(name, names, n=3) if n not in tail]


def _plot_signals(trace: Trace, columns: Sequence[tuple[str, str]] | None = None, **options):
    """``Trace.plot("signals")``: :func:`netcosim.plot.plot_signals` of the signals table."""
    from .plot import plot_signals
    df = trace.frame("signals")
    if columns is None:
        pairs = df[["source", "signal"]].astype(str).drop_duplicates()
        columns = list(zip(pairs["source"], pairs["signal"]))
        if not columns:
            raise ValueError("no logged signal: nothing to plot")
    return plot_signals(df, columns, **options)


class Trace:
    """All recorders of one simulation.

    ``clock`` (optional) returns the current simulated time in integer ticks; the
    ``window`` mode measures its window back from it when a table is read (without a
    clock: back from the latest row time).  :class:`~netcosim.Simulation` passes its own.

    Examples
    --------
    A simulation's trace (``sim.trace``) after 30 ms of a task that logs ``u = 2 t`` and runs
    2 ms every 10 ms; the schedule table keeps only its last 4 rows (times in seconds):

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def ctrl(ctx):
    ...     ctx.log("u", 2 * ctx.now)
    ...     yield ctx.execute(0.002)
    >>> sim.trace.configure("schedule", "ring", rows=4)
    >>> sim.run(until=0.030)
    >>> sim.trace.tables
    ['signals', 'schedule', 'jobs']
    >>> sim.trace.signal("cpu.ctrl", "u").round(6).tolist()
    [0.0, 0.02, 0.04]
    >>> sim.trace.jobs()[["release", "finish"]].round(6).values.tolist()
    [[0.0, 0.002], [0.01, 0.012], [0.02, 0.022]]
    >>> sim.trace.schedule()[["time", "state"]].values.tolist()
    [[0.012, 'idle'], [0.02, 'ready'], [0.02, 'running'], [0.022, 'idle']]
    """

    def __init__(self, clock: Callable[[], int] | None = None) -> None:
        self._tables: dict[str, Recorder] = {}
        self._clock = clock
        self._default: dict | None = None
        #: how each source's signals are sampled, as its producer describes it (a plant:
        #: ``"log_interval 1 ms"``, ``"default grid 1 ms until the first read or write, then
        #: read/write instants"``, ``"none"``); :meth:`signal` puts it in ``Series.attrs["grid"]``
        self.grids: dict[str, str] = {}
        #: what :meth:`plot` can draw: kind -> ``draw(trace, **options)``; the components add theirs
        #: with :meth:`add_plot` (the kernel ``"schedule"``, a network ``"network"``)
        self._plots: dict[str, Callable] = {"signals": _plot_signals}
        self.signal_rec = self.table("signals", ("time", "source", "signal", "value"),
                                     categorical=("source", "signal"), time_unit="s", key=("source", "signal"),
                                     dtypes=("float", None, None, "float"))

    def table(self, name: str, columns: Sequence[str], categorical: Iterable[str] = (),
              transform=None, *, time: str | None = "time", time_unit: str = "ticks",
              key: Sequence[str] = (), dtypes: Sequence[str | None] | None = None,
              keeps_categories: bool = False, identity: Sequence[str] = (),
              instant: Callable[[tuple], Any] | None = None) -> Recorder:
        """Create (or return the existing) recorder called *name*.

        ``columns`` are the stored columns; ``transform(df) -> df`` (optional) derives
        the reported frame from the stored one (e.g. ticks to seconds).  ``time`` is the
        stored column the ``window`` mode measures, in ``time_unit`` (``"ticks"`` or
        ``"s"``); ``key`` the columns naming one signal (for ``every``).  A table created
        after :meth:`configure_all` starts in that configuration.  ``dtypes`` (optional, one
        per column: None, ``"int"``, ``"float"`` or ``"bool"``) promises the producers'
        value types, which spares the columnar store checking them (see
        :class:`~netcosim.columns.ColumnStore`).  ``keeps_categories=True`` promises that
        ``transform`` leaves the values of the categorical columns alone (it may drop rows):
        a table with rows on disk then hands them to it as pandas categoricals rather than
        a string per row, which is what reading a long table back costs most (a table
        without a transform always does).  ``identity`` names categorical columns that hold
        objects coded by identity (the kernel's task objects) and that ``transform`` also
        accepts as a pandas ``Categorical`` of those objects: a table read back column by
        column hands them so (categories in order of appearance) instead of an object per
        row.  ``instant(row) -> key`` (optional): in the modes other than ``keep``, one row per
        key and instant, the latest replacing the earlier (:attr:`Recorder.instant
        <netcosim.recorder.Recorder.instant>`).
        """
        rec = self._tables.get(name)
        if rec is None:
            rec = self._tables[name] = Recorder(name, columns, categorical, transform, time=time,
                                                time_unit=time_unit, key=key, clock=self._clock, dtypes=dtypes,
                                                keeps_categories=keeps_categories, identity=identity,
                                                instant=instant)
            if self._default is not None:
                self._apply_default(rec)
        elif rec.columns != tuple(columns):
            raise ValueError(f"table {name!r} already exists with columns {rec.columns}, "
                             f"not {tuple(columns)}")
        return rec

    @property
    def tables(self) -> list[str]:
        """Names of the tables recorded so far, in creation order."""
        return list(self._tables)

    def recorder(self, name: str) -> Recorder:
        """The :class:`Recorder` of table *name* (its ``rows`` is what producers append to);
        :class:`~netcosim.errors.ConfigurationError` naming the tables when there is none."""
        return self._rec(name)

    def _rec(self, name) -> Recorder:
        if not isinstance(name, str):
            raise ConfigurationTypeError(f"trace table name must be a string, got {name!r}")
        try:
            return self._tables[name]
        except KeyError:
            raise ConfigurationError(f"no trace table {name!r}; have {self.tables} (network tables "
                                     f"exist once a network is created)") from None

    # Memory bounds ---------------------------------------------------------------
    def configure(self, name: str, mode: str = "keep", *, rows: int | None = None,
                  seconds: float | None = None, every: int = 1, path: str | os.PathLike | None = None,
                  row_group: int = DEFAULT_ROW_GROUP, overwrite: bool = False,
                  memory: int | None = DEFAULT_MEMORY) -> None:
        """Choose how table *name* stores its rows; callable at any time, also mid-run.

        mode:
            ``"keep"`` every row (default); ``"off"`` none; ``"ring"`` the last
            ``rows`` rows (positive integer); ``"window"`` the rows whose time lies
            within the last ``seconds`` (positive, >= 1e-12 s) of simulated time,
            i.e. ``time >= now - seconds`` when the table is read (the jobs table
            measures ``release``); ``"stream"`` rows are written as Parquet files
            ``path/part-000000.parquet, ...`` of ``row_group`` rows each (the reported
            columns, times in seconds, categories as strings), so at most
            ``row_group`` rows stay in memory; reading the table returns the written
            rows followed by those in memory.  ``overwrite=True`` deletes part files
            an earlier run left in ``path``; otherwise they are an error.
        every:
            Decimation for per-signal tables (``signals``): keep the 1st, (k+1)-th,
            (2k+1)-th, ... sample of each ``(source, signal)``; applied before the mode.
        memory:
            ``keep`` mode's memory budget, in bytes of encoded rows (default
            :data:`DEFAULT_MEMORY`, 4 MiB per table): beyond it the older rows move, in
            their columnar chunks, to an anonymous temporary file (in ``TMPDIR``, deleted
            when the table is cleared, reconfigured or the process ends) and are read
            back from it, the same values, when the table is read.  ``None``: no limit,
            every row in memory.  Ignored by the other modes.

        Rows held in memory carry over to the new mode (within its bounds); rows an
        earlier stream wrote stay in its files but are no longer part of the table.
        Current-state rows from providers (unfinished jobs) are added when the table is
        read in every mode but ``off`` (in ``window`` mode only if inside the window).
        """
        self._rec(name).configure(mode, rows=rows, seconds=seconds, every=every, path=path,
                                  row_group=row_group, overwrite=overwrite, memory=memory)

    def configure_all(self, mode: str = "keep", *, rows: int | None = None, seconds: float | None = None,
                      path: str | os.PathLike | None = None, row_group: int = DEFAULT_ROW_GROUP,
                      overwrite: bool = False, memory: int | None = DEFAULT_MEMORY) -> None:
        """Configure every table, and every table created later, like :meth:`configure`
        (``seconds``: the window width in s; ``rows``: the ring's size in rows; ``row_group``:
        rows per Parquet file in ``stream`` mode; ``overwrite``: delete part files an earlier
        run left; ``memory``: ``keep`` mode's budget in bytes per table, None: no limit).

        In ``stream`` mode each table streams into its own directory ``path/<table>``.
        Tables that cannot honour the mode (``window`` on a table without a time
        column) raise before any table is changed.
        """
        options = dict(rows=rows, seconds=seconds, path=path, row_group=row_group, overwrite=overwrite,
                       memory=memory)
        # validate everything first, so that a bad value changes no table
        if mode == "stream":
            if path is None:
                raise ConfigurationError("configure_all: mode='stream' needs path=..., got None")
            validate.path(path, "configure_all: path", kind="a directory path")
            if Path(path).exists() and not Path(path).is_dir():
                raise ConfigurationError(f"configure_all: stream path {os.fspath(path)!r} exists and is not "
                                         f"a directory")
            _positive_int(row_group, "configure_all: row_group")
        else:
            Recorder("configure_all", ("time",)).configure(mode, rows=rows, seconds=seconds, path=path,
                                                            row_group=row_group, memory=memory)
        if mode == "window":
            for rec in self._tables.values():
                if rec.time_index is None:
                    raise ConfigurationError(f"configure_all: table {rec.name!r} has no time column, "
                                             f"so mode='window' cannot apply")
        self._default = dict(options, mode=mode)
        for rec in self._tables.values():
            self._apply_default(rec)

    def _apply_default(self, rec: Recorder) -> None:
        assert self._default is not None
        d = dict(self._default)
        mode = d.pop("mode")
        if mode == "stream":
            d["path"] = Path(d["path"]) / rec.name
        else:
            d["path"] = None
        if mode != "ring":
            d["rows"] = None
        if mode != "window":
            d["seconds"] = None
        rec.configure(mode, **d)

    def clear(self, name: str | None = None) -> None:
        """Drop the rows recorded so far in table *name* (default: every table).

        Safe at any instant of a run: later rows keep appending in the same mode.
        """
        if name is None:
            for rec in self._tables.values():
                rec.clear()
        else:
            self._rec(name).clear()

    def maintain(self, more: Callable[[], bool] | None = None) -> bool:
        """Encode the rows appended to ``keep``-mode tables into their columnar chunks
        (:meth:`ColumnStore.maintain <netcosim.columns.ColumnStore.maintain>`); the
        simulation calls it every :data:`~netcosim.sim.MAINTAIN_EVERY` events and at
        the end of a run.  Reading is the same before and after.

        ``more()``, when given, is asked between two chunks and stops the work when it
        returns False (the real-time clock's budget: one chunk of 256 rows takes some
        tens of microseconds); returns True when everything was encoded."""
        for rec in self._tables.values():
            buf = rec._buf
            if type(buf) is ColumnStore and not buf.maintain(more):
                return False
        return True

    def flush(self) -> None:
        """Write the in-memory rows of every streamed table to Parquet now."""
        for rec in self._tables.values():
            if rec._stream is not None:
                rec._stream.flush()

    def mode(self, name: str) -> str:
        """The storage mode of table *name*."""
        return self._rec(name).mode

    # Reading -----------------------------------------------------------------------
    def frame(self, name: str) -> pd.DataFrame:
        """Table *name* as a DataFrame (times in seconds); :class:`KeyError` naming the tables when there is none."""
        try:
            rec = self._tables[name]
        except (KeyError, TypeError):
            raise KeyError(f"no trace table {name!r}; have {self.tables}") from None
        return rec.frame()

    # Convenience accessors -------------------------------------------------
    def signals(self, wide: bool = False) -> pd.DataFrame:
        """Logged signals; ``wide=True`` pivots to one column per ``source.signal``.

        ``attrs["grids"]`` holds :attr:`grids` (how each source is sampled)."""
        df = self.frame("signals")
        if wide:
            df = df.assign(column=df["source"].astype(str) + "." + df["signal"].astype(str))
            df = df.pivot_table(index="time", columns="column", values="value", aggfunc="last")
        df.attrs["grids"] = dict(self.grids)
        return df

    def signal(self, source: str, signal: str) -> pd.Series:
        """One logged signal as a Series indexed by time (s), named ``"source.signal"``.

        ``attrs["grid"]`` says how the source is sampled (``"source: "`` and its entry in
        :attr:`grids`; absent when its producer did not say).  A source or signal that was not logged raises
        :class:`UnknownSignalError` (a ``KeyError``) listing the signals of the source,
        or the sources, that were."""
        import pandas as pd
        df = self.frame("signals")
        src = df["source"].astype(str).to_numpy()
        sel = df[(src == source) & (df["signal"].astype(str).to_numpy() == signal)]
        if sel.empty:
            sources = sorted(set(src.tolist()))
            if source not in sources:
                hint = _closest(str(source), sources)
                raise UnknownSignalError(
                    f"no source {source!r} in the signals table; "
                    + (f"sources are {sources}" if sources else "nothing was logged")
                    + (f" (did you mean {hint[0]!r}?)" if hint else "")
                    + ("" if source not in self.grids else f"; {source!r} is logged: {self.grids[source]}"))
            names = sorted(set(df.loc[src == source, "signal"].astype(str).tolist()))
            hint = _closest(str(signal), names)
            raise UnknownSignalError(f"no signal {signal!r} logged by {source!r}; its signals are {names}"
                                     + (f" (did you mean {hint[0]!r}?)" if hint else ""))
        out = pd.Series(sel["value"].to_numpy(), index=sel["time"].to_numpy(), name=f"{source}.{signal}")
        if source in self.grids:
            out.attrs["grid"] = f"{source}: {self.grids[source]}"
        return out

    def schedule(self) -> pd.DataFrame:
        """The ``schedule`` table: one row per state change of a kernel task (``time`` in s,
        ``node``, ``task``, ``state``)."""
        return self.frame("schedule")

    def jobs(self) -> pd.DataFrame:
        """The ``jobs`` table: one row per job, with ``release``, ``deadline``, ``start``,
        ``finish``, ``execution_time`` and the derived latencies in s, and its outcome flags."""
        return self.frame("jobs")

    def to_pandas(self, name: str | None = None) -> pd.DataFrame | dict[str, pd.DataFrame]:
        """Table *name* as a DataFrame, or (``name=None``) a dict of every table by name, in
        creation order (:attr:`tables`; empty tables included).

        The same frames as :meth:`frame`: times in seconds (float) under ``time`` (the jobs
        table: ``release``, ``deadline``, ``start``, ``finish`` and the derived latencies, also
        in s), names as pandas categoricals.  ``signals`` carries ``attrs["grids"]`` as
        :meth:`signals` does.  An unknown *name* raises :class:`KeyError` naming the tables.
        """
        if name is None:
            return {n: self.to_pandas(n) for n in self.tables}
        return self.signals() if name == "signals" and name in self._tables else self.frame(name)

    def add_plot(self, kind: str, draw: Callable) -> None:
        """Let :meth:`plot` draw *kind* with ``draw(trace, **options)`` (returning what it
        draws on); a component registers the plots of its tables, as it registers the tables."""
        self._plots[kind] = draw

    def plot(self, kind: str = "schedule", **options):
        """Draw one of the recorded tables with matplotlib; returns the :class:`~matplotlib.axes.Axes`.

        ``kind="schedule"``: the kernel's schedule, one TrueTime staircase per task
        (:func:`netcosim.plot.plot_schedule`): the row of task *i* (top first) sits at height
        *i* and rises by 0.5 while the task runs, 0.25 while it is ready (preempted or waiting
        for the CPU), 0.125 while blocked, 0 while idle.  Options ``tasks`` (row order, top
        first; ``"node.task"`` labels, or task names with ``node=``), ``node``, ``t_range=(t0, t1)`` (s,
        ``None`` for an open end), ``ax``, ``path`` (save a PNG), ``title``.

        ``kind="network"``: each node's network state, one staircase per node
        (:func:`netcosim.network.plot.plot_network_schedule`; idle 0, receiving 0.2, waiting
        0.4, sending 0.7 above the row), with markers for the lost frames and the
        retransmissions of the ``frames`` table (``frames=None`` leaves them out).  Options
        ``network`` (needed if there are several), ``nodes``, ``t_range`` (s), ``ax``,
        ``path``, ``title``.

        ``kind="signals"``: logged signals against time in seconds, one line each
        (:func:`netcosim.plot.plot_signals`); ``columns`` lists the ``(source, signal)``
        pairs (default: every logged signal, in order of first appearance); options
        ``ax``, ``path``, ``title``, ``drawstyle`` (``"steps-post"`` for held values).

        The x axis is simulated time in seconds.  A kind nothing registered raises
        :class:`~netcosim.errors.ConfigurationError` naming the kinds there are.
        """
        draw = self._plots.get(kind) if isinstance(kind, str) else None
        if draw is None:
            raise ConfigurationError(f"no plot kind {kind!r}; have {sorted(self._plots)} (the network plot "
                                     f"exists once a network is created)")
        return draw(self, **options)

    def view(self, path: str | os.PathLike | None = "view.html", **options) -> Path:
        """Write the run's interactive timeline as one self-contained HTML file (opens
        offline from disk; needs ``pip install netcosim[view]``): tasks in TrueTime's
        encoding, each network's frames and busy medium, signals, marks; linked time axes
        in seconds.  Options: ``signals`` (``"source.signal"`` names; default the first 8),
        ``t_range=(t0, t1)`` (s, the initial window), ``title``, ``width`` (px) and the
        level of detail ``max_glyphs``, ``max_points``, ``bins``
        (:func:`netcosim.view.bokeh_timeline.build_layout`).  Returns the path."""
        from .view import view
        return view(self, path, **options)

    def to_chrome_trace(self, path: str | os.PathLike) -> Path:
        """Write the run as Chrome/Perfetto trace-event JSON (one track per task, per
        network sender and per signal; times in microseconds; mapping in docs/viewer.md),
        to open in https://ui.perfetto.dev or ``chrome://tracing``.  Returns the path."""
        from .view import to_chrome_trace
        return to_chrome_trace(self, path)

    def to_parquet(self, directory: str | os.PathLike, prefix: str = "") -> list[Path]:
        """Write every non-empty table to ``directory/prefix<name>.parquet``.

        A directory or file that cannot be created or written raises
        :class:`~netcosim.errors.TraceWriteError` (an ``OSError``) naming the path and the
        reason.
        """
        out = Path(directory)
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise TraceWriteError(f"to_parquet: cannot create directory {str(out)!r}: "
                                  f"{exc.strerror or exc}") from exc
        written = []
        for name, rec in self._tables.items():
            if len(rec) == 0 and not rec.providers:
                continue
            path = out / f"{prefix}{name}.parquet"
            frame = rec.frame()
            try:
                frame.to_parquet(path, index=False)
            except OSError as exc:
                raise TraceWriteError(f"to_parquet: cannot write trace table {name!r} to {str(path)!r}: "
                                      f"{getattr(exc, 'strerror', None) or exc}") from exc
            written.append(path)
        return written
