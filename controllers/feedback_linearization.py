"""Low-level controller of thesis §2.5 and the C² reference interpolator of Fig. 2.6.

:class:`FeedbackLinearization`
    With the auxiliary inputs (2.14) ``ū1 = a1 cos φ + a2 cos(φ+ϑ) f_R`` and
    ``ū2 = a3 τ_R`` the force model (2.3) becomes two decoupled double integrators
    (2.15) ``φ̈ = ū1``, ``ϑ̈ = ū2``.  Each is stabilized by PID with acceleration
    feed-forward, ``ū = q̈_d - K_P e - K_D ė - K_I ∫e``, ``e = q - q_d``, and (2.16)
    maps back to ``f_R = (ū1 - a1 cos φ) / (a2 cos(φ+ϑ))`` and ``τ_R = ū2 / a3``.

    Discrete-time implementation for a fixed sampling period ``dt`` (s): the
    integral is accumulated by forward Euler, the derivative uses the measured rates.
    The outputs are saturated to the actuator bounds (Table 2.1) and integration is
    frozen while an output is saturated in the direction of the error
    (conditional-integration anti-windup).

    Singularity: (2.16) divides by ``cos(φ+ϑ)``, zero when the thrust is normal to
    the circle on which the CoM moves (φ + ϑ = ±π/2).  Below ``|cos(φ+ϑ)| < cos_min``
    the controller either raises :class:`SingularityError` naming the configuration
    (``on_singular="raise"``, default) or divides by ``±cos_min`` (sign of the cosine)
    and counts the event in ``n_singular`` (``on_singular="saturate"``) -- the thrust
    command then stays finite and the output saturation bounds it.

:class:`C2Interpolator`
    Turns the sequence of NMPC reference states (one every T_s = 10 ms) into a
    reference that is twice continuously differentiable in time: on each update the
    new first segment is the quintic polynomial that starts from the interpolator's
    own position, velocity and acceleration at the update instant and reaches the
    plan's position, velocity and acceleration at the next node; further quintics
    join the plan's following nodes.  Position, velocity and acceleration are
    therefore continuous at every update, however late the update arrives, and a
    late update finds the reference still on the previous plan.  After the last
    knot the reference continues with constant acceleration (still C²).

Angles in radians, rates in rad/s, thrust in N, torque in N·m, time in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plants.tethered_uav import TetheredUAVParams

__all__ = ["FeedbackLinearization", "C2Interpolator", "PIDGains", "SingularityError", "quintic_coefficients"]


class SingularityError(ArithmeticError):
    """Raised when cos(φ + ϑ) is too close to zero to invert (2.14)."""


@dataclass(frozen=True)
class PIDGains:
    """PID gains of one double integrator: K_P [1/s²], K_D [1/s], K_I [1/s³]."""

    kp: float
    kd: float
    ki: float

    def __post_init__(self):
        for name in ("kp", "kd", "ki"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"PIDGains.{name} must be a finite non-negative number, got {v!r}")

    @classmethod
    def triple_pole(cls, omega: float) -> "PIDGains":
        """Gains placing the three closed-loop poles of ``q̈ = ū`` at ``-omega`` [rad/s]:
        ``(s + ω)³ = s³ + 3ω s² + 3ω² s + ω³``."""
        if not (isinstance(omega, (int, float)) and math.isfinite(omega) and omega > 0):
            raise ValueError(f"omega must be a positive number of rad/s, got {omega!r}")
        return cls(kp=3.0 * omega ** 2, kd=3.0 * omega, ki=omega ** 3)


class FeedbackLinearization:
    """Feedback linearization + PID/feed-forward for the force model (2.3).

    Parameters
    ----------
    params:
        Model parameters (a1, a2, a3 and the actuator bounds of Table 2.1).
    dt:
        Sampling period [s] (500 Hz in the thesis: 0.002).
    gains_phi, gains_theta:
        :class:`PIDGains` of the elevation and attitude loops (default: triple pole
        at -25 rad/s for both).
    cos_min, on_singular:
        Singularity guard, see the module doc.
    saturate:
        Clip f_R to [0, f_R_max] and τ_R to [-τ_R_max, τ_R_max] (default True).
    """

    def __init__(self, params: TetheredUAVParams | None = None, dt: float = 0.002, *,
                 gains_phi: PIDGains | None = None, gains_theta: PIDGains | None = None,
                 cos_min: float = 0.05, on_singular: str = "raise", saturate: bool = True):
        self.params = p = TetheredUAVParams() if params is None else params
        if not isinstance(p, TetheredUAVParams):
            raise TypeError(f"params must be TetheredUAVParams, got {params!r}")
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"sampling period dt must be a positive number of seconds, got {dt!r}")
        if not (isinstance(cos_min, (int, float)) and 0 < cos_min < 1):
            raise ValueError(f"cos_min must lie in (0, 1), got {cos_min!r}")
        if on_singular not in ("raise", "saturate"):
            raise ValueError(f"on_singular must be 'raise' or 'saturate', got {on_singular!r}")
        self.dt = float(dt)
        self.gains_phi = gains_phi or PIDGains.triple_pole(25.0)
        self.gains_theta = gains_theta or PIDGains.triple_pole(25.0)
        for nm, g in (("gains_phi", self.gains_phi), ("gains_theta", self.gains_theta)):
            if not isinstance(g, PIDGains):
                raise TypeError(f"{nm} must be PIDGains, got {g!r}")
        self.cos_min = float(cos_min)
        self.on_singular = on_singular
        self.saturate = bool(saturate)
        self.lb = np.array([0.0, -p.tau_R_max])
        self.ub = np.array([p.f_R_max, p.tau_R_max])
        self.reset()

    def reset(self) -> None:
        """Zero the integrators and the counters."""
        self.integral = np.zeros(2)  # ∫e for φ and ϑ [rad·s]
        self.n_singular = 0
        self.n_saturated = 0

    def __call__(self, x, ref_pos, ref_vel, ref_acc) -> np.ndarray:
        """One sample: ``[f_R, τ_R]`` from the state ``x = [φ, φ̇, ϑ, ϑ̇, ...]`` and
        the reference positions/velocities/accelerations ``(φ_d, ϑ_d)``."""
        x = np.asarray(x, dtype=float)
        if x.shape[0] < 4 or not np.all(np.isfinite(x[:4])):
            raise ValueError(f"state must start with 4 finite values [phi, dphi, theta, dtheta], got {x.tolist()}")
        qd = np.asarray(ref_pos, dtype=float).reshape(2)
        vd = np.asarray(ref_vel, dtype=float).reshape(2)
        ad = np.asarray(ref_acc, dtype=float).reshape(2)
        if not (np.all(np.isfinite(qd)) and np.all(np.isfinite(vd)) and np.all(np.isfinite(ad))):
            raise ValueError(f"reference must be finite, got pos={qd.tolist()} vel={vd.tolist()} acc={ad.tolist()}")
        p = self.params
        q = np.array([x[0], x[2]])
        v = np.array([x[1], x[3]])
        e = q - qd
        edot = v - vd
        kp = np.array([self.gains_phi.kp, self.gains_theta.kp])
        kd = np.array([self.gains_phi.kd, self.gains_theta.kd])
        ki = np.array([self.gains_phi.ki, self.gains_theta.ki])
        integral_new = self.integral + e * self.dt
        ubar = ad - kp * e - kd * edot - ki * integral_new
        u = self.invert(x, ubar)
        if self.saturate:
            sat = np.clip(u, self.lb, self.ub)
            hit = sat != u
            if np.any(hit):
                self.n_saturated += 1
            # conditional integration: freeze an axis whose output is clipped and whose
            # error would push it further into saturation.  ∂u/∂e has the sign of -ki·∂u/∂ū.
            du_dubar = np.array([1.0 / (p.a2 * math.cos(x[0] + x[2])) if abs(math.cos(x[0] + x[2])) > 0 else 0.0,
                                 1.0 / p.a3])
            push = -np.sign(e) * np.sign(du_dubar)  # direction the integral moves u
            windup = hit & (((sat == self.ub) & (push > 0)) | ((sat == self.lb) & (push < 0)))
            self.integral = np.where(windup, self.integral, integral_new)
            return sat
        self.integral = integral_new
        return u

    def invert(self, x, ubar) -> np.ndarray:
        """(2.16): ``[f_R, τ_R]`` producing the accelerations ``ubar = (φ̈, ϑ̈)`` at state *x*."""
        p = self.params
        c = math.cos(x[0] + x[2])
        if abs(c) < self.cos_min:
            if self.on_singular == "raise":
                raise SingularityError(
                    f"feedback linearization singular: cos(phi + theta) = {c:.3g} at phi = {float(x[0])!r} rad, "
                    f"theta = {float(x[2])!r} rad (|cos| < cos_min = {self.cos_min})")
            self.n_singular += 1
            c = math.copysign(self.cos_min, c) if c != 0 else self.cos_min
        f_R = (ubar[0] - p.a1 * math.cos(x[0])) / (p.a2 * c)
        tau_R = ubar[1] / p.a3
        return np.array([f_R, tau_R])


# ---------------------------------------------------------------------------
# C² interpolation
# ---------------------------------------------------------------------------

def quintic_coefficients(T: float, p0, v0, a0, p1, v1, a1) -> np.ndarray:
    """Coefficients ``c[0..5]`` (rows) of ``q(s) = Σ c_i s^i`` on ``s ∈ [0, T]`` matching
    position, velocity and acceleration at both ends (element-wise for arrays)."""
    if not (T > 0 and math.isfinite(T)):
        raise ValueError(f"segment duration must be positive, got {T!r}")
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
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n <= 0:
            raise ValueError(f"number of channels must be a positive integer, got {n!r}")
        self.n = int(n)
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
