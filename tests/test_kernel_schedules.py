"""Schedules against hand-derived timelines and response-time analysis."""

import math

import numpy as np
import pytest
from conftest import executes

from netcosim import Simulation
from netcosim.testing import assert_schedule, running_intervals


def run_taskset(tasks, policy, until, **node_kw):
    """tasks: list of (C, T) or (C, T, D); priorities by list order (1 = highest)."""
    sim = Simulation(seed=0)
    cpu = sim.node("cpu", scheduler=policy, **node_kw)
    for i, spec in enumerate(tasks, start=1):
        C, T = spec[0], spec[1]
        D = spec[2] if len(spec) > 2 else None
        cpu.periodic(executes(C), period=T, deadline=D, priority=i, name=f"t{i}")
    sim.run(until=until)
    return sim, sim.trace.jobs()


def timeline(jobs):
    return [(r.task, int(r.job), r.start, r.finish) for r in jobs.itertuples() if not math.isnan(r.finish)]


def test_edf_c123_t468_no_miss_over_hyperperiod():
    # EDF tie rule: equal absolute deadlines are served in release order and never preempt.
    sim, jobs = run_taskset([(1, 4), (2, 6), (3, 8)], "edf", until=24)
    done = jobs[jobs["finish"].notna()]
    assert not done["deadline_miss"].any()
    assert len(done) == 13  # 6 + 4 + 3 jobs released before 24
    assert timeline(done) == [
        ("t1", 0, 0, 1), ("t2", 0, 1, 3), ("t3", 0, 3, 6), ("t1", 1, 6, 7), ("t2", 1, 7, 9),
        ("t1", 2, 9, 10), ("t3", 1, 10, 13), ("t1", 3, 13, 14), ("t2", 2, 14, 16),
        ("t1", 4, 16, 17), ("t3", 2, 17, 20), ("t2", 3, 20, 22), ("t1", 5, 22, 23)]
    assert_schedule(sim.trace.schedule(), {
        "t1": [(0, 1), (6, 7), (9, 10), (13, 14), (16, 17), (22, 23)],
        "t2": [(1, 3), (7, 9), (14, 16), (20, 22)],
        "t3": [(3, 6), (10, 13), (17, 20)]}, t_range=(0, 24))


def test_rate_monotonic_t3_misses_first_deadline_at_8():
    sim, jobs = run_taskset([(1, 4), (2, 6), (3, 8)], "rate_monotonic", until=24)
    misses = jobs[jobs["deadline_miss"]].sort_values("deadline")
    first = misses.iloc[0]
    assert (first["task"], first["job"], first["deadline"], first["finish"]) == ("t3", 0, 8.0, 10.0)
    # hand-derived: t1 0-1, t2 1-3, t3 3-4, t1 4-5, t3 5-6, t2 6-8, t1 8-9, t3 9-10
    t3 = jobs[(jobs["task"] == "t3") & (jobs["job"] == 0)].iloc[0]
    assert t3["start"] == 3.0 and t3["response_time"] == 10.0
    assert_schedule(sim.trace.schedule(), {"t1": [(0, 1), (4, 5), (8, 9)], "t2": [(1, 3), (6, 8)],
                                           "t3": [(3, 4), (5, 6), (9, 10)]}, t_range=(0, 10))


def test_assert_schedule_names_the_task_and_the_interval_that_differ():
    sim, _ = run_taskset([(1, 4), (2, 6), (3, 8)], "rate_monotonic", until=10)
    assert running_intervals(sim.trace.schedule(), until=10)["t1"] == [(0, 1), (4, 5), (8, 9)]
    with pytest.raises(AssertionError, match=r"task 't3' ran in \[\(3.0, 4.0\), \(5.0, 6.0\), \(9.0, 10.0\)\], "
                                             r"expected \[\(3.0, 6.0\)\].*interval 0"):
        assert_schedule(sim.trace.schedule(), {"t3": [(3, 6)]}, t_range=(0, 10))


def rta(tasks):
    """Exact response-time analysis for fixed priorities (list order = priority)."""
    out = []
    for i, spec in enumerate(tasks):
        C = spec[0]
        R = C
        while True:
            Rn = C + sum(math.ceil(R / hp[1]) * hp[0] for hp in tasks[:i])
            if Rn == R:
                break
            R = Rn
            if R > 100 * spec[1]:
                R = math.inf
                break
        out.append(R)
    return out


TEXTBOOK_SETS = [
    # Buttazzo, Hard Real-Time Computing Systems, RM example
    [(1, 4), (2, 6), (3, 10)],
    # Liu & Layland style, larger numbers
    [(20, 100), (40, 150), (100, 350)],
    # deadline-monotonic with D < T (Audsley et al.)
    [(1, 10, 3), (2, 6, 5), (3, 20, 12), (2, 15, 15)],
    # high utilisation, four tasks
    [(1, 5), (2, 8), (3, 14), (1, 30)],
]


@pytest.mark.parametrize("tasks", TEXTBOOK_SETS)
def test_critical_instant_matches_response_time_analysis(tasks):
    policy = "deadline_monotonic" if any(len(t) == 3 for t in tasks) else "rate_monotonic"
    # order by the policy's priority for the analysis
    order = sorted(tasks, key=lambda t: t[2] if len(t) == 3 else t[1])
    expected = rta(order)
    hyper = np.lcm.reduce([t[1] for t in tasks])
    sim, jobs = run_taskset(order, policy, until=float(hyper))
    for i, R in enumerate(expected, start=1):
        worst = jobs[jobs["task"] == f"t{i}"]["response_time"].max()
        first = jobs[(jobs["task"] == f"t{i}") & (jobs["job"] == 0)]["response_time"].iloc[0]
        assert first == pytest.approx(R, abs=1e-12)  # the critical instant gives the worst case
        assert worst == pytest.approx(R, abs=1e-12)


def test_equal_priority_is_fifo_and_does_not_preempt():
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="fixed_priority")
    log = []

    def make(name, C):
        def body(ctx):
            log.append((name, ctx.now))
            yield ctx.execute(C)
        return body
    a = cpu.aperiodic(make("a", 2.0), priority=5, name="a")
    b = cpu.aperiodic(make("b", 1.0), priority=5, name="b")
    sim.call_at(0, a.release)
    sim.call_at(0.5, b.release)
    sim.run(until=5)
    assert log == [("a", 0.0), ("b", 2.0)]


def test_handlers_beat_tasks_and_nonpreemptible_tasks():
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="fixed_priority")
    order = []

    def low(ctx):
        order.append(("low", ctx.now))
        yield ctx.execute(3.0)
        order.append(("low-done", ctx.now))

    def high(ctx):
        order.append(("high", ctx.now))
        yield ctx.execute(1.0)

    def irq(ctx):
        order.append(("irq", ctx.now))
        yield ctx.execute(0.5)
    lo = cpu.aperiodic(low, priority=10, preemptible=False, name="low")
    hi = cpu.aperiodic(high, priority=1, name="high")
    h = cpu.handler(irq, priority=100)  # numerically "low", still beats every task
    sim.call_at(0, lo.release)
    sim.call_at(1.0, hi.release)
    sim.call_at(1.0, h.release)
    sim.run(until=10)
    # the handler preempts the non-preemptible task; the high task must wait for it
    assert order == [("low", 0.0), ("irq", 1.0), ("low-done", 3.5), ("high", 3.5)]


def test_job_queueing_and_skip():
    for on_busy, expect in (("queue", [0.0, 3.0, 6.0, 9.0]), ("skip", [0.0, 4.0, 8.0])):
        sim = Simulation()
        cpu = sim.node("cpu")
        starts = []

        def body(ctx):
            starts.append(ctx.now)
            yield ctx.execute(3.0)
        cpu.periodic(body, period=2.0, priority=1, on_busy=on_busy, name="t")
        sim.run(until=10.5)
        assert starts == expect, on_busy
        jobs = sim.trace.jobs()
        if on_busy == "queue":
            # each queued job keeps its own release time; response grows by 1 s per job
            done = jobs[jobs["finish"].notna()]
            assert done["response_time"].tolist() == [3.0, 4.0, 5.0]
        else:
            assert cpu.tasks["t"].skipped == 3  # releases at 2, 6 and 10 dropped (busy)


def test_periodic_release_has_no_drift():
    sim = Simulation()
    cpu = sim.node("cpu")
    rel = []

    def body(ctx):
        rel.append(ctx.job.release)
        yield ctx.execute(0.0)
    cpu.periodic(body, period=0.1, offset=0.05, priority=1)
    sim.run(until=1000.0)
    # release k is exactly offset + k*period on the picosecond grid (no accumulation)
    assert rel[9999] == 50_000_000_000 + 9999 * 100_000_000_000
    assert len(rel) == 10000


def test_timers_and_triggers_release_handlers():
    sim = Simulation()
    cpu = sim.node("cpu")
    hits = []

    def irq(ctx):
        hits.append(("irq", ctx.now))
        yield ctx.execute(0.1)

    def tick(ctx):
        hits.append(("tick", ctx.now))
        yield ctx.execute(0.0)
    h = cpu.handler(irq, priority=1, name="irq")
    tk = cpu.handler(tick, priority=2, name="tick")
    cpu.timer(tk, at=0.5, period=1.0)
    trig = cpu.trigger(h, min_interval=0.3)
    for t in (0.2, 0.4, 0.6, 0.65, 1.0):
        sim.call_at(t, trig.fire)
    sim.run(until=2.6)
    assert hits == [("irq", 0.2), ("tick", 0.5), ("irq", 0.6), ("irq", 1.0), ("tick", 1.5), ("tick", 2.5)]
    assert trig.ignored == 2  # 0.4 and 0.65 came too soon after an accepted edge
