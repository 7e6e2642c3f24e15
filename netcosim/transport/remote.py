"""Remote nodes: a simulated node whose tasks run in another OS process, over Zenoh.

A remote serves **requests**: the frames the simulated network delivers to the node
(``node`` = the sender's network index, ``values`` = the payload's numbers, then any
plant outputs the node reads), and samples of a plant taken every ``sample_period`` s
(``node`` = :data:`~netcosim.transport.wire.LOCAL`).  Each request is published on
``netcosim/<run>/<name>/rx`` with a fresh ``seq`` and the simulated time ``ticks``.  The
process answers a request with one **reply** on ``.../tx`` echoing its ``seq`` and
``ticks``, addressed to a node of the network (sent through the simulated network: delay,
contention and loss still apply), to every node (:data:`~netcosim.transport.wire.BROADCAST`)
or to the node's own plant inputs (:data:`~netcosim.transport.wire.LOCAL`, zero-order
hold).  Wire format: :mod:`netcosim.transport.wire`.

The rules of what is applied (deadlines, drops by reason, the backlog bound), the
session and the claim, and the loss policies are those of
:class:`~netcosim.transport.base.BaseRemote` (:mod:`netcosim.transport.base`).

Remote plant I/O (:class:`RemotePlantIO`): a remote with no network, sampling a plant's
outputs every ``period`` s and writing the replies to its inputs: a fast local loop (e.g.
a 500 Hz low-level controller) against a simulated plant.
"""

from __future__ import annotations

import logging
from typing import Any, Callable, Collection

import numpy as np

from .. import validate
from ..errors import ConfigurationError
from ..timebase import to_ticks
from . import wire
from .base import (
    AGGREGATE,
    DROP_REASONS,
    HIL_COLUMNS,
    LOSS_EVENTS,
    LOSS_POLICIES,
    OUTCOMES,
    REQUEST_COLUMNS,
    BaseRemote,
    RemoteFault,
    drain,
)
from .session import Session

log = logging.getLogger("netcosim.transport")

__all__ = ["RemoteNode", "RemotePlantIO", "RemoteFault", "drain", "HIL_COLUMNS", "REQUEST_COLUMNS", "OUTCOMES",
           "LOSS_POLICIES", "DROP_REASONS", "LOSS_EVENTS", "AGGREGATE"]


def _floats(payload: Any) -> tuple[float, ...]:
    if payload is None:
        return ()
    if isinstance(payload, (int, float)):
        return (float(payload),)
    return tuple(float(v) for v in payload)


def _flat(x: Any) -> tuple[float, ...]:
    """A number, or a sequence of numbers and arrays, as one flat tuple of floats (in order)."""
    if isinstance(x, (int, float, np.number)) or (isinstance(x, np.ndarray) and x.ndim == 0):
        return (float(x),)
    return tuple(v for part in x for v in np.ravel(np.asarray(part, dtype=float)).tolist())


class RemoteNode(BaseRemote):
    """Run the tasks of *node* in another process; the simulation keeps its network traffic.

    Parameters
    ----------
    sim:
        The simulation (a :class:`RealtimeClock` is attached if it has none; its
        ``factor`` and ``max_lag`` come from *clock_options*).
    node:
        The kernel node (or its name) to make remote.  It must have exactly one network
        interface; its receive handlers are replaced by publishing requests (its periodic
        tasks, if any, keep running in the simulation: give a remote node none).
    session:
        An open :class:`~netcosim.transport.session.Session` (the caller closes it).
    run:
        The run id: keys live under ``netcosim/<run>/<node>/``.
    size_bits:
        Size (bits) of each message the process sends (the network adds its overhead).
    period:
        The period (s) of the requests the node serves, e.g. the sampling period of the
        sensor that sends to it; the default deadline.
    deadline:
        A reply must be injected less than this many seconds (simulated) after its
        request; default: ``period``.
    reply_values:
        Number of values a reply to a network node must carry (None: any number; a
        receiving task may then fail on a short reply: give it).
    max_outstanding:
        Requests that may wait for a reply at once (default ``ceil(deadline / period) + 1``).
    stale_after:
        An expired request is forgotten after this many seconds (default 100 deadlines).
    plant, outputs, inputs, sample_period, extra:
        The node's own plant I/O: *outputs* (selector as for ``plant.output``; None: none)
        are read at every request and appended to its values; every *sample_period* s (if
        given) a request of them alone is published (``node`` = LOCAL), followed by the
        values of ``extra(t)`` if given (see :class:`RemotePlantIO`); a reply to LOCAL is
        written to *inputs* (selector as for ``plant.input``; None: none, and a reply to
        LOCAL is dropped, reason ``destination``; it must carry one value per input).
    destinations:
        Where a reply may go: names of network nodes, ``"broadcast"`` and ``"local"``
        (None: any node of the network, broadcast, and local when *inputs* are given).
        A reply elsewhere is dropped (reason ``destination``).
    loss_policy, abort_on:
        See the module docstring.
    schema:
        A description of the payloads (free-form, JSON-able) handed to the process by
        the info query, e.g. ``{"request": ["t_sample", "y"], "reply": ["t_sample", "u"]}``.
    encoding:
        ``"ncsm"`` (the native layout, default) or ``"cdr"`` (CDR payloads on
        rmw_zenoh-style keys, for ROS 2 tools; :mod:`netcosim.transport.codecs`); the
        process must use the same.

    Counters (:meth:`counters`): ``published``, ``received``, ``expired``, ``overruns``,
    ``unserved``, ``after_end``, ``dropped`` by reason.  Replies applied: :meth:`replies`.
    """

    def __init__(self, sim: Any, node: Any, session: Session, *, run: str, size_bits: int,
                 period: float | None = None, deadline: float | None = None, reply_values: int | None = None,
                 max_outstanding: int | None = None, stale_after: float | None = None,
                 plant: Any = None, outputs: Any = None, inputs: Any = None, sample_period: float | None = None,
                 extra: Callable[[float], Any] | None = None, destinations: Collection[str] | None = None,
                 loss_policy: str | Callable[[Any, str], None] = "hold", abort_on: Collection[str] = (),
                 schema: dict | None = None, encoding: str = "ncsm", **clock_options: Any):
        name = node if isinstance(node, str) else getattr(node, "name", None)
        if not isinstance(name, str) or name not in sim.nodes:
            raise ConfigurationError(f"no node {node!r} in this simulation")
        ifaces = [i for n in sim.networks.values() for i in n._ifaces if i.name == name]
        if len(ifaces) != 1:
            raise ConfigurationError(f"remote node {name!r} must have exactly one network interface, "
                                     f"has {len(ifaces)}")
        self.size_bits = validate.count(size_bits, "size_bits (bits)", minimum=1)
        self.reply_values = None if reply_values is None else validate.count(reply_values, "reply_values",
                                                                               minimum=0)
        self._io = _PlantIO(plant, outputs, inputs, extra, everything=False) if plant is not None else None
        if plant is None and (outputs is not None or inputs is not None or sample_period is not None):
            raise ConfigurationError(f"remote node {name!r}: outputs, inputs and sample_period need plant=")
        if sample_period is not None and outputs is None:
            raise ConfigurationError(f"remote node {name!r}: sample_period needs the outputs= it samples")
        if period is None and sample_period is not None:
            period = sample_period
        super().__init__(sim, name, session, run, period=period, deadline=deadline, max_outstanding=max_outstanding,
                         stale_after=stale_after, loss_policy=loss_policy, abort_on=abort_on, schema=schema,
                         encoding=encoding, clock_options=clock_options)
        self.iface = iface = ifaces[0]
        self.network = iface.network
        self._table = {i.name: i.index for i in self.network._ifaces}
        self._allowed = self._destinations(destinations)
        if self.reply_values is None and self._allowed - {wire.LOCAL}:
            log.warning("remote node %r: replies of any number of values are sent on to the network; give "
                        "reply_values= (netcosim hil --reply-values) so that a short or long one is dropped "
                        "instead of reaching a receiving task", name)
        self._last: dict[Any, int] = {}      # destination -> length of the last payload sent to it
        iface.handlers[:] = [self._deliver]
        iface.use_mailbox = False
        if sample_period is not None:
            assert self._io is not None
            self._io.start(sim, sample_period, lambda values: self._request(wire.LOCAL, values))

    def _index(self) -> int | None:
        return self.iface.index

    def _destinations(self, names: Collection[str] | None) -> frozenset[int]:
        """The addresses a reply may carry (network indices, LOCAL, BROADCAST)."""
        local = self._io is not None and self._io.u is not None
        if names is None:
            allowed = {i for n, i in self._table.items() if n != self.name} | {wire.BROADCAST}
            return frozenset(allowed | ({wire.LOCAL} if local else set()))
        if isinstance(names, str):
            raise ConfigurationError(f"destinations must be a collection of names, got {names!r}")
        out = set()
        for n in names:
            if n == "local" and local:
                out.add(wire.LOCAL)
            elif n == "broadcast":
                out.add(wire.BROADCAST)
            elif n in self._table and n != self.name:
                out.add(self._table[n])
            else:
                known = sorted(set(self._table) - {self.name}) + ["broadcast"] + (["local"] if local else [])
                raise ConfigurationError(f"remote node {self.name!r}: destination {n!r} is none of {known}")
        return frozenset(out)

    def _network_table(self) -> dict[str, int]:
        return dict(self._table)

    def _deliver(self, msg: Any) -> None:
        values = _floats(msg.payload)
        if self._io is not None and self._io.y is not None:
            values += self._io.read()
        self._request(self.network.interface(msg.src).index, values)

    def _check_reply(self, m: wire.Message) -> str | None:
        node = m.node
        if node not in self._allowed:
            return "destination"
        if node == wire.LOCAL:
            assert self._io is not None
            return None if len(m.values) == self._io.n_inputs else "values"
        if self.reply_values is not None and len(m.values) != self.reply_values:
            return "values"
        return None

    def _apply_to(self, node: int, values: tuple[float, ...]) -> None:
        if node == wire.LOCAL:
            assert self._io is not None
            self._io.write(values)
            self._last[wire.LOCAL] = len(values)
            return
        from ..network import BROADCAST
        dst = BROADCAST if node == wire.BROADCAST else self.network._ifaces[node].name
        self._last[dst] = len(values)
        self.iface.send(dst, values, self.size_bits)

    def _zero(self) -> None:
        for dst, n in self._last.items():
            if dst == wire.LOCAL:
                assert self._io is not None
                self._io.write((0.0,) * n)
            else:
                self.iface.send(dst, (0.0,) * n, self.size_bits)


class _PlantIO:
    """A plant's selected outputs (read) and inputs (written, zero-order hold), and the
    periodic sampling of the outputs (plus ``extra(t)``)."""

    def __init__(self, plant: Any, outputs: Any, inputs: Any, extra: Callable[[float], Any] | None,
                 everything: bool = True):
        if extra is not None:
            validate.callable_(extra, "extra", kind="None or a callable extra(t) returning numbers")
        self.plant, self.extra = plant, extra
        # None selects every output / input (everything) or none
        self.y = plant.output(outputs) if outputs is not None or everything else None
        self.u = plant.input(inputs) if inputs is not None or everything else None
        self.n_inputs = 0 if self.u is None else len(np.atleast_1d(plant.u[self.u.index]))

    def read(self) -> tuple[float, ...]:
        return () if self.y is None else _floats(np.atleast_1d(self.y.read()))

    def write(self, values: tuple[float, ...]) -> None:
        assert self.u is not None
        self.u.write(values[0] if self.n_inputs == 1 and type(self.u.index) is int else np.asarray(values))

    def start(self, sim: Any, period: float, request: Callable[[tuple[float, ...]], None]) -> None:
        period_ticks = to_ticks(validate.positive(period, "period (s)"), "period (s)")

        def sample() -> None:
            values = self.read()
            if self.extra is not None:
                values += _flat(self.extra(sim.now))
            request(values)
            sim.call_in_ticks(period_ticks, sample)
        sim._call_at_ticks(int(sim.now_ticks), sample)


class RemotePlantIO(BaseRemote):
    """A process reads *plant*'s outputs and writes its inputs directly (no simulated network).

    Parameters
    ----------
    sim, session, run, loss_policy, abort_on, deadline, max_outstanding, stale_after, schema, encoding:
        As for :class:`RemoteNode` (``"zero"`` writes zeros to the inputs; the deadline
        defaults to *period*).
    plant:
        The :class:`~netcosim.plant.PlantInstance`.
    period:
        Sampling period (s): a request is published at ``t0, t0 + period, t0 + 2 period,
        ...`` s of simulated time (``t0``: the simulated time at construction; ``node``
        LOCAL, ``ticks`` the sampling instant).
    outputs, inputs:
        Output and input selectors as for ``plant.output(...)`` / ``plant.input(...)``
        (None: all).  A reply carries one value per selected input, to LOCAL.
    name:
        The key name (default: the plant's name): keys ``netcosim/<run>/<name>/...``.
    extra:
        None, or ``extra(t)``: called on the simulation thread at every sampling instant
        ``t`` (s of simulated time), right after the outputs are read, returning a number
        or a sequence of numbers and arrays (the caller's units) -- values the simulation
        computes for the process, e.g. a reference.  What a sample carries, in this
        order, as float64: the selected outputs (selection order, the plant's units),
        then the values of ``extra(t)`` flattened in order (element by element, each
        array row by row).  An exception of ``extra`` ends the run
        like any exception of a simulated component.
    """

    def __init__(self, sim: Any, plant: Any, session: Session, *, run: str, period: float,
                 outputs: Any = None, inputs: Any = None, name: str | None = None,
                 deadline: float | None = None, max_outstanding: int | None = None, stale_after: float | None = None,
                 loss_policy: str | Callable[[Any, str], None] = "hold", abort_on: Collection[str] = (),
                 extra: Callable[[float], Any] | None = None, schema: dict | None = None, encoding: str = "ncsm",
                 **clock_options: Any):
        self._io = _PlantIO(plant, outputs, inputs, extra)
        self.plant = plant
        super().__init__(sim, name or plant.name, session, run, period=period, deadline=deadline,
                         max_outstanding=max_outstanding, stale_after=stale_after, loss_policy=loss_policy,
                         abort_on=abort_on, schema=schema, encoding=encoding, clock_options=clock_options)
        self.n_inputs = self._io.n_inputs
        self._io.start(sim, period, lambda values: self._request(wire.LOCAL, values))

    def _check_reply(self, m: wire.Message) -> str | None:
        if m.node != wire.LOCAL:
            return "destination"
        return None if len(m.values) == self.n_inputs else "values"

    def _apply_to(self, node: int, values: tuple[float, ...]) -> None:
        self._io.write(values)

    def _zero(self) -> None:
        self._io.write((0.0,) * self.n_inputs)
