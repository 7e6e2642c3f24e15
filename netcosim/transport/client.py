"""The library a real process uses to stand in for a remote node (stdlib and Zenoh only).

It imports neither SimPy, NumPy nor CasADi, so it runs where only Python and
``eclipse-zenoh`` are installed.  A process connects to the simulation's endpoint,
declares its liveliness token, receives the frames the simulated network delivers to
its node and publishes its own::

    from netcosim.transport.client import RemoteProcess

    with RemoteProcess("controller", run=RUN, connect=["tcp/127.0.0.1:PORT"]) as rp:
        for msg in rp.messages():          # until the simulation's END message
            t, y = msg.values
            rp.reply(msg, (t, law(t, y)))  # to the sender, echoing its seq

or a periodic loop with :meth:`RemoteProcess.periodic` (deadline misses counted), or
:meth:`RemoteProcess.serve` to answer every message from the receiving thread (no
thread hop: the shortest round trip).
Message fields: :class:`netcosim.transport.wire.Message`.
"""

from __future__ import annotations

import queue
import secrets
import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Sequence

from .. import validate
from ..errors import ConfigurationError
from . import wire
from .codecs import codec
from .session import DEFAULT_LEASE, Session, key, open_session

__all__ = ["RemoteProcess", "LoopStats", "periodic", "add_arguments", "connect", "finish"]


@dataclass
class LoopStats:
    """Result of :meth:`RemoteProcess.periodic`: ``periods`` run, ``misses`` (a body that
    ended after the start of the next period; that period starts late, none is skipped),
    ``max_overrun`` (s, the largest lateness of a period's start), ``period`` (s)."""

    period: float
    periods: int = 0
    misses: int = 0
    max_overrun: float = 0.0

    @property
    def miss_ratio(self) -> float:
        """``misses / periods`` (0 for no period)."""
        return self.misses / self.periods if self.periods else 0.0


def periodic(period: float, body: Callable[[int], bool | None], *, duration: float | None = None,
             clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep,
             stop: Callable[[], bool] = lambda: False) -> LoopStats:
    """Call ``body(k)`` at ``t0 + k * period`` s (k = 0, 1, ...) until it returns True,
    ``stop()`` is true or *duration* s have passed; count deadline misses.

    A body that ends after the start of the next period is a miss: the next period
    starts at once (late; none is skipped, so a transient overload is caught up).
    ``clock``/``sleep`` (s) are injectable for tests.  A NaN or negative *duration*
    raises :class:`~netcosim.errors.ConfigurationError` naming it.
    """
    validate.positive(period, "period", kind="a positive finite number of seconds",
                      type_error=ConfigurationError)       # a ValueError, as it always was
    if duration is not None:
        validate.real(duration, "duration", lo=0.0, allow_inf=True,
                      kind="None or a non-negative number of seconds (inf: until stopped)")
    stats = LoopStats(float(period))
    t0 = clock()
    k = 0
    while not stop() and (duration is None or k * period < duration):
        late = clock() - (t0 + k * period)
        if late > stats.max_overrun:
            stats.max_overrun = late
        done = body(k)
        stats.periods += 1
        if done:
            break
        k += 1
        wait = t0 + k * period - clock()
        if wait > 0:
            sleep(wait)
        else:
            stats.misses += 1
    return stats


class RemoteProcess:
    """The process side of a remote node called *node* of run *run*.

    ``connect``: the simulation's endpoints (``Session.endpoints`` of its side, printed
    by ``netcosim hil``); ``listen``: endpoints to listen on (default none); ``lease``:
    seconds of silence after which the simulation declares this process gone (and this
    process the simulation); ``session``: serve only this session id (an int, or 16 hex
    digits as printed; default: the first simulation of run *run* seen, through its
    liveliness token or the first request addressed to this process); ``config``: a
    Zenoh configuration file (authentication, TLS; see ``docs/hil_security.md``);
    ``encoding``: ``"ncsm"`` (default) or ``"cdr"``, as the simulation's.

    The process draws a random id (``peer``), declares the liveliness token
    ``netcosim/<run>/<node>/alive/<peer>`` and watches the simulation's token
    ``netcosim/<run>/<node>/sim/<session>``.  It serves one session: messages of another
    session or addressed to another process are dropped and counted.  The run is over
    when the simulation's END arrives (``status == "ended"``, answered with this
    process's own END after its last reply), when the simulation's token goes without an
    END (``"gone"``: it died, or hung for a lease), or when the simulation refused this
    process because another one serves the node (``"refused"``); ``reason`` says it in
    one line and :attr:`exit_code` gives the exit status a program should return.

    Counters: ``received`` DATA messages of this session, ``published`` replies sent,
    ``dropped`` invalid or foreign messages by reason.
    """

    def __init__(self, node: str, *, run: str, connect: Sequence[str], listen: Sequence[str] = (),
                 lease: float = DEFAULT_LEASE, session: int | str | None = None, config: str | None = None,
                 encoding: str = "ncsm"):
        self.node = node
        self.run = run
        self.codec = codec(encoding)
        self.keys = {leaf: key(run, node, leaf) for leaf in ("alive", "sim", "info")}
        self.keys.update({leaf: self.codec.data_key(run, node, leaf) for leaf in ("rx", "tx")})
        self.peer = secrets.randbits(64) or 1
        self.session_id: int | None = None if session is None else (
            int(session, 16) if isinstance(session, str) else int(session))
        self._fixed_session = session is not None
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()
        self.received = 0
        self.published = 0
        self.dropped: dict[str, int] = {}
        self.status = "running"
        self.reason = ""
        self._handler: Callable[[wire.Message], Sequence[float] | None] | None = None
        self._error: BaseException | None = None
        self._last_rx = 0.0             # monotonic time of the last message served (serve)
        kw = {} if config is None else {"config": config}
        self.session: Session = open_session(listen=listen, connect=connect, lease=lease, **kw)
        try:
            self._pub = self.codec.publisher(self.session, self.keys["tx"], self.peer)
            self._sub = self.session.subscribe(self.keys["rx"], self._on_rx)
            self._sim = self.session.watch_keys(self.keys["sim"] + "/*", self._on_sim)
            self._token = self.session.token(f"{self.keys['alive']}/{self.peer:016x}")
        except BaseException:
            self.session.close()
            raise

    @property
    def ended(self) -> bool:
        """True once the simulation's END message arrived."""
        return self.status == "ended"

    @property
    def exit_code(self) -> int:
        """What a remote program returns: 0 after the simulation's END, 3 when the
        simulation is gone without one, 4 when refused, 5 when no message came for the
        idle timeout, 1 while still running."""
        return {"ended": 0, "gone": 3, "refused": 4, "idle": 5}.get(self.status, 1)

    def _drop(self, reason: str) -> None:
        self.dropped[reason] = self.dropped.get(reason, 0) + 1

    def _stop(self, status: str, reason: str) -> None:
        if self.status == "running":
            self.status, self.reason = status, reason
        self.inbox.put(None)            # wake a waiting receive()

    def _on_sim(self, key_expr: str, alive: bool) -> None:
        try:
            sid = int(key_expr.rsplit("/", 1)[1], 16)
        except ValueError:
            return
        if alive:
            if self.session_id is None:
                self.session_id = sid
        elif sid == self.session_id and self.status == "running":
            self._stop("gone", f"the simulation of run {self.run} (session {sid:016x}) is gone without ending "
                               "the run (killed, or silent for the lease)")

    def _accept(self, data: bytes) -> wire.Message | None:
        """The message in *data* if it is for this process, else None (counted)."""
        try:
            m = self.codec.decode(data)
        except wire.WireError as e:
            self._drop(e.reason)
            return None
        if m.peer != self.peer and m.peer != 0:
            self._drop("peer")          # addressed to another process (or refusing it)
            return None
        if self.session_id is None and not self._fixed_session and m.kind == wire.DATA and m.peer == self.peer:
            self.session_id = m.session     # addressed to us: the simulation that accepted our claim
        if m.session != self.session_id:
            self._drop("session")
            return None
        if m.kind == wire.REFUSED:
            self._stop("refused", f"node {self.node!r} of run {self.run} is already served by another process; "
                                  "this one was refused")
            return None
        return m

    def _on_rx(self, data: bytes) -> None:
        handler = self._handler
        if handler is None or self._error is not None:
            self.inbox.put(data)
            return
        m = self._accept(data)
        if m is None:
            return
        if m.kind == wire.END:
            self.inbox.put(data)        # the waiting thread answers it and ends serve()
            return
        self.received += 1
        self._last_rx = time.monotonic()
        try:
            out = handler(m)
            if out is not None:
                self.reply(m, out)
        except BaseException as e:      # re-raised by serve() in its own thread
            self._error = e
            self.inbox.put(None)

    def serve(self, handler: Callable[[wire.Message], Sequence[float] | None], timeout: float | None = None) -> None:
        """Answer every request until the run ends: ``handler(msg)`` runs on the
        receiving (Zenoh) thread as the message arrives and its result, if not None, is
        sent back with :meth:`reply`.  Returns once the run is over (see the class
        docstring: ``status``), or once no message has arrived for *timeout* s (None:
        wait forever; then ``status == "idle"``); an exception of *handler* stops
        serving and is re-raised here.  Keep *handler* short: the next message waits
        for it."""
        self._handler = handler
        self._last_rx = time.monotonic()
        try:
            while self.status == "running":
                # messages answered on the receiving thread count as activity: wait for the
                # rest of *timeout* after the last one, not *timeout* after serving began
                wait = None if timeout is None else max(0.0, self._last_rx + timeout - time.monotonic())
                got = self.receive(wait, _idle=False)
                if self._error is not None:
                    raise self._error
                if got is None:
                    if self.status != "running":
                        return
                    if timeout is not None and time.monotonic() - self._last_rx >= timeout:
                        self._stop("idle", f"no message for {timeout} s")
                        return
                    continue
                out = handler(got)          # a message that arrived before serving began
                if out is not None:
                    self.reply(got, out)
        finally:
            self._handler = None

    def receive(self, timeout: float | None = None, *, _idle: bool = True) -> wire.Message | None:
        """The next request for this process, waiting up to *timeout* s (None: forever);
        None on timeout (``status`` becomes ``"idle"``) or once the run is over.  Invalid
        and foreign messages are counted and skipped.  ``_idle`` (internal): False leaves
        ``status`` as it is on a timeout (:meth:`serve` keeps waiting)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.status == "running":
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            try:
                data = self.inbox.get(timeout=left)
            except queue.Empty:
                if _idle:
                    self._stop("idle", f"no message for {timeout} s")
                return None
            if self._error is not None:     # a handler of serve() failed
                return None
            if data is None:                # stopped (the loop condition says so)
                continue
            m = self._accept(data)
            if m is None:
                continue
            if m.kind == wire.END:
                # answer with our own END: the simulation then knows every reply has arrived
                self._pub.put(self.codec.encode(wire.END, 0, m.session, self.peer, m.ticks, m.seq))
                self.status, self.reason = "ended", "the simulation ended the run"
                return None
            self.received += 1
            return m
        return None

    def messages(self, timeout: float | None = None) -> Iterator[wire.Message]:
        """Every request until the run is over (or none arrives for *timeout* s)."""
        while True:
            m = self.receive(timeout)
            if m is None:
                return
            yield m

    def reply(self, msg: wire.Message, values: Sequence[float], *, to: int | None = None) -> None:
        """Answer request *msg* with *values*: echoes its ``seq`` and ``ticks``; sent to
        its sender (``to=None``: the network index it came from, or LOCAL for a sample),
        or to network index *to* (:data:`~netcosim.transport.wire.BROADCAST`: every node;
        :data:`~netcosim.transport.wire.LOCAL`: the node's plant inputs).  One reply per
        request: the simulation drops any further one (``duplicate``)."""
        session = self.session_id if self.session_id is not None else msg.session
        self._pub.put(self.codec.encode(wire.DATA, msg.node if to is None else to, session, self.peer, msg.ticks,
                                  msg.seq, values))
        self.published += 1

    def info(self, timeout: float = 5.0) -> dict:
        """The run's parameters the simulation answers on ``netcosim/<run>/<node>/info``
        (JSON: session, the network's name -> index table, period, deadline, schema),
        waiting up to *timeout* s (:class:`TimeoutError` if no simulation answers)."""
        import json
        for reply in self.session.zenoh.get(self.keys["info"], timeout=timeout):
            ok = getattr(reply, "ok", None)
            if ok is not None:
                return json.loads(ok.payload.to_bytes())
        raise TimeoutError(f"no simulation answered {self.keys['info']!r} within {timeout} s")

    def periodic(self, period: float, body: Callable[[int], bool | None], *, duration: float | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> LoopStats:
        """:func:`periodic` (``period`` in s) that also stops when the run is over: ``body(k)``
        is called at ``t0 + k * period`` until it returns True, the run is over or
        *duration* s (None: no limit) have passed; ``clock`` (a monotonic time in s) and
        ``sleep`` (s) are injectable for tests."""
        return periodic(period, body, duration=duration, clock=clock, sleep=sleep,
                        stop=lambda: self.status != "running")

    def counters(self) -> dict:
        """``received``, ``published``, ``dropped`` (by reason), ``status``: what the example
        programs print as JSON on their last line."""
        return {"received": self.received, "published": self.published, "dropped": dict(self.dropped),
                "status": self.status}

    def close(self, linger: float = 0.1) -> None:
        """Drop the liveliness token and close the session (idempotent), after *linger* s
        if anything was published (closing at once can drop messages still queued)."""
        if self.published and not self.session.zenoh.is_closed():
            time.sleep(linger)
        self.session.close()

    def __enter__(self) -> "RemoteProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def add_arguments(parser: Any) -> None:
    """The options every remote program accepts (``netcosim hil`` prints them): ``--run``,
    ``--node``, ``--connect`` (repeatable), ``--session``, ``--lease``, ``--idle``,
    ``--zenoh-config``, ``--encoding``: added to *parser*, an :class:`argparse.ArgumentParser`."""
    parser.add_argument("--run", required=True, help="run id printed by the simulation side")
    parser.add_argument("--node", required=True, help="name of the remote node (or plant)")
    parser.add_argument("--connect", action="append", required=True, help="endpoint, e.g. tcp/127.0.0.1:7447")
    parser.add_argument("--session", help="serve only this session id (16 hex digits; default: the first seen)")
    parser.add_argument("--idle", type=float, default=10.0, help="give up after this many seconds without a message")
    parser.add_argument("--lease", type=float, default=DEFAULT_LEASE, help="liveliness lease of the session (s)")
    parser.add_argument("--zenoh-config", help="a Zenoh configuration file (authentication, TLS)")
    parser.add_argument("--encoding", choices=["ncsm", "cdr"], default="ncsm",
                        help="message encoding, as the simulation's (default ncsm; cdr: ROS 2-friendly)")


def connect(args: Any) -> RemoteProcess:
    """The :class:`RemoteProcess` of *args*, the parsed :func:`add_arguments` options (an
    :class:`argparse.Namespace`)."""
    return RemoteProcess(args.node, run=args.run, connect=args.connect, lease=args.lease, session=args.session,
                         config=args.zenoh_config, encoding=args.encoding)


def finish(rp: RemoteProcess, extra: dict | None = None) -> int:
    """End the remote program of *rp*: print its counters (and *extra*) as JSON on the last line of
    stdout, the reason on stderr when the run did not end normally; return the exit status.

    When the simulation is gone (``status == "gone"``) the process exits here, at once,
    with :attr:`RemoteProcess.exit_code` (:func:`os._exit`, after flushing): closing a
    Zenoh session whose peer is hung waits 10 s for it (measured with eclipse-zenoh
    1.10.2), and a remote must be done within a lease of its simulation's end."""
    import json
    import os
    import sys
    print(json.dumps({**rp.counters(), **(extra or {})}), flush=True)
    if rp.status != "ended":
        print(f"{sys.argv[0] if sys.argv else 'remote'}: {rp.reason}", file=sys.stderr, flush=True)
    if rp.status == "gone":
        os._exit(rp.exit_code)
    return rp.exit_code


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m netcosim.transport.client --run RUN --node NODE --connect ENDPOINT``: an
    echo process (answers every request with its own values, to its sender); prints its
    counters as JSON when the run is over; exit status :attr:`RemoteProcess.exit_code`.
    *argv*: the arguments (None: ``sys.argv[1:]``)."""
    import argparse
    p = argparse.ArgumentParser(prog="python -m netcosim.transport.client", description=main.__doc__)
    add_arguments(p)
    a = p.parse_args(argv)
    with connect(a) as rp:
        rp.serve(lambda msg: msg.values, timeout=a.idle)
        return finish(rp)


if __name__ == "__main__":
    raise SystemExit(main())
