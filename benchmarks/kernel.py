"""Kernel throughput: simulated jobs per second for a 10-task set, against bare SimPy.

The baseline is ten bare SimPy processes that each yield two timeouts per job (the
execution and the rest of the period) -- the same number of scheduled timeouts as the
kernel needs per job (release and segment end), but with no scheduling, tracing or
statistics.  The ratio (kernel time per job / bare time per job) is the kernel's
overhead.  Run: ``python -m benchmarks.kernel``.
"""

from __future__ import annotations

import statistics
import time

import simpy

from netcosim import Simulation
from netcosim.timebase import to_ticks

# (C, T) in ms: utilisation 0.73, rate-monotonic schedulable, hyperperiod-friendly
TASKS = [(0.2, 2), (0.3, 3), (0.4, 4), (0.5, 5), (0.3, 6), (0.4, 8), (0.5, 10), (0.6, 12), (0.5, 15), (0.6, 20)]


def kernel_run(until: float, policy: str = "fixed_priority") -> tuple[int, float]:
    sim = Simulation(seed=0)
    cpu = sim.node("cpu", scheduler=policy)
    for i, (C, T) in enumerate(TASKS, start=1):
        c = C * 1e-3

        def body(ctx, c=c):
            yield ctx.execute(c)
        cpu.periodic(body, period=T * 1e-3, priority=i, name=f"t{i}")
    t0 = time.perf_counter()
    sim.run(until=until)
    dt = time.perf_counter() - t0
    return len(sim.trace.job_rec.rows), dt


def bare_run(n_jobs_per_task: list[int]) -> float:
    env = simpy.Environment()

    def proc(C, T, n):
        c, rest = to_ticks(C * 1e-3), to_ticks((T - C) * 1e-3)
        for _ in range(n):
            yield env.timeout(c)
            yield env.timeout(rest)
    for (C, T), n in zip(TASKS, n_jobs_per_task):
        env.process(proc(C, T, n))
    t0 = time.perf_counter()
    env.run()
    return time.perf_counter() - t0


def main(until: float = 20.0, repeats: int = 7) -> dict:
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
          f"{res['overhead_ratio_median_pairwise']:.2f}x median of pairwise ratios (target <= 3x)")
    return res


if __name__ == "__main__":
    main()
