"""The package namespace: ``netcosim.__all__`` is exactly the table of contents written
in the package docstring, and every name in it is importable (as SimPy checks its
``toc``)."""

import re

import netcosim

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


def test_event_is_the_condition_variable_alias():
    assert netcosim.Event is netcosim.ConditionVariable
