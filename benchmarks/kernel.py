"""Kernel throughput: simulated jobs per second for a 10-task set, against bare SimPy,
and how the cost per job grows with the number of tasks.

The baseline is ten bare SimPy processes that each yield two timeouts per job (the
execution and the rest of the period) -- the same number of scheduled timeouts as the
kernel needs per job (release and segment end), but with no scheduling, tracing or
statistics.  The ratio (kernel time per job / bare time per job) is the kernel's
overhead.  :func:`scaling` runs the same set scaled to 10, 300, 1000 and 3000 tasks at
the same utilisation and reports the cost per job against the cost at 10 tasks (the
ready queue's growth); there the copies of a task share its period, so their releases
share one timer (release groups).  :func:`scaling_distinct` gives every task its own
period (no two alike: no release groups, one release instant per task), the case where
the release structure's own growth shows.  Times are CPU time of this process (``time.process_time``): on a
machine shared with other jobs the wall time includes waiting for a core, the CPU time
does not.  Run: ``python -m benchmarks.kernel``.
"""

from __future__ import annotations

import gc
import math
import statistics
import time

import simpy

from netcosim import Simulation
from netcosim.timebase import to_ticks

# (C, T) in ms: utilisation 0.66, rate-monotonic schedulable, hyperperiod-friendly
TASKS = [(0.2, 2), (0.3, 3), (0.4, 4), (0.5, 5), (0.3, 6), (0.4, 8), (0.5, 10), (0.6, 12), (0.5, 15), (0.6, 20)]


#: hyperperiod of TASKS (s): a scaled run covers whole hyperperiods
HYPERPERIOD = 0.12


def scaled_tasks(n: int) -> list[tuple[float, float]]:
    """*n* tasks (a multiple of 10): each of TASKS n/10 times with C scaled by 10/n (same utilisation),
    rate-monotonic order (shortest period first)."""
    if n % len(TASKS):
        raise ValueError(f"n must be a multiple of {len(TASKS)}, got {n!r}")
    k = n // len(TASKS)
    return [(C / k, T) for C, T in sorted(TASKS, key=lambda ct: ct[1]) for _ in range(k)]


def distinct_tasks(n: int) -> list[tuple[float, float]]:
    """*n* tasks (a multiple of 10) with *n* distinct periods: copy j = 0..k-1 (k = n/10) of
    each task (C, T) of TASKS has the period T(1 + j/(10k)) ms and C/k scaled by the same
    factor, so the utilisation is that of TASKS (0.66); the periods of one task's copies
    span [T, 1.1 T) and never meet another task's (TASKS' periods are at least 1.2x apart).
    ``distinct_tasks(10) == TASKS``."""
    if n % len(TASKS):
        raise ValueError(f"n must be a multiple of {len(TASKS)}, got {n!r}")
    k = n // len(TASKS)
    stretch = [1 + j / (10 * k) for j in range(k)]
    return [(C / k * s, T * s) for C, T in sorted(TASKS, key=lambda ct: ct[1]) for s in stretch]


def kernel_run(until: float, policy: str = "fixed_priority", tasks=TASKS) -> tuple[int, float]:
    sim = Simulation(seed=0)
    cpu = sim.node("cpu", scheduler=policy)
    for i, (C, T) in enumerate(tasks, start=1):
        c = C * 1e-3

        def body(ctx, c=c):
            yield ctx.execute(c)
        cpu.periodic(body, period=T * 1e-3, priority=i, name=f"t{i}")
    gc.collect()    # the previous runs' dead simulations, not this one's cost
    t0 = time.process_time()
    sim.run(until=until)
    dt = time.process_time() - t0
    return len(sim.trace.recorder("jobs").rows), dt


def bare_run(n_jobs_per_task: list[int]) -> float:
    env = simpy.Environment()

    def proc(C, T, n):
        c, rest = to_ticks(C * 1e-3), to_ticks((T - C) * 1e-3)
        for _ in range(n):
            yield env.timeout(c)
            yield env.timeout(rest)
    for (C, T), n in zip(TASKS, n_jobs_per_task):
        env.process(proc(C, T, n))
    gc.collect()
    t0 = time.process_time()
    env.run()
    return time.process_time() - t0


def overhead(until: float = 20.0, repeats: int = 7) -> dict:
    """Interleave kernel and baseline runs; compare the best (least disturbed) of each."""
    n_per_task = [int(round(until / (T * 1e-3))) for _, T in TASKS]
    n_b = sum(n_per_task)
    k_times, b_times, ratios = [], [], []
    for _ in range(repeats):
        jobs, dt_k = kernel_run(until)
        dt_b = bare_run(n_per_task)
        k_times.append(dt_k / jobs)
        b_times.append(dt_b / n_b)
        ratios.append(k_times[-1] / b_times[-1])
    res = {
        "jobs": jobs,
        "kernel_us_per_job": min(k_times) * 1e6,
        "bare_us_per_job": min(b_times) * 1e6,
        "overhead_ratio_best": min(k_times) / min(b_times),
        "overhead_ratio_median_pairwise": statistics.median(ratios),
    }
    print(f"10-task set, {until} s simulated, {jobs} jobs per run, {repeats} interleaved runs")
    print(f"  kernel:     {res['kernel_us_per_job']:.2f} us/job  ({1e6 / res['kernel_us_per_job']:,.0f} jobs/s, best)")
    print(f"  bare SimPy: {res['bare_us_per_job']:.2f} us/job  (2 timeouts per job, best)")
    print(f"  overhead ratio: {res['overhead_ratio_best']:.2f}x best-vs-best, "
          f"{res['overhead_ratio_median_pairwise']:.2f}x median of pairwise ratios (target <= 2x)")
    return res


def _growth(sizes, repeats: int, run_size, title: str, target: float) -> dict:
    """Best CPU seconds per job of ``run_size(n) -> (jobs, seconds)`` for each n of *sizes*
    (the sizes interleaved, best of *repeats*), printed against the first size's."""
    best: dict[int, float] = {n: math.inf for n in sizes}
    n_jobs: dict[int, int] = {}
    for _ in range(repeats):
        for n in sizes:
            n_jobs[n], dt = run_size(n)
            best[n] = min(best[n], dt / n_jobs[n])
    base = best[sizes[0]]
    print(f"per-job cost against the number of tasks, {title} (best of {repeats})")
    for n in sizes:
        print(f"  {n:5d} tasks: {best[n] * 1e6:6.2f} us/job  ({best[n] / base:.2f}x the {sizes[0]}-task cost, "
              f"{n_jobs[n]} jobs per run)")
    ratio = best[sizes[-1]] / base
    print(f"  cost({sizes[-1]}) / cost({sizes[0]}) = {ratio:.2f} (target <= {target})")
    return {"us_per_job": {n: best[n] * 1e6 for n in sizes}, "ratio": ratio}


def scaling(sizes=(10, 300, 1000, 3000), jobs: int = 60_000, repeats: int = 3) -> dict:
    """Cost per job (best of *repeats*, runs of the sizes interleaved) for each task count in
    *sizes*, each run covering whole hyperperiods and at least *jobs* jobs."""
    def run_size(n):
        rate = n / len(TASKS) * sum(1e3 / T for _, T in TASKS)  # jobs per simulated second
        return kernel_run(HYPERPERIOD * math.ceil(jobs / (rate * HYPERPERIOD)), tasks=scaled_tasks(n))
    return _growth(sizes, repeats, run_size, "utilisation 0.66", 1.5)


def scaling_distinct(sizes=(10, 300, 1000, 3000), jobs: int = 60_000, repeats: int = 3) -> dict:
    """:func:`scaling` for :func:`distinct_tasks`: every task its own period (runs of at
    least *jobs* jobs, not whole hyperperiods; the sizes interleaved, best of *repeats*)."""
    def run_size(n):
        tasks = distinct_tasks(n)
        return kernel_run(jobs / sum(1e3 / T for _, T in tasks), tasks=tasks)  # rate: jobs per simulated second
    return _growth(sizes, repeats, run_size, "all periods distinct", 1.2)


def main() -> dict:
    """The overhead against bare SimPy at 10 tasks, then the growth with the number of tasks
    (release groups, then distinct periods)."""
    return {"overhead": overhead(), "scaling": scaling(), "scaling_distinct": scaling_distinct()}


if __name__ == "__main__":
    main()
