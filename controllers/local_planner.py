"""Kinematic local planners for star-shaped multi-robot systems (thesis ch. 3 and 4).

A *kinematic system* is any object with

* ``n``, ``m``: the dimensions of ``p`` (stacked robot positions, m) and ``q``
  (configuration: cable angles in rad, pivot pose in m and rad);
* ``h(q) -> p`` (numpy, shape ``(n,)``) and ``jacobian(q) -> A_q`` (shape ``(n, m)``).

Every law here is written against that duck-typed interface, so it works on any system
of the class (the Fly-crane configurations of :mod:`plants.flycrane`, the 2-D formation,
...).  The robots are velocity controlled, ``p_dot = u`` (3.4); when ``n > m`` only the
projection of ``u`` onto ``Im A_q`` is realised (4.4)-(4.5) and the configuration moves as

    q_dot = A_q^+ u                                                   (3.7), (4.6), (4.13)

with ``A_q^+`` the Moore-Penrose inverse (``A_q^{-1}`` when ``n == m``).

Laws
----
* :func:`planner_velocity` -- continuous local planner ``u = -A_q K (q - q_r)``
  (3.8)/(4.14), centralized form;
* :func:`robot_velocity` -- its sparse per-robot form (3.10) for a block-diagonal
  ``K = diag(K_1, ..., K_N, K_V)``: robot *i* needs only its own ``q_i`` and the pivot
  pose ``q_V``;
* :func:`solve_auxiliary_flow` -- the auxiliary flow (3.12)/(4.17) whose solution gives
  the sampled closed loop by time rescaling (3.13)/(4.18), with ``tau_s`` found by event
  detection and ``tau_o`` by minimising the error norm over ``[0, tau_s]``;
* :func:`online_gain` -- ``k_h = tau_o(e_h) / T`` (3.26)/(4.30);
* :func:`simulate_sampled` -- the sampled planner (3.11)/(4.16) in closed loop with the
  kinematic model, offline or online gain.

Conventions: errors are ``e = q - q_r``; the thesis's ``(3.10)`` is printed without the
minus sign of (3.8), we keep the sign of (3.8) so that both forms give the same ``u``.
"""

from __future__ import annotations

import bisect
import hashlib
import math
import os
import shutil
import stat
import subprocess
import tempfile
import warnings
import weakref
from dataclasses import dataclass, field
from typing import Any, Callable

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp
from scipy.integrate._ivp import dop853_coefficients as _dop

# One exception class and one rank rule for the whole project (the rule, its threshold and
# why are documented at plants.flycrane.kinematics.SINGULAR_RTOL).
from netcosim.errors import SingularConfigurationError
from plants.flycrane.kinematics import SINGULAR_RTOL, check_singular_values, conditioning

__all__ = [
    "SingularConfigurationError", "StarStructure", "WeightedNorm", "check_system",
    "check_gain_matrix", "check_period", "planner_velocity", "robot_velocity",
    "configuration_rate", "project", "AuxiliaryFlow", "DenseFlow", "solve_auxiliary_flow",
    "online_gain", "OfflineGain", "OnlineGain", "sampled_velocity", "simulate_sampled", "integrate_kinematics",
    "CompiledCodeWarning", "cache_dir",
]




# ---------------------------------------------------------------------------
# Input validation
# ---------------------------------------------------------------------------

def check_system(system: Any) -> Any:
    """Raise ``TypeError`` unless *system* has ``n``, ``m``, ``h`` and ``jacobian``."""
    missing = [a for a in ("n", "m", "h", "jacobian") if not hasattr(system, a)]
    if missing:
        raise TypeError(f"{system!r} is not a kinematic system: missing {missing} "
                        "(need n, m, h(q) and jacobian(q))")
    n, m = system.n, system.m
    if not (isinstance(n, (int, np.integer)) and isinstance(m, (int, np.integer)) and n > 0 and m > 0):
        raise ValueError(f"system dimensions must be positive integers, got n={n!r}, m={m!r}")
    return system


def check_period(T: float, what: str = "sampling period T") -> float:
    """Return ``float(T)`` or raise ``ValueError`` if T is not a finite positive number (s)."""
    if isinstance(T, bool) or not isinstance(T, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(T)) or float(T) <= 0.0:
        raise ValueError(f"{what} must be a finite positive number of seconds, got {T!r}")
    return float(T)


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


def _diag_gain(kbar: Any, m: int) -> np.ndarray:
    """The diagonal of ``K_bar`` (4.14) as a length-m vector of positive gains."""
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


def _vec(x: Any, size: int, what: str) -> np.ndarray:
    v = np.asarray(x, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise ValueError(f"{what} must have {size} entries, got {v.shape[0]}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be finite, got {v.tolist()}")
    return v


# ---------------------------------------------------------------------------
# Norms
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class WeightedNorm:
    """``||e||_{D,p} = ||D e||_p`` with ``D = diag(weights)``, ``p`` in {2, inf} (ch. 4).

    ``weights=None`` is the Euclidean (or max) norm of ch. 3.  The weights multiply the
    error components (e.g. ``D = diag(I_4, 4 I_6)`` of Sec. 4.6 weighs pose errors 4x).
    """

    weights: tuple[float, ...] | None = None
    p: float = 2

    def __post_init__(self):
        if self.p not in (2, math.inf):
            raise ValueError(f"norm order p must be 2 or inf, got {self.p!r}")
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=float).reshape(-1)
            if not np.all(np.isfinite(w)) or np.any(w <= 0):
                raise ValueError(f"norm weights must be positive and finite, got {w.tolist()}")
            object.__setattr__(self, "weights", tuple(float(x) for x in w))

    @classmethod
    def of(cls, norm: "WeightedNorm | float | str | None") -> "WeightedNorm":
        """Coerce ``None`` / ``2`` / ``"inf"`` / ``math.inf`` / a WeightedNorm."""
        if norm is None:
            return cls()
        if isinstance(norm, WeightedNorm):
            return norm
        if isinstance(norm, str):
            if norm.lower() in ("inf", "infinity", "max"):
                return cls(p=math.inf)
            if norm == "2":
                return cls()
        if norm in (2, math.inf):
            return cls(p=norm)
        raise ValueError(f"unknown norm {norm!r}; use 2, 'inf' or a WeightedNorm")

    def w(self, m: int) -> np.ndarray:
        if self.weights is None:
            return np.ones(m)
        if len(self.weights) != m:
            raise ValueError(f"norm has {len(self.weights)} weights, the configuration has {m} entries")
        return np.asarray(self.weights)

    def __call__(self, e: np.ndarray) -> float:
        e = np.asarray(e, dtype=float)
        x = e if self.weights is None else self.w(e.shape[-1]) * e
        if self.p == 2:
            return float(np.sqrt(np.dot(x, x)))
        return float(np.max(np.abs(x)))

    def many(self, E: np.ndarray) -> np.ndarray:
        """Norms of the rows of *E* (shape ``(k, m)``)."""
        E = np.asarray(E, dtype=float)
        X = E if self.weights is None else E * self.w(E.shape[-1])
        if self.p == 2:
            return np.sqrt(np.einsum("ij,ij->i", X, X))
        return np.max(np.abs(X), axis=1)

    def sample_ball(self, rng: np.random.Generator, m: int, radius: float, size: int) -> np.ndarray:
        """*size* points drawn uniformly in ``{e : ||e|| < radius}`` (shape ``(size, m)``)."""
        if self.p == 2:
            x = rng.standard_normal((size, m))
            x /= np.linalg.norm(x, axis=1, keepdims=True)
            x *= radius * rng.random((size, 1)) ** (1.0 / m)
        else:
            x = rng.uniform(-radius, radius, (size, m))
        return x / self.w(m)


# ---------------------------------------------------------------------------
# Star structure (sparsity of (3.3)) and the laws
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class StarStructure:
    """Which rows of ``p`` and columns of ``q`` belong to each robot, and the pivot's columns.

    ``rows[i]``: indices of robot *i*'s entries of ``p`` (``p_i``);
    ``cols[i]``: indices of ``q_i`` (its cable angles, may be empty);
    ``pivot``: indices of ``q_V`` (pivot pose).  Robot *i*'s rows of ``A_q`` are zero
    outside ``cols[i]`` and ``pivot`` (3.3).
    """

    rows: tuple[tuple[int, ...], ...]
    cols: tuple[tuple[int, ...], ...]
    pivot: tuple[int, ...]

    def __post_init__(self):
        if len(self.rows) != len(self.cols) or not self.rows:
            raise ValueError(f"need one row set and one column set per robot, got {len(self.rows)} and {len(self.cols)}")
        object.__setattr__(self, "rows", tuple(tuple(int(i) for i in r) for r in self.rows))
        object.__setattr__(self, "cols", tuple(tuple(int(i) for i in c) for c in self.cols))
        object.__setattr__(self, "pivot", tuple(int(i) for i in self.pivot))
        allc = [c for cs in self.cols for c in cs] + list(self.pivot)
        if len(set(allc)) != len(allc):
            raise ValueError(f"robot and pivot columns overlap: {self.cols}, {self.pivot}")
        allr = [r for rs in self.rows for r in rs]
        if len(set(allr)) != len(allr):
            raise ValueError(f"robot rows overlap: {self.rows}")

    @property
    def N(self) -> int:
        """Number of robots."""
        return len(self.rows)

    @property
    def n(self) -> int:
        return sum(len(r) for r in self.rows)

    @property
    def m(self) -> int:
        return sum(len(c) for c in self.cols) + len(self.pivot)

    @classmethod
    def uniform(cls, N: int, n_i: int = 3, m_i: int = 1, m_V: int = 6) -> "StarStructure":
        """``p = [p_1..p_N]`` with ``n_i`` entries each, ``q = [q_1..q_N, q_V]`` (Fly-crane layout)."""
        if N < 1 or n_i < 1 or m_i < 0 or m_V < 1:
            raise ValueError(f"invalid structure N={N}, n_i={n_i}, m_i={m_i}, m_V={m_V}")
        rows = tuple(tuple(range(i * n_i, (i + 1) * n_i)) for i in range(N))
        cols = tuple(tuple(range(i * m_i, (i + 1) * m_i)) for i in range(N))
        pivot = tuple(range(N * m_i, N * m_i + m_V))
        return cls(rows, cols, pivot)

    @classmethod
    def for_system(cls, system: Any, m_V: int | None = None) -> "StarStructure":
        """The structure of *system*: its ``structure`` attribute or ``block_indices()``
        if it has one, else the uniform layout with ``N = m - m_V`` one-angle robots (``m_V`` = 6 unless given)."""
        s = getattr(system, "structure", None)
        if isinstance(s, StarStructure):
            return s
        if hasattr(system, "block_indices"):  # plants.flycrane.MultiRobotSystem
            rows, cols, pivot = system.block_indices()
            return cls(rows, cols, pivot)
        check_system(system)
        m_V = 6 if m_V is None else m_V
        N = system.m - m_V
        if N < 1 or system.n % N:
            raise ValueError(f"cannot infer a star structure for n={system.n}, m={system.m}, m_V={m_V}; "
                             "pass a StarStructure")
        return cls.uniform(N, system.n // N, 1, m_V)

    def agent_q(self, i: int) -> np.ndarray:
        """Indices of ``(q_i, q_V)`` in ``q``: what robot *i*'s law reads."""
        return np.asarray(self.cols[i] + self.pivot, dtype=int)


def _jacobian(system: Any, q: np.ndarray) -> np.ndarray:
    A = np.asarray(system.jacobian(q), dtype=float)
    if A.shape != (system.n, system.m):
        raise ValueError(f"jacobian returned shape {A.shape}, expected ({system.n}, {system.m})")
    if not np.all(np.isfinite(A)):
        raise SingularConfigurationError(f"jacobian is not finite at q={np.asarray(q).tolist()}")
    return A


def planner_velocity(system: Any, q: Any, q_ref: Any, K: Any = 1.0) -> np.ndarray:
    """Centralized local planner ``u = -A_q K (q - q_r)`` (3.8)/(4.14), in m/s.

    ``K``: scalar, diagonal vector or matrix; validated with :func:`check_gain_matrix`.
    """
    check_system(system)
    m = system.m
    q = _vec(q, m, "q")
    e = q - _vec(q_ref, m, "q_ref")
    K = check_gain_matrix(K, m)
    return _jacobian(system, q) @ (-(K @ e))


def robot_velocity(system: Any, structure: StarStructure, i: int, q_i: Any, q_V: Any,
                   q_ref: Any, K: Any = 1.0) -> np.ndarray:
    """Sparse per-robot planner (3.10): robot *i*'s velocity from ``(q_i, q_V)`` only.

    ``u_i = -A^(i)_{q_i} K_i (q_i - q_i^r) - A^(i)_{q_V} K_V (q_V - q_V^r)``.

    ``K``: scalar or length-m vector of diagonal gains (``K = diag(K_1..K_N, K_V)``
    block diagonal with diagonal blocks, as in Sec. 4.4).  Robot *i*'s rows of ``A_q``
    are evaluated at a configuration that holds ``(q_i, q_V)`` and the reference values
    elsewhere -- they do not depend on the other robots' coordinates (3.3).
    """
    check_system(system)
    m = system.m
    if not 0 <= i < structure.N:
        raise IndexError(f"robot index {i} out of range for {structure.N} robots")
    q_ref = _vec(q_ref, m, "q_ref")
    kd = _diag_gain(K, m)
    ci = np.asarray(structure.cols[i], dtype=int)
    cv = np.asarray(structure.pivot, dtype=int)
    q_i = _vec(q_i, len(ci), f"q_{i}")
    q_V = _vec(q_V, len(cv), "q_V")
    q = q_ref.copy()
    q[ci] = q_i
    q[cv] = q_V
    A = _jacobian(system, q)
    rows = np.asarray(structure.rows[i], dtype=int)
    idx = structure.agent_q(i)
    e = q[idx] - q_ref[idx]
    return A[np.ix_(rows, idx)] @ (-(kd[idx] * e))


#: Relative singular-value threshold below which ``A_q`` counts as rank deficient: the
#: project's one rule, :data:`plants.flycrane.kinematics.SINGULAR_RTOL` (1e-8).
RANK_RTOL = SINGULAR_RTOL


def _pinv_apply(A: np.ndarray, v: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``A^+ v`` for a full-rank A (``A^{-1} v`` when square).

    Solved by SVD least squares; :func:`plants.flycrane.kinematics.check_singular_values`
    (singular when ``sigma_min <= RANK_RTOL * sigma_max``) raises
    :class:`SingularConfigurationError` naming q, the rank, the smallest singular value
    and the condition number.
    """
    x, _, _, sv = np.linalg.lstsq(A, v, rcond=RANK_RTOL)
    check_singular_values(sv, f"q={np.asarray(q).tolist()}", RANK_RTOL)
    return x


def configuration_rate(system: Any, q: Any, u: Any) -> np.ndarray:
    """``q_dot = A_q^+ u`` (3.7)/(4.6)/(4.13): configuration rate under robot velocities u."""
    check_system(system)
    q = _vec(q, system.m, "q")
    u = _vec(u, system.n, "u")
    return _pinv_apply(_jacobian(system, q), u, q)


def project(system: Any, q: Any, u: Any) -> np.ndarray:
    """``Pi_q u = A_q A_q^+ u``: the closest feasible robot velocity to u (4.4)."""
    q = _vec(q, system.m, "q")
    A = _jacobian(system, q)
    return A @ _pinv_apply(A, _vec(u, system.n, "u"), q)


def integrate_kinematics(system: Any, q0: Any, u: Callable[[float], np.ndarray] | np.ndarray,
                         t0: float, t1: float, *, rtol: float = 1e-12, atol: float = 1e-13,
                         method: str = "DOP853", dense: bool = False):
    """Integrate ``q_dot = A_q^+ u(t)`` from t0 to t1 (s); returns ``q(t1)`` (and the
    ``OdeSolution`` when ``dense``).  ``u`` is a constant vector or a callable of t."""
    q0 = _vec(q0, system.m, "q0")
    if callable(u):
        ufun = u
    else:
        uc = _vec(u, system.n, "u")
        ufun = lambda t: uc  # noqa: E731

    def rhs(t, q):
        return _pinv_apply(_jacobian(system, q), ufun(t), q)

    sol = solve_ivp(rhs, (t0, t1), q0, method=method, rtol=rtol, atol=atol, dense_output=dense)
    if sol.status != 0:
        raise RuntimeError(f"kinematic integration failed on [{t0}, {t1}] s: {sol.message}")
    return (sol.y[:, -1].copy(), sol.sol) if dense else sol.y[:, -1].copy()


# ---------------------------------------------------------------------------
# The auxiliary flow (3.12)/(4.17)
# ---------------------------------------------------------------------------

#: Default integrator tolerances for the auxiliary flow: relative, and absolute as a
#: fraction of ||e_h||_2 (the flow scales with e_h).
FLOW_RTOL = 1e-10
FLOW_ATOL_REL = 1e-12
#: Absolute tolerance (in tau) of the minimisation giving tau_o.
TAU_XTOL = 1e-10
#: Compile the flow of systems that provide a CasADi Jacobian (``A_fun``) to machine
#: code with the C compiler ``$CC`` (default ``cc``), cached on disk in :func:`cache_dir`
#: (``$NETCOSIM_CACHE_DIR``, default ``$XDG_CACHE_HOME/netcosim`` or ``~/.cache/netcosim``;
#: private directory, libraries checked against a sha256 recorded at build time).
#: Read when a system's flow is first prepared.  Without a compiler, or when False, the
#: same CasADi functions run in CasADi's virtual machine (a step about 6x slower); the
#: former case issues one :class:`CompiledCodeWarning`.
COMPILE_FLOW = True
#: A QR pivot of ``A_q`` below this fraction of the largest one anywhere in a step of the
#: CasADi flow sends the whole flow back to the SVD right-hand side (rank test
#: :data:`RANK_RTOL`), which raises :class:`SingularConfigurationError` if needed.
PIVOT_RTOL = 1e-7

# DOP853 (Hairer, Norsett & Wanner): the tableau of SciPy's implementation.

_NS = _dop.N_STAGES                      # 12 stages; the 13th is f at the new point
_A, _B = _dop.A, _dop.B                  # the flow is autonomous: no C
_E3, _E5, _D = _dop.E3, _dop.E5, _dop.D
_NSX = _dop.N_STAGES_EXTENDED           # + 3 stages for the dense output


def _dense_to_monomial() -> np.ndarray:
    """Matrix M (7x7) with ``y(x) - y_old = sum_k (M F)_k x^(k+1)`` for DOP853's dense
    output ``x(F0 + (1-x)(F1 + x(F2 + (1-x)(F3 + x(F4 + (1-x)(F5 + x F6))))))``."""
    P = np.polynomial.polynomial
    M = np.zeros((7, 7))
    for j in range(7):
        poly = np.zeros(1)
        for i in range(6, -1, -1):
            poly = P.polyadd(poly, [1.0 if i == j else 0.0])
            poly = P.polymul(poly, [0.0, 1.0] if i % 2 == 0 else [1.0, -1.0])
        M[:len(poly) - 1, j] = poly[1:]
    return M


_MONO = _dense_to_monomial()
_POWERS = np.arange(1, 8)
#: Relative tolerance of the event location (tau_s) on the dense output.
EVENT_XTOL = 64 * np.finfo(float).eps


class _FallBack(Exception):
    """The compiled flow met a (near-)singular A_q or a non-finite value."""


class _SVDFlow:
    """DOP853 stages of the flow with the SVD right-hand side ``-A^+_{q_r + x} c``
    (:func:`_pinv_apply`): works for any kinematic system and raises
    :class:`SingularConfigurationError` where ``A_q`` loses rank."""

    def __init__(self, system, q_ref, c):
        self.system, self.q_ref, self.c = system, q_ref, c
        self.K = np.empty((_NSX, q_ref.shape[0]))
        self.nfev = 0

    def rhs(self, x):
        self.nfev += 1
        q = self.q_ref + x
        return -_pinv_apply(_jacobian(self.system, q), self.c, q)

    def step(self, y, f, h):
        K = self.K
        K[0] = f
        for s in range(1, _NS):
            K[s] = self.rhs(y + h * (K[:s].T @ _A[s, :s]))
        y_new = y + h * (K[:_NS].T @ _B)
        K[_NS] = f_new = self.rhs(y_new)
        self._y, self._h = y, h
        return y_new, f_new, K[:_NS + 1].T @ _E5, K[:_NS + 1].T @ _E3

    def dense(self, y_new):
        """The 7 dense-output vectors of the last step (3 more stages)."""
        K, y, h = self.K, self._y, self._h
        for s in range(_NS + 1, _NSX):
            K[s] = self.rhs(y + h * (K[:s].T @ _A[s, :s]))
        dy = y_new - y
        F = np.empty((7, y.shape[0]))
        F[0] = dy
        F[1] = h * K[0] - dy
        F[2] = 2.0 * dy - h * (K[_NS] + K[0])
        F[3:] = h * (_D @ K)
        return F


def _casadi_flow_functions(system):
    """CasADi Functions ``rhs(x, c, q_r) -> (f, piv)`` and ``step(y, f, h, c, q_r) ->
    (y_new, f_new, err5, err3, F, piv)`` of the flow, or None if *system* has no
    symbolic Jacobian ``A_fun``.  ``f = -A^+ c`` by QR (modified Gram-Schmidt),
    ``piv = min |R_ii| / max |R_ii|``; ``step`` is one DOP853 step with its dense output,
    the smallest ``piv`` of its stages and the sum of all stages (not finite if one is not)."""
    A_fun = getattr(system, "A_fun", None)
    n, m = int(system.n), int(system.m)
    if not isinstance(A_fun, ca.Function) or n < m or A_fun.n_in() != 1 or A_fun.n_out() < 1 \
            or A_fun.size_in(0) != (m, 1) or A_fun.size_out(0) != (n, m):
        return None
    x, c, qr = ca.SX.sym("x", m), ca.SX.sym("c", n), ca.SX.sym("q_r", m)
    try:
        A = ca.densify(A_fun(qr + x))
    except (RuntimeError, NotImplementedError):  # e.g. an MX-only Function (CasADi raises RuntimeError)
        return None
    Q, R = ca.qr(A)
    dR = ca.fabs(ca.diag(R))
    rhs = ca.Function("flow_rhs", [x, c, qr], [-ca.solve(R, Q.T @ c), ca.mmin(dR) / ca.mmax(dR)],
                      {"never_inline": True})
    y, f0, h = ca.SX.sym("y", m), ca.SX.sym("f", m), ca.SX.sym("h")
    K, piv = [f0], []

    def stage(s):
        dy = ca.SX.zeros(m)
        for j in range(s):
            if _A[s, j] != 0.0:
                dy += float(_A[s, j]) * K[j]
        fs, ps = rhs(y + h * dy, c, qr)
        K.append(fs)
        piv.append(ps)

    for s in range(1, _NS):
        stage(s)
    y_new = y + h * sum(float(_B[j]) * K[j] for j in range(_NS) if _B[j] != 0.0)
    f_new, p_new = rhs(y_new, c, qr)
    K.append(f_new)
    piv.append(p_new)
    for s in range(_NS + 1, _NSX):
        stage(s)
    err5 = sum(float(_E5[j]) * K[j] for j in range(_NS + 1) if _E5[j] != 0.0)
    err3 = sum(float(_E3[j]) * K[j] for j in range(_NS + 1) if _E3[j] != 0.0)
    dy = y_new - y
    F = [dy, h * K[0] - dy, 2.0 * dy - h * (f_new + K[0])]
    for r in range(_D.shape[0]):
        F.append(h * sum(float(_D[r, j]) * K[j] for j in range(_NSX) if _D[r, j] != 0.0))
    step = ca.Function("flow_step", [y, f0, h, c, qr],
                       [y_new, f_new, err5, err3, ca.horzcat(*F), ca.mmin(ca.vertcat(*piv)),
                        ca.sum1(ca.sum2(ca.horzcat(*K)))])
    return rhs, step


class CompiledCodeWarning(UserWarning):
    """The compiled flow could not be built or loaded (no C compiler, a build error, an
    unsafe cache directory); the same CasADi functions run uncompiled instead: the same
    numbers, a step about 6x slower.  Issued once per process."""


_warned_fallback = False


def _warn_fallback(reason: str) -> None:
    global _warned_fallback
    if not _warned_fallback:
        _warned_fallback = True
        warnings.warn(f"netcosim: compiled flow unavailable, running it uncompiled (same results, slower): "
                      f"{reason}", CompiledCodeWarning, stacklevel=4)


def cache_dir() -> str:
    """Directory of the compiled-code cache: ``$NETCOSIM_CACHE_DIR`` if set (the older
    name ``$NETCOSIM_CACHE`` is still read), else ``$XDG_CACHE_HOME/netcosim``, else
    ``~/.cache/netcosim``."""
    root = os.environ.get("NETCOSIM_CACHE_DIR") or os.environ.get("NETCOSIM_CACHE")
    if root:
        return root
    return os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
                        "netcosim")


def _safe_cache_dir() -> tuple[str | None, str]:
    """``(directory, "")`` if the cache directory exists or was created (mode 0o700), is
    a real directory (not a symbolic link), is owned by the current user and is not
    writable by group or others; else ``(None, why)``.  Nobody else can then plant or
    swap a library in it."""
    root = cache_dir()
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        st = os.lstat(root)
    except OSError as exc:
        return None, f"cannot create the cache directory {root!r}: {exc}"
    if not stat.S_ISDIR(st.st_mode):
        return None, f"cache path {root!r} is not a directory (a symbolic link or a file)"
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return None, f"cache directory {root!r} is owned by uid {st.st_uid}, not by the current user {os.getuid()}"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return None, (f"cache directory {root!r} is writable by group or others (mode {stat.S_IMODE(st.st_mode):#o}); "
                      f"not loading code from it (chmod 700 it to use the cache)")
    return root, ""


def _sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _verified(lib: str) -> bool:
    """Whether *lib* is a regular file whose sha256 matches the digest recorded beside it
    (``lib + ".sha256"``) when it was built."""
    side = lib + ".sha256"
    try:
        if not (stat.S_ISREG(os.lstat(lib).st_mode) and stat.S_ISREG(os.lstat(side).st_mode)):
            return False
        with open(side) as fh:
            recorded = fh.read().strip()
        return recorded == _sha256_file(lib)
    except OSError:
        return False


def _build(cc: str, flags: list, src: str, root: str, tag: str, lib: str) -> None:
    """Compile *src* into *lib* and record the sha256 of the library in ``lib.sha256``;
    both appear atomically (built in a private temporary directory, then renamed)."""
    with tempfile.TemporaryDirectory(dir=root) as tmp:
        csrc, out = os.path.join(tmp, f"{tag}.c"), os.path.join(tmp, f"{tag}.so")
        with open(csrc, "w") as fh:
            fh.write(src)
        subprocess.run([cc, *flags, csrc, "-o", out, "-lm"], check=True, capture_output=True, timeout=300)
        side = out + ".sha256"
        with open(side, "w") as fh:
            fh.write(_sha256_file(out) + "\n")
        os.replace(out, lib)
        os.replace(side, lib + ".sha256")


def _compile(funs, tag):
    """The CasADi Functions *funs* compiled to a shared library, or *funs* themselves.

    The library is cached in :func:`cache_dir` under a name holding a hash of its C
    source, the CasADi version, the compiler and its flags; the sha256 of the library
    bytes is recorded beside it at build time and checked before every load (a library
    that does not match is rebuilt, never loaded).  The directory must be private (see
    :func:`_safe_cache_dir`).  When the cache is unsafe, the compiler is missing or
    fails, or CasADi cannot load the result, the uncompiled *funs* are returned and a
    :class:`CompiledCodeWarning` is issued (once per process).  ``COMPILE_FLOW = False``
    returns *funs* silently.
    """
    if not COMPILE_FLOW:
        return funs
    cc_name = os.environ.get("CC") or "cc"
    cc = shutil.which(cc_name)
    if cc is None:
        _warn_fallback(f"C compiler {cc_name!r} not found (set $CC)")
        return funs
    root, why = _safe_cache_dir()
    if root is None:
        _warn_fallback(why)
        return funs
    flags = ["-O2", "-shared", "-fPIC"]
    try:
        cg = ca.CodeGenerator(f"{tag}.c", {"with_header": False})
        for f in funs:
            cg.add(f)
        src = cg.dump()
        key = hashlib.sha256("\n".join([src, ca.__version__, cc, *flags]).encode()).hexdigest()[:24]
        lib = os.path.join(root, f"{tag}_{key}.so")
        if not _verified(lib):
            _build(cc, flags, src, root, tag, lib)
            if not _verified(lib):
                raise OSError(f"{lib!r} changed while it was being built")
        return [ca.external(f.name(), lib) for f in funs]
    except subprocess.CalledProcessError as exc:
        err = exc.stderr.decode(errors="replace").strip()[-400:] if exc.stderr else ""
        _warn_fallback(f"{cc} failed with exit status {exc.returncode}: {err}")
    except subprocess.TimeoutExpired as exc:
        _warn_fallback(f"{cc} did not finish within {exc.timeout} s")
    except OSError as exc:        # compiler vanished (FileNotFoundError), unwritable cache, ...
        _warn_fallback(f"{type(exc).__name__}: {exc}")
    except RuntimeError as exc:   # CasADi: code generation or loading the library (external)
        _warn_fallback(f"CasADi could not generate or load the compiled code: {exc}")
    return funs


class _Buffers:
    """Numeric evaluation of a CasADi Function into preallocated arrays (no DM conversion)."""

    def __init__(self, fun):
        self.args = [np.zeros(fun.nnz_in(i)) for i in range(fun.n_in())]
        self.res = [np.zeros(fun.nnz_out(i)) for i in range(fun.n_out())]
        for i in range(fun.n_out()):
            if not fun.sparsity_out(i).is_dense():
                raise ValueError(f"{fun.name()}: output {i} must be dense")
        self._buf, self.eval = fun.buffer()
        for i, a in enumerate(self.args):
            self._buf.set_arg(i, memoryview(a))
        for i, a in enumerate(self.res):
            self._buf.set_res(i, memoryview(a))


class _CompiledFlow:
    """DOP853 stages of the flow from the CasADi Functions of :func:`_casadi_flow_functions`
    (one call per step, dense output included).  Raises :class:`_FallBack` when a QR pivot
    drops below :data:`PIVOT_RTOL` or a value is not finite."""

    def __init__(self, funs):
        self.rhs_buf, self.step_buf = _Buffers(funs[0]), _Buffers(funs[1])
        self.nfev = 0

    def start(self, q_ref, c):
        self.rhs_buf.args[1][:] = c
        self.rhs_buf.args[2][:] = q_ref
        self.step_buf.args[3][:] = c
        self.step_buf.args[4][:] = q_ref
        self.nfev = 0
        return self

    def rhs(self, x):
        b = self.rhs_buf
        b.args[0][:] = x
        b.eval()
        self.nfev += 1
        if not (b.res[1][0] > PIVOT_RTOL and math.isfinite(b.res[0].sum())):
            raise _FallBack
        return b.res[0].copy()

    def step(self, y, f, h):
        b = self.step_buf
        b.args[0][:] = y
        b.args[1][:] = f
        b.args[2][0] = h
        b.eval()
        self.nfev += _NSX - 1
        if not (b.res[5][0] > PIVOT_RTOL and math.isfinite(b.res[6][0])):
            raise _FallBack
        return b.res[0].copy(), b.res[1].copy(), b.res[2].copy(), b.res[3].copy()

    def dense(self, y_new):
        return self.step_buf.res[4].reshape(7, -1)  # column-major m x 7 -> rows F_0..F_6


_COMPILED_FLOWS = weakref.WeakKeyDictionary()      # system -> _CompiledFlow or None
_BY_SOURCE: dict = {}  # (serialized symbolic step, COMPILE_FLOW) -> Functions, shared by equal systems


def _compiled_flow(system):
    """The :class:`_CompiledFlow` of *system* (built and compiled once), or None."""
    try:
        return _COMPILED_FLOWS[system]
    except KeyError:
        pass
    except TypeError:  # not weakly referenceable: build every time would be too slow
        return None
    funs = _casadi_flow_functions(system)
    flow = None
    if funs is not None:
        key = funs[1].serialize()
        key = (key, COMPILE_FLOW)
        if key not in _BY_SOURCE:
            _BY_SOURCE[key] = _compile(list(funs), f"netcosim_flow_{system.n}x{system.m}")
        flow = _CompiledFlow(_BY_SOURCE[key])
    _COMPILED_FLOWS[system] = flow
    return flow


class DenseFlow:
    """Continuous DOP853 solution of the flow: one degree-7 polynomial per step.

    ``t``: step boundaries (k+1,); ``y``: states there (k+1, m); ``P``: monomial
    coefficients (k, 7, m) with ``y(t_i + x h_i) = y_i + sum_j P[i, j] x^(j+1)``, x in [0, 1].
    Called like SciPy's ``OdeSolution``: ``sol(tau)`` is ``(m,)`` for a scalar tau and
    ``(m, len(tau))`` for an array (tau outside ``[t_0, t_k]`` extrapolates the end pieces).
    """

    def __init__(self, t, y, P):
        self.t = np.asarray(t, dtype=float)
        self.y = np.asarray(y, dtype=float)
        self.P = np.asarray(P, dtype=float)
        self.h = np.diff(self.t)
        self._tl, self._hl = self.t.tolist(), self.h.tolist()

    def values(self, tau) -> np.ndarray:
        """``e'(tau)`` for a 1-D array of tau, shape ``(len(tau), m)``."""
        tau = np.asarray(tau, dtype=float)
        i = np.searchsorted(self.t[1:-1], tau, side="right")  # piece, end pieces extended
        x = (tau - self.t[i]) / self.h[i]
        return self.y[i] + np.einsum("kj,kjm->km", x[:, None] ** _POWERS, self.P[i])

    def derivatives(self, tau: float) -> np.ndarray:
        """Rows ``e'``, ``de'/dtau``, ``d2e'/dtau2`` at a scalar tau, shape ``(3, m)``."""
        i = min(max(bisect.bisect_right(self._tl, tau) - 1, 0), len(self._hl) - 1)
        h = self._hl[i]
        x = (tau - self._tl[i]) / h
        p = [1.0, x]
        for _ in range(6):
            p.append(p[-1] * x)
        h2 = h * h
        V = np.array((p[1:], [k * p[k - 1] / h for k in range(1, 8)],
                      [0.0] + [k * (k - 1) * p[k - 2] / h2 for k in range(2, 8)]))
        Y = V @ self.P[i]
        Y[0] += self.y[i]
        return Y

    def __call__(self, tau):
        tau = np.asarray(tau, dtype=float)
        if tau.ndim == 0:
            return self.values(tau[None])[0]
        return self.values(tau.reshape(-1)).T.reshape((self.y.shape[1],) + tau.shape)


def _rms(x):
    return math.sqrt(float(np.dot(x, x)) / x.shape[0])


def _dop853(stages, y0, t_bound, rtol, atol, fn):
    """Integrate from ``tau = 0`` with DOP853 (SciPy's step-size control, initial step and
    error norm) until ``fn.event(y) = ||y|| - ||e_h||`` rises through zero or ``t_bound``.

    Returns ``(DenseFlow, tau_s)`` (``tau_s = inf`` without event).  The event is located
    on the dense output of the step where it occurs by :func:`_root_increasing`, to
    :data:`EVENT_XTOL` (SciPy's ``solve_ivp`` uses Brent's method there, to 4 ulp).
    """
    f = stages.rhs(y0)
    # SciPy's select_initial_step (Hairer, Norsett & Wanner II.4), error order 7
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(f / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_bound)
    d2 = _rms((stages.rhs(y0 + h0 * f) - f) / scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1 / 8)
    h_abs = min(100 * h0, h1, t_bound)

    t, y, g = 0.0, y0, 0.0
    ts, ys, Ps = [0.0], [y0], []
    m = y0.shape[0]
    while True:
        min_step = 10 * abs(math.nextafter(t, math.inf) - t)
        h_abs = max(h_abs, min_step)
        rejected = False
        while True:
            if h_abs < min_step:
                raise RuntimeError(f"auxiliary flow integration failed: step size too small at tau={t}")
            t_new = min(t + h_abs, t_bound)
            h = t_new - t
            h_abs = abs(h)
            y_new, f_new, e5, e3 = stages.step(y, f, h)
            scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
            e5 = e5 / scale
            e3 = e3 / scale
            n5, n3 = float(np.dot(e5, e5)), float(np.dot(e3, e3))
            err = 0.0 if n5 == 0.0 and n3 == 0.0 else h_abs * n5 / math.sqrt((n5 + 0.01 * n3) * m)
            if err < 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** -0.125)
                h_abs *= min(1.0, factor) if rejected else factor
                break
            h_abs *= max(0.2, 0.9 * err ** -0.125)
            rejected = True
        Ps.append(_MONO @ stages.dense(y_new))
        ts.append(t_new)
        ys.append(y_new)
        g_new = fn.event(y_new)
        if g <= 0.0 <= g_new:
            sol = DenseFlow(ts, ys, Ps)
            return sol, _root_increasing(lambda s: fn.event_slope(sol.derivatives(s)), t, t_new, EVENT_XTOL)
        if t_new >= t_bound:
            return DenseFlow(ts, ys, Ps), math.inf
        t, y, f, g = t_new, y_new, f_new, g_new


def _root_increasing(fun, lo, hi, xtol, maxiter=200):
    """A zero of ``g`` on ``[lo, hi]`` where ``g(lo) <= 0 <= g(hi)``; ``fun(x) -> (g, g')``.

    Newton's method safeguarded by the bracket: a step that leaves the bracket, or does
    not halve the previous step, is replaced by bisection.  Returns once a Newton step
    or the bracket is below ``xtol * max(1, |x|)``.
    """
    x = 0.5 * (lo + hi)
    dx_old = hi - lo
    for _ in range(maxiter):
        g, dg = fun(x)
        if g == 0.0:
            return x
        if g < 0.0:
            lo = x
        else:
            hi = x
        tol = xtol * max(1.0, abs(x))
        xn = x - g / dg if dg > 0.0 else math.nan
        if lo <= xn <= hi:
            dx = abs(xn - x)
            if dx <= tol:
                return xn
            if dx < 0.5 * dx_old:
                dx_old, x = dx, xn
                continue
        dx_old = 0.5 * (hi - lo)
        x = lo + dx_old
        if dx_old <= tol:
            return x
    return x


class _FlowNorm:
    """The flow's norm ``||D y||_p`` with ``||e_h||``: the event ``||y|| - ||e_h||`` and the
    derivatives along the dense output that locate ``tau_s`` and ``tau_o``."""

    def __init__(self, nrm: WeightedNorm, m: int, n0: float):
        self.w = None if nrm.weights is None else nrm.w(m)
        self.two = nrm.p == 2
        self.n0 = n0

    def __call__(self, y) -> float:
        z = y if self.w is None else self.w * y
        if self.two:
            return math.sqrt(float(np.dot(z, z)))
        return float(np.max(np.abs(z)))

    def event(self, y) -> float:
        return self(y) - self.n0

    def event_slope(self, Y):
        """``(||e'|| - ||e_h||, d||e'||/dtau)`` from the rows ``e', e'_tau, e'_tautau``
        (one-sided derivative for the max-norm)."""
        Z = Y if self.w is None else self.w * Y
        if self.two:
            r = math.sqrt(float(np.dot(Z[0], Z[0])))
            return r - self.n0, (float(np.dot(Z[0], Z[1])) / r if r > 0.0 else 0.0)
        k = int(np.argmax(np.abs(Z[0])))
        return abs(Z[0, k]) - self.n0, math.copysign(1.0, Z[0, k]) * Z[1, k]

    def slope_curvature(self, Y):
        """A function with the sign of ``d||e'||/dtau`` and its derivative: for the 2-norm
        ``(z . z', z' . z' + z . z'')`` with ``z = D e'``; for the max-norm the one-sided
        derivative of the largest ``|z_k|`` and its own derivative."""
        Z = Y if self.w is None else self.w * Y
        if self.two:
            return float(np.dot(Z[0], Z[1])), float(np.dot(Z[1], Z[1]) + np.dot(Z[0], Z[2]))
        k = int(np.argmax(np.abs(Z[0])))
        s = math.copysign(1.0, Z[0, k])
        return s * Z[1, k], s * Z[2, k]


@dataclass
class AuxiliaryFlow:
    """Solution ``e'(tau; e_h)`` of the auxiliary flow (3.12)/(4.17) on ``[0, tau_end]``.

    ``tau_s``: first ``tau > 0`` with ``||e'(tau)|| = ||e_h||`` (``inf`` if the norm
    stays below ``||e_h||`` up to ``tau_max``); ``tau_o``: argmin of ``||e'||`` over
    ``[0, min(tau_s, tau_max)]``; ``min_norm = ||e'(tau_o)||``.  Calling the object
    evaluates ``e'`` (dense output) at one or many tau.  ``sol``: the :class:`DenseFlow`;
    ``nfev``: right-hand-side evaluations used.
    """

    e_h: np.ndarray
    tau_s: float
    tau_o: float
    min_norm: float
    tau_end: float
    norm: WeightedNorm
    sol: Any = field(repr=False, default=None)
    nfev: int = 0

    def __call__(self, tau):
        tau = np.asarray(tau, dtype=float)
        if self.sol is None:
            return np.broadcast_to(self.e_h, tau.shape + self.e_h.shape).copy() if tau.ndim else self.e_h.copy()
        if np.any(tau < -1e-15) or np.any(tau > self.tau_end * (1 + 1e-12) + 1e-15):
            raise ValueError(f"tau outside the solved range [0, {self.tau_end}]")
        y = self.sol.values(np.clip(tau, 0.0, self.tau_end).reshape(-1))
        return y.reshape(tau.shape + self.e_h.shape)


def solve_auxiliary_flow(system: Any, q_ref: Any, e_h: Any, *, kbar: Any = None, norm: Any = None,
                         tau_max: float | None = None, rtol: float = FLOW_RTOL,
                         atol_rel: float = FLOW_ATOL_REL, n_grid: int = 64) -> AuxiliaryFlow:
    """Integrate ``e'_dot = -A^+_{q_r + e'} A_{q_r + e_h} K_bar e_h``, ``e'(0) = e_h``.

    This is (3.12) for square systems with ``K_bar = I`` and (4.17) in general.  The
    integration (DOP853 with SciPy's step-size control, ``rtol``,
    ``atol = atol_rel * ||e_h||_2``, dense output on every step) stops at the first return
    of the norm to ``||e_h||`` (a rise through zero of ``||e'|| - ||e_h||`` at the end of a
    step, located on the dense output by safeguarded Newton to :data:`EVENT_XTOL`) or at ``tau_max``
    (default ``10 / min(K_bar)``).  ``tau_o`` is found by scanning the dense output on
    ``n_grid`` points plus the step ends and solving ``d||e'||/dtau = 0`` (for the
    max-norm: its one-sided version) on the best bracket by safeguarded Newton to
    :data:`TAU_XTOL`.  For ``e_h = 0`` the flow is at rest and ``tau_o := 1`` (the limit of
    Proposition 3.4.6).

    Right-hand side: for systems with a CasADi Jacobian ``A_fun`` (every
    :class:`plants.flycrane.MultiRobotSystem`) ``A^+ c`` comes from a QR factorisation in
    one compiled function per step (see :data:`COMPILE_FLOW`); otherwise, or where a QR
    pivot falls below :data:`PIVOT_RTOL`, from the SVD least squares of
    :func:`configuration_rate`, which raises :class:`SingularConfigurationError` at rank loss.
    """
    check_system(system)
    m = system.m
    q_ref = _vec(q_ref, m, "q_ref")
    e_h = _vec(e_h, m, "e_h")
    kd = _diag_gain(kbar, m)
    nrm = WeightedNorm.of(norm)
    nrm.w(m)
    if tau_max is None:
        tau_max = 10.0 / float(kd.min())
    tau_max = check_period(tau_max, "tau_max")
    n0 = nrm(e_h)
    scale = float(np.linalg.norm(e_h))
    if scale == 0.0:
        return AuxiliaryFlow(e_h, math.inf, 1.0, 0.0, tau_max, nrm, None, 0)
    c = _jacobian(system, q_ref + e_h) @ (kd * e_h)
    fn = _FlowNorm(nrm, m, n0)
    stages = _compiled_flow(system)
    sol = None
    if stages is not None:
        try:
            sol, tau_s = _dop853(stages.start(q_ref, c), e_h, tau_max, rtol, atol_rel * scale, fn)
        except _FallBack:
            sol = None
        # the QR pivot test is only a trigger; the rank rule itself is checked at every step end
        if sol is not None and not _regular_along(system, q_ref, sol.y):
            sol = None
    if sol is None:
        stages = _SVDFlow(system, q_ref, c)
        sol, tau_s = _dop853(stages, e_h, tau_max, rtol, atol_rel * scale, fn)
    tau_end = tau_s if math.isfinite(tau_s) else float(sol.t[-1])
    grid = np.union1d(np.linspace(0.0, tau_end, n_grid), sol.t[sol.t <= tau_end])
    vals = nrm.many(sol.values(grid))
    j = int(np.argmin(vals))
    lo = float(grid[max(j - 1, 0)])
    hi = float(grid[min(j + 1, len(grid) - 1)])
    tau_o, best = float(grid[j]), float(vals[j])
    if hi > lo:
        slope = lambda s: fn.slope_curvature(sol.derivatives(s))  # noqa: E731
        if slope(hi)[0] <= 0.0:      # still decreasing at the end of the bracket
            t = hi
        elif slope(lo)[0] >= 0.0:
            t = lo
        else:
            t = _root_increasing(slope, lo, hi, TAU_XTOL)
        v = fn(sol.derivatives(t)[0])
        if v < best:
            tau_o, best = t, v
    return AuxiliaryFlow(e_h, tau_s, tau_o, best, tau_end, nrm, sol, int(stages.nfev))


def _regular_along(system, q_ref, ys) -> bool:
    """Whether ``A_q`` passes the rank rule (:data:`RANK_RTOL`) at every ``q_ref + y``."""
    for y in ys:
        if conditioning(np.linalg.svd(_jacobian(system, q_ref + y), compute_uv=False), RANK_RTOL)[3]:
            return False
    return True


def online_gain(system: Any, q: Any, q_ref: Any, T: float, *, kbar: Any = None, norm: Any = None,
                **flow_kw) -> tuple[float, AuxiliaryFlow]:
    """Online gain ``k_h = tau_o(e_h) / T`` (3.26)/(4.30), in 1/s, and the flow used."""
    T = check_period(T)
    q = _vec(q, system.m, "q")
    q_ref = _vec(q_ref, system.m, "q_ref")
    flow = solve_auxiliary_flow(system, q_ref, q - q_ref, kbar=kbar, norm=norm, **flow_kw)
    return flow.tau_o / T, flow


# ---------------------------------------------------------------------------
# Sampled closed loop (3.11)/(4.16)
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class OfflineGain:
    """A constant planner gain ``k`` (1/s), e.g. ``k* = tau_o_bar(mu) / T`` (3.25)."""

    k: float

    def __post_init__(self):
        check_period(self.k, "offline gain k")

    def __call__(self, system, q, q_ref, T, kbar, norm):
        return float(self.k), None


@dataclass(frozen=True)
class OnlineGain:
    """The online gain ``k_h = tau_o(e_h) / T`` recomputed at every sample (3.26)/(4.30)."""

    tau_max: float | None = None

    def __call__(self, system, q, q_ref, T, kbar, norm):
        k, flow = online_gain(system, q, q_ref, T, kbar=kbar, norm=norm, tau_max=self.tau_max)
        return k, flow


def sampled_velocity(system: Any, q_h: Any, q_ref: Any, k: float, kbar: Any = None) -> np.ndarray:
    """``u_h = -k A_{q_h} K_bar (q_h - q_r)``, held on ``[hT, (h+1)T)`` (Sec. 3.4/4.5), m/s."""
    m = system.m
    q_h = _vec(q_h, m, "q_h")
    kd = _diag_gain(kbar, m)
    return _jacobian(system, q_h) @ (-k * (kd * (q_h - _vec(q_ref, m, "q_ref"))))


def simulate_sampled(system: Any, q0: Any, q_ref: Any, T: float, gain: Any, *, kbar: Any = None,
                     norm: Any = None, n_samples: int = 50, tol: float = 0.0,
                     plant: Callable[..., np.ndarray] | None = None, guarantee: Any = None):
    """Run the sampled planner (3.11)/(4.16) against the kinematic model.

    ``gain``: :class:`OfflineGain` or :class:`OnlineGain`.  At each sample ``h`` the gain
    ``k_h`` and ``u_h = -k_h A_{q_h} K_bar e_h`` are computed, then the plant
    ``q_dot = A_q^+ u_h`` is integrated over one period (``plant(q, u, T)``; default
    :func:`integrate_kinematics` with DOP853, rtol 1e-12, atol 1e-13).  Stops after
    ``n_samples`` periods or once ``||e_h|| < tol``.  ``guarantee``: a
    :class:`~controllers.gain_design.GainDesign`; an offline gain outside its stability
    interval ``0 < k T < tau_s_bar`` then raises ``ValueError`` before anything runs.

    Returns a ``pandas.DataFrame`` with one row per sample: ``h``, ``t`` (s), ``k``
    (1/s), ``tau`` (= k T), ``err`` (``||e_h||`` in *norm*), ``err2`` (Euclidean),
    ``tau_s`` and ``tau_o`` of the online flow (``inf`` and ``k T`` for an offline
    gain), and the columns ``q0..q{m-1}`` and ``u0..u{n-1}``.  The last row is the
    final state: no command is computed there, so its ``k``, ``tau``, ``tau_s``,
    ``tau_o`` are NaN and its ``u`` zero.
    """
    import pandas as pd

    check_system(system)
    T = check_period(T)
    m, n = system.m, system.n
    q = _vec(q0, m, "q0")
    q_ref = _vec(q_ref, m, "q_ref")
    nrm = WeightedNorm.of(norm)
    kd = _diag_gain(kbar, m)
    if not isinstance(gain, (OfflineGain, OnlineGain)) and not callable(gain):
        raise TypeError(f"gain must be OfflineGain(k) or OnlineGain(), got {gain!r}")
    if guarantee is not None and isinstance(gain, OfflineGain):
        guarantee.check_gain(gain.k, T)
    if plant is None:
        plant = lambda q, u, T: integrate_kinematics(system, q, u, 0.0, T)  # noqa: E731
    rows = []
    for h in range(int(n_samples) + 1):
        e = q - q_ref
        err = nrm(e)
        if h == n_samples or err < tol:
            rows.append((h, h * T, np.nan, np.nan, err, float(np.linalg.norm(e)), np.nan, np.nan,
                         *q, *np.zeros(n)))
            break
        k, flow = gain(system, q, q_ref, T, kd, nrm)
        u = sampled_velocity(system, q, q_ref, k, kd)
        rows.append((h, h * T, k, k * T, err, float(np.linalg.norm(e)),
                     flow.tau_s if flow is not None else np.inf,
                     flow.tau_o if flow is not None else k * T, *q, *u))
        q = plant(q, u, T)
    cols = (["h", "t", "k", "tau", "err", "err2", "tau_s", "tau_o"]
            + [f"q{i}" for i in range(m)] + [f"u{i}" for i in range(n)])
    return pd.DataFrame(rows, columns=cols)
