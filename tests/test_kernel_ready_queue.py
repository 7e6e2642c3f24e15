"""The ready queue (netcosim/kernel/ready.py): the kernel's tie rules in a heap with lazy deletion."""

import random

from netcosim import Simulation
from netcosim.kernel.ready import ReadyQueue
from netcosim.kernel.sync import Monitor


class _J:
    """The fields of a job the queue reads."""

    ready_entry = None

    def __init__(self, cls, key, seq):
        self.cls, self.key, self.seq = cls, key, seq

    def __repr__(self):
        return f"J{self.cls}/{self.key}/{self.seq}"


def _drain(q):
    out = []
    while (j := q.first()) is not None:
        q.pop_first()
        out.append(j)
    return out


def test_order_is_class_then_key_then_fifo():
    jobs = [_J(1, 2, 1), _J(1, 1, 2), _J(0, 5, 3), _J(1, 1, 4), _J(0, 5, 5), _J(0, 1, 6)]
    q = ReadyQueue()
    for j in jobs:
        q.push(j)
    assert len(q) == 6
    assert [j.seq for j in list(q)] == [6, 3, 5, 2, 4, 1]
    assert [j.seq for j in _drain(q)] == [6, 3, 5, 2, 4, 1]
    assert not q and q.first() is None


def test_discard_and_requeue_back_to_an_old_key():
    a, b, c = _J(1, 3, 1), _J(1, 2, 2), _J(1, 1, 3)
    q = ReadyQueue()
    for j in (a, b, c):
        q.push(j)
    q.discard(c)
    q.discard(c)  # not queued any more: no-op
    assert c not in q and a in q and len(q) == 2
    a.key = 0
    q.requeue(a)
    a.key = 3
    q.requeue(a)  # a dead entry with the same (cls, key, seq) stays in the heap: must not compare jobs
    a.key = 0
    q.requeue(a)
    q.requeue(c)  # not queued: no-op
    assert len(q) == 2
    assert _drain(q) == [a, b]


def test_matches_a_scan_under_random_operations():
    """Against the former implementation: a list scanned for the smallest (cls, key, seq)."""
    rng = random.Random(15)
    q, ref, seq = ReadyQueue(), [], 0
    for _ in range(5000):
        op = rng.random()
        if op < 0.4 or not ref:
            seq += 1
            j = _J(rng.randint(0, 1), rng.randint(0, 5), seq)
            q.push(j)
            ref.append(j)
        elif op < 0.6:
            best = min(ref, key=lambda j: (j.cls, j.key, j.seq))
            assert q.first() is best
            q.pop_first()
            ref.remove(best)
        elif op < 0.8:
            j = rng.choice(ref)
            q.discard(j)
            ref.remove(j)
        else:
            j = rng.choice(ref)
            j.cls, j.key = rng.randint(0, 1), rng.randint(0, 5)
            q.requeue(j)
        assert len(q) == len(ref)
        assert list(q) == sorted(ref, key=lambda j: (j.cls, j.key, j.seq))


def test_inheritance_raises_a_ready_holder_above_a_ready_middle_task():
    """The holder is preempted (ready) when the high-priority task blocks on its monitor; the
    raised key must reorder it in the ready queue ahead of the medium task released meanwhile."""
    sim = Simulation()
    cpu = sim.node("cpu")
    m = Monitor("m", inheritance=True)
    order = []

    def low(ctx):
        yield m.enter()
        yield ctx.execute(0.002)
        order.append(("low exits", round(ctx.now, 6)))
        m.exit()
        yield ctx.execute(0.001)

    def mid(ctx):
        yield ctx.execute(0.002)
        order.append(("mid done", round(ctx.now, 6)))

    def high(ctx):
        yield ctx.execute(0.0005)
        yield m.enter()
        order.append(("high in", round(ctx.now, 6)))
        yield ctx.execute(0.0005)
        m.exit()

    lo = cpu.aperiodic(low, priority=3, name="low")
    mi = cpu.aperiodic(mid, priority=2, name="mid")
    hi = cpu.aperiodic(high, priority=1, name="high")
    sim.call_at(0.0, lo.release)
    sim.call_at(0.0005, mi.release)
    sim.call_at(0.0005, hi.release)
    sim.run(until=0.01)
    # low holds m; at 0.5 ms mid and high arrive, high runs, blocks at 1 ms: low (raised to
    # high's priority) runs its remaining 1.5 ms before mid, exits at 2.5 ms, high enters.
    assert order == [("low exits", 0.0025), ("high in", 0.0025), ("mid done", 0.005)]


def test_a_job_killed_while_ready_never_runs_and_the_order_of_the_rest_holds():
    sim = Simulation()
    cpu = sim.node("cpu")
    ran = []

    def body(ctx):
        ran.append(ctx.task.name)
        yield ctx.execute(0.001)

    tasks = {p: cpu.aperiodic(body, priority=p, name=f"p{p}") for p in (1, 2, 3, 4)}
    jobs = {}
    sim.call_at(0.0, lambda: [jobs.__setitem__(p, t.release()) for p, t in tasks.items()])
    sim.call_at(0.0005, lambda: jobs[2].kill())
    sim.run(until=0.01)
    assert ran == ["p1", "p3", "p4"]
    assert len(cpu.ready) == 0
    killed = sim.trace.jobs().set_index("task")["killed"]
    assert bool(killed["p2"]) and not killed.drop("p2").any()


def test_a_job_killed_during_its_context_switch():
    """Off the ready queue but still in state ``ready``: the kill completes the switch, then the CPU
    is re-dispatched (the scanned list raised ValueError here)."""
    sim = Simulation()
    cpu = sim.node("cpu", context_switch=0.001)

    def body(ctx):
        yield ctx.execute(0.002)

    a = cpu.aperiodic(body, priority=1, name="a")
    b = cpu.aperiodic(body, priority=2, name="b")
    jobs = []
    sim.call_at(0.0, lambda: jobs.extend([a.release(), b.release()]))
    sim.call_at(0.0005, lambda: jobs[0].kill())
    sim.run(until=0.01)
    t = sim.trace.jobs().set_index("task")
    assert bool(t.loc["a", "killed"]) and t.loc["a", "finish"] == 0.0005
    assert not t.loc["b", "killed"] and abs(t.loc["b", "finish"] - 0.004) < 1e-12
