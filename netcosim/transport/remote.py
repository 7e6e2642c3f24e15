"""Remote nodes: a simulated node whose tasks run in another OS process, over Zenoh.

The simulated network still carries the node's frames (delay, contention and loss apply
as before).  A frame the network delivers to the remote node is published, at the
instant of delivery, on ``netcosim/<run>/<node>/rx`` (wire format:
:mod:`netcosim.transport.wire`; ``node`` = network index of the sender, ``ticks`` = the
simulated delivery time, the payload's numbers as float64).  What the process publishes
on ``netcosim/<run>/<node>/tx`` (``node`` = network index of the destination) enters
the simulated network at the simulated instant matching its wall-clock arrival (the
:class:`~netcosim.transport.realtime.RealtimeClock` injects it) and is sent by the
node's interface like any message of that node.

The process declares a liveliness token ``netcosim/<run>/<node>/alive``.  When the token
goes (the process died, or was silent for its session's lease), the node's loss policy
applies: ``"hold"`` sends nothing more (receivers keep the last command, zero-order
hold), ``"zero"`` sends, once, a message of zeros of the last payload's length to every
node it has sent to (the receivers' command becomes 0), a callable ``fn(remote)`` does
what it wants.  Every such event is a row of the trace table ``hil``.

Remote plant I/O (:class:`RemotePlantIO`): for a fast local loop (e.g. a 500 Hz
low-level controller) against a simulated plant, without a simulated network in
between: every ``period`` s the plant's outputs are published on
``netcosim/<run>/<name>/rx``, followed by any values the simulation computes for the
process at that instant (``extra``, e.g. a reference the simulation generates); what
the process publishes on ``.../tx`` is written to the plant's inputs (zero-order hold)
at the simulated instant matching its arrival.  Loss policies as above (``"zero"``
writes zeros to the inputs).
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import Counter
from typing import Any, Callable

import numpy as np

from .. import validate
from ..errors import ConfigurationError
from ..timebase import RESOLUTION, to_ticks
from . import wire
from .realtime import RealtimeClock
from .session import Session, key

__all__ = ["RemoteNode", "RemotePlantIO", "HIL_COLUMNS", "LOSS_POLICIES"]

log = logging.getLogger("netcosim.transport")

#: columns of the trace table ``hil``: simulated time (s), node, event, detail
HIL_COLUMNS = ("time", "node", "event", "detail")
#: built-in loss policies (or pass a callable ``fn(remote)``)
LOSS_POLICIES = ("hold", "zero")


def _hil_frame(df):
    df["time"] = df["time"] * RESOLUTION
    return df


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


class _Remote:
    """What a remote node and remote plant I/O share: keys, liveliness, loss policy,
    counters, validation of incoming messages, the ``hil`` trace rows."""

    def __init__(self, sim: Any, name: str, session: Session, run: str, loss_policy: Any, clock_options: dict):
        if not (callable(loss_policy) or loss_policy in LOSS_POLICIES):
            raise ConfigurationError(f"loss_policy must be one of {LOSS_POLICIES} or a callable, "
                                     f"got {loss_policy!r}")
        self.sim = sim
        self.name = name
        self.loss_policy = loss_policy
        self.clock = getattr(sim, "_realtime_clock", None) or RealtimeClock(sim, **clock_options)
        self.run_id = run
        self.keys = {leaf: key(run, name, leaf) for leaf in ("rx", "tx", "alive")}
        self.published = 0
        self.received = 0
        self.rejected: Counter[str] = Counter()
        self.alive = False
        self.after_end = 0
        self.connected = threading.Event()   # set (from a Zenoh thread) when the token appears
        self._seq = 0
        self._sent_at: dict[int, int] = {}   # seq -> tick of publication to the process
        self._rows = sim.trace.table("hil", HIL_COLUMNS, categorical=("node", "event"), transform=_hil_frame,
                                     dtypes=("int", None, None, None))
        self._signal = sim.trace.signal_rec
        self._pub = session.publisher(self.keys["rx"])
        self._subs = [session.subscribe(self.keys["tx"], self._on_tx),
                      session.watch(self.keys["alive"], self._on_alive)]

    # Zenoh threads: stamp and queue only ------------------------------------------
    def _on_tx(self, data: bytes) -> None:
        self.clock.post(self._receive, data)

    def _on_alive(self, alive: bool) -> None:
        if alive:
            self.connected.set()
        self.clock.post(self._liveliness, alive)

    # simulation thread ---------------------------------------------------------------
    def _record(self, event: str, detail: str = "") -> None:
        self._rows.append((self.sim.now_ticks, self.name, event, detail))

    def _publish(self, node: int, values: tuple[float, ...]) -> None:
        seq = self._seq
        self._seq = (seq + 1) & 0xFFFFFFFF
        now = self.sim.now_ticks
        self._sent_at[seq] = now
        if len(self._sent_at) > 4096:      # replies that never came: keep memory bounded
            self._sent_at.pop(next(iter(self._sent_at)))
        self._pub.put(wire.encode(wire.DATA, node, seq, now, values))
        self.published += 1
        self.clock.expect_reply()

    def _reject(self, reason: str, detail: str) -> None:
        self.rejected[reason] += 1
        log.warning("remote %r: %s", self.name, detail)
        self._record("rejected", reason)

    def _receive(self, data: bytes) -> None:
        try:
            m = wire.decode(data)
        except wire.WireError as e:
            self._reject(e.reason, str(e))
            return
        if m.kind == wire.END:
            self._record("ended")       # the process has answered everything it will answer
            return
        if not self._valid(m):
            return
        self.received += 1
        sent = self._sent_at.pop(m.seq, None)
        if sent is not None:
            self.clock.reply_arrived()
            self._signal.append((self.sim.now, f"{self.name}.remote", "response",
                                 (self.sim.now_ticks - sent) * RESOLUTION))
        self._apply(m)

    def _valid(self, m: wire.Message) -> bool:
        return True

    def _apply(self, m: wire.Message) -> None:
        raise NotImplementedError

    def _zero(self) -> None:
        raise NotImplementedError

    def _liveliness(self, alive: bool) -> None:
        if alive == self.alive:
            return
        self.alive = alive
        if alive:
            self._record("alive")
            return
        policy = self.loss_policy
        self._record("lost", policy if isinstance(policy, str) else getattr(policy, "__name__", "callable"))
        if policy == "zero":
            self._zero()
        elif callable(policy):
            policy(self)

    # any thread, outside the run -----------------------------------------------------
    def response_times(self) -> np.ndarray:
        """The response time (s, simulated) of every reply so far, in arrival order: from
        the publication of the message it answers to its injection (signal ``response``
        of source ``<name>.remote``)."""
        sig = self.sim.trace.signals()
        sel = (sig["source"] == f"{self.name}.remote") & (sig["signal"] == "response")
        return sig.loc[sel, "value"].to_numpy()

    def wait_connected(self, timeout: float) -> bool:
        """Block up to *timeout* s until the process's liveliness token is seen; True if it was."""
        return self.connected.wait(timeout)

    def finish(self) -> None:
        """Tell the process the run is over (an ``END`` message on ``rx``); call after ``sim.run``."""
        self._pub.put(wire.encode(wire.END, 0, self._seq, self.sim.now_ticks))

    def drain(self, timeout: float = 5.0, quiet: float = 0.5) -> int:
        """After the run and :meth:`finish`, once the process is ending: count the valid
        messages it sent that arrived after the run (``after_end``; replies in flight at
        the stop time, or scheduled after it by a lagging simulation).  Waits for the
        process's own END message (it sends one after its
        last reply), or else until its liveliness token has gone and then no message came
        for *quiet* s (Zenoh may deliver the token's end before the last data), at most
        *timeout* s.  Nothing is injected.  Returns ``after_end``."""
        for fn, arg in self.clock.take_pending():     # arrived, due after the stop time
            if fn == self._receive:
                self._count_late(arg)
        inbox = self.clock.inbox
        deadline = time.monotonic() + timeout
        gone = not self.alive
        while (left := deadline - time.monotonic()) > 0:
            try:
                _, fn, arg = inbox.get(timeout=min(left, quiet) if gone else left)
            except queue.Empty:
                break
            if fn == self._liveliness and arg is False:
                gone = True
            elif fn == self._receive and self._count_late(arg):
                break
        return self.after_end

    def _count_late(self, data: bytes) -> bool:
        """Count a message that arrived after the run; True if it is the process's END."""
        try:
            m = wire.decode(data)
        except wire.WireError:
            return False
        if m.kind == wire.END:
            return True
        self.after_end += 1
        return False

    def events(self):
        """The ``hil`` trace rows of this remote (``time`` in s, ``event``: alive, lost, rejected, ended)."""
        df = self.sim.trace.frame("hil")
        return df[df["node"] == self.name].reset_index(drop=True)


class RemoteNode(_Remote):
    """Run the tasks of *node* in another process; the simulation keeps its network traffic.

    Parameters
    ----------
    sim:
        The simulation (a :class:`RealtimeClock` is attached if it has none; its
        ``factor`` and ``max_lag`` come from *clock_options*).
    node:
        The kernel node (or its name) to make remote.  It must have exactly one network
        interface; its receive handlers are replaced by publishing (its periodic tasks,
        if any, keep running in the simulation: give a remote node none).
    session:
        An open :class:`~netcosim.transport.session.Session` (the caller closes it).
    run:
        The run id: keys live under ``netcosim/<run>/<node>/``.
    size_bits:
        Size (bits) of each message the process sends (the network adds its overhead).
    loss_policy:
        ``"hold"``, ``"zero"`` or ``fn(remote)`` (see the module docstring).

    Counters (simulation thread): ``published`` messages sent to the process, ``received``
    valid messages from it, ``rejected`` a :class:`collections.Counter` by reason of
    invalid ones (see :class:`~netcosim.transport.wire.WireError`; unknown destination:
    ``"destination"``), ``alive`` whether its token is present, ``after_end`` messages
    that arrived after the run (see :meth:`drain`).  The simulated response time of
    every reply (delivery of a message to the process to arrival of a reply echoing its
    ``seq``) is logged as signal ``response`` (s) of source ``<node>.remote``.
    """

    def __init__(self, sim: Any, node: Any, session: Session, *, run: str, size_bits: int,
                 loss_policy: str | Callable[["RemoteNode"], None] = "hold", **clock_options: Any):
        name = node if isinstance(node, str) else getattr(node, "name", None)
        if not isinstance(name, str) or name not in sim.nodes:
            raise ConfigurationError(f"no node {node!r} in this simulation")
        ifaces = [i for n in sim.networks.values() for i in n._ifaces if i.name == name]
        if len(ifaces) != 1:
            raise ConfigurationError(f"remote node {name!r} must have exactly one network interface, "
                                     f"has {len(ifaces)}")
        self.size_bits = validate.count(size_bits, "size_bits (bits)", minimum=1)
        super().__init__(sim, name, session, run, loss_policy, clock_options)
        self.iface = iface = ifaces[0]
        self.network = iface.network
        self._last: dict[str, int] = {}      # destination -> length of the last payload sent to it
        iface.handlers[:] = [self._deliver]
        iface.use_mailbox = False

    def _deliver(self, msg: Any) -> None:
        self._publish(self.network.interface(msg.src).index, _floats(msg.payload))

    def _valid(self, m: wire.Message) -> bool:
        ifaces = self.network._ifaces
        if m.node >= len(ifaces) or ifaces[m.node] is self.iface:
            self._reject("destination", f"no destination with network index {m.node}")
            return False
        return True

    def _apply(self, m: wire.Message) -> None:
        dst = self.network._ifaces[m.node].name
        self._last[dst] = len(m.values)
        self.iface.send(dst, m.values, self.size_bits)

    def _zero(self) -> None:
        for dst, n in self._last.items():
            self.iface.send(dst, (0.0,) * n, self.size_bits)


class RemotePlantIO(_Remote):
    """A process reads *plant*'s outputs and writes its inputs directly (no simulated network).

    Parameters
    ----------
    sim, session, run, loss_policy:
        As for :class:`RemoteNode` (``"zero"`` writes zeros to the inputs).
    plant:
        The :class:`~netcosim.continuous.PlantInstance`.
    period:
        Sampling period (s): a sample is published at ``t0, t0 + period, t0 + 2 period,
        ...`` s of simulated time (``t0``: the simulated time at construction; ``node``
        field 0, ``ticks`` the sampling instant).
    outputs, inputs:
        Output and input selectors as for ``plant.output(...)`` / ``plant.input(...)``
        (None: all).  A message from the process carries one value per selected input;
        another length is rejected (reason ``"length"``).
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

    The response time of every write (sample published to the reply echoing its
    ``seq``) is logged as signal ``response`` (s) of source ``<name>.remote``.
    """

    def __init__(self, sim: Any, plant: Any, session: Session, *, run: str, period: float,
                 outputs: Any = None, inputs: Any = None, name: str | None = None,
                 loss_policy: str | Callable[["RemotePlantIO"], None] = "hold",
                 extra: Callable[[float], Any] | None = None, **clock_options: Any):
        if extra is not None:
            validate.callable_(extra, "extra", kind="None or a callable extra(t) returning numbers")
        self.extra = extra
        self.period_ticks = to_ticks(validate.positive(period, "period (s)"), "period (s)")
        self.plant = plant
        self.y = plant.output(outputs)
        self.u = plant.input(inputs)
        self.n_inputs = len(np.atleast_1d(plant.u[self.u.index]))
        super().__init__(sim, name or plant.name, session, run, loss_policy, clock_options)
        self._k = 0
        sim.call_at_ticks(int(sim.now_ticks), self._sample)

    def _sample(self) -> None:
        values = _floats(np.atleast_1d(self.y.read()))
        if self.extra is not None:
            values += _flat(self.extra(self.sim.now))
        self._publish(0, values)
        self._k += 1
        self.sim.call_in_ticks(self.period_ticks, self._sample)

    def _valid(self, m: wire.Message) -> bool:
        if len(m.values) != self.n_inputs:
            self._reject("length", f"{len(m.values)} values for {self.n_inputs} plant inputs")
            return False
        return True

    def _write(self, values: tuple[float, ...]) -> None:
        self.u.write(values[0] if self.n_inputs == 1 and type(self.u.index) is int else np.asarray(values))

    def _apply(self, m: wire.Message) -> None:
        self._write(m.values)

    def _zero(self) -> None:
        self._write((0.0,) * self.n_inputs)
