"""Traffic sources driven from Python (no kernel task needed): for tests and benchmarks."""

from __future__ import annotations

from typing import Any

from .. import validate


class SaturatedSource:
    """Keep *iface*'s sender queue non-empty: ``backlog`` frames to *dst* at start, one more
    each time the interface is done with a frame (sent, acknowledged or dropped).

    This is the saturation assumption of Bianchi's analysis: a station always has a
    frame ready when its backoff expires.  ``size_bits``: message size in bits.
    ``backlog`` (frames, >= 1; else :class:`~netcosim.errors.ConfigurationError`);
    ``generated`` counts the messages sent so far.

    Examples
    --------
    A saturated sender on a 1 Mbit/s ideal link delivers one 1000-bit frame per ms, the
    link's full rate; the backlog stays at 2 frames:

    >>> from netcosim import Simulation
    >>> from netcosim.network import IdealLink, SaturatedSource
    >>> sim = Simulation(seed=0)
    >>> net = IdealLink(sim, "link", data_rate=1e6)
    >>> a, b = net.attach("a"), net.attach("b")
    >>> source = SaturatedSource(a, "b", size_bits=1000)
    >>> sim.run(until=0.0105)
    >>> b.stats["received"], source.generated, a.pending
    (10, 12, 2)
    """

    def __init__(self, iface, dst: Any, size_bits: int, backlog: int = 2):
        backlog = validate.count(backlog, "SaturatedSource backlog (frames)", minimum=1)
        self.iface, self.dst, self.size_bits = iface, dst, size_bits
        self.generated = 0
        iface.on_done.append(self._refill)
        for _ in range(backlog):
            self._send()

    def _send(self):
        self.generated += 1
        self.iface.send(self.dst, None, self.size_bits)

    def _refill(self, frame, ok):
        self._send()
