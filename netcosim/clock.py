"""The clock layer below the simulation, the kernel and the networks.

What every part that schedules something needs, and nothing more: the SimPy event
priorities netcosim uses to order simultaneous events, one cancellable timer class,
and a process-independent hash for naming random streams.  Times here are integer
ticks (:mod:`netcosim.timebase`); the seconds API lives on
:class:`~netcosim.sim.Simulation`.
"""

from __future__ import annotations

import hashlib
from heapq import heappush
from typing import Any, Callable

import simpy

__all__ = ["URGENT", "NORMAL", "DISPATCH", "ARBITRATE", "Timer", "stable_hash"]

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
    queue and fires into nothing.
    """

    __slots__ = ("arg", "fn")
    arg: Any
    fn: Callable[..., Any]
    NOARG = _NOARG

    def __init__(self, env: simpy.Environment, delay: int, callback: Callable[["Timer"], None],
                 arg: Any = None, priority: int = NORMAL):
        self.env = env
        self.arg = arg
        self._ok = True
        self._value = None
        self.callbacks = [callback]
        # env.schedule(self, priority, delay), inlined: a timer is created per job segment
        queue: list = env._queue
        heappush(queue, (env._now + delay, priority, next(env._eid), self))

    @classmethod
    def call(cls, env: simpy.Environment, delay: int, fn: Callable, arg: Any = _NOARG,
             priority: int = NORMAL) -> "Timer":
        """A timer, *delay* ticks from now, whose firing calls ``fn()`` (or ``fn(arg)``)."""
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
