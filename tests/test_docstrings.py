"""Docstring meta-test (after python-control's ``test_docstrings``).

1. Every public module, class, function, method and property of ``netcosim`` has a
   docstring.  Public: no leading underscore in its name nor in any module on its path;
   members are those defined in the class's own body (inherited ones are checked where
   they are defined); an override without a docstring of its own inherits the base's
   (as :func:`inspect.getdoc` does); dunder methods are exempt, ``__init__`` is documented
   by its class.
2. Units: a public callable with a parameter that carries a time, a rate or a physical
   quantity says its unit.  The rule, kept simple enough to check: if a parameter name
   matches ``_UNIT_PARAM`` (period, deadline, delay, offset, time(s), until, t, seconds,
   ``*_s``, ``*_time``, rate, ``*_dbm``, ``*_db``, ``bits``), the callable's docstring (or,
   for ``__init__``, the class docstring) contains one of the unit markers ``_UNITS``
   (``s``, ``seconds``, ``ticks``, ``bit/s``, ``Hz``, ``dB``, ``dBm``, ``W``, ``m``, ``bits``)
   as a word.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import netcosim

_UNIT_PARAM = re.compile(r"^(period|deadline|delay|offset|times?|until|t|seconds|at|\w+_s|\w+_time|\w*rate"
                         r"|\w+_dbm|\w+_db|\w*bits)$")
_UNITS = re.compile(r"(?<![\w.'’])(s|seconds?|ticks?|bit/s|Hz|dB|dBm|W|m|bits?)(?![\w/])")


def _modules():
    yield netcosim
    for info in pkgutil.walk_packages(netcosim.__path__, "netcosim."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        yield importlib.import_module(info.name)


def _public_objects():
    """(qualified name, object, owner class or None) of every public definition."""
    for mod in _modules():
        yield mod.__name__, mod, None
        for name, obj in vars(mod).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != mod.__name__:
                continue
            if inspect.isfunction(obj):
                yield f"{mod.__name__}.{name}", obj, None
            elif inspect.isclass(obj):
                yield f"{mod.__name__}.{name}", obj, None
                for mname, member in vars(obj).items():
                    if mname.startswith("_") and mname != "__init__":
                        continue
                    if isinstance(member, (staticmethod, classmethod)):
                        member = member.__func__
                    if isinstance(member, property) or inspect.isfunction(member):
                        yield f"{mod.__name__}.{name}.{mname}", member, obj


def test_every_public_object_has_a_docstring():
    missing = [qual for qual, obj, owner in _public_objects()
               if not qual.endswith(".__init__") and not (inspect.getdoc(obj) or "").strip()]
    assert not missing, f"{len(missing)} public objects without a docstring:\n" + "\n".join(missing)


def _params(fn) -> list[str]:
    try:
        return [p for p in inspect.signature(fn).parameters if p not in ("self", "cls")]
    except (TypeError, ValueError):
        return []


def test_quantities_state_their_units():
    missing = []
    for qual, obj, owner in _public_objects():
        if isinstance(obj, property) or not inspect.isfunction(obj):
            continue
        quantities = [p for p in _params(obj) if _UNIT_PARAM.match(p)]
        if not quantities:
            continue
        doc = (inspect.getdoc(obj) or "") if not qual.endswith(".__init__") else (owner.__doc__ or "") + (
            obj.__doc__ or "")
        if not _UNITS.search(doc):
            missing.append(f"{qual}({', '.join(quantities)})")
    assert not missing, f"{len(missing)} callables do not state a unit:\n" + "\n".join(missing)


def test_the_meta_test_sees_the_api():
    quals = {q for q, _, _ in _public_objects()}
    assert "netcosim.kernel.policies.SchedulingPolicy.key" in quals
    assert "netcosim.kernel.sync.Mailbox.fetch" in quals
    assert "netcosim.sim.Simulation.now" in quals       # a property
    assert len(quals) > 150


def test_unit_rule_reads_units_as_words():
    assert _UNITS.search("period (s) of the task")
    assert _UNITS.search("rate in bit/s")
    assert _UNITS.search("power in dBm")
    assert _UNITS.search("the deadline in seconds")
    assert not _UNITS.search("it's the task's period")     # an apostrophe s is not a unit
    assert not _UNITS.search("*size_bits* of payload")     # a parameter name is not a unit
    assert _UNIT_PARAM.match("slot_time") and _UNIT_PARAM.match("data_rate") and _UNIT_PARAM.match("t")
    assert not _UNIT_PARAM.match("priority")
