"""The sweep store's integrity: every file's SHA-256 recorded when it is written and
checked on ``load_sweep``, ``netcosim sweep verify`` and resume (which re-runs the
damaged runs); one sweep at a time in a directory (the lock); ``--retry-errors``;
grid validation before any run; one column type per parameter in every file; the
scenario's identity ignoring comments and docstrings; the messages of a resume.

The scenarios are in ``tests/sweep_scenarios.py`` (worker processes import them by name).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pandas.testing as pdt
import pytest
import sweep_scenarios as sc

from netcosim.cli import main
from netcosim.sweep import load_sweep, run_sweep, verify_sweep
from netcosim.sweep.store import DamagedSweepError

TESTS = Path(__file__).resolve().parent
GRID = {"a": [0, 1], "b": [0.5, 1.5]}


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
    fresh = run_sweep(sc.cheap, GRID, 1, executor="serial", quiet=True)
    pdt.assert_frame_equal(load_sweep(out).table("trajectory"), fresh.table("trajectory"))
