"""Fly-crane family systems as netcosim plants, one per input mode.

* :class:`KinematicPlant` — velocity input ``ṗ = u`` for square systems (3.4) and its
  projection ``ṗ = Π_q u`` for non-square ones (4.5), i.e. ``q̇ = A_q^† u`` (4.6).
  State q, input u (n, m/s).  The project's one kinematic plant, defined for any
  kinematic system in :mod:`netcosim.plants.kinematic` and re-exported here.
* :class:`VelocityTrackingPlant` — the dynamics (4.10) driven by the force
  ``F = -α (ṗ - u) + F_g(q)`` of (4.11) with gravity compensation, input u.  State
  (q, q̇).  As α grows, q̇ → A_q^† u (§4.3).
* :class:`ForcePlant` — the dynamics (4.10) with raw robot forces F (n, N) as input.

Outputs: the configuration q (noise-free, names ``q.<coordinate>``), and with
``noise_std`` a Gaussian-noisy copy (``meas.<coordinate>``) drawn from the
``numpy.random.Generator`` given as *rng* (use ``sim.rng("name")`` for reproducible
streams); each evaluation of the outputs draws fresh noise.  Dynamic plants also output
the robot velocities ``ṗ = A_q q̇`` and the smallest cable tension ``t_min`` [N], and
fire the hybrid event ``cable_slack`` when ``t_min`` crosses zero downwards: from then
on the taut-cable model is invalid (the plant keeps integrating it; subscribe to the
event to stop or flag the run).

Use :meth:`initial_state` to build x0: it checks the start configuration (domain,
singularity) and raises naming the value.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError
from netcosim.plant import ContinuousSystem, HybridEvent

from ..kinematic import KinematicPlant
from .kinematics import MultiRobotSystem, SingularConfigurationError

__all__ = ["KinematicPlant", "VelocityTrackingPlant", "ForcePlant"]


class _FlyCranePlant(ContinuousSystem):
    def __init__(self, system: MultiRobotSystem, states, inputs, extra_outputs, *, noise_std=None, rng=None,
                 events=(), name=None):
        if not isinstance(system, MultiRobotSystem):
            raise TypeError(f"system must be a MultiRobotSystem, got {system!r}")
        self.system = system
        qn = [f"q.{c}" for c in system.coordinate_names]
        outs = qn + list(extra_outputs)
        self.noise_std = None
        if noise_std is not None:
            std = np.broadcast_to(np.asarray(noise_std, dtype=float), (system.m,)).copy()
            if not np.all(np.isfinite(std)) or np.any(std < 0):
                raise ValueError(f"noise_std must be finite and non-negative, got {noise_std!r}")
            if rng is None or not isinstance(rng, np.random.Generator):
                raise ValueError(f"noisy measurements need rng=numpy.random.Generator (e.g. sim.rng(name)), "
                                 f"got {rng!r}")
            self.noise_std, self.rng = std, rng
            outs += [f"meas.{c}" for c in system.coordinate_names]
        super().__init__(states=states, inputs=inputs, outputs=outs, events=events,
                         name=name or system.name)

    def _measure(self, q, extra):
        parts = [q, *extra]
        if self.noise_std is not None:
            parts.append(q + self.noise_std * self.rng.standard_normal(q.shape[0]))
        return np.concatenate(parts)


class _DynamicPlant(_FlyCranePlant):
    def __init__(self, system, inputs, *, noise_std=None, rng=None, name=None):
        self.model = system.dynamics
        states = tuple(system.coordinate_names) + tuple(f"d{c}" for c in system.coordinate_names)
        extra = [f"pdot.{c}" for c in system.position_names] + ["t_min"]
        ev = (HybridEvent("cable_slack", lambda t, x, u, p: -self.min_tension(x, u), +1),)
        super().__init__(system, states, inputs, extra, noise_std=noise_std, rng=rng, events=ev, name=name)

    def initial_state(self, q0, qd0=None) -> np.ndarray:
        """x0 = (q0, q̇0) after checking q0 (domain, singularity); q̇0 defaults to 0."""
        q0 = self.system.check_configuration(q0, what="q0")
        qd0 = np.zeros(self.system.m) if qd0 is None else np.asarray(qd0, dtype=float).reshape(-1)
        if qd0.shape != (self.system.m,) or not np.all(np.isfinite(qd0)):
            raise ValueError(f"qd0 must be {self.system.m} finite values, got {qd0!r}")
        return np.concatenate([q0, qd0])

    def _qdd_F(self, x, u):
        raise NotImplementedError

    def _checked(self, x, qdd):
        if not np.all(np.isfinite(qdd)):
            raise SingularConfigurationError(
                f"{self.system.name}: dynamics not defined at q = {np.round(x[: self.system.m], 12).tolist()} "
                "(singular A_q or Euler gimbal lock)")
        return qdd

    def f(self, t, x, u, params):
        qdd, _ = self._qdd_F(x, u)
        return np.concatenate([x[self.system.m:], qdd])

    def tensions(self, x, u) -> np.ndarray:
        """Cable tensions [N] at state x under input u."""
        m = self.system.m
        qdd, F = self._qdd_F(x, u)
        return self.model.tensions_eval(x[:m], x[m:], qdd, F)[0]

    def min_tension(self, x, u) -> float:
        return float(self.tensions(x, u).min())

    def h(self, t, x, u, params):
        m = self.system.m
        x = np.asarray(x, dtype=float)
        A = self.system.jacobian(x[:m])
        return self._measure(x[:m], (A @ x[m:], [self.min_tension(x, u)]))


class ForcePlant(_DynamicPlant):
    """(4.10) with the robot forces F (n, world frame, N) as input:
    ``M q̈ + C q̇ + g = A_qᵀ F``.  Gravity acts; F = 0 is free fall.

    ``system``: the :class:`~netcosim.plants.flycrane.kinematics.MultiRobotSystem` (with mass
    properties); ``noise_std``: the standard deviation of the measured copy of q (rad/m,
    a scalar or one per coordinate, >= 0; None: no measured outputs); ``rng``: the
    ``numpy.random.Generator`` that noise is drawn from (required with ``noise_std``,
    e.g. ``sim.rng("name")``); ``name``: the plant's name."""

    def __init__(self, system: MultiRobotSystem, *, noise_std=None, rng=None, name=None):
        super().__init__(system, tuple(f"F.{c}" for c in system.position_names), noise_std=noise_std,
                         rng=rng, name=name)

    def _qdd_F(self, x, u):
        m, n = self.system.m, self.system.n
        F = u[:n]
        qdd = self.model.forward_eval(x[:m], x[m:], F)[0]
        return self._checked(x, qdd), F


class VelocityTrackingPlant(_DynamicPlant):
    """(4.10) under ``F = -α (A_q q̇ - u) + F_g(q)`` (4.11), ``F_g = A_q (A_qᵀA_q)^{-1} g(q)``.

    ``alpha`` [N·s/m] > 0 is the velocity-tracking gain; ``u`` (n, m/s) the desired
    robot velocities.  ``gravity_compensation=False`` drops F_g.
    ``system``: the :class:`~netcosim.plants.flycrane.kinematics.MultiRobotSystem` (with mass
    properties); ``noise_std``: the standard deviation of the measured copy of q (rad/m,
    a scalar or one per coordinate, >= 0; None: no measured outputs); ``rng``: the
    ``numpy.random.Generator`` that noise is drawn from (required with ``noise_std``,
    e.g. ``sim.rng("name")``); ``name``: the plant's name."""

    def __init__(self, system: MultiRobotSystem, alpha: float, *, gravity_compensation: bool = True,
                 noise_std=None, rng=None, name=None):
        self.alpha = validate.positive(alpha, "velocity-tracking gain alpha", kind="a positive number (N·s/m)",
                                       type_error=ConfigurationError)
        self.gravity_compensation = bool(gravity_compensation)
        super().__init__(system, tuple(f"u.{c}" for c in system.position_names), noise_std=noise_std,
                         rng=rng, name=name)

    def _qdd_F(self, x, u):
        m, n = self.system.m, self.system.n
        q, qd = x[:m], x[m:]
        if self.gravity_compensation:
            qdd, F = self.model.velocity_tracking_eval(q, qd, u[:n], self.alpha)
        else:
            A = self.system.jacobian(q)
            F = -self.alpha * (A @ qd - u[:n])
            qdd = self.model.forward_eval(q, qd, F)[0]
        return self._checked(x, qdd), F

    def casadi_dynamics(self):
        """``(F, pack)`` for integrators that evaluate whole steps in CasADi
        (:class:`netcosim.controllers.planner.plant_dop853.CompiledDOP853`), or None without
        gravity compensation: ``F(x, p) -> (dx/dt, r)`` with x = (q, q̇),
        ``p = pack(u) = (u[:n], alpha)`` (m/s, N·s/m) and ``r`` a regularity margin,
        negative at or near a singular configuration (a QR pivot ratio of ``M`` or
        ``A_qᵀA_q`` below :data:`PIVOT_RTOL`), where the integrator must fall back to
        :meth:`f`, which raises naming q.  The dynamics of :meth:`f` as one SX expression
        (the model's ``M``, ``C q̇``, ``g`` and ``A_q``, the two linear solves by symbolic
        QR): about twice as fast compiled as ``velocity_tracking_fun`` (an MX graph with
        numeric solves), equal to it to rounding where regular.  One Function per
        dynamics object."""
        if not self.gravity_compensation:
            return None
        F = _FLOWS.get(id(self.model))
        if F is None or F[0] is not self.model:
            F = _FLOWS[id(self.model)] = (self.model, _velocity_tracking_flow(self.model))
        n, alpha = self.system.n, self.alpha
        return F[1], lambda u: np.append(np.asarray(u, dtype=float)[:n], alpha)


_FLOWS: dict = {}  # id(LagrangianModel) -> (model, F): the model is held, so the id stays its own


#: Pivot ratio ``min |R_ii| / max |R_ii|`` of the QR factors of ``M`` and ``A_qᵀA_q`` below
#: which :meth:`VelocityTrackingPlant.casadi_dynamics` calls the configuration singular (its
#: regularity output turns negative; the integrator then falls back to the checked path).
PIVOT_RTOL = 1e-10


def _velocity_tracking_flow(model) -> ca.Function:
    """``F(x, p) -> ((q̇, q̈), r)`` of (4.10) under (4.11), ``p = (u, alpha)``, in SX;
    the solves by QR, ``r`` = the smaller pivot ratio of the two minus :data:`PIVOT_RTOL`."""
    sys_ = model.system
    n = sys_.n
    q, qd = sys_.q_sym, model.qd_sym
    p = ca.SX.sym("p", n + 1)
    A, M, c, g = sys_.A_expr, model.M_expr, model.Cqd_expr, model.g_expr
    Qa, Ra = ca.qr(A.T @ A)
    Fg = A @ ca.solve(Ra, Qa.T @ g)
    Fv = -p[n] * (A @ qd - p[:n]) + Fg
    Qm, Rm = ca.qr(M)
    qdd = ca.solve(Rm, Qm.T @ (A.T @ Fv - c - g))
    da, dm = ca.fabs(ca.diag(Ra)), ca.fabs(ca.diag(Rm))
    r = ca.fmin(ca.mmin(da) / ca.mmax(da), ca.mmin(dm) / ca.mmax(dm)) - PIVOT_RTOL
    return ca.Function(f"{sys_.name}_vt_flow", [ca.vertcat(q, qd), p], [ca.vertcat(qd, qdd), r],
                       ["x", "p"], ["dx", "r"])
