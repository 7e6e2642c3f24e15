"""Wiring of the landing tasks onto nodes, one function per topology, and the runner.

:func:`simulate_landing` runs a :class:`~netcosim.controllers.landing.LandingScenario`: it
builds (:func:`build_landing`) the simulation, the plant and node ``onboard``, the shared
:class:`~netcosim.controllers.landing.tasks.LandingLoop`, calls the wiring function of the
scenario's topology (:data:`WIRINGS`), adds the low-level task of the 2LC, runs it
and collects a :class:`~netcosim.controllers.landing.LandingRun` (:func:`landing_result`).
:func:`run_landing` is the keyword interface to it.

Times in seconds.
"""

from __future__ import annotations

import math

import pandas as pd

from netcosim import RK4, Simulation
from netcosim.plants.tethered_uav import TetheredUAV, TetheredUAVParams, wind_disturbance

from .feedback_linearization import PIDGains
from .ocp import LandingConfig
from .result import LandingRun, plant_signals
from .scenario import LandingScenario
from .tasks import LandingLoop, fl_task, ground_nmpc_task, nmpc_task, sensor_task
from .timing import LandingTiming

__all__ = ["run_landing", "simulate_landing", "build_landing", "landing_result", "wire_single_node",
           "wire_two_nodes", "WIRINGS"]

#: MAC priority (CAN identifier) of the messages each node sends in the two-node
#: variant: the references from ``ground`` beat the measurements from ``onboard``.
GROUND_PRIORITY, ONBOARD_PRIORITY = 1, 2


def wire_single_node(sim: Simulation, onboard, loop: LandingLoop) -> None:
    """Every task on *onboard* (a node of *sim*): the 100 Hz NMPC of *loop* at priority 2."""
    onboard.periodic(nmpc_task(loop), period=loop.scenario.nmpc_period, priority=2, name="nmpc")


def wire_two_nodes(sim: Simulation, onboard, loop: LandingLoop) -> None:
    """The NMPC of *loop* on node ``ground``, released by each measurement a 100 Hz sensor task
    (priority 2) on *onboard* sends it; the target it sends back updates the
    interpolator on delivery.  Network: ``scenario.network(sim)`` or an ideal
    1 Mbit/s link without propagation delay."""
    from netcosim.network import IdealLink
    sc = loop.scenario
    net = sc.network(sim) if sc.network is not None else IdealLink(sim, "link", data_rate=1e6, delay=0.0)
    ground = sim.node("ground", scheduler="fixed_priority", context_switch=sc.timing.context_switch)
    net.attach(onboard, priority=ONBOARD_PRIORITY, mailbox=False,
               handler=lambda msg: loop.apply_target(sim.now, msg.payload))
    g_iface = net.attach(ground, priority=GROUND_PRIORITY)
    task = ground.aperiodic(ground_nmpc_task(loop, g_iface, peer=onboard.name), priority=1, name="nmpc")
    g_iface.on_receive(task)
    onboard.periodic(sensor_task(loop, peer=ground.name), period=sc.nmpc_period, priority=2, name="sensor")


#: The wiring function of each topology: ``wire(sim, onboard, loop)``.
WIRINGS = {"single": wire_single_node, "two_nodes": wire_two_nodes}


def _add_plant(sim: Simulation, sc: LandingScenario, xs0, system=None):
    """The tethered UAV with landers (and wind), in the input mode of the controller; *system*
    replaces the Python plant (it then carries the wind itself: no disturbance is passed)."""
    wind = wind_disturbance(sc.params) if sc.wind and system is None else None
    system = TetheredUAV(sc.params, inputs=sc.plant_inputs, landers=True) if system is None else system
    x0 = xs0 if sc.plant_inputs == "rates" else xs0[:4]
    uav = sim.plant(system, x0, name="uav", integrator=RK4(dt=sc.integrator_dt),
                    disturbance=wind, log_interval=sc.log_interval)
    if sc.plant_inputs == "forces":
        uav.inputs.write(xs0[4:6])  # hover thrust, zero torque until the first FL job
    return uav


def build_landing(scenario: LandingScenario, *, low_level: bool = True, system=None):
    """The simulation of *scenario*, ready to run: ``(sim, uav, loop)`` -- the
    :class:`~netcosim.Simulation`, the plant, the shared
    :class:`~netcosim.controllers.landing.tasks.LandingLoop` with the tasks of the scenario's
    topology.  ``low_level=False`` leaves out the 2LC's 500 Hz task (priority 1 on node
    ``onboard``): something else then drives the force inputs, e.g. the low-level
    controller in a separate process (``experiments/hil_landing_llc.py``).  ``system``: a
    plant with the Python plant's states, inputs and outputs in place of
    :class:`~netcosim.plants.tethered_uav.TetheredUAV` (the UAV as an FMU, carrying its own
    wind: ``plants/tethered_uav_fmu.py``)."""
    sc = scenario
    xs0 = sc.initial_state()
    sim = Simulation(seed=sc.seed)
    uav = _add_plant(sim, sc, xs0, system)
    onboard = sim.node("onboard", scheduler="fixed_priority", context_switch=sc.timing.context_switch)
    loop = LandingLoop(sc, uav.inputs, uav.outputs, xs0)
    WIRINGS[sc.topology](sim, onboard, loop)
    if loop.fl is not None and low_level:
        onboard.periodic(fl_task(loop), period=sc.fl_period, priority=1, name="fl")
    return sim, uav, loop


def landing_result(sim: Simulation, loop: LandingLoop) -> LandingRun:
    """The :class:`~netcosim.controllers.landing.LandingRun` of a simulation built by
    :func:`build_landing` (after ``sim.run``), from *sim*'s traces and *loop*'s records."""
    sc = loop.scenario
    return LandingRun(controller=sc.controller, wind=sc.wind, signals=plant_signals(sim, "uav", sc.wind, sc.params),
                      steps=pd.DataFrame(loop.steps), reference=loop.reference_table(), jobs=sim.trace.jobs(),
                      schedule=sim.trace.schedule(), sim=sim, nmpc=loop.nmpc, fl=loop.fl,
                      meta=dict(params=sc.params, config=sc.config, timing=sc.timing, topology=sc.topology,
                                nmpc_init=sc.nmpc_init, n_reset=loop.n_reset),
                      cpu_times=loop.cpu_model.record(), reproducible=loop.cpu_model.reproducible, scenario=sc)


def simulate_landing(scenario: LandingScenario) -> LandingRun:
    """Simulate *scenario* for ``scenario.duration`` seconds and collect the result."""
    sim, _uav, loop = build_landing(scenario)
    sim.run(until=scenario.duration)
    return landing_result(sim, loop)


def run_landing(controller: str = "2lc", *, wind: bool = False, duration: float = 1.5,
                params: TetheredUAVParams | None = None, config: LandingConfig | None = None,
                timing: LandingTiming | None = None, fl_gains: PIDGains | None = None,
                x0=None, nmpc_period: float = 0.01, fl_period: float = 0.002,
                integrator_dt: float = 1e-4, log_interval: float = 1e-3, seed: int = 0,
                nmpc_kw: dict | None = None, actuator_state: str = "measured",
                ff_lead: float | None = None, topology: str = "single", network=None,
                ref_knots: int = 3, nmpc_init: str = "measured",
                reset_tol: tuple[float, float] = (math.radians(2.0), math.radians(20.0))) -> LandingRun:
    """Simulate the landing of §2.6.2 with *controller* ``"nmpc"`` or ``"2lc"``.

    Builds a :class:`~netcosim.controllers.landing.LandingScenario` of the arguments and runs
    it (:func:`simulate_landing`).

    ``wind``: apply the wind of §2.6.1 to the plant; ``duration``: simulated time [s];
    ``config``: the NMPC's :class:`~netcosim.controllers.landing.ocp.LandingConfig`
    (default ``LandingConfig()``); ``timing``: the tasks' CPU times, a
    :class:`~netcosim.controllers.landing.timing.LandingTiming` (default: ideal, zero);
    ``nmpc_period`` and ``fl_period``: the NMPC's and the low-level loop's periods [s];
    ``integrator_dt``: the plant's RK4 step [s]; ``log_interval``: the plant's signal
    logging interval [s]; ``seed``: the simulation's seed; ``nmpc_kw``: keyword
    arguments of the NMPC (:class:`~netcosim.controllers.nmpc.rti.RTINMPC`).

    ``params``: simulation-model parameters (default :data:`SIM_PARAMS`); the NMPC and
    the low-level controller use the same physical parameters (the model mismatch is
    the landers and the wind, which the controllers do not model).  ``x0``: initial
    ``[φ, φ̇, ϑ, ϑ̇]`` (default hover at φ = ϑ = 0).  ``actuator_state`` (2LC only): the
    ``(f_R, τ_R)`` entries of the NMPC's initial state are the thrust and torque the
    low-level controller applies (``"measured"``, default: the thesis's x₀ = x̂₀) or the
    values its previous plan predicted for now (``"plan"``, a variant and a departure:
    they are then reference quantities of the trajectory generator; docs/nmpc.md).  In
    the two-node topology the sensor sends ``[φ, φ̇, ϑ, ϑ̇]`` only, so the NMPC there
    always takes them from the plan.  ``fl_gains``: PID gains of both low-level loops
    (default :data:`DEFAULT_FL_GAINS`, triple pole at -120 rad/s; the project's former
    -60 rad/s gains are :data:`SLOW_FL_GAINS`, a named variant).  ``ff_lead``: the low-level job evaluates the
    acceleration feed-forward ``ff_lead`` seconds after its sampling instant (default
    half the low-level period: the input is held over the period, so the mid-period
    acceleration is the one it should produce on average).  ``ref_knots``: number of
    plan nodes (``x_1 .. x_K``) each NMPC solution hands to the interpolator, so that a
    late solution finds the reference still on the previous plan.

    ``nmpc_init`` (2LC only): where each plan starts.  ``"measured"`` (default, the
    thesis's scheme, (2.13) with x₀ = x̂₀): the angles and rates of the NMPC's initial
    state are the measured ones at every sample.  ``"reference"`` (the reference-start
    variant): those of the low-level reference at the sampling instant, falling back to
    the measured ones whenever the tracking error exceeds ``reset_tol`` = (angle [rad],
    rate [rad/s]).  Starting each plan where the reference is makes the new plan
    continue the old one, so a late plan (computation or network delay) needs no
    catch-up by the low-level loop; without delay it leaves the NMPC open loop on the
    plant (the fallback does not fire in the landings of §2.6.2).  See
    ``docs/nmpc.md`` for both schemes against the computation delay.

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
    scenario = LandingScenario(
        controller=controller, wind=wind, duration=duration, params=params, config=config, timing=timing,
        fl_gains=fl_gains, x0=x0, nmpc_period=nmpc_period, fl_period=fl_period, integrator_dt=integrator_dt,
        log_interval=log_interval, seed=seed, nmpc_kw=nmpc_kw, actuator_state=actuator_state, ff_lead=ff_lead,
        topology=topology, network=network, ref_knots=ref_knots, nmpc_init=nmpc_init, reset_tol=reset_tol)
    return simulate_landing(scenario)
