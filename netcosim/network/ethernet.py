"""CSMA/CD (shared, half-duplex Ethernet), with TrueTime's semantics as the default.

* 1-persistent carrier sense: a node with a frame transmits as soon as it senses the
  medium idle; if busy, it waits and transmits at the instant the medium goes idle
  (+ ``interframe_gap``).  All nodes waiting for that instant transmit together.
* A transmission is sensed by the others ``collision_window`` seconds after it starts
  (the worst-case propagation; TrueTime uses 1 µs).  A node starting while the only
  ongoing transmissions began less than a window ago does not sense them: collision.
  Every colliding node stops ``collision_window`` after the latest colliding start,
  sends ``jam_bits`` (0 in TrueTime, 32 in IEEE 802.3), and backs off.
* Binary exponential backoff: after the K-th collision of a frame the node waits
  ``U{0, ..., 2**min(K, backoff_limit) - 1}`` slot times; slot time = the minimum frame
  time ``min_frame_bits / data_rate`` (512 bits at 10 Mbit/s = 51.2 µs).
* ``max_attempts=None`` (TrueTime) retries forever; IEEE 802.3 gives up after 16.

Defaults: 10 Mbit/s, 512-bit minimum frame (TrueTime's defaults).
"""

from __future__ import annotations

from .. import validate
from ..errors import ConfigurationError
from .base import ARBITRATE, Network


class EthernetStation:
    """A CSMA/CD station's state: its pending timer (end of transmission or of backoff) and
    its backoff stream ``<net>/<node>/backoff`` (``rng``, a :class:`numpy.random.Generator`)."""

    __slots__ = ("timer", "rng")

    def __init__(self, rng):
        self.timer = None
        self.rng = rng


class CSMACD(Network):
    """Shared Ethernet with CSMA/CD.  See the module docstring for the semantics.

    ``data_rate`` in bit/s; ``min_frame_bits`` and ``jam_bits`` in bits; ``collision_window``,
    ``interframe_gap`` and ``slot_time`` in s (``slot_time`` None: ``min_frame_bits / data_rate``).
    ``max_attempts``: transmission attempts per frame before it is dropped (None: unlimited,
    as TrueTime); ``backoff_limit``: the cap on the backoff exponent (10: at most 1023 slots).

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        ``min_frame_bits=0`` without a ``slot_time`` (the backoff slot is the minimum
        frame time); ``collision_window`` or ``slot_time`` not positive; a negative
        ``interframe_gap`` or ``jam_bits``; ``max_attempts`` below 1; ``backoff_limit``
        outside 1..30; a common parameter out of range
        (:class:`~netcosim.network.base.Network`).
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sim* is not a :class:`~netcosim.Simulation`, or a parameter is not a number.

    Examples
    --------
    A 100-bit message on an idle 10 Mbit/s bus is padded to the 512-bit minimum frame and
    delivered after 512 / 10e6 s = 51.2 µs:

    >>> from netcosim import Simulation
    >>> from netcosim.network import CSMACD
    >>> sim = Simulation(seed=1)
    >>> eth = CSMACD(sim, "eth")
    >>> a, b, c = eth.attach("a"), eth.attach("b"), eth.attach("c")
    >>> msg = a.send("c", None, size_bits=100)
    >>> sim.run(until=0.001)
    >>> round(msg.delivered * 1e6, 6)                     # µs
    51.2

    Two nodes that start together collide, stop after the 1 µs collision window and back
    off 0 or 1 slot of 51.2 µs each (drawn); here ``b`` drew 0 and is delivered
    1 + 51.2 µs after the send, ``a`` drew 1 and follows one frame later:

    >>> m1, m2 = a.send("c", None, size_bits=512), b.send("c", None, size_bits=512)
    >>> sim.run(until=0.01)
    >>> eth.collisions, m1.attempts, m2.attempts
    (1, 2, 2)
    >>> round(m1.latency * 1e6, 6), round(m2.latency * 1e6, 6)          # µs
    (103.4, 52.2)
    """

    def __init__(self, sim, name, *, data_rate: float = 10e6, min_frame_bits: int = 512,
                 collision_window: float = 1e-6, jam_bits: int = 0, interframe_gap: float = 0.0,
                 max_attempts: int | None = None, backoff_limit: int = 10, slot_time: float | None = None, **kw):
        super().__init__(sim, name, data_rate=data_rate, min_frame_bits=min_frame_bits, **kw)
        w = f"network {name!r}"
        self._window = validate.duration(collision_window, f"{w}: collision_window (s)", positive=True)
        self.jam_bits = validate.bits(jam_bits, f"{w}: jam_bits")
        self._jam = self.duration(self.jam_bits)
        self._gap = validate.duration(interframe_gap, f"{w}: interframe_gap (s)")
        if max_attempts is not None:
            max_attempts = validate.count(max_attempts, f"{w}: max_attempts (a positive integer or None)", minimum=1)
        self.max_attempts = max_attempts
        self.backoff_limit = validate.count(backoff_limit, f"{w}: backoff_limit", minimum=1, maximum=30)
        if slot_time is None:
            if self.min_frame_bits == 0:
                raise ConfigurationError(f"{w}: CSMA/CD needs min_frame_bits > 0 or an explicit slot_time for "
                                         f"backoff")
            self._slot = self.duration(self.min_frame_bits)
        else:
            self._slot = validate.duration(slot_time, f"{w}: slot_time (s)", positive=True)
        self._active: dict = {}        # iface -> start tick
        self._waiting: list = []       # ifaces waiting for the medium to go idle
        self._colliders: list = []
        self._abort_timer = None
        self._idle_at = 0              # medium idle (incl. gap) from this tick on
        self._release_pending = False
        self.collisions = 0

    def _station(self, iface, options):
        return EthernetStation(self.sim.rng(f"{self.name}/{iface.name}/backoff"))

    # ------------------------------------------------------------------ MAC
    def _kick(self, iface):
        if self._next_frame(iface) is not None:
            self._try(iface)

    def _sensed_busy(self, now):
        if now < self._idle_at:
            return True
        w = self._window
        for start in self._active.values():
            if start + w <= now:
                return True
        return False

    def _try(self, iface):
        iface.mac.timer = None
        now = self._env.now
        if self._sensed_busy(now):
            self._waiting.append(iface)
            self._schedule_release()
            iface._state()
            return
        self._start(iface, now)

    def _start(self, iface, now):
        f = iface.current
        self.begin_attempt(iface, f)
        if self._active:
            # everyone active started less than a window ago: nobody sensed anybody
            if not self._colliders:
                self.collisions += 1
                for other in self._active:
                    other.mac.timer.cancel()
                    self._colliders.append(other)
            self._colliders.append(iface)
            self._active[iface] = now
            if self._abort_timer is not None:
                self._abort_timer.cancel()
            self._abort_timer = self.sim.call_in_ticks(self._window + self._jam, self._abort)
        else:
            self._active[iface] = now
            iface.mac.timer = self.sim.call_in_ticks(self.duration(f.bits), self._end, arg=iface)

    def _end(self, iface):
        iface.mac.timer = None
        del self._active[iface]
        a = iface.attempt
        a.end()
        a.deliver_all()
        # the sender may queue its next frame from on_done and seize the medium before the
        # waiters are released
        a.finish(restart=False)
        self._medium_idle()
        self._kick(iface)

    def _abort(self):
        self._abort_timer = None
        colliders, self._colliders = self._colliders, []
        now = self._env.now
        for iface in colliders:
            f = iface.current
            del self._active[iface]
            a = iface.attempt
            a.end("collision")
            if self.max_attempts is not None and f.attempts >= self.max_attempts:
                a.drop("retry_limit", restart=False)
                continue
            k = int(iface.mac.rng.integers(0, 2 ** min(f.attempts, self.backoff_limit)))
            iface.mac.timer = self.sim._call_at_ticks(now + k * self._slot, self._try, arg=iface)
            iface._state()
        self._medium_idle()
        for iface in colliders:
            if iface.current is None:
                self._kick(iface)

    def _medium_idle(self):
        if not self._active:
            self._idle_at = self._env.now + self._gap
            self._schedule_release()

    def _schedule_release(self):
        if self._waiting and not self._release_pending and not self._active:
            self._release_pending = True
            self.sim._call_at_ticks(max(self._idle_at, self._env.now), self._release, ARBITRATE)

    def _release(self):
        self._release_pending = False
        now = self._env.now
        if self._sensed_busy(now):
            self._schedule_release()
            return
        waiting, self._waiting = self._waiting, []
        for iface in waiting:
            self._start(iface, now)
