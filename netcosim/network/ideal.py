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

from .. import validate
from ..errors import ConfigurationError
from .base import Attempt, Network
from .interface import Interface


class IdealLink(Network):
    """Bandwidth and a fixed delay, no contention.  See the module docstring.

    ``delay`` is an alias of ``propagation_delay`` (s).

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        Both ``delay`` and ``propagation_delay`` given (non-zero); ``delay`` negative or
        not finite; a common parameter out of range (:class:`~netcosim.network.base.Network`).
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sim* is not a :class:`~netcosim.Simulation`, or a parameter is not a number.

    Examples
    --------
    1000 bits at 1 Mbit/s arrive 1 ms after they are sent:

    >>> from netcosim import IdealLink, Simulation
    >>> sim = Simulation(seed=0)
    >>> net = IdealLink(sim, "link", data_rate=1e6)
    >>> a, b = sim.node("a"), sim.node("b")
    >>> ia, ib = net.attach(a), net.attach(b)
    >>> @a.aperiodic(priority=1)
    ... def send(ctx):
    ...     ctx.send("b", "hello", 1000)
    ...     yield ctx.execute(1e-6)
    >>> arrivals = []
    >>> _ = ib.on_receive(lambda msg: arrivals.append((sim.now, msg.payload)))
    >>> _ = send.release()
    >>> sim.run(until=0.01)
    >>> arrivals
    [(0.001, 'hello')]
    """

    def __init__(self, sim, name: str, *, data_rate: float = 10e6, delay: float | None = None, **kw):
        if delay is not None:
            if kw.get("propagation_delay"):
                raise ConfigurationError(f"network {name!r}: give delay or propagation_delay, not both")
            validate.duration(delay, f"network {name!r}: delay (s)")
            kw["propagation_delay"] = delay
        super().__init__(sim, name, data_rate=data_rate, **kw)

    def rate_of(self, iface: Interface) -> float:
        """Transmission rate (bit/s) of *iface*."""
        return self.data_rate

    #: the ideal link's network_schedule lists the receivers' rows before the sender's
    receivers_first = True

    def _kick(self, iface: Interface) -> None:
        f = self._next_frame(iface)
        if f is not None:
            a = self.begin_attempt(iface, f)
            self.sim.call_in_ticks(self.duration(f.bits, self.rate_of(iface)), self._end, arg=a)

    def _end(self, a: Attempt) -> None:
        a.end()
        a.deliver_all()
        a.finish()


class FdmaStation:
    """An FDMA station's state: its ``share`` of the bandwidth (fraction in (0, 1])."""

    __slots__ = ("share",)

    def __init__(self, share: float):
        self.share = float(share)


class FDMA(IdealLink):
    """Frequency division: node *i* owns ``share`` of the bandwidth (``attach(node, share=0.3)``).

    Shares are fractions in (0, 1] whose sum may not exceed 1: ``attach`` raises
    :class:`~netcosim.errors.ConfigurationError` for a missing share, a share outside
    (0, 1], or one that would make the sum exceed 1.  Parameters as :class:`IdealLink`.

    Examples
    --------
    A 1 Mbit/s channel split 1/4 : 3/4.  Both nodes send 1000 bits at t = 0, at the same
    time without interfering: 1000 / 250e3 s = 4 ms for ``a``, 1000 / 750e3 s = 1.333 ms
    for ``b``:

    >>> from netcosim import Simulation
    >>> from netcosim.network import FDMA
    >>> sim = Simulation(seed=0)
    >>> net = FDMA(sim, "fdma", data_rate=1e6)
    >>> a, b = net.attach("a", share=0.25), net.attach("b", share=0.75)
    >>> ma, mb = a.send("b", None, size_bits=1000), b.send("a", None, size_bits=1000)
    >>> sim.run(until=0.01)
    >>> round(ma.delivered * 1e3, 6), round(mb.delivered * 1e3, 6)          # ms
    (4.0, 1.333333)
    >>> net.rate_of(a), net.rate_of(b)                                       # bit/s
    (250000.0, 750000.0)
    """

    def _station(self, iface, options):
        share = options.pop("share", None)
        name = iface.name
        if share is None:
            raise ConfigurationError(f"network {self.name!r} (FDMA): attach({name!r}, share=...) needs a bandwidth "
                                     f"share, got share=None")
        share = validate.real(share, f"network {self.name!r} (FDMA): share of {name!r}", lo=0.0, hi=1.0,
                              lo_open=True, kind="a fraction of the bandwidth in (0, 1]")
        # every station of an FDMA network is the FdmaStation this hook made
        total = sum(i.mac.share for i in self._ifaces) + share
        if total > 1 + 1e-12:
            raise ConfigurationError(f"network {self.name!r} (FDMA): shares would sum to {total:g} > 1 with {name!r}")
        return FdmaStation(share)

    def rate_of(self, iface):
        return self.data_rate * iface.mac.share
