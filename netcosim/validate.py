"""Parameter validation, shared by the kernel, the networks, the plants and the controllers.

Every function takes the value and ``what`` (the parameter's name as the message should
show it, e.g. ``"task 'ctrl': period"``), returns the value in the form the model
stores (float, int, integer ticks) and otherwise raises, naming ``what`` and
``repr(value)``:

* :class:`~netcosim.errors.ConfigurationTypeError` (a ``TypeError``) when the value is
  not of the expected kind at all (a string, None, a bool, a list);
* :class:`~netcosim.errors.ConfigurationError` (a ``ValueError``) when it is of the
  right kind but outside the allowed range, NaN or infinite, or not integral.

The message is ``"<what> must be <kind>, got <value!r>"``; ``kind`` is a keyword of
every function so a caller can describe the expected value in its own words
(``"a positive number of seconds"``).  ``type_error`` selects the class raised for a
value of the wrong kind; a few older parameters raise ``ConfigurationError`` there and
keep doing so, and ``value_error`` (where offered) the class raised for a value out of
range.  Bools are never numbers here (``True`` is not a period).  An optional parameter
is checked only when given: ``None if x is None else validate.real(x, ...)``.

Durations are checked by :func:`duration`, which delegates to
:func:`netcosim.timebase.to_ticks` (finite, >= 0, and 0 or at least the 1 ps resolution).
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import fields
from typing import Any, Callable, Iterable

from .errors import ConfigurationError, ConfigurationTypeError
from .timebase import to_ticks

__all__ = ["is_real", "real", "finite", "positive", "non_negative", "probability", "integer", "count", "bits",
           "duration", "name", "path", "boolean", "choice", "callable_", "numeric_fields", "check_numeric_fields"]


def _fail(cls: type[Exception], what: str, kind: str, value: Any) -> Exception:
    return cls(f"{what} must be {kind}, got {value!r}")


def is_real(value: Any) -> bool:
    """True if *value* is a real number (Python or NumPy; bools excluded), finite or not."""
    return not isinstance(value, bool) and isinstance(value, numbers.Real)


def real(value: Any, what: str, *, lo: float | None = None, hi: float | None = None,
         lo_open: bool = False, hi_open: bool = False, allow_inf: bool = False,
         kind: str = "a finite number",
         type_error: type[Exception] = ConfigurationTypeError,
         value_error: type[Exception] = ConfigurationError) -> float:
    """*value* as a float, if it is a real number in ``[lo, hi]``.

    ``lo``/``hi``: bounds (None = unbounded), exclusive when ``lo_open``/``hi_open``.
    NaN is always rejected, infinities unless ``allow_inf`` (then only the bounds limit
    them).  *what* names it in the error, ``kind`` describing what is expected; ``type_error``: the class
    raised for a value that is not a real number, ``value_error`` for a number that fails
    these rules.
    """
    if not is_real(value):
        raise _fail(type_error, what, kind, value)
    try:
        v = float(value)
    except OverflowError:           # an int beyond the float range (10**400): out of any range
        raise _fail(value_error, what, kind, value) from None
    if math.isnan(v) or (math.isinf(v) and not allow_inf) \
            or (lo is not None and (v < lo or (lo_open and v == lo))) \
            or (hi is not None and (v > hi or (hi_open and v == hi))):
        raise _fail(value_error, what, kind, value)
    return v


def finite(value: Any, what: str, unit: str = "", **kw) -> float:
    """*value* as a finite real number of any sign (e.g. a power in dBm, a priority); *what* names it in the error,
    ``unit`` (e.g. ``"dBm"``) in the default ``kind``; other keywords as :func:`real`."""
    kw.setdefault("kind", f"a finite number{' of ' + unit if unit else ''}")
    return real(value, what, **kw)


def positive(value: Any, what: str, **kw) -> float:
    """*value* as a finite real number > 0 (rates, distances, frequencies, gains); *what* names it in the error;
    other keywords as :func:`real`."""
    kw.setdefault("kind", "a positive finite number")
    return real(value, what, lo=0.0, lo_open=True, **kw)


def non_negative(value: Any, what: str, **kw) -> float:
    """*value* as a finite real number >= 0 (losses, weights, thresholds); *what* names it in the error;
    other keywords as :func:`real`."""
    kw.setdefault("kind", "a non-negative finite number")
    return real(value, what, lo=0.0, **kw)


def probability(value: Any, what: str, **kw) -> float:
    """*value* as a probability in [0, 1]; *what* names it in the error; other keywords as :func:`real`."""
    kw.setdefault("kind", "a probability in [0, 1]")
    return real(value, what, lo=0.0, hi=1.0, **kw)


def integer(value: Any, what: str, *, lo: int | None = None, hi: int | None = None,
            integral_floats: bool = False, kind: str | None = None,
            type_error: type[Exception] = ConfigurationTypeError,
            fraction_error: type[Exception] = ConfigurationError) -> int:
    """*value* as an int, if it is an integer (Python or NumPy; bools excluded) in
    ``[lo, hi]``.

    ``integral_floats``: also accept a real number with no fractional part (``64.0``).
    A non-integral real number (``2.5``) raises ``fraction_error``; anything else that
    is not an integer raises ``type_error``.  ``kind`` defaults to "an integer"
    plus the range.  *what* names it in the error.
    """
    if kind is None:
        kind = "an integer" + ("" if lo is None and hi is None else
                               f" >= {lo}" if hi is None else f" <= {hi}" if lo is None else f" in {lo}..{hi}")
    if not is_real(value):
        raise _fail(type_error, what, kind, value)
    if not isinstance(value, numbers.Integral):
        if not (integral_floats and math.isfinite(value) and float(value).is_integer()):
            raise _fail(fraction_error, what, kind, value)
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise _fail(ConfigurationError, what, kind, value)
    return int(value)


def count(value: Any, what: str, *, minimum: int = 0, maximum: int | None = None) -> int:
    """*value* as an integer count (attempts, retries, window sizes, exponents) in
    ``[minimum, maximum]`` (None: no maximum); integral floats are not accepted (a count of
    2.5 is a bug).  *what* names it in the error."""
    return integer(value, what, lo=minimum, hi=maximum)


#: The largest number of bits :func:`bits` accepts, 2**53 (a 1 PB frame): every count up to
#: it is exact as a float, so transmission times (bits / rate) stay finite numbers
#: (``1e300`` bits overflowed them).
MAX_BITS = 2**53


def bits(value: Any, what: str, *, allow_zero: bool = True) -> int:
    """*value* as a number of bits: an integer >= 0 (> 0 unless ``allow_zero``) and at most
    :data:`MAX_BITS`.  Integral floats (``64.0``) are accepted.  *what* names it in the error."""
    kind = "a non-negative integer number of bits" if allow_zero else "a positive integer number of bits"
    n = integer(value, what, lo=0 if allow_zero else 1, integral_floats=True, kind=kind)
    if n > MAX_BITS:
        raise _fail(ConfigurationError, what, "at most 2**53 bits", value)
    return n


def duration(value: Any, what: str, *, positive: bool = False,
             kind: str = "a positive number of seconds") -> int:
    """*value*, a duration in seconds, as integer ticks (:func:`~netcosim.timebase.to_ticks`:
    finite, >= 0, and 0 or at least 1 ps); ``positive`` also rejects 0 (the message for
    0 and for a negative value then uses ``kind``: a period of -1 "must be positive", not
    "non-negative", which would invite a 0).  *what* names it in the error."""
    if positive and is_real(value) and value < 0:
        raise _fail(ConfigurationError, what, kind, value)
    ticks = to_ticks(value, what)
    if positive and ticks <= 0:
        raise _fail(ConfigurationError, what, kind, value)
    return ticks


def name(value: Any, what: str, *, type_error: type[Exception] = ConfigurationTypeError) -> str:
    """*value* if it is a non-empty string (a component, table or phase name); *what* names it in the error;
    ``type_error``: the class raised otherwise."""
    if not isinstance(value, str) or not value:
        raise _fail(type_error, what, "a non-empty string", value)
    return value


def path(value: Any, what: str, *, kind: str = "a path (str or os.PathLike)") -> str | os.PathLike:
    """*value* if it is a non-empty file-system path (``str`` or ``os.PathLike``), returned
    unchanged; *what* names it in the error, ``kind`` describing what is expected (e.g. ``"a directory path"``)."""
    if isinstance(value, bool) or not isinstance(value, (str, os.PathLike)) or not os.fspath(value):
        raise _fail(ConfigurationTypeError, what, kind, value)
    return value


def boolean(value: Any, what: str) -> bool:
    """*value* if it is ``True`` or ``False`` exactly (not 0, 1 or ``"yes"``); *what* names it in the error."""
    if not isinstance(value, bool):
        raise _fail(ConfigurationTypeError, what, "True or False", value)
    return value


def choice(value: Any, what: str, options: Iterable[Any], *, kind: str | None = None,
           error: type[Exception] = ConfigurationError) -> Any:
    """*value* if it is one of *options*; the message lists them (``'a', 'b' or 'c'``)
    unless ``kind`` says it otherwise.  *what* names it in the error; ``error``: the class raised
    (default :class:`~netcosim.errors.ConfigurationError`)."""
    options = tuple(options)
    if kind is None:
        names = [repr(o) for o in options]
        kind = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " or " + names[-1]
    try:
        ok = value in options
    except TypeError:               # unhashable value against a set-like container
        ok = False
    if not ok:
        raise _fail(error, what, kind, value)
    return value


def callable_(value: Any, what: str, *, kind: str = "callable",
              type_error: type[Exception] = ConfigurationTypeError) -> Callable:
    """*value* if it is callable; *what* names it in the error, ``kind`` describing what is expected (e.g.
    ``"a callable body(ctx)"``); ``type_error``: the class raised otherwise."""
    if not callable(value):
        raise _fail(type_error, what, kind, value)
    return value


def numeric_fields(obj: Any, *, positive: Iterable[str] = (), non_negative: Iterable[str] = ()) -> None:
    """Require every field of dataclass *obj* to be a finite real number (bools excluded),
    the fields in *positive* to be > 0 and those in *non_negative* to be >= 0.

    Raises ``ValueError("<Class>.<field> must be ..., got <value>")``.
    """
    cls = type(obj).__name__
    for f in fields(obj):
        v = getattr(obj, f.name)
        real(v, f"{cls}.{f.name}", type_error=ConfigurationError)
    for name in positive:
        real(getattr(obj, name), f"{cls}.{name}", lo=0.0, lo_open=True, kind="positive")
    for name in non_negative:
        real(getattr(obj, name), f"{cls}.{name}", lo=0.0, kind="non-negative")


#: The name this function had before the module held every check.
check_numeric_fields = numeric_fields
