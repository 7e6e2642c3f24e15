"""The bound on a sender queue: a sender that outruns its network loses messages with
reason ``queue_overflow`` (counted, a warning the first time) or raises, as asked."""

from __future__ import annotations

import pytest

from netcosim import Simulation
from netcosim.errors import OverloadError, OverloadWarning
from netcosim.network import CAN
from netcosim.network.base import DEFAULT_QUEUE_CAPACITY


def flood(**kw):
    """A node sending a 100-bit message every 10 us over 125 kbit/s CAN (one frame takes about 1 ms)."""
    sim = Simulation()
    net = CAN(sim, "can", data_rate=125e3, **kw)
    a, b = sim.node("a"), sim.node("b")
    net.attach(a, priority=1)
    net.attach(b, priority=2)

    @a.periodic(period=1e-5, priority=1, name="spam")
    def spam(ctx):
        ctx.send("b", 1.0, 64)
        yield ctx.execute(0.0)
    return sim, net


def test_a_full_sender_queue_loses_counted_messages_with_one_warning():
    sim, net = flood(queue_capacity=50)
    with pytest.warns(OverloadWarning, match=r"network 'can': the sender queue of 'a' holds 50 frames"):
        sim.run(until=0.01)
    frames = sim.trace.frame("frames")
    over = frames[(frames["event"] == "lost") & (frames["outcome"] == "queue_overflow")]
    # 1000 messages in 10 ms, 19 sent (about 0.5 ms each), 1 on the wire, 50 queued, 930 lost
    assert len(net.interfaces["a"].queue) == 50
    assert len(over) == 930 and net.stats["total"]["messages_lost"] == 930


def test_on_queue_full_error_and_the_default():
    sim, net = flood(queue_capacity=20, on_queue_full="error")
    with pytest.raises(OverloadError, match=r"sender queue of 'a' holds 20 frames"):
        sim.run(until=0.01)
    sim, net = flood()
    assert net.queue_capacity == DEFAULT_QUEUE_CAPACITY == 100_000
    sim, net = flood(queue_capacity=None)       # TrueTime: unbounded
    sim.run(until=0.01)
    assert len(net.interfaces["a"].queue) > 900
