"""Kernel speed against SimSo 0.8.5: CPU time per simulated job for the 10-task set of
:mod:`benchmarks.kernel` on one processor under fixed priorities (rate-monotonic order).

SimSo (``simso.schedulers.FP``, its SimPy 2 apart from netcosim's SimPy 4) runs in a
subprocess with :data:`benchmarks.simso_global.SIMSO_PATH` on its path, which ``make``
installs; netcosim runs in this process (:func:`benchmarks.kernel.kernel_run`, traces kept).
Both simulate the same horizon; each side's time is the CPU time of its own run
(``time.process_time`` around the simulation, the set-up excluded) divided by the jobs it
finished.  SimSo's cost per job grows with the horizon (it keeps every job and its log):
the horizon is part of the comparison, 2.4 s by default (20 hyperperiods, 4500 jobs).
The runs alternate (``repeats`` pairs); the ratio reported is the median of the pairwise
ratios.  The idealised kernel of :mod:`benchmarks.kernel_floor` (netcosim's rows, none of
its features) runs beside them: the speed-up of a pure-Python kernel's floor.
Run: ``python -m benchmarks.simso_speed`` (skipped, saying why, without SimSo).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys

from .kernel import TASKS, kernel_run
from .kernel_floor import floor_run
from .simso_global import REPO, SIMSO_PATH

_SIMSO_RUN = r'''
import contextlib, io, json, sys, time
from simso.configuration import Configuration
from simso.core import Model
tasks, until_ms = json.loads(sys.argv[1])
cfg = Configuration()
cfg.duration = until_ms * cfg.cycles_per_ms
n = len(tasks)
for i, (c, t) in enumerate(tasks):     # SimSo's FP: the larger priority runs first
    cfg.add_task(name=f"t{i + 1}", identifier=i + 1, period=t, activation_date=0, wcet=c, deadline=t,
                 data={"priority": n - i})
cfg.add_processor(name="cpu", identifier=1)
cfg.scheduler_info.clas = "simso.schedulers.FP"
cfg.check_all()
model = Model(cfg)
t0 = time.process_time()
with contextlib.redirect_stdout(io.StringIO()):
    model.run_model()
dt = time.process_time() - t0
print(json.dumps([sum(1 for tk in model.task_list for j in tk.jobs if j.end_date is not None), dt]))
'''


def simso_run(until: float) -> tuple[int, float]:
    """SimSo's ``(finished jobs, CPU seconds)`` for TASKS over *until* seconds (a subprocess).
    FileNotFoundError if SimSo is not installed in :data:`SIMSO_PATH`."""
    if not (SIMSO_PATH / "simso").is_dir():
        raise FileNotFoundError(f"SimSo is not installed in {SIMSO_PATH} (make installs it)")
    arg = json.dumps([TASKS, until * 1e3])
    out = subprocess.run([sys.executable, "-c", _SIMSO_RUN, arg],
                         env={"PYTHONPATH": str(SIMSO_PATH), "PATH": "/usr/bin:/bin"}, cwd=REPO,
                         capture_output=True, text=True, timeout=600, check=True)
    jobs, dt = json.loads(out.stdout.splitlines()[-1])
    return int(jobs), float(dt)


def compare(until: float = 2.4, repeats: int = 5) -> dict:
    """CPU time per job of SimSo and of netcosim over *until* s, *repeats* alternated pairs."""
    simso_us, ours_us, floor_us, ratios, floor_ratios = [], [], [], [], []
    for _ in range(repeats):
        jobs_s, dt_s = simso_run(until)
        jobs_n, dt_n = kernel_run(until)
        jobs_f, dt_f, _, _ = floor_run(until)
        simso_us.append(dt_s / jobs_s * 1e6)
        ours_us.append(dt_n / jobs_n * 1e6)
        floor_us.append(dt_f / jobs_f * 1e6)
        ratios.append(simso_us[-1] / ours_us[-1])
        floor_ratios.append(simso_us[-1] / floor_us[-1])
    res = {"jobs": jobs_n, "simso_jobs": jobs_s, "simso_us_per_job": statistics.median(simso_us),
           "netcosim_us_per_job": statistics.median(ours_us), "speedup_median": statistics.median(ratios),
           "floor_us_per_job": statistics.median(floor_us), "floor_speedup_median": statistics.median(floor_ratios)}
    print(f"10-task set, one processor, fixed priorities, {until} s simulated, {repeats} alternated pairs (medians)")
    print(f"  SimSo 0.8.5: {res['simso_us_per_job']:8.2f} us/job ({jobs_s} jobs)")
    print(f"  netcosim:    {res['netcosim_us_per_job']:8.2f} us/job ({jobs_n} jobs)")
    print(f"  idealised:   {res['floor_us_per_job']:8.2f} us/job (benchmarks.kernel_floor: the same rows, no features)")
    print(f"  netcosim is {res['speedup_median']:.1f}x faster per job (median of pairwise ratios; target >= 40x); "
          f"the idealised kernel {res['floor_speedup_median']:.1f}x")
    return res


def main() -> dict | None:
    try:
        return compare()
    except FileNotFoundError as exc:
        print(f"skipped: {exc}")
        return None


if __name__ == "__main__":
    main()
