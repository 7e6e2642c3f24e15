"""The shared wireless medium: who hears what, how strongly, and what decodes.

Every transmission is a :class:`Transmission` with a start and an end tick.  When it
starts, the medium computes its received power at every other interface (positions
evaluated at that instant; cached when nobody moves) and updates, per listener:

* **carrier sense** -- the listener counts the ongoing transmissions it receives at or
  above its carrier-sense threshold; the medium is busy for it while the count is > 0
  (per-signal carrier sense, so two senders out of each other's range are *hidden*);
* **interference** -- the sum of the powers of all ongoing transmissions;
* **reception** -- a listener that is not transmitting (half duplex) *locks* onto a
  frame whose power is at or above its receiver threshold when it is not already locked.
  A later frame captures the receiver if its power is at least ``capture_ratio`` times
  the sum of every other signal (the locked frame is then lost, "message in message").
  A locked frame survives only while its signal-to-interference ratio stays at or above
  ``capture_ratio``; then bits are drawn against noise + interference: for each stretch
  of constant interference, ``(1 - BER(SINR))^bits`` (PLCP at 1 Mbit/s DBPSK, the rest
  at the frame's modulation).  The product is the frame's success probability.

At the end of a transmission every listener reports ``(ok, reason, locked)`` to its MAC;
failure reasons are ``collision``, ``below_threshold``, ``bit_errors``, ``half_duplex``.
All arithmetic on instants is in integer ticks; powers in watts.
"""

from __future__ import annotations

import math

from ..errors import ConfigurationError, ConfigurationTypeError
from ..timebase import TICKS_PER_SECOND
from .frame import BROADCAST
from .radio import distance, modulation_for

_TOL = 1.0 - 1e-9    # power ratios within 1e-9 of the capture ratio count as meeting it


class Transmission:
    """One frame (data or ACK) on the air.  Times in ticks, powers in watts; ``src`` and
    ``dst`` are radio stations (``dst`` may be :data:`BROADCAST`).  ``kind``: ``"data"`` or
    ``"ack"``; ``frame``: the :class:`~netcosim.network.frame.Frame` sent (an ACK's: the data
    frame it acknowledges); ``start`` and ``end``: the ticks its first and last bit go on the
    air; ``plcp_end``: the tick its PLCP preamble and header end (bits before it are decoded
    with the medium's PLCP modulation, bits after with ``mod``); ``mod``: the
    :class:`~netcosim.network.radio.Modulation` of the rest of the frame."""

    __slots__ = ("src", "kind", "frame", "dst", "start", "end", "plcp_end", "mod", "powers", "fail",
                 "dst_reason", "acked", "crowd_fail")

    def __init__(self, src, kind, frame, dst, start, end, plcp_end, mod):
        self.src, self.kind, self.frame, self.dst = src, kind, frame, dst
        self.start, self.end, self.plcp_end, self.mod = start, end, plcp_end, mod
        self.powers: list[float] | None = None  # received power per station (W), set by Medium.start
        self.fail = {}            # listener index -> reason it could not decode
        self.dst_reason = None    # why the (unicast) destination failed
        self.acked = False        # the destination decoded it and answers with an ACK
        self.crowd_fail = None    # why the listeners of a shared idle-slot clock could not decode it

    def addressed_to(self, r) -> bool:
        """True if station *r* is this transmission's destination (a broadcast data frame is addressed
        to every station; an ACK only to its data frame's sender)."""
        return self.dst is r or (self.dst is BROADCAST and self.kind == "data")


def _unlock(r) -> None:
    """Listener *r* stops receiving its locked frame."""
    tx = r.rx
    r.rx = None
    if tx is not None and tx.addressed_to(r):
        r.iface.receiving = 0
        r.iface._state()


def reception_end(r, tx: Transmission) -> tuple[bool, str | None, bool]:
    """*tx* leaves the air at listener *r*: the reception outcome ``(ok, reason, locked)``.

    The one decision of every path (:meth:`WirelessMedium.end`, and the shared idle-slot
    clock of :mod:`netcosim.network.wlan.shared` for its crowd and for the stations outside
    it).  A frame *r* was locked onto keeps the verdict reached while it was on the air,
    then survives the bit errors drawn from ``r.logp`` (log of its success probability);
    *r* stops receiving it and a failure is recorded in ``tx.fail``.  A frame it was not
    locked onto failed for the reason noted at its start (``collision`` if none).  *r* may
    be the crowd of a :class:`~netcosim.network.slotclock.SharedSlotClock` (index -1): its
    reason is ``tx.crowd_fail``, it has no interface and never draws bit errors.
    """
    if r.rx is not tx:
        return False, (tx.fail.get(r.index) if r.index >= 0 else tx.crowd_fail) or "collision", False
    ok, reason = r.rx_ok, r.rx_reason
    if ok and r.logp < 0.0 and r.phy_rng.random() >= math.exp(r.logp):
        ok, reason = False, "bit_errors"
    if r.index < 0:
        r.rx = None
    else:
        _unlock(r)
        if not ok:
            tx.fail[r.index] = reason
    return ok, reason, True


class WirelessMedium:
    """Reception physics shared by the wireless MACs (see the module docstring).

    ``mac`` provides ``_rx_end(r, tx, ok, reason, locked)`` and ``_reeval(r)`` and the
    list ``mac._stations`` of :class:`~netcosim.network.wireless.RadioStation` (by
    interface index), each with its radio attributes (``pos``, ``tx_w``, ``cs_w``,
    ``sens_w``) and its listener state.  ``noise_w``: noise power (W); ``capture_ratio``:
    linear power ratio (not dB); ``plcp_rate``: bit rate of the PLCP header (bit/s).
    ``path_loss``: a :class:`~netcosim.network.radio.PathLoss` (its ``gain(d)``, d in m,
    gives the received over the transmitted power).
    """

    def __init__(self, mac, *, path_loss, noise_w: float, capture_ratio: float, plcp_rate: float = 1e6):
        self.mac = mac
        self.sim = mac.sim
        self.env = mac.sim.env
        self.path_loss = path_loss
        self.noise_w = noise_w
        self.capture_ratio = capture_ratio
        self.plcp_mod = modulation_for(plcp_rate, "dbpsk")
        self._plcp_bps = plcp_rate / TICKS_PER_SECOND
        self.active: list[Transmission] = []
        self._rows: dict[int, list[float]] = {}
        self._static = True
        self.transmissions = 0

    def init_listener(self, r) -> None:
        """Station *r* (a :class:`~netcosim.network.wireless.RadioStation`) joins: check that
        nothing is on the air, note whether it moves (a callable ``r.pos``)."""
        if self.active:
            raise RuntimeError(f"network {self.mac.name!r}: cannot attach {r.name!r} while "
                               f"{len(self.active)} transmission(s) are on the air; attach nodes before or "
                               f"between transmissions")
        if callable(r.pos):
            self._static = False
        self._rows.clear()

    # ------------------------------------------------------------------ powers
    def _position(self, r, t_s):
        p = r.pos
        if callable(p):
            v = p(t_s)
            try:
                if isinstance(v, (str, bytes)):
                    raise TypeError
                v = tuple(float(x) for x in v)
            except (TypeError, ValueError):
                raise ConfigurationTypeError(f"network {self.mac.name!r}: position callable of {r.name!r} "
                                             f"returned {v!r} at t={t_s} s, not a point (2 or 3 numbers, m)"
                                             ) from None
            if len(v) not in (2, 3) or not all(math.isfinite(x) for x in v):
                raise ConfigurationError(f"network {self.mac.name!r}: position of {r.name!r} at t={t_s} s "
                                         f"is {v!r}; need 2 or 3 finite coordinates")
            return v
        return p

    def powers_from(self, src) -> list[float]:
        """Received power (W) at every interface (by index) of a transmission by *src* now."""
        if self._static:
            row = self._rows.get(src.index)
            if row is None:
                row = self._rows[src.index] = self._compute(src, 0.0)
            return row
        return self._compute(src, self.sim.now)

    def _compute(self, src, t_s):
        ps = self._position(src, t_s)
        g = self.path_loss.gain
        ptx = src.tx_w
        out = []
        for r in self.mac._stations:
            if r is src:
                out.append(0.0)
            else:
                out.append(ptx * g(distance(ps, self._position(r, t_s))))
        return out

    def forget(self, src) -> None:
        """*src*'s transmit power or thresholds changed: recompute its received powers at its next frame."""
        self._rows.pop(src.index, None)

    # ------------------------------------------------------------------ segments
    def _close(self, r, now) -> None:
        """Account the bits of r's locked frame received since ``r.seg_t`` at the current SINR."""
        t0 = r.seg_t
        if now <= t0:
            return
        r.seg_t = now
        if not r.rx_ok:
            return
        L = r.rx
        p = L.powers[r.index]
        interf = r.power - p
        sinr = p / (self.noise_w + (interf if interf > 0.0 else 0.0))
        logp = 0.0
        pe = L.plcp_end
        if t0 < pe:
            ber = self.plcp_mod.ber(sinr)
            if ber > 0.0:
                logp += ((now if now < pe else pe) - t0) * self._plcp_bps * math.log1p(-ber)
        if now > pe:
            ber = L.mod.ber(sinr)
            if ber > 0.0:
                logp += (now - (t0 if t0 > pe else pe)) * (L.mod.bit_rate / TICKS_PER_SECOND) * math.log1p(-ber)
        r.logp += logp

    def _lock(self, r, tx, now) -> None:
        r.rx = tx
        r.rx_ok = True
        r.rx_reason = None
        r.seg_t = now
        r.logp = 0.0
        if tx.addressed_to(r):
            r.iface.receiving = 1
            r.iface._state()

    _unlock = staticmethod(_unlock)

    # ------------------------------------------------------------------ events
    def _stop_receiving(self, src) -> None:
        """*src* starts sending: half duplex, the frame it was receiving fails there."""
        if src.rx is not None:
            L = src.rx
            L.fail[src.index] = "half_duplex"
            if L.dst is src:
                L.dst_reason = "half_duplex"
            self._unlock(src)

    def start(self, tx: Transmission) -> None:
        """*tx* begins now; update every listener and tell each MAC to re-evaluate."""
        self.transmissions += 1
        self._stop_receiving(tx.src)
        tx.powers = self.powers_from(tx.src)
        self.active.append(tx)
        self.start_at(tx, self.mac._stations)

    def start_at(self, tx: Transmission, listeners) -> None:
        """*tx* (already on the air: counted, ``tx.powers`` set) reaches each station of
        *listeners* now (its sender is skipped): carrier sense, interference, lock or capture,
        and the MAC's re-evaluation of a station the medium just turned busy for."""
        now = self.env.now
        src = tx.src
        powers = tx.powers
        assert powers is not None, "set when tx went on the air"
        cap = self.capture_ratio * _TOL
        mac = self.mac
        off = src.off       # a sender out of energy reaches nobody: its frames fail for that reason
        for r in listeners:
            if r is src:
                continue
            p = powers[r.index]
            L = r.rx
            if L is not None:
                self._close(r, now)
            r.power += p
            r.n_active += 1
            if r.tx is not None:
                tx.fail[r.index] = "half_duplex"
            elif p >= r.sens_w:
                if L is None:
                    self._lock(r, tx, now)
                    if p < cap * (r.power - p):
                        r.rx_ok = False
                        r.rx_reason = "collision"
                elif p >= cap * (r.power - p):   # the newcomer captures the receiver
                    L.fail[r.index] = "collision"
                    self._unlock(r)
                    self._lock(r, tx, now)
                else:
                    tx.fail[r.index] = "collision"
                    if r.rx_ok:
                        pl = L.powers[r.index]
                        if pl < cap * (r.power - pl):
                            r.rx_ok = False
                            r.rx_reason = "collision"
            else:
                tx.fail[r.index] = off or r.off or "below_threshold"
                if L is not None and r.rx_ok:
                    pl = L.powers[r.index]
                    if pl < cap * (r.power - pl):
                        r.rx_ok = False
                        r.rx_reason = "collision"
            if p >= r.cs_w:
                r.audible += 1
                if r.audible == 1:
                    mac._reeval(r)

    def end(self, tx: Transmission) -> None:
        """*tx* ends now; finish receptions and report to every listener's MAC."""
        self.active.remove(tx)
        self.end_at(tx, self.mac._stations)

    def end_at(self, tx: Transmission, listeners) -> None:
        """*tx* (already off the air) ends now at each station of *listeners* (its sender is
        skipped): finish the reception, report it to the MAC, let the MAC re-evaluate."""
        now = self.env.now
        src = tx.src
        powers = tx.powers
        assert powers is not None, "set by start(tx)"
        mac = self.mac
        for r in listeners:
            if r is src:
                continue
            p = powers[r.index]
            L = r.rx
            if L is not None:
                self._close(r, now)
            r.n_active -= 1
            r.power = r.power - p if r.n_active else 0.0
            ok, reason, locked = reception_end(r, tx)
            if p >= r.cs_w:
                r.audible -= 1
            mac._rx_end(r, tx, ok, reason, locked)
            mac._reeval(r)
