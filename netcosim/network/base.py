"""The pipeline every network shares, and the traces it writes.

    send -> pre-processing delay -> sender queue (FIFO or priority)
         -> medium access (the MAC: subclass) -> transmission of the frame's bits
         -> [loss draw] -> propagation + post-processing delay
         -> receiver mailbox and/or receive handlers (TrueTime's network interrupt)

A network is created with its simulation and a name, e.g.
``CAN(sim, "can", data_rate=500e3)``; it registers itself in ``sim.networks``.  Nodes
join with :meth:`Network.attach`, which returns the node's :class:`Interface` and
stores it in ``node.interfaces[network.name]`` so tasks can ``ctx.send(...)``.

Traces (tables of ``sim.trace``, times in seconds):

``frames``
    one row per frame event: ``time, network, frame, event, src, dst, node,
    attempt, outcome, bits, backoff``.  Events: ``created`` (``bits`` = declared
    size), ``queued``, ``attempt_start`` (``bits`` on the wire, ``backoff`` = slots
    drawn before this attempt where the MAC draws them), ``attempt_end`` (``outcome``:
    ``ok``/``sent`` or the failure reason), ``ack`` (WLAN: the receiver starts its ACK),
    ``delivered`` (``node`` = receiver), ``lost`` (``outcome`` = reason, ``node`` = where).
    ``dst`` is ``*`` for broadcast.  ``attempt`` counts attempts made so far.
``network_schedule``
    ``time, network, node, state`` with state in
    ``idle / waiting / sending / receiving`` (rows only on changes).

Durations are integer ticks computed once per (bits, rate): two frames of equal
length take exactly equal time, and instants that coincide on paper coincide here.

The MAC seam: a MAC subclasses :class:`Network` and implements ``_kick`` (medium
access for a queued frame) and usually ``_station`` (its per-station state, kept as
``iface.mac``); it drives each frame through its :class:`~netcosim.network.lifecycle.Attempt`
(``begin_attempt`` -> ``end`` -> ``deliver``/``deliver_all`` -> ``finish`` or ``drop``, checked
by state).  Everything else -- validation, queues, counters, interface states, trace
rows, the loss draw (:meth:`~netcosim.network.lifecycle.FrameLifecycle.frame_lost`, the
one place), delivery, ``stats``, ``on_done`` and the restart of the queue -- is the
base's.  Modules: this one (the pipeline), ``lifecycle`` (attempts, loss draw, hand-over),
``links`` (per-link accounting, ``message_loss``, ``stats``), ``tracing`` (the tables).
See "Writing a MAC" in ``docs/networks.md``.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Any

from .. import validate
from ..clock import ARBITRATE  # noqa: F401 (re-exported: MAC arbitration priority)
from ..errors import ConfigurationError, ConfigurationTypeError, OverloadError, OverloadWarning
from ..timebase import MAX_TICKS, RESOLUTION, TICKS_PER_SECOND
from .frame import BROADCAST, Frame, Message
from .interface import Interface, TxQueue
from .lifecycle import Attempt, FrameLifecycle, MacOrderError  # noqa: F401 (re-exported: the MAC seam)
from .links import LinkAccounting, _message_loss
from .loss import as_loss_model
from .plot import NETWORK_STATES  # noqa: F401 (re-exported: the states of the network_schedule table)
from .stats import LinkStats
from .tracing import (  # noqa: F401 (re-exported: the trace tables' columns)
    FRAME_COLUMNS,
    LINK_BITS,
    SCHEDULE_COLUMNS,
    _plot_network,
    network_tables,
)

#: default size (frames) of a sender queue: far beyond any load a network drains (tests
#: queue 30 000 messages at once); a sender that outruns its network then holds about
#: 150 MB (1.4 kB per queued message with its trace rows, measured), not the machine
DEFAULT_QUEUE_CAPACITY = 100_000

if TYPE_CHECKING:
    import pandas as pd

_NAN = math.nan
_LINK_UNIT = 1 << LINK_BITS     # one frame id in a frames row's key (tracing.NetworkNames.key)


def _check_sim(sim: Any, who: str) -> None:
    """Refuse a first argument that is not a :class:`~netcosim.Simulation`, naming it."""
    from ..sim import Simulation
    if not isinstance(sim, Simulation):
        raise ConfigurationTypeError(f"{who}: sim must be a netcosim Simulation (the first argument), got {sim!r}")


class Network(FrameLifecycle, LinkAccounting):
    """Base class of all networks (the common pipeline; subclasses are MACs).

    The parameters below are common to all networks.

    Parameters
    ----------
    sim, name:
        The simulation and a unique component name.
    data_rate:
        Bit rate in bit/s (any positive number).
    min_frame_bits:
        Minimum frame length; shorter messages are padded (TrueTime's minimum frame size).
    max_frame_bits:
        Largest message accepted (``send`` raises beyond it); None = no limit.
    pre_delay, post_delay:
        Pre-processing delay at the sender before queueing, post-processing delay at
        the receiver before delivery (s).
    propagation_delay:
        Added between the end of reception and delivery (s, default 0 as in TrueTime).
        MAC timing (carrier sense, ACK turnaround) does not see it.
    loss:
        A probability (Bernoulli), a :mod:`loss model <netcosim.network.loss>`, or a
        list of them.  It is a *frame* loss: drawn once per transmitted frame (each
        attempt of a retried frame is drawn again) and per receiver, independently of
        the physics' own losses.  The *message* loss a task sees follows from the MAC:
        where a frame lost so is not sent again (wired networks draw at delivery;
        broadcast on the radio networks) it equals the frame loss ``p``; acknowledged
        unicast on the radio networks retries it, up to ``retry_limit`` attempts in all
        on 802.11b and ``max_frame_retries + 1`` on 802.15.4, so with independent
        losses and no other failures a message is lost with probability ``p**attempts``
        (``0.5**7 < 1 %`` with 802.11b's default of 7).  A unicast frame loss of at
        least 0.05 that retries hide so that the expected message loss ``p**attempts``
        is below a tenth of ``p`` is noted once per network, at its first unicast
        message (:class:`~netcosim.network.loss.MaskedLossWarning`).
    message_loss:
        A probability or loss model like ``loss``, but drawn once per *message* and
        link when it is sent (TrueTime's wireless loss): a message drawn lost is
        silenced before medium access -- it never occupies the medium, is never
        retried, is traced ``lost`` with outcome ``message_loss`` at the receiver whose
        link was silenced, and the sender's ``on_done`` callbacks see it dropped.  A
        message loss ``p`` is a message loss ``p`` whatever the MAC (a broadcast is
        silenced per receiver and still sent to the others).  Draws come from the
        stream ``<net>/message_loss/<src>-><dst>``, so the same seed gives the same
        results and the frame-loss draws are unchanged.  Per link: a dict
        ``{(src, dst): p or model}`` of node names; links not listed lose no message.

        ===========================  =========================  ====================
        option                       message loss, Bernoulli p  medium occupied
        ===========================  =========================  ====================
        ``loss=p``, 1 attempt        ``p``                      yes, every attempt
        ``loss=p``, r attempts       ``p**r``                   yes, every attempt
        ``message_loss=p``           ``p``                      no, silenced message
        ===========================  =========================  ====================

        ``stats`` (and :meth:`link_stats`) counts both per link: messages sent,
        delivered, lost and the frame (attempt) losses; see :mod:`netcosim.network.stats`.
    queue, queue_capacity, on_queue_full:
        Sender queue discipline (``"fifo"`` or ``"priority"``) and size in frames
        (default :data:`DEFAULT_QUEUE_CAPACITY`; None: unbounded, as TrueTime).  A
        message that finds the queue full is lost with reason ``queue_overflow``
        (counted in the frames table and ``stats``) with an
        :class:`~netcosim.errors.OverloadWarning` the first time (``on_queue_full="drop"``,
        the default), or raises :class:`~netcosim.errors.OverloadError`
        (``on_queue_full="error"``).
    mailbox_capacity:
        Default receive-mailbox size (None = unbounded).
    trace:
        Record the ``frames`` and ``network_schedule`` tables (turn off for speed);
        ``True`` or ``False`` exactly.

    ``sim`` must be a :class:`~netcosim.Simulation` (``ConfigurationTypeError`` naming
    it otherwise, for every network).

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        A parameter out of range, naming it and the value: ``data_rate`` not positive and
        finite; a negative or non-integer number of bits; ``max_frame_bits`` below
        ``min_frame_bits``; a negative delay; a loss probability outside [0, 1]; ``queue``
        or ``on_queue_full`` not one of the names above; ``queue_capacity`` or
        ``mailbox_capacity`` below 1; *name* empty or already used by another component
        of *sim*.
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sim* is not a :class:`~netcosim.Simulation`; a parameter that is not a number
        (or, for ``trace``, not ``True``/``False``); ``loss`` or ``message_loss`` neither
        a probability, nor a loss model, nor a list of them.

    Examples
    --------
    Every MAC is a ``Network`` and takes these parameters.  On an
    :class:`~netcosim.network.ideal.IdealLink` a 100-bit message, padded to a 512-bit
    minimum frame, is delivered after ``pre_delay + 512 bits / 1 Mbit/s +
    propagation_delay + post_delay`` = 100 + 512 + 5 + 200 µs:

    >>> from netcosim import Simulation
    >>> from netcosim.network import IdealLink, Network
    >>> sim = Simulation(seed=0)
    >>> net = IdealLink(sim, "link", data_rate=1e6, min_frame_bits=512, pre_delay=100e-6,
    ...                 propagation_delay=5e-6, post_delay=200e-6)
    >>> isinstance(net, Network)
    True
    >>> a, b = net.attach("a"), net.attach("b")         # bare stations, driven from Python
    >>> msg = a.send("b", "hello", size_bits=100)
    >>> sim.run(until=0.01)
    >>> round(msg.latency * 1e6, 3), round((100e-6 + 512 / 1e6 + 5e-6 + 200e-6) * 1e6, 3)
    (817.0, 817.0)
    >>> net.duration(512) / 1e12, net.wire_bits(100)      # ticks (1 ps) of a 512-bit frame
    (0.000512, 512)
    """

    default_queue = "fifo"
    #: whether a message of 0 bits is meaningful (CAN data frames with 0 data bytes)
    allow_empty = False

    def __init__(self, sim, name: str, *, data_rate: float, min_frame_bits: int = 0,
                 max_frame_bits: int | None = None, pre_delay: float = 0.0, post_delay: float = 0.0,
                 propagation_delay: float = 0.0, loss: Any = None, message_loss: Any = None, queue: str | None = None,
                 queue_capacity: int | None = DEFAULT_QUEUE_CAPACITY, on_queue_full: str = "drop",
                 mailbox_capacity: int | None = None, trace: bool = True):
        _check_sim(sim, f"{type(self).__name__} {name!r}")
        self.sim = sim
        self._env = sim.env
        self.name = name
        w = f"network {name!r}"
        self.data_rate = validate.positive(data_rate, f"{w}: data_rate (bit/s)")
        self.min_frame_bits = validate.bits(min_frame_bits, f"{w}: min_frame_bits")
        if max_frame_bits is not None:
            max_frame_bits = validate.bits(max_frame_bits, f"{w}: max_frame_bits", allow_zero=False)
            if max_frame_bits < self.min_frame_bits:
                raise ConfigurationError(f"{w}: max_frame_bits={max_frame_bits} is below min_frame_bits="
                                 f"{self.min_frame_bits}")
        self.max_frame_bits = max_frame_bits
        self._pre = validate.duration(pre_delay, f"{w}: pre_delay (s)")
        self._post = validate.duration(post_delay, f"{w}: post_delay (s)")
        self._prop = validate.duration(propagation_delay, f"{w}: propagation_delay (s)")
        self.pre_delay, self.post_delay, self.propagation_delay = pre_delay, post_delay, propagation_delay
        self.loss = as_loss_model(loss)
        self.message_loss = _message_loss(message_loss, w)
        # the once-per-network notice of a frame loss hidden by retries (checked at the first unicast)
        p = self.loss.frame_loss() if self.loss is not None else None
        self._mask_check = p is not None and p >= 0.05
        self.queue = queue or self.default_queue
        TxQueue(self.queue, queue_capacity, what=w)  # validate now, not at attach
        self.queue_capacity = queue_capacity
        self.on_queue_full = validate.choice(on_queue_full, f"{w}: on_queue_full", ("drop", "error"))
        self._overflowed = False
        if mailbox_capacity is not None:
            mailbox_capacity = validate.count(mailbox_capacity, f"{w}: mailbox_capacity (messages)", minimum=1)
        self.mailbox_capacity = mailbox_capacity
        self._trace_on = validate.boolean(trace, f"{w}: trace")
        self.interfaces: dict[str, Interface] = {}
        self._ifaces: list[Interface] = []
        self._links: dict = {}
        self._mlinks: dict = {}
        self._lstats: dict[tuple[int, int], LinkStats] = {}
        self._dur: dict = {}
        self._next_id = 0
        # the trace's names of the network rows (tracing.py): rows store their codes
        self._tnames, self._frames_rec, self._sched_rec = network_tables(sim.trace)
        self._rows = self._frames_rec.rows
        self._sched_rows = self._sched_rec.rows
        self._tend: tuple | None = None     # the newest attempt_end row (merged with a delivery: lifecycle)
        sim.trace.add_plot("network", _plot_network)
        sim._register(name, self)
        sim.networks[name] = self

    # ------------------------------------------------------------------ nodes
    def attach(self, node, *, priority=None, mailbox: bool = True, mailbox_capacity: int | None = None,
               queue: str | None = None, queue_capacity: int | None = None, handler=None, **options) -> Interface:
        """Attach *node* (a kernel node, or a name for a bare station) and return its interface.

        ``priority``: default MAC priority of the node's messages.  ``handler``: a task
        (released per delivered message) or callable ``fn(msg)``.  ``mailbox=False``:
        deliver only to handlers.  Other keyword options are MAC-specific (e.g.
        ``position`` on wireless networks).  ``mailbox_capacity`` (messages, >= 1),
        ``queue`` (``"fifo"`` or ``"priority"``) and ``queue_capacity`` (frames, >= 1): this
        interface's receive mailbox size and sender queue, default (None) the network's.
        """
        if isinstance(node, str):
            name, knode = node, None
        elif hasattr(node, "interfaces") and hasattr(node, "name"):
            name, knode = node.name, node
        else:
            raise ConfigurationTypeError(f"network {self.name!r}: attach a kernel node or a station name, "
                                         f"got {node!r}")
        validate.name(name, f"network {self.name!r}: station name", type_error=ConfigurationError)
        if name in self.interfaces:
            raise ConfigurationError(f"network {self.name!r}: node {name!r} is already attached")
        if priority is not None:
            validate.real(priority, f"network {self.name!r}: default priority of node {name!r}",
                          kind="a finite number (small = high) or None")
        iface = Interface(self, name, knode, len(self._ifaces), priority=priority, mailbox=mailbox,
                          mailbox_capacity=self.mailbox_capacity if mailbox_capacity is None else mailbox_capacity,
                          queue=queue or self.queue,
                          queue_capacity=self.queue_capacity if queue_capacity is None else queue_capacity)
        options = dict(options)
        iface.mac = self._station(iface, options)
        if options:
            raise ConfigurationTypeError(f"network {self.name!r} ({type(self).__name__}): unknown attach "
                                         f"option(s) {sorted(options)}")
        self.interfaces[name] = iface
        self._ifaces.append(iface)
        if knode is not None:
            knode.interfaces[self.name] = iface
        if handler is not None:
            iface.on_receive(handler)
        iface._trace_codes(self._tnames)
        if self._trace_on:
            iface._srows = self._sched_rows
            self._sched_rows.append((self._env.now, iface._tstate["idle"]))
        return iface

    def interface(self, node) -> Interface:
        """The interface of *node* (name, kernel node or interface)."""
        key = getattr(node, "name", node)
        try:
            return self.interfaces[key]
        except (KeyError, TypeError):
            raise KeyError(f"network {self.name!r}: unknown node {key!r}; attached: {list(self.interfaces)}") \
                from None

    def _resolve_dst(self, dst, src: Interface):
        if dst is BROADCAST:
            return BROADCAST
        if isinstance(dst, Interface):
            if dst.network is not self:
                raise ConfigurationError(f"network {self.name!r}: destination {dst!r} is on another network")
            return dst
        key = getattr(dst, "name", dst)
        iface = self.interfaces.get(key) if isinstance(key, str) else None
        if iface is None:
            raise ConfigurationError(f"network {self.name!r}: unknown destination node {dst!r}; "
                                     f"attached: {list(self.interfaces)}")
        if iface is src:
            raise ConfigurationError(f"network {self.name!r}: node {src.name!r} cannot send to itself")
        return iface

    def receivers(self, frame: Frame):
        """Interfaces a frame is addressed to (every other one for broadcast)."""
        if frame.dst is BROADCAST:
            src = frame.src
            return [i for i in self._ifaces if i is not src]
        return (frame.dst,)

    # ------------------------------------------------------------------ timing
    def duration(self, bits: int, rate: float | None = None) -> int:
        """Ticks to transmit *bits* at *rate* bit/s (default the data rate), rounded once."""
        key = (bits, rate)
        d = self._dur.get(key)
        if d is None:
            exact = bits * TICKS_PER_SECOND / (rate or self.data_rate)
            if not exact <= MAX_TICKS:
                raise ConfigurationError(f"network {self.name!r}: {bits} bits at {rate or self.data_rate!r} bit/s take "
                                         f"{exact / TICKS_PER_SECOND:.6g} s, beyond netcosim's time range "
                                         f"({MAX_TICKS / TICKS_PER_SECOND:.6g} s)")
            d = self._dur[key] = int(round(exact))
        return d

    def wire_bits(self, size_bits: int) -> int:
        """Number of bits on the medium for a message of *size_bits* bits (default: padded to the
        minimum frame size)."""
        return size_bits if size_bits >= self.min_frame_bits else self.min_frame_bits

    def _check_priority(self, priority, iface) -> None:
        t = type(priority)
        if t is int or (t is float and math.isfinite(priority)):
            return                  # the common case, without the (slow) numbers.Real check
        if priority is not None:
            validate.finite(priority, f"network {self.name!r}: priority of a message from {iface.name!r}",
                            type_error=ConfigurationError)

    # ------------------------------------------------------------------ pipeline
    def _send(self, iface: Interface, dst, payload, size_bits, priority) -> Message:
        if size_bits is None:
            if self.min_frame_bits == 0:
                raise ConfigurationError(f"network {self.name!r}: send from {iface.name!r} needs size_bits "
                                         f"(this network has no minimum frame to default to)")
            size = self.min_frame_bits
        elif type(size_bits) is int and (0 < size_bits <= validate.MAX_BITS or (size_bits == 0 and self.allow_empty)):
            size = size_bits        # the common case, without building the error text
        else:
            size = validate.bits(size_bits, f"network {self.name!r}: size_bits of a message from {iface.name!r}",
                                 allow_zero=self.allow_empty)
        if self.max_frame_bits is not None and size > self.max_frame_bits:
            raise ConfigurationError(f"network {self.name!r}: message of size_bits={size} from {iface.name!r} exceeds "
                             f"the maximum frame of {self.max_frame_bits} bits")
        d = self._resolve_dst(dst, iface)
        prio = iface.priority if priority is None else priority
        self._check_priority(prio, iface)
        now = self._env.now
        self._next_id += 1
        msg = Message(self._next_id, self.name, iface.name, BROADCAST if d is BROADCAST else d.name, payload,
                      size, prio, now * RESOLUTION)
        frame = Frame(msg, iface, d, self.wire_bits(size), prio, iface._seq, now)
        iface._seq += 1
        merge = None
        if self._trace_on:
            lk = iface._tlinks.get(d)
            if lk is None:
                lk = iface._tlinks[d] = self._tnames.link(self.name, iface.name, frame.dname)
            frame.tkey = key = frame.id * _LINK_UNIT + lk     # id << LINK_BITS | lk, without the cold shift
            if self._pre or self.message_loss is not None or self._frames_rec.mode != "keep":
                self._rows.append((now, key, iface._tw_created, 0, size, _NAN))
                merge = None
            else:   # nothing can come between: _enqueue writes one row for both (tracing.py)
                merge = size
        if d is BROADCAST:
            for r in self._ifaces:
                if r is not iface:
                    self._open_link(frame, iface, r)
        else:
            if self._mask_check:
                self._check_masked_loss()
            self._open_link(frame, iface, d)
        if frame.silenced is not None and not frame.lstats:     # silenced on every link: never queued
            self._finish(frame, False)
            return msg
        if self._pre:
            self.sim.call_in_ticks(self._pre, self._enqueue, arg=frame)
        else:
            self._enqueue(frame, merge)
        return msg

    def _queue_full(self, iface: Interface) -> None:
        """A message finds *iface*'s sender queue full: raise, or warn the first time."""
        what = (f"network {self.name!r}: the sender queue of {iface.name!r} holds {iface.queue.capacity} frames "
                f"(queue_capacity) at t = {self.sim.now:.9g} s")
        if self.on_queue_full == "error":
            raise OverloadError(f"{what}: the sender is overloaded (on_queue_full='error')")
        if not self._overflowed:
            self._overflowed = True
            warnings.warn(f"{what}: this message and further ones that find a sender queue full are lost "
                          f"(reason queue_overflow, counted in stats); pass queue_capacity=None for TrueTime's "
                          f"unbounded queue, or on_queue_full='error'", OverloadWarning, stacklevel=4)

    def _enqueue(self, frame: Frame, created: int | None = None) -> None:
        """Put *frame* in its sender's queue (or lose it: queue full).  *created*: the declared
        size of a frame sent now whose ``created`` row is not written yet (``keep`` mode, no
        delay before the queue): one stored row then stands for ``created`` and ``queued``."""
        iface = frame.src
        if iface.queue.full():
            if created is not None:
                self._rows.append((frame.created, frame.tkey, iface._tw_created, 0, created, _NAN))
            self._queue_full(iface)
            self._lost(frame, iface, "queue_overflow")
            self._finish(frame, False)
            return
        frame.queued = self._env.now
        iface.queue.push(frame)
        if created is not None:
            append = self._rows.append      # a slot read: cheaper than a method lookup on the Sink
            append((frame.queued, frame.tkey, iface._tw_sent_now, 0, created, frame.bits))
        elif self._trace_on:
            self._rows.append((frame.queued, frame.tkey, iface._tw_queued, 0, frame.bits, _NAN))
        self._kick(iface)
        iface._state()

    # ------------------------------------------------------------------ MAC hooks
    # A MAC implements _kick (and usually _station); the life-cycle steps below are shared.
    def _station(self, iface: Interface, options: dict) -> Any:
        """Hook: the MAC's per-station state for a newly attached *iface* (kept as ``iface.mac``).

        Pop the MAC-specific ``attach`` keyword options from *options* (any left over is
        an error).  Default: no state.
        """
        return None

    def _kick(self, iface: Interface) -> None:
        """Hook: *iface* may have a frame to send (one was queued, or the MAC looks again)."""
        raise NotImplementedError

    def _restart(self, iface: Interface) -> None:
        """Hook: *iface* is free again after a frame; by default serve its queue (:meth:`_kick`)."""
        self._kick(iface)

    def frames(self) -> pd.DataFrame:
        """This network's rows of the ``frames`` trace."""
        df = self.sim.trace.frame("frames")
        return df[df["network"] == self.name].reset_index(drop=True)

    def schedule(self) -> pd.DataFrame:
        """This network's rows of the ``network_schedule`` trace."""
        df = self.sim.trace.frame("network_schedule")
        return df[df["network"] == self.name].reset_index(drop=True)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name} {self.data_rate:g} bit/s, {len(self._ifaces)} nodes>"

