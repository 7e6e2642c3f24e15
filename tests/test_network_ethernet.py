"""CSMA/CD (TrueTime semantics) and switched Ethernet (store-and-forward)."""

import pytest
from conftest import frame_rows

from netcosim import Simulation
from netcosim.network import BROADCAST, CSMACD, SwitchedEthernet

US = 1e-6
SLOT = 51.2 * US           # 512 bits at 10 Mbit/s: frame time of a minimum frame, the backoff unit
WINDOW = 1 * US


def at(sim, t, fn):
    sim.call_at(t, fn)


def csma(seed=0, **kw):
    sim = Simulation(seed=seed)
    net = CSMACD(sim, "eth", **kw)
    nodes = [net.attach(n) for n in ("a", "b", "c")]
    net.attach("sink", mailbox=False)
    return sim, net, nodes


def test_a_node_sensing_the_medium_busy_waits_and_sends_when_it_goes_idle():
    sim, net, (a, b, c) = csma()
    a.send("sink", None, 512)
    at(sim, 10 * US, lambda: b.send("sink", None, 512))
    sim.run(1e-3)
    st = frame_rows(net, "attempt_start")
    assert st["src"].tolist() == ["a", "b"]
    assert st["time"].tolist() == pytest.approx([0.0, SLOT], abs=1e-12)
    assert set(frame_rows(net, "attempt_end")["outcome"]) == {"ok"}
    assert net.collisions == 0


def test_frames_padded_to_the_minimum_frame():
    sim, net, (a, b, c) = csma()
    m = a.send("sink", None, 100)
    sim.run(1e-3)
    assert m.delivered == pytest.approx(SLOT, abs=1e-12)


def test_starts_within_the_collision_window_collide_and_abort_a_window_after_the_last_start():
    sim, net, (a, b, c) = csma(jam_bits=32)
    a.send("sink", None, 1000)
    at(sim, 0.5 * US, lambda: b.send("sink", None, 1000))
    sim.run(1e-3)
    end = frame_rows(net, "attempt_end")
    first = end[end["outcome"] == "collision"]
    assert sorted(first["src"]) == ["a", "b"]
    assert first["time"].tolist() == pytest.approx([0.5 * US + WINDOW + 3.2 * US] * 2, abs=1e-12)


def test_all_nodes_waiting_for_the_idle_instant_transmit_together_and_collide():
    sim, net, (a, b, c) = csma()
    a.send("sink", None, 512)
    at(sim, 10 * US, lambda: (b.send("sink", None, 512), c.send("sink", None, 512)))
    sim.run(1e-3)
    st = frame_rows(net, "attempt_start")
    assert st[st["src"] != "a"]["time"].tolist()[:2] == pytest.approx([SLOT, SLOT], abs=1e-12)
    coll = frame_rows(net, "attempt_end")
    coll = coll[coll["outcome"] == "collision"]
    assert coll["time"].tolist()[:2] == pytest.approx([SLOT + WINDOW] * 2, abs=1e-12)


def _first_backoffs(seed):
    s = Simulation(seed=seed)
    return int(s.rng("eth/a/backoff").integers(0, 2)), int(s.rng("eth/b/backoff").integers(0, 2))


def test_binary_exponential_backoff_after_a_collision():
    # find seeds where the first backoffs (U{0, 1} slots) differ and where they are equal
    differ = next(s for s in range(50) if len(set(_first_backoffs(s))) == 2)
    equal = next(s for s in range(50) if len(set(_first_backoffs(s))) == 1)

    sim, net, (a, b, c) = csma(seed=differ)
    a.send("sink", None, 512)
    b.send("sink", None, 512)
    sim.run(1e-3)
    ka, kb = _first_backoffs(differ)
    st = frame_rows(net, "attempt_start")
    winner = "a" if ka == 0 else "b"
    # the node that drew 0 retries at once; the other wakes one slot later, just as the
    # medium goes idle, and follows
    assert st["src"].tolist() == ["a", "b", winner, "b" if winner == "a" else "a"]
    assert st["time"].tolist() == pytest.approx([0, 0, WINDOW, WINDOW + SLOT], abs=1e-12)
    assert frame_rows(net, "attempt_end")["outcome"].tolist() == ["collision", "collision", "ok", "ok"]

    sim, net, (a, b, c) = csma(seed=equal)
    a.send("sink", None, 512)
    b.send("sink", None, 512)
    sim.run(1e-3)
    k = _first_backoffs(equal)[0]
    st = frame_rows(net, "attempt_start")
    assert st["time"].tolist()[2:4] == pytest.approx([WINDOW + k * SLOT] * 2, abs=1e-12)
    assert frame_rows(net, "attempt_end")["outcome"].tolist()[2:4] == ["collision", "collision"]
    assert net.collisions >= 2


def test_max_attempts_drops_frames_after_the_last_collision():
    sim, net, (a, b, c) = csma(max_attempts=1)
    a.send("sink", None, 512)
    b.send("sink", None, 512)
    sim.run(1e-3)
    lost = frame_rows(net, "lost")
    assert lost["outcome"].tolist() == ["retry_limit", "retry_limit"]
    assert frame_rows(net, "delivered").empty


def test_csma_cd_bad_input():
    with pytest.raises(ValueError, match="min_frame_bits > 0 or an explicit slot_time"):
        CSMACD(Simulation(), "e", min_frame_bits=0)
    with pytest.raises(ValueError, match="max_attempts.*0"):
        CSMACD(Simulation(), "e", max_attempts=0)


# ------------------------------------------------------------------ switched Ethernet
def switched(**kw):
    sim = Simulation()
    net = SwitchedEthernet(sim, "sw", data_rate=10e6, **kw)
    nodes = [net.attach(n) for n in ("a", "b", "c")]
    return sim, net, nodes


def test_store_and_forward_takes_two_frame_times_plus_the_switch_delay():
    sim, net, (a, b, c) = switched(switch_delay=5 * US)
    m = a.send("c", None, 1000)
    sim.run(1e-3)
    assert m.delivered == pytest.approx(100 * US + 5 * US + 100 * US, abs=1e-12)


def test_full_duplex_links_do_not_contend_but_output_ports_queue():
    sim, net, (a, b, c) = switched()
    mab, mba = a.send("b", None, 1000), b.send("a", None, 1000)
    m1, m2 = a.send("c", None, 1000), b.send("c", None, 1000)
    sim.run(1e-3)
    assert mab.delivered == pytest.approx(200 * US, abs=1e-12)
    assert mba.delivered == pytest.approx(200 * US, abs=1e-12)
    # both reach the switch at 200 us; c's port sends them one after the other
    assert sorted([m1.delivered, m2.delivered]) == pytest.approx([300 * US, 400 * US], abs=1e-12)


def test_broadcast_is_copied_to_every_other_port():
    sim, net, (a, b, c) = switched()
    a.send(BROADCAST, None, 1000)
    sim.run(1e-3)
    d = frame_rows(net, "delivered")
    assert sorted(d["node"]) == ["b", "c"] and d["time"].tolist() == pytest.approx([200 * US] * 2, abs=1e-12)


def test_full_switch_memory_drops_frames():
    sim, net, (a, b, c) = switched(switch_memory_bits=1000, overflow="drop")
    a.send("c", None, 1000)
    b.send("c", None, 1000)
    sim.run(1e-3)
    lost = frame_rows(net, "lost")
    assert lost["outcome"].tolist() == ["queue_overflow"] and lost["node"].tolist() == ["switch"]
    assert len(frame_rows(net, "delivered")) == 1
    assert net.memory_peak == 1000 and net.memory_used == 0


def test_full_switch_memory_makes_the_sender_retransmit():
    sim, net, (a, b, c) = switched(switch_memory_bits=1000, overflow="retransmit", switch_delay=5 * US)
    a.send("c", None, 1000)
    mb = b.send("c", None, 1000)
    sim.run(1e-3)
    # a's frame holds the memory from 100 us to 205 us; b's copies arrive at 100 and
    # 200 us (refused) and at 300 us (accepted), then 5 us + 100 us to c
    ends = frame_rows(net, "attempt_end", src="b")
    assert ends["outcome"].tolist() == ["switch_full", "switch_full", "ok"]
    assert ends["time"].tolist() == pytest.approx([100 * US, 200 * US, 300 * US], abs=1e-12)
    assert mb.delivered == pytest.approx(405 * US, abs=1e-12) and mb.attempts == 3


def test_symmetric_buffer_gives_each_output_port_its_share():
    sim, net, (a, b, c) = switched(switch_memory_bits=3000, buffer="symmetric")
    a.send("c", None, 1000)
    b.send("c", None, 1000)                 # c's share (1000 bits) is full: dropped
    c.send("a", None, 1000)                 # a's share is free
    sim.run(1e-3)
    assert frame_rows(net, "lost")["src"].tolist() == ["b"]
    assert sorted(frame_rows(net, "delivered")["node"]) == ["a", "c"]
    with pytest.raises(ValueError, match="overflow"):
        SwitchedEthernet(Simulation(), "x", overflow="panic")
