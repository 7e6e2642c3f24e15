"""Speed, power and batteries on multicore nodes: known schedules, hand-computed answers."""

import math
import warnings

import pytest

from netcosim import Simulation
from netcosim.energy import Battery, ConstantPower, DvsPower
from netcosim.errors import BatteryEmptyWarning, ConfigurationError, ConfigurationTypeError

MS = 1e-3


def _busy(c):
    def body(ctx):
        yield ctx.execute(c)
    return body


def _jobs(sim):
    return sim.trace.frame("jobs").set_index("task")


def _partitioned_pair(cs=0.0):
    """Core 0: a (3 ms every 10 ms); core 1: b (5 ms every 10 ms from 1 ms)."""
    sim = Simulation()
    cpu = sim.node("cpu", cores=2, context_switch=cs)
    cpu.periodic(_busy(3 * MS), period=10 * MS, priority=1, name="a", core=0)
    cpu.periodic(_busy(5 * MS), period=10 * MS, offset=1 * MS, priority=1, name="b", core=1)
    return sim, cpu


# ------------------------------------------------------------------------ energy
def test_partitioned_energy_is_the_integral_of_the_per_core_model():
    # DvsPower per core: 2 * 0.1 W static for 20 ms, plus 1 W of dynamic power per busy core.  Busy: core 0
    # 0..3.5 and 10..13.5 ms, core 1 1..6.5 and 11..16.5 ms (0.5 ms switch + the segment):
    # 18 ms of busy core time.  E = 0.004 + 0.018 = 0.022 J.
    sim, cpu = _partitioned_pair(cs=0.5 * MS)
    cpu.set_power_model(DvsPower(static=0.1, dynamic=1.0))
    sim.run(0.02)
    assert math.isclose(cpu.energy, 0.022, rel_tol=1e-12)
    rows = sim.trace.frame("energy")
    steps = list(zip(rows["time"].round(12), rows["power"].round(12)))
    # the node's power: 0.2 W idle, 1.2 W with one core busy, 2.2 W with both
    assert steps == [(0.0, 0.2), (0.0, 1.2), (0.001, 2.2), (0.0035, 1.2), (0.0065, 0.2), (0.01, 1.2),
                     (0.011, 2.2), (0.0135, 1.2), (0.0165, 0.2)]


def test_constant_power_is_the_kernels_once_not_per_core():
    sim, cpu = _partitioned_pair()
    cpu.set_power_model(ConstantPower(0.25))
    sim.run(0.02)
    assert math.isclose(cpu.energy, 0.25 * 0.02, rel_tol=1e-12)


def test_a_model_without_per_core_is_one_cores_and_a_model_swap_applies_at_once():
    class Busy:             # 1 W per busy core, nothing idle
        def power(self, busy, speed):
            return 1.0 if busy else 0.0

    sim, cpu = _partitioned_pair()
    cpu.set_power_model(Busy())
    sim.call_at(0.01, lambda: cpu.set_power_model(ConstantPower(0.5)))
    sim.run(0.02)
    # 0..10 ms: busy core time 3 + 5 ms at 1 W; 10..20 ms: 0.5 W
    assert math.isclose(cpu.energy, 0.008 + 0.005, rel_tol=1e-12)


def test_speed_change_on_a_partitioned_node_rescales_both_cores_and_the_power():
    # speed 0.5 from 2 ms.  a: 2 ms of 3 done, 1 ms left -> 2 ms, ends 4; next job 10..16.
    # b: 1 ms of 5 done, 4 ms left -> 8 ms, ends 10; next job 11..21 (cut at 20).
    # E = static 2 * 0.1 * 0.02 + 1 W * 3 ms (speed 1) + 0.125 W * (8 + 17) ms = 0.010125 J
    sim, cpu = _partitioned_pair()
    cpu.set_power_model(DvsPower(static=0.1, dynamic=1.0))
    sim.call_at(2 * MS, lambda: cpu.set_speed(0.5))
    sim.run(0.02)
    jobs = sim.trace.frame("jobs")
    fin = {(t, i): f for t, i, f in zip(jobs["task"], jobs["job"], jobs["finish"])}
    assert fin[("a", 0)] == pytest.approx(4 * MS, abs=1e-15) and fin[("a", 1)] == pytest.approx(16 * MS, abs=1e-15)
    assert fin[("b", 0)] == pytest.approx(10 * MS, abs=1e-15)
    assert math.isclose(cpu.energy, 0.010125, rel_tol=1e-12)
    assert cpu.speed == 0.5 and all(c._pw.speed == 0.5 for c in cpu.cores)


def _migration_case():
    sim = Simulation()
    node = sim.node("cpu", "edf", cores=2, scheduling="global", migration=0.5 * MS)
    node.periodic(_busy(4 * MS), period=20 * MS, name="A")
    node.periodic(_busy(2 * MS), period=10 * MS, name="B")
    node.periodic(_busy(3 * MS), period=50 * MS, deadline=5 * MS, offset=1 * MS, name="C")
    node.set_power_model(DvsPower(static=0.1, dynamic=1.0))
    return sim, node


def test_a_migration_keeps_the_core_busy():
    # tests/test_multicore.py's case: core 0 runs B 0..2, migrates A 2..2.5, runs A 2.5..5.5;
    # core 1 runs A 0..1, C 1..4.  Busy 5.5 + 4 ms; E = 0.2 W * 9 ms + 1 W * 9.5 ms
    sim, node = _migration_case()
    sim.run(0.009)
    assert math.isclose(node.energy, 0.0018 + 0.0095, rel_tol=1e-12)


def test_speed_change_during_a_migration_rescales_it_like_a_context_switch():
    # speed 0.5 at 2.25 ms: the migration's 0.25 ms left take 0.5 ms (ends 2.75), A's 3 ms
    # take 6 ms (ends 8.75); C's 1.75 ms left take 3.5 ms (ends 5.75).
    # E = 0.2 W * 9.5 ms + 1 W * 4.5 ms + 0.125 W * (6.5 + 3.5) ms = 0.00765 J
    sim, node = _migration_case()
    sim.call_at(2.25 * MS, lambda: node.set_speed(0.5))
    sim.run(0.0095)
    jobs = _jobs(sim)
    assert jobs.loc["A", "finish"] == pytest.approx(8.75 * MS, abs=1e-15)
    assert jobs.loc["C", "finish"] == pytest.approx(5.75 * MS, abs=1e-15)
    assert jobs.loc["A", "execution_time"] == pytest.approx(1 * MS + 6 * MS, abs=1e-15)
    assert math.isclose(node.energy, 0.00765, rel_tol=1e-12)


# ------------------------------------------------------------------------- speed
def _global_set(speed=None):
    sim = Simulation()
    node = sim.node("cpu", "edf", cores=2, scheduling="global", context_switch=0.1 * MS)
    for k, (c, t) in enumerate([(1, 10), (2, 10), (3, 20), (1.5, 5)]):
        node.periodic(_busy(c * MS), period=t * MS, offset=0.3 * k * MS, name=f"t{k}")
    if speed is not None:
        node.set_speed(speed)
    sim.run(0.2)
    jobs = sim.trace.frame("jobs")
    return jobs.sort_values(["task", "job"])["execution_time"].to_numpy()


def test_half_speed_on_a_global_node_doubles_execution_times_exactly():
    full, half = _global_set(), _global_set(0.5)
    assert len(full) == len(half) == 20 + 20 + 10 + 40
    assert (half == 2 * full).all()


def test_speed_change_on_a_global_node_rescales_running_and_preempted_jobs():
    # global FP on 2 cores: A (prio 2, 4 ms) on core 0, B (prio 3, 4 ms) on core 1 from 0;
    # H (prio 1, 2 ms) preempts B at 1 ms.  Speed 0.5 at 2 ms: H's 1 ms left -> 2 ms (ends
    # 4), A's 2 ms left -> 4 ms (ends 6), preempted B's 3 ms left -> 6 ms, resumed on core 1
    # at 4 (ends 10).  CPU times: H 1 + 2, A 2 + 4, B 1 + 6 ms.
    sim = Simulation()
    node = sim.node("cpu", cores=2, scheduling="global")
    node.periodic(_busy(4 * MS), period=100 * MS, priority=2, name="A")
    node.periodic(_busy(4 * MS), period=100 * MS, priority=3, name="B")
    node.periodic(_busy(2 * MS), period=100 * MS, offset=1 * MS, priority=1, name="H")
    sim.call_at(2 * MS, lambda: node.set_speed(0.5))
    sim.run(0.05)
    jobs = _jobs(sim)
    for name, finish, cpu_time, core in (("H", 4, 3, 1), ("A", 6, 6, 0), ("B", 10, 7, 1)):
        assert jobs.loc[name, "finish"] == pytest.approx(finish * MS, abs=1e-15), name
        assert jobs.loc[name, "execution_time"] == pytest.approx(cpu_time * MS, abs=1e-15), name
        assert jobs.loc[name, "core"] == core, name
    assert node.migrations == {"A": 0, "B": 0, "H": 0}


# ----------------------------------------------------------------------- battery
@pytest.mark.parametrize("scheduling", ["partitioned", "global"])
def test_battery_on_two_cores_empties_at_the_predicted_instant_and_both_cores_stop(scheduling):
    # DvsPower per core, static 0.5 W, dynamic 1 W: both cores busy draw 3 W; 0.06 J last
    # 20 ms.  a (40 ms) and b (50 ms) both run then: both are killed at 20 ms.
    sim = Simulation()
    cpu = sim.node("cpu", cores=2, scheduling=scheduling)
    pin = (lambda k: {"core": k}) if scheduling == "partitioned" else (lambda k: {})
    cpu.periodic(_busy(40 * MS), period=100 * MS, priority=1, name="a", **pin(0))
    cpu.periodic(_busy(50 * MS), period=100 * MS, priority=2, name="b", **pin(1))
    late = cpu.aperiodic(_busy(1 * MS), priority=0, name="late", **pin(1))
    cpu.set_power_model(DvsPower(static=0.5, dynamic=1.0))
    bat = cpu.set_battery(Battery(0.06))
    sim.call_at(30 * MS, late.release)
    with pytest.warns(BatteryEmptyWarning):
        sim.run(0.25)
    assert bat.empty_at == pytest.approx(0.02, abs=1e-12)
    jobs = _jobs(sim)
    assert sorted(jobs.index) == ["a", "b"]        # no later job of a or b, late never ran
    assert jobs["killed"].all() and jobs["finish"].tolist() == pytest.approx([0.02, 0.02], abs=1e-15)
    assert jobs["execution_time"].tolist() == pytest.approx([0.02, 0.02], abs=1e-15)
    assert cpu.releases_lost == 1 and not cpu.powered
    assert all(c.running is None and not c._in_cs for c in cpu.cores)
    assert math.isclose(cpu.energy, 0.06, rel_tol=1e-12) and bat.level == 0.0
    sched = sim.trace.frame("schedule")
    assert sched["time"].max() == pytest.approx(0.02, abs=1e-15)


def test_battery_empty_during_a_context_switch_on_one_core():
    # 1 ms switches; ConstantPower 1 W (the kernel's): 2.5 ms of charge.  Core 1's job b
    # (offset 2 ms) is in its switch (2..3 ms) at 2.5 ms: the switch is cancelled.
    sim = Simulation()
    cpu = sim.node("cpu", cores=2, context_switch=1 * MS)
    cpu.periodic(_busy(5 * MS), period=100 * MS, priority=1, name="a", core=0)
    cpu.periodic(_busy(5 * MS), period=100 * MS, offset=2 * MS, priority=1, name="b", core=1)
    cpu.set_power_model(ConstantPower(1.0))
    bat = cpu.set_battery(Battery(0.0025))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BatteryEmptyWarning)
        sim.run(0.01)
    assert bat.empty_at == pytest.approx(0.0025, abs=1e-12)
    jobs = _jobs(sim)
    assert jobs.loc["a", "execution_time"] == pytest.approx(1.5 * MS, abs=1e-15)
    assert math.isnan(jobs.loc["b", "start"]) and jobs.loc["b", "killed"]
    assert all(c.running is None and not c._in_cs for c in cpu.cores)
    assert sim.trace.frame("schedule")["time"].max() == pytest.approx(0.0025, abs=1e-15)


# -------------------------------------------------------------------- bad input
@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "fast", None])
def test_bad_speed_on_a_multicore_node_names_the_value_and_changes_nothing(bad):
    sim = Simulation()
    cpu = sim.node("cpu", cores=2)
    with pytest.raises((ConfigurationError, ConfigurationTypeError), match="speed"):
        cpu.set_speed(bad)
    assert cpu.speed == 1.0


def test_migration_below_the_resolution_at_the_new_speed_is_refused():
    sim = Simulation()
    cpu = sim.node("cpu", cores=2, scheduling="global", migration=1e-12)
    with pytest.raises(ConfigurationError, match=r"migration=1e-12 s at speed 4.*resolution"):
        cpu.set_speed(4)
    assert cpu.speed == 1.0 and cpu._mig_ticks == 1
    with pytest.raises(ConfigurationError, match="below the time resolution"):
        cpu.set_speed(2)        # 0.5 tick rounds to 0 (half to even): refused too
    cpu.set_speed(1.5)          # 2/3 tick rounds to 1
    assert cpu._mig_ticks == 1 and cpu.speed == 1.5


def test_bad_power_model_and_battery_on_a_multicore_node():
    sim = Simulation()
    cpu = sim.node("cpu", cores=2)

    class Vague:
        per_core = "yes"

        def power(self, busy, speed):
            return 1.0

    with pytest.raises(ConfigurationTypeError, match="per_core.*'yes'"):
        cpu.set_power_model(Vague())
    with pytest.raises(ConfigurationTypeError, match="power model"):
        cpu.set_power_model(0.01)
    with pytest.raises(ConfigurationTypeError, match="Battery.*0.5"):
        cpu.set_battery(0.5)
    cpu.set_battery(Battery(1.0))
    with pytest.raises(ConfigurationError, match="already has a battery"):
        cpu.set_battery(Battery(1.0))
