"""The job interpreter: runs a job's body, a generator, between its commands.

``yield ctx.execute(c)`` (integer ticks) starts a segment of *c* ticks on the CPU, a
:class:`~netcosim.kernel.task.Blocking` command (sleep, mailbox fetch, semaphore,
monitor, event) may block the job; any code between them runs in zero simulated time,
at the end of the preceding segment.  When the body ends the job finishes: its
statistics row is written and the task's next queued job, if any, is activated.
"""

from __future__ import annotations

from heapq import heappush
from typing import TYPE_CHECKING

from ..clock import DISPATCH, NORMAL, Timer
from ..errors import ConfigurationTypeError
from .overrun import Overruns
from .tables import STATE_CODES
from .task import Blocking

if TYPE_CHECKING:
    from .task import Job

_DONE = object()  # what a job's generator gives when it has finished
# state codes of the schedule table's rows (netcosim.kernel.tables.SCHEDULE_RAW)
_RUNNING, _IDLE = STATE_CODES["running"], STATE_CODES["idle"]


class Interpreter(Overruns):
    """The node's part that runs jobs' code and ends jobs (finished or killed)."""

    def _run(self, job: Job) -> None:
        self._loaded = job
        job.state = "running"
        now = self._env.now
        if job.start is None:
            job.start = now
        task = job.task
        if task.state != "running":
            task.state = "running"
            self._sched.append((now, task, _RUNNING))
        if job.remaining > 0:
            job.seg_start = now
            t = self._spare_timer
            if t is None:
                job.seg_timer = Timer(self._env, job.remaining, self._segment_cb, job)
            else:
                self._spare_timer = None
                t.arg = job
                t.callbacks = self._segment_cbs  # t.rearm(now + job.remaining, ...), inlined
                env = self._env
                heappush(env.queue, (now + job.remaining, NORMAL, next(env.ids), t))
                job.seg_timer = t
            if task.watched:
                self._arm_budget(job)
        else:
            self._step(job)

    def _start_cs(self, job: Job, ticks: int = 0) -> None:
        """Switch *job* in: ``_cs_ticks`` (or *ticks*: a multicore node's switch plus
        migration) of non-preemptible kernel work, then ``_cs_done`` (the timer is kept,
        so that a speed change can move it and a power-off cancel it)."""
        self._in_cs = True
        env = self._env
        pw = self._pw
        ticks = ticks or self._cs_ticks
        pw.cs_end = env.now + ticks
        pw.cs_timer = t = Timer(env, ticks, self._cs_done, job)
        meter = pw.cpu_meter
        if meter is not None:       # the CPU is busy from now until the switch ends
            t.callbacks.append(meter.update)
            meter.update()

    def _segment_done(self, ev: Timer) -> None:
        job = ev.arg
        now = self._env.now
        job.exec_done += now - job.seg_start
        job.remaining = 0
        job.seg_timer = None
        self._spare_timer = ev
        self._step(job)

    def _step(self, job: Job) -> None:
        """Run the job's code up to its next execute/blocking call (zero simulated time).

        While it runs, ``sim._stepping`` is raised so that dispatch requests are deferred.
        """
        gen = job.gen
        env = self._env
        sim = self.sim
        ctx = job.task.ctx
        sim._stepping += 1
        finished = False
        try:
            while True:
                value = job.resume_value
                try:
                    if value is None:
                        # next() with a default ends the generator without a StopIteration object
                        cmd = next(gen, _DONE)
                    else:
                        job.resume_value = None
                        cmd = gen.send(value)
                except StopIteration:
                    cmd = _DONE
                except Exception as exc:
                    exc.add_note(f"netcosim: in task {job.task.name!r} on node {self.name!r}, "
                                 f"job {job.index}, t = {sim.now:.9f} s")
                    raise
                if cmd is _DONE:
                    if ctx._unyielded is not None:
                        raise ctx._unyielded_error(f"finished at t = {sim.now:.9f} s") from None
                    finished = True
                    break
                if type(cmd) is int:
                    if ctx._unyielded is None:      # an int that ctx.execute did not make
                        raise self._bad_command(job, cmd)
                    ctx._unyielded = None  # the execute request came back through the yield
                    if cmd > 0:
                        job.remaining = cmd
                        now = job.seg_start = env.now
                        t = self._spare_timer
                        if t is None:
                            job.seg_timer = Timer(env, cmd, self._segment_cb, job)
                        else:
                            self._spare_timer = None
                            t.arg = job
                            t.callbacks = self._segment_cbs  # t.rearm(now + cmd, ...), inlined
                            heappush(env.queue, (now + cmd, NORMAL, next(env.ids), t))
                            job.seg_timer = t
                        if job.task.watched and job.budget_timer is None:
                            self._arm_budget(job)
                        break
                    continue        # ctx.execute(0): nothing to run (execute never returns < 0)
                if ctx._unyielded is not None:
                    raise ctx._unyielded_error(f"then yielded {cmd!r} at t = {sim.now:.9f} s")
                if isinstance(cmd, Blocking):
                    if cmd.attempt(job):
                        continue
                    self._stop_budget(job)
                    job.blocked_on = cmd
                    job.state = "blocked"
                    self.running = None
                    self._trace(job.task, "blocked")
                    self._request_dispatch()
                    break
                raise self._bad_command(job, cmd)
        finally:
            sim._stepping -= 1
        if finished:
            self._finish(job)

    def _bad_command(self, job: Job, cmd: object) -> ConfigurationTypeError:
        """The error for a yielded value that is not a kernel command (a bare number, None, ...)."""
        return ConfigurationTypeError(
            f"task {job.task.name!r} on node {self.name!r} yielded {cmd!r}, which is not a kernel command; "
            f"yield ctx.execute(seconds), ctx.sleep(...), or a blocking call")

    def _finish(self, job: Job, killed: bool = False) -> None:
        now = self._env.now
        task = job.task
        job.finish = now
        job.state = "done"
        if killed:
            job.killed = True
        if self.running is job:
            self.running = None
        if self._loaded is job:
            self._loaded = None
        if job.seg_timer is not None:
            job.seg_timer.cancel()
            job.seg_timer = None
        if job.deadline_timer is not None:
            job.deadline_timer.cancel()
            job.deadline_timer = None
        if task.watched:
            self._stop_budget(job)
        if job.held:
            names = [m.name for m in job.held]
            for m in list(job.held):
                m._release_by(job)
            if not killed:
                raise RuntimeError(f"task {task.name!r} on node {self.name!r} finished job {job.index} "
                                   f"while holding monitor(s) {names}")
        dl = job.abs_deadline  # _record, inlined
        miss = job.missed or (dl is not None and now > dl)
        if miss and not job.missed:
            task.misses += 1
            job.missed = True
        wcet = task.wcet_ticks
        self._jobrec.append((task, job.index, job.release, job.start, now, job.exec_done, miss,
                             job.budget_overrun or (wcet is not None and job.exec_done > wcet), job.killed))
        task.finished += 1
        task.active = None
        if task.pending:
            self._activate(task.pending.popleft())
        else:
            if task.state != "idle":
                task.state = "idle"
                self._sched.append((now, task, _IDLE))
            task.ctx.job = None
        if self.ready.live and not self._dispatch_pending:  # _request_dispatch, inlined
            if not self.sim._stepping:
                q = self._env.queue     # env.peek() > now, inlined
                if not q or q[0][0] > now:
                    self._dispatch()
                    return
            self._dispatch_pending = True
            self._dispatch_event.arm(self._env.now, DISPATCH, self._dispatch_callbacks)

    def _kill(self, job: Job) -> None:
        if job.state == "done":
            return
        task = job.task
        if job.state == "queued":
            task.pending.remove(job)
            job.state = "done"
            job.killed = True
            if job.deadline_timer is not None:
                job.deadline_timer.cancel()
            self._record(job)
            return
        if job.state == "ready":
            self.ready.discard(job)
            if job is self._np_job:
                self._np_job = None
        elif job.state == "blocked" and job.blocked_on is not None:
            job.blocked_on.cancel(job)
        elif job.state == "running" and job.seg_timer is not None:
            job.exec_done += self.sim.env.now - job.seg_start
        if self.running is job and self._in_cs:
            job.killed = True  # the switch completes, then the CPU is re-dispatched
        if job.gen is not None:
            job.gen.close()
        self._finish(job, killed=True)

    # ----------------------------------------------------------- statistics
    def _record(self, job: Job) -> None:
        """Append the job's statistics (raw ticks; the trace derives the reported columns)."""
        dl = job.abs_deadline
        miss = job.missed or (dl is not None and job.finish is not None and job.finish > dl)
        if miss and not job.missed:
            job.task.misses += 1
            job.missed = True
        wcet = job.task.wcet_ticks
        self._jobrec.append((job.task, job.index, job.release, job.start, job.finish, job.exec_done, miss,
                             job.budget_overrun or (wcet is not None and job.exec_done > wcet), job.killed))
