"""The clock layer below the simulation, the kernel and the networks.

What every part that schedules something needs, and nothing more: the engine that
drives SimPy (:class:`Engine`, and :class:`RealtimeEngine` against the wall clock),
the SimPy event priorities netcosim uses to order simultaneous events, one
cancellable timer class and one re-armable event, and a process-independent hash
for naming random streams.  Times here are integer ticks
(:mod:`netcosim.timebase`); the seconds API lives on
:class:`~netcosim.sim.Simulation`.

This is the only module that knows SimPy's private fields (``_now``, ``_queue``,
``_eid``, an event's ``_ok`` and ``_value``); ``tests/test_clock.py`` fails on any
other module that touches them.  Everything else uses :class:`Engine`'s public face:
``engine.now`` (ticks, a plain attribute), :meth:`Engine.at`, :meth:`Engine.mark`,
``peek()``, :class:`Timer` and :class:`Rearmable`.  One exception, measured: the
kernel's per-job path (a segment timer and a periodic release re-armed, the check
"nothing else due now") pushes ``(time, priority, next(engine.ids), event)`` onto
``engine.queue`` itself and reads ``engine.queue[0][0]``, because a method call there
costs 2.6 % of a job (cachegrind, 48.8k against 50.0k instructions per job).  That
layout, the fields and the processing of an event are what :func:`check_simpy` checks
at import, failing loudly if the installed SimPy differs (``pyproject.toml`` pins
SimPy's major version).

Why not subclass less: SimPy's ``Environment.now`` is a property (a call per read)
and ``schedule`` takes a delay (an addition and a call per event); the kernel reads
the time and schedules a few times per job, so the engine keeps ``now`` as an
attribute and schedules at absolute times.
"""

from __future__ import annotations

import hashlib
import math
from heapq import heappop, heappush
from itertools import count
from time import monotonic
from typing import Any, Callable

import simpy
import simpy.rt

from .timebase import RESOLUTION, to_seconds

__all__ = ["URGENT", "NORMAL", "DISPATCH", "ARBITRATE", "Engine", "RealtimeEngine", "Timer", "Rearmable",
           "MAINTAIN_EVERY", "check_simpy", "stable_hash"]

#: Priority for events that must precede ordinary ones at the same instant.
URGENT = simpy.events.URGENT
#: Priority of ordinary events (releases, segment ends, frame ends, user calls).
NORMAL = simpy.events.NORMAL
#: Kernel dispatch decisions: after every ordinary event of the same instant, so that
#: all releases and arrivals of an instant are seen before the kernel picks a job.
DISPATCH = 2
#: Medium arbitration (CAN, shared buses): after the kernels of the same instant have
#: dispatched, so that every frame queued at that instant competes.
ARBITRATE = DISPATCH + 1


def stable_hash(name: str) -> int:
    """A 64-bit hash of *name* that is the same in every process and Python run."""
    return int.from_bytes(hashlib.blake2b(name.encode("utf-8"), digest_size=8).digest(), "little")


_NOARG = object()


def _call(timer: "Timer") -> None:
    if timer.arg is _NOARG:
        timer.fn()
    else:
        timer.fn(timer.arg)


class Timer(simpy.events.Event):
    """A callback scheduled ``delay`` ticks from now that can be cancelled before it fires.

    ``Timer(env, delay, callback, arg)``: SimPy's firing calls ``callback(timer)``
    directly (the kernel's hot path: the callback reads ``timer.arg``).
    ``Timer.call(env, delay, fn, arg)``: the firing calls ``fn()``, or ``fn(arg)`` when
    *arg* is given (what :meth:`Simulation.call_at <netcosim.sim.Simulation.call_at>`
    returns).  ``cancel()`` empties the callback list: a cancelled timer stays in SimPy's
    queue and fires into nothing.  ``priority``: SimPy's event priority among events of
    the same instant, smaller first (:data:`URGENT`, then :data:`NORMAL`, the default,
    then the kernel's :data:`DISPATCH` and :data:`ARBITRATE`).
    """

    __slots__ = ("arg", "fn")
    arg: Any
    fn: Callable[..., Any]
    NOARG = _NOARG

    def __init__(self, env: "Engine", delay: int, callback: Callable[["Timer"], None],
                 arg: Any = None, priority: int = NORMAL):
        self.env = env
        self.arg = arg
        self._ok = True
        self._value = None
        self.callbacks = [callback]
        # env.schedule(self, priority, delay), inlined: a timer is created per job segment
        queue: list = env._queue
        heappush(queue, (env._now + delay, priority, next(env._eid), self))

    def rearm(self, at: int, callbacks: list, priority: int = NORMAL) -> None:
        """Schedule this timer again, after it fired, at absolute time *at* (ticks) with
        *callbacks* (a periodic release re-uses one timer instead of making one per job),
        at event *priority* (as for the class)."""
        self.callbacks = callbacks
        env = self.env
        queue: list = env._queue
        heappush(queue, (at, priority, next(env._eid), self))

    @classmethod
    def call(cls, env: "Engine", delay: int, fn: Callable, arg: Any = _NOARG,
             priority: int = NORMAL) -> "Timer":
        """A timer on *env* (the simulation's SimPy environment), *delay* ticks from now, whose
        firing calls ``fn()`` (or ``fn(arg)``); *priority* as for the class."""
        t = cls(env, delay, _call, arg, priority)
        t.fn = fn
        return t

    def cancel(self) -> None:
        """Make the timer a no-op (idempotent; harmless after it fired)."""
        if self.callbacks:
            self.callbacks = []

    @property
    def pending(self) -> bool:
        """True until the timer fires or is cancelled."""
        return bool(self.callbacks)


class Rearmable(simpy.events.Event):
    """A succeeded event that is scheduled again and again (a node's dispatch decision):
    :meth:`arm` puts it in the queue at absolute time *at* with *callbacks*; it must have
    fired (its callbacks spent) before it is armed again."""

    __slots__ = ()

    def __init__(self, env: "Engine"):
        self.env = env
        self._ok = True
        self._value = None
        self.callbacks = None  # type: ignore[assignment]  # not scheduled

    def arm(self, at: int, priority: int, callbacks: list) -> None:
        """Schedule the event at *at* (ticks) with *priority*; firing calls *callbacks*."""
        self.callbacks = callbacks
        env = self.env
        queue: list = env._queue
        heappush(queue, (at, priority, next(env._eid), self))


#: events between two calls of the engine's ``maintain`` (the trace's
#: :meth:`~netcosim.trace.Trace.maintain`, which encodes the rows appended since)
MAINTAIN_EVERY = 256


class Engine(simpy.Environment):
    """SimPy's environment as netcosim drives it: time in integer ticks from 0.

    ``now`` is the current time (ticks), a plain attribute kept equal to SimPy's own
    (reading it costs no call); :meth:`at` schedules an event at an absolute time;
    :meth:`run_until` is SimPy's ``run`` with its ``step`` inlined and a ``maintain()``
    call every :data:`MAINTAIN_EVERY` events.  Every SimPy event, process and timeout
    works as in a plain ``simpy.Environment``.
    """

    now = 0     # shadows SimPy's property: an instance attribute from __init__ on

    def __init__(self) -> None:
        super().__init__(initial_time=0)
        self.now = 0
        #: SimPy's event queue and event-id counter under public names (the same objects:
        #: SimPy never rebinds them), for the kernel's per-job paths, which inline
        #: :meth:`at` and ``peek()`` (a method call per job saved): push
        #: ``(at, priority, next(ids), event)`` onto ``queue`` with ``heapq.heappush``;
        #: ``queue[0][0]`` is the next event's time.  :func:`check_simpy` pins that layout.
        self.queue: list = self._queue
        self.ids: count = self._eid
        #: called every MAINTAIN_EVERY events by run_until (None: nothing)
        self.maintain: Callable[[], object] | None = None

    def at(self, at: int, priority: int, event: simpy.events.Event) -> None:
        """Schedule *event* (already triggered: ``_ok``/``_value`` set, callbacks attached)
        at absolute time *at* (ticks, not before ``now``) with *priority*."""
        queue: list = self._queue
        heappush(queue, (at, priority, next(self._eid), event))

    @property
    def queued(self) -> int:
        """Events in the queue (cancelled timers included: they fire into nothing)."""
        return len(self._queue)

    def mark(self) -> int:
        """A fresh event id: an id drawn later is larger iff something was scheduled in
        between (ids order the events of one instant and priority)."""
        return next(self._eid)

    def step(self) -> None:
        """SimPy's ``Environment.step``, with ``now`` set to the event's time before its
        callbacks run (as SimPy sets its own)."""
        queue: list = self._queue
        if queue:
            self.now = queue[0][0]
        simpy.Environment.step(self)

    def run_until(self, stop: int) -> None:
        """``run(until=stop)`` for ``stop > now``, with :meth:`step` inlined.

        The same stop event (urgent, at *stop*), the same order of events and callbacks,
        the same handling of ``StopSimulation`` and of failed events as SimPy 4's ``run``
        and ``step``; the method call per event is saved.
        """
        until = simpy.events.Event(self)
        until._ok = True
        until._value = None
        queue: list = self._queue
        heappush(queue, (stop, URGENT, next(self._eid), until))
        maintain = self.maintain
        countdown = MAINTAIN_EVERY
        while True:
            now, _, _, event = heappop(queue)  # `until` is in the queue: it never runs empty first
            self._now = self.now = now
            if event is until:
                until.callbacks = None  # as SimPy marks a processed event
                return
            countdown -= 1
            if not countdown:
                countdown = MAINTAIN_EVERY
                if maintain is not None:
                    maintain()
            callbacks, event.callbacks = event.callbacks, None
            try:
                for callback in callbacks:
                    callback(event)
            except simpy.core.StopSimulation:
                event.callbacks = callbacks[callbacks.index(callback) + 1:]
                self.schedule(event, simpy.core.EventPriority(-1))
                return
            if not event._ok and not hasattr(event, "_defused"):
                exc = type(event._value)(*event._value.args)
                exc.__cause__ = event._value
                raise exc


class RealtimeEngine(Engine):
    """An :class:`Engine` that processes each event no earlier than its wall-clock time:
    one simulated second takes *factor* wall-clock seconds (SimPy's
    ``RealtimeEnvironment`` with a lag tolerance in seconds instead of one time unit, and
    the lags recorded).

    *strict*: raise when an event is processed more than *max_lag* seconds late;
    otherwise record ``(simulated time s, lag s)`` in ``lags``.
    """

    def __init__(self, factor: float, strict: bool, max_lag: float):
        super().__init__()
        self.factor = factor * RESOLUTION      # wall seconds per tick
        self.strict_lag = strict
        self.max_lag = max_lag
        self.lags: list[tuple[float, float]] = []
        self.steps = 0
        self.env_start = 0
        self.real_start = monotonic()

    def sync(self) -> None:
        """Pin simulated time *now* to wall-clock time *now*."""
        self.env_start = self.now
        self.real_start = monotonic()

    def step(self) -> None:
        evt_time: Any = self.peek()     # integer ticks, or inf when the queue is empty
        if evt_time == math.inf:
            raise simpy.core.EmptySchedule
        real_time = self.real_start + (evt_time - self.env_start) * self.factor
        lag = monotonic() - real_time
        if lag > 0:
            if lag > self.max_lag:
                t = to_seconds(evt_time)
                self.lags.append((t, lag))
                if self.strict_lag:
                    raise RuntimeError(f"simulation too slow for real time: event at t={t:.6f} s "
                                       f"processed {lag:.6f} s late (max_lag={self.max_lag} s)")
        else:
            while True:
                delta = real_time - monotonic()
                if delta <= 0:
                    break
                simpy.rt.sleep(delta)
        Engine.step(self)
        self.steps += 1
        if self.maintain is not None and not self.steps % MAINTAIN_EVERY:
            self.maintain()


def check_simpy() -> None:
    """Fail loudly (ImportError naming the version) unless the installed SimPy has the
    private fields and queue layout :class:`Engine` relies on."""
    env = simpy.Environment()
    ev = simpy.events.Event(env)
    ok = (isinstance(getattr(env, "_now", None), int) and isinstance(getattr(env, "_queue", None), list)
          and isinstance(getattr(env, "_eid", None), count))
    if ok:
        ev._ok, ev._value = True, None
        env.schedule(ev, NORMAL, 5)
        entry = env._queue[0] if env._queue else None
        ok = (isinstance(entry, tuple) and len(entry) == 4 and entry[0] == 5 and entry[1] == NORMAL
              and isinstance(entry[2], int) and entry[3] is ev)
        if ok:
            env.step()
            ok = env._now == 5 and ev.callbacks is None
    if not ok:
        raise ImportError(f"netcosim needs SimPy 4 (an environment with _now, _queue, _eid and an event queue "
                          f"of (time, priority, id, event)); the installed SimPy {simpy.__version__} differs: "
                          f"install simpy>=4.1,<5")


check_simpy()
