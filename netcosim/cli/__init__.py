"""Command line: ``netcosim run EXPERIMENT``, ``netcosim sweep SCENARIO``, ``netcosim sweep verify DIR``,
``netcosim hil SCENARIO --remote NODE``, ``netcosim plot schedule|network TRACE`` and
``netcosim export-fmu BUILDER --nodes A,B --out NET.fmu``.

``run`` calls an experiment's entry point with ``outdir`` (and ``quick``) keyword
arguments.  EXPERIMENT is one of

* ``NAME``: the entry point NAME of the group ``netcosim.experiments`` (e.g. ``servo``,
  registered by netcosim's pyproject.toml; other installed packages can add their own);
* ``package.module``: any importable module, its function ``main``;
* ``package.module:function``: that function of that module;
* ``path/to/file.py`` (or ``path/to/file.py:function``): a Python file, loaded as a
  module (its directory is put first on ``sys.path``), its ``main`` (or *function*).

``sweep`` runs a scenario function ``fn(params, seed) -> dict`` over a grid of cases and
seeds (:func:`netcosim.sweep.run_sweep`) into a Parquet dataset: SCENARIO is
``package.module:function`` or ``path/to/file.py:function``; ``--grid NAME=V1,V2,...``
(repeatable, the product of the lists) with each value read as an int, else a float, else
a bool (``true``/``false``), else a string; ``--resume DIR`` continues the sweep stored in
DIR (``--retry-errors`` also re-runs its failed runs).  Modules are also looked up in the
current directory.  Exit status 1 if a run failed (error or timeout); Ctrl-C ends with
one line saying what is kept and how to resume (exit status 130).  ``sweep verify DIR``
checks every file of a stored sweep against its digest (exit status 1 if one is damaged).

``hil`` builds SCENARIO (``package.module:function`` returning a Simulation), makes node
NAME remote (:class:`netcosim.transport.remote.RemoteNode`) -- or, if NAME is a plant,
gives a process its outputs every ``--period`` s and its inputs
(:class:`netcosim.transport.remote.RemotePlantIO`) --, prints the command that starts
the remote side, waits for it and runs in real time, or ``--factor`` times slower; it
prints the counters and response times and writes the trace to ``--out`` (``--compare``:
also the all-simulated run and, with ``--replay``, the replay; docs/hil.md).

``export-fmu`` writes a network (``package.module:function`` returning it) as an FMI 2.0
co-simulation FMU whose inputs are messages to send and whose outputs are the delivered
messages and their delays (docs/fmi.md).

``plot schedule`` draws a schedule table written by ``Trace.to_parquet``; ``plot network``
its network timeline (``network_schedule``, with ``frames`` when it lies beside it).

``view`` writes the interactive HTML timeline of a run saved by ``Trace.to_parquet``
(PATH: its directory or one of its files), or the page of a stored sweep (PATH: the
sweep's directory); ``--chrome-trace OUT.json`` exports the run as Chrome/Perfetto
trace events (docs/viewer.md).

Bad arguments (unknown experiment, unreadable trace, empty time window, ...) print one
line naming the value on stderr and exit with status 2.
"""

from __future__ import annotations

import argparse
import sys

from . import export_fmu, hil, plot, run, sweep, view
from ._common import UsageError, check_writable_dir
from .hil import check_endpoint
from .plot import FRAME_MARKER_COLUMNS, NETWORK_SCHEDULE_COLUMNS, SCHEDULE_COLUMNS, time_window
from .run import available_experiments, resolve_experiment
from .sweep import grid_value, parse_grid

__all__ = ["FRAME_MARKER_COLUMNS", "NETWORK_SCHEDULE_COLUMNS", "SCHEDULE_COLUMNS", "UsageError",
           "available_experiments", "build_parser", "check_endpoint", "check_writable_dir", "grid_value", "main",
           "parse_grid", "resolve_experiment", "time_window"]


def build_parser() -> argparse.ArgumentParser:
    """The ``netcosim`` argument parser."""
    p = argparse.ArgumentParser(prog="netcosim", description=__doc__.splitlines()[0],
                                epilog="\n".join(__doc__.splitlines()[2:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    for command in (run, sweep, hil, plot, view, export_fmu):
        command.add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line with *argv* (default ``sys.argv[1:]``); returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return args.fn(args)
    except UsageError as exc:
        print(f"netcosim {args.cmd}: {exc}", file=sys.stderr)
        return 2

