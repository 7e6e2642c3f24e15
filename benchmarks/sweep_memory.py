"""Serial sweeps: resident memory over 200 runs of the networked servo in one process.

Scenario: ``netcosim.experiments.networked_servo.build(share=0.3, seed=k)`` (the DC servo closed
over CSMA/CD with 30 % interfering traffic), run for ``HORIZON`` simulated seconds, its
frame table read, then every reference to the simulation dropped -- what a sweep over
seeds does.  After each run the resident set size (``/proc/self/statm``) is recorded.

A finished simulation is a web of reference cycles (the simulation and its nodes,
networks, plants, tasks and timers refer to each other), so reference counting does not
free it: its traces stay in memory until the cyclic garbage collector runs a full
collection.  Python triggers one only when the objects promoted to the old generation
reach a quarter of it, and counts only container objects: trace rows (tuples of numbers
and strings, untracked by the collector) weigh in memory but not in that count, so many
dead simulations pile up first.  Three ways to run the same sweep, each in a fresh
Python process:

``plain``    nothing after a run (memory grows by the dead simulations until Python's
             own full collection);
``collect``  ``gc.collect()`` after each run, what a sweep runner does;
``every10``  ``gc.collect()`` after every 10th run (a tenth of the collection cost, the
             memory of up to 10 dead simulations).

Reported per mode: the slope of a least-squares line through RSS against run index
(MB per run, over runs 10..N), the range max - min of RSS over the same runs, the wall
time per run (collections included) and the median time of one ``gc.collect()``.  The
goal: memory flat within 20 MB over 200 runs.  No test depends on these numbers.

On the development machine (2 cores, 0.5 s per run): ``plain`` grows by 0.33 MB per run
(55 MB over the 190 runs, no full collection came); ``collect`` is flat (slope
-0.002 MB/run, range 1.0 MB) for 50 ms per collection (0.16 s per run instead of 0.11);
``every10`` is flat too (1.0 MB) at 0.10 s per run.
Run: ``python -m benchmarks.sweep_memory`` (``--runs N``, ``--horizon S``).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

RUNS = 200
HORIZON = 0.5           # simulated seconds per run
SKIP = 10               # first runs left out of the fit (imports, caches warming up)
MODES = {"plain": 0, "collect": 1, "every10": 10}   # mode: collect after every n-th run (0: never)


def rss_mb() -> float:
    """Resident set size of this process in MB (10^6 bytes)."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * resource.getpagesize() / 1e6


def sweep(mode: str, runs: int, horizon: float) -> dict:
    """Run the sweep in this process; returns RSS after each run and the timings."""
    import gc

    from netcosim.experiments.networked_servo import build

    rss, collect_s = [], []
    t0 = time.perf_counter()
    for k in range(runs):
        sim, net = build(share=0.3, seed=k)
        sim.run(horizon)
        frames = net.frames()
        assert len(frames) > 0
        del sim, net, frames
        every = MODES[mode]
        if every and (k + 1) % every == 0:
            t = time.perf_counter()
            gc.collect()
            collect_s.append(time.perf_counter() - t)
        rss.append(rss_mb())
    wall = time.perf_counter() - t0
    return {"rss_mb": rss, "s_per_run": wall / runs,
            "collect_s": sorted(collect_s)[len(collect_s) // 2] if collect_s else None}


def slope(ys: list[float]) -> float:
    """Least-squares slope of *ys* against their index."""
    n = len(ys)
    mx, my = (n - 1) / 2, sum(ys) / n
    return sum((i - mx) * (y - my) for i, y in enumerate(ys)) / sum((i - mx) ** 2 for i in range(n))


def main(runs: int = RUNS, horizon: float = HORIZON) -> dict:
    """Each mode in a fresh process; print slope and range of RSS over the runs."""
    res = {}
    for mode in MODES:
        out = subprocess.run([sys.executable, "-m", "benchmarks.sweep_memory", "--child", mode,
                              "--runs", str(runs), "--horizon", str(horizon)],
                             check=True, capture_output=True, text=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        ys = r["rss_mb"][SKIP:]
        r["slope_mb_per_run"] = slope(ys)
        r["range_mb"] = max(ys) - min(ys)
        res[mode] = r
    print(f"serial sweep: {runs} runs of the networked servo (CSMA/CD, 30 % interferer), {horizon} s "
          f"simulated each, one process per mode; RSS over runs {SKIP}..{runs}")
    for mode in MODES:
        r = res[mode]
        extra = f", gc.collect() {r['collect_s'] * 1e3:.0f} ms (median)" if r["collect_s"] is not None else ""
        print(f"  {mode:8s}: slope {r['slope_mb_per_run']:+.3f} MB/run, range {r['range_mb']:.1f} MB "
              f"({min(r['rss_mb'][SKIP:]):.0f}..{max(r['rss_mb'][SKIP:]):.0f} MB), "
              f"{r['s_per_run']:.2f} s/run{extra}")
    return res


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=RUNS)
    ap.add_argument("--horizon", type=float, default=HORIZON)
    ap.add_argument("--child", choices=list(MODES), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        print(json.dumps(sweep(a.child, a.runs, a.horizon)))
    else:
        main(a.runs, a.horizon)
