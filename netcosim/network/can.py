"""CAN: priority arbitration at every idle instant, non-preemptive (CSMA/AMP).

Whenever the bus goes idle (or a frame is queued on an idle bus) the frames at the head
of every node's queue compete and the one with the smallest priority number (the CAN
identifier) wins; it is sent to completion.  Each node's controller queue is ordered by
priority too (``queue="priority"``, the default).  Real CAN needs unique identifiers;
here equal priorities from different nodes are broken by attach order.

Cost: the bus keeps a heap of the nodes' head-of-queue identifiers, keyed
``(priority, attach index)``, updated when a node's head changes (a frame queued ahead
of the head, or the head taken into service).  An arbitration is O(log n) in the number
of nodes n instead of a scan of every queue.

Frame length, two models:

* ``frame_format="truetime"`` (default): ``max(size_bits, min_frame_bits)`` bits,
  TrueTime's model -- the message length is the frame length.
* ``frame_format="standard"``: ``size_bits`` is the payload (at most 8 bytes, rounded up
  to whole bytes ``s``); the bus carries the worst-case stuffed frame including the
  3-bit interframe space (Davis, Burns, Bril, Lukkien 2007, eq. 1)::

      C = g + 8 s + 13 + floor((g + 8 s - 1) / 4)   bits,  g = 34 (11-bit id) or 54 (29-bit id)

  = 55 + 10 s bits for standard identifiers.  ``stuffing=False`` gives the unstuffed
  length ``g + 8 s + 13``.
"""

from __future__ import annotations

import heapq
import math

from .. import validate
from ..errors import ConfigurationError
from .bus import SharedBus


def can_frame_bits(data_bytes: int, *, extended: bool = False, stuffing: bool = True) -> int:
    """Bits a CAN 2.0 data frame with *data_bytes* (0..8) occupies on the bus, with the 3-bit IFS.

    ``extended``: a 29-bit identifier (CAN 2.0B, 54 header bits before stuffing) instead of
    the 11-bit one (34).  Worst-case bit stuffing (Davis et al. 2007) unless ``stuffing=False``.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        *data_bytes* is not an integer in 0..8.

    Examples
    --------
    ``55 + 10 s`` bits for *s* data bytes with an 11-bit identifier, ``80 + 10 s`` with a
    29-bit one; at 500 kbit/s a full standard frame takes 135 / 500e3 s = 270 µs:

    >>> from netcosim.network import can_frame_bits
    >>> can_frame_bits(0), can_frame_bits(8), can_frame_bits(8, extended=True)
    (55, 135, 160)
    >>> can_frame_bits(8, stuffing=False)
    111
    """
    data_bytes = validate.integer(data_bytes, "a CAN frame's data_bytes", lo=0, hi=8, type_error=ConfigurationError)
    g = 54 if extended else 34
    n = g + 8 * data_bytes + 13
    if stuffing:
        n += (g + 8 * data_bytes - 1) // 4
    return n


class CAN(SharedBus):
    """A CAN bus.  See the module docstring.

    ``data_rate``: bit rate (bit/s; default 500 kbit/s).  ``frame_format``:
    ``"truetime"`` or ``"standard"``; ``extended``: 29-bit identifiers; ``stuffing``:
    worst-case stuff bits in the standard format.  Messages need a priority (pass
    ``priority=`` to ``send`` or a default to ``attach``); small = high.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        ``frame_format`` not ``"truetime"`` or ``"standard"``; in the standard format,
        a ``min_frame_bits`` given or a ``max_frame_bits`` above 64 (a CAN frame carries at
        most 8 data bytes); a common parameter out of range
        (:class:`~netcosim.network.base.Network`).  At ``send``: a message without a
        priority (none given to ``send`` nor to ``attach``).
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sim* is not a :class:`~netcosim.Simulation`, or a parameter is not a number.

    Examples
    --------
    Two nodes queue an 8-byte standard frame (135 bits, :func:`can_frame_bits`) at the
    same instant on a 500 kbit/s bus: identifier 1 wins the arbitration and is delivered
    after 135 / 500e3 s = 270 µs, identifier 2 after twice that:

    >>> from netcosim import Simulation
    >>> from netcosim.network import CAN
    >>> sim = Simulation(seed=0)
    >>> can = CAN(sim, "can", data_rate=500e3, frame_format="standard")
    >>> hi, lo = can.attach("hi", priority=1), can.attach("lo", priority=2)
    >>> ctrl = can.attach("ctrl")
    >>> arrivals = []
    >>> _ = ctrl.on_receive(lambda msg: arrivals.append((msg.src, round(sim.now * 1e6, 3))))
    >>> _ = lo.send("ctrl", None, size_bits=64)          # queued first, but lower priority
    >>> _ = hi.send("ctrl", None, size_bits=64)
    >>> sim.run(until=0.01)
    >>> arrivals                                          # (sender, µs)
    [('hi', 270.0), ('lo', 540.0)]
    """

    default_queue = "priority"

    def __init__(self, sim, name, *, data_rate: float = 500e3, frame_format: str = "truetime",
                 extended: bool = False, stuffing: bool = True, max_frame_bits: int | None = None, **kw):
        validate.choice(frame_format, f"network {name!r}: CAN frame_format", ("truetime", "standard"))
        if frame_format == "standard":
            if kw.get("min_frame_bits"):
                raise ConfigurationError(f"network {name!r}: min_frame_bits does not apply to the standard CAN "
                                         f"format, got min_frame_bits={kw['min_frame_bits']!r}")
            if max_frame_bits is None:
                max_frame_bits = 64
            elif validate.bits(max_frame_bits, f"network {name!r}: max_frame_bits", allow_zero=False) > 64:
                raise ConfigurationError(f"network {name!r}: standard CAN frames carry at most 64 data bits, "
                                 f"got max_frame_bits={max_frame_bits!r}")
        self.frame_format = frame_format
        self.allow_empty = frame_format == "standard"
        self.extended = bool(extended)
        self.stuffing = bool(stuffing)
        self._reset_heap()
        super().__init__(sim, name, data_rate=data_rate, max_frame_bits=max_frame_bits, **kw)

    def wire_bits(self, size_bits: int) -> int:
        """Number of bits on the bus for a message of *size_bits* bits: a standard-format CAN frame
        (with stuffing if configured), else the padded payload."""
        if self.frame_format == "standard":
            return can_frame_bits(math.ceil(size_bits / 8), extended=self.extended, stuffing=self.stuffing)
        return super().wire_bits(size_bits)

    def _check_priority(self, priority, iface):
        if priority is None:
            raise ConfigurationError(f"network {self.name!r}: CAN message from {iface.name!r} needs a priority "
                             f"(identifier): pass priority= to send() or to attach()")
        super()._check_priority(priority, iface)

    # Arbitration heap.  ``_head[i]`` is the identifier at the head of interface i's queue
    # (None: empty); ``_heap`` holds ``(identifier, index)`` entries, at least one per
    # non-empty queue with its current head.  An entry whose identifier is no longer the
    # head of its interface is stale and discarded when it reaches the top (lazy deletion).
    # The key (identifier, attach index) gives the same winner as a scan in attach order.
    def attach(self, node, **kw):
        iface = super().attach(node, **kw)
        self._head.append(None)
        return iface
    attach.__doc__ = SharedBus.attach.__doc__

    def _reset_heap(self) -> None:
        self._head: list = []
        self._heap: list = []
        self._waiting = 0       # interfaces with a non-empty queue

    def _head_changed(self, iface) -> None:
        q = iface.queue
        i = iface.index
        old = self._head[i]
        if q._q:
            key = q.peek().priority
            if old is None:
                self._waiting += 1
            elif key == old:
                return
            self._head[i] = key
            heap = self._heap
            heapq.heappush(heap, (key, i))
            if len(heap) > 4 * len(self._head) + 16:
                # too many stale entries (heads that changed without reaching the top): rebuild
                heap[:] = [(k, j) for j, k in enumerate(self._head) if k is not None]
                heapq.heapify(heap)
        elif old is not None:
            self._head[i] = None
            self._waiting -= 1

    def _kick(self, iface) -> None:
        self._head_changed(iface)     # a frame was queued at iface
        super()._kick(iface)

    def _next_frame(self, iface):
        f = super()._next_frame(iface)
        if f is not None:
            self._head_changed(iface)
        return f

    def _restart(self, iface) -> None:
        if self._waiting:
            self._kick(iface)

    def _choose(self):
        heap, head = self._heap, self._head
        while heap:
            key, i = heap[0]
            if head[i] is not None and head[i] == key:
                return self._ifaces[i]
            heapq.heappop(heap)
        return None
