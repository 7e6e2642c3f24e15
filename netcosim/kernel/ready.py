"""A node's ready queue: the jobs waiting for the CPU, ordered by the kernel's tie rules.

Order: job class first (handlers, class 0, before tasks, class 1), then the job's
current policy key (smallest first), then activation order ``seq`` (FIFO).  The queue is
a binary heap (``heapq``): insertion and taking the first job cost O(log n) for n ready
jobs, looking at the first job O(1).

A job leaves the queue other than by being taken first (killed while ready, or the
non-preemptible job that resumes ahead of the policy order) or changes its key while
ready (priority inheritance) by *lazy deletion*: its heap entry is marked dead and
skipped when it reaches the top; a key change pushes a fresh entry.  Each entry is the
list ``[cls, key, seq, n, job]`` where ``n`` numbers the pushes, so two entries of one
job (a dead one and its replacement, possibly with the same key) never compare the
jobs themselves; ``job`` is None once the entry is dead.
"""

from __future__ import annotations

from heapq import heapify, heappop, heappush
from typing import Iterator

#: rebuild the heap without dead entries once they outnumber the live ones by this much
_COMPACT_SLACK = 64


class ReadyQueue:
    """The ready jobs of one node (see the module docstring for the order)."""

    __slots__ = ("_heap", "_pushes", "live")

    def __init__(self):
        self._heap: list[list] = []
        self._pushes = 0
        #: number of jobs in the queue (the heap also holds dead entries)
        self.live = 0

    def push(self, job) -> None:
        """Add *job* (not already in the queue) with its current ``cls``, ``key`` and ``seq``."""
        self._pushes += 1
        entry = [job.cls, job.key, job.seq, self._pushes, job]
        job.ready_entry = entry
        heappush(self._heap, entry)
        self.live += 1

    def first(self):
        """The job that comes first, or None when the queue is empty (the job stays queued)."""
        heap = self._heap
        while heap:
            job = heap[0][4]
            if job is not None:
                return job
            heappop(heap)
        return None

    def pop_first(self) -> None:
        """Remove the job :meth:`first` just returned (it must not be None)."""
        entry = heappop(self._heap)
        entry[4].ready_entry = None
        self.live -= 1

    def discard(self, job) -> None:
        """Remove *job* wherever it is in the queue (no-op if it is not queued)."""
        entry = job.ready_entry
        if entry is None:
            return
        entry[4] = None
        job.ready_entry = None
        self.live -= 1
        if len(self._heap) > 2 * self.live + _COMPACT_SLACK:
            self._heap = [e for e in self._heap if e[4] is not None]
            heapify(self._heap)

    def requeue(self, job) -> None:
        """Re-order *job* after its ``cls`` or ``key`` changed (no-op if it is not queued)."""
        if job.ready_entry is not None:
            self.discard(job)
            self.push(job)

    def __len__(self) -> int:
        return self.live

    def __bool__(self) -> bool:
        return self.live > 0

    def __contains__(self, job) -> bool:
        return job.ready_entry is not None and job.ready_entry[4] is job

    def __iter__(self) -> Iterator:
        """The queued jobs in the order they would run (a snapshot)."""
        return iter([e[4] for e in sorted(self._heap) if e[4] is not None])

    def __repr__(self) -> str:
        return f"<ReadyQueue {list(self)}>"
