"""Low-level controller of thesis §2.5: feedback linearization with PID and feed-forward.

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

The C² interpolator of Fig. 2.6 that feeds it lives in
:mod:`netcosim.controllers.landing.interpolation`.

Angles in radians, rates in rad/s, thrust in N, torque in N·m, time in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError
from netcosim.plants.tethered_uav_params import TetheredUAVParams

__all__ = ["FeedbackLinearization", "PIDGains", "SingularityError", "DEFAULT_FL_GAINS", "DEFAULT_FL_POLE",
           "SLOW_FL_GAINS"]


class SingularityError(ArithmeticError):
    """Raised when cos(φ + ϑ) is too close to zero to invert (2.14)."""


@dataclass(frozen=True)
class PIDGains:
    """PID gains of one double integrator: ``kp`` = K_P [1/s²], ``kd`` = K_D [1/s], ``ki`` = K_I [1/s³]."""

    kp: float
    kd: float
    ki: float

    def __post_init__(self):
        for name in ("kp", "kd", "ki"):
            validate.non_negative(getattr(self, name), f"PIDGains.{name}", kind="a finite non-negative number",
                                  type_error=ConfigurationError)

    @classmethod
    def triple_pole(cls, omega: float) -> "PIDGains":
        """Gains placing the three closed-loop poles of ``q̈ = ū`` at ``-omega`` [rad/s]:
        ``(s + ω)³ = s³ + 3ω s² + 3ω² s + ω³``."""
        validate.positive(omega, "omega", kind="a positive number of rad/s", type_error=ConfigurationError)
        return cls(kp=3.0 * omega ** 2, kd=3.0 * omega, ki=omega ** 3)


#: Triple pole [rad/s] of the low-level loops of the landing, the thesis's design.  The
#: thesis gives no numbers ("the gains are tuned manually", §2.6; "aggressive PID
#: action", §2.6.2), so the pole is chosen from the two rates of its architecture:
#: faster than the NMPC update, ``1/ω < Ts = 10 ms`` (ω > 100 rad/s: the tracking
#: error a plan leaves decays within one NMPC period, so the next plan, started from
#: the measured state, does not start from it), and slow enough for the 500 Hz
#: emulation, ``ω T ≤ 0.3`` (ω ≤ 150 rad/s; at 200 rad/s one discrete pole is already at
#: z = 0.08 instead of e^(-ωT) = 0.67).  120 rad/s lies inside [100, 150] (ω T = 0.24,
#: discrete closed-loop poles at z = 0.55, 0.78, 0.86).  Measured (docs/nmpc.md,
#: "Low-level gains"): the thesis's scheme with the recorded NMPC solve times keeps
#: d_PG ≥ 0 and f_L ≤ f_L,max from 100 to 200 rad/s, fails at 60 and 80 rad/s.
DEFAULT_FL_POLE = 120.0

#: Gains of the low-level PID loops of the landing (the 2LC's default, also the remote
#: low-level process's, ``experiments/hil_landing_llc_controller.py``): triple pole at
#: -:data:`DEFAULT_FL_POLE` = -120 rad/s (K_P = 43200 s⁻², K_D = 360 s⁻¹,
#: K_I = 1728000 s⁻³).
DEFAULT_FL_GAINS = PIDGains.triple_pole(DEFAULT_FL_POLE)

#: Named variant (a departure, not the thesis's design): the project's former gains,
#: triple pole at -60 rad/s (K_P = 10800 s⁻², K_D = 180 s⁻¹, K_I = 216000 s⁻³).  1/ω =
#: 17 ms is longer than the 10 ms NMPC period: with the NMPC started from the measured
#: state, 1 ms of NMPC delay already puts the propellers into the slope (docs/nmpc.md).
SLOW_FL_GAINS = PIDGains.triple_pole(60.0)


def _check_sampling(dt, cos_min, on_singular) -> None:
    """Sampling period *dt* > 0 [s], singularity threshold *cos_min* in (0, 1) and
    *on_singular* ``"raise"`` or ``"saturate"``."""
    validate.positive(dt, "sampling period dt", kind="a positive number of seconds", type_error=ConfigurationError)
    if not (isinstance(cos_min, (int, float)) and 0 < cos_min < 1):
        raise ValueError(f"cos_min must lie in (0, 1), got {cos_min!r}")
    validate.choice(on_singular, "on_singular", ("raise", "saturate"), kind="'raise' or 'saturate'")


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
        _check_sampling(dt, cos_min, on_singular)
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
