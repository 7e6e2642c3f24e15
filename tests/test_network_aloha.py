"""Slotted ALOHA: slot timing, collisions and retries, and the textbook throughput."""

import math

import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError
from netcosim.network import SlottedAloha

SLOT = 1e-3


def aloha(**kw):
    sim = Simulation(seed=3)
    return sim, SlottedAloha(sim, "aloha", data_rate=1e6, slot_time=SLOT, **kw)


def test_a_lone_frame_waits_for_the_next_slot_and_takes_one_slot():
    sim, net = aloha()
    a, b = net.attach("a"), net.attach("b")

    def later():
        yield sim.timeout(0.3e-3)
        a.send("b", "x", 800)

    sim.process(later())
    sim.run(0.01)
    msg = b.receive()
    assert msg.payload == "x" and msg.attempts == 1
    assert msg.sent == pytest.approx(1e-3, abs=1e-15) and msg.delivered == pytest.approx(2e-3, abs=1e-15)


def test_colliders_retry_and_give_up_after_max_attempts():
    sim, net = aloha(retry_probability=1.0, max_attempts=3)
    a, b, c = net.attach("a"), net.attach("b"), net.attach("c")
    a.send("c", None, 800)
    b.send("c", None, 800)
    sim.run(0.01)
    df = net.frames()
    ends = df[df["event"] == "attempt_end"]
    # both transmit in slots 0, 1, 2 (p = 1): three collisions each, then both frames are lost
    assert list(ends["outcome"]) == ["collision"] * 6
    assert sorted(ends["time"].round(9)) == [1e-3, 1e-3, 2e-3, 2e-3, 3e-3, 3e-3]
    lost = df[df["event"] == "lost"]
    assert list(lost["outcome"]) == ["retry_limit", "retry_limit"]
    assert a.stats["dropped"] == b.stats["dropped"] == 1 and c.mailbox.try_fetch() is None


def test_retry_probability_must_be_positive():
    with pytest.raises(ConfigurationError, match="retry_probability"):
        aloha(retry_probability=0.0)


N_STATIONS = 400
N_SLOTS = 20_000


@pytest.mark.parametrize("G", [0.25, 0.5, 1.0, 2.0])
def test_throughput_is_G_exp_minus_G_under_poisson_load(G):
    """Poisson(G) new frames per slot, each from a different station among 400, each sent
    once (max_attempts=1), so the attempts per slot are Poisson(G) and a slot succeeds
    with probability G exp(-G), independently: the success count is binomial."""
    sim, net = aloha(max_attempts=1, trace=False)
    sink = net.attach("sink", mailbox=False)
    stations = [net.attach(f"s{i}", mailbox=False) for i in range(N_STATIONS)]
    rng = sim.rng("arrivals")

    def arrivals():
        yield sim.timeout(SLOT / 2)                 # mid-slot: sent at the next boundary
        for _ in range(N_SLOTS):
            for i in rng.choice(N_STATIONS, rng.poisson(G), replace=False):
                stations[i].send(sink, None, 800)
            yield sim.timeout(SLOT)

    sim.process(arrivals())
    sim.run((N_SLOTS + 2) * SLOT)
    ok = sum(s.stats["sent"] for s in stations)
    attempts = ok + sum(s.stats["dropped"] for s in stations)
    s_model = G * math.exp(-G)
    s_sim = ok / N_SLOTS
    assert abs(attempts / N_SLOTS - G) < 4 * math.sqrt(G / N_SLOTS)
    assert abs(s_sim - s_model) < 4 * math.sqrt(s_model * (1 - s_model) / N_SLOTS), (G, s_sim, s_model)
    assert sink.stats["received"] == ok
