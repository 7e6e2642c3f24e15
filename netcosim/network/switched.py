"""Switched Ethernet: full-duplex links to one store-and-forward switch.

Each node has a full-duplex link of ``data_rate`` bit/s to a switch port.  The node
sends its queue over its uplink (no contention: full duplex, one node per port); the
switch stores the *whole* frame, waits ``switch_delay`` s (forwarding decision), and
queues it on the output port of the destination (every other port for broadcast).
Each output port sends its queue (FIFO, or by priority with ``port_queue="priority"``)
to its node.  Timing of an unloaded frame: ``2 * bits / data_rate + switch_delay``.

Switch memory (``switch_memory_bits``, None = unbounded; else at least one frame of
``max_frame_bits``, or of ``min_frame_bits`` when frames are unbounded) holds frames from arrival until
their last copy has left the output port.  ``buffer="shared"``: one pool;
``"symmetric"``: each output port owns ``memory / n_ports``.  A frame that does not fit
is dropped (``overflow="drop"``, traced as ``lost``/``queue_overflow`` at node
``switch``) or refused and sent again by its sender (``overflow="retransmit"``; the
attempt ends with outcome ``switch_full``) -- TrueTime's two options.
"""

from __future__ import annotations

from .. import validate
from ..errors import ConfigurationError
from .base import Network
from .interface import TxQueue
from .lifecycle import CARRIER_SENDER


class SwitchPort:
    """The switch's output port towards one node: its queue, the frame it sends, and the
    bits of switch memory its frames hold.  ``discipline``: its queue's, ``"fifo"`` or
    ``"priority"`` (:class:`~netcosim.network.interface.TxQueue`)."""

    __slots__ = ("queue", "current", "used")

    def __init__(self, discipline: str):
        self.queue = TxQueue(discipline)
        self.current = None
        self.used = 0


class SwitchedEthernet(Network):
    """Star topology around a store-and-forward switch.  See the module docstring.

    On the MAC seam (:class:`~netcosim.network.lifecycle.Attempt`): an attempt is the
    frame's trip over the uplink (its carrier the sender's alone); it ends when the switch
    has it, finished (stored), dropped (``queue_overflow``) or requeued (``switch_full``).

    ``data_rate`` (each link) in bit/s; ``min_frame_bits`` and ``switch_memory_bits`` (None:
    unbounded) in bits; ``switch_delay`` in s.  ``buffer``: ``"shared"`` switch memory or
    ``"symmetric"`` (split evenly between the ports); ``overflow``: ``"drop"`` a frame the
    memory cannot take or ``"retransmit"`` it from the sender; ``port_queue``: ``"fifo"`` or
    ``"priority"`` order of each output port's queue.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        ``switch_memory_bits`` too small for one frame (``max_frame_bits``, or
        ``min_frame_bits`` when frames are unbounded); ``buffer``, ``overflow`` or
        ``port_queue`` not one of the names above; a negative ``switch_delay``; a common
        parameter out of range (:class:`~netcosim.network.base.Network`).
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sim* is not a :class:`~netcosim.Simulation`, or a parameter is not a number.

    Examples
    --------
    Store and forward: 1000 bits at 10 Mbit/s cross the uplink (100 µs), wait the 10 µs
    switch delay, and cross the output link (100 µs), ``2 * bits / data_rate +
    switch_delay`` = 210 µs:

    >>> from netcosim import Simulation
    >>> from netcosim.network import SwitchedEthernet
    >>> sim = Simulation(seed=0)
    >>> net = SwitchedEthernet(sim, "switch", data_rate=10e6, switch_delay=10e-6)
    >>> a, b = net.attach("a"), net.attach("b")
    >>> msg = a.send("b", None, size_bits=1000)
    >>> sim.run(until=0.01)
    >>> round(msg.delivered * 1e6, 6)                     # µs
    210.0
    """

    carrier = CARRIER_SENDER   # full duplex: the output ports make the receivers receiving

    def __init__(self, sim, name, *, data_rate: float = 10e6, min_frame_bits: int = 512,
                 switch_memory_bits: int | None = None, buffer: str = "shared", overflow: str = "drop",
                 switch_delay: float = 0.0, port_queue: str = "fifo", **kw):
        super().__init__(sim, name, data_rate=data_rate, min_frame_bits=min_frame_bits, **kw)
        w = f"network {name!r}"
        if switch_memory_bits is not None:
            switch_memory_bits = validate.bits(switch_memory_bits, f"{w}: switch_memory_bits", allow_zero=False)
            # the memory must hold at least one frame: the largest, or the smallest if unbounded
            need = self.max_frame_bits if self.max_frame_bits is not None else self.min_frame_bits
            if switch_memory_bits < need:
                raise ConfigurationError(
                    f"{w}: switch_memory_bits={switch_memory_bits!r} cannot hold one frame of "
                    f"{'max_frame_bits' if self.max_frame_bits is not None else 'min_frame_bits'}={need} bits")
        self.switch_memory_bits = switch_memory_bits
        validate.choice(buffer, f"{w}: buffer", ("shared", "symmetric"))
        validate.choice(overflow, f"{w}: overflow", ("drop", "retransmit"))
        self.buffer, self.overflow = buffer, overflow
        self._switch_delay = validate.duration(switch_delay, f"{w}: switch_delay (s)")
        TxQueue(port_queue, None, what=w)
        self.port_queue = port_queue
        self.memory_used = 0
        self.memory_peak = 0

    def _station(self, iface, options):
        return SwitchPort(self.port_queue)

    # uplink ---------------------------------------------------------------------
    def _kick(self, iface):
        f = self._next_frame(iface)
        if f is not None:
            self.begin_attempt(iface, f)        # the carrier is the uplink's alone
            self.sim.call_in_ticks(self.duration(f.bits), self._at_switch, arg=f)

    def _fits(self, f, outs) -> bool:
        mem = self.switch_memory_bits
        if mem is None:
            return True
        if self.buffer == "shared":
            return self.memory_used + f.bits * len(outs) <= mem
        per_port = mem // len(self._ifaces)
        return all(o.mac.used + f.bits <= per_port for o in outs)

    def _at_switch(self, f):
        src = f.src
        a = src.attempt
        outs = self.receivers(f)
        if not self._fits(f, outs):
            if self.overflow == "retransmit":
                a.end("switch_full")
                a.requeue()
                self._kick(src)
                return
            a.end()                             # sent on the uplink, dropped in the switch
            a.drop("queue_overflow", where="switch")
            return
        a.end()
        for o in outs:
            o.mac.used += f.bits
        self.memory_used += f.bits * len(outs)
        self.memory_peak = max(self.memory_peak, self.memory_used)
        f.holds += len(outs)        # the copies in the switch keep the message's fate open (stats)
        a.finish(restart=False)
        if self._switch_delay:
            self.sim.call_in_ticks(self._switch_delay, self._forward, arg=(f, outs))
        else:
            self._forward((f, outs))
        self._kick(src)

    # output ports ----------------------------------------------------------------
    def _forward(self, item):
        f, outs = item
        for o in outs:
            o.mac.queue.push(f)
            if o.mac.current is None:
                self._port_start(o)

    def _port_start(self, o):
        f = o.mac.current = o.mac.queue.pop()
        o.receiving += 1
        o._state()
        self.sim.call_in_ticks(self.duration(f.bits), self._port_end, arg=o)

    def _port_end(self, o):
        port = o.mac
        f = port.current
        port.current = None
        o.receiving -= 1
        port.used -= f.bits
        self.memory_used -= f.bits
        o._state()
        self._deliver(f, o)     # the switch's copy: loss drawn, hand-over (the sender is done)
        self._let_go(f)
        if port.queue._q:
            self._port_start(o)
