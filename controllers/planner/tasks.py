"""The ch. 3-5 planners as netcosim tasks, in both architectures of Fig. 3.3 / Fig. 5.1.

:func:`deploy_planner` builds, inside a :class:`netcosim.Simulation`, a pivot node, one
node per robot, a network between them and the kinematic plant ``q_dot = A_q^+ u``:

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

The numerical law is the same code as the pure-math simulations
(:mod:`controllers.planner.laws`, :mod:`controllers.planner.sikm`), so over an ideal
zero-delay network with zero execution times the sample sequences coincide with
:func:`controllers.planner.laws.simulate_sampled`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from netcosim.continuous import SolveIVP

from plants.kinematic import KinematicPlant

from .kinematics import as_vector, check_period, check_system, diag_gain, jacobian
from .laws import OfflineGain, OnlineGain, robot_velocity, sampled_velocity
from .norms import WeightedNorm
from .structure import StarStructure
from .sikm import FEEDFORWARDS, Trajectory

__all__ = ["KinematicVelocityPlant", "PlannerLaw", "Deployment", "deploy_planner", "ideal_network",
           "plant_integrator"]


class KinematicVelocityPlant(KinematicPlant):
    """The one kinematic plant ``q_dot = A_q^+ u`` (:class:`plants.kinematic.KinematicPlant`)
    as the deployments build it: states and outputs ``q0..q{m-1}`` (rad, m), inputs
    ``u0..u{n-1}`` (m/s), no singular-set event (the pseudo-inverse still raises by the
    rank rule wherever the integrator evaluates it)."""

    def __init__(self, system: Any, name: str | None = None):
        super().__init__(system, name=name, indexed=True, singular_event=False)


def plant_integrator() -> SolveIVP:
    """The plant integrator matching :func:`controllers.planner.kinematics.integrate_kinematics`
    (DOP853, rtol 1e-12, atol 1e-13)."""
    return SolveIVP(method="DOP853", rtol=1e-12, atol=1e-13)


def ideal_network(sim, name: str = "planner_net"):
    """A contention-free link whose transmissions take zero ticks (1e18 bit/s, no delay)."""
    from netcosim.network.ideal import IdealLink
    return IdealLink(sim, name, data_rate=1e18, delay=0.0)


@dataclass(frozen=True)
class PlannerLaw:
    """Which law the tasks run.

    ``gain``: :class:`OfflineGain` or :class:`OnlineGain`; ``kbar``: diagonal of
    ``K_bar`` (ch. 4); ``norm``: norm of the online gain's minimisation; ``q_ref``: a
    constant reference (point stabilization, ch. 3/4) or ``trajectory``: a
    :class:`~controllers.planner.sikm.Trajectory` (ch. 5) with ``feedforward`` in
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
        if self.trajectory is not None:
            return self.trajectory(t)[0]
        return np.asarray(self.q_ref, dtype=float)


@dataclass
class _RobotState:
    u_fb: np.ndarray
    t_rx: float = -math.inf
    q_h: Any = None        # sample used for the (5.14) feed-forward
    have: bool = False
    zeroed: bool = False


@dataclass
class Deployment:
    """What :func:`deploy_planner` built: the plant, nodes, network and the records.

    ``records``: one dict per computation (``node``, ``h``, ``t`` = nominal sample time
    hT, ``t_done`` = when the command/message left, and the values read/computed).
    """

    sim: Any
    plant: Any
    pivot: Any
    robots: list
    network: Any
    architecture: str
    law: PlannerLaw
    structure: StarStructure
    records: list = field(default_factory=list)

    def samples(self):
        """One row per sample h: ``t`` (hT), ``k`` (centralized), ``q0..``, ``u0..`` as
        read and computed by the tasks (the feedback part of the command)."""
        import pandas as pd

        st = self.structure
        m, n = st.m, st.n
        by_h: dict[int, dict] = {}
        for r in self.records:
            row = by_h.setdefault(r["h"], {"h": r["h"], "t": r["t"], "k": math.nan,
                                          "q": np.full(m, math.nan), "u": np.full(n, math.nan)})
            if r["node"] == "pivot":
                if "q" in r:
                    row["q"][:] = r["q"]
                    row["u"][:] = r["u"]
                    row["k"] = r["k"]
                else:
                    row["q"][list(st.pivot)] = r["q_V"]
            else:
                i = r["robot"]
                if "q_i" in r:
                    row["q"][list(st.cols[i])] = r["q_i"]
                    row["k"] = r["k"]
                row["u"][list(st.rows[i])] = r["u_i"]
        rows = []
        for h in sorted(by_h):
            d = by_h[h]
            rows.append((h, d["t"], d["k"], *d["q"], *d["u"]))
        return pd.DataFrame(rows, columns=["h", "t", "k"] + [f"q{i}" for i in range(m)]
                            + [f"u{i}" for i in range(n)])


def deploy_planner(sim, system: Any, q0: Any, T: float, law: PlannerLaw, *, architecture: str = "sparse",
                   network: Any = None, exec_pivot: Any = 0.0, exec_robot: Any = 0.0, size_bits: int = 64,
                   on_loss: str = "hold", watchdog_period: float = 0.2, watchdog_timeout: float | None = None,
                   structure: StarStructure | None = None, integrator: Any = None, plant_name: str = "plant",
                   log_interval: float | None = None, guarantee: Any = None) -> Deployment:
    """Build the plant, the pivot and robot nodes and their tasks (see module docstring).

    ``sim``: a :class:`netcosim.Simulation`; ``q0``: initial configuration (rad, m);
    ``T``: sampling period (s); ``network``: any netcosim network (default
    :func:`ideal_network`); nodes ``pivot`` and ``robot1..robotN`` are attached to it.
    ``size_bits``: bits per float in a message (message length = floats x size_bits).
    ``on_loss``: ``"hold"`` the last command or ``"zero"`` it after the watchdog timeout.
    ``integrator``: plant integrator (default :func:`plant_integrator`).
    ``guarantee``: a :class:`~controllers.planner.gain_design.GainDesign` (point stabilization)
    or :class:`~controllers.planner.sikm.SIKMParams` (tracking); an offline gain outside the
    corresponding stability set raises ``ValueError``.
    """
    check_system(system)
    T = check_period(T)
    if architecture not in ("sparse", "centralized"):
        raise ValueError(f"architecture must be 'sparse' or 'centralized', got {architecture!r}")
    if on_loss not in ("hold", "zero"):
        raise ValueError(f"on_loss must be 'hold' or 'zero', got {on_loss!r}")
    if not isinstance(law, PlannerLaw):
        raise TypeError(f"law must be a PlannerLaw, got {law!r}")
    if architecture == "sparse" and isinstance(law.gain, OnlineGain):
        raise ValueError("the online gain tau_o(e_h)/T needs the whole q: use architecture='centralized'")
    if isinstance(size_bits, bool) or not isinstance(size_bits, (int, np.integer)) or size_bits < 1:
        raise ValueError(f"size_bits must be a positive integer, got {size_bits!r}")
    if guarantee is not None and isinstance(law.gain, OfflineGain):
        if hasattr(guarantee, "check_gain"):
            guarantee.check_gain(law.gain.k, T)
        else:
            from .sikm import check_offline_gain
            check_offline_gain(law.gain.k, T, guarantee)
    watchdog_period = check_period(watchdog_period, "watchdog_period")
    timeout = T if watchdog_timeout is None else check_period(watchdog_timeout, "watchdog_timeout")
    m, n = system.m, system.n
    q0 = as_vector(q0, m, "q0")
    st = structure or StarStructure.for_system(system)
    if st.m != m or st.n != n:
        raise ValueError(f"structure is for n={st.n}, m={st.m}; the system has n={n}, m={m}")
    kd = diag_gain(law.kbar, m)
    nrm = WeightedNorm.of(law.norm)
    ff = law.feedforward

    plant = sim.plant(KinematicVelocityPlant(system, plant_name), q0, name=plant_name,
                      integrator=integrator or plant_integrator(), log_interval=log_interval)
    net = network if network is not None else ideal_network(sim)
    pivot = sim.node("pivot")
    net.attach(pivot)
    robots, ifaces = [], []
    dep = Deployment(sim, plant, pivot, robots, net, architecture, law, st)
    rec = dep.records
    names = [f"robot{i + 1}" for i in range(st.N)]

    # ---------------------------------------------------------------- pivot
    if architecture == "centralized":
        q_port = plant.output(None)

        @pivot.periodic(period=T, priority=1, name="planner")
        def pivot_planner(ctx):
            q = np.asarray(ctx.read(q_port), dtype=float)
            job = ctx.job
            h, t_h = job.index, job.release_time
            qr_h = law.reference(t_h)
            k, _ = law.gain(system, q, qr_h, T, kd, nrm)
            u = sampled_velocity(system, q, qr_h, k, kd)
            A_h = jacobian(system, q) if ff == "sample" else None
            yield ctx.execute(exec_pivot)
            for i, dst in enumerate(names):
                rows = list(st.rows[i])
                payload = {"h": h, "t": t_h, "u": u[rows], "A": None if A_h is None else A_h[rows]}
                ctx.send(dst, payload, size_bits * (len(rows) * (1 + (m if A_h is not None else 0)) + 1))
            rec.append({"node": "pivot", "h": h, "t": t_h, "t_done": ctx.now, "q": q, "u": u, "k": k})
            ctx.log("k", k)
    else:
        qV_port = plant.output(list(st.pivot))
        k_off = float(law.gain.k)

        @pivot.periodic(period=T, priority=1, name="pose")
        def pivot_pose(ctx):
            q_V = np.atleast_1d(np.asarray(ctx.read(qV_port), dtype=float))
            job = ctx.job
            h, t_h = job.index, job.release_time
            yield ctx.execute(exec_pivot)
            for dst in names:
                ctx.send(dst, {"h": h, "t": t_h, "q_V": q_V}, size_bits * (len(q_V) + 1))
            rec.append({"node": "pivot", "h": h, "t": t_h, "t_done": ctx.now, "q_V": q_V})

    # ---------------------------------------------------------------- robots
    for i, nm in enumerate(names):
        node = sim.node(nm)
        iface = net.attach(node)
        robots.append(node)
        ifaces.append(iface)
        rows = list(st.rows[i])
        u_port = plant.input(rows)
        qi_port = plant.output(list(st.cols[i])) if architecture == "sparse" else None
        state = _RobotState(np.zeros(len(rows)))

        def ff_term(t, i=i, state=state, rows=rows):
            qr_t, qrd_t = law.trajectory(t)
            if ff == "reference":
                return jacobian(system, qr_t)[rows] @ qrd_t
            return state.q_h @ qrd_t  # "sample": A_{q_h} rows received/computed at the sample

        def rx_body(ctx, i=i, iface=iface, state=state, rows=rows, u_port=u_port, qi_port=qi_port, nm=nm,
                    ff_term=ff_term):
            msg = iface.mailbox.try_fetch()
            nxt = iface.mailbox.try_fetch()
            while nxt is not None:  # several queued: only the newest matters
                msg, nxt = nxt, iface.mailbox.try_fetch()
            if msg is None:
                return
            p = msg.payload
            r = {"node": nm, "robot": i, "h": p["h"], "t": p["t"]}
            if architecture == "centralized":
                u_fb = np.asarray(p["u"], dtype=float)
                A_rows = p["A"]
            else:
                q_i = np.atleast_1d(np.asarray(ctx.read(qi_port), dtype=float))
                qr_h = law.reference(p["t"])
                u_fb = robot_velocity(system, st, i, q_i, p["q_V"], qr_h, k_off * kd)
                A_rows = None
                if ff == "sample":
                    qh = qr_h.copy()
                    qh[list(st.cols[i])] = q_i
                    qh[list(st.pivot)] = p["q_V"]
                    A_rows = jacobian(system, qh)[rows]
                r.update(q_i=q_i, k=k_off)
            yield ctx.execute(exec_robot)
            state.u_fb, state.q_h, state.t_rx, state.have, state.zeroed = u_fb, A_rows, ctx.now, True, False
            u = u_fb if ff == "none" else u_fb + ff_term(ctx.now)
            ctx.write(u_port, u)
            r.update(u_i=u_fb, t_done=ctx.now)
            rec.append(r)

        rx = node.aperiodic(rx_body, priority=1, name="command")
        iface.on_receive(rx)

        if ff != "none":
            def act_body(ctx, state=state, u_port=u_port, ff_term=ff_term):
                if state.have and not state.zeroed:
                    ctx.write(u_port, state.u_fb + ff_term(ctx.now))

            node.periodic(act_body, period=law.ff_period, priority=2, name="actuation")

        if on_loss == "zero":
            def wd_body(ctx, state=state, u_port=u_port, rows=rows):
                if state.have and not state.zeroed and ctx.now - state.t_rx > timeout:
                    ctx.write(u_port, np.zeros(len(rows)))
                    state.zeroed = True
                    ctx.log("watchdog_zero", 1.0)

            node.periodic(wd_body, period=watchdog_period, priority=3, name="watchdog")
    return dep
