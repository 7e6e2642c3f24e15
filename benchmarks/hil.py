"""Hardware-in-the-loop round trip over Zenoh on loopback, and a 500 Hz remote loop.

A node ``io`` sends an 80-bit frame every 2 ms (500 Hz) over an ideal 1 Gbit/s link to
the remote node ``echo``; the echo process (``python -m netcosim.transport.client``, a
separate OS process) answers each with the same values.  The simulated response time
of every reply (delivery to the process -> reply injected into the simulation; in real
time, so simulated = wall-clock seconds plus the simulation's own lateness) gives:

* the round trip simulation -> process -> simulation: median and p99 (targets on a
  2-core machine: median <= 0.5 ms, p99 <= 2 ms);
* the share of periods whose reply misses the next period (response > 2 ms; target
  <= 0.1 %);
* the real-time lateness of the simulation's events (histogram quantiles, overruns
  beyond 1 ms);
* the same-run baseline: a raw Zenoh ping-pong between the same two processes, on the
  same sessions, before the loop (no netcosim on the path: the echo process answers
  from its Zenoh callback, the benchmark waits on a queue filled by its callback), paced
  at the same period; netcosim's round trip is reported as a ratio to it.

On a machine shared with other jobs the tails grow with the load: run it on an idle
machine for numbers to compare.  Run: ``python -m benchmarks.hil [--duration S]``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
PERIOD = 0.002          # s: 500 Hz
FRAME_BITS = 80


def _raw_ping(session, run: str, pings: int) -> np.ndarray:
    """Round trips (s) of *pings* raw Zenoh messages to the echo process, one per period."""
    import queue
    import time
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    sub = session.zenoh.declare_subscriber(f"netcosim/{run}/raw/tx", lambda s: inbox.put(time.perf_counter()))
    pub = session.publisher(f"netcosim/{run}/raw/rx")
    payload = bytes(40 + 8)            # the size of a one-value netcosim message
    out = []
    try:
        for _ in range(20):            # until the echo's subscriber is matched
            pub.put(payload)
            try:
                inbox.get(timeout=0.25)
                break
            except queue.Empty:
                continue
        while not inbox.empty():
            inbox.get_nowait()
        t_next = time.perf_counter()
        for _ in range(pings):
            t_next += PERIOD
            while (d := t_next - time.perf_counter()) > 0:
                time.sleep(d)
            t0 = time.perf_counter()
            pub.put(payload)
            try:
                out.append(inbox.get(timeout=1.0) - t0)
            except queue.Empty:
                continue
    finally:
        sub.undeclare()
        pub.undeclare()
    return np.asarray(out)


def _flood(session, remote, count: int, at: float, sent: list) -> None:
    """From a third session, publish *count* garbage messages on *remote*'s reply key as
    fast as possible, *at* s after the run starts (a thread); the wall time it took goes to *sent*."""
    import os
    import threading
    import time

    from netcosim.transport.session import open_session
    peer = open_session(listen=(), connect=session.endpoints)
    pub = peer.publisher(remote.keys["tx"])
    deadline = time.monotonic() + 10
    while not pub.matching_status.matching and time.monotonic() < deadline:
        time.sleep(0.01)
    junk = os.urandom(64)

    def go():
        try:
            time.sleep(at)
            t0 = time.monotonic()
            for i in range(count):
                pub.put(junk[: i % 64])
            sent.append(time.monotonic() - t0)
            time.sleep(0.5)
        finally:
            peer.close()
    threading.Thread(target=go, daemon=True).start()


def measure(duration: float = 10.0, baseline_pings: int = 5000, spin: float | None = None, flood: int = 0) -> dict:
    """Run *baseline_pings* raw pings, then the 500 Hz echo loop for *duration* s of real
    time (``spin``: the real-time clock's busy-wait, s; None: its default; ``flood``: that
    many garbage messages from a third session halfway through); returns the statistics."""
    from netcosim import IdealLink, Simulation
    from netcosim.transport.remote import RemoteNode
    from netcosim.transport.session import new_run_id, open_session

    sim = Simulation()
    net = IdealLink(sim, "link", data_rate=1e9)
    io, _ = sim.node("io"), sim.node("echo")
    net.attach(io)
    net.attach("echo")

    @io.periodic(period=PERIOD, priority=1, name="send")
    def send(ctx):
        ctx.send("echo", (ctx.now,), FRAME_BITS)
        yield ctx.execute(0.0)

    run = new_run_id()
    session = open_session()
    child = None
    try:
        remote = RemoteNode(sim, "echo", session, run=run, size_bits=FRAME_BITS, period=PERIOD, reply_values=1,
                            max_lag=0.001, spin=spin)
        cmd = [sys.executable, "-m", "benchmarks.hil", "--echo", "--run", run, "--connect", session.endpoints[0]]
        flood_took: list = []
        child = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL)
        if not remote.wait_connected(30):
            raise TimeoutError("the echo process did not connect within 30 s")
        raw = _raw_ping(session, run, baseline_pings)
        if len(raw) == 0:
            raise TimeoutError("the echo process answered no raw Zenoh ping")
        if flood:
            _flood(session, remote, flood, duration / 2, flood_took)
        sim.run(until=duration)
        remote.finish()
        child.wait(timeout=10)
    finally:
        if child is not None and child.poll() is None:
            child.kill()
            child.wait(timeout=10)
        session.close()
    resp = remote.response_times()
    lat = remote.clock.lateness
    sent = remote.published
    counters = remote.counters()
    raw_median = float(np.median(raw))
    return {"raw_pings": baseline_pings, "raw_replies": len(raw), "raw_median_ms": raw_median * 1e3,
            "raw_p99_ms": float(np.quantile(raw, 0.99)) * 1e3,
            "raw_miss_share": float(((raw > PERIOD).sum() + baseline_pings - len(raw)) / baseline_pings),
            "ratio_median": float(np.median(resp)) / raw_median,
            "ratio_p99": float(np.quantile(resp, 0.99)) / float(np.quantile(raw, 0.99)),
            "periods": sent, "replies": len(resp), "rtt_median_ms": float(np.median(resp)) * 1e3,
            "rtt_p99_ms": float(np.quantile(resp, 0.99)) * 1e3, "rtt_max_ms": float(resp.max()) * 1e3,
            # a reply later than the deadline (one period) is dropped as late, and a request
            # withheld behind two unanswered ones is an overrun: both are misses
            "miss_share": float((sent + counters["overruns"] - len(resp)) / (sent + counters["overruns"])),
            "dropped": counters["dropped"], "expired": counters["expired"], "overruns": counters["overruns"],
            "flood": flood, "flood_publish_s": flood_took[0] if flood_took else float("nan"),
            "injections": lat.injections,
            "lateness_p50_ms": lat.quantile(0.5) * 1e3, "lateness_p99_ms": lat.quantile(0.99) * 1e3,
            "lateness_max_ms": lat.max * 1e3, "overruns_1ms": lat.overruns, "events": lat.events,
            "collections": tuple(remote.clock.collections)}


def echo(run: str, connect: str) -> None:
    """The echo process: a raw Zenoh echo (answered from the callback) on
    ``netcosim/<run>/raw/...`` and the netcosim echo of node ``echo`` until the run ends."""
    from netcosim.transport.client import RemoteProcess
    with RemoteProcess("echo", run=run, connect=[connect], lease=1.0) as rp:
        z = rp.session.zenoh
        raw_pub = z.declare_publisher(f"netcosim/{run}/raw/tx", express=True)
        raw_sub = z.declare_subscriber(f"netcosim/{run}/raw/rx", lambda s: raw_pub.put(s.payload))
        try:
            rp.serve(lambda msg: msg.values, timeout=30.0)
        finally:
            raw_sub.undeclare()
            raw_pub.undeclare()


def main(argv: list[str] | None = None) -> None:
    """Print the statistics of one run (default 10 s)."""
    p = argparse.ArgumentParser(prog="python -m benchmarks.hil", description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=10.0, help="seconds of real time (default 10)")
    p.add_argument("--pings", type=int, default=5000,
                   help="raw Zenoh pings of the baseline, one per period (default 5000: 10 s)")
    p.add_argument("--spin", type=float, default=None,
                   help="busy-wait (s) of the real-time clock before each event (default: the clock's, 1e-4)")
    p.add_argument("--flood", type=int, default=0, metavar="N",
                   help="also run the loop with N garbage messages from a third session halfway through, "
                        "after the same loop without (the baseline of the same invocation)")
    p.add_argument("--echo", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--run", help=argparse.SUPPRESS)
    p.add_argument("--connect", help=argparse.SUPPRESS)
    a = p.parse_args([] if argv is None and __name__ != "__main__" else argv)
    if a.echo:
        echo(a.run, a.connect)
        return
    if a.flood:
        base = measure(a.duration, a.pings, a.spin)
        r = measure(a.duration, a.pings, a.spin, flood=a.flood)
        for label, x in (("without flood", base), (f"with {a.flood} garbage messages", r)):
            print(f"{label}: lateness max {x['lateness_max_ms']:.3f} ms, p99 <= {x['lateness_p99_ms']:.3f} ms, "
                  f"{x['overruns_1ms']} events over 1 ms; round trip median {x['rtt_median_ms']:.3f} ms, "
                  f"p99 {x['rtt_p99_ms']:.3f} ms; misses {100 * x['miss_share']:.3f} %; dropped {x['dropped']}; "
                  f"{x['injections']} injections")
        print(f"the flood took {r['flood_publish_s'] * 1e3:.0f} ms to publish; worst lateness with it "
              f"x{r['lateness_max_ms'] / base['lateness_max_ms']:.2f} the baseline's")
        return
    r = measure(a.duration, a.pings, a.spin)
    print(f"raw Zenoh ping-pong, same processes, {r['raw_replies']}/{r['raw_pings']} replies: "
          f"median {r['raw_median_ms']:.3f} ms, p99 {r['raw_p99_ms']:.3f} ms, "
          f"{100 * r['raw_miss_share']:.3f} % beyond one period")
    print(f"500 Hz remote loop, {a.duration:g} s: {r['periods']} requests published, {r['overruns']} overruns, "
          f"{r['replies']} replies applied, dropped {r['dropped']}")
    print(f"  round trip sim -> process -> sim: median {r['rtt_median_ms']:.3f} ms (target <= 0.5), "
          f"p99 {r['rtt_p99_ms']:.3f} ms (target <= 2), max {r['rtt_max_ms']:.3f} ms")
    print(f"  ratio to raw Zenoh: median x{r['ratio_median']:.2f}, p99 x{r['ratio_p99']:.2f}")
    print(f"  replies missing the next period: {100 * r['miss_share']:.3f} % (target <= 0.1 %)")
    print(f"  lateness of {r['events']} events: p50 <= {r['lateness_p50_ms']:.3f} ms, "
          f"p99 <= {r['lateness_p99_ms']:.3f} ms, max {r['lateness_max_ms']:.3f} ms, "
          f"{r['overruns_1ms']} over 1 ms")
    print(f"  garbage collections in the slack (generations 0, 1, 2): {r['collections']}")


if __name__ == "__main__":
    main()
