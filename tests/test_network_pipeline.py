"""The common pipeline (delays, queues, delivery to kernel tasks, traces) and the
contention-free / scheduled MACs: ideal link, FDMA, round robin, TDMA."""


import pytest
from conftest import frame_rows

from netcosim import Simulation
from netcosim.errors import ConfigurationError
from netcosim.network import BROADCAST, FDMA, TDMA, IdealLink, RoundRobin
from netcosim.network.plot import plot_network_schedule

US = 1e-6


def test_ideal_link_timing_is_pre_delay_plus_transmission_plus_delay_plus_post_delay():
    sim = Simulation()
    net = IdealLink(sim, "link", data_rate=1e6, delay=150e-6, pre_delay=20e-6, post_delay=30e-6,
                    min_frame_bits=512)
    a = net.attach("a")
    b = net.attach("b")
    m1 = a.send("b", "x", 1000)
    m2 = a.send("b", "y", 100)             # padded to 512 bits, queued behind the first
    sim.run(0.01)
    assert m1.delivered == pytest.approx(20e-6 + 1000e-6 + 150e-6 + 30e-6, abs=1e-12)
    assert m2.delivered == pytest.approx(20e-6 + 1000e-6 + 512e-6 + 150e-6 + 30e-6, abs=1e-12)
    assert m1.sent == pytest.approx(20e-6, abs=1e-12) and m2.latency == pytest.approx(m2.delivered)
    assert [b.receive().payload, b.receive().payload, b.receive()] == ["x", "y", None]
    starts = frame_rows(net, "attempt_start")
    assert starts["bits"].tolist() == [1000.0, 512.0]


def test_priority_queue_serves_the_most_urgent_first_and_fifo_among_equals():
    sim = Simulation()
    net = IdealLink(sim, "link", data_rate=1e6, queue="priority")
    a = net.attach("a")
    b = net.attach("b")
    for tag, prio in (("first", 5), ("p1", 1), ("p3a", 3), ("p3b", 3), ("p0", 0)):
        a.send("b", tag, 100, priority=prio)
    sim.run(0.01)
    got = [b.receive().payload for _ in range(5)]
    assert got == ["first", "p0", "p1", "p3a", "p3b"]       # the first was already on the wire


def test_queue_overflow_and_full_mailbox_lose_frames_with_their_reasons():
    sim = Simulation()
    net = IdealLink(sim, "link", data_rate=1e6, queue_capacity=2, mailbox_capacity=2)
    a = net.attach("a")
    net.attach("b")
    for _ in range(5):
        a.send("b", None, 100)             # 1 in service + 2 queued, 2 overflow
    sim.run(0.01)
    lost = frame_rows(net, "lost")
    assert lost["outcome"].tolist() == ["queue_overflow"] * 2 + ["mailbox_full"]
    assert lost["node"].tolist() == ["a", "a", "b"]
    assert len(frame_rows(net, "delivered")) == 2


def test_delivery_releases_a_handler_task_that_fetches_from_the_mailbox():
    """TrueTime's networked pattern: a periodic sender task, a receive handler per frame."""
    sim = Simulation()
    tx_node = sim.node("sensor")
    rx_node = sim.node("controller")
    net = IdealLink(sim, "net", data_rate=80e3)
    net.attach(tx_node)
    rx = net.attach(rx_node)
    got = []

    @tx_node.periodic(period=0.01, priority=1)
    def sample(ctx):
        yield ctx.execute(0.001)
        ctx.send("controller", ctx.now, 80)

    @rx_node.aperiodic(priority=1)
    def on_msg(ctx):
        msg = yield rx.mailbox.fetch()
        yield ctx.execute(0.0005)
        got.append((msg.payload, msg.delivered, ctx.now))

    rx.on_receive(on_msg)
    sim.run(0.035)
    # sent at 1 ms after each release, 80 bits at 80 kbit/s = 1 ms on the link, 0.5 ms handling
    assert [g[0] for g in got] == pytest.approx([0.001, 0.011, 0.021, 0.031], abs=1e-12)
    assert [g[1] for g in got] == pytest.approx([0.002, 0.012, 0.022, 0.032], abs=1e-12)
    assert [g[2] for g in got] == pytest.approx([0.0025, 0.0125, 0.0225, 0.0325], abs=1e-12)
    with pytest.raises(ValueError, match="not on network"):
        tx_node.send("controller", None, 8, network="other")


def test_callable_handlers_and_broadcast_reach_every_other_node():
    sim = Simulation()
    net = IdealLink(sim, "link", data_rate=1e6)
    seen = []
    a = net.attach("a", handler=lambda m: seen.append(("a", m.payload)))
    net.attach("b", handler=lambda m: seen.append(("b", m.payload)), mailbox=False)
    net.attach("c", handler=lambda m: seen.append(("c", m.payload)))
    a.send(BROADCAST, "hi", 10)
    sim.run(0.001)
    assert sorted(seen) == [("b", "hi"), ("c", "hi")]
    assert len(net.interfaces["b"].mailbox) == 0 and len(net.interfaces["c"].mailbox) == 1


def test_network_schedule_states_for_one_frame():
    sim = Simulation()
    net = IdealLink(sim, "link", data_rate=1e6, pre_delay=5e-6)
    a = net.attach("a")
    net.attach("b")
    sim.call_at(10e-6, lambda: a.send("b", None, 100))
    sim.run(0.001)
    sch = net.schedule()
    rows = list(zip(sch["time"].round(9), sch["node"], sch["state"]))
    assert rows == [(0.0, "a", "idle"), (0.0, "b", "idle"), (15e-6, "b", "receiving"), (15e-6, "a", "sending"),
                    (115e-6, "b", "idle"), (115e-6, "a", "idle")]


def test_fdma_nodes_send_in_parallel_at_their_share_of_the_bandwidth():
    sim = Simulation()
    net = FDMA(sim, "fdma", data_rate=1e6)
    a = net.attach("a", share=0.25)
    b = net.attach("b", share=0.5)
    net.attach("c", share=0.25)
    ma = a.send("c", None, 1000)
    mb = b.send("c", None, 1000)
    sim.run(0.1)
    assert ma.delivered == pytest.approx(4e-3, abs=1e-12) and mb.delivered == pytest.approx(2e-3, abs=1e-12)
    with pytest.raises(ValueError, match="sum"):
        net.attach("d", share=0.1)
    with pytest.raises(ValueError, match="share"):
        FDMA(sim, "f2").attach("x")


def test_round_robin_gives_each_node_one_frame_per_turn():
    sim = Simulation()
    net = RoundRobin(sim, "rr", data_rate=1e6)
    nodes = [net.attach(n) for n in ("a", "b", "c")]
    net.attach("sink")
    for _ in range(2):
        nodes[2].send("sink", None, 100)      # c alone at an idle bus: it sends at once
    # a and b queue during c's frame; the token continues after c: a, b, c, a, b
    sim.call_at(50e-6, lambda: [nodes[i].send("sink", None, 100) for i in (1, 0, 1, 0)])
    sim.run(0.01)
    st = frame_rows(net, "attempt_start")
    assert st["src"].tolist() == ["c", "a", "b", "c", "a", "b"]
    assert st["time"].tolist() == pytest.approx([k * 100e-6 for k in range(6)], abs=1e-12)


def test_tdma_suspends_frames_at_slot_end_and_resumes_in_the_next_own_slot():
    sim = Simulation()
    net = TDMA(sim, "tdma", data_rate=1e6, slot_time=1e-3, schedule=["a", "b", None])
    a = net.attach("a")
    b = net.attach("b")
    ma = a.send("b", None, 1500)             # 1.5 ms: 1 ms in slot 0, 0.5 ms in slot 3
    sim.call_at(0.2e-3, lambda: b.send("a", None, 300))
    sim.call_at(3.7e-3, lambda: a.send("b", None, 200))   # rest of a's slot after the first frame
    sim.call_at(3.9e-3, lambda: a.send("b", None, 200))   # does not fit: 0.1 ms now, 0.1 ms in slot 6
    sim.run(0.02)
    assert ma.delivered == pytest.approx(3.5e-3, abs=1e-12)
    d = frame_rows(net, "delivered")
    assert d["time"].tolist() == pytest.approx([1.3e-3, 3.5e-3, 3.9e-3, 6.1e-3], abs=1e-12)
    assert frame_rows(net, "suspended")["time"].tolist() == pytest.approx([1e-3, 4e-3], abs=1e-12)
    assert frame_rows(net, "resumed")["time"].tolist() == pytest.approx([3e-3, 6e-3], abs=1e-12)
    c = net.attach("c")
    with pytest.raises(ConfigurationError, match="owns no slot"):     # a netcosim error (a ValueError)
        c.send("a", None, 10)


def test_tdma_network_schedule_is_readable_and_shows_the_suspension():
    # the slot list once hid Network.schedule() on TDMA networks
    sim = Simulation()
    net = TDMA(sim, "tdma", data_rate=1e6, slot_time=1e-3, schedule=["a", "b", None])
    a = net.attach("a")
    net.attach("b")
    a.send("b", None, 1500)
    sim.run(0.01)
    assert net.slots == ["a", "b", None]
    rows = net.schedule()
    rows = rows[rows["node"] == "a"]
    assert rows["state"].tolist() == ["sending", "waiting", "sending", "idle"]
    assert rows["time"].tolist() == pytest.approx([0.0, 1e-3, 3e-3, 3.5e-3], abs=1e-12)


def test_bad_pipeline_input_raises_naming_the_value():
    sim = Simulation()
    with pytest.raises(ValueError, match="data_rate.*0"):
        IdealLink(sim, "l0", data_rate=0)
    with pytest.raises(ValueError, match="pre_delay"):
        IdealLink(sim, "l1", pre_delay=-1e-3)
    with pytest.raises(ValueError, match="discipline"):
        IdealLink(sim, "l2", queue="lifo")
    net = IdealLink(sim, "l3", max_frame_bits=1000)
    a = net.attach("a")
    net.attach("b")
    with pytest.raises(ValueError, match="size_bits=1001"):
        a.send("b", None, 1001)
    with pytest.raises(ValueError, match="size_bits.*-5"):
        a.send("b", None, -5)
    with pytest.raises(ValueError, match="needs size_bits"):
        a.send("b", None)
    with pytest.raises(ValueError, match="unknown destination node 'zed'"):
        a.send("zed", None, 10)
    with pytest.raises(ValueError, match="itself"):
        a.send("a", None, 10)
    with pytest.raises(KeyError, match="unknown node 'q'"):
        net.interface("q")
    with pytest.raises(ValueError, match="already exists"):
        IdealLink(sim, "l3")
    with pytest.raises(TypeError, match="unknown attach option"):
        net.attach("c", position=(0, 0))
    with pytest.raises(ValueError, match="slot_time"):
        TDMA(sim, "t", slot_time=0.0, schedule=["a"])


def test_plot_network_schedule_writes_a_png(tmp_path):
    from conftest import lossy_link
    sim = lossy_link()
    path = tmp_path / "net.png"
    ax = plot_network_schedule(sim.trace.frame("network_schedule"), frames=sim.trace.frame("frames"),
                               t_range=(0.0, 0.011), path=path)
    assert path.stat().st_size > 1000
    assert [t.get_text() for t in ax.get_yticklabels()] == ["b", "a"]
    with pytest.raises(KeyError, match="zz"):
        plot_network_schedule(sim.trace.frame("network_schedule"), nodes=["zz"])
