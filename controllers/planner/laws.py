"""The local planners of thesis ch. 3 and 4, continuous and sampled, and their closed loop.

* :func:`planner_velocity` -- continuous local planner ``u = -A_q K (q - q_r)``
  (3.8)/(4.14), centralized form;
* :func:`robot_velocity` -- its sparse per-robot form (3.10) for a block-diagonal
  ``K = diag(K_1, ..., K_N, K_V)``: robot *i* needs only its own ``q_i`` and the pivot
  pose ``q_V``;
* :func:`sampled_velocity` -- the sampled law ``u_h = -k A_{q_h} K_bar e_h`` (3.11)/(4.16);
* :class:`OfflineGain`, :class:`OnlineGain` -- a constant gain or ``k_h = tau_o(e_h)/T``;
* :func:`simulate_sampled` -- the sampled planner in closed loop with the kinematic model.

Conventions: errors are ``e = q - q_r``; the thesis's ``(3.10)`` is printed without the
minus sign of (3.8), we keep the sign of (3.8) so that both forms give the same ``u``.
Units: q in rad and m, u in m/s, T in s, gains in 1/s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .flow import online_gain
from .kinematics import (
    as_vector,
    check_gain_matrix,
    check_period,
    check_system,
    diag_gain,
    integrate_kinematics,
    jacobian,
)
from .norms import WeightedNorm
from .structure import StarStructure

__all__ = ["planner_velocity", "robot_velocity", "sampled_velocity", "OfflineGain", "OnlineGain",
           "simulate_sampled"]


def planner_velocity(system: Any, q: Any, q_ref: Any, K: Any = 1.0) -> np.ndarray:
    """Centralized local planner ``u = -A_q K (q - q_r)`` (3.8)/(4.14), in m/s.

    ``K``: scalar, diagonal vector or matrix; validated with :func:`check_gain_matrix`.
    *system*: the kinematic system; *q_ref*: the reference configuration q_r (rad, m); *q*: the configuration.
    """
    check_system(system)
    m = system.m
    q = as_vector(q, m, "q")
    e = q - as_vector(q_ref, m, "q_ref")
    K = check_gain_matrix(K, m)
    return jacobian(system, q) @ (-(K @ e))


def robot_velocity(system: Any, structure: StarStructure, i: int, q_i: Any, q_V: Any,
                   q_ref: Any, K: Any = 1.0) -> np.ndarray:
    """Sparse per-robot planner (3.10): robot *i*'s velocity from ``(q_i, q_V)`` only.

    ``u_i = -A^(i)_{q_i} K_i (q_i - q_i^r) - A^(i)_{q_V} K_V (q_V - q_V^r)``.

    ``K``: scalar or length-m vector of diagonal gains (``K = diag(K_1..K_N, K_V)``
    block diagonal with diagonal blocks, as in Sec. 4.4).  Robot *i*'s rows of ``A_q``
    are evaluated at a configuration that holds ``(q_i, q_V)`` and the reference values
    elsewhere -- they do not depend on the other robots' coordinates (3.3).
    *system*: the kinematic system; *q_ref*: the reference configuration q_r (rad, m);
    *structure*: the :class:`StarStructure` saying which coordinates are
    robot *i*'s and which the pivot's.
    """
    check_system(system)
    m = system.m
    if not 0 <= i < structure.N:
        raise IndexError(f"robot index {i} out of range for {structure.N} robots")
    q_ref = as_vector(q_ref, m, "q_ref")
    kd = diag_gain(K, m)
    ci = np.asarray(structure.cols[i], dtype=int)
    cv = np.asarray(structure.pivot, dtype=int)
    q_i = as_vector(q_i, len(ci), f"q_{i}")
    q_V = as_vector(q_V, len(cv), "q_V")
    q = q_ref.copy()
    q[ci] = q_i
    q[cv] = q_V
    A = jacobian(system, q)
    rows = np.asarray(structure.rows[i], dtype=int)
    idx = structure.agent_q(i)
    e = q[idx] - q_ref[idx]
    return A[np.ix_(rows, idx)] @ (-(kd[idx] * e))


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
    """The online gain ``k_h = tau_o(e_h) / T`` recomputed at every sample (3.26)/(4.30);
    ``tau_max``: the bound on tau_o passed to :func:`~netcosim.controllers.planner.flow.online_gain`
    (None: none)."""

    tau_max: float | None = None

    def __call__(self, system, q, q_ref, T, kbar, norm):
        k, flow = online_gain(system, q, q_ref, T, kbar=kbar, norm=norm, tau_max=self.tau_max)
        return k, flow


def sampled_velocity(system: Any, q_h: Any, q_ref: Any, k: float, kbar: Any = None) -> np.ndarray:
    """``u_h = -k A_{q_h} K_bar (q_h - q_r)``, held on ``[hT, (h+1)T)`` (Sec. 3.4/4.5), m/s.
    *system*: the kinematic system; *q_ref*: the reference configuration q_r (rad, m);
    *kbar*: the diagonal of K_bar (None: ones; see
    :func:`~netcosim.controllers.planner.kinematics.diag_gain`)."""
    m = system.m
    q_h = as_vector(q_h, m, "q_h")
    kd = diag_gain(kbar, m)
    return jacobian(system, q_h) @ (-k * (kd * (q_h - as_vector(q_ref, m, "q_ref"))))


def simulate_sampled(system: Any, q0: Any, q_ref: Any, T: float, gain: Any, *, kbar: Any = None,
                     norm: Any = None, n_samples: int = 50, tol: float = 0.0,
                     plant: Callable[..., np.ndarray] | None = None, guarantee: Any = None):
    """Run the sampled planner (3.11)/(4.16) against the kinematic model.

    *system*: the kinematic system; *q_ref*: the reference configuration q_r (rad, m);
    *kbar*: the diagonal of K_bar (None: ones).

    ``gain``: :class:`OfflineGain` or :class:`OnlineGain`.  At each sample ``h`` the gain
    ``k_h`` and ``u_h = -k_h A_{q_h} K_bar e_h`` are computed, then the plant
    ``q_dot = A_q^+ u_h`` is integrated over one period (``plant(q, u, T)``; default
    :func:`integrate_kinematics` with DOP853, rtol 1e-12, atol 1e-13).  Stops after
    ``n_samples`` periods or once ``||e_h|| < tol``.  ``guarantee``: a
    :class:`~netcosim.controllers.planner.gain_design.GainDesign`; an offline gain outside its stability
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
    q = as_vector(q0, m, "q0")
    q_ref = as_vector(q_ref, m, "q_ref")
    nrm = WeightedNorm.of(norm)
    kd = diag_gain(kbar, m)
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
