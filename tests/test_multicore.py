"""Multicore nodes: partitioned == per-core uniprocessor schedules, global EDF / FP ==
SimSo 0.8.5's G-EDF / G-FP, Dhall's effect, migration cost, the core columns, bad input."""

import json
import math
import random

import numpy as np
import pytest

from benchmarks import simso_global
from netcosim import Simulation
from netcosim.errors import ConfigurationError, ConfigurationTypeError

MS = 1e-3


def _busy(c):
    def body(ctx):
        yield ctx.execute(c)
    return body


def _task_set(rng, n):
    """*n* random periodic tasks (period, wcet, offset in s; core, priority) -- a mix of
    sleeping and plain bodies."""
    tasks = []
    for i in range(n):
        period = rng.choice((2, 3, 4, 5, 6, 8, 10)) * MS
        tasks.append({"name": f"t{i}", "period": period, "c": round(rng.uniform(0.05, 0.3) * period, 6),
                      "offset": rng.choice((0, 0, 0.5, 1)) * MS, "priority": rng.randint(1, 9),
                      "sleep": rng.random() < 0.3})
    return tasks


def _add(node, spec, core=None):
    c, sleep = spec["c"], spec["sleep"]

    def body(ctx):
        yield ctx.execute(c / 2)
        if sleep:
            yield ctx.sleep(0.2 * MS)
        yield ctx.execute(c / 2)
    kw = {} if core is None else {"core": core}
    node.periodic(body, name=spec["name"], period=spec["period"], offset=spec["offset"],
                  priority=spec["priority"], **kw)


def _per_task(sim, names):
    sched = sim.trace.frame("schedule")
    jobs = sim.trace.frame("jobs")
    cols = ["job", "release", "deadline", "start", "finish", "execution_time", "deadline_miss"]
    out = {}
    for name in names:
        s = sched[sched["task"] == name]
        j = jobs[jobs["task"] == name].sort_values("job")
        # repr: exact floats, and NaN (a job not started) equal to NaN
        out[name] = repr((list(zip(s["time"], s["state"].astype(str))), j[cols].to_numpy().tolist()))
    return out


# ------------------------------------------------------------------ partitioned
@pytest.mark.parametrize("policy", ["fixed_priority", "edf", "rate_monotonic"])
@pytest.mark.parametrize("seed", range(4))
def test_partitioned_schedule_is_the_per_core_uniprocessor_schedules(policy, seed):
    rng = random.Random(seed)
    cores = 3
    tasks = _task_set(rng, 9)
    where = [rng.randrange(cores) for _ in tasks]
    sim = Simulation()
    node = sim.node("cpu", policy, cores=cores, context_switch=0.05 * MS)
    for spec, k in zip(tasks, where):
        _add(node, spec, core=k)
    node.handler(_busy(0.1 * MS), name="irq", core=1)
    node.timer(node.tasks["irq"], at=3.3 * MS, period=7 * MS)
    sim.run(0.06)
    got = _per_task(sim, [t["name"] for t in tasks] + ["irq"])
    for k in range(cores):
        alone = Simulation()
        one = alone.node("cpu", policy, context_switch=0.05 * MS)
        mine = [spec for spec, w in zip(tasks, where) if w == k]
        for spec in mine:
            _add(one, spec)
        names = [t["name"] for t in mine]
        if k == 1:
            one.handler(_busy(0.1 * MS), name="irq")
            one.timer(one.tasks["irq"], at=3.3 * MS, period=7 * MS)
            names.append("irq")
        alone.run(0.06)
        want = _per_task(alone, names)
        for name in names:
            assert got[name] == want[name], (k, name)
    # every running row of a pinned task names its core, and so does every job row
    sched, jobs = sim.trace.frame("schedule"), sim.trace.frame("jobs")
    pinned = dict(zip([t["name"] for t in tasks], where)) | {"irq": 1}
    running = sched[sched["state"] == "running"]
    assert (running["core"].to_numpy() == running["task"].astype(str).map(pinned).to_numpy()).all()
    assert (sched.loc[sched["state"] != "running", "core"] == -1).all()
    assert (jobs["core"].to_numpy() == jobs["task"].astype(str).map(pinned).to_numpy()).all()
    assert (jobs["migrations"] == 0).all()
    assert node.core_of(node.tasks["t0"]) == where[0]


def test_a_partitioned_core_is_not_disturbed_by_the_others():
    """Core 1's long task keeps running while core 0's urgent task comes and goes."""
    sim = Simulation()
    node = sim.node("cpu", "fixed_priority", cores=2)
    node.periodic(_busy(1 * MS), period=2 * MS, priority=1, name="urgent", core=0)
    node.periodic(_busy(5 * MS), period=10 * MS, priority=2, name="long", core=1)
    sim.run(0.0099)
    jobs = sim.trace.frame("jobs")
    long = jobs[jobs["task"] == "long"].iloc[0]
    assert (long["start"], long["finish"]) == (0.0, 0.005)   # on one core it would end at 0.009


# ----------------------------------------------------------------------- global
def test_global_edf_and_fp_equal_simso_085():
    """The stored SimSo 0.8.5 answers (benchmarks/simso_global.py): 20 random task sets
    each for G-EDF and G-FP on 2 and 4 cores, every job's CPU intervals identical."""
    ref = json.loads(simso_global.REFERENCE.read_text())
    assert ref["simso"] == "0.8.5" and len(ref["cases"]) == 80
    kinds = {(c["policy"], c["cores"]) for c in ref["cases"]}
    assert kinds == {("edf", 2), ("edf", 4), ("fp", 2), ("fp", 4)}
    preempted = 0
    for case in ref["cases"]:
        got = simso_global.netcosim_intervals(case["tasks"], case["cores"], case["policy"], ref["horizon_ms"])
        assert got == case["intervals"], case
        preempted += sum(len(runs) for runs in got) > sum(ref["horizon_ms"] // t["t"] for t in case["tasks"])
    assert preempted > 40       # the sets do exercise preemption (more runs than jobs)


def test_global_matches_simso_live():
    """The same comparison with SimSo itself (a test-only reference that ``make`` installs
    apart, in .venv/simso: it needs SimPy 2), on task sets the stored ones do not hold."""
    if not (simso_global.SIMSO_PATH / "simso").is_dir():
        pytest.skip(f"SimSo is not installed in {simso_global.SIMSO_PATH} (make installs it)")
    rng = random.Random(99)
    checked = 0
    while checked < 4:
        policy = ("edf", "fp")[checked % 2]
        tasks = simso_global.random_task_set(rng, 3, policy == "edf")
        want = simso_global.simso_intervals_apart(tasks, 3, policy)
        if want is None:
            continue
        assert simso_global.netcosim_intervals(tasks, 3, policy) == want
        checked += 1


@pytest.mark.parametrize("policy", ["edf", "fixed_priority"])
def test_global_on_one_core_is_the_uniprocessor_schedule(policy):
    rng = random.Random(5)
    tasks = _task_set(rng, 6)
    runs = []
    for kw in ({}, {"cores": 1, "scheduling": "global"}):
        sim = Simulation()
        node = sim.node("cpu", policy, context_switch=0.02 * MS, **kw)
        for spec in tasks:
            _add(node, spec)
        sim.run(0.05)
        runs.append(_per_task(sim, [t["name"] for t in tasks]))
    assert runs[0] == runs[1]


def _dhall(m, scheduling, policy="edf", heavy_priority=9):
    """Dhall's task set on *m* cores: m light tasks C = 2 eps, T = 1 and one heavy task
    C = 1, T = 1 + eps (unit 10 ms, eps = 0.1 ms)."""
    unit, eps = 10 * MS, 0.1 * MS
    sim = Simulation()
    node = sim.node("cpu", policy, cores=m, scheduling=scheduling)
    for i in range(m):
        kw = {"core": 1 % m} if scheduling == "partitioned" else {}
        node.periodic(_busy(2 * eps), period=unit, priority=i, name=f"light{i}", **kw)
    kw = {"core": 0} if scheduling == "partitioned" else {}
    node.periodic(_busy(unit), period=unit + eps, priority=heavy_priority, name="heavy", **kw)
    sim.run(0.1)
    jobs = sim.trace.frame("jobs")
    return jobs[jobs["task"] == "heavy"].iloc[0], jobs


@pytest.mark.parametrize("m", [2, 4])
def test_dhalls_effect(m):
    """Utilisation 2 m eps + 1/(1 + eps) (1.03 on 2 cores, 1.07 on 4), far below m, yet
    global EDF (and global RM) misses: the light jobs' earlier deadlines hold every core
    for 2 eps, the heavy job starts at 0.2 ms and ends at 10.2 ms > 10.1 ms (RM: 10.4 ms).  Pinning the
    heavy task alone on core 0 (partitioned) or giving it the top priority meets every
    deadline."""
    heavy, _ = _dhall(m, "global")
    assert (heavy["start"], heavy["finish"], heavy["deadline"]) == (0.0002, 0.0102, 0.0101)
    assert heavy["deadline_miss"] and math.isclose(heavy["lateness"], 0.1 * MS, abs_tol=1e-15)
    heavy_rm, _ = _dhall(m, "global", "rate_monotonic")
    # under RM the light jobs released at 10 ms (shorter period) preempt it once more
    assert heavy_rm["finish"] == 0.0104 and heavy_rm["deadline_miss"]
    for scheduling, policy, prio in (("partitioned", "edf", 9), ("global", "fixed_priority", -1)):
        heavy, jobs = _dhall(m, scheduling, policy, prio)
        assert heavy["finish"] == 0.01 and not jobs["deadline_miss"].any()


def _migration_case(cs, mig):
    sim = Simulation()
    node = sim.node("cpu", "edf", cores=2, scheduling="global", context_switch=cs, migration=mig)
    node.periodic(_busy(4 * MS), period=20 * MS, name="A")
    node.periodic(_busy(2 * MS), period=10 * MS, name="B")
    node.periodic(_busy(3 * MS), period=50 * MS, deadline=5 * MS, offset=1 * MS, name="C")
    sim.run(0.009)
    jobs = sim.trace.frame("jobs").set_index("task")
    return node, jobs, sim.trace.frame("schedule")


def test_migration_cost_is_charged_on_the_new_core():
    """B (d 10) takes core 0, A (d 20) core 1; C (d 6) arrives at 1 ms and preempts A
    (the worst deadline) on core 1; B ends at 2 ms and A resumes on core 0: a migration
    of 0.5 ms, so A's 3 ms left run 2.5..5.5 ms."""
    node, jobs, sched = _migration_case(0.0, 0.5 * MS)
    assert jobs.loc["B", ["start", "finish", "core", "migrations"]].tolist() == [0.0, 0.002, 0, 0]
    assert jobs.loc["C", ["start", "finish", "core", "migrations"]].tolist() == [0.001, 0.004, 1, 0]
    assert jobs.loc["A", ["start", "finish", "core", "migrations"]].tolist() == [0.0, 0.0055, 0, 1]
    assert math.isclose(jobs.loc["A", "execution_time"], 0.004, rel_tol=1e-12)
    a = sched[sched["task"] == "A"]
    assert list(zip(a["time"], a["state"].astype(str), a["core"])) == [
        (0.0, "ready", -1), (0.0, "running", 1), (0.001, "ready", -1), (0.0025, "running", 0),
        (0.0055, "idle", -1)]
    assert node.migrations == {"A": 1, "B": 0, "C": 0}


def test_migration_adds_to_the_context_switch():
    """With a 0.1 ms context switch: B runs 0.1..2.1 on core 0, A 0.1..1 on core 1, C
    (switch 1..1.1) runs 1.1..4.1; A moves to core 0 at 2.1 and pays 0.1 + 0.5 ms: it runs
    its 3.1 ms left from 2.7 to 5.8 ms."""
    _, jobs, _ = _migration_case(0.1 * MS, 0.5 * MS)
    assert jobs.loc["B", ["start", "finish"]].tolist() == [0.0001, 0.0021]
    assert jobs.loc["C", ["start", "finish"]].tolist() == [0.0011, 0.0041]
    assert jobs.loc["A", ["start", "finish", "core", "migrations"]].tolist() == [0.0001, 0.0058, 0, 1]


def test_without_migration_cost_the_job_still_counts_its_migration():
    _, jobs, _ = _migration_case(0.0, 0.0)
    assert jobs.loc["A", ["finish", "core", "migrations"]].tolist() == [0.005, 0, 1]


def test_global_non_preemptible_task_keeps_its_core():
    sim = Simulation()
    node = sim.node("cpu", "fixed_priority", cores=2, scheduling="global")
    node.periodic(_busy(3 * MS), period=20 * MS, priority=5, name="np1", preemptible=False)
    node.periodic(_busy(3 * MS), period=20 * MS, priority=4, name="p2")
    node.periodic(_busy(1 * MS), period=20 * MS, offset=1 * MS, priority=1, name="hi")
    sim.run(0.01)
    jobs = sim.trace.frame("jobs").set_index("task")
    # hi preempts p2 (the worst preemptible job), not the worse but non-preemptible np1
    assert jobs.loc["np1", ["start", "finish"]].tolist() == [0.0, 0.003]
    assert jobs.loc["hi", ["start", "finish"]].tolist() == [0.001, 0.002]
    assert jobs.loc["p2", ["start", "finish"]].tolist() == [0.0, 0.004]


def test_killed_job_on_a_global_node_frees_its_core():
    sim = Simulation()
    node = sim.node("cpu", "edf", cores=2, scheduling="global")
    node.periodic(_busy(8 * MS), period=20 * MS, deadline=5 * MS, name="late", on_deadline_miss="kill")
    node.periodic(_busy(2 * MS), period=20 * MS, deadline=19 * MS, name="x")
    node.periodic(_busy(2 * MS), period=20 * MS, deadline=19 * MS, name="y")
    sim.run(0.012)
    jobs = sim.trace.frame("jobs").set_index("task")
    assert jobs.loc["late", ["finish", "killed", "core"]].tolist() == [0.005, True, 0]
    assert jobs.loc["y", ["start", "finish", "core"]].tolist() == [0.002, 0.004, 1]


# ------------------------------------------------------------------ the tables
def test_one_core_tables_keep_their_columns():
    sim = Simulation()
    node = sim.node("cpu")
    node.periodic(_busy(1 * MS), period=2 * MS, priority=1)
    sim.run(0.01)
    assert "core" not in sim.trace.frame("schedule") and "core" not in sim.trace.frame("jobs")


def test_core_columns_next_to_a_one_core_node():
    """A simulation with a one-core and a multicore node: the one-core node's running rows
    say core 0."""
    sim = Simulation()
    one = sim.node("one")
    one.periodic(_busy(1 * MS), period=4 * MS, priority=1, name="a")
    many = sim.node("many", cores=2)
    many.periodic(_busy(1 * MS), period=4 * MS, priority=1, name="b", core=1)
    sim.run(0.01)
    sched, jobs = sim.trace.frame("schedule"), sim.trace.frame("jobs")
    running = sched[sched["state"] == "running"]
    assert set(zip(running["task"].astype(str), running["core"])) == {("a", 0), ("b", 1)}
    assert set(zip(jobs["task"].astype(str), jobs["core"])) == {("a", 0), ("b", 1)}
    assert jobs["core"].dtype == np.int64


# ------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kw, err, text", [
    ({"cores": 0}, ConfigurationError, "0"),
    ({"cores": 65}, ConfigurationError, "65"),
    ({"cores": 2.5}, ConfigurationError, "2.5"),
    ({"cores": "2"}, ConfigurationTypeError, "'2'"),
    ({"cores": 2, "scheduling": "mixed"}, ConfigurationError, "mixed"),
    ({"cores": 2, "migration": 1e-3}, ConfigurationError, "0.001"),
    ({"migration": 1e-3}, ConfigurationError, "0.001"),
    ({"cores": 2, "scheduling": "global", "migration": -1.0}, ConfigurationError, "-1"),
])
def test_bad_node_arguments_are_named(kw, err, text):
    with pytest.raises(err, match=text):
        Simulation().node("cpu", **kw)


def test_bad_core_is_named():
    sim = Simulation()
    part = sim.node("p", cores=2)
    with pytest.raises(ConfigurationError, match="core.*2"):
        part.periodic(_busy(MS), period=2 * MS, priority=1, core=2)
    with pytest.raises(ConfigurationError, match="-1"):
        part.handler(_busy(MS), core=-1)
    with pytest.raises(ConfigurationTypeError, match="'a'"):
        part.aperiodic(_busy(MS), priority=1, core="a")
    glob = sim.node("g", cores=2, scheduling="global")
    with pytest.raises(ConfigurationError, match="core=1"):
        glob.periodic(_busy(MS), period=2 * MS, priority=1, core=1)
    one = sim.node("one")
    with pytest.raises(ConfigurationError, match="core=1"):
        one.periodic(_busy(MS), period=2 * MS, priority=1, core=1)
    edf = sim.node("e", "edf", cores=2)
    with pytest.raises(ConfigurationError, match="one-core"):
        edf.cbs(1 * MS, 4 * MS)


def test_a_mailbox_links_tasks_on_two_cores():
    """A producer on core 0 posts at 1 ms; the consumer blocked on core 1 resumes then and
    runs 0.5 ms: its job ends at 1.5 ms while core 0 is still busy until 3 ms."""
    from netcosim import Mailbox
    box = Mailbox("box")
    sim = Simulation()
    node = sim.node("cpu", cores=2)

    def producer(ctx):
        yield ctx.execute(1 * MS)
        yield box.post("x")
        yield ctx.execute(2 * MS)

    def consumer(ctx):
        item = yield box.fetch()
        assert item == "x"
        yield ctx.execute(0.5 * MS)
    node.periodic(producer, period=10 * MS, priority=1, name="producer", core=0)
    node.periodic(consumer, period=10 * MS, priority=1, name="consumer", core=1)
    sim.run(0.005)
    jobs = sim.trace.frame("jobs").set_index("task")
    assert jobs.loc["consumer", ["start", "finish", "core"]].tolist() == [0.0, 0.0015, 1]
    assert jobs.loc["producer", ["finish", "core"]].tolist() == [0.003, 0]


def test_plot_schedule_shades_each_core(tmp_path):
    from netcosim.plot import plot_schedule
    _, _, sched = _migration_case(0.0, 0.5 * MS)
    ax = plot_schedule(sched, path=tmp_path / "cores.png")
    assert (tmp_path / "cores.png").stat().st_size > 0
    assert sorted(t.get_text() for t in ax.get_legend().get_texts()) == ["core 0", "core 1"]


def test_a_job_killed_in_its_context_switch_holds_the_core_until_the_switch_ends():
    """Context switch 1 ms: 'late' (deadline 0.5 ms) is killed inside its switch on core 0;
    core 0 stays busy until 1 ms, then y switches in (1..2 ms) and runs 2..4 ms."""
    sim = Simulation()
    node = sim.node("cpu", "edf", cores=2, scheduling="global", context_switch=1 * MS)
    node.periodic(_busy(2 * MS), period=20 * MS, deadline=0.5 * MS, name="late", on_deadline_miss="kill")
    node.periodic(_busy(2 * MS), period=20 * MS, deadline=19 * MS, name="x")
    node.periodic(_busy(2 * MS), period=20 * MS, deadline=19 * MS, name="y")
    sim.run(0.006)
    jobs = sim.trace.frame("jobs").set_index("task")
    assert jobs.loc["late", ["finish", "killed", "core"]].tolist() == [0.0005, True, 0]
    assert jobs.loc["x", ["start", "finish", "core"]].tolist() == [0.001, 0.003, 1]
    assert jobs.loc["y", ["start", "finish", "core"]].tolist() == [0.002, 0.004, 0]


def test_the_dhall_experiment(tmp_path):
    from netcosim.experiments import multicore_dhall
    sims = multicore_dhall.main(tmp_path, cores=2, quick=True)
    ends = {}
    for mode, sim in sims.items():
        jobs = sim.trace.jobs()
        ends[mode] = (jobs.loc[(jobs["task"] == "heavy") & (jobs["job"] == 0), "finish"].item(),
                      int(jobs["deadline_miss"].sum()))
        assert (tmp_path / f"{mode}_schedule.png").stat().st_size > 0
    assert ends == {"global_edf": (0.0102, 1), "global_rm": (0.0104, 2), "partitioned_edf": (0.01, 0),
                    "global_fp_heavy_first": (0.01, 0)}
    with pytest.raises(ConfigurationError, match="1"):
        multicore_dhall.main(tmp_path, cores=1)


def test_priority_inheritance_crosses_cores():
    """'low' (core 1) holds a monitor; 'mid' (core 1) preempts it at 0.5 ms; 'high' (core 0)
    blocks on the monitor at 1 ms: low inherits high's priority, preempts mid on core 1,
    leaves the monitor at 2.5 ms, and high runs 2.5..3 ms (without inheritance: 5..5.5)."""
    from netcosim import Monitor
    results = {}
    for inheritance in (True, False):
        m = Monitor("m", inheritance=inheritance)
        sim = Simulation()
        node = sim.node("cpu", cores=2)

        def low(ctx):
            yield m.enter()
            yield ctx.execute(2 * MS)
            m.exit()

        def high(ctx):
            yield m.enter()
            yield ctx.execute(0.5 * MS)
            m.exit()
        node.periodic(low, period=20 * MS, priority=3, name="low", core=1)
        node.periodic(_busy(3 * MS), period=20 * MS, offset=0.5 * MS, priority=2, name="mid", core=1)
        node.periodic(high, period=20 * MS, offset=1 * MS, priority=1, name="high", core=0)
        sim.run(0.01)
        jobs = sim.trace.frame("jobs").set_index("task")
        results[inheritance] = {t: jobs.loc[t, "finish"] for t in ("low", "mid", "high")}
    assert results[True] == {"low": 0.0025, "mid": 0.005, "high": 0.003}
    assert results[False] == {"low": 0.005, "mid": 0.0035, "high": 0.0055}


def test_a_handler_on_a_global_node_preempts_the_worst_task():
    sim = Simulation()
    node = sim.node("cpu", cores=2, scheduling="global")
    node.periodic(_busy(3 * MS), period=20 * MS, priority=1, name="a")
    node.periodic(_busy(3 * MS), period=20 * MS, priority=2, name="b")
    irq = node.handler(_busy(0.5 * MS), name="irq")
    node.timer(irq, at=1 * MS)
    sim.run(0.01)
    jobs = sim.trace.frame("jobs").set_index("task")
    assert jobs.loc["a", ["finish", "core"]].tolist() == [0.003, 0]
    assert jobs.loc["irq", ["start", "finish", "core"]].tolist() == [0.001, 0.0015, 1]
    assert jobs.loc["b", ["finish", "core", "migrations"]].tolist() == [0.0035, 1, 0]


@pytest.mark.parametrize("scheduling", ["partitioned", "global"])
def test_a_multicore_node_on_a_local_clock(scheduling):
    """Periods are local on every core: h = 10 ms at drift 0.25 is 8 ms of simulation time."""
    sim = Simulation()
    cpu = sim.node("cpu", "edf", cores=2, scheduling=scheduling, clock_drift=0.25)
    for k in range(2):
        pin = {"core": k} if scheduling == "partitioned" else {}

        @cpu.periodic(period=0.01, name=f"t{k}", **pin)
        def t(ctx):
            yield ctx.execute(0.002)
    sim.run(0.05)
    jobs = sim.trace.jobs()
    for k in range(2):
        j = jobs[jobs["task"] == f"t{k}"]
        assert np.allclose(j["release"], np.arange(7) * 0.008, rtol=0, atol=1e-12)
        done = j[j["finish"].notna()]
        assert np.allclose(done["finish"] - done["release"], 0.002, rtol=0, atol=1e-12)
    assert sorted(jobs.loc[jobs["finish"].notna(), "core"].unique()) == [0, 1]
