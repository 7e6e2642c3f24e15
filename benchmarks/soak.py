"""Soak: one simulated hour of the lossy 802.11b servo with default trace settings.

The scenario is :func:`benchmarks.memory.build` (TrueTime's networked DC servo over
802.11b at 11 Mbit/s, 70 % Bernoulli frame loss on every link, every trace table at its
default).  In a fresh Python process: run ``HOURS`` simulated hours and take the peak
resident memory (``VmHWM``); reset the peak (``/proc/self/clear_refs``), read every table
back with ``sim.trace.frame(name)`` one at a time (each frame dropped before the next)
and take the peak again; then the same for ``sim.trace.to_parquet(tmpdir)``.

Issue 23's target: under 200 MB resident during the run, under 500 MB reading back.
No test depends on these numbers.  Run: ``python -m benchmarks.soak`` (``--hours 0.05``
for a short smoke run).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import subprocess
import sys
import tempfile
import time

from .memory import _vm  # one reader of /proc/self/status


def _reset_peak() -> bool:
    """Reset ``VmHWM`` to the current RSS (Linux >= 4.0); False when not allowed."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def child(hours: float, memory: int | None = None) -> dict:
    import netcosim.recorder
    from benchmarks.memory import build
    if memory is not None:
        netcosim.recorder.DEFAULT_MEMORY = memory
    sim = build("default")
    t0 = time.perf_counter()
    sim.run(hours * 3600.0)
    wall = time.perf_counter() - t0
    res: dict = {"hours": hours, "wall": wall, "peak_run": _vm("VmHWM"), "rss_end": _vm("VmRSS"),
                 "rows": {n: len(sim.trace._tables[n]) for n in sim.trace.tables},
                 "spilled": {n: getattr(sim.trace._tables[n]._buf, "spilled_rows", 0) for n in sim.trace.tables}}
    gc.collect()
    res["peak_reset"] = _reset_peak()
    t0 = time.perf_counter()
    for name in sim.trace.tables:
        df = sim.trace.frame(name)
        del df
        gc.collect()
    res["read_wall"] = time.perf_counter() - t0
    res["peak_read"] = _vm("VmHWM")
    _reset_peak()
    with tempfile.TemporaryDirectory() as d:
        sim.trace.to_parquet(d)
    res["peak_parquet"] = _vm("VmHWM")
    return res


def main(hours: float, memory: int | None = None) -> dict:
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-m", "benchmarks.soak", "--child", str(hours)]
                         + (["--memory", str(memory)] if memory is not None else []),
                         cwd=root, env=env, check=True, capture_output=True, text=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    mb = 2.0 ** 20
    print(f"soak: networked DC servo, 802.11b 11 Mbit/s, 70 % loss, default tracing, {hours:g} simulated h "
          f"({sum(res['rows'].values()):,} rows, {sum(res['spilled'].values()):,} in temporary files)")
    print(f"  peak RSS during the run       {res['peak_run'] / mb:8.1f} MB  ({res['wall']:.0f} s wall)")
    print(f"  peak RSS reading every frame  {res['peak_read'] / mb:8.1f} MB  ({res['read_wall']:.0f} s wall)")
    print(f"  peak RSS in to_parquet        {res['peak_parquet'] / mb:8.1f} MB")
    return res


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", metavar="HOURS", help=argparse.SUPPRESS)
    ap.add_argument("--hours", type=float, default=1.0, help="simulated hours (default 1)")
    ap.add_argument("--memory", type=int, default=None,
                    help="in-memory bytes per keep-mode table instead of netcosim.recorder.DEFAULT_MEMORY")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(float(args.child), args.memory)))
    else:
        main(args.hours, args.memory)
