"""Kernel timers and external triggers (TrueTime's ``ttCreateTimer`` and trigger inputs).

A :class:`KernelTimer` releases a task at an absolute time, optionally periodically;
a :class:`Trigger` releases a task on each external edge, ignoring edges closer than a
minimum interval.  Create them with :meth:`Node.timer <netcosim.kernel.node.Node.timer>`
and :meth:`Node.trigger <netcosim.kernel.node.Node.trigger>`.  Times in seconds at the
API, integer ticks inside.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import validate
from ..errors import ConfigurationError
from ..timebase import to_ticks

if TYPE_CHECKING:
    from .state import KernelState
    from .task import Task


class KernelTimer:
    """Releases a task at an absolute time ``at`` (s; now when None), then every ``period`` s if
    given (TrueTime's timers): ``target`` (a task of ``node``) gets ``target.release()`` at
    each instant; ``at`` may not lie in the past, ``period`` must be positive.

    Raises
    ------
    ConfigurationTypeError
        If ``at`` or ``period`` is not a number of seconds.
    ConfigurationError
        If ``at`` lies before the current time or ``period`` is not positive (or either is
        not finite, or is below the 1 ps resolution).

    Examples
    --------
    A timer that releases a sampling task first at 5 ms, then every 10 ms (times in seconds):

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.aperiodic(priority=1)
    ... def sample(ctx):
    ...     yield ctx.execute(0.001)
    >>> timer = cpu.timer(sample, at=0.005, period=0.010)
    >>> sim.run(until=0.030)
    >>> sim.trace.jobs().release.round(6).tolist()
    [0.005, 0.015, 0.025]
    >>> timer.cancel()                   # no further releases
    >>> cpu.timer(sample, at=0.010)      # now is 0.03 s
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: timer for 'sample': at=0.01 s lies in the past (now 0.03 s)
    """

    def __init__(self, node: KernelState, target: Task, at: float | None, period: float | None):
        self.node, self.target = node, target
        now = node.sim.env.now
        self._start = now if at is None else to_ticks(at, f"timer for {target.name!r} at")
        if self._start < now:
            raise ConfigurationError(f"timer for {target.name!r}: at={at!r} s lies in the past "
                                     f"(now {node.sim.now} s)")
        self._period = None if period is None else validate.duration(period, f"timer for {target.name!r}: period",
                                                                     positive=True, kind="positive")
        self._k = 0
        self._timer = node.sim._call_at_ticks(self._start, self._fire)

    def _fire(self):
        self._k += 1
        if self._period is not None:
            self._timer = self.node.sim._call_at_ticks(self._start + self._k * self._period, self._fire)
        else:
            self._timer = None
        self.target.release()

    def cancel(self) -> None:
        """Stop the timer: no further releases (idempotent; harmless after a one-shot fired)."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None


class Trigger:
    """An external trigger edge source; ``fire()`` releases the target unless too soon.

    ``target``: the task of ``node`` released on each edge; ``min_interval`` (s, >= 0): an
    edge less than this after the last accepted one is ignored (0: every edge counts).

    Raises
    ------
    ConfigurationTypeError
        If ``min_interval`` is not a number of seconds.
    ConfigurationError
        If ``min_interval`` is negative, not finite, or non-zero and below the 1 ps resolution.

    Examples
    --------
    Edges at 1, 2, 4 and 4.5 ms on a trigger that ignores edges closer than 2 ms to the last
    accepted one: the edges at 2 and 4.5 ms are ignored (times in seconds).

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.aperiodic(priority=1)
    ... def on_edge(ctx):
    ...     yield ctx.execute(0.0005)
    >>> trigger = cpu.trigger(on_edge, min_interval=0.002)
    >>> for t in (0.001, 0.002, 0.004, 0.0045):
    ...     _ = sim.call_at(t, trigger.fire)
    >>> sim.run(until=0.010)
    >>> sim.trace.jobs().release.round(6).tolist(), trigger.ignored
    ([0.001, 0.004], 2)
    """

    def __init__(self, node: KernelState, target: Task, min_interval: float):
        self.node, self.target = node, target
        self._min = to_ticks(min_interval, f"trigger for {target.name!r} min_interval")
        self._last = None
        self.ignored = 0

    def fire(self) -> bool:
        """An edge now: release the target and return True, or ignore it (counted in ``ignored``) and
        return False when it comes less than ``min_interval`` s after the last accepted edge."""
        now = self.node.sim.env.now
        if self._last is not None and now - self._last < self._min:
            self.ignored += 1
            return False
        self._last = now
        self.target.release()
        return True
