"""CAN arbitration by a heap of head-of-queue identifiers gives the frame tables of a scan.

The reference is the arbitration CAN had before: scan every node's queue in attach order
and take the smallest head identifier (the first one among equals).  Random traffic with
repeated identifiers across nodes, FIFO and priority queues, and bursts that change a
queue's head many times before it wins must give identical frame tables, bit for bit.
"""

import pandas as pd
import pytest

from benchmarks.network import ScanCAN  # the scan arbitration, kept as the benchmark's baseline
from netcosim import Simulation
from netcosim.network import CAN


def random_traffic(cls, seed, n_nodes, horizon=0.05):
    sim = Simulation(seed=seed)
    bus = cls(sim, "can", data_rate=500e3, frame_format="standard")
    sink = bus.attach("sink", priority=50, mailbox=False)
    rng = sim.rng("traffic")
    nodes = [bus.attach(f"n{i}", priority=int(rng.integers(0, 8)), mailbox=False,
                        queue="fifo" if i % 3 == 0 else "priority") for i in range(n_nodes)]
    for _ in range(int(rng.integers(200, 400))):
        t = float(rng.uniform(0, horizon))
        src = nodes[int(rng.integers(0, n_nodes))]
        burst = int(rng.integers(1, 4))
        prios = [int(p) for p in rng.integers(0, 8, size=burst)]
        size = int(rng.integers(0, 9)) * 8

        def send(src=src, prios=prios, size=size):
            for p in prios:
                src.send(sink, None, size, priority=p)
        sim.call_at(t, send)
    sim.run(horizon * 2)
    return bus.frames(), [i.stats for i in bus._ifaces]


@pytest.mark.parametrize("seed,n_nodes", [(0, 3), (1, 10), (2, 40), (3, 100)])
def test_heap_arbitration_gives_the_frame_table_of_a_scan(seed, n_nodes):
    heap_frames, heap_stats = random_traffic(CAN, seed, n_nodes)
    scan_frames, scan_stats = random_traffic(ScanCAN, seed, n_nodes)
    assert len(heap_frames) > 1000
    pd.testing.assert_frame_equal(heap_frames, scan_frames, check_exact=True)
    assert heap_stats == scan_stats


def test_equal_identifiers_are_broken_by_attach_order_and_stale_entries_are_bounded():
    sim = Simulation(seed=0)
    bus = CAN(sim, "can", data_rate=500e3, frame_format="standard")
    sink = bus.attach("sink", priority=999, mailbox=False)
    a, b, c = (bus.attach(x, mailbox=False) for x in "abc")
    # every send puts a new head on its queue: 199, 198, ..., 0 (each leaves a stale heap entry)
    for p in range(199, -1, -1):
        for i in (c, b, a):
            i.send(sink, None, 8, priority=p)
    assert len(bus._heap) <= 4 * len(bus._ifaces) + 16
    sim.run(1.0)
    df = bus.frames()
    starts = df[df["event"] == "attempt_start"]
    assert starts["src"].tolist() == ["a", "b", "c"] * 200
    assert bus._waiting == 0 and all(h is None for h in bus._head)
