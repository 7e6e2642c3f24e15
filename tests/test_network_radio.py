"""Radio: path loss, noise, bit error rates, capture, frame errors, moving nodes."""

import math

import numpy as np
import pytest
from scipy import constants
from scipy.integrate import quad
from scipy.stats import binomtest

from netcosim import Simulation
from netcosim.network import (
    BROADCAST,
    LogDistance,
    TrueTimePathLoss,
    WLAN80211b,
    ber_cck,
    ber_dbpsk,
    ber_dqpsk,
    thermal_noise_dbm,
)

US = 1e-6


def test_received_power_follows_the_log_distance_formula():
    sim = Simulation()
    net = WLAN80211b(sim, "w", path_loss=LogDistance(exponent=3.0), tx_power_dbm=15.0)
    net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(12.0, 35.0))
    net.attach("c", position=(0.3, 0.4))                     # closer than d0 = 1 m: clamped
    pl0 = 20 * math.log10(4 * math.pi * 1.0 * 2.412e9 / constants.c)
    assert pl0 == pytest.approx(40.09, abs=0.01)
    assert net.rx_power_dbm("a", "b") == pytest.approx(15.0 - pl0 - 30 * math.log10(37.0), abs=1e-9)
    assert net.rx_power_dbm("a", "c") == pytest.approx(15.0 - pl0, abs=1e-9)
    assert net.rx_power_dbm("b", "a") == pytest.approx(net.rx_power_dbm("a", "b"), abs=1e-12)


def test_truetime_path_loss_is_ptx_over_d_plus_one_to_the_a():
    sim = Simulation()
    net = WLAN80211b(sim, "w", path_loss=TrueTimePathLoss(3.5), tx_power_dbm=20.0)
    net.attach("a", position=(0.0, 0.0, 0.0))
    net.attach("b", position=(3.0, 4.0, 12.0))               # 13 m in 3-D
    p_w = 10 ** ((20.0 - 30) / 10) / (13.0 + 1.0) ** 3.5
    assert net.rx_power_dbm("a", "b") == pytest.approx(10 * math.log10(p_w) + 30, abs=1e-9)


def test_thermal_noise_floor():
    assert thermal_noise_dbm(22e6) == pytest.approx(-174.0 + 10 * math.log10(22e6), abs=0.03)
    assert thermal_noise_dbm(22e6, noise_figure_db=6.0) == pytest.approx(thermal_noise_dbm(22e6) + 6.0)


def _dqpsk_reference(g):
    """Gray-coded DQPSK BER by the single-integral form (Simon & Alouini), independent of Marcum Q."""
    a = math.sqrt(2 * g * (1 - 1 / math.sqrt(2)))
    b = math.sqrt(2 * g * (1 + 1 / math.sqrt(2)))
    beta = a / b

    def f(th):
        s = 1 + 2 * beta * math.sin(th) + beta ** 2
        return (1 - beta ** 2) / s * math.exp(-b * b / 2 * s)
    return quad(f, -math.pi, math.pi, epsabs=0, epsrel=1e-12)[0] / (4 * math.pi)


@pytest.mark.parametrize("ebn0", [0.05, 0.5, 1.0, 3.0, 10.0, 30.0])
def test_bit_error_rates(ebn0):
    assert ber_dbpsk(ebn0) == pytest.approx(0.5 * math.exp(-ebn0), rel=1e-12)
    assert ber_dqpsk(ebn0) == pytest.approx(_dqpsk_reference(ebn0), rel=1e-9)
    assert ber_cck(ebn0) == pytest.approx(0.5 * math.erfc(math.sqrt(ebn0)), rel=1e-12)
    # DQPSK costs about 2.3 dB against DBPSK at high SNR, never less than coherent QPSK
    assert ber_cck(ebn0) < ber_dqpsk(ebn0) + 1e-300
    assert ber_dqpsk(0.0) == pytest.approx(0.5)


def _capture_setup(d_weak_over_d_strong, stagger=None, strong_first=True):
    """Strong sender s at 20 m, weak sender w on the other side; both broadcast 1000 bits.

    Carrier sense is switched off at the senders (cs threshold 0 dBm) so that a staggered
    second frame really overlaps the first.  Returns the lost/delivered rows at r.
    """
    sim = Simulation(seed=1)
    net = WLAN80211b(sim, "w", data_rate=1e6, path_loss=LogDistance(3.0))
    s = net.attach("s", position=(-20.0, 0.0), cs_threshold_dbm=0.0)
    wk = net.attach("wk", position=(20.0 * d_weak_over_d_strong, 0.0), cs_threshold_dbm=0.0)
    net.attach("r", position=(0.0, 0.0))
    if stagger is None:
        s.send(BROADCAST, None, 1000)
        wk.send(BROADCAST, None, 1000)
    else:
        first, second = (s, wk) if strong_first else (wk, s)
        first.send(BROADCAST, None, 1000)
        sim.call_at(stagger, lambda: second.send(BROADCAST, None, 1000))
    sim.run(0.05)
    df = net.frames()
    at_r = df[df["node"] == "r"]
    return net, at_r


def test_a_frame_10_db_stronger_than_the_interferer_is_received():
    ratio = 10 ** (10 / 30)                     # exponent 3: 10 dB weaker at 10^(1/3) times the distance
    net, at_r = _capture_setup(ratio)
    assert net.rx_power_dbm("s", "r") - net.rx_power_dbm("wk", "r") == pytest.approx(10.0, abs=1e-9)
    assert list(at_r[at_r["event"] == "delivered"]["src"]) == ["s"]
    lost = at_r[at_r["event"] == "lost"]
    assert list(lost["src"]) == ["wk"] and list(lost["outcome"]) == ["collision"]


@pytest.mark.parametrize("strong_first", [True, False])
def test_capture_also_works_when_the_frames_start_at_different_instants(strong_first):
    net, at_r = _capture_setup(10 ** (10 / 30), stagger=0.3e-3, strong_first=strong_first)
    assert list(at_r[at_r["event"] == "delivered"]["src"]) == ["s"]
    assert list(at_r[at_r["event"] == "lost"]["src"]) == ["wk"]


@pytest.mark.parametrize("ratio", [1.0, 10 ** (9 / 30)])
def test_equal_powers_or_less_than_the_capture_margin_destroy_both(ratio):
    net, at_r = _capture_setup(ratio)
    assert at_r[at_r["event"] == "delivered"].empty
    lost = at_r[at_r["event"] == "lost"]
    assert sorted(lost["src"]) == ["s", "wk"] and set(lost["outcome"]) == {"collision"}


@pytest.mark.parametrize("rate", [1e6, 11e6])
def test_frame_success_rate_equals_one_minus_ber_to_the_bits(rate):
    """Noise-limited link: success probability (1 - BER_PLCP)^192 (1 - BER_data)^(224 + L).

    PLCP: DBPSK at 1 Mbit/s, Eb/N0 = SNR * 22; data: the rate's modulation, Eb/N0 = SNR * 22e6 / R.
    """
    L, n = 800, 3000
    sim = Simulation(seed=9)
    probe = WLAN80211b(Simulation(), "probe")
    probe.attach("a", position=(0.0, 0.0))
    probe.attach("b", position=(10.0, 0.0))
    p_rx = probe.rx_power_dbm("a", "b")
    snr_db = -4.9 if rate == 1e6 else 4.3
    net = WLAN80211b(sim, "w", data_rate=rate, noise_dbm=p_rx - snr_db, threshold_dbm=-95.0)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0))
    for k in range(n):
        sim.call_at(k * 3e-3, lambda: a.send(BROADCAST, None, L))
    sim.run(n * 3e-3 + 0.01)
    g = 10 ** (snr_db / 10)
    if rate == 1e6:
        p = (1 - ber_dbpsk(22 * g)) ** (192 + 224 + L)
    else:
        p = (1 - ber_dbpsk(22 * g)) ** 192 * (1 - ber_cck(g * 22e6 / rate)) ** (224 + L)
    assert 0.3 < p < 0.9
    df = net.frames()
    ok = int(((df["event"] == "delivered") & (df["node"] == "b")).sum())
    lost = df[(df["event"] == "lost") & (df["node"] == "b")]
    assert ok + len(lost) == n and set(lost["outcome"]) == {"bit_errors"}
    ci = binomtest(ok, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= p <= ci.high, (ok / n, p)


def test_a_moving_node_leaves_the_range_where_the_formula_says():
    """Receiver carried away at 10 m/s; positions are evaluated at each transmission start."""
    sim = Simulation(seed=2)
    net = WLAN80211b(sim, "w", data_rate=1e6, tx_power_dbm=15.0, threshold_dbm=-85.0)
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("rover", position=lambda t: (10.0 * t, 0.0))
    for k in range(20):
        sim.call_at(k * 1.0, lambda: a.send(BROADCAST, None, 100))
    sim.run(20.0)
    pl0 = 20 * math.log10(4 * math.pi * 2.412e9 / constants.c)
    d_max = 10 ** ((15.0 + 85.0 - pl0) / 30.0)                 # ~99 m
    starts = net.frames().query("event == 'attempt_start'")["time"].to_numpy()
    expect_ok = 10.0 * starts <= d_max
    df = net.frames()
    got_ok = np.isin(df.query("event == 'attempt_start'")["frame"],
                     df.query("event == 'delivered'")["frame"])
    assert np.array_equal(expect_ok, got_ok)
    assert 0 < expect_ok.sum() < 20
    assert set(df.query("event == 'lost'")["outcome"]) == {"below_threshold"}
    assert net.position("rover", 2.5) == (25.0, 0.0)


def test_bad_radio_input_raises_naming_the_value():
    with pytest.raises(ValueError, match="exponent"):
        LogDistance(exponent=-2)
    sim = Simulation()
    net = WLAN80211b(sim, "w")
    net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=lambda t: (float("nan"), 0.0))
    with pytest.raises(ValueError, match="position of 'b'"):
        net.interfaces["a"].send("b", None, 100)
        sim.run(0.01)
    with pytest.raises(ValueError, match="tx_power_dbm"):
        WLAN80211b(sim, "w2", tx_power_dbm=float("inf"))


@pytest.mark.parametrize("ber", ["ber_dbpsk", "ber_dqpsk", "ber_cck", "ber_oqpsk"])
def test_ber_functions_take_linear_ratios_and_refuse_the_rest_by_name(ber):
    from netcosim.errors import ConfigurationError, ConfigurationTypeError
    from netcosim.network import lrwpan, radio
    f = getattr(radio, ber, None) or getattr(lrwpan, ber)
    assert f(0.0) == pytest.approx(0.5)
    assert f(math.inf) == 0.0 and f(1e300) == 0.0     # no NaN from a huge ratio
    np.testing.assert_array_equal(f(np.array([math.inf, 1e300])), [0.0, 0.0])
    for dB_by_mistake in (-3.0, -math.inf, [1.0, -2.0]):
        with pytest.raises(ConfigurationError, match=r"linear power ratio >= 0 \(not dB, not NaN\), got"):
            f(dB_by_mistake)
    with pytest.raises(ConfigurationError, match="got nan"):
        f(math.nan)
    for junk in ("10", None, 1j, np.array([1 + 0j])):
        with pytest.raises(ConfigurationTypeError, match="must be a linear power ratio"):
            f(junk)
