"""``netcosim run EXPERIMENT``: find the experiment, call it with ``outdir`` (and ``quick``), say what it wrote."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import sys
from pathlib import Path

from ._common import UsageError, _syntax_error, check_writable_dir


def _load_module_from_file(given: str):
    path = Path(given)
    if not path.is_file():
        raise UsageError(f"no experiment file {given!r}")
    if path.suffix != ".py":
        raise UsageError(_not_python(given))
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


def _not_python(given: str) -> str:
    return (f"{given!r} is not a Python file (.py): an experiment or scenario is a function of a Python file "
            f"or module (path/to/file.py[:function], package.module[:function])")


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


#: The entry-point group of the experiments ``netcosim run NAME`` runs (``name = "module:function"``).
EXPERIMENT_GROUP = "netcosim.experiments"


def _registered() -> dict:
    """``{name: EntryPoint}`` of the group :data:`EXPERIMENT_GROUP` in every installed distribution
    (the first one wins if two register a name; nothing is imported)."""
    from importlib.metadata import entry_points
    found: dict = {}
    for ep in entry_points(group=EXPERIMENT_GROUP):
        found.setdefault(ep.name, ep)
    return found


def available_experiments() -> list[str]:
    """The NAMEs ``netcosim run NAME`` accepts: the entry points of the group ``netcosim.experiments``
    (netcosim's own in pyproject.toml, and those of any other installed package)."""
    return sorted(_registered())


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
    if not target.endswith(".py") and Path(target).suffix and Path(target).is_file():
        raise UsageError(_not_python(target))       # some.parquet: a file, but not one to import
    if target.endswith(".py") or "/" in target or "\\" in target:
        module = _load_module_from_file(target)
        where = f"file {target!r}"
    elif not sep and target in (registered := _registered()):
        ep = registered[target]
        where = f"experiment {target!r} (entry point {ep.value!r} of group {EXPERIMENT_GROUP!r})"
        module = _import_module(ep.module, f"{where}: no module {ep.module!r}")
        func = ep.attr or "main"
    elif sep or "." in target:
        module = _import_module(target, f"no module {target!r} (experiment {spec!r})")
        where = f"module {target!r}"
    else:
        import difflib
        known = sorted(registered)
        close = difflib.get_close_matches(target, known, n=1)
        raise UsageError(f"no experiment {target!r} (no entry point {target!r} in group {EXPERIMENT_GROUP!r})"
                         + (f"; did you mean {close[0]!r}?" if close else "")
                         + f" The experiments are: {', '.join(known) or 'none found'}")
    fn = getattr(module, func, None)
    if fn is None:
        raise UsageError(f"{where} has no function {func!r}")
    if not callable(fn):
        raise UsageError(f"{where}: {func!r} is not a function but {type(fn).__name__}")
    return fn


#: What ``netcosim run`` calls, said in the messages that refuse something else.
WHAT_IS_AN_EXPERIMENT = ("an experiment is a function main(outdir, quick=False) that writes its results "
                         "into outdir")


def _accepts(fn, keyword: str) -> bool:
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return True
    return keyword in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


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
    if inspect.isclass(fn):
        raise UsageError(f"{args.experiment!r} is a class ({label}), not an experiment entry point: "
                         f"{WHAT_IS_AN_EXPERIMENT}")
    if not _accepts(fn, "outdir"):
        try:
            sig = str(inspect.signature(fn))
        except (TypeError, ValueError):
            sig = "(...)"
        raise UsageError(f"{args.experiment!r} is not an experiment entry point: {label}{sig} takes no 'outdir' "
                         f"({WHAT_IS_AN_EXPERIMENT}; netcosim run calls FUNCTION(outdir=..., quick=...))")
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


def add_parser(sub) -> None:
    """Add the ``run`` subcommand to the subparsers *sub* of the ``netcosim`` parser."""
    r = sub.add_parser("run", help="run an experiment (calls its main(outdir=..., quick=...))")
    r.add_argument("experiment",
                   help="NAME of a registered experiment (entry point group netcosim.experiments, e.g. servo), "
                        "package.module[:function], or path/to/file.py[:function]")
    r.add_argument("--outdir", help="output directory (default: the experiment's own)")
    r.add_argument("--quick", action="store_true", help="pass quick=True: the experiment's short run")
    r.set_defaults(fn=_run)
