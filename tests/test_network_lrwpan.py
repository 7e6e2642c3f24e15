"""IEEE 802.15.4 unslotted CSMA/CA: exact timing, CCA back-off progression, retries, bit errors."""

import math

import pytest
from conftest import frame_rows
from scipy.stats import binomtest

from netcosim import Simulation
from netcosim.network import BROADCAST, IEEE802154
from netcosim.network.lrwpan import ber_oqpsk

US = 1e-6
UNIT, CCA, TURN = 320 * US, 128 * US, 192 * US     # 20, 8 and 12 symbols of 16 us
SHR, MAC_BITS, ACK = 192 * US, 88, 352 * US
RATE = 250e3


def stream(seed, name):
    return Simulation(seed=seed).rng(name)


def test_unicast_on_an_idle_channel():
    sim = Simulation(seed=4)
    net = IEEE802154(sim, "z")
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0))
    m = a.send("b", "x", 400)
    sim.run(0.1)
    k = int(stream(4, "z/a/backoff").integers(0, 8))
    start = k * UNIT + CCA + TURN
    air = SHR + (MAC_BITS + 400) / RATE
    assert frame_rows(net, "attempt_start")["time"][0] == pytest.approx(start, abs=1e-12)
    assert m.delivered == pytest.approx(start + air, abs=1e-12)
    assert frame_rows(net, "attempt_end")["time"][0] == pytest.approx(start + air + TURN + ACK, abs=1e-12)
    assert frame_rows(net, "attempt_end")["outcome"].tolist() == ["ok"]


def _csma_prediction(seed, t_send, busy, max_backoffs=4):
    """Replay B's CSMA/CA: returns (transmission start or None, number of busy CCAs)."""
    rng = stream(seed, "z/b/backoff")
    t, nb, be = t_send, 0, 3
    while True:
        c0 = t + int(rng.integers(0, 2 ** be)) * UNIT
        c1 = c0 + CCA
        if any(b0 <= c1 and b1 > c0 for b0, b1 in busy):     # busy at the start or during the CCA
            nb += 1
            be = min(be + 1, 5)
            if nb > max_backoffs:
                return None, nb
            t = c1
        else:
            return c1 + TURN, nb


@pytest.mark.parametrize("seed", range(6))
def test_busy_cca_raises_the_backoff_exponent_until_the_channel_is_clear(seed):
    sim = Simulation(seed=seed)
    net = IEEE802154(sim, "z")
    a = net.attach("a", position=(0.0, 0.0))
    b = net.attach("b", position=(10.0, 0.0))
    net.attach("c", position=(0.0, 10.0))
    a.send(BROADCAST, None, 928)                                   # 4.256 ms on the air
    sim.call_at(0.5e-3, lambda: b.send("c", None, 80))
    sim.run(0.2)
    st = frame_rows(net, "attempt_start")
    a0 = st[st["node"] == "a"]["time"].iloc[0]
    a_busy = [(a0, a0 + SHR + (MAC_BITS + 928) / RATE)]
    t_b, nb = _csma_prediction(seed, 0.5e-3, a_busy)
    assert st[st["node"] == "b"]["time"].iloc[0] == pytest.approx(t_b, abs=1e-12)
    assert set(frame_rows(net, "attempt_end")["outcome"]) <= {"sent", "ok"}


def test_channel_access_failure_after_max_csma_backoffs():
    for seed in range(20):
        sim = Simulation(seed=seed)
        net = IEEE802154(sim, "z", max_csma_backoffs=0)
        a = net.attach("a", position=(0.0, 0.0))
        b = net.attach("b", position=(10.0, 0.0))
        a.send(BROADCAST, None, 928)
        sim.call_at(0.5e-3, lambda: b.send("a", None, 80))
        sim.run(0.2)
        st = frame_rows(net, "attempt_start")
        a0 = st[st["node"] == "a"]["time"].iloc[0]
        t_b, nb = _csma_prediction(seed, 0.5e-3, [(a0, a0 + SHR + (MAC_BITS + 928) / RATE)], max_backoffs=0)
        lost = frame_rows(net, "lost")
        if t_b is None:
            assert lost["outcome"].tolist() == ["channel_access"] and lost["node"].tolist() == ["b"]
            return
        assert lost.empty
    pytest.fail("no seed produced a busy first CCA")


def test_unacknowledged_frames_are_retried_max_frame_retries_times():
    sim = Simulation(seed=1)
    net = IEEE802154(sim, "z")
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("far", position=(5000.0, 0.0))
    a.send("far", None, 80)
    sim.run(1.0)
    assert len(frame_rows(net, "attempt_start")) == 4
    assert set(frame_rows(net, "attempt_end")["outcome"]) == {"below_threshold"}
    assert frame_rows(net, "lost")["outcome"].tolist() == ["retry_limit"]


def test_oqpsk_ber_and_frame_success_rate():
    assert ber_oqpsk(0.0) == pytest.approx(0.5)
    vals = [ber_oqpsk(10 ** (db / 10)) for db in (-6, -3, 0, 3)]
    assert all(x > y for x, y in zip(vals, vals[1:]))
    # direct evaluation of the standard's sum
    s = 0.5
    direct = 8 / 15 / 16 * sum((-1) ** k * math.comb(16, k) * math.exp(20 * s * (1 / k - 1)) for k in range(2, 17))
    assert ber_oqpsk(s) == pytest.approx(direct, rel=1e-9)
    # noise-limited link: success = (1 - BER)^(48 + 88 + L) (every bit, SHR included)
    L, n, snr_db = 400, 3000, 0.0
    probe = IEEE802154(Simulation(), "p")
    probe.attach("a", position=(0.0, 0.0))
    probe.attach("b", position=(10.0, 0.0))
    p_rx = probe.rx_power_dbm("a", "b")
    sim = Simulation(seed=3)
    net = IEEE802154(sim, "z", noise_dbm=p_rx - snr_db, threshold_dbm=-110.0)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0))
    for k in range(n):
        sim.call_at(k * 10e-3, lambda: a.send(BROADCAST, None, L))
    sim.run(n * 10e-3 + 0.1)
    p = (1 - ber_oqpsk(10 ** (snr_db / 10))) ** (48 + MAC_BITS + L)
    assert 0.3 < p < 0.95
    ok = len(frame_rows(net, "delivered", "b"))
    ci = binomtest(ok, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= p <= ci.high, (ok / n, p)
