"""Columnar recorders that turn a run into tidy pandas DataFrames.

A :class:`Trace` holds named :class:`Recorder` tables.  Appending a row is a list
append of a tuple (cheap on the hot path); the DataFrame is built only when asked.
Times are stored in seconds (float) in every table, under the column ``time``.

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

#: Task states in the schedule trace, with TrueTime's plotting level offsets.
TASK_STATES = {"idle": 0.0, "blocked": 0.125, "ready": 0.25, "running": 0.5}

JOB_COLUMNS = (
    "node", "task", "job", "release", "deadline", "start", "finish",
    "response_time", "release_latency", "start_latency", "execution_time",
    "lateness", "deadline_miss", "budget_overrun", "killed",
)


class Recorder:
    """One table: a fixed tuple of column names and a list of row tuples."""

    __slots__ = ("name", "columns", "rows", "categorical", "providers")

    def __init__(self, name: str, columns: Sequence[str], categorical: Iterable[str] = ()):
        self.name = name
        self.columns = tuple(columns)
        self.rows: list[tuple] = []
        self.categorical = tuple(c for c in categorical if c in self.columns)
        #: callables returning rows that describe the current state (e.g. unfinished
        #: jobs); evaluated each time the table is read, never stored.
        self.providers: list = []

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
        for c in self.categorical:
            df[c] = df[c].astype("category")
        return df


class Trace:
    """All recorders of one simulation."""

    def __init__(self) -> None:
        self._tables: dict[str, Recorder] = {}
        self.signal_rec = self.table("signals", ("time", "source", "signal", "value"),
                                     categorical=("source", "signal"))
        self.schedule_rec = self.table("schedule", ("time", "node", "task", "state"),
                                       categorical=("node", "task", "state"))
        self.job_rec = self.table("jobs", JOB_COLUMNS, categorical=("node", "task"))

    def table(self, name: str, columns: Sequence[str], categorical: Iterable[str] = ()) -> Recorder:
        """Create (or return the existing) recorder called *name*."""
        rec = self._tables.get(name)
        if rec is None:
            rec = self._tables[name] = Recorder(name, columns, categorical)
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
