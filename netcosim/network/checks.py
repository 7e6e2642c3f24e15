"""Validation of network parameters, shared by every network, MAC, radio and loss model.

Each function returns the value in the form the model stores (float, int or integer
ticks) or raises, naming the parameter and the offending value (its ``repr``):

* :class:`~netcosim.errors.ConfigurationTypeError` (a ``TypeError``) when the value is
  not a number at all (a string, None, a bool, a list);
* :class:`~netcosim.errors.ConfigurationError` (a ``ValueError``) when it is a number
  outside the allowed range, NaN or infinite, or (for bit counts) not integral.

Parameters are checked when a network, loss model or path-loss model is constructed and
when a node is attached, so a bad value fails at once instead of producing NaN powers or
"cannot schedule in the past" deep inside a run.  Durations (delays, slot times,
windows, gaps) go through :func:`netcosim.timebase.to_ticks`, which also rejects
non-zero values below the 1 ps resolution.
"""

from __future__ import annotations

import math
import numbers

from ..errors import ConfigurationError, ConfigurationTypeError
from ..timebase import to_ticks

__all__ = ["check_real", "check_finite", "check_positive", "check_non_negative", "check_probability",
           "check_bits", "check_count", "check_duration"]


def check_real(value, what: str, *, low: float | None = None, high: float | None = None,
               low_open: bool = False, high_open: bool = False, kind: str = "a finite number") -> float:
    """*value* as a float, if it is a finite real number in the given range.

    ``low``/``high``: bounds (None = unbounded), exclusive when ``low_open``/``high_open``.
    ``kind`` describes the expected value in the message (e.g. ``"a positive number of
    seconds"``).
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigurationTypeError(f"{what} must be {kind}, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ConfigurationError(f"{what} must be {kind}, got {value!r}")
    if low is not None and (v < low or (low_open and v == low)):
        raise ConfigurationError(f"{what} must be {kind}, got {value!r}")
    if high is not None and (v > high or (high_open and v == high)):
        raise ConfigurationError(f"{what} must be {kind}, got {value!r}")
    return v


def check_finite(value, what: str, unit: str = "") -> float:
    """A finite real number (any sign), e.g. a power in dBm."""
    return check_real(value, what, kind=f"a finite number{' of ' + unit if unit else ''}")


def check_positive(value, what: str) -> float:
    """A finite real number > 0 (rates, distances, frequencies, exponents)."""
    return check_real(value, what, low=0.0, low_open=True, kind="a positive finite number")


def check_non_negative(value, what: str) -> float:
    """A finite real number >= 0 (losses and thresholds in dB that cannot be negative)."""
    return check_real(value, what, low=0.0, kind="a non-negative finite number")


def check_probability(p, what: str) -> float:
    """A probability in [0, 1]."""
    return check_real(p, what, low=0.0, high=1.0, kind="a probability in [0, 1]")


def _integral(value) -> bool:
    if isinstance(value, bool):
        return False
    if isinstance(value, numbers.Integral):
        return True
    return isinstance(value, numbers.Real) and math.isfinite(value) and float(value).is_integer()


def check_bits(value, what: str, *, allow_zero: bool = True) -> int:
    """A number of bits: an integer >= 0 (> 0 unless ``allow_zero``).  Integral floats
    (``64.0``) are accepted."""
    kind = "a non-negative integer number of bits" if allow_zero else "a positive integer number of bits"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigurationTypeError(f"{what} must be {kind}, got {value!r}")
    if not _integral(value) or value < 0 or (not allow_zero and value == 0):
        raise ConfigurationError(f"{what} must be {kind}, got {value!r}")
    return int(value)  # type: ignore[call-overload]  # the numbers ABCs are untyped (mypy #3186)


def check_count(value, what: str, *, minimum: int = 0, maximum: int | None = None) -> int:
    """An integer count (attempts, retries, window sizes, exponents) in
    ``[minimum, maximum]``; integral floats are not accepted (a count of 2.5 is a bug)."""
    rng = f">= {minimum}" if maximum is None else f"in {minimum}..{maximum}"
    kind = f"an integer {rng}"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if isinstance(value, numbers.Real) and not isinstance(value, bool):
            raise ConfigurationError(f"{what} must be {kind}, got {value!r}")
        raise ConfigurationTypeError(f"{what} must be {kind}, got {value!r}")
    if value < minimum or (maximum is not None and value > maximum):  # type: ignore[operator]  # mypy #3186
        raise ConfigurationError(f"{what} must be {kind}, got {value!r}")
    return int(value)


def check_duration(value, what: str, *, positive: bool = False) -> int:
    """A duration in seconds as integer ticks (:func:`~netcosim.timebase.to_ticks`:
    finite, >= 0, and 0 or at least 1 ps); ``positive`` also rejects 0."""
    ticks = to_ticks(value, what)
    if positive and ticks <= 0:
        raise ConfigurationError(f"{what} must be a positive number of seconds, got {value!r}")
    return ticks
