"""Offline gain design for the sampled local planners (thesis Sec. 3.4.1 and 4.5.1).

The sampled closed loop is the auxiliary flow rescaled in time (3.13)/(4.18); its error
obeys ``||e'(tau; e_h)|| <= g(tau; mu) ||e_h||`` (3.20)/(4.28) where ``mu`` bounds the
second-order remainder of the flow.  From ``g``:

* ``tau_s_bar(mu)``: end of the interval where ``g < 1`` (stability), (3.21)/(3.22);
* ``tau_o_bar(mu)``: minimiser of ``g`` (3.23); ``rho(mu) = g(tau_o_bar; mu)`` (3.24);
* offline gain ``k* = tau_o_bar(mu) / T`` (3.25), contraction ``||e_{h+1}|| <= rho ||e_h||``
  (Proposition 3.4.5).

Square systems with ``K_bar = I`` use the closed forms of Propositions 3.4.3-3.4.4;
non-square systems with diagonal ``K_bar`` and weight ``D`` use ``g`` of (4.29) minimised
numerically (:func:`design_nonsquare`).  ``mu`` is estimated by Monte-Carlo sampling of
the ball (3.19)/(4.27) with :func:`estimate_mu`.

All times ``tau`` are dimensionless (flow time of (3.12)); gains are in 1/s; ``T`` in s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from netcosim import validate
from netcosim.errors import ConfigurationError

from .flow import solve_auxiliary_flow
from .kinematics import as_vector, check_period, check_system, diag_gain
from .norms import WeightedNorm

__all__ = [
    "tau_s_bar", "tau_o_bar", "rho", "g_square", "offline_gain", "GainDesign", "g_nonsquare",
    "design_nonsquare", "design", "MuEstimate", "estimate_mu",
]


def _check_mu(mu: float) -> float:
    return validate.non_negative(mu, "mu", kind="a finite non-negative number", type_error=ConfigurationError)


# ---------------------------------------------------------------------------
# Square systems, K_bar = I: closed forms (Propositions 3.4.3-3.4.4)
# ---------------------------------------------------------------------------

def g_square(tau: Any, mu: float) -> np.ndarray | float:
    """``g(tau; mu) = |1 - tau| + mu tau^2`` (Sec. 3.4.1)."""
    mu = _check_mu(mu)
    tau = np.asarray(tau, dtype=float)
    out = np.abs(1.0 - tau) + mu * tau * tau
    return float(out) if out.ndim == 0 else out


def tau_s_bar(mu: float) -> float:
    """Stability bound (3.21): ``4 / (1 + sqrt(1 + 8 mu))`` if ``mu < 1``, else ``1 / mu``."""
    mu = _check_mu(mu)
    if mu < 1.0:
        return 4.0 / (1.0 + math.sqrt(1.0 + 8.0 * mu))
    return 1.0 / mu


def tau_o_bar(mu: float) -> float:
    """Optimal flow time (3.23): 1 if ``mu < 1/2``, else ``1 / (2 mu)``."""
    mu = _check_mu(mu)
    return 1.0 if mu < 0.5 else 1.0 / (2.0 * mu)


def rho(mu: float) -> float:
    """Guaranteed contraction (3.24): ``mu`` if ``mu < 1/2``, else ``1 - 1/(4 mu)``.

    ``rho(0) = 0`` is the dead-beat case.
    """
    mu = _check_mu(mu)
    return mu if mu < 0.5 else 1.0 - 1.0 / (4.0 * mu)


def offline_gain(mu: float, T: float) -> float:
    """Offline gain ``k* = tau_o_bar(mu) / T`` (3.25), in 1/s."""
    T = check_period(T)
    return tau_o_bar(mu) / T


# ---------------------------------------------------------------------------
# Non-square systems: g of (4.29), minimised numerically
# ---------------------------------------------------------------------------

def g_nonsquare(tau: Any, mu: float, kbar: Any, d: Any = None, *, form: str = "induced"):
    """``g(tau; mu) = ||I - tau K_bar|| + mu tau^2`` for diagonal ``K_bar`` (4.28)-(4.29), its
    diagonal given as *kbar*.

    ``form="induced"`` (default) uses the matrix norm induced by the weighted 2- or
    inf-norm, which for a diagonal matrix is ``max_i |1 - tau k_i|`` whatever the
    (diagonal) weights; this is the bound (4.28) actually needs.
    ``form="thesis"`` evaluates (4.29) as printed, ``max_i |1 - tau k_i| / d_i^2`` with the
    weights ``d_i >= 1`` of (4.9) (``d`` per configuration entry); note that it is
    smaller than the induced norm when some ``d_i > 1``, so it is not a valid bound in
    general.  Both coincide when ``min(d) = 1`` is attained on the entries with the
    smallest gain -- in particular for ``K_bar = I`` -- and for ``D = I``.
    """
    mu = _check_mu(mu)
    k = np.asarray(kbar, dtype=float).reshape(-1)
    if k.size == 0 or np.any(k <= 0) or not np.all(np.isfinite(k)):
        raise ValueError(f"K_bar diagonal must be positive, got {k.tolist()}")
    tau = np.asarray(tau, dtype=float)
    a = np.abs(1.0 - np.multiply.outer(tau, k))
    if form == "thesis":
        dd = np.ones_like(k) if d is None else np.asarray(d, dtype=float).reshape(-1)
        if dd.shape != k.shape or np.any(dd < 1.0):
            raise ValueError(f"weights d must have {k.size} entries >= 1 (4.9), got {np.asarray(d).tolist()}")
        a = a / dd ** 2
    elif form != "induced":
        raise ValueError(f"form must be 'induced' or 'thesis', got {form!r}")
    out = a.max(axis=-1) + mu * tau * tau
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True)
class GainDesign:
    """Result of the offline design: ``tau_s_bar``, ``tau_o_bar``, ``rho`` for a ``mu``
    (fields ``mu``, ``tau_s`` = tau_s_bar, ``tau_o`` = tau_o_bar, ``rho``; the taus are
    dimensionless, ``k T``)."""

    mu: float
    tau_s: float
    tau_o: float
    rho: float

    def gain(self, T: float) -> float:
        """Offline gain ``k = tau_o_bar / T`` (3.25)/(4.30 offline), 1/s."""
        return self.tau_o / check_period(T)

    def check_gain(self, k: float, T: float) -> None:
        """Raise ``ValueError`` unless ``0 < k T < tau_s_bar`` (guaranteed decrease)."""
        T = check_period(T)
        if not (k > 0 and k * T < self.tau_s):
            raise ValueError(f"gain k={k!r} 1/s with T={T} s gives kT={k * T:.6g}, outside the "
                             f"stability interval (0, {self.tau_s:.6g}) for mu={self.mu:.6g}")


#: Tolerances of the numerical design (flow time units).
DESIGN_XTOL = 1e-12


def design_nonsquare(mu: float, kbar: Any, d: Any = None, *, form: str = "induced") -> GainDesign:
    """``tau_s_bar``, ``tau_o_bar``, ``rho`` from ``g`` of (4.29) (Sec. 4.5.1), for the estimate
    *mu* of mu*, the diagonal *kbar* of K_bar and the weights *d* and *form* of
    :func:`g_nonsquare`.

    ``g`` is convex in tau with ``g(0) <= 1`` and ``g'(0) < 0``; ``tau_o_bar`` is found by
    bounded Brent minimisation on ``[0, 2/min k]`` (xatol :data:`DESIGN_XTOL`) and
    ``tau_s_bar`` as the root of ``g = 1`` beyond it by Brent's method (same tolerance).
    """
    mu = _check_mu(mu)
    k = np.asarray(kbar, dtype=float).reshape(-1)
    gfun = lambda t: g_nonsquare(t, mu, k, d, form=form)  # noqa: E731
    hi = 2.0 / float(k.min())
    # g is convex; its minimiser lies in [0, hi] since g(hi) >= g(0) there.  Between
    # consecutive breakpoints (zeros and pairwise crossings of the affine pieces
    # +-(1 - tau k_i) w_i) the max is one affine piece, so g is a smooth parabola there.
    w = np.ones_like(k) if (form == "induced" or d is None) else 1.0 / np.asarray(d, dtype=float).reshape(-1) ** 2
    pieces = np.unique(np.stack([w, w * k], axis=1), axis=0)  # (c0, c1): c0 - c1 tau
    bps = [0.0, hi] + [c0 / c1 for c0, c1 in pieces]
    for i in range(len(pieces)):
        for j in range(i + 1, len(pieces)):
            (a0, a1), (b0, b1) = pieces[i], pieces[j]
            for s_ in (1.0, -1.0):  # a0 - a1 t = s (b0 - b1 t)
                den = a1 - s_ * b1
                if den != 0.0:
                    bps.append((a0 - s_ * b0) / den)
    bps = np.asarray(bps)
    kinks = np.unique(bps[(bps >= 0.0) & (bps <= hi)])
    best_t, best_g = 0.0, gfun(0.0)
    for lo_, hi_ in zip(kinks[:-1], kinks[1:]):  # Brent on each smooth piece
        if hi_ <= lo_:
            continue
        r = minimize_scalar(gfun, bounds=(lo_, hi_), method="bounded", options={"xatol": DESIGN_XTOL})
        for t_, g_ in ((r.x, r.fun), (lo_, gfun(lo_)), (hi_, gfun(hi_))):
            if g_ < best_g:
                best_t, best_g = float(t_), float(g_)
    if best_g >= 1.0:
        raise ValueError(f"g(tau; mu={mu}) never drops below 1: no stabilising offline gain")
    if gfun(hi) >= 1.0:
        ts = brentq(lambda t: gfun(t) - 1.0, best_t, hi, xtol=DESIGN_XTOL, rtol=4 * np.finfo(float).eps)
    else:  # only possible for form="thesis" with d_i > 1
        ub = hi
        while gfun(ub) < 1.0:
            ub *= 2.0
        ts = brentq(lambda t: gfun(t) - 1.0, hi, ub, xtol=DESIGN_XTOL, rtol=4 * np.finfo(float).eps)
    return GainDesign(mu, float(ts), best_t, best_g)


def design(mu: float) -> GainDesign:
    """Closed-form design for square systems with ``K_bar = I`` (Propositions 3.4.3-3.4.4), for
    the estimate *mu* of mu* (> 0)."""
    return GainDesign(_check_mu(mu), tau_s_bar(mu), tau_o_bar(mu), rho(mu))


# ---------------------------------------------------------------------------
# Monte-Carlo estimate of mu (3.19)/(4.27)
# ---------------------------------------------------------------------------

@dataclass
class MuEstimate:
    """Estimate ``mu_hat*`` of (3.19)/(4.27) and the per-sample details.

    ``samples``: the sampled errors ``e_h`` (rows); ``mu_i``: each sample's
    ``max_tau ||d'(tau, e_h)|| / (tau^2 ||e_h||)``; ``tau_s``: each sample's return time (dimensionless, ``k T``)
    (``inf`` if the flow did not return before ``tau_max``); ``radius``: the radius of
    the ball sampled; ``norm``: the :class:`~netcosim.controllers.planner.norms.WeightedNorm`
    it is measured in.
    """

    mu_hat: float
    radius: float
    samples: np.ndarray = field(repr=False)
    mu_i: np.ndarray = field(repr=False)
    tau_s: np.ndarray = field(repr=False)
    norm: WeightedNorm = field(default_factory=WeightedNorm)

    @property
    def n(self) -> int:
        """The number of sampled errors."""
        return int(self.samples.shape[0])


def estimate_mu(system: Any, q_ref: Any, radius: float, n_samples: int = 200, *, kbar: Any = None,
                norm: Any = None, seed: int | np.random.Generator = 0, n_tau: int = 100,
                tau_max: float | None = None, include_boundary: bool = True) -> MuEstimate:
    """Monte-Carlo estimate ``mu_hat*`` (3.19)/(4.27) over the ball ``||e|| < radius``.

    *system*: the kinematic system; *q_ref*: the reference configuration (rad, m) the
    errors are taken around; *kbar*: the diagonal of K_bar (None: ones); *seed*: a seed or
    a ``numpy.random.Generator`` for the draws; *tau_max*: the flows' horizon (None: the
    default of :func:`~netcosim.controllers.planner.flow.solve_auxiliary_flow`).

    For each of ``n_samples`` errors ``e_h`` drawn uniformly in the (weighted) ball, the
    auxiliary flow is integrated until the norm returns to ``||e_h||`` (event detection,
    see :func:`~netcosim.controllers.planner.flow.solve_auxiliary_flow`) and the ratio
    ``||e'(tau) - (I - tau K_bar) e_h|| / (tau^2 ||e_h||)`` is maximised over ``n_tau``
    points of ``(0, tau_s]`` (geometric near 0, uniform beyond).  With
    ``include_boundary`` half of the samples are pushed to the sphere ``||e|| = radius``
    (the remainder scales with ``||e_h||``, so the maximum is near the boundary).
    ``radius`` is in the units of the (weighted) norm.
    """
    check_system(system)
    m = system.m
    q_ref = as_vector(q_ref, m, "q_ref")
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) or n_samples < 1:
        raise ValueError(f"mu estimation needs at least one sample, got n_samples={n_samples!r}")
    radius = check_period(radius, "ball radius r")
    nrm = WeightedNorm.of(norm)
    kd = diag_gain(kbar, m)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    E = nrm.sample_ball(rng, m, radius, int(n_samples))
    if include_boundary:
        half = int(n_samples) // 2
        for i in range(half):
            E[i] *= radius / nrm(E[i]) * (1.0 - 1e-9)
    mu_i = np.empty(len(E))
    ts = np.empty(len(E))
    for i, e_h in enumerate(E):
        flow = solve_auxiliary_flow(system, q_ref, e_h, kbar=kd, norm=nrm, tau_max=tau_max)
        tau_end = flow.tau_end
        taus = np.unique(np.concatenate((np.geomspace(tau_end * 1e-3, tau_end * 0.05, n_tau // 4),
                                         np.linspace(tau_end * 0.05, tau_end, n_tau - n_tau // 4))))
        Ep = flow(taus)
        D = Ep - (1.0 - np.multiply.outer(taus, kd)) * e_h
        mu_i[i] = float(np.max(nrm.many(D) / (taus ** 2 * nrm(e_h))))
        ts[i] = flow.tau_s
    return MuEstimate(float(mu_i.max()), radius, E, mu_i, ts, nrm)
