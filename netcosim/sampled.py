"""Sampled signals as :mod:`netcosim.metrics` integrates them: the checks of sample times
and values, the error against a reference, the window ``[start, until]`` (s) under a hold
(``"zoh"`` or ``"linear"``), the zero crossings of the interpolant, and the instant a
signal settles into a band.

The rules (what the holds mean, which values are refused, the window's defaults) are
stated in :mod:`netcosim.metrics`, whose public functions these helpers serve.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import validate
from .errors import ConfigurationError, ConfigurationTypeError

__all__: list[str] = []


def _times(t: Any, what: str) -> np.ndarray:
    try:
        arr = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"{what}: sample times must be numbers (s), got {t!r}") from None
    if arr.ndim != 1:
        raise ConfigurationError(f"{what}: sample times must be one-dimensional, got shape {arr.shape}")
    if arr.size == 0:
        raise ConfigurationError(f"{what}: no samples (empty time array)")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ConfigurationError(f"{what}: sample time t[{bad[0]}]={float(arr[bad[0]])!r} is not finite")
    back = np.flatnonzero(np.diff(arr) < 0)
    if back.size:
        k = back[0]
        raise ConfigurationError(f"{what}: sample times must be sorted (non-decreasing); "
                                 f"t[{k + 1}]={float(arr[k + 1])!r} < t[{k}]={float(arr[k])!r}")
    return arr


def _values(v: Any, n: int, what: str, *, columns: bool = False) -> np.ndarray:
    try:
        arr = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"{what}: values must be numbers, got {v!r}") from None
    if columns and arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != (2 if columns else 1):
        raise ConfigurationError(f"{what}: values must be {'a (samples, n) array' if columns else 'one-dimensional'}"
                                 f", got shape {arr.shape}")
    if arr.shape[0] != n:
        raise ConfigurationError(f"{what}: {arr.shape[0]} values for {n} sample times (lengths must match)")
    return arr


def _no_nan(t: np.ndarray, v: np.ndarray, what: str) -> None:
    """Refuse NaN values (an integral of them would be NaN), naming the first one's index
    and time.  (:func:`settling_time` does not call it: NaN there means "not settled".)"""
    nan = np.flatnonzero(np.isnan(v).any(axis=1) if v.ndim == 2 else np.isnan(v))
    if nan.size:
        k = int(nan[0])
        raise ConfigurationError(f"{what}: the value at index {k} (t={float(t[k])!r} s) is NaN"
                                 + (f", and {nan.size - 1} more" if nan.size > 1 else "")
                                 + ": an integral over it would be NaN")


def _tidy_names(df: Any) -> np.ndarray:
    """``"<source>.<signal>"`` of every row of a tidy signals table."""
    return (df["source"].astype(str) + "." + df["signal"].astype(str)).to_numpy()


def _unknown(message: str) -> Exception:
    """:class:`netcosim.trace.UnknownSignalError` (a ``KeyError`` too) with *message*."""
    from .trace import UnknownSignalError
    return UnknownSignalError(message)


def _error(t: np.ndarray, v: np.ndarray, reference: Any) -> np.ndarray:
    if reference is None:
        return v
    if callable(reference):
        r = np.array([float(reference(x)) for x in t])
    else:
        r = np.full(t.size, validate.finite(reference, "reference"))
    return r - v


def _window(t: np.ndarray, v: np.ndarray, start, until, hold: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Samples restricted to ``[start, until]``, with exact values at both ends (held or
    interpolated); returns ``(t, v, start)``.  *v* may be (n,) or (n, k)."""
    s = t[0] if start is None else validate.finite(start, "start (s)")
    e = t[-1] if until is None else validate.finite(until, "until (s)")
    s, e = float(s), float(e)
    first, last = float(t[0]), float(t[-1])
    if s < first:
        raise ConfigurationError(f"start={start!r} s is before the first sample at t={first!r} s")
    if until is None and s > e:
        raise ConfigurationError(f"start={start!r} s is after the last sample at t={last!r} s")
    if e < s:
        raise ConfigurationError(f"until={until!r} s is before start={s!r} s")
    if e == s:
        raise ConfigurationError(f"the window from start={s!r} s to until={e!r} s has zero length (the samples "
                                 f"span t={first!r} to {last!r} s): nothing to integrate over")

    def at(x):
        if hold == "zoh" or x >= t[-1]:
            return v[np.searchsorted(t, x, side="right") - 1]
        k = np.searchsorted(t, x, side="right") - 1
        if t[k] == x:
            return v[k]
        w = (x - t[k]) / (t[k + 1] - t[k])
        return (1 - w) * v[k] + w * v[k + 1]

    inside = (t > s) & (t < e)
    tt = np.concatenate(([s], t[inside], [e]))
    vv = np.concatenate(([at(s)], v[inside], [at(e)]))
    return tt, vv, s


def _split_at_zeros(t: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Insert the zero crossings of the linear interpolant (exact, for IAE/ITAE)."""
    a, b = e[:-1], e[1:]
    k = np.flatnonzero(a * b < 0)
    if k.size == 0:
        return t, e
    tc = t[k] + (t[k + 1] - t[k]) * a[k] / (a[k] - b[k])
    return np.insert(t, k + 1, tc), np.insert(e, k + 1, 0.0)


def _settling(t: np.ndarray, y: np.ndarray, s: float, final, band, abs_band, hold: str) -> float:
    yf = y[-1] if final is None else validate.finite(final, "settling_time: final")
    if abs_band is not None:
        width = validate.non_negative(abs_band, "settling_time: abs_band")
    else:
        frac = validate.non_negative(band, "settling_time: band (fraction of the step)")
        width = frac * abs(yf - y[0])
        if width == 0.0 and frac > 0.0:
            raise ConfigurationError(f"settling_time: no step to settle from: final={yf!r} equals the value at "
                                     f"start ({y[0]!r}); give abs_band (signal units) instead")
    if not np.all(np.isfinite(y)):
        return math.inf
    out = np.flatnonzero(np.abs(y - yf) > width)
    if out.size == 0:
        return 0.0
    k = int(out[-1])
    if k == y.size - 1:
        return math.inf
    if hold == "zoh":
        return float(t[k + 1] - s)
    a, b = y[k], y[k + 1]
    level = yf + math.copysign(width, a - yf)
    return float(t[k] + (t[k + 1] - t[k]) * (level - a) / (b - a) - s)
