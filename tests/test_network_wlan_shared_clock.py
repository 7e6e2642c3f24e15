"""802.11b: the shared idle-slot clock gives the per-station path's results bit for bit.

Random scenarios (2..20 stations, unicast and broadcast, saturated and periodic senders,
Bernoulli loss, EIFS on and off, small contention windows and retry limits, transmit
powers differing by up to 4 dB, replies sent from receive handlers and from other
stations' completion callbacks, a station attached mid-run) run twice, with
``shared_clock=True`` and ``False``; the frame and network-schedule tables and the
counters must be identical.  The same scenarios spread over a disc of 8 m (everybody
still hears everybody, but a near sender captures a receiver from a far one, and a frame
that survives an overlap may lose bits) check the crowd's capture-aware mode.
"""

import math

import numpy as np
import pytest

from benchmarks.network import periodic_sender
from netcosim import Simulation
from netcosim.network import BROADCAST, SaturatedSource, WLAN80211b


def scenario(seed: int, shared_clock: bool, until: float = 0.08, radius: float = 0.7):
    """A random network drawn from *seed* (the same for both paths), its stations within
    *radius* m of the origin; returns (sim, net)."""
    g = np.random.default_rng(seed)
    n = int(g.integers(2, 21))
    sim = Simulation(seed=seed)
    rate = float(g.choice([1e6, 2e6, 5.5e6, 11e6]))
    loss = float(g.choice([0.0, 0.0, 0.1, 0.3]))
    net = WLAN80211b(sim, "w", data_rate=rate, eifs=bool(g.integers(0, 2)), loss=loss or None,
                     preamble=str(g.choice(["long", "short"])), shared_clock=shared_clock,
                     cw_min=int(g.choice([31, 31, 7, 3])), retry_limit=int(g.choice([7, 7, 2])),
                     propagation_delay=float(g.choice([0.0, 0.0, 1e-6])))
    # with the default radius, stations within 1.5 m of each other, transmit powers within
    # 4 dB: everybody hears everybody, no capture possible
    ifaces = []
    for i in range(n):
        a = g.uniform(0, 2 * math.pi)
        rad = g.uniform(0, radius)
        ifaces.append(net.attach(f"s{i}", position=(rad * math.cos(a), rad * math.sin(a)),
                                 tx_power_dbm=15.0 + float(g.choice([0.0, 0.0, 2.0, -2.0]))))
    size = lambda: int(g.integers(1, 12)) * 800  # noqa: E731
    for i, iface in enumerate(ifaces):
        kind = g.integers(0, 4)
        dst = ifaces[(i + 1 + int(g.integers(0, n - 1))) % n]
        if dst is iface:
            dst = ifaces[(i + 1) % n]
        if kind == 0:
            SaturatedSource(iface, dst, size(), backlog=int(g.integers(1, 3)))
        else:
            period = float(g.choice([1e-3, 2e-3, 5e-3]))
            phase = float(g.choice([0.0, float(g.uniform(0, period))]))   # many share phase 0
            to = BROADCAST if kind == 1 else dst
            bits = size()

            sim.call_at(phase, periodic_sender(sim, iface, to, period, bits))
    # a receiver that answers at once (a callable handler sends from inside the reception)
    echo = ifaces[int(g.integers(0, n))]
    back = ifaces[(echo.index + 1) % n]
    echo.on_receive(lambda msg, echo=echo, back=back: echo.send(back, None, 400)
                    if msg.payload is None and len(echo.queue) < 3 else None)
    # a station that sends when another one is done with a frame (a callback of another station)
    if n >= 3:
        watcher, other = ifaces[0], ifaces[n - 1]
        watcher.on_done.append(lambda f, ok: other.send(watcher, "cb", 600) if len(other.queue) < 3 else None)

    # a station attached mid-run: near, or 3 m away, where its frames can capture receivers
    # (the shared clock goes on, checking each overlap station by station from then on)
    far = bool(g.integers(0, 3) == 0)

    def late_attach():
        if net.medium.active:               # attach between transmissions
            sim.call_in(1e-6, late_attach)
            return
        net.attach("late", position=(3.0, 0.0) if far else (0.3, 0.3))
        SaturatedSource(net.interface("late"), ifaces[0], 1600)
    sim.call_at(until / 2, late_attach)
    sim.run(until)
    net.late_far = far and "late" in net.interfaces
    return sim, net


def tables(sim, net):
    frames = sim.trace.frame("frames")
    sched = sim.trace.frame("network_schedule")
    stats = [(i.name, dict(i.stats)) for i in net._ifaces]
    return frames, sched, stats, net.collisions, net.medium.transmissions


@pytest.mark.parametrize("seed", range(16))
def test_shared_clock_reproduces_the_per_station_path(seed):
    sim_f, net_f = scenario(seed, True)
    sim_s, net_s = scenario(seed, False)
    assert net_f._fast and not net_s._fast      # the shared clock was used
    assert net_f._shared.exact is net_f.late_far    # capture possible once "far" attached
    ff, sf, stf, cf, tf = tables(sim_f, net_f)
    fs, ss, sts, cs, ts = tables(sim_s, net_s)
    assert len(ff) > 100
    assert stf == sts and cf == cs and tf == ts
    assert ff.equals(fs), (seed, ff.compare(fs).head())
    assert sf.equals(ss)


@pytest.mark.slow
@pytest.mark.parametrize("block", range(8))
def test_shared_clock_reproduces_the_per_station_path_on_many_seeds(block):
    for seed in range(16 + 50 * block, 16 + 50 * (block + 1)):
        sim_f, net_f = scenario(seed, True, 0.1)
        sim_s, net_s = scenario(seed, False, 0.1)
        assert net_f._fast
        a, b = tables(sim_f, net_f), tables(sim_s, net_s)
        assert a[0].equals(b[0]) and a[1].equals(b[1]) and a[2:] == b[2:], seed


@pytest.mark.parametrize("seed", range(16))
def test_shared_clock_reproduces_the_per_station_path_when_capture_is_possible(seed):
    sim_f, net_f = scenario(seed, True, radius=8.0)
    sim_s, net_s = scenario(seed, False, radius=8.0)
    assert net_f._fast and net_f._shared.exact
    a, b = tables(sim_f, net_f), tables(sim_s, net_s)
    assert len(a[0]) > 100
    assert a[0].equals(b[0]), (seed, a[0].compare(b[0]).head())
    assert a[1].equals(b[1]) and a[2:] == b[2:]


@pytest.mark.slow
@pytest.mark.parametrize("block", range(4))
def test_shared_clock_reproduces_the_per_station_path_when_capture_is_possible_on_many_seeds(block):
    exact = 0
    for seed in range(16 + 50 * block, 16 + 50 * (block + 1)):
        sim_f, net_f = scenario(seed, True, 0.1, radius=8.0)
        sim_s, net_s = scenario(seed, False, 0.1, radius=8.0)
        assert net_f._fast
        exact += net_f._shared.exact        # (two stations alone cannot capture)
        a, b = tables(sim_f, net_f), tables(sim_s, net_s)
        assert a[0].equals(b[0]) and a[1].equals(b[1]) and a[2:] == b[2:], seed
    assert exact >= 40


def test_a_station_able_to_capture_keeps_the_shared_clock_and_one_out_of_range_ends_it():
    # s2 sits next to s0: at s0 its frames are > 10 dB above s1's, so capture is possible and
    # the crowd checks overlaps station by station; s3, 200 m away, hears nobody (-91 dBm <
    # -85 dBm): the network goes on station by station for good
    for far in (False, True):
        for shared in (True, False):
            sim = Simulation(seed=1)
            net = WLAN80211b(sim, "w", shared_clock=shared)
            a = net.attach("s0", position=(0.0, 0.0))
            b = net.attach("s1", position=(30.0, 0.0))
            assert net._fast is shared and not net._shared.exact
            c = net.attach("s2", position=(1.0, 0.0))
            assert net._fast is shared and net._shared.exact is shared
            if far:
                net.attach("s3", position=(200.0, 0.0))
                assert not net._fast
            SaturatedSource(a, b, 8000)
            SaturatedSource(b, a, 8000)
            SaturatedSource(c, b, 8000)
            sim.run(0.3)
            out = tables(sim, net)
            if shared:
                ref = out
        assert ref[0].equals(out[0]) and ref[1].equals(out[1]) and ref[2:] == out[2:]
        assert out[3] > 0 and out[4] > 100      # collisions at a destination happened


def test_shared_clock_must_be_a_bool():
    from netcosim.errors import ConfigurationTypeError
    with pytest.raises(ConfigurationTypeError, match="shared_clock"):
        WLAN80211b(Simulation(), "w", shared_clock="yes")


def test_moving_stations_take_the_per_station_path():
    sim = Simulation(seed=2)
    net = WLAN80211b(sim, "w")
    a = net.attach("a", position=(0.0, 0.0))
    assert net._fast
    net.attach("b", position=lambda t: (0.5 + t, 0.0))
    assert not net._fast
    SaturatedSource(a, "b", 8000)
    sim.run(0.02)
    assert a.stats["sent"] > 10


def test_where_capture_is_possible_the_crowd_spares_most_re_evaluations():
    # 50 saturated stations on a 10 m circle around the access point (capture possible):
    # station by station, every station takes a DCF step at every end of a transmission
    # (data and ACK at least: > 2 * 49 per frame); the crowd takes one step for all its
    # members, and only the stations that left it (sender, receiver, the listeners whose
    # reception of an overlap differs) take their own
    from benchmarks.counters import wlan_reevals_per_frame
    per_station = wlan_reevals_per_frame(50, 0.3, shared_clock=False)
    shared = wlan_reevals_per_frame(50, 0.3, shared_clock=True)
    assert per_station > 2 * 49
    assert shared < per_station / 4
    assert wlan_reevals_per_frame(2, 0.3, shared_clock=True) < 10


@pytest.mark.parametrize("when", ["timer", "handler"])
def test_a_power_change_where_capture_is_possible_hands_over_to_the_per_station_path(when):
    # 12 saturated stations on an 8 m circle around an access point: capture possible, so the
    # crowd can hand every station its exact state back at any instant; a transmit-power
    # change (at a given time, or from a receive handler while a frame ends) switches to the
    # per-station path for good, with the same tables as a network built without the clock
    def run(shared):
        sim = Simulation(seed=3)
        net = WLAN80211b(sim, "w", shared_clock=shared)
        ap = net.attach("ap", position=(0.0, 0.0))
        ifaces = [net.attach(f"s{i}", position=(8 * math.cos(i), 8 * math.sin(i))) for i in range(12)]
        for i in ifaces[1:]:
            SaturatedSource(i, ap, 8000)
        assert net._fast is shared and net._shared.exact is shared
        if when == "timer":
            sim.call_at(0.0237, lambda: net.set_tx_power("s3", 5.0))
        else:
            ap.on_receive(lambda msg: net.set_tx_power("s3", 5.0) if sim.now > 0.02 else None)
        sim.run(0.06)
        assert not net._fast and net.tx_power("s3") == 5.0
        return tables(sim, net)
    a, b = run(True), run(False)
    assert len(a[0]) > 100
    assert a[0].equals(b[0]) and a[1].equals(b[1]) and a[2:] == b[2:]


def test_a_power_change_without_capture_still_needs_the_per_station_path():
    from netcosim.errors import ConfigurationError
    sim = Simulation(seed=1)
    net = WLAN80211b(sim, "w")
    net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(0.5, 0.0))
    with pytest.raises(ConfigurationError, match="shared_clock=False"):
        net.set_tx_power("a", 5.0)
