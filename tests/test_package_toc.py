"""The package namespace: ``netcosim.__all__`` is exactly the table of contents written
in the package docstring, and every name in it is importable (as SimPy checks its
``toc``)."""

import ast
import importlib
import re
from pathlib import Path

import netcosim

ROOT = Path(__file__).resolve().parent.parent

_ROLE = re.compile(r":(?:class|data|func|exc):`~?([A-Za-z_][A-Za-z0-9_.]*)`")


def toc_names() -> list[str]:
    """Names in the docstring's table of contents, in order (a parenthesised remark may
    name one again: it is counted once)."""
    doc = netcosim.__doc__
    start = doc.index("Contents of the package namespace")
    names: list[str] = []
    for line in doc[start:].splitlines():
        # the entries of a section; a remark in parentheses refers to an entry, it is not one
        entries = re.sub(r"\([^)]*\)", "", line)
        names += [m.group(1).rsplit(".", 1)[-1] for m in _ROLE.finditer(entries)]
    return names


def test_toc_has_sections_and_no_duplicates():
    names = toc_names()
    assert len(names) >= 40
    assert len(names) == len(set(names)), [n for n in names if names.count(n) > 1]


def test_all_equals_toc():
    assert len(netcosim.__all__) == len(set(netcosim.__all__))
    assert sorted(netcosim.__all__) == sorted(toc_names())


def test_every_name_is_importable():
    namespace: dict = {}
    exec("from netcosim import *", namespace)
    for name in toc_names():
        assert getattr(netcosim, name) is namespace[name]


def test_the_api_table_is_the_one_spelling():
    # __all__, the lazy imports and dir() come from netcosim._API (the docstring's table of
    # contents is checked against __all__ above)
    table = netcosim._API
    assert netcosim.__all__ == list(table)
    assert set(netcosim.__all__) <= set(dir(netcosim))
    for name, module in table.items():
        assert getattr(netcosim, name) is getattr(importlib.import_module(f"netcosim.{module}"), name)


def type_checking_imports(names: dict[str, str], indent: str = "    ", width: int = 120) -> str:
    """The ``from .module import ...`` lines that show type checkers the names (name ->
    submodule) netcosim imports lazily, formatted as ruff's isort keeps them (by module;
    constants, then classes, then functions; one name a line when the line is too long)."""
    by_module: dict[str, list[str]] = {}
    for name, module in names.items():
        by_module.setdefault(module, []).append(name)

    def order(name: str) -> tuple[int, str]:
        return (0 if name.isupper() and len(name) > 1 else 1 if name[:1].isupper() else 2, name)
    out = []
    for module in sorted(by_module):
        members = sorted(by_module[module], key=order)
        line = f"{indent}from .{module} import {', '.join(members)}"
        if len(line) > width:
            line = f"{indent}from .{module} import (\n" + "".join(f"{indent}    {m},\n" for m in members) + f"{indent})"
        out.append(line + "\n")
    return "".join(out)


def test_the_type_checking_imports_mirror_the_table():
    """The ``if TYPE_CHECKING:`` block of netcosim/__init__.py is generated from ``_API``
    by :func:`type_checking_imports` (when this fails, paste the expected text there)."""
    source = (ROOT / "netcosim" / "__init__.py").read_text()
    tree = ast.parse(source)
    (block,) = [n for n in tree.body if isinstance(n, ast.If) and getattr(n.test, "id", "") == "TYPE_CHECKING"]
    lines = source.splitlines(keepends=True)
    got = "".join(lines[block.body[0].lineno - 1:block.body[-1].end_lineno])
    assert got == type_checking_imports(netcosim._API)


def test_dropped_names_are_gone():
    # Event was an alias of ConditionVariable (clashing with simpy.Event by name);
    # SingularConfigurationError lives with the kinematic plants (netcosim.plants.kinematic)
    for name in ("Event", "SingularConfigurationError"):
        assert name not in netcosim.__all__
        assert not hasattr(netcosim, name)
