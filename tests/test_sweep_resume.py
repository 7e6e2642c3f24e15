"""A sweep killed with SIGKILL mid-way and resumed: no finished run lost, no corrupt file,
exactly the missing runs executed, the same table as a sweep never interrupted.  Also the
``netcosim sweep`` command: grid values, exit status, ``--resume``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pandas.testing as pdt
import pytest
import sweep_scenarios as sc

from netcosim.cli import grid_value, main, parse_grid
from netcosim.sweep import load_sweep, run_sweep

ROOT = Path(__file__).resolve().parent.parent
TESTS = Path(__file__).resolve().parent
GRID = {"a": [0, 1, 2, 3], "b": [0, 1]}
SEEDS = 3
TOTAL = 4 * 2 * SEEDS


def _env(log: Path, sleep: str = "0") -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS), str(ROOT)]), "SWEEP_TEST_LOG": str(log),
            "SWEEP_TEST_SLEEP": sleep}


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


@pytest.mark.timeout(180)
def test_a_sweep_killed_with_sigkill_resumes_running_exactly_the_missing_runs(tmp_path, monkeypatch):
    out, log1, log2 = tmp_path / "sweep", tmp_path / "first.log", tmp_path / "resume.log"
    cmd = [sys.executable, "-m", "netcosim.cli", "sweep", "sweep_scenarios:logged", "--grid", "a=0,1,2,3",
           "--grid", "b=0,1", "--seeds", str(SEEDS), "--workers", "2", "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, env=_env(log1, sleep="0.2"), cwd=tmp_path, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while len(list((out / "parts").glob("run-*.parquet"))) < 5:
        assert proc.poll() is None, proc.stderr.read().decode() if proc.stderr else ""
        assert time.monotonic() < deadline, "the sweep wrote no 5 runs in 120 s"
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)          # the sweep and its workers, as a killed job
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    finished = sorted((out / "parts").glob("run-*.parquet"))
    k = len(finished)
    assert 5 <= k < TOTAL
    for part in finished:                        # every file on disk is complete
        assert len(pd.read_parquet(part)) == 1
    assert not (out / "runs.parquet").exists()
    assert len(load_sweep(out).runs) == k and load_sweep(out).summary["missing"] == TOTAL - k

    monkeypatch.setenv("SWEEP_TEST_LOG", str(log2))
    resumed = run_sweep(sc.logged, GRID, SEEDS, executor="serial", out=out, quiet=True)
    assert len(_lines(log2)) == TOTAL - k         # exactly the missing runs executed
    assert resumed.summary["skipped"] == k and resumed.summary["ok"] == TOTAL
    assert not list(out.rglob("*.tmp"))
    fresh = run_sweep(sc.cheap, GRID, SEEDS, executor="serial", quiet=True)
    pdt.assert_frame_equal(resumed.runs.drop(columns="wall_time"), fresh.runs.drop(columns="wall_time"))
    pdt.assert_frame_equal(resumed.table("trajectory"), fresh.table("trajectory"))


def test_grid_values_read_as_int_float_bool_or_text():
    assert [grid_value(v) for v in ["0", "-3", "0.1", "1e-3", "true", "False", "a", "0x1"]] == \
        [0, -3, 0.1, 1e-3, True, False, "a", "0x1"]
    assert type(grid_value("0")) is int and type(grid_value("2.0")) is float
    assert parse_grid(["loss=0,0.1,0.3", "strategy=a,b"]) == {"loss": [0, 0.1, 0.3], "strategy": ["a", "b"]}


def test_the_command_writes_the_dataset_exits_1_on_a_failed_run_and_resumes(tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    out = tmp_path / "ok"
    assert main(["sweep", "sweep_scenarios:cheap", "--grid", "a=1,2", "--grid", "b=0.5", "--seeds", "2",
                 "--root-seed", "4", "--executor", "serial", "--out", str(out), "--quiet"]) == 0
    assert "4 runs: 4 ok, 0 error, 0 timeout, 0 already done" in capsys.readouterr().out
    expected = run_sweep(sc.cheap, {"a": [1, 2], "b": [0.5]}, 2, root_seed=4, executor="serial", quiet=True)
    pdt.assert_frame_equal(pd.read_parquet(out / "runs.parquet").drop(columns="wall_time"),
                           expected.runs.drop(columns="wall_time"))
    (out / "parts" / "run-000001-000001.parquet").unlink()
    assert main(["sweep", "--resume", str(out), "--executor", "serial", "--quiet"]) == 0
    assert "4 runs: 4 ok, 0 error, 0 timeout, 3 already done" in capsys.readouterr().out
    bad = tmp_path / "bad"
    assert main(["sweep", "sweep_scenarios:flaky", "--grid", "mode=ok,raise", "--grid", "i=3",
                 "--executor", "serial", "--out", str(bad), "--quiet"]) == 1
    assert "2 runs: 1 ok, 1 error, 0 timeout" in capsys.readouterr().out


def test_the_command_answers_help():
    result = subprocess.run([sys.executable, "-m", "netcosim.cli", "sweep", "--help"], capture_output=True,
                            text=True, env=_env(Path(os.devnull)), timeout=60)
    assert result.returncode == 0
    for option in ("--grid", "--seeds", "--root-seed", "--executor", "--scheduler", "--workers", "--timeout",
                   "--out", "--resume", "--fresh", "--quiet"):
        assert option in result.stdout
