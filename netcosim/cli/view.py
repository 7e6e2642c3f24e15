"""``netcosim view PATH``: the interactive HTML view of a saved run or of a stored sweep,
or its export to the Chrome/Perfetto trace-event format (docs/viewer.md)."""

from __future__ import annotations

import math
from pathlib import Path

from ._common import UsageError


def _source(given: str) -> tuple[Path, str, bool]:
    """``(directory, prefix, is_sweep)`` of PATH: a sweep directory (with ``sweep.json``), a
    directory of ``Trace.to_parquet`` files, or one of those files (``PREFIXschedule.parquet``:
    the run's files share its prefix)."""
    from ..view.tables import TABLES
    path = Path(given)
    if path.is_dir():
        return path, "", (path / "sweep.json").is_file()
    if path.is_file() and path.suffix == ".parquet":
        for name in TABLES:
            if path.name.endswith(f"{name}.parquet"):
                return path.parent, path.name[: -len(f"{name}.parquet")], False
        raise UsageError(f"{given!r} is not a trace table file: its name must end in one of "
                         f"{[n + '.parquet' for n in TABLES]}")
    raise UsageError(f"cannot view {given!r}: " + ("no such file or directory" if not path.exists() else
                                                  "give a directory or a .parquet trace table"))


def _view(args) -> int:
    from ..errors import ConfigurationError, ConfigurationTypeError
    folder, prefix, sweep = _source(args.path)
    for flag, v in (("--t0", args.t0), ("--t1", args.t1)):
        if v is not None and not math.isfinite(v):
            raise UsageError(f"{flag} must be a finite number of seconds, got {v!r}")
    if args.t0 is not None and args.t1 is not None and not args.t1 > args.t0:
        raise UsageError(f"empty or reversed time window: --t0 {args.t0!r} --t1 {args.t1!r} (need t1 > t0)")
    for flag, out in (("-o/--output", args.output), ("--chrome-trace", args.chrome_trace)):
        if out is not None and not Path(out).parent.is_dir():
            raise UsageError(f"{flag} {out!r}: the folder {str(Path(out).parent)!r} does not exist")
    try:
        from .. import view as v
        written = []
        if sweep:
            if args.chrome_trace is not None:
                raise UsageError("--chrome-trace exports one run: give a run's trace directory, not a sweep")
            written.append(v.view_sweep(folder, args.output, y=args.metric))
        else:
            if args.chrome_trace is not None:
                written.append(v.to_chrome_trace(folder, args.chrome_trace, prefix=prefix))
            if args.output is not None or args.chrome_trace is None:
                t_range = None if args.t0 is None and args.t1 is None else (args.t0, args.t1)
                written.append(v.view(folder, args.output or (folder / f"{prefix}view.html"), prefix=prefix,
                                      signals=args.signal, t_range=t_range, title=args.title))
    except ImportError as exc:
        raise UsageError(f"the view needs Bokeh: pip install 'netcosim[view]' ({exc})") from None
    except (ConfigurationError, ConfigurationTypeError, KeyError, ValueError) as exc:
        reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise UsageError(f"{args.path!r}: {reason}") from None
    except OSError as exc:
        raise UsageError(f"cannot write: {exc.strerror or exc}") from None
    for w in written:
        print(w)
    return 0


def add_parser(sub) -> None:
    """Add the ``view`` subcommand to the subparsers *sub* of the ``netcosim`` parser."""
    p = sub.add_parser("view", help="interactive HTML timeline of a saved run or a sweep; trace-event export",
                       description="Write one self-contained HTML file (opens offline from disk) with the run's "
                                   "tasks, frames and signals on linked time axes, from the tables "
                                   "Trace.to_parquet wrote (PATH: their directory, or one of the files, whose "
                                   "prefix selects the run); for a sweep directory, the cost-versus-parameter "
                                   "page, each run with a kept trace linked to its timeline.  --chrome-trace "
                                   "writes the Chrome/Perfetto trace-event JSON instead (with -o: both).")
    p.add_argument("path", help="a run's trace directory or table file (*.parquet), or a sweep directory")
    p.add_argument("-o", "--output", help="HTML file to write (default: PATH/PREFIXview.html; a sweep: "
                                          "SWEEP_DIR/view.html)")
    p.add_argument("--chrome-trace", metavar="JSON", help="write the trace-event JSON to this file")
    p.add_argument("--signal", action="append", help="signal to draw, as source.signal (repeatable; default: "
                                                     "the first 8 logged)")
    p.add_argument("--t0", type=float, help="initial window start in seconds (default: start of the run)")
    p.add_argument("--t1", type=float, help="initial window end in seconds (default: end of the run)")
    p.add_argument("--title", help="page title")
    p.add_argument("--metric", help="sweep: the metric on the y axis (default cost, else the first numeric one)")
    p.set_defaults(fn=_view)
