"""Bad inputs to the kernel and the Simulation life cycle (``Simulation``, ``Node``, tasks,
timers, triggers, synchronisation primitives, and what a task body asks at run time)."""

from __future__ import annotations

from conftest import periodic_task

from invalid_cases import Case
from netcosim import ConditionVariable, Mailbox, Monitor, Semaphore, Simulation
from netcosim.errors import (
    ConfigurationError,
    ConfigurationTypeError,
    SimulationFailedError,
    UnyieldedExecuteError,
)

NAN, INF = float("nan"), float("inf")


def body(ctx):
    yield ctx.execute(0.001)


def cpu(**kw):
    return Simulation().node("cpu", **kw)


def periodic(**kw):
    kw.setdefault("period", 0.01)
    kw.setdefault("priority", 1)
    return cpu().periodic(body, name="t", **kw)


def aperiodic(**kw):
    return cpu().aperiodic(body, name="t", **kw)


def run_task(make_body, until=0.05, **node_kw):
    """Run one periodic task whose body is ``make_body()`` (errors surface inside run)."""
    periodic_task(make_body(), period=0.01, until=until, **node_kw)


def executes(c):
    def make():
        def b(ctx):
            yield ctx.execute(c)
        return b
    return make


def sleeps(s, until=False):
    def make():
        def b(ctx):
            yield (ctx.sleep_until(s) if until else ctx.sleep(s))
        return b
    return make


def yields(value):
    def make():
        def b(ctx):
            yield value
        return b
    return make


def forgets_yield():
    def b(ctx):
        ctx.execute(0.002)
        yield ctx.sleep(0.001)
    return b


def timer(**kw):
    node = cpu()
    return node.timer(node.aperiodic(body, priority=1, name="t"), **kw)


def timer_in_the_past():
    sim = Simulation()
    node = sim.node("cpu")
    t = node.aperiodic(body, priority=1, name="t")
    sim.run(until=1.0)
    return node.timer(t, at=0.5)


def trigger(min_interval):
    node = cpu()
    return node.trigger(node.aperiodic(body, priority=1, name="t"), min_interval=min_interval)


def run_back():
    sim = Simulation()
    sim.run(until=1.0)
    sim.run(until=0.5)


def duplicate_task():
    node = cpu()
    node.periodic(body, period=0.01, priority=1, name="t")
    node.aperiodic(body, priority=2, name="t")


def duplicate_node():
    sim = Simulation()
    sim.node("cpu")
    sim.node("cpu")


CASES = [
    # Simulation
    Case(id="kernel-sim-seed-negative", call=lambda: Simulation(seed=-3), exc=ValueError, names="-3"),
    Case(id="kernel-sim-seed-str", call=lambda: Simulation(seed="x"), exc=ValueError, names="'x'"),
    Case(id="kernel-sim-seed-bool", call=lambda: Simulation(seed=True), exc=ValueError, names="True"),
    Case(id="kernel-sim-seed-float", call=lambda: Simulation(seed=1.5), exc=ValueError, names="1.5"),
    Case(id="kernel-sim-rt-factor-nan", call=lambda: Simulation(realtime=True, factor=NAN),
         exc=ValueError, names="nan"),
    Case(id="kernel-sim-rt-factor-negative", call=lambda: Simulation(realtime=True, factor=-1.0),
         exc=ValueError, names="-1.0"),
    Case(id="kernel-sim-rt-factor-bool", call=lambda: Simulation(realtime=True, factor=True),
         exc=ValueError, names="True"),
    Case(id="kernel-sim-rt-max-lag-negative", call=lambda: Simulation(realtime=True, max_lag=-0.1),
         exc=ValueError, names="-0.1"),
    Case(id="kernel-sim-rt-max-lag-nan", call=lambda: Simulation(realtime=True, max_lag=NAN),
         exc=ValueError, names="nan"),
    Case(id="kernel-sim-rt-strict-str", call=lambda: Simulation(realtime=True, strict="yes"),
         exc=TypeError, names="'yes'"),
    Case(id="kernel-sim-until-nan", call=lambda: Simulation().run(until=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-sim-until-inf", call=lambda: Simulation().run(until=INF), exc=ValueError, names="inf"),
    Case(id="kernel-sim-until-negative", call=lambda: Simulation().run(until=-1.0), exc=ValueError,
         names="-1.0"),
    Case(id="kernel-sim-until-sub-resolution", call=lambda: Simulation().run(until=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-sim-until-str", call=lambda: Simulation().run(until="fast"), exc=TypeError,
         names="'fast'"),
    Case(id="kernel-sim-until-before-now", call=run_back, exc=ValueError, names="0.5"),
    Case(id="kernel-sim-timeout-negative", call=lambda: Simulation().timeout(-1.0), exc=ValueError,
         names="-1.0"),
    Case(id="kernel-sim-timeout-sub-resolution", call=lambda: Simulation().timeout(1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-sim-node-name-none", call=lambda: Simulation().node(None), exc=ValueError, names="None"),
    Case(id="kernel-sim-node-name-empty", call=lambda: Simulation().node(""), exc=ValueError, names="''"),
    Case(id="kernel-sim-node-name-duplicate", call=duplicate_node, exc=ValueError, names="'cpu'"),
    # Node
    Case(id="kernel-node-scheduler-unknown", call=lambda: cpu(scheduler="lottery"), exc=ValueError,
         names="'lottery'"),
    Case(id="kernel-node-scheduler-int", call=lambda: cpu(scheduler=42), exc=TypeError, names="42"),
    Case(id="kernel-node-scheduler-none", call=lambda: cpu(scheduler=None), exc=TypeError, names="None"),
    Case(id="kernel-node-scheduler-class", call=lambda: cpu(scheduler=dict), exc=TypeError,
         names="<class 'dict'>"),
    Case(id="kernel-node-speed-zero", call=lambda: cpu(speed=0), exc=ValueError, names="got 0"),
    Case(id="kernel-node-speed-negative", call=lambda: cpu(speed=-2), exc=ValueError, names="-2"),
    Case(id="kernel-node-speed-nan", call=lambda: cpu(speed=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-node-speed-inf", call=lambda: cpu(speed=INF), exc=ValueError, names="inf"),
    Case(id="kernel-node-speed-str", call=lambda: cpu(speed="fast"), exc=TypeError, names="'fast'"),
    Case(id="kernel-node-speed-bool", call=lambda: cpu(speed=True), exc=TypeError, names="True"),
    Case(id="kernel-node-cs-negative", call=lambda: cpu(context_switch=-1e-6), exc=ValueError, names="-1e-06"),
    Case(id="kernel-node-cs-nan", call=lambda: cpu(context_switch=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-node-cs-sub-resolution", call=lambda: cpu(context_switch=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-node-cs-zero-at-speed", call=lambda: cpu(context_switch=1e-12, speed=4.0),
         exc=ValueError, names="1e-12"),
    Case(id="kernel-node-cs-str", call=lambda: cpu(context_switch="fast"), exc=TypeError, names="'fast'"),
    Case(id="kernel-node-analog-in-negative", call=lambda: cpu().analog_in(-1), exc=ValueError, names="-1"),
    Case(id="kernel-node-analog-out-str", call=lambda: cpu().analog_out("a"), exc=ValueError, names="'a'"),
    # Tasks
    Case(id="kernel-task-period-sub-resolution", call=lambda: periodic(period=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-task-period-zero", call=lambda: periodic(period=0.0), exc=ValueError, names="0.0"),
    Case(id="kernel-task-period-negative", call=lambda: periodic(period=-1.0), exc=ValueError,
         names="period must be positive, got -1.0"),     # not "non-negative": 0 is refused too
    Case(id="kernel-task-period-inf", call=lambda: periodic(period=INF), exc=ValueError, names="inf"),
    Case(id="kernel-task-period-nan", call=lambda: periodic(period=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-task-period-str", call=lambda: periodic(period="fast"), exc=TypeError, names="'fast'"),
    Case(id="kernel-task-period-none", call=lambda: periodic(period=None), exc=TypeError, names="None"),
    Case(id="kernel-task-offset-negative", call=lambda: periodic(offset=-1.0), exc=ValueError, names="-1.0"),
    Case(id="kernel-task-offset-sub-resolution", call=lambda: periodic(offset=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-task-offset-nan", call=lambda: periodic(offset=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-task-deadline-zero", call=lambda: periodic(deadline=0.0), exc=ValueError, names="0.0"),
    Case(id="kernel-task-deadline-sub-resolution", call=lambda: aperiodic(priority=1, deadline=1e-13),
         exc=ValueError, names="1e-13"),
    Case(id="kernel-task-deadline-negative", call=lambda: periodic(deadline=-0.5), exc=ValueError,
         names="-0.5"),
    Case(id="kernel-task-deadline-bool", call=lambda: periodic(deadline=True), exc=TypeError, names="True"),
    Case(id="kernel-task-wcet-zero", call=lambda: periodic(wcet=0.0), exc=ValueError, names="0.0"),
    Case(id="kernel-task-wcet-sub-resolution", call=lambda: periodic(wcet=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-task-wcet-nan", call=lambda: periodic(wcet=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-task-priority-str", call=lambda: periodic(priority="high"), exc=TypeError,
         names="'high'"),
    Case(id="kernel-task-priority-nan", call=lambda: periodic(priority=NAN), exc=TypeError, names="nan"),
    Case(id="kernel-task-priority-none-fp", call=lambda: periodic(priority=None), exc=TypeError,
         names="None"),
    Case(id="kernel-task-priority-bool", call=lambda: aperiodic(priority=True), exc=TypeError, names="True"),
    Case(id="kernel-task-on-busy-unknown", call=lambda: periodic(on_busy="drop"), exc=ValueError,
         names="'drop'"),
    Case(id="kernel-task-preemptible-str", call=lambda: periodic(preemptible="yes"), exc=TypeError,
         names="'yes'"),
    Case(id="kernel-task-on-deadline-miss-str", call=lambda: periodic(on_deadline_miss="abort"),
         exc=TypeError, names="'abort'"),
    Case(id="kernel-task-on-budget-overrun-int", call=lambda: periodic(wcet=0.001, on_budget_overrun=42),
         exc=TypeError, names="42"),
    Case(id="kernel-task-name-duplicate", call=duplicate_task, exc=ValueError, names="'t'"),
    Case(id="kernel-task-body-not-callable", call=lambda: cpu().periodic(42, period=0.01, priority=1),
         exc=TypeError, names="42"),
    Case(id="kernel-handler-priority-nan", call=lambda: cpu().handler(body, priority=NAN), exc=TypeError,
         names="nan"),
    Case(id="kernel-handler-priority-str", call=lambda: cpu().handler(body, priority="x"), exc=TypeError,
         names="'x'"),
    Case(id="kernel-handler-deadline-sub-resolution", call=lambda: cpu().handler(body, deadline=1e-13),
         exc=ValueError, names="1e-13"),
    # Timers and triggers
    Case(id="kernel-timer-at-negative", call=lambda: timer(at=-1.0), exc=ValueError, names="-1.0"),
    Case(id="kernel-timer-at-nan", call=lambda: timer(at=NAN), exc=ValueError, names="nan"),
    Case(id="kernel-timer-at-past", call=timer_in_the_past, exc=ValueError, names="0.5"),
    Case(id="kernel-timer-period-zero", call=lambda: timer(at=0.0, period=0.0), exc=ValueError, names="0.0"),
    Case(id="kernel-timer-period-sub-resolution", call=lambda: timer(period=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-timer-period-str", call=lambda: timer(period="fast"), exc=TypeError, names="'fast'"),
    Case(id="kernel-trigger-min-interval-negative", call=lambda: trigger(-1.0), exc=ValueError, names="-1.0"),
    Case(id="kernel-trigger-min-interval-sub-resolution", call=lambda: trigger(1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-trigger-min-interval-str", call=lambda: trigger("fast"), exc=TypeError, names="'fast'"),
    # Synchronisation primitives
    Case(id="kernel-semaphore-value-negative", call=lambda: Semaphore("s", value=-1), exc=ValueError,
         names="-1"),
    Case(id="kernel-semaphore-value-float", call=lambda: Semaphore("s", value=1.5), exc=ValueError,
         names="1.5"),
    Case(id="kernel-semaphore-value-bool", call=lambda: Semaphore("s", value=True), exc=ValueError,
         names="True"),
    Case(id="kernel-semaphore-name-int", call=lambda: Semaphore(42), exc=TypeError, names="42"),
    Case(id="kernel-mailbox-capacity-zero", call=lambda: Mailbox("m", capacity=0), exc=ValueError,
         names="0"),
    Case(id="kernel-mailbox-capacity-float", call=lambda: Mailbox("m", capacity=2.5), exc=ValueError,
         names="2.5"),
    Case(id="kernel-mailbox-name-none", call=lambda: Mailbox(None), exc=TypeError, names="None"),
    Case(id="kernel-monitor-inheritance-str", call=lambda: Monitor("m", inheritance="yes"), exc=TypeError,
         names="'yes'"),
    Case(id="kernel-event-monitor-str", call=lambda: ConditionVariable("e", monitor="m"), exc=TypeError, names="'m'"),
    # What a task body asks at run time
    Case(id="kernel-execute-nan", call=lambda: run_task(executes(NAN)), exc=ValueError, names="nan"),
    Case(id="kernel-execute-inf", call=lambda: run_task(executes(INF)), exc=ValueError, names="inf"),
    Case(id="kernel-execute-negative", call=lambda: run_task(executes(-0.001)), exc=ValueError,
         names="-0.001"),
    Case(id="kernel-execute-sub-resolution", call=lambda: run_task(executes(1e-13)), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-execute-zero-ticks-at-speed", call=lambda: run_task(executes(1e-12), speed=3.0),
         exc=ValueError, names="speed 3.0"),
    Case(id="kernel-execute-str", call=lambda: run_task(executes("fast")), exc=TypeError, names="'fast'"),
    Case(id="kernel-execute-none", call=lambda: run_task(executes(None)), exc=TypeError, names="None"),
    Case(id="kernel-execute-bool", call=lambda: run_task(executes(True)), exc=TypeError, names="True"),
    Case(id="kernel-execute-callable-negative", call=lambda: run_task(executes(lambda rng: -1.0)),
         exc=ValueError, names="-1.0"),
    Case(id="kernel-execute-callable-sub-resolution", call=lambda: run_task(executes(lambda rng: 5e-13)),
         exc=ValueError, names="5e-13"),
    Case(id="kernel-execute-unyielded", call=lambda: run_task(forgets_yield), exc=UnyieldedExecuteError,
         names="execute(0.002)"),
    Case(id="kernel-sleep-negative", call=lambda: run_task(sleeps(-1.0)), exc=ValueError, names="-1.0"),
    Case(id="kernel-sleep-nan", call=lambda: run_task(sleeps(NAN)), exc=ValueError, names="nan"),
    Case(id="kernel-sleep-sub-resolution", call=lambda: run_task(sleeps(1e-13)), exc=ValueError,
         names="1e-13"),
    Case(id="kernel-sleep-until-nan", call=lambda: run_task(sleeps(NAN, until=True)), exc=ValueError,
         names="nan"),
    Case(id="kernel-sleep-str", call=lambda: run_task(sleeps("fast")), exc=TypeError, names="'fast'"),
    Case(id="kernel-yield-garbage", call=lambda: run_task(yields("soon")), exc=TypeError, names="'soon'"),
    # a bare int is not a kernel command (only ctx.execute's request is): refused as a wrong kind
    Case(id="kernel-yield-negative-ticks", call=lambda: run_task(yields(-5)), exc=ConfigurationTypeError,
         names="-5"),
    Case(id="kernel-run-after-failure", call=lambda: _failed_then_run(), exc=SimulationFailedError,
         names="ZeroDivisionError: boom"),
    # --- found by tests/test_properties.py (issue 23) -----------------------------------
    Case(id="kernel-execute-beyond-time-range", call=lambda: run_task(executes(1e300)), exc=ConfigurationError,
         names="1e+300"),
    Case(id="kernel-execute-int-beyond-float", call=lambda: run_task(executes(10**400)), exc=ConfigurationError,
         names="time range"),
    Case(id="kernel-speed-subnormal", call=lambda: cpu(speed=5e-324), exc=ConfigurationError, names="5e-324"),
    Case(id="kernel-run-until-int-beyond-float", call=lambda: Simulation().run(until=10**400),
         exc=ConfigurationError, names="until"),
    Case(id="kernel-call-at-in-the-past", call=lambda: _call_at_past(), exc=ConfigurationError, names="t=0.001"),
    Case(id="kernel-timer-target-not-a-task", call=lambda: cpu().timer("t", at=0.1), exc=ConfigurationTypeError,
         names="'t'"),
    Case(id="kernel-trigger-target-not-a-task", call=lambda: cpu().trigger(None), exc=ConfigurationTypeError,
         names="None"),
    Case(id="kernel-analog-channel-unhashable", call=lambda: cpu().analog_in([0]), exc=ConfigurationError,
         names="[0]"),
    Case(id="kernel-task-name-not-a-string", call=lambda: cpu().periodic(body, period=0.01, priority=1, name=7),
         exc=ConfigurationTypeError, names="7"),
    Case(id="kernel-process-not-a-generator", call=lambda: Simulation().process(body), exc=ConfigurationTypeError,
         names="body"),
    Case(id="kernel-rng-name-not-a-string", call=lambda: Simulation().rng(3), exc=ConfigurationTypeError,
         names="3"),
]


def _call_at_past():
    sim = Simulation()
    sim.run(until=0.002)
    sim.call_at(0.001, lambda: None)


def _failed_then_run():
    """A run that failed (task raised) makes the next run() refuse, naming the failure."""
    sim = Simulation()

    def b(ctx):
        yield ctx.execute(0.001)
        raise ZeroDivisionError("boom")
    sim.node("cpu").periodic(b, period=0.01, priority=1, name="t")
    try:
        sim.run(until=0.05)
    except ZeroDivisionError:
        pass
    sim.run(until=0.1)


def _returns(value):
    def make():
        return lambda ctx: value
    return make


def _yields_bare_int():
    """``yield 5`` is not ``yield ctx.execute(...)``: refused naming the task and the value."""
    sim = Simulation()

    def b(ctx):
        yield 5
    sim.node("cpu").periodic(b, period=0.01, priority=1, name="bare")
    sim.run(until=0.05)


def _bare_int_names_the_task():
    try:
        _yields_bare_int()
    except ConfigurationTypeError as exc:
        assert "'bare'" in str(exc), exc
        raise


# Audit fixes (Simulation arguments, call_at/call_in/call_at_ticks/add_finalizer, task names,
# analog channel range, what a body may return or yield).
CASES += [
    Case(id="kernel-sim-realtime-str", call=lambda: Simulation(realtime="yes"), exc=ConfigurationTypeError,
         names="'yes'"),
    Case(id="kernel-sim-realtime-int", call=lambda: Simulation(realtime=1), exc=ConfigurationTypeError,
         names="1"),
    Case(id="kernel-sim-factor-negative-not-realtime", call=lambda: Simulation(factor=-5),
         exc=ConfigurationError, names="-5"),
    Case(id="kernel-sim-strict-str-not-realtime", call=lambda: Simulation(strict="no"),
         exc=ConfigurationTypeError, names="'no'"),
    Case(id="kernel-sim-max-lag-negative-not-realtime", call=lambda: Simulation(max_lag=-1.0),
         exc=ConfigurationError, names="-1.0"),
    Case(id="kernel-sim-call-at-not-callable", call=lambda: Simulation().call_at(0.1, 5),
         exc=ConfigurationTypeError, names="5"),
    Case(id="kernel-sim-call-in-not-callable", call=lambda: Simulation().call_in(0.1, "f"),
         exc=ConfigurationTypeError, names="'f'"),
    Case(id="kernel-sim-call-at-ticks-float", call=lambda: Simulation().call_at_ticks(1.5, print),
         exc=ConfigurationTypeError, names="1.5"),
    Case(id="kernel-sim-call-at-ticks-bool", call=lambda: Simulation().call_at_ticks(True, print),
         exc=ConfigurationTypeError, names="True"),
    Case(id="kernel-sim-call-at-ticks-not-callable", call=lambda: Simulation().call_at_ticks(10, 5),
         exc=ConfigurationTypeError, names="5"),
    Case(id="kernel-sim-finalizer-not-callable", call=lambda: Simulation().add_finalizer(5),
         exc=ConfigurationTypeError, names="5"),
    Case(id="kernel-task-name-empty", call=lambda: cpu().periodic(body, period=0.006, priority=1, name=""),
         exc=ConfigurationTypeError, names="''"),
    Case(id="kernel-analog-out-channel-huge", call=lambda: cpu().analog_out(2**70), exc=ConfigurationError,
         names=str(2**70)),
    Case(id="kernel-analog-in-channel-huge", call=lambda: cpu().analog_in(65536), exc=ConfigurationError,
         names="65536"),
    Case(id="kernel-body-returns-value", call=lambda: run_task(_returns(5)), exc=ConfigurationTypeError,
         names="returned 5"),
    Case(id="kernel-body-returns-generator", call=lambda: run_task(_returns(i for i in ())),
         exc=ConfigurationTypeError, names="it returned a generator"),
    Case(id="kernel-yield-bare-int", call=_bare_int_names_the_task, exc=ConfigurationTypeError,
         names="yielded 5"),
]
