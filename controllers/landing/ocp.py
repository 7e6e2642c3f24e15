"""The landing optimal control problem of thesis §2.3 and its NMPC (§2.4).

The OCP is built from the symbolic tethered-UAV model of :mod:`netcosim.plants.tethered_uav`
(one source of truth for the equations):

* state (2.5) ``x = [φ, φ̇, ϑ, ϑ̇, f_R, τ_R]`` (rad, rad/s, rad, rad/s, N, N·m),
  input ``u = [ḟ_R, τ̇_R]`` (N/s, N·m/s), parameter ``p = [α]`` (slope, rad);
* constraints (2.6) with Table 2.1: ``0 <= f_R <= 15`` N and ``|τ_R| <= 1.2`` N·m as
  state bounds, ``0 <= f_L <= 10`` N (2.4) as a hard path constraint, the
  propeller–ground distances (2.7) ``d_PG1, d_PG2 >= 0`` as soft constraints with a
  quadratic slack penalty ``k_s`` (2.8); the same rows are imposed at the last node;
* cost (2.9)–(2.10): stage residual
  ``η = [ḟ_R, τ̇_R, h(φ)(ϑ-ϑ*), h(φ)φ̇, h(φ)ϑ̇, φ-φ*, ϑ-ϑ*]`` with the weights of
  Table 2.2 and the sigmoid (2.11) ``h(φ) = 1 / (1 + exp(γ (φ - φ_lim)))``,
  ``γ = 19``, ``φ_lim = -0.24`` rad; targets ``ϑ* = α``, ``φ* = -α``;
  terminal residual: the state terms of η (η³, η⁴, η⁵, η⁸, η⁹) with the same weights.

Discretization (§2.4.1): N = 30 intervals of T_s = 10 ms, one RK4 step each.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.plants.tethered_uav import TetheredUAVParams, casadi_model, hover_thrust
from netcosim.validate import numeric_fields

from ..nmpc import OCP, RTINMPC

__all__ = ["LandingConfig", "landing_ocp", "landing_nmpc", "sigmoid", "initial_state"]


@dataclass(frozen=True)
class LandingConfig:
    """Tuning of the landing NMPC (Table 2.2, §2.3.2, §2.4.1).

    Weights are the ``w_j`` of ``||η^j||²_{w_j} = w_j (η^j)²`` (non-negative; ``k_s`` positive).

    Fields: ``k_fR``, ``k_tauR`` weights of ḟ_R [(N/s)⁻²] and τ̇_R [(N·m/s)⁻²];
    ``k_theta`` of h(φ)(ϑ - ϑ*) [rad⁻²]; ``k_dphi``, ``k_dtheta`` of h(φ)φ̇ and h(φ)ϑ̇
    [(rad/s)⁻²]; ``k_s`` of the slack variables of (2.8) [m⁻²]; ``k_dphi_target``,
    ``k_dtheta_target`` of φ - φ* and ϑ - ϑ* [rad⁻²]; ``terminal_factor``: multiplier of
    the stage weights for the terminal residual; ``gamma`` [1/rad] and ``phi_lim`` [rad]:
    the sigmoid (2.11); ``input_range``: the fraction, in (0, 1], of the Table 2.1 thrust
    and torque ranges the NMPC plans with (centred); the horizon: ``N`` intervals of
    ``Ts`` seconds, ``rk4_steps`` RK4 steps per interval.
    """

    #: k_fR, k_τR: weights of ḟ_R [(N/s)⁻²] and τ̇_R [(N·m/s)⁻²].
    k_fR: float = 1e-4
    k_tauR: float = 1e-4
    #: k_ϑ: weight of h(φ)(ϑ - ϑ*) [rad⁻²].
    k_theta: float = 1.0
    #: k_φ̇, k_ϑ̇: weights of h(φ)φ̇ and h(φ)ϑ̇ [(rad/s)⁻²].
    k_dphi: float = 1.0
    k_dtheta: float = 1.0
    #: k_s: weight of the slack variables of (2.8) [m⁻²].
    k_s: float = 1e6
    #: k_Δφ, k_Δϑ: weights of φ - φ* and ϑ - ϑ* [rad⁻²].
    k_dphi_target: float = 2e2
    k_dtheta_target: float = 2e2
    #: Multiplier of the stage weights used for the terminal residual.
    terminal_factor: float = 1.0
    #: Sigmoid (2.11): steepness γ [1/rad] and half point φ_lim [rad].
    gamma: float = 19.0
    phi_lim: float = -0.24
    #: Fraction of the Table 2.1 thrust and torque ranges the NMPC may plan with,
    #: centred in the range (1 = the whole range).  A reference generator for a
    #: tracking controller leaves it some margin (e.g. 0.9: f_R in [0.75, 14.25] N,
    #: ``|τ_R| <= 1.08`` N·m); the actuator bounds themselves are enforced by saturation.
    input_range: float = 1.0
    #: Horizon: N intervals of Ts seconds, rk4_steps RK4 steps per interval.
    N: int = 30
    Ts: float = 0.01
    rk4_steps: int = 1

    def __post_init__(self):
        numeric_fields(self, non_negative=("k_fR", "k_tauR", "k_theta", "k_dphi", "k_dtheta",
                                                  "k_dphi_target", "k_dtheta_target", "terminal_factor"))
        if not 0 < self.input_range <= 1:
            raise ValueError(f"LandingConfig.input_range must lie in (0, 1], got {self.input_range!r}")
        validate.positive(self.k_s, "LandingConfig.k_s", kind="positive")

    @property
    def stage_weights(self) -> np.ndarray:
        """The stage weights as an array, in this order: k_fR, k_tauR, k_theta, k_dphi, k_dtheta,
        k_dphi_target, k_dtheta_target."""
        return np.array([self.k_fR, self.k_tauR, self.k_theta, self.k_dphi, self.k_dtheta,
                         self.k_dphi_target, self.k_dtheta_target])

    @property
    def terminal_weights(self) -> np.ndarray:
        """``terminal_factor`` times the weights k_theta, k_dphi, k_dtheta, k_dphi_target,
        k_dtheta_target (the terminal residual's)."""
        return self.terminal_factor * np.array([self.k_theta, self.k_dphi, self.k_dtheta,
                                                self.k_dphi_target, self.k_dtheta_target])


def sigmoid(phi, gamma: float = 19.0, phi_lim: float = -0.24):
    """h(φ) of (2.11): 1 / (1 + exp(γ (φ - φ_lim))) of *phi* (φ, rad), with the steepness *gamma*
    (γ, 1/rad) and half point *phi_lim* (φ_lim, rad); works on floats and CasADi symbols."""
    return 1.0 / (1.0 + ca.exp(gamma * (phi - phi_lim)))


def landing_ocp(params: TetheredUAVParams | None = None, config: LandingConfig | None = None) -> OCP:
    """The landing OCP of §2.3 for *params* (default parameters) and *config*."""
    params = TetheredUAVParams() if params is None else params
    cfg = LandingConfig() if config is None else config
    m = casadi_model(params)
    x = ca.SX.sym("x", 6)
    u = ca.SX.sym("u", 2)
    alpha = ca.SX.sym("alpha")
    xdot = m.f_smooth(x, u)
    phi, dphi, theta, dtheta = x[0], x[1], x[2], x[3]
    theta_star, phi_star = alpha, -alpha
    hs = sigmoid(phi, cfg.gamma, cfg.phi_lim)
    eta_state = ca.vertcat(hs * (theta - theta_star), hs * dphi, hs * dtheta, phi - phi_star, theta - theta_star)
    eta = ca.vertcat(u[0], u[1], eta_state)
    f_L = m.stress(x)
    d_pg = m.propeller_ground_distances(x, alpha)
    h = ca.vertcat(f_L, d_pg)
    lbh = [0.0, 0.0, 0.0]
    ubh = [params.f_L_max, np.inf, np.inf]
    inf = np.inf
    df = 0.5 * (1.0 - cfg.input_range) * params.f_R_max
    tau_max = cfg.input_range * params.tau_R_max
    return OCP(x=x, u=u, p=alpha, xdot=xdot, N=cfg.N, Ts=cfg.Ts, rk4_steps=cfg.rk4_steps,
               residual=eta, weights=cfg.stage_weights,
               terminal_residual=eta_state, terminal_weights=cfg.terminal_weights,
               lbx=[-inf, -inf, -inf, -inf, df, -tau_max],
               ubx=[inf, inf, inf, inf, params.f_R_max - df, tau_max],
               h=h, lbh=lbh, ubh=ubh, soft=[1, 2], soft_weights=[cfg.k_s, cfg.k_s],
               h_N=h, lbh_N=lbh, ubh_N=ubh, soft_N=[1, 2], soft_weights_N=[cfg.k_s, cfg.k_s],
               p_default=[params.alpha], state_names=m.state_names, input_names=m.input_names)


def initial_state(phi: float = 0.0, theta: float = 0.0, params: TetheredUAVParams | None = None) -> np.ndarray:
    """Hovering state at (*phi*, *theta*) = (φ, ϑ) [rad]: zero rates, hover thrust, zero torque,
    for the vehicle *params* (None: the default :class:`TetheredUAVParams`)."""
    params = TetheredUAVParams() if params is None else params
    return np.array([phi, 0.0, theta, 0.0, hover_thrust(phi, theta, params), 0.0])


def landing_nmpc(params: TetheredUAVParams | None = None, config: LandingConfig | None = None,
                 x0=None, **kw) -> RTINMPC:
    """An :class:`RTINMPC` of :func:`landing_ocp` for the vehicle *params* and tuning *config*
    (None: the defaults), initialized at *x0* (default: hover at 0, 0); *kw* go to
    :class:`RTINMPC`."""
    ocp = landing_ocp(params, config)
    x0 = initial_state(params=params) if x0 is None else x0
    return RTINMPC(ocp, x_guess=x0, **kw)
