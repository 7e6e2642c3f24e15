"""Cost counters: deterministic per-example counts of the work the simulator does.

Wall-clock ratios (the other benchmarks) depend on the machine and its load; these counts
do not, so a test (``tests/test_cost_counters.py``) checks them against stored values
(:data:`REFERENCE`) and a change that makes an example do more work fails in CI whatever
the host.  Three kinds:

``events_per_job``  SimPy events processed per kernel job: the events taken from the
                    engine's queue (cancelled timers, which fire into nothing, included),
                    divided by the jobs in the ``jobs`` table.  Example: the 10 periodic
                    tasks of :mod:`benchmarks.kernel` (utilisation 0.66, fixed priority) for
                    1.2 s (10 hyperperiods).
``rows_per_frame``  trace rows per frame sent: the rows of every trace table of the run
                    (DataFrame lengths) over the frames the interfaces sent.  Examples: 10
                    CAN nodes at 90 % bus load (:func:`benchmarks.network.can_run`'s
                    periodic scenario) for 2000 frame times; 10 saturated 802.11b stations
                    on a 10 m circle (:func:`benchmarks.network.wlan_run`) for 0.2 s.
``values_per_frame``  Python values in the stored trace rows per frame sent: the length of
                    every row the tables hold (what the networks append and the columnar
                    store encodes; the reported rows above are made from them when a table
                    is read), over the frames sent.  The same two network examples.
``rhs_per_second``  right-hand-side evaluations per simulated second: calls of the plant
                    system's ``f`` plus the stage evaluations a compiled stepper reports
                    (``nfev`` of :class:`~netcosim.controllers.planner.plant_dop853.CompiledDOP853`'s
                    bound stepper).  Examples: the README servo under RK4(dt=1e-4) for 1 s
                    (4 per step: 40 000); the networked Fly-crane (online, 30 % loss, seed
                    0, dynamic plant, schedules off) for 10 s.
``reevals_per_frame``  802.11b station re-evaluations per frame sent or dropped: calls of
                    the DCF step of one station after a change of the medium it hears
                    (:meth:`~netcosim.network.wlan.dcf.PerStationAccess.reeval`; the shared
                    idle-slot clock's crowd counts as none).  Example: 50 saturated stations
                    on a 10 m circle sending to an access point at its centre (the ``circle``
                    geometry of :func:`benchmarks.network.wlan_scaling_run`: capture possible)
                    for 0.3 s, with the shared clock.

Tolerances (:data:`TOLERANCE`): events, rows, stored values and re-evaluations exact (integer logic only); RHS calls
+-2 % (an adaptive integrator's step count moves with the last bits of floating point,
e.g. another BLAS or compiler).  ``python -m benchmarks.counters`` prints the counts and
the stored ones; ``--record`` stores the current counts (after a change that is meant to
change them: say so in the commit).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

#: Stored counts (written by ``--record``).
REFERENCE = Path(__file__).with_name("counters_reference.json")
#: Allowed relative difference per kind of count.
TOLERANCE = {"events_per_job": 0.0, "rows_per_frame": 0.0, "values_per_frame": 0.0, "rhs_per_second": 0.02,
             "reevals_per_frame": 0.0}


class _EventCount:
    """Counts the events ``sim``'s engine processes from now on (see the module docstring):
    its ``run_until`` takes them one at a time through ``Engine.step`` and counts them
    (the same events in the same order; the trace is encoded when it is read)."""

    def __init__(self, sim):
        env = sim.env
        self.processed = 0
        run_until = env.run_until

        def counted(stop: int) -> None:
            q = env.queue
            while q and q[0][0] < stop:     # what run_until(stop) processes: the events before stop
                env.step()
                self.processed += 1
            run_until(stop)                 # now = stop
        env.run_until = counted     # an instance attribute: Simulation.run calls env.run_until

    def events(self) -> int:
        return self.processed


class _RhsCount:
    """Counts the evaluations of *plant*'s right-hand side (its system's ``f`` and the
    stage evaluations of a stepper with ``nfev``)."""

    def __init__(self, plant):
        self.plant, self.calls = plant, 0
        f = plant.system.f

        def counted(*a):
            self.calls += 1
            return f(*a)
        plant.system.f = counted    # an instance attribute: every path looks it up on the system
        self.nfev0 = getattr(plant._stepper, "nfev", 0)

    def evaluations(self) -> int:
        return self.calls + getattr(self.plant._stepper, "nfev", 0) - self.nfev0


def _rows(sim) -> int:
    return sum(len(sim.trace.frame(name)) for name in sim.trace.tables)


def _values(sim) -> int:
    """Python values in the rows every table of *sim*'s trace stores."""
    return sum(len(row) for name in sim.trace.tables for row in sim.trace.recorder(name).rows)


def kernel_events_per_job(until: float = 1.2) -> float:
    """SimPy events per job of the 10-task set of :mod:`benchmarks.kernel`."""
    from netcosim import Simulation

    from .kernel import TASKS
    sim = Simulation(seed=0)
    cpu = sim.node("cpu", scheduler="fixed_priority")
    for i, (C, T) in enumerate(TASKS, start=1):
        def body(ctx, c=C * 1e-3):
            yield ctx.execute(c)
        cpu.periodic(body, period=T * 1e-3, priority=i, name=f"t{i}")
    count = _EventCount(sim)
    sim.run(until=until)
    return count.events() / len(sim.trace.frame("jobs"))


def can_rows_per_frame(n: int = 10, frames: int = 2000) -> float:
    """Trace rows per CAN frame sent (periodic scenario of :func:`benchmarks.network.can_run`)."""
    sim, sent = _can(n, frames)
    return _rows(sim) / sent


def can_values_per_frame(n: int = 10, frames: int = 2000) -> float:
    """Stored trace values per CAN frame sent (the example of :func:`can_rows_per_frame`)."""
    sim, sent = _can(n, frames)
    return _values(sim) / sent


def _can(n: int, frames: int):
    from netcosim import Simulation
    from netcosim.network import CAN, can_frame_bits

    from .network import CAN_LOAD, CAN_RATE, periodic_sender
    sim = Simulation(seed=0)
    bus = CAN(sim, "can", data_rate=CAN_RATE, frame_format="standard")
    sink = bus.attach("sink", priority=10**6, mailbox=False)
    c = can_frame_bits(8) / CAN_RATE
    period = n * c / CAN_LOAD
    rng = sim.rng("phases")
    for i in range(n):
        iface = bus.attach(f"n{i}", priority=i, mailbox=False)

        sim.call_at(float(rng.uniform(0, period)), periodic_sender(sim, iface, sink, period))
    sim.run(frames * c / CAN_LOAD)
    return sim, sum(i.stats["sent"] for i in bus._ifaces)


def wlan_rows_per_frame(until: float = 0.2) -> float:
    """Trace rows per 802.11b frame sent or dropped (:func:`benchmarks.network.wlan_run`, traced)."""
    sim, sent = _wlan(until)
    return _rows(sim) / sent


def wlan_values_per_frame(until: float = 0.2) -> float:
    """Stored trace values per 802.11b frame sent or dropped (the example of :func:`wlan_rows_per_frame`)."""
    sim, sent = _wlan(until)
    return _values(sim) / sent


def _wlan(until: float):
    from netcosim import Simulation
    from netcosim.network import SaturatedSource, WLAN80211b

    from .network import N_STATIONS, PAYLOAD_BITS
    sim = Simulation(seed=0)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, trace=True)
    ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
    for i in range(N_STATIONS):
        s = net.attach(f"s{i}", position=(10 * math.cos(i), 10 * math.sin(i)))
        SaturatedSource(s, ap, PAYLOAD_BITS)
    sim.run(until)
    return sim, sum(i.stats["sent"] + i.stats["dropped"] for i in net._ifaces)


def wlan_reevals_per_frame(n: int = 50, until: float = 0.3, shared_clock: bool = True) -> float:
    """Station re-evaluations per 802.11b frame sent or dropped: *n* saturated stations on a
    10 m circle around an access point, *until* simulated seconds (see the module docstring)."""
    from netcosim import Simulation
    from netcosim.network import SaturatedSource, WLAN80211b
    from netcosim.network.wlan.dcf import PerStationAccess

    from .network import PAYLOAD_BITS
    calls = 0
    reeval = PerStationAccess.reeval

    def counted(self, r):
        nonlocal calls
        calls += 1
        return reeval(self, r)
    PerStationAccess.reeval = counted       # type: ignore[method-assign]  # for this run only
    try:
        sim = Simulation(seed=0)
        net = WLAN80211b(sim, "wlan", data_rate=11e6, trace=False, shared_clock=shared_clock)
        ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
        for i in range(n):
            s = net.attach(f"s{i}", position=(10 * math.cos(i), 10 * math.sin(i)))
            SaturatedSource(s, ap, PAYLOAD_BITS)
        sim.run(until)
    finally:
        PerStationAccess.reeval = reeval    # type: ignore[method-assign]
    return calls / sum(i.stats["sent"] + i.stats["dropped"] for i in net._ifaces)


def servo_rhs_per_second(until: float = 1.0) -> float:
    """RHS evaluations per simulated second of the README servo under RK4(dt=1e-4)."""
    from netcosim import RK4, Simulation
    from netcosim.controllers.pid import PID
    from netcosim.plants.dc_servo import DCServo
    sim = Simulation(seed=1)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], integrator=RK4(dt=1e-4))
    cpu = sim.node("controller", scheduler="fixed_priority", context_switch=20e-6)
    pid = PID(h=0.006)

    @cpu.periodic(period=0.006, priority=1)
    def control(ctx):
        y = ctx.read(servo.output("y"))
        u = pid.compute(1.0, y)
        yield ctx.execute(0.002)
        ctx.write(servo.input("u"), u)
    count = _RhsCount(servo)
    sim.run(until=until)
    return count.evaluations() / until


def flycrane_rhs_per_second(horizon: float = 10.0) -> float:
    """RHS evaluations per simulated second of the networked Fly-crane (dynamic plant)."""
    from netcosim import Simulation
    from netcosim.controllers.planner import networked as nw
    cfg = nw.FlyCraneNetworkConfig(loss=0.3, strategy="online", seed=0, horizon=horizon, schedules=False)
    sim = Simulation(cfg.seed)
    dep, recorder = nw.build(sim, cfg)
    recorder.start(dep.plant)
    count = _RhsCount(dep.plant)
    sim.run(cfg.horizon)
    return count.evaluations() / horizon


#: name -> (kind, function)
COUNTERS = {
    "kernel_10_tasks.events_per_job": ("events_per_job", kernel_events_per_job),
    "can_10_nodes.rows_per_frame": ("rows_per_frame", can_rows_per_frame),
    "wlan_10_stations.rows_per_frame": ("rows_per_frame", wlan_rows_per_frame),
    "can_10_nodes.values_per_frame": ("values_per_frame", can_values_per_frame),
    "wlan_10_stations.values_per_frame": ("values_per_frame", wlan_values_per_frame),
    "wlan_50_circle.reevals_per_frame": ("reevals_per_frame", wlan_reevals_per_frame),
    "servo_rk4.rhs_per_second": ("rhs_per_second", servo_rhs_per_second),
    "flycrane_dynamic.rhs_per_second": ("rhs_per_second", flycrane_rhs_per_second),
}


def measure(names=None) -> dict[str, float]:
    """The counts of *names* (default all of :data:`COUNTERS`)."""
    return {n: float(COUNTERS[n][1]()) for n in (names or COUNTERS)}


def load(path: Path = REFERENCE) -> dict[str, float]:
    return {k: float(v) for k, v in json.loads(Path(path).read_text()).items()}


def differences(got: dict[str, float], stored: dict[str, float]) -> list[str]:
    """One line per count outside its tolerance (:data:`TOLERANCE`) of the stored one."""
    out = []
    for name, v in got.items():
        ref = stored.get(name)
        tol = TOLERANCE[COUNTERS[name][0]]
        if ref is None or abs(v - ref) > tol * abs(ref):
            out.append(f"{name}: {v!r}, stored {ref!r} (tolerance {tol:.0%})")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", action="store_true", help=f"store the counts in {REFERENCE.name}")
    a = ap.parse_args(argv)
    got = measure()
    stored = load() if REFERENCE.exists() else {}
    w = max(map(len, got))
    print(f"{'counter':<{w}}  {'now':>12}  {'stored':>12}")
    for name, v in got.items():
        print(f"{name:<{w}}  {v:12.4f}  {stored.get(name, math.nan):12.4f}")
    if a.record:
        REFERENCE.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        print(f"stored in {REFERENCE}")
        return 0
    bad = differences(got, stored)
    for line in bad:
        print("DIFFERS", line)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
