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
    override :meth:`choose` to pick among the ready jobs themselves)."""

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
    """Static priorities given by the user (small number = high priority)."""

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
    """Priority by period (shorter period = higher priority); aperiodic tasks by deadline."""

    name = "rate_monotonic"
    static = True

    def key(self, job):
        """The task's period in ticks; an aperiodic task's relative deadline in ticks, else infinity."""
        t = job.task
        return t.period_ticks if t.period_ticks is not None else (t.deadline_ticks or math.inf)


class DeadlineMonotonic(SchedulingPolicy):
    """Priority by relative deadline (shorter = higher). Equals RM when D = T."""

    name = "deadline_monotonic"
    static = True

    def key(self, job):
        """The task's relative deadline in ticks (infinity without a deadline)."""
        d = job.task.deadline_ticks
        return math.inf if d is None else d


class EDF(SchedulingPolicy):
    """Earliest absolute deadline first; jobs without a deadline run last."""

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
