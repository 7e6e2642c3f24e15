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
    the path.  See :func:`netcosim.view.bokeh_timeline.write_view` for the options.

    Raises
    ------
    ConfigurationError
        The folder of *path* does not exist; an unknown option, an empty ``t_range``, a
        signal that was not logged; nothing to view (no schedule, frames or signals); a
        directory without trace tables.
    ConfigurationTypeError
        *source* is none of the above; a level-of-detail option is not a positive integer.

    Examples
    --------
    Two tasks under EDF for 15 ms; the timeline has one row per task:

    >>> from netcosim import Simulation
    >>> sim = Simulation(seed=1)
    >>> cpu = sim.node("cpu", scheduler="edf")
    >>> @cpu.periodic(period=0.010, name="slow")
    ... def slow(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.004, name="fast")
    ... def fast(ctx):
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=0.015)
    >>> import os, re, tempfile
    >>> from netcosim.view import view
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     html = view(sim, os.path.join(tmp, "run.html")).read_text()
    >>> sorted(set(re.findall(r'"(cpu[.][a-z]+)"', html)))       # the task rows, read back from the file
    ['cpu.fast', 'cpu.slow']
    """
    from .bokeh_timeline import write_view
    return write_view(source, path, **options)


def to_chrome_trace(source: Any, path: Any, **options: Any):
    """Write *source*'s trace as Chrome/Perfetto trace-event JSON to *path*; returns the
    path.  See :func:`netcosim.view.chrome_trace.write_chrome_trace`.

    Raises
    ------
    ConfigurationError
        The folder of *path* does not exist; *source* is a directory without trace tables.
    ConfigurationTypeError
        *source* is not a Trace, a Simulation, a dict of DataFrames or a directory.

    Examples
    --------
    Two tasks under EDF for 15 ms: one ``running`` event per job (none is preempted here),
    times in microseconds; ``slow``'s first job waits for ``fast`` and runs from 1 ms to 3 ms.

    >>> from netcosim import Simulation
    >>> sim = Simulation(seed=1)
    >>> cpu = sim.node("cpu", scheduler="edf")
    >>> @cpu.periodic(period=0.010, name="slow")
    ... def slow(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.004, name="fast")
    ... def fast(ctx):
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=0.015)
    >>> import json, os, tempfile
    >>> from netcosim.view import to_chrome_trace
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     events = json.loads(to_chrome_trace(sim, os.path.join(tmp, "run.json")).read_text())["traceEvents"]
    >>> running = [e for e in events if e.get("cat") == "running"]
    >>> len(running), len(sim.trace.to_pandas("jobs"))
    (6, 6)
    >>> [(e["name"], round(e["ts"], 3), round(e["dur"], 3)) for e in running if e["name"].startswith("slow")]
    [('slow job 0', 1000.0, 2000.0), ('slow job 1', 10000.0, 2000.0)]
    """
    from .chrome_trace import write_chrome_trace
    return write_chrome_trace(source, path, **options)


def view_sweep(directory: Any, path: Any = None, **options: Any):
    """Write the HTML view of the sweep stored in *directory*; returns its path.  See
    :func:`netcosim.view.sweep_view.write_sweep_view`.

    Raises
    ------
    ConfigurationError
        *directory* holds no sweep or no finished run yet; the sweep has no numeric metric,
        or none named ``y``; the folder of *path* does not exist.

    Examples
    --------
    A sweep whose scenario keeps each run's trace (:func:`trace_tables`): the page plots the
    messages received against the loss, and each run gets a timeline of its own beside it.

    >>> import pathlib, tempfile
    >>> from netcosim.sweep import run_sweep
    >>> from netcosim.view import trace_tables, view_sweep
    >>> from netcosim.sweep.demo import lossy_link_run   # 100 messages over a lossy link
    >>> def lossy_link(params, seed):
    ...     sim, arrivals = lossy_link_run(params["loss"], seed)
    ...     return {"received": len(arrivals), **trace_tables(sim)}      # the run's trace is kept
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = pathlib.Path(tmp, "sweep")
    ...     _ = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial", out=out, quiet=True)
    ...     page = view_sweep(out)
    ...     run_pages = sorted(p.name for p in (out / "runs").glob("*.html"))
    >>> page.name, len(run_pages), run_pages[0]
    ('view.html', 4, 'run-000000-000000.html')
    """
    from .sweep_view import write_sweep_view
    return write_sweep_view(directory, path, **options)


def trace_tables(source: Any, prefix: str = "trace_") -> dict:
    """The trace tables of *source* (a Simulation or a Trace) as ``{prefix + name: DataFrame}``,
    for a sweep scenario to return so that the sweep keeps each run's trace (the sweep
    view then links every point to that run's timeline).  Empty tables are left out.

    Raises
    ------
    ConfigurationTypeError
        *source* is not a Simulation or a Trace (nor a dict of DataFrames or a directory of
        ``Trace.to_parquet`` files, which are read too).
    ConfigurationError
        *source* is a directory without trace tables.

    Examples
    --------
    Two tasks under EDF for 15 ms have 6 jobs:

    >>> from netcosim import Simulation
    >>> sim = Simulation(seed=1)
    >>> cpu = sim.node("cpu", scheduler="edf")
    >>> @cpu.periodic(period=0.010, name="slow")
    ... def slow(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.004, name="fast")
    ... def fast(ctx):
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=0.015)
    >>> from netcosim.view import trace_tables
    >>> tables = trace_tables(sim)
    >>> sorted(tables), len(tables["trace_jobs"])
    (['trace_jobs', 'trace_schedule'], 6)

    Returned by a sweep's scenario, they are kept per run, their parameters prepended
    (282 messages arrived in the four runs):

    >>> from netcosim.sweep import run_sweep
    >>> from netcosim.sweep.demo import lossy_link_run   # 100 messages over a lossy link
    >>> def lossy_link(params, seed):
    ...     sim, arrivals = lossy_link_run(params["loss"], seed)
    ...     return {"received": len(arrivals), **trace_tables(sim)}      # the run's trace is kept
    >>> res = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial", quiet=True)
    >>> res.table_names
    ['trace_frames', 'trace_jobs', 'trace_network_schedule', 'trace_schedule']
    >>> frames = res.table("trace_frames")
    >>> list(frames.columns[:3]), len(frames[frames["event"] == "delivered"])
    (['loss', 'seed_index', 'seed'], 282)
    """
    from .tables import read_tables
    return {prefix + k: v for k, v in read_tables(source).items() if len(v)}
