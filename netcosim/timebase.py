"""Simulated time: integer picoseconds inside, float seconds at the API.

Every instant netcosim schedules is an integer number of *ticks* of
:data:`RESOLUTION` = 1e-12 s (the resolution TrueTime uses to decide that two
instants are equal).  Users speak seconds; the kernel, the networks and the plant
coupling convert once, at the edge, with :func:`to_ticks`.  Two instants are equal
exactly when their tick counts are equal, so ``offset + k*period`` releases, segment
completions and frame ends that coincide on paper coincide in the simulation, and
their order is decided by the documented tie rules, never by rounding noise.
"""

from __future__ import annotations

import math
import numbers

from .errors import ConfigurationError, ConfigurationTypeError

#: Seconds per tick.
RESOLUTION = 1e-12
#: Ticks per second.
TICKS_PER_SECOND = 10**12
#: The largest instant (and duration) in ticks: traces store ticks as signed 64-bit
#: integers, so every instant of a run stays readable up to 2**63 - 1 ps, about 9.22e6 s
#: (106.7 simulated days).
MAX_TICKS = 2**63 - 1
#: The largest time in seconds :func:`to_ticks` accepts: the largest float whose ticks
#: do not exceed :data:`MAX_TICKS` (``MAX_TICKS / TICKS_PER_SECOND`` itself rounds up to
#: 2**63 ticks).
MAX_SECONDS = math.nextafter(MAX_TICKS / TICKS_PER_SECOND, 0.0)


def to_ticks(seconds: float, what: str = "time", *, allow_negative: bool = False) -> int:
    """Convert a duration or instant in seconds to integer ticks (rounded to nearest).

    Raises :class:`~netcosim.errors.ConfigurationTypeError` (a ``TypeError``) if the
    value is not a real number, and :class:`~netcosim.errors.ConfigurationError` (a
    ``ValueError``) naming *what* and the value if it is not finite, is negative when
    ``allow_negative`` is false, is non-zero but smaller in magnitude than
    :data:`RESOLUTION` (it would round to an instant or a duration it does not mean:
    a period of 1e-13 s would release forever at the same instant), or is larger in
    magnitude than :data:`MAX_SECONDS` (the traces could not hold it).
    """
    if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real):
        raise ConfigurationTypeError(f"{what} must be a real number of seconds, got {seconds!r}")
    try:
        s = float(seconds)
    except OverflowError:           # an int beyond the float range (10**400)
        raise ConfigurationError(f"{what}={seconds!r} s lies beyond netcosim's time range, {MAX_SECONDS:.6g} s") \
            from None
    if not math.isfinite(s):
        raise ConfigurationError(f"{what} must be finite, got {seconds!r}")
    if s < 0 and not allow_negative:
        raise ConfigurationError(f"{what} must be non-negative, got {seconds!r}")
    if s != 0.0 and abs(s) < RESOLUTION:
        raise ConfigurationError(f"{what}={seconds!r} s is non-zero but below the time resolution "
                                 f"{RESOLUTION} s (netcosim.RESOLUTION); use 0 or at least {RESOLUTION} s")
    ticks = int(round(s * TICKS_PER_SECOND)) if abs(s) <= MAX_SECONDS else MAX_TICKS + 1
    if abs(ticks) > MAX_TICKS:      # MAX_SECONDS itself rounds to 2**63 ticks: the range is checked in ticks
        raise ConfigurationError(f"{what}={seconds!r} s lies beyond netcosim's time range, {MAX_SECONDS:.6g} s "
                                 f"(106.7 days: 2**63 - 1 ticks of {RESOLUTION} s, what the traces store)")
    return ticks


def to_seconds(ticks: int) -> float:
    """Convert integer ticks to float seconds (correctly rounded: 2e11 ticks -> 0.2)."""
    return ticks / TICKS_PER_SECOND
