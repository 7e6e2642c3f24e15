"""The release heap and its groups (netcosim.kernel.releases) give exactly the schedule of
one timer per task: random task sets with shared periods, offsets, deadline handlers,
stopped tasks, callbacks and messages scheduled between task creations, run both ways;
and releases that share an instant cost one SimPy event."""

import numpy as np
import pandas as pd
import pytest

from netcosim import Simulation
from netcosim.kernel import releases
from netcosim.network import IdealLink


def build(seed: int) -> Simulation:
    rng = np.random.default_rng(seed)
    sim = Simulation(seed=seed)
    nodes = [sim.node(f"n{i}", scheduler=rng.choice(["fixed_priority", "edf"]),
                      context_switch=float(rng.choice([0.0, 1e-5]))) for i in range(2)]
    net = IdealLink(sim, "link", data_rate=1e6)
    for n in nodes:
        net.attach(n)
    log = []
    periods = [0.002, 0.0033, 0.0047]    # releases of different periods seldom coincide
    n_tasks = int(rng.integers(8, 20))
    priorities = rng.permutation(n_tasks)
    k = 0
    node, T, offset = nodes[0], periods[0], 0.0
    for _ in range(n_tasks):
        if rng.random() < 0.5:          # often the same as the previous task: a group
            node = nodes[int(rng.integers(0, 2))]
            T = float(rng.choice(periods))
            offset = float(rng.integers(0, 10)) * 1e-4
        c = float(rng.uniform(0.02, 0.2)) * T / 3     # utilisation about 0.2-0.6 per node
        send = bool(rng.random() < 0.2)
        other = nodes[1] if node is nodes[0] else nodes[0]

        def body(ctx, c=c, send=send, other=other.name):
            yield ctx.execute(c)
            if send:
                ctx.send(other, (ctx.now,), 64)
            yield ctx.execute(c / 2)
        miss = None
        if rng.random() < 0.15:
            miss = "kill" if rng.random() < 0.5 else (lambda job: log.append(("miss", job.task.name, job.index)))
        deadline = T if rng.random() < 0.7 else T * 0.6
        task = node.periodic(body, period=T, offset=offset, priority=int(priorities[k]), deadline=deadline,
                             name=f"t{k}",
                             on_deadline_miss=miss)
        k += 1
        r = rng.random()
        if r < 0.1:     # something scheduled between two task creations
            sim.call_at(offset, lambda k=k: log.append(("call", k)))
        elif r < 0.2:
            sim.call_at(float(rng.choice([0.004, 0.006, 0.0065])), task.stop)
    return sim


def tables(sim: Simulation) -> dict[str, pd.DataFrame]:
    return {name: sim.trace.frame(name) for name in ("schedule", "jobs")}


@pytest.mark.parametrize("seed", [*range(48), *(pytest.param(s, marks=pytest.mark.slow) for s in range(48, 448))])
def test_grouped_release_timers_give_the_schedule_of_one_timer_per_task(seed, monkeypatch):
    grouped = build(seed)
    grouped.run(until=0.03)
    monkeypatch.setattr(releases, "GROUP_RELEASES", False)
    separate = build(seed)
    separate.run(until=0.03)
    for name, df in tables(separate).items():
        pd.testing.assert_frame_equal(tables(grouped)[name], df, check_exact=True)
    assert separate.trace.frame("frames").equals(grouped.trace.frame("frames"))


def test_consecutive_tasks_with_the_same_releases_share_one_timer():
    sim = Simulation()
    cpu = sim.node("cpu")
    a = [cpu.periodic(lambda ctx: None, period=0.01, priority=i, name=f"a{i}") for i in range(3)]
    b = cpu.periodic(lambda ctx: None, period=0.02, priority=5, name="b")          # another period
    c = [cpu.periodic(lambda ctx: None, period=0.01, priority=6 + i, name=f"c{i}") for i in range(2)]
    sim.call_at(0.0, lambda: None)                                                   # something between
    d = cpu.periodic(lambda ctx: None, period=0.01, priority=9, name="d")
    e = cpu.periodic(lambda ctx: None, period=0.01, priority=10, name="e", on_deadline_miss="kill")
    group = cpu._releases.group_of
    assert all(group(t) is group(a[0]) for t in a)
    assert group(a[0]).members == a
    assert group(b).members == [b] and group(c[0]) is group(c[1]) is not group(a[0])
    assert group(d).members == [d] and group(e).members == [e]  # not after the call_at; a deadline handler
    assert len(cpu._releases.heap) == 5                 # a, b, c, d, e: one entry per group
    assert sim.env.queued == 1 + 1                      # SimPy's queue: the heap's stand-in, the call
    a[1].stop()
    assert group(a[1]) is None and group(a[0]).members == [a[0], a[2]]
    sim.run(until=0.025)
    jobs = sim.trace.jobs()
    assert (jobs["task"] == "a1").sum() == 0 and (jobs["task"] == "a0").sum() == 3


def test_a_group_defers_the_dispatch_until_every_member_is_released(monkeypatch):
    """Nothing else happens at the release instants: the higher-priority task created
    second runs first, as with one timer each (ready lo, ready hi, running hi)."""
    def run():
        sim = Simulation()
        cpu = sim.node("cpu")

        def body(ctx):
            yield ctx.execute(0.001)
        cpu.periodic(body, period=0.01, priority=2, name="lo")
        cpu.periodic(body, period=0.01, priority=1, name="hi")
        sim.run(until=0.02)
        return sim.trace.frame("schedule")
    grouped = run()
    monkeypatch.setattr(releases, "GROUP_RELEASES", False)
    separate = run()
    pd.testing.assert_frame_equal(grouped, separate, check_exact=True)
    assert list(zip(grouped["task"], grouped["state"]))[:6] == [
        ("lo", "ready"), ("hi", "ready"), ("hi", "running"), ("hi", "idle"), ("lo", "running"), ("lo", "idle")]


def test_releases_sharing_an_instant_cost_one_event(monkeypatch):
    """Periods 2, 4 and 8 ms for 8 ms: 7 jobs released at 4 instants (0, 2, 4, 6 ms), each
    job one segment.  From the heap: 4 release events + 7 segment ends, and the dispatch
    at 0 and 4 ms done at once after the instant's last release.  One timer per task: 7
    release events + 7 segment ends + 2 dispatch events (a release while another timer is
    due at the same instant defers the dispatch).  The same schedule both ways."""
    from benchmarks.counters import _EventCount

    def run():
        sim = Simulation()
        cpu = sim.node("cpu")
        for p, T in enumerate((0.002, 0.004, 0.008), start=1):
            def body(ctx):
                yield ctx.execute(1e-4)
            cpu.periodic(body, period=T, priority=p, name=f"t{p}")
        count = _EventCount(sim)
        sim.run(until=0.008)
        assert len(sim.trace.frame("jobs")) == 7
        return count.events(), sim.trace.frame("schedule")
    events, heap = run()
    monkeypatch.setattr(releases, "GROUP_RELEASES", False)
    events_separate, separate = run()
    assert (events, events_separate) == (4 + 7, 7 + 7 + 2)
    pd.testing.assert_frame_equal(heap, separate, check_exact=True)


def test_a_task_armed_ahead_of_the_heap_first_entry_keeps_the_order(monkeypatch):
    """A task created at run time whose first release comes before every armed one gets a
    stand-in of its own; the old first entry keeps its stand-in (not queued twice) and,
    due at 5 ms with the new task's second release, is released first (created first)."""
    def run():
        sim = Simulation()
        cpu = sim.node("cpu")
        seen = []

        def body(ctx):
            seen.append((ctx.task.name, round(ctx.now * 1e6)))
            yield ctx.execute(1e-5)
        cpu.periodic(body, period=0.01, offset=0.005, priority=2, name="late")

        def early():
            cpu.periodic(body, period=0.003, offset=0.001, priority=1, name="early")
        sim.call_at(0.001, early)   # first release at 2 ms, before "late"'s at 5 ms
        sim.run(until=0.03)
        return seen, sim.trace.frame("schedule")
    seen, heap = run()
    monkeypatch.setattr(releases, "GROUP_RELEASES", False)
    seen_separate, separate = run()
    assert seen == seen_separate
    assert seen[:4] == [("early", 2000), ("early", 5000), ("late", 5010), ("early", 8000)]
    jobs = heap.query("state == 'ready' and time == 0.005")["task"].tolist()
    assert jobs == ["late", "early"]
    pd.testing.assert_frame_equal(heap, separate, check_exact=True)
