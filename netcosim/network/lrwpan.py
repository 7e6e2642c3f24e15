"""IEEE 802.15.4 (2.4 GHz O-QPSK PHY) with unslotted CSMA/CA, on the radio medium of
:mod:`netcosim.network.medium`.

Constants (IEEE Std 802.15.4-2006; one symbol = 16 µs at 62.5 ksymbol/s, 250 kbit/s):

=======================  ===========================================================
unit backoff period      20 symbols = 320 µs (aUnitBackoffPeriod)
CCA                      8 symbols = 128 µs
turnaround RX <-> TX     12 symbols = 192 µs (aTurnaroundTime)
SHR + PHR                6 bytes = 192 µs before every frame
MAC overhead             11 bytes (2 frame control, 1 sequence, 2 PAN id, 2 + 2 short
                         addresses, 2 FCS) = 88 bits
ACK frame                5 bytes + SHR/PHR = 352 µs, sent aTurnaroundTime after the frame
ACK wait                 54 symbols = 864 µs from the end of the frame (macAckWaitDuration)
macMinBE / macMaxBE      3 / 5
macMaxCSMABackoffs       4
macMaxFrameRetries       3 (so at most 4 transmissions)
max payload              127 - 11 = 116 bytes
IFS                      SIFS 12 symbols after frames of <= 18 bytes, LIFS 40 symbols otherwise
=======================  ===========================================================

Unslotted CSMA/CA: NB = 0, BE = macMinBE; wait ``U{0 .. 2^BE - 1}`` unit backoff
periods (the timer is *not* frozen by a busy medium); perform CCA; if the channel was
busy at any time during the CCA, NB += 1 and BE = min(BE + 1, macMaxBE), and either
back off again or, once NB > macMaxCSMABackoffs, give up (``lost``, reason
``channel_access``).  If idle, turn the radio around (192 µs) and transmit.  A unicast
frame is acknowledged by its receiver a turnaround time after it ends; without an ACK
within the ACK wait the frame is sent again with a fresh CSMA/CA, up to
macMaxFrameRetries retries.  CCA mode: carrier sense at ``cs_threshold_dbm``.

Bit errors: the standard's O-QPSK DSSS formula (IEEE 802.15.4-2006, E.4.1.8), with the
SINR over the 2 MHz channel, for every bit including the synchronisation header::

    BER = 8/15 * 1/16 * sum_{k=2..16} (-1)^k C(16, k) exp(20 SINR (1/k - 1))
"""

from __future__ import annotations

import math

import numpy as np

from .. import validate
from ..errors import ConfigurationError
from ..timebase import to_ticks
from .frame import BROADCAST
from .medium import Transmission
from .radio import Modulation, PathLoss, linear_ratio, thermal_noise_dbm
from .wireless import RadioNetwork, RadioStation

SYMBOL = 16e-6
_K = np.arange(2, 17)
_COEF = (-1.0) ** _K * np.array([math.comb(16, int(k)) for k in _K], dtype=float)

def ber_oqpsk(sinr):
    """802.15.4 2.4 GHz O-QPSK bit error rate as a function of *sinr*, the SINR (a linear
    power ratio, not dB, >= 0; a number or an array, giving a float or an array)."""
    s = np.atleast_1d(linear_ratio(sinr, "SINR"))
    terms = _COEF[None, :] * np.exp(20.0 * s[:, None] * (1.0 / _K[None, :] - 1.0))
    ber = np.clip(8.0 / 15.0 / 16.0 * terms.sum(axis=1), 0.0, 0.5)
    return float(ber[0]) if np.ndim(sinr) == 0 else ber

class CsmaCaStation(RadioStation):
    """An 802.15.4 station: radio and ACK state plus unslotted CSMA/CA: ``nb`` (backoffs
    so far), ``be`` (backoff exponent), ``in_cca``/``cca_busy`` (a CCA is running / saw
    the channel busy), ``ifs_until`` (tick before which the next frame may not start).
    ``net``, ``iface`` and the radio parameters as for
    :class:`~netcosim.network.wireless.RadioStation`."""

    __slots__ = ("nb", "be", "in_cca", "cca_busy", "ifs_until")

    def __init__(self, net, iface, *radio):
        super().__init__(net, iface, *radio)
        self.nb = self.be = 0
        self.in_cca = False
        self.cca_busy = False
        self.ifs_until = 0


class IEEE802154(RadioNetwork):
    """IEEE 802.15.4 network, unslotted CSMA/CA.  See the module docstring.

    Radio parameters as for :class:`~netcosim.network.wlan.WLAN80211b` (defaults:
    0 dBm transmit power, -85 dBm threshold, thermal noise in 2 MHz, log-distance path
    loss with exponent 3).  ``ack=False`` sends unicast frames without acknowledgement.
    ``min_be <= max_be`` (0..30), ``max_csma_backoffs`` and ``max_frame_retries`` are
    integers >= 0, ``mac_overhead_bits`` an integer >= 0; powers and thresholds (also
    per node in ``attach``) finite dBm, ``capture_db`` finite and >= 0.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        ``min_be`` above ``max_be``, either outside 0..30; a negative
        ``max_csma_backoffs``, ``max_frame_retries`` or ``mac_overhead_bits``; a radio
        parameter out of range (:class:`~netcosim.network.wireless.RadioNetwork`) or a
        common one (:class:`~netcosim.network.base.Network`).
    :class:`~netcosim.errors.ConfigurationTypeError`
        A parameter that is not a number, a ``path_loss`` that is not a
        :class:`~netcosim.network.radio.PathLoss`, *sim* not a :class:`~netcosim.Simulation`.

    Examples
    --------
    One unicast frame of 112 payload bits on an idle channel.  ``min_be=0`` makes the
    first backoff 0 unit periods, so the timing is fixed: CCA (128 µs), turnaround
    (192 µs), SHR + PHR (192 µs), then the 88 MAC bits and the payload at 250 kbit/s
    (800 µs): delivered at 1312 µs.  The ACK follows a turnaround later and lasts 352 µs:

    >>> from netcosim import Simulation
    >>> from netcosim.network import IEEE802154
    >>> sim = Simulation(seed=0)
    >>> net = IEEE802154(sim, "zigbee", min_be=0)
    >>> a, b = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(5.0, 0.0))
    >>> acked = []
    >>> a.on_done.append(lambda frame, ok: acked.append((round(sim.now * 1e6, 3), ok)))
    >>> msg = a.send("b", None, size_bits=112)
    >>> sim.run(until=0.01)
    >>> round(msg.delivered * 1e6, 3), round((128e-6 + 192e-6 + 192e-6 + (88 + 112) / 250e3) * 1e6, 3)
    (1312.0, 1312.0)
    >>> acked                                          # (µs, acknowledged)
    [(1856.0, True)]
    """

    station_class = CsmaCaStation

    def __init__(self, sim, name, *, data_rate: float = 250e3, min_be: int = 3, max_be: int = 5,
                 max_csma_backoffs: int = 4, max_frame_retries: int = 3, ack: bool = True,
                 mac_overhead_bits: int = 88, max_frame_bits: int | None = 116 * 8,
                 path_loss: PathLoss | None = None, tx_power_dbm: float = 0.0, threshold_dbm: float = -85.0,
                 cs_threshold_dbm: float | None = None, capture_db: float = 10.0, noise_dbm: float | None = None,
                 **kw):
        super().__init__(sim, name, data_rate=data_rate, max_frame_bits=max_frame_bits, path_loss=path_loss,
                         tx_power_dbm=tx_power_dbm, threshold_dbm=threshold_dbm, cs_threshold_dbm=cs_threshold_dbm,
                         capture_db=capture_db, noise_dbm=noise_dbm, **kw)
        w = f"network {name!r}"
        # macMinBE/macMaxBE: 2**BE - 1 unit periods must stay a sane integer (the standard allows 0..8)
        self.min_be = validate.count(min_be, f"{w}: min_be", minimum=0, maximum=30)
        self.max_be = validate.count(max_be, f"{w}: max_be", minimum=0, maximum=30)
        if not self.min_be <= self.max_be:
            raise ConfigurationError(f"{w}: min_be={min_be!r} exceeds max_be={max_be!r}")
        self.max_csma_backoffs = validate.count(max_csma_backoffs, f"{w}: max_csma_backoffs", minimum=0)
        self.max_frame_retries = validate.count(max_frame_retries, f"{w}: max_frame_retries", minimum=0)
        self.use_ack = bool(ack)
        self.mac_overhead_bits = validate.bits(mac_overhead_bits, f"{w}: mac_overhead_bits")
        sym = to_ticks(SYMBOL)
        self.unit = 20 * sym
        self.cca = 8 * sym
        self.turnaround = 12 * sym
        self.shr = self.duration(48)
        self.ack_time = self.shr + self.duration(40)
        self.ack_wait = 54 * sym
        self.sifs, self.lifs = 12 * sym, 40 * sym
        self.mod = Modulation("oqpsk", self.data_rate, ber_oqpsk, bandwidth=self.data_rate)
        self._ack_mod = self.mod
        self._ack_plcp = 0
        self._ack_delay = self.turnaround
        self.ack_bits = 40
        self.max_attempts = self.max_frame_retries + 1
        self._ack_timeout_ticks = self.ack_wait

    def default_noise_dbm(self) -> float:
        """Thermal noise in the 2 MHz channel at 290 K (dBm)."""
        return thermal_noise_dbm(2e6)

    def frame_time(self, size_bits: int) -> int:
        """Time on air (ticks) of a data frame with *size_bits* bits of payload."""
        return self.shr + self.duration(self.mac_overhead_bits + self.wire_bits(size_bits))

    # ------------------------------------------------------------------ CSMA/CA (r: the CsmaCaStation)
    def _kick(self, iface) -> None:
        if self._next_frame(iface) is not None:
            self._csma_start(iface.mac)

    def _csma_start(self, r) -> None:
        now = self._env.now
        if r.ifs_until > now:
            self.sim._call_at_ticks(r.ifs_until, self._csma_start, arg=r)
            return
        r.nb, r.be = 0, self.min_be
        self._backoff(r)

    def _backoff(self, r) -> None:
        k = int(r.rng.integers(0, 2 ** r.be))
        r.bo_drawn = k
        self.sim.call_in_ticks(k * self.unit, self._cca_start, arg=r)

    def _cca_start(self, r) -> None:
        r.in_cca = True
        r.cca_busy = bool(r.audible or r.tx is not None or r.responding)
        self.sim.call_in_ticks(self.cca, self._cca_end, arg=r)

    def _cca_end(self, r) -> None:
        r.in_cca = False
        if r.cca_busy or r.audible or r.tx is not None or r.responding:
            r.nb += 1
            r.be = min(r.be + 1, self.max_be)
            if r.nb > self.max_csma_backoffs:
                r.iface.attempt.fail("channel_access")
                self._frame_dropped(r, "channel_access")
                return
            self._backoff(r)
            return
        self.sim.call_in_ticks(self.turnaround, self._transmit, arg=r)

    def _transmit(self, r) -> None:
        if r.tx is not None:            # busy sending an ACK: start over
            self._backoff(r)
            return
        f = r.iface.current
        bits = self.mac_overhead_bits + f.bits
        self.begin_attempt(r.iface, f, bits, r.bo_drawn)
        now = self._env.now
        tx = Transmission(r, "data", f, f.dst if f.dst is BROADCAST else f.dst.mac, now,
                          now + self.shr + self.duration(bits), now, self.mod)
        self._start_tx(r, tx)

    def _ifs(self, bits) -> int:
        return self.sifs if bits <= 18 * 8 else self.lifs

    def _frame_sent(self, r) -> None:
        r.ifs_until = self._env.now + self._ifs(self.mac_overhead_bits + r.iface.current.bits)
        r.iface.attempt.finish()

    def _retry(self, r) -> None:
        self._csma_start(r)

    # ------------------------------------------------------------------ medium callbacks
    def _reeval(self, r) -> None:
        if r.in_cca and r.audible:
            r.cca_busy = True

    def _rx_end(self, r, tx, ok, reason, locked) -> None:
        f = tx.frame
        if tx.kind == "data":
            if tx.dst is r:
                if not ok:
                    tx.dst_reason = reason
                    if not self.use_ack:
                        self._lost(f, r.iface, reason)
                else:
                    self._receive_unicast(r, tx, self.use_ack)
            elif tx.dst is BROADCAST:
                if ok:
                    tx.src.iface.attempt.deliver(r.iface)   # the sender's attempt is still on
                else:
                    self._lost(f, r.iface, reason)
        elif ok and tx.dst is r and r.awaiting is not None and r.awaiting.frame is f:
            self._ack_ok(r)
            return
        if r.ack_wait and r.awaiting is not None and r.rx is None:
            self._ack_fail(r)
