"""Bandwidth servers under EDF (netcosim.kernel.servers): CBS schedules hand-computed from
the Abeni-Buttazzo rules (soft and hard), TBS deadlines from the formula, isolation."""

from __future__ import annotations

import numpy as np
import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.testing import running_intervals

MS = 1e-3


def _cbs_scenario(hard: bool):
    """EDF: t1 periodic (T = 4 ms, C = 1 ms) and one 5 ms job at t = 0 served by a CBS with
    Qs = 2 ms, Ts = 5 ms."""
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="edf")
    s = cpu.cbs(budget=2 * MS, period=5 * MS, hard=hard, name="s")

    @cpu.periodic(period=4 * MS, name="t1")
    def t1(ctx):
        yield ctx.execute(1 * MS)

    @cpu.aperiodic(name="srv", server=s)
    def srv(ctx):
        yield ctx.execute(5 * MS)

    sim.call_at(0.0, srv.release)
    sim.run(16 * MS)
    return sim, s


def _ms(intervals):
    return [(round(a / MS, 9), round(b / MS, 9)) for a, b in intervals]


def test_soft_cbs_schedule_by_hand():
    # t=0: recharge ds=5, cs=2; t1 (d=4) runs [0,1]; srv [1,3] exhausts: ds=10, cs=2;
    # srv [3,4]; t1 (d=8 < 10) preempts [4,5]; srv [5,6] exhausts (cs 1 left at 4): ds=15;
    # srv [6,7] ends (5 ms in all).
    sim, s = _cbs_scenario(hard=False)
    sched = sim.trace.schedule()
    assert _ms(running_intervals(sched, node="cpu")["srv"]) == [(1, 4), (5, 7)]
    assert _ms(running_intervals(sched, node="cpu")["t1"]) == [(0, 1), (4, 5), (8, 9), (12, 13)]
    ev = sim.trace.frame("servers")
    assert list(ev.event) == ["recharged", "exhausted", "postponed", "exhausted", "postponed"]
    assert np.allclose(ev.time / MS, [0, 3, 3, 6, 6]) and np.allclose(ev.deadline / MS, [5, 5, 10, 10, 15])
    assert s.exhaustions == 2 and s.recharges == 1 and s.deadline == pytest.approx(15 * MS)
    assert s.budget == pytest.approx(1 * MS)      # 1 ms of the last budget (from 6) used by [6,7]


def test_hard_cbs_schedule_by_hand():
    # t=0: ds=5, cs=2; t1 [0,1]; srv [1,3] exhausts: throttled until 5 (CPU idle [3,4]);
    # t1 [4,5]; t=5 replenished ds=10; srv [5,7] exhausts: throttled until 10; t1 [8,9];
    # t=10 replenished ds=15; srv [10,11] ends.
    sim, s = _cbs_scenario(hard=True)
    sched = sim.trace.schedule()
    assert _ms(running_intervals(sched, node="cpu")["srv"]) == [(1, 3), (5, 7), (10, 11)]
    jobs = sim.trace.jobs().set_index("task")
    assert jobs.loc["srv", "finish"] == pytest.approx(11 * MS, abs=1e-15)
    ev = sim.trace.frame("servers")
    assert list(ev.event) == ["recharged", "exhausted", "throttled", "replenished", "exhausted", "throttled",
                              "replenished"]
    assert np.allclose(ev.time / MS, [0, 3, 3, 5, 7, 7, 10])
    assert np.allclose(ev.deadline / MS, [5, 5, 5, 10, 10, 10, 15])
    assert not s.throttled and s.exhaustions == 2
    # the server waits for budget as a ready task (not blocked)
    srv_states = sched[sched.task == "srv"]
    assert list(srv_states.state) == ["ready", "running", "ready", "running", "ready", "running", "idle"]


def test_the_arrival_rule_keeps_a_deadline_that_still_has_budget():
    # CBS Qs = 2, Ts = 10 (ms), 1 ms jobs.  At 0: recharge, ds = 10, cs = 2 (1 left at 1).
    # At 2 (server idle): cs*Ts = 10 < (ds - r)*Qs = 16 -> no recharge, ds = 10, cs = 1;
    # the job exhausts the budget at 3: postponed, ds = 20, cs = 2 (1 left at 4).
    # At 18: cs*Ts = 10 >= (20 - 18)*2 = 4 -> recharge, ds = 28.
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="edf")
    s = cpu.cbs(budget=2 * MS, period=10 * MS)

    @cpu.aperiodic(name="a", server=s)
    def a(ctx):
        yield ctx.execute(1 * MS)

    for t in (0.0, 2 * MS, 18 * MS):
        sim.call_at(t, a.release)
    sim.run(30 * MS)
    ev = sim.trace.frame("servers")
    assert list(ev.event) == ["recharged", "exhausted", "postponed", "recharged"]
    assert np.allclose(ev.time / MS, [0, 3, 3, 18]) and np.allclose(ev.deadline / MS, [10, 10, 20, 28])
    assert s.recharges == 2 and s.exhaustions == 1


def test_tbs_deadlines_follow_the_formula():
    # Us = 0.25, wcet 1 ms: C/Us = 4 ms.  Arrivals 0, 1, 10 ms: d = 4, max(4,1)+4 = 8, max(8,10)+4 = 14
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="edf")
    s = cpu.tbs(utilization=0.25, name="tbs")

    @cpu.aperiodic(name="a", wcet=1 * MS, server=s)
    def a(ctx):
        yield ctx.execute(0.5 * MS)

    @cpu.aperiodic(name="b", wcet=1 * MS, server=s)
    def b(ctx):
        yield ctx.execute(0.5 * MS)

    sim.call_at(0.0, a.release)
    sim.call_at(1 * MS, b.release)
    sim.call_at(10 * MS, a.release)
    sim.run(20 * MS)
    ev = sim.trace.frame("servers")
    assert list(ev.event) == ["deadline"] * 3
    assert np.allclose(ev.deadline / MS, [4, 8, 14], rtol=0, atol=1e-12) and ev.budget.isna().all()
    assert s.deadline == pytest.approx(14 * MS)


def test_tbs_deadline_orders_the_served_job_against_others():
    # TBS Us = 0.5, wcet 2 ms -> d = 4 ms for a job at 0; a periodic task with deadline 3 ms runs first,
    # one with deadline 5 ms after it
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="edf")
    s = cpu.tbs(utilization=0.5)

    @cpu.aperiodic(name="served", wcet=2 * MS, server=s)
    def served(ctx):
        yield ctx.execute(1 * MS)

    for name, d in (("early", 3 * MS), ("late", 5 * MS)):
        @cpu.periodic(period=10 * MS, deadline=d, name=name)
        def body(ctx):
            yield ctx.execute(1 * MS)
    sim.call_at(0.0, served.release)
    sim.run(10 * MS)
    jobs = sim.trace.jobs().set_index("task")
    assert [round(jobs.loc[t, "start"] / MS, 9) for t in ("early", "served", "late")] == [0, 1, 2]


@pytest.mark.parametrize("hard", [False, True])
def test_a_cbs_isolates_an_overrunning_task(hard):
    """A task that overruns by far in a CBS (Qs = 1 ms, Ts = 4 ms: 25 %) next to two periodic
    tasks using 70 %: the others meet every deadline, the server never takes more than its
    bandwidth, and a hard server uses at most Qs in every server period."""
    sim = Simulation(seed=3)
    cpu = sim.node("cpu", scheduler="edf")
    s = cpu.cbs(budget=1 * MS, period=4 * MS, hard=hard)
    rng = np.random.default_rng(3)

    @cpu.periodic(period=4 * MS, name="hog", server=s)
    def hog(ctx):
        yield ctx.execute(float(rng.uniform(1, 6)) * MS)     # far beyond its 1 ms budget

    @cpu.periodic(period=5 * MS, name="a")
    def a(ctx):
        yield ctx.execute(2 * MS)

    @cpu.periodic(period=10 * MS, name="b")
    def b(ctx):
        yield ctx.execute(3 * MS)

    sim.run(2.0)
    jobs = sim.trace.jobs()
    others = jobs[jobs.task.isin(["a", "b"])]
    assert len(others) == 400 + 200 and not others.deadline_miss.any()
    hog_run = running_intervals(sim.trace.schedule(), node="cpu", until=2.0)["hog"]
    used = sum(e - b for b, e in hog_run)
    if hard:
        assert used <= 2.0 * 0.25 + 1e-9                        # never more than its bandwidth
        # in every server period [ds - Ts, ds] the hard server runs at most Qs
        ev = sim.trace.frame("servers")
        for d in ev.deadline.unique():
            lo, hi = d - 4 * MS, d
            inside = sum(max(0.0, min(e, hi) - max(b, lo)) for b, e in hog_run)
            assert inside <= 1 * MS + 1e-12, (d, inside)
    else:
        # a soft server takes its 25 % and the CPU the others leave idle (30 %), no more
        assert 2.0 * 0.25 < used <= 2.0 * 0.3 + 1e-9


def test_servers_need_edf_and_valid_parameters():
    sim = Simulation()
    fp = sim.node("fp", scheduler="fixed_priority")
    with pytest.raises(ConfigurationError, match="EDF"):
        fp.cbs(budget=1 * MS, period=4 * MS)
    cpu = sim.node("cpu", scheduler="edf")
    with pytest.raises(ConfigurationError, match="budget=0.005 s exceeds period=0.004 s"):
        cpu.cbs(budget=5 * MS, period=4 * MS)
    with pytest.raises(ValueError, match="budget"):
        cpu.cbs(budget=float("nan"), period=4 * MS)
    with pytest.raises(ConfigurationError, match="utilization=1.5"):
        cpu.tbs(utilization=1.5)
    t = cpu.tbs(utilization=0.5, name="t")
    with pytest.raises(ConfigurationError, match="no wcet"):
        cpu.aperiodic(lambda ctx: iter(()), name="x", server=t)
    other = sim.node("other", scheduler="edf").cbs(budget=1 * MS, period=4 * MS)
    with pytest.raises(ConfigurationTypeError, match="server of this node"):
        cpu.aperiodic(lambda ctx: iter(()), name="y", server=other)
    c = cpu.cbs(budget=1 * MS, period=4 * MS, name="c")
    with pytest.raises(ConfigurationError, match="non-preemptible"):
        cpu.aperiodic(lambda ctx: iter(()), name="z", preemptible=False, server=c)
    with pytest.raises(ConfigurationError, match="already has a server called 'c'"):
        cpu.cbs(budget=1 * MS, period=4 * MS, name="c")


def test_a_node_without_servers_keeps_the_key_rule():
    sim = Simulation()
    cpu = sim.node("cpu", scheduler="edf")
    assert type(cpu.policy).__name__ == "EDF" and cpu._choose is None
    cpu.cbs(budget=1 * MS, period=4 * MS)
    assert type(cpu.policy).__name__ == "ServedEDF" and cpu._choose is not None
    assert cpu._dispatch_callbacks == [cpu._dispatch_chosen]
