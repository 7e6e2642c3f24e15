"""netcosim's time range: integer ticks of 1 ps stored as signed 64-bit integers, so every
instant up to 2**63 - 1 ps (9.22e6 s, 106.7 simulated days) is representable and readable
back; anything beyond is refused where it is given, before a run starts."""

from __future__ import annotations

import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError
from netcosim.timebase import MAX_SECONDS, MAX_TICKS, to_ticks


def test_the_range_is_what_int64_ticks_hold():
    assert MAX_TICKS == 2**63 - 1 and MAX_SECONDS == pytest.approx(9.223372e6)
    assert to_ticks(9.0e6) == 9 * 10**18
    for bad in (1e300, 1e7, -1e7):
        with pytest.raises(ConfigurationError, match=r"period=.* s lies beyond netcosim's time range, 9\.22337e\+06 s"):
            to_ticks(bad, "period", allow_negative=True)


def test_until_past_the_range_is_refused_before_the_run_and_the_simulation_goes_on():
    sim = Simulation()
    node = sim.node("cpu")

    @node.periodic(period=1.0e6, priority=1, name="slow")
    def slow(ctx):
        yield ctx.execute(1.0)
    with pytest.raises(ConfigurationError, match=r"until=1e\+300 s lies beyond netcosim's time range"):
        sim.run(until=1e300)
    assert sim.now == 0.0 and sim.failure is None
    sim.run(until=9.2e6)        # near the end of the range: 10 jobs, every table readable
    jobs = sim.trace.frame("jobs")
    assert len(jobs) == 10 and jobs["release"].max() == pytest.approx(9.0e6)
    sched = sim.trace.frame("schedule")
    assert sched["time"].max() == pytest.approx(9.0e6 + 1.0)


def test_the_largest_accepted_time_fits_in_int64_ticks_and_the_next_float_is_refused():
    import math

    from netcosim.errors import ConfigurationError
    from netcosim.timebase import MAX_SECONDS, MAX_TICKS, to_ticks
    assert to_ticks(MAX_SECONDS) <= MAX_TICKS
    # MAX_TICKS / 1e12 rounds up to 2**63 ticks: once accepted, its deadline overflowed int64
    assert MAX_TICKS / 1e12 == math.nextafter(MAX_SECONDS, math.inf)
    with pytest.raises(ConfigurationError, match="beyond netcosim's time range"):
        to_ticks(MAX_TICKS / 1e12)
    with pytest.raises(ConfigurationError, match="beyond netcosim's time range"):
        to_ticks(-MAX_TICKS / 1e12, allow_negative=True)


def test_a_deadline_beyond_the_tick_range_is_reported_as_a_float_not_wrapped():
    # a release late in the range plus a relative deadline that together pass 2**63 - 1
    # ticks: the jobs table reports their float sum (it once wrapped to a negative time)
    sim = Simulation()
    cpu = sim.node("cpu")
    sim.run(MAX_SECONDS / 2 + 1.0)

    @cpu.aperiodic(priority=1, deadline=MAX_SECONDS * 0.75)
    def late(ctx):
        yield ctx.execute(1e-3)
    late.release()
    sim.run(MAX_SECONDS / 2 + 2.0)
    jobs = sim.trace.jobs()
    assert len(jobs) == 1
    deadline = jobs["deadline"].iloc[0]
    assert deadline > MAX_SECONDS and deadline == pytest.approx(MAX_SECONDS * 1.25 + 1.0, rel=1e-12)
