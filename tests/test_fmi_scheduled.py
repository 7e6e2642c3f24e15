"""FMI 3 Scheduled Execution: the two clocked partitions of a C-built FMU run as kernel tasks,
and their schedule under fixed priority and under EDF is the one computed by hand.

The FMU (netcosim/fmi/csrc/fmi3_se.c): clock ``fast`` every 5 ms, ``slow`` every 8 ms; here the
partitions take 2 ms and 4 ms of CPU (utilisation 0.4 + 0.5 = 0.9).
"""

import pytest

from netcosim import EDF, FixedPriority, Simulation
from netcosim.errors import ConfigurationError, FMUError
from netcosim.testing import assert_schedule

fmi = pytest.importorskip("netcosim.fmi")

MS = 1e-3


@pytest.fixture
def se_fmu(fmu_builder, tmp_path):
    from fmu_build import build_se_fmu
    fmu_builder("servo", 3)          # skips without FMPy or gcc
    return build_se_fmu(tmp_path)


def run(path, policy, until=14.5 * MS):
    fmu = fmi.ScheduledExecutionFMU(path)
    sim = Simulation()
    node = sim.node("ecu", policy)
    fmu.add_tasks(node, {"fast": 2 * MS, "slow": 4 * MS})
    sim.run(until)
    return fmu, sim


def test_the_clocks_come_from_the_description(se_fmu):
    fmu = fmi.ScheduledExecutionFMU(se_fmu)
    assert fmu.clocks == {"fast": 0.005, "slow": 0.008} and fmu.shifts == {"fast": 0.0, "slow": 0.0}


def test_fixed_priority_schedule_is_the_hand_computed_one(se_fmu):
    # rate monotonic: fast (5 ms) above slow (8 ms).
    # fast: 0-2, 5-7, 10-12; slow job 1 runs 2-5 and 7-8 (preempted at 5), job 2 8-10 and 12-14
    fmu, sim = run(se_fmu, FixedPriority())
    assert_schedule(sim.trace.schedule(), {
        "fast": [(0, 2 * MS), (5 * MS, 7 * MS), (10 * MS, 12 * MS)],
        "slow": [(2 * MS, 5 * MS), (7 * MS, 10 * MS), (12 * MS, 14 * MS)]}, node="ecu", atol=1e-12)
    # each partition was activated at its job's end, with its clock tick as activation time
    assert fmu.activations == [("fast", 0.0, 2 * MS), ("fast", 5 * MS, 7 * MS), ("slow", 0.0, 8 * MS),
                               ("fast", 10 * MS, 12 * MS), ("slow", 8 * MS, 14 * MS)]
    assert fmu.output("fast_count") == 3 and fmu.output("fast_time") == 10 * MS
    assert fmu.output("slow_count") == 2 and fmu.output("slow_time") == 8 * MS
    assert fmu.output("fast_out") == 6.0        # gain 2 times the count, computed inside the FMU


def test_edf_schedule_is_the_hand_computed_one(se_fmu):
    # EDF: at 5 ms slow (deadline 8) keeps the CPU over fast's job 2 (deadline 10);
    # at 10 ms fast's job 3 (deadline 15) preempts slow's job 2 (deadline 16)
    fmu, sim = run(se_fmu, EDF())
    assert_schedule(sim.trace.schedule(), {
        "fast": [(0, 2 * MS), (6 * MS, 8 * MS), (10 * MS, 12 * MS)],
        "slow": [(2 * MS, 6 * MS), (8 * MS, 10 * MS), (12 * MS, 14 * MS)]}, node="ecu", atol=1e-12)
    assert fmu.activations == [("fast", 0.0, 2 * MS), ("slow", 0.0, 6 * MS), ("fast", 5 * MS, 8 * MS),
                               ("fast", 10 * MS, 12 * MS), ("slow", 8 * MS, 14 * MS)]


def test_bad_schedules_are_named(se_fmu):
    fmu = fmi.ScheduledExecutionFMU(se_fmu)
    node = Simulation().node("ecu")
    with pytest.raises(ConfigurationError, match=r"no execution time for clock 'slow'"):
        fmu.add_tasks(node, {"fast": 1e-3})
    with pytest.raises(ConfigurationError, match=r"execution_time names clock 'medium'.*\['fast', 'slow'\]"):
        fmu.add_tasks(node, {"fast": 1e-3, "slow": 1e-3, "medium": 1e-3})


def test_an_fmu_without_scheduled_execution_is_named(fmu_builder):
    with pytest.raises(FMUError, match=r"servo3\.fmu'.*has no scheduled execution interface"):
        fmi.ScheduledExecutionFMU(fmu_builder("servo", 3))
