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

Data rate: any positive number, a documented modelling choice (the thesis uses 1.2
Mbit/s; ``data_rate=5e6`` or ``basic_rates=[3e6]`` are accepted as such, with the
modulation ``modulation`` picks for them); :data:`RATES` lists the 802.11b rates.  A rate
at which the largest frame (``max_frame_bits``) would take more than
:data:`MAX_FRAME_SECONDS` (1 s) on the air is refused: ``data_rate=11`` is a slip for
11e6, and its frames would stay in flight for half an hour (``message_loss`` NaN, no
message with a known fate).  The radio side (positions, powers, thresholds, capture, BER) is described
in :mod:`netcosim.network.medium` and :mod:`netcosim.network.radio`.

Simplifications: no RTS/CTS, no fragmentation, no rate adaptation, the short-preamble
PLCP header is treated like the long one (DBPSK at 1 Mbit/s) for bit errors, and
``propagation_delay`` only delays delivery (MAC timing sees zero propagation, as
Bianchi's model with delta = 0).
"""

from __future__ import annotations

import heapq
import math
from typing import Any

from ... import validate
from ...errors import ConfigurationError, ConfigurationTypeError
from ...timebase import TICKS_PER_SECOND, to_ticks
from ..frame import BROADCAST
from ..medium import Transmission
from ..radio import DSSS_BANDWIDTH, PathLoss, modulation_for, thermal_noise_dbm
from ..wireless import RadioNetwork
from .dcf import DcfStation, PerStationAccess
from .shared import SharedClockAccess

#: 802.11b data rates (bit/s).
RATES = (1e6, 2e6, 5.5e6, 11e6)
#: 802.11b basic rate set commonly configured (bit/s).
BASIC_RATES = (1e6, 2e6)
#: The longest air time (s) of the largest data frame (``max_frame_bits``) at the data
#: rate that a network accepts; a slower rate is refused as a unit slip (bit/s vs Mbit/s).
MAX_FRAME_SECONDS = 1.0


def _index(r) -> int:
    return r.index


class WLAN80211b(RadioNetwork):
    """IEEE 802.11b DCF network.  See the module docstring for the semantics.

    The parameters below come besides those of every network (:class:`~netcosim.network.base.Network`).
    Every parameter is validated here (:mod:`netcosim.validate`); powers and
    thresholds must be finite numbers of dBm, also when given per node to ``attach``.

    Parameters
    ----------
    data_rate:
        Data rate in bit/s (default 11 Mbit/s; any positive value at which a frame of
        ``max_frame_bits`` takes at most :data:`MAX_FRAME_SECONDS`, see the module docstring).
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
        (or the data rate if it is below all of them).  Any positive values, like
        ``data_rate`` (not restricted to :data:`RATES`).
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
    modulation:
        ``"auto"`` (by rate), ``"dbpsk"``, ``"dqpsk"``, ``"cck"``.
    shared_clock:
        True (default): while every station hears every other one and no bit error is
        possible without interference (decided at each ``attach`` from positions, powers
        and thresholds, see :mod:`netcosim.network.slotclock`), the stations not taking
        part in the current exchange share one idle-slot clock, so a frame costs about the
        same whatever the number of stations when no capture is possible; where it is,
        the listeners whose reception of an overlap differs take their own steps.  The
        results are identical bit for bit to False, which updates every station on every
        medium change.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        A ``data_rate`` so low that a frame of ``max_frame_bits`` would take more than
        :data:`MAX_FRAME_SECONDS` (a rate in Mbit/s given as bit/s); ``cw_max`` below
        ``cw_min``; ``basic_rates`` empty; ``ack_timeout`` not above SIFS; ``preamble`` or
        ``modulation`` not one of the names above; ``retry_limit`` below 1; ``slot`` or
        ``sifs`` not positive; a radio parameter out of range
        (:class:`~netcosim.network.wireless.RadioNetwork`) or a common one
        (:class:`~netcosim.network.base.Network`).
    :class:`~netcosim.errors.ConfigurationTypeError`
        ``basic_rates`` not a sequence; ``shared_clock`` not ``True``/``False``; a
        parameter that is not a number; *sim* not a :class:`~netcosim.Simulation`.

    Examples
    --------
    One unicast frame of 1000 payload bits at 11 Mbit/s on an idle channel: the medium
    is idle for DIFS (50 µs) after the send, then PLCP (192 µs) and the 224 MAC bits
    with the payload at 11 Mbit/s (111.27 µs): delivered at 353.27 µs.  The ACK
    starts SIFS (10 µs) later and takes 248 µs (PLCP and 112 bits at 2 Mbit/s):

    >>> from netcosim import Simulation
    >>> from netcosim.network import WLAN80211b
    >>> sim = Simulation(seed=0)
    >>> net = WLAN80211b(sim, "wlan", data_rate=11e6)
    >>> a, b = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(10.0, 0.0))
    >>> acked = []
    >>> a.on_done.append(lambda frame, ok: acked.append((round(sim.now * 1e6, 3), ok)))
    >>> msg = a.send("b", None, size_bits=1000)
    >>> sim.run(until=0.01)
    >>> t = net.timing()                                # the constants in s
    >>> delivery = t["difs"] + t["plcp"] + (t["mac_overhead_bits"] + 1000) / 11e6
    >>> round(msg.delivered * 1e6, 3), round(delivery * 1e6, 3)                  # µs
    (353.273, 353.273)
    >>> acked, round((delivery + t["sifs"] + t["ack_time"]) * 1e6, 3)           # ACK end, µs
    ([(611.273, True)], 611.273)
    """

    station_class = DcfStation

    def __init__(self, sim, name, *, data_rate: float = 11e6, preamble: str = "long", retry_limit: int = 7,
                 eifs: bool = True, ack_timeout: float | None = None, basic_rates=BASIC_RATES,
                 slot: float = 20e-6, sifs: float = 10e-6, cw_min: int = 31, cw_max: int = 1023,
                 mac_overhead_bits: int = 224, ack_bits: int = 112, max_frame_bits: int | None = 2312 * 8,
                 path_loss: PathLoss | None = None, tx_power_dbm: float = 15.0, threshold_dbm: float = -85.0,
                 cs_threshold_dbm: float | None = None, capture_db: float = 10.0, noise_dbm: float | None = None,
                 modulation: str = "auto", shared_clock: bool = True, loss: Any = None, **kw):
        super().__init__(sim, name, data_rate=data_rate, max_frame_bits=max_frame_bits, path_loss=path_loss,
                         tx_power_dbm=tx_power_dbm, threshold_dbm=threshold_dbm, cs_threshold_dbm=cs_threshold_dbm,
                         capture_db=capture_db, noise_dbm=noise_dbm, loss=loss, **kw)
        w = f"network {name!r}"
        if self.max_frame_bits is not None and self.max_frame_bits / self.data_rate > MAX_FRAME_SECONDS:
            raise ConfigurationError(
                f"{w}: data_rate={data_rate!r} bit/s makes a frame of max_frame_bits={self.max_frame_bits} take "
                f"{self.max_frame_bits / self.data_rate:.6g} s, more than MAX_FRAME_SECONDS={MAX_FRAME_SECONDS} s; "
                f"the rate is in bit/s (11 Mbit/s is 11e6)")
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
        # when each station accesses the medium: the shared idle-slot clock while every station
        # hears every other one (decided at each attach), else station by station; the shared
        # clock's object stays after the switch, for the entries it left in the access heap
        self._shared = SharedClockAccess(self)
        self._use(self._shared if shared_clock else PerStationAccess(self))

    def default_noise_dbm(self) -> float:
        """Thermal noise in the 22 MHz DSSS channel at 290 K (dBm)."""
        return thermal_noise_dbm(DSSS_BANDWIDTH)

    # ------------------------------------------------------------------ timing helpers
    def data_time(self, size_bits: int) -> int:
        """Time on air (ticks) of a data frame carrying *size_bits* bits (PLCP + MAC header/FCS +
        payload)."""
        return self.plcp + self.duration(self.mac_overhead_bits + self.wire_bits(size_bits))

    # ------------------------------------------------------------------ DCF (r: the DcfStation)
    def _use(self, dcf: PerStationAccess) -> None:
        """Decide from now on with the strategy *dcf* when each station accesses the medium."""
        self._dcf = dcf
        self._fast = dcf.shared
        self._reeval = dcf.reeval   # type: ignore[method-assign]  # the medium's hook, one call
        self._rx_end = dcf.rx_end
        self._air_start = dcf.air_start
        self._air_end = dcf.air_end

    def _push_access(self, r, at) -> None:
        """Station *r* accesses the medium at *at* (ticks) unless something changes before."""
        r.access_at = at
        r.acc_gen += 1
        heapq.heappush(self._acc, (at, r.index, r.acc_gen, r))
        if self._acc_timer_at < 0 or at < self._acc_timer_at:
            self._arm_access(at)

    def _arm_access(self, at) -> None:
        if self._acc_timer is not None:
            self._acc_timer.cancel()
        self._acc_timer_at = at
        self._acc_timer = self.sim._call_at_ticks(at, self._access_due)

    def _access_due(self) -> None:
        """Every station whose access instant is now transmits (in station order)."""
        now = self._env.now
        self._acc_timer = None
        self._acc_timer_at = -1
        acc = self._acc
        due = []
        shared = self._shared
        clock = shared.clock
        while acc and acc[0][0] <= now:
            at, _, gen, r = heapq.heappop(acc)
            if r.acc_gen == gen and r.access_at == at:
                if r is clock:
                    due.extend(shared.pop_due(now, False))
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
                    shared.try_join(r)       # post-backoff over, nothing to send
            if not clock.mac_busy and clock.access_at < 0:
                shared.clock_schedule()
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
        if r.in_crowd and self._shared.kick_member(r):
            return
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
        self.begin_attempt(iface, f, bits, r.bo_drawn)
        r.bo_drawn = math.nan
        now = self._env.now
        tx = Transmission(r, "data", f, f.dst if f.dst is BROADCAST else f.dst.mac, now,
                          now + self.plcp + self.duration(bits), now + self.plcp, self.data_mod)
        self._start_tx(r, tx)

    def _start_tx(self, r, tx) -> None:
        r.mac_busy = True
        super()._start_tx(r, tx)

    def _frame_sent(self, r) -> None:
        r.cw = self.cw_min
        self._draw(r)                 # post-backoff, drawn before the sender hears it is free
        r.iface.attempt.finish(restart=False)

    def _frame_dropped(self, r, reason: str) -> None:
        r.cw = self.cw_min
        self._draw(r)                 # post-backoff, as after a frame sent
        r.iface.attempt.drop(reason, restart=False)

    def _retry(self, r) -> None:
        r.cw = min(2 * (r.cw + 1) - 1, self.cw_max)
        self._draw(r)

    def _set_nav(self, r, nav) -> None:
        """Station *r* (or the shared clock's crowd) decoded a unicast frame addressed to another
        station: its NAV covers the ACK, until *nav* (ticks)."""
        if nav > r.nav_end:
            r.nav_end = nav
            waiting = self._nav.get(nav)
            if waiting is None:
                waiting = self._nav[nav] = []
                self.sim._call_at_ticks(nav, self._nav_due, arg=nav)
            waiting.append(r)

    def _nav_due(self, nav) -> None:
        clock = self._shared.clock
        for r in self._nav.pop(nav):
            if r is clock:
                if clock.count:
                    self._shared.clock_reeval(self._env.now)
            elif not r.in_crowd:
                self._reeval(r)

    def _require_per_station(self, what: str) -> None:
        """Run-time changes of radio powers: where capture is possible the shared clock hands every
        station its exact state back at any instant, and the network goes on station by station
        for good; otherwise they need ``shared_clock=False`` (see :class:`RadioNetwork`)."""
        if self._fast and self._shared.exact:
            self._shared.dissolve()
            self._use(PerStationAccess(self))
        super()._require_per_station(what)

    def _station(self, iface, options):
        r = super()._station(iface, options)
        if self._fast and not self._shared.attached(r):
            # a station out of range or able to capture: station by station from now on, for good
            self._shared.dissolve()
            self._use(PerStationAccess(self))
        return r

    # ------------------------------------------------------------------ analysis helpers
    def timing(self) -> dict:
        """The MAC/PHY constants in seconds (for analysis and documentation)."""
        s = 1.0 / TICKS_PER_SECOND
        return {"slot": self.slot * s, "sifs": self.sifs * s, "difs": self.difs * s, "eifs": self.eifs_time * s,
                "plcp": self.plcp * s, "ack_time": self.ack_time * s, "ack_rate": self.ack_rate,
                "ack_timeout": self.ack_timeout * s, "cw_min": self.cw_min, "cw_max": self.cw_max,
                "mac_overhead_bits": self.mac_overhead_bits, "retry_limit": self.retry_limit}
