"""The kernel on a local clock: periodic releases, kernel timers, sleeps and deadlines in
local time, re-mapped when the clock is stepped or slewed.

Only a node created with a clock (``sim.node(..., clock=LocalClock(...))``) uses this
module: its node swaps in :class:`LocalReleases` for the periodic releases, a
:class:`LocalTaskContext` for each task's ``ctx``, :class:`LocalKernelTimer` for
``node.timer`` and :func:`release_local` for its release path (the deadline in local
time).  A node without a clock keeps the kernel's code path as it is.

Everything pending on the local clock is an :class:`Alarm`: a local due time (exact
local ticks) and a global timer at :meth:`LocalClock.due
<netcosim.kernel.localclock.LocalClock.due>` of it.  When the clock is stepped or slewed
(:class:`LocalTime` hears it), every pending alarm is re-armed at the global instant its
due time now maps to -- at once if a forward step skipped it -- in the order the alarms
were due (then armed).  POSIX ``CLOCK_REALTIME`` semantics: absolute waits (periodic
releases, kernel timers, ``sleep_until``) keep their local due time; a relative
``ctx.sleep`` keeps its remaining length (a step shifts its due time by the step; a slew
changes its rate like everything else).  A periodic release or periodic timer whose
instants a forward step skipped fires once, at once, and counts the skipped ones
(``task.missed_releases``, ``timer.overruns``): POSIX timer overruns.
"""

from __future__ import annotations

from array import array
from fractions import Fraction
from typing import TYPE_CHECKING, Any, Callable

from .. import validate
from ..errors import ConfigurationError
from ..timebase import TICKS_PER_SECOND, to_ticks
from .overrun import DEADLINE, OverrunTimer
from .task import Blocking, Job, Task, TaskContext

if TYPE_CHECKING:
    from .localclock import LocalClock

__all__ = ["Alarm", "LocalTime", "LocalReleases", "LocalKernelTimer", "LocalSleep", "LocalTaskContext",
           "release_local"]


class Alarm:
    """A wait on a node's local clock: ``fire()`` is called when the clock reads
    ``num / den`` local ticks (integers: no Fraction on the per-release path);
    ``relative``: a step shifts the due time with it (a relative sleep); ``remapped``:
    the clock changed since it was armed; ``k``: a periodic alarm's index."""

    __slots__ = ("num", "den", "fire", "relative", "timer", "at", "seq", "remapped", "k")

    def __init__(self, due: Fraction | int, fire: Callable[[], None], relative: bool = False):
        self.num: int = due.numerator
        self.den: int = due.denominator
        self.fire = fire
        self.relative = relative
        self.timer: Any = None      # the global timer while armed
        self.at = 0                 # its global tick
        self.seq = 0                # arm order (ties at one instant)
        self.remapped = False
        self.k = 0

    @property
    def due(self) -> Fraction:
        """The due time (local ticks)."""
        return Fraction(self.num, self.den)


class LocalTime:
    """The pending alarms of one node's local clock, re-armed when the clock changes."""

    def __init__(self, node: Any, clock: LocalClock):
        self.node = node
        self.clock = clock
        self.alarms: dict[Alarm, None] = {}     # the armed ones (an ordered set)
        #: each task's absolute deadlines (ticks) by job index, as converted at release (the
        #: jobs table's deadline column; 8 bytes a job)
        self.deadlines: dict[Task, array] = {}
        self._seq = 0
        clock._attach(node._env, node.name, self._changed)

    def local_now(self) -> Fraction:
        """The clock's reading now (local ticks)."""
        return self.clock.local_ticks(self.node._env.now)

    def arm(self, alarm: Alarm) -> None:
        """Arm *alarm* at the first global tick at which the clock reads its due time."""
        now = self.node._env.now
        alarm.at = at = self.clock.due_nd(alarm.num, alarm.den, now)
        self._seq += 1
        alarm.seq = self._seq
        alarm.timer = self.node.sim._call_at_ticks(at, self._fire, arg=alarm)
        self.alarms[alarm] = None

    def _fire(self, alarm: Alarm) -> None:
        self.alarms.pop(alarm, None)
        alarm.timer = None
        alarm.fire()

    def cancel(self, alarm: Alarm) -> None:
        """Disarm *alarm* (idempotent)."""
        if alarm.timer is not None:
            alarm.timer.cancel()
            alarm.timer = None
        self.alarms.pop(alarm, None)

    def _changed(self, step: Fraction) -> None:
        """The clock was stepped by *step* local ticks (0: slewed): re-arm every pending alarm."""
        pending = sorted(self.alarms, key=lambda a: (a.at, a.seq))
        for alarm in pending:
            alarm.timer.cancel()
            alarm.remapped = True
            if alarm.relative and step:
                due = alarm.due + step
                alarm.num, alarm.den = due.numerator, due.denominator
        self.alarms.clear()
        for alarm in pending:
            self.arm(alarm)

    def skipped(self, alarm: Alarm, first_num: int, first_den: int, period: int) -> int:
        """Instants of the grid ``first + j·period`` (local ticks) a step skipped between
        *alarm*'s index ``k`` and now (0 unless the clock changed since it was armed);
        advances ``alarm.k`` to the last index due now.  The grid's first instant is the
        fraction ``first_num / first_den`` local ticks (integers); *period* in local ticks."""
        if not alarm.remapped:
            return 0
        alarm.remapped = False
        ln, ld = self.clock.local_nd(self.node._env.now)
        n = (ln * first_den - first_num * ld) // (ld * first_den * period)     # the last index due (>= k)
        missed = max(n - alarm.k, 0)
        alarm.k += missed
        return missed


class LocalReleases:
    """The periodic releases of a node on a local clock (``node._releases``): release *k*
    of a task when its clock reads ``first + k·period`` (local ticks, ``first`` = the
    reading at the task's creation + its offset)."""

    def __init__(self, local: LocalTime):
        self.local = local
        #: the alarm releasing each armed (not stopped) periodic task
        self.alarms: dict[Task, Alarm] = {}

    def arm(self, task: Task) -> None:
        """Release *task* every ``period`` local seconds from ``offset`` after now (local)."""
        local = self.local
        num, den = local.clock.local_nd(local.node._env.now)
        num += task.offset_ticks * den
        alarm = Alarm(Fraction(num, den), lambda: self._fire(task, alarm, num, den))
        num, den = alarm.num, alarm.den          # reduced
        self.alarms[task] = alarm
        local.arm(alarm)

    def _fire(self, task: Task, alarm: Alarm, first_num: int, first_den: int) -> None:
        # release k is due at first + k*period; a forward step may have skipped some:
        # release once, count the skipped ones, re-arm for the next one
        local = self.local
        period = task.period_ticks
        missed = local.skipped(alarm, first_num, first_den, period)
        if missed:
            task.missed_releases += missed
        alarm.k = k = alarm.k + 1
        alarm.num = first_num + k * period * first_den
        alarm.den = first_den
        local.arm(alarm)
        node = local.node
        node._release(task, node._env.now)

    def stop(self, task: Task) -> None:
        """No further releases of *task* (idempotent)."""
        alarm = self.alarms.pop(task, None)
        if alarm is not None:
            self.local.cancel(alarm)

    def group_of(self, task: Task) -> None:
        """None: *task*, on a local clock, is released on its own (no release groups)."""
        return None


class LocalKernelTimer:
    """:class:`~netcosim.kernel.timers.KernelTimer` on a local clock: releases *target* when
    the clock reads ``at`` (local s; now when None), then every ``period`` local s.
    ``overruns``: periodic instants a forward step skipped (released once, at once).
    ``node``: the node (with a local clock) whose kernel releases *target*."""

    def __init__(self, node: Any, target: Task, at: float | None, period: float | None):
        self.node, self.target = node, target
        local: LocalTime = node._local
        self._local = local
        here = local.local_now()
        name = f"timer for {target.name!r}"
        self._start = here if at is None else Fraction(to_ticks(at, f"{name} at", allow_negative=True))
        if self._start < here:
            raise ConfigurationError(f"{name}: at={at!r} s lies in the past of node {node.name!r}'s clock "
                                     f"(it reads {float(here / TICKS_PER_SECOND)!r} s)")
        self._period = None if period is None else validate.duration(period, f"{name}: period", positive=True,
                                                                     kind="positive")
        #: periodic instants skipped by a forward step of the clock
        self.overruns = 0
        self._alarm: Alarm | None = Alarm(self._start, self._fire)
        local.arm(self._alarm)

    def _fire(self) -> None:
        alarm = self._alarm
        assert alarm is not None
        if self._period is not None:
            start = self._start
            self.overruns += self._local.skipped(alarm, start.numerator, start.denominator, self._period)
            alarm.k = k = alarm.k + 1
            alarm.num = start.numerator + k * self._period * start.denominator
            alarm.den = start.denominator
            self._local.arm(alarm)
        else:
            self._alarm = None
        self.target.release()

    def cancel(self) -> None:
        """Stop the timer: no further releases (idempotent; harmless after a one-shot fired)."""
        if self._alarm is not None:
            self._local.cancel(self._alarm)
            self._alarm = None


class LocalSleep(Blocking):
    """Block until the node's clock reads ``until`` (local ticks); *relative*: a
    ``ctx.sleep`` (a step of the clock shifts it, keeping its remaining length)."""

    __slots__ = ("until", "relative", "alarm")

    def __init__(self, until: Fraction | int, relative: bool):
        self.until = until
        self.relative = relative
        self.alarm: Alarm | None = None

    def attempt(self, job: Job) -> bool:
        """True if the clock already reads ``until``; otherwise arm the wake-up and return False."""
        node = job.node
        local: LocalTime = node._local
        if self.until <= local.local_now():
            return True
        self.alarm = Alarm(self.until, lambda: node._unblock(job, None), self.relative)
        local.arm(self.alarm)
        return False

    def cancel(self, job: Job) -> None:
        """Cancel the pending wake-up, if any."""
        if self.alarm is not None:
            job.node._local.cancel(self.alarm)


class LocalTaskContext(TaskContext):
    """``ctx`` of a task on a node with a local clock: ``now``, ``sleep`` and
    ``sleep_until`` in local time."""

    __slots__ = ()

    @property
    def now(self) -> float:
        """The node's local time (s)."""
        num, den = self.node._local.clock.local_nd(self.sim.env.now)
        return num / (den * TICKS_PER_SECOND)

    def sleep(self, seconds: float) -> LocalSleep:  # type: ignore[override]
        """Block for *seconds* of the node's clock (a step of the clock does not change it)."""
        d = to_ticks(seconds, f"task {self.task.name!r} sleep")
        return LocalSleep(self.node._local.local_now() + d, True)

    def sleep_until(self, t: float) -> LocalSleep:  # type: ignore[override]
        """Block until the node's clock reads *t* (local s)."""
        return LocalSleep(to_ticks(t, f"task {self.task.name!r} sleep_until", allow_negative=True), False)


def release_local(node: Any, task: Task, t: int) -> Job | None:
    """``Dispatcher._release`` for a node on a local clock, a release of *task* (one of
    *node*'s) at global tick *t* (ticks): the job's absolute deadline (ticks) is its relative deadline after the
    release in local time (kept in step with
    :meth:`netcosim.kernel.dispatcher.Dispatcher._release` otherwise)."""
    task.jobs_released = n = task.jobs_released + 1
    job = Job(task, n - 1, t)
    if job.abs_deadline is not None:
        local = node._local
        clock = local.clock
        num, den = clock.local_nd(t)
        job.abs_deadline = d = clock.due_nd(num + task.deadline_ticks * den, den, t)
        known = local.deadlines.get(task)
        if known is None:
            local.deadlines[task] = known = array("q")
        known.append(d)
        if task.on_deadline_miss is not None:
            job.deadline_timer = OverrunTimer(job, job.abs_deadline - node._env.now, DEADLINE)
    if task.active is not None:
        return node._release_while_busy(task, job)
    # on a partitioned multicore node the task's core activates it (its ready queue)
    pinned = getattr(node, "_pinned", None)
    (node if not pinned else pinned.get(task, node))._activate(job)
    return job
