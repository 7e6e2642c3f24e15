"""Checks on the numbers a plant's functions return: arrays of finite floats.

Shared by the integrators and :class:`~netcosim.plant.instance.PlantInstance`.
"""

from __future__ import annotations

import math

import numpy as np

from .. import validate
from ..errors import ConfigurationTypeError

_FLOAT = np.dtype(float)


def _all_finite(a: np.ndarray) -> bool:
    """True when every entry of the float array *a* is finite.

    The sum of the entries (as Python floats) is finite whenever every entry is, and
    costs far less than ``np.isfinite(a).all()`` for the few entries of a plant state;
    only a non-finite (or overflowing) sum needs the exact check.
    """
    return math.isfinite(sum(a.tolist())) or bool(np.isfinite(a).all())


def _floats(value, what: str) -> np.ndarray:
    """*value*, returned by a user's function (*what* names it), as a 1-D float array;
    :class:`ConfigurationTypeError` naming the value when it is not numbers (None, text,
    complex numbers: none of them silently becomes NaN or loses its imaginary part)."""
    if value is None or (isinstance(value, np.ndarray) and value.dtype.kind not in "fiub"):
        raise ConfigurationTypeError(f"{what} returned {value!r}, not real numbers")
    try:
        return np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ConfigurationTypeError(f"{what} returned {value!r}, not real numbers ({exc})") from None



def _check_count(v, what: str) -> None:
    validate.integer(v, what, lo=1, kind="a positive integer", fraction_error=ConfigurationTypeError)
