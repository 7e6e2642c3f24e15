"""The floor of a pure-Python kernel: what the least code producing netcosim's rows costs.

:func:`floor_run` is an idealised fixed-priority kernel for the periodic task sets of
:mod:`benchmarks.kernel`: one preemptive CPU, each task's body a generator that yields
one execution request, and nothing else -- no SimPy (a plain heap of ``(time, priority,
id, event)`` tuples and a loop), no deadlines, budgets, servers, context switches,
blocking, inheritance, clocks or error checks.  It keeps what every kernel must do per
job -- a job object, the body's generator, a ready heap, the segment timer -- and the
rows netcosim's default traces keep (``schedule``: a ``ready``, a ``running`` and an
``idle`` row per job, more with preemptions; ``jobs``: one row), in the same columnar
store, encoded every 256 events as the simulation does.  :func:`check` shows that its
rows are netcosim's, value for value, so the two do the same work.

What it measures is a lower bound for netcosim's kernel, not a design: the cost per job
of the idealised kernel against bare SimPy (two timeouts per job, as in
:mod:`benchmarks.kernel`), with the rows kept and without, at 10 tasks and with 3000
distinct periods.  Run: ``python -m benchmarks.kernel_floor``.
"""

from __future__ import annotations

import gc
import math
import time
from heapq import heappop, heappush
from itertools import count

from netcosim import Simulation
from netcosim.columns import ColumnStore
from netcosim.kernel.tables import STATE_CODES
from netcosim.timebase import to_ticks

from .kernel import TASKS, bare_run, distinct_tasks

_READY, _RUNNING, _IDLE = STATE_CODES["ready"], STATE_CODES["running"], STATE_CODES["idle"]
_EVERY = 256        # events between two encodings, as netcosim.clock.MAINTAIN_EVERY


class _Task:
    __slots__ = ("name", "body", "period", "prio", "jobs", "state")


class _Job:
    __slots__ = ("task", "index", "release", "gen", "start", "exec_done", "seg_start", "seg", "remaining")

    def __init__(self, task, index, release):
        self.task = task
        self.index = index
        self.release = release
        self.start = None
        self.exec_done = 0
        self.seg = None


class _Ctx:
    __slots__ = ()

    @staticmethod
    def execute(ticks):
        return ticks


def floor_run(until: float, tasks=TASKS, keep: bool = True) -> tuple[int, float, list, list]:
    """Run the idealised kernel on *tasks* ((C, T) in ms, rate-monotonic priorities in list
    order) for *until* seconds: ``(jobs finished, CPU seconds, schedule rows, jobs rows)``;
    *keep*: keep the rows (columnar, as netcosim's ``keep`` mode), else none."""
    queue: list = []
    ids = count().__next__
    sched = ColumnStore(3, categorical=(1,), dtypes=("int", None, "uint8"))
    jobrows = ColumnStore(9, categorical=(0,), dtypes=(None,) + ("int",) * 5 + ("bool",) * 3)
    srow, jrow = sched.append, jobrows.append
    ready: list = []
    ctx = _Ctx()
    made = []
    for i, (C, T) in enumerate(tasks, start=1):
        task = _Task()
        task.name, task.period, task.prio, task.jobs, task.state = f"t{i}", to_ticks(T * 1e-3), i, 0, _IDLE

        def body(ctx, c=to_ticks(C * 1e-3)):
            yield ctx.execute(c)
        task.body = body
        made.append(task)
        heappush(queue, (0, 1, ids(), task))
    stop = to_ticks(until)
    heappush(queue, (stop, 0, ids(), None))
    running = None
    seq = 0
    finished = 0
    countdown = _EVERY
    gc.collect()    # the previous runs' dead objects, not this run's cost
    t0 = time.process_time()
    while True:
        now, _, _, ev = heappop(queue)
        if ev is None:
            break
        countdown -= 1
        if not countdown:
            countdown = _EVERY
            if keep:
                sched.maintain()
                jobrows.maintain()
        if type(ev) is _Task:                           # a release
            task = ev
            heappush(queue, (now + task.period, 1, ids(), task))
            job = _Job(task, task.jobs, now)
            task.jobs += 1
            job.gen = task.body(ctx)
            seq += 1
            heappush(ready, (task.prio, seq, job))
            if keep:
                task.state = _READY
                srow((now, task, _READY))
        else:                                           # a segment end: (job, token)
            job, token = ev
            if job.seg is not token:
                continue                                # preempted: a cancelled timer
            job.exec_done += now - job.seg_start
            job.seg = None
            if next(job.gen, None) is not None:
                raise RuntimeError("the idealised kernel runs one execute per job")
            task = job.task
            finished += 1
            if keep:
                jrow((task, job.index, job.release, job.start, now, job.exec_done, False, False, False))
                task.state = _IDLE
                srow((now, task, _IDLE))
            running = None
        if queue[0][0] == now:
            continue                                    # dispatch after every event of the instant
        if ready and (running is None or ready[0][0] < running.task.prio):
            if running is not None:                     # preempt
                elapsed = now - running.seg_start
                running.exec_done += elapsed
                running.remaining -= elapsed
                running.seg = None
                seq += 1
                heappush(ready, (running.task.prio, -seq, running))   # first among its priority
                if keep:
                    running.task.state = _READY
                    srow((now, running.task, _READY))
            job = heappop(ready)[2]
            running = job
            if keep:
                job.task.state = _RUNNING
                srow((now, job.task, _RUNNING))
            if job.start is None:
                job.start = now
                job.remaining = cmd = next(job.gen)
            else:
                cmd = job.remaining
            job.seg_start = now
            job.seg = token = object()
            heappush(queue, (now + cmd, 1, ids(), (job, token)))
    dt = time.process_time() - t0
    return finished, dt, list(sched), list(jobrows)


def check(until: float = 1.2) -> bool:
    """True if the idealised kernel's schedule and jobs rows for TASKS over *until* seconds
    are netcosim's (tasks compared by name), as stored."""
    sim = Simulation(seed=0)
    cpu = sim.node("cpu")
    for i, (C, T) in enumerate(TASKS, start=1):
        def body(ctx, c=C * 1e-3):
            yield ctx.execute(c)
        cpu.periodic(body, period=T * 1e-3, priority=i, name=f"t{i}")
    sim.run(until=until)
    ours_s = [(t, task.name, s) for t, task, s in sim.trace.recorder("schedule").rows]
    ours_j = [(task.name,) + tuple(r) for task, *r in sim.trace.recorder("jobs").rows]
    _, _, sched, jobs = floor_run(until)
    return ours_s == [(t, task.name, s) for t, task, s in sched] and \
        ours_j == [(task.name,) + tuple(r) for task, *r in jobs]


def overhead(until: float = 20.0, repeats: int = 5) -> dict:
    """Cost per job of the idealised kernel (rows kept, and none) against bare SimPy at 10
    tasks, runs interleaved, best of *repeats* each."""
    n_per_task = [int(round(until / (T * 1e-3))) for _, T in TASKS]
    best = {"kept": math.inf, "none": math.inf, "bare": math.inf}
    for _ in range(repeats):
        for mode in ("kept", "none"):
            jobs, dt, _, _ = floor_run(until, keep=mode == "kept")
            best[mode] = min(best[mode], dt / jobs)
        best["bare"] = min(best["bare"], bare_run(n_per_task) / sum(n_per_task))
    print(f"idealised kernel, 10-task set, {until} s simulated, best of {repeats} interleaved runs")
    for mode in ("kept", "none"):
        print(f"  rows {mode:4s}: {best[mode] * 1e6:.2f} us/job = {best[mode] / best['bare']:.2f}x bare SimPy "
              f"({best['bare'] * 1e6:.2f} us/job)")
    return {k: v * 1e6 for k, v in best.items()}


def scaling_distinct(sizes=(10, 300, 1000, 3000), jobs: int = 60_000, repeats: int = 3) -> dict:
    """:func:`benchmarks.kernel.scaling_distinct` for the idealised kernel (rows kept)."""
    best = {n: math.inf for n in sizes}
    for _ in range(repeats):
        for n in sizes:
            tasks = distinct_tasks(n)
            done, dt, _, _ = floor_run(jobs / sum(1e3 / T for _, T in tasks), tasks)
            best[n] = min(best[n], dt / done)
    print(f"idealised kernel, all periods distinct (rows kept, best of {repeats})")
    for n in sizes:
        ratio = best[n] / best[sizes[0]]
        print(f"  {n:5d} tasks: {best[n] * 1e6:6.2f} us/job  ({ratio:.2f}x the {sizes[0]}-task cost)")
    return {n: best[n] * 1e6 for n in sizes}


def main() -> dict:
    """The check, then the floor at 10 tasks and its growth with distinct periods."""
    same = check()
    print(f"idealised kernel's rows equal netcosim's (10 tasks, 1.2 s): {same}")
    return {"same_rows": same, "overhead": overhead(), "scaling_distinct": scaling_distinct()}


if __name__ == "__main__":
    main()
