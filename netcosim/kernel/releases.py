"""Periodic release timers: one per task, or one per group of tasks released together.

A periodic task is released at ``offset + k*period`` by a timer in SimPy's event queue
that re-arms itself when it fires.  With thousands of tasks the queue holds thousands
of such timers, and every push and pop pays for its depth (O(log n) comparisons of
``(time, priority, id, event)`` entries that tie on time and priority).

Tasks created one after another on a node with the same first release and period are
released at the same instants, one right after the other: a :class:`ReleaseGroup`
releases them from one timer, in creation order, and gives exactly the event order of
separate timers (``tests/test_kernel_release_groups.py`` compares the two on random
task sets, bit for bit).  That holds because:

* the group is formed only while nothing else is scheduled in between (no event id is
  taken between two members' creation: a ``sim.call_at``, another node's task, a
  network frame between them starts a new group), so at the first release the
  members come in the order their own timers would;
* between two members' releases at an instant, separate timers would let nothing else
  run: the next member's timer is the next event -- unless a release schedules an
  event for the next release instant itself, which only a deadline timer of a task
  with ``on_deadline_miss`` can (deadline = period); such tasks keep their own timer;
* a separate timer's release defers the dispatch to the end of the instant while the
  next member's timer is pending; the group defers it the same way (``sim._stepping``)
  for every member but the last, whose release sees the queue as the last separate
  timer would.

:data:`GROUP_RELEASES` switches grouping off (one timer per task).
"""

from __future__ import annotations

from typing import Any, Callable

from ..clock import Timer

__all__ = ["GROUP_RELEASES", "ReleaseGroup", "arm_periodic"]

#: group the release timers of consecutively created tasks with the same release instants
GROUP_RELEASES = True


class ReleaseGroup:
    """Periodic tasks of one node released from one timer, in creation order."""

    __slots__ = ("node", "members", "timer", "k", "first", "period", "_cbs")

    def __init__(self, node: Any, task: Any):
        self.node = node
        self.members: list = [task]
        self.timer: Timer = task._release_timer
        self.k = task._k
        self.first: int = task.offset_ticks     # absolute tick of the first release
        self.period: int = task.period_ticks
        self._cbs: list[Callable[[Any], None]] = [self._fire]
        self.timer.callbacks = self._cbs
        task._group = self

    def add(self, task: Any) -> None:
        """Release *task* after the current members (created right after the last of them)."""
        self.members.append(task)
        task._group = self
        task._release_timer = self.timer

    def remove(self, task: Any) -> None:
        """*task* stops (``Task.stop``): the others go on; the timer goes with the last one."""
        self.members.remove(task)
        task._group = None
        if not self.members:
            self.timer.cancel()

    def _fire(self, timer: Timer) -> None:
        node = self.node
        env = node._env
        now = env.now
        self.k = k = self.k + 1
        timer.rearm(self.first + k * self.period, self._cbs)
        members = self.members
        release = node._release
        sim = node.sim
        sim._stepping += 1      # the later members are still to come at this instant: dispatch waits
        try:
            for task in members[:-1]:
                task._k = k
                release(task, now)
        finally:
            sim._stepping -= 1
        last = members[-1]
        last._k = k
        release(last, now)


def arm_periodic(node: Any, task: Any) -> None:
    """Arm *task*'s release timer (``task.offset_ticks``: ticks from now, made absolute
    here): its own, or a place in the group of the task created just before it when
    that gives the same order of events."""
    env = node._env
    prev = node._last_periodic
    mark = env.mark()           # nothing was scheduled since the previous task iff this follows its mark
    task.offset_ticks += env.now
    task._k = 0
    task._group = None
    if (GROUP_RELEASES and prev is not None and mark == node._periodic_mark + 1
            and task.on_deadline_miss is None and prev.on_deadline_miss is None
            and prev.offset_ticks == task.offset_ticks and prev.period_ticks == task.period_ticks
            and prev._k == 0 and prev._release_timer is not None and prev._release_timer.pending):
        group = prev._group if prev._group is not None else ReleaseGroup(node, prev)
        group.add(task)
    else:
        task._release_timer = Timer(env, task.offset_ticks - env.now, task._periodic_release, None)
    node._last_periodic, node._periodic_mark = task, env.mark()
