"""The C² reference interpolator of thesis Fig. 2.6.

:class:`C2Interpolator` turns the sequence of NMPC reference states (one every
T_s = 10 ms) into a reference that is twice continuously differentiable in time: on
each update the new first segment is the quintic polynomial that starts from the
interpolator's own position, velocity and acceleration at the update instant and
reaches the plan's position, velocity and acceleration at the next node; further
quintics join the plan's following nodes.  Position, velocity and acceleration are
therefore continuous at every update, however late the update arrives, and a late
update finds the reference still on the previous plan.  After the last knot the
reference continues with constant acceleration (still C²).

Positions in the channel's unit (radians for the landing's (φ, ϑ)), velocities in
that unit per second, accelerations per second squared, times in seconds.
"""

from __future__ import annotations

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

__all__ = ["C2Interpolator", "quintic_coefficients"]


def quintic_coefficients(T: float, p0, v0, a0, p1, v1, a1) -> np.ndarray:
    """Coefficients ``c[0..5]`` (rows) of ``q(s) = Σ c_i s^i`` on ``s ∈ [0, T]`` matching
    position, velocity and acceleration at both ends (element-wise for arrays): *p0*, *v0*,
    *a0* at s = 0 and *p1*, *v1*, *a1* at s = *T* (T > 0, in the time unit of the
    velocities and accelerations, s for the landing's references)."""
    validate.positive(T, "segment duration", kind="positive")
    p0, v0, a0, p1, v1, a1 = (np.asarray(a, dtype=float) for a in (p0, v0, a0, p1, v1, a1))
    c0, c1, c2 = p0, v0, 0.5 * a0
    dp = p1 - (p0 + v0 * T + 0.5 * a0 * T ** 2)
    dv = v1 - (v0 + a0 * T)
    da = a1 - a0
    T2, T3 = T * T, T ** 3
    c3 = (10 * dp - 4 * dv * T + 0.5 * da * T2) / T3
    c4 = (-15 * dp + 7 * dv * T - da * T2) / (T3 * T)
    c5 = (6 * dp - 3 * dv * T + 0.5 * da * T2) / (T3 * T2)
    return np.array([c0, c1, c2, c3, c4, c5])


class C2Interpolator:
    """C² reference through consecutive NMPC reference states (Fig. 2.6), see module doc.

    ``n`` channels (2 for (φ, ϑ)).  Call :meth:`reset` once, then :meth:`update` at
    each new NMPC solution with its reference states at one or more future knot
    times, and :meth:`evaluate` at each low-level sample.  On an update at ``t_now``
    the reference becomes: a quintic from the current reference (position, velocity,
    acceleration at ``t_now``) to the first knot, then quintics between consecutive
    knots, then constant acceleration after the last knot.  Passing more than one
    knot (the plan's states at ``t_s + T_s``, ``t_s + 2 T_s``, ...) keeps the reference
    on the plan when the next update comes late.
    """

    def __init__(self, n: int = 2):
        self.n = validate.integer(n, "number of channels", lo=1, kind="a positive integer",
                                  type_error=ConfigurationError)
        self._starts: np.ndarray | None = None   # segment start times (s)
        self._durations: np.ndarray | None = None
        self._coefs: list[np.ndarray] = []        # (6, n) per segment
        self.n_updates = 0

    def _arr(self, v, what):
        a = np.asarray(v, dtype=float).reshape(-1)
        if a.shape[0] != self.n or not np.all(np.isfinite(a)):
            raise ValueError(f"{what} must be {self.n} finite values, got {np.asarray(v).tolist()}")
        return a

    def _knots(self, v, k, what):
        a = np.asarray(v, dtype=float)
        if a.ndim <= 1:
            a = a.reshape(1, -1)
        if a.shape != (k, self.n) or not np.all(np.isfinite(a)):
            raise ValueError(f"{what} must be {k} x {self.n} finite values (one row per knot), "
                             f"got {np.asarray(v).tolist()}")
        return a

    def reset(self, t: float, pos, vel=None, acc=None) -> None:
        """Start at time *t* [s] from (pos, vel, acc); the reference then extrapolates
        with constant acceleration until the first :meth:`update`."""
        pos = self._arr(pos, "pos")
        vel = np.zeros(self.n) if vel is None else self._arr(vel, "vel")
        acc = np.zeros(self.n) if acc is None else self._arr(acc, "acc")
        z = np.zeros(self.n)
        self._starts = np.array([float(t)])
        self._durations = np.array([0.0])
        self._coefs = [np.array([pos, vel, 0.5 * acc, z, z, z])]

    def update(self, t_now: float, t_knots, pos, vel, acc) -> None:
        """New reference from the current one at *t_now* through the knots.

        *t_knots*: one time or an increasing sequence of K times (s) after *t_now*;
        *pos*, *vel*, *acc*: the reference states there, shape (n,) for one knot or
        (K, n).
        """
        if self._starts is None:
            raise RuntimeError("C2Interpolator.update before reset")
        tk = np.atleast_1d(np.asarray(t_knots, dtype=float))
        if tk.ndim != 1 or tk.size == 0 or not np.all(np.isfinite(tk)):
            raise ValueError(f"knot times must be a non-empty sequence of finite seconds, got {t_knots!r}")
        if not (tk[0] > t_now):
            raise ValueError(f"target time {float(tk[0])!r} s must be after the update time {t_now!r} s")
        if np.any(np.diff(tk) <= 0):
            raise ValueError(f"knot times must increase, got {tk.tolist()}")
        if t_now < self._starts[0] - 1e-12:
            raise ValueError(f"update time {t_now!r} s lies before the current reference start "
                             f"{float(self._starts[0])!r} s")
        K = tk.size
        P = self._knots(pos, K, "pos")
        V = self._knots(vel, K, "vel")
        A = self._knots(acc, K, "acc")
        p0, v0, a0 = self.evaluate(t_now)
        starts = [float(t_now)]
        durs = [float(tk[0] - t_now)]
        coefs = [quintic_coefficients(durs[0], p0, v0, a0, P[0], V[0], A[0])]
        for k in range(1, K):
            starts.append(float(tk[k - 1]))
            durs.append(float(tk[k] - tk[k - 1]))
            coefs.append(quintic_coefficients(durs[-1], P[k - 1], V[k - 1], A[k - 1], P[k], V[k], A[k]))
        self._starts = np.array(starts)
        self._durations = np.array(durs)
        self._coefs = coefs
        self.n_updates += 1

    @property
    def end_time(self) -> float:
        """Time (s) of the last knot; constant-acceleration extrapolation after it."""
        return float(self._starts[-1] + self._durations[-1])

    def evaluate(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration) of the reference at time *t* [s]."""
        if self._starts is None:
            raise RuntimeError("C2Interpolator.evaluate before reset")
        t = float(t)
        if t < self._starts[0] - 1e-12:
            raise ValueError(f"time {t!r} s lies before the current reference start {float(self._starts[0])!r} s")
        i = int(np.searchsorted(self._starts, t, side="right")) - 1
        i = max(i, 0)
        s = t - self._starts[i]
        T = self._durations[i]
        if s > T:
            if i < len(self._starts) - 1:  # numerical edge between segments
                s = T
            else:  # past the last knot: constant acceleration from its state
                pT, vT, aT = self._poly(self._coefs[i], T)
                r = s - T
                return pT + vT * r + 0.5 * aT * r * r, vT + aT * r, aT
        return self._poly(self._coefs[i], max(s, 0.0))

    @staticmethod
    def _poly(c, s):
        pos = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))))
        vel = c[1] + s * (2 * c[2] + s * (3 * c[3] + s * (4 * c[4] + s * 5 * c[5])))
        acc = 2 * c[2] + s * (6 * c[3] + s * (12 * c[4] + s * 20 * c[5]))
        return pos, vel, acc
