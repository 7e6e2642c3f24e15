"""The landing controllers of thesis ch. 2 as netcosim tasks.

Two controllers close the loop on the simulation model of §2.6.1
(:class:`plants.tethered_uav.TetheredUAV`, landers (2.17), optional wind):

``"nmpc"``  NMPC alone: a 100 Hz task runs one real-time iteration of the landing
            NMPC on the measured state and writes its first input ``(ḟ_R, τ̇_R)``
            to the rate-input plant (2.5).
``"2lc"``   Two-layer controller (Fig. 2.1): the 100 Hz NMPC task feeds the state
            of its plan at the next node to a C² interpolator (Fig. 2.6); a 500 Hz
            task with higher priority evaluates the interpolated reference and runs
            the feedback linearization (2.14)–(2.16) with PID + feed-forward, writing
            ``(f_R, τ_R)`` to the force-input plant (2.3).  The NMPC's measured state
            is ``[φ, φ̇, ϑ, ϑ̇]`` with the thrust and torque currently applied.

Timing of the NMPC job (:class:`LandingTiming`): each job reads the plant at its
start, runs the RTI *feedback* phase (QP solve), outputs, then runs the
*preparation* phase (shift + linearization) for the next sample.  The CPU time of
each phase comes from a :mod:`netcosim.cputime` model: zero (ideal, the thesis's
Simulink setting), a fixed budget, a recorded table of solve times replayed job by job
(reproducible: what the experiments use), or -- on explicit opt-in only -- the
wall-clock time the real computation just took on this host multiplied by
``cpu_factor`` (``nmpc_exec="measured"``; not reproducible, flagged in the results
and warned about).  Both tasks run on one node (fixed priority, FL above NMPC).

All angles in radians, forces in N, torques in N·m, times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from netcosim import RK4, Simulation
from netcosim.cputime import CPUTimeModel, FixedCPUTime, WallClockCPUTime
from plants.tethered_uav import TetheredUAV, TetheredUAVParams, ddphi_ddtheta, wind_disturbance

from .feedback_linearization import FeedbackLinearization, PIDGains
from .interpolation import C2Interpolator
from .ocp import LandingConfig, initial_state, landing_nmpc

__all__ = ["LandingTiming", "LandingRun", "run_landing", "landing_metrics", "SIM_PARAMS", "DEFAULT_FL_GAINS"]

#: Simulation-model parameters of the ch. 2 experiments: the project defaults (1 cm
#: landers, which stop the CoM within 1° of φ* = -α as in Fig. 2.8).
SIM_PARAMS = TetheredUAVParams()


#: Gains of the low-level PID loops: triple pole at -60 rad/s (K_P = 10800 s⁻²,
#: K_D = 180 s⁻¹, K_I = 216000 s⁻³), ~10 times slower than the 500 Hz sampling
#: (ω T = 0.12) and fast enough to keep the tracking error below 0.01° during the
#: landing (the "aggressive PID action" of §2.6.2).
DEFAULT_FL_GAINS = PIDGains.triple_pole(60.0)


@dataclass(frozen=True)
class LandingTiming:
    """CPU times of the tasks (seconds at node speed 1).

    ``nmpc_exec`` says what one NMPC job costs:

    * ``0.0`` (ideal) or a number: a fixed budget for the whole job, split between the
      feedback and preparation phases in proportion ``feedback_share``;
    * a :class:`netcosim.cputime.CPUTimeModel` with phases ``"feedback"`` and
      ``"prepare"``, e.g. :class:`~netcosim.cputime.RecordedCPUTime` replaying solve
      times recorded once (reproducible); each run starts from a fresh copy of it;
    * ``"measured"``: the wall-clock time each phase took on this host ×
      ``cpu_factor`` (:class:`~netcosim.cputime.WallClockCPUTime`).  Opt-in only: the
      results then depend on the host's speed and load; each run warns
      (:class:`~netcosim.cputime.NonReproducibleWarning`) and reports
      ``reproducible=False``.  ``clock`` replaces :func:`time.perf_counter` for it
      (tests inject a fake clock).

    ``fl_exec``: CPU time of one low-level job.  ``context_switch``: kernel
    context-switch time.
    """

    nmpc_exec: Any = 0.0
    cpu_factor: float = 1.0
    feedback_share: float = 0.8
    fl_exec: float = 0.0
    context_switch: float = 0.0
    clock: Any = None

    def __post_init__(self):
        e = self.nmpc_exec
        if isinstance(e, str):
            if e != "measured":
                raise ValueError(f"nmpc_exec must be a number of seconds or 'measured', got {e!r} "
                                 f"(or a netcosim.cputime.CPUTimeModel)")
        elif isinstance(e, CPUTimeModel):
            pass
        elif isinstance(e, bool) or not isinstance(e, (int, float)) or not math.isfinite(e) or e < 0:
            raise ValueError(f"nmpc_exec must be a non-negative number of seconds, a CPUTimeModel or 'measured', "
                             f"got {e!r}")
        for name in ("cpu_factor",):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not (0.0 <= self.feedback_share <= 1.0):
            raise ValueError(f"feedback_share must lie in [0, 1], got {self.feedback_share!r}")
        for name in ("fl_exec", "context_switch"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"{name} must be a non-negative number of seconds, got {v!r}")
        if self.clock is not None and not callable(self.clock):
            raise ValueError(f"clock must be a callable returning seconds, got {self.clock!r}")

    def nmpc_model(self) -> CPUTimeModel:
        """A fresh CPU-time model for one run (phases ``"feedback"`` and ``"prepare"``)."""
        e = self.nmpc_exec
        if isinstance(e, CPUTimeModel):
            return e.fresh()
        if e == "measured":
            kw = {} if self.clock is None else {"clock": self.clock}
            return WallClockCPUTime(self.cpu_factor, **kw)
        return FixedCPUTime({"feedback": float(e) * self.feedback_share,
                             "prepare": float(e) * (1.0 - self.feedback_share)})


@dataclass
class LandingRun:
    """Result of :func:`run_landing`.

    ``signals``: wide DataFrame sampled every ``log_interval`` s, columns ``time,
    phi, dphi, theta, dtheta, f_R, tau_R, f_L, d_PG1, d_PG2, f_RF, wind`` (plant
    outputs, SI units, radians); ``steps``: one row per NMPC job (``time`` of the
    sample, ``status``, ``success``, ``fallback``, ``qp_iter``, ``t_feedback``,
    ``t_prepare`` wall-clock seconds, ``c_feedback``, ``c_prepare`` simulated CPU
    seconds); ``reference``: the 500 Hz reference of the low-level task (2LC only);
    ``jobs``/``schedule``: kernel traces; ``sim``: the simulation; ``cpu_times``: every
    CPU time charged to the NMPC (:meth:`netcosim.cputime.CPUTimeModel.record`: replay
    it with :class:`~netcosim.cputime.RecordedCPUTime` to reproduce the run);
    ``reproducible``: False when the CPU times were measured on the wall clock.
    The ``t_feedback``/``t_prepare`` columns of ``steps`` are the solver's own
    wall-clock diagnostics; only ``c_feedback``/``c_prepare`` enter the simulation.
    """

    controller: str
    wind: bool
    signals: pd.DataFrame
    steps: pd.DataFrame
    reference: pd.DataFrame
    jobs: pd.DataFrame
    schedule: pd.DataFrame
    sim: Simulation
    nmpc: Any
    fl: Any = None
    meta: dict = field(default_factory=dict)
    cpu_times: pd.DataFrame | None = None
    reproducible: bool = True


def _plant_signals(sim: Simulation, plant_name: str, wind_on: bool, params) -> pd.DataFrame:
    df = sim.trace.signals()
    df = df[df["source"] == plant_name]
    df = df[df["signal"].astype(str).str.startswith("y.")]
    wide = df.pivot_table(index="time", columns="signal", values="value", aggfunc="last", observed=True)
    wide.columns = [str(c)[2:] for c in wide.columns]
    wide = wide.reset_index()
    wd = wind_disturbance(params)
    wide["wind"] = [float(wd(t)[0]) if wind_on else 0.0 for t in wide["time"]]
    return wide


def run_landing(controller: str = "2lc", *, wind: bool = False, duration: float = 1.5,
                params: TetheredUAVParams | None = None, config: LandingConfig | None = None,
                timing: LandingTiming | None = None, fl_gains: PIDGains | None = None,
                x0=None, nmpc_period: float = 0.01, fl_period: float = 0.002,
                integrator_dt: float = 1e-4, log_interval: float = 1e-3, seed: int = 0,
                nmpc_kw: dict | None = None, actuator_state: str = "plan",
                ff_lead: float | None = None, topology: str = "single", network=None,
                ref_knots: int = 3, nmpc_init: str = "reference",
                reset_tol: tuple[float, float] = (math.radians(2.0), math.radians(20.0))) -> LandingRun:
    """Simulate the landing of §2.6.2 with *controller* ``"nmpc"`` or ``"2lc"``.

    ``params``: simulation-model parameters (default :data:`SIM_PARAMS`); the NMPC and
    the low-level controller use the same physical parameters (the model mismatch is
    the landers and the wind, which the controllers do not model).  ``x0``: initial
    ``[φ, φ̇, ϑ, ϑ̇]`` (default hover at φ = ϑ = 0).  ``actuator_state`` (2LC only): the
    ``(f_R, τ_R)`` entries of the NMPC's initial state are the values its previous plan
    predicted for now (``"plan"``, default: they are reference quantities of the
    trajectory generator) or the thrust and torque the low-level controller applies
    (``"measured"``).  ``fl_gains``: PID gains of both low-level loops (default
    :data:`DEFAULT_FL_GAINS`).  ``ff_lead``: the low-level job evaluates the
    acceleration feed-forward ``ff_lead`` seconds after its sampling instant (default
    half the low-level period: the input is held over the period, so the mid-period
    acceleration is the one it should produce on average).  ``ref_knots``: number of
    plan nodes (``x_1 .. x_K``) each NMPC solution hands to the interpolator, so that a
    late solution finds the reference still on the previous plan.

    ``nmpc_init`` (2LC only): the angles and rates of the NMPC's initial state are the
    measured ones (``"measured"``, the thesis's scheme) or those of the low-level
    reference at the sampling instant (``"reference"``), falling back to the measured
    ones whenever the tracking error exceeds ``reset_tol`` = (angle [rad], rate
    [rad/s]).  Starting each plan where the reference is makes the new plan continue
    the old one, so a late plan (computation or network delay) needs no catch-up by
    the low-level loop; the measured variant degrades quickly with delay (see
    ``docs/nmpc.md``).

    ``topology="two_nodes"`` (2LC only): the low-level task runs on node ``onboard``
    with the plant I/O; a 100 Hz sensor task there (priority 2) sends the measured
    ``[φ, φ̇, ϑ, ϑ̇]`` and its sampling time to node ``ground``, whose NMPC task is
    released by each arrival and sends back the reference target; the target updates
    the interpolator when it is delivered on board.  ``network``: a callable
    ``network(sim) -> Network`` (default: :class:`~netcosim.network.IdealLink` at
    1 Mbit/s, no propagation delay); MAC priorities (CAN identifiers): the references
    from ``ground`` 1, the measurements from ``onboard`` 2.  Messages are 64 bits per
    value.
    """
    if isinstance(ref_knots, bool) or not isinstance(ref_knots, int) or not 1 <= ref_knots <= (
            config.N if config is not None else LandingConfig().N):
        raise ValueError(f"ref_knots must be an integer between 1 and N, got {ref_knots!r}")
    if nmpc_init not in ("measured", "reference"):
        raise ValueError(f"nmpc_init must be 'measured' or 'reference', got {nmpc_init!r}")
    if topology not in ("single", "two_nodes"):
        raise ValueError(f"topology must be 'single' or 'two_nodes', got {topology!r}")
    if topology == "two_nodes" and controller != "2lc":
        raise ValueError(f"the two-node variant needs the two-layer controller, got controller={controller!r}")
    if ff_lead is None:
        ff_lead = 0.5 * fl_period
    if not (isinstance(ff_lead, (int, float)) and math.isfinite(ff_lead) and 0 <= ff_lead <= nmpc_period):
        raise ValueError(f"ff_lead must be a number of seconds in [0, nmpc_period], got {ff_lead!r}")
    if actuator_state not in ("plan", "measured"):
        raise ValueError(f"actuator_state must be 'plan' or 'measured', got {actuator_state!r}")
    if controller not in ("nmpc", "2lc"):
        raise ValueError(f"controller must be 'nmpc' or '2lc', got {controller!r}")
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive number of seconds, got {duration!r}")
    params = SIM_PARAMS if params is None else params
    cfg = LandingConfig() if config is None else config
    timing = LandingTiming() if timing is None else timing
    if abs(nmpc_period - cfg.Ts) > 1e-12:
        raise ValueError(f"nmpc_period={nmpc_period!r} s must equal the shooting interval Ts={cfg.Ts!r} s")
    q0 = np.zeros(4) if x0 is None else np.asarray(x0, dtype=float).reshape(4)
    xs0 = initial_state(q0[0], q0[2], params)
    xs0[1], xs0[3] = q0[1], q0[3]

    sim = Simulation(seed=seed)
    mode = "rates" if controller == "nmpc" else "forces"
    system = TetheredUAV(params, inputs=mode, landers=True)
    plant_x0 = xs0 if mode == "rates" else xs0[:4]
    uav = sim.plant(system, plant_x0, name="uav", integrator=RK4(dt=integrator_dt),
                    disturbance=wind_disturbance(params) if wind else None, log_interval=log_interval)
    if mode == "forces":
        uav.inputs.write(xs0[4:6])  # hover thrust, zero torque until the first FL job
    cpu = sim.node("onboard", scheduler="fixed_priority", context_switch=timing.context_switch)
    nmpc = landing_nmpc(params, cfg, x0=xs0, **(nmpc_kw or {}))
    cpu_model = timing.nmpc_model()
    steps: list[dict] = []
    ref_rows: list[tuple] = []
    Ts = cfg.Ts

    interp = fl = None
    if controller == "2lc":
        interp = C2Interpolator(2)
        interp.reset(0.0, [xs0[0], xs0[2]], [xs0[1], xs0[3]],
                     ddphi_ddtheta(xs0[0], xs0[1], xs0[2], xs0[4], xs0[5], params))
        gains = fl_gains or DEFAULT_FL_GAINS
        fl = FeedbackLinearization(params, fl_period, gains_phi=gains, gains_theta=gains)

    out_port = uav.outputs
    in_port = uav.inputs

    def nmpc_body(ctx, y, t_s, send=None):
        """One NMPC job on the measurement *y* sampled at *t_s*; *send* ships the target."""
        x = np.asarray(y[:6], dtype=float) if len(y) >= 6 else np.concatenate([y[:4], [0.0, 0.0]])
        if controller == "2lc" and (actuator_state == "plan" or len(y) < 6):
            x[4:6] = nmpc.X[0, 4:6]  # the shifted plan's node 0 = previous plan at this instant
        with cpu_model.measure("feedback") as m:
            r = nmpc.feedback(x)
        c_fb = m.seconds
        yield ctx.execute(c_fb)
        if controller == "nmpc":
            ctx.write(in_port, r.u)
        else:
            Xk = r.X[1:ref_knots + 1]
            acc = np.array([ddphi_ddtheta(x[0], x[1], x[2], x[4], x[5], params) for x in Xk], dtype=float)
            target = (t_s + Ts * np.arange(1, ref_knots + 1), Xk[:, [0, 2]], Xk[:, [1, 3]], acc)
            if send is None:
                apply_target(ctx.now, target)
            else:
                send(target)
        with cpu_model.measure("prepare") as m:
            t_prep = nmpc.preparation()
        c_prep = m.seconds
        steps.append(dict(time=t_s, released=ctx.job.release_time, status=r.status, success=r.success,
                          fallback=r.fallback, qp_iter=r.qp_iter, step_norm=r.step_norm,
                          t_feedback=r.t_feedback, t_prepare=t_prep, c_feedback=c_fb, c_prepare=c_prep,
                          u0=float(r.u[0]), u1=float(r.u[1])))
        yield ctx.execute(c_prep)

    def reference_state(t):
        """[φ, φ̇, ϑ, ϑ̇] of the low-level reference at time t."""
        pos, vel, _ = interp.evaluate(t)
        return np.array([pos[0], vel[0], pos[1], vel[1]])

    init_log: list[tuple[float, str]] = []

    def initial_measurement(y, t):
        """The state the NMPC starts from (see ``nmpc_init``)."""
        y = np.array(y, dtype=float)
        if nmpc_init == "measured":
            return y
        r = reference_state(t)
        e = np.abs(y[:4] - r)
        if max(e[0], e[2]) > reset_tol[0] or max(e[1], e[3]) > reset_tol[1]:
            init_log.append((t, "measured"))
            return y
        init_log.append((t, "reference"))
        y[:4] = r
        return y

    def apply_target(now, target):
        t_knots, pos, vel, acc = target
        keep = t_knots > now + 1e-9  # knots already in the past are dropped
        if not keep.any():  # the whole target arrived too late: aim one interval ahead
            t_knots, pos, vel, acc = np.array([now + Ts]), pos[-1:], vel[-1:], acc[-1:]
            keep = np.array([True])
        interp.update(now, t_knots[keep], pos[keep], vel[keep], acc[keep])

    if topology == "single":
        @cpu.periodic(period=nmpc_period, priority=2, name="nmpc")
        def nmpc_task(ctx):
            y = ctx.read(out_port)
            if controller == "2lc":
                y = initial_measurement(y, ctx.now)
            yield from nmpc_body(ctx, y, ctx.now)
    else:
        from netcosim.network import IdealLink
        net = network(sim) if network is not None else IdealLink(sim, "link", data_rate=1e6, delay=0.0)
        ground = sim.node("ground", scheduler="fixed_priority", context_switch=timing.context_switch)
        net.attach(cpu, priority=2, mailbox=False, handler=lambda msg: apply_target(sim.now, msg.payload))
        g_iface = net.attach(ground, priority=1)

        @ground.aperiodic(priority=1, name="nmpc")
        def nmpc_task(ctx):
            msg = g_iface.mailbox.try_fetch()
            nxt = g_iface.mailbox.try_fetch()
            while nxt is not None:  # only the newest measurement matters
                msg, nxt = nxt, g_iface.mailbox.try_fetch()
            if msg is None:
                return
            t_s, y = msg.payload
            yield from nmpc_body(ctx, np.asarray(y), t_s, send=lambda target: ctx.send("onboard", target, 64 * (1 + 7 * ref_knots)))

        g_iface.on_receive(nmpc_task)

        @cpu.periodic(period=nmpc_period, priority=2, name="sensor")
        def sensor_task(ctx):
            y = ctx.read(out_port)
            t_s = ctx.now
            y = initial_measurement(y, t_s)[:4]
            yield ctx.execute(timing.fl_exec)
            ctx.send("ground", (t_s, [float(v) for v in y[:4]]), 64 * 5)

    if controller == "2lc":
        @cpu.periodic(period=fl_period, priority=1, name="fl")
        def fl_task(ctx):
            y = ctx.read(out_port)
            t = ctx.now
            pos, vel, acc = interp.evaluate(t)
            if ff_lead:
                acc = interp.evaluate(t + ff_lead)[2]
            u = fl(y[:4], pos, vel, acc)
            ref_rows.append((t, pos[0], pos[1], vel[0], vel[1], acc[0], acc[1], u[0], u[1]))
            yield ctx.execute(timing.fl_exec)
            ctx.write(in_port, u)

    sim.run(until=duration)
    signals = _plant_signals(sim, "uav", wind, params)
    reference = pd.DataFrame(ref_rows, columns=["time", "phi_ref", "theta_ref", "dphi_ref", "dtheta_ref",
                                                "ddphi_ref", "ddtheta_ref", "f_R_cmd", "tau_R_cmd"])
    return LandingRun(controller=controller, wind=wind, signals=signals, steps=pd.DataFrame(steps),
                      reference=reference, jobs=sim.trace.jobs(), schedule=sim.trace.schedule(), sim=sim,
                      nmpc=nmpc, fl=fl, meta=dict(params=params, config=cfg, timing=timing, topology=topology,
                                                  nmpc_init=nmpc_init,
                                                  n_reset=sum(1 for _, k in init_log if k == "measured")),
                      cpu_times=cpu_model.record(), reproducible=cpu_model.reproducible)


def landing_metrics(run: LandingRun, tol_deg: float = 1.0) -> dict:
    """Summary numbers of a landing run (angles in degrees, times in s, SI otherwise).

    ``t_reach``: first instant both |φ - φ*| and |ϑ - ϑ*| are within *tol_deg*;
    ``t_settle``: instant after which they stay within it until the end (NaN if never);
    ``rms_phi``, ``rms_theta``: RMS over the run of the errors against the final
    reference (φ* = -α, ϑ* = α); ``rms`` = sqrt(mean(e_φ² + e_ϑ²)); extremes of the
    thrust, torque, cable stress and propeller–ground distances; QP fallbacks.
    """
    s = run.signals
    alpha = run.meta["params"].alpha
    e_phi = np.degrees(s["phi"].to_numpy() + alpha)
    e_theta = np.degrees(s["theta"].to_numpy() - alpha)
    t = s["time"].to_numpy()
    inside = (np.abs(e_phi) <= tol_deg) & (np.abs(e_theta) <= tol_deg)
    t_reach = float(t[np.argmax(inside)]) if inside.any() else math.nan
    if inside[-1]:
        outside = np.nonzero(~inside)[0]
        t_settle = float(t[outside[-1] + 1]) if outside.size else float(t[0])
    else:
        t_settle = math.nan
    steps = run.steps
    return dict(
        controller=run.controller, wind=run.wind, t_reach=t_reach, t_settle=t_settle,
        phi_final=float(np.degrees(s["phi"].iloc[-1])), theta_final=float(np.degrees(s["theta"].iloc[-1])),
        rms_phi=float(np.sqrt(np.mean(e_phi ** 2))), rms_theta=float(np.sqrt(np.mean(e_theta ** 2))),
        rms=float(np.sqrt(np.mean(e_phi ** 2 + e_theta ** 2))),
        f_R_min=float(s["f_R"].min()), f_R_max=float(s["f_R"].max()),
        tau_R_min=float(s["tau_R"].min()), tau_R_max=float(s["tau_R"].max()),
        f_L_min=float(s["f_L"].min()), f_L_max=float(s["f_L"].max()),
        d_PG_min=float(min(s["d_PG1"].min(), s["d_PG2"].min())),
        n_steps=int(len(steps)), n_fallback=int(steps["fallback"].sum()) if len(steps) else 0,
        qp_iter_max=int(steps["qp_iter"].max()) if len(steps) else 0,
    )
