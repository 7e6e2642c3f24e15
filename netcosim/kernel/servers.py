"""Bandwidth servers under EDF: the constant-bandwidth server (CBS) and the total-bandwidth
server (TBS), as TrueTime's ``ttCreateCBS`` / ``ttAttachCBS``.

A server is a plug-in on the scheduling policy's seams, not a case in the kernel: a node
that has a server schedules with :class:`ServedEDF`, the EDF policy whose ``key`` gives a
job of a served task its server's deadline, and whose ``choose`` passes over the jobs of a
hard CBS that ran out of budget.  The kernel tells the server when one of its jobs gets
the CPU and when it leaves it (the same two calls that run a job's execution-budget
timer, :mod:`~netcosim.kernel.overrun`); everything else is here.

Rules (Abeni and Buttazzo's CBS; TrueTime's replenishment rules), all in integer ticks:

* A server has a budget ``cs`` (CPU time it may still use) and a deadline ``ds``; its
  jobs are scheduled by EDF with ``ds`` as their deadline (the task's own relative
  deadline still decides the job's deadline misses in the jobs table).  Jobs of one server
  are served in the order they reach it (equal keys are FIFO).
* **Arrival** of a job to an idle server at time r (no job of the server active): if
  ``cs * Ts >= (ds - r) * Qs`` the server is recharged, ``ds = r + Ts``, ``cs = Qs``;
  otherwise it goes on with its current budget and deadline.  A job queued behind its own
  task's previous job reached the server while it was busy (no recharge).
* While a job of the server runs, ``cs`` decreases at 1 tick per tick.  When it reaches 0,
  a **soft** CBS postpones at once (``ds += Ts``, ``cs = Qs``) and the ready jobs are
  re-sorted; a **hard** CBS suspends its jobs until the old ``ds``, then ``cs = Qs`` and
  ``ds += Ts`` (the running job is preempted and traced ``ready``: it waits for budget).
* **TBS** (utilisation Us): a job reaching the server at r gets the deadline
  ``d = max(d_last, r) + C / Us``, C the task's ``wcet`` (as TrueTime), rounded to the
  nearest tick; no budget is enforced.

The ``servers`` trace table has one row per server event: ``time`` (s), ``node``,
``server``, ``event`` (``recharged``, ``exhausted``, ``postponed``, ``throttled``,
``replenished``, ``deadline``), ``budget`` (s left after the event; NaN for a TBS) and
``deadline`` (s, the server deadline after the event).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from .. import validate
from ..clock import Timer
from ..errors import ConfigurationError, ConfigurationTypeError
from ..readback import categorical_from_codes
from ..timebase import TICKS_PER_SECOND, to_ticks
from .policies import EDF
from .tables import _per_task

if TYPE_CHECKING:
    import pandas as pd

    from ..recorder import Recorder
    from ..trace import Trace
    from .task import Job, Task

__all__ = ["CBS", "TBS", "Server", "ServedEDF", "servers_table"]

#: Columns of the servers table as stored: times in ticks, the server object.
SERVERS_RAW = ("time", "server", "event", "budget", "deadline")


class Server:
    """Base of the servers: the tasks attached, the deadline, the trace rows.

    A subclass gives :meth:`deadline_for` (the key of a job reaching the server) and, if it
    enforces a budget, :meth:`_start` / :meth:`_stop` (a job of the server got / left the CPU).
    ``node``: the (EDF) node whose tasks it serves; ``name``: its name, unique on the node
    (the ``servers`` table's rows carry it).
    """

    #: a hard server's jobs may be held back from the CPU (see :meth:`eligible`)
    throttled = False

    def __init__(self, node, name: str):
        self.node = node
        self.name = name
        self.tasks: list[Task] = []
        self._ds = 0                        # the server deadline (ticks)
        self._jobs: list[Job] = []          # its jobs that reached it and are not done
        self._rows = servers_table(node.sim.trace).rows

    # -- the tasks ----------------------------------------------------------------------
    def attach(self, task: Task) -> Task:
        """Serve *task* (of this server's node; not a handler; preemptible; not yet released).
        Returns the task.  ``node.periodic(..., server=s)`` calls this."""
        from .task import Task
        if not isinstance(task, Task):
            raise ConfigurationTypeError(f"server {self.name!r}: attach takes a task, got {task!r}")
        if task.node is not self.node:
            raise ConfigurationError(f"server {self.name!r} is on node {self.node.name!r}; task {task.name!r} "
                                     f"is on node {task.node.name!r}")
        if task.kind == "handler":
            raise ConfigurationError(f"server {self.name!r}: handler {task.name!r} cannot be served "
                                     f"(handlers beat every task)")
        if getattr(task, "server", None) is not None:
            raise ConfigurationError(f"task {task.name!r} is already served by {task.server.name!r}")
        if not task.preemptible:
            raise ConfigurationError(f"server {self.name!r}: task {task.name!r} is non-preemptible; a server "
                                     f"must be able to stop its tasks when the budget runs out")
        if task.jobs_released:
            raise ConfigurationError(f"server {self.name!r}: task {task.name!r} has already released jobs; "
                                     f"attach it before the simulation runs it")
        self._check(task)
        task.server = self
        task.watched = True
        self.tasks.append(task)
        return task

    def _check(self, task: Task) -> None:
        """What this kind of server needs of a task (raise naming the value)."""

    # -- run-time state -----------------------------------------------------------------
    @property
    def deadline(self) -> float:
        """The server deadline (s) now."""
        return self._ds / TICKS_PER_SECOND

    def eligible(self, job: Job) -> bool:
        """Whether *job* (of this server) may have the CPU now."""
        return True

    def deadline_for(self, job: Job) -> int:
        """The EDF key (ticks) of *job* reaching the server now."""
        raise NotImplementedError

    def _reached(self, job: Job) -> bool:
        """Note that *job* reaches the server now; True if the server was idle and the job
        arrived now (not queued behind its own task's previous job)."""
        jobs = [j for j in self._jobs if j.state != "done"]
        idle = not jobs
        jobs.append(job)
        self._jobs = jobs
        return idle and job.release >= self.node._env.now

    def _start(self, job: Job) -> None:
        """*job* got the CPU (its segment starts or resumes)."""

    def _stop(self, job: Job) -> None:
        """*job* left the CPU (preempted, blocked, finished or killed)."""

    def _rekey(self) -> None:
        """Give every active job of the server the current deadline as its key."""
        node, ds = self.node, self._ds
        for j in self._jobs:
            if j.state == "done" or j.base_key == ds:
                continue
            j.base_key = ds
            if j.held:
                node._reprioritise(j)
            elif j.key != ds:
                j.key = ds
                if j.state == "ready":
                    node.ready.requeue(j)
        node._request_dispatch()

    def _trace(self, event: str, budget: int | None) -> None:
        self._rows.append((self.node._env.now, self, event, budget, self._ds))

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.node.name}.{self.name}>"


class CBS(Server):
    """Constant-bandwidth server: *budget* Qs (s of CPU) per *period* Ts (s); ``hard=True``
    suspends the server's jobs until its deadline when the budget runs out (TrueTime's hard
    CBS), ``hard=False`` postpones the deadline at once (soft).  Create with
    :meth:`Node.cbs <netcosim.kernel.node.Node.cbs>`; ``node`` and ``name`` as for :class:`Server`.

    Run-time counters: :attr:`budget` (s left), :attr:`deadline` (s), ``exhaustions``
    (times the budget ran out), ``recharges`` (arrival rule), ``throttled`` (hard: held now).
    """

    def __init__(self, node, name: str, budget: float, period: float, hard: bool = False):
        super().__init__(node, name)
        what = f"CBS {name!r} on node {node.name!r}"
        self.q = to_ticks(validate.positive(budget, f"{what}: budget (s)"), f"{what}: budget")
        self.t = to_ticks(validate.positive(period, f"{what}: period (s)"), f"{what}: period")
        if not self.q or not self.t:
            raise ConfigurationError(f"{what}: budget={budget!r} s and period={period!r} s must each be at least "
                                     f"one tick")
        if self.q > self.t:
            raise ConfigurationError(f"{what}: budget={budget!r} s exceeds period={period!r} s (bandwidth > 1)")
        self.hard = validate.boolean(hard, f"{what}: hard")
        self.bandwidth = self.q / self.t
        self._cs = 0                        # budget left (ticks), as of _since when a job runs
        self._job: Job | None = None        # the job of the server on the CPU
        self._since = 0                     # when it got it (ticks)
        self._timer: Timer | None = None    # budget exhaustion, or (hard) the replenishment
        self.exhaustions = 0
        self.recharges = 0
        self.throttled = False

    @property
    def budget(self) -> float:
        """Budget left now (s), counting the running job's use so far."""
        cs = self._cs
        if self._job is not None:
            cs -= self.node._env.now - self._since
        return cs / TICKS_PER_SECOND

    def eligible(self, job: Job) -> bool:
        return not self.throttled

    def deadline_for(self, job: Job) -> int:
        if self._reached(job) and not self.throttled:
            r = self.node._env.now
            if self._cs * self.t >= (self._ds - r) * self.q:
                self._ds, self._cs = r + self.t, self.q
                self.recharges += 1
                self._trace("recharged", self._cs)
        return self._ds

    def _start(self, job: Job) -> None:
        if self._job is job:
            return
        self._job = job
        self._since = self.node._env.now
        self._timer = Timer(self.node._env, self._cs, self._exhausted)

    def _stop(self, job: Job) -> None:
        if self._job is not job:
            return
        self._cs -= self.node._env.now - self._since
        self._job = None
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self._cs <= 0:
            self._exhaust()

    def _exhausted(self, _timer) -> None:
        """The budget ran out while a job of the server runs."""
        self._timer = None
        job = self._job
        self._cs -= self.node._env.now - self._since
        self._job = None
        self._exhaust()
        if job is None or job.state != "running":
            return
        if self.throttled:
            self.node._preempt(job)       # the CPU is free for others until the replenishment
            self.node._request_dispatch()
        else:
            self._start(job)              # soft: it goes on with the new budget and deadline

    def _exhaust(self) -> None:
        self._cs = 0
        self.exhaustions += 1
        self._trace("exhausted", 0)
        if self.hard:
            self.throttled = True
            self._trace("throttled", 0)
            self._timer = Timer(self.node._env, self._ds - self.node._env.now, self._replenish)
        else:
            self._ds += self.t
            self._cs = self.q
            self._trace("postponed", self._cs)
            self._rekey()

    def _replenish(self, _timer) -> None:
        """Hard CBS: the old deadline is reached: recharge, postpone, release the jobs."""
        self._timer = None
        self.throttled = False
        self._cs = self.q
        self._ds = max(self._ds, self.node._env.now) + self.t
        self._trace("replenished", self._cs)
        self._rekey()



class TBS(Server):
    """Total-bandwidth server of utilisation *utilization* (0 < Us <= 1): a job reaching it
    at r gets the deadline ``max(d_last, r) + C/Us`` with C its task's ``wcet`` (required).
    Create with :meth:`Node.tbs <netcosim.kernel.node.Node.tbs>`; ``node`` and ``name`` as
    for :class:`Server`."""

    def __init__(self, node, name: str, utilization: float):
        super().__init__(node, name)
        u = validate.positive(utilization, f"TBS {name!r} on node {node.name!r}: utilization")
        if u > 1:
            raise ConfigurationError(f"TBS {name!r} on node {node.name!r}: utilization={utilization!r} exceeds 1")
        self.utilization = u

    def _check(self, task: Task) -> None:
        if task.wcet_ticks is None:
            raise ConfigurationError(f"TBS {self.name!r}: task {task.name!r} has no wcet; a TBS deadline is "
                                     f"max(d_last, r) + wcet / utilization")

    def deadline_for(self, job: Job) -> int:
        self._reached(job)
        r = job.release
        self._ds = max(self._ds, r) + round(job.task.wcet_ticks / self.utilization)
        self._trace("deadline", None)
        return self._ds


class ServedEDF(EDF):
    """EDF with servers: a served job's key is its server's deadline, and jobs of a server
    that may not run now (a hard CBS out of budget) are passed over."""

    name = "edf"

    def __init__(self, servers: list[Server]):
        self.servers = servers

    def key(self, job) -> Any:
        """The server deadline (ticks) of a served job; else EDF's key."""
        srv = job.task.server
        if srv is not None:
            return srv.deadline_for(job)
        d = job.abs_deadline
        return math.inf if d is None else d

    def choose(self, ready, core):
        """The first ready job in EDF order whose server lets it run, if it beats the running job."""
        best = ready.first()
        if best is not None and best.task.server is not None and not best.task.server.eligible(best):
            best = next((j for j in ready if j.task.server is None or j.task.server.eligible(j)), None)
        r = core.running
        if best is None or (r is not None and not (best.cls, best.key) < (r.cls, r.key)):
            return None
        return best


def servers_table(trace: Trace) -> Recorder:
    """The ``servers`` table of *trace* (created on first call); see the module docstring."""
    return trace.table("servers", SERVERS_RAW, categorical=("node", "server", "event"),
                       transform=_servers_frame, identity=("server",))


def _servers_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Stored server rows (:data:`SERVERS_RAW`) as reported: times in s, node and server names."""
    import pandas as pd
    codes, unique = _per_task(df["server"])
    return pd.DataFrame({
        "time": pd.to_numeric(df["time"]).astype(float) / TICKS_PER_SECOND,
        "node": categorical_from_codes(codes, [s.node.name for s in unique]),
        "server": categorical_from_codes(codes, [s.name for s in unique]),
        "event": df["event"].astype("category"),
        "budget": pd.to_numeric(df["budget"], errors="coerce").astype(float) / TICKS_PER_SECOND,
        "deadline": pd.to_numeric(df["deadline"]).astype(float) / TICKS_PER_SECOND,
    })
