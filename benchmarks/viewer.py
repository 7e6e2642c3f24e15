"""The interactive view at scale: time to build the HTML, its size, and the headless
browser's load time, for runs of about 10^4, 10^5 and 10^6 trace rows.

The runs are TrueTime's networked servo (``netcosim.experiments.networked_servo``:
CSMA/CD, interferer share 0.3 -- stable over long horizons, where 0.6 diverges --, plant
logged every 1 ms), their horizon sized from a 5 s run so that the tables the view draws
(schedule, jobs, frames, network_schedule, signals) hold about N rows.  For each: the
rows and the drawn rows the page holds exactly (task intervals, frame attempts, busy
periods, samples of the two signals drawn); the simulated seconds; the time to build and
write the page (``Trace.view``, wall clock, reading the tables from the trace included);
the file's size; the time from navigation to the first level-of-detail update in
headless Chromium (:class:`netcosim.view.headless.Page`); the time of one update after a
zoom to a 10 ms window (exact rows) and back to the whole run (aggregated); and the
trace-event export's time and size.

Run: ``python -m benchmarks.viewer`` (``--rows 10000 100000`` for some sizes only).
``--screenshot PNG`` writes a screenshot of the Fly-crane main job's online run at 20 %
loss, Figs. A.4/A.5's window, in headless Chromium.

No test depends on these numbers; docs/viewer.md lists what they were on the development
machine.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from netcosim.view.headless import chromium_path, open_view

SIZES = (10_000, 100_000, 1_000_000)
TABLES = ("schedule", "jobs", "frames", "network_schedule", "signals")


def _run(until: float):
    from netcosim.experiments.networked_servo import build
    sim, _ = build("csma_cd", 0.3, seed=0)
    sim.run(until=until)
    return sim


def rows_of(sim) -> int:
    """Rows of the tables the view draws."""
    return sum(len(sim.trace.frame(t)) for t in TABLES if t in sim.trace.tables)


def measure(n: int, folder: Path, rate: float) -> dict:
    """One size: build, size and load of the page for about *n* rows (*rate*: rows per simulated s)."""
    until = max(0.1, round(n / rate, 3))
    t = time.perf_counter()
    sim = _run(until)
    sim_s = time.perf_counter() - t
    rows = rows_of(sim)
    from netcosim.view import segments as sg
    tables = {t: sim.trace.frame(t) for t in TABLES}
    att = sg.frame_attempts(tables["frames"])
    sig = tables["signals"]
    drawn = (len(sg.task_segments(tables["schedule"])) + len(att) + len(sg.medium_busy(att))
             + int(sig["signal"].astype(str).isin(("y.y", "u")).sum()))
    html = folder / f"view_{n}.html"
    t = time.perf_counter()
    sim.trace.view(html, signals=["servo.y.y", "sensor.actuate.u"])
    build_s = time.perf_counter() - t
    t = time.perf_counter()
    js = sim.trace.to_chrome_trace(folder / f"trace_{n}.json")
    export_s = time.perf_counter() - t
    out = {"rows": rows, "drawn": drawn, "simulated_s": until, "simulate_s": sim_s, "build_s": build_s,
           "html_MB": html.stat().st_size / 1e6, "export_s": export_s, "json_MB": js.stat().st_size / 1e6}
    if chromium_path() is not None:
        with open_view(html, timeout=600) as page:
            out["load_s"] = page.load_time
            t = time.perf_counter()
            page.set_range(until / 2, until / 2 + 0.01)
            out["zoom_in_s"] = time.perf_counter() - t
            t = time.perf_counter()
            page.set_range(0.0, until)
            out["zoom_out_s"] = time.perf_counter() - t
            out["errors"] = len(page.errors)
    return out


def screenshot(path: str | os.PathLike) -> Path:
    """A screenshot of the main job's online run at 20 % loss (horizon 45 s),
    its timeline opened at Figs. A.4/A.5's window (2.9 to 4.9 s), in headless Chromium."""
    from netcosim.controllers.planner.networked import FlyCraneNetworkConfig, run
    from netcosim.experiments.flycrane_network import fig_view
    r = run(FlyCraneNetworkConfig(strategy="online", loss=0.2, seed=0, horizon=45.0))
    with tempfile.TemporaryDirectory() as tmp:
        html = fig_view(r, Path(tmp) / "timeline_online_loss20.html")
        with open_view(html, width=1250, height=800) as page:
            if page.errors:
                raise RuntimeError(f"the page reported errors: {page.errors}")
            page.page.screenshot(path=str(path), full_page=False, clip={"x": 0, "y": 0, "width": 1250,
                                                                         "height": 800})
    return Path(path)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, nargs="*", default=list(SIZES), help="sizes (rows) to measure")
    ap.add_argument("--screenshot", metavar="PNG", help="write a screenshot of the main job's timeline instead")
    a = ap.parse_args(argv)
    if a.screenshot:
        print(screenshot(a.screenshot))
        return
    if chromium_path() is None:
        print("no Chromium (/usr/bin/chromium): load times are not measured")
    import bokeh.embed  # noqa: F401 - imported before the clock: the first build would pay it (about 2 s)
    import bokeh.plotting  # noqa: F401
    probe = _run(5.0)
    rate = rows_of(probe) / 5.0
    print(f"networked servo, share 0.3: {rate:.0f} trace rows per simulated second")
    print(f"{'rows':>9} {'drawn':>8} {'sim s':>7} {'build s':>8} {'HTML MB':>8} {'load s':>7} {'zoom in s':>9} "
          f"{'zoom out s':>10} {'export s':>8} {'JSON MB':>8}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in a.rows:
            m = measure(n, Path(tmp), rate)
            print(f"{m['rows']:>9} {m['drawn']:>8} {m['simulated_s']:>7.2f} {m['build_s']:>8.2f} {m['html_MB']:>8.1f} "
                  f"{m.get('load_s', float('nan')):>7.2f} {m.get('zoom_in_s', float('nan')):>9.3f} "
                  f"{m.get('zoom_out_s', float('nan')):>10.3f} {m['export_s']:>8.2f} {m['json_MB']:>8.1f}"
                  + (f"  ({m['errors']} page errors)" if m.get("errors") else ""), flush=True)


if __name__ == "__main__":
    main()
