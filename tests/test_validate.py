"""Direct tests of netcosim.validate: accepted forms, the exception class, and messages
that name the parameter and the value."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from netcosim import validate
from netcosim.errors import ConfigurationError, ConfigurationTypeError


def test_real_returns_float_and_checks_bounds():
    assert validate.real(np.int64(3), "x") == 3.0 and type(validate.real(2, "x")) is float
    assert validate.real(math.inf, "x", lo=0, allow_inf=True) == math.inf
    with pytest.raises(ConfigurationError, match=r"^x must be a finite number, got nan$"):
        validate.real(math.nan, "x", allow_inf=True)
    with pytest.raises(ConfigurationError, match=r"^share must be in \(0, 1\], got 0.0$"):
        validate.real(0.0, "share", lo=0, hi=1, lo_open=True, kind="in (0, 1]")
    with pytest.raises(ConfigurationError, match=r"^p must be a probability in \[0, 1\], got 1.5$"):
        validate.probability(1.5, "p")


@pytest.mark.parametrize("bad", [True, "1", None, [1.0]])
def test_a_value_of_the_wrong_kind_is_a_type_error_unless_told_otherwise(bad):
    with pytest.raises(ConfigurationTypeError, match=re.escape(f"speed must be a positive finite number, got {bad!r}")):
        validate.positive(bad, "speed")
    with pytest.raises(ConfigurationError):
        validate.positive(bad, "speed", type_error=ConfigurationError)


def test_positive_and_non_negative():
    assert validate.non_negative(0, "w") == 0.0
    with pytest.raises(ConfigurationError, match="^w must be a positive finite number, got 0$"):
        validate.positive(0, "w")
    with pytest.raises(ConfigurationError, match="^w must be a non-negative finite number, got -1$"):
        validate.non_negative(-1, "w")


def test_integer_ranges_fractions_and_integral_floats():
    assert validate.integer(np.int32(4), "n", lo=1) == 4 and type(validate.integer(np.int32(4), "n")) is int
    assert validate.integer(64.0, "n", integral_floats=True) == 64
    with pytest.raises(ConfigurationError, match=r"^n must be an integer in 1\.\.3, got 4$"):
        validate.integer(4, "n", lo=1, hi=3)
    with pytest.raises(ConfigurationError, match=r"^n must be an integer >= 1, got 2.5$"):
        validate.integer(2.5, "n", lo=1)
    with pytest.raises(ConfigurationTypeError, match=r"^n must be an integer >= 1, got 2.5$"):
        validate.integer(2.5, "n", lo=1, fraction_error=ConfigurationTypeError)
    with pytest.raises(ConfigurationTypeError, match=r"^n must be an integer, got True$"):
        validate.integer(True, "n")
    with pytest.raises(ConfigurationError, match="bits"):
        validate.bits(-8, "size")
    with pytest.raises(ConfigurationError, match=r"^k must be an integer >= 1, got 0$"):
        validate.count(0, "k", minimum=1)


def test_duration_is_integer_ticks_via_timebase():
    assert validate.duration(1e-3, "d") == 10**9
    with pytest.raises(ConfigurationError, match="^d must be a positive number of seconds, got 0$"):
        validate.duration(0, "d", positive=True)
    # a negative value gets the same message: "non-negative" would invite the 0 it also refuses
    with pytest.raises(ConfigurationError, match="^d must be a positive number of seconds, got -0.01$"):
        validate.duration(-0.01, "d", positive=True)
    with pytest.raises(ConfigurationError, match="^d must be positive, got -inf$"):
        validate.duration(-math.inf, "d", positive=True, kind="positive")
    with pytest.raises(ConfigurationError, match="^d must be non-negative, got -0.01$"):
        validate.duration(-0.01, "d")            # a duration that may be 0
    with pytest.raises(ConfigurationError, match="below the time resolution"):
        validate.duration(1e-13, "d")
    with pytest.raises(ConfigurationTypeError, match="'1'"):
        validate.duration("1", "d")


def test_boolean_choice_callable():
    assert validate.boolean(False, "b") is False
    with pytest.raises(ConfigurationTypeError, match="^b must be True or False, got 1$"):
        validate.boolean(1, "b")
    assert validate.choice("fifo", "q", ("fifo", "priority")) == "fifo"
    with pytest.raises(ConfigurationError, match=r"^q must be 'fifo' or 'priority', got 'lifo'$"):
        validate.choice("lifo", "q", ("fifo", "priority"))
    with pytest.raises(ConfigurationError, match=r"^s must be 'a', 'b' or 'c', got None$"):
        validate.choice(None, "s", "abc")
    with pytest.raises(ConfigurationError, match=r"^d must be -1, 0 or \+1, got 2$"):
        validate.choice(2, "d", (-1, 0, 1), kind="-1, 0 or +1")
    with pytest.raises(ConfigurationError, match="got \\[1\\]"):
        validate.choice([1], "q", {"a"})
    assert validate.callable_(len, "f") is len
    with pytest.raises(ConfigurationTypeError, match="^f must be callable, got 3$"):
        validate.callable_(3, "f")


def test_numeric_fields_names_class_field_and_value():
    from dataclasses import dataclass

    @dataclass
    class P:
        a: float = 1.0
        b: float = 0.0

    validate.numeric_fields(P(), positive=("a",), non_negative=("b",))
    with pytest.raises(ValueError, match=r"^P.a must be a finite number, got 'x'$"):
        validate.numeric_fields(P(a="x"))
    with pytest.raises(ValueError, match=r"^P.a must be positive, got 0.0$"):
        validate.numeric_fields(P(a=0.0), positive=("a",))
    with pytest.raises(ValueError, match=r"^P.b must be non-negative, got -1.0$"):
        validate.numeric_fields(P(b=-1.0), non_negative=("b",))
    assert validate.check_numeric_fields is validate.numeric_fields


def test_name_and_path():
    assert validate.name("ctrl", "task name") == "ctrl"
    with pytest.raises(ConfigurationTypeError, match="^phase must be a non-empty string, got ''$"):
        validate.name("", "phase")
    with pytest.raises(ConfigurationError, match="^component name must be a non-empty string, got 3$"):
        validate.name(3, "component name", type_error=ConfigurationError)
    assert validate.path("out", "dir") == "out"
    with pytest.raises(ConfigurationTypeError, match=r"^dir must be a path \(str or os.PathLike\), got ''$"):
        validate.path("", "dir")
    with pytest.raises(ConfigurationTypeError, match="got True"):
        validate.path(True, "dir")


def test_number_checks_are_not_retyped_inline():
    """New parameter checks use netcosim.validate instead of re-typing the bool/number test.

    Allowed: timebase (validate is built on it), and two checks whose messages state a
    domain rule rather than a parameter range."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    allowed = {"netcosim/validate.py", "netcosim/timebase.py", "controllers/nmpc/ocp.py",
               "controllers/planner/gain_design.py"}
    pattern = re.compile(r"isinstance\(\w+, bool\) or not isinstance\(")
    offenders = [f"{p.relative_to(root)}:{i}"
                 for top in ("netcosim", "plants", "controllers") for p in sorted((root / top).rglob("*.py"))
                 if p.relative_to(root).as_posix() not in allowed
                 for i, line in enumerate(p.read_text().splitlines(), start=1) if pattern.search(line)]
    assert offenders == []
