"""The landing controllers of thesis ch. 2 as netcosim tasks.

Two controllers close the loop on the simulation model of §2.6.1
(:class:`netcosim.plants.tethered_uav.TetheredUAV`, landers (2.17), optional wind):

``"nmpc"``  NMPC alone: a 100 Hz task runs one real-time iteration of the landing
            NMPC on the measured state and writes its first input ``(ḟ_R, τ̇_R)``
            to the rate-input plant (2.5).
``"2lc"``   Two-layer controller (Fig. 2.1): the 100 Hz NMPC task feeds the state
            of its plan at the next node to a C² interpolator (Fig. 2.6); a 500 Hz
            task with higher priority evaluates the interpolated reference and runs
            the feedback linearization (2.14)–(2.16) with PID + feed-forward, writing
            ``(f_R, τ_R)`` to the force-input plant (2.3).  The NMPC's measured state
            is ``[φ, φ̇, ϑ, ϑ̇]`` with the thrust and torque currently applied.

Timing of the NMPC job (:class:`~netcosim.controllers.landing.LandingTiming`): each job reads
the plant at its start, runs the RTI *feedback* phase (QP solve), outputs, then runs
the *preparation* phase (shift + linearization) for the next sample.  The CPU time of
each phase comes from a :mod:`netcosim.cputime` model: zero (ideal, the thesis's
Simulink setting), a fixed budget, a recorded table of solve times replayed job by job
(reproducible: what the experiments use), or -- on explicit opt-in only -- the
wall-clock time the real computation just took on this host multiplied by
``cpu_factor`` (``nmpc_exec="measured"``; not reproducible, flagged in the results
and warned about).

:class:`LandingLoop` holds what the tasks of one run share (the NMPC, the
interpolator, the low-level controller, the logs); the task factories
(:func:`nmpc_task`, :func:`ground_nmpc_task`, :func:`sensor_task`, :func:`fl_task`)
return task bodies to register on a node; :mod:`netcosim.controllers.landing.topology` wires
them for each topology.

All angles in radians, forces in N, torques in N·m, times in seconds.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from netcosim.plants.tethered_uav import ddphi_ddtheta

from .feedback_linearization import FeedbackLinearization
from .interpolation import C2Interpolator
from .ocp import landing_nmpc
from .result import REFERENCE_COLUMNS
from .scenario import LandingScenario

__all__ = ["LandingLoop", "nmpc_task", "ground_nmpc_task", "sensor_task", "fl_task"]


class LandingLoop:
    """The controller state the tasks of one landing run share.

    Built from a validated :class:`~netcosim.controllers.landing.LandingScenario` (*scenario*),
    the plant's input and output ports (*in_port*: where ``(f_R, τ_R)`` is written,
    *out_port*: where ``[φ, φ̇, ϑ, ϑ̇]`` is read) and the initial state
    ``xs0 = [φ, φ̇, ϑ, ϑ̇, f_R, τ_R]``.
    ``steps``: one dict per NMPC job; ``ref_rows``: one tuple per low-level job
    (:data:`~netcosim.controllers.landing.result.REFERENCE_COLUMNS`); ``init_log``: ``(time,
    "reference" | "measured")`` per NMPC initialization of the 2LC.
    """

    def __init__(self, scenario: LandingScenario, in_port, out_port, xs0: np.ndarray):
        sc = self.scenario = scenario
        self.params = sc.params
        self.Ts = sc.config.Ts
        self.in_port, self.out_port = in_port, out_port
        self.nmpc = landing_nmpc(sc.params, sc.config, x0=xs0, **sc.nmpc_kw)
        self.cpu_model = sc.timing.nmpc_model()
        self.steps: list[dict] = []
        self.ref_rows: list[tuple] = []
        self.init_log: list[tuple[float, str]] = []
        self.interp = self.fl = None
        if sc.controller == "2lc":
            self.interp = C2Interpolator(2)
            self.interp.reset(0.0, [xs0[0], xs0[2]], [xs0[1], xs0[3]],
                              ddphi_ddtheta(xs0[0], xs0[1], xs0[2], xs0[4], xs0[5], sc.params))
            self.fl = FeedbackLinearization(sc.params, sc.fl_period, gains_phi=sc.fl_gains,
                                            gains_theta=sc.fl_gains)

    # -- the NMPC job -------------------------------------------------------

    def nmpc_job(self, ctx, y, t_s: float, send=None):
        """One NMPC job (a generator run by the task whose context is *ctx*) on the measurement
        *y* sampled at *t_s* [s]; *send* ships the 2LC's target to another node (default:
        apply it here)."""
        x = self._nmpc_state(y)
        with self.cpu_model.measure("feedback") as m:
            r = self.nmpc.feedback(x)
        c_fb = m.seconds
        yield ctx.execute(c_fb)
        if self.scenario.controller == "nmpc":
            ctx.write(self.in_port, r.u)
        else:
            target = self._target(r, t_s)
            if send is None:
                self.apply_target(ctx.now, target)
            else:
                send(target)
        with self.cpu_model.measure("prepare") as m:
            t_prep = self.nmpc.preparation()
        c_prep = m.seconds
        self.steps.append(dict(time=t_s, released=ctx.job.release_time, status=r.status, success=r.success,
                               fallback=r.fallback, qp_iter=r.qp_iter, step_norm=r.step_norm,
                               t_feedback=r.t_feedback, t_prepare=t_prep, c_feedback=c_fb, c_prepare=c_prep,
                               u0=float(r.u[0]), u1=float(r.u[1])))
        yield ctx.execute(c_prep)

    def _nmpc_state(self, y) -> np.ndarray:
        """The NMPC's initial state from the measurement *y* (4 or 6 values)."""
        x = np.asarray(y[:6], dtype=float) if len(y) >= 6 else np.concatenate([y[:4], [0.0, 0.0]])
        if self.scenario.controller == "2lc" and (self.scenario.actuator_state == "plan" or len(y) < 6):
            x[4:6] = self.nmpc.X[0, 4:6]  # the shifted plan's node 0 = previous plan at this instant
        return x

    def _target(self, r, t_s: float) -> tuple:
        """The 2LC target of plan *r* sampled at *t_s*: knot times [s], positions,
        velocities and accelerations of (φ, ϑ) at the plan's next ``ref_knots`` nodes."""
        k = self.scenario.ref_knots
        Xk = r.X[1:k + 1]
        acc = np.array([ddphi_ddtheta(x[0], x[1], x[2], x[4], x[5], self.params) for x in Xk], dtype=float)
        return (t_s + self.Ts * np.arange(1, k + 1), Xk[:, [0, 2]], Xk[:, [1, 3]], acc)

    def apply_target(self, now: float, target) -> None:
        """Update the interpolator at *now* [s] with *target*; knots already in the past
        are dropped, and a target that is all past aims one interval ahead."""
        t_knots, pos, vel, acc = target
        keep = t_knots > now + 1e-9
        if not keep.any():
            t_knots, pos, vel, acc = np.array([now + self.Ts]), pos[-1:], vel[-1:], acc[-1:]
            keep = np.array([True])
        self.interp.update(now, t_knots[keep], pos[keep], vel[keep], acc[keep])

    # -- the NMPC's initial state in the 2LC ---------------------------------

    def reference_state(self, t: float) -> np.ndarray:
        """``[φ, φ̇, ϑ, ϑ̇]`` of the low-level reference at time *t* [s]."""
        pos, vel, _ = self.interp.evaluate(t)
        return np.array([pos[0], vel[0], pos[1], vel[1]])

    def initial_measurement(self, y, t: float) -> np.ndarray:
        """The state the NMPC starts from at *t* [s] given the measured ``[φ, φ̇, ϑ, ϑ̇]`` *y*
        (see ``nmpc_init`` of :func:`~netcosim.controllers.landing.run_landing`)."""
        y = np.array(y, dtype=float)
        if self.scenario.nmpc_init == "measured":
            return y
        r = self.reference_state(t)
        e = np.abs(y[:4] - r)
        tol_angle, tol_rate = self.scenario.reset_tol
        if max(e[0], e[2]) > tol_angle or max(e[1], e[3]) > tol_rate:
            self.init_log.append((t, "measured"))
            return y
        self.init_log.append((t, "reference"))
        y[:4] = r
        return y

    @property
    def n_reset(self) -> int:
        """Number of NMPC initializations that fell back to the measurement."""
        return sum(1 for _, k in self.init_log if k == "measured")

    # -- the low-level job ---------------------------------------------------

    def low_level_reference(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What the low-level controller tracks at sampling instant *t* [s]: the
        interpolated positions ``(φ_d, ϑ_d)`` [rad] and velocities [rad/s] at *t*, and
        the accelerations [rad/s²] ``ff_lead`` seconds later (the feed-forward)."""
        pos, vel, acc = self.interp.evaluate(t)
        lead = self.scenario.feedforward_lead
        if lead:
            acc = self.interp.evaluate(t + lead)[2]
        return pos, vel, acc

    def low_level_command(self, t: float, y, reference=None) -> np.ndarray:
        """One low-level sample at *t* [s] on the measurement *y* (``[φ, φ̇, ϑ, ϑ̇, ...]``):
        feedback linearization of *reference* (default :meth:`low_level_reference` at
        *t*), logged in :attr:`ref_rows`; returns ``(f_R, τ_R)`` [N, N·m]."""
        pos, vel, acc = self.low_level_reference(t) if reference is None else reference
        u = self.fl(y[:4], pos, vel, acc)
        self.ref_rows.append((t, pos[0], pos[1], vel[0], vel[1], acc[0], acc[1], u[0], u[1]))
        return u

    def fl_job(self, ctx):
        """One 500 Hz job: reference at the sampling instant (acceleration ``ff_lead``
        seconds later), feedback linearization, command ``(f_R, τ_R)`` to the plant; a
        generator run by the task whose context is *ctx*."""
        y = ctx.read(self.out_port)
        u = self.low_level_command(ctx.now, y)
        yield ctx.execute(self.scenario.timing.fl_exec)
        ctx.write(self.in_port, u)

    def reference_table(self) -> pd.DataFrame:
        """The low-level reference and commands logged so far (:data:`REFERENCE_COLUMNS`)."""
        return pd.DataFrame(self.ref_rows, columns=REFERENCE_COLUMNS)


# ---------------------------------------------------------------------------
# Task factories: each returns a body ``body(ctx)`` for Node.periodic/aperiodic
# ---------------------------------------------------------------------------

def nmpc_task(loop: LandingLoop):
    """The NMPC next to the plant: reads it, (2LC) picks the initial state, runs a job.
    *loop*: the :class:`LandingLoop` it works on; returns the task body ``body(ctx)``."""
    two_layer = loop.scenario.controller == "2lc"

    def body(ctx):
        y = ctx.read(loop.out_port)
        if two_layer:
            y = loop.initial_measurement(y, ctx.now)
        yield from loop.nmpc_job(ctx, y, ctx.now)
    return body


def ground_nmpc_task(loop: LandingLoop, iface, peer: str = "onboard"):
    """The NMPC on a remote node, released by each measurement arriving at *iface*:
    runs on the newest one and sends the target to node *peer* (64 bits per value).
    *loop*: the :class:`LandingLoop` it works on; returns the task body ``body(ctx)``."""
    bits = 64 * (1 + 7 * loop.scenario.ref_knots)

    def body(ctx):
        msg = iface.mailbox.try_fetch()
        nxt = iface.mailbox.try_fetch()
        while nxt is not None:  # only the newest measurement matters
            msg, nxt = nxt, iface.mailbox.try_fetch()
        if msg is None:
            return
        t_s, y = msg.payload
        yield from loop.nmpc_job(ctx, np.asarray(y), t_s, send=lambda target: ctx.send(peer, target, bits))
    return body


def sensor_task(loop: LandingLoop, peer: str = "ground"):
    """Samples ``[φ, φ̇, ϑ, ϑ̇]`` (or the reference state, see ``nmpc_init``), charges
    ``fl_exec`` and sends ``(t_s, y)`` to node *peer* (64 bits per value).
    *loop*: the :class:`LandingLoop` it works on; returns the task body ``body(ctx)``."""
    def body(ctx):
        y = ctx.read(loop.out_port)
        t_s = ctx.now
        y = loop.initial_measurement(y, t_s)[:4]
        yield ctx.execute(loop.scenario.timing.fl_exec)
        ctx.send(peer, (t_s, [float(v) for v in y[:4]]), 64 * 5)
    return body


def fl_task(loop: LandingLoop):
    """The 500 Hz low-level task of the 2LC (:meth:`LandingLoop.fl_job`).
    *loop*: the :class:`LandingLoop` it works on; returns the task body ``body(ctx)``."""
    def body(ctx):
        yield from loop.fl_job(ctx)
    return body
