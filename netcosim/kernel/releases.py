"""Periodic releases: this module is their one owner (timers, counts, groups).

A node's :class:`Releases` arms a periodic task (``Node.periodic``), stops it
(``Task.stop``) and fires its releases; the task itself keeps only its configuration
(``offset_ticks`` stays relative to its creation; the absolute first release is the
group's ``first``).  A periodic task is released at ``offset + k*period`` by a timer in
SimPy's event queue that re-arms itself when it fires.  With thousands of tasks the queue holds thousands
of such timers, and every push and pop pays for its depth (O(log n) comparisons of
``(time, priority, id, event)`` entries that tie on time and priority).

Tasks created one after another on a node with the same first release and period are
released at the same instants, one right after the other: a :class:`ReleaseGroup`
releases them from one timer, in creation order (a task released alone is a group of
one: there is one re-arm path, :meth:`ReleaseGroup._fire`), and gives exactly the event
order of separate timers (``tests/test_kernel_release_groups.py`` compares the two on random
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

from heapq import heappush
from typing import Any, Callable

from ..clock import NORMAL, Timer

__all__ = ["GROUP_RELEASES", "ReleaseGroup", "Releases"]

#: group the release timers of consecutively created tasks with the same release instants
GROUP_RELEASES = True


class ReleaseGroup:
    """Periodic tasks of one node released from one timer, in creation order (one task
    or several): release *k* of every member is at ``first + k*period``."""

    __slots__ = ("node", "members", "timer", "k", "first", "period", "_cbs")

    def __init__(self, node: Any, task: Any, first: int):
        self.node = node
        self.members: list = [task]
        self.k = 0                          # releases fired so far
        self.first = first                  # absolute tick of the first release
        self.period: int = task.period_ticks
        self._cbs: list[Callable[[Any], None]] = [self._fire]
        env = node._env
        # one timer, re-armed when it fires: SimPy only replaces a fired event's callback
        # list, never mutates it, so every firing shares ``_cbs``
        self.timer = timer = Timer(env, first - env.now, self._fire, None)
        timer.callbacks = self._cbs

    def _fire(self, timer: Timer) -> None:
        # The timer that fired is out of SimPy's queue (its callbacks are spent): re-arm
        # it for the next release instead of creating a new one.  A cancelled timer is
        # never re-armed (it may still sit in the queue): `Releases.stop` drops it.
        node = self.node
        env = node._env
        now = env.now
        self.k = k = self.k + 1
        timer.callbacks = self._cbs  # timer.rearm(first + k * period, ...), inlined
        heappush(env.queue, (self.first + k * self.period, NORMAL, next(env.ids), timer))
        members = self.members
        if len(members) == 1:
            node._release(members[0], now)
            return
        release = node._release
        sim = node.sim
        sim._stepping += 1      # the later members are still to come at this instant: dispatch waits
        try:
            for task in members[:-1]:
                release(task, now)
        finally:
            sim._stepping -= 1
        release(members[-1], now)


class Releases:
    """The periodic releases of one node: which group releases each task, and whether
    the next task created may join the group of the one created just before it."""

    __slots__ = ("node", "groups", "_last", "_mark")

    def __init__(self, node: Any):
        self.node = node
        #: the group releasing each armed (not stopped) periodic task
        self.groups: dict[Any, ReleaseGroup] = {}
        self._last: Any = None      # the periodic task created last on the node
        self._mark = -1             # the event id taken right after it

    def arm(self, task: Any) -> None:
        """Release *task* every ``period_ticks`` from ``offset_ticks`` after now: from its own
        timer, or from the group of the task created just before it when that gives the
        same order of events."""
        env = self.node._env
        mark = env.mark()           # nothing was scheduled since the previous task iff this follows its mark
        first = env.now + task.offset_ticks
        prev = self._last
        group = self.groups.get(prev) if prev is not None else None
        if (GROUP_RELEASES and group is not None and mark == self._mark + 1
                and task.on_deadline_miss is None and prev.on_deadline_miss is None
                and group.first == first and group.period == task.period_ticks
                and group.k == 0 and group.timer.pending):
            group.members.append(task)  # released right after the current members
        else:
            group = ReleaseGroup(self.node, task, first)
        self.groups[task] = group
        self._last, self._mark = task, env.mark()

    def stop(self, task: Any) -> None:
        """No further releases of *task* (``Task.stop``): the other members go on; the timer
        goes with the last one (idempotent)."""
        group = self.groups.pop(task, None)
        if group is not None:
            group.members.remove(task)
            if not group.members:
                group.timer.cancel()

    def group_of(self, task: Any) -> ReleaseGroup | None:
        """The group releasing *task* (None when it is not periodic or stopped)."""
        return self.groups.get(task)
