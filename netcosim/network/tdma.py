"""TDMA: a cyclic slot table; frames are suspended at slot end and resumed in the owner's next slot.

``schedule`` lists the owner of each slot (node name, or None for an unused slot);
slot *k* of cycle *c* spans ``[(c * len(schedule) + k) * slot_time, ... + slot_time)``
measured from the network's creation time.  A node transmits its queue only inside its
own slots, frame after frame; a frame that does not fit in the rest of the slot is
cut at the slot end (trace event ``suspended``) and continues at the start of the
node's next slot -- TrueTime's TDMA semantics.  Consecutive slots of the same owner
form one transmission window.

No event is scheduled for slots in which nothing is sent: the next usable slot is
computed analytically from the table.

Checks: every slot owner must be attached (a node or a bare station of that name) by
the time the simulation runs: the first event of the network, at its creation instant,
refuses an owner that is still unknown (``ConfigurationError`` naming it), since slots
of a name nobody attached would silently stay idle.  A frame may be cut any number of
times, but one that would need more than :data:`MAX_SEGMENTS` of its owner's
transmission windows (a ``slot_time`` far shorter than the frames, a unit slip) is
refused when it is first cut (``ConfigurationError`` naming the frame's size and the
slot time) instead of running millions of segments.
"""

from __future__ import annotations

from typing import Sequence

from .. import validate
from ..clock import URGENT
from ..errors import ConfigurationError, ConfigurationTypeError
from ..timebase import TICKS_PER_SECOND
from .base import Network

#: The most transmission windows (owned slot runs) one frame may span; a frame that
#: would need more is refused when it is first cut (see the module docstring).
MAX_SEGMENTS = 1000


class TdmaStation:
    """A TDMA station's state: the pending slot/segment timer and the segment length (ticks)."""

    __slots__ = ("timer", "seg")

    def __init__(self):
        self.timer = None
        self.seg = 0


class TDMA(Network):
    """Time-division bus.  See the module docstring.

    ``data_rate`` in bit/s, ``slot_time`` in s; ``schedule`` lists the slot owners (node names,
    None for an idle slot).

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationTypeError`
        ``schedule`` is a string or not a list, or an entry is neither a node name (or a
        node) nor None; *sim* is not a :class:`~netcosim.Simulation`, or a parameter is
        not a number.
    :class:`~netcosim.errors.ConfigurationError`
        ``schedule`` is empty; ``slot_time`` is not positive; a common parameter out of
        range (:class:`~netcosim.network.base.Network`).  When the run starts: a slot
        owner that no attached node is called.  During the run: a frame that would span
        more than :data:`MAX_SEGMENTS` of its owner's windows.

    Examples
    --------
    Slots of 1 ms owned by ``a``, ``b`` in turn; 1 Mbit/s.  Both queue a frame at t = 0:
    ``b``'s 500 bits wait for its slot (1 ms) and arrive at 1.5 ms; ``a``'s 1500 bits do
    not fit in one slot: 1 ms is sent in slot 0, the frame is suspended, and the last
    0.5 ms goes out at the start of ``a``'s next slot (2 ms), delivered at 2.5 ms:

    >>> from netcosim import Simulation
    >>> from netcosim.network import TDMA
    >>> sim = Simulation(seed=0)
    >>> net = TDMA(sim, "tdma", data_rate=1e6, slot_time=1e-3, schedule=["a", "b"])
    >>> a, b = net.attach("a"), net.attach("b")
    >>> ma, mb = a.send("b", None, size_bits=1500), b.send("a", None, size_bits=500)
    >>> sim.run(until=0.01)
    >>> round(ma.delivered * 1e3, 6), round(mb.delivered * 1e3, 6)          # ms
    (2.5, 1.5)
    >>> net.frames().query("event in ['suspended', 'resumed']")[["time", "event", "src"]].values.tolist()
    [[0.001, 'suspended', 'a'], [0.002, 'resumed', 'a']]
    """

    #: the slot owners, one per slot of the cycle (node names, None for an idle slot)
    slots: list[str | None]

    def __init__(self, sim, name, *, data_rate: float = 10e6, slot_time: float, schedule: Sequence, **kw):
        super().__init__(sim, name, data_rate=data_rate, **kw)
        w = f"network {name!r}"
        self._slot = validate.duration(slot_time, f"{w}: slot_time (s)", positive=True)
        if isinstance(schedule, (str, bytes)) or not hasattr(schedule, "__iter__"):
            raise ConfigurationTypeError(f"{w}: TDMA schedule must be a list of slot owners (node names or "
                                         f"None), got {schedule!r}")
        sched = list(schedule)
        if not sched:
            raise ConfigurationError(f"{w}: TDMA schedule must list at least one slot owner, got {schedule!r}")
        for s in sched:
            if s is not None and not isinstance(s, str):
                s = getattr(s, "name", s)
                if not isinstance(s, str):
                    raise ConfigurationTypeError(f"{w}: schedule entries must be node names or None, got {s!r}")
        self.slots = [None if s is None else getattr(s, "name", s) for s in sched]
        self._cycle = self._slot * len(self.slots)
        self._t0 = sim.env.now
        self._windows: dict[str, list[tuple[int, int]]] = {}
        for k, owner in enumerate(self.slots):
            if owner is None:
                continue
            wins = self._windows.setdefault(owner, [])
            a, b = k * self._slot, (k + 1) * self._slot
            if wins and wins[-1][1] == a:
                wins[-1] = (wins[-1][0], b)
            else:
                wins.append((a, b))
        # a frame longer than this (ticks) would span more than MAX_SEGMENTS windows
        self._max_span = MAX_SEGMENTS * min((b - a for ws in self._windows.values() for a, b in ws), default=0)
        # slot owners must be attached when the run starts (one check, at the first event)
        sim._call_at_ticks(self._t0, self._check_owners, URGENT)

    def _check_owners(self) -> None:
        missing = sorted({o for o in self.slots if o is not None and o not in self.interfaces})
        if missing:
            raise ConfigurationError(f"network {self.name!r}: TDMA schedule {self.slots} names slot owner(s) "
                                     f"{', '.join(map(repr, missing))} that no attached node is called; attach "
                                     f"them before running (attached: {sorted(self.interfaces)})")

    def _station(self, iface, options):
        return TdmaStation()

    def window(self, iface, t: int) -> tuple[int, int]:
        """The transmission window (start, end) in ticks owned by interface *iface* containing *t*
        or the first after it; :class:`~netcosim.errors.ConfigurationError` if *iface* owns no slot."""
        wins = self._windows.get(iface.name)
        if not wins:
            raise ConfigurationError(f"network {self.name!r}: node {iface.name!r} owns no slot in the TDMA schedule "
                             f"{self.slots}")
        rel = t - self._t0
        c, r = divmod(rel, self._cycle)
        for a, b in wins:
            if r < b:
                base = self._t0 + c * self._cycle
                return max(base + a, t), base + b
        base = self._t0 + (c + 1) * self._cycle
        a, b = wins[0]
        return base + a, base + b

    def _kick(self, iface):
        f = self._next_frame(iface)
        if f is not None:
            f.remaining = self.duration(f.bits)
            self._resume(iface)

    def _resume(self, iface):
        st = iface.mac
        st.timer = None
        now = self._env.now
        start, end = self.window(iface, now)
        if start > now:
            st.timer = self.sim._call_at_ticks(start, self._resume, arg=iface)
            iface._state()
            return
        f = iface.current
        if f.attempts == 0:
            self.begin_attempt(iface, f)
        else:
            iface.attempt.resume()
        st.seg = min(f.remaining, end - now)
        st.timer = self.sim.call_in_ticks(st.seg, self._segment_end, arg=iface)

    def _segment_end(self, iface):
        st = iface.mac
        st.timer = None
        f = iface.current
        f.remaining -= st.seg
        a = iface.attempt
        if f.remaining > 0:
            if f.remaining + st.seg > self._max_span:   # rare path: checked only when a frame is cut
                raise ConfigurationError(
                    f"network {self.name!r}: a frame of {f.bits} bits from {iface.name!r} takes "
                    f"{(f.remaining + st.seg) / TICKS_PER_SECOND!r} s at {self.data_rate!r} bit/s, more than "
                    f"{MAX_SEGMENTS} of its owner's windows with slot_time={self._slot / TICKS_PER_SECOND!r} s; "
                    f"is slot_time in seconds?")
            a.suspend()
            self._resume(iface)
            return
        a.end()
        a.deliver_all()
        a.finish()
