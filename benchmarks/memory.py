"""Trace memory: peak RSS of a long networked servo run, with default and bounded tracing.

Scenario: TrueTime's networked DC servo (``k / (s (s + 1))``, PID K = 0.96, Ti = 0.12,
Td = 0.049, h = 10 ms, square-wave reference, control saturated at +-10 V) closed over 802.11b at 11 Mbit/s with 70 %
Bernoulli frame loss on every link (up to 7 retries per frame).  The sensor node samples
and sends ``(t, y)``; the controller node runs the PID on arrival and sends ``u`` back;
the sensor's handler writes it to the servo.  The plant logs at every read and write
(``log="io"``), the tasks log ``u``, ``y`` and the delay: every trace table grows.

Configurations, each run in a fresh Python process (its peak RSS is ``VmHWM`` from
``/proc/self/status``, which includes the interpreter and numpy/pandas/scipy):

``default``  default settings: every table keeps every row, at most 4 MiB of them per
             table in memory and the rest in a temporary file (``docs/architecture.md``,
             "Default bound"; ``python -m benchmarks.soak`` also measures reading back)
``unbounded`` ``configure_all(mode="keep", memory=None)``: every row in memory (the default
             before issue 23)
``ring``     ``configure_all(mode="ring", rows=10_000)``
``window``   ``configure_all(mode="window", seconds=5.0)``
``off``      ``configure_all(mode="off")``

Bytes per trace row (:func:`bytes_per_row`): the same scenario, default tracing, run for
``ROW_SECONDS`` simulated seconds under :mod:`tracemalloc` twice in one process -- once
with today's columnar store, once with every table's store replaced by a plain list of
row tuples (the storage netcosim used before the columnar one; it exists only here, as
the baseline).  The memory allocated during the run and still held at its end, divided
by the rows kept, is the cost of a row; the ratio is what the columnar store saves.

The bounded configurations (``default`` among them) run one simulated hour.  The
unbounded one grows without bound, so it runs two shorter horizons and the growth per
simulated hour is extrapolated from the difference (``--default-hours`` to choose them).
No test depends on these numbers.
Run: ``python -m benchmarks.memory`` (``--quick`` for a 60 s smoke run, ``--rows`` for the
bytes per row only).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import tracemalloc

PERIOD = 0.010
EXEC_IO, EXEC_PID = 0.0002, 0.0005
FRAME_BITS = 80
LOSS = 0.7
U_MAX = 10.0            # actuator saturation (V)
ROW_SECONDS = 30.0      # simulated seconds of the bytes-per-row measurement
CONFIGS = {
    "default": None,
    "unbounded": dict(mode="keep", memory=None),
    "ring": dict(mode="ring", rows=10_000),
    "window": dict(mode="window", seconds=5.0),
    "off": dict(mode="off"),
}


def build(config: str, seed: int = 0):
    """The networked servo over lossy 802.11b with trace configuration *config*."""
    from netcosim import RK4, Simulation
    from netcosim.controllers.networked_loop import networked_loop
    from netcosim.controllers.pid import PID
    from netcosim.experiments.servo import square_wave
    from netcosim.network import Bernoulli, WLAN80211b
    from netcosim.plants.dc_servo import DCServo

    sim = Simulation(seed=seed)
    if CONFIGS[config] is not None:
        sim.trace.configure_all(**CONFIGS[config])
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=RK4(dt=1e-4))
    net = WLAN80211b(sim, "wlan", data_rate=11e6, loss=Bernoulli(LOSS))
    sensor, controller = sim.node("sensor"), sim.node("controller")
    s_if = net.attach(sensor, position=(0.0, 0.0))
    c_if = net.attach(controller, position=(10.0, 0.0))
    # actuator saturation: at 70 % loss the unsaturated loop diverges within a minute
    networked_loop(servo, sensor, controller, s_if, c_if, law=PID(h=PERIOD).compute,
                   reference=square_wave(amplitude=1.0, period=1.0), period=PERIOD, io_exec=EXEC_IO,
                   control_exec=EXEC_PID, frame_bits=FRAME_BITS, u_max=U_MAX, log_reference=False)
    return sim


def _vm(key: str) -> int:
    """A ``/proc/self/status`` memory field in bytes (``VmHWM`` = peak RSS, ``VmRSS`` = now)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    raise RuntimeError(f"no {key} in /proc/self/status")


def child(config: str, until: float) -> dict:
    """Run one configuration in this process and report its memory."""
    sim = build(config)
    rss0 = _vm("VmRSS")
    t0 = time.perf_counter()
    sim.run(until)
    wall = time.perf_counter() - t0
    rows = {name: len(sim.trace._tables[name]) for name in sim.trace.tables}
    return {"config": config, "until": until, "rss_built": rss0, "peak_rss": _vm("VmHWM"),
            "rss_end": _vm("VmRSS"), "anon_end": _vm("RssAnon"), "rows": rows, "wall": wall}


def measure(config: str, until: float) -> dict:
    """Run :func:`child` in a fresh interpreter (this checkout first on the path)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-m", "benchmarks.memory", "--child", config, str(until)],
                         cwd=root, env=env, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _tuple_store(sim) -> None:
    """Baseline for :func:`bytes_per_row`: every table keeps its rows as a list of tuples."""
    for rec in sim.trace._tables.values():
        rec._buf = list(rec._buf)  # rows recorded while building (network attach) carry over
        rec.rows.append = rec._buf.append
        rec.rows.extend = rec._buf.extend


def _row_cost(tuples: bool, until: float) -> tuple[int, int]:
    """(bytes allocated during the run and held at its end, rows kept) for one run."""
    import gc
    sim = build("default")
    if tuples:
        _tuple_store(sim)
    gc.collect()
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    sim.run(until)
    gc.collect()
    held = tracemalloc.get_traced_memory()[0] - base
    tracemalloc.stop()
    return held, sum(len(rec) for rec in sim.trace._tables.values())


def bytes_per_row(until: float = ROW_SECONDS) -> dict:
    """Trace memory per row, columnar store against a tuple store, measured in this process."""
    col_bytes, col_rows = _row_cost(False, until)
    tup_bytes, tup_rows = _row_cost(True, until)
    if col_rows != tup_rows:
        raise RuntimeError(f"the two runs kept {col_rows} and {tup_rows} rows; they should be identical")
    res = {"rows": col_rows, "columnar": col_bytes / col_rows, "tuples": tup_bytes / tup_rows}
    res["ratio"] = res["tuples"] / res["columnar"]
    print(f"trace memory per row, networked servo, {until:g} simulated s, {col_rows} rows (tracemalloc)")
    print(f"  tuples:   {res['tuples']:6.1f} bytes/row")
    print(f"  columnar: {res['columnar']:6.1f} bytes/row  ({res['ratio']:.1f}x smaller)")
    return res


def main(hours: float = 1.0, default_hours: tuple[float, float] = (60.0, 240.0),
         row_seconds: float = ROW_SECONDS) -> dict:
    """Bytes per row (:func:`bytes_per_row`), then every configuration; print tables (MB = 2**20 bytes)."""
    until = hours * 3600.0
    res: dict = {"bytes_per_row": bytes_per_row(row_seconds)}
    lo, hi = (measure("unbounded", t) for t in default_hours)
    slope = (hi["rss_end"] - lo["rss_end"]) / (hi["until"] - lo["until"])  # bytes per simulated s
    res["unbounded"] = {"short": lo, "long": hi, "bytes_per_sim_hour": slope * 3600.0,
                        "peak_rss_1h_extrapolated": hi["peak_rss"] + slope * (until - hi["until"])}
    for config in ("default", "ring", "window", "off"):
        res[config] = measure(config, until)
    mb = 2.0 ** 20
    print(f"networked DC servo, h = {PERIOD * 1e3:.0f} ms, 802.11b 11 Mbit/s, {LOSS:.0%} Bernoulli loss; "
          f"peak RSS per fresh process (MB)")
    print(f"  {'config':8s} {'sim time':>9s} {'peak RSS':>9s} {'after build':>12s} {'rows kept':>10s} "
          f"{'wall s':>7s}")
    for r in (lo, hi):
        print(f"  {'unbounded':8s} {r['until']:8.0f}s {r['peak_rss'] / mb:9.1f} {r['rss_built'] / mb:12.1f} "
              f"{sum(r['rows'].values()):10d} {r['wall']:7.1f}")
    for config in ("default", "ring", "window", "off"):
        r = res[config]
        print(f"  {config:8s} {r['until']:8.0f}s {r['peak_rss'] / mb:9.1f} {r['rss_built'] / mb:12.1f} "
              f"{sum(r['rows'].values()):10d} {r['wall']:7.1f}")
    d = res["unbounded"]
    print(f"  unbounded tracing grows by {d['bytes_per_sim_hour'] / mb:,.0f} MB per simulated hour "
          f"(extrapolated from {default_hours[0]:.0f} s and {default_hours[1]:.0f} s): "
          f"~{d['peak_rss_1h_extrapolated'] / mb:,.0f} MB peak for {hours:g} h")
    return res


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", nargs=2, metavar=("CONFIG", "UNTIL"), help=argparse.SUPPRESS)
    ap.add_argument("--quick", action="store_true", help="60 s instead of one simulated hour")
    ap.add_argument("--rows", action="store_true", help="only the bytes per trace row (tuples vs columnar)")
    args = ap.parse_args()
    if args.rows:
        bytes_per_row()
    elif args.child:
        print(json.dumps(child(args.child[0], float(args.child[1]))))
    elif args.quick:
        main(hours=60.0 / 3600.0, default_hours=(15.0, 60.0), row_seconds=10.0)
    else:
        main()
