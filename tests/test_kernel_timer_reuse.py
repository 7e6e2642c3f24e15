"""The kernel re-arms the timers that fired (a task's release timer, a node's segment
timer) instead of creating new ones; these cases pin what that must not change."""

from __future__ import annotations

import pytest

from netcosim import Simulation


def test_a_task_stopped_by_its_own_job_releases_no_further_job():
    sim = Simulation()
    cpu = sim.node("cpu")
    released = []

    @cpu.periodic(period=0.01, priority=1)
    def loop(ctx):
        released.append(round(ctx.now, 9))
        if len(released) == 3:
            ctx.task.stop()  # the release timer was re-armed for 0.03 s just before
        yield ctx.execute(0.002)

    sim.run(until=0.1)
    assert released == [0.0, 0.01, 0.02]
    assert loop.jobs_released == loop.finished == 3


def test_preempted_segments_keep_their_own_end_times():
    # a cancelled (preempted) segment timer stays in SimPy's queue: it must never be
    # re-armed for another segment, or the low task would end early
    sim = Simulation()
    cpu = sim.node("cpu")

    @cpu.periodic(period=0.004, priority=1, name="high")
    def high(ctx):
        yield ctx.execute(0.001)

    @cpu.periodic(period=0.012, priority=2, name="low")
    def low(ctx):
        yield ctx.execute(0.005)
        yield ctx.execute(0.001)

    sim.run(until=0.012)
    jobs = sim.trace.jobs()
    low_job = jobs[jobs.task == "low"].iloc[0]
    # low runs 1-4 and 5-8 ms around high's jobs at 0 and 4 ms: its 6 ms of CPU end at 8 ms
    assert low_job.finish == pytest.approx(0.008, abs=1e-12)
    assert low_job.execution_time == pytest.approx(0.006, abs=1e-12)
    assert list(jobs[jobs.task == "high"].finish.round(9)) == [0.001, 0.005, 0.009]


def test_a_body_that_returns_a_value_finishes_its_job():
    sim = Simulation()
    cpu = sim.node("cpu")

    @cpu.periodic(period=0.01, priority=1)
    def loop(ctx):
        yield ctx.execute(0.001)
        return 42  # a generator's return value ends the job like a bare return

    sim.run(until=0.035)
    jobs = sim.trace.jobs()
    assert list(jobs.finish.round(9)) == [0.001, 0.011, 0.021, 0.031]
