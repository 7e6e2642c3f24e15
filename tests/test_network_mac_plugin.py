"""The MAC as a plug-in: the base owns the frame life cycle, each MAC declares its
per-station state, and a new MAC needs only the hooks."""

import numpy as np
import pytest

from netcosim import Simulation
from netcosim.network import (
    CAN,
    CSMACD,
    FDMA,
    IEEE802154,
    TDMA,
    Bernoulli,
    IdealLink,
    Network,
    RoundRobin,
    SlottedAloha,
    SwitchedEthernet,
    WLAN80211b,
)
from netcosim.network.ethernet import EthernetStation
from netcosim.network.frame import Frame
from netcosim.network.ideal import FdmaStation
from netcosim.network.lifecycle import MacOrderError
from netcosim.network.lrwpan import CsmaCaStation
from netcosim.network.switched import SwitchPort
from netcosim.network.tdma import TdmaStation
from netcosim.network.wlan import DcfStation

MACS = {
    "ideal": (lambda sim: IdealLink(sim, "n"), {}, type(None)),
    "fdma": (lambda sim: FDMA(sim, "n"), {"share": 0.5}, FdmaStation),
    "can": (lambda sim: CAN(sim, "n"), {"priority": 1}, type(None)),
    "rr": (lambda sim: RoundRobin(sim, "n"), {}, type(None)),
    "tdma": (lambda sim: TDMA(sim, "n", slot_time=1e-3, schedule=["a", "b"]), {}, TdmaStation),
    "csmacd": (lambda sim: CSMACD(sim, "n"), {}, EthernetStation),
    "switched": (lambda sim: SwitchedEthernet(sim, "n"), {}, SwitchPort),
    "wlan": (lambda sim: WLAN80211b(sim, "n"), {"position": (0.0, 0.0)}, DcfStation),
    "802.15.4": (lambda sim: IEEE802154(sim, "n"), {"position": (0.0, 0.0)}, CsmaCaStation),
    "aloha": (lambda sim: SlottedAloha(sim, "n", slot_time=1e-3), {}, np.random.Generator),
}


@pytest.mark.parametrize("mac", MACS)
def test_per_station_state_is_a_declared_object_and_interfaces_all_look_alike(mac):
    make, opts, station_type = MACS[mac]
    sim = Simulation(seed=1)
    net = make(sim)
    a, b = net.attach("a", **opts), net.attach("b", **opts)
    assert isinstance(a.mac, station_type) and isinstance(b.mac, station_type)
    if a.mac is not None:
        assert a.mac is not b.mac
    if station_type.__module__.startswith("netcosim"):
        assert not hasattr(a.mac, "__dict__")          # fields declared, nothing hung on at run time
    ref = set(vars(IdealLink(Simulation(seed=1), "x").attach("a")))
    assert set(vars(a)) == ref                         # no MAC adds attributes to the interface
    a.send("b", "hello", 64, priority=1)
    sim.run(0.05)
    assert b.receive().payload == "hello"
    assert set(vars(a)) == ref
    assert a.stats == {"sent": 1, "dropped": 0, "received": 0}


@pytest.mark.parametrize("mac", MACS)
def test_unknown_attach_options_are_refused_by_every_mac(mac):
    make, opts, _ = MACS[mac]
    net = make(Simulation(seed=1))
    with pytest.raises(TypeError, match="unknown attach option"):
        net.attach("a", colour="red", **opts)
    assert "a" not in net.interfaces


def test_the_removed_arguments_and_fields_are_gone():
    sim = Simulation(seed=1)
    net = IdealLink(sim, "n")
    a, _ = net.attach("a"), net.attach("b")
    with pytest.raises(TypeError):
        a.send("b", None, 64, sender=object())
    assert "info" not in Frame.__slots__ and "fail_reason" not in Frame.__slots__


class Instant(Network):
    """A MAC that sends every frame at once, one at a time per sender, for ``bits / rate``."""

    def _kick(self, iface):
        f = self._next_frame(iface)
        if f is not None:
            self.begin_attempt(iface, f)
            self.sim.call_in_ticks(self.duration(f.bits), self._end, arg=f)

    def _end(self, f):
        a = f.src.attempt
        a.end()
        a.deliver_all()
        a.finish()


def test_a_mac_written_from_the_hooks_gets_the_whole_pipeline():
    sim = Simulation(seed=5)
    net = Instant(sim, "n", data_rate=1e6, pre_delay=1e-4, post_delay=2e-4, loss=Bernoulli(0.0),
                  queue_capacity=2)
    a, b = net.attach("a"), net.attach("b")
    for k in range(4):                                 # one in service, two queued, one overflows
        a.send("b", k, 1000)
    sim.run(1.0)
    got = [b.receive() for _ in range(3)]
    assert [m.payload for m in got] == [0, 1, 2] and b.receive() is None
    # pre-delay 100 us, 1 ms per frame back to back, post-delay 200 us
    assert [round(m.delivered, 9) for m in got] == [0.0013, 0.0023, 0.0033]
    assert a.stats == {"sent": 3, "dropped": 1, "received": 0}
    ev = net.frames()
    assert list(ev[ev["event"] == "lost"]["outcome"]) == ["queue_overflow"]
    assert list(ev[ev["event"] == "attempt_end"]["outcome"]) == ["ok"] * 3
    sch = net.schedule()
    assert list(zip(sch["time"].round(9), sch["node"], sch["state"])) == [
        (0.0, "a", "idle"), (0.0, "b", "idle"), (0.0001, "a", "sending"), (0.0001, "b", "receiving"),
        (0.0031, "b", "idle"), (0.0031, "a", "idle")]


class Twice(Instant):
    """A broken MAC: it reports the same frame done twice."""

    def _end(self, f):
        super()._end(f)
        f.src.attempt.finish()


def test_the_base_checks_that_a_mac_works_on_the_frame_in_service():
    sim = Simulation(seed=5)
    net = Twice(sim, "n", data_rate=1e6)
    a, _ = net.attach("a"), net.attach("b")
    a.send("b", None, 1000)
    with pytest.raises(MacOrderError, match=r"network 'n' \(Twice\): finish of None at 'a' in state 'idle'; "
                                            r"allowed only after a successful end\(\)"):
        sim.run(1.0)
