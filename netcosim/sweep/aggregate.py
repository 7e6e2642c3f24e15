"""Aggregating a sweep's runs across seeds: medians and inter-quantile bands, with
diverged and failed runs counted apart, never averaged in.

The runs table (one row per run) has the parameter columns, ``seed_index``, ``seed``,
the metric columns, ``status`` (``"ok"``, ``"error"`` or ``"timeout"``), ``error``,
``traceback`` and ``wall_time``; a scenario that reports divergence adds a boolean
metric column (``diverged`` by default, see :func:`netcosim.metrics.diverged`).

Per group (one value of ``x``, and of ``hue`` if given) a run is

* *failed* if a ``status`` column exists and its status is not ``"ok"``;
* *diverged* if it did not fail and its ``diverged`` flag is true or its ``y`` is not
  finite (NaN, +-inf);
* *used* otherwise: the median and the quantiles are computed over the used runs only,
  so one blown-up run (J = 1e16) moves the median by one rank, not to 1e16.

Quantiles use linear interpolation between order statistics (NumPy's and pandas'
default, Hyndman and Fan's type 7).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["summarize", "plot_sweep", "SUMMARY_COLUMNS"]

#: Columns of :func:`summarize`'s result after the group columns.
SUMMARY_COLUMNS = ("n", "n_failed", "n_diverged", "n_used", "median", "q_low", "q_high")


def _column(df: pd.DataFrame, name: Any, what: str) -> str:
    if not isinstance(name, str):
        raise ConfigurationTypeError(f"{what} must be a column name (str), got {name!r}")
    if name not in df.columns:
        raise ConfigurationError(f"{what}={name!r} is not a column of the runs table; columns: {list(df.columns)}")
    return name


def _quantiles(q: Any) -> tuple[float, float]:
    if isinstance(q, (str, bytes)) or not isinstance(q, Sequence) or len(q) != 2:
        raise ConfigurationTypeError(f"quantiles must be a pair (low, high) of probabilities, got {q!r}")
    lo = validate.probability(q[0], "quantiles: low")
    hi = validate.probability(q[1], "quantiles: high")
    if lo > hi:
        raise ConfigurationError(f"quantiles must be (low, high) with low <= high, got {q!r}")
    return lo, hi


def _flags(df: pd.DataFrame, x: str, y: str, hue: str | None, diverged: str | None):
    """(group columns, failed mask, diverged mask, y as floats) after checking the input."""
    import pandas as pd

    if not isinstance(df, pd.DataFrame):
        raise ConfigurationTypeError(f"the runs must be a pandas DataFrame, got {type(df).__name__}")
    keys = [_column(df, x, "x")]
    _column(df, y, "y")
    if hue is not None:
        keys.append(_column(df, hue, "hue"))
        if hue == x:
            raise ConfigurationError(f"hue={hue!r} is the same column as x")
    values = pd.to_numeric(df[y], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(df[y].notna().to_numpy() & np.isnan(values))
    if bad.size:
        raise ConfigurationTypeError(f"y={y!r} must be numeric; row {int(bad[0])} holds {df[y].iloc[bad[0]]!r}")
    failed = (df["status"] != "ok").to_numpy() if "status" in df.columns else np.zeros(len(df), bool)
    flag = np.zeros(len(df), bool)
    if diverged is not None:
        if diverged not in df.columns:
            raise ConfigurationError(f"diverged={diverged!r} is not a column of the runs table (pass diverged=None "
                                     f"if the runs carry no divergence flag); columns: {list(df.columns)}")
        flag = df[diverged].fillna(False).astype(bool).to_numpy()
    div = ~failed & (flag | ~np.isfinite(values))
    return keys, failed, div, values


def summarize(df: pd.DataFrame, x: str, y: str, hue: str | None = None,
              quantiles: Sequence[float] = (0.25, 0.75), diverged: str | None = "diverged") -> pd.DataFrame:
    """Per ``(x, hue)`` group: the run counts and the median and quantiles of ``y``.

    ``df``: the runs table; ``x``, ``y``, ``hue``: column names (``hue=None``: group by
    ``x`` only); ``quantiles``: ``(low, high)`` probabilities of the band (default the
    quartiles); ``diverged``: the boolean column flagging diverged runs (None: no such
    column; non-finite ``y`` still counts as diverged).  Returns one row per group,
    sorted, with the group columns then :data:`SUMMARY_COLUMNS`: ``n`` runs,
    ``n_failed`` (status not ``"ok"``), ``n_diverged``, ``n_used`` and ``median``,
    ``q_low``, ``q_high`` of ``y`` over the used runs (NaN if none).

    Raises
    ------
    ConfigurationError
        ``x``, ``y``, ``hue`` or ``diverged`` is not a column of *df*, ``hue`` is ``x``, or
        ``quantiles`` are not probabilities with low <= high.
    ConfigurationTypeError
        *df* is not a DataFrame, a column name is not a str, ``y`` holds a value that is
        not a number, or ``quantiles`` is not a pair.

    Examples
    --------
    The messages received over a lossy link (100 sent), two seeds per loss probability:

    >>> from netcosim.sweep import run_sweep
    >>> from netcosim.sweep.demo import lossy_link   # 100 messages; frames lost with params["loss"]
    >>> res = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial", quiet=True)
    >>> print(summarize(res.runs, x="loss", y="received", diverged=None).to_string(index=False))
     loss  n  n_failed  n_diverged  n_used  median  q_low  q_high
      0.1  2         0           0       2    87.5  87.25   87.75
      0.5  2         0           0       2    53.5  53.25   53.75

    A diverged run (flagged, or a non-finite ``y``) and a failed one are counted, not
    used: the median of gain 2 is that of its one usable run, not moved by J = 1e16.

    >>> import pandas as pd
    >>> runs = pd.DataFrame({"gain": [1, 1, 1, 2, 2, 2], "J": [1.0, 2.0, 3.0, 4.0, 1e16, 5.0],
    ...                      "diverged": [False, False, False, False, True, False],
    ...                      "status": ["ok", "ok", "ok", "ok", "ok", "error"]})
    >>> print(summarize(runs, x="gain", y="J")[["gain", "n", "n_failed", "n_diverged", "median"]]
    ...       .to_string(index=False))
     gain  n  n_failed  n_diverged  median
        1  3         0           0     2.0
        2  3         1           1     4.0
    """
    import pandas as pd

    lo, hi = _quantiles(quantiles)
    keys, failed, div, values = _flags(df, x, y, hue, diverged)
    work = df[keys].copy()
    work["_failed"], work["_div"] = failed, div
    work["_y"] = np.where(failed | div, np.nan, values)
    rows = []
    for key, g in work.groupby(keys, sort=True, dropna=False):
        used = g["_y"].dropna().to_numpy()
        stats = (np.median(used), *np.quantile(used, [lo, hi])) if used.size else (np.nan,) * 3
        rows.append((*(key if isinstance(key, tuple) else (key,)), len(g), int(g["_failed"].sum()),
                     int(g["_div"].sum()), int(used.size), *map(float, stats)))
    return pd.DataFrame(rows, columns=[*keys, *SUMMARY_COLUMNS])


def plot_sweep(df: pd.DataFrame, x: str = "loss", y: str = "J", hue: str | None = "strategy", ax: Any = None, *,
               quantiles: Sequence[float] = (0.25, 0.75), diverged: str | None = "diverged", logy: bool = False):
    """Plot ``y`` against ``x`` per ``hue``: the median over seeds as a line with markers
    and the ``quantiles`` band shaded; diverged and failed runs are not plotted but
    counted: a label ``"<d> div, <f> fail"`` at each ``x`` that has any (at the
    median, or at the top of the axes if no run was used) and the totals in the legend.
    A numeric ``x`` axis spans every ``x`` of the runs, usable or not.

    ``df``: the run table (:attr:`SweepResult.runs <netcosim.sweep.result.SweepResult.runs>`);
    other arguments as :func:`summarize`; ``ax``: a matplotlib ``Axes`` (default: a new
    figure); ``logy``: logarithmic ``y`` axis.  Returns the axes.

    Raises
    ------
    ConfigurationError, ConfigurationTypeError
        As :func:`summarize`, for the same arguments.

    Examples
    --------
    The messages received over a lossy link (100 sent), two seeds per loss probability:
    the line is the median across seeds.

    >>> from netcosim.sweep import run_sweep
    >>> from netcosim.sweep.demo import lossy_link   # 100 messages; frames lost with params["loss"]
    >>> res = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial", quiet=True)
    >>> import matplotlib.pyplot as plt
    >>> from netcosim.sweep import plot_sweep
    >>> ax = plot_sweep(res.runs, x="loss", y="received", hue=None, diverged=None)
    >>> ax.lines[0].get_xydata().tolist(), ax.get_legend().get_texts()[0].get_text()
    ([[0.1, 87.5], [0.5, 53.5]], 'received (diverged 0/4)')
    >>> plt.close(ax.figure)
    """
    import matplotlib.pyplot as plt
    from matplotlib.transforms import blended_transform_factory

    s = summarize(df, x, y, hue, quantiles, diverged)
    lo, hi = _quantiles(quantiles)
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    groups = [(None, s)] if hue is None else list(s.groupby(hue, sort=True))
    top = blended_transform_factory(ax.transData, ax.transAxes)
    for i, (level, g) in enumerate(groups):
        g = g.sort_values(x)
        n_div, n_fail, n = int(g["n_diverged"].sum()), int(g["n_failed"].sum()), int(g["n"].sum())
        label = y if level is None else f"{hue}={level}"
        label += f" (diverged {n_div}/{n}" + (f", failed {n_fail}" if n_fail else "") + ")"
        (line,) = ax.plot(g[x], g["median"], "o-", label=label)
        ax.fill_between(g[x], g["q_low"], g["q_high"], color=line.get_color(), alpha=0.2, lw=0)
        for _, r in g.iterrows():
            if r["n_diverged"] == 0 and r["n_failed"] == 0:
                continue
            text = f"{int(r['n_diverged'])} div" + (f", {int(r['n_failed'])} fail" if r["n_failed"] else "")
            if np.isfinite(r["median"]):
                ax.annotate(text, (r[x], r["median"]), xytext=(4, 6 + 10 * i), textcoords="offset points",
                            fontsize=7, color=line.get_color())
            else:
                ax.text(r[x], 0.97 - 0.05 * i, text, transform=top, fontsize=7, color=line.get_color(),
                        ha="center", va="top")
    xs = s[x].to_numpy()
    if xs.size and np.issubdtype(xs.dtype, np.number):
        # every x stays in view, also one where no run was usable (only its count is drawn)
        lo_x, hi_x = float(np.min(xs)), float(np.max(xs))
        pad = 0.05 * (hi_x - lo_x) if hi_x > lo_x else 0.5
        ax.set_xlim(lo_x - pad, hi_x + pad)
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel(x)
    ax.set_ylabel(f"{y}: median, q{lo:g}-q{hi:g} band")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return ax
