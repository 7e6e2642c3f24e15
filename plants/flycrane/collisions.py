"""Robot–robot distances along a motion, between the samples too (thesis §6.3).

The thesis's future work (§6.3): "during the maneuver a robot may collide against an
other robot ... this could be not enough if the collision happens between two sampling
times".  This module measures the smallest centre-to-centre distance between any two
robots over a whole motion, not only at the samples:

* :func:`segment_min_distance` — two points moving at constant velocity over
  ``[0, T]`` (straight segments): the minimum of ``|d0 + t (d1 - d0) / T|`` in closed
  form, with the instant where it occurs.  Exact for the kinematic model of a square
  system, where ``p_dot = u`` is held constant between samples (3.4).
* :func:`min_pairwise_distance` — all robot pairs over a piecewise-linear path given at
  increasing times (positions ``(K, N, 3)`` [m]): the closed form on each piece.  For a
  curved path (a non-square kinematic model, ``p_dot = Pi_q u`` turns as q moves; the
  dynamic model) give it dense output; ``chord_error`` then bounds how far the true
  path can come below the chords: a curve with acceleration ``|p_ddot| <= a`` leaves
  its chord over a piece of length ``dt`` by at most ``a dt^2 / 8``, so the relative
  distance of two robots by at most ``a_rel dt^2 / 8`` (:func:`chord_error_bound`).

Robot size: neither the thesis's appendix B nor ch. 4 gives it.  :data:`ROBOT_RADIUS`
= 0.25 m is an assumption (a quadrotor of the Fly-crane's 1.03 kg, §3.6, spans about
0.5 m with its propellers); two robots *touch* when their centres are closer than
:data:`SAFETY_DISTANCE` = 2 x 0.25 m = 0.5 m.  Pass another value where it matters.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["ROBOT_RADIUS", "SAFETY_DISTANCE", "segment_min_distance", "min_pairwise_distance",
           "chord_error_bound", "ClosestApproach"]

#: Assumed robot radius [m] (propeller tip to centre); not in the thesis.
ROBOT_RADIUS = 0.25
#: Centre-to-centre distance [m] below which two robots of :data:`ROBOT_RADIUS` touch.
SAFETY_DISTANCE = 2 * ROBOT_RADIUS


def _vec(v, what):
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.size == 0 or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be finite coordinates in metres, got {v!r}")
    return a


def segment_min_distance(pa0, pa1, pb0, pb1, T: float = 1.0) -> tuple[float, float]:
    """Smallest distance [m] between robots a and b moving in straight lines at constant
    velocity from ``pa0``, ``pb0`` (time 0) to ``pa1``, ``pb1`` (time ``T`` [s]), and the
    time [s] in ``[0, T]`` where it occurs (the earliest, if the distance is constant).

    With ``d(t) = d0 + (t / T) (d1 - d0)``, ``d0 = pa0 - pb0``, ``d1 = pa1 - pb1``:
    ``|d(t)|^2`` is a convex quadratic, minimal at ``t* = -T d0.(d1 - d0) / |d1 - d0|^2``
    clipped to ``[0, T]``.
    """
    T = float(T)
    if not np.isfinite(T) or T <= 0:
        raise ValueError(f"segment duration T must be a positive number of seconds, got {T!r}")
    d0 = _vec(pa0, "pa0") - _vec(pb0, "pb0")
    d1 = _vec(pa1, "pa1") - _vec(pb1, "pb1")
    if d0.shape != d1.shape:
        raise ValueError(f"positions must all have the same dimension, got {d0.shape} and {d1.shape}")
    w = d1 - d0
    ww = float(w @ w)
    s = 0.0 if ww == 0.0 else min(1.0, max(0.0, -float(d0 @ w) / ww))
    return float(np.linalg.norm(d0 + s * w)), s * T


@dataclass(frozen=True)
class ClosestApproach:
    """The closest approach of two robots over a motion.

    ``distance`` [m] (centre to centre, on the chords of the given path), ``time`` [s],
    ``pair`` (robot indices, 0-based), ``at_sample`` the smallest distance at the given
    instants only [m], ``chord_error`` [m] the bound on how much lower the true path can
    go (0 for straight segments), ``safety_distance`` [m] and ``below_safety``
    (``distance - chord_error < safety_distance``: a possible contact).
    """

    distance: float
    time: float
    pair: tuple[int, int]
    at_sample: float
    chord_error: float
    safety_distance: float

    @property
    def below_safety(self) -> bool:
        """``distance - chord_error < safety_distance``: the robots may have touched."""
        return bool(self.distance - self.chord_error < self.safety_distance)

    def as_row(self) -> dict:
        """A flat dict (for a table row): the fields and ``below_safety``."""
        return dict(min_distance=self.distance, t_min_distance=self.time, pair_a=self.pair[0],
                    pair_b=self.pair[1], min_distance_at_samples=self.at_sample,
                    chord_error=self.chord_error, safety_distance=self.safety_distance,
                    below_safety=self.below_safety)


def chord_error_bound(times, positions) -> float:
    """Bound [m] on how far the relative position of two robots can leave the chords of
    the dense path *positions* (``(K, N, 3)`` at *times*): ``a_rel dt^2 / 8`` with the
    largest piece ``dt`` and ``a_rel`` twice the largest second difference of any
    relative position (``|d(t_{k+1}) - 2 d(t_k) + d(t_{k-1})|`` over the local step
    squared; the factor 2 covers the acceleration between the dense points).  0 with
    fewer than 3 instants (nothing to estimate a curvature from)."""
    t = np.asarray(times, dtype=float)
    P = np.asarray(positions, dtype=float)
    if t.size < 3:
        return 0.0
    dt = np.diff(t)
    N = P.shape[1]
    a = 0.0
    for i, j in itertools.combinations(range(N), 2):
        d = P[:, i] - P[:, j]
        v = np.diff(d, axis=0) / dt[:, None]
        acc = np.diff(v, axis=0) / ((dt[1:] + dt[:-1]) / 2)[:, None]
        a = max(a, float(np.linalg.norm(acc, axis=1).max()))
    return 2.0 * a * float(dt.max()) ** 2 / 8.0


def min_pairwise_distance(times, positions, *, safety_distance: float = SAFETY_DISTANCE,
                          chord_error: float | None = 0.0) -> ClosestApproach:
    """Closest approach of any two robots along the piecewise-linear path through
    *positions* (array ``(K, N, 3)`` or ``(K, 3N)`` [m], robot positions at the
    increasing *times* [s], K >= 1).

    ``chord_error``: the bound [m] to report (0 for an exactly piecewise-linear path,
    e.g. the kinematic square model sampled at its samples); ``None`` estimates it
    with :func:`chord_error_bound` (dense output of a curved path).  ``safety_distance``
    [m]: the centre-to-centre distance below which two robots may touch (default
    :data:`SAFETY_DISTANCE`, two :data:`ROBOT_RADIUS`).
    """
    t = np.asarray(times, dtype=float).reshape(-1)
    P = np.asarray(positions, dtype=float)
    if P.ndim == 2:
        if P.shape[1] % 3:
            raise ValueError(f"flat positions need 3 coordinates per robot, got {P.shape[1]} columns")
        P = P.reshape(P.shape[0], -1, 3)
    if P.ndim != 3 or P.shape[0] != t.size or P.shape[1] < 2 or t.size < 1:
        raise ValueError(f"positions must be (K, N >= 2, 3) with K = len(times) = {t.size}, got {P.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(P))):
        raise ValueError("times and positions must be finite")
    if np.any(np.diff(t) <= 0):
        raise ValueError("times must be strictly increasing")
    sd = float(safety_distance)
    if not np.isfinite(sd) or sd < 0:
        raise ValueError(f"safety_distance must be a non-negative distance in metres, got {safety_distance!r}")
    best = (np.inf, 0.0, (0, 1))
    at_sample = np.inf
    N = P.shape[1]
    for i, j in itertools.combinations(range(N), 2):
        d = P[:, i] - P[:, j]
        dist = np.linalg.norm(d, axis=1)
        at_sample = min(at_sample, float(dist.min()))
        k0 = int(np.argmin(dist))
        if dist[k0] < best[0]:
            best = (float(dist[k0]), float(t[k0]), (i, j))
        if t.size > 1:
            w = np.diff(d, axis=0)
            ww = np.einsum("ij,ij->i", w, w)
            s = np.where(ww > 0, -np.einsum("ij,ij->i", d[:-1], w) / np.where(ww > 0, ww, 1.0), 0.0)
            s = np.clip(s, 0.0, 1.0)
            seg = np.linalg.norm(d[:-1] + s[:, None] * w, axis=1)
            k = int(np.argmin(seg))
            if seg[k] < best[0]:
                best = (float(seg[k]), float(t[k] + s[k] * (t[k + 1] - t[k])), (i, j))
    ce = chord_error_bound(t, P) if chord_error is None else float(chord_error)
    return ClosestApproach(best[0], best[1], best[2], at_sample, ce, sd)
