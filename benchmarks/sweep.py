"""Sweeps: runs per second serially, on the process pool and on Dask, and each executor's overhead per run.

1. Throughput for runs of about 1 s: the networked servo
   (``netcosim.experiments.networked_servo``: DC servo over CSMA/CD with 30 % interfering
   traffic), its simulated horizon sized so that one run takes about ``RUN_S`` s here
   (measured before the sweeps), swept over seeds serially (``SERIAL_RUNS`` runs), on a
   pool of 2 workers and on a 2-worker Dask ``LocalCluster`` (``PARALLEL_RUNS`` runs
   each; start-up of the workers included).  Speed-up: runs/s of the parallel executor
   over runs/s serially.  Targets on 2 cores: >= 1.8x (pool), >= 1.7x (Dask).  Also
   reported: the utilisation, the sum of the runs' own wall times over (workers x the
   sweep's wall time), the share of the workers' time spent running: on a machine with
   other load, runs slow down and the speed-up with them, but the utilisation shows what
   the executor itself loses (start-up, dispatch, collection); on an idle machine the
   speed-up approaches workers x utilisation.
2. Overhead per run: a scenario that returns at once, swept with one worker; the cost
   per run is the difference between a long and a short sweep
   divided by the difference in runs (start-up cancels out; ``OVERHEAD_RUNS``), minus
   the cost of calling the scenario directly.  Targets: <= 5 ms (pool), <= 20 ms (Dask).

Run: ``python -m benchmarks.sweep``.  No test depends on these numbers.

Measured on the development machine (2 cores, otherwise idle: load average below 2)::

    runs of the networked servo, 5.39 simulated s each
      serial: 0.97 runs/s (mean run 1.03 s), speed-up 1.00x, utilisation 1.00
      pool  : 1.79 runs/s (mean run 1.04 s), speed-up 1.84x, utilisation 0.93
      dask  : 1.78 runs/s (mean run 1.06 s), speed-up 1.83x, utilisation 0.94
    overhead per run against a direct call (0.1 us), one worker:
      serial: 0.05 ms
      pool  : 0.12 ms
      dask  : 4.58 ms

Both parallel executors meet their speed-up targets (1.8x, 1.7x) and their overhead
targets (5 ms, 20 ms).  The utilisation (0.93, 0.94) is what they lose, mostly starting
the pool's two interpreters (the Dask cluster is started before the clock) and the last
run's tail over a 20-run sweep.  With Dask's default worker settings each run was about
10 % slower than on the pool (its profiler samples the worker's stack every 10 ms):
1.67x; :func:`netcosim.sweep.executors.local_cluster` switches that off.  On a machine
busy with other work (load average 5) the same command gave 1.43x and 0.88x, and Dask's
overhead per run grew to 8-21 ms: other processes took the second core.
"""

from __future__ import annotations

import time

RUN_S = 1.0             # target wall seconds per run
SERIAL_RUNS = 6
PARALLEL_RUNS = 20
#: (short, long) sweep sizes of the overhead measurement, per executor
OVERHEAD_RUNS = {"serial": (100, 5100), "pool": (100, 5100), "dask": (50, 1050)}


def servo_run(params: dict, seed: int) -> dict:
    """One networked-servo run of ``params["horizon"]`` simulated seconds (s); its frame count."""
    from netcosim.experiments.networked_servo import build

    sim, net = build(share=0.3, seed=seed)
    sim.run(params["horizon"])
    return {"frames": len(net.frames())}


def instant(params: dict, seed: int) -> dict:
    """A scenario that costs nothing: the executor's overhead alone."""
    return {"x": seed % 7}


def _sweep(scenario: str, n: int, executor, workers: int, **kw) -> float:
    from netcosim.sweep import run_sweep

    t0 = time.perf_counter()
    res = run_sweep(scenario, {"case": [0]}, n, executor=executor, workers=workers, quiet=True, **kw)
    wall = time.perf_counter() - t0
    assert res.summary["ok"] == n, res.summary
    return wall


def calibrate() -> float:
    """The simulated horizon (s) that makes one servo run take about RUN_S wall seconds."""
    servo_run({"horizon": 0.2}, 0)                     # warm-up: imports
    times = []
    for seed in (1, 2):
        t0 = time.perf_counter()
        servo_run({"horizon": 1.0}, seed)
        times.append(time.perf_counter() - t0)
    per_s = min(times)
    return round(RUN_S / per_s, 2)


def main() -> dict:
    """Measure and print both parts (see the module docstring)."""

    from distributed import Client

    from netcosim.sweep.executors import local_cluster

    horizon = calibrate()
    res: dict = {"horizon": horizon}
    grid = "benchmarks.sweep:servo_run"
    from netcosim.sweep import run_sweep

    def throughput(n, executor, workers):
        t0 = time.perf_counter()
        r = run_sweep(grid, {"horizon": [horizon]}, n, executor=executor,
                      workers=None if not isinstance(executor, str) else workers, quiet=True)
        wall = time.perf_counter() - t0
        assert r.summary["ok"] == n, r.summary
        return n / wall, float(r.runs["wall_time"].mean()), float(r.runs["wall_time"].sum()) / (workers * wall)

    res["serial"] = throughput(SERIAL_RUNS, "serial", 1)
    res["pool"] = throughput(PARALLEL_RUNS, "pool", 2)
    with local_cluster(2) as cluster, Client(cluster, set_as_default=False) as client:
        res["dask"] = throughput(PARALLEL_RUNS, client, 2)
    print(f"runs of the networked servo, {horizon} simulated s each")
    for name in ("serial", "pool", "dask"):
        rate, mean, use = res[name]
        print(f"  {name:6s}: {rate:.2f} runs/s (mean run {mean:.2f} s), speed-up {rate / res['serial'][0]:.2f}x, "
              f"utilisation {use:.2f}")

    # overhead per run
    n = 20000
    t0 = time.perf_counter()
    for k in range(n):
        instant({"case": 0}, k)
    direct = (time.perf_counter() - t0) / n
    res["direct_s"] = direct
    tiny = "benchmarks.sweep:instant"

    def per_run(executor, workers):
        short, long = OVERHEAD_RUNS[name]
        return (_sweep(tiny, long, executor, workers) - _sweep(tiny, short, executor, workers)) / (long - short)

    over = {}
    for name in ("serial", "pool"):
        over[name] = per_run(name, 1)
    with local_cluster(1) as cluster, Client(cluster, set_as_default=False) as client:
        _sweep(tiny, 10, client, None)               # warm-up: the worker imports the scenario
        name = "dask"
        over[name] = per_run(client, None)
    print(f"overhead per run against a direct call ({direct * 1e6:.1f} us), one worker:")
    for name, per in over.items():
        print(f"  {name:6s}: {(per - direct) * 1e3:.2f} ms")
        res[f"overhead_{name}_s"] = per - direct
    return res


if __name__ == "__main__":
    main()
