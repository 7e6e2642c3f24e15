"""One run of a scenario, wherever it executes: call, sort the result, catch the failure.

:func:`run_one` is what every executor calls in its worker (the serial executor in the
calling process): it calls ``fn(params, seed)``, splits the returned dict into metrics
(scalars) and tables (DataFrames), turns an exception or a malformed result into status
``"error"`` with the message and traceback, measures the wall time, and finally runs
``gc.collect()``: a finished simulation is a web of reference cycles that only the
cyclic collector frees, so without it a worker's memory grows with every run
(``benchmarks/sweep_memory.py``).
"""

from __future__ import annotations

import gc
import math
import re
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .grid import RESERVED

__all__ = ["Outcome", "run_one", "split_result", "TABLE_NAME"]

#: A table name is used as a directory name: letters, digits, ``_``, ``-``, ``.`` (not first).
TABLE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")


@dataclass
class Outcome:
    """What one run produced: ``status`` (``"ok"``, ``"error"`` or ``"timeout"``), ``metrics``
    (name -> scalar), ``tables`` (name -> DataFrame), ``error`` (one-line message or None),
    ``traceback`` (text or None) and ``wall_time`` (s, the call alone)."""

    status: str
    metrics: dict[str, Any] = field(default_factory=dict)
    tables: dict[str, Any] = field(default_factory=dict)
    error: str | None = None
    traceback: str | None = None
    wall_time: float = math.nan


def split_result(result: Any, params: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(metrics, tables)`` of a scenario's return value *result* (a dict of metric name ->
    int, float, bool, str or None, and table name -> DataFrame); raises ``TypeError`` /
    ``ValueError`` naming the key and the type of anything that is neither, or a metric
    or column named as one of the case's *params* (parameter name -> value)."""
    import pandas as pd

    if not isinstance(result, dict):
        raise TypeError(f"scenario returned {type(result).__name__} {_short(result)}, not a dict of metrics")
    metrics: dict[str, Any] = {}
    tables: dict[str, Any] = {}
    for key, value in result.items():
        if not isinstance(key, str) or not key:
            raise TypeError(f"scenario returned key {key!r}: metric and table names must be non-empty strings")
        if isinstance(value, pd.DataFrame):
            if not TABLE_NAME.match(key):
                raise ValueError(f"scenario returned table {key!r}: a table name may hold letters, digits, "
                                 f"'_', '-' and '.' only")
            clash = [c for c in value.columns if c in params or c in ("seed_index", "seed")]
            if clash:
                raise ValueError(f"scenario returned table {key!r} with column {clash[0]!r}, which the sweep "
                                 f"adds itself (parameters, seed_index, seed)")
            tables[key] = value
            continue
        if key in RESERVED or key in params:
            raise ValueError(f"scenario returned metric {key!r}, which is the name of a "
                             f"{'parameter' if key in params else 'column the sweep adds'}")
        if isinstance(value, np.generic):
            value = value.item()
        if value is not None and not isinstance(value, (bool, int, float, str)):
            raise TypeError(f"scenario returned {type(value).__name__} {_short(value)} for {key!r}: a metric "
                            f"must be an int, float, bool, str or None, a table a pandas DataFrame")
        metrics[key] = value
    return metrics, tables


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def run_one(fn: Callable, params: dict[str, Any], seed: int) -> Outcome:
    """Run ``fn(params, seed)`` once and return its :class:`Outcome` (never raises except
    for ``KeyboardInterrupt``); collects garbage afterwards."""
    t0 = time.perf_counter()
    try:
        result = fn(dict(params), seed)
        metrics, tables = split_result(result, params)
        out = Outcome("ok", metrics, tables, wall_time=time.perf_counter() - t0)
        del result
    except (Exception, SystemExit) as exc:
        wall = time.perf_counter() - t0
        message = f"{type(exc).__name__}: {exc}".strip()
        out = Outcome("error", error=message, traceback=traceback.format_exc(), wall_time=wall)
    gc.collect()
    return out
