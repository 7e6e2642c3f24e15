"""Bounded trace memory: every table can be switched off, kept as a ring, a time window,
decimated, or streamed to Parquet, at any time, with exact, known row sets.

The reference schedule: one periodic task, period 1 ms, execution 0.1 ms, logging its
job index; over [0, 1) s it runs exactly 1000 jobs (indices 0..999, released at k ms).
"""

import math

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from conftest import periodic_task

from netcosim import Simulation
from netcosim.network import SaturatedSource, WLAN80211b
from netcosim.trace import Trace

PERIOD, C = 1e-3, 1e-4


def servo_sim(n_signals=1):
    """A node with the 1 ms task; each job logs its index under ``k`` (and ``k2`` = -index)."""
    def body(ctx):
        ctx.log("k", ctx.job.index)
        if n_signals > 1:
            ctx.log("k2", -ctx.job.index)
        yield ctx.execute(C)
    return periodic_task(body, period=PERIOD)


def keep_frames(until=1.0):
    sim = servo_sim()
    sim.run(until)
    return sim.trace.jobs(), sim.trace.schedule(), sim.trace.signals()


def test_reference_schedule_has_1000_jobs_in_keep_mode():
    sim = servo_sim()
    assert sim.trace.mode("jobs") == "keep"
    sim.run(1.0)
    jobs = sim.trace.jobs()
    assert list(jobs["job"]) == list(range(1000))
    # each job: ready, running, idle -> 3 rows per job
    assert len(sim.trace.schedule()) == 3 * 1000


def test_ring_of_100_keeps_exactly_the_last_100_jobs():
    keep_jobs, keep_sched, _ = keep_frames()
    sim = servo_sim()                     # components exist before the table is configured
    sim.trace.configure("jobs", mode="ring", rows=100)
    sim.trace.configure("schedule", mode="ring", rows=100)
    sim.run(1.0)
    jobs = sim.trace.jobs()
    assert list(jobs["job"]) == list(range(900, 1000))
    np.testing.assert_array_equal(jobs["release"].to_numpy(), np.arange(900, 1000) / 1000)
    pd.testing.assert_frame_equal(jobs.reset_index(drop=True),
                                  keep_jobs.iloc[-100:].reset_index(drop=True), check_categorical=False)
    sched = sim.trace.schedule()
    pd.testing.assert_frame_equal(sched, keep_sched.iloc[-100:].reset_index(drop=True),
                                  check_categorical=False)


def test_ring_stays_bounded_over_a_long_run():
    sim = servo_sim()
    sim.trace.configure("jobs", mode="ring", rows=50)
    seen = []

    def watch():
        seen.append(len(sim.trace.recorder("jobs").rows))
        sim.call_in(1e-3, watch)          # every 1 ms
    sim.call_in(0, watch)
    sim.run(20.0)
    assert max(seen) == 50
    assert list(sim.trace.jobs()["job"]) == list(range(19950, 20000))


def test_window_keeps_exactly_the_jobs_released_in_the_last_100_ms():
    sim = servo_sim()
    sim.trace.configure("jobs", mode="window", seconds=0.1)
    sim.trace.configure("signals", mode="window", seconds=0.1)
    held = []

    def watch():
        held.append(len(sim.trace.recorder("jobs").rows))
        sim.call_in(1e-3, watch)
    sim.call_in(0, watch)
    sim.run(0.55)
    # now = 0.55 s: releases 0.450 .. 0.549
    assert list(sim.trace.jobs()["job"]) == list(range(450, 550))
    sim.run(1.0)
    jobs = sim.trace.jobs()
    assert list(jobs["job"]) == list(range(900, 1000))
    assert jobs["release"].min() == pytest.approx(0.9, abs=0)
    # memory: never more than the window's 100 jobs plus the newest one
    assert max(held) <= 101
    sig = sim.trace.signals()
    assert list(sig["value"]) == [float(k) for k in range(900, 1000)]


def test_off_keeps_no_rows_and_reports_empty_frames_with_the_columns():
    sim = servo_sim()
    for name in ("jobs", "schedule", "signals"):
        sim.trace.configure(name, mode="off")
    sim.run(1.0)
    assert len(sim.trace.jobs()) == 0 and len(sim.trace.schedule()) == 0 and len(sim.trace.signals()) == 0
    assert list(sim.trace.signals().columns) == ["time", "source", "signal", "value"]
    assert len(sim.trace.recorder("jobs")) == 0


def test_stream_writes_parquet_files_equal_to_the_keep_frames_bit_for_bit(tmp_path):
    keep_jobs, keep_sched, keep_sig = keep_frames()
    sim = servo_sim()
    sim.trace.configure("jobs", mode="stream", path=tmp_path / "jobs", row_group=300)
    sim.trace.configure("signals", mode="stream", path=tmp_path / "signals", row_group=300)
    sim.run(1.0)
    parts = sorted((tmp_path / "jobs").glob("*.parquet"))
    assert [p.name for p in parts] == ["part-000000.parquet", "part-000001.parquet", "part-000002.parquet"]
    assert len(sim.trace.recorder("jobs").rows) == 100          # only the unwritten rows stay in memory
    assert len(sim.trace.recorder("jobs")) == 1000
    # reading the table: the written rows, then those in memory -- identical to keep mode
    pd.testing.assert_frame_equal(sim.trace.jobs(), keep_jobs, check_exact=True)
    pd.testing.assert_frame_equal(sim.trace.signals(), keep_sig, check_exact=True)
    sim.trace.flush()
    assert len(sim.trace.recorder("jobs").rows) == 0
    on_disk = pd.concat([pq.read_table(p).to_pandas() for p in sorted((tmp_path / "jobs").glob("*.parquet"))],
                        ignore_index=True)
    expected = keep_jobs.astype({"node": str, "task": str})
    pd.testing.assert_frame_equal(on_disk, expected, check_exact=True)
    sig_disk = pd.read_parquet(tmp_path / "signals")
    pd.testing.assert_frame_equal(sig_disk.astype({"source": str, "signal": str}),
                                  keep_sig.astype({"source": str, "signal": str}), check_exact=True)


def test_stream_refuses_to_mix_with_an_earlier_run_unless_told(tmp_path):
    sim = servo_sim()
    sim.trace.configure("jobs", mode="stream", path=tmp_path, row_group=10)
    sim.run(0.05)
    sim2 = servo_sim()
    with pytest.raises(ValueError, match="already holds 5 Parquet"):
        sim2.trace.configure("jobs", mode="stream", path=tmp_path, row_group=10)
    sim2.trace.configure("jobs", mode="stream", path=tmp_path, row_group=10, overwrite=True)
    sim2.run(0.02)
    assert list(sim2.trace.jobs()["job"]) == list(range(20))


def test_every_keeps_every_kth_sample_of_each_signal():
    sim = servo_sim(n_signals=2)
    sim.trace.configure("signals", every=10)
    sim.run(1.0)
    sig = sim.trace.signals()
    k = sig[sig["signal"] == "k"]["value"].tolist()
    k2 = sig[sig["signal"] == "k2"]["value"].tolist()
    assert k == [float(i) for i in range(0, 1000, 10)]
    assert k2 == [-float(i) for i in range(0, 1000, 10)]
    np.testing.assert_array_equal(sig[sig["signal"] == "k"]["time"].to_numpy(), np.arange(0, 1000, 10) / 1000)


def test_every_combines_with_a_ring():
    sim = servo_sim()
    sim.trace.configure("signals", mode="ring", rows=5, every=7)
    sim.run(1.0)
    assert sim.trace.signals()["value"].tolist() == [float(i) for i in range(966, 1000, 7)]


def test_clear_mid_run_keeps_exactly_the_rows_after_it():
    sim = servo_sim()
    sim.run(0.5)
    assert len(sim.trace.jobs()) == 500
    sim.trace.clear()
    sim.run(1.0)
    assert list(sim.trace.jobs()["job"]) == list(range(500, 1000))
    sched = sim.trace.schedule()
    assert sched["time"].min() == 0.5 and len(sched) == 3 * 500
    assert sim.trace.signals()["value"].tolist() == [float(i) for i in range(500, 1000)]


def test_clear_of_a_streamed_table_deletes_its_files_and_streaming_goes_on(tmp_path):
    sim = servo_sim()
    sim.trace.configure("jobs", mode="stream", path=tmp_path, row_group=100)
    sim.run(0.25)
    assert len(list(tmp_path.glob("*.parquet"))) == 2
    sim.trace.clear("jobs")
    assert list(tmp_path.glob("*.parquet")) == []
    sim.run(1.0)
    assert list(sim.trace.jobs()["job"]) == list(range(250, 1000))
    sim.trace.flush()
    disk = pd.read_parquet(tmp_path)
    assert disk["job"].tolist() == list(range(250, 1000))


def test_unfinished_job_is_still_reported_after_clear_and_in_a_ring():
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(0.3)
    cpu.periodic(body, period=1.0, priority=1, name="slow")
    sim.trace.configure("jobs", mode="ring", rows=3)
    sim.run(1.1)                          # job 0 done at 0.3, job 1 running since 1.0
    sim.trace.clear()
    jobs = sim.trace.jobs()
    assert list(jobs["job"]) == [1]
    assert math.isnan(jobs["finish"][0])
    assert jobs["execution_time"][0] == pytest.approx(0.1, abs=1e-12)
    sim.run(1.5)
    jobs = sim.trace.jobs()
    assert list(jobs["job"]) == [1] and jobs["finish"][0] == pytest.approx(1.3, abs=1e-12)


def test_reconfiguring_mid_run_carries_the_held_rows_into_the_new_bounds():
    sim = servo_sim()
    sim.run(0.5)
    sim.trace.configure("jobs", mode="ring", rows=10)
    assert list(sim.trace.jobs()["job"]) == list(range(490, 500))
    sim.trace.configure("jobs", mode="keep")
    sim.run(0.6)
    assert list(sim.trace.jobs()["job"]) == list(range(490, 600))


def test_configure_all_bounds_network_tables_created_later_and_keeps_the_ring_exact():
    def run(configure):
        sim = Simulation(seed=1)
        if configure:
            sim.trace.configure_all(mode="ring", rows=200)
        net = WLAN80211b(sim, "wlan", data_rate=11e6)
        ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
        for i in range(3):
            SaturatedSource(net.attach(f"s{i}", position=(10.0 * math.cos(i), 10.0 * math.sin(i))), ap, 8000)
        sim.run(0.2)
        return sim
    keep, ring = run(False), run(True)
    for name in ("frames", "network_schedule"):
        assert ring.trace.mode(name) == "ring"
        rec = keep.trace._tables[name]
        kept = list(rec.rows)
        assert len(kept) > 400
        # the same-instant overwrite of the network schedule hits the right row in the ring:
        # the ring holds the last 200 of the keep-mode rows as the other modes store them
        # (keep mode stores a frame's created and queued rows as one, and appends a
        # same-instant change, both expanded alike when read)
        assert list(ring.trace._tables[name].rows) == rec.carry(kept)[-200:]
        pd.testing.assert_frame_equal(ring.trace.frame(name), keep.trace.frame(name).iloc[-len(ring.trace.frame(name)):]
                                      .reset_index(drop=True), check_exact=True, check_categorical=False)


def test_per_network_trace_switch_still_records_nothing_whatever_the_table_mode():
    sim = Simulation(seed=1)
    sim.trace.configure_all(mode="ring", rows=100)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, trace=False)
    ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
    SaturatedSource(net.attach("s", position=(10.0, 0.0)), ap, 8000)
    sim.run(0.05)
    assert len(sim.trace.frame("frames")) == 0 and len(sim.trace.frame("network_schedule")) == 0
    assert net.interfaces["s"].stats["sent"] > 10


def test_window_on_a_bare_trace_measures_back_from_the_latest_row():
    tr = Trace()
    rec = tr.table("x", ("time", "v"), time_unit="s")
    tr.configure("x", mode="window", seconds=1.0)
    for i in range(100):
        rec.rows.append((0.25 * i, i))
    assert tr.frame("x")["v"].tolist() == [95, 96, 97, 98, 99]   # time >= 24.75 - 1.0


def test_rti_history_is_bounded_and_the_last_step_is_still_read():
    from test_nmpc import cartpole_ocp

    from netcosim.controllers.nmpc import RTINMPC
    ocp = cartpole_ocp(N=10)
    ctrl = RTINMPC(ocp, x_guess=[0, 0.2, 0, 0])
    unbounded = RTINMPC(ocp, x_guess=[0, 0.2, 0, 0], history_length=None)
    none = RTINMPC(ocp, x_guess=[0, 0.2, 0, 0], history_length=0)
    x = np.array([0.0, 0.2, 0.0, 0.0])
    for _ in range(300):
        r = ctrl.step(x)
        ru = unbounded.step(x)
        rn = none.step(x)
        assert r.t_prepare > 0 and ctrl.last is r
        np.testing.assert_array_equal(r.u, ru.u)
        np.testing.assert_array_equal(rn.u, ru.u)
        x = np.asarray(ocp.F(x, r.u, [])).ravel()
    assert ctrl.history_length == 1 and len(ctrl.history) == 1 and ctrl.history[-1] is ctrl.last
    assert len(unbounded.history) == 300 and unbounded.n_steps == 300
    assert len(none.history) == 0 and none.last is not None
