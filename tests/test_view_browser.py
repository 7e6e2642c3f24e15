"""The interactive view in a real headless browser (Debian's Chromium driven by Playwright):
the three-servo and networked-servo pages load without JavaScript errors, draw the
expected task rows, frame glyphs and signal lines, a wheel zoom changes the visible
range, zoomed out the bars carry the exact busy time, and a screenshot is written.

Skipped, with the reason, only where Chromium or Playwright is missing (``.ci/run``
installs Chromium; Playwright is in the ``dev`` extra).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("bokeh", reason="the view needs bokeh (pip install netcosim[view])")
pytest.importorskip("playwright", reason="the browser tests need playwright (pip install playwright)")

from netcosim.view import segments as sg  # noqa: E402
from netcosim.view.headless import chromium_path, open_view  # noqa: E402

pytestmark = pytest.mark.skipif(chromium_path() is None,
                                reason="no Chromium at /usr/bin/chromium (apt-get install chromium; .ci/run does)")

#: JavaScript: the drawn quads of the named renderers, as columns.
QUADS_JS = """(names) => { const out = {}; for (const m of Bokeh.documents[0]._all_models.values())
  if (m.name && names.includes(m.name)) { const d = m.data_source.data;
    out[m.name] = {left: [...d.left], right: [...d.right], bottom: [...d.bottom], alpha: [...d.alpha]}; }
  return out; }"""


def _overlapping(seg, t0, t1):
    return seg[(seg["end"] > t0) & (seg["start"] < t1)]


@pytest.fixture(scope="module")
def threeservos(tmp_path_factory):
    from netcosim.experiments.threeservos import build
    sim = build()
    sim.run(until=1.0)
    out = tmp_path_factory.mktemp("view3")
    path = sim.trace.view(out / "threeservos.html", signals=["servo1.y.y", "servo2.y.y", "servo3.y.y"],
                         max_glyphs=200)
    return sim, path


def test_threeservos_page_draws_every_task_segment_and_zooms(threeservos, tmp_path):
    sim, path = threeservos
    seg = sg.task_segments(sim.trace.schedule(), sim.trace.jobs(), t_end=1.0)
    with open_view(path) as page:
        assert page.errors == []
        drawn = page.drawn()
        assert drawn["rows"]["tasks"] == 3
        assert drawn["range"] == [0.0, 1.0]
        signal_lines = {k for k in drawn["glyphs"] if k.startswith("signal:")}
        assert signal_lines == {"signal:servo1.y.y", "signal:servo2.y.y", "signal:servo3.y.y"}
        # 1 s of the three loops is 850 intervals, more than max_glyphs=200: zoomed out the page aggregates
        assert len(seg) == 850
        assert sum(drawn["glyphs"][f"task:{s}"] for s in ("running", "ready", "blocked")) <= 3 * 3 * 800
        # the aggregated bars carry the exact busy time: sum of fraction x bin width per task
        quads = page.page.evaluate(QUADS_JS, ["task:running"])["task:running"]
        w = 1.0 / 800
        frac = (np.array(quads["alpha"]) - 0.15) / 0.85
        rows = {"cpu.pid3": 0, "cpu.pid2": 1, "cpu.pid1": 2}        # top row first
        run = seg[seg["state"] == "running"]
        for label, row in rows.items():
            got = float(np.sum(frac[np.array(quads["bottom"]) == row]) * w)
            want = float((run.loc[run["label"] == label, "end"] - run.loc[run["label"] == label, "start"]).sum())
            assert got == pytest.approx(want, rel=1e-9)
        # a wheel zoom over the task panel narrows the visible range
        page.page.mouse.move(650, 110)
        n = drawn["updates"]
        page.page.mouse.wheel(0, -600)
        page.wait_updates(n + 1)
        zoomed = page.drawn()["range"]
        assert zoomed[1] - zoomed[0] < 0.9 and 0.0 <= zoomed[0] < zoomed[1] <= 1.0
        # zoomed in to 20 ms: every interval in the window drawn exactly
        exact = page.set_range(0.10, 0.12)
        for state in ("running", "ready", "blocked"):
            want = _overlapping(seg[seg["state"] == state], 0.10, 0.12)
            assert exact["glyphs"][f"task:{state}"] == len(want)
        shot = page.screenshot(tmp_path / "threeservos.png")
    assert shot.stat().st_size > 10_000 and shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert page.errors == []


def test_networked_servo_page_draws_every_frame_attempt_by_outcome(tmp_path):
    from netcosim.experiments.networked_servo import build
    sim, _ = build("csma_cd", 0.6)
    sim.run(until=1.5)
    path = sim.trace.view(tmp_path / "networked.html", signals=["servo.y.y", "sensor.actuate.u"])
    att = sg.frame_attempts(sim.trace.frame("frames"))
    busy = sg.medium_busy(att)
    assert len(att) < 4000                     # few enough to be drawn exactly over the whole run
    with open_view(path) as page:
        assert page.errors == []
        drawn = page.drawn()
        assert drawn["rows"] == {"tasks": 4, "network net": 4}   # 4 tasks; 3 senders and the medium
        for outcome in sg.FRAME_OUTCOMES:
            assert drawn["glyphs"][f"frame:net:{outcome}"] == int((att["outcome"] == outcome).sum())
        assert drawn["glyphs"]["frame:net:collided"] > 10
        assert drawn["glyphs"]["busy:net:medium busy"] == len(busy)
        assert {k for k in drawn["glyphs"] if k.startswith("signal:")} == {"signal:servo.y.y",
                                                                         "signal:sensor.actuate.u"}
        narrow = page.set_range(0.5, 0.55)
        assert narrow["range"] == [0.5, 0.55]
        assert sum(narrow["glyphs"][f"frame:net:{o}"] for o in sg.FRAME_OUTCOMES) == len(_overlapping(att, 0.5, 0.55))
        shot = page.screenshot(tmp_path / "networked.png")
        assert page.errors == []
    assert shot.stat().st_size > 10_000


def test_sweep_page_and_a_linked_run_load_without_errors(tmp_path):
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parent))
    import sweep_scenarios

    from netcosim.sweep import run_sweep
    res = run_sweep(sweep_scenarios.servo_traced, {"share": [0.0, 0.6], "until": [0.2]}, seeds=2,
                    out=tmp_path / "sw", executor="serial")
    page_path = res.view()
    with open_view(page_path, wait_update=False) as page:
        assert page.errors == []
        assert page.drawn()["glyphs"]["runs"] == 4
        urls = page.page.evaluate("""() => [...Bokeh.documents[0]._all_models.values()]
            .find(m => m.name === "runs").data_source.data.url""")
        # a click on a run selects it and runs the tap tool's callback: a new tab with its timeline
        with page.page.context.expect_page() as opened:
            page.page.evaluate("""() => { const ms = [...Bokeh.documents[0]._all_models.values()];
                const runs = ms.find(m => m.name === "runs"), tap = ms.find(m => m.type === "TapTool"
                    || (m.callback && m.callback.type === "OpenURL") || (m.callback && m.callback.url));
                runs.data_source.selected.indices = [2];
                tap.callback.execute(runs.data_source, {source: runs.data_source}); }""")
        assert opened.value.url.endswith("/sw/" + urls[2])
    assert len(urls) == 4 and all((tmp_path / "sw" / u).is_file() for u in urls)
    with open_view(tmp_path / "sw" / urls[0]) as run:
        assert run.errors == [] and run.drawn()["rows"]["tasks"] == 3
