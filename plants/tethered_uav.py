"""Tethered UAV in the vertical plane (thesis ch. 2, §2.2, §2.3, §2.6.1).

A vehicle of mass ``m_B`` and inertia ``J_B`` is tied to the world origin ``O_W`` by
a taut massless cable of length ``l``; it moves in the (x_W, z_W) plane, z_W up.

Conventions (radians, SI units throughout):

* ``phi`` (φ) is the elevation of the cable: CoM at ``p_B = l (cos φ, sin φ)`` in
  (x_W, z_W).
* ``theta`` (ϑ) is the attitude, a rotation about y_W: the body axes are
  ``x_B = (cos ϑ, -sin ϑ)`` and ``z_B = (sin ϑ, cos ϑ)``.  The total thrust ``f_R``
  acts along ``z_B`` (this is the direction that makes (2.3) and (2.4) hold; the
  thesis writes ``f_R = -f_R z_B`` with the opposite axis label).  A positive
  torque ``τ_R`` about y_B increases ϑ.
* Propeller 1 sits at ``p_B + d x_B`` and propeller 2 at ``p_B - d x_B``; with
  (2.1), ``τ_R = d (f_2 - f_1)`` is the moment of the two thrusts about y_B.
* The slope of angle ``alpha`` passes through ``O_W`` and descends towards +x_W; its
  upward unit normal is ``n = (sin α, cos α)``, so the CoM height above it is
  ``z = l sin(φ + α)`` (the ``a`` of (2.7)).

Every equation is written once, in the functions of the section "Equations", using
``casadi`` operators only.  Called with CasADi symbols (SX or MX) they return
expressions (that is how :func:`casadi_model` builds its ``Function`` objects and how
an optimal-control problem can reuse them); called with floats they return floats
(that is how the netcosim plants evaluate them, without CasADi call overhead).
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationTypeError
from netcosim.plant import ContinuousSystem, HybridEvent

from .tethered_uav_params import TetheredUAVParams

__all__ = [
    "TetheredUAVParams", "TetheredUAVModel", "TetheredUAV", "casadi_model", "wind",
    "wind_disturbance", "ddphi_ddtheta", "smooth_dynamics", "force_dynamics", "cable_stress",
    "propeller_ground_distances", "input_map", "propeller_forces", "lander_reaction",
    "hover_thrust",
]


# ---------------------------------------------------------------------------
# Equations (one source of truth: casadi operators, symbolic or float)
# ---------------------------------------------------------------------------

def _symbolic(*vals) -> bool:
    return any(isinstance(v, (ca.SX, ca.MX, ca.DM)) for v in vals)


def _stack(items):
    if _symbolic(*items):
        return ca.vertcat(*items)
    return np.array([float(v) for v in items])


def ddphi_ddtheta(phi, dphi, theta, f_R, tau_R, p: TetheredUAVParams, f_ext=None):
    """Accelerations (φ̈, ϑ̈) [rad/s²] of (2.2)/(2.3).

    ``f_ext = (F_x, F_z)`` [N] is an optional external force on the CoM in world axes
    (wind, lander reaction); its moment about the CoM is zero, so ϑ̈ is unaffected.
    *phi* (φ, rad), *dphi* (φ̇, rad/s), *theta* (ϑ, rad), *f_R* (thrust, N), *tau_R*
    (torque, N·m); *p*: the :class:`TetheredUAVParams`.
    """
    ddphi = p.a1 * ca.cos(phi) + p.a2 * ca.cos(phi + theta) * f_R
    if f_ext is not None:
        # tangential component: t = (-sin φ, cos φ)
        ddphi = ddphi + p.a2 * (-ca.sin(phi) * f_ext[0] + ca.cos(phi) * f_ext[1])
    return ddphi, p.a3 * tau_R


def smooth_dynamics(x, u, p: TetheredUAVParams, f_ext=None):
    """Right-hand side of (2.5).

    ``x = [φ, φ̇, ϑ, ϑ̇, f_R, τ_R]`` (rad, rad/s, rad, rad/s, N, N·m),
    ``u = [ḟ_R, τ̇_R]`` (N/s, N·m/s); *p*: the :class:`TetheredUAVParams`; *f_ext*: an external force
    ``(F_x, F_z)`` [N] on the CoM, or None.  Returns ẋ (CasADi column or numpy array).
    """
    ddphi, ddtheta = ddphi_ddtheta(x[0], x[1], x[2], x[4], x[5], p, f_ext)
    return _stack([x[1], ddphi, x[3], ddtheta, u[0], u[1]])


def force_dynamics(x, u, p: TetheredUAVParams, f_ext=None):
    """Right-hand side of (2.3): ``x = [φ, φ̇, ϑ, ϑ̇]``, ``u = [f_R, τ_R]`` (N, N·m); *p*: the :class:`TetheredUAVParams`;
    *f_ext*: an external force ``(F_x, F_z)`` [N] on the CoM, or None (:func:`ddphi_ddtheta`)."""
    ddphi, ddtheta = ddphi_ddtheta(x[0], x[1], x[2], u[0], u[1], p, f_ext)
    return _stack([x[1], ddphi, x[3], ddtheta])


def cable_stress(phi, dphi, theta, f_R, p: TetheredUAVParams, f_ext=None):
    """Cable stress f_L [N] of (2.4), positive when the cable pulls (taut).

    f_L = φ̇²/a_2 + (a_1/a_2) sin φ + sin(φ + ϑ) f_R, plus the radial component
    ``cos φ F_x + sin φ F_z`` of an optional external force on the CoM.  *phi* (φ, rad),
    *dphi* (φ̇, rad/s), *theta* (ϑ, rad), *f_R* (thrust, N); *p*: the :class:`TetheredUAVParams`; *f_ext*:
    ``(F_x, F_z)`` [N] in world axes, or None.
    """
    f_L = dphi ** 2 / p.a2 + (p.a1 / p.a2) * ca.sin(phi) + ca.sin(phi + theta) * f_R
    if f_ext is not None:
        f_L = f_L + ca.cos(phi) * f_ext[0] + ca.sin(phi) * f_ext[1]
    return f_L


def propeller_ground_distances(phi, theta, alpha, p: TetheredUAVParams):
    """(d_PG1, d_PG2) [m] of (2.7): ``a - b`` and ``a + b`` with a = l sin(φ + α),
    b = d sin(ϑ - α).  Distances of propellers 1 and 2 from the slope of angle α (*alpha*,
    rad), for *phi* (φ) and *theta* (ϑ) in rad; *p*: the :class:`TetheredUAVParams`."""
    a = p.l * ca.sin(phi + alpha)
    b = p.d * ca.sin(theta - alpha)
    return a - b, a + b


def input_map(f1, f2, p: TetheredUAVParams):
    """(f_R, τ_R) from the propeller thrusts (*f1*, *f2*) [N], eq. (2.1); *p*: the
    :class:`TetheredUAVParams` (its ``d``)."""
    return f1 + f2, p.d * (f2 - f1)


def propeller_forces(f_R, tau_R, p: TetheredUAVParams):
    """Inverse of (2.1): (f_1, f_2) = ((f_R - τ_R/d)/2, (f_R + τ_R/d)/2) [N] for the thrust *f_R*
    [N] and torque *tau_R* [N·m]; *p*: the :class:`TetheredUAVParams` (its ``d``)."""
    return 0.5 * (f_R - tau_R / p.d), 0.5 * (f_R + tau_R / p.d)


def lander_reaction(phi, dphi, p: TetheredUAVParams, alpha=None):
    """Lander reaction f_RF [N] of (2.17), along the slope normal n = (sin α, cos α).

    With z = l sin(φ+α) the CoM height above the slope and ż = l cos(φ+α) φ̇ its
    rate, f_RF = max(0, k_el (h - z) - ξ ż) when z ≤ h, else 0.  Two choices are
    made where (2.17) is loose: the damping multiplies the CoM velocity normal to the
    slope ż (the thesis writes ξ φ̇; near contact ż ≈ l φ̇), and the force is clipped
    at zero because a lander can push but not pull.  It acts at the CoM (the
    simplification of §2.3.1), so it exerts no moment on the attitude.  *phi* (φ, rad),
    *dphi* (φ̇, rad/s); *p*: the :class:`TetheredUAVParams`; *alpha*: the slope [rad], None: ``p.alpha``.
    """
    alpha = p.alpha if alpha is None else alpha
    z = p.l * ca.sin(phi + alpha)
    zdot = p.l * ca.cos(phi + alpha) * dphi
    push = ca.fmax(0.0, p.k_el * (p.lander_height - z) - p.xi * zdot)
    if _symbolic(phi, dphi, alpha):
        return ca.if_else(z <= p.lander_height, push, 0.0)
    return push if z <= p.lander_height else 0.0


def _external_force(phi, dphi, d, p: TetheredUAVParams, landers: bool):
    """World-frame external force on the CoM: disturbance d plus lander reaction."""
    fx, fz = d[0], d[1]
    if landers:
        f_rf = lander_reaction(phi, dphi, p)
        fx = fx + f_rf * math.sin(p.alpha)
        fz = fz + f_rf * math.cos(p.alpha)
    return fx, fz


def _check_params(p, what: str) -> TetheredUAVParams:
    if not isinstance(p, TetheredUAVParams):
        raise ConfigurationTypeError(f"{what} must be TetheredUAVParams, got {p!r}")
    return p


def hover_thrust(phi, theta, p: TetheredUAVParams) -> float:
    """Thrust [N] holding the vehicle still at (φ, ϑ): m_B g cos φ / cos(φ + ϑ) (φ̈ = 0).

    *phi*, *theta* must be finite angles [rad] and *p* a :class:`TetheredUAVParams`;
    anything else raises naming it (ConfigurationTypeError / ConfigurationError)."""
    phi = validate.finite(phi, "hover_thrust: phi", "rad")
    theta = validate.finite(theta, "hover_thrust: theta", "rad")
    _check_params(p, "hover_thrust: p")
    c = math.cos(phi + theta)
    if abs(c) < 1e-9:
        raise ValueError(f"no hover thrust at phi + theta = {phi + theta!r} rad (thrust normal to the "
                         f"circle's tangent)")
    return p.m_B * p.g * math.cos(phi) / c


# ---------------------------------------------------------------------------
# Wind disturbance (§2.6.1)
# ---------------------------------------------------------------------------

def wind(t: float, params: TetheredUAVParams | None = None) -> np.ndarray:
    """Wind force [N] on the CoM in world axes (F_x, F_z) at time *t* [s].

    A "1 - cosine" pulse ``(A/2)(1 - cos(2π t / T))`` on ``[0, T]`` with peak
    ``A = wind_pulse_amplitude`` and ``T = wind_pulse_duration``, plus
    ``wind_sine_amplitude · sin(2π f (t - t_s))`` for ``t ≥ t_s = wind_sine_start``,
    along x_W only (F_z = 0).  The profile is continuous in t.  A *t* that is not a
    finite number of seconds, or *params* that are not :class:`TetheredUAVParams`,
    raise naming it (ConfigurationTypeError / ConfigurationError).
    """
    t = validate.finite(t, "wind: t", "seconds")
    p = TetheredUAVParams() if params is None else _check_params(params, "wind: params")
    fx = 0.0
    if 0.0 <= t <= p.wind_pulse_duration and p.wind_pulse_duration > 0:
        fx += 0.5 * p.wind_pulse_amplitude * (1.0 - math.cos(2.0 * math.pi * t / p.wind_pulse_duration))
    if t >= p.wind_sine_start:
        fx += p.wind_sine_amplitude * math.sin(2.0 * math.pi * p.wind_sine_frequency * (t - p.wind_sine_start))
    return np.array([fx, 0.0])


def wind_disturbance(params: TetheredUAVParams | None = None):
    """``d(t)`` callable for :meth:`netcosim.sim.Simulation.plant` (``disturbance=``): the wind
    of *params* (a :class:`TetheredUAVParams`; None: the defaults), t in s."""
    p = TetheredUAVParams() if params is None else _check_params(params, "wind_disturbance: params")
    return lambda t: wind(t, p)


# ---------------------------------------------------------------------------
# CasADi model (Functions built once per parameter set)
# ---------------------------------------------------------------------------

class TetheredUAVModel:
    """Symbols, expressions and CasADi ``Function`` objects of one parameter set.

    Obtain it with :func:`casadi_model` (cached), for the parameters *params* (a
    :class:`TetheredUAVParams`).  Symbols (SX): ``x`` (6, smooth
    state), ``u`` (2, rates), ``x4`` (4, force-model state), ``u_force`` (2, [f_R,
    τ_R]), ``d`` (2, external force on the CoM), ``alpha_sym`` (slope).  Expressions:
    ``xdot_smooth`` (2.5), ``xdot_force`` (2.3), ``f_L`` (2.4, on ``x``), ``d_pg``
    (2.7, on ``x`` and ``alpha_sym``).  Functions:

    * ``f_smooth(x[6], u[2]) -> xdot[6]``  (2.5)
    * ``f_force(x[4], u[2]) -> xdot[4]``  (2.3)
    * ``stress(x[6]) -> f_L``  (2.4); ``stress_force(x[4], u[2]) -> f_L``
    * ``propeller_ground_distances(x[6], alpha) -> [d_PG1, d_PG2]``  (2.7)
    * ``input_map(f12[2]) -> [f_R, τ_R]``  (2.1); ``propeller_forces`` its inverse
    * ``f_sim_smooth(x[6], u[2], d[2])``, ``f_sim_force(x[4], u[2], d[2])``: the
      simulation model of §2.6.1 (landers + external force d at the CoM)
    * ``lander_reaction(x[6]) -> f_RF``  (2.17)

    For MX-based problems call the module-level equation functions
    (:func:`smooth_dynamics` etc.) on MX symbols, or call these Functions on MX.
    """

    def __init__(self, params: TetheredUAVParams):
        p = self.params = params
        self.x = x = ca.SX.sym("x", 6)
        self.u = u = ca.SX.sym("u", 2)
        self.x4 = x4 = ca.SX.sym("x4", 4)
        self.u_force = uf = ca.SX.sym("u_force", 2)
        self.d = d = ca.SX.sym("d", 2)
        self.alpha_sym = alpha = ca.SX.sym("alpha")
        f12 = ca.SX.sym("f12", 2)
        fr = ca.SX.sym("fr", 2)

        self.xdot_smooth = smooth_dynamics(x, u, p)
        self.xdot_force = force_dynamics(x4, uf, p)
        self.f_L = cable_stress(x[0], x[1], x[2], x[4], p)
        self.d_pg = ca.vertcat(*propeller_ground_distances(x[0], x[2], alpha, p))
        xs, us = ["phi", "dphi", "theta", "dtheta", "f_R", "tau_R"], ["df_R", "dtau_R"]

        self.f_smooth = ca.Function("f_smooth", [x, u], [self.xdot_smooth], ["x", "u"], ["xdot"])
        self.f_force = ca.Function("f_force", [x4, uf], [self.xdot_force], ["x", "u"], ["xdot"])
        self.stress = ca.Function("stress", [x], [self.f_L], ["x"], ["f_L"])
        self.stress_force = ca.Function("stress_force", [x4, uf],
                                        [cable_stress(x4[0], x4[1], x4[2], uf[0], p)], ["x", "u"], ["f_L"])
        self.propeller_ground_distances = ca.Function(
            "propeller_ground_distances", [x, alpha], [self.d_pg], ["x", "alpha"], ["d_pg"])
        self.input_map = ca.Function("input_map", [f12], [ca.vertcat(*input_map(f12[0], f12[1], p))],
                                     ["f12"], ["u_force"])
        self.propeller_forces = ca.Function("propeller_forces", [fr],
                                            [ca.vertcat(*propeller_forces(fr[0], fr[1], p))],
                                            ["u_force"], ["f12"])
        fe = _external_force(x[0], x[1], d, p, True)
        self.f_sim_smooth = ca.Function("f_sim_smooth", [x, u, d], [smooth_dynamics(x, u, p, fe)],
                                        ["x", "u", "d"], ["xdot"])
        fe4 = _external_force(x4[0], x4[1], d, p, True)
        self.f_sim_force = ca.Function("f_sim_force", [x4, uf, d], [force_dynamics(x4, uf, p, fe4)],
                                       ["x", "u", "d"], ["xdot"])
        self.lander_reaction = ca.Function("lander_reaction", [x], [lander_reaction(x[0], x[1], p)],
                                           ["x"], ["f_RF"])
        self.state_names = tuple(xs)
        self.input_names = tuple(us)


@functools.lru_cache(maxsize=32)
def casadi_model(params: TetheredUAVParams | None = None) -> TetheredUAVModel:
    """The :class:`TetheredUAVModel` of *params* (built once per parameter set)."""
    if params is None:
        params = TetheredUAVParams()
    if not isinstance(params, TetheredUAVParams):
        raise TypeError(f"params must be TetheredUAVParams, got {params!r}")
    return TetheredUAVModel(params)


# ---------------------------------------------------------------------------
# netcosim plant: the simulation model of §2.6.1
# ---------------------------------------------------------------------------

def _g_contact(t, x, u, p):
    """h - z: rises through zero when the CoM comes within the lander height."""
    return p.lander_height - p.l * math.sin(x[0] + p.alpha)


class TetheredUAV(ContinuousSystem):
    """The simulation model of §2.6.1 as a netcosim plant.

    ``inputs="rates"`` (default): the smooth-input model (2.5), states
    ``[φ, φ̇, ϑ, ϑ̇, f_R, τ_R]``, inputs ``[ḟ_R, τ̇_R]``.  ``inputs="forces"``: the
    model (2.3), states ``[φ, φ̇, ϑ, ϑ̇]``, inputs ``[f_R, τ_R]``.

    Disturbances ``[f_ext_x, f_ext_z]`` [N]: an external force on the CoM in world
    axes (pass ``disturbance=wind_disturbance(params)`` for the wind of §2.6.1).
    With ``landers=True`` the reaction (2.17) acts when the CoM is within
    ``lander_height`` of the slope; events ``touchdown``/``liftoff`` fire when
    that contact starts/ends, so integrators restart exactly at the kink.  Events
    ``wind_pulse_end`` and ``wind_sine_start`` restart them at the edges of the wind
    profile.  No saturation is applied to the inputs (that is the controller's job).

    Outputs: the states, then (force model) ``f_R, τ_R``, then ``f_L`` (2.4, including
    the radial part of external forces), ``d_PG1, d_PG2`` (2.7, slope α of the
    parameters) and the lander reaction ``f_RF``.
    """

    name = "tethered_uav"
    disturbance_names = ("f_ext_x", "f_ext_z")

    def __init__(self, params: TetheredUAVParams | None = None, *, inputs: str = "rates",
                 landers: bool = True, name: str | None = None):
        params = TetheredUAVParams() if params is None else params
        if not isinstance(params, TetheredUAVParams):
            raise TypeError(f"params must be TetheredUAVParams, got {params!r}")
        validate.choice(inputs, "inputs", ("rates", "forces"))
        self.mode, self.landers = inputs, validate.boolean(landers, "TetheredUAV: landers")
        q = ("phi", "dphi", "theta", "dtheta")
        if inputs == "rates":
            states, ins, outs = q + ("f_R", "tau_R"), ("df_R", "dtau_R"), q + ("f_R", "tau_R")
        else:
            states, ins, outs = q, ("f_R", "tau_R"), q + ("f_R", "tau_R")
        events = []
        if self.landers:
            events += [HybridEvent("touchdown", _g_contact, +1), HybridEvent("liftoff", _g_contact, -1)]
        events += [HybridEvent("wind_pulse_end", lambda t, x, u, p: t - p.wind_pulse_duration, +1),
                   HybridEvent("wind_sine_start", lambda t, x, u, p: t - p.wind_sine_start, +1)]
        super().__init__(states=states, inputs=ins, outputs=outs + ("f_L", "d_PG1", "d_PG2", "f_RF"),
                         disturbances=self.disturbance_names, events=events, params=params, name=name)

    def _split(self, x, u):
        if self.mode == "rates":
            return x[4], x[5], u[2:4]
        return u[0], u[1], u[2:4]

    def f(self, t, x, u, params):
        p = params
        f_R, tau_R, d = self._split(x, u)
        fe = _external_force(x[0], x[1], d, p, self.landers)
        if self.mode == "rates":
            return smooth_dynamics(x, u, p, fe)
        return force_dynamics(x, u, p, fe)

    def h(self, t, x, u, params):
        p = params
        f_R, tau_R, d = self._split(x, u)
        f_rf = lander_reaction(x[0], x[1], p) if self.landers else 0.0
        fe = _external_force(x[0], x[1], d, p, self.landers)
        f_L = cable_stress(x[0], x[1], x[2], f_R, p, fe)
        d1, d2 = propeller_ground_distances(x[0], x[2], p.alpha, p)
        head = list(x) if self.mode == "rates" else list(x) + [f_R, tau_R]
        return np.array(head + [f_L, d1, d2, f_rf], dtype=float)
