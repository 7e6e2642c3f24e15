"""Bad input to every ``netcosim`` command: one line on stderr naming the value, exit status 2,
no traceback (issue 23); and what ``run`` and ``plot network`` print and write.

The ``hil`` cases need no Zenoh: every one must fail before a session is opened (the
test replaces ``open_session`` by a function that fails the test).
"""

from __future__ import annotations

import sys

import pandas as pd
import pytest

from netcosim.cli import main

SCENARIO = "netcosim.experiments.networked_servo:build"      # nodes sensor, controller, interferer; plant servo (y; u)
NODE = [SCENARIO, "--remote", "controller", "--period", "0.01"]
PLANT = [SCENARIO, "--remote", "servo", "--period", "0.01"]


def _one_line_exit_2(argv, named, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2, (argv, code, err)
    assert len(lines) == 1, err
    assert "Traceback" not in err + out
    assert named in lines[0], (named, lines[0])
    return lines[0]


@pytest.fixture
def no_session(monkeypatch):
    import netcosim.transport.session as session

    def fail(*a, **kw):
        raise AssertionError("a Zenoh session was opened before the arguments were checked")
    monkeypatch.setattr(session, "open_session", fail)


@pytest.mark.parametrize("args, named", [
    (NODE + ["--factor", "0"], "--factor"),
    (NODE + ["--factor", "nan"], "nan"),
    (NODE + ["--lease", "0"], "--lease"),
    (NODE + ["--size-bits", "0"], "--size-bits"),
    (NODE[:-1] + ["0"], "--period"),
    (NODE[:-1] + ["-0.01"], "-0.01"),
    (PLANT + ["--outputs", "x"], "'x'"),
    (PLANT + ["--inputs", "x"], "'x'"),
    (PLANT + ["--outputs", ","], "--outputs ','"),
    (NODE + ["--listen", "x"], "--listen 'x'"),
    (NODE + ["--listen", "tcp/127.0.0.1"], "'tcp/127.0.0.1'"),
    (NODE + ["--connect", "tcp/127.0.0.1:0"], "--connect 'tcp/127.0.0.1:0'"),
    (NODE + ["--until", "-1"], "--until"),
    (NODE + ["--until", "nan"], "nan"),
    (NODE + ["--until", "0"], "--until"),
    (NODE + ["--deadline", "0"], "--deadline"),
    (NODE + ["--max-outstanding", "0"], "--max-outstanding"),
    (NODE + ["--reply-values", "-1"], "--reply-values"),
    (NODE + ["--wait", "-1"], "--wait"),
    (NODE + ["--remote-cmd", "'unclosed"], "--remote-cmd"),
    (NODE + ["--zenoh-config", "/no/such/zenoh.json5"], "'/no/such/zenoh.json5'"),
    (NODE + ["--out", "{file}/sub"], "{file}"),
])
def test_hil_rejects_bad_options_before_opening_a_session(args, named, tmp_path, capsys, no_session):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    args = [a.format(file=a_file) for a in args]
    _one_line_exit_2(["hil", *args], named.format(file=a_file), capsys)


def test_hil_rejects_an_unwritable_out(tmp_path, capsys, no_session):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        import os
        if os.access(locked, os.W_OK) and os.geteuid() == 0:
            pytest.skip("root writes in a read-only directory")
        _one_line_exit_2(["hil", *NODE, "--out", str(locked / "hil")], str(locked / "hil"), capsys)
    finally:
        locked.chmod(0o700)


STUDY = '''
def build(seed=0):
    return "a simulation"

def writes_nothing(outdir="never_written"):
    return {"answer": 42}

def needs_outdir(outdir):
    return None
'''


@pytest.fixture
def study(tmp_path, monkeypatch):
    (tmp_path / "my_study.py").write_text(STUDY)
    (tmp_path / "broken_study.py").write_text("def main(outdir='o'):\n    x = (\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    for name in ("my_study", "broken_study"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    return tmp_path


@pytest.mark.parametrize("args, named", [
    (["my_study.py:build"], "'my_study.py:build'"),
    (["my_study.py:needs_outdir"], "--outdir"),
    (["broken_study.py"], "broken_study.py:2"),
    (["srevo"], "'srevo'"),
    (["servo", "--outdir", "{file}/out"], "{file}"),
    (["servo", "--outdir", " "], "' '"),
])
def test_run_rejects_bad_input(study, args, named, capsys):
    a_file = study / "my_study.py"
    line = _one_line_exit_2(["run", *[a.format(file=a_file) for a in args]], named.format(file=a_file), capsys)
    if args == ["srevo"]:
        assert "did you mean 'servo'?" in line
        assert "networked_servo" in line and "hil_servo_controller" not in line


def test_run_says_what_it_ran_when_nothing_was_written(study, capsys):
    assert main(["run", "my_study.py:writes_nothing"]) == 0
    out = capsys.readouterr().out
    assert "my_study.writes_nothing()" in out and "{'answer': 42}" in out and "wrote no file to never_written" in out


def test_run_servo_says_where_it_wrote(tmp_path, capsys):
    out = tmp_path / "servo"
    assert main(["run", "servo", "--quick", "--outdir", str(out)]) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    assert len(printed) == 1 and printed[0].endswith(f"to {out}"), printed
    assert "netcosim.experiments.servo.main(" in printed[0] and "quick=True" in printed[0]
    assert (out / "schedule.parquet").is_file()


def test_a_scenario_with_a_syntax_error_is_one_line(tmp_path, monkeypatch, capsys, no_session):
    (tmp_path / "broken_scenario.py").write_text("def build():\n    return [\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.delitem(sys.modules, "broken_scenario", raising=False)
    _one_line_exit_2(["hil", "broken_scenario.py:build", "--remote", "x"], "broken_scenario.py:2", capsys)


def test_run_from_python_keeps_no_stale_module(study, capsys):
    _one_line_exit_2(["run", "broken_study.py"], "broken_study.py", capsys)
    assert "broken_study" not in sys.modules


def _schedule_frame(**columns) -> pd.DataFrame:
    frame = {"time": [0.0, 0.002, 0.010, 0.012], "node": "cpu", "task": "t",
             "state": ["running", "idle", "running", "idle"]}
    frame.update(columns)
    return pd.DataFrame(frame)


def _network_trace(directory):
    """A small simulated network trace (IdealLink a -> b, half the frames lost) written by to_parquet."""
    from conftest import lossy_link
    lossy_link().trace.to_parquet(directory)
    return directory / "network_schedule.parquet"


@pytest.mark.parametrize("kind, frame, options, named", [
    ("schedule", {"state": ["running", "idle", "sleeping", "idle"]}, [], "'sleeping'"),
    ("schedule", {"time": ["0", "0.002", "0.010", "0.012"]}, [], "'0'"),
    ("schedule", {"time": [0.0, float("nan"), 0.01, 0.012]}, [], "nan"),
    ("schedule", {}, ["-o", "{tmp}/no_such_folder/s.png"], "no_such_folder"),
    ("schedule", {}, ["-o", ""], "''"),
    ("schedule", {}, ["--network", "link"], "--network"),
    ("schedule", {}, ["--t0", "0.02"], "(0.02, None)"),
    ("network", {"network": "link", "state": ["sending", "idle", "sending", "asleep"]}, [], "'asleep'"),
    ("network", {"network": ["x", "x", "y", "y"], "state": "idle"}, [], "--network"),
    ("network", {"network": "link", "state": "idle"}, ["--network", "lnk"], "'lnk'"),
    ("network", {"network": "link", "state": "idle"}, ["--node", "gpu"], "'gpu'"),
    ("network", {}, [], "['network']"),
])
def test_plot_rejects_bad_input(kind, frame, options, named, tmp_path, capsys):
    trace = tmp_path / "trace.parquet"
    _schedule_frame(**frame).to_parquet(trace)
    out = tmp_path / "p.png"
    options = [o.format(tmp=tmp_path) for o in options]
    _one_line_exit_2(["plot", kind, str(trace), "-o", str(out), *options], named, capsys)
    assert not out.exists()


def test_plot_t0_alone_plots_to_the_end(tmp_path, capsys):
    trace = tmp_path / "trace.parquet"
    _schedule_frame().to_parquet(trace)
    assert main(["plot", "schedule", str(trace), "-o", str(tmp_path / "s.png"), "--t0", "0.005"]) == 0
    assert (tmp_path / "s.png").stat().st_size > 1000


def test_plot_network_draws_a_simulated_trace(tmp_path, monkeypatch, capsys):
    import netcosim.network.plot as network_plot
    trace = _network_trace(tmp_path / "trace")
    drawn = []
    real = network_plot.plot_network_schedule

    def spy(*a, **kw):
        ax = real(*a, **kw)
        drawn.append([t.get_text() for t in ax.get_legend().get_texts()])
        return ax
    monkeypatch.setattr(network_plot, "plot_network_schedule", spy)
    out = tmp_path / "network.png"
    assert main(["plot", "network", str(trace), "-o", str(out), "--t1", "0.01"]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 5_000
    assert "frame lost" in drawn[0]          # the frames.parquet next to the trace adds the markers
    (tmp_path / "trace" / "frames.parquet").unlink()
    assert main(["plot", "network", str(trace), "-o", str(out), "--node", "a"]) == 0
    assert "frame lost" not in drawn[1]


# --- the audit's CLI cases --------------------------------------------------------------------

SCEN = '''
def fn(params, seed):
    return {"J": 1.0}

def main(outdir):
    return None
'''


@pytest.fixture
def scen(tmp_path, monkeypatch):
    (tmp_path / "audit_scen.py").write_text(SCEN)
    _schedule_frame().to_parquet(tmp_path / "some.parquet")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.delitem(sys.modules, "audit_scen", raising=False)
    return tmp_path


@pytest.mark.parametrize("args, named", [
    (["run", "netcosim.cli:UsageError", "--outdir", "o"], "an experiment is a function main(outdir"),
    (["run", "netcosim.errors:NetcosimError"], "'netcosim.errors:NetcosimError' is a class"),
    (["run", "some.parquet"], "'some.parquet' is not a Python file"),
    (["run", "{tmp}/some.parquet:main"], "some.parquet' is not a Python file"),
    (["hil", "{tmp}/some.parquet:fn", "--remote", "controller", "--period", "0.01"],
     "some.parquet' is not a Python file"),
    (["hil", "audit_scen.py:fn", "--remote", "controller", "--period", "0.01"], "build() -> Simulation"),
    (["hil", "audit_scen.py:main", "--remote", "controller", "--period", "0.01"], "signature (outdir)"),
])
def test_run_and_hil_refuse_what_is_not_an_entry_point(scen, args, named, capsys, no_session):
    _one_line_exit_2([a.format(tmp=scen) for a in args], named, capsys)


@pytest.mark.parametrize("kind, options, named", [
    ("schedule", ["--t0", "-1", "--t1", "-0.5"], "time span 0.0 to 0.012 s"),
    ("schedule", ["--t0", "5", "--t1", "6"], "time span 0.0 to 0.012 s"),
    ("network", ["--t0", "0", "--t1", "1e-15"], "time resolution"),
    ("schedule", ["-o", "{tmp}/noext"], "'{tmp}/noext' has no file extension"),
    ("schedule", ["-o", "{tmp}/.png"], "has no file extension"),
])
def test_plot_refuses_an_empty_window_and_a_name_without_extension(kind, options, named, tmp_path, capsys):
    trace = tmp_path / "trace.parquet"
    _schedule_frame(**({"network": "link", "state": ["sending", "idle", "sending", "idle"]}
                       if kind == "network" else {})).to_parquet(trace)
    options = [o.format(tmp=tmp_path) for o in options]
    if "-o" not in options:
        options += ["-o", str(tmp_path / "p.png")]
    _one_line_exit_2(["plot", kind, str(trace), *options], named.format(tmp=tmp_path), capsys)
    assert not (tmp_path / "p.png").exists() and not (tmp_path / "noext").exists()


@pytest.mark.parametrize("slash", ["", "/"])
def test_plot_into_a_folder_writes_kind_png_there(tmp_path, capsys, slash):
    trace = tmp_path / "trace.parquet"
    _schedule_frame().to_parquet(trace)
    folder = tmp_path / "images"
    folder.mkdir()
    assert main(["plot", "schedule", str(trace), "-o", f"{folder}{slash}"]) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["schedule.png"]


def test_python_dash_m_netcosim_is_the_command():
    import subprocess
    from pathlib import Path
    r = subprocess.run([sys.executable, "-m", "netcosim", "--help"], capture_output=True, text=True, timeout=120,
                       cwd=Path(__file__).resolve().parents[1])
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("usage: netcosim")
