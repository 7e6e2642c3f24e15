"""``netcosim plot schedule|network TRACE``: check every argument, read the table, draw it."""

from __future__ import annotations

import math
from pathlib import Path

from ._common import UsageError

#: Columns a schedule table (``sim.trace.schedule()``) must have to be plotted.
SCHEDULE_COLUMNS = ("time", "node", "task", "state")


def time_window(t0: float | None, t1: float | None) -> tuple[float | None, float | None] | None:
    """``(t0, t1)`` in seconds for ``plot_schedule(t_range=...)``; ``None`` ends are open.

    Raises :class:`UsageError` naming the values if one is not finite or if ``t1 <= t0``.
    """
    for flag, v in (("--t0", t0), ("--t1", t1)):
        if v is not None and not math.isfinite(v):
            raise UsageError(f"{flag} must be a finite number of seconds, got {v!r}")
    if t0 is not None and t1 is not None and not t1 > t0:
        raise UsageError(f"empty or reversed time window: --t0 {t0!r} --t1 {t1!r} (need t1 > t0)")
    if t0 is None and t1 is None:
        return None
    return (t0, t1)


#: Columns a network schedule table (``sim.trace.frame("network_schedule")``) must have to be plotted.
NETWORK_SCHEDULE_COLUMNS = ("time", "network", "node", "state")
#: Columns of the ``frames`` table the network plot's markers read.
FRAME_MARKER_COLUMNS = ("time", "network", "node", "src", "event", "attempt")


def _read_table(given: str, columns: tuple[str, ...], what: str):
    """The Parquet table *given* as a DataFrame with *columns*; :class:`UsageError` naming it otherwise."""
    import pandas as pd
    path = Path(given)
    if not path.is_file():
        why = "it is a directory" if path.is_dir() else "no such file"
        raise UsageError(f"cannot read {given!r}: {why}")
    try:
        df = pd.read_parquet(path)
    except (OSError, ValueError) as exc:      # pyarrow's ArrowInvalid is a ValueError
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UsageError(f"cannot read {given!r} as Parquet: {reason}") from None
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise UsageError(f"{given!r} is not {what}: missing columns {missing}")
    return df


def _check_image_path(given: str) -> None:
    """The folder of the image *given* must exist and be writable (it is not created)."""
    import tempfile
    folder = Path(given).parent
    if not folder.is_dir():
        why = "is a file" if folder.exists() else "does not exist (create it first)"
        raise UsageError(f"cannot write {given!r}: the folder {str(folder)!r} {why}")
    try:
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as exc:
        raise UsageError(f"cannot write {given!r}: {exc.strerror or exc}") from None


def _plot(args) -> int:
    """``plot schedule`` / ``plot network``: check every argument, read the table, draw it.

    ``--t0`` alone is the window from t0 to the end of the trace, ``--t1`` alone from its
    start; the image's folder must exist (it is not created)."""
    from ..errors import ConfigurationError, ConfigurationTypeError
    network = args.kind == "network"
    if not network and (args.network is not None or args.frames is not None):
        raise UsageError(f"{'--network' if args.network is not None else '--frames'} is an option of "
                         "`netcosim plot network`, not of `plot schedule`")
    t_range = time_window(args.t0, args.t1)
    output = args.output if args.output is not None else f"{args.kind}.png"
    if not output.strip():
        raise UsageError(f"-o/--output must name an image file, got {output!r}")
    if Path(output).is_dir() or output.endswith(("/", "\\")):
        output = str(Path(output) / f"{args.kind}.png")        # a folder: KIND.png in it
    elif not Path(output).suffix or not Path(output).stem:
        raise UsageError(f"-o/--output {output!r} has no file extension: give the image format as one "
                         f"(e.g. {args.kind}.png, {args.kind}.pdf, {args.kind}.svg)")
    _check_image_path(output)
    frames = None
    if network:
        df = _read_table(args.trace, NETWORK_SCHEDULE_COLUMNS,
                         "a network schedule table (Trace.to_parquet's network_schedule.parquet)")
        frames_path = args.frames
        if frames_path is None and Path(args.trace).name.endswith("network_schedule.parquet"):
            sibling = Path(args.trace).with_name(Path(args.trace).name.removesuffix("network_schedule.parquet")
                                                 + "frames.parquet")
            frames_path = str(sibling) if sibling.is_file() else None
        if frames_path is not None:
            frames = _read_table(frames_path, FRAME_MARKER_COLUMNS,
                                 "a frames table (Trace.to_parquet's frames.parquet)")
        have = sorted(set(df["network"].astype(str)))
        if args.network is not None and args.network not in have:
            raise UsageError(f"no network {args.network!r} in {args.trace!r}; have {have}")
        if args.network is None and len(have) > 1:
            raise UsageError(f"{args.trace!r} holds several networks {have}: choose one with --network")
    else:
        df = _read_table(args.trace, SCHEDULE_COLUMNS, "a schedule table (Trace.to_parquet's schedule.parquet)")

    from .. import plot
    from ..network import plot as network_plot
    try:
        if network:
            network_plot.plot_network_schedule(df, network=args.network, t_range=t_range, frames=frames,
                                               nodes=None if args.node is None else [args.node], path=output)
        else:
            plot.plot_schedule(df, t_range=t_range, node=args.node, path=output)
    except KeyError as exc:
        reason = exc.args[0] if exc.args else repr(exc)
        raise UsageError(f"{args.trace!r}: {reason}") from None
    except (ConfigurationError, ConfigurationTypeError) as exc:
        raise UsageError(f"{args.trace!r}: {exc}") from None
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:
        raise UsageError(f"cannot write {output!r}: {exc.strerror or exc}") from None
    print(output)
    return 0


def add_parser(sub) -> None:
    """Add the ``plot`` subcommand to the subparsers *sub* of the ``netcosim`` parser."""
    pl = sub.add_parser("plot", help="plot a saved trace (task schedule or network timeline)",
                        description="Draw a table written by Trace.to_parquet as a PNG: `schedule` a task "
                                    "schedule (schedule.parquet), `network` the network timeline "
                                    "(network_schedule.parquet; the frames.parquet next to it adds a cross per "
                                    "lost frame and a triangle per retransmission).  --t0 alone plots from t0 to "
                                    "the end of the trace, --t1 alone from its start; a window outside the trace's "
                                    "time span or narrower than 1 ps is refused.  The image's folder must exist.")
    pl.add_argument("kind", choices=["schedule", "network"])
    pl.add_argument("trace", help="Parquet file written by Trace.to_parquet: schedule.parquet (schedule) or "
                                  "network_schedule.parquet (network)")
    pl.add_argument("-o", "--output", help="image to write, its format given by its extension (.png, .pdf, .svg; "
                                           "a name without one is refused); an existing folder or a name ending "
                                           "in / writes KIND.png in that folder (default KIND.png: schedule.png "
                                           "or network.png)")
    pl.add_argument("--node", help="plot only this node (schedule: its tasks; network: its row)")
    pl.add_argument("--network", help="network: the network to plot (needed if the table holds several)")
    pl.add_argument("--frames", metavar="PATH",
                    help="network: the frames table for the loss and retransmission markers (default: the "
                         "frames.parquet next to TRACE, if any)")
    pl.add_argument("--t0", type=float, help="window start in seconds (default: start of the trace)")
    pl.add_argument("--t1", type=float, help="window end in seconds (default: end of the trace; --t0 alone "
                                             "plots from t0 to the end)")
    pl.set_defaults(fn=_plot)
