"""The sweep store's integrity: every file's SHA-256 recorded when it is written and
checked on ``load_sweep``, ``netcosim sweep verify`` and resume (which re-runs the
damaged runs); one sweep at a time in a directory (the lock); ``--retry-errors``;
grid validation before any run; one column type per parameter in every file; the
scenario's identity ignoring comments and docstrings; the messages of a resume.

The scenarios are in ``tests/sweep_scenarios.py`` (worker processes import them by name).
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pandas.testing as pdt
import pytest
import sweep_scenarios as sc

from netcosim.cli import main
from netcosim.errors import ConfigurationError
from netcosim.sweep import load_sweep, run_sweep, verify_sweep
from netcosim.sweep.store import DamagedSweepError, SweepLockedError

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent
GRID = {"a": [0, 1], "b": [0.5, 1.5]}


# --- scenarios (worker processes import them from this file) ------------------------
def gated(params, seed):
    """Returns at once for a == 0; the other runs wait until the file $SWEEP_TEST_GATE exists."""
    gate = os.environ.get("SWEEP_TEST_GATE")
    if gate and params["a"] > 0:
        while not os.path.exists(gate):
            time.sleep(0.01)
    return {"y": params["a"] * 2}


def fails_while_flagged(params, seed):
    """Raises for a == 1 while the file $SWEEP_TEST_FLAG exists; an int metric and a table."""
    flag = os.environ.get("SWEEP_TEST_FLAG")
    if params["a"] == 1 and flag and os.path.exists(flag):
        raise RuntimeError("flag is set")
    return {"y": params["a"] * 10 + seed % 7, "ok": True, "t": pd.DataFrame({"k": [0, 1]})}


def interrupted(params, seed):
    """Ctrl-C during the run with a == 1."""
    if params["a"] == 1:
        raise KeyboardInterrupt
    return {"y": params["a"]}


def checked(params, seed):
    return {"y": params["loss"]}


def _check_loss(params):
    if not 0 <= params["loss"] <= 1:
        raise ValueError(f"loss must be a probability in [0, 1], got {params['loss']}")


checked.validate = _check_loss


def lossy(params, seed):
    return {"n": 3, "err": pd.DataFrame({"t": [0.0, 0.1], "e": [params["loss"], 1.0]})}


def _flip(path: Path, at: float = 0.5) -> None:
    data = bytearray(path.read_bytes())
    i = int(len(data) * at)
    data[i] ^= 0x01
    path.write_bytes(bytes(data))


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _loaded_equal(x: Path, y: Path) -> None:
    rx, ry = load_sweep(x), load_sweep(y)
    pdt.assert_frame_equal(rx.runs.drop(columns="wall_time"), ry.runs.drop(columns="wall_time"))
    for name in rx.table_names:
        pdt.assert_frame_equal(rx.table(name), ry.table(name))
    assert ry.table_names == rx.table_names
    pdt.assert_frame_equal(pd.read_parquet(x / "runs.parquet").drop(columns="wall_time"),
                           pd.read_parquet(y / "runs.parquet").drop(columns="wall_time"))


def test_a_flipped_byte_or_a_truncated_file_is_found_by_load_verify_and_resume_which_restores_it(
        tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    untouched, damaged = tmp_path / "untouched", tmp_path / "damaged"
    for out in (untouched, damaged):
        run_sweep(sc.cheap, GRID, 2, executor="serial", out=out, quiet=True)
    assert verify_sweep(untouched) == [] and verify_sweep(damaged) == []
    _flip(damaged / "parts" / "run-000001-000001.parquet")          # case 1 {a: 0, b: 1.5}, seed 1
    _truncate(damaged / "tables" / "trajectory" / "run-000002-000000.parquet")   # case 2 {a: 1, b: 0.5}, seed 0
    _flip(damaged / "runs.parquet", at=0.3)

    with pytest.raises(DamagedSweepError) as info:
        load_sweep(damaged)
    err = info.value
    assert err.keys == [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1), (3, 0), (3, 1)]   # runs.parquet holds all
    assert sorted(d.file for d in err.damage) == ["parts/run-000001-000001.parquet", "runs.parquet",
                                                  "tables/trajectory/run-000002-000000.parquet"]
    text = str(err)
    assert 'parts/run-000001-000001.parquet' in text and 'case 1 {"a": 0, "b": 1.5} seed_index 1' in text
    assert 'case 2 {"a": 1, "b": 0.5} seed_index 0' in text and "--resume" in text

    capsys.readouterr()
    assert main(["sweep", "verify", str(untouched)]) == 0
    assert capsys.readouterr().out.startswith(f"ok: {untouched}: 8 runs")
    assert main(["sweep", "verify", str(damaged)]) == 1
    out = capsys.readouterr().out
    assert out.startswith(f"damaged: {damaged}: 3 file(s)")
    assert "tables/trajectory/run-000002-000000.parquet: SHA-256 differs" in out and "seed_index 0" in out

    assert main(["sweep", "--resume", str(damaged), "--executor", "serial", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "3 damaged file(s)" in captured.err and "re-running 2 run(s)" in captured.err
    assert "resuming: 2 of 8 runs to do" in captured.err
    assert "8 runs: 8 ok, 0 error, 0 timeout, 6 already done" in captured.out
    assert verify_sweep(damaged) == []
    _loaded_equal(untouched, damaged)
    for f in sorted((untouched / "tables").rglob("*.parquet")):      # the tables again bit for bit
        assert (damaged / f.relative_to(untouched)).read_bytes() == f.read_bytes()


def test_a_deleted_table_file_and_an_unreadable_part_are_damage_too(tmp_path):
    out = tmp_path / "sweep"
    run_sweep(sc.cheap, GRID, 1, executor="serial", out=out, quiet=True)
    (out / "tables" / "trajectory" / "run-000003-000000.parquet").unlink()
    (out / "parts" / "run-000000-000000.parquet").write_bytes(b"not parquet at all")
    damage = {d.file: d for d in verify_sweep(out)}
    assert set(damage) == {"tables/trajectory/run-000003-000000.parquet", "parts/run-000000-000000.parquet"}
    assert damage["tables/trajectory/run-000003-000000.parquet"].reason == "missing"
    assert damage["parts/run-000000-000000.parquet"].keys == ((0, 0),)
    with pytest.raises(DamagedSweepError, match="cannot be read"):
        load_sweep(out, verify=False)
    messages: list[str] = []
    res = run_sweep(sc.cheap, GRID, 1, executor="serial", out=out, quiet=True, notify=messages.append)
    assert res.summary["skipped"] == 2 and res.summary["ok"] == 4
    assert "re-running 2 run(s)" in messages[0] and verify_sweep(out) == []
    assert sorted(d.file for d in res.repaired) == ["parts/run-000000-000000.parquet",
                                                    "tables/trajectory/run-000003-000000.parquet"]
    fresh = run_sweep(sc.cheap, GRID, 1, executor="serial", quiet=True)
    pdt.assert_frame_equal(load_sweep(out).table("trajectory"), fresh.table("trajectory"))


def _env(**extra) -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS), str(ROOT)]), **extra}


def test_a_second_sweep_into_a_live_directory_stops_at_once_naming_the_owner(tmp_path, capsys):
    out, gate = tmp_path / "sweep", tmp_path / "gate"
    cmd = [sys.executable, "-m", "netcosim.cli", "sweep", "test_sweep_integrity:gated", "--grid", "a=0,1,2",
           "--seeds", "2", "--executor", "serial", "--out", str(out), "--quiet"]
    first = subprocess.Popen(cmd, env=_env(SWEEP_TEST_GATE=str(gate)), cwd=tmp_path, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        while len(list((out / "parts").glob("run-*.parquet"))) < 2:      # the a == 0 runs; the others wait
            assert first.poll() is None, first.communicate()
            time.sleep(0.01)
        owner = json.loads((out / "sweep.lock").read_text())
        assert owner["pid"] == first.pid and owner["host"] == socket.gethostname()
        with pytest.raises(SweepLockedError, match=f"in use by another sweep: process {first.pid} on host"):
            run_sweep(gated, {"a": [0, 1, 2]}, 2, executor="serial", out=out, quiet=True)
        assert main(["sweep", "--resume", str(out), "--executor", "serial", "--quiet"]) == 2
        assert f"process {first.pid}" in capsys.readouterr().err
        partial = load_sweep(out)                                      # readers take no lock
        assert partial.summary["missing"] == 4 and verify_sweep(out) == []
    finally:
        gate.touch()
        stdout, stderr = first.communicate(timeout=120)
    assert first.returncode == 0, stderr
    assert "6 runs: 6 ok, 0 error, 0 timeout, 0 already done" in stdout
    assert not (out / "sweep.lock").exists() and verify_sweep(out) == []
    assert load_sweep(out).runs["y"].tolist() == [0, 0, 2, 2, 4, 4]


def test_a_stale_lock_of_a_dead_process_is_taken_over_one_of_another_host_is_not(tmp_path):
    out = tmp_path / "sweep"
    run_sweep(sc.cheap, GRID, 1, executor="serial", out=out, quiet=True)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (out / "sweep.lock").write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname()}))
    res = run_sweep(sc.cheap, GRID, 2, executor="serial", out=out, quiet=True, fresh=True)
    assert res.summary["ok"] == 8 and not (out / "sweep.lock").exists()
    (out / "sweep.lock").write_text(json.dumps({"pid": dead.pid, "host": "elsewhere.example"}))
    with pytest.raises(SweepLockedError, match="on host 'elsewhere.example'.*delete"):
        run_sweep(sc.cheap, GRID, 2, executor="serial", out=out, quiet=True)


def test_the_lock_is_released_on_ctrl_c_and_the_command_says_how_to_resume(tmp_path, capsys):
    out = tmp_path / "sweep"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(interrupted, {"a": [0, 1, 2]}, 1, executor="serial", out=out, quiet=True)
    assert not (out / "sweep.lock").exists() and len(list((out / "parts").iterdir())) == 1
    capsys.readouterr()
    assert main(["sweep", f"{__file__}:interrupted", "--grid", "a=0,1,2", "--executor", "serial", "--out",
                 str(out), "--quiet"]) == 130
    err = capsys.readouterr().err.strip()
    assert err.splitlines() == [f"netcosim sweep: resuming: 2 of 3 runs to do ({out})",
                                f"netcosim sweep: interrupted; the 1 finished runs are kept in {out}; resume "
                                f"with: netcosim sweep --resume {out}"]
    assert not (out / "sweep.lock").exists()


def test_retry_errors_runs_the_failed_runs_again_and_int_metrics_stay_ints(tmp_path, monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(TESTS))
    out, flag = tmp_path / "sweep", tmp_path / "flag"
    flag.touch()
    monkeypatch.setenv("SWEEP_TEST_FLAG", str(flag))
    grid = {"a": [0, 1, 2]}
    res = run_sweep(fails_while_flagged, grid, 2, executor="serial", out=out, quiet=True)
    assert res.runs["status"].tolist() == ["ok", "ok", "error", "error", "ok", "ok"]
    for runs in (res.runs, load_sweep(out).runs, pd.read_parquet(out / "runs.parquet")):
        assert str(runs["y"].dtype) == "Int64" and str(runs["ok"].dtype) == "boolean"   # not float, not object
        assert runs["y"].isna().tolist() == [False, False, True, True, False, False]
    flag.unlink()
    again = run_sweep(fails_while_flagged, grid, 2, executor="serial", out=out, quiet=True)
    assert again.summary["skipped"] == 6 and again.summary["error"] == 2          # an error is a result
    messages: list[str] = []
    retried = run_sweep(fails_while_flagged, grid, 2, executor="serial", out=out, quiet=True, retry_errors=True,
                        notify=messages.append)
    assert retried.summary == {"total": 6, "ok": 6, "error": 0, "timeout": 0, "skipped": 4, "missing": 0, "nan": 0}
    assert messages == ["retrying 2 run(s) that failed (error or timeout)", f"resuming: 2 of 6 runs to do ({out})"]
    expected = run_sweep(fails_while_flagged, grid, 2, executor="serial", quiet=True)
    loaded = load_sweep(out)
    assert loaded.runs["y"].dtype == "int64" and loaded.runs["ok"].dtype == bool
    pdt.assert_frame_equal(loaded.runs.drop(columns="wall_time"), expected.runs.drop(columns="wall_time"))
    pdt.assert_frame_equal(loaded.table("t"), expected.table("t"))
    assert verify_sweep(out) == []
    # the command line
    flag.touch()
    cli_out = tmp_path / "cli"
    args = ["sweep", "test_sweep_integrity:fails_while_flagged", "--grid", "a=0,1", "--executor", "serial",
            "--out", str(cli_out), "--quiet"]
    assert main(args) == 1
    flag.unlink()
    assert main(["sweep", "--resume", str(cli_out), "--executor", "serial", "--quiet"]) == 1
    assert main(["sweep", "--resume", str(cli_out), "--retry-errors", "--executor", "serial", "--quiet"]) == 0
    assert "2 runs: 2 ok, 0 error, 0 timeout, 1 already done" in capsys.readouterr().out


def test_every_case_is_validated_before_any_run_and_all_refusals_are_listed(tmp_path, capsys):
    out = tmp_path / "sweep"
    with pytest.raises(ConfigurationError) as info:
        run_sweep(checked, {"loss": [-0.1, 0, 0.5, 1.5]}, 3, executor="serial", out=out, quiet=True)
    text = str(info.value)
    assert text.startswith("2 of 4 grid cases are refused by the scenario's validate(); no run started")
    assert "case 0 {'loss': -0.1}: ValueError: loss must be a probability in [0, 1], got -0.1" in text
    assert "case 3 {'loss': 1.5}: ValueError: loss must be a probability in [0, 1], got 1.5" in text
    assert "case 1" not in text and not out.exists()
    assert main(["sweep", f"{__file__}:checked", "--grid", "loss=-0.2,0.1", "--executor", "serial",
                 "--out", str(out), "--quiet"]) == 2
    assert "case 0 {'loss': -0.2}" in capsys.readouterr().err and not out.exists()
    assert run_sweep(checked, {"loss": [0, 1]}, 1, executor="serial", quiet=True).summary["ok"] == 2


def test_a_grid_mixing_ints_and_floats_gets_one_float_column_in_every_file(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    out = tmp_path / "sweep"
    assert main(["sweep", "test_sweep_integrity:lossy", "--grid", "loss=0,0.1,0.3", "--seeds", "2",
                 "--executor", "serial", "--out", str(out), "--quiet"]) == 0
    err = pd.read_parquet(out / "tables" / "err")                     # as docs/sweeps.md shows
    runs = pd.read_parquet(out / "runs.parquet")
    assert err["loss"].dtype == "float64" and runs["loss"].dtype == "float64"
    assert err["loss"].tolist() == [0.0] * 4 + [0.1] * 4 + [0.3] * 4
    pdt.assert_frame_equal(load_sweep(out).table("err"), err)
    for f in (out / "parts").iterdir():
        assert pd.read_parquet(f)["loss"].dtype == "float64"
    # a str parameter with None in a case: one string column
    cases = [{"loss": 0.5, "label": None}, {"loss": 0.5, "label": "x"}]
    run_sweep(lossy, cases, 1, executor="serial", out=tmp_path / "none", quiet=True)
    label = pd.read_parquet(tmp_path / "none" / "tables" / "err")["label"]
    assert label.isna().tolist() == [True, True, False, False] and label.iloc[2] == "x"


SCENARIO = '''"""A study."""

def f(params, seed):
    """One run."""
    return {"y": params["a"] * 2}   # doubled
'''


def test_comments_and_docstrings_do_not_change_the_scenario_code_does_and_resuming_is_announced(tmp_path, capsys):
    script, out = tmp_path / "study.py", tmp_path / "sweep"
    script.write_text(SCENARIO)
    args = ["sweep", f"{script}:f", "--grid", "a=1,2", "--executor", "serial", "--out", str(out), "--quiet"]
    assert main(args) == 0
    capsys.readouterr()
    script.write_text(SCENARIO.replace("# doubled", "# twice a, see the notes").replace("One run.", "Run once.")
                      .replace('"y": params', '"y" :  params') + "\n\n# the end\n")
    assert main(args) == 0
    assert f"netcosim sweep: 2 of 2 runs already done; nothing to run ({out})" in capsys.readouterr().err
    (out / "parts" / "run-000001-000000.parquet").unlink()
    assert main(["sweep", "--resume", str(out), "--executor", "serial", "--quiet"]) == 0
    assert f"netcosim sweep: resuming: 1 of 2 runs to do ({out})" in capsys.readouterr().err
    script.write_text(SCENARIO.replace("* 2", "* 3"))
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"holds a different sweep: the scenario's code changed: {script} (f changed)" in err
    assert "--fresh" in err


def test_ctrl_c_on_the_command_prints_one_line_and_exits_130_and_resume_completes(tmp_path):
    import signal

    out, gate = tmp_path / "sweep", tmp_path / "gate"
    cmd = [sys.executable, "-m", "netcosim.cli", "sweep", "test_sweep_integrity:gated", "--grid", "a=0,1",
           "--seeds", "2", "--executor", "serial", "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, env=_env(SWEEP_TEST_GATE=str(gate)), cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    while len(list((out / "parts").glob("run-*.parquet"))) < 2:      # the a == 0 runs; then it waits
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130
    assert stderr.strip() == (f"netcosim sweep: interrupted; the 2 finished runs are kept in {out}; resume with: "
                              f"netcosim sweep --resume {out}")
    assert not (out / "sweep.lock").exists() and verify_sweep(out) == []
    gate.touch()
    result = subprocess.run([sys.executable, "-m", "netcosim.cli", "sweep", "--resume", str(out), "--executor",
                             "serial", "--quiet"], env=_env(SWEEP_TEST_GATE=str(gate)), cwd=tmp_path,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "4 runs: 4 ok, 0 error, 0 timeout, 2 already done" in result.stdout
    assert f"resuming: 2 of 4 runs to do ({out})" in result.stderr


def test_a_sweep_written_without_digests_is_read_but_not_continued_without_fresh(tmp_path, capsys):
    out = tmp_path / "sweep"
    run_sweep(sc.cheap, GRID, 1, executor="serial", out=out, quiet=True)
    meta = json.loads((out / "sweep.json").read_text())
    (out / "sweep.json").write_text(json.dumps({**meta, "format": 1}))
    (out / "digests.jsonl").unlink()
    assert len(load_sweep(out).runs) == 4
    with pytest.raises(ConfigurationError, match="holds a sweep of format 1, written by an earlier netcosim"):
        run_sweep(sc.cheap, GRID, 1, executor="serial", out=out, quiet=True)
    assert main(["sweep", "verify", str(out)]) == 2
    assert "cannot be verified" in capsys.readouterr().err
    assert run_sweep(sc.cheap, GRID, 1, executor="serial", out=out, quiet=True, fresh=True).summary["ok"] == 4
    assert verify_sweep(out) == []
