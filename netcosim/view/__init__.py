"""See a run: an interactive timeline in one self-contained HTML file, and export to the
Chrome / Perfetto trace-event format (docs/viewer.md).

* :func:`view` (``Trace.view``): tasks, frames, signals and marks on linked time axes,
  written as an HTML file that opens from disk, offline (Bokeh, its JavaScript inlined);
* :func:`to_chrome_trace` (``Trace.to_chrome_trace``): the run as trace-event JSON for
  https://ui.perfetto.dev or ``chrome://tracing``;
* :func:`view_sweep`: a sweep's cost-versus-parameter plot, a click opening a run's timeline;
* :mod:`netcosim.view.segments`: what is drawn (shared with the PNG plots of :mod:`netcosim.plot`).

Bokeh is imported only when a view is built (``pip install netcosim[view]``).
"""

from __future__ import annotations

from typing import Any

__all__ = ["view", "to_chrome_trace", "view_sweep", "trace_tables"]


def view(source: Any, path: Any = None, **options: Any):
    """Write the interactive timeline of *source* (a Trace, a Simulation, a dict of
    tables or a directory of ``Trace.to_parquet`` files) to *path* (``.html``); returns
    the path.  See :func:`netcosim.view.bokeh_timeline.write_view` for the options."""
    from .bokeh_timeline import write_view
    return write_view(source, path, **options)


def to_chrome_trace(source: Any, path: Any, **options: Any):
    """Write *source*'s trace as Chrome/Perfetto trace-event JSON to *path*; returns the
    path.  See :func:`netcosim.view.chrome_trace.write_chrome_trace`."""
    from .chrome_trace import write_chrome_trace
    return write_chrome_trace(source, path, **options)


def view_sweep(directory: Any, path: Any = None, **options: Any):
    """Write the HTML view of the sweep stored in *directory*; returns its path.  See
    :func:`netcosim.view.sweep_view.write_sweep_view`."""
    from .sweep_view import write_sweep_view
    return write_sweep_view(directory, path, **options)


def trace_tables(source: Any, prefix: str = "trace_") -> dict:
    """The trace tables of *source* (a Simulation or a Trace) as ``{prefix + name: DataFrame}``,
    for a sweep scenario to return so that the sweep keeps each run's trace (the sweep
    view then links every point to that run's timeline)."""
    from .tables import read_tables
    return {prefix + k: v for k, v in read_tables(source).items() if len(v)}
