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

from ..errors import ConfigurationError, ConfigurationTypeError
from ..timebase import to_ticks
from .checks import check_bits, check_count, check_finite, check_non_negative
from .frame import BROADCAST
from .interface import Interface
from .medium import RadioNetwork, Transmission, WirelessMedium
from .radio import LogDistance, Modulation, PathLoss, as_position, db_to_ratio, dbm_to_watt, thermal_noise_dbm

SYMBOL = 16e-6
_K = np.arange(2, 17)
_COEF = (-1.0) ** _K * np.array([math.comb(16, int(k)) for k in _K], dtype=float)

def ber_oqpsk(sinr):
    """802.15.4 2.4 GHz O-QPSK bit error rate as a function of the (linear) SINR."""
    s = np.atleast_1d(np.asarray(sinr, dtype=float))
    terms = _COEF[None, :] * np.exp(20.0 * s[:, None] * (1.0 / _K[None, :] - 1.0))
    ber = np.clip(8.0 / 15.0 / 16.0 * terms.sum(axis=1), 0.0, 0.5)
    return float(ber[0]) if np.ndim(sinr) == 0 else ber

class IEEE802154(RadioNetwork):
    """IEEE 802.15.4 network, unslotted CSMA/CA.  See the module docstring.

    Radio parameters as for :class:`~netcosim.network.wlan.WLAN80211b` (defaults:
    0 dBm transmit power, -85 dBm threshold, thermal noise in 2 MHz, log-distance path
    loss with exponent 3).  ``ack=False`` sends unicast frames without acknowledgement.
    ``min_be <= max_be`` (0..30), ``max_csma_backoffs`` and ``max_frame_retries`` are
    integers >= 0, ``mac_overhead_bits`` an integer >= 0; powers and thresholds (also
    per node in ``attach``) finite dBm, ``capture_db`` finite and >= 0.
    """

    def __init__(self, sim, name, *, data_rate: float = 250e3, min_be: int = 3, max_be: int = 5,
                 max_csma_backoffs: int = 4, max_frame_retries: int = 3, ack: bool = True,
                 mac_overhead_bits: int = 88, max_frame_bits: int | None = 116 * 8,
                 path_loss: PathLoss | None = None, tx_power_dbm: float = 0.0, threshold_dbm: float = -85.0,
                 cs_threshold_dbm: float | None = None, capture_db: float = 10.0, noise_dbm: float | None = None,
                 **kw):
        super().__init__(sim, name, data_rate=data_rate, max_frame_bits=max_frame_bits, **kw)
        w = f"network {name!r}"
        # macMinBE/macMaxBE: 2**BE - 1 unit periods must stay a sane integer (the standard allows 0..8)
        self.min_be = check_count(min_be, f"{w}: min_be", minimum=0, maximum=30)
        self.max_be = check_count(max_be, f"{w}: max_be", minimum=0, maximum=30)
        if not self.min_be <= self.max_be:
            raise ConfigurationError(f"{w}: min_be={min_be!r} exceeds max_be={max_be!r}")
        self.max_csma_backoffs = check_count(max_csma_backoffs, f"{w}: max_csma_backoffs", minimum=0)
        self.max_frame_retries = check_count(max_frame_retries, f"{w}: max_frame_retries", minimum=0)
        self.use_ack = bool(ack)
        self.mac_overhead_bits = check_bits(mac_overhead_bits, f"{w}: mac_overhead_bits")
        sym = to_ticks(SYMBOL)
        self.unit = 20 * sym
        self.cca = 8 * sym
        self.turnaround = 12 * sym
        self.shr = self.duration(48)
        self.ack_time = self.shr + self.duration(40)
        self.ack_wait = 54 * sym
        self.sifs, self.lifs = 12 * sym, 40 * sym
        self.tx_power_dbm = check_finite(tx_power_dbm, f"{w}: tx_power_dbm", "dBm")
        self.threshold_dbm = check_finite(threshold_dbm, f"{w}: threshold_dbm", "dBm")
        self.cs_threshold_dbm = (self.threshold_dbm if cs_threshold_dbm is None
                                 else check_finite(cs_threshold_dbm, f"{w}: cs_threshold_dbm", "dBm"))
        self.capture_db = check_non_negative(capture_db, f"{w}: capture_db (dB)")
        self.noise_dbm = (thermal_noise_dbm(2e6) if noise_dbm is None
                          else check_finite(noise_dbm, f"{w}: noise_dbm", "dBm"))
        if path_loss is None:
            path_loss = LogDistance(3.0)
        if not isinstance(path_loss, PathLoss):
            raise ConfigurationTypeError(f"{w}: path_loss must be a PathLoss model, got {path_loss!r}")
        self.path_loss = path_loss
        self.mod = Modulation("oqpsk", self.data_rate, ber_oqpsk, bandwidth=self.data_rate)
        self.medium = WirelessMedium(self, path_loss=self.path_loss, noise_w=dbm_to_watt(self.noise_dbm),
                                     capture_ratio=db_to_ratio(self.capture_db))

    # ------------------------------------------------------------------ attach
    def attach(self, node, *, position=(0.0, 0.0), tx_power_dbm: float | None = None,
               threshold_dbm: float | None = None, cs_threshold_dbm: float | None = None, **kw) -> Interface:
        """Attach *node* at *position* (point in m or callable ``p(t)``)."""
        return super().attach(node, position=position, tx_power_dbm=tx_power_dbm, threshold_dbm=threshold_dbm,
                              cs_threshold_dbm=cs_threshold_dbm, **kw)

    def _make_interface(self, name, node, index, options, **common):
        opts = dict(options)
        pos, txp = opts.pop("position"), opts.pop("tx_power_dbm")
        thr, cst = opts.pop("threshold_dbm"), opts.pop("cs_threshold_dbm")
        if opts:
            raise ConfigurationTypeError(f"network {self.name!r}: unknown attach option(s) {sorted(opts)}")
        w = f"network {self.name!r} node {name!r}"
        txp = self.tx_power_dbm if txp is None else check_finite(txp, f"{w}: tx_power_dbm", "dBm")
        thr = self.threshold_dbm if thr is None else check_finite(thr, f"{w}: threshold_dbm", "dBm")
        cst = self.cs_threshold_dbm if cst is None else check_finite(cst, f"{w}: cs_threshold_dbm", "dBm")
        r = Interface(self, name, node, index, **common)
        r.pos = as_position(pos, w)
        r.tx_power_dbm = txp
        r.tx_w = dbm_to_watt(txp)
        r.sens_w = dbm_to_watt(thr)
        r.cs_w = dbm_to_watt(cst)
        r.nb = r.be = 0
        r.in_cca = False
        r.cca_busy = False
        r.awaiting = None
        r.ack_timer = None
        r.ack_wait = False
        r.responding = 0
        r.ifs_until = 0
        r.last_seq = {}
        r.bo_drawn = math.nan
        r.rng = self.sim.rng(f"{self.name}/{name}/backoff")
        self.medium.init_listener(r)
        return r

    def frame_time(self, size_bits: int) -> int:
        """Ticks on air of a data frame with *size_bits* of payload."""
        return self.shr + self.duration(self.mac_overhead_bits + self.wire_bits(size_bits))

    # ------------------------------------------------------------------ CSMA/CA
    def _kick(self, r) -> None:
        if r.current is None and r.queue._q:
            r.current = r.queue.pop()
            self._csma_start(r)

    def _csma_start(self, r) -> None:
        now = self._env._now
        if r.ifs_until > now:
            self.sim.call_at_ticks(r.ifs_until, self._csma_start, arg=r)
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
                f = r.current
                self._trace("attempt_end", f, r.name, "channel_access")
                self._lost(f, r, "channel_access")
                self._done(r, f, False)
                return
            self._backoff(r)
            return
        self.sim.call_in_ticks(self.turnaround, self._transmit, arg=r)

    def _transmit(self, r) -> None:
        if r.tx is not None:            # busy sending an ACK: start over
            self._backoff(r)
            return
        f = r.current
        f.attempts += 1
        now = self._env._now
        f.sent = now
        air = self.shr + self.duration(self.mac_overhead_bits + f.bits)
        tx = Transmission(r, "data", f, f.dst, now, now + air, now, self.mod)
        self._trace("attempt_start", f, r.name, bits=self.mac_overhead_bits + f.bits, backoff=r.bo_drawn)
        self._start_tx(r, tx)

    def _start_tx(self, r, tx) -> None:
        r.tx = tx
        r.sending = 1
        r._state()
        self.medium.start(tx)
        self.sim.call_at_ticks(tx.end, self._tx_end, arg=tx)

    def _ifs(self, bits) -> int:
        return self.sifs if bits <= 18 * 8 else self.lifs

    def _tx_end(self, tx) -> None:
        r = tx.src
        self.medium.end(tx)
        r.tx = None
        r.sending = 0
        if tx.kind == "data":
            f = tx.frame
            if f.dst is BROADCAST or not self.use_ack:
                self._trace("attempt_end", f, r.name, "sent")
                r.ifs_until = self._env._now + self._ifs(self.mac_overhead_bits + f.bits)
                self._done(r, f, True)
            else:
                r.awaiting = tx
                r.ack_wait = False
                r.ack_timer = self.sim.call_in_ticks(self.ack_wait, self._ack_timeout, arg=r)
        else:
            r.responding -= 1
        r._state()

    def _done(self, r, f, ok) -> None:
        r.current = None
        self._finish(f, ok)
        r._state()
        self._kick(r)

    def _ack_timeout(self, r) -> None:
        r.ack_timer = None
        if r.awaiting is None:
            return
        if r.rx is not None:
            r.ack_wait = True
            return
        self._ack_fail(r)

    def _ack_fail(self, r) -> None:
        tx, r.awaiting, r.ack_wait = r.awaiting, None, False
        f = tx.frame
        self._trace("attempt_end", f, r.name, tx.dst_reason or ("ack_lost" if tx.acked else "no_ack"))
        if f.attempts > self.max_frame_retries:
            self._lost(f, r, "retry_limit")
            self._done(r, f, False)
        else:
            self._csma_start(r)

    def _ack_ok(self, r) -> None:
        tx, r.awaiting, r.ack_wait = r.awaiting, None, False
        if r.ack_timer is not None:
            r.ack_timer.cancel()
            r.ack_timer = None
        f = tx.frame
        self._trace("attempt_end", f, r.name, "ok")
        r.ifs_until = self._env._now + self._ifs(self.mac_overhead_bits + f.bits)
        self._done(r, f, True)

    # ------------------------------------------------------------------ medium callbacks
    def _reeval(self, r) -> None:
        if r.in_cca and r.audible:
            r.cca_busy = True

    def _rx_end(self, r, tx, ok, reason, locked) -> None:
        f = tx.frame
        if tx.kind == "data":
            if f.dst is r:
                if not ok:
                    tx.dst_reason = reason
                elif self.loss is not None and self._link(f.src, r).lost():
                    tx.dst_reason = "random_loss"
                    if not self.use_ack:
                        self._lost(f, r, "random_loss")
                else:
                    tx.acked = self.use_ack
                    if r.last_seq.get(f.src.index) != f.seq:
                        r.last_seq[f.src.index] = f.seq
                        self._deliver(f, r, apply_loss=False)
                    if self.use_ack and r.tx is None:
                        r.responding += 1
                        self.sim.call_in_ticks(self.turnaround, self._send_ack, arg=tx)
                if not ok and not self.use_ack:
                    self._lost(f, r, reason)
            elif f.dst is BROADCAST:
                if ok:
                    self._deliver(f, r, apply_loss=True)
                else:
                    self._lost(f, r, reason)
        elif ok and tx.dst is r and r.awaiting is not None and r.awaiting.frame is f:
            self._ack_ok(r)
            return
        if r.ack_wait and r.awaiting is not None and r.rx is None:
            self._ack_fail(r)

    def _send_ack(self, data_tx) -> None:
        r = data_tx.dst
        if r.tx is not None:
            r.responding -= 1
            return
        now = self._env._now
        ack = Transmission(r, "ack", data_tx.frame, data_tx.src, now, now + self.ack_time, now, self.mod)
        self._trace("ack", data_tx.frame, r.name, bits=40)
        self._start_tx(r, ack)
