"""The plants a planner deployment (:func:`netcosim.controllers.planner.tasks.deploy`) can drive.

A *plant model* tells :func:`~netcosim.controllers.planner.tasks.deploy` how to build the
continuous plant under the planner tasks; it is the ``plant`` field of
:class:`~netcosim.controllers.planner.tasks.DeploymentConfig`.  Every model gives

* ``build(system, name)`` -- the :class:`~netcosim.plant.ContinuousSystem` whose
  first ``m`` outputs are the configuration ``q`` (rad, m) and whose ``n`` inputs are
  the desired robot velocities ``u`` (m/s), in the order of ``system``;
* ``initial_state(plant, q0)`` -- the state vector starting at configuration ``q0``;
* ``integrator()`` -- the default plant integrator.

Two models:

* :class:`KinematicModel` (the default): ``q_dot = A_q^+ u`` (4.6), state q, DOP853
  rtol 1e-12, atol 1e-13 (as :func:`netcosim.controllers.planner.kinematics.integrate_kinematics`);
* :class:`VelocityTrackingModel`: the Lagrangian model (4.10) of appendix B.1.2 under the
  velocity-tracking force ``F = -alpha (p_dot - u) + F_g(q)`` (4.11) that Fig. 4.10
  uses (:class:`netcosim.plants.flycrane.input_modes.VelocityTrackingPlant`), state
  ``(q, q_dot)`` starting at rest, rtol 1e-8, atol 1e-10: by default DOP853 with every
  step one compiled CasADi call (:class:`~netcosim.controllers.planner.plant_dop853.CompiledDOP853`),
  ``method="lsoda"`` the former LSODA (the integrator of
  ``netcosim.experiments.ch4_fig4_10.simulate_dynamic``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError
from netcosim.plant import SolveIVP
from netcosim.plants.flycrane.input_modes import VelocityTrackingPlant
from netcosim.plants.kinematic import KinematicPlant

from .plant_dop853 import CompiledDOP853

__all__ = ["KinematicVelocityPlant", "KinematicModel", "VelocityTrackingModel", "PLANT_MODELS",
           "VELOCITY_TRACKING_METHODS", "plant_model", "check_model", "plant_integrator"]


class KinematicVelocityPlant(KinematicPlant):
    """The one kinematic plant ``q_dot = A_q^+ u`` (:class:`netcosim.plants.kinematic.KinematicPlant`)
    as the deployments build it: states and outputs ``q0..q{m-1}`` (rad, m), inputs
    ``u0..u{n-1}`` (m/s), no singular-set event (the pseudo-inverse still raises by the
    rank rule wherever the integrator evaluates it)."""

    def __init__(self, system: Any, name: str | None = None):
        super().__init__(system, name=name, indexed=True, singular_event=False)


def plant_integrator() -> SolveIVP:
    """The plant integrator matching :func:`netcosim.controllers.planner.kinematics.integrate_kinematics`
    (DOP853, rtol 1e-12, atol 1e-13)."""
    return SolveIVP(method="DOP853", rtol=1e-12, atol=1e-13)


@dataclass(frozen=True)
class KinematicModel:
    """``q_dot = A_q^+ u`` (4.6): state and outputs q (rad, m), inputs u (m/s)."""

    def build(self, system: Any, name: str) -> KinematicVelocityPlant:
        """The plant for *system* (any kinematic system with ``n``, ``m``, ``jacobian``), named *name*."""
        return KinematicVelocityPlant(system, name)

    def initial_state(self, plant: Any, q0: np.ndarray) -> np.ndarray:
        """The state is q itself: ``q0`` (rad, m), whatever the *plant*."""
        return q0

    def integrator(self) -> SolveIVP:
        """:func:`plant_integrator` (DOP853, rtol 1e-12, atol 1e-13)."""
        return plant_integrator()


@dataclass(frozen=True)
class VelocityTrackingModel:
    """The dynamic model (4.10) driven through the velocity-tracking force (4.11).

    ``alpha`` (N s/m, > 0): the tracking gain of ``F = -alpha (A_q q_dot - u) + F_g(q)``
    (a robot of mass 1.03 kg tracks a velocity step with time constant about
    ``1.03 / alpha`` s); ``gravity_compensation``: add ``F_g`` (default True, as (4.11));
    ``cable_slack_event``: keep the plant's ``cable_slack`` hybrid event (off by default:
    it evaluates the cable tensions at every integrator step, which doubles the cost, and
    stops the integrator where a cable goes slack; the tension is an output, ``t_min``,
    either way); ``rtol``, ``atol``: the integrator's tolerances (the state is (q, q_dot)
    in rad, m, rad/s, m/s); ``method``: ``"dop853"`` (default) -- SciPy's DOP853 with each
    step (12 stages, error norm, dense output) one call of compiled CasADi code
    (:class:`~netcosim.controllers.planner.plant_dop853.CompiledDOP853`), no Python per
    stage -- or ``"lsoda"``, ``solve_ivp``'s LSODA, the integrator of this model before
    the compiled step (and of ``simulate_dynamic``), to reproduce the former numbers.
    DOP853 is the default because its trajectories stay within the tolerance of LSODA's:
    over the networked Fly-crane runs (30 s, both strategies, several seeds) the largest
    ``|q_dop853 - q_lsoda|`` is stated in docs/flycrane_network.md (1.5e-8); the integration
    is about 3 times faster, a sweep run about twice.  With ``cable_slack_event`` or without gravity compensation the
    integrator is LSODA whatever ``method`` says (the compiled step has no events and is
    built for the compensated dynamics).  ``compiled``: evaluate the closed-loop dynamics with the CasADi function
    compiled to C (:func:`netcosim.plants.casadi_tools.compile_functions`, cached on disk; the
    same expression graph, about 4x faster than CasADi's virtual machine; without a C
    compiler it falls back to the uncompiled function with one warning).  The system must be a
    :class:`netcosim.plants.flycrane.kinematics.MultiRobotSystem`.
    """

    alpha: float = 30.0
    gravity_compensation: bool = True
    cable_slack_event: bool = False
    rtol: float = 1e-8
    atol: float = 1e-10
    compiled: bool = True
    method: str = "dop853"

    def __post_init__(self):
        object.__setattr__(self, "alpha", validate.positive(
            self.alpha, "velocity-tracking gain alpha", kind="a positive number (N s/m)",
            type_error=ConfigurationError))
        for nm in ("rtol", "atol"):
            validate.positive(getattr(self, nm), f"VelocityTrackingModel {nm}", kind="a positive number",
                              type_error=ConfigurationError)
        validate.choice(self.method, "VelocityTrackingModel method", VELOCITY_TRACKING_METHODS)

    def build(self, system: Any, name: str):
        """A :class:`netcosim.plants.flycrane.input_modes.VelocityTrackingPlant` of *system* named *name*
        (outputs ``q.*`` first, inputs ``u.*`` in robot order)."""
        cls = _CompiledVelocityTracking if self.compiled and self.gravity_compensation else VelocityTrackingPlant
        plant = cls(system, self.alpha, gravity_compensation=self.gravity_compensation, name=name)
        if not self.cable_slack_event:
            plant.events = ()
        return plant

    def initial_state(self, plant: Any, q0: np.ndarray) -> np.ndarray:
        """``(q0, 0)``: the system starts at rest at ``q0`` (checked for singularity by the built
        *plant*)."""
        return plant.initial_state(q0)

    def integrator(self) -> Any:
        """:class:`~netcosim.controllers.planner.plant_dop853.CompiledDOP853` with ``rtol``,
        ``atol`` (one compiled call per step), or LSODA (one ``solve_ivp`` call between I/O
        instants) for ``method="lsoda"``, with ``cable_slack_event`` or without gravity
        compensation."""
        if self.method == "lsoda" or self.cable_slack_event or not self.gravity_compensation:
            return SolveIVP(method="LSODA", rtol=self.rtol, atol=self.atol)
        return CompiledDOP853(self.rtol, self.atol, compiled=self.compiled)


#: ``VelocityTrackingModel(method=...)``: the compiled DOP853 (default) or the former LSODA.
VELOCITY_TRACKING_METHODS = ("dop853", "lsoda")

_COMPILED: dict = {}


def _compiled_velocity_tracking(dynamics):
    """The velocity-tracking function of *dynamics* compiled to C (one per dynamics object)."""
    from netcosim.plants.casadi_tools import BufferedFunction, compile_functions
    hit = _COMPILED.get(id(dynamics))
    if hit is None or hit[0] is not dynamics:
        fun = dynamics.velocity_tracking_fun
        (cfun,) = compile_functions([fun], f"netcosim_{fun.name()}")
        hit = _COMPILED[id(dynamics)] = (dynamics, BufferedFunction(cfun))
    return hit[1]


class _CompiledVelocityTracking(VelocityTrackingPlant):
    """:class:`~netcosim.plants.flycrane.input_modes.VelocityTrackingPlant` with gravity
    compensation, its closed-loop dynamics evaluated by compiled code: the arguments are
    written into the Function's own buffers in place (no conversion per call) and the
    finiteness of q̈ checked by one sum (the plant's ``_checked`` names q when it fails)."""

    def __init__(self, system, alpha, **kw):
        super().__init__(system, alpha, **kw)
        self._vt = _compiled_velocity_tracking(system.dynamics)
        from netcosim.plants.casadi_tools import FunctionBuffers
        self._buf = FunctionBuffers(self._vt.fun)
        self._buf.args[3][0] = self.alpha

    def _eval(self, x, u):
        """Evaluate the compiled dynamics at (x, u) into the buffers; q̈ (the buffer, checked)."""
        m, n = self.system.m, self.system.n
        b = self._buf
        a = b.args
        a[0][:] = x[:m]
        a[1][:] = x[m:]
        a[2][:] = u[:n]
        b.eval()
        qdd = b.res[0]
        if not math.isfinite(qdd.sum()):
            self._checked(x, qdd)
        return qdd

    def _qdd_F(self, x, u):
        return self._eval(x, u).copy(), self._buf.res[1].copy()

    def f(self, t, x, u, params):
        m = self.system.m
        qdd = self._eval(x, u)
        dx = np.empty(2 * m)
        dx[:m] = x[m:]
        dx[m:] = qdd
        return dx


#: Plant model names accepted by :func:`plant_model`.
PLANT_MODELS = ("kinematic", "dynamic")


def plant_model(plant: Any, alpha: float = 30.0) -> Any:
    """A plant model from a name: ``"kinematic"`` -> :class:`KinematicModel`,
    ``"dynamic"`` -> :class:`VelocityTrackingModel` with ``alpha`` (N s/m); a model
    object is returned as it is."""
    if isinstance(plant, str):
        if plant == "kinematic":
            return KinematicModel()
        if plant == "dynamic":
            return VelocityTrackingModel(alpha)
        raise ConfigurationError(f"plant must be one of {PLANT_MODELS} or a plant model, got {plant!r}")
    check_model(plant)
    return plant


def check_model(model: Any) -> None:
    """Raise :class:`~netcosim.errors.ConfigurationTypeError` unless *model* has
    ``build``, ``initial_state`` and ``integrator``."""
    from netcosim.errors import ConfigurationTypeError
    missing = [a for a in ("build", "initial_state", "integrator") if not callable(getattr(model, a, None))]
    if missing:
        raise ConfigurationTypeError(f"plant must be a plant model (KinematicModel(), VelocityTrackingModel(alpha)) "
                                     f"with build/initial_state/integrator, got {model!r} (missing {missing})")
