"""The layering of ``netcosim/``: no import cycle, and the framework knows nothing of
the plants, controllers or experiments built on it; no import cycle inside ``plants/``
or ``controllers/`` either (each package read against itself).

Imports are read from the source with :mod:`ast`, including those inside functions
(a lazy import is still a dependency) and those under ``if TYPE_CHECKING:`` (an
annotation-only import is still a cycle for the reader and the type checker); a module
name given as a literal to ``importlib.import_module`` counts too for the rule on the
applications.  A package's ``__init__`` re-exporting its submodules is not counted as a
dependency of those submodules on the package.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "netcosim"
#: the repository's folders built on the framework (installed under its namespace)
APPLICATIONS = ("plants", "controllers", "experiments")


#: packages checked for cycles, each against itself
CYCLE_FREE = (PKG, ROOT / "plants", ROOT / "controllers")


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[0] in APPLICATIONS:    # installed as netcosim.plants ... (pyproject package-dir)
        parts.insert(0, "netcosim")
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path, typing: bool = True) -> set[str]:
    """Absolute names of every module *path* imports (at module level, inside a function,
    and, unless ``typing=False``, under ``if TYPE_CHECKING:``)."""
    return _imports_of(ast.parse(path.read_text(), str(path)), _module_name(path), path.name == "__init__.py",
                       typing)


def _imports_of(tree: ast.AST, name: str, is_package: bool = False, typing: bool = True) -> set[str]:
    package = name if is_package else name.rpartition(".")[0]
    out: set[str] = set()
    typing_only = set() if typing else {
        id(n) for top in ast.walk(tree) if isinstance(top, ast.If)
        and isinstance(top.test, ast.Name) and top.test.id == "TYPE_CHECKING"
        for stmt in top.body for n in ast.walk(stmt)}
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)  # `from pkg import submodule`
    return out


def _graph(pkg: Path = PKG, typing: bool = True) -> dict[str, set[str]]:
    """Module -> the modules of *pkg* it imports (``typing=False``: at run time only)."""
    modules = {_module_name(p): p for p in pkg.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        deps = {d for d in _imports(path, typing) if d in modules and d != name}
        if path.name != "__init__.py":
            # importing netcosim.x.y runs netcosim/__init__ and netcosim/x/__init__: not a real edge back
            deps = {d for d in deps if not name.startswith(d + ".")}
        graph[name] = deps
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_graph_is_read_from_the_code():
    g = _graph()
    assert "netcosim.clock" in g["netcosim.kernel.node"]
    assert "netcosim.kernel.node" in g["netcosim.sim"]  # Simulation.node builds a Node (lazily)


#: cycles waiting for a file another change holds: lifecycle.py annotates with Interface
#: under TYPE_CHECKING (to become a small Protocol there), interface.py builds an Attempt
KNOWN_CYCLES: list[list[str]] = []


@pytest.mark.parametrize("pkg", CYCLE_FREE, ids=lambda p: p.name)
def test_no_import_cycle(pkg):
    assert [c for c in _cycles(_graph(pkg)) if c not in KNOWN_CYCLES] == []


def test_the_other_packages_are_read_too():
    assert "netcosim.controllers.nmpc.ocp" in _graph(ROOT / "controllers")["netcosim.controllers.nmpc.rti"]
    assert _graph(ROOT / "plants")


def test_the_cycle_detector_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == [["a", "b", "c"]]


def test_a_cycle_through_type_checking_only_is_found():
    a = ast.parse("from .b import g\n")
    b = ast.parse("from typing import TYPE_CHECKING\n"
                  "if TYPE_CHECKING:\n"
                  "    from .a import F\n"
                  "def g(f: F) -> None: ...\n")
    modules = {"p.a": a, "p.b": b}
    graph = {n: {d for d in _imports_of(t, n) if d in modules and d != n} for n, t in modules.items()}
    assert graph == {"p.a": {"p.b"}, "p.b": {"p.a"}}
    assert _cycles(graph) == [["p.a", "p.b"]]
    assert _imports_of(b, "p.b", typing=False) == {"typing", "typing.TYPE_CHECKING"}


#: Functions that import (or find) a module named by their first argument.
_IMPORTERS = {"import_module", "__import__", "find_spec"}


def _string_imports(tree: ast.AST) -> set[str]:
    """The module names given as a literal (or the literal start of an f-string) to
    ``importlib.import_module``, ``__import__`` or ``importlib.util.find_spec``."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and node.args):
            continue
        f = node.func
        name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
        if name not in _IMPORTERS:
            continue
        arg = node.args[0]
        if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
            out.add(arg.value)
        elif isinstance(arg, ast.JoinedStr):
            head = "".join(v.value for v in arg.values[:1] if isinstance(v, ast.Constant))
            if head:
                out.add(head)
    return out


def _application_imports(path: Path) -> list[str]:
    deps = _imports(path) | _string_imports(ast.parse(path.read_text(), str(path)))
    return sorted(d for d in deps if _is_application(d))


def _is_application(module: str) -> bool:
    """*module* is in the applications: by its installed name (netcosim.plants ...) or by the
    folder's own name (which would import a user's package of that name)."""
    parts = module.split(".")
    return parts[0] in APPLICATIONS or (parts[0] == "netcosim" and parts[1:2] != [] and parts[1] in APPLICATIONS)


def test_netcosim_does_not_import_the_applications():
    # by import statement or by a name handed to import_module: `netcosim run NAME` finds the
    # experiments through the entry-point group netcosim.experiments instead
    offenders = {}
    for path in PKG.rglob("*.py"):
        bad = _application_imports(path)
        if bad:
            offenders[_module_name(path)] = bad
    assert offenders == {}


def test_the_string_import_detector_finds_one():
    tree = ast.parse("import importlib\n"
                     "def f(name):\n"
                     "    importlib.import_module(f'experiments.{name}')\n"
                     "    __import__('netcosim.plants.servo')\n"
                     "    importlib.util.find_spec('controllers')\n"
                     "    importlib.import_module(name)\n")
    assert _string_imports(tree) == {"experiments.", "netcosim.plants.servo", "controllers"}
    assert all(map(_is_application, _string_imports(tree)))
    assert not _is_application("netcosim.plant.system") and not _is_application("netcosim")


def test_the_trace_does_not_know_the_kernel():
    # the kernel registers its tables (netcosim.kernel.tables) with the Trace, as the networks do;
    # the tables annotate with Trace (TYPE_CHECKING) but get it handed in at run time
    g = _graph()
    assert not {d for d in g["netcosim.trace"] if d.startswith(("netcosim.kernel", "netcosim.network"))}
    assert "netcosim.trace" not in _graph(typing=False)["netcosim.kernel.tables"]


#: the largest a module may grow before it is split along its concepts (lines)
MAX_MODULE_LINES = 600


def test_no_module_is_a_big_room():
    big = {str(p.relative_to(ROOT)): n for pkg in (PKG, ROOT / "plants", ROOT / "controllers")
           for p in pkg.rglob("*.py") if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert big == {}


#: CPython shares one key table among the instance dicts of a class up to 30 keys
#: (``SHARED_KEYS_MAX_SIZE`` in Objects/dictobject.c, 3.11-3.13); beyond it every node's
#: ``__dict__`` is a dict of its own and every attribute read of the kernel's hot path is
#: slower (measured: 7 % per job when a 30th attribute was added).
SHARED_KEYS_MAX = 30


def test_a_node_keeps_its_attributes_within_the_shared_key_table():
    from netcosim import Simulation
    sim = Simulation()
    node = sim.node("cpu")
    # 29 today: new per-node state goes on an object the node already holds (its power,
    # its releases, its clock), not on the node itself
    assert len(vars(node)) < SHARED_KEYS_MAX, sorted(vars(node))


#: what the linear-quadratic analysis may import from netcosim: it sits under the simulation
LQ_ALLOWED = {"netcosim.errors", "netcosim.validate", "netcosim.timebase"}


def test_the_lq_layer_sits_low():
    # netcosim.lq imports numpy/scipy, the errors and the validation only (validate imports
    # timebase): no kernel, network, plant, trace, clock or SimPy, so a kernel coupling is
    # an adapter above it
    g = _graph()
    lq_modules = {m for m in g if m.startswith("netcosim.lq")}
    assert "netcosim.lq.propagation" in lq_modules
    outside = {d for m in lq_modules for d in g[m] if not d.startswith("netcosim.lq")}
    assert outside <= LQ_ALLOWED, outside
    third_party = {d.split(".")[0] for m in lq_modules
                   for d in _imports(PKG / Path(*m.split(".")[1:]).with_suffix(".py")
                                     if (PKG / Path(*m.split(".")[1:]).with_suffix(".py")).exists()
                                     else PKG / Path(*m.split(".")[1:]) / "__init__.py")}
    assert third_party <= {"numpy", "scipy", "pandas", "matplotlib", "netcosim", "__future__", "typing",
                           "dataclasses", "math", "collections", "itertools"}, third_party
    assert "simpy" not in third_party
