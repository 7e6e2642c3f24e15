"""Speed changes (DVS), CPU and radio energy, batteries: known schedules, hand-computed answers."""

import math
import warnings

import pandas as pd
import pytest

from netcosim import Simulation
from netcosim.energy import Battery, ConstantPower, DvsPower, RadioPower
from netcosim.errors import BatteryEmptyWarning, ConfigurationError, ConfigurationTypeError
from netcosim.network import IEEE802154

MS = 1e-3


def _jobs(sim):
    return sim.trace.jobs()


# ----------------------------------------------------------------------------- DVS
def test_half_speed_doubles_execution_times_exactly():
    out = {}
    for speed in (1.0, 0.5):
        sim = Simulation()
        cpu = sim.node("cpu", speed=speed)
        cpu.periodic(lambda ctx: (yield ctx.execute(3 * MS)), period=10 * MS, priority=1, name="a")
        sim.run(0.05)
        out[speed] = _jobs(sim)["execution_time"].to_numpy()
    assert (out[0.5] == 2 * out[1.0]).all()
    assert out[0.5][0] == 6 * MS


def test_speed_change_mid_segment_gives_the_hand_computed_finish():
    # 4 ms of work from t = 0; at t = 1 ms (1 ms of work done) the speed halves: the 3 ms of
    # work left take 6 ms, so the job finishes at 7 ms; execution time 7 ms of CPU
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.periodic(lambda ctx: (yield ctx.execute(4 * MS)), period=20 * MS, priority=1, name="a")
    sim.call_at(1 * MS, lambda: cpu.set_speed(0.5))
    sim.run(0.01)
    j = _jobs(sim).iloc[0]
    assert j["finish"] == pytest.approx(7 * MS, abs=1e-15)
    assert j["execution_time"] == pytest.approx(7 * MS, abs=1e-15)
    assert cpu.speed == 0.5


def test_speed_change_of_a_preempted_job_and_repeated_changes_conserve_work():
    # low: 5 ms of work from 0; high preempts it at 1 ms for 1 ms; speed 2 from 1.5 ms (high's
    # 0.5 ms of work left takes 0.25 ms, ends at 1.75); speed 0.25 from 3 ms: low ran
    # 1.25 ms at speed 2 = 2.5 ms of work, 1 + 2.5 = 3.5 done, 1.5 ms left takes 6 ms -> 9 ms
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.periodic(lambda ctx: (yield ctx.execute(5 * MS)), period=50 * MS, priority=2, name="low")
    cpu.periodic(lambda ctx: (yield ctx.execute(1 * MS)), period=50 * MS, offset=1 * MS, priority=1,
                 name="high")
    sim.call_at(1.5 * MS, lambda: cpu.set_speed(2.0))
    sim.call_at(3 * MS, lambda: cpu.set_speed(0.25))
    sim.run(0.02)
    j = _jobs(sim).set_index("task")
    assert j.loc["high", "finish"] == pytest.approx(1.75 * MS, abs=1e-15)
    assert j.loc["low", "finish"] == pytest.approx(9 * MS, abs=1e-15)


def test_awkward_speeds_lose_no_work():
    # 1 ms of work under speeds 1/3 and 3 in turn: rounding carried, the finish is exact to 1 tick
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.periodic(lambda ctx: (yield ctx.execute(1 * MS)), period=1.0, priority=1, name="a")
    t, work, s = 0.0, 0.0, 1.0
    speeds = [1 / 3, 3.0, 1 / 3, 3.0, 0.7]
    times = [0.1 * MS * (k + 1) for k in range(len(speeds))]
    for tk, sk in zip(times, speeds):
        sim.call_at(tk, lambda sk=sk: cpu.set_speed(sk))
    for tk, sk in zip(times, speeds):
        work += (tk - t) * s
        t, s = tk, sk
    expected = t + (1 * MS - work) / s
    sim.run(0.01)
    assert _jobs(sim)["finish"].iloc[0] == pytest.approx(expected, abs=1.5e-12)


def test_context_switch_scales_with_speed_set_at_run_time():
    sim = Simulation()
    cpu = sim.node("cpu", context_switch=0.1 * MS)
    cpu.set_speed(0.5)
    cpu.periodic(lambda ctx: (yield ctx.execute(1 * MS)), period=10 * MS, priority=1, name="a")
    sim.run(0.005)
    j = _jobs(sim).iloc[0]
    assert j["start"] == pytest.approx(0.2 * MS, abs=1e-15)
    assert j["finish"] == pytest.approx(2.2 * MS, abs=1e-15)


def test_speed_from_task_code_and_property():
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(1 * MS)
        ctx.node.speed = 0.5
        yield ctx.execute(1 * MS)
    cpu.periodic(body, period=10 * MS, priority=1, name="a")
    sim.run(0.005)
    assert _jobs(sim)["finish"].iloc[0] == pytest.approx(3 * MS, abs=1e-15)


@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "fast"])
def test_bad_speed_names_the_value(bad):
    sim = Simulation()
    cpu = sim.node("cpu")
    with pytest.raises((ConfigurationError, ConfigurationTypeError), match="speed"):
        cpu.set_speed(bad)
    assert cpu.speed == 1.0


# ----------------------------------------------------------------------------- CPU energy
def test_energy_of_a_known_schedule_is_the_integral_of_the_power_model():
    # one task, 2 ms every 10 ms, over 50 ms; speed 0.5 from t = 25 ms (between jobs): jobs 0-2
    # busy 2 ms at speed 1, jobs 3-4 busy 4 ms at speed 0.5
    model = DvsPower(static=0.1, dynamic=2.0)
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.set_power_model(model)
    cpu.periodic(lambda ctx: (yield ctx.execute(2 * MS)), period=10 * MS, priority=1, name="a")
    sim.call_at(25 * MS, lambda: cpu.set_speed(0.5))
    sim.run(0.05)
    expected = 0.1 * 0.05 + 3 * 2e-3 * 2.0 + 2 * 4e-3 * 2.0 * 0.125
    assert cpu.energy == pytest.approx(expected, rel=1e-12)
    e = sim.trace.frame("energy")
    assert e["energy"].iloc[-1] <= cpu.energy
    assert set(e["power"]) == {0.1, 2.1, 0.35}


def test_constant_power_ignores_the_load():
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.set_power_model(ConstantPower(0.01))
    cpu.periodic(lambda ctx: (yield ctx.execute(3 * MS)), period=10 * MS, priority=1, name="a")
    sim.run(2.0)
    assert cpu.energy == pytest.approx(0.02, rel=1e-12)


def test_unmetered_node_keeps_the_exact_schedule():
    rows = []
    for metered in (False, True):
        sim = Simulation()
        cpu = sim.node("cpu", context_switch=0.05 * MS)
        if metered:
            cpu.set_power_model(DvsPower(0.1, 1.0))
        cpu.periodic(lambda ctx: (yield ctx.execute(2 * MS)), period=5 * MS, priority=2, name="a")
        cpu.periodic(lambda ctx: (yield ctx.execute(1 * MS)), period=3 * MS, priority=1, name="b")
        sim.run(0.1)
        rows.append((_jobs(sim), sim.trace.frame("schedule")))
    pd.testing.assert_frame_equal(rows[0][0], rows[1][0])
    pd.testing.assert_frame_equal(rows[0][1], rows[1][1])


# ----------------------------------------------------------------------------- batteries
def test_battery_empties_at_E_over_P_and_the_node_stops():
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.set_power_model(ConstantPower(0.01))
    bat = cpu.set_battery(Battery(0.3))
    cpu.periodic(lambda ctx: (yield ctx.execute(3 * MS)), period=10 * MS, priority=1, name="a")
    with pytest.warns(BatteryEmptyWarning, match="30 s"):
        sim.run(40.0)
    assert bat.empty_at == pytest.approx(30.0, abs=1e-12)
    assert bat.level == 0.0
    jobs = _jobs(sim)
    assert jobs["release"].max() < 30.0
    assert jobs["finish"].max() <= 30.0
    assert not cpu.powered and cpu.releases_lost == 0       # periodic releases stopped
    marks = sim.trace.frame("energy").query("event == 'empty'")
    assert marks["time"].tolist() == [pytest.approx(30.0)]


def test_battery_with_a_load_dependent_model_empties_at_the_hand_computed_time():
    # 1 W busy + 0 W idle, 2 ms every 10 ms: 2 mJ per period; 0.011 J lasts 5 periods and 1 ms of
    # the sixth job: empty at 51 ms, the running job is stopped (killed) then
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.set_power_model(DvsPower(0.0, 1.0))
    cpu.set_battery(Battery(0.011))
    cpu.periodic(lambda ctx: (yield ctx.execute(2 * MS)), period=10 * MS, priority=1, name="a")
    with pytest.warns(BatteryEmptyWarning):
        sim.run(0.1)
    assert cpu.battery.empty_at == pytest.approx(0.051, abs=1e-12)
    jobs = _jobs(sim)
    assert len(jobs) == 6 and jobs["killed"].tolist() == [False] * 5 + [True]
    assert jobs["finish"].iloc[-1] == pytest.approx(0.051, abs=1e-12)
    assert cpu.energy == pytest.approx(0.011, rel=1e-12)


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf])
def test_bad_battery_capacity_names_the_value(bad):
    with pytest.raises(ConfigurationError, match="capacity"):
        Battery(bad)


def test_bad_initial_charge_and_power_models():
    with pytest.raises(ConfigurationError, match="initial=2"):
        Battery(1.0, initial=2)
    with pytest.raises(ConfigurationError, match="watts"):
        ConstantPower(-0.1)
    with pytest.raises(ConfigurationError, match="efficiency"):
        RadioPower(efficiency=1.5)
    sim = Simulation()
    with pytest.raises(ConfigurationTypeError, match="power model"):
        sim.node("cpu").set_power_model(3.0)


# ----------------------------------------------------------------------------- radios
def _pair(model=None, tx_dbm=0.0):
    sim = Simulation(seed=4)
    net = IEEE802154(sim, "z", tx_power_dbm=tx_dbm)
    a = sim.node("a")
    b = sim.node("b")
    net.attach(a, position=(0.0, 0.0))
    net.attach(b, position=(10.0, 0.0))
    if model is not None:
        net.set_energy_model(model)
    return sim, net, a, b


def test_radio_energy_truetime_model_is_transmit_power_times_air_time():
    sim, net, a, b = _pair(RadioPower.truetime())
    net.interface("a").send("b", "x", 400)
    sim.run(0.1)
    air = 192e-6 + (88 + 400) / 250e3
    ack = 192e-6 + 40 / 250e3
    assert a.energy == pytest.approx(1e-3 * air, rel=1e-12)
    assert b.energy == pytest.approx(1e-3 * ack, rel=1e-12)


def test_radio_energy_with_listening_is_exact():
    m = RadioPower(tx_elec=0.05, efficiency=0.5, rx=0.04, listen=0.03)
    sim, net, a, b = _pair(m)
    net.interface("a").send("b", "x", 400)
    sim.run(0.1)
    att = sim.trace.frame("frames").query("event == 'attempt_start'")["time"].iloc[0]
    air = 192e-6 + (88 + 400) / 250e3
    ack_start = att + air + 192e-6
    ack = 192e-6 + 40 / 250e3
    ea = 0.03 * (0.1 - air - ack) + (0.05 + 1e-3 / 0.5) * air + 0.04 * ack
    eb = 0.03 * (0.1 - air - ack) + 0.04 * air + (0.05 + 1e-3 / 0.5) * ack
    assert a.energy == pytest.approx(ea, rel=1e-12)
    assert b.energy == pytest.approx(eb, rel=1e-12)
    assert ack_start > att


def test_transmit_power_change_takes_effect_at_the_next_frame():
    sim, net, a, b = _pair(RadioPower.truetime())
    ia = net.interface("a")
    ia.send("b", "x", 400)                  # on the air from 1.28 ms to 3.424 ms
    sim.call_at(2e-3, lambda: net.set_tx_power("a", 10.0))
    sim.call_at(0.01, lambda: ia.send("b", "y", 400))
    sim.run(0.1)
    air = 192e-6 + (88 + 400) / 250e3
    assert a.energy == pytest.approx(1e-3 * air + 1e-2 * air, rel=1e-12)
    assert net.tx_power("a") == 10.0
    with pytest.raises(ConfigurationError, match="tx_power_dbm"):
        net.set_tx_power("a", math.nan)


def test_node_out_of_energy_stops_its_radio_frames_to_it_lost_with_a_reason():
    sim, net, a, b = _pair(RadioPower.truetime())
    b.set_power_model(ConstantPower(0.01))
    b.set_battery(Battery(0.001))
    got = []

    def sender(ctx):
        yield ctx.execute(0.1 * MS)
        ctx.node.send("b", ctx.now, 80)
    a.periodic(sender, period=20 * MS, priority=1, name="s")

    def receiver(ctx):
        msg = yield net.interface("b").mailbox.fetch()
        got.append(ctx.now)
        del msg
    b.aperiodic(receiver, priority=1, name="r")
    net.interface("b").handlers.append(lambda *args: b.tasks["r"].release())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BatteryEmptyWarning)
        sim.run(0.2)
    frames = sim.trace.frame("frames")
    lost = frames.query("event == 'lost'")
    t_empty = b.battery.empty_at      # 10 mW for the CPU, 1 mW while b sends its ACKs: just before 0.1 s
    assert 0.099 < t_empty < 0.1
    assert b.energy == pytest.approx(0.001, rel=1e-12)
    # each attempt fails at the dead destination for that reason, the frame then hits the retry limit
    ends = frames.query(f"event == 'attempt_end' and time > {t_empty}")
    assert set(ends["outcome"]) == {"battery_empty"} and len(ends) == 5 * net.max_attempts
    assert set(lost["outcome"]) == {"retry_limit"}
    assert lost["time"].min() > t_empty and len(lost) == 5      # the sends at 0.1, 0.12, ... 0.18 s
    assert len(got) == 5 and all(t < t_empty for t in got)
    after = frames.query(f"time > {t_empty} and event == 'attempt_start' and src == 'b'")
    assert after.empty                      # b never acknowledges again


def test_radio_tables_unchanged_without_energy():
    out = []
    for metered in (False, True):
        sim, net, a, b = _pair(RadioPower() if metered else None)
        ia = net.interface("a")
        for k in range(5):
            sim.call_at(k * 0.01, lambda k=k: ia.send("b", k, 400))
        sim.run(0.1)
        out.append(sim.trace.frame("frames"))
    pd.testing.assert_frame_equal(out[0], out[1])


def test_power_off_kills_running_and_preempted_jobs_and_runs_no_other_code():
    # busy 1 W, idle 0: 2 mJ last 2 ms of CPU; low runs 0-1 ms, high preempts it at 1 ms and is
    # running when the battery empties at 2 ms, mid (released at 1.5 ms) waits; killing high must
    # not start mid: no task code runs after the instant, no job row follows
    ran = []
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.set_power_model(DvsPower(0.0, 1.0))
    cpu.set_battery(Battery(0.002))

    def body(name, c):
        def b(ctx):
            ran.append(name)
            yield ctx.execute(c)
            ran.append(name + " done")
        return b
    cpu.periodic(body("high", 2 * MS), period=10 * MS, offset=1 * MS, priority=1, name="high")
    cpu.periodic(body("mid", 2 * MS), period=10 * MS, offset=1.5 * MS, priority=1.5, name="mid")
    cpu.periodic(body("low", 5 * MS), period=10 * MS, priority=2, name="low")
    cpu.aperiodic(body("late", 1 * MS), priority=0, name="late")
    sim.call_at(5 * MS, cpu.tasks["late"].release)
    with pytest.warns(BatteryEmptyWarning):
        sim.run(0.05)
    jobs = _jobs(sim).set_index("task")
    assert ran == ["low", "high"]
    assert sorted(jobs.index) == ["high", "low", "mid"]
    assert jobs["killed"].all() and jobs["finish"].tolist() == pytest.approx([2 * MS] * 3, abs=1e-15)
    assert jobs["start"].isna().tolist() == [False, True, False]    # mid never started
    assert cpu.releases_lost == 1 and not cpu.powered
    assert cpu.energy == pytest.approx(0.002, rel=1e-12)


def test_multicore_core_keeps_its_context_switch_timer():
    sim = Simulation()
    cpu = sim.node("cpu", cores=2, context_switch=0.1 * MS)
    cpu.periodic(lambda ctx: (yield ctx.execute(1 * MS)), period=10 * MS, priority=1, name="a", core=1)
    sim.run(0.005)
    j = _jobs(sim).iloc[0]
    assert j["start"] == pytest.approx(0.1 * MS, abs=1e-15) and j["finish"] == pytest.approx(1.1 * MS, abs=1e-15)
