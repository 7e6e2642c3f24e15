"""802.11b throughput of the simulator: saturated DCF with 10 stations, against bare SimPy.

Scenario: 10 saturated stations send 1500-byte unicast frames at 11 Mbit/s to an access
point (full DCF: backoff, collisions, ACKs, NAV, EIFS, radio reception with SINR).  The
measure is simulated data frames (acknowledged or dropped) per wall-clock second, with
and without tracing.

Baseline, measured in the same run: bare SimPy processes doing nothing but
``yield env.timeout(dt)``.  The ratio (wall time per simulated frame / wall time per bare
timeout) is the cost of one complete 802.11 frame exchange -- which needs several
events per station (carrier-sense changes, backoff timers, data, SIFS, ACK, NAV) -- in
units of the cheapest possible SimPy event.  Run: ``python -m benchmarks.network``.
"""

from __future__ import annotations

import math
import statistics
import time

import simpy

from netcosim import Simulation
from netcosim.network import SaturatedSource, WLAN80211b

N_STATIONS = 10
PAYLOAD_BITS = 1500 * 8


def wlan_run(until: float, trace: bool) -> tuple[int, float, int]:
    sim = Simulation(seed=0)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, trace=trace)
    ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
    for i in range(N_STATIONS):
        s = net.attach(f"s{i}", position=(10 * math.cos(i), 10 * math.sin(i)))
        SaturatedSource(s, ap, PAYLOAD_BITS)
    t0 = time.perf_counter()
    sim.run(until)
    dt = time.perf_counter() - t0
    frames = sum(i.stats["sent"] + i.stats["dropped"] for i in net._ifaces)
    return frames, dt, len(sim.env._queue) if hasattr(sim.env, "_queue") else 0


def bare_run(n_timeouts: int) -> float:
    env = simpy.Environment()
    per = n_timeouts // N_STATIONS

    def proc(dt):
        for _ in range(per):
            yield env.timeout(dt)
    for i in range(N_STATIONS):
        env.process(proc(1000 + i))
    t0 = time.perf_counter()
    env.run()
    return (time.perf_counter() - t0) / (per * N_STATIONS)


def main(until: float = 2.0, repeats: int = 5) -> dict:
    """Interleave WLAN and baseline runs; report the best (least disturbed) of each."""
    res = {}
    for trace in (True, False):
        per_frame, ratios, frames = [], [], 0
        for _ in range(repeats):
            frames, dt, _ = wlan_run(until, trace)
            bare = bare_run(200_000)
            per_frame.append(dt / frames)
            ratios.append(per_frame[-1] / bare)
            res.setdefault("bare_us", []).append(bare * 1e6)
        key = "traced" if trace else "untraced"
        res[key] = {"frames": frames, "us_per_frame": min(per_frame) * 1e6,
                    "frames_per_s": 1.0 / min(per_frame), "ratio_median": statistics.median(ratios)}
    bare_us = min(res["bare_us"])
    print(f"saturated 802.11b, {N_STATIONS} stations, 11 Mbit/s, {PAYLOAD_BITS // 8}-byte frames, "
          f"{until} s simulated per run, {repeats} interleaved runs")
    for key in ("traced", "untraced"):
        r = res[key]
        print(f"  {key:9s}: {r['frames']} frames/run, {r['us_per_frame']:.1f} us/frame "
              f"({r['frames_per_s']:,.0f} simulated frames per wall second, best)")
        print(f"             {r['us_per_frame'] / bare_us:.0f}x a bare SimPy timeout best-vs-best, "
              f"{r['ratio_median']:.0f}x median of pairwise ratios")
    print(f"  bare SimPy: {bare_us:.3f} us per timeout (best)")
    res["bare_us_per_timeout"] = bare_us
    return res


if __name__ == "__main__":
    main()
