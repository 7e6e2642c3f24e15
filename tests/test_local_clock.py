"""A node's local clock (netcosim.kernel.localclock, netcosim.kernel.localtime): periods,
offsets, ctx.now, sleeps, timers and deadlines in local time; steps and slews re-map what
is pending; the instants against hand-computed ones, in ticks (1 ps).

Rounding rule under test: an event due at local time L happens at the first global tick at
which the clock reads at least L (a ceiling), computed from L itself, so release k of a
task with period h on a clock of rate r = 1 + drift lands at ceil(k*h/r) ticks: never more
than one tick late, whatever k.
"""

import math
from fractions import Fraction

import pytest

from netcosim import ConfigurationError, ConfigurationTypeError, LocalClock, Simulation
from netcosim.kernel.localtime import LocalTaskContext
from netcosim.kernel.releases import Releases
from netcosim.kernel.task import TaskContext

TPS = 10**12
MS = 10**9          # ticks per millisecond


def periodic_releases(node, *, period, offset=0.0, priority=5, cpu=1e-4, name="t"):
    """A periodic task recording (global tick, ctx.now) at each job start."""
    seen = []

    def body(ctx):
        seen.append((ctx.job.release, ctx.sim.env.now, ctx.now))
        yield ctx.execute(cpu)
    node.periodic(body, period=period, offset=offset, priority=priority, name=name)
    return seen


@pytest.mark.parametrize("drift", [50e-6, -50e-6, 0.25, -0.5])
def test_drift_only_release_k_is_the_ceiling_of_k_h_over_rate(drift):
    sim = Simulation()
    n = sim.node("a", clock=LocalClock(drift=drift))
    seen = periodic_releases(n, period=0.01)
    sim.run(1.0)
    rate = 1 + Fraction(drift)
    h = 10 * MS
    releases = [r for r, _, _ in seen]
    assert releases == [math.ceil(k * h / rate) for k in range(len(releases))]
    # the number of releases in 1 s of global time: local time 1 s * rate
    assert len(releases) == math.ceil(TPS * rate / h)   # k*h/rate < 1 s (the run stops before 1 s)
    # not accumulating: every release within one tick of k*h/(1 + drift)
    assert all(0 <= r - k * h / rate < 1 for k, r in enumerate(releases))
    # the global period is h/(1 + drift) to the tick
    gaps = {b - a for a, b in zip(releases, releases[1:])}
    assert gaps <= {math.floor(h / rate), math.ceil(h / rate)}


def test_50ppm_period_in_numbers():
    sim = Simulation()
    n = sim.node("a", clock_drift=50e-6)
    seen = periodic_releases(n, period=0.01)
    sim.run(0.05)
    # 10 ms / 1.00005 = 9.99950002499875... ms: release 1 at 9_999_500_025 ticks (ceiling)
    assert [r for r, _, _ in seen] == [0, 9_999_500_025, 19_999_000_050, 29_998_500_075, 39_998_000_100,
                                       49_997_500_125]


def test_ctx_now_is_local_time_and_clock_offset_shifts_absolute_times():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock(offset=0.003, drift=0.25))
    seen = periodic_releases(n, period=0.01)          # relative: first release at creation
    fired = []
    t = n.aperiodic(lambda ctx: fired.append((ctx.sim.env.now, ctx.now)), priority=1, name="timed")
    n.timer(t, at=0.013, period=0.005)                # absolute local times
    sim.run(0.021)
    # ctx.now = 1.25 * t + 0.003 at every job start; releases at local 3, 13, 23 ms
    assert [(r, now) for r, _, now in seen] == [(0, 0.003), (8 * MS, 0.013), (16 * MS, 0.023)]
    # the timer at local 13, 18, 23, 28 ms: global (L - 3 ms) / 1.25 = 8, 12, 16, 20 ms
    assert fired == [(8 * MS, 0.013), (12 * MS, 0.018), (16 * MS, 0.023), (20 * MS, 0.028)]
    assert n.clock.local(0.008) == 0.013 and n.clock.global_time(0.013) == 0.008
    assert n.clock.now() == 0.02925 and n.clock.rate == 1.25


def test_sleep_and_sleep_until_run_on_the_local_clock():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock(offset=0.002, drift=0.25))
    woke = []

    def body(ctx):
        yield ctx.sleep_until(0.012)        # local 12 ms: global (12 - 2) / 1.25 = 8 ms
        woke.append((ctx.sim.env.now, ctx.now))
        yield ctx.sleep(0.005)              # 5 local ms = 4 global ms
        woke.append((ctx.sim.env.now, ctx.now))
        yield ctx.sleep_until(0.001)        # already past: no wait
        woke.append((ctx.sim.env.now, ctx.now))
    t = n.aperiodic(body, priority=1, name="s")
    sim.call_at(0.0, t.release)
    sim.run(0.1)
    assert woke == [(8 * MS, 0.012), (12 * MS, 0.017), (12 * MS, 0.017)]


def _stepper(sim, node, at_global, action):
    """An interrupt handler on *node* that runs *action(ctx)* at global time *at_global*."""
    def body(ctx):
        action(ctx)
    h = node.handler(body, priority=0, name="stepper")
    sim.call_at(at_global, h.release)


def test_step_forward_releases_once_at_once_and_counts_the_skipped():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    seen = periodic_releases(n, period=0.01)
    _stepper(sim, n, 0.025, lambda ctx: ctx.clock.set(0.057))  # local 25 -> 57 ms: 30, 40, 50 skipped
    sim.run(0.05)
    task = n.tasks["t"]
    # 0, 10, 20 ms; the step at 25 ms: one release at once (30 due), 40 and 50 counted;
    # then local 60, 70 ms at global 28, 38, 48 ms
    assert [r for r, _, _ in seen] == [0, 10 * MS, 20 * MS, 25 * MS, 28 * MS, 38 * MS, 48 * MS]
    assert task.missed_releases == 2 and n.clock.steps == 1
    assert n.clock.local(0.024) == 0.024 and n.clock.local(0.025) == 0.057


def test_step_backward_delays_absolute_waits_not_relative_sleeps():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    seen = periodic_releases(n, period=0.01, priority=9)
    woke = {}

    def sleeper(ctx):
        yield ctx.sleep(0.010)                  # from 22 ms: 10 ms of clock, whatever the step
        woke["sleep"] = ctx.sim.env.now

    def until(ctx):
        yield ctx.sleep_until(0.030)            # local 30 ms: after the step back, at global 50 ms
        woke["until"] = ctx.sim.env.now
    a, b = n.aperiodic(sleeper, priority=2, name="sleeper"), n.aperiodic(until, priority=3, name="until")
    sim.call_at(0.022, a.release)
    sim.call_at(0.022, b.release)
    _stepper(sim, n, 0.025, lambda ctx: ctx.clock.step(-0.020))   # local 25 -> 5 ms
    sim.run(0.06)
    assert woke == {"sleep": 32 * MS, "until": 50 * MS}
    assert [r for r, _, _ in seen] == [0, 10 * MS, 20 * MS, 50 * MS]
    assert n.tasks["t"].missed_releases == 0


def test_step_forward_wakes_skipped_absolute_sleeps_and_timers_at_once():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    woke = []
    fired = []

    def until(ctx):
        yield ctx.sleep_until(0.040)
        woke.append(ctx.sim.env.now)
    u = n.aperiodic(until, priority=3, name="until")
    sim.call_at(0.0, u.release)
    t = n.aperiodic(lambda ctx: fired.append(ctx.sim.env.now), priority=4, name="timed")
    timer = n.timer(t, at=0.005, period=0.010)            # local 5, 15, 25, ...
    _stepper(sim, n, 0.012, lambda ctx: ctx.clock.set(0.047))   # skips 15, 25, 35, 45 and the sleep's 40
    sim.run(0.06)
    assert woke == [12 * MS]
    # 5 ms; at the step once (15 due, 25, 35, 45 skipped); then local 55, 65 -> global 20, 30 ms ...
    assert fired[:4] == [5 * MS, 12 * MS, 20 * MS, 30 * MS] and timer.overruns == 3


def test_slew_gains_delta_over_the_interval_then_runs_at_the_base_rate():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    seen = periodic_releases(n, period=0.01)
    left = []
    sim.call_at(0.0, lambda: left.append(n.clock.adjust(1e-3, over=0.1)))   # rate 1.01 for 100 ms
    sim.run(0.13)
    releases = [r for r, _, _ in seen]
    # local k*10 ms during the slew at ceil(k*1e10/1.01); the slew ends at global 100 ms
    # (local 101 ms): local 110, 120 ms at global 109, 119, 129 ms
    assert releases[:11] == [math.ceil(Fraction(k * 10 * MS) / Fraction(101, 100)) for k in range(11)]
    assert releases[11:] == [109 * MS, 119 * MS, 129 * MS]
    assert n.clock.local(0.1) == 0.101 and n.clock.local(0.13) == 0.131 and left == [0.0]
    # monotone: never backwards, and the reading continuous
    assert all(n.clock.local(a / 1000) < n.clock.local((a + 1) / 1000) for a in range(130))


def test_negative_slew_runs_slower_never_backwards_and_a_new_one_replaces_it():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    seen = periodic_releases(n, period=0.01)
    left = []
    sim.call_at(0.0, lambda: left.append(n.clock.adjust(-2e-3, over=0.1)))  # rate 0.98
    sim.call_at(0.05, lambda: left.append(n.clock.adjust(0.0, over=0.01)))   # -1 ms still to lose: dropped
    sim.run(0.07)
    assert left == [0.0, -0.001]
    # local 49 ms at global 50 ms, then rate 1: local 50, 60 ms at global 51, 61 ms
    assert [r for r, _, _ in seen] == [math.ceil(Fraction(k * 10 * MS) / Fraction(98, 100)) for k in range(5)] \
        + [51 * MS, 61 * MS]
    assert n.clock.local(0.05) == 0.049 and n.clock.slews == 2


def test_slew_moves_a_pending_sleep_with_the_rate():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    woke = []

    def body(ctx):
        yield ctx.sleep(0.020)
        woke.append(ctx.sim.env.now)
    t = n.aperiodic(body, priority=1, name="s")
    sim.call_at(0.0, t.release)
    sim.call_at(0.010, lambda: n.clock.adjust(0.005, over=0.010))  # from 10 ms: rate 1.5 for 10 ms
    sim.run(0.1)
    # local 10 ms at global 10 ms; local 20 ms at 10 + 10/1.5 ms
    assert woke == [10 * MS + math.ceil(Fraction(10 * MS) / Fraction(3, 2))]


def test_deadline_is_relative_to_the_release_in_local_time_and_cpu_time_is_not_scaled():
    sim = Simulation()
    n = sim.node("a", clock_drift=-0.5)                 # local time at half the rate
    jobs = []
    for name, c in (("ok", 0.006), ("late", 0.009)):
        t = n.aperiodic(lambda ctx, c=c: (yield ctx.execute(c)), priority=1, deadline=0.004, name=name)
        sim.call_at(0.0 if name == "ok" else 0.1, t.release)
        jobs.append(t)
    sim.run(0.2)
    df = sim.trace.jobs().set_index("task")
    # deadline 4 local ms = 8 global ms after the release; execution 6 and 9 ms of CPU as given
    assert df.loc["ok", "deadline"] == 0.008 and df.loc["ok", "finish"] == 0.006
    assert not df.loc["ok", "deadline_miss"]
    assert df.loc["late", "deadline"] == pytest.approx(0.108, abs=1e-15) and df.loc["late", "finish"] == 0.109
    assert df.loc["late", "deadline_miss"]


def test_no_clock_keeps_the_kernel_code_path_and_reads_as_simulation_time():
    sim = Simulation()
    n = sim.node("a")
    t = n.periodic(lambda ctx: None, period=0.01, priority=1, name="t")
    assert n._local is None and type(n._releases) is Releases and type(t.ctx) is TaskContext
    assert "_release" not in vars(n)
    sim.run(0.02)
    assert n.clock.local(0.015) == 0.015 and n.clock.global_time(0.015) == 0.015 and n.clock.now() == 0.02
    with pytest.raises(ConfigurationError, match=r"node 'a' runs on simulation time.*clock=LocalClock"):
        n.clock.set(1.0)
    with pytest.raises(ConfigurationError, match=r"node 'a'"):
        t.ctx.clock.adjust(1e-3, over=1.0)
    m = sim.node("b", clock=LocalClock())
    assert type(m.periodic(lambda ctx: None, period=0.01, priority=1).ctx) is LocalTaskContext


def test_an_identity_clock_gives_the_schedule_of_no_clock():
    def run(**kw):
        sim = Simulation(seed=3)
        n = sim.node("cpu", **kw)
        for i, (c, h) in enumerate([(0.001, 0.004), (0.002, 0.006), (0.003, 0.008)], start=1):
            n.periodic(lambda ctx, c=c: (yield ctx.execute(c)), period=h, priority=i, name=f"t{i}", offset=0.0005 * i)
        done = []
        s = n.aperiodic(lambda ctx: (yield ctx.sleep(0.0013)) or done.append(ctx.now), priority=0, name="s")
        n.timer(s, at=0.0021, period=0.0051)
        sim.run(0.1)
        return sim.trace.jobs(), sim.trace.schedule(), done
    jobs0, sched0, done0 = run()
    jobs1, sched1, done1 = run(clock=LocalClock())
    assert jobs0.equals(jobs1) and sched0.equals(sched1) and done0 == done1 and len(jobs0) > 60


@pytest.mark.parametrize("make, error, match", [
    (lambda: LocalClock(drift=-1.0), ConfigurationError, r"drift=-1.0 must be finite and > -1"),
    (lambda: LocalClock(drift=-2), ConfigurationError, r"drift=-2 must be"),
    (lambda: LocalClock(drift=math.nan), ConfigurationError, r"drift=nan"),
    (lambda: LocalClock(drift=math.inf), ConfigurationError, r"drift=inf"),
    (lambda: LocalClock(drift="50ppm"), ConfigurationTypeError, r"drift must be a real number.*'50ppm'"),
    (lambda: LocalClock(drift=True), ConfigurationTypeError, r"drift must be a real number.*True"),
    (lambda: LocalClock(offset=math.nan), ConfigurationError, r"offset must be finite, got nan"),
    (lambda: Simulation().node("a", clock="fast"), ConfigurationTypeError,
     r"node 'a': clock must be a LocalClock.*'fast'"),
    (lambda: Simulation().node("a", clock=LocalClock(), clock_drift=1e-6), ConfigurationError,
     r"node 'a': pass either clock="),
    (lambda: Simulation().node("a", clock_drift=-3.0), ConfigurationError, r"drift=-3.0"),
])
def test_bad_clock_configuration_is_refused_naming_the_value(make, error, match):
    with pytest.raises(error, match=match):
        make()


def test_bad_clock_changes_are_refused_naming_the_value():
    sim = Simulation()
    c = LocalClock(offset=0.01)
    n = sim.node("a", clock=c)
    with pytest.raises(ConfigurationError, match=r"already serves node 'a'.*node 'b'"):
        sim.node("b", clock=c)
    with pytest.raises(ConfigurationError, match=r"adjust\(delta=-0.2, over=0.1\).*backwards"):
        c.adjust(-0.2, over=0.1)
    with pytest.raises(ConfigurationError, match=r"over=0 s must be positive"):
        c.adjust(0.001, over=0)
    with pytest.raises(ConfigurationError, match=r"set local must be finite, got inf"):
        c.set(math.inf)
    t = n.aperiodic(lambda ctx: None, priority=1, name="t")
    with pytest.raises(ConfigurationError, match=r"at=0.005 s lies in the past of node 'a'.s clock .*0.01 s"):
        n.timer(t, at=0.005)
    with pytest.raises(ConfigurationError, match=r"serves no node yet"):
        LocalClock().set(1.0)
    assert c.steps == 0 and c.slews == 0      # nothing refused changed the clock


def test_slew_by_rate_correction_is_adjust_of_rate_times_duration():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock(drift=0.25))
    sim.call_at(0.0, lambda: n.clock.slew(0.25, duration=0.1))      # rate 1.25 x 1.25 for 80 ms
    sim.run(0.2)
    # 0.1 s at the base rate 1.25 = 80 ms of simulation time, gaining 0.25 x 0.1 s: local
    # 0.1 + 0.025 at 80 ms, then 1.25 per second again
    assert n.clock.local(0.08) == 0.125 and n.clock.local(0.2) == 0.275
    assert n.clock.global_time(0.125) == 0.08 and n.clock.rate == 1.25


def test_a_step_during_a_slew_abandons_it_and_global_time_sees_the_step():
    sim = Simulation()
    n = sim.node("a", clock=LocalClock())
    sim.call_at(0.0, lambda: n.clock.adjust(0.01, over=0.1))        # rate 1.1 for 100 ms
    sim.call_at(0.05, lambda: n.clock.set(1.0))                      # local 55 ms -> 1 s
    sim.run(0.1)
    assert n.clock.local(0.05) == 1.0 and n.clock.local(0.1) == 1.05  # rate 1 after the step
    # before the step the clock read up to 55 ms; local 0.5 s was never read: the step's instant
    assert n.clock.global_time(0.011) == 0.01 and n.clock.global_time(0.5) == 0.05
    assert n.clock.steps == 1 and n.clock.slews == 1


def test_deadline_miss_handler_fires_at_the_local_deadline():
    sim = Simulation()
    n = sim.node("a", clock_drift=-0.5)
    killed = []
    t = n.aperiodic(lambda ctx: (yield ctx.execute(0.02)), priority=1, deadline=0.004, name="late",
                    on_deadline_miss=lambda job: killed.append(job.node.sim.now))
    sim.call_at(0.001, t.release)
    sim.run(0.1)
    assert killed == [0.009] and t.misses == 1                        # 1 ms + 4 local ms at rate 0.5
