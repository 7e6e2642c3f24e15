"""Robot–robot clearance along the planners' motions, between the samples too (§6.3).

Two sources of a motion:

* :func:`sampled_clearance` -- a run of :func:`~netcosim.controllers.planner.laws.simulate_sampled`
  (the kinematic model, one row per sample with ``q0..`` and ``u0..``).  For a square
  system ``p_dot = u_h`` is constant over a period, so every robot moves on the straight
  segment from ``p_h`` to ``p_h + T u_h``: the closest approach of each pair per period
  is the closed form of :func:`~netcosim.plants.flycrane.collisions.segment_min_distance`
  (the reported ``chord_error`` is then only the integrator's mismatch between
  ``p_h + T u_h`` and ``h(q_{h+1})``).  For a non-square system ``p_dot = Pi_q u_h``
  turns as q moves (4.5): each period is integrated again with dense output
  (``per_period`` points) and the chord error bounded
  (:func:`~netcosim.plants.flycrane.collisions.chord_error_bound`).
* :func:`trajectory_clearance` -- a dense configuration series (dynamic model, network
  runs): robot positions ``h(q(t))`` on the grid, chord error bounded the same way.

Both return a :class:`~netcosim.plants.flycrane.collisions.ClosestApproach` (distance
in m, time in s, the pair, whether it comes below the safety distance).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from netcosim.plants.flycrane.collisions import SAFETY_DISTANCE, ClosestApproach, min_pairwise_distance

from .kinematics import check_period, integrate_kinematics

__all__ = ["sampled_clearance", "trajectory_clearance"]


def _columns(samples, prefix, k):
    cols = [f"{prefix}{i}" for i in range(k)]
    missing = [c for c in cols if c not in samples.columns]
    if missing:
        raise ValueError(f"samples lack the columns {missing[:3]}... of a simulate_sampled run")
    return samples[cols].to_numpy(dtype=float)


def sampled_clearance(system: Any, samples, T: float, *, per_period: int = 16,
                      safety_distance: float = SAFETY_DISTANCE) -> ClosestApproach:
    """Closest robot–robot approach of one sampled kinematic run (*samples*: the
    DataFrame of one :func:`simulate_sampled` run, rows in time order; *T* [s] its
    period).  Straight segments in closed form for a square system, dense
    re-integration (*per_period* points per period) otherwise.  ``safety_distance`` [m]:
    the centre-to-centre distance below which two robots may touch."""
    T = check_period(T)
    if int(per_period) != per_period or per_period < 2:
        raise ValueError(f"per_period must be an integer >= 2, got {per_period!r}")
    Q = _columns(samples, "q", system.m)
    U = _columns(samples, "u", system.n)
    t = samples["t"].to_numpy(dtype=float)
    if system.n == system.m:
        P = np.array([system.h(q) for q in Q])
        # the model's segment ends p_h + T u_h against the integrated h(q_{h+1})
        ce = float(np.abs(P[:-1] + T * U[:-1] - P[1:]).max()) if len(P) > 1 else 0.0
        return min_pairwise_distance(t, P, safety_distance=safety_distance, chord_error=2 * ce)
    times, pos = [], []
    for k in range(len(Q) - 1):
        _, sol = integrate_kinematics(system, Q[k], U[k], 0.0, T, dense=True)
        for s in np.arange(per_period) * (T / per_period):
            times.append(t[k] + s)
            pos.append(system.h(sol(s)))
    times.append(t[-1])
    pos.append(system.h(Q[-1]))
    return min_pairwise_distance(np.array(times), np.array(pos), safety_distance=safety_distance,
                                 chord_error=None)


def trajectory_clearance(system: Any, t, q, *, safety_distance: float = SAFETY_DISTANCE) -> ClosestApproach:
    """Closest robot–robot approach along the configuration series *q* (``(K, m)``) at
    the times *t* [s] (a dense grid of a dynamic run) of the kinematic *system*;
    ``safety_distance`` [m]: the centre-to-centre distance below which two robots may touch."""
    q = np.asarray(q, dtype=float)
    P = np.array([system.h(qk) for qk in q])
    return min_pairwise_distance(np.asarray(t, dtype=float), P, safety_distance=safety_distance,
                                 chord_error=None)
