"""Contention-free links: the ideal link and FDMA.

:class:`IdealLink` -- every sender has its own channel of ``data_rate`` bit/s to every
receiver: frames of one sender go out back to back in queue order, frames of different
senders never interfere.  A fixed ``delay`` (s) is added between the end of the
transmission and delivery.  Timing of a frame: ``queue wait + bits / data_rate + delay``
(+ pre/post-processing delays).

:class:`FDMA` -- the same with the bandwidth split: node *i* transmits at
``share_i * data_rate`` (TrueTime's FDMA network).
"""

from __future__ import annotations

from ..errors import ConfigurationError
from .base import Network
from .checks import check_duration, check_real
from .interface import Interface


class IdealLink(Network):
    """Bandwidth and a fixed delay, no contention.  See the module docstring.

    ``delay`` is an alias of ``propagation_delay`` (s).
    """

    def __init__(self, sim, name: str, *, data_rate: float = 10e6, delay: float | None = None, **kw):
        if delay is not None:
            if kw.get("propagation_delay"):
                raise ConfigurationError(f"network {name!r}: give delay or propagation_delay, not both")
            check_duration(delay, f"network {name!r}: delay (s)")
            kw["propagation_delay"] = delay
        super().__init__(sim, name, data_rate=data_rate, **kw)

    def rate_of(self, iface: Interface) -> float:
        """Transmission rate (bit/s) of *iface*."""
        return self.data_rate

    def _kick(self, iface: Interface) -> None:
        if iface.current is None and iface.queue._q:
            self._start(iface)

    def _start(self, iface: Interface) -> None:
        f = iface.queue.pop()
        iface.current = f
        f.attempts += 1
        f.sent = self._env._now
        iface.sending = 1
        for r in self.receivers(f):
            r.receiving += 1
            r._state()
        iface._state()
        self._trace("attempt_start", f, iface.name, bits=f.bits)
        self.sim.call_in_ticks(self.duration(f.bits, self.rate_of(iface)), self._end, arg=f)

    def _end(self, f) -> None:
        iface = f.src
        iface.sending = 0
        iface.current = None
        self._trace("attempt_end", f, iface.name, "ok" if not f.broadcast else "sent")
        for r in self.receivers(f):
            r.receiving -= 1
            r._state()
            self._deliver(f, r)
        iface._state()
        self._finish(f, True)
        self._kick(iface)


class FDMA(IdealLink):
    """Frequency division: node *i* owns ``share`` of the bandwidth (``attach(node, share=0.3)``).

    Shares are fractions in (0, 1] whose sum may not exceed 1.
    """

    def _make_interface(self, name, node, index, options, **common):
        share = options.pop("share", None)
        iface = super()._make_interface(name, node, index, options, **common)
        if share is None:
            raise ConfigurationError(f"network {self.name!r} (FDMA): attach({name!r}, share=...) needs a bandwidth "
                                     f"share, got share=None")
        share = check_real(share, f"network {self.name!r} (FDMA): share of {name!r}", low=0.0, high=1.0,
                           low_open=True, kind="a fraction of the bandwidth in (0, 1]")
        total = sum(i.share for i in self._ifaces) + share
        if total > 1 + 1e-12:
            raise ConfigurationError(f"network {self.name!r} (FDMA): shares would sum to {total:g} > 1 with {name!r}")
        iface.share = float(share)
        return iface

    def rate_of(self, iface):
        return self.data_rate * iface.share
