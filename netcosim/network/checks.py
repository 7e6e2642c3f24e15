"""Former home of the network parameter checks, kept so old imports keep working.

The checks live in :mod:`netcosim.validate` (one module for every parameter of the
kernel, the networks, the plants and the controllers); the names here are aliases.
``check_real`` keeps its old keywords ``low``/``high``/``low_open``/``high_open``.
"""

from __future__ import annotations

from ..validate import bits as check_bits
from ..validate import count as check_count
from ..validate import duration as check_duration
from ..validate import finite as check_finite
from ..validate import non_negative as check_non_negative
from ..validate import positive as check_positive
from ..validate import probability as check_probability
from ..validate import real as _real

__all__ = ["check_real", "check_finite", "check_positive", "check_non_negative", "check_probability",
           "check_bits", "check_count", "check_duration"]


def check_real(value, what: str, *, low: float | None = None, high: float | None = None,
               low_open: bool = False, high_open: bool = False, kind: str = "a finite number") -> float:
    """:func:`netcosim.validate.real` under its former name and keywords."""
    return _real(value, what, lo=low, hi=high, lo_open=low_open, hi_open=high_open, kind=kind)
