"""Columnar recorders that turn a run into tidy pandas DataFrames.

A :class:`Trace` holds named :class:`Recorder` tables.  Appending a row is a list
append of a tuple (cheap on the hot path); the DataFrame is built only when asked.
Every table reports times in seconds (float), under the column ``time``; hot-path
tables may store integer ticks and convert when the frame is built (``transform``).

Standard tables:

``signals``   ``time, source, signal, value``  -- plant logs and ``ctx.log``
``schedule``  ``time, node, task, state``       -- every task state change
``jobs``      one row per finished (or killed) job with its statistics

Other components (networks, for instance) register their own tables with
:meth:`Trace.table`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable, Sequence

import pandas as pd

from .timebase import TICKS_PER_SECOND

#: Task states in the schedule trace, with TrueTime's plotting level offsets.
TASK_STATES = {"idle": 0.0, "blocked": 0.125, "ready": 0.25, "running": 0.5}

#: Columns of the jobs table as reported (times in seconds; NaN where not applicable).
JOB_COLUMNS = (
    "node", "task", "job", "release", "deadline", "start", "finish",
    "response_time", "release_latency", "start_latency", "execution_time",
    "lateness", "deadline_miss", "budget_overrun", "killed",
)
#: Columns of the jobs table as stored by the kernel (times in integer ticks, None if unset).
JOB_RAW = ("node", "task", "job", "release", "deadline", "start", "finish", "execution_time",
           "deadline_miss", "budget_overrun", "killed")


def _ticks_to_seconds(df: pd.DataFrame, cols) -> pd.DataFrame:
    for c in cols:
        df[c] = pd.to_numeric(df[c], errors="coerce").astype(float) / TICKS_PER_SECOND
    return df


def _schedule_frame(df: pd.DataFrame) -> pd.DataFrame:
    return _ticks_to_seconds(df, ("time",))


def _jobs_frame(df: pd.DataFrame) -> pd.DataFrame:
    df = _ticks_to_seconds(df, ("release", "deadline", "start", "finish", "execution_time"))
    df["response_time"] = df["finish"] - df["release"]
    df["release_latency"] = 0.0
    df["start_latency"] = df["start"] - df["release"]
    df["lateness"] = df["finish"] - df["deadline"]
    for c in ("deadline_miss", "budget_overrun", "killed"):
        df[c] = df[c].astype(bool)
    df["job"] = df["job"].astype(int)
    return df[list(JOB_COLUMNS)]


class Recorder:
    """One table: a fixed tuple of column names and a list of row tuples."""

    __slots__ = ("name", "columns", "rows", "categorical", "providers", "transform")

    def __init__(self, name: str, columns: Sequence[str], categorical: Iterable[str] = (),
                 transform=None):
        self.name = name
        self.columns = tuple(columns)
        self.rows: list[tuple] = []
        self.categorical = tuple(c for c in categorical if c in self.columns)
        #: callables returning rows that describe the current state (e.g. unfinished
        #: jobs); evaluated each time the table is read, never stored.
        self.providers: list = []
        #: optional function turning the stored frame into the reported one
        self.transform = transform

    def append(self, row: tuple) -> None:
        self.rows.append(row)

    def __len__(self) -> int:
        return len(self.rows)

    def frame(self) -> pd.DataFrame:
        """The table as a DataFrame (a fresh copy every call)."""
        rows = self.rows
        if self.providers:
            rows = rows + [r for p in self.providers for r in p()]
        df = pd.DataFrame.from_records(rows, columns=list(self.columns))
        if self.transform is not None:
            df = self.transform(df)
        for c in self.categorical:
            df[c] = df[c].astype("category")
        return df


class Trace:
    """All recorders of one simulation."""

    def __init__(self) -> None:
        self._tables: dict[str, Recorder] = {}
        self.signal_rec = self.table("signals", ("time", "source", "signal", "value"),
                                     categorical=("source", "signal"))
        # stored in ticks, reported in seconds
        self.schedule_rec = self.table("schedule", ("time", "node", "task", "state"),
                                       categorical=("node", "task", "state"), transform=_schedule_frame)
        self.job_rec = self.table("jobs", JOB_RAW, categorical=("node", "task"), transform=_jobs_frame)

    def table(self, name: str, columns: Sequence[str], categorical: Iterable[str] = (),
              transform=None) -> Recorder:
        """Create (or return the existing) recorder called *name*.

        ``columns`` are the stored columns; ``transform(df) -> df`` (optional) derives
        the reported frame from the stored one (e.g. ticks to seconds).
        """
        rec = self._tables.get(name)
        if rec is None:
            rec = self._tables[name] = Recorder(name, columns, categorical, transform)
        elif rec.columns != tuple(columns):
            raise ValueError(f"table {name!r} already exists with columns {rec.columns}, "
                             f"not {tuple(columns)}")
        return rec

    @property
    def tables(self) -> list[str]:
        return list(self._tables)

    def frame(self, name: str) -> pd.DataFrame:
        try:
            return self._tables[name].frame()
        except KeyError:
            raise KeyError(f"no trace table {name!r}; have {self.tables}") from None

    # Convenience accessors -------------------------------------------------
    def signals(self, wide: bool = False) -> pd.DataFrame:
        """Logged signals; ``wide=True`` pivots to one column per ``source.signal``."""
        df = self.frame("signals")
        if not wide:
            return df
        df = df.assign(column=df["source"].astype(str) + "." + df["signal"].astype(str))
        return df.pivot_table(index="time", columns="column", values="value", aggfunc="last")

    def signal(self, source: str, signal: str) -> pd.Series:
        """One logged signal as a Series indexed by time."""
        df = self.frame("signals")
        sel = df[(df["source"] == source) & (df["signal"] == signal)]
        if sel.empty:
            raise KeyError(f"no signal {signal!r} logged by {source!r}")
        return pd.Series(sel["value"].to_numpy(), index=sel["time"].to_numpy(), name=f"{source}.{signal}")

    def schedule(self) -> pd.DataFrame:
        return self.frame("schedule")

    def jobs(self) -> pd.DataFrame:
        return self.frame("jobs")

    def to_parquet(self, directory: str | os.PathLike, prefix: str = "") -> list[Path]:
        """Write every non-empty table to ``directory/prefix<name>.parquet``."""
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        for name, rec in self._tables.items():
            if len(rec) == 0 and not rec.providers:
                continue
            path = out / f"{prefix}{name}.parquet"
            rec.frame().to_parquet(path, index=False)
            written.append(path)
        return written
