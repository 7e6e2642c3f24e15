"""Switched Ethernet: full-duplex links to one store-and-forward switch.

Each node has a full-duplex link of ``data_rate`` bit/s to a switch port.  The node
sends its queue over its uplink (no contention: full duplex, one node per port); the
switch stores the *whole* frame, waits ``switch_delay`` s (forwarding decision), and
queues it on the output port of the destination (every other port for broadcast).
Each output port sends its queue (FIFO, or by priority with ``port_queue="priority"``)
to its node.  Timing of an unloaded frame: ``2 * bits / data_rate + switch_delay``.

Switch memory (``switch_memory_bits``, None = unbounded) holds frames from arrival until
their last copy has left the output port.  ``buffer="shared"``: one pool;
``"symmetric"``: each output port owns ``memory / n_ports``.  A frame that does not fit
is dropped (``overflow="drop"``, traced as ``lost``/``queue_overflow`` at node
``switch``) or refused and sent again by its sender (``overflow="retransmit"``; the
attempt ends with outcome ``switch_full``) -- TrueTime's two options.
"""

from __future__ import annotations

from ..errors import ConfigurationError
from .base import Network
from .checks import check_bits, check_duration
from .interface import TxQueue


class _Switch:
    name = "switch"


class SwitchedEthernet(Network):
    """Star topology around a store-and-forward switch.  See the module docstring."""

    def __init__(self, sim, name, *, data_rate: float = 10e6, min_frame_bits: int = 512,
                 switch_memory_bits: int | None = None, buffer: str = "shared", overflow: str = "drop",
                 switch_delay: float = 0.0, port_queue: str = "fifo", **kw):
        super().__init__(sim, name, data_rate=data_rate, min_frame_bits=min_frame_bits, **kw)
        w = f"network {name!r}"
        if switch_memory_bits is not None:
            switch_memory_bits = check_bits(switch_memory_bits, f"{w}: switch_memory_bits", allow_zero=False)
        self.switch_memory_bits = switch_memory_bits
        if buffer not in ("shared", "symmetric"):
            raise ConfigurationError(f"{w}: buffer must be 'shared' or 'symmetric', got {buffer!r}")
        if overflow not in ("drop", "retransmit"):
            raise ConfigurationError(f"{w}: overflow must be 'drop' or 'retransmit', got {overflow!r}")
        self.buffer, self.overflow = buffer, overflow
        self._switch_delay = check_duration(switch_delay, f"{w}: switch_delay (s)")
        TxQueue(port_queue, None, what=w)
        self.port_queue = port_queue
        self.memory_used = 0
        self.memory_peak = 0
        self._switch = _Switch()

    def _attached(self, iface):
        iface.port = TxQueue(self.port_queue)
        iface.port_current = None
        iface.port_used = 0

    # uplink ---------------------------------------------------------------------
    def _kick(self, iface):
        if iface.current is None and iface.queue._q:
            f = iface.queue.pop()
            iface.current = f
            f.attempts += 1
            f.sent = self._env._now
            iface.sending = 1
            iface._state()
            self._trace("attempt_start", f, iface.name, bits=f.bits)
            self.sim.call_in_ticks(self.duration(f.bits), self._at_switch, arg=f)

    def _fits(self, f, outs) -> bool:
        mem = self.switch_memory_bits
        if mem is None:
            return True
        if self.buffer == "shared":
            return self.memory_used + f.bits * len(outs) <= mem
        per_port = mem // len(self._ifaces)
        return all(o.port_used + f.bits <= per_port for o in outs)

    def _at_switch(self, f):
        src = f.src
        src.sending = 0
        src.current = None
        outs = self.receivers(f)
        if not self._fits(f, outs):
            if self.overflow == "retransmit":
                self._trace("attempt_end", f, src.name, "switch_full")
                src.queue.push_front(f)
                src._state()
                self._kick(src)
                return
            self._trace("attempt_end", f, src.name, "sent" if f.broadcast else "ok")
            self._lost(f, self._switch, "queue_overflow")
            src._state()
            self._finish(f, False)
            self._kick(src)
            return
        self._trace("attempt_end", f, src.name, "sent" if f.broadcast else "ok")
        for o in outs:
            o.port_used += f.bits
        self.memory_used += f.bits * len(outs)
        self.memory_peak = max(self.memory_peak, self.memory_used)
        src._state()
        self._finish(f, True)
        if self._switch_delay:
            self.sim.call_in_ticks(self._switch_delay, self._forward, arg=(f, outs))
        else:
            self._forward((f, outs))
        self._kick(src)

    # output ports ----------------------------------------------------------------
    def _forward(self, item):
        f, outs = item
        for o in outs:
            o.port.push(f)
            if o.port_current is None:
                self._port_start(o)

    def _port_start(self, o):
        f = o.port.pop()
        o.port_current = f
        o.receiving += 1
        o._state()
        self.sim.call_in_ticks(self.duration(f.bits), self._port_end, arg=o)

    def _port_end(self, o):
        f = o.port_current
        o.port_current = None
        o.receiving -= 1
        o.port_used -= f.bits
        self.memory_used -= f.bits
        o._state()
        self._deliver(f, o)
        if o.port._q:
            self._port_start(o)
