"""Context-switch overhead, CPU speed, overrun handling, bad input, determinism."""


import numpy as np
import pandas as pd
import pytest
from conftest import executes
from scipy import stats

from netcosim import Simulation


def two_tasks(cs=0.0, speed=1.0):
    """H: C=1, released at 1; L: C=3, released at 0 (fixed priority)."""
    sim = Simulation()
    cpu = sim.node("cpu", context_switch=cs, speed=speed)

    H = cpu.aperiodic(executes(1.0), priority=1, name="H")
    L = cpu.aperiodic(executes(3.0), priority=2, name="L")
    sim.call_at(0, L.release)
    sim.call_at(1.0, H.release)
    sim.run(until=20)
    return sim.trace.jobs().set_index("task")


def test_context_switch_overhead_adds_exactly_one_switch_per_switch_in():
    base = two_tasks()
    assert base.loc["H", "response_time"] == 1.0 and base.loc["L", "response_time"] == 4.0
    cs = 0.1
    j = two_tasks(cs=cs)
    # L: switch 0-0.1, runs 0.1-1 (0.9 done); H: switch 1-1.1, runs 1.1-2.1;
    # L: switch 2.1-2.2, runs 2.2-4.3.  H pays one switch, L three (its own two plus H's).
    assert j.loc["H", "response_time"] == pytest.approx(1.0 + cs, abs=1e-12)
    assert j.loc["L", "response_time"] == pytest.approx(4.0 + 3 * cs, abs=1e-12)
    assert j.loc["H", "start"] == pytest.approx(1.1, abs=1e-12)


def test_cpu_speed_scales_execution_and_switch_times():
    j = two_tasks(speed=2.0)
    # L needs 1.5 s at speed 2: runs 0-1, H runs 1-1.5, L resumes 1.5-2.0
    assert j.loc["H", "response_time"] == 0.5
    assert j.loc["L", "response_time"] == 2.0
    assert j.loc["L", "execution_time"] == 1.5
    j = two_tasks(cs=0.2, speed=2.0)  # each switch costs 0.1 s at speed 2
    assert j.loc["H", "response_time"] == pytest.approx(0.6, abs=1e-12)
    assert j.loc["L", "response_time"] == pytest.approx(2.3, abs=1e-12)


def test_deadline_overrun_handler_kills_late_jobs():
    sim = Simulation()
    cpu = sim.node("cpu")
    seen = []

    def body(ctx):
        yield ctx.execute(1.5 if ctx.job.index % 2 == 0 else 0.5)

    def on_miss(job):
        seen.append((job.index, job.node.sim.now))
        job.kill()
    cpu.periodic(body, period=1.0, priority=1, on_deadline_miss=on_miss, name="t")
    sim.run(until=4.0)
    jobs = sim.trace.jobs()
    assert seen == [(0, 1.0), (2, 3.0)]
    killed = jobs[jobs["killed"]]
    assert killed["job"].tolist() == [0, 2] and killed["deadline_miss"].all()
    ok = jobs[~jobs["killed"] & jobs["finish"].notna()]
    assert ok["job"].tolist() == [1, 3] and ok["response_time"].tolist() == [0.5, 0.5]


def test_budget_overrun_detected_at_wcet():
    sim = Simulation()
    cpu = sim.node("cpu")
    hits = []

    def body(ctx):
        yield ctx.execute(0.3)
        yield ctx.execute(0.4)
    cpu.periodic(body, period=1.0, wcet=0.5, priority=1, name="t",
                 on_budget_overrun=lambda job: hits.append(job.node.sim.now))
    sim.run(until=2.5)
    assert hits == pytest.approx([0.5, 1.5], abs=1e-12)
    jobs = sim.trace.jobs()
    assert jobs["budget_overrun"].tolist() == [True, True, False]  # job 2 has used 0.5 s at 2.5
    assert jobs[jobs["finish"].notna()]["response_time"].tolist() == pytest.approx([0.7, 0.7])


def test_unfinished_jobs_are_reported_with_nan_finish():
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(10.0)
    cpu.periodic(body, period=4.0, priority=1, name="t")
    sim.run(until=9.0)
    jobs = sim.trace.jobs()
    assert len(jobs) == 3
    assert jobs["finish"].isna().all()
    assert jobs["deadline_miss"].tolist() == [True, True, False]  # deadlines 4, 8, 12
    assert jobs["execution_time"].tolist() == [9.0, 0.0, 0.0]


@pytest.mark.parametrize("make, match", [
    (lambda cpu: cpu.periodic(lambda ctx: None, period=-1.0, priority=1), "period.*-1.0"),
    (lambda cpu: cpu.periodic(lambda ctx: None, period=0.0, priority=1), "period.*0.0"),
    (lambda cpu: cpu.periodic(lambda ctx: None, period=float("nan"), priority=1), "period.*nan"),
    (lambda cpu: cpu.periodic(lambda ctx: None, period=1.0, priority="high"), "priority.*'high'"),
    (lambda cpu: cpu.periodic(lambda ctx: None, period=1.0), "priority.*None"),
    (lambda cpu: cpu.periodic(lambda ctx: None, period=1.0, priority=1, on_busy="drop"), "on_busy.*'drop'"),
    (lambda cpu: cpu.aperiodic(lambda ctx: None, priority=True), "priority.*True"),
])
def test_bad_task_parameters_name_the_value(make, match):
    sim = Simulation()
    cpu = sim.node("cpu")
    with pytest.raises((ValueError, TypeError), match=match):
        make(cpu)


def test_bad_node_and_simulation_parameters():
    with pytest.raises(ValueError, match="'lottery'"):
        Simulation().node("a", scheduler="lottery")
    with pytest.raises(ValueError, match="speed.*-2"):
        Simulation().node("a", speed=-2)
    with pytest.raises(ValueError, match="context_switch.*-1e-06"):
        Simulation().node("a", context_switch=-1e-6)
    with pytest.raises(ValueError, match="seed.*-3"):
        Simulation(seed=-3)
    sim = Simulation()
    sim.node("a")
    with pytest.raises(ValueError, match="'a' already exists"):
        sim.node("a")


def test_negative_execution_time_raises_inside_run():
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(-0.001)
    cpu.periodic(body, period=1.0, priority=1, name="bad")
    with pytest.raises(ValueError, match="-0.001"):
        sim.run(until=2.0)


def test_unconnected_analog_channel_raises():
    from netcosim import NotConnectedError
    sim = Simulation()
    cpu = sim.node("ctrl")
    ain = cpu.analog_in(3)

    def body(ctx):
        ctx.read(ain)
        yield ctx.execute(0.1)
    cpu.periodic(body, period=1.0, priority=1)
    with pytest.raises(NotConnectedError, match="analog input 3 of node 'ctrl'"):
        sim.run(until=1.0)


def test_yielding_garbage_raises_clear_error():
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield "soon"
    cpu.periodic(body, period=1.0, priority=1, name="junk")
    with pytest.raises(TypeError, match="'junk'.*yielded 'soon'"):
        sim.run(until=1.0)


def random_run(seed):
    sim = Simulation(seed=seed)
    cpu = sim.node("cpu", scheduler="edf", context_switch=1e-5)
    for i, T in enumerate((0.01, 0.015, 0.02)):
        dist = stats.uniform(loc=0.001, scale=0.004)

        def body(ctx, dist=dist):
            yield ctx.execute(dist)
            ctx.log("noise", ctx.rng.normal())
        cpu.periodic(body, period=T, name=f"t{i}")
    sim.run(until=2.0)
    return sim.trace.jobs(), sim.trace.schedule(), sim.trace.signals()


def test_same_seed_identical_dataframes_different_seed_differs():
    a, b, c = random_run(7), random_run(7), random_run(8)
    for x, y in zip(a, b):
        pd.testing.assert_frame_equal(x, y)
    assert not a[0]["execution_time"].equals(c[0]["execution_time"])


def test_named_streams_are_independent_of_other_components():
    s1 = Simulation(seed=3)
    x = s1.rng("radio").normal(size=5)
    s2 = Simulation(seed=3)
    s2.rng("another-component").normal(size=100)
    y = s2.rng("radio").normal(size=5)
    np.testing.assert_array_equal(x, y)


def test_execution_time_from_callable_distribution():
    sim = Simulation(seed=1)
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(lambda rng: rng.uniform(0.1, 0.2))
    cpu.periodic(body, period=1.0, priority=1, name="t")
    sim.run(until=50)
    e = sim.trace.jobs()["execution_time"]
    assert 0.1 <= e.min() and e.max() <= 0.2 and e.std() > 0.01


def test_killing_a_queued_job_records_it_and_keeps_the_queue():
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(3.0)
    t = cpu.periodic(body, period=1.0, priority=1, name="t")
    sim.call_at(2.5, lambda: t.pending[0].kill())  # job 1 (released at 1) is queued
    sim.run(until=6.5)
    df = sim.trace.jobs()
    killed = df[df["killed"]]
    assert killed["job"].tolist() == [1] and killed["finish"].isna().all()
    done = df[df["finish"].notna() & ~df["killed"]]
    assert done["job"].tolist() == [0, 2] and done["finish"].tolist() == [3.0, 6.0]
