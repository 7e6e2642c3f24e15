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
import time
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

from . import wire
from .session import DEFAULT_LEASE, Session, key, open_session

__all__ = ["RemoteProcess", "LoopStats", "periodic"]


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
    ``clock``/``sleep`` (s) are injectable for tests.
    """
    if not (isinstance(period, (int, float)) and period > 0):
        raise ValueError(f"period must be a positive number of seconds, got {period!r}")
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
    seconds of silence after which the simulation declares this process gone.

    Counters: ``received`` valid DATA messages, ``published`` messages sent,
    ``rejected`` invalid messages by reason, ``ended`` True once the simulation's END
    message arrived (the process answers it with its own END, after its last reply).
    """

    def __init__(self, node: str, *, run: str, connect: Sequence[str], listen: Sequence[str] = (),
                 lease: float = DEFAULT_LEASE):
        self.node = node
        self.keys = {leaf: key(run, node, leaf) for leaf in ("rx", "tx", "alive")}
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()
        self.received = 0
        self.published = 0
        self.rejected: dict[str, int] = {}
        self.ended = False
        self._seq = 0
        self._handler: Callable[[wire.Message], Sequence[float] | None] | None = None
        self._error: BaseException | None = None
        self._last_rx = 0.0             # monotonic time of the last message served (serve)
        self.session: Session = open_session(listen=listen, connect=connect, lease=lease)
        try:
            self._pub = self.session.publisher(self.keys["tx"])
            self._sub = self.session.subscribe(self.keys["rx"], self._on_rx)
            self._token = self.session.token(self.keys["alive"])
        except BaseException:
            self.session.close()
            raise

    def _decode(self, data: bytes) -> wire.Message | None:
        """The message in *data*, or None when it is invalid (counted in ``rejected`` by reason)."""
        try:
            return wire.decode(data)
        except wire.WireError as e:
            self.rejected[e.reason] = self.rejected.get(e.reason, 0) + 1
            return None

    def _on_rx(self, data: bytes) -> None:
        handler = self._handler
        if handler is None or self._error is not None:
            self.inbox.put(data)
            return
        m = self._decode(data)
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
            self.inbox.put(b"")

    def serve(self, handler: Callable[[wire.Message], Sequence[float] | None], timeout: float | None = None) -> None:
        """Answer every DATA message until the run ends: ``handler(msg)`` runs on the
        receiving (Zenoh) thread as the message arrives and its result, if not None, is
        sent back with :meth:`reply`.  Returns once the simulation's END message came, or
        once no message has arrived for *timeout* s (None: wait forever); an exception
        of *handler* stops serving and is re-raised here.  Keep *handler* short: the
        next message waits for it."""
        self._handler = handler
        self._last_rx = time.monotonic()
        try:
            while not self.ended:
                # messages answered on the receiving thread count as activity: wait for the
                # rest of *timeout* after the last one, not *timeout* after serving began
                wait = None if timeout is None else max(0.0, self._last_rx + timeout - time.monotonic())
                got = self.receive(wait)
                if self._error is not None:
                    raise self._error
                if got is None:
                    if self.ended or timeout is None or time.monotonic() - self._last_rx >= timeout:
                        return
                    continue
                out = handler(got)          # a message that arrived before serving began
                if out is not None:
                    self.reply(got, out)
        finally:
            self._handler = None

    def receive(self, timeout: float | None = None) -> wire.Message | None:
        """The next DATA message for this node, waiting up to *timeout* s (None: forever);
        None on timeout or once the run has ended.  Invalid messages are counted and skipped."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self.ended:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            try:
                data = self.inbox.get(timeout=left)
            except queue.Empty:
                return None
            if self._error is not None:     # a handler of serve() failed
                return None
            m = self._decode(data)
            if m is None:
                continue
            if m.kind == wire.END:
                # answer with our own END: the simulation then knows every reply has arrived
                self._pub.put(wire.encode(wire.END, 0, self._seq, m.ticks))
                self.ended = True
                return None
            self.received += 1
            return m
        return None

    def messages(self, timeout: float | None = None) -> Iterator[wire.Message]:
        """Every DATA message until the run ends (or none arrives for *timeout* s)."""
        while True:
            m = self.receive(timeout)
            if m is None:
                return
            yield m

    def publish(self, dst: int, values: Sequence[float], *, seq: int | None = None, ticks: int = 0) -> None:
        """Send *values* to the node with network index *dst* through the simulated network.
        ``seq`` defaults to this process's own counter (pass a received ``seq`` to mark a
        reply); ``ticks`` is informational (the simulation stamps the arrival itself)."""
        if seq is None:
            seq = self._seq
            self._seq += 1
        self._pub.put(wire.encode(wire.DATA, dst, seq, ticks, values))
        self.published += 1

    def reply(self, msg: wire.Message, values: Sequence[float]) -> None:
        """Send *values* back to the sender of *msg*, echoing its ``seq`` (the simulation
        logs the response time of the reply)."""
        self.publish(msg.node, values, seq=msg.seq, ticks=msg.ticks)

    def periodic(self, period: float, body: Callable[[int], bool | None], *, duration: float | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> LoopStats:
        """:func:`periodic` (``period`` in s) that also stops when the run ends."""
        return periodic(period, body, duration=duration, clock=clock, sleep=sleep, stop=lambda: self.ended)

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


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m netcosim.transport.client --run RUN --node NODE --connect ENDPOINT``: an
    echo process (answers every message with its own values, to its sender); prints its
    counters as JSON when the run ends.  Every remote process accepts these three options
    (``netcosim hil`` prints them)."""
    import argparse
    import json
    p = argparse.ArgumentParser(prog="python -m netcosim.transport.client", description=main.__doc__)
    p.add_argument("--run", required=True, help="run id printed by the simulation side")
    p.add_argument("--node", required=True, help="name of the remote node")
    p.add_argument("--connect", action="append", required=True, help="endpoint, e.g. tcp/127.0.0.1:7447")
    p.add_argument("--idle", type=float, default=10.0, help="give up after this many seconds without a message")
    p.add_argument("--lease", type=float, default=DEFAULT_LEASE, help="liveliness lease of the session (s)")
    a = p.parse_args(argv)
    with RemoteProcess(a.node, run=a.run, connect=a.connect, lease=a.lease) as rp:
        rp.serve(lambda msg: msg.values, timeout=a.idle)
        print(json.dumps({"received": rp.received, "published": rp.published, "rejected": rp.rejected,
                          "ended": rp.ended}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
