"""A node's speed changes, CPU power meter and power-off (the kernel's side of ``netcosim.energy``).

**Speed changes (DVS).**  Work is measured in ticks at speed 1: a segment of ``w`` work
ticks lasts ``w / speed`` ticks of simulated time.  When the speed changes from ``s0`` to
``s1`` at ``now``, every job with CPU work left in its current segment -- the running one
(its segment timer is moved) and the preempted ones -- has its remaining time ``r`` (ticks
at ``s0``) replaced by ``round(W / s1)`` with ``W = r * s0 + carry`` the exact remaining
work (rational arithmetic, :class:`fractions.Fraction` of the float speeds); the rounding
error ``carry = W - round(W / s1) * s1`` stays with the job's segment and enters the next
change, so no work is lost or invented however often the speed changes: the segment's end
is rounded to the nearest tick once, as ``execute`` rounds it at a fixed speed (±½ tick).
A context switch under way is rescaled the same way.  Execution times (``exec_done``, the
jobs table's ``execution`` column) are CPU time in simulated seconds: at half speed they
double.  Budgets (``wcet``) count the same simulated CPU time.  A multicore node has one
speed: a change rescales each of its jobs once and the switch (and migration) under way on
each core, with this same code.

**CPU meter.**  The CPU is *busy* while a job's segment or a context switch runs (a task
is ``running`` in the schedule table, or a switch is under way) and idle otherwise; the
meter watches the node's schedule rows and its context switches and sets the power of the
model (``model.power(busy, speed)``) at every change, including speed changes.  A
multicore node's meter (:class:`CoresMeter`) sums the power over its cores.

**Power-off.**  When the node's battery runs empty, every job is killed (a row with
``killed``, finish = that instant), the periodic releases stop, later releases of any kind
(timers, triggers, messages, ``task.release()``) are dropped and counted in
``node.releases_lost``, and the node's radio stations go deaf and mute
(:meth:`~netcosim.network.wireless.RadioNetwork._power_off`).  On a multicore node every
core stops: the switches under way are cancelled and the jobs on every core killed.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from ..clock import Timer
from ..energy import PowerMeter
from .tables import STATE_CODES

if TYPE_CHECKING:
    from .task import Job

_RUNNING = STATE_CODES["running"]


class NodePower:
    """A node's speed and energy state, one attribute of the node (``node._pw``).

    Kept in one object so that the node's own attributes stay under CPython's limit of 30
    for key-sharing instance dictionaries: beyond it every attribute read on the per-job
    path gets slower (measured: 7 % per job with these fields on the node itself).
    ``speed``; ``cs_work`` (context-switch work, ticks at speed 1); ``cs_timer``, ``cs_end``
    (the switch under way and its end tick); ``carry`` (rounding carry of rescaled
    segments); ``meters``, ``battery``, ``cpu_meter``; ``powered``, ``releases_lost``.
    """

    __slots__ = ("speed", "cs_work", "cs_timer", "cs_end", "carry", "meters", "battery", "cpu_meter", "powered",
                 "releases_lost")

    def __init__(self, speed: float, cs_work: int):
        self.speed = speed
        self.cs_work = cs_work
        self.cs_timer: Timer | None = None
        self.cs_end = 0
        self.carry: dict = {}
        self.meters: list = []
        self.battery: Any = None
        self.cpu_meter: Any = None
        self.powered = True
        self.releases_lost = 0


class CpuMeter(PowerMeter):
    """The power meter of a node's CPU (source ``"cpu"``); ``model.power(busy, speed)`` W."""

    __slots__ = ("model", "busy_task", "sink")

    def __init__(self, node: Any, model: Any):
        self.model = model
        r = node.running
        self.busy_task = r.task if r is not None and r.seg_timer is not None else None
        self.sink = node._sched
        super().__init__(node, "cpu", model.power(self.busy_task is not None or node._in_cs, node._pw.speed))
        node._sched = self       # the node appends its schedule rows here: see append

    def _power_now(self) -> float:
        node = self.owner
        return self.model.power(self.busy_task is not None or node._in_cs, node._pw.speed)

    def append(self, row: tuple) -> None:
        """A schedule row of the node: pass it on, then update the power if the CPU's state changed."""
        self.sink.append(row)
        _, task, code = row
        if code == _RUNNING:
            self.busy_task = task
        elif task is self.busy_task:
            self.busy_task = None
        self.update()

    def update(self, _event: Any = None) -> None:
        """Set the power for the CPU's state now (busy or idle, speed); also a timer callback
        (*_event*, the fired event, is ignored)."""
        p = self._power_now()
        if p != self.power:
            self.set(p)


class CoresMeter(PowerMeter):
    """The power meter of a multicore node's CPU (source ``"cpu"``): the sum over its cores.

    Core *k* is busy while a job's segment runs on it (its job's task is ``running``) or
    while it switches a context in (migration included).  A model with ``per_core`` true
    (:class:`~netcosim.energy.DvsPower`, and any model without the attribute) is one
    core's: the node draws ``sum_k model.power(busy_k, speed)`` W, static power once per
    core; a model with ``per_core`` false (:class:`~netcosim.energy.ConstantPower`,
    TrueTime's kernel power) is the whole kernel's: ``model.power(any core busy, speed)``.
    Every schedule row of the node and of its cores, and every context switch's start and
    end, sets the power anew (the rows pass through :meth:`append`)."""

    __slots__ = ("model", "sink", "cores")

    def __init__(self, node: Any, model: Any):
        self.model = model
        self.cores = tuple(node.cores)
        self.sink = node._sched
        super().__init__(node, "cpu", self._power_of(node))
        node._sched = self
        for core in self.cores:
            core._sched._append = self.append   # the core's rows (kernel.multicore._CoreRows)
            core._pw.cpu_meter = self           # its context switches (Interpreter._start_cs)

    def _power_of(self, node: Any) -> float:
        model = self.model
        speed = node._pw.speed
        busy = [c._in_cs or (c.running is not None and c.running.task.state == "running") for c in self.cores]
        if getattr(model, "per_core", True):
            return math.fsum(model.power(b, speed) for b in busy)
        return model.power(any(busy), speed)

    def append(self, row: tuple) -> None:
        """A schedule row of the node or of a core: pass it on, then update the power."""
        self.sink.append(row)
        self.update()

    def update(self, _event: Any = None) -> None:
        """Set the power for the cores' state now; also a timer callback (*_event*, the fired
        event, is ignored)."""
        p = self._power_of(self.owner)
        if p != self.power:
            self.set(p)


def _rescale(carry: dict, job: Any, s0: float, s1: float) -> int:
    """The remaining ticks of *job*'s segment (``job.remaining``, at speed *s0*) at speed *s1*.

    *carry* maps a job to ``(exec_done + remaining, rounding error in work ticks)``: the
    sum is constant within a segment (preemption moves ticks from one to the other) and
    grows with every new segment, so a stale carry is never applied."""
    ticks = job.remaining
    key = job.exec_done + ticks
    prev = carry.get(job)
    c = prev[1] if prev is not None and prev[0] == key else Fraction(0)
    work = ticks * Fraction(s0) + c
    f1 = Fraction(s1)
    new = round(work / f1)
    carry[job] = (job.exec_done + new, work - new * f1)    # the key once job.remaining = new
    return new


def _cpus(node: Any) -> tuple:
    """The kernels that run *node*'s jobs: its cores (a multicore node), else the node itself."""
    return tuple(node.cores) if node.multicore else (node,)


def change_speed(node: Any, s0: float, s1: float) -> None:
    """Rescale the remaining work of *node*'s jobs and context switches from *s0* to *s1* (now).

    On a multicore node every core changes: each job once (the running ones on the core
    that runs them), each core's switch under way, each core's switch length."""
    env = node._env
    now = env.now
    pw = node._pw
    carry: dict = pw.carry
    cpus = _cpus(node)
    on = {c.running: c for c in cpus if c.running is not None}     # the kernel of each running job
    live = set()
    for task in node.tasks.values():
        job: Job | None = task.active
        if job is None or job.remaining <= 0:
            continue
        live.add(job)
        if job.seg_timer is not None:       # running: close the part done, move the timer
            job.seg_timer.cancel()
            elapsed = now - job.seg_start
            job.exec_done += elapsed
            job.remaining -= elapsed
            new = _rescale(carry, job, s0, s1)
            job.remaining = new
            job.seg_start = now
            job.seg_timer = Timer(env, new, on[job]._segment_cb, job)
        else:
            job.remaining = _rescale(carry, job, s0, s1)
    for job in [j for j in carry if j not in live]:
        del carry[job]
    for cpu in cpus:
        cpw = cpu._pw
        if cpu is not node:
            cpu._cs_ticks = node._cs_ticks
            cpw.speed = s1
        t = cpw.cs_timer
        if cpu._in_cs and t is not None:
            left = cpw.cs_end - now
            new = round(left * Fraction(s0) / Fraction(s1))
            cbs = t.callbacks
            t.callbacks = []
            cpw.cs_timer = nt = Timer(env, new, cpu._cs_done, t.arg)
            nt.callbacks = cbs
            cpw.cs_end = now + new


def power_off(node: Any) -> None:
    """Stop *node* for good (its battery is empty): see the module docstring."""
    pw = node._pw
    pw.powered = False
    node._release = node._release_lost
    for task in list(node.tasks.values()):
        node._releases.stop(task)
    cpus = _cpus(node)
    for cpu in cpus:
        t = cpu._pw.cs_timer
        if cpu._in_cs and t is not None:
            t.cancel()
            cpu._in_cs = False
            cpu._pw.cs_timer = None
    sim = node.sim
    sim._stepping += 1      # a kill must not dispatch (and run the code of) another job meanwhile
    try:
        for task in list(node.tasks.values()):
            for job in list(task.pending):
                node._kill(job)
            if task.active is not None:
                node._kill(task.active)
    finally:
        sim._stepping -= 1
    for cpu in cpus:
        cpu.running = None
    for iface in node.interfaces.values():
        off = getattr(iface.network, "_power_off", None)
        if off is not None:
            off(iface)
