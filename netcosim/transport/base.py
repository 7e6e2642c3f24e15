"""What every remote shares, whatever its requests come from: the session and the claim,
requests and their deadlines, the matching of replies, drops and counters, the loss
policy and the ``hil`` trace rows (:class:`BaseRemote`, as SimPy's ``BaseResource`` owns a
resource's bookkeeping); :class:`~netcosim.transport.remote.RemoteNode` and
:class:`~netcosim.transport.remote.RemotePlantIO` say where requests come from and how a
reply is applied.

A request is published on ``netcosim/<run>/<name>/rx`` with a fresh ``seq`` and the
simulated time ``ticks``; the process answers it with one reply on ``.../tx`` echoing both.

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
from typing import Any, Collection

import numpy as np

from .. import validate
from ..errors import ConfigurationError, NetcosimError
from ..timebase import RESOLUTION, to_ticks
from . import wire
from .codecs import codec
from .realtime import RealtimeClock
from .session import Session, key

__all__ = ["BaseRemote", "RemoteFault", "drain", "HIL_COLUMNS", "REQUEST_COLUMNS", "OUTCOMES", "LOSS_POLICIES",
           "DROP_REASONS", "LOSS_EVENTS", "AGGREGATE"]

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


class _Request:
    __slots__ = ("ticks", "deadline", "source", "timer", "expired")

    def __init__(self, ticks: int, deadline: int, source: int, timer: Any):
        self.ticks, self.deadline, self.source, self.timer, self.expired = ticks, deadline, source, timer, False


class BaseRemote:
    """The bookkeeping every remote shares: session and claim, keys and liveliness,
    requests and their deadlines, matching and dropping replies, counters, the loss
    policy and the ``hil`` trace rows.  A subclass says where requests come from (it
    calls :meth:`_request`) and how a reply is applied (:meth:`_apply_to`,
    :meth:`_check_reply`, :meth:`_zero`).

    ``period`` (s): the period of the requests; ``deadline`` (s of simulated time, default
    the period): a reply must be injected before it; ``max_outstanding`` (default
    ``ceil(deadline / period) + 1``); ``stale_after`` (s, default 100 deadlines); ``name``:
    the ``<node>`` of its keys; ``clock_options``: the :class:`RealtimeClock`'s keywords;
    ``sim``, ``session``, ``run``, ``loss_policy``, ``abort_on``, ``schema``, ``encoding``
    as documented for :class:`~netcosim.transport.remote.RemoteNode`.
    """

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
        timer = self.sim._call_at_ticks(deadline, self._expire, arg=seq)
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
        remote alone (*timeout*, *quiet*: s, as there).  Returns ``after_end``."""
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
        aborted; ``count``: events aggregated in the row).  Counts not yet in a row -- a
        reply dropped after the run's last row, e.g. a duplicate that arrived while the
        run was draining -- are written first, so the rows add up to :meth:`counters`."""
        self.flush()
        df = self.sim.trace.frame("hil")
        return df[df["node"] == self.name].reset_index(drop=True)


def drain(remotes: Any, timeout: float = 5.0, quiet: float = 0.5) -> None:
    """After the run and each remote's :meth:`~BaseRemote.finish`: count, for every remote of
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
