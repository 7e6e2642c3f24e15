"""The result of a sweep: the run table, the per-run tables, the counts."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["SweepResult", "run_frame"]


def _column(values: list[Any]):
    """*values* as one typed column: ints (``Int64`` if some are None), bools (``boolean``
    if some are None), ints and floats as ``float64``; None for anything else (left as
    pandas infers it)."""
    import pandas as pd

    present = [v for v in values if v is not None]
    missing = len(present) < len(values)
    dtype = None
    if present and all(type(v) is bool for v in present):
        dtype = "boolean" if missing else "bool"
    elif present and all(type(v) is int for v in present):
        dtype = "Int64" if missing else "int64"
    elif present and all(type(v) in (int, float) for v in present):
        dtype = "float64"
    if dtype is None:
        return None
    try:
        return pd.array([math.nan if v is None and dtype == "float64" else v for v in values], dtype=dtype)
    except (OverflowError, TypeError, ValueError):
        return None


def run_frame(records: list[dict[str, Any]], params: list[str]):
    """The tidy run table of *records* (in the order given): parameter columns (*params*, the
    parameter names, in order),
    ``seed_index``, ``seed``, the metrics (in order of first appearance), ``status``,
    ``error``, ``traceback``, ``wall_time``.

    Each column has one type whatever runs failed: a metric that failed runs lack (or
    a parameter with None in some cases) keeps its int or bool type as pandas'
    nullable ``Int64`` / ``boolean`` rather than turning into floats."""
    import pandas as pd

    head = [*params, "seed_index", "seed"]
    tail = ["status", "error", "traceback", "wall_time"]
    metrics: dict[str, None] = {}
    for r in records:
        for k in r:
            if k not in metrics and k not in head and k not in tail:
                metrics[k] = None
    columns = head + list(metrics) + tail
    if not records:
        return pd.DataFrame(columns=columns)
    frame = pd.DataFrame.from_records(records, columns=columns)
    for col in [*params, *metrics]:
        typed = _column([r.get(col) for r in records])
        if typed is not None:
            frame[col] = typed
    return frame


class SweepResult:
    """What :func:`~netcosim.sweep.run_sweep` returns (and :func:`~netcosim.sweep.load_sweep` reads back).

    ``runs``: the tidy run table, one row per (case, seed) in grid order then seed index
    (see :func:`run_frame`; ``wall_time`` in s); ``summary``: counts ``total``, ``ok``,
    ``error``, ``timeout``, ``skipped`` (runs found finished on disk and not rerun) and
    ``missing`` (runs not finished, for a sweep read back before its end) and ``nan``
    (finished runs that returned NaN for a metric, kept as returned and named by a
    :class:`~netcosim.errors.NaNMetricWarning`); ``meta``: the
    sweep's metadata; ``path``: its directory (None for a sweep kept in memory);
    ``repaired``: the damaged files (:class:`~netcosim.sweep.store.Damage`) a sweep
    found in its directory and whose runs it ran again (empty if none).
    ``params``: the parameter names (the run table's first columns); ``tables``: the
    per-run tables of a sweep kept in memory, ``{(case, seed_index): {name: DataFrame}}``;
    ``store``: the sweep's on-disk store, which holds them otherwise; ``keys``: the
    ``(case, seed_index)`` of the runs in run-table order (the order of :meth:`table`).

    Examples
    --------
    100 messages over a link that loses frames with probability p, two values of p, two
    seeds each; each run returns the count received and a table of the arrival times:

    >>> import pandas as pd
    >>> from netcosim.sweep import run_sweep
    >>> from netcosim.sweep.demo import lossy_link_run   # 100 messages over a lossy link
    >>> def lossy_link(params, seed):
    ...     sim, arrivals = lossy_link_run(params["loss"], seed)
    ...     return {"received": len(arrivals), "arrivals": pd.DataFrame({"time": arrivals})}
    >>> res = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial", quiet=True)
    >>> res
    SweepResult(4 runs: 4 ok, 0 error, 0 timeout, 0 skipped)
    >>> res.params, list(res.runs.columns[:4]), res.runs["received"].tolist()
    (['loss'], ['loss', 'seed_index', 'seed', 'received'], [88, 87, 53, 54])
    >>> arrivals = res.table("arrivals")             # every run's table, its parameters prepended
    >>> res.table_names, len(arrivals), list(arrivals.columns)
    (['arrivals'], 282, ['loss', 'seed_index', 'seed', 'time'])
    """

    def __init__(self, runs, params: list[str], meta: dict[str, Any], summary: dict[str, int],
                 tables: dict[tuple[int, int], dict[str, Any]] | None = None, store: Any = None,
                 keys: list[tuple[int, int]] | None = None):
        self.runs = runs
        self.params = list(params)
        self.meta = meta
        self.summary = summary
        self._tables = tables or {}
        self._store = store
        self._keys = keys or []
        self.path = None if store is None else store.root
        self.repaired: list[Any] = []

    def to_pandas(self):
        """The run table (:attr:`runs`)."""
        return self.runs

    @property
    def table_names(self) -> list[str]:
        """Names of the per-run tables some run returned."""
        if self._store is not None:
            return self._store.table_names()
        return sorted({n for t in self._tables.values() for n in t})

    def table(self, name: str):
        """Long DataFrame of the tables the runs returned under *name*, each with the
        parameter columns, ``seed_index`` and ``seed`` prepended, in run order.

        Raises ``KeyError`` naming *name* (and the available names) if no run returned it.
        """
        import pandas as pd

        if name not in self.table_names:
            raise KeyError(f"no run returned a table {name!r}; tables: {self.table_names}")
        frames = []
        for key in self._keys:
            frame = (self._store.read_table(name, *key) if self._store is not None
                     else self._tables.get(key, {}).get(name))
            if frame is not None:
                frames.append(frame)
        return pd.concat(frames, ignore_index=True)

    def plot(self, y: str, x: str | None = None, hue: str | None = None, **kw):
        """``plot_sweep(self.runs, x, y, hue)``: median and band of *y* across seeds
        (:func:`netcosim.sweep.aggregate.plot_sweep`); *x* defaults to the first parameter;
        runs flagged by a ``diverged`` column, if the scenario returns one, are counted
        apart (``diverged=`` overrides)."""
        from .aggregate import plot_sweep
        kw.setdefault("diverged", "diverged" if "diverged" in self.runs.columns else None)
        return plot_sweep(self.runs, x=x or self.params[0], y=y, hue=hue, **kw)

    def view(self, path=None, **options):
        """Write the sweep's HTML view (cost versus parameter with its seed band; a click on
        a run opens its timeline when the scenario kept its trace, see
        :func:`netcosim.view.trace_tables`); needs a sweep stored on disk (``out=``).
        Returns the path (:func:`netcosim.view.sweep_view.write_sweep_view`)."""
        from ..errors import ConfigurationError
        if self.path is None:
            raise ConfigurationError("this sweep was kept in memory: run it with out=DIR to view it")
        from ..view import view_sweep
        return view_sweep(self.path, path, **options)

    def __repr__(self) -> str:
        s = self.summary
        where = f", path={str(self.path)!r}" if self.path is not None else ""
        nan = f" ({s['nan']} with a NaN metric)" if s.get("nan") else ""
        return (f"SweepResult({s['total']} runs: {s['ok']} ok{nan}, {s['error']} error, {s['timeout']} timeout, "
                f"{s['skipped']} skipped{where})")
