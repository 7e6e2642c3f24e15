"""Invalid network parameters: every network's constructor, attach and send, the radio and
path-loss models and the loss models.  Each case builds its own simulation."""

from __future__ import annotations

from invalid_cases import Case
from netcosim.errors import ConfigurationError, ConfigurationTypeError, LossTraceExhaustedError

NAN, INF = float("nan"), float("inf")


def _sim():
    from netcosim import Simulation
    return Simulation()


def _net(cls_name, **kw):
    import netcosim.network as N
    return getattr(N, cls_name)(_sim(), "n", **kw)


def _wlan(**kw):
    return _net("WLAN80211b", **kw)


def _zig(**kw):
    return _net("IEEE802154", **kw)


def _attach(cls_name, net_kw=None, **attach_kw):
    net = _net(cls_name, **(net_kw or {}))
    return net.attach("a", **attach_kw)


def _send(cls_name, dst="b", size_bits=100, net_kw=None, **send_kw):
    net = _net(cls_name, **(net_kw or {}))
    a = net.attach("a", **({"priority": 1} if cls_name == "CAN" else {}))
    net.attach("b")
    return a.send(dst, None, size_bits, **send_kw)


def _logdistance(**kw):
    from netcosim.network import LogDistance
    return LogDistance(**kw)


def _ttpl(a):
    from netcosim.network import TrueTimePathLoss
    return TrueTimePathLoss(a)


def _noise(**kw):
    from netcosim.network import thermal_noise_dbm
    return thermal_noise_dbm(**kw)


def _ge(**kw):
    from netcosim.network import GilbertElliott
    base = dict(p_gb=0.1, p_bg=0.5)
    base.update(kw)
    return GilbertElliott(**base)


def _bernoulli(p):
    from netcosim.network import Bernoulli
    return Bernoulli(p)


def _anyloss(models):
    from netcosim.network import AnyLoss
    return AnyLoss(models)


def _traceloss(seq):
    from netcosim.network import TraceLoss
    return TraceLoss(seq)


def _traceloss_run_out():
    from netcosim.network import IdealLink, TraceLoss
    sim = _sim()
    net = IdealLink(sim, "n", loss=TraceLoss([0], repeat=False))
    a = net.attach("a")
    net.attach("b")
    for _ in range(2):
        a.send("b", None, 100)
    sim.run(until=0.01)


def _dbm_to_watt(p):
    from netcosim.network import dbm_to_watt
    return dbm_to_watt(p)


def _tdma(**kw):
    base = dict(slot_time=1e-3, schedule=["a"])
    base.update(kw)
    return _net("TDMA", **base)


def _sat(backlog):
    from netcosim.network import SaturatedSource
    net = _net("IdealLink")
    a = net.attach("a")
    net.attach("b")
    return SaturatedSource(a, "b", 100, backlog=backlog)


E = ValueError
T = TypeError

CASES = [
    # --- radio: NaN / inf / wrong sign at construction ------------------------------
    Case("network-wlan-noise-dbm-nan", lambda: _wlan(noise_dbm=NAN), E, "nan"),
    Case("network-wlan-noise-dbm-inf", lambda: _wlan(noise_dbm=-INF), E, "-inf"),
    Case("network-wlan-cs-threshold-nan", lambda: _wlan(cs_threshold_dbm=NAN), E, "nan"),
    Case("network-wlan-capture-db-negative", lambda: _wlan(capture_db=-3.0), E, "-3.0"),
    Case("network-wlan-tx-power-string", lambda: _wlan(tx_power_dbm="15"), T, "'15'"),
    Case("network-wlan-attach-cs-threshold-nan",
         lambda: _attach("WLAN80211b", cs_threshold_dbm=NAN), E, "nan"),
    Case("network-wlan-attach-position-string", lambda: _attach("WLAN80211b", position="12"), T, "'12'"),
    Case("network-wlan-attach-position-inf", lambda: _attach("WLAN80211b", position=(0.0, INF)), E, "inf"),
    Case("network-wlan-path-loss-type", lambda: _wlan(path_loss=3.0), T, "3.0"),
    Case("network-zigbee-noise-dbm-nan", lambda: _zig(noise_dbm=NAN), E, "nan"),
    Case("network-zigbee-cs-threshold-inf", lambda: _zig(cs_threshold_dbm=INF), E, "inf"),
    Case("network-zigbee-attach-tx-power-nan", lambda: _attach("IEEE802154", tx_power_dbm=NAN), E, "nan"),
    Case("network-zigbee-attach-threshold-inf", lambda: _attach("IEEE802154", threshold_dbm=INF), E, "inf"),
    Case("network-zigbee-capture-db-nan", lambda: _zig(capture_db=NAN), E, "nan"),
    Case("network-zigbee-path-loss-type", lambda: _zig(path_loss="free-space"), T, "'free-space'"),
    Case("network-logdistance-reference-loss-nan", lambda: _logdistance(reference_loss_db=NAN), E, "nan"),
    Case("network-logdistance-reference-loss-negative",
         lambda: _logdistance(reference_loss_db=-40.0), E, "-40.0"),
    Case("network-logdistance-frequency-inf", lambda: _logdistance(frequency=INF), E, "inf"),
    Case("network-logdistance-distance-zero", lambda: _logdistance(reference_distance=0.0), E, "0.0"),
    Case("network-truetime-pathloss-inf", lambda: _ttpl(INF), E, "inf"),
    Case("network-thermal-noise-figure-nan", lambda: _noise(noise_figure_db=NAN), E, "nan"),
    Case("network-thermal-noise-bandwidth-inf", lambda: _noise(bandwidth=INF), E, "inf"),
    Case("network-wlan-modulation-unknown", lambda: _wlan(modulation="qam64"), E, "'qam64'"),
    # --- MAC overheads, frame sizes, counts ----------------------------------------
    Case("network-wlan-mac-overhead-negative", lambda: _wlan(mac_overhead_bits=-300), E, "-300"),
    Case("network-wlan-mac-overhead-fraction", lambda: _wlan(mac_overhead_bits=22.5), E, "22.5"),
    Case("network-wlan-ack-bits-zero", lambda: _wlan(ack_bits=0), E, "ack_bits must be a positive"),
    Case("network-wlan-ack-bits-negative", lambda: _wlan(ack_bits=-112), E, "-112"),
    Case("network-wlan-cw-min-float", lambda: _wlan(cw_min=31.0), E, "31.0"),
    Case("network-wlan-basic-rates-nan", lambda: _wlan(basic_rates=(1e6, NAN)), E, "nan"),
    Case("network-zigbee-mac-overhead-negative", lambda: _zig(mac_overhead_bits=-88), E, "-88"),
    Case("network-zigbee-max-be-huge", lambda: _zig(max_be=64), E, "64"),
    Case("network-base-min-frame-negative", lambda: _net("IdealLink", min_frame_bits=-8), E, "-8"),
    Case("network-base-max-frame-string", lambda: _net("IdealLink", max_frame_bits="1500"), T, "'1500'"),
    Case("network-base-data-rate-nan", lambda: _net("CAN", data_rate=NAN), E, "nan"),
    Case("network-base-data-rate-string", lambda: _net("CAN", data_rate="fast"), T, "'fast'"),
    Case("network-base-mailbox-capacity-zero", lambda: _net("IdealLink", mailbox_capacity=0), E, "0"),
    Case("network-can-standard-max-frame-string",
         lambda: _net("CAN", frame_format="standard", max_frame_bits="64"), T, "'64'"),
    Case("network-ethernet-jam-bits-negative", lambda: _net("CSMACD", jam_bits=-32), E, "-32"),
    Case("network-ethernet-backoff-limit-float", lambda: _net("CSMACD", backoff_limit=10.5), E, "10.5"),
    Case("network-switched-memory-negative", lambda: _net("SwitchedEthernet", switch_memory_bits=-1), E, "-1"),
    Case("network-traffic-backlog-zero", lambda: _sat(0), E, "0"),
    # --- durations: NaN, negative, below the 1 ps resolution ----------------------
    Case("network-wlan-slot-1e-13", lambda: _wlan(slot=1e-13), E, "slot (s)=1e-13"),
    Case("network-wlan-sifs-nan", lambda: _wlan(sifs=NAN), E, "nan"),
    Case("network-wlan-ack-timeout-1e-13", lambda: _wlan(ack_timeout=1e-13), E, "ack_timeout (s)=1e-13"),
    Case("network-ethernet-slot-time-1e-13", lambda: _net("CSMACD", slot_time=1e-13), E, "slot_time (s)=1e-13"),
    Case("network-ethernet-collision-window-negative",
         lambda: _net("CSMACD", collision_window=-1e-6), E, "-1e-06"),
    Case("network-ethernet-interframe-gap-inf", lambda: _net("CSMACD", interframe_gap=INF), E, "inf"),
    Case("network-tdma-slot-time-1e-13", lambda: _tdma(slot_time=1e-13), E, "1e-13"),
    Case("network-tdma-slot-time-nan", lambda: _tdma(slot_time=NAN), E, "nan"),
    Case("network-tdma-schedule-string", lambda: _tdma(schedule="abc"), T, "'abc'"),
    Case("network-tdma-schedule-empty", lambda: _tdma(schedule=[]), E, "[]"),
    Case("network-ideal-delay-1e-13", lambda: _net("IdealLink", delay=1e-13), E, "1e-13"),
    Case("network-ideal-delay-negative", lambda: _net("IdealLink", delay=-0.002), E, "-0.002"),
    Case("network-base-post-delay-nan", lambda: _net("RoundRobin", post_delay=NAN), E, "nan"),
    Case("network-switched-delay-1e-13", lambda: _net("SwitchedEthernet", switch_delay=1e-13), E, "1e-13"),
    # --- loss models -------------------------------------------------------------------
    Case("network-loss-bernoulli-nan", lambda: _bernoulli(NAN), E, "nan"),
    Case("network-loss-bernoulli-string", lambda: _bernoulli("0.1"), T, "'0.1'"),
    Case("network-loss-ge-p-bg-negative", lambda: _ge(p_bg=-0.2), E, "-0.2"),
    Case("network-loss-ge-loss-good-above-one", lambda: _ge(loss_good=1.5), E, "1.5"),
    Case("network-loss-ge-start", lambda: _ge(start="ugly"), E, "'ugly'"),
    Case("network-loss-any-none-entry", lambda: _anyloss([0.1, None]), T, "None"),
    Case("network-loss-any-empty", lambda: _anyloss([]), E, "empty"),
    # --- attach and send -------------------------------------------------------------
    Case("network-fdma-share-nan", lambda: _attach("FDMA", share=NAN), E, "nan"),
    Case("network-attach-priority-nan", lambda: _attach("CAN", priority=NAN), E, "nan"),
    Case("network-send-unknown-destination", lambda: _send("IdealLink", dst="zed"), E, "'zed'"),
    Case("network-send-size-bits-nan", lambda: _send("IdealLink", size_bits=NAN), E, "nan"),
    Case("network-send-size-bits-string", lambda: _send("CSMACD", size_bits="64"), T, "'64'"),
    Case("network-send-priority-inf", lambda: _send("CAN", priority=INF), E, "inf"),
    # --- found by tests/test_properties.py (issue 23) -----------------------------------
    Case("network-wlan-tx-power-huge", lambda: _wlan(tx_power_dbm=1e300), ConfigurationError, "1e+300"),
    Case("network-wlan-noise-tiny", lambda: _wlan(noise_dbm=-1e300), ConfigurationError, "-1e+300"),
    Case("network-wlan-capture-db-huge", lambda: _wlan(capture_db=1e300), ConfigurationError, "1e+300"),
    Case("network-min-frame-bits-huge", lambda: _net("IdealLink", min_frame_bits=1e300), ConfigurationError,
         "1e+300"),
    Case("network-bernoulli-int-beyond-float", lambda: _bernoulli(10**400), ConfigurationError, "1000000000"),
    Case("network-anyloss-not-a-list", lambda: _anyloss(0.1), ConfigurationTypeError, "0.1"),
    Case("network-traceloss-ragged", lambda: _traceloss([0, [1, 0]]), ConfigurationError, "[0, [1, 0]]"),
    Case("network-traceloss-exhausted", lambda: _traceloss_run_out(), LossTraceExhaustedError, "exhausted"),
    Case("network-dbm-to-watt-huge", lambda: _dbm_to_watt(1e300), ConfigurationError, "1e+300"),
]


# Audit fixes: the sim argument and trace flag of every network, WLAN rates, TDMA slot
# owners and slot lengths, switch memory, distances and moving positions.
def _every_network_refuses_a_non_simulation():
    import netcosim.network as N
    for cls, kw in ((N.IdealLink, {}), (N.CAN, {}), (N.CSMACD, {}), (N.SlottedAloha, {"slot_time": 1e-3}),
                    (N.SwitchedEthernet, {}), (N.WLAN80211b, {}), (N.IEEE802154, {})):
        try:
            cls("sim", "n", **kw)
        except ConfigurationTypeError as exc:
            assert "'sim'" in str(exc), exc
        else:
            raise AssertionError(f"{cls.__name__} accepted sim='sim'")
    N.TDMA("sim", "n", slot_time=1e-3, schedule=["a"])


def _tdma_run(slot_time=1e-3, schedule=("a", "b"), size_bits=100):
    sim = _sim()
    import netcosim.network as N
    net = N.TDMA(sim, "n", slot_time=slot_time, schedule=list(schedule))
    a = net.attach("a")
    net.attach("b")
    a.send("b", None, size_bits)
    sim.run(0.1)


def _moving_station(position):
    sim = _sim()
    import netcosim.network as N
    net = N.WLAN80211b(sim, "n")
    a = net.attach("a")
    net.attach("mover", position=position)
    a.send("mover", None, 800)
    sim.run(0.01)


def _logdistance_gain(d):
    from netcosim.network.radio import LogDistance
    return LogDistance().gain(d)


def _truetime_pathloss(d):
    from netcosim.network.radio import TrueTimePathLoss
    return TrueTimePathLoss().gain(d)


CASES += [
    Case("network-sim-not-a-simulation", lambda: _net_with_sim("sim"), ConfigurationTypeError, "'sim'"),
    Case("network-sim-not-a-simulation-every-network", _every_network_refuses_a_non_simulation,
         ConfigurationTypeError, "'sim'"),
    Case("network-trace-str", lambda: _net("IdealLink", trace="x"), ConfigurationTypeError, "'x'"),
    Case("network-trace-int", lambda: _net("IdealLink", trace=1), ConfigurationTypeError, "1"),
    Case("network-wlan-data-rate-bits-slip", lambda: _wlan(data_rate=11), ConfigurationError, "data_rate=11"),
    Case("network-tdma-ghost-slot-owner", lambda: _tdma_run(schedule=("a", "b", "ghost")), ConfigurationError,
         "'ghost'"),
    Case("network-tdma-slot-far-shorter-than-frame", lambda: _tdma_run(slot_time=1e-9), ConfigurationError,
         "slot_time=1e-09"),
    Case("network-switch-memory-below-one-frame", lambda: _net("SwitchedEthernet", switch_memory_bits=8),
         ConfigurationError, "switch_memory_bits=8"),
    Case("network-switch-memory-below-max-frame",
         lambda: _net("SwitchedEthernet", switch_memory_bits=1000, max_frame_bits=12000),
         ConfigurationError, "switch_memory_bits=1000"),
    Case("network-logdistance-negative", lambda: _logdistance_gain(-1), ConfigurationError, "-1"),
    Case("network-logdistance-nan", lambda: _logdistance_gain(NAN), ConfigurationError, "nan"),
    Case("network-truetime-pathloss-nan", lambda: _truetime_pathloss(NAN), ConfigurationError, "nan"),
    Case("network-truetime-pathloss-negative", lambda: _truetime_pathloss(-0.5), ConfigurationError, "-0.5"),
    Case("network-position-callable-returns-str", lambda: _moving_station(lambda t: "x"),
         ConfigurationTypeError, "'mover'"),
    Case("network-position-callable-returns-str-value", lambda: _moving_station(lambda t: "x"),
         ConfigurationTypeError, "'x'"),
    Case("network-position-callable-returns-nan", lambda: _moving_station(lambda t: (NAN, 0.0)),
         ConfigurationError, "'mover'"),
]


def _net_with_sim(sim):
    import netcosim.network as N
    return N.IdealLink(sim, "n")
