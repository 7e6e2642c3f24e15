"""802.11b DCF: exact frame timing, backoff, retries, hidden terminals, Bianchi's saturation throughput."""

import math

import numpy as np
import pytest
from conftest import frame_rows
from scipy.optimize import brentq

from netcosim import Simulation
from netcosim.network import BROADCAST, SaturatedSource, WLAN80211b

US = 1e-6
# 802.11b constants, written out independently of the implementation
SLOT, SIFS, DIFS = 20 * US, 10 * US, 50 * US
PLCP_LONG, PLCP_SHORT = 192 * US, 96 * US
MAC_BITS, ACK_BITS = 224, 112   # 24-byte header + 4-byte FCS; 14-byte ACK


def same_stream(seed, name):
    """The random stream the simulation hands to component *name* (streams are named)."""
    return Simulation(seed=seed).rng(name)


@pytest.mark.parametrize("rate,preamble,size,ack_rate", [
    (1.2e6, "long", 8000, 1e6),      # the thesis' rate; ACK at the 1 Mbit/s basic rate
    (11e6, "long", 12000, 2e6),      # ACK at the highest basic rate <= 11 Mbit/s
    (2e6, "short", 800, 2e6),
])
def test_unicast_on_idle_channel_takes_difs_plcp_data_sifs_ack(rate, preamble, size, ack_rate):
    sim = Simulation(seed=3)
    net = WLAN80211b(sim, "wlan", data_rate=rate, preamble=preamble)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(30.0, 0.0))
    t_send = 0.0123
    sim.call_at(t_send, lambda: a.send("b", "hello", size))
    sim.run(0.2)
    plcp = PLCP_LONG if preamble == "long" else PLCP_SHORT
    data_air = plcp + (MAC_BITS + size) / rate
    ack_air = plcp + ACK_BITS / ack_rate
    start = frame_rows(net, "attempt_start")
    assert len(start) == 1 and math.isnan(start["backoff"][0])      # no backoff on an idle channel
    assert start["time"][0] == pytest.approx(t_send + DIFS, abs=1e-12)
    delivered = frame_rows(net, "delivered", "b")["time"][0]
    assert delivered == pytest.approx(t_send + DIFS + data_air, abs=1e-11)
    assert frame_rows(net, "ack", "b")["time"][0] == pytest.approx(t_send + DIFS + data_air + SIFS, abs=1e-11)
    end = frame_rows(net, "attempt_end")
    assert list(end["outcome"]) == ["ok"]
    total = end["time"][0] - t_send
    assert total == pytest.approx(DIFS + data_air + SIFS + ack_air, abs=1e-11)
    # to the microsecond, spelled out for the thesis case
    if rate == 1.2e6:
        assert round(total / US, 3) == round(50 + 192 + 8224 / 1.2 + 10 + 192 + 112, 3)
    msg = b_msg = net.interfaces["b"].receive()
    assert msg.payload == "hello" and b_msg.attempts == 1


def test_second_frame_waits_for_the_post_backoff_the_standard_requires():
    sim = Simulation(seed=11)
    net = WLAN80211b(sim, "wlan", data_rate=11e6)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0))
    a.send("b", None, 4000)
    a.send("b", None, 4000)
    sim.run(0.1)
    starts, ends = frame_rows(net, "attempt_start"), frame_rows(net, "attempt_end")
    assert list(ends["outcome"]) == ["ok", "ok"]
    # after the first exchange the station draws its post-backoff from CW = 31
    b = int(same_stream(11, "wlan/a/backoff").integers(0, 32))
    assert starts["backoff"][1] == b
    assert starts["time"][1] == pytest.approx(ends["time"][0] + DIFS + b * SLOT, abs=1e-12)


def test_frame_queued_while_medium_busy_defers_past_nav_and_backs_off():
    sim = Simulation(seed=5)
    net = WLAN80211b(sim, "wlan", data_rate=2e6)
    a = net.attach("a", position=(0.0, 0.0))
    c = net.attach("c", position=(0.0, 20.0))
    net.attach("b", position=(20.0, 0.0))
    a.send("b", None, 8000)
    sim.call_at(1e-3, lambda: c.send("b", None, 800))    # a is on the air at 1 ms
    sim.run(0.1)
    st = frame_rows(net, "attempt_start")
    end_a = frame_rows(net, "attempt_end", "a")["time"][0]
    b = int(same_stream(5, "wlan/c/backoff").integers(0, 32))
    c_start = st[st["node"] == "c"].reset_index()
    assert c_start["backoff"][0] == b
    # c overheard a's data frame: NAV covers SIFS + ACK, then DIFS and the backoff
    assert c_start["time"][0] == pytest.approx(end_a + DIFS + b * SLOT, abs=1e-12)


def test_broadcast_is_neither_acknowledged_nor_retried():
    sim = Simulation(seed=1)
    net = WLAN80211b(sim, "wlan", data_rate=1e6)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0))
    net.attach("c", position=(0.0, 10.0))
    net.attach("far", position=(5000.0, 0.0))      # far below the receiver threshold
    a.send(BROADCAST, "all", 1000)
    sim.run(0.05)
    assert frame_rows(net, "ack").empty
    end = frame_rows(net, "attempt_end")
    assert list(end["outcome"]) == ["sent"]
    assert end["time"][0] == pytest.approx(DIFS + PLCP_LONG + (MAC_BITS + 1000) / 1e6, abs=1e-12)
    assert sorted(frame_rows(net, "delivered")["node"]) == ["b", "c"]
    lost = frame_rows(net, "lost")
    assert list(lost["node"]) == ["far"] and list(lost["outcome"]) == ["below_threshold"]


def test_unreachable_destination_is_retried_with_doubling_window_until_the_retry_limit():
    sim = Simulation(seed=2)
    net = WLAN80211b(sim, "wlan", data_rate=11e6)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(2000.0, 0.0))
    msg = a.send("b", None, 1000)
    sim.run(1.0)
    st, en = frame_rows(net, "attempt_start"), frame_rows(net, "attempt_end")
    assert len(st) == 7 and set(en["outcome"]) == {"below_threshold"}
    lost = frame_rows(net, "lost")
    assert list(lost["outcome"]) == ["retry_limit"] and lost["attempt"][0] == 7
    assert math.isnan(msg.delivered)
    # failure is detected an ACK timeout after the data frame; the next attempt follows
    # DIFS + b_k slots later, b_k drawn from CW = 63, 127, ..., 1023
    rng = same_stream(2, "wlan/a/backoff")
    ack_timeout = SIFS + SLOT + PLCP_LONG
    air = PLCP_LONG + (MAC_BITS + 1000) / 11e6
    cw = 31
    for k in range(6):
        assert en["time"][k] == pytest.approx(st["time"][k] + air + ack_timeout, abs=1e-11)
        cw = min(2 * (cw + 1) - 1, 1023)
        b = int(rng.integers(0, cw + 1))
        assert st["backoff"][k + 1] == b
        assert st["time"][k + 1] == pytest.approx(en["time"][k] + DIFS + b * SLOT, abs=1e-12)
    assert cw == 1023


def test_lost_ack_causes_a_retry_and_the_duplicate_is_delivered_once():
    sim = Simulation(seed=4)
    net = WLAN80211b(sim, "wlan", data_rate=11e6)
    a = net.attach("a", position=(0.0, 0.0))
    # b hears a (a transmits loud), a cannot decode b's ACK (b transmits quietly)
    net.attach("b", position=(50.0, 0.0), tx_power_dbm=-20.0)
    a.send("b", None, 1000)
    sim.run(0.5)
    assert set(frame_rows(net, "attempt_end")["outcome"]) == {"ack_lost"}
    assert len(frame_rows(net, "ack")) == 7
    assert len(frame_rows(net, "delivered")) == 1
    assert list(frame_rows(net, "lost")["outcome"]) == ["retry_limit"]


def _hidden_pair(seed, c_position, cs_range_note=""):
    """a and c broadcast periodically to b; returns (net, starts of a, starts of c)."""
    sim = Simulation(seed=seed)
    net = WLAN80211b(sim, "wlan", data_rate=1e6)
    a = net.attach("a", position=(-60.0, 0.0))
    net.attach("b", position=(0.0, 0.0))
    c = net.attach("c", position=c_position)
    for k in range(100):
        sim.call_at(k * 10e-3, lambda: a.send(BROADCAST, None, 1600))
    for k in range(137):
        sim.call_at((0.4e-3 + k * 7.3e-3), lambda: c.send(BROADCAST, None, 1600))
    sim.run(1.2)
    return net


def test_hidden_terminals_collide_at_the_receiver_as_predicted_by_interval_overlap():
    # a-b and c-b are 60 m apart (-78.4 dBm at b), a-c 120 m (-87.5 dBm < -85 dBm threshold):
    # a and c never sense each other.  Broadcasts: no ACKs, so each sender's timing is
    # its own: frame k goes out DIFS after its release (the post-backoff of 1..31 slots
    # ends long before the next release).
    net = _hidden_pair(0, (60.0, 0.0))
    assert net.rx_power_dbm("a", "c") < net.threshold_dbm < net.rx_power_dbm("a", "b")
    air = PLCP_LONG + (MAC_BITS + 1600) / 1e6
    sa = np.array([k * 10e-3 for k in range(100)]) + DIFS
    sc = np.array([0.4e-3 + k * 7.3e-3 for k in range(137)]) + DIFS
    st = frame_rows(net, "attempt_start")
    assert np.allclose(np.sort(st[st["node"] == "a"]["time"]), sa, atol=1e-12)
    assert np.allclose(np.sort(st[st["node"] == "c"]["time"]), sc, atol=1e-12)
    overlap = np.abs(sa[:, None] - sc[None, :]) < air          # equal powers at b: both destroyed
    expected = int(overlap.any(axis=1).sum() + overlap.any(axis=0).sum())
    lost_b = frame_rows(net, "lost", "b")
    assert expected > 10
    assert len(lost_b) == expected and set(lost_b["outcome"]) == {"collision"}
    assert len(frame_rows(net, "delivered", "b")) == 237 - expected


def test_the_same_senders_within_carrier_sense_range_do_not_collide():
    net = _hidden_pair(0, (-30.0, 40.0))     # 50 m from b and from a: everybody hears everybody
    lost_b = frame_rows(net, "lost", "b")
    st = frame_rows(net, "attempt_start")
    # With carrier sense a deferring station waits for the other's frame to end; the only
    # collisions left are two backoffs expiring at the same slot boundary.
    t_of = dict(zip(st["frame"], st["time"]))
    for fid in lost_b["frame"]:
        same_instant = st[(st["time"] == t_of[fid]) & (st["frame"] != fid)]
        assert len(same_instant) == 1
    assert len(lost_b) <= 4
    assert len(frame_rows(net, "delivered", "b")) == 237 - len(lost_b)


# ---------------------------------------------------------------------------- Bianchi
def bianchi_throughput(n, W, m, sigma, Ts, Tc, payload_bits):
    """Bianchi (2000): saturation throughput (bit/s) of basic access with n stations.

    tau = 2 (1 - 2p) / ((1 - 2p)(W + 1) + p W (1 - (2p)^m)),  p = 1 - (1 - tau)^(n - 1)
    S = Ps Ptr E[P] / ((1 - Ptr) sigma + Ptr Ps Ts + Ptr (1 - Ps) Tc)
    """
    if n == 1:
        tau = 2.0 / (W + 1)
    else:
        def g(tau):
            p = 1 - (1 - tau) ** (n - 1)
            return tau - 2 * (1 - 2 * p) / ((1 - 2 * p) * (W + 1) + p * W * (1 - (2 * p) ** m))
        tau = brentq(g, 1e-9, 0.999, xtol=1e-15)
    p = 1 - (1 - tau) ** (n - 1)
    ptr = 1 - (1 - tau) ** n
    ps = n * tau * (1 - tau) ** (n - 1) / ptr
    S = ps * ptr * payload_bits / ((1 - ptr) * sigma + ptr * ps * Ts + ptr * (1 - ps) * Tc)
    return S, p


def saturated_run(n, rate, payload, until, seed=1, warmup=0.5):
    sim = Simulation(seed=seed)
    net = WLAN80211b(sim, "wlan", data_rate=rate, retry_limit=10**6, trace=False)
    # Convention so that every station resumes at the same instant after a collision, as
    # Bianchi's model assumes: ACK timeout = EIFS - DIFS (= SIFS + ACK time at 1 Mbit/s),
    # so the colliding stations (ACK timeout + DIFS) and the others (EIFS) both resume
    # EIFS after the collision: Tc = H + P + EIFS.
    net.ack_timeout = net.eifs_time - net.difs
    ap = net.attach("ap", position=(0.0, 0.0))
    stations = [net.attach(f"s{i}", position=(5 * math.cos(i), 5 * math.sin(i))) for i in range(n)]
    for s in stations:
        SaturatedSource(s, "ap", payload)
    sim.run(warmup)
    r0 = ap.stats["received"]
    fails0 = net.collisions
    sim.run(warmup + until)
    received = ap.stats["received"] - r0
    collisions = net.collisions - fails0
    return received * payload / until, collisions / (collisions + received), net


@pytest.mark.parametrize("rate,payload,until", [(1e6, 8184, 40.0), (11e6, 12000, 6.0)])
def test_saturation_throughput_matches_bianchi_within_3_percent(rate, payload, until):
    """Constants: slot 20 us, SIFS 10 us, DIFS 50 us, W = CWmin + 1 = 32, m = 5 (CWmax = 1023),
    PLCP 192 us, MAC header + FCS 224 bit, ACK 112 bit + PLCP at the highest basic rate
    <= data rate (1 or 2 Mbit/s), propagation delay 0, no losses, no retry limit.
    Ts = PLCP + (224 + P)/R + SIFS + ACK + DIFS, Tc = PLCP + (224 + P)/R + EIFS,
    EIFS = SIFS + DIFS + PLCP + 112 bit / 1 Mbit/s = 364 us."""
    ack_rate = 1e6 if rate < 2e6 else 2e6
    data = PLCP_LONG + (MAC_BITS + payload) / rate
    ack = PLCP_LONG + ACK_BITS / ack_rate
    eifs = SIFS + DIFS + PLCP_LONG + ACK_BITS / 1e6
    Ts, Tc = data + SIFS + ack + DIFS, data + eifs
    for n in (1, 2, 5, 10, 20):
        S_sim, p_sim, net = saturated_run(n, rate, payload, until)
        S_model, p_model = bianchi_throughput(n, 32, 5, SLOT, Ts, Tc, payload)
        assert net.eifs_time * 1e-12 == pytest.approx(eifs, abs=1e-12)
        assert S_sim == pytest.approx(S_model, rel=0.03), (n, S_sim, S_model)
        if n > 1:   # conditional collision probability, a sharper check of the backoff process
            assert p_sim == pytest.approx(p_model, rel=0.12, abs=0.01), (n, p_sim, p_model)
        else:
            assert p_sim == 0.0


def test_same_seed_gives_identical_traces_and_another_seed_does_not():
    def run(seed):
        sim = Simulation(seed=seed)
        net = WLAN80211b(sim, "wlan", data_rate=11e6)
        ap = net.attach("ap", position=(0.0, 0.0))
        for i in range(4):
            SaturatedSource(net.attach(f"s{i}", position=(3.0 * i + 1, 2.0)), ap, 4000)
        sim.run(0.05)
        return sim.trace.frame("frames"), sim.trace.frame("network_schedule")
    f1, s1 = run(7)
    f2, s2 = run(7)
    f3, _ = run(8)
    assert f1.equals(f2) and s1.equals(s2)
    assert not f1.equals(f3)
    assert {"waiting", "sending", "receiving", "idle"} <= set(s1["state"])


def test_bad_input_names_the_value():
    sim = Simulation()
    with pytest.raises(ValueError, match="data_rate.*-1"):
        WLAN80211b(sim, "w0", data_rate=-1)
    net = WLAN80211b(sim, "w", data_rate=11e6)
    a = net.attach("a", position=(0, 0))
    with pytest.raises(ValueError, match="nobody"):
        a.send("nobody", None, 100)
    with pytest.raises(ValueError, match="20000"):
        a.send(BROADCAST, None, 20000)        # more than 2312 bytes
    with pytest.raises(ValueError, match="loss probability.*1.5"):
        WLAN80211b(sim, "w2", loss=1.5)
    with pytest.raises(ValueError, match="position"):
        net.attach("b", position=(1.0,))
    with pytest.raises(ValueError, match="retry_limit.*0"):
        WLAN80211b(sim, "w3", retry_limit=0)
    with pytest.raises(ValueError, match="already attached"):
        net.attach("a", position=(0, 0))
