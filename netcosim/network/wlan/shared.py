"""The shared idle-slot clock as a strategy of the 802.11b network (see :mod:`netcosim.network.slotclock`).

:class:`SharedClockAccess` applies the DCF rules of :class:`~netcosim.network.wlan.dcf.PerStationAccess`
once to the *crowd* of stations that see the same medium, and one by one (the reference
rules) to the others: the stations sending, answering, waiting for an ACK or receiving a
frame addressed to them.  It puts transmissions on the air and takes them off itself
(:meth:`SharedClockAccess.fast_start`, :meth:`~SharedClockAccess.fast_end`).  Every
station hears every other one; where no frame can capture a receiver, a frame
overlapping another fails at every listener, and the stations outside the crowd take
the reduced steps :meth:`~SharedClockAccess.solo_start` and
:meth:`~SharedClockAccess.listener_end`.  Where capture is possible (``exact``), a
frame that starts while the crowd hears another first sends out of the crowd the members
whose own reception would differ (:meth:`~SharedClockAccess.evict`: the medium's tests
on each member's interference power, a vector kept with the medium's own float
operations), and the stations outside the crowd take the medium's per-listener code
(:meth:`~netcosim.network.medium.WirelessMedium.start_at`,
:meth:`~netcosim.network.medium.WirelessMedium.end_at`).  The reception outcome is
decided by :func:`~netcosim.network.medium.reception_end` as on the medium.  The
network uses this strategy while :class:`~netcosim.network.slotclock.Audibility` holds
and switches to the per-station strategy for good when a station out of range, moving,
or with bit errors possible on its own attaches.
"""

from __future__ import annotations

import bisect
import heapq

import numpy as np

from ..frame import BROADCAST
from ..medium import _TOL, Transmission, reception_end
from ..slotclock import Audibility, SharedSlotClock
from .dcf import PerStationAccess


class SharedClockAccess(PerStationAccess):
    """The shared idle-slot clock of the network *net* (see the module docstring).

    ``clock`` (the crowd's :class:`~netcosim.network.slotclock.SharedSlotClock`),
    ``solo`` (indices of the stations outside the crowd, sorted); while a transmission
    ends: ``end_pos`` (the station being processed), ``end_pre`` (the crowd's state
    before the end), ``end_heap`` (the stations still to do), ``end_mid`` (a crowd
    station delivering a broadcast frame, its own step).  ``exact``: capture is possible
    (see the module docstring); then ``pvec`` holds each member's received power (W, by
    station index; ``pvec_pre`` before the end being processed) and ``member`` marks the
    members.
    """

    shared = True

    def __init__(self, net):
        super().__init__(net)
        self.air_start = self.fast_start
        self.air_end = self.fast_end
        self.clock = SharedSlotClock(self.env.now, self.difs)
        self.audibility = Audibility()
        self.solo: list[int] = []
        self.end_pos = -1
        self.end_pre: tuple | None = None
        self.end_heap: list | None = None
        self.end_mid = None
        # capture possible (``exact``): each member's interference power (W, by station index,
        # the same float operations as the medium's per-listener ``power``), before the end
        # being processed (``pvec_pre``); which stations are members; power rows by sender
        self.exact = False
        self.pvec = np.zeros(0)
        self.pvec_pre = self.pvec
        self.member = np.zeros(0, dtype=bool)
        self.rows: dict[int, np.ndarray] = {}
        # members whose EIFS flag differs from the crowd's (index -> theirs): they joined
        # locked onto the crowd's frame, at whose end every member's flag is set alike
        self.eifs_own: dict[int, bool] = {}

    def attached(self, r) -> bool:
        """Station *r* attached: False if the crowd's conditions no longer hold (the caller
        then dissolves the crowd and goes on station by station)."""
        m = self.net.medium
        net = self.net
        if not self.audibility.add(r, net._stations, net.path_loss.gain, m.capture_ratio, _TOL, m.noise_w,
                                   (m.plcp_mod, net.data_mod, net.ack_mod)):
            return False
        stations: list = net._stations
        # attached between transmissions: no power on the air anywhere
        self.pvec = np.zeros(len(stations))
        self.member = np.array([s.in_crowd for s in stations], dtype=bool)
        self.rows.clear()
        self.exact = self.audibility.capture
        bisect.insort(self.solo, r.index)
        self.try_join(r)
        return True

    def row(self, src) -> np.ndarray:
        """The powers (W) a transmission by *src* brings to each station (by index)."""
        v = self.rows.get(src.index)
        if v is None:
            v = self.rows[src.index] = np.array(self.net.medium.powers_from(src))
        return v

    def evict(self, tx) -> None:
        """*tx* starts while the crowd hears another frame and capture is possible: the members
        whose own reception would differ from the crowd's (*tx* locked intact or capturing,
        the locked frame surviving) leave first, with the state they had (so does *tx*'s
        destination); the medium's per-listener code then takes *tx* at each of them.  The
        tests are the medium's, on the same floats (see ``pvec``)."""
        c = self.clock
        p = self.row(tx.src)
        pw = self.pvec + p
        cap = self.net.medium.capture_ratio * _TOL
        out = p >= cap * (pw - p)
        if c.rx is not None and c.rx_ok:
            pl = self.row(c.rx.src)
            out |= pl >= cap * (pw - pl)
        out &= self.member
        d = tx.dst
        if d is not BROADCAST and d.in_crowd:
            out[d.index] = True
        stations: list = self.net._stations
        for i in np.flatnonzero(out).tolist():
            self.leave(stations[i])

    def kick_member(self, r) -> bool:
        """Crowd member *r* got a frame to send: while the crowd is busy it draws its backoff
        in the crowd (True); otherwise it leaves the crowd (False: the network goes on)."""
        if self.clock.mac_busy and self.end_pre is None:
            self.net._draw(r)
            self.clock_key(r, r.backoff)
            return True
        self.leave(r)
        return False

    def dissolve(self) -> None:
        """Every station of the crowd gets its own state back (the network goes on station by
        station; nobody joins again, also in the rest of a transmission's end under way)."""
        self.shared = False
        stations: list = self.net._stations
        for r in stations:
            if r.in_crowd:
                self.leave(r)

    def clock_key(self, r, b) -> None:
        """Member *r* has *b* backoff slots left (the crowd is busy or *b* counts from ``C``)."""
        c = self.clock
        c.seq += 1
        r.cseq = c.seq
        r.ckey = c.S + b
        heapq.heappush(c.heap, (r.ckey, r.index, c.seq, r))

    def clock_schedule(self) -> None:
        """The crowd is idle: put its earliest member's access instant in the access heap."""
        c = self.clock
        h = c.heap
        while h and h[0][3].cseq != h[0][2]:
            heapq.heappop(h)
        if not h:
            c.access_at = -1
            return
        at = c.C + (h[0][0] - c.S) * self.slot
        if c.access_at >= 0 and c.access_at <= at:
            return
        c.access_at = at
        c.acc_gen -= 1
        heapq.heappush(self.net._acc, (at, h[0][1], c.acc_gen, c))
        if self.net._acc_timer_at < 0 or at < self.net._acc_timer_at:
            self.net._arm_access(at)

    def pop_due(self, now, push: bool) -> list:
        """Members whose access instant is *now* (ticks) leave the crowd (in station order) to
        transmit; with *push* each is also put in the network's access heap at *now*."""
        c = self.clock
        h = c.heap
        out = []
        while h:
            key, _, seq, r = h[0]
            if r.cseq != seq:
                heapq.heappop(h)
                continue
            if c.C + (key - c.S) * self.slot != now:
                break
            heapq.heappop(h)
            self.leave(r, due=now)
            if push:
                r.acc_gen += 1
                heapq.heappush(self.net._acc, (now, r.index, r.acc_gen, r))
            out.append(r)
        c.access_at = -1
        return out

    def clock_busy(self, now) -> None:
        """_on_busy for the crowd: EIFS expiry, members due now go ahead, the others freeze."""
        c = self.clock
        if c.eifs and now - c.idle_start >= self.eifs_time:
            c.eifs = False
        if c.access_at == now:
            self.pop_due(now, True)
        c.access_at = -1
        if now > c.C:
            c.S += (now - c.C) // self.slot

    def clock_reeval(self, now) -> None:
        """_reeval for the crowd, at tick *now*."""
        c = self.clock
        if c.audible or c.nav_end > now:
            if not c.mac_busy:
                c.mac_busy = True
                self.clock_busy(now)
        else:
            if c.mac_busy:
                c.mac_busy = False
                c.idle_start = now
                c.C = now + (self.eifs_time if (c.eifs and self.use_eifs) else self.difs)
            if c.access_at < 0:
                self.clock_schedule()

    def try_join(self, r) -> bool:
        """Idle station *r* joins the crowd if it sees the medium as the crowd does (True if it
        did).  Its countdown, scheduled or not yet, starts where the crowd's does: same idle
        instant and EIFS flag, no immediate access."""
        if (r.in_crowd or r.mac_busy or r.tx is not None or r.awaiting is not None or r.responding or r.immediate
                or r.ack_wait or r.rx is not None):
            return False
        c = self.clock
        if c.count:
            if c.mac_busy or c.idle_start != r.idle_start or c.eifs != r.eifs:
                return False
            if r.access_at >= 0 and r.count_start != c.C:
                return False
        else:                                   # the first member: the crowd takes its view
            self.eifs_own = {}
            c.mac_busy = False
            c.idle_start = r.idle_start
            c.eifs = r.eifs
            c.nav_end = r.nav_end
            c.rx = None
            c.audible = 0
            c.C = r.idle_start + (self.eifs_time if (r.eifs and self.use_eifs) else self.difs)
            c.access_at = -1
            c.acc_gen -= 1
            if r.access_at >= 0 and r.count_start != c.C:
                return False
        r.in_crowd = True
        c.count += 1
        del self.solo[bisect.bisect_left(self.solo, r.index)]
        self.member[r.index] = True
        self.pvec[r.index] = r.power
        if r.backoff is not None:
            r.access_at = -1
            self.clock_key(r, r.backoff)
            self.clock_schedule()
        return True

    def leave(self, r, due: int = -1) -> None:
        """Member *r* gets its own state back (as the crowd's; during the end of a transmission,
        as before it if the per-station path has not reached *r* yet).  ``due``: *r*
        transmits at that instant."""
        c = self.clock
        pre = self.end_pre
        ended = None
        pvec = self.pvec
        if pre is not None and r.index > self.end_pos:
            rx, rx_ok, rx_reason, audible, busy, idle_start, eifs, nav_end, ended, own = pre
            eifs = own.get(r.index, eifs)
            pvec = self.pvec_pre
            if self.end_mid is None:           # (a broadcast end visits every station anyway)
                heapq.heappush(self.end_heap, r.index)  # type: ignore[arg-type]  # set with end_pre
        elif r is self.end_mid:
            # half-way through its own step of a broadcast end: received, not yet re-evaluated
            rx, rx_ok, rx_reason, audible = c.rx, c.rx_ok, c.rx_reason, c.audible
            eifs, nav_end = self.eifs_own.get(self.end_pos, c.eifs), c.nav_end     # end_pos: r's index
            busy, idle_start = pre[4], pre[5]   # type: ignore[index]  # set with end_pre
        else:
            rx, rx_ok, rx_reason, audible = c.rx, c.rx_ok, c.rx_reason, c.audible
            busy, idle_start, nav_end = c.mac_busy, c.idle_start, c.nav_end
            eifs = self.eifs_own.get(r.index, c.eifs)
        self.eifs_own.pop(r.index, None)
        r.in_crowd = False
        c.count -= 1
        bisect.insort(self.solo, r.index)
        self.member[r.index] = False
        r.rx, r.rx_ok, r.rx_reason = rx, rx_ok, rx_reason
        r.audible = r.n_active = audible
        if self.exact:
            # a locked frame the crowd still decodes is alone on the air and error-free: no bit
            # error accounting so far, none until the next change of the medium
            r.power = float(pvec[r.index])
            r.seg_t = self.env.now
            r.logp = 0.0
        r.mac_busy, r.idle_start, r.eifs, r.nav_end = busy, idle_start, eifs, nav_end
        r.immediate = False
        if nav_end > self.env.now:
            self.net._nav[nav_end].append(r)
        for tx in self.net.medium.active:
            if tx.crowd_fail is not None:
                tx.fail[r.index] = tx.crowd_fail
        if ended is not None and ended.crowd_fail is not None:
            ended.fail[r.index] = ended.crowd_fail
        if r.cseq < 0:
            r.backoff = None
            return
        r.cseq = -1
        b = r.backoff = r.ckey - c.S
        if busy:
            r.access_at = -1
        elif due >= 0:
            r.count_start = c.C
            r.access_at = due
        else:
            r.count_start = c.C
            self.net._push_access(r, c.C + b * self.slot)

    def fast_start(self, tx: Transmission) -> None:
        """WirelessMedium.start of transmission *tx* when every station hears every other (see the module docstring of
        netcosim.network.slotclock): a frame that overlaps another fails at every listener."""
        m = self.net.medium
        now = self.env.now
        src = tx.src
        m.transmissions += 1
        m._stop_receiving(src)
        tx.powers = m.powers_from(src)
        c = self.clock
        dst = tx.dst
        bcast = dst is BROADCAST
        if c.count and not c.mac_busy and c.access_at == now:
            self.pop_due(now, True)
        exact = self.exact
        if exact and c.count and c.audible:
            self.evict(tx)
        active = m.active
        active.append(tx)
        first = len(active) == 1
        lock = False
        if c.count:
            if c.rx is None:
                lock = True
                c.rx = tx
                c.rx_ok = first
                c.rx_reason = None if first else "collision"
            else:
                tx.crowd_fail = "collision"
                if c.rx_ok:
                    c.rx_ok = False
                    c.rx_reason = "collision"
            c.audible += 1
            if not c.mac_busy:
                c.mac_busy = True
                self.clock_busy(now)
            if lock and not bcast and dst.in_crowd:    # a destination in the crowd: leaves at the end
                dst.iface.receiving = 1
                dst.iface._state()
            if exact:
                self.pvec = self.pvec + self.row(src)
        stations: list = self.net._stations
        if bcast and tx.kind == "data" and c.count:
            for r in stations:
                if r is src:
                    continue
                if r.in_crowd:
                    if lock:
                        r.iface.receiving = 1
                        r.iface._state()
                else:
                    if exact:
                        m.start_at(tx, (r,))
                    else:
                        self.solo_start(r, tx, first, now)
                    if r.rx is c.rx and r.access_at < 0 and r.tx is None:
                        self.try_join_busy(r, c, now)
        elif exact:
            # each station's start reads and writes only its own state: all of them, then the joins
            solo = [stations[i] for i in self.solo]
            m.start_at(tx, solo)
            for r in solo:
                if r.rx is c.rx and r.access_at < 0 and r.tx is None and c.count and r is not src:
                    self.try_join_busy(r, c, now)
        else:
            for i in tuple(self.solo):
                r = stations[i]
                if r is not src:
                    self.solo_start(r, tx, first, now)
                    # the start set r's state for this frame; no other station's processing changes it
                    if r.rx is c.rx and r.access_at < 0 and r.tx is None and c.count:
                        self.try_join_busy(r, c, now)

    def try_join_busy(self, r, c, now) -> None:
        """Busy station *r* joins the busy crowd *c* (at tick *now*) if it will see the medium as the crowd does:
        same locked frame and reception outcome, carrier sense, NAV and EIFS, and no frame on
        the air is addressed to it (while busy, the instant it went idle last does not matter;
        both freeze their backoff and count again from the same idle instant).  Its EIFS flag
        may differ while both are locked onto a frame: it is read only once the medium is idle,
        and the frame's end sets it alike for both; until then the crowd keeps it."""
        if (r.tx is not None or r.awaiting is not None or r.responding or r.immediate or r.ack_wait
                or r.access_at >= 0 or r.rx is not c.rx or r.rx_ok != c.rx_ok or r.rx_reason != c.rx_reason
                or r.audible != c.audible or (r.eifs != c.eifs and c.rx is None) or not c.mac_busy):
            return
        if r.nav_end != c.nav_end and (r.nav_end > now or c.nav_end > now):
            return
        if self.exact and (r.n_active != c.audible or (r.rx_ok and r.logp != 0.0)):
            return
        for tx in self.net.medium.active:
            if tx.dst is r or tx.fail.get(r.index) != tx.crowd_fail:
                return
        r.in_crowd = True
        c.count += 1
        del self.solo[bisect.bisect_left(self.solo, r.index)]
        self.member[r.index] = True
        self.pvec[r.index] = r.power
        if r.eifs != c.eifs:
            self.eifs_own[r.index] = r.eifs
        if r.backoff is not None:
            self.clock_key(r, r.backoff)

    def solo_start(self, r, tx, first, now) -> None:
        """*tx* starts at *r*, a station outside the crowd: it locks onto it (spoilt unless it is the
        *first* frame on the air) or, already receiving or sending, misses it (*now*: ticks)."""
        r.n_active += 1
        if r.tx is not None:
            tx.fail[r.index] = "half_duplex"
        elif r.rx is None:
            self.net.medium._lock(r, tx, now)
            if not first:
                r.rx_ok = False
                r.rx_reason = "collision"
        else:
            tx.fail[r.index] = "collision"
            if r.rx_ok:
                r.rx_ok = False
                r.rx_reason = "collision"
        r.audible += 1
        if r.audible == 1:
            self.reeval(r)

    def fast_end(self, tx: Transmission) -> None:
        """WirelessMedium.end of transmission *tx* when every station hears every other."""
        m = self.net.medium
        now = self.env.now
        m.active.remove(tx)
        src = tx.src
        c = self.clock
        crowd_bcast = tx.dst is BROADCAST and tx.kind == "data" and c.count
        if c.count:
            if self.exact:
                pv = self.pvec_pre = self.pvec
                self.pvec = pv - self.row(src) if c.audible > 1 else np.zeros(len(pv))
            self.end_pre = (c.rx, c.rx_ok, c.rx_reason, c.audible, c.mac_busy, c.idle_start, c.eifs, c.nav_end, tx,
                            self.eifs_own)
            d = tx.dst
            if d is not BROADCAST and d.in_crowd:
                self.end_heap = []
                self.leave(d)      # the destination answers or notes why it missed the frame: its own step
            ok, reason, locked = reception_end(c, tx)
            if locked:
                self.eifs_own = {}      # the members' flags are all set below
            c.audible -= 1
            if ok:
                c.eifs = False
                if tx.kind == "data" and not crowd_bcast:   # unicast to a station outside the crowd: NAV
                    self.net._set_nav(c, now + self.net.sifs + self.net.ack_time)
            elif locked and self.use_eifs:
                c.eifs = True
            self.clock_reeval(now)
        stations = self.net._stations
        if crowd_bcast:
            self.bcast_end(tx, src, ok, locked, reason)
            return
        heap = self.end_heap = [i for i in self.solo if i != src.index]
        try:
            if self.exact:
                m.end_at(tx, self.pending(heap, stations))
            while heap:
                i = heapq.heappop(heap)
                r = stations[i]
                if r.in_crowd:
                    continue
                self.end_pos = i
                self.listener_end(r, tx)
        finally:
            self.end_heap = None
            self.end_pre = None
            self.end_pos = -1

    def pending(self, heap: list, stations: list):
        """The stations outside the crowd still to take the end of a transmission, in index
        order, from *heap* (which grows when a member leaves meanwhile); ``end_pos`` follows."""
        while heap:
            i = heapq.heappop(heap)
            r = stations[i]
            if not r.in_crowd:
                self.end_pos = i
                yield r

    def listener_end(self, r, tx) -> None:
        """*tx* left the air at *r*, a station outside the crowd: its reception outcome,
        then its own DCF step."""
        if self.exact:
            self.net.medium.end_at(tx, (r,))
            return
        r.n_active -= 1
        ok, reason, locked = reception_end(r, tx)
        r.audible -= 1
        self.rx_end(r, tx, ok, reason, locked)
        self.reeval(r)

    def bcast_end(self, tx, src, c_ok, c_locked, c_reason) -> None:
        """End of a broadcast data frame *tx* from station *src* with a crowd (already updated:
        its outcome ``c_ok``, ``c_reason``, ``c_locked`` as of
        :func:`~netcosim.network.medium.reception_end`): every station in order delivers or
        loses it (the crowd's stations with the crowd's outcome), the
        others also do their own reception and DCF step."""
        stations: list = self.net._stations
        f = tx.frame
        self.end_heap = []
        try:
            for r in stations:
                if r is src:
                    continue
                self.end_pos = r.index
                if r.in_crowd:
                    if c_locked:
                        r.iface.receiving = 0
                        r.iface._state()
                    self.end_mid = r
                    if c_ok:
                        src.iface.attempt.deliver(r.iface)
                    else:
                        self.net._lost(f, r.iface, c_reason)
                    self.end_mid = None
                    if not r.in_crowd:          # it left (a callback made it send): its own re-evaluation
                        self.reeval(r)
                    continue
                self.listener_end(r, tx)
        finally:
            self.end_heap = None
            self.end_pre = None
            self.end_pos = -1
            self.end_mid = None

