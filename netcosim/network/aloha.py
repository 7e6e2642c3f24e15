"""Slotted ALOHA (Roberts 1975): the smallest contention MAC, and the example of
"Writing a MAC" in ``docs/networks.md``.

Time is cut into slots of ``slot_time`` seconds from t = 0; a frame occupies one slot
(size frames to fit: ``slot_time * data_rate`` bits).  A station with a frame
transmits at the next slot boundary (at once if a boundary is now).  A slot with one
transmission delivers it; two or more collide (``attempt_end`` outcome ``collision``)
and each collider transmits again in every following slot with probability
``retry_probability`` (``p``, in (0, 1]), until ``max_attempts`` attempts (None:
forever; then ``lost`` with reason ``retry_limit``).  With Poisson attempts of mean G per slot the throughput
is ``S = G exp(-G)`` frames per slot.  Random streams: ``<net>/<node>/backoff``.
"""

from __future__ import annotations

from .. import validate
from .base import ARBITRATE, Network


class SlottedAloha(Network):
    """Slotted ALOHA (see the module docstring): ``data_rate`` in bit/s, ``slot_time`` in s,
    ``retry_probability`` in (0, 1], ``max_attempts`` per frame (None: unlimited).

    A ``slot_time`` that is not positive, a ``retry_probability`` outside (0, 1] or a
    ``max_attempts`` below 1 raises :class:`~netcosim.errors.ConfigurationError`; the other
    parameters as :class:`~netcosim.network.base.Network`.

    Examples
    --------
    Slots of 1 ms, frames of 1000 bits at 1 Mbit/s (one slot).  A message sent at
    0.3 ms waits for the next slot boundary (1 ms) and is delivered at the slot's end:

    >>> from netcosim import Simulation
    >>> from netcosim.network import SlottedAloha
    >>> sim = Simulation(seed=0)
    >>> net = SlottedAloha(sim, "aloha", data_rate=1e6, slot_time=1e-3, retry_probability=0.5)
    >>> a, b, c = net.attach("a"), net.attach("b"), net.attach("c")
    >>> sent = []
    >>> _ = sim.call_at(0.3e-3, lambda: sent.append(a.send("c", None, size_bits=1000)))
    >>> sim.run(until=0.01)
    >>> round(sent[0].sent * 1e3, 6), round(sent[0].delivered * 1e3, 6)     # ms
    (1.0, 2.0)

    Two messages in one slot collide, and each sender retries in every later slot with
    probability 1/2 until it is alone in one (here after 3 collisions; latencies in ms):

    >>> m1, m2 = a.send("c", None, size_bits=1000), b.send("c", None, size_bits=1000)
    >>> sim.run(until=0.1)
    >>> m1.attempts, m2.attempts, round(m1.latency * 1e3, 6), round(m2.latency * 1e3, 6)
    (4, 4, 5.0, 4.0)
    """

    def __init__(self, sim, name, *, data_rate: float = 1e6, slot_time: float, retry_probability: float = 0.1,
                 max_attempts: int | None = None, **kw):
        super().__init__(sim, name, data_rate=data_rate, **kw)
        w = f"network {name!r}"
        self._slot = validate.duration(slot_time, f"{w}: slot_time (s)", positive=True)
        self.p = validate.real(retry_probability, f"{w}: retry_probability", lo=0.0, hi=1.0, lo_open=True)
        self.max_attempts = (None if max_attempts is None
                             else validate.count(max_attempts, f"{w}: max_attempts", minimum=1))
        self._slots: dict[int, list] = {}          # slot start tick -> stations transmitting then

    def _station(self, iface, options):
        return self.sim.rng(f"{self.name}/{iface.name}/backoff")

    def _kick(self, iface):
        if self._next_frame(iface) is not None:
            self._transmit_at(iface, self._env.now + -self._env.now % self._slot)

    def _transmit_at(self, iface, at):
        if at not in self._slots:       # one event per slot, after everything else at that instant
            self._slots[at] = []
            self.sim._call_at_ticks(at, self._slot_start, ARBITRATE, arg=at)
        self._slots[at].append(iface)

    def _slot_start(self, at):
        group = self._slots.pop(at)
        for iface in group:
            self.begin_attempt(iface, iface.current)
        self.sim.call_in_ticks(self._slot, self._slot_end, arg=group)

    def _slot_end(self, group):
        ok = len(group) == 1
        for iface in group:
            a = iface.attempt
            a.end(None if ok else "collision")
            if ok:
                a.deliver_all()
                a.finish()
            elif self.max_attempts is not None and a.frame.attempts >= self.max_attempts:
                a.drop("retry_limit")
            else:       # the first following slot in which the station draws "transmit"
                k = int(iface.mac.geometric(self.p))
                self._transmit_at(iface, self._env.now + (k - 1) * self._slot)
