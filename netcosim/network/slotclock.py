"""The shared idle-slot clock of an 802.11 DCF network whose stations all hear each other.

When every station hears every other one and decodes every frame sent alone without a
bit error, every station that neither sends nor takes part in a frame exchange sees the
same medium while frames do not overlap: the same busy/idle instants, the same locked
frame, the same NAV and EIFS; if moreover no frame can capture a receiver, an overlap
destroys both frames at every listener, so they still do.  Those stations form one
*crowd* kept as a single :class:`SharedSlotClock` instead of being updated one by one on
every medium change:

* the crowd's listener state (locked frame, carrier sense, NAV, EIFS, idle since) is
  held once;
* a member's backoff is a key ``K = S + slots left`` on one counter ``S`` of idle slots
  elapsed, which advances by ``(t_busy - C) // slot`` when the medium turns busy at
  ``t_busy`` after counting started at ``C`` (the per-station rule, applied once); the
  next member to transmit is the smallest key: a heap, with one entry for the whole
  crowd in the network's access heap.

A station leaves the crowd (its state is written back into its own fields) when it is
due to transmit, is the destination of a unicast frame, or gets a frame to send while
the medium is idle; where capture is possible, also when a frame starts while the crowd
hears another and the station's own reception of it would differ from the crowd's (the
new frame locked intact or capturing it, its locked frame surviving).  It rejoins when
it is idle again with the same idle instant and EIFS flag as the crowd, or busy with the
same view of the medium.  A broadcast frame is delivered (or lost) at each crowd station
in station order, with the crowd's outcome.  Stations outside the crowd are processed
exactly as on the per-station path.

:class:`Audibility` decides from the geometry, powers and thresholds whether the
conditions hold: every received power at or above the receiver and carrier-sense
thresholds, and a bit error rate of exactly zero at the weakest link without
interference for the PLCP, data and ACK modulations (so a frame alone never draws a bit
error); and whether capture is possible (a receiver where one sender is within the
capture ratio of another, with a margin; else any overlap destroys both frames
everywhere).  Moving stations (a callable position) are never in this case.
"""

from __future__ import annotations

import math
from typing import Any

from .radio import distance

#: Margin on the capture test: received power ratios within this relative distance of the
#: capture ratio count as possibly capturing (the crowd then checks each overlap).
_CAPTURE_MARGIN = 1e-6


class SharedSlotClock:
    """The crowd's state (see the module docstring).  Times in ticks.

    ``count`` members; listener state ``rx``, ``rx_ok``, ``rx_reason``, ``audible``
    (transmissions on the air); DCF state ``mac_busy``, ``idle_start``, ``eifs``,
    ``nav_end``; the slot counter ``S`` (value at ``C``, the start of counting in the
    current idle period, or frozen while busy); ``heap`` of ``(key, index, seq,
    station)`` (an entry is current while ``station.cseq == seq``); ``access_at``,
    ``acc_gen`` (the crowd's entry in the network's access heap; generations are
    negative so they never equal a station's).  ``now``: the tick the crowd is created
    (its idle period starts then); ``difs``: the DIFS (ticks), after which it counts slots.
    """

    __slots__ = ("count", "rx", "rx_ok", "rx_reason", "audible", "mac_busy", "idle_start", "eifs", "nav_end",
                 "S", "C", "heap", "access_at", "acc_gen", "seq", "index")

    #: the crowd never draws bit errors (see :func:`~netcosim.network.medium.reception_end`)
    logp = 0.0

    def __init__(self, now: int, difs: int):
        self.count = 0
        self.rx: Any = None
        self.rx_ok = False
        self.rx_reason: str | None = None
        self.audible = 0
        self.mac_busy = False
        self.idle_start = now
        self.eifs = False
        self.nav_end = 0
        self.S = 0
        self.C = now + difs
        self.heap: list = []
        self.access_at = -1
        self.acc_gen = 0
        self.seq = 0
        self.index = -1

    def __repr__(self) -> str:
        return f"<SharedSlotClock {self.count} stations, {'busy' if self.mac_busy else 'idle'}>"


class Audibility:
    """Incremental check that every station hears every other one (the conditions above)
    as stations attach (O(n) per station); ``capture`` tells whether capture is possible.

    Keeps, per listener index, the smallest and largest power received from any other
    station, and the smallest power over all links (W).
    """

    def __init__(self):
        self.pmin: list[float] = []
        self.pmax: list[float] = []
        self.weakest = math.inf
        self.ok = True
        #: some receiver may be captured (or a frame survive an overlap): the crowd must check
        #: each overlap station by station (see :mod:`netcosim.network.wlan.shared`)
        self.capture = False

    def add(self, n, stations, gain, capture_ratio: float, capture_tol: float, noise_w: float, mods) -> bool:
        """Station *n* (already in *stations*, by index) joins; False once the conditions fail
        (``capture`` turns True, for good, once a receiver could be captured).

        ``gain``: the path loss's ``gain(d)`` (received over transmitted power at d m);
        ``capture_ratio``: the medium's capture ratio (linear, not dB) and ``capture_tol``
        the tolerance (just below 1) within which a power ratio counts as meeting it;
        ``noise_w``: the noise power (W); ``mods``: the
        :class:`~netcosim.network.radio.Modulation` objects in use (PLCP, data, ACK), each of
        which must be error-free at the weakest link's SNR."""
        if not self.ok:
            return False
        if callable(n.pos):
            self.ok = False
            return False
        self.pmin.append(math.inf)
        self.pmax.append(0.0)
        for r in stations:
            if r is n:
                continue
            if callable(r.pos):
                self.ok = False
                return False
            p_rn = r.tx_w * gain(distance(r.pos, n.pos))     # as the medium computes it: sender first
            p_nr = n.tx_w * gain(distance(n.pos, r.pos))
            if p_rn < n.sens_w or p_rn < n.cs_w or p_nr < r.sens_w or p_nr < r.cs_w:
                self.ok = False
                return False
            for i, p in ((n.index, p_rn), (r.index, p_nr)):
                if p < self.pmin[i]:
                    self.pmin[i] = p
                if p > self.pmax[i]:
                    self.pmax[i] = p
            self.weakest = min(self.weakest, p_rn, p_nr)
        lim = capture_ratio * capture_tol * (1.0 - _CAPTURE_MARGIN)
        if len(stations) >= 3 and any(hi >= lim * lo for lo, hi in zip(self.pmin, self.pmax)):
            self.capture = True
        if self.weakest < math.inf:
            snr = self.weakest / noise_w
            # Modulation.ber is exactly 0 from this Eb/N0 on: no bit error is ever drawn
            if any(snr * m.gain < m._cut for m in mods):
                self.ok = False
        return self.ok
