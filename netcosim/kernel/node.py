"""A node: one CPU with a real-time kernel (TrueTime's kernel block).

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

import math
import warnings
from heapq import heappop, heappush
from typing import Any, Callable

from .. import validate
from ..clock import DISPATCH, Rearmable, Timer
from ..errors import ConfigurationError, ConfigurationTypeError, NotConnectedError, OverloadError, OverloadWarning
from ..timebase import MAX_SECONDS, MAX_TICKS, RESOLUTION, TICKS_PER_SECOND, to_ticks
from ..trace import Sink
from .io import AnalogIn, AnalogOut
from .policies import make_policy
from .ready import ReadyQueue
from .releases import Releases
from .tables import STATE_CODES, jobs_table, schedule_table
from .task import DEFAULT_MAX_PENDING, HANDLER, Blocking, Job, Task
from .timers import KernelTimer, Trigger

_INF = math.inf
_DONE = object()  # what a job's generator gives when it has finished
# state codes of the schedule table's rows (netcosim.kernel.tables.SCHEDULE_RAW)
_READY, _RUNNING, _IDLE = STATE_CODES["ready"], STATE_CODES["running"], STATE_CODES["idle"]


def _check_target(target: Any, what: str) -> None:
    """The task a timer or trigger releases must be a task (``node.aperiodic(...)``)."""
    if not isinstance(target, Task):
        raise ConfigurationTypeError(f"{what} target must be a task (from node.aperiodic or node.periodic), "
                                     f"got {target!r}")


class Node:
    """A CPU with a scheduler.  Create with :meth:`Simulation.node`."""

    def __init__(self, sim, name: str, scheduler: Any = "fixed_priority", *, context_switch: float = 0.0,
                 speed: float = 1.0):
        self.sim = sim
        self.name = name
        self.policy = make_policy(scheduler)
        self.speed = validate.positive(speed, f"node {name!r}: speed")
        if RESOLUTION / self.speed > MAX_SECONDS:
            raise ConfigurationError(f"node {name!r}: speed={speed!r} is so slow that 1 ps of CPU time would "
                                     f"last beyond netcosim's time range, {MAX_SECONDS:.6g} s")
        self._tick_scale = TICKS_PER_SECOND / self.speed
        cs = to_ticks(context_switch, f"node {name!r} context_switch")
        self.context_switch = context_switch
        if cs / self.speed > MAX_TICKS:
            raise ConfigurationError(f"node {name!r}: context_switch={context_switch!r} s at speed {speed!r} "
                                     f"lasts beyond netcosim's time range, {MAX_SECONDS:.6g} s")
        self._cs_ticks: int = int(round(cs / self.speed))
        if cs and not self._cs_ticks:
            raise ConfigurationError(
                f"node {name!r}: context_switch={context_switch!r} s at speed {speed!r} is "
                f"{context_switch / speed!r} s, below the time resolution {RESOLUTION} s")
        self.tasks: dict[str, Task] = {}
        self.ready = ReadyQueue()
        self.running: Job | None = None
        self._loaded: Job | None = None
        self._in_cs: bool = False
        self._np_job: Job | None = None  # non-preemptible job interrupted by a handler
        self._dispatch_pending: bool = False
        self._seq: int = 0
        self._ain: dict[int, AnalogIn] = {}
        self._aout: dict[int, AnalogOut] = {}
        self.interfaces: dict[str, Any] = {}
        self._env: Any = sim.env  # SimPy types `now` as int | float; here it is always integer ticks
        # one event object, re-armed for every dispatch request (at most one pending)
        self._dispatch_event = Rearmable(sim.env)
        self._dispatch_callbacks: list[Callable] = [self._dispatch]
        self._segment_cb = self._segment_done  # one bound method for every segment timer
        # ...and one callback list for a re-armed one: SimPy only replaces a fired event's list
        self._segment_cbs: list[Callable[[Any], None]] = [self._segment_cb]
        # a segment timer that has fired (out of SimPy's queue), re-armed for the next segment
        # instead of creating one; cancelled timers may still sit in the queue and are never kept
        self._spare_timer: Timer | None = None
        self._sched: Sink = schedule_table(sim.trace).rows
        self._releases = Releases(self)  # the periodic releases (kernel.releases owns them)
        jobs = jobs_table(sim.trace)
        self._jobrec: Sink = jobs.rows
        jobs.providers.append(self._unfinished_rows)

    # ------------------------------------------------------------------ tasks
    def _add_task(self, body, kind, name, **kw) -> Task:
        task = Task(self, body, name=name, kind=kind, **kw)
        if task.name in self.tasks:
            raise ConfigurationError(f"node {self.name!r} already has a task called {task.name!r}")
        if kind == "handler":
            validate.finite(task.priority, f"handler {task.name!r}: priority", value_error=ConfigurationTypeError)
        else:
            self.policy.validate(task)
        if kind != "handler" and self.policy.static:
            task.static_key = self.policy.key(Job(task, -1, 0))
        self.tasks[task.name] = task
        self._trace(task, "idle")
        return task

    def periodic(self, body: Callable | None = None, *, period: float, offset: float = 0.0, priority=None,
                 deadline: float | None = None, wcet: float | None = None, name: str | None = None,
                 preemptible: bool = True, on_busy: str = "queue", on_deadline_miss=None,
                 on_budget_overrun=None, max_pending: int | None = DEFAULT_MAX_PENDING,
                 on_queue_full: str = "drop"):
        """Add a periodic task released at ``offset + k*period`` (s).  Usable as a decorator.

        ``priority``: small = high (fixed-priority policy; ignored by RM/DM/EDF).
        ``deadline``: relative deadline (default: the period).  ``max_pending`` (jobs,
        None: unbounded) and ``on_queue_full`` (``"drop"`` or ``"error"``): the bound on
        queued jobs (:class:`~netcosim.kernel.task.Task`).
        """
        def make(fn):
            task = self._add_task(fn, "periodic", name, priority=priority, period=period, offset=offset,
                                  deadline=deadline, wcet=wcet, preemptible=preemptible, on_busy=on_busy,
                                  on_deadline_miss=on_deadline_miss, on_budget_overrun=on_budget_overrun,
                                  max_pending=max_pending, on_queue_full=on_queue_full)
            self._releases.arm(task)
            return task
        return make if body is None else make(body)

    def aperiodic(self, body: Callable | None = None, *, priority=None, deadline: float | None = None,
                  wcet: float | None = None, name: str | None = None, preemptible: bool = True,
                  on_busy: str = "queue", on_deadline_miss=None, on_budget_overrun=None,
                  max_pending: int | None = DEFAULT_MAX_PENDING, on_queue_full: str = "drop"):
        """Add a task whose jobs are released by ``task.release()``, triggers, timers or messages.

        ``deadline``: relative deadline (s) of each job; ``wcet``: execution budget (s);
        ``max_pending``, ``on_queue_full``: the bound on queued jobs, as for :meth:`periodic`.
        """
        def make(fn):
            return self._add_task(fn, "aperiodic", name, priority=priority, deadline=deadline, wcet=wcet,
                                  preemptible=preemptible, on_busy=on_busy, on_deadline_miss=on_deadline_miss,
                                  on_budget_overrun=on_budget_overrun, max_pending=max_pending,
                                  on_queue_full=on_queue_full)
        return make if body is None else make(body)

    def handler(self, body: Callable | None = None, *, priority: float = 0, name: str | None = None,
                deadline: float | None = None):
        """Add an interrupt handler: it beats every task; handlers are ordered by priority.

        ``deadline``: relative deadline (s) of each activation.
        """
        def make(fn):
            return self._add_task(fn, "handler", name, priority=priority, deadline=deadline)
        return make if body is None else make(body)

    def timer(self, target: Task, *, at: float | None = None, period: float | None = None) -> "KernelTimer":
        """Release *target* at absolute time ``at`` (s), then every ``period`` s if given."""
        _check_target(target, "timer")
        return KernelTimer(self, target, at, period)

    def trigger(self, target: Task, *, min_interval: float = 0.0) -> "Trigger":
        """An external trigger releasing *target*; edges closer than ``min_interval`` s are ignored."""
        _check_target(target, "trigger")
        return Trigger(self, target, min_interval)

    # --------------------------------------------------------------- analog I/O
    def analog_in(self, channel: int) -> AnalogIn:
        """Analog input *channel* of this node (connect it to a plant output port)."""
        try:
            ch = self._ain.get(channel)
        except TypeError:           # unhashable: AnalogIn refuses it, naming it
            ch = None
        if ch is None:
            ch = AnalogIn(self, channel)
            self._ain[ch.channel] = ch
        return ch

    def analog_out(self, channel: int) -> AnalogOut:
        """Analog output *channel* of this node (connect it to a plant input port)."""
        try:
            ch = self._aout.get(channel)
        except TypeError:           # unhashable: AnalogOut refuses it, naming it
            ch = None
        if ch is None:
            ch = AnalogOut(self, channel)
            self._aout[ch.channel] = ch
        return ch

    # ---------------------------------------------------------------- networks
    def send(self, dst, payload=None, size_bits=None, *, priority=None, network=None):
        """Send a message through a network interface of this node.

        ``size_bits``: the message size in bits (the network's default when None);
        ``network`` names the interface when the node has several.
        """
        if not self.interfaces:
            raise NotConnectedError(f"node {self.name!r} has no network interface; attach it to a network first")
        if network is None:
            if len(self.interfaces) > 1:
                raise ConfigurationError(f"node {self.name!r} is on several networks {sorted(self.interfaces)}; "
                                         f"pass network=")
            iface = next(iter(self.interfaces.values()))
        else:
            key = getattr(network, "name", network)
            try:
                iface = self.interfaces[key]
            except (KeyError, TypeError):       # TypeError: an unhashable network=
                raise ConfigurationError(f"node {self.name!r} is not on network {key!r}; "
                                         f"it is on {sorted(self.interfaces)}") from None
        return iface.send(dst, payload, size_bits, priority=priority)

    # ------------------------------------------------------------------ kernel
    def _trace(self, task: Task, state: str) -> None:
        if task.state != state:
            task.state = state
            self._sched.append((self._env.now, task, STATE_CODES[state]))

    def _release(self, task: Task, t: int) -> Job | None:
        task.jobs_released = n = task.jobs_released + 1
        job = Job(task, n - 1, t)
        if task.on_deadline_miss is not None and job.abs_deadline is not None:
            job.deadline_timer = self.sim.call_at_ticks(job.abs_deadline, self._deadline_due, arg=job)
        if task.active is not None:
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
        self._activate(job)
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
                if env.peek() > env.now:
                    self._dispatch()
                    return
            self._dispatch_pending = True
            self._dispatch_event.arm(env.now, DISPATCH, self._dispatch_callbacks)

    def _request_dispatch(self) -> None:
        if not self._dispatch_pending:
            # Shortcut with identical semantics: when no task code is executing and no
            # other event is due at this instant, the deferred dispatch would be the next
            # thing to happen anyway -- do it now instead of through the event queue.
            if not self.sim._stepping:
                if self._env.peek() > self._env.now:
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
            self._in_cs = True
            Timer(self._env, self._cs_ticks, self._cs_done, best)
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
            self._in_cs = True
            Timer(self._env, self._cs_ticks, self._cs_done, job)
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
                t.rearm(now + job.remaining, self._segment_cbs)
                job.seg_timer = t
            if task.wcet_ticks is not None:
                self._arm_budget(job)
        else:
            self._step(job)

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
                            t.rearm(now + cmd, self._segment_cbs)
                            job.seg_timer = t
                        if job.task.wcet_ticks is not None and job.budget_timer is None:
                            self._arm_budget(job)
                        break
                    if cmd < 0:
                        raise ValueError(f"task {job.task.name!r}: yielded a negative execution time {cmd}")
                    continue
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
                raise TypeError(f"task {job.task.name!r} on node {self.name!r} yielded {cmd!r}; "
                                f"yield ctx.execute(seconds), ctx.sleep(...), or a blocking call")
        finally:
            sim._stepping -= 1
        if finished:
            self._finish(job)

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
        if job.budget_timer is not None:
            job.budget_timer.cancel()
            job.budget_timer = None
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
                if self._env.peek() > now:
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

    # ----------------------------------------------------------- overruns
    def _deadline_due(self, job: Job) -> None:
        job.deadline_timer = None
        if job.state == "done":
            return
        job.missed = True
        job.task.misses += 1
        h = job.task.on_deadline_miss
        if h == "kill":
            self._kill(job)
        elif h is not None:
            h(job)

    def _arm_budget(self, job: Job) -> None:
        task = job.task
        if task.wcet_ticks is None or job.budget_overrun:
            return
        left = task.wcet_ticks - job.exec_done
        if task.on_budget_overrun is None:
            return
        job.budget_timer = self.sim.call_in_ticks(max(left, 0), self._budget_due, arg=job)

    def _stop_budget(self, job: Job) -> None:
        if job.budget_timer is not None:
            job.budget_timer.cancel()
            job.budget_timer = None

    def _budget_due(self, job: Job) -> None:
        job.budget_timer = None
        if job.state != "running":
            return
        job.budget_overrun = True
        h = job.task.on_budget_overrun
        if h == "kill":
            self._kill(job)
        elif h is not None:
            h(job)

    # ------------------------------------------------------------ priorities
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

    def _unfinished_rows(self) -> list[tuple]:
        """Rows for jobs still active or queued now (finish = NaN); added when the table is read."""
        now = self._env.now
        rows = []
        for task in self.tasks.values():
            jobs = ([task.active] if task.active is not None else []) + list(task.pending)
            for job in jobs:
                done = job.exec_done
                if job.state == "running" and job.seg_timer is not None:
                    done += now - job.seg_start
                rows.append((task, job.index, job.release, job.start, None, done,
                             job.abs_deadline is not None and now > job.abs_deadline, job.budget_overrun, False))
        return rows

    def __repr__(self):
        return f"<Node {self.name} {self.policy.name}>"
