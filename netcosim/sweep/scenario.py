"""The scenario of a sweep: a function ``fn(params: dict, seed: int) -> dict``, found by name.

A scenario is given as a callable or as text:

* ``package.module:function``: that function of an importable module;
* ``path/to/file.py:function``: that function of a Python file, loaded as a module
  named after the file (its directory is put first on ``sys.path``).

Worker processes find the scenario again by its :class:`ScenarioRef` (module name,
function name and the module's file as a fallback), so a scenario must be defined at
the top level of a module or file; a lambda or a nested function runs only with the
serial executor.
"""

from __future__ import annotations

import ast
import hashlib
import importlib
import importlib.util
import inspect
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..errors import ConfigurationError, ConfigurationTypeError

__all__ = ["ScenarioRef", "resolve", "reference", "source_sha256", "code_digest"]


@dataclass(frozen=True)
class ScenarioRef:
    """Where a scenario lives: ``module`` (importable name), ``function`` (qualified name in
    it) and ``file`` (the module's source file, loaded directly where the module is not
    importable, e.g. on a worker with another ``sys.path``; ``None`` if unknown)."""

    module: str
    function: str
    file: str | None

    @property
    def spec(self) -> str:
        """The text form ``module:function`` (``/abs/path/file.py:function`` for a file)."""
        if self.file is not None and not _importable(self.module):
            return f"{self.file}:{self.function}"
        return f"{self.module}:{self.function}"


def _importable(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def _load_file(path: Path) -> Any:
    name = path.stem
    if not name.isidentifier():
        raise ConfigurationError(f"scenario file {str(path)!r}: {name!r} is not a valid module name")
    loaded = sys.modules.get(name)
    loaded_file = getattr(loaded, "__file__", None)
    if loaded_file and Path(loaded_file).resolve() == path:
        return loaded
    directory = str(path.parent)
    if directory not in sys.path:
        sys.path.insert(0, directory)
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _attr(module: Any, qualname: str, spec: str) -> Callable:
    obj = module
    for part in qualname.split("."):
        if not hasattr(obj, part):
            raise ConfigurationError(f"scenario {spec!r}: {getattr(module, '__name__', module)!r} "
                                     f"has no attribute {qualname!r}")
        obj = getattr(obj, part)
    if not callable(obj):
        raise ConfigurationTypeError(f"scenario {spec!r} is not callable but {type(obj).__name__}")
    return obj


def resolve(spec: str, file: str | None = None) -> Callable:
    """The function *spec* (``module:function`` or ``path/file.py:function``) names.

    *file*: the module's source file, loaded if the module cannot be imported by name.
    Raises :class:`~netcosim.errors.ConfigurationError` naming *spec* if the module, file
    or function does not exist, :class:`~netcosim.errors.ConfigurationTypeError` if it
    is not callable.
    """
    if not isinstance(spec, str):
        raise ConfigurationTypeError(f"scenario must be a callable or 'module:function', got {spec!r}")
    target, sep, func = spec.rpartition(":")
    if not sep or not target or not func:
        raise ConfigurationError(f"scenario {spec!r} must be 'package.module:function' or "
                                 f"'path/to/file.py:function'")
    if target.endswith(".py") or "/" in target or "\\" in target:
        path = Path(target).resolve()
        if not path.is_file():
            raise ConfigurationError(f"scenario {spec!r}: no file {target!r}")
        module = _load_file(path)
    else:
        try:
            module = importlib.import_module(target)
        except ModuleNotFoundError as exc:
            parts = target.split(".")
            if exc.name not in {".".join(parts[:i]) for i in range(1, len(parts) + 1)}:
                raise
            if file is not None and Path(file).is_file():
                module = _load_file(Path(file).resolve())
            else:
                raise ConfigurationError(f"scenario {spec!r}: no module {target!r}") from None
    return _attr(module, func, spec)


def reference(scenario: Any) -> tuple[Callable, ScenarioRef | None]:
    """``(function, ref)`` for a scenario given as a callable or as text; ``ref`` is
    ``None`` for a callable that worker processes cannot find (a lambda, a nested
    function, an object without a module)."""
    if isinstance(scenario, str):
        fn = resolve(scenario)
        target = scenario.rpartition(":")[0]
        if target.endswith(".py") or "/" in target or "\\" in target:
            path = Path(target).resolve()
            return fn, ScenarioRef(path.stem, scenario.rpartition(":")[2], str(path))
        mod = sys.modules.get(target)
        return fn, ScenarioRef(target, scenario.rpartition(":")[2], getattr(mod, "__file__", None))
    if not callable(scenario):
        raise ConfigurationTypeError(f"scenario must be a callable fn(params, seed) or 'module:function', "
                                     f"got {scenario!r}")
    module = getattr(scenario, "__module__", None)
    qualname = getattr(scenario, "__qualname__", None)
    if not module or not qualname or "<" in qualname:
        return scenario, None
    mod = sys.modules.get(module)
    file = getattr(mod, "__file__", None)
    file = str(Path(file).resolve()) if file else None
    if module == "__main__":
        if file is None:
            return scenario, None
        return scenario, ScenarioRef(Path(file).stem, qualname, file)
    return scenario, ScenarioRef(module, qualname, file)


def _strip_docstrings(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                node.body = body[1:]
    return tree


def _definition_name(stmt: ast.stmt) -> str:
    if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
        return stmt.name
    if isinstance(stmt, ast.Assign):
        return ", ".join(ast.unparse(t) for t in stmt.targets)
    if isinstance(stmt, (ast.AnnAssign, ast.AugAssign)):
        return ast.unparse(stmt.target)
    if isinstance(stmt, (ast.Import, ast.ImportFrom)):
        return "imports"
    return "module-level statements"


def code_digest(fn: Callable) -> tuple[str | None, dict[str, str]]:
    """The identity of the code of the module defining *fn* (of *fn* alone if the
    module's source is not available): ``(sha256, {definition: sha256})``, the SHA-256
    (hex) of the module's syntax tree without docstrings (``ast.dump``: comments,
    docstrings, blank lines and formatting do not count, a changed statement or constant
    does), and the same per top-level definition (function, class, assignment,
    ``imports``), to say what changed.  Without source (a lambda inside a longer
    expression, a function built at run time): the SHA-256 of its code object's
    instructions, constants and names.  ``(None, {})`` if it has neither."""
    for obj in (inspect.getmodule(fn), fn):
        if obj is None:
            continue
        try:
            source = textwrap.dedent(inspect.getsource(obj))
            tree = _strip_docstrings(ast.parse(source))
        except (OSError, TypeError, SyntaxError, ValueError):
            continue
        assert isinstance(tree, ast.Module)
        parts: dict[str, list[str]] = {}
        for stmt in tree.body:
            parts.setdefault(_definition_name(stmt), []).append(ast.dump(stmt))
        per = {k: hashlib.sha256("\n".join(v).encode()).hexdigest() for k, v in parts.items()}
        return hashlib.sha256(ast.dump(tree).encode()).hexdigest(), per
    code = getattr(fn, "__code__", None)
    if code is not None:            # no source (a lambda inside an expression, a compiled function): its bytecode
        name = getattr(fn, "__qualname__", "function")
        sha = hashlib.sha256(_code_text(code).encode()).hexdigest()
        return sha, {name: sha}
    return None, {}


def _code_text(code: Any) -> str:
    """The instructions, constants and names of a code object (not its line numbers)."""
    consts = [_code_text(c) if inspect.iscode(c) else repr(c) for c in code.co_consts]
    return repr((code.co_code.hex(), consts, code.co_names, code.co_varnames))


def source_sha256(fn: Callable) -> str | None:
    """The SHA-256 of the code of the module defining *fn* (:func:`code_digest`):
    comments, docstrings and formatting do not change it."""
    return code_digest(fn)[0]
