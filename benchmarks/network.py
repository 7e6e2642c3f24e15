"""802.11b throughput of the simulator: saturated DCF with 10 stations, against bare SimPy.

Scenario: 10 saturated stations send 1500-byte unicast frames at 11 Mbit/s to an access
point (full DCF: backoff, collisions, ACKs, NAV, EIFS, radio reception with SINR).  The
measure is simulated data frames (acknowledged or dropped) per wall-clock second, with
and without tracing.

Baseline, measured in the same run: bare SimPy processes doing nothing but
``yield env.timeout(dt)``.  The ratio (wall time per simulated frame / wall time per bare
timeout) is the cost of one complete 802.11 frame exchange -- which needs several
events per station (carrier-sense changes, backoff timers, data, SIFS, ACK, NAV) -- in
units of the cheapest possible SimPy event.

802.11b per-frame cost against the number of stations n (2, 10, 50), saturated unicast to
an access point, measured with the shared idle-slot clock (``shared_clock=True``, the
default) and with the per-station path (``False``), interleaved (one run of each
configuration per round), untraced, in CPU time of this process (``time.process_time``: on
a machine shared with other jobs, wall time also counts the time the other jobs run, which
distorts the long runs at 50 stations more than the short ones).  Two geometries:

``cluster``  the stations within 0.5 m of the access point: every station hears every
             other one at the same power, no capture is possible -- the shared clock's case;
``circle``   the stations on a 10 m circle (as above): all in range, but a near sender
             can capture a receiver from a far one: the shared clock checks each overlap
             station by station, and the listeners whose reception of it differs from
             the crowd's leave the crowd until their view of the medium is the crowd's
             again (about 18 of 49 per overlap at 50 stations).

Measured on the development machine (2 cores shared with other jobs, load average about
15-19, CPU time, best of 5 rounds, the paired median in brackets), us per frame at n = 2
/ 10 / 50: cluster on the shared clock 36.4 / 44.4 / 64.9, ratio 50/2 1.78 (1.77);
circle on the shared clock 36.8 / 59.2 / 148.9, ratio 4.04 (4.11), where it took the
per-station path before (main, same load: 35.5 / 66.3 / 261.9, ratio 7.39); circle on the
per-station path 32.1 / 65.1 / 258.8, ratio 8.06 (8.22).  The circle's ratio on the
shared clock is bounded by the overlaps (about 0.8 overlapping starts per delivered frame
at 50 stations) times the listeners whose reception of an overlap differs from the
crowd's (about 18 of 49), each taking the per-station steps and its own bit-error draw
until it rejoins: O(n) per overlap, with a smaller constant than the per-station path.

CAN per-frame cost against the number of nodes n (10 and 100), two scenarios with 8-byte
standard frames, identifier = node index:

``periodic``   every node sends periodically with a random phase, for a bus load of 90 %
               whatever n: the queues of a few nodes compete at each arbitration;
``saturated``  every node keeps a frame queued (:class:`SaturatedSource`): all n queues
               compete at every arbitration (the worst case for a scan).

The measure is wall time per frame sent; the ratio of the cost at 100 nodes to the cost at
10 nodes, measured in the same run, for the heap arbitration of :class:`~netcosim.network.CAN`
and for the scan of every node's queue it replaced (:class:`ScanCAN`, kept here for comparison).

Trace cost: the per-frame cost with the ``frames`` and ``network_schedule`` tables recorded
(the default, ``keep`` mode) over the cost without them (``trace=False``), on CAN (10 nodes,
the ``periodic`` scenario above, 20 000 frames) and on 802.11b (the 10 saturated stations
above, 1 s simulated), in CPU time of this process: each round runs traced then untraced
back to back, the ratio is taken within the round and its median over the rounds reported
(with the best per-frame cost of each).

Run: ``python -m benchmarks.network`` (``--can`` for the CAN part only, ``--wlan-scaling`` for
the 802.11b scaling only, ``--trace`` for the trace cost only).
"""

from __future__ import annotations

import gc
import math
import statistics
import sys
import time

import simpy

from netcosim import Simulation
from netcosim.network import CAN, SaturatedSource, WLAN80211b, can_frame_bits

N_STATIONS = 10
PAYLOAD_BITS = 1500 * 8


def wlan_run(until: float, trace: bool, clock=time.perf_counter) -> tuple[int, float, int]:
    """The 10 saturated stations (see the module docstring) for *until* s, traced or not; returns
    (frames sent or dropped, seconds of *clock*: wall time by default, events queued at the end)."""
    sim = Simulation(seed=0)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, trace=trace)
    ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
    for i in range(N_STATIONS):
        s = net.attach(f"s{i}", position=(10 * math.cos(i), 10 * math.sin(i)))
        SaturatedSource(s, ap, PAYLOAD_BITS)
    gc.collect()
    t0 = clock()
    sim.run(until)
    dt = clock() - t0
    frames = sum(i.stats["sent"] + i.stats["dropped"] for i in net._ifaces)
    return frames, dt, sim.env.queued


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
    res["wlan_scaling"] = wlan_scaling_main()
    res["can"] = can_main()
    res["trace"] = trace_main()
    return res


def trace_main(repeats: int = 7, can_frames: int = 20_000, wlan_until: float = 1.0) -> dict:
    """Traced over untraced per-frame cost on CAN and 802.11b (see the module docstring): CPU
    time, traced and untraced back to back in each round, median of the rounds' ratios."""
    cpu = time.process_time
    runs = {"can": lambda trace: can_run(10, can_frames, trace=trace, clock=cpu),
            "wlan": lambda trace: wlan_run(wlan_until, trace, clock=cpu)[:2]}
    runs["can"](True)       # warm-up (first-use imports)
    wlan_run(0.05, True)
    ratios: dict = {k: [] for k in runs}
    best: dict = {}
    for _ in range(repeats):
        for name, run in runs.items():
            cost = {}
            for trace in (True, False):
                frames, dt = run(trace)
                cost[trace] = dt / frames
                best[(name, trace)] = min(best.get((name, trace), math.inf), cost[trace])
            ratios[name].append(cost[True] / cost[False])
    print(f"trace cost: traced / untraced per frame, CPU time, median of {repeats} paired rounds "
          f"(CAN: 10 nodes at {CAN_LOAD:.0%} load, {can_frames} frames; 802.11b: {N_STATIONS} saturated "
          f"stations, {wlan_until} s)")
    out: dict = {}
    for name, label in (("can", "CAN"), ("wlan", "802.11b")):
        med = statistics.median(ratios[name])
        print(f"  {label:8s}: {best[(name, True)] * 1e6:.1f} us/frame traced, {best[(name, False)] * 1e6:.1f} "
              f"untraced (best); ratio {med:.3f} (median; rounds {min(ratios[name]):.3f}..{max(ratios[name]):.3f})")
        out[name] = {"ratio_median": med, "ratios": ratios[name], "us_traced": best[(name, True)] * 1e6,
                     "us_untraced": best[(name, False)] * 1e6}
    return out


#: Simulated seconds run before the timed part of a scaling run (s).
WLAN_WARMUP = 0.2


def wlan_scaling_run(n: int, shared_clock: bool, geometry: str, until: float) -> tuple[int, float, bool]:
    """n saturated stations (*geometry*, see the module docstring) sending to an access point;
    returns (frames sent or dropped, CPU seconds of this process, whether the shared clock was in
    use) over
    *until* simulated seconds after :data:`WLAN_WARMUP` (the steady state: at the start every
    station sends at once, a collision of all n frames)."""
    sim = Simulation(seed=0)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, trace=False, shared_clock=shared_clock)
    ap = net.attach("ap", position=(0.0, 0.0), mailbox=False)
    radius = 0.5 if geometry == "cluster" else 10.0
    for i in range(n):
        s = net.attach(f"s{i}", position=(radius * math.cos(i), radius * math.sin(i)))
        SaturatedSource(s, ap, PAYLOAD_BITS)
    sim.run(WLAN_WARMUP)            # past the start, where every station sends at once
    done = sum(i.stats["sent"] + i.stats["dropped"] for i in net._ifaces)
    gc.collect()
    t0 = time.process_time()
    sim.run(WLAN_WARMUP + until)
    dt = time.process_time() - t0
    return sum(i.stats["sent"] + i.stats["dropped"] for i in net._ifaces) - done, dt, net._fast


def wlan_scaling_main(until: float = 1.0, repeats: int = 5, ns=(2, 10, 50)) -> dict:
    """Per-frame cost at each n, shared clock vs per-station path, interleaved.

    Each round runs every configuration once, the n of one configuration back to back:
    the ratio largest n / smallest n is taken within a round (a pair of neighbouring
    runs, so a burst of load from other jobs hits both or neither) and its median over
    the rounds is reported, with the best (least disturbed) cost of each configuration.
    """
    best: dict = {}
    fast: dict = {}
    paired: dict = {}
    wlan_scaling_run(2, True, "cluster", 0.05)      # warm-up (first-use imports)
    wlan_scaling_run(2, False, "circle", 0.05)
    for _ in range(repeats):
        for geometry in ("cluster", "circle"):
            for shared in (True, False):
                cost = {}
                for n in ns:
                    frames, dt, used = wlan_scaling_run(n, shared, geometry, until)
                    key = (geometry, shared, n)
                    cost[n] = dt / frames
                    best[key] = min(best.get(key, math.inf), cost[n])
                    fast[key] = used
                paired.setdefault((geometry, shared), []).append(cost[ns[-1]] / cost[ns[0]])
    print(f"802.11b scaling: n saturated stations -> AP, 11 Mbit/s, {PAYLOAD_BITS // 8}-byte frames, {until} s "
          f"simulated per run after {WLAN_WARMUP} s, untraced, CPU time, {repeats} interleaved rounds")
    out: dict = {}
    for geometry in ("cluster", "circle"):
        for shared in (True, False):
            us = [best[(geometry, shared, n)] * 1e6 for n in ns]
            used = "shared clock" if all(fast[(geometry, shared, n)] for n in ns[1:]) else "per-station path"
            cost = ", ".join(f"{u:.1f}" for u in us)
            med = statistics.median(paired[(geometry, shared)])
            print(f"  {geometry:7s} shared_clock={shared!s:5s} ({used}): best us/frame at n = "
                  f"{'/'.join(map(str, ns))}: {cost}; ratio {ns[-1]}/{ns[0]}: {us[-1] / us[0]:.2f} best-vs-best, "
                  f"{med:.2f} median of paired runs")
            out[(geometry, shared)] = {"us_per_frame": dict(zip(ns, us)), "ratio": us[-1] / us[0],
                                       "ratio_paired_median": med, "path": used}
    return out


class ScanCAN(CAN):
    """CAN with the arbitration it had before the heap: scan every node's queue (comparison only)."""

    def _choose(self):
        best, bkey = None, None
        for i in self._ifaces:
            q = i.queue
            if q._q:
                key = q.peek().priority
                if bkey is None or key < bkey:
                    best, bkey = i, key
        return best

    def _restart(self, iface):
        for i in self._ifaces:
            if i.queue._q:
                self._kick(i)
                break


CAN_RATE = 500e3
CAN_LOAD = 0.9


def periodic_sender(sim, iface, dst, period: float, bits: int = 64):
    """A callable that sends a *bits* frame from *iface* to *dst* and calls itself again
    *period* seconds later (start it with ``sim.call_at``): each sender its own period."""
    def send():
        iface.send(dst, None, bits)
        sim.call_in(period, send)
    return send


def can_run(n: int, frames: int, cls=CAN, scenario: str = "periodic", *, trace: bool = True,
            clock=time.perf_counter) -> tuple[int, float]:
    """n senders (*scenario*, see the module docstring), the network traced or not; returns
    (frames sent, seconds of *clock*: wall time by default)."""
    sim = Simulation(seed=0)
    bus = cls(sim, "can", data_rate=CAN_RATE, frame_format="standard", trace=trace)
    sink = bus.attach("sink", priority=10**6, mailbox=False)
    c = can_frame_bits(8) / CAN_RATE
    period = n * c / CAN_LOAD
    rng = sim.rng("phases")
    for i in range(n):
        iface = bus.attach(f"n{i}", priority=i, mailbox=False)
        if scenario == "saturated":
            SaturatedSource(iface, sink, 64)
            continue

        sim.call_at(float(rng.uniform(0, period)), periodic_sender(sim, iface, sink, period))
    until = frames * c / (1.0 if scenario == "saturated" else CAN_LOAD)
    gc.collect()    # the previous runs' dead simulations, not this one's cost
    t0 = clock()
    sim.run(until)
    dt = clock() - t0
    return sum(i.stats["sent"] for i in bus._ifaces), dt


def can_main(frames: int = 20_000, repeats: int = 5) -> dict:
    """Per-frame cost at 10 and 100 nodes, heap vs scan, interleaved; the best run of each."""
    res: dict = {}
    scenarios = ("periodic", "saturated")
    for _ in range(repeats):
        for scenario in scenarios:
            for cls in (CAN, ScanCAN):
                for n in (10, 100):
                    sent, dt = can_run(n, frames, cls, scenario)
                    key = (scenario, cls.__name__, n)
                    res[key] = min(res.get(key, math.inf), dt / sent)
    print(f"CAN, {CAN_RATE / 1e3:.0f} kbit/s, 8-byte standard frames, ~{frames} frames per run, "
          f"best of {repeats} interleaved runs")
    out: dict = {}
    for scenario in scenarios:
        print(f"  {scenario} ({f'{CAN_LOAD:.0%} load' if scenario == 'periodic' else 'every queue non-empty'}):")
        for name, label in (("CAN", "heap (now)"), ("ScanCAN", "scan (before)")):
            a, b = res[(scenario, name, 10)] * 1e6, res[(scenario, name, 100)] * 1e6
            print(f"    {label:13s}: {a:.1f} us/frame at 10 nodes, {b:.1f} us/frame at 100 nodes, "
                  f"ratio 100/10 = {b / a:.2f}")
            out[(scenario, name)] = {"us_per_frame_10": a, "us_per_frame_100": b, "ratio": b / a}
    return out

if __name__ == "__main__":
    if "--can" in sys.argv[1:]:
        can_main()
    elif "--wlan-scaling" in sys.argv[1:]:
        wlan_scaling_main()
    elif "--trace" in sys.argv[1:]:
        trace_main()
    else:
        main()
