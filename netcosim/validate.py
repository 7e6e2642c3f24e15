"""Checks for parameter dataclasses: every error names the field and its value."""

from __future__ import annotations

import math
from dataclasses import fields


def check_numeric_fields(obj, *, positive=(), non_negative=()) -> None:
    """Require every field of dataclass *obj* to be a finite real number (bools excluded),
    the fields in *positive* to be > 0 and those in *non_negative* to be >= 0.

    Raises ``ValueError("<Class>.<field> must be ..., got <value>")``.
    """
    cls = type(obj).__name__
    for f in fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{cls}.{f.name} must be a finite number, got {v!r}")
    for name in positive:
        v = getattr(obj, name)
        if v <= 0:
            raise ValueError(f"{cls}.{name} must be positive, got {v!r}")
    for name in non_negative:
        v = getattr(obj, name)
        if v < 0:
            raise ValueError(f"{cls}.{name} must be non-negative, got {v!r}")
