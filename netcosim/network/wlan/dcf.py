"""The 802.11 DCF rules applied station by station: the reference strategy.

:class:`PerStationAccess` decides when each station accesses the medium by updating every
station on every change of the medium it hears (the access rules are listed in
:mod:`netcosim.network.wlan.network`): carrier sense and NAV make the medium busy or idle
for the station, a busy medium freezes its backoff, an idle one (after DIFS/EIFS) lets it
count down; the network's access heap holds the instant each station transmits.  It also
applies the MAC's reception rules at the end of every frame a station hears (deliver,
answer, set the NAV, note EIFS).

The shared idle-slot clock (:class:`~netcosim.network.wlan.shared.SharedClockAccess`)
applies the same rules once for all the stations that see the same medium; the network
uses it while that holds and this strategy otherwise.
"""

from __future__ import annotations

from ..frame import BROADCAST
from ..wireless import RadioStation


class DcfStation(RadioStation):
    """A WLAN station: radio and ACK state (:class:`RadioStation`) plus the DCF state.

    Ticks: ``idle_start`` (medium idle since), ``count_start`` (backoff countdown
    starts), ``nav_end``, ``anchor`` (earliest immediate access: arrival + DIFS),
    ``access_at`` (pending channel access, -1 if none; ``acc_gen`` invalidates stale
    entries of the network's access heap).  ``mac_busy`` (medium busy as the DCF sees
    it), ``eifs`` (EIFS instead of DIFS), ``backoff`` (slots left, None: no backoff),
    ``immediate`` (access after DIFS without backoff), ``cw`` (contention window, slots).
    ``in_crowd``: the station is one of the shared idle-slot clock's stations
    (:mod:`netcosim.network.slotclock`); its listener and DCF fields are then held by the
    clock, and ``cseq``/``ckey`` are its entry in the clock's heap (``cseq`` -1: none).
    """

    __slots__ = ("mac_busy", "idle_start", "count_start", "nav_end", "eifs", "backoff", "immediate", "anchor",
                 "cw", "access_at", "acc_gen", "in_crowd", "cseq", "ckey")

    def __init__(self, net, iface, *radio):
        super().__init__(net, iface, *radio)
        self.mac_busy = False
        self.idle_start = net._env.now
        self.count_start = 0
        self.nav_end = 0
        self.eifs = False
        self.backoff = None
        self.immediate = False
        self.anchor = 0
        self.cw = net.cw_min
        self.access_at = -1
        self.acc_gen = 0
        self.in_crowd = False
        self.cseq = -1
        self.ckey = 0


class PerStationAccess:
    """The DCF rules station by station (see the module docstring) for the network *net*.

    ``air_start``/``air_end`` put a transmission on the air and take it off (here the
    medium's own, which updates every listener); ``reeval(r)`` and ``rx_end(r, tx, ok,
    reason, locked)`` are the medium's hooks (see :class:`~netcosim.network.medium.WirelessMedium`).
    """

    #: True for the shared idle-slot clock (stations may join its crowd)
    shared = False

    def __init__(self, net):
        self.net = net
        self.env = net._env
        self.slot = net.slot
        self.difs = net.difs
        self.eifs_time = net.eifs_time
        self.use_eifs = net.use_eifs
        self.air_start = net.medium.start
        self.air_end = net.medium.end

    def try_join(self, r) -> bool:
        """Hook of the shared clock: idle station *r* joins its crowd (True if it did)."""
        return False

    def reeval(self, r) -> None:
        """Re-evaluate station *r*'s (physical + virtual) medium state and act on changes."""
        if r.in_crowd:
            return              # joined the shared clock at this instant, nothing changed since
        now = self.env.now
        if r.audible or r.tx is not None or r.awaiting is not None or r.responding or r.nav_end > now:
            if not r.mac_busy:
                r.mac_busy = True
                self.on_busy(r, now)
        else:
            if r.mac_busy:
                r.mac_busy = False
                r.idle_start = now
            if self.shared and self.try_join(r):
                return              # the crowd counts its backoff down
            if r.access_at < 0 and r.backoff is not None:
                self.schedule(r)

    def on_busy(self, r, now) -> None:
        """The medium turned busy for *r*: EIFS may have expired; a pending access is frozen
        (the slots counted so far are taken off the backoff) unless it is now."""
        if r.eifs and now - r.idle_start >= self.eifs_time:
            r.eifs = False
        if r.access_at < 0:
            return
        if r.access_at == now:
            return          # the slot boundary is now: the transmission goes ahead (not sensed in time)
        r.access_at = -1
        if r.immediate:
            r.immediate = False
            self.net._draw(r)
        elif now > r.count_start:
            r.backoff -= (now - r.count_start) // self.slot

    def schedule(self, r) -> None:
        """The medium is idle for *r*, which has a backoff: its access instant into the heap."""
        cs = r.idle_start + (self.eifs_time if (r.eifs and self.use_eifs) else self.difs)
        if r.immediate and r.anchor > cs:
            cs = r.anchor
        r.count_start = cs
        self.net._push_access(r, cs + r.backoff * self.slot)

    def rx_end(self, r, tx, ok, reason, locked) -> None:
        """MAC processing of the end of *tx* at listener *r* (called by the medium), with the
        reception outcome of :func:`~netcosim.network.medium.reception_end`: ``ok`` (decoded),
        ``reason`` (why not, e.g. ``"collision"``; None when ok), ``locked`` (*r* was receiving
        *tx*, which sets EIFS on a failure)."""
        net = self.net
        f = tx.frame
        if tx.kind == "data":
            dst = tx.dst
            if ok:
                r.eifs = False
                if dst is r:
                    net._receive_unicast(r, tx, True)
                elif dst is BROADCAST:
                    tx.src.iface.attempt.deliver(r.iface)   # the sender's attempt is still on
                else:
                    net._set_nav(r, self.env.now + net.sifs + net.ack_time)
            else:
                if locked and self.use_eifs:
                    r.eifs = True
                if dst is r:
                    tx.dst_reason = reason
                elif dst is BROADCAST:
                    net._lost(f, r.iface, reason)
        else:  # ACK
            mine = tx.dst is r and r.awaiting is not None and r.awaiting.frame is f
            if ok:
                r.eifs = False
                if mine:
                    net._ack_ok(r)
                    return
            elif locked and self.use_eifs:
                r.eifs = True
        if r.ack_wait and r.awaiting is not None and r.rx is None:
            net._ack_fail(r)

