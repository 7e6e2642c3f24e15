"""Tasks, jobs and the context object a task body receives.

A task body is a generator function ``body(ctx)``.  It consumes CPU time only through
``yield ctx.execute(c)``; everything else takes zero simulated time.  Code before the
first ``execute`` runs when the job first gets the CPU; code between two ``execute``
calls runs at the end of the preceding segment (TrueTime's segment semantics).
Blocking calls (``ctx.sleep``, mailbox fetch, semaphore wait, monitor enter, event
wait) are also yielded; the value of the ``yield`` is the fetched item where there is
one.  A ``ctx.execute(c)`` that is not yielded is an error
(:class:`~netcosim.errors.UnyieldedExecuteError`), raised at the latest when the job
next yields something else or finishes.
"""

from __future__ import annotations

import inspect
import math
from collections import deque
from typing import Any, Callable

from .. import validate
from ..clock import Timer
from ..errors import ConfigurationError, ConfigurationTypeError, UnyieldedExecuteError
from ..timebase import MAX_SECONDS, MAX_TICKS, RESOLUTION, TICKS_PER_SECOND, to_ticks

HANDLER, TASK = 0, 1  # job classes: handlers always beat tasks


class Blocking:
    """Base of yieldable commands that may block the job.

    ``attempt(job)`` returns True if satisfied at once (the result, if any, in
    ``job.resume_value``); otherwise it registers the job and the primitive later calls
    ``job.node._unblock(job, value)``.  ``cancel(job)`` withdraws a blocked job.
    """

    __slots__ = ()

    def attempt(self, job) -> bool:
        """Try the operation for *job*: True if satisfied now (a result in ``job.resume_value``), else
        register *job* and return False."""
        raise NotImplementedError

    def cancel(self, job) -> None:
        """Withdraw *job* from the wait it registered (the job was killed or timed out); default: nothing to undo."""
        pass


class Sleep(Blocking):
    """Block until absolute time ``until`` (ticks)."""

    __slots__ = ("until", "timer")

    def __init__(self, until: int):
        self.until = until
        self.timer = None

    def attempt(self, job):
        """True if ``until`` (ticks) is not in the future; otherwise schedule the wake-up and return False."""
        node = job.node
        if self.until <= node.sim.env.now:
            return True
        self.timer = node.sim._call_at_ticks(self.until, lambda: node._unblock(job, None))
        return False

    def cancel(self, job):
        """Cancel the pending wake-up, if any."""
        if self.timer is not None:
            self.timer.cancel()


class Job:
    """One activation of a task.

    ``task``: the :class:`Task` it belongs to; ``index``: its number among the task's jobs
    (0 for the first release); ``release``: its release time (ticks), from which the
    absolute deadline ``release + task.deadline_ticks`` is set.

    Examples
    --------
    Jobs of 3 ms of work with a 2 ms deadline every 5 ms: each misses, and the handler sees
    the job at the instant of the miss, 2 ms of CPU into it (times in seconds):

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> missed = []
    >>> def note(job):
    ...     missed.append((job.index, job.release_time, job.deadline, round(job.execution_time, 6)))
    >>> @cpu.periodic(period=0.005, deadline=0.002, priority=1, on_deadline_miss=note)
    ... def late(ctx):
    ...     yield ctx.execute(0.003)
    >>> sim.run(until=0.010)
    >>> missed
    [(0, 0.0, 0.002, 0.002), (1, 0.005, 0.007, 0.002)]
    """

    # Slots: a job is created per release, and slot stores are cheaper than a dict's.
    __slots__ = ("task", "index", "release", "abs_deadline", "cls", "gen", "state", "remaining",
                 "seg_start", "exec_done", "start", "finish", "seq", "base_key", "key", "resume_value",
                 "seg_timer", "deadline_timer", "budget_timer", "blocked_on", "ready_entry", "killed",
                 "missed", "budget_overrun", "held")

    # A job is created per release: only what a queued job needs is set here; ``gen``,
    # ``seq``, ``base_key`` and ``key`` are set when it is activated, ``seg_start`` when a
    # segment starts.
    def __init__(self, task: "Task", index: int, release: int):
        self.task = task
        self.index = index
        self.release = release
        d = task.deadline_ticks
        self.abs_deadline: int | None = None if d is None else release + d
        self.cls: int = task.cls
        self.state = "queued"
        self.remaining = 0
        self.exec_done = 0
        self.start: int | None = None
        self.finish: int | None = None
        self.resume_value: Any = None
        self.seg_timer: Timer | None = None
        self.deadline_timer: Timer | None = None
        self.budget_timer: Timer | None = None
        self.blocked_on: Blocking | None = None
        self.ready_entry: list | None = None  # the job's live entry in its node's ready queue
        self.killed = False
        self.missed = False
        self.budget_overrun = False
        self.held: list | tuple[()] = ()  # monitors held (a list once the job enters one)

    gen: Any            # the body's generator (set on activation)
    seq: int            # activation order on the node (FIFO among equal keys)
    base_key: Any       # the policy's ordering key (a number or a tuple)
    key: Any            # the effective key (base_key, or an inherited better one)
    seg_start: int      # tick at which the running segment started

    @property
    def node(self):
        """The node the job runs on (its task's)."""
        return self.task.node

    @property
    def release_time(self) -> float:
        """Release time of this job (s)."""
        return self.release / TICKS_PER_SECOND

    @property
    def deadline(self) -> float | None:
        """Absolute deadline of this job (s), or None for a task without a deadline."""
        return None if self.abs_deadline is None else self.abs_deadline / TICKS_PER_SECOND

    @property
    def execution_time(self) -> float:
        """CPU time consumed so far (s), including the running segment."""
        done = self.exec_done
        if self.state == "running" and self.seg_timer is not None:
            done += self.node.sim.env.now - self.seg_start
        return done / TICKS_PER_SECOND

    def kill(self) -> None:
        """Abort this job now (it is recorded as killed; a queued successor starts)."""
        self.node._kill(self)

    def __repr__(self):
        return f"<Job {self.node.name}.{self.task.name}#{self.index} {self.state}>"


def _as_generator_function(body: Callable, task_name: str) -> Callable:
    """*body* itself if it is a generator function; else a generator function that calls it.

    A plain function body runs in zero simulated time and must return None: a value it
    returns (``lambda ctx: 5``, or a generator it built but did not yield from) would be
    dropped without effect, so it is refused, naming the task and the value.
    """
    if inspect.isgeneratorfunction(body):
        return body

    def gen(ctx):
        r = body(ctx)
        if r is not None:
            hint = (" (it returned a generator: make the body itself a generator function, e.g. "
                    "`yield from ...`)" if inspect.isgenerator(r) else "")
            raise ConfigurationTypeError(
                f"task {task_name!r}: a body that is not a generator function must return None, it "
                f"returned {r!r}{hint}")
        return
        yield  # unreachable: makes this a generator

    gen.__name__ = getattr(body, "__name__", "body")
    return gen


def _check_time(value, what, task_name, *, positive=False, allow_none=True):
    """Ticks of a task duration *value* (s); None stays None when *allow_none*.

    Raises ``ConfigurationTypeError`` for a non-number and ``ConfigurationError`` for a
    non-finite, negative, zero (when *positive*) or sub-resolution value, naming the task,
    the parameter and the value.
    """
    if value is None and allow_none:
        return None
    what = f"task {task_name!r}: {what}"
    if not validate.is_real(value):
        raise ConfigurationTypeError(f"{what} must be a finite number of seconds, got {value!r}")
    return validate.duration(value, what, positive=positive, kind="positive")


#: default bound on a task's pending jobs (``max_pending``): far beyond any schedule that
#: recovers, small enough that an overloaded task costs at most a few MB
DEFAULT_MAX_PENDING = 10_000


class Task:
    """A task or interrupt handler on a node.

    Attributes in seconds: ``period``, ``offset``, ``deadline`` (relative), ``wcet``
    (execution budget).  ``on_busy`` says what a release does while the previous job is
    still active: ``"queue"`` (TrueTime: a FIFO of pending jobs, each keeping its own release
    time) or ``"skip"`` (the release is dropped and counted in ``skipped``).  The queue holds
    at most ``max_pending`` jobs (default :data:`DEFAULT_MAX_PENDING`; None: unbounded, as
    TrueTime): a release beyond it is dropped and counted in ``dropped``, with an
    :class:`~netcosim.errors.OverloadWarning` the first time (``on_queue_full="drop"``,
    the default), or raises :class:`~netcosim.errors.OverloadError`
    (``on_queue_full="error"``).  An overloaded task otherwise grows its queue without end
    (a 1 ps period with a 10 ms body: 330 MB per simulated microsecond).
    ``on_deadline_miss`` / ``on_budget_overrun`` are called with the job at the instant of
    the overrun (``"kill"`` aborts the job); without them misses are only recorded.

    Created by :meth:`Node.periodic <netcosim.kernel.node.Node.periodic>`,
    :meth:`~netcosim.kernel.node.Node.aperiodic` and :meth:`~netcosim.kernel.node.Node.handler`:
    ``node`` runs it, ``body`` is its generator function ``body(ctx)``, ``name`` its name
    (None: the body's ``__name__``), ``kind`` one of ``"periodic"``, ``"aperiodic"``,
    ``"handler"`` (a handler beats every task).  ``priority``: small = high (a handler's
    orders the handlers; a task's is read by the fixed-priority policy).  ``preemptible``
    (bool): False runs a started job to its end, interrupted only by handlers.

    Raises
    ------
    ConfigurationTypeError
        If *body* is not callable, *name* is not a non-empty string, a time (``period``,
        ``offset``, ``deadline``, ``wcet``) is not a number of seconds (a periodic task's
        ``period`` None included), ``preemptible`` is not True or False, ``max_pending`` is
        not a number, or ``on_deadline_miss`` / ``on_budget_overrun`` is neither None,
        ``"kill"`` nor a callable.
    ConfigurationError
        If ``period``, ``deadline`` or ``wcet`` is not positive, ``offset`` is negative, a
        time is not finite or is below the 1 ps resolution, ``max_pending`` is not an
        integer >= 1, or ``on_busy`` / ``on_queue_full`` is not one of its choices.

    Examples
    --------
    A periodic task, as :meth:`Node.periodic <netcosim.kernel.node.Node.periodic>` returns
    it: its times in seconds, and its counters after 50 ms (releases at 2, 12, ..., 42 ms):

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=0.010, offset=0.002, priority=1)
    ... def ctrl(ctx):
    ...     yield ctx.execute(0.003)
    >>> ctrl, ctrl.period, ctrl.deadline, ctrl.offset
    (<Task cpu.ctrl periodic>, 0.01, 0.01, 0.002)
    >>> sim.run(until=0.050)
    >>> ctrl.jobs_released, ctrl.finished, ctrl.misses
    (5, 5, 0)
    >>> cpu.periodic(ctrl.body, period=0, priority=1, name="bad")
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: task 'bad': period must be positive, got 0
    """

    # Slots for what the kernel reads on every job (fewer cache lines per task when there
    # are thousands); ``__dict__`` keeps a task open to attributes of the user's own.
    __slots__ = ("node", "name", "kind", "cls", "body", "priority", "period_ticks", "offset_ticks",
                 "deadline_ticks", "wcet_ticks", "preemptible", "on_busy", "on_deadline_miss",
                 "on_budget_overrun", "active", "pending", "jobs_released", "skipped", "misses", "finished",
                 "missed_releases",
                 "max_pending", "on_queue_full", "dropped",
                 "state", "static_key", "ctx", "server", "watched",
                 "__dict__", "__weakref__")

    def __init__(self, node, body: Callable, *, name: str | None, kind: str, priority=None,
                 period=None, offset=0.0, deadline=None, wcet=None, preemptible=True,
                 on_busy="queue", on_deadline_miss=None, on_budget_overrun=None,
                 max_pending: int | None = DEFAULT_MAX_PENDING, on_queue_full: str = "drop"):
        validate.callable_(body, "task body", kind="a callable body(ctx)")
        self.node = node
        if name is not None:        # '' is refused, like node('') (None: the body's name)
            validate.name(name, "task name")
        self.name: str = name if name is not None else getattr(body, "__name__", "task")
        self.kind = kind
        self.cls = HANDLER if kind == "handler" else TASK
        self.body = _as_generator_function(body, self.name)
        self.priority = priority
        self.period_ticks = _check_time(period, "period", self.name, positive=True,
                                        allow_none=kind != "periodic")
        # ticks from the task's creation to its first release (the release group keeps the absolute one)
        self.offset_ticks = _check_time(offset, "offset", self.name) or 0
        if deadline is None and period is not None:
            self.deadline_ticks = self.period_ticks
        else:
            self.deadline_ticks = _check_time(deadline, "deadline", self.name, positive=True)
        self.wcet_ticks = _check_time(wcet, "wcet", self.name, positive=True)
        validate.boolean(preemptible, f"task {self.name!r}: preemptible")
        self.preemptible = preemptible
        validate.choice(on_busy, f"task {self.name!r}: on_busy", ("queue", "skip"))
        self.on_busy = on_busy
        self.max_pending = None if max_pending is None else validate.count(
            max_pending, f"task {self.name!r}: max_pending (jobs)", minimum=1)
        validate.choice(on_queue_full, f"task {self.name!r}: on_queue_full", ("drop", "error"))
        self.on_queue_full = on_queue_full
        for nm, h in (("on_deadline_miss", on_deadline_miss), ("on_budget_overrun", on_budget_overrun)):
            if h is not None and h != "kill" and not callable(h):
                raise ConfigurationTypeError(f"task {self.name!r}: {nm} must be a callable(job) or 'kill', "
                                             f"got {h!r}")
        self.on_deadline_miss = on_deadline_miss
        self.on_budget_overrun = on_budget_overrun
        self.active: Job | None = None
        self.pending: deque[Job] = deque()
        self.jobs_released = 0
        self.skipped = 0
        self.dropped = 0
        self.misses = 0
        self.finished = 0
        #: periodic releases a forward step of the node's local clock skipped (docs/kernel.md, "Local clocks")
        self.missed_releases = 0
        self.state = "idle"
        self.static_key: Any = None  # set by the node when the policy key depends on the task only
        #: the bandwidth server serving the task (:mod:`~netcosim.kernel.servers`), or None
        self.server: Any = None
        # the kernel tells someone when a job gets and leaves the CPU: a budget timer, a server
        self.watched = self.wcet_ticks is not None
        self.ctx = TaskContext(self)

    # Release ---------------------------------------------------------------
    def release(self) -> Job | None:
        """Release a job now (aperiodic tasks and handlers; also allowed for periodic)."""
        return self.node._release(self, self.node.sim.env.now)

    def stop(self) -> None:
        """Stop future periodic releases (jobs already released continue)."""
        self.node._releases.stop(self)

    @property
    def period(self) -> float | None:
        """Period (s), or None for an aperiodic task or a handler."""
        return None if self.period_ticks is None else self.period_ticks / TICKS_PER_SECOND

    @property
    def offset(self) -> float:
        """Time (s) from the task's creation to its first periodic release."""
        return self.offset_ticks / TICKS_PER_SECOND

    @property
    def deadline(self) -> float | None:
        """Relative deadline (s), or None when the task has none."""
        return None if self.deadline_ticks is None else self.deadline_ticks / TICKS_PER_SECOND

    def __repr__(self):
        return f"<Task {self.node.name}.{self.name} {self.kind}>"


class TaskContext:
    """What a task body sees: time, CPU, I/O, synchronisation, logging, messages.

    Examples
    --------
    A body reads the time (``ctx.now``, s), asks for 2 ms of CPU, sleeps 1 ms and logs how
    long that took: 3 ms per job (times in seconds).

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def ctrl(ctx):
    ...     t0 = ctx.now
    ...     yield ctx.execute(0.002)
    ...     yield ctx.sleep(0.001)
    ...     ctx.log("elapsed", ctx.now - t0)
    >>> sim.run(until=0.030)
    >>> sim.trace.signal("cpu.ctrl", "elapsed").round(6).tolist()
    [0.003, 0.003, 0.003]
    """

    __slots__ = ("task", "node", "sim", "job", "_exec_rng", "_unyielded")

    def __init__(self, task: Task):
        self.task = task
        self.node = task.node
        self.sim = task.node.sim
        self.job: Job | None = None
        self._exec_rng = None
        #: the *c* of an ``execute(c)`` not yet yielded (the node clears it when the
        #: request comes back through the generator, and raises if something else does)
        self._unyielded: Any = None

    @property
    def now(self) -> float:
        """Current time (s): the simulation's, or the node's local clock when it has one."""
        return self.sim.env.now / TICKS_PER_SECOND

    @property
    def clock(self):
        """The node's clock (:class:`~netcosim.kernel.localclock.LocalClock`): ``ctx.clock.set(t)``
        steps it, ``ctx.clock.adjust(delta, over=...)`` slews it (nodes created with a clock)."""
        return self.node.clock

    @property
    def rng(self):
        """This task's random stream (named ``node/task``)."""
        return self.sim.rng(f"{self.node.name}/{self.task.name}")

    def execute(self, c) -> int:
        """Request *c* seconds of CPU (at speed 1); preemptible.  Must be yielded:
        ``yield ctx.execute(c)``.

        *c* is a number of seconds (0, or at least the 1 ps resolution after division by
        the node's ``speed``), a frozen ``scipy.stats`` distribution (``.rvs``), or a
        callable ``c(rng) -> seconds`` drawn from the task's execution-time stream.
        Returns the request (integer ticks at the node's speed) for the kernel.  A bad
        or sub-resolution *c* raises naming it; calling ``execute`` again before the
        previous request was yielded raises :class:`~netcosim.errors.UnyieldedExecuteError`.
        """
        if type(c) is float and 0.0 < c < 1e9 and self._unyielded is None:  # fast path
            scaled = c * self.node._tick_scale
            ticks = int(scaled + 0.5) if scaled < MAX_TICKS else 0   # beyond the time range: checked below
            if ticks:
                self._unyielded = c
                return ticks
        return self._execute_checked(c)

    def _execute_checked(self, c) -> int:
        node = self.node
        who = f"task {self.task.name!r} on node {node.name!r}"
        if self._unyielded is not None:
            raise self._unyielded_error(f"then called ctx.execute({c!r})")
        if not isinstance(c, (int, float)) or isinstance(c, bool):
            if self._exec_rng is None:
                self._exec_rng = self.sim.rng(f"{node.name}/{self.task.name}/execution")
            if hasattr(c, "rvs"):
                c = float(c.rvs(random_state=self._exec_rng))
            elif callable(c):
                c = c(self._exec_rng)
            if not validate.is_real(c):
                raise ConfigurationTypeError(f"{who}: execution time must be a number of seconds, got {c!r}")
        if not (c >= 0) or c == math.inf:
            raise ConfigurationError(f"{who}: execution time must be finite and >= 0, got {c!r}")
        if 0 < c < RESOLUTION:
            raise ConfigurationError(f"{who}: execution time {c!r} s is non-zero but below the time "
                                     f"resolution {RESOLUTION} s (netcosim.RESOLUTION)")
        scaled = float(c) * node._tick_scale if c <= MAX_SECONDS else math.inf
        if not scaled <= MAX_TICKS:
            raise ConfigurationError(f"{who}: execution time {c!r} s at node speed {node.speed!r} lies beyond "
                                     f"netcosim's time range, {MAX_SECONDS:.6g} s")
        ticks = int(round(scaled))
        if ticks == 0 and c > 0:
            raise ConfigurationError(f"{who}: execution time {c!r} s at node speed {node.speed!r} is "
                                     f"{c / node.speed!r} s, below the time resolution {RESOLUTION} s")
        self._unyielded = c
        return ticks

    def _unyielded_error(self, what: str) -> UnyieldedExecuteError:
        c, self._unyielded = self._unyielded, None
        job = self.job
        return UnyieldedExecuteError(
            f"task {self.task.name!r} on node {self.node.name!r}"
            f"{'' if job is None else f' (job {job.index})'} called ctx.execute({c!r}) without "
            f"yielding it and {what}; write `yield ctx.execute({c!r})` (an unyielded request "
            f"consumes no CPU time)")

    def sleep(self, seconds: float) -> Sleep:
        """Block for *seconds* (the CPU is free meanwhile)."""
        d = to_ticks(seconds, f"task {self.task.name!r} sleep")
        return Sleep(self.sim.env.now + d)

    def sleep_until(self, t: float) -> Sleep:
        """Block until absolute time *t* seconds."""
        return Sleep(to_ticks(t, f"task {self.task.name!r} sleep_until"))

    def read(self, port):
        """Sample an analog input (a plant output port or a node channel) now."""
        try:
            reader = port.read
        except AttributeError:
            raise TypeError(f"task {self.task.name!r}: cannot read from {port!r}") from None
        return reader()

    def write(self, port, value) -> None:
        """Write *value* (the plant's input units) to *port*, an analog output (a plant input
        port or a node's :meth:`~netcosim.kernel.node.Node.analog_out` channel); the plant
        holds it until the next write (ZOH)."""
        try:
            writer = port.write
        except AttributeError:
            raise TypeError(f"task {self.task.name!r}: cannot write to {port!r}") from None
        writer(value)

    def log(self, signal: str, value: float) -> None:
        """Record ``value`` under ``signal`` in the signals trace (source ``node.task``)."""
        self.sim.trace.signal_rec.rows.append(
            (self.sim.env.now / TICKS_PER_SECOND, f"{self.node.name}.{self.task.name}", signal, float(value)))

    def release(self, task: Task) -> Job | None:
        """Release a job of *task* now."""
        return task.release()

    def send(self, dst, payload: Any = None, size_bits: int | None = None, *, priority=None, network=None):
        """Send a message over one of this node's network interfaces (see netcosim.network):
        *payload* to *dst* (a node name, node, interface or ``BROADCAST``), ``size_bits`` in
        bits, ``priority`` the MAC priority (small = high), ``network`` the interface when the
        node has several (:meth:`Node.send <netcosim.kernel.node.Node.send>`)."""
        return self.node.send(dst, payload, size_bits, priority=priority, network=network)

    def kill(self) -> None:
        """Abort the current job."""
        job = self.job
        assert job is not None, "kill() is called from a running task body"
        job.kill()
