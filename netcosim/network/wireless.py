"""Radio networks: what 802.11b and 802.15.4 share above the medium.

:class:`RadioNetwork` holds the radio parameters (path loss, transmit power, receiver and
carrier-sense thresholds, capture ratio, noise floor: powers in dBm, validated once),
attaches stations at a ``position`` (a 2-D/3-D point in m, or a callable ``p(t)`` of
seconds), keeps one :class:`RadioStation` per interface (``iface.mac``, also in
``self._stations`` by interface index) and runs the unicast ACK/retry exchange.

A wireless MAC subclasses it and provides:

* ``station_class`` -- a :class:`RadioStation` subclass declaring the MAC's own
  per-station state;
* ``_kick(iface)`` (base :class:`~netcosim.network.base.Network`) -- start medium access;
* ``_reeval(r)`` -- the medium's view of station *r* changed (carrier sense);
* ``_rx_end(r, tx, ok, reason, locked)`` -- *tx* ended at listener *r*;
* ``_retry(r)`` -- the ACK did not come and attempts remain;
* optionally ``_frame_sent(r)`` / ``_frame_dropped(r, reason)`` -- the station is done
  with its frame, sent (acknowledged) or given up (default: ``r.iface.attempt.finish()`` /
  ``.drop(reason)``, the life cycle of :mod:`netcosim.network.lifecycle`);
* attributes ``use_ack``, ``max_attempts`` (transmissions of a unicast frame),
  ``_ack_timeout_ticks`` (from the end of a data frame), ``_ack_delay`` (ticks from
  the end of a data frame to its ACK), ``ack_time``, ``ack_bits``, ``_ack_plcp`` and
  ``_ack_mod`` for :meth:`RadioNetwork._send_ack`.

A data frame goes through the life cycle of every MAC (:class:`~netcosim.network.lifecycle.Attempt`):
``begin_attempt`` as it goes on the air, ``deliver`` at each listener that decoded a
broadcast (while the attempt is still on), ``end`` when it left the air (broadcast,
unacknowledged) or when its ACK came or did not, then ``finish``, ``drop`` or a retry.
The carrier is the medium's (``carrier = CARRIER_MEDIUM``): :meth:`RadioNetwork._start_tx`
and the medium's locks turn ``sending`` and ``receiving`` on and off, for the ACKs too.
"""

from __future__ import annotations

import math
from typing import Any

from .. import validate
from ..clock import Timer
from ..energy import BareOwner, PowerMeter, check_radio_model
from ..errors import ConfigurationError, ConfigurationTypeError
from .base import Network
from .frame import BROADCAST
from .interface import Interface
from .lifecycle import CARRIER_MEDIUM
from .medium import Transmission, WirelessMedium
from .radio import LogDistance, PathLoss, as_position, db_to_ratio, dbm_to_watt, watt_to_dbm

#: The largest power (dBm, either sign) and gain (dB) a radio parameter may have: far beyond
#: any radio (+-300 dBm is 1e27 W / 1e-33 W), yet the powers in watts stay normal floats
#: (1e300 dBm overflows, -1e300 dBm is 0 W and divides the SINR by zero).
MAX_DB = 300.0


def _dbm(value, what: str) -> float:
    """A power in dBm, finite and within +-:data:`MAX_DB`."""
    v = validate.finite(value, what, "dBm")
    if abs(v) > MAX_DB:
        raise ConfigurationError(f"{what} must be within +-{MAX_DB:g} dBm, got {value!r}")
    return v


class RadioStation:
    """One interface on a radio network: radio parameters, listener state, ACK state.

    Radio (fixed at attach): ``pos`` (point in m or callable), ``tx_power_dbm``, and in
    watts ``tx_w`` (transmit power), ``sens_w`` (receiver threshold), ``cs_w``
    (carrier-sense threshold).  Listener state (kept by the
    :class:`~netcosim.network.medium.WirelessMedium`): ``power`` (W on the air here),
    ``n_active``, ``audible`` (transmissions above ``cs_w``), ``rx`` (locked frame),
    ``rx_ok``/``rx_reason``, ``seg_t``/``logp`` (bit-error accounting), ``tx`` (own
    transmission), ``phy_rng`` (stream ``<net>/phy/<node>``).  ACK state: ``awaiting``
    (own data frame waiting for its ACK), ``ack_timer``, ``ack_wait`` (timeout passed
    during a reception), ``responding`` (ACKs scheduled), ``last_seq`` (duplicate
    detection per sender index), ``rng`` (backoff stream ``<net>/<node>/backoff``),
    ``bo_drawn`` (backoff slots drawn before the next attempt, for the trace).
    ``net``: the network; ``iface``: the station's interface; ``pos``, ``tx_power_dbm``
    (dBm), ``sens_w``, ``cs_w`` (W): its radio parameters, checked by
    :meth:`RadioNetwork.attach`.

    Examples
    --------
    A network makes one per attached node (:meth:`RadioNetwork.station`).  At 0 dBm a
    station sends 1 mW; 10 dB less power is 10 dB less at the receiver:

    >>> from netcosim import Simulation
    >>> from netcosim.network import IEEE802154
    >>> sim = Simulation(seed=0)
    >>> net = IEEE802154(sim, "zigbee")
    >>> _ = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(10.0, 0.0))
    >>> station = net.station("a")
    >>> station.tx_power_dbm, round(station.tx_w, 9)                     # dBm, W
    (0.0, 0.001)
    >>> before = net.rx_power_dbm("a", "b")
    >>> station.set_tx_power(-10.0)
    >>> round(before, 2), round(net.rx_power_dbm("a", "b"), 2)           # dBm at b
    (-70.1, -80.1)
    """

    __slots__ = ("iface", "name", "index", "pos", "tx_power_dbm", "tx_w", "sens_w", "cs_w", "power", "n_active",
                 "audible", "rx", "rx_ok", "rx_reason", "seg_t", "logp", "tx", "phy_rng", "awaiting", "ack_timer",
                 "ack_wait", "responding", "last_seq", "rng", "bo_drawn", "off", "meter", "rstate")

    def __init__(self, net: "RadioNetwork", iface: Interface, pos, tx_power_dbm: float, sens_w: float,
                 cs_w: float):
        self.iface = iface
        self.name = iface.name
        self.index = iface.index
        self.pos = pos
        self.tx_power_dbm = tx_power_dbm
        self.tx_w = dbm_to_watt(tx_power_dbm)
        self.sens_w = sens_w
        self.cs_w = cs_w
        self.power = 0.0
        self.n_active = 0
        self.audible = 0
        self.rx = None
        self.rx_ok = False
        self.rx_reason = None
        self.seg_t = 0
        self.logp = 0.0
        self.tx: Transmission | None = None
        self.phy_rng = net.sim.rng(f"{net.name}/phy/{iface.name}")
        self.awaiting: Transmission | None = None
        self.ack_timer: Timer | None = None
        self.ack_wait = False
        self.responding = 0
        self.last_seq: dict = {}
        self.rng = net.sim.rng(f"{net.name}/{iface.name}/backoff")
        self.bo_drawn = math.nan
        #: why the station neither sends nor receives (``"battery_empty"``), None while it works
        self.off: str | None = None
        self.meter: Any = None      # its PowerMeter when the network meters radio energy
        self.rstate = "listen"      # its metered state: "tx", "rx" or "listen"

    def set_tx_power(self, dbm: float) -> None:
        """Transmit with *dbm* (finite, within +-300 dBm) from the next frame (data or ACK) on;
        a frame already on the air keeps its power.

        Raises :class:`~netcosim.errors.ConfigurationError` for a *dbm* out of range, and on
        an 802.11b network that runs the shared idle-slot clock (``shared_clock=True``,
        which assumes fixed powers; build it with ``shared_clock=False``)."""
        net = self.iface.network
        txp = _dbm(dbm, f"network {net.name!r} node {self.name!r}: tx_power_dbm")
        net._require_per_station("set_tx_power")
        if self.off is not None:
            return
        self.tx_power_dbm = txp
        self.tx_w = dbm_to_watt(txp)
        net.medium.forget(self)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.iface.network.name}/{self.name}>"


class RadioNetwork(Network):
    """Base class of the wireless MACs (see the module docstring).

    Radio parameters (validated here; also per node in :meth:`attach`): ``path_loss`` (a
    :class:`~netcosim.network.radio.PathLoss`, default log-distance with exponent 3),
    ``tx_power_dbm``, ``threshold_dbm`` (receiver sensitivity, and carrier sense unless
    ``cs_threshold_dbm`` is given), ``capture_db`` (finite, >= 0), ``noise_dbm`` (default
    the thermal noise of the subclass's channel, :meth:`default_noise_dbm`).  ``loss``
    (the frame loss model, as :class:`Network`'s) is drawn at the destination before it
    acknowledges (:meth:`frame_lost`).

    Each subclass sets the ACK/retry parameters the shared code reads: ``use_ack``,
    ``max_attempts`` (attempts per frame), ``ack_bits``, and in ticks ``ack_time`` (ACK on
    the air), ``_ack_plcp`` (its preamble), ``_ack_delay`` (reception end to ACK start),
    ``_ack_timeout_ticks``; ``_ack_mod`` is the ACK's modulation.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationTypeError`
        ``path_loss`` is not a :class:`~netcosim.network.radio.PathLoss`; a power, threshold
        or ratio that is not a number; *sim* not a :class:`~netcosim.Simulation`.
    :class:`~netcosim.errors.ConfigurationError`
        ``tx_power_dbm``, ``threshold_dbm``, ``cs_threshold_dbm`` or ``noise_dbm`` not
        finite or beyond +-300 dBm; ``capture_db`` negative, not finite or above 300 dB;
        a common parameter out of range (:class:`~netcosim.network.base.Network`).

    Examples
    --------
    Both radio networks derive from ``RadioNetwork``.  The power received 10 m away from a
    15 dBm sender under log-distance path loss (exponent 3, 40.1 dB at 1 m) is
    ``15 - 40.1 - 30 log10(10)`` = -55.1 dBm, above the -85 dBm threshold:

    >>> from netcosim import Simulation
    >>> from netcosim.network import LogDistance, RadioNetwork, WLAN80211b
    >>> sim = Simulation(seed=0)
    >>> net = WLAN80211b(sim, "wlan", tx_power_dbm=15.0, path_loss=LogDistance(exponent=3.0))
    >>> isinstance(net, RadioNetwork)
    True
    >>> _ = net.attach("a", position=(0.0, 0.0)), net.attach("b", position=(10.0, 0.0))
    >>> round(net.rx_power_dbm("a", "b"), 2), round(15.0 - LogDistance(3.0).loss_db(10.0), 2)
    (-55.1, -55.1)
    >>> net.position("b"), round(net.noise_dbm, 2)                      # m, dBm
    ((10.0, 0.0), -100.55)
    """

    use_ack: bool
    max_attempts: int
    ack_bits: int
    ack_time: int
    _ack_plcp: int
    _ack_delay: int
    _ack_timeout_ticks: int
    _ack_mod: Any

    station_class = RadioStation
    #: the medium owns the carrier: power on the air, per-listener reception and lock
    carrier = CARRIER_MEDIUM

    def __init__(self, sim, name, *, path_loss: PathLoss | None = None, tx_power_dbm: float,
                 threshold_dbm: float, cs_threshold_dbm: float | None = None, capture_db: float = 10.0,
                 noise_dbm: float | None = None, loss: Any = None, **kw):
        super().__init__(sim, name, loss=loss, **kw)
        w = f"network {name!r}"
        self._stations: list[RadioStation] = []
        if path_loss is None:
            path_loss = LogDistance(3.0)
        if not isinstance(path_loss, PathLoss):
            raise ConfigurationTypeError(f"{w}: path_loss must be a PathLoss model, got {path_loss!r}")
        self.path_loss = path_loss
        self.tx_power_dbm = _dbm(tx_power_dbm, f"{w}: tx_power_dbm")
        self.threshold_dbm = _dbm(threshold_dbm, f"{w}: threshold_dbm")
        self.cs_threshold_dbm = (self.threshold_dbm if cs_threshold_dbm is None
                                 else _dbm(cs_threshold_dbm, f"{w}: cs_threshold_dbm"))
        self.capture_db = validate.non_negative(capture_db, f"{w}: capture_db (dB)")
        if self.capture_db > MAX_DB:
            raise ConfigurationError(f"{w}: capture_db (dB) must be at most {MAX_DB:g} dB, got {capture_db!r}")
        self.noise_dbm = (self.default_noise_dbm() if noise_dbm is None
                          else _dbm(noise_dbm, f"{w}: noise_dbm"))
        self.medium = WirelessMedium(self, path_loss=path_loss, noise_w=dbm_to_watt(self.noise_dbm),
                                     capture_ratio=db_to_ratio(self.capture_db))
        # what puts a transmission on the air and takes it off (a MAC may use a faster equivalent)
        self._air_start = self.medium.start
        self._air_end = self.medium.end
        #: unicast attempts that failed by a collision at the destination
        self.collisions = 0

    def default_noise_dbm(self) -> float:
        """Noise floor (dBm) when ``noise_dbm`` is not given."""
        raise NotImplementedError

    # ------------------------------------------------------------------ stations
    def attach(self, node, *, position=(0.0, 0.0), tx_power_dbm: float | None = None,
               threshold_dbm: float | None = None, cs_threshold_dbm: float | None = None, **kw) -> Interface:
        """Attach *node* at *position* (2-D/3-D point in m, or a callable ``p(t)`` of seconds,
        evaluated at the start of every transmission).  Radio parameters (dBm) default to
        the network's: ``tx_power_dbm`` (transmit power), ``threshold_dbm`` (receiver
        sensitivity: weaker frames are not decoded), ``cs_threshold_dbm`` (carrier sense:
        the channel is busy above it; default the network's, not this node's threshold)."""
        return super().attach(node, position=position, tx_power_dbm=tx_power_dbm, threshold_dbm=threshold_dbm,
                              cs_threshold_dbm=cs_threshold_dbm, **kw)

    def _station(self, iface, options) -> RadioStation:
        pos = options.pop("position")
        txp = options.pop("tx_power_dbm")
        thr = options.pop("threshold_dbm")
        cst = options.pop("cs_threshold_dbm")
        if options:
            raise ConfigurationTypeError(f"network {self.name!r}: unknown attach option(s) {sorted(options)}")
        w = f"network {self.name!r} node {iface.name!r}"
        pos = as_position(pos, w)
        txp = self.tx_power_dbm if txp is None else _dbm(txp, f"{w}: tx_power_dbm")
        sens = dbm_to_watt(self.threshold_dbm if thr is None else _dbm(thr, f"{w}: threshold_dbm"))
        cs = dbm_to_watt(self.cs_threshold_dbm if cst is None else _dbm(cst, f"{w}: cs_threshold_dbm"))
        r = self.station_class(self, iface, pos, txp, sens, cs)
        self.medium.init_listener(r)
        self._stations.append(r)
        if getattr(self, "_energy_model", None) is not None:
            self._meter(r)
        return r

    def station(self, node) -> RadioStation:
        """The radio station (MAC state) of *node* (name, kernel node or interface)."""
        return self.interface(node).mac     # set by _station at attach

    def position(self, node, t: float | None = None):
        """Position of *node* at time *t* (s; default now)."""
        return self.medium._position(self.station(node), self.sim.now if t is None else t)

    def rx_power_dbm(self, src, dst) -> float:
        """Power (dBm) at *dst* of a transmission by *src* starting now."""
        s, d = self.station(src), self.station(dst)
        return watt_to_dbm(self.medium.powers_from(s)[d.index])

    def set_tx_power(self, node, dbm: float) -> None:
        """Transmit power *dbm* (dBm, finite) of *node* (name, kernel node or interface) from its next frame on
        (:meth:`RadioStation.set_tx_power`); e.g. from task code, transmit-power control."""
        self.station(node).set_tx_power(dbm)

    def tx_power(self, node) -> float:
        """Current transmit power (dBm) of *node*."""
        return self.station(node).tx_power_dbm

    # ------------------------------------------------------------------ energy
    def _require_per_station(self, what: str) -> None:
        """Run-time changes of radio parameters need the per-station medium (802.11b's shared
        idle-slot clock assumes fixed powers)."""
        if getattr(self, "_fast", False):
            raise ConfigurationError(f"network {self.name!r}: {what} changes radio powers during the run, which "
                                     f"the shared idle-slot clock cannot follow; build the network with "
                                     f"shared_clock=False")

    def set_energy_model(self, model: Any) -> None:
        """Meter the energy of every station's radio with *model* (``model.power(state, tx_w)``:
        :class:`~netcosim.energy.RadioPower`, or ``RadioPower.truetime()``), from now on and for
        stations attached later; the energy is drawn from each node's battery and shows in
        ``node.energy`` and the ``energy`` table (source: this network's name)."""
        model = check_radio_model(model, f"network {self.name!r}")
        self._require_per_station("set_energy_model")
        first = getattr(self, "_energy_model", None) is None
        self._energy_model = model
        if first:
            start, end = self._air_start, self._air_end

            def air_start(tx: Transmission) -> None:
                start(tx)
                self._meter_states(None)

            def air_end(tx: Transmission) -> None:
                end(tx)
                self._meter_states(tx.src)      # still ``tx`` until _tx_end clears it

            self._air_start, self._air_end = air_start, air_end
        for r in self._stations:
            self._meter(r)

    def _meter(self, r: RadioStation) -> None:
        model = self._energy_model
        if r.meter is None:
            r.rstate = "tx" if r.tx is not None else "rx" if r.rx is not None else "listen"
            owner = r.iface.node if r.iface.node is not None else BareOwner(self.sim, r.name)
            r.meter = PowerMeter(owner, self.name, model.power(r.rstate, r.tx_w))
        else:
            r.meter.set(model.power(r.rstate, r.tx_w))

    def _meter_states(self, ending: RadioStation | None) -> None:
        """Set the power of every station whose radio state changed (at an air start or end)."""
        model = self._energy_model
        for r in self._stations:
            m = r.meter
            if m is None:
                continue
            st = ("tx" if r.tx is not None and r is not ending else "rx" if r.rx is not None else "listen")
            if st != r.rstate:
                r.rstate = st
                p = model.power(st, r.tx_w)
                if p != m.power:
                    m.set(p)

    def _power_off(self, iface: Interface) -> None:
        """*iface*'s node ran out of energy: its radio goes deaf (frames to it are lost, reason
        ``battery_empty``) and mute (what it still sends radiates 0 W and reaches nobody)."""
        self._require_per_station("a battery running empty")
        r = iface.mac
        r.off = "battery_empty"
        r.tx_w = 0.0
        r.sens_w = r.cs_w = math.inf
        self.medium.forget(r)
        if r.meter is not None:
            r.meter.stop()

    # ------------------------------------------------------------------ transmissions and ACKs
    def _start_tx(self, r: RadioStation, tx: Transmission) -> None:
        """Station *r* puts *tx* on the air until ``tx.end``."""
        r.tx = tx
        r.iface.sending = 1
        r.iface._state()
        self._air_start(tx)
        self.sim._call_at_ticks(tx.end, self._tx_end, arg=tx)

    def _tx_end(self, tx: Transmission) -> None:
        """*tx* left the air: an ACK is done, a broadcast (or unacknowledged) data frame is
        sent, a unicast data frame waits for its ACK."""
        r = tx.src
        self._air_end(tx)
        r.tx = None
        r.iface.sending = 0
        if tx.kind != "data":
            r.responding -= 1
        elif tx.dst is BROADCAST or not self.use_ack:
            r.iface.attempt.end("sent")
            self._frame_sent(r)
        else:
            self._await_ack(r, tx, self._ack_timeout_ticks)
        r.iface._state()
        self._reeval(r)

    def _frame_sent(self, r: RadioStation) -> None:
        """Hook: *r*'s attempt ended well (acknowledged, or sent unacknowledged): done with
        its frame."""
        r.iface.attempt.finish()

    def _frame_dropped(self, r: RadioStation, reason: str) -> None:
        """Hook: *r* gives its frame up after a failed attempt (``lost`` row *reason*)."""
        r.iface.attempt.drop(reason)

    def _retry(self, r: RadioStation) -> None:
        """Hook: the ACK for *r*'s current frame did not come; try again."""
        raise NotImplementedError

    def _await_ack(self, r: RadioStation, tx: Transmission, timeout: int) -> None:
        """*r* sent the unicast data frame *tx*: wait *timeout* ticks for its ACK to begin."""
        r.awaiting = tx
        r.ack_wait = False
        r.ack_timer = self.sim.call_in_ticks(timeout, self._ack_timeout, arg=r)

    def _ack_timeout(self, r: RadioStation) -> None:
        r.ack_timer = None
        if r.awaiting is None:
            return
        if r.rx is not None:          # a reception began within the timeout: wait for its end
            r.ack_wait = True
            return
        self._ack_fail(r)
        self._reeval(r)

    def _stop_waiting(self, r: RadioStation) -> Transmission:
        """End the ACK wait of *r*; returns the data transmission it was for."""
        tx = r.awaiting
        assert tx is not None  # called only while r waits for an ACK
        r.awaiting = None
        r.ack_wait = False
        if r.ack_timer is not None:
            r.ack_timer.cancel()
            r.ack_timer = None
        return tx

    def _ack_ok(self, r: RadioStation) -> None:
        self._stop_waiting(r)
        r.iface.attempt.end()
        self._frame_sent(r)
        r.iface._state()

    def _ack_fail(self, r: RadioStation) -> None:
        """No (intact) ACK: the attempt failed for the reason the destination missed the frame
        (``ack_lost`` if it did receive it); retry, or drop after ``max_attempts``."""
        tx = self._stop_waiting(r)
        f = tx.frame
        reason = tx.dst_reason or ("ack_lost" if tx.acked else "no_ack")
        if reason == "collision":
            self.collisions += 1
        r.iface.attempt.end(reason)
        if f.attempts >= self.max_attempts:
            self._frame_dropped(r, "retry_limit")
        else:
            self._retry(r)
        r.iface._state()

    def _receive_unicast(self, r: RadioStation, tx: Transmission, ack: bool) -> None:
        """*r* decoded the data frame *tx* addressed to it: draw the link loss (a frame lost
        so is not acknowledged), deliver it once (duplicates are acknowledged but not
        delivered again), and answer with an ACK after ``_ack_delay`` if *ack*."""
        f = tx.frame
        if self.loss is not None and self.frame_lost(f, r.iface):
            tx.dst_reason = "random_loss"
            if not ack:
                self._lost(f, r.iface, "random_loss")
            return
        f.rx_now.add(r.iface.index)
        tx.acked = ack
        if r.last_seq.get(f.src.index) != f.seq:
            r.last_seq[f.src.index] = f.seq
            self._accept(f, r.iface)
        if ack and r.tx is None:
            r.responding += 1
            self.sim.call_in_ticks(self._ack_delay, self._send_ack, arg=tx)

    def _send_ack(self, data_tx: Transmission) -> None:
        r = data_tx.dst
        if r.tx is not None:
            r.responding -= 1
            self._reeval(r)
            return
        now = self._env.now
        f = data_tx.frame
        ack = Transmission(r, "ack", f, data_tx.src, now, now + self.ack_time, now + self._ack_plcp,
                           self._ack_mod)
        self._trace("ack", f, r.name, bits=self.ack_bits)
        self._start_tx(r, ack)

    def _reeval(self, r: RadioStation) -> None:
        """Hook of the medium: station *r*'s view of the medium changed."""
