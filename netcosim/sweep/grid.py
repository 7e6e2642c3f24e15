"""The cases of a sweep: a grid of named parameter values, checked and listed in order.

A grid is given as

* a dict of lists, ``{"loss": [0, 0.1], "strategy": ["a", "b"]}``: the Cartesian
  product, the last key varying fastest (``itertools.product`` order);
* a list of dicts, one per case, all with the same keys;
* a pandas DataFrame, one case per row, the columns as parameter names.

A parameter value is a plain scalar: ``int``, finite ``float``, ``bool``, ``str`` or
``None`` (NumPy scalars are converted to them), the values of one parameter all
numbers, all bools or all strings (``None`` goes with any), so that a case has one canonical text
form (its run seeds derive from it, see :mod:`netcosim.sweep.seeds`) and fits a Parquet
column.  Anything else raises, naming the parameter and the value.
"""

from __future__ import annotations

import itertools
import math
from typing import Any, Iterable

import numpy as np

from ..errors import ConfigurationError, ConfigurationTypeError

__all__ = ["cases", "param_value", "check_accepted", "RESERVED", "MAX_RUNS"]

#: The most runs (grid cases x seeds) one sweep may hold, 10**7: a larger sweep is refused
#: before anything is listed (its run table alone would not fit in memory, and listing
#: its runs would stall before the first one).
MAX_RUNS = 10**7

#: Column names of a sweep's run table that a parameter or a metric may not take.
RESERVED = ("seed_index", "seed", "status", "error", "traceback", "wall_time")


_KIND = {int: "number", float: "number", bool: "bool", str: "string"}


def param_value(value: Any, what: str) -> Any:
    """*value* as a plain Python scalar (int, finite float, bool, str or None), or raise
    :class:`~netcosim.errors.ConfigurationTypeError` / :class:`~netcosim.errors.ConfigurationError`
    naming *what* and the value."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ConfigurationError(f"{what} must be a finite number, got {value!r}")
        return value
    raise ConfigurationTypeError(f"{what} must be an int, float, bool, str or None, got {value!r} "
                                 f"({type(value).__name__})")


def _check_name(name: Any, what: str) -> str:
    if not isinstance(name, str) or not name:
        raise ConfigurationTypeError(f"{what}: a parameter name must be a non-empty string, got {name!r}")
    if name in RESERVED:
        raise ConfigurationError(f"{what}: parameter name {name!r} is reserved for a column of the run table "
                                 f"({', '.join(RESERVED)})")
    return name


def _check_size(n: int, what: str) -> None:
    if n > MAX_RUNS:
        raise ConfigurationError(f"{what} has {n} cases, more than a sweep may run (MAX_RUNS = {MAX_RUNS} runs)")


def cases(grid: Any) -> list[dict[str, Any]]:
    """The list of cases (dicts of parameter values, in order) that *grid* describes.

    Raises, naming the offending value: an empty grid, a parameter with no values, a
    value that is not a plain scalar, cases with different parameter names, a case
    given twice, more than :data:`MAX_RUNS` cases (checked before the product is listed).
    """
    import pandas as pd

    if isinstance(grid, pd.DataFrame):
        if grid.shape[1] == 0 or grid.shape[0] == 0:
            raise ConfigurationError(f"grid must have at least one case, got an empty DataFrame of shape {grid.shape}")
        names = [_check_name(c, "grid") for c in grid.columns]
        _check_size(grid.shape[0], f"grid (a DataFrame of {grid.shape[0]} rows)")
        raw = [dict(zip(names, row)) for row in grid.itertuples(index=False, name=None)]
    elif isinstance(grid, dict):
        if not grid:
            raise ConfigurationError(f"grid must name at least one parameter, got {grid!r}")
        names = [_check_name(k, "grid") for k in grid]
        values = []
        for k, v in grid.items():
            if isinstance(v, (str, bytes)) or not isinstance(v, Iterable):
                raise ConfigurationTypeError(f"grid[{k!r}] must be a list of values, got {v!r}")
            v = list(v)
            if not v:
                raise ConfigurationError(f"grid[{k!r}] must list at least one value, got {v!r}")
            values.append(v)
        _check_size(math.prod(len(v) for v in values),
                    "grid (the product of " + " x ".join(f"{len(v)} {k!r}" for k, v in zip(names, values)) + ")")
        raw = [dict(zip(names, combo)) for combo in itertools.product(*values)]
    elif isinstance(grid, (list, tuple)):
        if not grid:
            raise ConfigurationError(f"grid must have at least one case, got {grid!r}")
        if not all(isinstance(c, dict) for c in grid):
            bad = next(c for c in grid if not isinstance(c, dict))
            raise ConfigurationTypeError(f"grid as a list must hold dicts (one per case), got {bad!r}")
        _check_size(len(grid), f"grid (a list of {len(grid)} cases)")
        names = [_check_name(k, "grid") for k in grid[0]]
        for i, c in enumerate(grid):
            if set(c) != set(names):
                raise ConfigurationError(f"grid case {i} {c!r} has parameters {sorted(c)}, "
                                         f"the first case has {sorted(names)}")
        raw = [{k: c[k] for k in names} for c in grid]
    else:
        raise ConfigurationTypeError(f"grid must be a dict of lists, a list of dicts or a DataFrame, got {grid!r}")
    out = [{k: param_value(v, f"grid parameter {k!r}") for k, v in c.items()} for c in raw]
    for k in names:
        kinds: dict[str, Any] = {}
        for c in out:
            v = c[k]
            if v is not None:
                kinds.setdefault(_KIND[type(v)], v)
        if len(kinds) > 1:
            (k1, v1), (k2, v2) = list(kinds.items())[:2]
            raise ConfigurationTypeError(f"grid parameter {k!r} mixes a {k1} ({v1!r}) and a {k2} ({v2!r}): the "
                                         f"values of one parameter must be all numbers, all bools or all strings")
    seen: dict[tuple, int] = {}
    for i, c in enumerate(out):
        key = tuple((type(v).__name__, v) for v in c.values())
        if key in seen:
            raise ConfigurationError(f"grid case {c!r} is given twice (cases {seen[key]} and {i})")
        seen[key] = i
    return out


def check_accepted(names: Iterable[str], scenario: Any) -> None:
    """Refuse a grid parameter the scenario does not accept.

    The convention: a scenario declares the parameter names it reads as an attribute
    ``params`` (any collection of strings), e.g. ``loss_run.params = {"loss", "strategy"}``.
    A grid parameter outside it raises :class:`~netcosim.errors.ConfigurationError` naming
    the parameter, before any run.  A scenario without ``params`` is not checked (its
    function body cannot be inspected without running it).
    """
    declared = getattr(scenario, "params", None)
    if declared is None:
        return
    if isinstance(declared, str) or not isinstance(declared, Iterable):
        raise ConfigurationTypeError(f"scenario {getattr(scenario, '__name__', scenario)!r}: its 'params' attribute "
                                     f"must be a collection of parameter names, got {declared!r}")
    accepted = set(declared)
    unknown = [n for n in names if n not in accepted]
    if unknown:
        raise ConfigurationError(f"grid parameter {unknown[0]!r} is not accepted by scenario "
                                 f"{getattr(scenario, '__name__', scenario)!r} (it declares params "
                                 f"{sorted(accepted)})")
