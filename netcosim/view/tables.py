"""The trace tables a view reads, from whatever holds them: a :class:`~netcosim.trace.Trace`,
a :class:`~netcosim.Simulation`, a dict of DataFrames, or a directory of
``Trace.to_parquet`` files (``prefix`` selects one run's files among several)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ..errors import ConfigurationError, ConfigurationTypeError

__all__ = ["TABLES", "Tables", "read_tables", "end_time"]

#: The tables a view draws (others are ignored).
TABLES = ("schedule", "jobs", "frames", "network_schedule", "signals", "hil")


class Tables(dict):
    """``{name: DataFrame}`` with ``end``: the simulated time (s) the run had reached when
    the tables were read (None when unknown, e.g. read from Parquet files)."""

    end: float | None = None


def end_time(tables: dict) -> float:
    """When the run ends (s): ``tables.end`` if known, else the latest time of its tables."""
    end = getattr(tables, "end", None)
    times = [float(df["time"].max()) for n, df in tables.items() if n != "jobs" and len(df) and "time" in df]
    latest = max(times) if times else 0.0
    return latest if end is None else max(end, latest)


def read_tables(source: Any, prefix: str = "") -> Tables:
    """``{name: DataFrame}`` of the tables of :data:`TABLES` that *source* holds (times in s).

    *source*: a Trace (anything with ``frame(name)`` and ``tables``), an object with a
    ``trace`` attribute (a Simulation), a dict of DataFrames, or a directory holding
    ``prefix + name + ".parquet"`` files.  Raises
    :class:`~netcosim.errors.ConfigurationError` naming a directory without any such file,
    :class:`~netcosim.errors.ConfigurationTypeError` naming anything else."""
    import pandas as pd
    if hasattr(source, "trace") and hasattr(source.trace, "frame"):
        source = source.trace
    if hasattr(source, "frame") and hasattr(source, "tables"):
        out = Tables((n, source.frame(n)) for n in TABLES if n in source.tables)
        clock = getattr(source, "_clock", None)
        if clock is not None:
            from ..timebase import to_seconds
            out.end = to_seconds(clock())
        return out
    if isinstance(source, dict):
        bad = [k for k, v in source.items() if not isinstance(v, pd.DataFrame)]
        if bad:
            raise ConfigurationTypeError(f"tables must be DataFrames; {bad} are not")
        out = Tables((n, source[n]) for n in TABLES if n in source)
        out.end = getattr(source, "end", None)
        return out
    if isinstance(source, (str, os.PathLike)):
        folder = Path(source)
        if not folder.is_dir():
            raise ConfigurationError(f"cannot read a trace from {os.fspath(source)!r}: not a directory")
        found = Tables((n, pd.read_parquet(folder / f"{prefix}{n}.parquet")) for n in TABLES
                       if (folder / f"{prefix}{n}.parquet").is_file())
        if not found:
            raise ConfigurationError(f"no trace table in {os.fspath(source)!r} (looked for "
                                     f"{[prefix + n + '.parquet' for n in TABLES]})")
        return found
    raise ConfigurationTypeError(f"cannot read trace tables from {type(source).__name__} {source!r:.60}: give a "
                                 f"Trace, a Simulation, a dict of DataFrames or a directory of Parquet files")
