"""How the network tables store their rows (netcosim/network/tracing.py): in ``keep`` mode a
stored ``frames`` row may stand for two reported rows (``created`` + ``queued``;
``attempt_end`` + the ``delivered`` right after it), the ``network_schedule`` appends every
state change and the other modes keep one row per node and instant (``Recorder.instant``).
Whatever the mode, the tables read are the same, row for row."""

import math

import pandas as pd
import pytest

from netcosim import Simulation
from netcosim.network import BROADCAST, CAN, can_frame_bits
from netcosim.packing import INT64, PackError, typed_array
from netcosim.recorder import Recorder


def _two_frames(sim):
    """Two 8-byte standard frames queued at t = 0 on a 500 kbit/s bus: 270 µs each."""
    bus = CAN(sim, "can", data_rate=500e3, frame_format="standard")
    hi, lo, sink = bus.attach("hi", priority=1), bus.attach("lo", priority=2), bus.attach("sink")
    lo.send(sink, None, 64)
    hi.send(sink, None, 64)
    return bus


def test_a_can_frame_stores_three_rows_for_its_five_and_reads_back_at_the_known_times():
    sim = Simulation(seed=0)
    _two_frames(sim)
    sim.run(0.001)
    stored = sim.trace.recorder("frames").rows
    assert len(stored) == 6        # per frame: created+queued, attempt_start, attempt_end+delivered
    df = sim.trace.frame("frames")
    hi = df[df["src"] == "hi"]
    assert list(hi["event"]) == ["created", "queued", "attempt_start", "attempt_end", "delivered"]
    assert [round(t * 1e6, 9) for t in hi["time"]] == [0.0, 0.0, 0.0, 270.0, 270.0]
    assert list(hi["node"]) == ["hi"] * 4 + ["sink"]
    assert list(hi["attempt"]) == [0, 0, 1, 1, 1]
    assert list(hi["outcome"]) == ["", "", "", "ok", ""]
    c = can_frame_bits(8)
    assert hi["bits"].tolist()[:3] == [64.0, c, c] and math.isnan(hi["bits"].iloc[3]) and hi["bits"].iloc[4] == c
    assert hi["backoff"].isna().all()
    lo = df[df["src"] == "lo"]
    assert [round(t * 1e6, 9) for t in lo["time"]] == [0.0, 0.0, 270.0, 540.0, 540.0]


def _mixed_traffic(sim):
    """Unicast and broadcast frames, a receiver whose mailbox overflows, random loss and a
    propagation delay on a second bus: every kind of row, merged or not."""
    bus = CAN(sim, "can", data_rate=500e3, frame_format="standard")
    sink = bus.attach("sink", priority=10**6, mailbox_capacity=2)
    nodes = [bus.attach(f"n{i}", priority=i, mailbox=False) for i in range(4)]
    lossy = CAN(sim, "lossy", data_rate=250e3, loss=0.3, propagation_delay=1e-6)
    a, b = lossy.attach("a", priority=1), lossy.attach("b", priority=2)
    rng = sim.rng("traffic")
    c = can_frame_bits(8) / 500e3

    def send(k=0):
        for i, n in enumerate(nodes):
            if rng.uniform() < 0.5:
                n.send(sink if (k + i) % 3 else BROADCAST, None, 64)
        a.send("b", None, 64)
        b.send(BROADCAST, None, 32)
        if k < 40:
            sim.call_in(2 * c, send, k + 1)
    sim.call_at(0.0, send)


def _read(mode, switch=None, clear=False, tmp_path=None):
    sim = Simulation(seed=3)
    _mixed_traffic(sim)

    def configure(m):
        for t in ("frames", "network_schedule"):
            opts: dict = {"ring": {"rows": 10**6}, "window": {"seconds": 10.0}}.get(m, {})
            if m == "stream":
                opts = {"path": tmp_path / f"{t}-{m}", "overwrite": True}
            sim.trace.configure(t, m, **opts)
    configure(mode)
    if switch is not None:
        sim.run(0.004)
        configure(switch)
    if clear:
        sim.run(0.006)
        sim.trace.clear()
    sim.run(0.03)
    return sim.trace.frame("frames"), sim.trace.frame("network_schedule")


@pytest.mark.parametrize("mode,switch,clear", [("ring", None, False), ("window", None, False),
                                               ("stream", None, False), ("keep", "ring", False),
                                               ("keep", "window", False), ("ring", "keep", False)])
def test_every_mode_reads_the_keep_tables_row_for_row(tmp_path, mode, switch, clear):
    frames, sched = _read("keep")
    assert len(frames) > 500 and {"delivered", "lost"} <= set(frames["event"])
    assert set(frames["outcome"]) >= {"ok", "sent", "random_loss", "mailbox_full"}
    f2, s2 = _read(mode, switch, clear, tmp_path)
    pd.testing.assert_frame_equal(f2, frames)
    pd.testing.assert_frame_equal(s2, sched)


def test_clear_mid_run_keeps_the_same_rows_in_keep_and_ring_mode():
    f1, s1 = _read("keep", clear=True)
    f2, s2 = _read("ring", clear=True)
    assert 0 < len(f1) < len(_read("keep")[0])
    pd.testing.assert_frame_equal(f1, f2)
    pd.testing.assert_frame_equal(s1, s2)


def test_instant_rule_one_row_per_key_and_instant_outside_keep_mode():
    rows = [(0, "a", 1), (0, "b", 1), (0, "a", 2), (5, "a", 3), (5, "a", 4), (6, "b", 0)]
    kept = {}
    for mode, opts in (("keep", {}), ("ring", {"rows": 100}), ("ring", {"rows": 2}), ("window", {"seconds": 1e-12})):
        rec = Recorder("t", ("time", "key", "state"), instant=lambda r: r[1])
        rec.configure(mode, **opts)
        for r in rows:
            rec.rows.append(r)
        kept[(mode, opts.get("rows"))] = list(rec.rows)
    assert kept[("keep", None)] == rows
    assert kept[("ring", 100)] == [(0, "a", 2), (0, "b", 1), (5, "a", 4), (6, "b", 0)]
    assert kept[("ring", 2)] == [(5, "a", 4), (6, "b", 0)]
    # the window (1 ps = 1 tick) holds rows of the latest tick: the instant rule applied first
    assert kept[("window", None)] == [(5, "a", 4), (6, "b", 0)]


def test_typed_array_gives_the_bytes_of_array_and_refuses_what_array_refuses():
    ints = (0, 1, -1, 2**62, -(2**63), True, 135)
    assert typed_array(INT64, ints).tobytes() == typed_array("q", ints).tobytes()
    assert typed_array(INT64, ints).tolist() == [0, 1, -1, 2**62, -(2**63), 1, 135]
    floats = (0.5, -0.0, math.nan, math.inf, 135, 2**53)
    got = typed_array("d", floats)
    from array import array
    assert got.tobytes() == array("d", floats).tobytes()
    assert math.copysign(1.0, got[1]) == -1.0 and math.isnan(got[2])
    for bad in ((1, None), (1, 2.0), (2**64,)):
        with pytest.raises(PackError):
            typed_array(INT64, bad)
    with pytest.raises(PackError):
        typed_array("d", (1.0, None))
    assert typed_array("d", ()).tolist() == []
