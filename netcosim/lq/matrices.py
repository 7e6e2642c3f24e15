"""Checked matrices for the linear-quadratic layer: real, finite, of the expected shape.

Every function takes the value and ``what`` (the parameter's name as the message should
show it, e.g. ``"ContinuousSystem: A"``) and returns a float ``numpy`` array, or raises

* :class:`~netcosim.errors.ConfigurationTypeError` when the value is not numeric at all
  (a string, None where a matrix is needed, an object);
* :class:`~netcosim.errors.ConfigurationError` when it is numeric but of the wrong shape,
  not square, NaN or infinite, not symmetric or not positive semidefinite.

The message names ``what``, the expected kind and the value.  A scalar stands for a 1x1
matrix; a matrix must otherwise be given two-dimensional (a 1-D list is ambiguous between
a row and a column, so it is refused).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigurationError, ConfigurationTypeError

__all__ = ["matrix", "square", "covariance", "vector", "show"]

#: relative tolerance of the symmetry and semidefiniteness checks (of the largest entry)
PSD_TOLERANCE = 1e-10


def show(value: Any) -> str:
    """A short printable form of *value* for an error message."""
    if isinstance(value, np.ndarray):
        return np.array2string(value, threshold=20, precision=6)
    text = repr(value)
    return text if len(text) <= 200 else text[:197] + "..."


def matrix(value: Any, what: str, shape: tuple[int | None, int | None] | None = None) -> np.ndarray:
    """*value* as a finite 2-D float array (a scalar: 1 x 1); ``shape`` (None entries: any size)
    is checked; *what* names it in errors (e.g. ``"ContinuousSystem: B"``)."""
    if value is None or isinstance(value, (str, bytes, bool)):
        raise ConfigurationTypeError(f"{what} must be a real matrix, got {show(value)}")
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"{what} must be a real matrix, got {show(value)}") from None
    if a.ndim == 0:
        a = a.reshape(1, 1)
    if a.ndim != 2:
        raise ConfigurationError(f"{what} must be a 2-D matrix (a scalar stands for 1x1), "
                                 f"got an array of shape {a.shape}: {show(value)}")
    if not np.all(np.isfinite(a)):
        raise ConfigurationError(f"{what} must be finite (no NaN or inf), got {show(value)}")
    if shape is not None:
        rows, cols = shape
        if (rows is not None and a.shape[0] != rows) or (cols is not None and a.shape[1] != cols):
            want = f"{'any' if rows is None else rows}x{'any' if cols is None else cols}"
            raise ConfigurationError(f"{what} must be {want}, got shape {a.shape[0]}x{a.shape[1]}: {show(value)}")
    return a


def square(value: Any, what: str, n: int | None = None) -> np.ndarray:
    """*value* as a finite square matrix (``n`` x ``n`` if *n* is given); *what* names it in errors."""
    a = matrix(value, what)
    if a.shape[0] != a.shape[1]:
        raise ConfigurationError(f"{what} must be square, got shape {a.shape[0]}x{a.shape[1]}: {show(value)}")
    if n is not None and a.shape[0] != n:
        raise ConfigurationError(f"{what} must be {n}x{n}, got shape {a.shape[0]}x{a.shape[1]}: {show(value)}")
    return a


def covariance(value: Any, what: str, n: int) -> np.ndarray:
    """*value* as a symmetric positive semidefinite ``n`` x ``n`` matrix (a noise intensity or a cost
    weight); None means zero; *what* names it in errors.  Symmetry and the smallest eigenvalue are checked to
    :data:`PSD_TOLERANCE` times the largest entry; the result is symmetrised."""
    if value is None:
        return np.zeros((n, n))
    a = square(value, what, n)
    scale = max(1.0, float(np.max(np.abs(a)))) if a.size else 1.0
    if not np.allclose(a, a.T, rtol=0.0, atol=PSD_TOLERANCE * scale):
        raise ConfigurationError(f"{what} must be symmetric, got {show(value)}")
    a = 0.5 * (a + a.T)
    if a.size:
        lowest = float(np.linalg.eigvalsh(a)[0])
        if lowest < -PSD_TOLERANCE * scale:
            raise ConfigurationError(f"{what} must be positive semidefinite, got {show(value)} "
                                     f"(smallest eigenvalue {lowest:.6g})")
    return a


def vector(value: Any, what: str, n: int) -> np.ndarray:
    """*value* as a finite vector of length *n* (a list, a 1-D array or an n x 1 column); *what*
    names it in errors."""
    if value is None or isinstance(value, (str, bytes, bool)):
        raise ConfigurationTypeError(f"{what} must be a real vector of length {n}, got {show(value)}")
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"{what} must be a real vector of length {n}, got {show(value)}") from None
    if a.ndim == 0 or (a.ndim == 2 and a.shape[1] == 1):
        a = a.reshape(-1)
    if a.ndim != 1 or a.shape[0] != n:
        raise ConfigurationError(f"{what} must be a vector of length {n}, got shape {a.shape}: {show(value)}")
    if not np.all(np.isfinite(a)):
        raise ConfigurationError(f"{what} must be finite (no NaN or inf), got {show(value)}")
    return a
