"""IEEE 802.11b DCF (basic access) over the radio medium of :mod:`netcosim.network.medium`.

Faithful to IEEE Std 802.11 (DSSS/HR-DSSS PHY, clauses 9.3 DCF and 15/16 PHY); TrueTime
leaves out the ACK frames, SIFS and the PLCP, this model does not.

Constants (defaults; all configurable):

==================  ==========================================================
slot                20 µs (aSlotTime)
SIFS                10 µs
DIFS                SIFS + 2 slots = 50 µs
EIFS                SIFS + DIFS + ACK time at the lowest basic rate (1 Mbit/s)
                    = 364 µs with the long preamble
CW                  CWmin = 31, doubled (2 (CW + 1) - 1) per failure up to CWmax = 1023,
                    reset after success or drop; backoff drawn U{0..CW} slots
PLCP                preamble + header 192 µs (long) or 96 µs (short), before every frame
MAC overhead        24-byte header + 4-byte FCS = 224 bits per data frame
ACK                 14 bytes (112 bits) + PLCP, at the highest basic rate <= data rate
                    (basic rates 1 and 2 Mbit/s), sent SIFS after the data frame
ACK timeout         SIFS + slot + PLCP (aSIFSTime + aSlotTime + aPHY-RX-START-Delay)
retry limit         7 transmission attempts in all (dot11ShortRetryLimit), then the frame is
                    dropped: a frame loss p gives a unicast message loss p**7
max MSDU            2312 bytes
==================  ==========================================================

Access rules implemented (per station):

* A frame arriving with no backoff in progress and the medium idle is sent after the
  medium has stayed idle for DIFS (EIFS after an erroneous reception) counted from its
  arrival; if the medium is busy at arrival, or turns busy during that DIFS, the station
  defers and draws a backoff.
* Backoff: once the medium has been idle for DIFS/EIFS the counter decreases by one per
  idle slot; it is frozen while the medium is busy (physical carrier sense, NAV, own
  transmission, waiting for an ACK, answering with an ACK) and the countdown resumes
  after the next DIFS/EIFS.  The station transmits when the counter reaches 0.  Stations
  whose counters expire at the same slot boundary transmit together (collision): a
  transmission starting at the very instant another one starts is not sensed.
  Countdowns are computed from the idle periods, not simulated slot by slot.
* After every transmission (success or drop) the station runs a *post-backoff* with the
  reset window, even if it has nothing else to send.
* Unicast: the receiver answers a correctly decoded frame with an ACK after SIFS,
  regardless of the medium.  The sender waits for the ACK timeout; if a reception began
  before the timeout it waits for its end; a missing or corrupted ACK is a failed
  attempt (CW doubled, retry).  Duplicates (lost ACK) are acknowledged but delivered
  once.  Stations that decode a unicast frame addressed to someone else set their NAV
  to cover SIFS + ACK.  After the ACK timeout the station defers DIFS before counting
  down again (the convention of ns-3).
* Broadcast frames are never acknowledged or retried.
* EIFS (``eifs=True``) replaces DIFS after a frame was received with errors, until a
  frame is received correctly or an EIFS-long idle period has elapsed.

Data rate: any positive number (the thesis uses 1.2 Mbit/s); :data:`RATES` lists the
802.11b rates.  The radio side (positions, powers, thresholds, capture, BER) is described
in :mod:`netcosim.network.medium` and :mod:`netcosim.network.radio`.

Simplifications: no RTS/CTS, no fragmentation, no rate adaptation, the short-preamble
PLCP header is treated like the long one (DBPSK at 1 Mbit/s) for bit errors, and
``propagation_delay`` only delays delivery (MAC timing sees zero propagation, as
Bianchi's model with delta = 0).
"""

from __future__ import annotations

import bisect
import heapq
import math

from ... import validate
from ...errors import ConfigurationError, ConfigurationTypeError
from ...timebase import TICKS_PER_SECOND, to_ticks
from ..frame import BROADCAST
from ..medium import _TOL, Transmission
from ..radio import DSSS_BANDWIDTH, PathLoss, modulation_for, thermal_noise_dbm
from ..slotclock import Audibility, SharedSlotClock
from ..wireless import RadioNetwork, RadioStation

#: 802.11b data rates (bit/s).
RATES = (1e6, 2e6, 5.5e6, 11e6)
#: 802.11b basic rate set commonly configured (bit/s).
BASIC_RATES = (1e6, 2e6)


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


def _index(r) -> int:
    return r.index


class WLAN80211b(RadioNetwork):
    """IEEE 802.11b DCF network.  See the module docstring for the semantics.

    Parameters (besides those of :class:`~netcosim.network.base.Network`)
    ----------------------------------------------------------------------
    data_rate:
        Data rate in bit/s (default 11 Mbit/s; any positive value).
    preamble:
        ``"long"`` (192 µs PLCP) or ``"short"`` (96 µs).
    retry_limit:
        Maximum transmission *attempts* of a unicast frame, the first one included
        (default 7, dot11ShortRetryLimit): the frame is dropped (``lost`` with outcome
        ``retry_limit``) when its attempt number ``retry_limit`` fails, so
        ``retry_limit=1`` means no retransmission.  A frame ``loss`` p then gives a
        message loss of ``p**retry_limit`` if nothing else fails an attempt.  A retry
        limit that counts retransmissions after the first attempt (TrueTime's reading
        of its default 5, message loss ``p**6``) is ``retry_limit=6`` here.  For a loss
        of whole messages, TrueTime's wireless loss, pass ``message_loss=p`` instead: the
        message is silenced before medium access, never retried, message loss ``p``
        (see :class:`~netcosim.network.base.Network`); ``stats`` counts both.  Broadcast
        frames (destination :data:`~netcosim.network.BROADCAST`; the trace writes it
        ``*``, which is not an address) are sent once, never acknowledged.
    eifs:
        Use EIFS after erroneous receptions (default True, as the standard).
    ack_timeout:
        Seconds from the end of a data frame until the ACK must have begun
        (default SIFS + slot + PLCP).
    basic_rates:
        Rates (bit/s) usable for ACKs; the ACK uses the highest one <= the data rate
        (or the data rate if it is below all of them).
    slot, sifs, cw_min, cw_max, mac_overhead_bits, ack_bits:
        MAC constants (see the table above): ``slot``, ``sifs`` in seconds (> 0, at
        least 1 ps), ``cw_min <= cw_max`` integer slot counts, ``mac_overhead_bits``
        an integer >= 0, ``ack_bits`` an integer > 0.
    path_loss:
        A :class:`~netcosim.network.radio.PathLoss` (default log-distance, exponent 3).
    tx_power_dbm:
        Default transmit power (dBm; default 15 dBm).
    threshold_dbm:
        Receiver threshold: decoding sensitivity and carrier-sense threshold (default
        -85 dBm); ``cs_threshold_dbm`` sets carrier sense separately.
    capture_db:
        Capture threshold (dB, finite, >= 0): the signal-to-interference ratio a frame
        needs to survive / to capture a receiver (default 10 dB).
    noise_dbm:
        Noise floor (dBm, finite; default thermal noise in 22 MHz at 290 K, -100.6 dBm).

    Every parameter is validated here (:mod:`netcosim.network.checks`); powers and
    thresholds must be finite numbers of dBm, also when given per node to ``attach``.
    modulation:
        ``"auto"`` (by rate), ``"dbpsk"``, ``"dqpsk"``, ``"cck"``.
    shared_clock:
        True (default): while every station hears every other one and no capture or bit
        error is possible (decided at each ``attach`` from positions, powers and
        thresholds, see :mod:`netcosim.network.slotclock`), the stations not taking part
        in the current exchange share one idle-slot clock, so a frame costs about the same
        whatever the number of stations.  The results are identical bit for bit to
        False, which updates every station on every medium change.
    """

    station_class = DcfStation

    def __init__(self, sim, name, *, data_rate: float = 11e6, preamble: str = "long", retry_limit: int = 7,
                 eifs: bool = True, ack_timeout: float | None = None, basic_rates=BASIC_RATES,
                 slot: float = 20e-6, sifs: float = 10e-6, cw_min: int = 31, cw_max: int = 1023,
                 mac_overhead_bits: int = 224, ack_bits: int = 112, max_frame_bits: int | None = 2312 * 8,
                 path_loss: PathLoss | None = None, tx_power_dbm: float = 15.0, threshold_dbm: float = -85.0,
                 cs_threshold_dbm: float | None = None, capture_db: float = 10.0, noise_dbm: float | None = None,
                 modulation: str = "auto", shared_clock: bool = True, **kw):
        super().__init__(sim, name, data_rate=data_rate, max_frame_bits=max_frame_bits, path_loss=path_loss,
                         tx_power_dbm=tx_power_dbm, threshold_dbm=threshold_dbm, cs_threshold_dbm=cs_threshold_dbm,
                         capture_db=capture_db, noise_dbm=noise_dbm, **kw)
        w = f"network {name!r}"
        validate.choice(preamble, f"{w}: preamble", ("long", "short"))
        self.preamble = preamble
        self.retry_limit = validate.count(retry_limit, f"{w}: retry_limit (attempts)", minimum=1)
        self.cw_min = validate.count(cw_min, f"{w}: cw_min (slots)", minimum=0)
        self.cw_max = validate.count(cw_max, f"{w}: cw_max (slots)", minimum=0)
        if self.cw_max < self.cw_min:
            raise ConfigurationError(f"{w}: cw_max={cw_max!r} is below cw_min={cw_min!r}")
        self.slot = validate.duration(slot, f"{w}: slot (s)", positive=True)
        self.sifs = validate.duration(sifs, f"{w}: sifs (s)", positive=True)
        self.difs = self.sifs + 2 * self.slot
        self.plcp = to_ticks(192e-6 if preamble == "long" else 96e-6)
        self.mac_overhead_bits = validate.bits(mac_overhead_bits, f"{w}: mac_overhead_bits")
        self.ack_bits = validate.bits(ack_bits, f"{w}: ack_bits", allow_zero=False)
        if isinstance(basic_rates, (str, bytes)) or not hasattr(basic_rates, "__iter__"):
            raise ConfigurationTypeError(f"{w}: basic_rates must be a sequence of rates (bit/s), got {basic_rates!r}")
        rates = sorted(validate.positive(r, f"{w}: basic rate (bit/s)") for r in basic_rates)
        if not rates:
            raise ConfigurationError(f"{w}: basic_rates must not be empty, got {basic_rates!r}")
        self.basic_rates = tuple(rates)
        usable = [r for r in rates if r <= self.data_rate]
        self.ack_rate = usable[-1] if usable else self.data_rate
        self.ack_time = self.plcp + self.duration(self.ack_bits, self.ack_rate)
        self.eifs_time = self.sifs + self.difs + self.plcp + self.duration(self.ack_bits, rates[0])
        self.use_eifs = bool(eifs)
        if ack_timeout is None:
            self.ack_timeout = self.sifs + self.slot + self.plcp
        else:
            self.ack_timeout = validate.duration(ack_timeout, f"{w}: ack_timeout (s)", positive=True)
            if self.ack_timeout <= self.sifs:
                raise ConfigurationError(f"{w}: ack_timeout={ack_timeout!r} s must exceed SIFS "
                                         f"({self.sifs * 1e-12} s)")
        self.data_mod = modulation_for(self.data_rate, modulation)
        self.ack_mod = self._ack_mod = modulation_for(self.ack_rate, "auto")
        self.use_ack = True
        self.max_attempts = self.retry_limit
        self._ack_timeout_ticks = self.ack_timeout
        self._ack_plcp = self.plcp
        self._ack_delay = self.sifs
        # Access instants of all stations in one heap, one SimPy timer at the earliest:
        # entries (tick, station index, generation, station); stale entries are skipped.
        self._acc: list = []
        self._acc_timer = None
        self._acc_timer_at = -1
        # NAV expiries: tick -> stations to re-evaluate then (one timer per instant)
        self._nav: dict = {}
        # the shared idle-slot clock (see netcosim.network.slotclock)
        if not isinstance(shared_clock, bool):
            raise ConfigurationTypeError(f"{w}: shared_clock must be True or False, got {shared_clock!r}")
        self.shared_clock = shared_clock
        self._clock = SharedSlotClock(self._env.now, self.difs)
        self._audibility = Audibility()
        self._solo: list[int] = []          # indices of the stations outside the crowd, sorted
        self._end_pos = -1                  # while a transmission ends: the station being processed,
        self._end_pre: tuple | None = None  # the crowd's state before the end, and the stations still to do
        self._end_heap: list | None = None
        self._end_mid = None                # a crowd station delivering a broadcast frame (its own step)
        self._fast = shared_clock
        if shared_clock:
            self._air_start = self._fast_start
            self._air_end = self._fast_end

    def default_noise_dbm(self) -> float:
        """Thermal noise in the 22 MHz DSSS channel at 290 K (dBm)."""
        return thermal_noise_dbm(DSSS_BANDWIDTH)

    # ------------------------------------------------------------------ timing helpers
    def data_time(self, size_bits: int) -> int:
        """Time on air (ticks) of a data frame carrying *size_bits* bits (PLCP + MAC header/FCS +
        payload)."""
        return self.plcp + self.duration(self.mac_overhead_bits + self.wire_bits(size_bits))

    # ------------------------------------------------------------------ DCF (r: the DcfStation)
    def _busy_now(self, r) -> bool:
        return bool(r.audible or r.tx is not None or r.awaiting is not None or r.responding
                    or r.nav_end > self._env.now)

    def _reeval(self, r) -> None:
        """Re-evaluate the station's (physical + virtual) medium state and act on changes."""
        if r.in_crowd:
            return              # joined the shared clock at this instant, nothing changed since
        now = self._env.now
        if r.audible or r.tx is not None or r.awaiting is not None or r.responding or r.nav_end > now:
            if not r.mac_busy:
                r.mac_busy = True
                self._on_busy(r, now)
        else:
            if r.mac_busy:
                r.mac_busy = False
                r.idle_start = now
            if self._fast and self._try_join(r):
                return              # the crowd counts its backoff down
            if r.access_at < 0 and r.backoff is not None:
                self._schedule_access(r)

    def _on_busy(self, r, now) -> None:
        if r.eifs and now - r.idle_start >= self.eifs_time:
            r.eifs = False
        if r.access_at < 0:
            return
        if r.access_at == now:
            return          # the slot boundary is now: the transmission goes ahead (not sensed in time)
        r.access_at = -1
        if r.immediate:
            r.immediate = False
            self._draw(r)
        elif now > r.count_start:
            r.backoff -= (now - r.count_start) // self.slot

    def _schedule_access(self, r) -> None:
        cs = r.idle_start + (self.eifs_time if (r.eifs and self.use_eifs) else self.difs)
        if r.immediate and r.anchor > cs:
            cs = r.anchor
        r.count_start = cs
        at = cs + r.backoff * self.slot
        r.access_at = at
        r.acc_gen += 1
        heapq.heappush(self._acc, (at, r.index, r.acc_gen, r))
        if self._acc_timer_at < 0 or at < self._acc_timer_at:
            self._arm_access(at)

    def _arm_access(self, at) -> None:
        if self._acc_timer is not None:
            self._acc_timer.cancel()
        self._acc_timer_at = at
        self._acc_timer = self.sim.call_at_ticks(at, self._access_due)

    def _access_due(self) -> None:
        """Every station whose access instant is now transmits (in station order)."""
        now = self._env.now
        self._acc_timer = None
        self._acc_timer_at = -1
        acc = self._acc
        due = []
        clock = self._clock
        while acc and acc[0][0] <= now:
            at, _, gen, r = heapq.heappop(acc)
            if r.acc_gen == gen and r.access_at == at:
                if r is clock:
                    due.extend(self._pop_due(now, False))
                else:
                    due.append(r)
        if self._fast:
            due.sort(key=_index)
        for r in due:
            if r.access_at == now:
                self._access(r)
        if self._fast:
            for r in due:
                if r.tx is None and not r.mac_busy:
                    self._try_join(r)       # post-backoff over, nothing to send
            if not clock.mac_busy and clock.access_at < 0:
                self._clock_schedule()
        while acc and not (acc[0][3].acc_gen == acc[0][2] and acc[0][3].access_at == acc[0][0]):
            heapq.heappop(acc)
        if acc and (self._acc_timer_at < 0 or acc[0][0] < self._acc_timer_at):
            self._arm_access(acc[0][0])

    def _draw(self, r) -> None:
        b = int(r.rng.integers(0, r.cw + 1))
        r.backoff = b
        r.bo_drawn = b

    def _kick(self, iface) -> None:
        r = iface.mac
        if iface.current is not None or r.backoff is not None:
            return
        if r.in_crowd:
            c = self._clock
            if c.mac_busy and self._end_pre is None:
                self._draw(r)
                self._clock_key(r, r.backoff)
                return
            self._leave(r)
        if r.mac_busy:
            self._draw(r)
        else:
            r.backoff = 0
            r.immediate = True
            r.anchor = self._env.now + self.difs
            r.bo_drawn = math.nan
        self._reeval(r)

    def _access(self, r) -> None:
        r.access_at = -1
        r.backoff = None
        r.immediate = False
        r.eifs = False
        iface = r.iface
        f = iface.current
        if f is None:
            f = self._next_frame(iface)
            if f is None:
                return              # post-backoff finished, nothing to send
        bits = self.mac_overhead_bits + f.bits
        self._attempt_start(iface, f, bits, r.bo_drawn)
        r.bo_drawn = math.nan
        now = self._env.now
        tx = Transmission(r, "data", f, f.dst if f.dst is BROADCAST else f.dst.mac, now,
                          now + self.plcp + self.duration(bits), now + self.plcp, self.data_mod)
        self._start_tx(r, tx)

    def _start_tx(self, r, tx) -> None:
        r.mac_busy = True
        super()._start_tx(r, tx)

    def _frame_done(self, r, f, ok: bool) -> None:
        r.cw = self.cw_min
        self._draw(r)                 # post-backoff, drawn before the sender hears it is free
        self._done(r.iface, f, ok, restart=False)

    def _retry(self, r) -> None:
        r.cw = min(2 * (r.cw + 1) - 1, self.cw_max)
        self._draw(r)

    def _rx_end(self, r, tx, ok, reason, locked) -> None:
        """MAC processing of the end of *tx* at listener *r* (called by the medium)."""
        f = tx.frame
        if tx.kind == "data":
            dst = tx.dst
            if ok:
                r.eifs = False
                if dst is r:
                    self._receive_unicast(r, tx, True)
                elif dst is BROADCAST:
                    self._deliver(f, r.iface)
                else:
                    nav = self._env.now + self.sifs + self.ack_time
                    if nav > r.nav_end:
                        r.nav_end = nav
                        waiting = self._nav.get(nav)
                        if waiting is None:
                            waiting = self._nav[nav] = []
                            self.sim.call_at_ticks(nav, self._nav_due, arg=nav)
                        waiting.append(r)
            else:
                if locked and self.use_eifs:
                    r.eifs = True
                if dst is r:
                    tx.dst_reason = reason
                elif dst is BROADCAST:
                    self._lost(f, r.iface, reason)
        else:  # ACK
            mine = tx.dst is r and r.awaiting is not None and r.awaiting.frame is f
            if ok:
                r.eifs = False
                if mine:
                    self._ack_ok(r)
                    return
            elif locked and self.use_eifs:
                r.eifs = True
        if r.ack_wait and r.awaiting is not None and r.rx is None:
            self._ack_fail(r)

    def _nav_due(self, nav) -> None:
        clock = self._clock
        for r in self._nav.pop(nav):
            if r is clock:
                if clock.count:
                    self._clock_reeval(self._env.now)
            elif not r.in_crowd:
                self._reeval(r)

    def _station(self, iface, options):
        r = super()._station(iface, options)
        if self._fast:
            m = self.medium
            if self._audibility.add(r, self._stations, self.path_loss.gain, m.capture_ratio, _TOL, m.noise_w,
                                    (m.plcp_mod, self.data_mod, self.ack_mod)):
                bisect.insort(self._solo, r.index)
                self._try_join(r)
            else:
                self._per_station()
        return r

    # ------------------------------------------------------------------ shared idle-slot clock
    # (netcosim.network.slotclock): the same DCF and reception rules as above, applied once to
    # the crowd of stations that see the same medium, and one by one to the others.
    def _per_station(self) -> None:
        """Leave the shared clock for good (a station out of range or able to capture attached):
        every station gets its own state back."""
        self._dissolve()
        self._fast = False
        self._air_start = self.medium.start
        self._air_end = self.medium.end

    def _dissolve(self) -> None:
        stations: list = self._stations
        for r in stations:
            if r.in_crowd:
                self._leave(r)

    def _clock_key(self, r, b) -> None:
        """Member *r* has *b* backoff slots left (the crowd is busy or *b* counts from ``C``)."""
        c = self._clock
        c.seq += 1
        r.cseq = c.seq
        r.ckey = c.S + b
        heapq.heappush(c.heap, (r.ckey, r.index, c.seq, r))

    def _clock_schedule(self) -> None:
        """The crowd is idle: put its earliest member's access instant in the access heap."""
        c = self._clock
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
        heapq.heappush(self._acc, (at, h[0][1], c.acc_gen, c))
        if self._acc_timer_at < 0 or at < self._acc_timer_at:
            self._arm_access(at)

    def _pop_due(self, now, push: bool) -> list:
        """Members whose access instant is now leave the crowd (in station order) to transmit."""
        c = self._clock
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
            self._leave(r, due=now)
            if push:
                r.acc_gen += 1
                heapq.heappush(self._acc, (now, r.index, r.acc_gen, r))
            out.append(r)
        c.access_at = -1
        return out

    def _clock_busy(self, now) -> None:
        """_on_busy for the crowd: EIFS expiry, members due now go ahead, the others freeze."""
        c = self._clock
        if c.eifs and now - c.idle_start >= self.eifs_time:
            c.eifs = False
        if c.access_at == now:
            self._pop_due(now, True)
        c.access_at = -1
        if now > c.C:
            c.S += (now - c.C) // self.slot

    def _clock_reeval(self, now) -> None:
        """_reeval for the crowd."""
        c = self._clock
        if c.audible or c.nav_end > now:
            if not c.mac_busy:
                c.mac_busy = True
                self._clock_busy(now)
        else:
            if c.mac_busy:
                c.mac_busy = False
                c.idle_start = now
                c.C = now + (self.eifs_time if (c.eifs and self.use_eifs) else self.difs)
            if c.access_at < 0:
                self._clock_schedule()

    def _try_join(self, r) -> bool:
        """Idle station *r* joins the crowd if it sees the medium as the crowd does (True if it
        did).  Its countdown, scheduled or not yet, starts where the crowd's does: same idle
        instant and EIFS flag, no immediate access."""
        if (r.in_crowd or r.mac_busy or r.tx is not None or r.awaiting is not None or r.responding or r.immediate
                or r.ack_wait or r.rx is not None):
            return False
        c = self._clock
        if c.count:
            if c.mac_busy or c.idle_start != r.idle_start or c.eifs != r.eifs:
                return False
            if r.access_at >= 0 and r.count_start != c.C:
                return False
        else:                                   # the first member: the crowd takes its view
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
        del self._solo[bisect.bisect_left(self._solo, r.index)]
        if r.backoff is not None:
            r.access_at = -1
            self._clock_key(r, r.backoff)
            self._clock_schedule()
        return True

    def _leave(self, r, due: int = -1) -> None:
        """Member *r* gets its own state back (as the crowd's; during the end of a transmission,
        as before it if the per-station path has not reached *r* yet).  ``due``: *r*
        transmits at that instant."""
        c = self._clock
        pre = self._end_pre
        ended = None
        if pre is not None and r.index > self._end_pos:
            rx, rx_ok, rx_reason, audible, busy, idle_start, eifs, nav_end, ended = pre
            if self._end_mid is None:           # (a broadcast end visits every station anyway)
                heapq.heappush(self._end_heap, r.index)  # type: ignore[arg-type]  # set with _end_pre
        elif r is self._end_mid:
            # half-way through its own step of a broadcast end: received, not yet re-evaluated
            rx, rx_ok, rx_reason, audible = c.rx, c.rx_ok, c.rx_reason, c.audible
            eifs, nav_end = c.eifs, c.nav_end
            busy, idle_start = pre[4], pre[5]   # type: ignore[index]  # set with _end_pre
        else:
            rx, rx_ok, rx_reason, audible = c.rx, c.rx_ok, c.rx_reason, c.audible
            busy, idle_start, eifs, nav_end = c.mac_busy, c.idle_start, c.eifs, c.nav_end
        r.in_crowd = False
        c.count -= 1
        bisect.insort(self._solo, r.index)
        r.rx, r.rx_ok, r.rx_reason = rx, rx_ok, rx_reason
        r.audible = r.n_active = audible
        r.mac_busy, r.idle_start, r.eifs, r.nav_end = busy, idle_start, eifs, nav_end
        r.immediate = False
        if nav_end > self._env.now:
            self._nav[nav_end].append(r)
        for tx in self.medium.active:
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
            at = r.access_at = c.C + b * self.slot
            r.acc_gen += 1
            heapq.heappush(self._acc, (at, r.index, r.acc_gen, r))
            if self._acc_timer_at < 0 or at < self._acc_timer_at:
                self._arm_access(at)

    def _fast_start(self, tx: Transmission) -> None:
        """WirelessMedium.start when every station hears every other (see the module docstring of
        netcosim.network.slotclock): a frame that overlaps another fails at every listener."""
        m = self.medium
        now = self._env.now
        src = tx.src
        m.transmissions += 1
        m._stop_receiving(src)
        c = self._clock
        dst = tx.dst
        bcast = dst is BROADCAST
        if c.count and not c.mac_busy and c.access_at == now:
            self._pop_due(now, True)
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
                self._clock_busy(now)
            if lock and not bcast and dst.in_crowd:    # a destination in the crowd: leaves at the end
                dst.iface.receiving = 1
                dst.iface._state()
        stations: list = self._stations
        if bcast and tx.kind == "data" and c.count:
            for r in stations:
                if r is src:
                    continue
                if r.in_crowd:
                    if lock:
                        r.iface.receiving = 1
                        r.iface._state()
                else:
                    self._solo_start(r, tx, first, now)
                    if r.rx is c.rx and r.access_at < 0 and r.tx is None:
                        self._try_join_busy(r, c, now)
        else:
            for i in tuple(self._solo):
                r = stations[i]
                if r is not src:
                    self._solo_start(r, tx, first, now)
                    # the start set r's state for this frame; no other station's processing changes it
                    if r.rx is c.rx and r.access_at < 0 and r.tx is None and c.count:
                        self._try_join_busy(r, c, now)

    def _try_join_busy(self, r, c, now) -> None:
        """Busy station *r* joins the busy crowd if it will see the medium as the crowd does:
        same locked frame and reception outcome, carrier sense, NAV and EIFS, and no frame on
        the air is addressed to it (while busy, the instant it went idle last does not matter;
        both freeze their backoff and count again from the same idle instant)."""
        if (r.tx is not None or r.awaiting is not None or r.responding or r.immediate or r.ack_wait
                or r.access_at >= 0 or r.rx is not c.rx or r.rx_ok != c.rx_ok or r.rx_reason != c.rx_reason
                or r.audible != c.audible or r.eifs != c.eifs or not c.mac_busy):
            return
        if r.nav_end != c.nav_end and (r.nav_end > now or c.nav_end > now):
            return
        for tx in self.medium.active:
            if tx.dst is r or tx.fail.get(r.index) != tx.crowd_fail:
                return
        r.in_crowd = True
        c.count += 1
        del self._solo[bisect.bisect_left(self._solo, r.index)]
        if r.backoff is not None:
            self._clock_key(r, r.backoff)

    def _solo_start(self, r, tx, first, now) -> None:
        r.n_active += 1
        if r.tx is not None:
            tx.fail[r.index] = "half_duplex"
        elif r.rx is None:
            self.medium._lock(r, tx, now)
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
            self._reeval(r)

    def _fast_end(self, tx: Transmission) -> None:
        """WirelessMedium.end when every station hears every other."""
        m = self.medium
        now = self._env.now
        m.active.remove(tx)
        src = tx.src
        c = self._clock
        crowd_bcast = tx.dst is BROADCAST and tx.kind == "data" and c.count
        if c.count:
            self._end_pre = (c.rx, c.rx_ok, c.rx_reason, c.audible, c.mac_busy, c.idle_start, c.eifs, c.nav_end, tx)
            d = tx.dst
            if d is not BROADCAST and d.in_crowd:
                self._end_heap = []
                self._leave(d)      # the destination answers or notes why it missed the frame: its own step
            if c.rx is tx:
                ok, locked, reason = c.rx_ok, True, c.rx_reason
                c.rx = None
            else:
                ok = locked = False
                reason = tx.crowd_fail or "collision"
            c.audible -= 1
            if ok:
                c.eifs = False
                if tx.kind == "data" and not crowd_bcast:   # unicast to a station outside the crowd: NAV
                    nav = now + self.sifs + self.ack_time
                    if nav > c.nav_end:
                        c.nav_end = nav
                        waiting = self._nav.get(nav)
                        if waiting is None:
                            waiting = self._nav[nav] = []
                            self.sim.call_at_ticks(nav, self._nav_due, arg=nav)
                        waiting.append(c)
            elif locked and self.use_eifs:
                c.eifs = True
            self._clock_reeval(now)
        stations = self._stations
        if crowd_bcast:
            self._bcast_end(tx, src, ok, locked, reason)
            return
        heap = self._end_heap = [i for i in self._solo if i != src.index]
        try:
            while heap:
                i = heapq.heappop(heap)
                r = stations[i]
                if r.in_crowd:
                    continue
                self._end_pos = i
                self._listener_end(r, tx)
        finally:
            self._end_heap = None
            self._end_pre = None
            self._end_pos = -1

    def _listener_end(self, r, tx) -> None:
        """*tx* left the air at *r*, a station outside the crowd: its reception outcome,
        then its own DCF step."""
        r.n_active -= 1
        if r.rx is tx:
            ok, reason = r.rx_ok, r.rx_reason
            self.medium._unlock(r)
            locked = True
            if not ok:
                tx.fail[r.index] = reason
        else:
            ok, locked = False, False
            reason = tx.fail.get(r.index, "collision")
        r.audible -= 1
        self._rx_end(r, tx, ok, reason, locked)
        self._reeval(r)

    def _bcast_end(self, tx, src, c_ok, c_locked, c_reason) -> None:
        """End of a broadcast data frame with a crowd (already updated): every station in
        order delivers or loses it (the crowd's stations with the crowd's outcome), the
        others also do their own reception and DCF step."""
        stations: list = self._stations
        f = tx.frame
        self._end_heap = []
        try:
            for r in stations:
                if r is src:
                    continue
                self._end_pos = r.index
                if r.in_crowd:
                    if c_locked:
                        r.iface.receiving = 0
                        r.iface._state()
                    self._end_mid = r
                    if c_ok:
                        self._deliver(f, r.iface)
                    else:
                        self._lost(f, r.iface, c_reason)
                    self._end_mid = None
                    if not r.in_crowd:          # it left (a callback made it send): its own re-evaluation
                        self._reeval(r)
                    continue
                self._listener_end(r, tx)
        finally:
            self._end_heap = None
            self._end_pre = None
            self._end_pos = -1
            self._end_mid = None

    # ------------------------------------------------------------------ analysis helpers
    def timing(self) -> dict:
        """The MAC/PHY constants in seconds (for analysis and documentation)."""
        s = 1.0 / TICKS_PER_SECOND
        return {"slot": self.slot * s, "sifs": self.sifs * s, "difs": self.difs * s, "eifs": self.eifs_time * s,
                "plcp": self.plcp * s, "ack_time": self.ack_time * s, "ack_rate": self.ack_rate,
                "ack_timeout": self.ack_timeout * s, "cw_min": self.cw_min, "cw_max": self.cw_max,
                "mac_overhead_bits": self.mac_overhead_bits, "retry_limit": self.retry_limit}
