"""Network interfaces: a node's attachment point to one network.

An :class:`Interface` owns the sender queue (FIFO or by priority), the receive
:class:`~netcosim.kernel.Mailbox`, and the list of receive handlers (tasks released,
or callables called, once per delivered message -- TrueTime's network interrupt).
Tasks send with ``ctx.send(dst, payload, size_bits, priority=...)``; the kernel routes
that to :meth:`Interface.send`.  Code outside a kernel (tests, traffic generators) may
call :meth:`Interface.send` directly.
"""

from __future__ import annotations

import heapq
from collections import deque
from typing import Any, Callable

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from ..kernel.sync import Mailbox
from ..kernel.task import Task
from .lifecycle import Attempt


class TxQueue:
    """Sender queue: ``"fifo"`` or ``"priority"`` (smallest priority first, FIFO among equals).

    ``discipline`` is ``"fifo"`` (default) or ``"priority"``; ``capacity`` (frames, None =
    unbounded) counts frames waiting, not the frame in service; ``what`` names the queue's
    owner in error messages (e.g. ``"network 'can' node 'n1'"``).
    """

    __slots__ = ("discipline", "capacity", "_q", "_n")

    def __init__(self, discipline: str = "fifo", capacity: int | None = None, what: str = "queue"):
        validate.choice(discipline, f"{what}: queue discipline", ("fifo", "priority"))
        if capacity is not None:
            capacity = validate.integer(capacity, f"{what}: queue capacity", lo=1, kind="a positive integer or None",
                                        type_error=ConfigurationError)
        self.discipline = discipline
        self.capacity = capacity
        self._q: Any = deque() if discipline == "fifo" else []
        self._n = 0

    def __len__(self) -> int:
        return len(self._q)

    def full(self) -> bool:
        """True when a bounded queue holds ``capacity`` frames (never for ``capacity=None``)."""
        return self.capacity is not None and len(self._q) >= self.capacity

    def push(self, frame) -> None:
        """Append *frame*: at the tail (``fifo``), or by its ``priority``, small first, FIFO among
        equals (``priority``).  The caller checks :meth:`full` first."""
        if self.discipline == "fifo":
            self._q.append(frame)
        else:
            self._n += 1
            p = frame.priority
            heapq.heappush(self._q, (0 if p is None else p, self._n, frame))

    def push_front(self, frame) -> None:
        """Put a frame back at the head (retransmission after a refused hand-over)."""
        if self.discipline == "fifo":
            self._q.appendleft(frame)
        else:
            p = frame.priority
            heapq.heappush(self._q, (0 if p is None else p, -10**18 + frame.id, frame))

    def peek(self):
        """The frame that :meth:`pop` would return, without removing it; None when empty."""
        if not self._q:
            return None
        return self._q[0] if self.discipline == "fifo" else self._q[0][2]

    def pop(self):
        """Remove and return the head frame (raises :class:`IndexError` when empty)."""
        if self.discipline == "fifo":
            return self._q.popleft()
        return heapq.heappop(self._q)[2]

    def __iter__(self):
        if self.discipline == "fifo":
            return iter(self._q)
        return (e[2] for e in sorted(self._q))


class Interface:
    """A node's interface on one network.  Create with ``network.attach(node, ...)``.

    Attributes: ``name`` (the node's name), ``node`` (the kernel node, or None for a
    bare station driven from Python), ``network``, ``mailbox`` (received messages),
    ``queue`` (frames waiting to be sent), ``priority`` (default MAC priority of this
    node's messages), ``state`` (``idle``/``waiting``/``sending``/``receiving``), ``mac``
    (the MAC's per-station state object, e.g. a WLAN station's contention window).
    ``on_done`` is a list of callables ``fn(frame, ok)`` called when the sender is done
    with a frame (sent / acknowledged: ``ok=True``; dropped: ``ok=False``).
    ``index``: the interface's position in the network's attach order (0 for the first),
    its receiver index in the loss and link accounting; ``mailbox_capacity`` (messages,
    None: unbounded) bounds the mailbox; ``queue`` (``"fifo"`` or ``"priority"``) and
    ``queue_capacity`` (frames, None: unbounded) make the sender :class:`TxQueue`.

    Examples
    --------
    A sensor task sends a sample every 10 ms (``ctx.send`` goes through the node's
    interface); the controller's network interrupt, a task released per delivered
    message, fetches it from its mailbox.  1000 bits at 1 Mbit/s take 1 ms:

    >>> from netcosim import Simulation
    >>> from netcosim.network import IdealLink
    >>> sim = Simulation(seed=0)
    >>> net = IdealLink(sim, "link", data_rate=1e6)
    >>> sensor, ctrl = sim.node("sensor"), sim.node("ctrl")
    >>> s_if, c_if = net.attach(sensor), net.attach(ctrl)
    >>> @sensor.periodic(period=0.01, priority=1)
    ... def sample(ctx):
    ...     ctx.send("ctrl", round(ctx.now, 6), size_bits=1000)
    ...     yield ctx.execute(1e-4)
    >>> log = []
    >>> @ctrl.aperiodic(priority=1)
    ... def on_message(ctx):
    ...     msg = yield c_if.mailbox.fetch()
    ...     log.append((msg.payload, round(ctx.now, 6)))        # (sent at, received at), s
    ...     yield ctx.execute(1e-4)
    >>> _ = c_if.on_receive(on_message)
    >>> sim.run(until=0.025)
    >>> log
    [(0.0, 0.001), (0.01, 0.011), (0.02, 0.021)]
    >>> s_if.stats["sent"], c_if.stats["received"], sensor.interfaces["link"] is s_if
    (3, 3, True)
    """

    def __init__(self, network, name: str, node, index: int, *, priority=None, mailbox: bool = True,
                 mailbox_capacity: int | None = None, queue: str = "fifo", queue_capacity: int | None = None):
        self.network = network
        self.name = name
        self.node = node
        self.index = index
        self.priority = priority
        self.mailbox = Mailbox(f"{network.name}/{name}", capacity=mailbox_capacity)
        self.use_mailbox = bool(mailbox)
        self.queue = TxQueue(queue, queue_capacity, what=f"network {network.name!r} node {name!r}")
        self.handlers: list = []
        self.on_done: list[Callable] = []
        self.current = None     # frame in service (being sent, backing off, awaiting ACK)
        self.attempt = Attempt(network, self)   # its life cycle, the MAC seam (lifecycle.py)
        self.sending = 0        # transmissions of this interface on the medium (0/1)
        self.receiving = 0      # frames addressed to this interface being received
        self.state = "idle"
        self._env = network._env
        # the trace rows of this interface (netcosim.network.tracing): the network schedule's
        # rows when traced (None: untraced), its stored code per state, the link code per
        # destination, and the codes of its fixed frames rows (set by _trace_codes)
        self._srows: Any = None
        self._tstate: dict[str, int] = {}
        self._tlinks: dict = {}
        self._tw_created = self._tw_queued = self._tw_start = self._tw_ok = self._tw_sent = self._tw_delivered = 0
        self._tw_sent_now = 0
        self._tw_joined: dict[int, int] = {}    # attempt_end code -> its code merged with a delivery here
        self._seq = 0
        self.mac: Any = None    # the MAC's per-station state (see Network._station)
        #: frames ``sent`` (or acknowledged) and ``dropped`` by this sender, messages ``received``
        self.stats = {"sent": 0, "dropped": 0, "received": 0}

    # ------------------------------------------------------------------ user API
    def send(self, dst, payload: Any = None, size_bits: int | None = None, *, priority=None):
        """Queue a message carrying *payload* (any Python object, delivered as is) to *dst*
        (node name, node, interface or ``BROADCAST``).

        ``size_bits``: message length in bits (the wire carries ``max(size_bits,
        min_frame_bits)`` plus the MAC's own overhead).  ``priority``: MAC priority
        (small = high; CAN identifier order), default ``self.priority``.
        Returns the :class:`~netcosim.network.frame.Message`.
        """
        return self.network._send(self, dst, payload, size_bits, priority)

    def on_receive(self, target=None):
        """Release *target* (a task or handler) or call ``target(msg)`` for every delivered message.

        A released task fetches the message from :attr:`mailbox` (``yield
        iface.mailbox.fetch()`` or ``iface.mailbox.try_fetch()``); a callable gets the
        message directly (it is posted to the mailbox as well when the interface has one,
        ``mailbox=True``, the default).  Usable as a decorator.
        """
        def reg(t):
            if not (isinstance(t, Task) or callable(t)):
                raise ConfigurationTypeError(f"on_receive target must be a task or a callable(msg), got {t!r}")
            self.handlers.append(t)
            return t
        return reg if target is None else reg(target)

    def receive(self):
        """The oldest message in the mailbox, or None (non-blocking)."""
        return self.mailbox.try_fetch()

    @property
    def pending(self) -> int:
        """Frames waiting or in service at this sender."""
        return len(self.queue) + (self.current is not None)

    # ------------------------------------------------------------------ internals
    def _state(self) -> None:
        """Recompute the network-schedule state and trace it if it changed."""
        if self.sending:
            s = "sending"
        elif self.current is not None or self.queue._q:
            s = "waiting"
        elif self.receiving:
            s = "receiving"
        else:
            s = "idle"
        if s != self.state:
            self.state = s
            rows = self._srows
            if rows is not None:
                # one row per node and instant: a state that lasts zero time is overwritten by
                # the table in the modes other than keep (Recorder.instant); keep mode appends
                # it, and reading keeps the instant's last state (tracing.collapse_instants)
                append = rows.append        # a slot read: cheaper than a method lookup on the Sink
                append((self._env.now, self._tstate[s]))

    def _trace_codes(self, names) -> None:
        """Take this interface's codes in the trace rows from *names* (a
        :class:`~netcosim.network.tracing.NetworkNames`)."""
        self._tstate = names.state_codes(self.network.name, self.name)
        w = names.row_codes(self.name)
        self._tw_created, self._tw_queued, self._tw_start = w["created"], w["queued"], w["attempt_start"]
        self._tw_ok, self._tw_sent, self._tw_delivered = w["ok"], w["sent"], w["delivered"]
        self._tw_sent_now = w["created+queued"]

    def __repr__(self) -> str:
        return f"<Interface {self.network.name}/{self.name}>"
