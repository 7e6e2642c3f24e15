"""Message loss next to frame loss: per-link counters of every network.

Two losses, counted side by side for every directed link (sender -> receiver):

*frame loss*
    A transmission **attempt** that the receiver did not receive: it collided, was below
    the receiver's threshold, had bit errors, was dropped by the network's ``loss`` model,
    or never reached the receiver (refused or dropped by a switch).  An attempt whose
    data frame was received counts as received even if its ACK was lost.  A broadcast
    attempt is one attempt on the link to every receiver.
*message loss*
    A **message** (one ``send``, per receiver) that was never handed to the receiver's
    interface -- posted to its mailbox and given to its receive handlers -- after
    everything the MAC did about it: every retry failed (``retry_limit``), the sender
    queue or the switch overflowed, 802.15.4 found no clear channel, the receiver's
    mailbox was full, or ``message_loss`` silenced it before medium access.

With retries the two differ by orders of magnitude: frame loss ``p`` on 802.11b unicast
with 7 attempts is a message loss of ``p**7`` (0.8 % for ``p = 0.5``).

``network.stats`` returns ``{"links": {"src->dst": counters}, "total": counters}``,
``network.link_stats()`` the same as a DataFrame and :func:`loss_summary` flat totals
over every network of a simulation (scalars, ready to be returned as sweep metrics).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

#: Counters of a link (and of the totals), in the order of :meth:`LinkStats.as_dict`.
STATS_KEYS = ("messages_sent", "messages_delivered", "messages_lost", "messages_silenced", "messages_in_flight",
              "message_loss", "frame_attempts", "frames_lost", "frame_loss")


def _ratio(num: int, den: int) -> float:
    return num / den if den else math.nan


class LinkStats:
    """Counters of one directed link (sender ``src`` -> receiver ``dst``).

    ``sent``: messages sent on the link (a broadcast counts once per receiver attached
    when it was sent); ``delivered``: handed to the receiver's interface; ``lost``:
    message losses (never delivered, final); ``silenced``: of those, silenced by
    ``message_loss`` before medium access; ``attempts``: completed transmission attempts
    of the link's messages (an attempt counts once it is over: the next attempt started
    or the sender and the network are done with the frame); ``frames_lost``: of those,
    attempts the receiver did not receive.

    A network keeps one per directed link; ``network.stats["links"]["a->b"]`` is its
    :meth:`as_dict` (see :func:`loss_summary` for a run).

    Examples
    --------
    10 messages, 9 delivered and 1 lost after 14 attempts of which 5 were lost: a message
    loss of 1 / (9 + 1), a frame loss of 5 / 14:

    >>> from netcosim.network import LinkStats
    >>> link = LinkStats("a", "b")
    >>> link.sent, link.delivered, link.lost, link.attempts, link.frames_lost = 10, 9, 1, 14, 5
    >>> counters = link.as_dict()
    >>> counters["message_loss"], round(counters["frame_loss"], 6), counters["messages_in_flight"]
    (0.1, 0.357143, 0)
    """

    __slots__ = ("src", "dst", "sent", "delivered", "lost", "silenced", "attempts", "frames_lost")

    def __init__(self, src: str, dst: str):
        self.src, self.dst = src, dst
        self.sent = self.delivered = self.lost = self.silenced = 0
        self.attempts = self.frames_lost = 0

    def as_dict(self) -> dict:
        """The counters and ratios under the names of :data:`STATS_KEYS`."""
        return _counters(self.sent, self.delivered, self.lost, self.silenced, self.attempts, self.frames_lost)

    def __repr__(self) -> str:
        return (f"<LinkStats {self.src}->{self.dst} messages {self.delivered}/{self.sent} delivered, "
                f"{self.lost} lost; frames {self.frames_lost}/{self.attempts} lost>")


def _counters(sent: int, delivered: int, lost: int, silenced: int, attempts: int, frames_lost: int) -> dict:
    """Counters and ratios: ``message_loss`` = lost / (delivered + lost), the share of the
    messages whose fate is known (NaN before any); ``frame_loss`` = frames_lost / attempts."""
    return {"messages_sent": sent, "messages_delivered": delivered, "messages_lost": lost,
            "messages_silenced": silenced, "messages_in_flight": sent - delivered - lost,
            "message_loss": _ratio(lost, delivered + lost), "frame_attempts": attempts,
            "frames_lost": frames_lost, "frame_loss": _ratio(frames_lost, attempts)}


def total(links) -> dict:
    """Sum of the counters of *links* (an iterable of :class:`LinkStats`), with the ratios."""
    s = [0] * 6
    for ls in links:
        s[0] += ls.sent
        s[1] += ls.delivered
        s[2] += ls.lost
        s[3] += ls.silenced
        s[4] += ls.attempts
        s[5] += ls.frames_lost
    return _counters(*s)


def stats_frame(links) -> "pd.DataFrame":
    """One row per link of *links* (:class:`LinkStats` objects): ``src, dst`` and the
    :data:`STATS_KEYS` columns."""
    import pandas as pd

    rows = [{"src": ls.src, "dst": ls.dst, **ls.as_dict()} for ls in links]
    return pd.DataFrame(rows, columns=["src", "dst", *STATS_KEYS])


def loss_summary(sim, network=None) -> dict:
    """Message and frame loss over every network of *sim* (or only *network*, a name or a network).

    Flat scalars, e.g. to return from a sweep scenario next to its own metrics:
    ``message_loss`` (messages never delivered / messages whose fate is known),
    ``frame_loss`` (attempts not received / completed attempts), ``messages_sent``,
    ``messages_delivered``, ``messages_lost``, ``messages_silenced``,
    ``messages_in_flight``, ``frame_attempts``, ``frames_lost``.  A broadcast counts once
    per receiver.  See :mod:`netcosim.network.stats` for the definitions.

    A simulation without any network has no loss to summarise: it raises
    :class:`~netcosim.errors.ConfigurationError` saying so (rather than ratios of 0/0).
    The ratios are NaN only when networks exist but no message (frame) had a known fate.
    *sim* not a Simulation raises :class:`~netcosim.errors.ConfigurationTypeError`, an
    unknown *network* :class:`~netcosim.errors.ConfigurationError` naming it and the
    networks there are.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sim* is not a :class:`~netcosim.Simulation`.
    :class:`~netcosim.errors.ConfigurationError`
        *sim* has no network; *network* is not one of its networks.

    Examples
    --------
    A frame loss of 0.3 on 802.11b with at most 2 attempts per message: about 30 % of
    the attempts are lost, but a message only when both are, ``0.3**2 = 0.09``:

    >>> from netcosim import Simulation
    >>> from netcosim.network import WLAN80211b, loss_summary
    >>> sim = Simulation(seed=2)
    >>> net = WLAN80211b(sim, "wlan", loss=0.3, retry_limit=2)
    >>> a, b = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(5.0, 0.0))
    >>> for k in range(300):
    ...     _ = a.send("b", k, size_bits=1000)
    >>> sim.run(until=2.0)
    >>> summary = loss_summary(sim)
    >>> summary["messages_sent"], summary["messages_lost"], summary["frame_attempts"]
    (300, 27, 390)
    >>> round(summary["message_loss"], 6), round(summary["frame_loss"], 6)
    (0.09, 0.3)
    >>> loss_summary(Simulation())  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: loss_summary: the simulation has no network, so no message ...
    """
    from ..errors import ConfigurationError, ConfigurationTypeError
    networks = getattr(sim, "networks", None)
    if not isinstance(networks, dict):
        raise ConfigurationTypeError(f"loss_summary: sim must be a netcosim Simulation, got "
                                     f"{type(sim).__name__} {sim!r}")
    if not networks:
        raise ConfigurationError("loss_summary: the simulation has no network, so no message or frame loss to "
                                 "summarise (add a network, or leave the loss metrics out for this case)")
    if network is None:
        nets = list(networks.values())
    else:
        name = getattr(network, "name", network)
        if not isinstance(name, str) or name not in networks:
            raise ConfigurationError(f"loss_summary: no network {network!r} in the simulation; it has "
                                     f"{sorted(networks)}")
        nets = [networks[name]]
    return total(ls for net in nets for ls in net._lstats.values())
