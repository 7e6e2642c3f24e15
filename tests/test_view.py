"""The view's shared definition of what is drawn (segments), the trace-event export and its
round trip, the HTML files (self-contained, no server), the sweep page and the CLI.  The
pages in a real browser: tests/test_view_browser.py."""

from __future__ import annotations

import collections
import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from netcosim import Simulation
from netcosim.cli import main
from netcosim.view import segments as sg
from netcosim.view.chrome_trace import check_chrome_trace, chrome_trace_events

pytest.importorskip("bokeh", reason="the view needs bokeh (pip install netcosim[view])")


def _two_tasks(until=0.1):
    """Rate-monotonic: a (2 ms every 5 ms, priority 1) preempts b (3 ms every 10 ms)."""
    sim = Simulation()
    cpu = sim.node("cpu")

    def work(c):
        def body(ctx):
            yield ctx.execute(c)
        return body
    cpu.periodic(work(0.002), period=0.005, priority=1, name="a")
    cpu.periodic(work(0.003), period=0.010, priority=2, name="b")
    sim.run(until=until)
    return sim


def test_task_segments_follow_the_known_schedule():
    sim = _two_tasks(0.01)
    seg = sg.task_segments(sim.trace.schedule(), sim.trace.jobs(), t_end=0.01)
    run = seg[seg["state"] == "running"]
    got = [(lab, round(s, 9), round(e, 9), j) for lab, s, e, j in zip(run["label"], run["start"], run["end"],
                                                                       run["job"])]
    # a runs [0, 2) and [5, 7) ms; b runs [2, 5) ms: not preempted (a's second job comes at 5 ms)
    assert got == [("cpu.a", 0.0, 0.002, 0), ("cpu.b", 0.002, 0.005, 0), ("cpu.a", 0.005, 0.007, 1)]
    ready = seg[seg["state"] == "ready"]
    assert [(lab, round(s, 9), round(e, 9)) for lab, s, e in zip(ready["label"], ready["start"], ready["end"])] \
        == [("cpu.b", 0.0, 0.002)]
    assert set(seg["level"]) <= {0.5, 0.25, 0.125}


def test_frame_attempts_classify_each_attempt_and_the_medium_busy_periods_join_them():
    rows = [  # time, frame, event, src, dst, node, attempt, outcome
        (0.0, 1, "attempt_start", "s", "c", "s", 1, ""), (1.0, 1, "attempt_end", "s", "c", "s", 1, "ok"),
        (1.0, 1, "delivered", "s", "c", "c", 1, ""),
        (0.5, 2, "attempt_start", "i", "k", "i", 1, ""), (1.5, 2, "attempt_end", "i", "k", "i", 1, "collision"),
        (2.0, 2, "attempt_start", "i", "k", "i", 2, ""), (3.0, 2, "attempt_end", "i", "k", "i", 2, "ok"),
        (3.0, 2, "lost", "i", "k", "k", 2, "bit_errors"),
        (5.0, 3, "attempt_start", "s", "c", "s", 1, ""), (6.0, 3, "attempt_end", "s", "c", "s", 1, "no_ack"),
        (6.5, 3, "attempt_start", "s", "c", "s", 2, ""), (7.0, 3, "attempt_end", "s", "c", "s", 2, "no_ack"),
        (7.0, 3, "lost", "s", "c", "s", 2, "retry_limit"),
    ]
    fr = pd.DataFrame(rows, columns=["time", "frame", "event", "src", "dst", "node", "attempt", "outcome"])
    fr.insert(1, "network", "net")
    fr["bits"] = 80.0
    att = sg.frame_attempts(fr)
    assert list(zip(att["frame"], att["attempt"], att["outcome"])) == [
        (1, 1, "delivered"), (2, 1, "collided"), (2, 2, "lost"), (3, 1, "retried"), (3, 2, "dropped")]
    busy = sg.medium_busy(att)
    assert list(zip(busy["start"], busy["end"], busy["frames"])) == [(0.0, 1.5, 2), (2.0, 3.0, 1), (5.0, 6.0, 1),
                                                                      (6.5, 7.0, 1)]


def test_marks_name_deadline_misses_overruns_watchdogs_and_hil_events():
    jobs = pd.DataFrame({"node": ["n", "n"], "task": ["t", "t"], "job": [0, 1], "release": [0.0, 1.0],
                         "deadline": [0.5, 1.5], "start": [0.0, 1.0], "finish": [0.4, 1.7],
                         "deadline_miss": [False, True], "budget_overrun": [False, True]})
    sig = pd.DataFrame({"time": [0.2, 0.3], "source": ["n.w", "n.w"], "signal": ["watchdog_zero", "u"],
                        "value": [1.0, 2.0]})
    hil = pd.DataFrame({"time": [0.9], "node": ["r"], "event": ["expired"], "detail": ["late"], "count": [2]})
    mk = sg.marks({"jobs": jobs, "signals": sig, "hil": hil})
    assert list(zip(mk["time"], mk["kind"], mk["where"])) == [
        (0.2, "watchdog", "n.w"), (0.9, "hil", "r"), (1.5, "deadline_miss", "n.t"), (1.7, "budget_overrun", "n.t")]


def _busy_from_export(events):
    names = {(e["pid"], e["tid"]): e["args"]["name"] for e in events if e["name"] == "thread_name"}
    procs = {e["pid"]: e["args"]["name"] for e in events if e["name"] == "process_name"}
    busy = collections.Counter()
    for e in events:
        if e["ph"] == "X" and e.get("cat") == "running":
            busy[(procs[e["pid"]].removeprefix("node "), names[(e["pid"], e["tid"])])] += e["dur"] / 1e6
    return busy


def test_chrome_trace_validates_and_its_busy_time_equals_the_jobs_table(tmp_path):
    from netcosim.experiments.threeservos import build
    sim = build()
    sim.run(until=1.0)
    path = sim.trace.to_chrome_trace(tmp_path / "run.json")
    doc = json.loads(path.read_text())
    assert check_chrome_trace(doc) == len(doc["traceEvents"]) > 1000
    busy = _busy_from_export(doc["traceEvents"])
    jobs = sim.trace.jobs()
    want = jobs.groupby(["node", "task"], observed=True)["execution_time"].sum()
    assert set(busy) == {(str(n), str(t)) for n, t in want.index} == {("cpu", "pid1"), ("cpu", "pid2"),
                                                                       ("cpu", "pid3")}
    for (n, t), v in want.items():
        assert busy[(str(n), str(t))] == pytest.approx(v, rel=1e-9, abs=1e-12)
    # pid3 runs 2 ms every 4 ms, pid2 2 ms every 5 ms... the known utilisations of the three loops
    assert busy[("cpu", "pid3")] == pytest.approx(0.5, abs=1e-12)
    counters = [e for e in doc["traceEvents"] if e["ph"] == "C"]
    assert len(counters) == int(np.isfinite(sim.trace.signals()["value"]).sum())


def test_chrome_trace_has_a_track_per_network_sender_and_one_for_the_medium():
    from netcosim.experiments.networked_servo import build
    sim, _ = build("csma_cd", 0.6)
    sim.run(until=0.5)
    tables = {n: sim.trace.frame(n) for n in ("schedule", "jobs", "frames", "signals")}
    events = chrome_trace_events(tables)
    check_chrome_trace(events)
    att = sg.frame_attempts(tables["frames"])
    net_pid = next(e["pid"] for e in events if e["name"] == "process_name" and e["args"]["name"] == "network net")
    threads = {e["args"]["name"] for e in events if e["name"] == "thread_name" and e["pid"] == net_pid}
    assert threads == {"sensor", "controller", "interferer", "medium"}
    frames = [e for e in events if e["ph"] == "X" and e["pid"] == net_pid and e["cat"] != "medium"]
    assert collections.Counter(e["cat"] for e in frames) == collections.Counter(att["outcome"])
    assert (att["outcome"] == "collided").sum() > 10          # share 0.6 on CSMA/CD collides


@pytest.mark.parametrize("bad, why", [
    ([{"ph": "X", "ts": 0, "pid": 1, "name": "x", "dur": 1}], "lacks ['tid']"),
    ([{"ph": "X", "ts": 0, "pid": 1, "tid": 1, "name": "x", "dur": -1}], "dur -1"),
    ([{"ph": "X", "ts": 5, "pid": 1, "tid": 1, "name": "x", "dur": 1},
      {"ph": "X", "ts": 4, "pid": 1, "tid": 1, "name": "y", "dur": 1}], "comes before"),
    ([{"ph": "i", "ts": float("nan"), "pid": 1, "tid": 1, "name": "x"}], "finite"),
])
def test_check_chrome_trace_refuses_a_bad_trace(bad, why):
    with pytest.raises(ValueError, match=why.replace("[", r"\[").replace("]", r"\]")):
        check_chrome_trace(bad)


def test_view_html_is_self_contained_and_holds_every_row(tmp_path):
    sim = _two_tasks(0.1)
    path = sim.trace.view(tmp_path / "v.html", title="two tasks")
    html = path.read_text()
    assert "<script src=" not in html and "cdn.bokeh.org" not in html   # BokehJS inlined: opens offline
    assert "Bokeh" in html and "two tasks" in html
    seg = sg.task_segments(sim.trace.schedule())
    assert len(seg) == 20 + 10 + 10     # 20 jobs of a running, 10 of b running, 10 ready intervals of b


def test_view_refuses_an_unknown_signal_and_bad_options(tmp_path):
    from netcosim.errors import ConfigurationError, ConfigurationTypeError
    sim = _two_tasks(0.02)
    with pytest.raises(ConfigurationError, match="no signal 'x.y': the run logged no signal"):
        sim.trace.view(tmp_path / "v.html", signals=["x.y"])
    with pytest.raises(ConfigurationTypeError, match="bins must be a positive integer, got 0"):
        sim.trace.view(tmp_path / "v.html", bins=0)
    with pytest.raises(ConfigurationError, match="does not exist"):
        sim.trace.view(tmp_path / "missing" / "v.html")


def test_import_netcosim_does_not_import_bokeh():
    code = ("import sys, netcosim, netcosim.plot, netcosim.view, netcosim.trace; "
            "print('bokeh' in sys.modules, 'playwright' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_cli_view_writes_the_page_and_the_trace_events(tmp_path, capsys):
    sim = _two_tasks(0.05)
    sim.trace.to_parquet(tmp_path, prefix="r_")
    assert main(["view", str(tmp_path / "r_schedule.parquet"), "--chrome-trace", str(tmp_path / "r.json"),
                 "-o", str(tmp_path / "r.html"), "--t0", "0.01", "--t1", "0.02"]) == 0
    assert capsys.readouterr().out.split() == [str(tmp_path / "r.json"), str(tmp_path / "r.html")]
    assert check_chrome_trace(json.loads((tmp_path / "r.json").read_text())) > 0
    assert main(["view", str(tmp_path / "r_schedule.parquet")]) == 0
    assert (tmp_path / "r_view.html").is_file()


@pytest.mark.parametrize("args, message", [
    (["view", "nowhere"], "no such file or directory"),
    (["view", "{tmp}", "--t0", "2", "--t1", "1"], "empty or reversed time window"),
    (["view", "{tmp}"], "no trace table in"),
    (["view", "{tmp}/x.parquet"], "not a trace table file"),
])
def test_cli_view_bad_arguments_exit_2_naming_them(tmp_path, capsys, args, message):
    (tmp_path / "x.parquet").write_text("")
    assert main([a.replace("{tmp}", str(tmp_path)) for a in args]) == 2
    assert message in capsys.readouterr().err


def test_sweep_view_links_each_run_with_a_kept_trace(tmp_path):
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
    import sweep_scenarios

    from netcosim.sweep import run_sweep
    res = run_sweep(sweep_scenarios.servo_traced, {"share": [0.0, 0.6], "until": [0.2], "keep_trace": [True]},
                    seeds=2, out=tmp_path / "sw", executor="serial")
    page = res.view()
    assert page == tmp_path / "sw" / "view.html"
    runs = sorted(p.name for p in (tmp_path / "sw" / "runs").iterdir())
    assert runs == ["run-000000-000000.html", "run-000000-000001.html", "run-000001-000000.html",
                    "run-000001-000001.html"]
    html = page.read_text()
    assert all(f"runs/{r}" in html for r in runs)
    bare = run_sweep(sweep_scenarios.servo_traced, {"share": [0.0], "until": [0.1], "keep_trace": [False]},
                     seeds=1, out=tmp_path / "bare", executor="serial")
    assert main(["view", str(bare.path)]) == 0
    assert not (tmp_path / "bare" / "runs").exists() and (tmp_path / "bare" / "view.html").is_file()
