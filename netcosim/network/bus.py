"""Shared buses with arbitration at idle instants: CAN-like buses and round robin.

One frame at a time occupies the bus.  Whenever the bus is idle and some node has a
frame queued, an *arbitration* takes place at that instant (after every event of the
instant, so frames queued at the same instant compete) and the chosen frame is sent to
completion (non-preemptive).  Subclasses choose the winner.
"""

from __future__ import annotations

from .base import ARBITRATE, Network
from .interface import Interface


class SharedBus(Network):
    """Base class: a bus with one transmission at a time; subclasses implement ``_choose``.

    Parameters as :class:`~netcosim.network.base.Network`.  ``busy_ticks``: the time the
    bus has carried frames so far, in ticks (1 ps; :data:`~netcosim.timebase.TICKS_PER_SECOND`).

    Examples
    --------
    A bus of one's own, where the node with the most frames queued wins (the first
    attached among equals); and the bus's busy time, three 1000-bit frames at 1 Mbit/s
    = 3 ms:

    >>> from netcosim import Simulation
    >>> from netcosim.network import SharedBus
    >>> class LongestQueue(SharedBus):
    ...     def _choose(self):
    ...         waiting = [i for i in self.interfaces.values() if len(i.queue)]
    ...         return max(waiting, key=lambda i: len(i.queue), default=None)
    >>> sim = Simulation(seed=0)
    >>> bus = LongestQueue(sim, "bus", data_rate=1e6)
    >>> a, b = bus.attach("a"), bus.attach("b")
    >>> m1 = a.send("b", None, size_bits=1000)
    >>> m2, m3 = b.send("a", None, size_bits=1000), b.send("a", None, size_bits=1000)
    >>> sim.run(until=0.0015)
    >>> m1.delivered, round(m2.delivered * 1e3, 6)       # b (2 queued) went first: ms
    (nan, 1.0)
    >>> sim.run(until=0.01)
    >>> round(bus.busy_ticks / 1e12 * 1e3, 6)            # ms
    3.0
    """

    def __init__(self, sim, name, **kw):
        super().__init__(sim, name, **kw)
        self._busy = False
        self._arb = False
        self.busy_ticks = 0

    def _kick(self, iface: Interface) -> None:
        if not self._busy and not self._arb:
            self._arb = True
            self.sim.call_in_ticks(0, self._arbitrate, ARBITRATE)

    def _choose(self) -> Interface | None:
        """The interface whose head-of-queue frame wins the bus now (None: nobody waits)."""
        raise NotImplementedError

    def _arbitrate(self) -> None:
        self._arb = False
        if self._busy:
            return
        iface = self._choose()
        if iface is None:
            return
        f = self._next_frame(iface)
        assert f is not None  # _choose picked a station with a frame waiting
        self._busy = True
        a = self.begin_attempt(iface, f)
        d = self.duration(f.bits)
        self.busy_ticks += d
        self.sim.call_in_ticks(d, self._end, arg=a)

    def _end(self, a) -> None:
        self._busy = False
        a.end()
        a.deliver_all()
        a.finish()

    def _restart(self, iface: Interface) -> None:
        # the bus is free: arbitrate if anybody waits
        for i in self._ifaces:
            if i.queue._q:
                self._kick(i)
                break


class RoundRobin(SharedBus):
    """Token passing: the token visits the nodes cyclically in attach order and a node
    holding it sends at most one frame.  Passing the token takes no time, so at an idle
    instant the next node (after the last sender) with a queued frame transmits.
    ``data_rate`` in bit/s; the other parameters as :class:`~netcosim.network.base.Network`.

    Examples
    --------
    Three nodes queue a 1000-bit frame at t = 0 (``c`` first): the token serves them in
    attach order, one frame time (1000 bits / 1 Mbit/s = 1 ms) apart:

    >>> from netcosim import Simulation
    >>> from netcosim.network import RoundRobin
    >>> sim = Simulation(seed=0)
    >>> bus = RoundRobin(sim, "rr", data_rate=1e6)
    >>> a, b, c = bus.attach("a"), bus.attach("b"), bus.attach("c")
    >>> msgs = [c.send("a", None, 1000), b.send("a", None, 1000), a.send("b", None, 1000)]
    >>> sim.run(until=0.01)
    >>> [(m.src, round(m.delivered * 1e3, 6)) for m in msgs]                 # ms
    [('c', 3.0), ('b', 2.0), ('a', 1.0)]
    """

    def __init__(self, sim, name, *, data_rate: float = 10e6, **kw):
        super().__init__(sim, name, data_rate=data_rate, **kw)
        self._token = 0

    def _choose(self):
        n = len(self._ifaces)
        for k in range(n):
            i = self._ifaces[(self._token + k) % n]
            if i.queue._q:
                self._token = (i.index + 1) % n
                return i
        return None
