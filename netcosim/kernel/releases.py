"""Periodic releases: this module is their one owner (the release heap, counts, groups).

A node's :class:`Releases` arms a periodic task (``Node.periodic``), stops it
(``Task.stop``) and fires its releases; the task itself keeps only its configuration
(``offset_ticks`` stays relative to its creation; the absolute first release is the
group's ``first``).  Release *k* of a periodic task is due at ``offset + k*period``.

**The release heap.**  The next release of every periodic task of a node waits in the
node's own heap of ``(time, id, group)`` entries, not in SimPy's event queue.  The
``id`` is an event id drawn from SimPy's counter exactly where a timer per task would
draw its own (when the task is armed, and when its previous release fires), so an
entry orders against every other event of the simulation as that timer would:
``(time, NORMAL, id)``.  SimPy's queue holds one stand-in event for the heap's first
entry (under that entry's key), so that SimPy's queue, every ``peek()`` and every "is
anything else due now?" test see what they would see with a timer per task.  When the
stand-in fires, the due entry is released and re-armed in place (``heapreplace``: one
O(log n) sift for n periodic tasks, where a timer per task pays a push and a pop in a
queue that also holds n timers); while the heap's next entry is due at the same instant
and comes before everything in SimPy's queue, it is released in the same callback (the
event it would have been is the very next one: nothing can run in between).  Releases
that share an instant therefore cost one SimPy event, and SimPy's queue stays as short
as the other events make it (segment ends, timeouts, frames), whatever the number of
tasks.

The rules that make this the event order of one timer per task
(``tests/test_kernel_release_groups.py`` compares the two on random task sets, bit for
bit, with ``GROUP_RELEASES = False``, the timer per task):

* the ids are drawn where the timers would draw theirs, and no other id is drawn:
  the stand-in is pushed under its entry's id, and an id drawn nowhere else leaves the
  relative order of all other events unchanged;
* a release made while another one is due at the same instant defers the dispatch to
  the end of the instant (``sim._stepping``), as the pending timer would make it do;
  the last release of an instant sees SimPy's queue as the last timer would;
* the stand-in for the next entry is in SimPy's queue before a release that may run
  task code (a dispatch at once), so that code sees a consistent heap;
* a stopped task's entry stays in the heap until it is due and then goes without a
  release, as a cancelled timer stays in SimPy's queue and fires into nothing; an entry
  armed ahead of the heap's first gets a stand-in of its own (the old first keeps its
  stand-in, listed in ``_covered``: it is never pushed twice, never merged).

**Release groups.**  Tasks created one after another on a node with the same first
release and period are released at the same instants, one right after the other: a
:class:`ReleaseGroup` releases them from one heap entry, in creation order (a task
released alone is a group of one).  That gives the order of separate entries because
the group is formed only while nothing else is scheduled in between (no event id is
taken between two members' creation: a ``sim.call_at``, another node's task, a network
frame between them starts a new group), and because between two members' releases at
an instant separate entries would let nothing else run -- unless a release schedules an
event for the next release instant itself, which only a deadline timer of a task with
``on_deadline_miss`` can (deadline = period); such tasks get an entry of their own.

:data:`GROUP_RELEASES` switches both off: one SimPy timer per task, re-armed when it
fires (the reference the heap is checked against).
"""

from __future__ import annotations

from heapq import heappop, heappush, heapreplace
from typing import Any, Callable

from ..clock import NORMAL, Rearmable, Timer

__all__ = ["GROUP_RELEASES", "ReleaseGroup", "Releases"]

#: release periodic tasks from the node's release heap, consecutively created tasks with
#: the same release instants from one entry (False: one SimPy timer per task)
GROUP_RELEASES = True


class ReleaseGroup:
    """Periodic tasks of one node released together, in creation order (one task or
    several): release *k* of every member is at ``first + k*period``."""

    __slots__ = ("members", "k", "first", "period", "timer")

    def __init__(self, task: Any, first: int):
        self.members: list = [task]
        self.k = 0                          # releases fired so far
        self.first = first                  # absolute tick of the first release
        self.period: int = task.period_ticks
        #: the group's own SimPy timer (``GROUP_RELEASES = False`` only), else None
        self.timer: Timer | None = None


class Releases:
    """The periodic releases of one node: the release heap, which group releases each
    task, and whether the next task created may join the group of the one created just
    before it."""

    __slots__ = ("node", "groups", "heap", "_cbs", "_covered", "_last", "_mark", "_timer_cbs")

    def __init__(self, node: Any):
        self.node = node
        #: the group releasing each armed (not stopped) periodic task
        self.groups: dict[Any, ReleaseGroup] = {}
        #: the next release of every group: ``(tick, event id, group)``, a binary heap
        self.heap: list[tuple[int, int, ReleaseGroup]] = []
        self._cbs: list[Callable[[Any], None]] = [self._fire]   # every stand-in's callbacks
        #: ids of heap entries whose stand-in is in SimPy's queue although they are not first
        self._covered: set[int] = set()
        self._last: Any = None      # the periodic task created last on the node
        self._mark = -1             # the event id taken right after it
        self._timer_cbs: list[Callable[[Any], None]] = [self._fire_timer]

    def arm(self, task: Any) -> None:
        """Release *task* every ``period_ticks`` from ``offset_ticks`` after now: from the
        group of the task created just before it when that gives the same order of
        events, else from a heap entry of its own."""
        env = self.node._env
        mark = env.mark()           # nothing was scheduled since the previous task iff this follows its mark
        first = env.now + task.offset_ticks
        prev = self._last
        group = self.groups.get(prev) if prev is not None else None
        if not GROUP_RELEASES:
            group = ReleaseGroup(task, first)
            group.timer = timer = Timer(env, first - env.now, self._fire_timer, group)
            timer.callbacks = self._timer_cbs
        elif (group is not None and mark == self._mark + 1
                and task.on_deadline_miss is None and prev.on_deadline_miss is None
                and group.first == first and group.period == task.period_ticks
                and group.k == 0 and group.members):
            group.members.append(task)  # released right after the current members
        else:
            group = ReleaseGroup(task, first)
            entry = (first, next(env.ids), group)   # the id a timer of its own would draw now
            heap = self.heap
            old = heap[0] if heap else None
            heappush(heap, entry)
            if old is None or entry < old:          # the new first: a stand-in of its own
                if old is not None:
                    self._covered.add(old[1])       # the old first keeps its stand-in
                stand_in = Rearmable(env)
                stand_in.callbacks = self._cbs
                heappush(env.queue, (first, NORMAL, entry[1], stand_in))
        self.groups[task] = group
        self._last, self._mark = task, env.mark()

    def _fire(self, stand_in: Any) -> None:
        # The heap's first entry is due (its stand-in fired: the first entry always has one
        # in SimPy's queue under its key, so the one that fires is the first's).  Re-arm
        # it (a stopped group's entry goes), then release its members and leave a
        # stand-in -- the one that fired, out of the queue now -- for the new first entry.
        node = self.node
        env = node._env
        heap = self.heap
        group = heap[0][2]
        members = group.members
        if members:
            group.k = k = group.k + 1
            heapreplace(heap, (group.first + k * group.period, next(env.ids), group))
        else:
            heappop(heap)           # stopped: due now, releases nothing (a cancelled timer)
            if not heap:
                return
        t, i, _ = heap[0]
        now = env.now
        if t == now:
            self._instant(stand_in, members)
            return
        # the only release due now: the stand-in first (task code may run at once)
        if self._covered and i in self._covered:
            self._covered.discard(i)
        else:
            stand_in.callbacks = self._cbs  # stand_in.arm(t, NORMAL, ...) under id i, inlined
            heappush(env.queue, (t, NORMAL, i, stand_in))
        if len(members) == 1:
            node._release(members[0], now)
        elif members:
            self._release_all(members, now)

    def _instant(self, stand_in: Any, members: list) -> None:
        """:meth:`_fire` when the heap's next entry is due at this instant too: release
        *members* (the entry just re-armed), then every further entry due now while it is
        the next event of the simulation, then leave the stand-in for the first entry.

        Every release but the last of the instant defers the dispatch to the end of the
        instant (``sim._stepping``), as a timer due now would; on a one-core node the
        callback also holds the dispatch (no dispatch event) until it is done (:meth:`_unhold`)."""
        node = self.node
        env = node._env
        now = env.now
        heap = self.heap
        q = env.queue
        covered = self._covered
        release = node._release
        sim = node.sim
        seq0 = -1
        if not node._dispatch_pending and not node.multicore:
            node._dispatch_pending = True   # held: no dispatch event while the instant's releases come
            seq0 = node._seq
        last: list | tuple = ()
        sim._stepping += 1
        try:
            while True:
                for task in members:
                    release(task, now)
                t, i, group = heap[0]       # due now
                if covered and i in covered:    # it has its own stand-in in SimPy's queue
                    covered.discard(i)
                    break
                q0 = q[0] if q else None
                if not (q0 is None or q0[0] > now or q0[1] > NORMAL or (q0[1] == NORMAL and q0[2] > i)):
                    stand_in.callbacks = self._cbs      # something else comes first
                    heappush(q, (t, NORMAL, i, stand_in))
                    break
                members = group.members     # the very next event of the simulation: released here
                if members:
                    group.k = k = group.k + 1
                    heapreplace(heap, (group.first + k * group.period, next(env.ids), group))
                else:
                    heappop(heap)
                    if not heap:
                        break
                t, i, _ = heap[0]
                if t != now:                # the instant's last release: the stand-in first
                    if covered and i in covered:
                        covered.discard(i)
                    else:
                        stand_in.callbacks = self._cbs
                        heappush(q, (t, NORMAL, i, stand_in))
                    last = members
                    break
        except BaseException:
            if heap and stand_in.callbacks is None:
                self._stand_in_for_first(stand_in)
            if seq0 >= 0:
                node._dispatch_pending = False
            raise
        finally:
            sim._stepping -= 1
        if len(last) == 1:
            release(last[0], now)
        elif last:
            self._release_all(last, now)
        if seq0 >= 0:
            self._unhold(seq0)

    def _unhold(self, seq0: int) -> None:
        """End the hold of :meth:`_instant` on a one-core node's dispatch: if a job was
        activated since (the node's activation count moved on from *seq0*), ask for the
        dispatch the instant's first release would have armed -- at once when nothing else
        is due now, else at the end of the instant (the dispatch event then takes its id
        here instead: nothing was scheduled for this instant in between, so the order of
        events is the same)."""
        node = self.node
        node._dispatch_pending = False
        if node._seq != seq0:
            node._request_dispatch()

    def _stand_in_for_first(self, stand_in: Any) -> None:
        """Put *stand_in* (out of SimPy's queue) in SimPy's queue for the heap's first entry,
        unless that entry has its stand-in there already."""
        t, i, _ = self.heap[0]
        if i in self._covered:
            self._covered.discard(i)
            return
        stand_in.callbacks = self._cbs
        heappush(self.node._env.queue, (t, NORMAL, i, stand_in))

    def _release_all(self, members: list | tuple, now: int) -> None:
        """Release *members* (in order) at *now*, the dispatch deferred until the last."""
        node = self.node
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

    def _fire_timer(self, timer: Timer) -> None:
        """A group's own timer fired (``GROUP_RELEASES = False``): re-arm it, release."""
        group = timer.arg
        env = self.node._env
        group.k = k = group.k + 1
        timer.rearm(group.first + k * group.period, self._timer_cbs)
        self._release_all(group.members, env.now)

    def stop(self, task: Any) -> None:
        """No further releases of *task* (``Task.stop``): the other members go on; the
        group's entry (or timer) is due once more and then goes (idempotent)."""
        group = self.groups.pop(task, None)
        if group is not None:
            group.members.remove(task)
            if not group.members and group.timer is not None:
                group.timer.cancel()

    def group_of(self, task: Any) -> ReleaseGroup | None:
        """The group releasing *task* (None when it is not periodic or stopped)."""
        return self.groups.get(task)
