"""Command line: ``netcosim run EXPERIMENT`` and ``netcosim plot schedule TRACE.parquet``.

``run`` imports ``experiments.<EXPERIMENT>`` and calls its ``main(outdir)``;
``plot schedule`` draws a schedule table written by ``Trace.to_parquet``.
"""

from __future__ import annotations

import argparse
import importlib
import sys


def _run(args) -> int:
    name = args.experiment.removeprefix("experiments.")
    try:
        mod = importlib.import_module(f"experiments.{name}")
    except ModuleNotFoundError as exc:
        if exc.name in (f"experiments.{name}", "experiments"):
            print(f"netcosim: no experiment {name!r} (looked for module experiments.{name})", file=sys.stderr)
            return 2
        raise
    if not hasattr(mod, "main"):
        print(f"netcosim: experiments.{name} has no main()", file=sys.stderr)
        return 2
    kwargs = {"outdir": args.outdir} if args.outdir else {}
    mod.main(**kwargs)
    return 0


def _plot(args) -> int:
    import pandas as pd

    from .plot import plot_schedule
    df = pd.read_parquet(args.trace)
    t_range = (args.t0, args.t1) if args.t1 is not None else None
    plot_schedule(df, t_range=t_range, node=args.node, path=args.output)
    print(args.output)
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="netcosim", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run an experiment module's main()")
    r.add_argument("experiment", help="name of a module in experiments/, e.g. servo")
    r.add_argument("--outdir", help="output directory (default: the experiment's own)")
    r.set_defaults(fn=_run)
    pl = sub.add_parser("plot", help="plot a saved trace")
    pl.add_argument("kind", choices=["schedule"])
    pl.add_argument("trace", help="Parquet file written by Trace.to_parquet (schedule table)")
    pl.add_argument("-o", "--output", default="schedule.png")
    pl.add_argument("--node")
    pl.add_argument("--t0", type=float, default=0.0)
    pl.add_argument("--t1", type=float)
    pl.set_defaults(fn=_plot)
    args = p.parse_args(argv)
    return args.fn(args)


if __name__ == "__main__":
    sys.exit(main())
