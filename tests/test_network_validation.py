"""Network parameters are validated once, at construction/attach, by one shared helper.

Before, NaN radio parameters were accepted and produced NaN powers (silently "nobody
hears anybody"), and a negative MAC overhead made a frame's air time negative, failing
deep in the run with "cannot schedule in the past".
"""

from __future__ import annotations

import math

import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.network import CSMACD, IEEE802154, TDMA, IdealLink, LogDistance, WLAN80211b
from netcosim.validate import bits as check_bits
from netcosim.validate import count as check_count
from netcosim.validate import duration as check_duration
from netcosim.validate import real as check_real

NAN = float("nan")


@pytest.mark.parametrize("make, names", [
    (lambda s: WLAN80211b(s, "w", noise_dbm=NAN), "noise_dbm"),
    (lambda s: WLAN80211b(s, "w", cs_threshold_dbm=NAN), "cs_threshold_dbm"),
    (lambda s: IEEE802154(s, "z", noise_dbm=NAN), "noise_dbm"),
    (lambda s: IEEE802154(s, "z", cs_threshold_dbm=NAN), "cs_threshold_dbm"),
    (lambda s: IEEE802154(s, "z").attach("a", tx_power_dbm=NAN), "tx_power_dbm"),
    (lambda s: WLAN80211b(s, "w", path_loss=LogDistance(reference_loss_db=NAN)), "reference_loss_db"),
])
def test_nan_radio_parameters_are_rejected_at_construction(make, names):
    with pytest.raises(ConfigurationError) as info:
        make(Simulation())
    assert names in str(info.value) and "nan" in str(info.value)


def test_a_nan_noise_floor_used_to_lose_every_frame_silently():
    """What the validation prevents: with noise_dbm = NaN every SINR is NaN.  The
    parameter is now refused; the same network with a finite floor delivers the frame
    at the analytic instant (PLCP 192 us + (224 + 1000) bit at 1 Mbit/s = 1.416 ms)."""
    sim = Simulation(seed=1)
    net = WLAN80211b(sim, "w", data_rate=1e6, noise_dbm=-100.0)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0))
    msg = a.send("b", None, 1000)
    sim.run(0.01)
    # DIFS (50 us) after the arrival, then the frame; delivery at its end
    assert msg.delivered == pytest.approx(50e-6 + 192e-6 + 1224e-6, abs=1e-12)
    with pytest.raises(ConfigurationError, match="noise_dbm must be a finite number of dBm, got nan"):
        WLAN80211b(Simulation(), "w", data_rate=1e6, noise_dbm=NAN)


@pytest.mark.parametrize("make, value", [
    (lambda s: WLAN80211b(s, "w", mac_overhead_bits=-300), "-300"),
    (lambda s: WLAN80211b(s, "w", ack_bits=-112), "-112"),
    (lambda s: IEEE802154(s, "z", mac_overhead_bits=-88), "-88"),
    (lambda s: WLAN80211b(s, "w", mac_overhead_bits=2.5), "2.5"),
])
def test_negative_mac_overheads_fail_at_construction_not_at_run_time(make, value):
    sim = Simulation()
    with pytest.raises(ConfigurationError) as info:
        net = make(sim)
        # (old behaviour: accepted here, then "cannot schedule in the past" once a frame flew)
        a = net.attach("a")
        net.attach("b")
        a.send("b", None, 100)
        sim.run(0.01)
    assert value in str(info.value) and "bits" in str(info.value)
    assert "past" not in str(info.value)


def test_boundary_values_are_accepted_with_exact_timing():
    """Not over-eager: zero overhead, 0 dB capture and a 0 dB reference loss are legal
    and give the analytic air time (long PLCP 192 us + 1000 bit at 1 Mbit/s)."""
    sim = Simulation()
    net = WLAN80211b(sim, "w", data_rate=1e6, mac_overhead_bits=0, capture_db=0.0,
                     path_loss=LogDistance(reference_loss_db=0.0))
    assert net.data_time(1000) == 1_192_000_000          # ticks of 1 ps
    assert net.capture_db == 0.0 and net.path_loss.pl0 == 0.0
    z = IEEE802154(sim, "z", mac_overhead_bits=0)
    # SHR 48 bit + 800 bit at 250 kbit/s = 3.392 ms
    assert z.frame_time(800) == 3_392_000_000


@pytest.mark.parametrize("make, what", [
    (lambda s: WLAN80211b(s, "w", slot=1e-13), "slot (s)=1e-13"),
    (lambda s: WLAN80211b(s, "w", ack_timeout=1e-13), "ack_timeout (s)=1e-13"),
    (lambda s: CSMACD(s, "e", slot_time=1e-13), "slot_time (s)=1e-13"),
    (lambda s: TDMA(s, "t", slot_time=1e-13, schedule=["a"]), "slot_time (s)=1e-13"),
    (lambda s: IdealLink(s, "l", delay=1e-13), "delay (s)=1e-13"),
])
def test_durations_below_the_resolution_are_refused_naming_the_parameter(make, what):
    with pytest.raises(ConfigurationError) as info:
        make(Simulation())
    assert what in str(info.value)


def test_the_shared_helpers():
    assert check_real(2, "x", lo=0.0, lo_open=True) == 2.0
    with pytest.raises(ConfigurationError, match=r"x must be a positive thing, got 0\.0"):
        check_real(0.0, "x", lo=0.0, lo_open=True, kind="a positive thing")
    with pytest.raises(ConfigurationTypeError, match="got True"):
        check_real(True, "x")
    assert check_bits(64.0, "b") == 64 and isinstance(check_bits(64.0, "b"), int)
    with pytest.raises(ConfigurationError, match="got -1"):
        check_bits(-1, "b")
    with pytest.raises(ConfigurationError, match="positive integer number of bits, got 0"):
        check_bits(0, "b", allow_zero=False)
    assert check_count(3, "c", minimum=1) == 3
    with pytest.raises(ConfigurationError, match=r"in 1\.\.30, got 31"):
        check_count(31, "c", minimum=1, maximum=30)
    assert check_duration(1e-3, "d") == 10**9
    with pytest.raises(ConfigurationError, match="positive number of seconds, got 0"):
        check_duration(0, "d", positive=True)
    assert math.isfinite(check_real(-90, "p"))
