"""Scheduling policies: small plug-in classes that give a job its priority key.

A key is a number; the ready job with the *smallest* key runs (TrueTime's convention:
small number = high priority).  Interrupt handlers always beat tasks whatever the
policy; among handlers the handler priority decides.  Equal keys are served FIFO by
release order, and a newly ready job never preempts a running job with an equal key.
Under EDF, equal absolute deadlines are therefore served in release order.

A policy that must see the ready jobs to decide -- a server under EDF -- overrides
:meth:`SchedulingPolicy.choose`; the key-based rule stays the default and costs nothing
extra (the dispatcher inlines it and calls ``choose`` only when a policy class has its
own).  Multicore nodes (:mod:`~netcosim.kernel.multicore`) schedule by the key alone.
"""

from __future__ import annotations

import math

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError


class SchedulingPolicy:
    """Base class. Subclasses implement :meth:`key` (and may refine :meth:`validate`, or
    override :meth:`choose` to pick among the ready jobs themselves).

    Examples
    --------
    A policy of one's own, given to a node like the built-in ones: the job with the smaller
    budget (``wcet``) first.  Both jobs are released at t = 0; the 1 ms one runs first,
    the 3 ms one ends at 4 ms (times in seconds).

    >>> from netcosim import SchedulingPolicy, Simulation
    >>> class ShortestFirst(SchedulingPolicy):
    ...     name = "shortest_first"
    ...     static = True                      # the key depends on the task only
    ...     def key(self, job):
    ...         return job.task.wcet_ticks
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu", scheduler=ShortestFirst())
    >>> @cpu.aperiodic(wcet=0.003)
    ... def long(ctx):
    ...     yield ctx.execute(0.003)
    >>> @cpu.aperiodic(wcet=0.001)
    ... def short(ctx):
    ...     yield ctx.execute(0.001)
    >>> _ = long.release(), short.release()
    >>> sim.run(until=0.010)
    >>> jobs = sim.trace.jobs()
    >>> dict(zip(jobs.task, jobs.finish.round(6)))
    {'short': 0.001, 'long': 0.004}
    """

    name = "policy"
    #: True when the key depends on the task only (computed once per task)
    static = False

    def key(self, job) -> float:
        """The priority key of *job*: the ready job with the smallest key runs.

        A number (or anything ordered), compared only with keys of the same policy; times
        are integer ticks.  Called when the job is released (once per task when ``static``).
        """
        raise NotImplementedError

    def choose(self, ready, core):
        """The ready job that should have the CPU *core* now, or None to leave the CPU as it is.

        *ready* is the node's :class:`~netcosim.kernel.ready.ReadyQueue` (``first()``, and
        iteration in key order); *core* is what runs the jobs, with ``running`` (the job on
        the CPU or None) -- the node itself while a node has one CPU.  Called at each
        dispatch decision of a node whose policy overrides it; the job returned must be in
        *ready* (or be ``core.running``: no change).  The kernel keeps its own rules around
        the choice: handlers are never preempted by tasks, a non-preemptible task only by
        handlers, and a non-preemptible task interrupted by a handler resumes before any
        other task.  This default is the key rule: the first job in *ready* if it is strictly
        better (class, key) than the running one (the dispatcher runs it inlined).
        """
        best = ready.first()
        r = core.running
        if best is None or (r is not None and not (best.cls, best.key) < (r.cls, r.key)):
            return None
        return best

    def validate(self, task) -> None:
        """Check that *task* carries what this policy needs (raise naming the value)."""
        if task.priority is not None:
            validate.finite(task.priority, f"task {task.name!r}: priority", value_error=ConfigurationTypeError)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class FixedPriority(SchedulingPolicy):
    """Static priorities given by the user (small number = high priority).

    Every task needs a numeric ``priority``: one without is refused when it is created
    (:class:`~netcosim.errors.ConfigurationTypeError`).

    Examples
    --------
    ``fast`` (1 ms every 4 ms, priority 1) preempts ``slow`` (5 ms every 20 ms, priority 2)
    twice, so ``slow``'s response time is 5 + 2 x 1 = 7 ms (the classic response-time
    equation ``R = C + ceil(R / T_fast) C_fast``); times in seconds.

    >>> from netcosim import FixedPriority, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu", scheduler=FixedPriority())     # or scheduler="fixed_priority"
    >>> @cpu.periodic(period=0.004, priority=1)
    ... def fast(ctx):
    ...     yield ctx.execute(0.001)
    >>> @cpu.periodic(period=0.020, priority=2)
    ... def slow(ctx):
    ...     yield ctx.execute(0.005)
    >>> sim.run(until=0.020)
    >>> jobs = sim.trace.jobs()
    >>> jobs[jobs.task == "slow"].response_time.round(6).tolist()
    [0.007]
    """

    name = "fixed_priority"
    static = True

    def key(self, job):
        """The task's user-given ``priority`` (small = high)."""
        return job.task.priority

    def validate(self, task):
        super().validate(task)
        if task.priority is None:
            raise ConfigurationTypeError(f"task {task.name!r}: fixed-priority scheduling needs a numeric "
                                         f"priority, got None")


class RateMonotonic(SchedulingPolicy):
    """Priority by period (shorter period = higher priority); aperiodic tasks by deadline.

    Examples
    --------
    Two tasks of utilisation 2/5 + 4/7 = 0.97 (times in seconds): rate-monotonic gives the
    5 ms task the higher priority, and the 7 ms task's first job, preempted at 5 ms, ends
    at 8 ms, 1 ms after its deadline (:class:`EDF` schedules the same pair without a miss).

    >>> from netcosim import RateMonotonic, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu", scheduler=RateMonotonic())     # or scheduler="rate_monotonic"
    >>> @cpu.periodic(period=0.005)
    ... def t1(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.007)
    ... def t2(ctx):
    ...     yield ctx.execute(0.004)
    >>> sim.run(until=0.035)
    >>> jobs = sim.trace.jobs()
    >>> jobs[jobs.task == "t2"][["response_time", "deadline_miss"]].round(6).values.tolist()[0]
    [0.008, True]
    """

    name = "rate_monotonic"
    static = True

    def key(self, job):
        """The task's period in ticks; an aperiodic task's relative deadline in ticks, else infinity."""
        t = job.task
        return t.period_ticks if t.period_ticks is not None else (t.deadline_ticks or math.inf)


class DeadlineMonotonic(SchedulingPolicy):
    """Priority by relative deadline (shorter = higher). Equals RM when D = T.

    Examples
    --------
    ``a`` runs every 10 ms but must finish within 2 ms; ``b`` runs every 5 ms (deadline 5
    ms).  Deadline-monotonic runs ``a`` first (response 1 ms); rate-monotonic would run ``b``
    first and ``a`` would finish at 3 ms, past its deadline.  Times in seconds.

    >>> from netcosim import DeadlineMonotonic, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu", scheduler=DeadlineMonotonic())     # or "deadline_monotonic"
    >>> @cpu.periodic(period=0.005)
    ... def b(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.010, deadline=0.002)
    ... def a(ctx):
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=0.010)
    >>> jobs = sim.trace.jobs()
    >>> jobs.set_index(["task", "job"]).response_time.round(6).to_dict()
    {('a', 0): 0.001, ('b', 0): 0.003, ('b', 1): 0.002}
    """

    name = "deadline_monotonic"
    static = True

    def key(self, job):
        """The task's relative deadline in ticks (infinity without a deadline)."""
        d = job.task.deadline_ticks
        return math.inf if d is None else d


class EDF(SchedulingPolicy):
    """Earliest absolute deadline first; jobs without a deadline run last.

    Examples
    --------
    The pair that :class:`RateMonotonic` cannot schedule (2 ms every 5 ms, 4 ms every 7
    ms: utilisation 0.97): at 5 ms the 7 ms task's job has the earlier deadline (7 ms
    against 10 ms), keeps the CPU and ends at 6 ms.  No job misses; times in seconds.

    >>> from netcosim import EDF, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu", scheduler=EDF())     # or scheduler="edf"
    >>> @cpu.periodic(period=0.005)
    ... def t1(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.007)
    ... def t2(ctx):
    ...     yield ctx.execute(0.004)
    >>> sim.run(until=0.035)
    >>> jobs = sim.trace.jobs()
    >>> jobs[jobs.task == "t2"].response_time.round(6).tolist()
    [0.006, 0.005, 0.006, 0.005, 0.004]
    >>> bool(jobs.deadline_miss.any())
    False
    """

    name = "edf"

    def key(self, job):
        """The job's absolute deadline in ticks (infinity without a deadline)."""
        d = job.abs_deadline
        return math.inf if d is None else d


POLICIES = {cls.name: cls for cls in (FixedPriority, RateMonotonic, DeadlineMonotonic, EDF)}
POLICIES.update({"fp": FixedPriority, "rm": RateMonotonic, "dm": DeadlineMonotonic})


def own_choose(policy: SchedulingPolicy):
    """*policy*'s bound ``choose`` when its class overrides the key rule's, else None."""
    return None if type(policy).choose is SchedulingPolicy.choose else policy.choose


def make_policy(spec) -> SchedulingPolicy:
    """A policy instance from *spec*: a :class:`SchedulingPolicy` instance (returned as is),
    a subclass (instantiated without arguments) or a name of :data:`POLICIES`, any case
    (``"fixed_priority"``, ``"rate_monotonic"``, ``"deadline_monotonic"``, ``"edf"``, and the
    short ``"fp"``, ``"rm"``, ``"dm"``)."""
    if isinstance(spec, SchedulingPolicy):
        return spec
    if isinstance(spec, type) and issubclass(spec, SchedulingPolicy):
        return spec()
    if isinstance(spec, str):
        cls = POLICIES.get(spec.lower())
        if cls is None:
            raise ConfigurationError(f"unknown scheduling policy {spec!r}; choose one of {sorted(POLICIES)}")
        return cls()
    raise ConfigurationTypeError(f"scheduler must be a SchedulingPolicy or a policy name, got {spec!r}")
