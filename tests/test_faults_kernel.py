"""Kernel and simulation life cycle under faults: sub-resolution durations, failed runs,
plant failures, execute requests that were never yielded."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import periodic_task
from scipy import stats

from netcosim import RK4, ContinuousSystem, Simulation
from netcosim.errors import ConfigurationError, IntegrationError, SimulationFailedError, UnyieldedExecuteError

# 1. Durations below the time resolution -------------------------------------------


def test_sub_resolution_period_is_rejected_naming_value_task_and_resolution():
    cpu = Simulation().node("cpu")
    with pytest.raises(ConfigurationError) as info:
        cpu.periodic(lambda ctx: None, period=1e-13, priority=1, name="fast")
    msg = str(info.value)
    assert "1e-13" in msg and "1e-12" in msg and "'fast'" in msg


@pytest.mark.timeout(10)
def test_loop_of_sub_resolution_executes_raises_instead_of_hanging_at_one_instant():
    sim = Simulation()
    cpu = sim.node("cpu")

    def spin(ctx):
        while True:
            yield ctx.execute(1e-13)
    cpu.periodic(spin, period=1e-3, priority=1, name="spin")
    with pytest.raises(ConfigurationError) as info:
        sim.run(until=1e-3)
    msg = str(info.value)
    assert "1e-13" in msg and "1e-12" in msg and "'spin'" in msg
    assert sim.now == 0.0


@pytest.mark.timeout(10)
def test_execute_that_rounds_to_zero_ticks_at_the_node_speed_names_c_and_speed():
    def body(ctx):
        yield ctx.execute(1e-12)
    # at speed 1, 1 ps of CPU is exactly one tick
    sim = Simulation()
    sim.node("cpu").periodic(body, period=1e-3, priority=1, name="t")
    sim.run(until=0.5e-3)
    row = sim.trace.recorder("jobs").rows[0]
    assert (row[3], row[4], row[5]) == (0, 1, 1)  # start, finish, execution in ticks
    # at speed 3 it is 1/3 ps: below the resolution, rejected
    sim = Simulation()
    sim.node("cpu", speed=3.0).periodic(body, period=1e-3, priority=1, name="t")
    with pytest.raises(ConfigurationError) as info:
        sim.run(until=1e-3)
    msg = str(info.value)
    assert "1e-12" in msg and "speed 3.0" in msg and "'t'" in msg


@pytest.mark.timeout(10)
@pytest.mark.parametrize("draw", [lambda rng: 1e-13, stats.uniform(loc=1e-13, scale=1e-14)],
                         ids=["callable", "distribution"])
def test_sub_resolution_execution_time_drawn_at_run_time_is_rejected(draw):
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        while True:
            yield ctx.execute(draw)
    cpu.periodic(body, period=1e-3, priority=1, name="t")
    with pytest.raises(ConfigurationError, match=r"execution time 1(\.\d+)?e-13 s .*below the time resolution"):
        sim.run(until=1e-3)


def test_context_switch_that_rounds_to_zero_at_the_node_speed_is_rejected():
    with pytest.raises(ConfigurationError) as info:
        Simulation().node("cpu", context_switch=1e-12, speed=4.0)
    msg = str(info.value)
    assert "context_switch=1e-12" in msg and "speed 4.0" in msg


# 2. A failed simulation refuses to continue ---------------------------------------


def _failing_sim():
    """Task 'ctrl' (period 0.1 s, C = 0.01 s) raises in its job 2, at t = 0.21 s."""
    sim = Simulation()
    cpu = sim.node("cpu")

    def ctrl(ctx):
        yield ctx.execute(0.01)
        if ctx.job.index == 2:
            raise ZeroDivisionError("gain table empty")
    cpu.periodic(ctrl, period=0.1, priority=1, name="ctrl")
    return sim


def test_failed_run_raises_with_time_note_and_a_second_run_refuses_naming_the_failure():
    sim = _failing_sim()
    with pytest.raises(ZeroDivisionError) as info:
        sim.run(until=1.0)
    first = info.value
    assert "netcosim: run failed at t = 0.210000000 s" in first.__notes__
    assert sim.failure is first
    with pytest.raises(SimulationFailedError) as again:
        sim.run(until=2.0)
    msg = str(again.value)
    assert "t = 0.210000000 s" in msg and "ZeroDivisionError" in msg and "gain table empty" in msg
    assert "build a new Simulation" in msg
    assert again.value.__cause__ is first
    assert sim.now == pytest.approx(0.21)  # nothing advanced


def test_traces_of_a_failed_run_stay_readable():
    sim = _failing_sim()
    with pytest.raises(ZeroDivisionError):
        sim.run(until=1.0)
    with pytest.raises(SimulationFailedError):
        sim.run(until=2.0)
    jobs = sim.trace.jobs()
    assert jobs["job"].tolist() == [0, 1, 2]
    assert jobs["finish"].tolist()[:2] == pytest.approx([0.01, 0.11])
    assert np.isnan(jobs["finish"].iloc[2])
    assert jobs["execution_time"].tolist() == pytest.approx([0.01, 0.01, 0.01])
    sched = sim.trace.schedule()
    assert sched["time"].max() == pytest.approx(0.2)


# 3. A plant failure is raised once, with the time; the other plants follow -------


def _ramp(name, blow_up_after=None):
    """x' = 1 (x = t from x0 = 0); with *blow_up_after*, f is NaN for t > that time."""
    def f(t, x, u, p):
        if blow_up_after is not None and t > blow_up_after:
            return np.array([np.nan])
        return np.array([1.0])
    return ContinuousSystem(f=f, states=1, name=name)


@pytest.mark.parametrize("read_by_task", [True, False], ids=["inside-task-read", "at-end-of-run"])
def test_plant_failure_is_raised_once_with_time_and_other_plants_reach_the_failure_instant(read_by_task):
    sim = Simulation()
    # the failing plant is registered first, so its finalizer would run before the other's
    bad = sim.plant(_ramp("blowup", blow_up_after=0.25), [0.0], integrator=RK4(dt=1e-3))
    good = sim.plant(_ramp("steady"), [0.0], integrator=RK4(dt=1e-3))
    if read_by_task:
        cpu = sim.node("cpu")

        def sample(ctx):
            ctx.read(bad.outputs)
            yield ctx.execute(0.001)
        cpu.periodic(sample, period=0.1, priority=1, name="sample")
    with pytest.raises((FloatingPointError, IntegrationError)) as info:
        sim.run(until=0.3)
    exc = info.value
    assert "'blowup'" in str(exc)
    assert exc.__context__ is None  # not re-raised by a finalizer while handling the first
    assert "netcosim: run failed at t = 0.300000000 s" in exc.__notes__
    # the other plant is brought to the failure instant
    assert good.t == pytest.approx(0.3, abs=1e-15)
    assert good.x == pytest.approx([0.3], abs=1e-12)
    # the failed plant keeps its last finite state (x = t before the blow-up)
    assert bad.t <= 0.25 and np.all(np.isfinite(bad.x))
    assert bad.x == pytest.approx([bad.t], abs=1e-12)
    with pytest.raises(SimulationFailedError, match="'blowup'"):
        sim.run(until=0.4)


# 4. An execute request that was never yielded -------------------------------------


def test_unyielded_execute_in_a_plain_function_body_raises_naming_task_and_node():
    def ctl(ctx):
        ctx.execute(0.001)  # forgot yield; a plain function cannot even yield
    with pytest.raises(UnyieldedExecuteError) as info:
        periodic_task(ctl, period=0.1, name="ctl", until=0.05)
    msg = str(info.value)
    assert "'ctl'" in msg and "'cpu'" in msg and "execute(0.001)" in msg and "finished" in msg


def test_unyielded_execute_followed_by_a_blocking_yield_raises_after_correct_jobs():
    def ctl(ctx):
        yield ctx.execute(0.0)
        req = ctx.execute(0.002)  # a request may be yielded later in the same step
        ctx.log("between", 1.0)
        yield req
        if ctx.job.index == 1:
            ctx.execute(0.001)  # forgotten yield in job 1
        yield ctx.sleep(0.01)
    sim = Simulation()
    sim.node("cpu").periodic(ctl, period=0.1, priority=1, name="ctl")
    with pytest.raises(UnyieldedExecuteError, match=r"'ctl'.*job 1.*execute\(0\.001\).*yielded"):
        sim.run(until=0.3)
    jobs = sim.trace.jobs()
    assert jobs["execution_time"].tolist() == pytest.approx([0.002, 0.002])
    assert jobs["finish"].iloc[0] == pytest.approx(0.012)
    assert sim.now == pytest.approx(0.102)


def test_second_execute_before_the_first_was_yielded_raises_at_once():
    def ctl(ctx):
        ctx.execute(0.001)
        yield ctx.execute(0.002)
    with pytest.raises(UnyieldedExecuteError, match=r"'ctl'.*execute\(0\.001\).*execute\(0\.002\)"):
        periodic_task(ctl, period=0.1, name="ctl", until=0.05)
