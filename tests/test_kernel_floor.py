"""The idealised kernel of benchmarks/kernel_floor.py does the same work as netcosim's:
its schedule and jobs rows for the 10-task benchmark set are netcosim's, value for value
(an independent fixed-priority implementation, so also a known answer for the kernel)."""

from benchmarks import kernel_floor


def test_idealised_kernel_rows_are_netcosims():
    _, _, sched, jobs = kernel_floor.floor_run(1.2)
    assert len(jobs) == 2250                    # 1.2 s of the set: sum of 1200 / T_ms jobs
    assert len(sched) == 3 * 2250 + 2 * 260     # ready, running, idle per job; 260 preemptions: ready, running
    assert kernel_floor.check(1.2)


def test_the_comparison_sees_a_different_schedule():
    # the rows of a shorter run are not those of the 1.2 s run: check() compares all of them
    def named(until):
        return [(t, task.name, s) for t, task, s in kernel_floor.floor_run(until)[2]]
    short, full = named(0.6), named(1.2)
    assert short != full and full[:len(short)] == short
