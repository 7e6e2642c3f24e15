"""Plots: TrueTime-style schedule staircases and signal plots (matplotlib, saved as PNG).

One row per task, at height ``row``; the staircase sits at ``row + 0.5`` while the task
runs, ``row + 0.25`` while ready (preempted or waiting for the CPU), ``row + 0.125`` while
blocked and ``row`` while idle -- TrueTime's encoding.

The backend is left to the user (``MPLBACKEND`` or ``matplotlib.use``); without a
display matplotlib itself falls back to Agg, so saving PNGs works headless.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from . import validate
from .errors import ConfigurationError, ConfigurationTypeError, NetcosimError
from .timebase import RESOLUTION
from .view.segments import TASK_STATES, staircase, state_intervals

if TYPE_CHECKING:  # matplotlib and pandas load when a plot is drawn, not on import
    import pandas as pd

__all__ = ["TASK_STATES", "MissingColumnsError", "PlotSaveError", "check_columns", "check_image_path",
           "time_window", "check_table", "plot_staircases", "save", "plot_schedule", "plot_signals"]


class MissingColumnsError(ConfigurationError, KeyError):
    """A table given to a plot lacks columns the plot reads; the message names them and
    the columns the table has (a :class:`KeyError` too, so ``except KeyError`` still catches it)."""

    def __str__(self) -> str:
        # KeyError quotes its argument like a key; this one is a sentence
        return str(self.args[0]) if self.args else ""


class PlotSaveError(NetcosimError, OSError):
    """The image could not be written (the message names the path and the reason)."""


def check_columns(df, columns: Sequence[str], what: str) -> None:
    """Refuse *df* (called *what* in the message) unless it is a pandas DataFrame with
    every one of *columns*: :class:`~netcosim.errors.ConfigurationTypeError` naming the
    value for a non-DataFrame, :class:`MissingColumnsError` listing the missing columns
    and those it has."""
    import pandas as pd
    if not isinstance(df, pd.DataFrame):
        text = repr(df)
        raise ConfigurationTypeError(f"{what} must be a pandas DataFrame with columns {list(columns)}, got "
                                     f"{type(df).__name__} {text if len(text) <= 60 else text[:57] + '...'}")
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise MissingColumnsError(f"{what} lacks the columns {missing} (it has {[str(c) for c in df.columns]}; "
                                  f"a plot needs {list(columns)})")


def check_image_path(path) -> None:
    """Refuse an image *path* (None: nothing to check) that cannot be written, naming it:
    a directory (give a file name in it), a name without extension (the format is read
    from it: ``.png``, ``.pdf``, ``.svg``), or a folder that does not exist
    (:class:`~netcosim.errors.ConfigurationError`; it is not created)."""
    if path is None:
        return
    validate.path(path, "path", kind="an image file name (str or os.PathLike)")
    text = str(path)
    p = Path(path)
    if p.is_dir() or text.endswith(("/", "\\")):
        raise ConfigurationError(f"path {text!r} is a directory: give an image file name in it "
                                 f"(e.g. {str(p / 'schedule.png')!r})")
    if not p.suffix or not p.stem:
        raise ConfigurationError(f"path {text!r} has no file extension: give the image format as one "
                                 f"(e.g. .png, .pdf, .svg)")
    if not p.parent.is_dir():
        why = "is a file" if p.parent.exists() else "does not exist (create it first)"
        raise ConfigurationError(f"cannot write {text!r}: the folder {str(p.parent)!r} {why}")


def time_window(times, t_range) -> tuple[float, float]:
    """The plotted window ``(t0, t1)`` in seconds for data at *times* (seconds).

    ``t_range=None`` spans the data (a single instant gets a 1 ns window); otherwise
    ``t_range = (t0, t1)`` where either end may be ``None`` for "start" / "end of the
    data".  Raises :class:`~netcosim.errors.ConfigurationTypeError` if *t_range* is not
    a pair of real numbers or ``None``, and :class:`~netcosim.errors.ConfigurationError`
    naming it if an end is not finite, the window is empty or reversed (``t1 <= t0``),
    narrower than the 1 ps time resolution, or lies wholly outside the data's time span
    (the message names the span).
    """
    lo, hi = float(np.min(times)), float(np.max(times))
    if t_range is None:
        return (lo, hi) if hi > lo else (lo, lo + 1e-9)
    try:
        t0, t1 = t_range
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"t_range must be a pair (t0, t1) of seconds, got {t_range!r}") from None
    for v in (t0, t1):
        if v is not None and not validate.is_real(v):
            raise ConfigurationTypeError(f"t_range must be a pair (t0, t1) of seconds, got {t_range!r}")
    start = lo if t0 is None else float(t0)
    end = hi if t1 is None else float(t1)
    if not (math.isfinite(start) and math.isfinite(end)):
        raise ConfigurationError(f"t_range must be finite, got {t_range!r}")
    if not end > start:
        data = f" (the data span {lo!r} to {hi!r} s)" if t0 is None or t1 is None else ""
        raise ConfigurationError(f"t_range={t_range!r} is an empty or reversed window{data}: "
                                 f"need t1 > t0")
    if end - start < RESOLUTION:
        raise ConfigurationError(f"t_range={t_range!r} is narrower than the time resolution "
                                 f"({RESOLUTION:g} s): nothing can change inside it")
    if end <= lo or start > hi:
        raise ConfigurationError(f"t_range={t_range!r} lies outside the data's time span {lo!r} to {hi!r} s: "
                                 f"nothing to plot in it")
    return start, end


def check_table(df: pd.DataFrame, levels: dict[str, float]) -> None:
    """Check the ``time`` and ``state`` columns of *df*, a schedule table, before plotting it.

    Raises :class:`~netcosim.errors.ConfigurationTypeError` if ``time`` does not hold
    numbers (e.g. strings), :class:`~netcosim.errors.ConfigurationError` if a time is
    NaN or infinite, or if a ``state`` is not one of *levels* (naming the unknown ones).
    """
    import pandas as pd
    times = df["time"]
    if not pd.api.types.is_numeric_dtype(times) or pd.api.types.is_bool_dtype(times):
        example = times.iloc[0] if len(times) else None
        raise ConfigurationTypeError(f"column 'time' must hold numbers of seconds, got {times.dtype} values "
                                     f"(e.g. {example!r})")
    values = times.to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if bad.any():
        raise ConfigurationError(f"column 'time' must hold finite seconds, got {values[bad][0]!r} "
                                 f"({int(bad.sum())} of {len(values)} rows)")
    unknown = sorted(set(df["state"].astype(str)) - set(levels))
    if unknown:
        raise ConfigurationError(f"unknown states {unknown} in column 'state'; the states are {list(levels)}")


def plot_staircases(df: pd.DataFrame, label: str, levels: dict[str, float], *, order=None, t_range=None,
                    ax=None, what: str = "row"):
    """One TrueTime staircase per distinct ``df[label]`` (top row first).

    ``df`` has columns ``time`` (s), *label* and ``state``; ``levels`` maps each state
    to its offset above the row (both columns are checked by :func:`check_table`);
    ``t_range`` is checked by :func:`time_window`.  ``order``: the labels, top row first
    (default: order of appearance); ``ax``: the axes to draw on (None: a new figure);
    ``what`` names a row in the error for a label of *order* that *df* lacks (e.g. ``"task"``).
    Returns ``(ax, row_of, (t0, t1))``.
    """
    check_table(df, levels)
    labels = df[label].astype(str)
    order = list(order) if order is not None else list(dict.fromkeys(labels))
    t0, t1 = time_window(df["time"].to_numpy(dtype=float), t_range)
    if ax is None:
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(10, 0.8 + 0.6 * len(order)))
    row_of = {}
    for row, lab in enumerate(reversed(order)):
        row_of[lab] = row
        sel = df[labels == lab]
        if sel.empty:
            raise KeyError(f"no {what} {lab!r} in the schedule; have {sorted(set(labels))}")
        times = sel["time"].to_numpy(dtype=float)
        lv = row + sel["state"].astype(str).map(levels).to_numpy(dtype=float)
        # value in force at t0, then the changes inside the window, held to t1
        ts, ls = staircase(times, lv, t0, t1, floor=row)
        ax.step(ts, ls, where="post", lw=1.2)
    ax.set_yticks([r + 0.25 for r in range(len(order))])
    ax.set_yticklabels(list(reversed(order)))
    ax.set_xlim(t0, t1)
    ax.set_xlabel("time [s]")
    ax.grid(axis="x", alpha=0.3)
    return ax, row_of, (t0, t1)


def save(ax, path) -> None:
    """Save the figure of *ax* (matplotlib axes) as PNG (if *path* is given) and close it (also if saving fails).

    A path that cannot be written raises :class:`PlotSaveError` (an ``OSError``) naming it."""
    if path is not None:
        try:
            ax.figure.tight_layout()
            ax.figure.savefig(path, dpi=120)
        except OSError as exc:
            raise PlotSaveError(f"cannot write the image {str(path)!r}: {exc.strerror or exc}") from None
        finally:
            import matplotlib.pyplot as plt
            plt.close(ax.figure)


def plot_schedule(schedule: pd.DataFrame, *, tasks: Sequence[str] | None = None, t_range=None,
                  node: str | None = None, ax=None, path: str | Path | None = None, title: str | None = None):
    """Draw the schedule trace (``sim.trace.schedule()``) as one staircase per task.

    ``tasks`` orders the rows (top row first; default: order of appearance); ``t_range``
    = (t0, t1) in seconds restricts the window (``None`` for an open end, e.g. ``(0.5,
    None)`` is from 0.5 s to the end; see :func:`time_window` for the checks); ``node``
    keeps one node's tasks (:class:`~netcosim.errors.ConfigurationError` naming it if
    the schedule has no such node); ``ax``: the matplotlib axes to draw on (None: a new
    figure); ``title``: the axes' title (None: none); ``path`` saves a PNG.  Returns the axes.

    A *schedule* that is not a DataFrame with columns ``time``, ``node``, ``task`` and
    ``state``, or a *path* that cannot be an image file (:func:`check_image_path`), is
    refused naming it before anything is drawn.
    """
    check_columns(schedule, ("time", "node", "task", "state"), "schedule")
    check_image_path(path)
    df = schedule
    if node is not None:
        have = sorted(set(df["node"].astype(str)))
        df = df[df["node"] == node]
        if df.empty and have:
            raise ConfigurationError(f"no node {node!r} in the schedule; have {have}")
    if df.empty:
        raise ValueError("empty schedule: nothing to plot (did the simulation run?)")
    labels = (df["node"].astype(str) + "." + df["task"].astype(str)) if node is None else df["task"].astype(str)
    df = df.assign(label=labels.to_numpy())
    ax, row_of, (t0, t1) = plot_staircases(df, "label", TASK_STATES, order=tasks, t_range=t_range, ax=ax,
                                           what="task")
    if "core" in df.columns:
        _shade_cores(ax, df, row_of, t1)
    ax.set_title(title or "schedule (high = running, medium = ready, low = idle)")
    save(ax, path)
    return ax


def _shade_cores(ax, df: pd.DataFrame, row_of: dict, t_end: float) -> None:
    """Shade each running interval of a schedule with a ``core`` column in its core's
    colour (a multicore node's trace), with a legend entry per core."""
    seen: set[int] = set()
    for lab, sel in df.groupby("label", sort=False, observed=True):
        if lab not in row_of:
            continue
        times, ends, states = state_intervals(sel["time"].to_numpy(dtype=float), sel["state"].astype(str), t_end)
        for t, end, st, core in zip(times, ends, states, sel["core"]):
            if st == "running" and core >= 0 and end > t:
                ax.broken_barh([(t, end - t)], (row_of[lab], 0.5), facecolors=f"C{int(core) % 10}", alpha=0.3,
                               label=None if int(core) in seen else f"core {int(core)}")
                seen.add(int(core))
    if seen:
        ax.legend(loc="upper right", fontsize="small")


def plot_signals(signals: pd.DataFrame, columns: Sequence[tuple[str, str]], *, path=None, ax=None,
                 title: str | None = None, drawstyle: str = "default"):
    """Plot selected ``(source, signal)`` pairs from the tidy signals table.

    *signals* must be a DataFrame with columns ``time``, ``source``, ``signal``, ``value``
    and *path* an image file name (:func:`check_image_path`), both checked before drawing.
    ``ax``: the matplotlib axes to draw on (None: a new figure); ``title``: the axes' title
    (None: none); ``drawstyle``: matplotlib's line draw style (``"default"`` joins the
    samples by straight lines, ``"steps-post"`` holds each until the next)."""
    check_columns(signals, ("time", "source", "signal", "value"), "signals")
    check_image_path(path)
    if ax is None:
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(10, 4))
    for source, signal in columns:
        sel = signals[(signals["source"] == source) & (signals["signal"] == signal)]
        if sel.empty:
            raise KeyError(f"no signal {signal!r} from {source!r}")
        ax.plot(sel["time"], sel["value"], label=f"{source}.{signal}", drawstyle=drawstyle)
    ax.set_xlabel("time [s]")
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    save(ax, path)
    return ax
