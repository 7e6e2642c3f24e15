"""The dispatcher: releases, the ready queue, the choice of the job to run, preemption,
context switches and priority inheritance.

Dispatching is deferred to the end of the instant (SimPy priority ``DISPATCH``), so
every release, arrival and segment end of an instant is seen before the kernel decides
who runs: handlers before tasks, then the policy key, then release order (FIFO).

Context switches: each time a job is switched in -- its first start, or resuming
after it was preempted or blocked while another job held the CPU -- the CPU spends
``context_switch / speed`` seconds before the job's code runs.  The switch is kernel
work: non-preemptible; the job is traced as ``ready`` meanwhile.  A job that continues
with its next segment, or resumes when nothing else ran since it stopped, pays nothing.
"""

from __future__ import annotations

import warnings
from heapq import heappop, heappush

from ..clock import DISPATCH, Timer
from ..errors import OverloadError, OverloadWarning
from .interpreter import Interpreter
from .overrun import DEADLINE, OverrunTimer
from .tables import STATE_CODES
from .task import HANDLER, Job, Task

# state codes of the schedule table's rows (netcosim.kernel.tables.SCHEDULE_RAW)
_READY, _RUNNING = STATE_CODES["ready"], STATE_CODES["running"]


class Dispatcher(Interpreter):
    """The node's part that queues ready jobs and decides which one has the CPU."""

    # ------------------------------------------------------------- releases
    def _release(self, task: Task, t: int) -> Job | None:
        task.jobs_released = n = task.jobs_released + 1
        job = Job(task, n - 1, t)
        if task.on_deadline_miss is not None and job.abs_deadline is not None:
            job.deadline_timer = OverrunTimer(job, job.abs_deadline - self._env.now, DEADLINE)
        if task.active is not None:
            return self._release_while_busy(task, job)
        self._activate(job)
        return job

    def _release_while_busy(self, task: Task, job: Job) -> Job | None:
        """*job* is released while the task's previous job is active: skipped (counted),
        dropped when the queue is full, or queued (TrueTime); the queued job or None."""
        if task.on_busy == "skip":
            task.skipped += 1
            if job.deadline_timer is not None:
                job.deadline_timer.cancel()
            return None
        if task.max_pending is not None and len(task.pending) >= task.max_pending:
            self._queue_full(task, job)
            return None
        task.pending.append(job)
        return job

    def _queue_full(self, task: Task, job: Job) -> None:
        """A release finds ``max_pending`` jobs queued: drop it (counted) or raise."""
        if job.deadline_timer is not None:
            job.deadline_timer.cancel()
        what = (f"task {self.name}.{task.name}: {task.max_pending} jobs already queued (max_pending) at "
                f"t = {self.sim.now:.9g} s")
        if task.on_queue_full == "error":
            raise OverloadError(f"{what}: the task is overloaded (on_queue_full='error')")
        task.dropped += 1
        if task.dropped == 1:
            warnings.warn(f"{what}: this release and further ones while the queue is full are dropped and counted "
                          f"(task.dropped); pass max_pending=None for TrueTime's unbounded queue, or "
                          f"on_queue_full='error'", OverloadWarning, stacklevel=2)

    def _activate(self, job: Job) -> None:
        task = job.task
        task.active = job
        ctx = task.ctx
        ctx.job = job
        job.gen = task.body(ctx)
        self._seq = seq = self._seq + 1
        job.seq = seq
        cls = job.cls
        if cls == HANDLER:
            key = task.priority
        elif task.static_key is not None:
            key = task.static_key
        else:
            key = self.policy.key(job)
        job.base_key = job.key = key
        job.state = "ready"
        ready = self.ready  # ReadyQueue.push, inlined
        ready._pushes = n = ready._pushes + 1
        job.ready_entry = entry = [cls, key, seq, n, job]
        heappush(ready._heap, entry)
        ready.live += 1
        env = self._env
        if task.state != "ready":
            task.state = "ready"
            self._sched.append((env.now, task, _READY))
        if not self._dispatch_pending:  # _request_dispatch, inlined
            if not self.sim._stepping:
                q = env.queue       # env.peek() > env.now, inlined
                if not q or q[0][0] > env.now:
                    self._dispatch()
                    return
            self._dispatch_pending = True
            self._dispatch_event.arm(env.now, DISPATCH, self._dispatch_callbacks)

    # ----------------------------------------------------------- dispatching
    def _request_dispatch(self) -> None:
        if not self._dispatch_pending:
            # Shortcut with identical semantics: when no task code is executing and no
            # other event is due at this instant, the deferred dispatch would be the next
            # thing to happen anyway -- do it now instead of through the event queue.
            if not self.sim._stepping:
                env = self._env
                q = env.queue       # env.peek() > env.now, inlined
                if not q or q[0][0] > env.now:
                    self._dispatch()
                    return
            self._dispatch_pending = True
            self._dispatch_event.arm(self._env.now, DISPATCH, self._dispatch_callbacks)

    def _dispatch(self, _event=None) -> None:
        self._dispatch_pending = False
        ready = self.ready
        if self._in_cs or not ready.live:
            return
        best: Job = ready._heap[0][4]  # ReadyQueue.first, inlined
        if best is None:
            best = ready.first()  # live > 0: a job is queued under the dead entries
        np_job = self._np_job
        if np_job is not None and best.cls != HANDLER:
            best = np_job  # resumes before any task once the handlers are done
        r = self.running
        if r is not None:
            if not ((best.cls, best.key) < (r.cls, r.key) and (r.task.preemptible or best.cls < r.cls)):
                return
            self._preempt(r)
        if best is np_job:
            ready.discard(best)
            self._switch_in(best)
            return
        heappop(ready._heap)  # ReadyQueue.pop_first, inlined
        best.ready_entry = None
        ready.live -= 1
        self.running = best  # _switch_in, inlined (best is not the non-preemptible job)
        if self._cs_ticks and self._loaded is not best:
            self._start_cs(best)
            return
        if best.remaining > 0:
            self._run(best)
            return
        self._loaded = best  # _run of a job at the start of a segment, inlined
        best.state = "running"
        if best.start is None:
            best.start = self._env.now
        task = best.task
        if task.state != "running":
            task.state = "running"
            self._sched.append((self._env.now, task, _RUNNING))
        self._step(best)

    def _dispatch_chosen(self, _event=None) -> None:
        """:meth:`_dispatch` for a policy with its own ``choose`` (``SchedulingPolicy.choose``):
        the node's ``_dispatch`` then (set on the instance: the key rule's path pays nothing)."""
        self._dispatch_pending = False
        ready = self.ready
        if self._in_cs or not ready.live:
            return
        r = self.running
        best = self._choose(ready, self)  # type: ignore[misc]  # not None on such a node
        if best is None or best is r:
            return
        if best.ready_entry is None:
            raise RuntimeError(f"node {self.name!r}: policy {self.policy!r} chose {best!r}, "
                               f"which is not in the ready queue")
        np_job = self._np_job
        if np_job is not None and best.cls != HANDLER:
            best = np_job  # resumes before any task once the handlers are done
        if r is not None:
            if best.cls > r.cls or not (r.task.preemptible or best.cls < r.cls):
                return
            self._preempt(r)
        ready.discard(best)
        self._switch_in(best)

    def _preempt(self, job: Job) -> None:
        now = self.sim.env.now
        if job.seg_timer is not None:
            job.seg_timer.cancel()
            job.seg_timer = None
            elapsed = now - job.seg_start
            job.remaining -= elapsed
            job.exec_done += elapsed
        self._stop_budget(job)
        if not job.task.preemptible:
            self._np_job = job
        job.state = "ready"
        self.ready.push(job)
        self.running = None
        self._trace(job.task, "ready")

    def _switch_in(self, job: Job) -> None:
        if job is self._np_job:
            self._np_job = None
        self.running = job
        if self._cs_ticks and self._loaded is not job:
            self._start_cs(job)
            return
        self._run(job)

    def _cs_done(self, ev: Timer) -> None:
        job = ev.arg
        self._in_cs = False
        self._loaded = job
        if job.killed:
            self.running = None
            self._request_dispatch()
            return
        self._run(job)
        # something better may have arrived during the (non-preemptible) switch
        if self.ready.live:
            self._request_dispatch()

    def _unblock(self, job: Job, value=None) -> None:
        """Called by a primitive when a blocked job may continue (its code runs when it gets the CPU)."""
        if job.state != "blocked":
            return
        job.blocked_on = None
        job.resume_value = value
        job.state = "ready"
        self.ready.push(job)
        self._trace(job.task, "ready")
        self._request_dispatch()

    # --------------------------------------------------- priority inheritance
    def _reprioritise(self, job: Job) -> None:
        """Recompute a job's effective key from inheritance (monitors it holds)."""
        best_cls, best_key = job.cls, job.base_key
        for m in job.held:
            if m.inheritance:
                for w in m.waiters:
                    if (w.cls, w.key) < (best_cls, best_key):
                        best_cls, best_key = w.cls, w.key
        if (best_cls, best_key) != (job.cls, job.key):
            job.cls, job.key = best_cls, best_key
            if job.state == "ready":
                self.ready.requeue(job)
            if job.state == "blocked" and job.blocked_on is not None:
                holder = getattr(job.blocked_on, "holder", None)
                if holder is not None:
                    holder.node._reprioritise(holder)
            self._request_dispatch()
