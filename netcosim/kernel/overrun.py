"""Overruns: a job's deadline timer and execution-budget (WCET) timer.

Both are an :class:`OverrunTimer`, created only for a task with a handler
(``on_deadline_miss``, ``on_budget_overrun``): without one, misses and overruns are
found from the job's times when it finishes.  When the timer fires the job is marked
(``missed``, ``budget_overrun``) and the handler is called with it; ``"kill"`` aborts it.
The budget timer runs only while the job runs: it is stopped when the job is preempted
or blocks, and armed again for what is left when it runs again.  The same two calls tell
a task's bandwidth server (:mod:`~netcosim.kernel.servers`) when its job gets and leaves
the CPU.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..clock import Timer
from .state import KernelState

if TYPE_CHECKING:
    from .task import Job

#: the two kinds of overrun timer
DEADLINE, BUDGET = 0, 1


def _fired(timer: Any) -> None:  # an OverrunTimer (SimPy calls it with the event)
    job = timer.arg
    task = job.task
    if timer.kind == DEADLINE:
        job.deadline_timer = None
        if job.state == "done":
            return
        job.missed = True
        task.misses += 1
        h = task.on_deadline_miss
    else:
        job.budget_timer = None
        if job.state != "running":
            return
        job.budget_overrun = True
        h = task.on_budget_overrun
    if h == "kill":
        task.node._kill(job)
    elif h is not None:
        h(job)


class OverrunTimer(Timer):
    """*job*'s deadline (``kind=DEADLINE``) or budget (``BUDGET``) timer, *delay* ticks from now."""

    __slots__ = ("kind",)

    def __init__(self, job: Job, delay: int, kind: int):
        super().__init__(job.task.node._env, delay, _fired, job)
        self.kind = kind


class Overruns(KernelState):
    """The node's part that arms and stops budget timers (deadline timers are armed at release)."""

    def _arm_budget(self, job: Job) -> None:
        """*job* got the CPU: its server is told, its budget timer armed (if it has a handler)."""
        task = job.task
        if task.server is not None:
            task.server._start(job)
        if task.wcet_ticks is None or job.budget_overrun or task.on_budget_overrun is None:
            return
        job.budget_timer = OverrunTimer(job, max(task.wcet_ticks - job.exec_done, 0), BUDGET)

    def _stop_budget(self, job: Job) -> None:
        """*job* left the CPU: its budget timer stopped, its server told."""
        if job.task.server is not None:
            job.task.server._stop(job)
        if job.budget_timer is not None:
            job.budget_timer.cancel()
            job.budget_timer = None
