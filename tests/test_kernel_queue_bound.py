"""The bound on a task's queued jobs: an overloaded task drops (counted, a warning the
first time) or raises, as asked; its queue never holds more than ``max_pending`` jobs."""

from __future__ import annotations

import warnings

import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError, OverloadError, OverloadWarning
from netcosim.kernel.task import DEFAULT_MAX_PENDING


def overloaded(**kw):
    sim = Simulation()
    node = sim.node("cpu")

    @node.periodic(period=1e-6, priority=1, name="hog", **kw)   # 1 us period, 10 ms body
    def hog(ctx):
        yield ctx.execute(0.010)
    return sim, hog


def test_an_overloaded_task_keeps_at_most_max_pending_jobs_and_counts_the_rest():
    sim, hog = overloaded(max_pending=100)
    with pytest.warns(OverloadWarning, match=r"task cpu\.hog: 100 jobs already queued .* dropped and counted"):
        sim.run(until=0.001)
    # 1000 releases in [0, 1 ms): one active, 100 queued, 899 dropped
    assert hog.jobs_released == 1000 and len(hog.pending) == 100 and hog.dropped == 899
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # the warning comes once per task
        sim.run(until=0.002)
    assert hog.dropped == 1899 and len(hog.pending) == 100


def test_on_queue_full_error_stops_the_run_naming_the_task():
    sim, hog = overloaded(max_pending=10, on_queue_full="error")
    with pytest.raises(OverloadError, match=r"task cpu\.hog: 10 jobs already queued .* t = 1.1e-05 s"):
        sim.run(until=0.001)


def test_the_default_bound_and_truetime_unbounded_queue():
    sim, hog = overloaded()
    assert hog.max_pending == DEFAULT_MAX_PENDING == 10_000
    sim2, hog2 = overloaded(max_pending=None)
    sim2.run(until=0.02)            # TrueTime: every release queued
    assert hog2.dropped == 0 and len(hog2.pending) == 20_001 - 3     # 2 jobs done, 1 running
    with pytest.raises(ConfigurationError, match="max_pending"):
        overloaded(max_pending=0)
    with pytest.raises(ConfigurationError, match="on_queue_full"):
        overloaded(on_queue_full="wait")
