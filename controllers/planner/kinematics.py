"""Kinematic helpers of the planners: the kinematic model (re-exported from
:mod:`netcosim.plants.kinematic`, the one model shared with the plants), argument checks and the
integration of ``q_dot = A_q^+ u`` over a period.

Units: q in rad and m, robot velocities u in m/s, times and periods in s, gains in 1/s.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
from scipy.integrate import solve_ivp

from netcosim import validate
from netcosim.errors import ConfigurationError
from netcosim.plants.kinematic import (
    SINGULAR_RTOL,
    KinematicSystem,
    SingularConfigurationError,
    as_vector,
    check_system,
    configuration_rate,
    jacobian,
    pinv_solve,
    project,
    rank_rtol,
)

__all__ = ["KinematicSystem", "SingularConfigurationError", "RANK_RTOL", "check_system", "check_period",
           "check_gain_matrix", "diag_gain", "as_vector", "jacobian", "pinv_solve", "configuration_rate",
           "project", "integrate_kinematics", "rank_rtol"]

#: Relative singular-value threshold below which ``A_q`` counts as rank deficient: the
#: project's one rule, :data:`netcosim.plants.kinematic.SINGULAR_RTOL` (1e-8).  A system's own
#: ``singular_tol`` takes precedence (:func:`netcosim.plants.kinematic.rank_rtol`).
RANK_RTOL = SINGULAR_RTOL


def check_period(T: float, what: str = "sampling period T") -> float:
    """Return ``float(T)`` or raise ``ValueError`` if T is not a finite positive number (s);
    *what* names it in the error."""
    return validate.positive(T, what, kind="a finite positive number of seconds", type_error=ConfigurationError)


def check_gain_matrix(K: Any, m: int | None = None) -> np.ndarray:
    """Return *K* as an ``(m, m)`` array, raising unless ``K + K^T`` is positive definite.

    A scalar or a vector is read as ``k I`` or ``diag(k)``.  Proposition 3.3.1 needs
    ``K + K^T > 0``; the smallest eigenvalue of the symmetric part is reported on failure.
    """
    K = np.asarray(K, dtype=float)
    if K.ndim == 0:
        if m is None:
            raise ValueError("a scalar gain needs the dimension m")
        K = float(K) * np.eye(m)
    elif K.ndim == 1:
        K = np.diag(K)
    if K.ndim != 2 or K.shape[0] != K.shape[1] or (m is not None and K.shape[0] != m):
        raise ValueError(f"gain matrix must be {m}x{m}, got shape {K.shape}")
    if not np.all(np.isfinite(K)):
        raise ValueError(f"gain matrix has non-finite entries: {K}")
    lam = float(np.linalg.eigvalsh(K + K.T).min())
    if lam <= 0.0:
        raise ValueError(f"gain matrix K must satisfy K + K^T > 0 (Proposition 3.3.1); "
                         f"smallest eigenvalue of K + K^T is {lam:.6g}")
    return K


def diag_gain(kbar: Any, m: int) -> np.ndarray:
    """The diagonal of ``K_bar`` (4.14) as a length-m vector of positive gains, from *kbar*: None
    (ones), a scalar, a length-m vector or a diagonal m x m matrix."""
    if kbar is None:
        return np.ones(m)
    k = np.asarray(kbar, dtype=float)
    if k.ndim == 0:
        k = np.full(m, float(k))
    elif k.ndim == 2:
        if k.shape != (m, m) or np.any(k - np.diag(np.diag(k))):
            raise ValueError(f"K_bar must be a diagonal {m}x{m} matrix, got {k}")
        k = np.diag(k).copy()
    if k.shape != (m,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise ValueError(f"K_bar must have {m} positive finite diagonal entries, got {np.asarray(kbar).tolist()}")
    return k


def integrate_kinematics(system: Any, q0: Any, u: Callable[[float], np.ndarray] | np.ndarray,
                         t0: float, t1: float, *, rtol: float = 1e-12, atol: float = 1e-13,
                         method: str = "DOP853", dense: bool = False):
    """Integrate ``q_dot = A_q^+ u(t)`` from t0 to t1 (s); returns ``q(t1)`` (and the
    ``OdeSolution`` when ``dense``).  ``u`` is a constant vector or a callable of t.
    *system*: the kinematic system; *q0*: the initial configuration; *method*, *rtol*,
    *atol*: :func:`scipy.integrate.solve_ivp`'s."""
    q0 = as_vector(q0, system.m, "q0")
    rank_tol = rank_rtol(system)
    if callable(u):
        ufun = u
    else:
        uc = as_vector(u, system.n, "u")
        ufun = lambda t: uc  # noqa: E731

    def rhs(t, q):
        return pinv_solve(jacobian(system, q), ufun(t), q, rank_tol)

    sol = solve_ivp(rhs, (t0, t1), q0, method=method, rtol=rtol, atol=atol, dense_output=dense)
    if sol.status != 0:
        raise RuntimeError(f"kinematic integration failed on [{t0}, {t1}] s: {sol.message}")
    return (sol.y[:, -1].copy(), sol.sol) if dense else sol.y[:, -1].copy()
