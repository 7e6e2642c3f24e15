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
    ``retry_probability`` in (0, 1], ``max_attempts`` per frame (None: unlimited)."""

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
