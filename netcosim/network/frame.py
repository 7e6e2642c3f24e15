"""Messages and frames.

A :class:`Message` is what a task sends and what the receiving node finds in its
mailbox.  A :class:`Frame` is the network's bookkeeping for one message on its way:
the bits on the wire, the attempts made, the interface it came from.  Times on a
``Message`` are in seconds; frames keep integer ticks (see :mod:`netcosim.timebase`).
"""

from __future__ import annotations

from typing import Any

from ..timebase import RESOLUTION


class _Broadcast:
    """The broadcast address: every other node attached to the network."""

    __slots__ = ()
    _instance = None

    def __new__(cls):
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "BROADCAST"

    def __reduce__(self):
        return (_Broadcast, ())


#: Destination meaning "every other node on the network" (no ACK, no retries on WLAN).
BROADCAST = _Broadcast()

#: Reasons a frame can be lost, as written in the ``outcome`` column of the frames trace.
LOSS_REASONS = (
    "collision",        # overlapping transmissions (SIR below the capture threshold)
    "below_threshold",  # received power below the receiver threshold
    "bit_errors",       # decoded with bit errors (BER from the SINR)
    "half_duplex",      # the receiver was transmitting itself
    "random_loss",      # drawn by the network's loss model
    "retry_limit",      # sender gave up after the maximum number of attempts
    "queue_overflow",   # sender queue (or switch memory) full
    "mailbox_full",     # receiver mailbox full at delivery
    "channel_access",   # 802.15.4: CSMA/CA found the channel busy too often
    "message_loss",     # silenced before medium access by the network's message_loss (never sent)
)


class Message:
    """One message as seen by sender and receiver.

    Attributes (times in seconds, ``nan``/``None`` until they happen):
    ``src`` and ``dst`` are node names (``dst`` may be :data:`BROADCAST`);
    ``payload`` is any Python object (the network never inspects it);
    ``size_bits`` the length the sender declared; ``priority`` the MAC priority
    (small = high, as on CAN); ``created`` when ``send`` was called; ``sent`` when
    the first bit of the (last) successful attempt went on the medium; ``delivered``
    when it reached the receiver's mailbox; ``attempts`` transmission attempts made.
    ``id``: the message's number on its network (1, 2, ... in send order), the ``id`` of the
    frames table; ``network``: the network's name.

    Examples
    --------
    ``send`` returns the message; the receiver gets the same object (a copy per receiver
    for a broadcast).  1000 bits at 1 Mbit/s plus a 0.5 ms delay:

    >>> from netcosim import Simulation
    >>> from netcosim.network import IdealLink
    >>> sim = Simulation(seed=0)
    >>> net = IdealLink(sim, "link", data_rate=1e6, delay=0.5e-3)
    >>> a, b = net.attach("a"), net.attach("b")
    >>> msg = a.send("b", {"y": 1.23}, size_bits=1000)
    >>> msg.id, msg.src, msg.dst, msg.payload, msg.size_bits, msg.created, msg.delivered
    (1, 'a', 'b', {'y': 1.23}, 1000, 0.0, nan)
    >>> sim.run(until=0.01)
    >>> b.receive() is msg
    True
    >>> msg.sent, round(msg.delivered * 1e3, 6), round(msg.latency * 1e3, 6), msg.attempts   # s, ms, ms
    (0.0, 1.5, 1.5, 1)
    """

    __slots__ = ("id", "network", "src", "dst", "payload", "size_bits", "priority", "created",
                 "sent", "delivered", "attempts")

    def __init__(self, id: int, network: str, src: str, dst: Any, payload: Any, size_bits: int,
                 priority: Any, created: float):
        self.id = id
        self.network = network
        self.src = src
        self.dst = dst
        self.payload = payload
        self.size_bits = size_bits
        self.priority = priority
        self.created = created
        self.sent = float("nan")
        self.delivered = float("nan")
        self.attempts = 0

    def copy(self) -> "Message":
        """An independent copy (same id and times): what each receiver of a broadcast gets."""
        m = Message(self.id, self.network, self.src, self.dst, self.payload, self.size_bits,
                    self.priority, self.created)
        m.sent, m.delivered, m.attempts = self.sent, self.delivered, self.attempts
        return m

    @property
    def latency(self) -> float:
        """End-to-end delay ``delivered - created`` in seconds."""
        return self.delivered - self.created

    def __repr__(self) -> str:
        return (f"<Message #{self.id} {self.src}->{self.dst} {self.size_bits} bit "
                f"created={self.created:.9f} delivered={self.delivered:.9f}>")


class Frame:
    """A message in transit (internal).  Times in ticks.

    ``msg``: the :class:`Message` it carries; ``src``: the sending interface; ``dst``: the
    receiving interface, or :data:`BROADCAST`; ``bits``: its length on the wire (after the
    minimum frame size and the MAC's overhead); ``priority``: its MAC priority (small =
    high); ``seq``: the sender's sequence number (duplicate detection); ``created``: the
    tick ``send`` was called."""

    __slots__ = ("msg", "id", "src", "dst", "dname", "bits", "priority", "seq", "attempts", "created",
                 "queued", "sent", "remaining", "holds", "lstats", "pend", "rx_now", "silenced", "tkey")

    def __init__(self, msg: Message, src, dst, bits: int, priority, seq: int, created: int):
        self.msg = msg
        self.id = msg.id
        self.src = src            # sending Interface
        self.dst = dst            # receiving Interface, or BROADCAST
        self.dname = "*" if dst is BROADCAST else dst.name
        self.bits = bits          # bits on the wire (after minimum size and overheads)
        self.priority = priority
        self.seq = seq            # per-sender sequence number (duplicate detection)
        self.attempts = 0
        self.created = created
        self.queued = None
        self.sent = None
        self.remaining: int | None = None  # ticks of transmission left (TDMA suspension)
        # message/frame loss bookkeeping (netcosim.network.stats):
        self.holds = 1            # who still works on it: the sender, pending hand-overs, switch copies
        self.lstats: dict = {}    # receiver index -> LinkStats, for the receivers the message goes to
        self.pend: set = set()    # receiver indices it was not yet delivered to
        self.rx_now: set = set()  # receiver indices that received the current attempt
        self.silenced: set | None = None  # receiver indices silenced by message_loss (None: none)
        self.tkey = 0             # its id, network, sender and destination in the frames rows (tracing.py)

    @property
    def broadcast(self) -> bool:
        """True for a frame addressed to every node (``dst`` is :data:`BROADCAST`)."""
        return self.dst is BROADCAST

    def __repr__(self) -> str:
        d = "*" if self.dst is BROADCAST else self.dst.name
        return f"<Frame #{self.id} {self.src.name}->{d} {self.bits} bit>"


def seconds(ticks: int) -> float:
    """Integer *ticks* as seconds (float)."""
    return ticks * RESOLUTION
