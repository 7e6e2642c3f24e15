"""Multicore nodes: several CPUs ("cores") under one kernel, partitioned or global.

A node created with ``cores=N`` (``Simulation.node``) is a :class:`MulticoreNode`.  A
one-core node keeps the plain :class:`~netcosim.kernel.node.Node` and its inlined
single-CPU path; this module is used only by multicore nodes.

Each core is a :class:`Core`: the per-CPU state a one-core node holds itself
(``running``, ``_loaded``, ``_in_cs``, ``_np_job``) plus its own dispatch event, and it
*is* a kernel (a :class:`~netcosim.kernel.dispatcher.Dispatcher`): it runs job bodies,
switches contexts and dispatches with exactly the code of a one-core node.

* ``scheduling="partitioned"`` (TrueTime's multicore kernel): every task and handler is
  pinned to one core (``core=k``, default 0, TrueTime's default affinity) and each core
  is an independent uniprocessor with the node's policy and its own ready queue: the
  schedule of a core is that of a one-core node running the core's tasks alone.
* ``scheduling="global"`` (not in TrueTime; SimSo's G-EDF / G-FP): one ready queue, the
  jobs with the M best (class, key) run on the M cores.  The rules, all at the end of
  an instant like a one-core node's dispatch:

  - a ready job takes an idle core: the core it last ran on if that is idle, else the
    lowest-numbered idle core;
  - with no idle core, it preempts the running job with the worst (class, key, seq) --
    among equal keys the latest activated -- if it is strictly better than that job
    (equal keys never preempt; FIFO among equal keys, as on one core); a core in a
    context switch and a non-preemptible task (except by a handler) are not preempted;
  - a preempted job returns to the ready queue and may resume on another core: a
    *migration*, which costs ``migration`` s (at speed 1) of non-preemptible kernel time
    on the new core on top of the context switch (the job is traced ``ready``
    meanwhile), counted per job (jobs table ``migrations``) and per task
    (``task.migrations``).

The trace: a ``running`` row of a multicore node's schedule table says the core, and the
jobs table says the core a job finished on (:mod:`~netcosim.kernel.tables`).
"""

from __future__ import annotations

from typing import Any

from .. import validate
from ..clock import Rearmable
from ..errors import ConfigurationError
from ..timebase import MAX_TICKS, RESOLUTION, to_ticks
from .dispatcher import Dispatcher
from .node import Node
from .power import NodePower
from .ready import ReadyQueue
from .tables import RUNNING_ON_CORE, STATE_CODES
from .task import Job, Task

__all__ = ["MAX_CORES", "SCHEDULING", "Core", "MulticoreNode"]

#: the most cores a node may have (TrueTime's limit, 64)
MAX_CORES = 64
#: the multicore scheduling schemes
SCHEDULING = ("partitioned", "global")

_RUNNING = STATE_CODES["running"]


class _CoreRows:
    """A core's view of the schedule table: its ``running`` rows carry the core
    (code ``RUNNING_ON_CORE + index``); the other rows go through unchanged."""

    __slots__ = ("_append", "_code")

    def __init__(self, sink: Any, index: int):
        self._append = sink.append
        self._code = RUNNING_ON_CORE + index

    def append(self, row: tuple) -> None:
        if row[2] == _RUNNING:
            row = (row[0], row[1], self._code)
        self._append(row)


class Core(Dispatcher):
    """One CPU of a :class:`MulticoreNode`: its running job, loaded context, context
    switch and dispatch (``index`` 0..N-1).  Jobs of its tasks run here with the code of
    a one-core node."""

    def __init__(self, node: MulticoreNode, index: int):
        self.node = node
        #: the core's number on its node, from 0
        self.index = index
        self.sim = node.sim
        self.name = node.name
        self.policy = node.policy
        self._choose = node._choose
        self.tasks = node.tasks
        self._env = node._env
        self._cs_ticks = node._cs_ticks
        # this core's context switch and speed (kernel.power; the node's meter, if any, is its cpu_meter)
        self._pw = NodePower(node._pw.speed, node._pw.cs_work)
        self._releases = node._releases
        self._sched = _CoreRows(node._sched, index)  # type: ignore[assignment]
        self._jobrec = node._jobrec
        self.ready = ReadyQueue()
        self._seq = 0
        self.running: Job | None = None
        self._loaded: Job | None = None
        self._in_cs = False
        self._np_job: Job | None = None
        self._dispatch_pending = False
        self._dispatch_event = Rearmable(node.sim.env)
        if self._choose is not None:
            self._dispatch = self._dispatch_chosen  # type: ignore[method-assign]
        self._dispatch_callbacks = [self._dispatch]
        self._segment_cb = self._segment_done
        self._segment_cbs = [self._segment_cb]
        self._spare_timer = None

    def _trace(self, task: Task, state: str) -> None:
        if task.state != state:
            task.state = state
            self._sched.append((self._env.now, task, STATE_CODES[state]))

    def __repr__(self):
        return f"<Core {self.name}[{self.index}]>"


class GlobalCore(Core):
    """A core of a globally scheduled node: it shares the node's ready queue and
    activation order, and every dispatch it asks for is the node's global one."""

    def __init__(self, node: MulticoreNode, index: int):
        super().__init__(node, index)
        self.ready = node.ready
        self._activate = node._activate  # type: ignore[method-assign]  # one activation order
        self._dispatch = self._dispatch_global  # type: ignore[method-assign]
        self._dispatch_callbacks = [self._dispatch_global]

    def _dispatch_global(self, _event=None) -> None:
        self._dispatch_pending = False
        self.node._schedule_global()

    def _place(self, job: Job) -> None:
        """Give this (idle) core to *job*: a context switch unless its context is loaded
        here, plus the migration cost if it last ran on another core."""
        node: Any = self.node
        last = node._last_core.get(job)
        node._last_core[job] = self
        overhead = self._cs_ticks if self._loaded is not job else 0
        if last is not None and last is not self:
            node._migrations[job] = node._migrations.get(job, 0) + 1
            node.migrations[job.task.name] += 1
            overhead = self._cs_ticks + node._mig_ticks
            if last._loaded is job:
                last._loaded = None
        self.running = job
        if overhead:
            self._start_cs(job, overhead)
            return
        self._run(job)

    def _finish(self, job: Job, killed: bool = False) -> None:
        self.node._note_finish(job, self.index)
        super()._finish(job, killed)


class MulticoreNode(Node):
    """A node with several cores (see the module docstring).  Create with
    ``Simulation.node(name, cores=N, scheduling=..., migration=...)``."""

    multicore = True

    def __init__(self, sim, name: str, scheduler: Any = "fixed_priority", *, cores: int = 2,
                 scheduling: str = "partitioned", migration: float = 0.0, context_switch: float = 0.0,
                 speed: float = 1.0, **clock: Any):
        super().__init__(sim, name, scheduler, context_switch=context_switch, speed=speed, **clock)
        validate.choice(scheduling, f"node {name!r}: scheduling", SCHEDULING)
        #: "partitioned" or "global"
        self.scheduling = scheduling
        if self._choose is not None:
            raise ConfigurationError(f"node {name!r}: policy {self.policy!r} picks jobs itself (choose); "
                                     f"multicore nodes schedule by the policy key only")
        mig = to_ticks(migration, f"node {name!r} migration")
        if scheduling == "partitioned" and mig:
            raise ConfigurationError(f"node {name!r}: migration={migration!r} s, but partitioned tasks never "
                                     f"migrate; use scheduling='global' or leave migration at 0")
        #: the migration cost (s, at speed 1)
        self.migration = migration
        self._mig_work = mig
        self._mig_ticks = self._migration_ticks(speed)
        cls = GlobalCore if scheduling == "global" else Core
        #: the node's cores, ``cores[k].index == k``
        self.cores: list[Any] = [cls(self, k) for k in range(cores)]
        #: migrations so far by task name (global scheduling; 0 when partitioned)
        self.migrations: dict[str, int] = {}
        self._pinned: dict[Task, Core] = {}     # partitioned: each task's core
        self._last_core: dict[Job, Any] = {}    # global: the core each unfinished job last ran on
        self._migrations: dict[Job, int] = {}   # global: migrations of each unfinished job
        self._job_cores: dict[tuple[Task, int], int] = {}       # global: the core each job finished on
        self._job_migrations: dict[tuple[Task, int], int] = {}  # global: migrations of each finished job

    def _migration_ticks(self, speed: float) -> int:
        """The migration's ticks at *speed* (checked like the context switch's)."""
        mig = self._mig_work
        if mig / speed > MAX_TICKS:
            raise ConfigurationError(f"node {self.name!r}: migration={self.migration!r} s at speed {speed!r} "
                                     f"lasts beyond netcosim's time range")
        ticks = int(round(mig / speed))
        if mig and not ticks:
            raise ConfigurationError(f"node {self.name!r}: migration={self.migration!r} s at speed {speed!r} is "
                                     f"below the time resolution {RESOLUTION} s")
        return ticks

    def set_speed(self, speed: float) -> None:
        """Change the speed of every core now (TrueTime: one speed per kernel); see
        :meth:`Node.set_speed <netcosim.kernel.node.Node.set_speed>`.  Running and
        preempted segments, switches and migrations under way are rescaled exactly as on
        one core; later migrations last ``migration / speed``."""
        self._scaled(speed)     # checks speed (and the context switch) before the migration uses it
        mig = self._migration_ticks(float(speed))
        super().set_speed(speed)
        self._mig_ticks = mig

    @property
    def n_cores(self) -> int:
        """The number of cores."""
        return len(self.cores)

    # ------------------------------------------------------------ placement
    def _add_task(self, body, kind, name, server=None, core=None, **kw) -> Task:
        if server is not None:
            raise ConfigurationError(f"node {self.name!r}: bandwidth servers run on one-core nodes only")
        if self.scheduling == "global":
            if core is not None:
                raise ConfigurationError(f"node {self.name!r} schedules globally: its jobs run on any core; "
                                         f"core={core!r} pins a task only with scheduling='partitioned'")
            where: Core | None = None
        else:
            k = 0 if core is None else validate.integer(
                core, f"node {self.name!r}: core", lo=0, hi=len(self.cores) - 1)
            where = self.cores[k]
        task = super()._add_task(body, kind, name, **kw)
        if where is not None:
            self._pinned[task] = where
        self.migrations[task.name] = 0
        return task

    def core_of(self, task: Task) -> int | None:
        """The core *task* is pinned to (partitioned), None under global scheduling."""
        core = self._pinned.get(task)
        return None if core is None else core.index

    def job_core(self, task: Task, index: int) -> int:
        """The core job *index* of *task* finished on: the pinned core (partitioned); under
        global scheduling the recorded one, -1 for a job not finished or ended off any core."""
        core = self._pinned.get(task)
        if core is not None:
            return core.index
        return self._job_cores.get((task, index), -1)

    def job_migrations(self, task: Task, index: int) -> int:
        """The migrations of finished job *index* of *task* (0 under partitioned scheduling)."""
        return self._job_migrations.get((task, index), 0)

    def _add_server(self, cls, name, **kw):
        raise ConfigurationError(f"node {self.name!r}: bandwidth servers run on one-core nodes only "
                                 f"(this node has {len(self.cores)} cores)")

    # ----------------------------------------- kernel calls, routed to the core
    def _release(self, task: Task, t: int) -> Job | None:
        core = self._pinned.get(task)
        if core is None:
            return Dispatcher._release(self, task, t)
        return core._release(task, t)

    def _unblock(self, job: Job, value=None) -> None:
        core = self._pinned.get(job.task)
        if core is None:
            Dispatcher._unblock(self, job, value)
        else:
            core._unblock(job, value)

    def _reprioritise(self, job: Job) -> None:
        core = self._pinned.get(job.task)
        if core is None:
            Dispatcher._reprioritise(self, job)
        else:
            core._reprioritise(job)

    def _kill(self, job: Job) -> None:
        core = self._pinned.get(job.task)
        if core is None:    # global: on the core that runs it, else off any core
            for c in self.cores:
                if c.running is job:
                    c._kill(job)
                    return
            Dispatcher._kill(self, job)
        else:
            core._kill(job)

    def _preempt(self, job: Job) -> None:
        core = self._pinned.get(job.task)
        if core is not None:
            core._preempt(job)
            return
        for c in self.cores:
            if c.running is job:
                c._preempt(job)
                return

    def _finish(self, job: Job, killed: bool = False) -> None:
        self._note_finish(job, -1)  # global: a job ended off any core (killed while ready or blocked)
        super()._finish(job, killed)

    def _note_finish(self, job: Job, core: int) -> None:
        self._job_cores[job.task, job.index] = core
        n = self._migrations.pop(job, 0)
        if n:
            self._job_migrations[job.task, job.index] = n
        self._last_core.pop(job, None)

    # ------------------------------------------------------- global dispatch
    def _dispatch(self, _event=None) -> None:
        self._dispatch_pending = False
        if self.scheduling == "global":
            self._schedule_global()
        else:
            for c in self.cores:
                c._request_dispatch()

    def _schedule_global(self) -> None:
        """Run the M best ready or running jobs (the rules are in the module docstring)."""
        ready = self.ready
        cores = self.cores
        while ready.live:
            best = ready.first()
            target: Any = self._last_core.get(best)
            if target is None or target.running is not None or target._in_cs:
                target = None
                for c in cores:
                    if c.running is None and not c._in_cs:  # a job killed in a switch leaves it busy
                        target = c
                        break
            if target is None:
                worst = None
                for c in cores:
                    r = c.running
                    if c._in_cs or r is None or not (r.task.preemptible or best.cls < r.cls):
                        continue
                    if worst is None or (r.cls, r.key, r.seq) > (worst.cls, worst.key, worst.seq):
                        worst, target = r, c
                if worst is None or not (best.cls, best.key) < (worst.cls, worst.key):
                    return
                target._preempt(worst)
                target._np_job = None   # it competes by its key like any ready job
            ready.discard(best)
            target._place(best)

    def __repr__(self):
        return f"<MulticoreNode {self.name} {self.policy.name} {len(self.cores)} cores {self.scheduling}>"
