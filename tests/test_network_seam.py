"""The MAC seam (issue 24): the attempt's life cycle is enforced by state, and frame loss
is drawn in one named hook, ``Network.frame_lost``."""

import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError
from netcosim.network import BROADCAST, IEEE802154, IdealLink, SlottedAloha, SwitchedEthernet, WLAN80211b
from netcosim.network.lifecycle import CARRIER_LINK, CARRIER_MEDIUM, CARRIER_SENDER, Attempt, MacOrderError


def _in_service():
    """A link whose sender a has a frame in service (medium access not yet started)."""
    sim = Simulation(seed=0)
    net = IdealLink(sim, "n", data_rate=1e6)
    a, b = net.attach("a"), net.attach("b")
    net._kick = lambda iface: None          # the test drives the life cycle itself
    a.send(b, None, 100)
    f = net._next_frame(a)
    return sim, net, a, b, f


def test_the_steps_in_order_deliver_and_count():
    sim, net, a, b, f = _in_service()
    att = net.begin_attempt(a, f)
    assert isinstance(att, Attempt) and att.state == "on" and a.sending == 1 and b.receiving == 1
    att.end()
    att.deliver(b)
    att.finish(restart=False)
    assert att.state == "idle" and a.current is None
    assert a.stats["sent"] == 1 and b.stats["received"] == 1
    assert net.stats["total"]["messages_delivered"] == 1


@pytest.mark.parametrize("steps, message", [
    (("end", "end"), "end of"),
    (("end:collision", "deliver"), "deliver of"),
    (("end:collision", "deliver_all"), "deliver_all of"),
    (("end:collision", "finish"), "finish of"),
    (("deliver",), "deliver of"),
    (("finish",), "finish of"),
    (("drop",), "drop of"),
    (("begin",), "begin_attempt of"),
    (("resume",), "resume of"),
    (("requeue",), "requeue of"),
    (("end", "requeue"), "requeue of"),
])
def test_a_step_out_of_order_raises_before_any_bookkeeping(steps, message):
    sim, net, a, b, f = _in_service()
    att = net.begin_attempt(a, f)
    *first, last = steps
    for s in first:
        name, _, arg = s.partition(":")
        getattr(att, name)(*([arg] if arg else []))
    rows = len(net._rows)
    stats = (dict(a.stats), dict(b.stats), f.attempts)
    with pytest.raises(MacOrderError, match=f"network 'n' \\(IdealLink\\): {message}") as e:
        if last == "begin":
            net.begin_attempt(a, f)
        elif last == "drop":
            att.drop("retry_limit")
        else:
            getattr(att, last)(*([b] if last == "deliver" else []))
    assert "'a'" in str(e.value) and "state" in str(e.value)
    assert len(net._rows) == rows and (dict(a.stats), dict(b.stats), f.attempts) == stats


def test_a_failed_attempt_may_be_retried_then_dropped():
    sim, net, a, b, f = _in_service()
    net.begin_attempt(a, f).end("collision")
    att = net.begin_attempt(a, f)
    assert f.attempts == 2
    att.end("collision")
    att.drop("retry_limit", restart=False)
    assert a.stats["dropped"] == 1 and a.current is None
    assert net.stats["total"]["messages_lost"] == 1
    assert net.stats["total"]["frame_attempts"] == 2


def test_a_failed_attempt_may_be_requeued_at_the_head_of_the_queue():
    sim, net, a, b, f = _in_service()
    a.send(b, None, 100)                    # a second frame behind f
    att = net.begin_attempt(a, f)
    att.end("switch_full")
    att.requeue()
    assert att.state == "idle" and a.current is None and a.sending == 0
    assert a.stats["sent"] == 0 and a.stats["dropped"] == 0
    assert net._next_frame(a) is f          # f first again, then retried
    net.begin_attempt(a, f).end()
    assert f.attempts == 2


def test_switched_ethernet_carrier_is_the_uplinks_alone():
    sim = Simulation(seed=0)
    net = SwitchedEthernet(sim, "sw", data_rate=1e6)
    a, b = net.attach("a"), net.attach("b")
    seen = []
    net._at_switch, at_switch = (lambda f: (seen.append((a.sending, b.receiving, a.attempt.state)),
                                            at_switch(f))), net._at_switch
    sim.call_at(0.0, lambda: a.send(b, None, 1000))
    sim.run(0.1)
    assert seen == [(1, 0, "on")]           # on the uplink: b receives only from its switch port
    assert a.attempt.state == "idle" and b.stats["received"] == 1 and b.receiving == 0


class _Deaf:
    """Mixin: every frame lost, decided in the one hook."""

    def frame_lost(self, frame, rx):
        return True


class DeafLink(_Deaf, IdealLink):
    pass


class DeafAloha(_Deaf, SlottedAloha):
    pass


class DeafWLAN(_Deaf, WLAN80211b):
    pass


class DeafSwitch(_Deaf, SwitchedEthernet):
    pass


@pytest.mark.parametrize("make", [
    lambda sim: DeafLink(sim, "n", loss=0.0),
    lambda sim: DeafAloha(sim, "n", slot_time=1e-3),
    lambda sim: DeafWLAN(sim, "n", retry_limit=2),
    lambda sim: DeafSwitch(sim, "n", switch_delay=1e-5),
])
@pytest.mark.parametrize("broadcast", [False, True])
def test_frame_lost_is_the_one_place_frame_loss_is_drawn(make, broadcast):
    sim = Simulation(seed=0)
    net = make(sim)
    # a lossless network never calls the hook on the hot path; give it a (never drawn) model
    net.loss = object()
    kw = {"position": (0.0, 0.0)} if isinstance(net, WLAN80211b) else {}
    a = net.attach("a", **kw)
    b = net.attach("b", **({"position": (5.0, 0.0)} if kw else {}))
    sim.call_at(0.0, lambda: a.send(BROADCAST if broadcast else b, None, 400))
    sim.run(0.5)
    assert b.stats["received"] == 0
    lost = net.frames().query("event == 'lost'")
    assert set(lost["outcome"]) <= {"random_loss", "retry_limit"} and len(lost)


def _radio_in_service(broadcast=False):
    """A WLAN whose sender a has a frame in service (medium access not started)."""
    sim = Simulation(seed=0)
    net = WLAN80211b(sim, "w")
    a, b = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(5.0, 0.0))
    net._kick = lambda iface: None
    a.send(BROADCAST if broadcast else b, None, 100)
    return sim, net, a, b, net._next_frame(a)


def test_the_radio_carrier_is_the_mediums_and_a_reception_completes_while_the_attempt_is_on():
    sim, net, a, b, f = _radio_in_service(broadcast=True)
    att = net.begin_attempt(a, f)
    assert att.state == "on" and a.sending == 0 and b.receiving == 0     # the medium turns them on
    assert att.deliver(b)                   # legal while on: the frame left the air at b
    att.end()
    assert a.sending == 0 and att.state == "ok"
    with pytest.raises(MacOrderError, match=r"deliver of .* in state 'ok'; allowed only while the frame is on the "
                                            r"air \(state 'on': the carrier is the medium's\)"):
        att.deliver(b)
    att.finish(restart=False)
    with pytest.raises(MacOrderError, match="deliver_all of None at 'a' in state 'idle'"):
        att.deliver_all()


def test_radio_unicast_is_received_and_acknowledged_while_the_senders_attempt_is_on():
    sim = Simulation(seed=0)
    net = WLAN80211b(sim, "w")
    a, b = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(5.0, 0.0))
    seen = []
    b.on_receive(lambda msg: seen.append((sim.now, a.attempt.state)))
    done = []
    a.on_done.append(lambda frame, ok: done.append((sim.now, ok, a.attempt.state)))
    sim.call_at(0.0, lambda: a.send(b, None, 1000))
    sim.run(0.1)
    assert [s for _, s in seen] == ["on"]   # data received, a's attempt still on
    assert [(ok, s) for _, ok, s in done] == [(True, "idle")]
    assert done[0][0] - seen[0][0] > net.timing()["ack_time"]     # ... until its ACK came
    ev = net.frames()
    assert list(ev[ev["event"] == "attempt_end"]["outcome"]) == ["ok"]


def test_a_channel_access_failure_ends_an_attempt_that_never_went_on_the_air():
    sim = Simulation(seed=0)
    net = IEEE802154(sim, "z")
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(5.0, 0.0))
    net._kick = lambda iface: None
    a.send("b", None, 100)
    f = net._next_frame(a)
    att = a.attempt
    att.fail("channel_access")
    assert att.state == "failed" and f.attempts == 0
    att.drop("channel_access", restart=False)
    assert a.stats["dropped"] == 1
    ev = net.frames()
    assert list(ev[ev["node"] == "a"]["event"])[-2:] == ["attempt_end", "lost"]
    with pytest.raises(MacOrderError, match="fail of None at 'a' in state 'idle'"):
        att.fail("channel_access")          # no frame in service
    a.send("b", None, 100)
    net.begin_attempt(a, net._next_frame(a))
    with pytest.raises(MacOrderError, match="fail of .* in state 'on'"):
        att.fail("channel_access")          # an attempt is on the medium


def test_the_carrier_setting_is_one_of_three():
    class Odd(IdealLink):
        carrier = "air"

    with pytest.raises(ConfigurationError, match=r"carrier must be one of \('link', 'sender', 'medium'\), "
                                                 r"got 'air'"):
        Odd(Simulation(seed=0), "n").attach("a")
    assert (IdealLink.carrier, SwitchedEthernet.carrier, WLAN80211b.carrier, IEEE802154.carrier) == (
        CARRIER_LINK, CARRIER_SENDER, CARRIER_MEDIUM, CARRIER_MEDIUM)
