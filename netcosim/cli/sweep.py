"""``netcosim sweep SCENARIO --grid ...`` and ``netcosim sweep verify DIR``."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ._common import UsageError, _syntax_error, check_writable_dir


def grid_value(text: str) -> int | float | bool | str:
    """A ``--grid`` value: an int if it reads as one, else a float, else a bool
    (``true``/``false``, any case), else the text itself."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def parse_grid(items: list[str]) -> dict[str, list]:
    """``{"loss": [0, 0.1]}`` from ``["loss=0,0.1"]``: *items* are the ``--grid`` options,
    each ``NAME=VALUE[,VALUE...]`` (values read by :func:`grid_value`); raises
    :class:`UsageError` naming a malformed item or a parameter given twice."""
    grid: dict[str, list] = {}
    for item in items:
        name, sep, values = item.partition("=")
        name = name.strip()
        if not sep or not name or not values.strip():
            raise UsageError(f"--grid {item!r} must read NAME=VALUE[,VALUE...]")
        if name in grid:
            raise UsageError(f"--grid names parameter {name!r} twice")
        grid[name] = [grid_value(v.strip()) for v in values.split(",")]
    return grid


def _sweep(args) -> int:
    from ..errors import NetcosimError
    from ..sweep import run_sweep, verify_sweep
    from ..sweep.store import Store, describe_damage

    if args.scenario == "verify":
        if args.dir is None or args.grid or args.out or args.resume:
            raise UsageError("usage: netcosim sweep verify DIR")
        try:
            damage = verify_sweep(args.dir)
            meta = Store(args.dir).read_metadata()
        except NetcosimError as exc:
            raise UsageError(str(exc)) from None
        if meta is not None and meta.get("format", 1) < 2:
            raise UsageError(f"{args.dir!r} holds a sweep of format {meta.get('format', 1)}, written without the "
                             f"SHA-256 of its files: it cannot be verified")
        if not damage:
            print(f"ok: {args.dir}: {len(Store(args.dir).finished())} runs, every file matches its SHA-256")
            return 0
        print(f"damaged: {args.dir}: {len(damage)} file(s); netcosim sweep --resume {args.dir} re-runs their runs")
        for line in describe_damage(meta, damage, limit=10**9):
            print(f"  {line}")
        return 1
    if args.dir is not None:
        raise UsageError(f"unexpected argument {args.dir!r} (only 'netcosim sweep verify DIR' takes a directory "
                         f"as argument; give --out DIR)")
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())       # as `python -m` does: a module in the current directory is found
    common = dict(executor=args.executor, workers=args.workers, scheduler=args.scheduler, timeout=args.timeout,
                  quiet=args.quiet, retry_errors=args.retry_errors,
                  notify=lambda m: print(f"netcosim sweep: {m}", file=sys.stderr, flush=True))
    out = args.resume if args.resume is not None else args.out
    try:
        if args.resume is not None:
            if args.scenario is not None or args.grid or args.seeds is not None or args.out is not None \
                    or args.root_seed is not None:
                raise UsageError("--resume DIR takes the scenario, grid, seeds and output from DIR: "
                                 "give no SCENARIO, --grid, --seeds, --root-seed or --out with it")
            meta = Store(args.resume).read_metadata()
            if meta is None:
                raise UsageError(f"{args.resume!r} holds no sweep (no {Path(args.resume) / 'sweep.json'})")
            from ..sweep.scenario import resolve
            scenario = resolve(meta["scenario"], meta.get("scenario_file"))
            res = run_sweep(scenario, meta["cases"], meta["seeds"], root_seed=meta["root_seed"], out=args.resume,
                            fresh=args.fresh, **common)
        else:
            if args.scenario is None:
                raise UsageError("give a SCENARIO (package.module:function or path/file.py:function) or --resume DIR")
            if args.out is None:
                raise UsageError("--out DIR is required: the directory of the sweep's Parquet dataset")
            if not args.grid:
                raise UsageError("give at least one --grid NAME=VALUE[,VALUE...]")
            check_writable_dir(args.out, "--out")
            res = run_sweep(args.scenario, parse_grid(args.grid), 1 if args.seeds is None else args.seeds,
                            root_seed=args.root_seed or 0, out=args.out, fresh=args.fresh, **common)
    except NetcosimError as exc:
        raise UsageError(str(exc)) from None
    except SyntaxError as exc:            # the scenario's file does not parse: one line, as `netcosim run` says it
        raise _syntax_error(exc) from None
    except KeyboardInterrupt:
        kept = len(Store(out).finished()) if out is not None and Path(out).is_dir() else 0
        print(f"{chr(10) if sys.stderr.isatty() else ''}netcosim sweep: interrupted; the {kept} finished runs are "
              f"kept in {out}; resume with: netcosim sweep --resume {out}", file=sys.stderr)
        return 130
    s = res.summary
    print(f"{s['total']} runs: {s['ok']} ok, {s['error']} error, {s['timeout']} timeout, "
          f"{s['skipped']} already done; {res.path}")
    return 1 if s["error"] or s["timeout"] else 0


def add_parser(sub) -> None:
    """Add the ``sweep`` subcommand to the subparsers *sub* of the ``netcosim`` parser."""
    sw = sub.add_parser("sweep", help="run a scenario over a grid of cases and seeds into a Parquet dataset",
                        description="Run SCENARIO(params, seed) for every case of the grid and every seed; "
                                    "results go to the Parquet dataset --out DIR as runs finish (see "
                                    "docs/sweeps.md).  Exit status 1 if a run failed.  'netcosim sweep verify DIR' "
                                    "checks every file of the dataset in DIR against its recorded SHA-256 (exit "
                                    "status 1 if one is damaged).")
    sw.add_argument("scenario", nargs="?",
                    help="package.module:function or path/to/file.py:function, called as fn(params: dict, seed: int); "
                         "or 'verify'")
    sw.add_argument("dir", nargs="?", metavar="DIR", help="with verify: the sweep directory to check")
    sw.add_argument("--grid", action="append", default=[], metavar="NAME=V1,V2",
                    help="a parameter and its values (repeat for more parameters: their product is swept); each "
                         "value is read as an int, else a float, else true/false, else a string")
    sw.add_argument("--seeds", type=int, help="runs per case (default 1; cases x seeds at most 10**7 runs)")
    sw.add_argument("--root-seed", type=int, help="root of every run's seed (default 0)")
    sw.add_argument("--executor", choices=["pool", "dask", "serial"], default="pool",
                    help="where runs execute: local worker processes (default), Dask, or this process")
    sw.add_argument("--scheduler", metavar="tcp://HOST:8786", help="address of a Dask scheduler (implies dask)")
    sw.add_argument("--workers", type=int, help="worker processes of the pool or the local Dask cluster "
                                                "(default: one per CPU)")
    sw.add_argument("--timeout", type=float, metavar="S", help="wall-clock seconds one run may take (at most 1e9)")
    sw.add_argument("--out", metavar="DIR", help="directory of the sweep's Parquet dataset")
    sw.add_argument("--resume", metavar="DIR", help="continue the sweep stored in DIR (runs only the missing runs "
                                                    "and those whose files are damaged)")
    sw.add_argument("--retry-errors", action="store_true",
                    help="also run again the stored runs that failed (status error or timeout)")
    sw.add_argument("--fresh", action="store_true", help="discard a sweep found in --out and start over")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.set_defaults(fn=_sweep)
