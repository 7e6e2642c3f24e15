"""Command line: ``netcosim run EXPERIMENT``, ``netcosim sweep SCENARIO``, ``netcosim sweep verify DIR``,
``netcosim hil SCENARIO --remote NODE`` and ``netcosim plot schedule|network TRACE``.

``run`` calls an experiment's entry point with ``outdir`` (and ``quick``) keyword
arguments.  EXPERIMENT is one of

* ``NAME``: the module ``experiments.NAME`` shipped with netcosim (e.g. ``servo``),
  its function ``main``;
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

``plot schedule`` draws a schedule table written by ``Trace.to_parquet``; ``plot network``
its network timeline (``network_schedule``, with ``frames`` when it lies beside it).

Bad arguments (unknown experiment, unreadable trace, empty time window, ...) print one
line naming the value on stderr and exit with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import inspect
import math
import os
import sys
from pathlib import Path

#: Columns a schedule table (``sim.trace.schedule()``) must have to be plotted.
SCHEDULE_COLUMNS = ("time", "node", "task", "state")


class UsageError(Exception):
    """A command-line argument the command cannot use; the message names it (exit status 2)."""


def _syntax_error(exc: SyntaxError) -> UsageError:
    """One line naming the file and line of *exc* (``file.py:3: SyntaxError: invalid syntax``)."""
    return UsageError(f"{exc.filename or '<unknown file>'}:{exc.lineno}: {type(exc).__name__}: {exc.msg}")


def _load_module_from_file(given: str):
    path = Path(given)
    if not path.is_file():
        raise UsageError(f"no experiment file {given!r}")
    name = path.stem
    if not name.isidentifier():
        raise UsageError(f"experiment file {given!r}: {name!r} is not a valid module name")
    directory = str(path.resolve().parent)
    if directory not in sys.path:
        sys.path.insert(0, directory)      # as `python path/to/file.py` does: siblings are importable
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None  # a .py path that exists always has one
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        del sys.modules[name]
        raise _syntax_error(exc) from None
    return module


def _import_module(name: str, what: str):
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        # only a missing target is a usage error; a missing dependency inside it is a real failure
        parts = name.split(".")
        if exc.name in {".".join(parts[:i]) for i in range(1, len(parts) + 1)}:
            raise UsageError(what) from None
        raise
    except SyntaxError as exc:
        raise _syntax_error(exc) from None


def available_experiments() -> list[str]:
    """The NAMEs ``netcosim run NAME`` accepts: the modules of the ``experiments`` package
    whose ``main`` takes ``outdir`` first (read from the sources, nothing is imported)."""
    import re
    spec = importlib.util.find_spec("experiments")
    names = set()
    for directory in (spec.submodule_search_locations or []) if spec is not None else []:
        for f in Path(directory).glob("*.py"):
            if not f.stem.startswith("_") and re.search(r"^def main\(\s*outdir\b",
                                                        f.read_text(encoding="utf-8", errors="replace"), re.M):
                names.add(f.stem)
    return sorted(names)


def resolve_experiment(spec: str):
    """The callable that ``netcosim run SPEC`` runs (see the module docstring for SPEC).

    Raises :class:`UsageError` naming *spec* if the module, file or function does not exist.
    """
    if not spec or not spec.strip():
        raise UsageError(f"empty experiment name {spec!r}")
    target, sep, func = spec.partition(":")
    if sep and len(target) == 1 and target.isalpha():      # a Windows drive letter, C:\...
        drive_rest, sep, func = func.partition(":")
        target = f"{target}:{drive_rest}"
    if sep and not func:
        raise UsageError(f"experiment {spec!r}: no function name after ':'")
    func = func or "main"
    if target.endswith(".py") or "/" in target or "\\" in target:
        module = _load_module_from_file(target)
        where = f"file {target!r}"
    elif sep or "." in target.removeprefix("experiments."):
        module = _import_module(target, f"no module {target!r} (experiment {spec!r})")
        where = f"module {target!r}"
    else:
        name = target.removeprefix("experiments.")
        try:
            module = _import_module(f"experiments.{name}", "")
        except UsageError:
            import difflib
            known = available_experiments()
            close = difflib.get_close_matches(name, known, n=1)
            raise UsageError(f"no experiment {name!r} (no module experiments.{name})"
                             + (f"; did you mean {close[0]!r}?" if close else "")
                             + f" The experiments are: {', '.join(known) or 'none found'}") from None
        where = f"experiments.{name}"
    fn = getattr(module, func, None)
    if fn is None:
        raise UsageError(f"{where} has no function {func!r}")
    if not callable(fn):
        raise UsageError(f"{where}: {func!r} is not a function but {type(fn).__name__}")
    return fn


def _accepts(fn, keyword: str) -> bool:
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return True
    return keyword in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def check_writable_dir(given: str | os.PathLike, what: str) -> Path:
    """*given* as a Path if it is, or could be made, a directory this process can write in.

    Nothing is created: the nearest existing ancestor must be a directory in which a
    (nameless, at once removed) temporary file can be made.  Raises :class:`UsageError`
    naming *what* and *given* otherwise.
    """
    import tempfile
    if not os.fspath(given).strip():
        raise UsageError(f"{what} must name a directory, got {os.fspath(given)!r}")
    path = Path(given)
    probe = path
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"{what} {os.fspath(given)!r} cannot be a directory: {str(probe)!r} is a file")
    try:
        tempfile.TemporaryFile(dir=probe).close()
    except OSError as exc:
        raise UsageError(f"{what} {os.fspath(given)!r} is not writable: cannot write in {str(probe)!r} "
                         f"({exc.strerror or exc})") from None
    return path


def _files(directory: str | os.PathLike | None) -> dict[str, int]:
    """``{path: mtime_ns}`` of every file under *directory* (none if it does not exist)."""
    out: dict[str, int] = {}
    if directory is None:
        return out
    for root, _, names in os.walk(os.fspath(directory)):
        for n in names:
            f = os.path.join(root, n)
            try:
                out[f] = os.stat(f).st_mtime_ns
            except OSError:
                pass
    return out


def _short(value) -> str:
    """A one-line description of a returned value, at most ~80 characters."""
    shape = getattr(value, "shape", None)
    if shape is not None and not callable(shape):
        return f"a {type(value).__name__} of shape {tuple(shape)}"
    text = " ".join(repr(value).split())
    return text if len(text) <= 80 else text[:77] + "..."


def _run(args) -> int:
    fn = resolve_experiment(args.experiment)
    label = f"{getattr(fn, '__module__', None) or '?'}.{getattr(fn, '__qualname__', None) or args.experiment}"
    if not _accepts(fn, "outdir"):
        try:
            sig = str(inspect.signature(fn))
        except (TypeError, ValueError):
            sig = "(...)"
        raise UsageError(f"{args.experiment!r} is not an experiment entry point: {label}{sig} takes no 'outdir' "
                         "(netcosim run calls FUNCTION(outdir=..., quick=...) and reports what it wrote)")
    kwargs = {}
    if args.outdir is not None:
        outdir: str | os.PathLike | None = check_writable_dir(args.outdir, "--outdir")
        kwargs["outdir"] = args.outdir
    else:
        try:
            param = inspect.signature(fn).parameters.get("outdir")
        except (TypeError, ValueError):
            param = None
        outdir = None
        if param is not None and param.default is param.empty and param.kind is not param.VAR_KEYWORD:
            raise UsageError(f"experiment {args.experiment!r} has no default output directory: give --outdir DIR")
        if param is not None and isinstance(param.default, (str, os.PathLike)) and os.fspath(param.default):
            outdir = param.default
            check_writable_dir(outdir, f"the output directory of {args.experiment!r} (change it with --outdir)")
    if args.quick:
        if not _accepts(fn, "quick"):
            raise UsageError(f"experiment {args.experiment!r} has no quick mode (its function takes no 'quick')")
        kwargs["quick"] = True
    call = f"{label}({', '.join(f'{k}={v!r}' for k, v in kwargs.items())})"
    before = _files(outdir)
    result = fn(**kwargs)
    after = _files(outdir)
    written = sum(1 for f, t in after.items() if before.get(f) != t)
    if outdir is None:
        print(f"ran {call}: it returned {_short(result)}")
    elif written:
        print(f"ran {call}: wrote {written} file{'s' * (written != 1)} to {os.fspath(outdir)}")
    else:
        print(f"ran {call}: it returned {_short(result)} and wrote no file to {os.fspath(outdir)}")
    return 0


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
    from .errors import ConfigurationError, ConfigurationTypeError
    network = args.kind == "network"
    if not network and (args.network is not None or args.frames is not None):
        raise UsageError(f"{'--network' if args.network is not None else '--frames'} is an option of "
                         "`netcosim plot network`, not of `plot schedule`")
    t_range = time_window(args.t0, args.t1)
    output = args.output if args.output is not None else f"{args.kind}.png"
    if not output.strip():
        raise UsageError(f"-o/--output must name an image file, got {output!r}")
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

    from . import plot
    from .network import plot as network_plot
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
    """``{"loss": [0, 0.1]}`` from ``["loss=0,0.1"]``; raises :class:`UsageError` naming a
    malformed item or a parameter given twice."""
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
    from .errors import NetcosimError
    from .sweep import run_sweep, verify_sweep
    from .sweep.store import Store, describe_damage

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
            from .sweep.scenario import resolve
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
            res = run_sweep(args.scenario, parse_grid(args.grid), 1 if args.seeds is None else args.seeds,
                            root_seed=args.root_seed or 0, out=args.out, fresh=args.fresh, **common)
    except NetcosimError as exc:
        raise UsageError(str(exc)) from None
    except KeyboardInterrupt:
        kept = len(Store(out).finished()) if out is not None and Path(out).is_dir() else 0
        print(f"{chr(10) if sys.stderr.isatty() else ''}netcosim sweep: interrupted; the {kept} finished runs are "
              f"kept in {out}; resume with: netcosim sweep --resume {out}", file=sys.stderr)
        return 130
    s = res.summary
    print(f"{s['total']} runs: {s['ok']} ok, {s['error']} error, {s['timeout']} timeout, "
          f"{s['skipped']} already done; {res.path}")
    return 1 if s["error"] or s["timeout"] else 0


def _names(csv: str | None) -> list[str] | None:
    """``"a,b"`` -> ``["a", "b"]`` (None stays None: all)."""
    return None if csv is None else [n.strip() for n in csv.split(",") if n.strip()]


def _plant_deviation(hil_sim, ref_sim) -> list[tuple[str, str, float]]:
    """``(plant, signal, max |hil - reference|)`` for every plant output (``y.*``; every
    plant signal if none) both runs logged (the reference interpolated linearly on the
    HIL run's times)."""
    import numpy as np
    a, b = hil_sim.trace.signals(), ref_sim.trace.signals()
    out = []
    a = a[a["source"].isin(list(hil_sim.plants))]
    if a["signal"].astype(str).str.startswith("y.").any():     # the outputs, when the plants log them
        a = a[a["signal"].astype(str).str.startswith("y.")]
    for (src, sig), ga in a.groupby(["source", "signal"], observed=True):
        gb = b[(b["source"] == src) & (b["signal"] == sig)]
        if len(ga) and len(gb):
            diff = ga["value"].to_numpy() - np.interp(ga["time"], gb["time"], gb["value"])
            out.append((str(src), str(sig), float(np.max(np.abs(diff)))))
    return out


def _hil_report(run, args, compare_with) -> None:
    import numpy as np
    remote = run.remote
    c = remote.counters()
    lat = run.lateness
    resp = remote.response_times()
    print(f"requests to the remote: {c['published']} published ({c['overruns']} overruns, {c['unserved']} unserved), "
          f"replies applied: {c['received']} (+{c['after_end']} after the end), expired: {c['expired']}, "
          f"dropped: {c['dropped']}, refused claimants: {c['refused']}")
    if len(resp):
        q = np.quantile(resp, [0.5, 0.9, 0.99]) * 1e3
        print(f"response time (simulated): median {q[0]:.3f} ms, p90 {q[1]:.3f} ms, p99 {q[2]:.3f} ms, "
              f"max {resp.max() * 1e3:.3f} ms over {len(resp)} replies")
    print(f"lateness: median <= {lat.quantile(0.5) * 1e3:.3f} ms, p99 <= {lat.quantile(0.99) * 1e3:.3f} ms, "
          f"max {lat.max * 1e3:.3f} ms, overruns {lat.overruns} of {lat.events} events")
    if run.process is not None:
        print(f"remote process: {run.process}")
    print(remote.events().to_string(index=False))
    if run.failure is not None:
        print(f"the run failed at t = {run.sim.now:.6f} s: {type(run.failure).__name__}: {run.failure}")
    for label, ref in compare_with:
        rows = _plant_deviation(run.sim, ref)
        worst = max(rows, key=lambda r: r[2]) if rows else None
        print(f"max deviation from the {label}: " + (f"{worst[2]:.3e} ({worst[0]}.{worst[1]})" if worst else
                                                       "no plant signal logged in both runs"))


def _checked(check, value, flag: str, **kw):
    """``check(value, flag, **kw)`` (a :mod:`netcosim.validate` function), its error a :class:`UsageError`."""
    from .errors import ConfigurationError, ConfigurationTypeError
    try:
        return check(value, flag, **kw)
    except (ConfigurationError, ConfigurationTypeError) as exc:
        raise UsageError(str(exc)) from None


#: Zenoh link protocols whose address is HOST:PORT.
_HOST_PORT_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")


def check_endpoint(endpoint: str, flag: str) -> str:
    """*endpoint* if it reads as a Zenoh endpoint ``<protocol>/<address>[?<metadata>][#<config>]``
    (HOST:PORT for tcp, udp, tls, quic, ws; port 0, "any", only for ``--listen``); raises
    :class:`UsageError` naming *flag* and *endpoint* otherwise."""
    import re
    m = re.fullmatch(r"([a-z][a-z0-9-]*)/([^?#]+)(\?[^#]*)?(#.*)?", endpoint)
    if m is None:
        raise UsageError(f"{flag} {endpoint!r} is not a Zenoh endpoint <protocol>/<address> "
                         "(e.g. tcp/127.0.0.1:7447)")
    if m.group(1) in _HOST_PORT_PROTOCOLS:
        host, colon, port = m.group(2).rpartition(":")
        lowest = 0 if flag == "--listen" else 1
        if not (colon and host and port.isdigit() and lowest <= int(port) <= 65535):
            raise UsageError(f"{flag} {endpoint!r}: a {m.group(1)} address is HOST:PORT with a port in "
                             f"{lowest}..65535")
    return endpoint


def _check_hil_options(args) -> None:
    """Every ``hil`` option that does not need the scenario, before anything is built or opened."""
    import shlex

    from . import validate
    from .transport.wire import MAX_VALUES
    _checked(validate.duration, args.until, "--until", positive=True, kind="a positive number of seconds")
    _checked(validate.positive, args.factor, "--factor",
             kind="a positive finite number (wall-clock seconds per simulated second)")
    for flag, value in (("--period", args.period), ("--deadline", args.deadline)):
        if value is not None:
            _checked(validate.duration, value, flag, positive=True, kind="a positive number of seconds")
    if args.max_outstanding is not None:
        _checked(validate.count, args.max_outstanding, "--max-outstanding", minimum=1)
    if args.reply_values is not None:
        _checked(validate.count, args.reply_values, "--reply-values", minimum=0, maximum=MAX_VALUES)
    _checked(validate.bits, args.size_bits, "--size-bits", allow_zero=False)
    _checked(validate.real, args.lease, "--lease", lo=0.01, hi=3600.0, kind="a number of seconds in [0.01, 3600]")
    _checked(validate.non_negative, args.wait, "--wait", kind="a non-negative finite number of seconds")
    for flag, endpoints in (("--listen", args.listen), ("--connect", args.connect)):
        for e in endpoints:
            check_endpoint(e, flag)
    if args.zenoh_config is not None and not Path(args.zenoh_config).is_file():
        raise UsageError(f"--zenoh-config {args.zenoh_config!r}: no such file")
    try:
        words = shlex.split(args.remote_cmd)
    except ValueError as exc:
        raise UsageError(f"--remote-cmd {args.remote_cmd!r}: {exc}") from None
    if not words:
        raise UsageError(f"--remote-cmd must name a program, got {args.remote_cmd!r}")
    for flag, names in (("--outputs", args.outputs), ("--inputs", args.inputs), ("--abort-on", args.abort_on)):
        if names is not None and not _names(names):
            raise UsageError(f"{flag} {names!r} names nothing (give NAME[,NAME...])")
    check_writable_dir(args.out, "--out")


def _zenoh_reason(exc: BaseException) -> str:
    """The first line of a Zenoh error without the Rust source location it ends with."""
    import re
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return re.sub(r"\s+at \S+\.rs:\d+\.?$", "", text)


def _check_plant_ports(plant, args) -> None:
    """``--outputs`` / ``--inputs`` name ports of *plant*."""
    from .errors import ConfigurationTypeError
    for flag, given, select in (("--outputs", args.outputs, plant.output), ("--inputs", args.inputs, plant.input)):
        if given is not None:
            try:
                select(_names(given))
            except (KeyError, IndexError, ConfigurationTypeError) as exc:
                raise UsageError(f"{flag} {given!r}: {exc.args[0] if exc.args else exc}") from None


def _hil(args) -> int:
    import shlex
    from pathlib import Path

    from .errors import NetcosimError
    from .transport.harness import remote_command, run_with_remote
    from .transport.remote import DROP_REASONS, LOSS_EVENTS, RemoteNode, RemotePlantIO
    from .transport.session import LOOPBACK, new_run_id, open_session

    if ":" not in args.scenario:
        raise UsageError(f"scenario {args.scenario!r}: give package.module:function or path/to/file.py:function")
    _check_hil_options(args)
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    build = resolve_experiment(args.scenario)
    built = build()
    sim = built[0] if isinstance(built, tuple) else built
    is_node = args.remote in getattr(sim, "nodes", {})
    if not is_node and args.remote not in getattr(sim, "plants", {}):
        raise UsageError(f"scenario {args.scenario!r} has no node or plant {args.remote!r}")
    plant_options = [o for o, v in (("--outputs", args.outputs), ("--inputs", args.inputs), ("--extra", args.extra))
                     if v is not None]
    if is_node and plant_options:
        raise UsageError(f"{args.remote!r} is a node, not a plant: {', '.join(plant_options)} given")
    if not is_node and args.period is None:
        raise UsageError(f"{args.remote!r} is a plant: give its sampling period with --period SECONDS")
    if not is_node:
        _check_plant_ports(sim.plants[args.remote], args)
    if is_node and args.period is None and args.deadline is None:
        raise UsageError(f"{args.remote!r} is a node: give the period of the requests it serves with "
                         "--period SECONDS (the default deadline), or --deadline SECONDS")
    abort_on = _names(args.abort_on) or []
    bad = sorted(set(abort_on) - set(DROP_REASONS) - set(LOSS_EVENTS))
    if bad:
        raise UsageError(f"--abort-on {', '.join(bad)}: not one of {', '.join(DROP_REASONS + LOSS_EVENTS)}")
    if args.replay is not None and not args.compare:
        raise UsageError("--replay needs --compare")
    replay = None if args.replay is None else resolve_experiment(args.replay)
    extra = None if args.extra is None else resolve_experiment(args.extra)(built)
    listen = args.listen or ([] if args.connect else [LOOPBACK])
    run = new_run_id()
    kw = {} if args.zenoh_config is None else {"config": args.zenoh_config}
    try:
        session = open_session(listen=listen, connect=args.connect, lease=args.lease, **kw)
    except (OSError, ValueError, RuntimeError) as e:
        raise UsageError(str(e)) from None
    except Exception as e:      # zenoh.ZError (not importable without the zenoh extra): an endpoint Zenoh refuses
        if type(e).__name__ != "ZError":
            raise
        where = " ".join(f"--listen {x}" for x in args.listen) + " ".join(f" --connect {x}" for x in args.connect)
        raise UsageError(f"cannot open a Zenoh session ({where.strip() or 'default endpoints'}): "
                         f"{_zenoh_reason(e)}") from None
    try:
        common = dict(deadline=args.deadline, max_outstanding=args.max_outstanding, loss_policy=args.loss_policy,
                      abort_on=abort_on, encoding=args.encoding, factor=args.factor)
        remote: RemoteNode | RemotePlantIO
        try:
            if is_node:
                remote = RemoteNode(sim, args.remote, session, run=run, size_bits=args.size_bits, period=args.period,
                                    reply_values=args.reply_values, **common)
            else:
                remote = RemotePlantIO(sim, sim.plants[args.remote], session, run=run, period=args.period,
                                       outputs=_names(args.outputs), inputs=_names(args.inputs), extra=extra,
                                       **common)
        except NetcosimError as e:
            raise UsageError(str(e)) from None
        cmd = remote_command(shlex.split(args.remote_cmd), run=run, node=args.remote,
                             endpoints=args.connect or session.endpoints, lease=args.lease,
                             session=remote.session_id, zenoh_config=args.zenoh_config, encoding=args.encoding)
        try:
            result = run_with_remote(sim, remote, args.until, cmd, spawn=False, connect_timeout=args.wait)
        except TimeoutError as e:
            print(f"netcosim hil: {e}", file=sys.stderr)
            return 1
    finally:
        session.close()
    compare_with = []
    if args.compare:
        ref_built = build()
        ref = ref_built[0] if isinstance(ref_built, tuple) else ref_built
        ref.run(until=args.until)
        compare_with.append(("all-simulated run", ref))
        if replay is not None:
            compare_with.append(("replay with the measured response times", replay(args.until, remote.requests())))
    _hil_report(result, args, compare_with)
    out = Path(args.out) / run
    result.save(out)
    print(f"trace and counters written to {out}")
    return 1 if result.failure is not None else 0


def build_parser() -> argparse.ArgumentParser:
    """The ``netcosim`` argument parser."""
    p = argparse.ArgumentParser(prog="netcosim", description=__doc__.splitlines()[0],
                                epilog="\n".join(__doc__.splitlines()[2:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run an experiment (calls its main(outdir=..., quick=...))")
    r.add_argument("experiment",
                   help="NAME of a module in experiments/ (e.g. servo), package.module[:function], "
                        "or path/to/file.py[:function]")
    r.add_argument("--outdir", help="output directory (default: the experiment's own)")
    r.add_argument("--quick", action="store_true", help="pass quick=True: the experiment's short run")
    r.set_defaults(fn=_run)
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
    sw.add_argument("--seeds", type=int, help="runs per case (default 1)")
    sw.add_argument("--root-seed", type=int, help="root of every run's seed (default 0)")
    sw.add_argument("--executor", choices=["pool", "dask", "serial"], default="pool",
                    help="where runs execute: local worker processes (default), Dask, or this process")
    sw.add_argument("--scheduler", metavar="tcp://HOST:8786", help="address of a Dask scheduler (implies dask)")
    sw.add_argument("--workers", type=int, help="worker processes of the pool or the local Dask cluster "
                                                "(default: one per CPU)")
    sw.add_argument("--timeout", type=float, metavar="S", help="wall-clock seconds one run may take")
    sw.add_argument("--out", metavar="DIR", help="directory of the sweep's Parquet dataset")
    sw.add_argument("--resume", metavar="DIR", help="continue the sweep stored in DIR (runs only the missing runs "
                                                    "and those whose files are damaged)")
    sw.add_argument("--retry-errors", action="store_true",
                    help="also run again the stored runs that failed (status error or timeout)")
    sw.add_argument("--fresh", action="store_true", help="discard a sweep found in --out and start over")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.set_defaults(fn=_sweep)
    h = sub.add_parser("hil", help="run a scenario in real time with one node in another process (Zenoh)",
                       description="Build SCENARIO, make NODE remote, print the command that starts the remote "
                                   "side, wait for it, run in real time (see docs/hil.md).")
    h.add_argument("scenario", help="package.module:function or path/to/file.py:function returning a Simulation "
                                    "(or a tuple starting with one)")
    h.add_argument("--remote", required=True, metavar="NAME",
                   help="the node whose tasks run in the remote process, or a plant the process reads and drives "
                        "(remote plant I/O: give --period)")
    h.add_argument("--until", type=float, default=5.0, help="simulated seconds to run (default 5)")
    h.add_argument("--factor", type=float, default=1.0,
                   help="wall-clock seconds per simulated second (default 1: real time)")
    h.add_argument("--period", type=float, metavar="SECONDS",
                   help="node: the period of the requests it serves (the default deadline); plant: the sampling "
                        "period (s) of the outputs sent to the process")
    h.add_argument("--deadline", type=float, metavar="SECONDS",
                   help="a reply must arrive within this many simulated seconds of its request (default: --period)")
    h.add_argument("--reply-values", type=int, metavar="N",
                   help="node: number of values every reply must carry (default: any)")
    h.add_argument("--max-outstanding", type=int, metavar="N",
                   help="requests that may wait for a reply at once (default: ceil(deadline / period) + 1)")
    h.add_argument("--abort-on", metavar="REASON,...",
                   help="end the run (trace kept, END sent, exit status 1) on these drop reasons or on expired, "
                        "overrun, lost (default: never; they are dropped and counted)")
    h.add_argument("--outputs", metavar="A,B", help="remote plant: the outputs sent, by name (default all)")
    h.add_argument("--inputs", metavar="A,B", help="remote plant: the inputs the process writes (default all)")
    h.add_argument("--extra", metavar="MODULE:FUNCTION",
                   help="remote plant: FUNCTION(what SCENARIO returned) gives extra(t), whose values follow the "
                        "outputs in every sample (e.g. a reference)")
    h.add_argument("--connect", action="append", default=[], metavar="tcp/HOST:PORT",
                   help="a Zenoh router (or peer) to connect to; then nothing listens unless --listen is given")
    h.add_argument("--listen", action="append", default=[], metavar="tcp/HOST:PORT",
                   help="endpoint to listen on (default tcp/127.0.0.1:0 without --connect)")
    h.add_argument("--zenoh-config", metavar="PATH",
                   help="a Zenoh configuration file for both sides (authentication, TLS; docs/hil_security.md)")
    h.add_argument("--encoding", choices=["ncsm", "cdr"], default="ncsm",
                   help="message encoding: ncsm (native, default) or cdr (CDR on rmw_zenoh keys, for ROS 2 tools)")
    h.add_argument("--size-bits", type=int, default=80, help="size (bits) of each message the remote sends")
    h.add_argument("--loss-policy", choices=["hold", "zero"], default="hold",
                   help="at a lost reply (expired, overrun, remote lost): keep the last command (hold) or send "
                        "zeros (zero)")
    h.add_argument("--lease", type=float, default=1.0, help="liveliness lease (s): a silent remote is lost after it")
    h.add_argument("--wait", type=float, default=60.0, help="seconds to wait for the remote side to connect")
    h.add_argument("--remote-cmd", default="python -m netcosim.transport.client",
                   help="the remote program, printed with --run/--node/--session/--connect (default: the echo "
                        "process; a leading 'python' is the running interpreter)")
    h.add_argument("--out", default="results/hil", metavar="DIR",
                   help="write the trace, the hil tables and the counters to DIR/<run id> (default results/hil)")
    h.add_argument("--compare", action="store_true",
                   help="then run SCENARIO all-simulated and print the largest deviation of the plant signals")
    h.add_argument("--replay", metavar="MODULE:FUNCTION",
                   help="with --compare: FUNCTION(until, requests) runs the all-simulated scenario replaying the "
                        "measured response times (e.g. experiments.hil_servo:run_replay)")
    h.set_defaults(fn=_hil)
    pl = sub.add_parser("plot", help="plot a saved trace (task schedule or network timeline)",
                        description="Draw a table written by Trace.to_parquet as a PNG: `schedule` a task "
                                    "schedule (schedule.parquet), `network` the network timeline "
                                    "(network_schedule.parquet; the frames.parquet next to it adds a cross per "
                                    "lost frame and a triangle per retransmission).  --t0 alone plots from t0 to "
                                    "the end of the trace, --t1 alone from its start.  The image's folder must "
                                    "exist.")
    pl.add_argument("kind", choices=["schedule", "network"])
    pl.add_argument("trace", help="Parquet file written by Trace.to_parquet: schedule.parquet (schedule) or "
                                  "network_schedule.parquet (network)")
    pl.add_argument("-o", "--output", help="image to write (default KIND.png: schedule.png or network.png)")
    pl.add_argument("--node", help="plot only this node (schedule: its tasks; network: its row)")
    pl.add_argument("--network", help="network: the network to plot (needed if the table holds several)")
    pl.add_argument("--frames", metavar="PATH",
                    help="network: the frames table for the loss and retransmission markers (default: the "
                         "frames.parquet next to TRACE, if any)")
    pl.add_argument("--t0", type=float, help="window start in seconds (default: start of the trace)")
    pl.add_argument("--t1", type=float, help="window end in seconds (default: end of the trace; --t0 alone "
                                             "plots from t0 to the end)")
    pl.set_defaults(fn=_plot)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line with *argv* (default ``sys.argv[1:]``); returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return args.fn(args)
    except UsageError as exc:
        print(f"netcosim {args.cmd}: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
