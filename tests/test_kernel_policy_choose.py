"""The policy seam ``SchedulingPolicy.choose(ready, core)``: a policy that overrides it
picks the job to run among the ready ones; the key rule stays the default."""

import pandas as pd
import pytest
from test_kernel_release_groups import build

from netcosim import Simulation
from netcosim.kernel import EDF, FixedPriority
from netcosim.kernel.policies import own_choose


class LastInFirstOut(FixedPriority):
    """Non-preemptive: when the CPU is free, the job activated last runs (handlers first)."""

    name = "lifo"

    def choose(self, ready, core):
        return None if core.running is not None else max(ready, key=lambda job: (-job.cls, job.seq))


def _tables(sim):
    return {name: sim.trace.frame(name) for name in ("schedule", "jobs")}


def test_only_a_policy_with_its_own_choose_is_asked():
    assert own_choose(FixedPriority()) is None and own_choose(EDF()) is None
    p = LastInFirstOut()
    assert own_choose(p) == p.choose


@pytest.mark.parametrize("seed", range(12))
def test_the_default_choose_called_gives_the_inlined_schedule(seed, monkeypatch):
    """Random task sets (fixed priority and EDF, context switches, messages, deadline kills):
    the default ``choose`` called at every dispatch gives the tables of the inlined rule."""
    inlined = build(seed)
    inlined.run(until=0.03)
    calls = []

    def counted(policy):
        def choose(ready, core):
            calls.append(core.name)
            return policy.choose(ready, core)
        return choose
    monkeypatch.setattr("netcosim.kernel.node.own_choose", counted)
    called = build(seed)
    called.run(until=0.03)
    assert len(calls) > 10
    for name, df in _tables(inlined).items():
        pd.testing.assert_frame_equal(_tables(called)[name], df, check_exact=True)


def _handlers_and_non_preemptible(scheduler):
    """A handler interrupting a non-preemptible task, a sleeper, EDF or fixed priority, switches."""
    sim = Simulation()
    cpu = sim.node("cpu", scheduler=scheduler, context_switch=1e-5)

    @cpu.handler(priority=1, name="irq")
    def irq(ctx):
        yield ctx.execute(2e-4)
    cpu.timer(irq, at=0.0013, period=0.0031)

    @cpu.periodic(period=0.004, priority=3, preemptible=False, name="np")
    def np_task(ctx):
        yield ctx.execute(0.0015)

    @cpu.periodic(period=0.002, priority=1, name="fast")
    def fast(ctx):
        yield ctx.execute(3e-4)
        yield ctx.sleep(1e-4)
        yield ctx.execute(1e-4)

    @cpu.periodic(period=0.005, priority=2, name="slow", deadline=0.004)
    def slow(ctx):
        yield ctx.execute(0.001)
    return sim


@pytest.mark.parametrize("scheduler", ["fixed_priority", "edf"])
def test_the_default_choose_keeps_the_kernel_rules_for_handlers_and_non_preemptible_tasks(scheduler, monkeypatch):
    inlined = _handlers_and_non_preemptible(scheduler)
    inlined.run(until=0.05)
    monkeypatch.setattr("netcosim.kernel.node.own_choose", lambda policy: policy.choose)
    called = _handlers_and_non_preemptible(scheduler)
    assert called.nodes["cpu"]._dispatch == called.nodes["cpu"]._dispatch_chosen
    called.run(until=0.05)
    for name, df in _tables(inlined).items():
        pd.testing.assert_frame_equal(_tables(called)[name], df, check_exact=True)


def test_a_choosing_policy_runs_the_last_activated_job_without_preemption():
    sim = Simulation()
    cpu = sim.node("cpu", scheduler=LastInFirstOut())

    def body(ctx):
        yield ctx.execute(0.001)
    for i, offset in enumerate([0.0, 0.0, 0.0, 0.0005]):
        cpu.periodic(body, period=0.01, offset=offset, priority=i, name=f"t{i}")
    sim.run(until=0.005)
    jobs = sim.trace.jobs()
    # at 0: t2 (activated last) runs; t3 arrives at 0.5 ms but does not preempt; at 1 ms t3, then t1, t0
    assert list(jobs.sort_values("start").task) == ["t2", "t3", "t1", "t0"]
    assert list(jobs.sort_values("start").start.round(9)) == [0.0, 0.001, 0.002, 0.003]


def test_a_choice_outside_the_ready_queue_is_refused():
    class Bad(FixedPriority):
        def choose(self, ready, core):
            return core.tasks["a"].active if core.running is None else None

    sim = Simulation()
    cpu = sim.node("cpu", scheduler=Bad())

    @cpu.periodic(period=0.01, priority=1, name="a")
    def a(ctx):
        yield ctx.sleep(0.001)
        yield ctx.execute(0.001)

    @cpu.periodic(period=0.01, priority=2, name="b")
    def b(ctx):
        yield ctx.execute(0.002)
    with pytest.raises(RuntimeError, match="not in the ready queue"):
        sim.run(until=0.01)
