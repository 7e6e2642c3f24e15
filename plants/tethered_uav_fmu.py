"""The tethered UAV (:class:`~netcosim.plants.tethered_uav.TetheredUAV`) as a model-exchange FMU.

:func:`uav_fmu_functions` writes the plant's ``f``, ``h`` and event guards as CasADi
functions of ``(t, x, u)`` from the same equations (the module's casadi operators, called on
SX symbols); :func:`build_uav_fmu` hands them to :func:`netcosim.fmi.casadi_fmu.build_casadi_fmu`.
With ``wind=True`` the wind of §2.6.1 (:func:`~netcosim.plants.tethered_uav.wind`) is a
function of ``t`` inside the FMU (the Python plant takes it as its disturbance).

Names and units are the Python plant's: states, inputs, outputs; in the force model the
outputs ``f_R, tau_R`` repeat the inputs and are named ``f_R_out, tau_R_out`` (an FMI output
cannot be an input).  Event indicators, in the Python plant's order: the contact guard
``h - l sin(φ + α)`` (touchdown rising, liftoff falling: one indicator), ``t - T_pulse``,
``t - t_sine``.
"""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca

from .tethered_uav import (
    TetheredUAV,
    TetheredUAVParams,
    cable_stress,
    force_dynamics,
    lander_reaction,
    propeller_ground_distances,
    smooth_dynamics,
)

__all__ = ["uav_fmu_functions", "build_uav_fmu", "UNITS"]

#: SI units of the plant's signals
UNITS = {"phi": "rad", "dphi": "rad/s", "theta": "rad", "dtheta": "rad/s", "f_R": "N", "tau_R": "N.m",
         "df_R": "N/s", "dtau_R": "N.m/s", "f_R_out": "N", "tau_R_out": "N.m", "f_L": "N", "d_PG1": "m",
         "d_PG2": "m", "f_RF": "N"}


def _wind_sym(t, p: TetheredUAVParams):
    """The wind force F_x [N] of :func:`~netcosim.plants.tethered_uav.wind` as an SX expression of t."""
    fx = 0.0
    if p.wind_pulse_duration > 0:
        pulse = 0.5 * p.wind_pulse_amplitude * (1.0 - ca.cos(2.0 * math.pi * t / p.wind_pulse_duration))
        fx = ca.if_else(ca.logic_and(t >= 0.0, t <= p.wind_pulse_duration), pulse, 0.0)
    sine = p.wind_sine_amplitude * ca.sin(2.0 * math.pi * p.wind_sine_frequency * (t - p.wind_sine_start))
    return fx + ca.if_else(t >= p.wind_sine_start, sine, 0.0)


def uav_fmu_functions(params: TetheredUAVParams | None = None, *, inputs: str = "rates", landers: bool = True,
                      wind: bool = False) -> dict:
    """``dict(f=, h=, g=, states=, inputs=, outputs=, units=)`` for :func:`build_casadi_fmu`:
    the tethered UAV of *params* with the input mode, landers and wind of the Python plant."""
    plant = TetheredUAV(params, inputs=inputs, landers=landers)
    p = plant.params
    nx, nu = len(plant.state_names), len(plant.input_names)
    t, x, u = ca.SX.sym("t"), ca.SX.sym("x", nx), ca.SX.sym("u", nu)
    fx = _wind_sym(t, p) if wind else 0.0
    fz = 0.0
    if landers:
        f_rf = lander_reaction(x[0], x[1], p)
        fx, fz = fx + f_rf * math.sin(p.alpha), fz + f_rf * math.cos(p.alpha)
    else:
        f_rf = 0.0
    fe = (fx, fz)
    if inputs == "rates":
        xdot, f_R, tau_R, head = smooth_dynamics(x, u, p, fe), x[4], x[5], [x[i] for i in range(6)]
    else:
        xdot, f_R, tau_R = force_dynamics(x, u, p, fe), u[0], u[1]
        head = [x[i] for i in range(4)] + [f_R, tau_R]
    f_L = cable_stress(x[0], x[1], x[2], f_R, p, fe)
    d1, d2 = propeller_ground_distances(x[0], x[2], p.alpha, p)
    y = ca.vertcat(*head, f_L, d1, d2, f_rf)
    guards = []
    if landers:
        guards.append(p.lander_height - p.l * ca.sin(x[0] + p.alpha))
    guards += [t - p.wind_pulse_duration, t - p.wind_sine_start]
    outputs = [n if n in plant.state_names else f"{n}_out" if n in plant.input_names else n
               for n in plant.output_names]
    return dict(f=ca.Function("f", [t, x, u], [xdot]), h=ca.Function("h", [t, x, u], [y]),
                g=ca.Function("g", [t, x, u], [ca.vertcat(*guards)]), states=list(plant.state_names),
                inputs=list(plant.input_names), outputs=outputs, units=UNITS)


def build_uav_fmu(directory, params: TetheredUAVParams | None = None, *, inputs: str = "rates",
                  landers: bool = True, wind: bool = False, fmi: int = 2, name: str | None = None) -> Path:
    """Build the tethered UAV as a model-exchange FMU (FMI *fmi*) in *directory*; returns its path.

    *params*: the :class:`~netcosim.plants.tethered_uav.TetheredUAVParams` (None: the defaults);
    *inputs*: ``"rates"`` (the smooth-input model (2.5)) or ``"forces"`` (the model (2.3)),
    as for :class:`~netcosim.plants.tethered_uav.TetheredUAV`; *landers*: include the lander
    reaction (2.17); *wind*: include the wind of §2.6.1 as a function of time; *name*: the
    FMU's name, as for ``build_casadi_fmu`` (default
    ``tethered_uav_<inputs><fmi>``)."""
    from netcosim.fmi.casadi_fmu import build_casadi_fmu
    spec = uav_fmu_functions(params, inputs=inputs, landers=landers, wind=wind)
    return build_casadi_fmu(name or f"tethered_uav_{inputs}{fmi}", directory, fmi=fmi, **spec)
