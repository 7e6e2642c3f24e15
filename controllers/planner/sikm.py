"""SIKM: sampled-communication-aware inverse-kinematics tracking controller (thesis ch. 5).

Laws (square systems, ``q_dot = A_q^{-1} u``; ``e = q - q_r``), held or evaluated on
``t = hT + tau``, ``tau in [0, T)``:

* point-stabilization tracking (5.13): ``u = -k A_{q_h} (q_h - q_r(hT))``;
* sampled feed-forward, Jacobian at the last sample (5.14):
  ``u = -k A_{q_h} (q_h - q_r(hT)) + A_{q_h} q_r_dot(hT + tau)``;
* sampled feed-forward, Jacobian at the reference (5.15) -- the SIKM law:
  ``u = -k A_{q_h} (q_h - q_r(hT)) + A_{q_r(hT + tau)} q_r_dot(hT + tau)``.

Table 5.1 combines them with an online gain ``k_ON = tau_o(e_h)/T`` (5.12) or an
offline gain ``k_OFF``: :data:`TABLE_5_1`.

Gain/period design from the bound ``||e(hT + tau)|| <= z(k, tau) ||e(hT)||`` with
``z = |1 - k tau| + alpha tau + tau^2 (k^2 mu + k gamma1 + gamma2)`` (5.20):
stability set (Prop. 5.4.2), optimal time for a gain (Prop. 5.4.3), optimal gain for a
period (Prop. 5.4.4), the critical period ``tau_CR = max_k tau_s(k)``, and the
estimate of ``(mu, alpha, gamma1, gamma2)`` from sampled trajectories by the QP (5.27).

Units: k in 1/s, T and tau in s, q in rad / m, ``mu`` in s^0 ... as in the thesis the
parameters absorb the units so that ``z`` is dimensionless.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

from .flow import online_gain
from .kinematics import as_vector, check_period, check_system, integrate_kinematics, jacobian
from .norms import WeightedNorm

__all__ = [
    "SIKMParams", "z", "k_bar", "k_barbar", "tau_s", "tau_o", "rho_of_k", "k_o", "rho_of_tau",
    "tau_critical", "in_stability_set", "optimal_offline_gain", "check_offline_gain",
    "estimate_parameters", "bootstrap_parameters", "Trajectory", "sikm_velocity", "Strategy", "TABLE_5_1",
    "simulate_tracking", "checked_tracking_run", "collect_interval_samples",
]


# ---------------------------------------------------------------------------
# The bound z (5.20) and its analysis (Propositions 5.4.2-5.4.4)
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class SIKMParams:
    """``theta = (mu, alpha, gamma1, gamma2) >= 0`` of the bound (5.20)."""

    mu: float
    alpha: float
    gamma1: float
    gamma2: float

    def __post_init__(self):
        for nm in ("mu", "alpha", "gamma1", "gamma2"):
            v = validate.non_negative(getattr(self, nm), f"SIKM parameter {nm}", kind="finite and >= 0",
                                      type_error=ConfigurationError)
            object.__setattr__(self, nm, v)

    def Q(self, k):
        """``k^2 mu + k gamma1 + gamma2`` (the tau^2 coefficient of z)."""
        return k * k * self.mu + k * self.gamma1 + self.gamma2

    def as_array(self) -> np.ndarray:
        """``[mu, alpha, gamma1, gamma2]`` as an array."""
        return np.array([self.mu, self.alpha, self.gamma1, self.gamma2])


def z(k, tau, p: SIKMParams):
    """``z(k, tau) = |1 - k tau| + alpha tau + tau^2 (k^2 mu + k gamma1 + gamma2)`` (5.20).
    *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    k = np.asarray(k, dtype=float)
    tau = np.asarray(tau, dtype=float)
    out = np.abs(1.0 - k * tau) + p.alpha * tau + tau * tau * p.Q(k)
    return float(out) if out.ndim == 0 else out


def k_bar(p: SIKMParams) -> float:
    """``k_bar`` of Prop. 5.4.2 (``mu < 1``): above it the stability bound is ``tau_s2``.
    ``inf`` for ``mu >= 1``.  *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    if p.mu >= 1.0:
        return math.inf
    a = p.alpha + p.gamma1
    return (a + math.sqrt(a * a + 4.0 * p.gamma2 * (1.0 - p.mu))) / (2.0 * (1.0 - p.mu))


def k_barbar(p: SIKMParams) -> float:
    """``k_barbar`` of Prop. 5.4.3 (``mu < 1/2``): above it ``tau_o(k) = 1/k``.
    ``inf`` for ``mu >= 1/2``.  *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    if p.mu >= 0.5:
        return math.inf
    a = p.alpha + 2.0 * p.gamma1
    return (a + math.sqrt(a * a + 8.0 * p.gamma2 * (1.0 - 2.0 * p.mu))) / (2.0 * (1.0 - 2.0 * p.mu))


def _tau_s1(k, p):
    return (k - p.alpha) / p.Q(k)


def _tau_s2(k, p):
    Q = p.Q(k)
    return (-(p.alpha + k) + math.sqrt((p.alpha + k) ** 2 + 8.0 * Q)) / (2.0 * Q)


def tau_s(k: float, p: SIKMParams) -> float:
    """Stability bound ``tau_s(k)`` of Prop. 5.4.2: ``z(k, tau) < 1`` iff ``0 < tau < tau_s(k)``.

    ``(k - alpha) / Q(k)`` for ``alpha < k < k_bar`` (all ``k > alpha`` if ``mu >= 1``);
    ``(-(alpha + k) + sqrt((alpha + k)^2 + 8 Q(k))) / (2 Q(k))`` for ``k > k_bar``;
    0 for ``k <= alpha`` (no decrease possible).  ``inf`` when ``Q(k) = 0``.
    *p*: the bound's parameters θ (:class:`SIKMParams`).
    """
    k = float(k)
    if k <= p.alpha:
        return 0.0
    if p.Q(k) == 0.0:
        return math.inf
    return _tau_s1(k, p) if k < k_bar(p) else _tau_s2(k, p)


def tau_o(k: float, p: SIKMParams) -> float:
    """Optimal time for a gain, Prop. 5.4.3: ``(k - alpha) / (2 Q(k))`` for
    ``alpha < k < k_barbar`` (all ``k > alpha`` if ``mu >= 1/2``), ``1/k`` beyond.
    *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    k = float(k)
    if k <= p.alpha:
        raise ValueError(f"gain k={k!r} 1/s must exceed alpha={p.alpha} for any decrease (Prop. 5.4.2)")
    if k < k_barbar(p):
        return (k - p.alpha) / (2.0 * p.Q(k))
    return 1.0 / k


def rho_of_k(k: float, p: SIKMParams) -> float:
    """Convergence rate ``rho_o(k) = z(k, tau_o(k))`` of Prop. 5.4.3 (closed form):
    ``1 - (alpha - k)^2 / (4 Q(k))`` below ``k_barbar``, ``mu + (alpha + gamma1)/k + gamma2/k^2`` above.
    *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    k = float(k)
    if k <= p.alpha:
        raise ValueError(f"gain k={k!r} 1/s must exceed alpha={p.alpha} (Prop. 5.4.2)")
    if k < k_barbar(p):
        return 1.0 - (p.alpha - k) ** 2 / (4.0 * p.Q(k))
    return p.mu + (p.alpha + p.gamma1) / k + p.gamma2 / (k * k)


def k_o(tau: float, p: SIKMParams) -> float:
    """Optimal gain for a period, Prop. 5.4.4: ``1/tau`` for ``tau < (1 - 2 mu)/gamma1``
    (``mu < 1/2``), ``(1 - tau gamma1) / (2 tau mu)`` up to ``1/gamma1``.  Raises beyond
    ``1/gamma1`` (no positive minimiser).  *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    tau = check_period(tau, "period tau")
    g1, mu = p.gamma1, p.mu
    t_mk = (1.0 - 2.0 * mu) / g1 if g1 > 0 else (math.inf if mu < 0.5 else -math.inf)
    t_Mk = 1.0 / g1 if g1 > 0 else math.inf
    if mu < 0.5 and tau < t_mk:
        return 1.0 / tau
    if tau < t_Mk:
        return (1.0 - tau * g1) / (2.0 * tau * mu)
    raise ValueError(f"period tau={tau} s >= 1/gamma1={t_Mk:.6g} s: z has no minimiser in k > 0 "
                     "(Prop. 5.4.4)")


def rho_of_tau(tau: float, p: SIKMParams) -> float:
    """``rho_o(tau) = z(k_o(tau), tau)`` of Prop. 5.4.4 (closed forms
    ``gamma2 tau^2 + (alpha + gamma1) tau + mu`` on the ``k = 1/tau`` branch and
    ``((4 gamma2 mu - gamma1^2) tau^2 + 2 (gamma1 + 2 alpha mu) tau + 4 mu - 1) / (4 mu)``
    on the other).  *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    tau = check_period(tau, "period tau")
    k = k_o(tau, p)
    if abs(k * tau - 1.0) < 1e-15:
        return p.gamma2 * tau * tau + (p.alpha + p.gamma1) * tau + p.mu
    mu, g1, g2, a = p.mu, p.gamma1, p.gamma2, p.alpha
    return ((4 * g2 * mu - g1 * g1) * tau * tau + 2 * (g1 + 2 * a * mu) * tau + 4 * mu - 1) / (4 * mu)


def tau_critical(p: SIKMParams) -> float:
    """``tau_CR = max_k tau_s(k)`` (Sec. 5.4.2): the longest period any gain can stabilise.

    ``tau_s1`` is unimodal with maximiser ``k* = alpha + sqrt(alpha^2 + (gamma2 + alpha
    gamma1)/mu)``; ``tau_s2`` decreases in k.  Hence ``tau_CR = tau_s1(k*)`` if
    ``k* < k_bar`` (always when ``mu >= 1``) and ``1 / k_bar`` otherwise.
    *p*: the bound's parameters θ (:class:`SIKMParams`).
    """
    kb = k_bar(p)
    if p.mu > 0:
        ks = p.alpha + math.sqrt(p.alpha ** 2 + (p.gamma2 + p.alpha * p.gamma1) / p.mu)
        if ks < kb:
            return _tau_s1(ks, p)
    if not math.isfinite(kb):
        return math.inf
    return 1.0 / kb


def in_stability_set(k: float, T: float, p: SIKMParams) -> bool:
    """``(k, T)`` in the set ``U`` of Prop. 5.4.2, i.e. ``z(k, T) < 1`` with ``k > alpha``.
    *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    T = check_period(T)
    return float(k) > p.alpha and T < tau_s(k, p)


def check_offline_gain(k: float, T: float, p: SIKMParams) -> None:
    """Raise ``ValueError`` naming k and T unless ``(k, T)`` is in the stability set.
    *p*: the bound's parameters θ (:class:`SIKMParams`)."""
    if not in_stability_set(k, T, p):
        raise ValueError(f"(k={k!r} 1/s, T={T!r} s) is outside the stability set of Prop. 5.4.2 "
                         f"(need k > alpha={p.alpha:.6g} and T < tau_s(k)={tau_s(k, p):.6g} s)")


def optimal_offline_gain(T: float, p: SIKMParams, *, require_stable: bool = True) -> float:
    """Optimal offline gain ``k_o(T)`` (Prop. 5.4.4), 1/s.

    With ``require_stable`` (default) raises ``ValueError`` naming T and ``tau_CR`` when
    ``rho_o(T) >= 1``, i.e. T lies outside the stability set for every gain.
    *p*: the bound's parameters θ (:class:`SIKMParams`).
    """
    T = check_period(T)
    try:
        k = k_o(T, p)
    except ValueError:
        if require_stable:
            raise ValueError(f"sampling period T={T} s is outside the stability set for every gain "
                             f"(tau_CR={tau_critical(p):.6g} s)") from None
        raise
    if require_stable and not z(k, T, p) < 1.0:
        raise ValueError(f"sampling period T={T} s is outside the stability set for every gain: "
                         f"rho_o(T)={z(k, T, p):.6g} >= 1 (tau_CR={tau_critical(p):.6g} s)")
    return k


# ---------------------------------------------------------------------------
# Parameter estimation: the QP (5.27)
# ---------------------------------------------------------------------------

def estimate_parameters(k: Any, T: Any, e_h: Any, e_next: Any, *, solver: str = "daqp",
                        feas_tol: float = 1e-9) -> SIKMParams:
    """Solve the QP (5.27): ``min ||theta||^2`` s.t. ``theta >= 0``,
    ``y_i <= a_i^T theta + b_i`` with ``y_i = ||e_{h+1}^i||``,
    ``a_i = [T^2 k^2, T, T^2 k, T^2] ||e_h^i||``, ``b_i = |1 - k T| ||e_h^i||``.

    ``k``, ``T`` (1/s, s), ``e_h``, ``e_next`` (error norms) are equal-length arrays.
    Solved with CasADi's conic interface (``solver``: "daqp" default -- an exact dual active-set method -- or any conic
    plugin such as "qpoases", "osqp"); the returned ``theta`` is checked for feasibility (all
    constraints met to ``feas_tol`` relative to ``max y``).
    """
    import casadi as ca

    k, T, eh, en = (np.asarray(x, dtype=float).reshape(-1) for x in (k, T, e_h, e_next))
    N = k.size
    if N == 0:
        raise ValueError("parameter estimation needs at least one sample, got 0")
    if not (T.size == eh.size == en.size == N):
        raise ValueError(f"k, T, e_h, e_next must have equal lengths, got {k.size}, {T.size}, {eh.size}, {en.size}")
    for nm, v in (("k", k), ("T", T), ("e_h", eh), ("e_next", en)):
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{nm} has non-finite entries")
    if np.any(T <= 0):
        raise ValueError(f"sampling periods must be positive, got min T={T.min()!r}")
    if np.any(eh <= 0) or np.any(en < 0):
        raise ValueError("error norms must be positive (e_h) / non-negative (e_next)")
    A = np.stack([T * T * k * k, T, T * T * k, T * T], axis=1) * eh[:, None]
    b = np.abs(1.0 - k * T) * eh
    lb = en - b
    H = ca.DM(2.0 * np.eye(4))
    qp = {"h": H.sparsity(), "a": ca.DM(A).sparsity()}
    opts = {"printLevel": "none"} if solver == "qpoases" else {}
    S = ca.conic("sikm_theta", solver, qp, opts)
    sol = S(h=H, g=ca.DM.zeros(4), a=ca.DM(A), lba=ca.DM(lb), uba=ca.inf,
            lbx=ca.DM.zeros(4), ubx=ca.inf)
    theta = np.maximum(np.asarray(sol["x"]).reshape(-1), 0.0)
    viol = float(np.max(lb - A @ theta)) if N else 0.0
    if viol > feas_tol * max(1.0, float(np.max(np.abs(en)))):
        raise RuntimeError(f"QP (5.27) solution violates a constraint by {viol:.3g}")
    return SIKMParams(*theta)


def bootstrap_parameters(k: Any, T: Any, e_h: Any, e_next: Any, *, n_boot: int = 500, seed: int = 0,
                         solver: str = "daqp"):
    """The QP (5.27) fitted on ``n_boot`` bootstrap resamples of the samples (drawn with
    replacement, as many as given; numpy generator seeded by ``seed``): the one-period
    samples *k* (1/s), *T* (s), *e_h* = ``||e_h||`` and *e_next* = ``||e_{h+1}||`` (equal-length
    sequences, the columns of :func:`collect_interval_samples`); *solver*: the CasADi QP
    plugin.

    Returns a DataFrame, one row per resample: ``mu, alpha, gamma1, gamma2`` and
    ``tau_CR`` (s, :func:`tau_critical`).  Its quantiles give the percentile confidence
    interval of theta_hat and tau_CR over sample sets (e.g. 2.5 % and 97.5 % for 95 %).
    """
    import pandas as pd

    n_boot = int(n_boot)
    if n_boot < 1:
        raise ValueError(f"n_boot must be a positive number of resamples, got {n_boot!r}")
    k, T, eh, en = (np.asarray(x, dtype=float).reshape(-1) for x in (k, T, e_h, e_next))
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n_boot):
        i = rng.integers(0, k.size, k.size)
        p = estimate_parameters(k[i], T[i], eh[i], en[i], solver=solver)
        rows.append((p.mu, p.alpha, p.gamma1, p.gamma2, tau_critical(p)))
    return pd.DataFrame(rows, columns=["mu", "alpha", "gamma1", "gamma2", "tau_CR"])


# ---------------------------------------------------------------------------
# Control laws and strategies (Table 5.1)
# ---------------------------------------------------------------------------

class Trajectory:
    """A reference ``(q_r(t), q_r_dot(t))`` from two callables of t (s): *q* gives q_r(t) (rad,
    m), *qdot* its rate."""

    def __init__(self, q: Callable[[float], np.ndarray], qdot: Callable[[float], np.ndarray]):
        self.q, self.qdot = q, qdot

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.q(t), dtype=float), np.asarray(self.qdot(t), dtype=float)


FEEDFORWARDS = ("reference", "sample", "none")


def sikm_velocity(system: Any, q_h: Any, qr_h: Any, k: float, qr_t: Any = None, qrdot_t: Any = None,
                  feedforward: str = "reference") -> np.ndarray:
    """Robot velocities ``u(hT + tau)`` (m/s) of (5.13)/(5.14)/(5.15).

    ``q_h``: last sample ``q(hT)``; ``qr_h``: ``q_r(hT)``; ``qr_t``, ``qrdot_t``: the
    reference and its rate at the current time ``hT + tau``; ``feedforward``:
    "reference" (5.15), "sample" (5.14) or "none" (5.13).  *system*: the kinematic
    system; *k*: the gain (1/s).
    """
    m = system.m
    q_h = as_vector(q_h, m, "q_h")
    A_h = jacobian(system, q_h)
    u = A_h @ (-float(k) * (q_h - as_vector(qr_h, m, "q_r(hT)")))
    if feedforward == "none":
        return u
    qrdot_t = as_vector(qrdot_t, m, "q_r_dot(t)")
    if feedforward == "reference":
        return u + jacobian(system, as_vector(qr_t, m, "q_r(t)")) @ qrdot_t
    if feedforward == "sample":
        return u + A_h @ qrdot_t
    raise ValueError(f"feedforward must be one of {FEEDFORWARDS}, got {feedforward!r}")


@dataclass(frozen=True)
class Strategy:
    """A tracking strategy of Table 5.1: ``gain`` in {"online", "offline"} and a ``feedforward``
    (``"reference"``, ``"sample"`` or ``"none"``, see :func:`sikm_velocity`); ``label``: its
    name in tables and plots."""

    gain: str
    feedforward: str
    label: str = ""

    def __post_init__(self):
        validate.choice(self.gain, "strategy gain", ("online", "offline"))
        if self.feedforward not in FEEDFORWARDS:
            raise ValueError(f"feedforward must be one of {FEEDFORWARDS}, got {self.feedforward!r}")


#: Table 5.1: 1) k_ON + A_{q_r(t)} ff, 2) k_OFF + A_{q_r(t)} ff, 3) k_ON + A_{q_h} ff, 4) k_ON, no ff.
TABLE_5_1 = {
    1: Strategy("online", "reference", "1) k_ON, ff at q_r(t)"),
    2: Strategy("offline", "reference", "2) k_OFF, ff at q_r(t)"),
    3: Strategy("online", "sample", "3) k_ON, ff at q(hT)"),
    4: Strategy("online", "none", "4) k_ON, no ff"),
}


def checked_tracking_run(strategy, T: float, duration: float, k_off, params) -> tuple:
    """The validated ``(strategy, T, duration)`` of a tracking run: *strategy* a Table 5.1
    number (1-4) or a strategy object, *T* and *duration* in s; an offline strategy needs
    a positive ``k_off`` (1/s), checked against *params* (the stability set) when given.
    Raises ``ValueError`` naming the bad value."""
    T = check_period(T)
    duration = check_period(duration, "duration")
    if isinstance(strategy, int):
        if strategy not in TABLE_5_1:
            raise ValueError(f"strategy number must be 1-4 (Table 5.1), got {strategy}")
        strategy = TABLE_5_1[strategy]
    if strategy.gain == "offline":
        if k_off is None:
            raise ValueError("an offline strategy needs k_off")
        check_period(k_off, "offline gain k_off")
        if params is not None:
            check_offline_gain(k_off, T, params)
    return strategy, T, duration


def simulate_tracking(system: Any, trajectory: Trajectory, q0: Any, T: float, duration: float,
                      strategy: Strategy | int, *, k_off: float | None = None,
                      params: SIKMParams | None = None, n_dense: int = 10,
                      rtol: float = 1e-12, atol: float = 1e-13):
    """Simulate a Table 5.1 strategy on the kinematic model ``q_dot = A_q^{-1} u(t)``.

    The measurement ``q(hT)`` is taken every T; the gain is ``k_off`` (offline; when
    ``params`` is given it must lie in the stability set of Prop. 5.4.2) or the online
    ``tau_o(e_h)/T`` (5.12) computed on the point-stabilization flow towards ``q_r(hT)``.
    The plant is integrated with DOP853 (``rtol``, ``atol``) between samples with the
    time-varying ``u(t)`` of the chosen feed-forward.  *system*: the kinematic system;
    *trajectory*: the :class:`Trajectory` to track; *q0*: the initial configuration;
    *duration*: the simulated time [s].

    Returns ``(samples, dense)`` DataFrames: ``samples`` has ``h, t, k, err`` (Euclidean
    ``||e(hT)||``) and ``q*``; ``dense`` has ``t, err`` and ``q*``, ``qr*`` on ``n_dense``
    points per period.
    """
    import pandas as pd

    check_system(system)
    strategy, T, duration = checked_tracking_run(strategy, T, duration, k_off, params)
    m = system.m
    q = as_vector(q0, m, "q0")
    n_steps = int(math.floor(duration / T + 1e-9))
    srows, drows = [], []
    for h in range(n_steps + 1):
        t0 = h * T
        qr_h, _ = trajectory(t0)
        e = q - qr_h
        if h == n_steps:
            srows.append((h, t0, np.nan, float(np.linalg.norm(e)), *q))
            drows.append((t0, float(np.linalg.norm(e)), *q, *qr_h))
            break
        if strategy.gain == "online":
            k, _ = online_gain(system, q, qr_h, T)
        else:
            k = float(k_off)
        srows.append((h, t0, k, float(np.linalg.norm(e)), *q))
        q_h = q.copy()
        ff = strategy.feedforward

        def u_of_t(t, q_h=q_h, qr_h=qr_h, k=k):
            qr_t, qrd_t = trajectory(t)
            return sikm_velocity(system, q_h, qr_h, k, qr_t, qrd_t, ff)

        q_next, sol = integrate_kinematics(system, q, u_of_t, t0, t0 + T, rtol=rtol, atol=atol, dense=True)
        for t in np.linspace(t0, t0 + T, n_dense, endpoint=False):
            qq = sol(t)
            qr_t, _ = trajectory(t)
            drows.append((t, float(np.linalg.norm(qq - qr_t)), *qq, *qr_t))
        q = q_next
    samples = pd.DataFrame(srows, columns=["h", "t", "k", "err"] + [f"q{i}" for i in range(m)])
    dense = pd.DataFrame(drows, columns=["t", "err"] + [f"q{i}" for i in range(m)] + [f"qr{i}" for i in range(m)])
    return samples, dense


def collect_interval_samples(system: Any, trajectory: Trajectory, pairs, starts, radius: float,
                             n_per: int = 1, *, seed: int | np.random.Generator = 0,
                             feedforward: str = "reference"):
    """One-period samples ``(k_i, T_i, ||e_h||, ||e_{h+1}||)`` for the QP (5.27).

    For every gain/period pair in ``pairs`` and start time in ``starts`` (s), ``n_per``
    initial errors are drawn uniformly in the Euclidean ball of ``radius`` around
    ``q_r(t0)``; the law (5.15) (or ``feedforward``) is applied for one period T.
    Returns a DataFrame with columns ``k, T, t0, e_h, e_next``.  *system*: the kinematic
    system; *trajectory*: the :class:`Trajectory`; *seed*: a seed or a
    ``numpy.random.Generator`` for the draws.
    """
    import pandas as pd

    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    nrm = WeightedNorm()
    m = system.m
    rows = []
    for (k, T) in pairs:
        T = check_period(T)
        for t0 in starts:
            qr0, _ = trajectory(t0)
            for e0 in nrm.sample_ball(rng, m, radius, n_per):
                q0 = qr0 + e0

                def u_of_t(t, q0=q0, qr0=qr0, k=k):
                    qr_t, qrd_t = trajectory(t)
                    return sikm_velocity(system, q0, qr0, k, qr_t, qrd_t, feedforward)

                q1 = integrate_kinematics(system, q0, u_of_t, t0, t0 + T, rtol=1e-10, atol=1e-12)
                qr1, _ = trajectory(t0 + T)
                rows.append((float(k), T, float(t0), float(np.linalg.norm(e0)), float(np.linalg.norm(q1 - qr1))))
    return pd.DataFrame(rows, columns=["k", "T", "t0", "e_h", "e_next"])
