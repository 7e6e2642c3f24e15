"""The ch. 3-5 planners as netcosim tasks, in both architectures of Fig. 3.3 / Fig. 5.1.

:func:`deploy` builds, from a validated :class:`DeploymentConfig`, inside a
:class:`netcosim.Simulation`, a pivot node, one node per robot, a network between them
and the plant ``config.plant`` (:mod:`netcosim.controllers.planner.plant_models`: the kinematic
``q_dot = A_q^+ u`` by default, or the dynamic model with velocity tracking)
(:func:`deploy_planner`: the same with the configuration as keyword arguments).  Small
task factories (``add_planner_task``, ``add_pose_task``, ``add_command_task``,
``add_actuation_task``, ``add_watchdog_task``)
are wired by one function per architecture (:func:`wire_centralized`,
:func:`wire_sparse`):

* ``architecture="centralized"`` (3.6)/(5.3): a periodic task on the pivot reads the
  whole ``q`` every T, computes the gain (offline, or online ``tau_o(e_h)/T``) and the
  feedback ``u_h = -k A_{q_h} K_bar (q_h - q_r(hT))``, and sends ``u_i`` to robot *i*;
* ``architecture="sparse"`` (3.5)/(5.2): the pivot reads its pose ``q_V`` every T and
  sends it to every robot; robot *i* reads its own ``q_i`` on reception and computes
  ``u_i`` with the sparse law (3.10).  Only an offline gain is possible (the online gain
  needs the whole ``q``).

A robot writes its command to the plant when the message has been processed and holds
it (ZOH) until the next one.  With ``on_loss="zero"`` a watchdog task checks every
``watchdog_period`` (0.2 s in appendix A) how old the last message is and zeroes the
command when it is older than ``watchdog_timeout`` (default T).  With a trajectory
(SIKM, ch. 5) the robot adds the feed-forward of (5.15) (``"reference"``) or (5.14)
(``"sample"``), refreshed every ``ff_period`` seconds by an actuation task.

Execution times (``exec_pivot``, ``exec_robot``: seconds, a ``scipy.stats`` frozen
distribution or ``fn(rng) -> s``) are consumed with ``ctx.execute`` after the inputs are
read; commands and messages leave at the end of that segment.

Results: :class:`~netcosim.controllers.planner.deployment.Deployment` holds typed records of every
computation and gives the sample sequence as a
:class:`~netcosim.controllers.planner.deployment.PlannerResponse` (``.to_pandas()``, ``.plot()``).

The numerical law is the same code as the pure-math simulations
(:mod:`netcosim.controllers.planner.laws`, :mod:`netcosim.controllers.planner.sikm`), so over an ideal
zero-delay network with zero execution times the sample sequences coincide with
:func:`netcosim.controllers.planner.laws.simulate_sampled`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError
from netcosim.network.frame import BROADCAST

from .deployment import CommandRecord, Deployment, PlannerRecord, PlannerResponse, PoseRecord
from .kinematics import as_vector, check_period, check_system, diag_gain, jacobian
from .laws import OfflineGain, OnlineGain, robot_velocity, sampled_velocity
from .norms import WeightedNorm
from .plant_models import KinematicModel, KinematicVelocityPlant, VelocityTrackingModel, check_model, plant_integrator
from .sikm import FEEDFORWARDS, Trajectory
from .structure import StarStructure

__all__ = ["KinematicVelocityPlant", "KinematicModel", "VelocityTrackingModel", "PlannerLaw", "DeploymentConfig",
           "Deployment", "PlannerResponse",
           "PlannerRecord", "PoseRecord", "CommandRecord", "deploy", "deploy_planner", "wire_centralized",
           "wire_sparse", "add_planner_task", "add_pose_task", "add_command_task", "add_actuation_task",
           "add_watchdog_task", "ideal_network", "plant_integrator", "ARCHITECTURES", "ON_LOSS", "MESSAGING"]


def ideal_network(sim, name: str = "planner_net"):
    """A contention-free link whose transmissions take zero ticks (1e18 bit/s, no delay), in
    *sim*, called *name*."""
    from netcosim.network.ideal import IdealLink
    return IdealLink(sim, name, data_rate=1e18, delay=0.0)


@dataclass(frozen=True)
class PlannerLaw:
    """Which law the tasks run.

    ``gain``: :class:`OfflineGain` or :class:`OnlineGain`; ``kbar``: diagonal of
    ``K_bar`` (ch. 4); ``norm``: norm of the online gain's minimisation; ``q_ref``: a
    constant reference (point stabilization, ch. 3/4) or ``trajectory``: a
    :class:`~netcosim.controllers.planner.sikm.Trajectory` (ch. 5) with ``feedforward`` in
    {"none", "reference", "sample"} refreshed every ``ff_period`` s at the robots.
    """

    gain: Any
    q_ref: Any = None
    kbar: Any = None
    norm: Any = None
    trajectory: Trajectory | None = None
    feedforward: str = "none"
    ff_period: float | None = None

    def __post_init__(self):
        if not isinstance(self.gain, (OfflineGain, OnlineGain)):
            raise TypeError(f"gain must be OfflineGain(k) or OnlineGain(), got {self.gain!r}")
        if (self.q_ref is None) == (self.trajectory is None):
            raise ValueError("give exactly one of q_ref (constant reference) and trajectory")
        if self.feedforward not in FEEDFORWARDS:
            raise ValueError(f"feedforward must be one of {FEEDFORWARDS}, got {self.feedforward!r}")
        if self.feedforward != "none":
            if self.trajectory is None:
                raise ValueError("a feed-forward needs a trajectory")
            check_period(self.ff_period if self.ff_period is not None else math.nan, "feed-forward period ff_period")

    def reference(self, t: float) -> np.ndarray:
        """The reference configuration q_r at time *t* [s] (rad, m): the trajectory's, or the
        constant ``q_ref``."""
        if self.trajectory is not None:
            return self.trajectory(t)[0]
        return np.asarray(self.q_ref, dtype=float)


#: The two architectures of Fig. 3.3 / Fig. 5.1 and what a robot does on a lost command.
ARCHITECTURES = ("sparse", "centralized")
ON_LOSS = ("hold", "zero")
#: How the pivot addresses the robots: one message per robot, or one broadcast frame.
MESSAGING = ("unicast", "broadcast")


@dataclass(frozen=True)
class DeploymentConfig:
    """A validated description of a planner deployment (everything but the simulation,
    the system, q0 and the objects it is wired to).

    ``T``: sampling period (s); ``law``: the :class:`PlannerLaw`; ``architecture``:
    ``"sparse"`` or ``"centralized"``; ``exec_pivot``, ``exec_robot``: execution times
    (s, a ``scipy.stats`` frozen distribution or ``fn(rng) -> s``); ``size_bits``: bits
    per float in a message (a message is ``floats x size_bits`` long); ``on_loss``:
    ``"hold"`` the last command or ``"zero"`` it once it is older than
    ``watchdog_timeout`` (s, default T), checked every ``watchdog_period`` (s);
    ``plant_name``, ``log_interval`` (s): passed to ``sim.plant``; ``guarantee``: a
    :class:`~netcosim.controllers.planner.gain_design.GainDesign` (point stabilization) or
    :class:`~netcosim.controllers.planner.sikm.SIKMParams` (tracking): an offline gain outside
    the corresponding stability set raises ``ValueError``; ``plant``: the plant model
    (:mod:`netcosim.controllers.planner.plant_models`: :class:`KinematicModel` ``q_dot = A_q^+ u``,
    the default, or :class:`VelocityTrackingModel` ``(alpha)``, the dynamic model (4.10)
    under the velocity-tracking force (4.11)); ``messaging``: ``"unicast"`` (one message
    per robot with its part) or ``"broadcast"`` (one message to every robot: the whole
    ``u``, or ``q_V``); ``exec_watchdog``: the watchdog's execution time (s, as above).
    """

    T: float
    law: PlannerLaw
    architecture: str = "sparse"
    exec_pivot: Any = 0.0
    exec_robot: Any = 0.0
    size_bits: int = 64
    on_loss: str = "hold"
    watchdog_period: float = 0.2
    watchdog_timeout: float | None = None
    plant_name: str = "plant"
    log_interval: float | None = None
    guarantee: Any = None
    plant: Any = KinematicModel()
    messaging: str = "unicast"
    exec_watchdog: Any = 0.0

    def __post_init__(self):
        object.__setattr__(self, "T", check_period(self.T))
        check_model(self.plant)
        if self.messaging not in MESSAGING:
            raise ConfigurationError(f"messaging must be one of {MESSAGING}, got {self.messaging!r}")
        if self.architecture not in ARCHITECTURES:
            raise ValueError(f"architecture must be 'sparse' or 'centralized', got {self.architecture!r}")
        if self.on_loss not in ON_LOSS:
            raise ValueError(f"on_loss must be 'hold' or 'zero', got {self.on_loss!r}")
        if not isinstance(self.law, PlannerLaw):
            raise TypeError(f"law must be a PlannerLaw, got {self.law!r}")
        if self.architecture == "sparse" and isinstance(self.law.gain, OnlineGain):
            raise ValueError("the online gain tau_o(e_h)/T needs the whole q: use architecture='centralized'")
        _check_size_bits(self.size_bits)
        _check_guarantee(self.law.gain, self.T, self.guarantee)
        object.__setattr__(self, "watchdog_period", check_period(self.watchdog_period, "watchdog_period"))
        if self.watchdog_timeout is not None:
            object.__setattr__(self, "watchdog_timeout", check_period(self.watchdog_timeout, "watchdog_timeout"))

    @property
    def timeout(self) -> float:
        """Age (s) beyond which the watchdog zeroes a command: ``watchdog_timeout`` or T."""
        return self.T if self.watchdog_timeout is None else self.watchdog_timeout


def _check_size_bits(b) -> None:
    validate.integer(b, "size_bits", lo=1, kind="a positive integer", type_error=ConfigurationError)


def _check_guarantee(gain, T: float, guarantee) -> None:
    """Raise ``ValueError`` if an offline gain lies outside the stability set of *guarantee*."""
    if guarantee is None or not isinstance(gain, OfflineGain):
        return
    if hasattr(guarantee, "check_gain"):
        guarantee.check_gain(gain.k, T)
    else:
        from .sikm import check_offline_gain
        check_offline_gain(gain.k, T, guarantee)


@dataclass
class _Shared:
    """What every task of one deployment reads: the system, its structure, the law and
    its parsed gains, the configuration and the record list."""

    system: Any
    structure: StarStructure
    config: DeploymentConfig
    records: list
    kd: np.ndarray = field(init=False)
    nrm: WeightedNorm = field(init=False)

    def __post_init__(self):
        self.kd = diag_gain(self.config.law.kbar, self.system.m)
        self.nrm = WeightedNorm.of(self.config.law.norm)

    @property
    def law(self) -> PlannerLaw:
        return self.config.law

    @property
    def ff(self) -> str:
        return self.config.law.feedforward

    @property
    def names(self) -> list[str]:
        return [f"robot{i + 1}" for i in range(self.structure.N)]


@dataclass
class _Robot:
    """Robot *i*: its node, interface, plant ports and the command it holds (ZOH)."""

    i: int
    name: str
    node: Any
    iface: Any
    rows: list
    u_port: Any
    qi_port: Any
    u_fb: np.ndarray
    t_rx: float = -math.inf
    A_rows: Any = None     # rows of A_{q_h} for the (5.14) feed-forward
    have: bool = False
    zeroed: bool = False

    def feedforward(self, sh: _Shared, t: float) -> np.ndarray:
        """The feed-forward at time t (s): (5.15) ``A_{q_r(t)} q_r_dot(t)`` ("reference")
        or (5.14) ``A_{q_h} q_r_dot(t)`` ("sample"), robot i's rows."""
        qr_t, qrd_t = sh.law.trajectory(t)
        if sh.ff == "reference":
            return jacobian(sh.system, qr_t)[self.rows] @ qrd_t
        return self.A_rows @ qrd_t


# ---------------------------------------------------------------- task factories

def add_planner_task(pivot, sh: _Shared, q_port) -> Any:
    """Centralized (3.6)/(5.3): every T the pivot reads q, computes the gain and
    ``u_h = -k A_{q_h} K_bar (q_h - q_r(hT))`` and sends ``u_i`` (and, for the (5.14)
    feed-forward, A_{q_h}'s rows) to robot i.  *pivot*: the pivot node; *sh*: the
    deployment's shared state (system, structure, configuration, records); *q_port*: the
    plant's output port of q."""
    cfg, system, st = sh.config, sh.system, sh.structure
    m = system.m

    def planner(ctx):
        q = np.asarray(ctx.read(q_port), dtype=float)
        job = ctx.job
        h, t_h = job.index, job.release_time
        qr_h = sh.law.reference(t_h)
        k, _ = sh.law.gain(system, q, qr_h, cfg.T, sh.kd, sh.nrm)
        u = sampled_velocity(system, q, qr_h, k, sh.kd)
        A_h = jacobian(system, q) if sh.ff == "sample" else None
        yield ctx.execute(cfg.exec_pivot)
        if cfg.messaging == "broadcast":
            ctx.send(BROADCAST, {"h": h, "t": t_h, "u": u, "A": A_h, "all": True},
                     cfg.size_bits * (system.n * (1 + (m if A_h is not None else 0)) + 1))
        else:
            for i, dst in enumerate(sh.names):
                rows = list(st.rows[i])
                payload = {"h": h, "t": t_h, "u": u[rows], "A": None if A_h is None else A_h[rows]}
                ctx.send(dst, payload, cfg.size_bits * (len(rows) * (1 + (m if A_h is not None else 0)) + 1))
        sh.records.append(PlannerRecord("pivot", h, t_h, ctx.now, q, u, k))
        ctx.log("k", k)

    return pivot.periodic(planner, period=cfg.T, priority=1, name="planner")


def add_pose_task(pivot, sh: _Shared, qV_port) -> Any:
    """Sparse (3.5)/(5.2): every T the pivot reads its pose q_V and sends it to every robot.
    *pivot*: the pivot node; *sh*: the deployment's shared state (system, structure,
    configuration, records); *qV_port*: the plant's output port of q_V."""
    cfg = sh.config

    def pose(ctx):
        q_V = np.atleast_1d(np.asarray(ctx.read(qV_port), dtype=float))
        job = ctx.job
        h, t_h = job.index, job.release_time
        yield ctx.execute(cfg.exec_pivot)
        for dst in ((BROADCAST,) if cfg.messaging == "broadcast" else sh.names):
            ctx.send(dst, {"h": h, "t": t_h, "q_V": q_V}, cfg.size_bits * (len(q_V) + 1))
        sh.records.append(PoseRecord("pivot", h, t_h, ctx.now, q_V))

    return pivot.periodic(pose, period=cfg.T, priority=1, name="pose")


def _newest(mailbox):
    """The newest queued message (several queued: only the newest matters), or None."""
    msg = mailbox.try_fetch()
    nxt = mailbox.try_fetch()
    while nxt is not None:
        msg, nxt = nxt, mailbox.try_fetch()
    return msg


def _received_feedback(ctx, sh: _Shared, robot: _Robot, p) -> tuple:
    """Centralized: the feedback ``u_i`` (and A_{q_h} rows) as sent by the pivot (a
    broadcast carries all robots' rows: robot i picks its own)."""
    if p.get("all"):
        A = p["A"]
        return (np.asarray(p["u"], dtype=float)[robot.rows], None if A is None else A[robot.rows], np.zeros(0),
                math.nan)
    return np.asarray(p["u"], dtype=float), p["A"], np.zeros(0), math.nan


def _sparse_feedback(ctx, sh: _Shared, robot: _Robot, p) -> tuple:
    """Sparse (3.10): robot i reads q_i and computes ``u_i`` from ``(q_i, q_V)`` with the offline gain."""
    st, i = sh.structure, robot.i
    k_off = float(sh.law.gain.k)
    q_i = np.atleast_1d(np.asarray(ctx.read(robot.qi_port), dtype=float))
    qr_h = sh.law.reference(p["t"])
    u_fb = robot_velocity(sh.system, st, i, q_i, p["q_V"], qr_h, k_off * sh.kd)
    A_rows = None
    if sh.ff == "sample":
        qh = qr_h.copy()
        qh[list(st.cols[i])] = q_i
        qh[list(st.pivot)] = p["q_V"]
        A_rows = jacobian(sh.system, qh)[robot.rows]
    return u_fb, A_rows, q_i, k_off


def add_command_task(sh: _Shared, robot: _Robot, feedback) -> Any:
    """Robot i's command task, released by every received message: the newest message
    gives the feedback (``feedback(ctx, sh, robot, payload)``), written to the plant after
    the execution time, plus the feed-forward if any; held until the next one."""
    cfg = sh.config

    def command(ctx):
        msg = _newest(robot.iface.mailbox)
        if msg is None:
            return
        p = msg.payload
        u_fb, A_rows, q_i, k = feedback(ctx, sh, robot, p)
        yield ctx.execute(cfg.exec_robot)
        robot.u_fb, robot.A_rows, robot.t_rx, robot.have, robot.zeroed = u_fb, A_rows, ctx.now, True, False
        u = u_fb if sh.ff == "none" else u_fb + robot.feedforward(sh, ctx.now)
        ctx.write(robot.u_port, u)
        sh.records.append(CommandRecord(robot.name, robot.i, p["h"], p["t"], ctx.now, u_fb, q_i, k))

    task = robot.node.aperiodic(command, priority=1, name="command")
    robot.iface.on_receive(task)
    return task


def add_actuation_task(sh: _Shared, robot: _Robot) -> Any:
    """Every ``ff_period`` s: the held feedback plus the feed-forward at the current time, on
    *robot* (its node and command state); *sh*: the deployment's shared state (system,
    structure, configuration, records)."""

    def actuation(ctx):
        if robot.have and not robot.zeroed:
            ctx.write(robot.u_port, robot.u_fb + robot.feedforward(sh, ctx.now))

    return robot.node.periodic(actuation, period=sh.law.ff_period, priority=2, name="actuation")


def add_watchdog_task(sh: _Shared, robot: _Robot) -> Any:
    """Every ``watchdog_period`` s: zero the command once the last one is older than the
    timeout (decided at the release instant, written after ``exec_watchdog``), on *robot*
    (its node and command state); *sh*: the deployment's shared state (system, structure,
    configuration, records)."""
    cfg = sh.config

    def watchdog(ctx):
        late = robot.have and not robot.zeroed and ctx.now - robot.t_rx > cfg.timeout
        if cfg.exec_watchdog != 0.0:
            yield ctx.execute(cfg.exec_watchdog)
        if late:
            ctx.write(robot.u_port, np.zeros(len(robot.rows)))
            robot.zeroed = True
            ctx.log("watchdog_zero", 1.0)

    return robot.node.periodic(watchdog, period=cfg.watchdog_period, priority=3, name="watchdog")


def _add_robot(sim, net, plant, sh: _Shared, i: int, feedback, reads_q_i: bool) -> _Robot:
    """Node ``robot<i+1>`` on *net* with its command task, and the actuation and watchdog
    tasks when the law and ``on_loss`` ask for them."""
    st, name = sh.structure, sh.names[i]
    node = sim.node(name)
    iface = net.attach(node)
    rows = list(st.rows[i])
    u_port = plant.input(rows)
    qi_port = plant.output(list(st.cols[i])) if reads_q_i else None
    robot = _Robot(i, name, node, iface, rows, u_port, qi_port, np.zeros(len(rows)))
    add_command_task(sh, robot, feedback)
    if sh.ff != "none":
        add_actuation_task(sh, robot)
    if sh.config.on_loss == "zero":
        add_watchdog_task(sh, robot)
    return robot


# ---------------------------------------------------------------- wiring, one per architecture

def wire_centralized(sim, plant, pivot, net, sh: _Shared) -> list:
    """The pivot runs the whole planner on q; the robots apply what they receive.  *sim*: the
    simulation; *plant*: the plant instance; *pivot*: the pivot node; *net*: the network the
    nodes attach to; *sh*: the deployment's shared state (system, structure,
    configuration, records).  Returns the robots' states (node, ports, held command), one
    per robot."""
    add_planner_task(pivot, sh, plant.output(list(range(sh.system.m))))
    return [_add_robot(sim, net, plant, sh, i, _received_feedback, False) for i in range(sh.structure.N)]


def wire_sparse(sim, plant, pivot, net, sh: _Shared) -> list:
    """The pivot broadcasts q_V; each robot computes its own command from (q_i, q_V).  *sim*:
    the simulation; *plant*: the plant instance; *pivot*: the pivot node; *net*: the network
    the nodes attach to; *sh*: the deployment's shared state (system, structure,
    configuration, records).  Returns the robots' states (node, ports, held command), one
    per robot."""
    add_pose_task(pivot, sh, plant.output(list(sh.structure.pivot)))
    return [_add_robot(sim, net, plant, sh, i, _sparse_feedback, True) for i in range(sh.structure.N)]


WIRING = {"centralized": wire_centralized, "sparse": wire_sparse}


def _structure_of(system: Any, structure: StarStructure | None) -> StarStructure:
    st = structure or StarStructure.for_system(system)
    if st.m != system.m or st.n != system.n:
        raise ValueError(f"structure is for n={st.n}, m={st.m}; the system has n={system.n}, m={system.m}")
    return st


def deploy(sim, system: Any, q0: Any, config: DeploymentConfig, *, network: Any = None,
           structure: StarStructure | None = None, integrator: Any = None) -> Deployment:
    """Build, inside *sim*, the plant ``config.plant`` (default ``q_dot = A_q^+ u``) from *q0*
    (rad, m; a dynamic plant starts at rest), node ``pivot``
    and nodes ``robot1..robotN`` on *network* (default :func:`ideal_network`) and their
    tasks, wired for ``config.architecture`` (see the module docstring).  *system*: the
    kinematic system; *config*: the :class:`DeploymentConfig`.

    ``structure``: the :class:`StarStructure` (default :meth:`StarStructure.for_system`);
    ``integrator``: plant integrator (default ``config.plant.integrator()``).
    """
    check_system(system)
    q0 = as_vector(q0, system.m, "q0")
    sh = _Shared(system, _structure_of(system, structure), config, [])
    model = config.plant
    cs = model.build(system, config.plant_name)
    plant = sim.plant(cs, model.initial_state(cs, q0), name=config.plant_name,
                      integrator=integrator or model.integrator(), log_interval=config.log_interval)
    net = network if network is not None else ideal_network(sim)
    pivot = sim.node("pivot")
    net.attach(pivot)
    dep = Deployment(sim, plant, pivot, [], net, config.architecture, config.law, sh.structure, sh.records)
    robots = WIRING[config.architecture](sim, plant, pivot, net, sh)
    dep.robots.extend(r.node for r in robots)
    return dep


def deploy_planner(sim, system: Any, q0: Any, T: float, law: PlannerLaw, *, architecture: str = "sparse",
                   network: Any = None, exec_pivot: Any = 0.0, exec_robot: Any = 0.0, size_bits: int = 64,
                   on_loss: str = "hold", watchdog_period: float = 0.2, watchdog_timeout: float | None = None,
                   structure: StarStructure | None = None, integrator: Any = None, plant_name: str = "plant",
                   log_interval: float | None = None, guarantee: Any = None) -> Deployment:
    """:func:`deploy` with the :class:`DeploymentConfig` given as keyword arguments (the
    original signature): ``T`` in s, ``q0`` in rad and m; ``law``, ``architecture``,
    ``exec_pivot``, ``exec_robot``, ``size_bits``, ``on_loss``, ``watchdog_period``,
    ``watchdog_timeout``, ``plant_name``, ``log_interval`` and ``guarantee`` as the
    fields of :class:`DeploymentConfig`; *sim*, *system*, ``network``, ``structure`` and
    ``integrator`` as for :func:`deploy`."""
    check_system(system)
    config = DeploymentConfig(T, law, architecture=architecture, exec_pivot=exec_pivot, exec_robot=exec_robot,
                              size_bits=size_bits, on_loss=on_loss, watchdog_period=watchdog_period,
                              watchdog_timeout=watchdog_timeout, plant_name=plant_name,
                              log_interval=log_interval, guarantee=guarantee)
    return deploy(sim, system, q0, config, network=network, structure=structure, integrator=integrator)
