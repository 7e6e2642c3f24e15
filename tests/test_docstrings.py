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
   (``s``, ``seconds``, ``ticks``, ``bit/s``, ``Hz``, ``dB``, ``dBm``, ``W``, ``m``, ``bits``,
   ``dimensionless``) as a word.  The plants and controllers follow it too, except where a
   name that looks like a quantity is not one (:data:`_NOT_QUANTITIES`).
3. Summary: the first paragraph of every public docstring is a sentence (what the API
   reference's tables show).
4. Parameters: every parameter of a public callable is named in its docstring (for
   ``__init__``, the class's; for an override, also the overridden method's), without
   exception in ``netcosim`` proper (the gaps listed when the rule came are all documented).
5. The user-facing plants and controllers (``netcosim.plants``, ``netcosim.controllers``:
   the repository's ``plants/`` and ``controllers/``) follow rules 1, 3 and 4 too.
6. Examples and errors: every class and function of the user-facing surface (the
   ``__all__`` of ``netcosim`` and of its kernel, network, plant, metrics, sweep, lq, view
   and fmi packages, and the trace) has an ``Examples`` section with doctest lines (run by
   ``make doctest-docs``), and one whose own code raises has a ``Raises`` section.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import netcosim
import netcosim.controllers
import netcosim.plants

#: the user-facing packages installed into netcosim's namespace from other folders (rule 5)
_USER_PACKAGES = (netcosim.plants, netcosim.controllers)

_UNIT_PARAM = re.compile(r"^(period|deadline|delay|offset|times?|until|t|seconds|at|\w+_s|\w+_time|\w*rate"
                         r"|\w+_dbm|\w+_db|\w*bits)$")
_UNITS = re.compile(r"(?<![\w.'’])(s|seconds?|ticks?|bit/s|Hz|dB|dBm|W|m|bits?|dimensionless)(?![\w/])")
#: parameters of the plants and controllers whose names look like a quantity but are not one
_NOT_QUANTITIES = {
    "netcosim.plants.kinematic.check_singular_values(at)": "names a configuration (q = [...])",
    "netcosim.plants.kinematic.pinv_solve(at)": "names a configuration (q = [...])",
}


def _modules(package=netcosim):
    yield package
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        yield importlib.import_module(info.name)


def _public_objects(package=netcosim):
    """(qualified name, object, owner class or None) of every public definition of
    *package* (``netcosim`` walks its own folder only: not the plants and controllers,
    which install into its namespace from other folders)."""
    for mod in _modules(package):
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
    everything = [item for package in (netcosim, *_USER_PACKAGES) for item in _public_objects(package)]
    for qual, obj, owner in everything:
        if isinstance(obj, property) or not inspect.isfunction(obj):
            continue
        quantities = [p for p in _params(obj) if _UNIT_PARAM.match(p) and f"{qual}({p})" not in _NOT_QUANTITIES]
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


# ------------------------------------------------------------------ summary lines and parameters
def test_every_docstring_opens_with_a_summary_sentence():
    """The first paragraph of every public docstring is a sentence (it ends with a stop, a
    colon or a closing bracket): what autosummary shows in the API reference's tables.  The
    plants' and controllers' too."""
    bad = []
    everything = [item for package in (netcosim, *_USER_PACKAGES) for item in _public_objects(package)]
    for qual, obj, _owner in everything:
        if qual.endswith(".__init__"):
            continue
        first = (inspect.getdoc(obj) or "").split("\n\n")[0]
        if not first.strip():           # no docstring at all: rule 1's (or, for plants and controllers, listed)
            continue
        if not re.search(r"[.:;?!)]\s*$|[.:;?!]\s", first):
            bad.append(f"{qual}: {first[:60]!r}")
    assert not bad, f"{len(bad)} docstrings without a summary sentence:\n" + "\n".join(bad)


def _docs_naming_parameters(obj, owner) -> str:
    """The text that may document *obj*'s parameters: its docstring, or for a method the
    docstrings of the same method up the class's bases; for ``__init__`` the class's."""
    if owner is None:
        return inspect.getdoc(obj) or ""
    parts = []
    for base in owner.__mro__:
        if obj.__name__ == "__init__":
            parts.append(base.__doc__ or "")
        member = vars(base).get(obj.__name__)
        member = getattr(member, "__func__", member)
        parts.append(getattr(member, "__doc__", None) or "")
    return "\n".join(parts)


def _undocumented_parameters(obj, owner) -> list[str]:
    try:
        params = inspect.signature(obj).parameters.values()
    except (TypeError, ValueError):
        return []
    names = [p.name for p in params if p.name not in ("self", "cls")
             and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    doc = _docs_naming_parameters(obj, owner)
    return [n for n in names if not re.search(rf"(?<!\w){re.escape(n)}(?!\w)", doc)]


def _gaps(package=netcosim) -> set[str]:
    found = set()
    for qual, obj, owner in _public_objects(package):
        if isinstance(obj, property) or not inspect.isfunction(obj):
            continue
        found.update(f"{qual}({name})" for name in _undocumented_parameters(obj, owner))
    return found


def test_parameters_are_documented():
    """Every parameter of a public callable of netcosim is named in its docstring (for
    ``__init__``, in the class's; for an override, also in the overridden method's)."""
    gaps = sorted(_gaps())
    assert not gaps, f"{len(gaps)} parameters not named in their docstring:\n" + "\n".join(gaps)


# ------------------------------------------------------------------ the plants and controllers
def _user_gaps() -> set[str]:
    """Objects without a docstring (``qual``) and unnamed parameters (``qual(param)``) of
    the plants and controllers."""
    found = set()
    for package in _USER_PACKAGES:
        found |= _gaps(package)
        found.update(qual for qual, obj, _owner in _public_objects(package)
                     if not qual.endswith(".__init__") and not (inspect.getdoc(obj) or "").strip())
    return found


def test_plants_and_controllers_are_documented():
    """The plants' and controllers' public objects have docstrings naming every parameter."""
    gaps = sorted(_user_gaps())
    assert not gaps, (f"{len(gaps)} plant/controller objects without a docstring or parameters not named in "
                      f"it:\n" + "\n".join(gaps))


def test_the_meta_test_sees_the_plants_and_controllers():
    quals = {q for package in _USER_PACKAGES for q, _, _ in _public_objects(package)}
    assert "netcosim.plants.dc_servo.DCServo" in quals
    assert "netcosim.controllers.pid.PID" in quals
    assert not any(q.startswith("netcosim.plants") for q, _, _ in _public_objects())


def test_the_package_namespace_documents_every_parameter():
    """netcosim.__all__, what the API reference opens with, has no gap at all."""
    top = []
    for name in netcosim.__all__:
        obj = getattr(netcosim, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            top.append(f"{obj.__module__}.{obj.__qualname__}")
    gaps = [g for g in _gaps() if any(g.startswith(t + "(") or g.startswith(t + ".") for t in top)]
    assert not gaps, "\n".join(sorted(gaps))


def test_parameter_rule_reads_names_as_words():
    def f(period, rate):
        """Run every *period* seconds at ``rate`` bit/s."""
    def g(period, rate):
        """Run with a periodic rate_limit."""
    assert _undocumented_parameters(f, None) == []
    assert _undocumented_parameters(g, None) == ["period", "rate"]


# ------------------------------------------------------------------ examples and raised errors
#: the packages whose ``__all__`` is the API reference's user-facing surface (rule 6)
_EXAMPLE_PACKAGES = ("netcosim", "netcosim.kernel", "netcosim.network", "netcosim.plant", "netcosim.metrics",
                     "netcosim.sweep", "netcosim.lq", "netcosim.view", "netcosim.fmi")


def _example_scope() -> dict[str, object]:
    """Qualified name → object of every class and function in the ``__all__`` of
    :data:`_EXAMPLE_PACKAGES` (constants and warnings excepted), plus the trace."""
    from netcosim.trace import Trace
    scope = {"netcosim.trace.Trace": Trace}
    for name in _EXAMPLE_PACKAGES:
        module = importlib.import_module(name)
        for attr in module.__all__:
            obj = getattr(module, attr)
            if not (inspect.isclass(obj) or inspect.isfunction(obj)):
                continue
            if inspect.isclass(obj) and issubclass(obj, Warning):
                continue
            scope[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return scope


def _raises_directly(obj) -> bool:
    """Whether *obj*'s own code (a function's body, a class's ``__init__``) raises."""
    target = vars(obj).get("__init__") if inspect.isclass(obj) else obj
    if target is None or not inspect.isfunction(target):
        return False
    try:
        source = inspect.getsource(target)
    except (OSError, TypeError):
        return False
    return re.search(r"^\s+raise \w", source, re.MULTILINE) is not None


def _example_findings() -> tuple[list[str], list[str]]:
    no_example, no_raises = [], []
    for qual, obj in sorted(_example_scope().items()):
        doc = inspect.getdoc(obj) or ""
        if not re.search(r"^Examples?\n-{4,}", doc, re.MULTILINE) or ">>> " not in doc:
            no_example.append(qual)
        if inspect.isclass(obj) and issubclass(obj, Exception):
            continue
        if _raises_directly(obj) and not re.search(r"^Raises\n-{4,}", doc, re.MULTILINE):
            no_raises.append(qual)
    return no_example, no_raises


def test_the_user_facing_api_has_examples_and_states_its_errors():
    """Rule 6: every class and function of the user-facing surface has an ``Examples``
    section (run by ``make doctest-docs``), and one whose own code raises has a ``Raises``
    section naming what."""
    no_example, no_raises = _example_findings()
    assert not no_example and not no_raises, (
        f"{len(no_example)} without an Examples section:\n" + "\n".join(no_example)
        + f"\n{len(no_raises)} raise without a Raises section:\n" + "\n".join(no_raises))


def test_the_example_rule_can_fail():
    def bare(x):
        """Do a thing with *x*."""
        if x < 0:
            raise ValueError(x)

    assert _raises_directly(bare)
    assert not re.search(r"^Examples?\n-{4,}", inspect.getdoc(bare), re.MULTILINE)


def test_the_example_scope_is_the_api_surface():
    scope = _example_scope()
    assert "netcosim.sim.Simulation" in scope and "netcosim.sweep.run.run_sweep" in scope or any(
        q.endswith(".run_sweep") for q in scope)
    assert any(q.endswith(".loss_cost") for q in scope) and any(q.endswith(".WLAN80211b") for q in scope)
    assert len(scope) > 100
