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

**What is applied.**  A reply is applied only if it answers an outstanding request of
this session, once, before the request's deadline (``deadline`` s after the request;
default: the period).  Everything else is dropped and counted by reason (``dropped``,
:data:`DROP_REASONS`) and recorded in aggregated rows of the trace table ``hil``; a
request that got no reply in time is ``expired`` and a lost reply under the loss
policy.  At most ``max_outstanding`` requests may wait in the process: requests it has
not answered in any way (in time, late or malformed) since the newest one it did answer;
a request beyond that is not published (an ``overrun``, a lost reply too), so a process
slower than the period is never handed more than it can answer.  A request unanswered
for ``stale_after`` s is forgotten (a reply to it is then ``stale``), so a silent process
is offered requests again from time to time.  Checks that need no simulated time
(format, session, peer, values, and replies to requests that are not outstanding) run on
the Zenoh thread, so a flood of bad messages never reaches the simulation's event queue.

**Session and claim.**  Each remote has a random 64-bit session id, in every message, and
declares the liveliness token ``netcosim/<run>/<name>/sim/<session>`` (the process sees
the simulation end or die through it).  A process declares
``netcosim/<run>/<name>/alive/<peer>`` with its own random id; the first one claims the
node, any other gets a :data:`~netcosim.transport.wire.REFUSED` message and its replies
are dropped (reason ``"peer"``).  A claimant whose token goes (killed: at once; hung: after
the lease) is ``lost``: the loss policy applies once, no request is published until a
process claims the node again.  The process can ask the run's parameters (session, the
network's name -> index table, period, deadline, payload schema) on
``netcosim/<run>/<name>/info`` (a Zenoh query answered with JSON).

**Loss policy** (a lost reply: expired, overrun, or the claimant lost): ``"hold"`` does
nothing (receivers keep the last command, zero-order hold); ``"zero"`` sends zeros of the
last reply's length to every destination the remote has sent to (``LOCAL``: writes zeros
to the inputs); a callable ``fn(remote, why)`` with ``why`` one of ``"expired"``,
``"overrun"``, ``"lost"``.  ``abort_on``: reasons (drop reasons, ``"expired"``,
``"overrun"``, ``"lost"``) that end the run with :class:`RemoteFault` instead; the trace
is kept and the harness still sends END.

Remote plant I/O (:class:`RemotePlantIO`): a remote with no network, sampling a plant's
outputs every ``period`` s and writing the replies to its inputs: a fast local loop (e.g.
a 500 Hz low-level controller) against a simulated plant.
"""

from __future__ import annotations

import json
import logging
import math
import queue
import secrets
import threading
import time
from collections import Counter, deque
from typing import Any, Callable, Collection

import numpy as np

from .. import validate
from ..errors import ConfigurationError, NetcosimError
from ..timebase import RESOLUTION, to_ticks
from . import wire
from .codecs import codec
from .realtime import RealtimeClock
from .session import Session, key

__all__ = ["RemoteNode", "RemotePlantIO", "RemoteFault", "drain", "HIL_COLUMNS", "REQUEST_COLUMNS", "OUTCOMES",
           "LOSS_POLICIES", "DROP_REASONS", "LOSS_EVENTS"]

log = logging.getLogger("netcosim.transport")

#: columns of the trace table ``hil``: simulated time (s), remote, event, detail, count
#: (aggregated rows: ``count`` events of this kind since the previous row of the same
#: event and detail)
HIL_COLUMNS = ("time", "node", "event", "detail", "count")
#: columns of the trace table ``hil_requests``, one row per request: its simulated time (s),
#: remote, seq, the network index it came from (LOCAL for a sample), its outcome (one of
#: :data:`OUTCOMES`) and the response time (s; NaN unless a reply was applied)
REQUEST_COLUMNS = ("time", "node", "seq", "source", "outcome", "response")
#: what became of a request: ``replied`` (a reply applied in time), ``expired`` (published,
#: no reply in time), ``open`` (published, no reply when the run ended), ``overrun`` and
#: ``unserved`` (not published: ``max_outstanding`` were waiting / no process claimed the node)
OUTCOMES = ("replied", "expired", "open", "overrun", "unserved")
#: built-in loss policies (or pass a callable ``fn(remote, why)``)
LOSS_POLICIES = ("hold", "zero")
#: why a reply is a lost one (what a loss policy is called with)
LOSS_EVENTS = ("expired", "overrun", "lost")
#: why a message from the process is dropped: the wire format's (short, magic -- or
#: encapsulation with the ``cdr`` encoding --, version, kind, oversized, length), then
#: ``session`` (another run's), ``peer`` (not from the process that claimed the node),
#: ``nonfinite`` (a NaN or infinity), ``values`` (another number of values than the
#: destination takes), ``destination`` (no such node), ``unsolicited`` (answers no request
#: ever published), ``duplicate`` (answers a request already answered), ``late`` (after
#: the request's deadline), ``stale`` (answers a request forgotten: older than
#: ``stale_after``), ``mismatch`` (its ticks are not its request's)
DROP_REASONS = ("short", "magic", "encapsulation", "version", "kind", "oversized", "length", "session", "peer",
                "nonfinite", "values", "destination", "unsolicited", "duplicate", "late", "stale", "mismatch")
#: aggregation of the ``hil`` rows: at most one row per event and detail per this many
#: simulated seconds (plus one at the end)
AGGREGATE = 0.1
#: at most this many answered requests are remembered (a reply to an older one is ``stale``)
_ANSWERED_MEMORY = 65536


class RemoteFault(NetcosimError):
    """A remote misbehaved in a way the run was told to abort on (``abort_on``)."""


def _hil_frame(df):
    df["time"] = df["time"] * RESOLUTION
    return df


def _request_frame(df):
    df["time"] = df["time"] * RESOLUTION
    df["response"] = df["response"].where(df["response"] >= 0) * RESOLUTION
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


class _Request:
    __slots__ = ("ticks", "deadline", "source", "timer", "expired")

    def __init__(self, ticks: int, deadline: int, source: int, timer: Any):
        self.ticks, self.deadline, self.source, self.timer, self.expired = ticks, deadline, source, timer, False


class _Remote:
    """The bookkeeping every remote shares: session and claim, keys and liveliness,
    requests and their deadlines, matching and dropping replies, counters, the loss
    policy and the ``hil`` trace rows.  A subclass says where requests come from and
    how a reply is applied (:meth:`_apply_to`, :meth:`_check_reply`, :meth:`_zero`)."""

    def __init__(self, sim: Any, name: str, session: Session, run: str, *, period: float | None,
                 deadline: float | None, max_outstanding: int | None, stale_after: float | None,
                 loss_policy: Any, abort_on: Collection[str], schema: dict | None, encoding: str,
                 clock_options: dict):
        if not (callable(loss_policy) or loss_policy in LOSS_POLICIES):
            raise ConfigurationError(f"loss_policy must be one of {LOSS_POLICIES} or a callable "
                                     f"fn(remote, why), got {loss_policy!r}")
        unknown = sorted(set(abort_on) - set(DROP_REASONS) - set(LOSS_EVENTS))
        if isinstance(abort_on, str) or unknown:
            raise ConfigurationError(f"abort_on must be a collection of {DROP_REASONS + LOSS_EVENTS}, "
                                     f"got {abort_on!r}")
        if period is None and deadline is None:
            raise ConfigurationError(f"remote {name!r}: give the period of its requests (period=, s) or a "
                                     "deadline= (s) for its replies")
        self.period = None if period is None else validate.positive(period, "period (s)",
                                                                      type_error=ConfigurationError)
        self.deadline = validate.positive(deadline if deadline is not None else period, "deadline (s)",
                                          type_error=ConfigurationError)
        if max_outstanding is None:
            max_outstanding = math.ceil(self.deadline / self.period - 1e-9) + 1 if self.period else 2
        self.max_outstanding = validate.count(max_outstanding, "max_outstanding", minimum=1)
        self.stale_after = validate.positive(stale_after if stale_after is not None else 100 * self.deadline,
                                             "stale_after (s)", type_error=ConfigurationError)
        self.sim = sim
        self.name = name
        self.loss_policy = loss_policy
        self.abort_on = frozenset(abort_on)
        self.schema = dict(schema or {})
        self.clock = getattr(sim, "_realtime_clock", None) or RealtimeClock(sim, **clock_options)
        self.run_id = run
        self.session_id = secrets.randbits(64) or 1
        try:
            self.codec = codec(encoding)
            self.keys = {leaf: key(run, name, leaf) for leaf in ("alive", "sim", "info")}
            self.keys.update({leaf: self.codec.data_key(run, name, leaf) for leaf in ("rx", "tx")})
        except ValueError as e:
            raise ConfigurationError(str(e)) from None
        # counters (simulation thread; Zenoh-thread drops are folded in by _fold)
        self.published = 0          # requests published to the process
        self.received = 0           # replies applied
        self.expired = 0            # requests without a reply before their deadline
        self.overruns = 0           # requests not published: max_outstanding were waiting
        self.unserved = 0           # requests while no process had claimed the node
        self.after_end = 0          # valid messages that arrived after the run (drain)
        self.dropped: Counter[str] = Counter()
        self.alive = False
        self.peer: int | None = None        # the claimant's id (set on a Zenoh thread)
        self.refused: list[int] = []        # ids of refused claimants (appended on a Zenoh thread)
        self._refused_alive: set[int] = set()   # refused claimants whose token is still there
        self.connected = threading.Event()  # set when a process has claimed the node
        self._lock = threading.Lock()
        self._zdrops: Counter[str] = Counter()  # drops decided on Zenoh threads, not yet folded
        self._claimed: set[int] = set()         # seqs a reply is already on its way for (Zenoh threads)
        self._seq = 0
        self._requests: dict[int, _Request] = {}    # outstanding (pending or expired), publication order
        self._answered: deque[tuple[int, int]] = deque()  # (seq, tick of its request), oldest first
        self._answered_set: set[int] = set()
        self._heard = -1        # tick of the newest request the process answered in any way (Zenoh threads too)
        self._issued = 0
        self._deadline_ticks = to_ticks(self.deadline, "deadline (s)")
        self._stale_ticks = to_ticks(self.stale_after, "stale_after (s)")
        self._tally: dict[tuple[str, str], list] = {}   # (event, detail) -> [pending count, last row tick]
        self._aggregate_ticks = to_ticks(AGGREGATE, "aggregation")
        self._warned: set[str] = set()
        self._rows = sim.trace.table("hil", HIL_COLUMNS, categorical=("node", "event", "detail"),
                                     transform=_hil_frame, dtypes=("int", None, None, None, "int"))
        self._outcomes = sim.trace.table("hil_requests", REQUEST_COLUMNS, categorical=("node", "outcome"),
                                         transform=_request_frame, dtypes=("int", None, "int", "int", None, "int"))
        sim._finalizers.append(self.flush)
        self._session = session
        self._pub = self.codec.publisher(session, self.keys["rx"], self.session_id)
        self._decls = [session.subscribe(self.keys["tx"], self._on_tx),
                       session.watch_keys(self.keys["alive"] + "/*", self._on_token),
                       session.token(f"{self.keys['sim']}/{self.session_id:016x}"),
                       session.zenoh.declare_queryable(self.keys["info"], self._on_info)]

    # Zenoh threads: stamp and queue, or drop and count ----------------------------
    def _zdrop(self, reason: str) -> None:
        with self._lock:
            self._zdrops[reason] += 1

    def _on_tx(self, data: bytes) -> None:
        try:
            m = self.codec.decode(data)
        except wire.WireError as e:
            self._zdrop(e.reason)
            return
        if m.session != self.session_id:
            self._zdrop("session")
            return
        if self.peer is None or m.peer != self.peer:
            self._zdrop("peer")
            return
        req = self._requests.get(m.seq)
        if req is not None and req.ticks > self._heard:
            self._heard = req.ticks         # the process got this far, whatever its reply is worth
        if m.kind == wire.END:
            self.clock.post(self._ended, m)
        elif m.kind != wire.DATA:
            self._zdrop("kind")
        elif not wire.finite(m.values):
            self._zdrop("nonfinite")
        elif (reason := self._check_reply(m)) is not None:
            self._zdrop(reason)
        else:
            seq = m.seq
            if req is None:
                self._zdrop(self._classify(seq))
                return
            if m.ticks != req.ticks:
                self._zdrop("mismatch")
                return
            with self._lock:
                if seq in self._claimed:
                    self._zdrops["duplicate"] += 1
                    return
                self._claimed.add(seq)
            self.clock.post(self._receive, m)

    def _on_token(self, key_expr: str, alive: bool) -> None:
        try:
            peer = int(key_expr.rsplit("/", 1)[1], 16)
        except ValueError:
            return
        with self._lock:    # the claim is decided here, so that replies are filtered from now on
            if alive:
                if self.peer is None or peer == self.peer or not self.connected.is_set():
                    self.peer = peer
                    self.connected.set()
                    what = "claim"
                else:
                    what = "refuse"
                    self.refused.append(peer)
                    self._refused_alive.add(peer)
            elif peer == self.peer and self.connected.is_set():
                self.connected.clear()      # a new process may claim the node
                what = "lost"
            else:
                what = "left"
                self._refused_alive.discard(peer)
        if what == "refuse":
            # the refused process learns it at once (and again with every request while its
            # token stays: it may not have subscribed yet); the simulation records it at its next step
            self._pub.put(self.codec.encode(wire.REFUSED, 0, self.session_id, peer, 0, 0))
        self.clock.post(self._token, (peer, what))

    def _on_info(self, query: Any) -> None:
        query.reply(self.keys["info"], json.dumps(self.info()).encode())

    # simulation thread ---------------------------------------------------------------
    def info(self) -> dict:
        """What a process may ask on ``netcosim/<run>/<name>/info`` (JSON): wire
        version, session id (16 hex digits), remote name, its network index and the
        network's name -> index table (empty without a network), the encoding and the
        request and reply keys, LOCAL and BROADCAST
        addresses, period and deadline (s), values a reply must carry per destination,
        and the scenario's payload schema."""
        return {"version": wire.VERSION, "encoding": self.codec.name, "keys": {k: self.keys[k] for k in ("rx", "tx")},
                "session": f"{self.session_id:016x}", "name": self.name,
                "index": self._index(), "network": self._network_table(), "local": wire.LOCAL,
                "broadcast": wire.BROADCAST, "period": self.period, "deadline": self.deadline,
                "max_outstanding": self.max_outstanding, "schema": self.schema}

    def _index(self) -> int | None:
        return None

    def _network_table(self) -> dict[str, int]:
        return {}

    def _record(self, event: str, detail: str = "", count: int = 1) -> None:
        self._rows.append((self.sim.now_ticks, self.name, event, detail, count))

    def _count(self, event: str, detail: str = "", n: int = 1) -> None:
        """Count *n* events in the aggregated ``hil`` rows: a row at the first one, then at
        most one per :data:`AGGREGATE` s holding the count since the previous row."""
        now = self.sim.now_ticks
        entry = self._tally.get((event, detail))
        if entry is None:
            self._tally[(event, detail)] = [0, now]
            self._record(event, detail, n)
            return
        entry[0] += n
        if now - entry[1] >= self._aggregate_ticks:
            self._record(event, detail, entry[0])
            entry[0], entry[1] = 0, now

    def flush(self) -> None:
        """Write the counts not yet in a ``hil`` row (called at the end of every run,
        also a failed one; never aborts)."""
        self._fold(abort=False)
        for (event, detail), entry in self._tally.items():
            if entry[0]:
                self._record(event, detail, entry[0])
                entry[0], entry[1] = 0, self.sim.now_ticks

    def _fold(self, abort: bool = True) -> None:
        if not self._zdrops:
            return
        with self._lock:
            drops, self._zdrops = self._zdrops, Counter()
        for reason, n in drops.items():
            self._drop(reason, n, abort)

    def _drop(self, reason: str, n: int = 1, abort: bool = True) -> None:
        self.dropped[reason] += n
        self._count("dropped", reason, n)
        if reason not in self._warned:
            self._warned.add(reason)
            log.warning("remote %r: dropped a message (%s); further ones are counted, not logged", self.name, reason)
        if abort and reason in self.abort_on:
            self._abort(f"a reply was dropped ({reason})")

    def _abort(self, why: str) -> None:
        self._record("aborted", why)
        raise RemoteFault(f"remote {self.name!r}: {why} (abort_on={sorted(self.abort_on)})")

    def _classify(self, seq: int) -> str:
        """Why a reply to *seq*, which is not outstanding, is dropped."""
        if seq in self._answered_set:
            return "duplicate"

        age = (self._seq - 1 - seq) & 0xFFFFFFFF
        return "stale" if age < self._issued else "unsolicited"

    def _request(self, source: int, values: tuple[float, ...]) -> None:
        """Publish one request (or count why not) and arm its deadline."""
        self._fold()
        seq = self._seq
        self._seq = (seq + 1) & 0xFFFFFFFF
        self._issued = min(self._issued + 1, 1 << 31)
        now = self.sim.now_ticks
        self._forget(now)
        if not self.connected.is_set():     # decided on the Zenoh thread: no claimant now
            self.unserved += 1
            self._count("unserved")
            self._outcomes.append((now, self.name, seq, source, "unserved", -1))
            return
        if self._backlog() >= self.max_outstanding:
            self.overruns += 1
            self._count("overrun")
            self._outcomes.append((now, self.name, seq, source, "overrun", -1))
            self._lost("overrun")
            return
        for peer in list(self._refused_alive):
            self._pub.put(self.codec.encode(wire.REFUSED, 0, self.session_id, peer, 0, 0))
        deadline = now + self._deadline_ticks
        timer = self.sim.call_at_ticks(deadline, self._expire, arg=seq)
        self._requests[seq] = _Request(now, deadline, source, timer)
        self._pub.put(self.codec.encode(wire.DATA, source, self.session_id, self.peer or 0, now, seq, values))
        self.published += 1
        self.clock.expect_reply()

    def _backlog(self) -> int:
        """Requests the process has not answered in any way (in time, late or malformed)
        since the newest one it did answer: what may still wait in its queue."""
        n, heard = 0, self._heard
        for req in reversed(self._requests.values()):
            if req.ticks <= heard:
                break
            n += 1
        return n

    def _forget(self, now: int) -> None:
        """Forget requests older than ``stale_after``: expired ones no longer count as
        outstanding, and a reply to one, answered or not, is ``stale``."""
        horizon = now - self._stale_ticks
        answered = self._answered
        while answered and (answered[0][1] <= horizon or len(answered) > _ANSWERED_MEMORY):
            self._answered_set.discard(answered.popleft()[0])
        reqs = self._requests
        while reqs:
            seq, req = next(iter(reqs.items()))
            if not (req.expired and now - req.ticks >= self._stale_ticks):
                return
            del reqs[seq]
            self._claimed.discard(seq)

    def _expire(self, seq: int) -> None:
        req = self._requests.get(seq)
        if req is None or req.expired:
            return
        req.expired = True
        self.expired += 1
        self._outcomes.append((req.ticks, self.name, seq, req.source, "expired", -1))
        self._count("expired")
        self._lost("expired")

    def _lost(self, why: str) -> None:
        if why in self.abort_on:
            self._abort(f"a reply was lost ({why})")
        policy = self.loss_policy
        if policy == "zero":
            self._zero()
        elif callable(policy):
            policy(self, why)

    def _receive(self, m: wire.Message) -> None:
        self._fold()
        seq = m.seq
        req = self._requests.pop(seq, None)
        self._claimed.discard(seq)
        if req is None:                 # forgotten meanwhile
            self._drop(self._classify(seq))
            return
        if req.ticks > self._heard:
            self._heard = req.ticks
        self._answered.append((seq, req.ticks))
        self._answered_set.add(seq)
        if req.expired:
            self._drop("late")
            return
        req.timer.cancel()
        self.clock.reply_arrived()
        self.received += 1
        now = self.sim.now_ticks
        self._outcomes.append((req.ticks, self.name, seq, req.source, "replied", now - req.ticks))
        self._apply_to(m.node, m.values)

    def _ended(self, m: wire.Message) -> None:
        self._record("ended")       # the process has answered everything it will answer

    def _token(self, arg: tuple[int, str]) -> None:
        peer, what = arg
        hexid = f"{peer:016x}"
        if what == "refuse":
            self._record("refused", hexid)
            log.warning("remote %r: refused a second process claiming it (%s)", self.name, hexid)
        elif what == "left":
            self._record("left", hexid)     # a token that was not the claimant's went away
        elif what == "claim":
            if not self.alive:
                self.alive = True
                self._record("alive", hexid)
        elif self.alive:                    # lost
            self.alive = False
            policy = self.loss_policy
            self._record("lost", policy if isinstance(policy, str) else getattr(policy, "__name__", "callable"))
            for req in self._requests.values():
                req.timer.cancel()
            self._requests.clear()
            with self._lock:
                self._claimed.clear()
            self._lost("lost")

    # subclasses ------------------------------------------------------------------------
    def _check_reply(self, m: wire.Message) -> str | None:
        """Why reply *m* cannot be applied whatever the time (a drop reason), or None.
        Runs on a Zenoh thread: read only what does not change during the run."""
        return None

    def _apply_to(self, node: int, values: tuple[float, ...]) -> None:
        raise NotImplementedError

    def _zero(self) -> None:
        raise NotImplementedError

    # any thread, outside the run -----------------------------------------------------
    def counters(self) -> dict:
        """Requests published, replies applied, requests expired, overruns, requests
        while unclaimed, messages after the end, and the drops by reason (a dict)."""
        self._fold(abort=False)
        return {"published": self.published, "received": self.received, "expired": self.expired,
                "overruns": self.overruns, "unserved": self.unserved, "after_end": self.after_end,
                "dropped": dict(self.dropped), "refused": len(self.refused)}

    def requests(self):
        """One row per request of this remote (trace table ``hil_requests``), in the
        order of ``seq``: ``time`` of the request (s), ``seq``, ``source`` (network index,
        or LOCAL for a sample), ``outcome`` (:data:`OUTCOMES`), ``response`` (s, simulated:
        request published to reply injected; NaN unless ``replied``)."""
        df = self.sim.trace.frame("hil_requests")
        df = df[df["node"] == self.name]
        return df.sort_values(["time", "seq"], kind="stable").reset_index(drop=True)

    def response_times(self) -> np.ndarray:
        """The response time (s, simulated) of every applied reply, in the order of the
        requests."""
        df = self.requests()
        return df.loc[df["outcome"] == "replied", "response"].to_numpy()

    def wait_connected(self, timeout: float) -> bool:
        """Block up to *timeout* s until a process has claimed the node; True if one has."""
        return self.connected.wait(timeout)

    def finish(self) -> None:
        """Tell the process the run is over (an ``END`` message on ``rx``); call after
        ``sim.run``, also after a failed one.  Requests still waiting are recorded
        ``open``."""
        for seq, req in self._requests.items():
            if not req.expired:
                self._outcomes.append((req.ticks, self.name, seq, req.source, "open", -1))
                req.expired = True
        self.flush()
        self._pub.put(self.codec.encode(wire.END, 0, self.session_id, self.peer or 0, self.sim.now_ticks, self._seq))

    def drain(self, timeout: float = 5.0, quiet: float = 0.5) -> int:
        """After the run and :meth:`finish`, once the process is ending: count the valid
        replies that arrived after the run (``after_end``; replies in flight at the stop
        time, or scheduled after it by a lagging simulation); :func:`drain` for this
        remote alone.  Returns ``after_end``."""
        drain([self], timeout, quiet)
        return self.after_end

    def close(self) -> None:
        """Undeclare this remote's subscribers, token and queryable (idempotent); the
        process then sees the simulation gone.  The caller still closes the session."""
        decls, self._decls = self._decls, []
        for d in decls:
            try:
                d.undeclare()
            except Exception:   # the session is already closed: nothing left to undeclare
                pass

    def events(self):
        """The ``hil`` trace rows of this remote (``time`` in s; ``event``: alive, lost,
        refused, left, ended, dropped (detail: the reason), expired, overrun, unserved,
        aborted; ``count``: events aggregated in the row)."""
        df = self.sim.trace.frame("hil")
        return df[df["node"] == self.name].reset_index(drop=True)


def drain(remotes: Any, timeout: float = 5.0, quiet: float = 0.5) -> None:
    """After the run and each remote's :meth:`~_Remote.finish`: count, for every remote of
    *remotes* (sharing the simulation's clock), the valid replies that arrived after the
    run (``after_end``).  Each remote is done when its process's own END has come (it
    sends one after its last reply), or when its process is gone and then no message came
    for *quiet* s; waits at most *timeout* s in all.  Messages are routed to the remote
    they were posted for; nothing is applied."""
    remotes = list(remotes)
    if not remotes:
        return
    clock = remotes[0].clock
    ended: set[int] = set()
    gone = {id(r) for r in remotes if not r.alive}
    owners = {id(r): r for r in remotes}

    def route(fn: Any, arg: Any) -> None:
        owner = owners.get(id(getattr(fn, "__self__", None)))
        if owner is None:
            return
        if fn == owner._receive:
            owner.after_end += 1
        elif fn == owner._ended:
            ended.add(id(owner))
        elif fn == owner._token and arg[1] == "lost":
            gone.add(id(owner))
    for fn, arg in clock.take_pending():     # arrived, due after the stop time
        route(fn, arg)
    deadline = time.monotonic() + timeout
    while len(ended) < len(remotes) and (left := deadline - time.monotonic()) > 0:
        waiting_gone = all(i in ended or i in gone for i in owners)
        try:
            _, fn, arg = clock.inbox.get(timeout=min(left, quiet) if waiting_gone else left)
        except queue.Empty:
            break
        route(fn, arg)


class RemoteNode(_Remote):
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
        sim.call_at_ticks(int(sim.now_ticks), sample)


class RemotePlantIO(_Remote):
    """A process reads *plant*'s outputs and writes its inputs directly (no simulated network).

    Parameters
    ----------
    sim, session, run, loss_policy, abort_on, deadline, max_outstanding, stale_after, schema, encoding:
        As for :class:`RemoteNode` (``"zero"`` writes zeros to the inputs; the deadline
        defaults to *period*).
    plant:
        The :class:`~netcosim.continuous.PlantInstance`.
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
