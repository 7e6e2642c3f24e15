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

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

__all__ = [
    "SingularConfigurationError", "StarStructure", "WeightedNorm", "check_system",
    "check_gain_matrix", "check_period", "planner_velocity", "robot_velocity",
    "configuration_rate", "project", "AuxiliaryFlow", "solve_auxiliary_flow",
    "online_gain", "OfflineGain", "OnlineGain", "sampled_velocity", "simulate_sampled", "integrate_kinematics",
]


class SingularConfigurationError(ValueError):
    """The Jacobian ``A_q`` lost column rank at a configuration the law had to use."""


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


#: Relative singular-value threshold below which ``A_q`` counts as rank deficient.
RANK_RTOL = 1e-10


def _pinv_apply(A: np.ndarray, v: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``A^+ v`` for a full-column-rank A (``A^{-1} v`` when square).

    Solved by SVD least squares; singular values below :data:`RANK_RTOL` times the
    largest count as zero, and a rank below ``m`` raises SingularConfigurationError.
    """
    m = A.shape[1]
    x, _, rank, _ = np.linalg.lstsq(A, v, rcond=RANK_RTOL)
    if rank < m:
        raise SingularConfigurationError(f"A_q is singular (rank {rank} < m={m}) at q={q.tolist()}")
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


@dataclass
class AuxiliaryFlow:
    """Solution ``e'(tau; e_h)`` of the auxiliary flow (3.12)/(4.17) on ``[0, tau_end]``.

    ``tau_s``: first ``tau > 0`` with ``||e'(tau)|| = ||e_h||`` (``inf`` if the norm
    stays below ``||e_h||`` up to ``tau_max``); ``tau_o``: argmin of ``||e'||`` over
    ``[0, min(tau_s, tau_max)]``; ``min_norm = ||e'(tau_o)||``.  Calling the object
    evaluates ``e'`` (dense output) at one or many tau.
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
        y = self.sol(np.clip(tau, 0.0, self.tau_end))
        return y.T if tau.ndim else y


def solve_auxiliary_flow(system: Any, q_ref: Any, e_h: Any, *, kbar: Any = None, norm: Any = None,
                         tau_max: float | None = None, rtol: float = FLOW_RTOL,
                         atol_rel: float = FLOW_ATOL_REL, n_grid: int = 64) -> AuxiliaryFlow:
    """Integrate ``e'_dot = -A^+_{q_r + e'} A_{q_r + e_h} K_bar e_h``, ``e'(0) = e_h``.

    This is (3.12) for square systems with ``K_bar = I`` and (4.17) in general.  The
    integration (SciPy ``solve_ivp``, DOP853, ``rtol``, ``atol = atol_rel * ||e_h||_2``)
    stops at the first return of the norm to ``||e_h||`` (terminal event, direction +1,
    located by SciPy's root finder) or at ``tau_max`` (default ``10 / min(K_bar)``).
    ``tau_o`` is found by scanning the dense output on ``n_grid`` points plus the solver's
    own steps and refining the best bracket with bounded Brent minimisation to
    :data:`TAU_XTOL`.  For ``e_h = 0`` the flow is at rest and ``tau_o := 1`` (the limit of
    Proposition 3.4.6).
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

    def rhs(tau, x):
        q = q_ref + x
        return -_pinv_apply(_jacobian(system, q), c, q)

    def back(tau, x):
        return nrm(x) - n0
    back.terminal = True
    back.direction = 1.0

    sol = solve_ivp(rhs, (0.0, tau_max), e_h, method="DOP853", rtol=rtol, atol=atol_rel * scale,
                    events=back, dense_output=True)
    if sol.status == -1:
        raise RuntimeError(f"auxiliary flow integration failed: {sol.message}")
    if sol.status == 1 and len(sol.t_events[0]):
        tau_s = float(sol.t_events[0][0])
        tau_end = tau_s
    else:
        tau_s = math.inf
        tau_end = float(sol.t[-1])
    grid = np.union1d(np.linspace(0.0, tau_end, n_grid), sol.t[sol.t <= tau_end])
    vals = nrm.many(sol.sol(grid).T)
    j = int(np.argmin(vals))
    lo = grid[max(j - 1, 0)]
    hi = grid[min(j + 1, len(grid) - 1)]
    tau_o, best = float(grid[j]), float(vals[j])
    if hi > lo:
        res = minimize_scalar(lambda t: nrm(sol.sol(t)), bounds=(lo, hi), method="bounded",
                              options={"xatol": TAU_XTOL})
        if res.fun < best:
            tau_o, best = float(res.x), float(res.fun)
    return AuxiliaryFlow(e_h, tau_s, tau_o, best, tau_end, nrm, sol.sol, int(sol.nfev))


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
