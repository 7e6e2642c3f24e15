"""Cost counters (benchmarks/counters.py): the work per example -- SimPy events per kernel
job, trace rows per frame, right-hand-side evaluations per simulated second -- equals the
stored counts (benchmarks/counters_reference.json): exactly for events and rows, within
2 % for RHS evaluations (adaptive step counts move with the last bits of floating point).
These counts do not depend on the host's speed; a change meant to alter them re-records
with ``python -m benchmarks.counters --record``."""

import pytest

from benchmarks import counters


def test_counts_equal_the_stored_ones():
    stored = counters.load()
    assert set(stored) == set(counters.COUNTERS)
    got = counters.measure()
    assert counters.differences(got, stored) == []


def test_known_counts_from_first_principles():
    """RK4 evaluates f 4 times per step and takes 1e4 steps of 1e-4 s in 1 s of the servo:
    4e4 within one or two steps (measured 40 004).  The 10-task set takes one event per
    job's segment end (2250 jobs in 1.2 s), one per distinct release instant (88 of the 225
    releases of a 120 ms hyperperiod: the multiples of 2, 3 and 5 ms), and a few more for
    preemptions and dispatches at instants shared with a segment end: between
    (2250 + 880) / 2250 and 2."""
    assert abs(counters.servo_rhs_per_second() - 40_000.0) <= 8.0
    assert (2250 + 880) / 2250 <= counters.kernel_events_per_job() < 2.0


def test_a_change_outside_the_tolerance_is_reported():
    stored = {"servo_rk4.rhs_per_second": 40_004.0, "kernel_10_tasks.events_per_job": 2.0}
    assert counters.differences({"servo_rk4.rhs_per_second": 40_800.0}, stored) == []          # +1.99 %
    assert counters.differences({"servo_rk4.rhs_per_second": 40_900.0}, stored) != []          # +2.2 %
    assert counters.differences({"kernel_10_tasks.events_per_job": 2.0001}, stored) != []      # exact
    with pytest.raises(KeyError):
        counters.differences({"nope": 1.0}, stored)
