"""``netcosim.sweep``: seeds from what a run is, the same table on every executor, failures
recorded, the Parquet dataset on disk and resuming it.

The scenarios are in ``tests/sweep_scenarios.py`` (worker processes import them by name).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pandas.testing as pdt
import pytest
import sweep_scenarios as sc

from netcosim.errors import ConfigurationError
from netcosim.sweep import SweepResult, load_sweep, run_sweep
from netcosim.sweep.seeds import run_seed

GRID = {"a": [0, 1, 2, 3, 4], "b": [0.0, 0.5, 1.0, 1.5]}


def _same(r1: SweepResult, r2: SweepResult) -> None:
    pdt.assert_frame_equal(r1.runs.drop(columns="wall_time"), r2.runs.drop(columns="wall_time"))


def test_the_run_table_holds_each_case_and_seed_in_grid_order_with_the_scenarios_values():
    res = run_sweep(sc.cheap, {"a": [2, 1], "b": [0.5]}, seeds=3, root_seed=7, executor="serial", quiet=True)
    df = res.runs
    assert list(df.columns) == ["a", "b", "seed_index", "seed", "x", "draw", "label", "status", "error",
                                "traceback", "wall_time"]
    assert df["a"].tolist() == [2, 2, 2, 1, 1, 1] and df["seed_index"].tolist() == [0, 1, 2, 0, 1, 2]
    for row in df.itertuples():
        params = {"a": row.a, "b": row.b}
        assert row.seed == run_seed(7, params, row.seed_index)
        expected = sc.cheap(params, row.seed)
        assert row.x == expected["x"] and row.draw == expected["draw"] and row.label == expected["label"]
    assert (df["status"] == "ok").all() and df["error"].isna().all() and (df["wall_time"] > 0).all()
    assert res.summary == {"total": 6, "ok": 6, "error": 0, "timeout": 0, "skipped": 0, "missing": 0, "nan": 0}
    assert res.to_pandas() is res.runs
    traj = res.table("trajectory")
    assert list(traj.columns) == ["a", "b", "seed_index", "seed", "k", "v"] and len(traj) == 18
    first = sc.cheap({"a": 2, "b": 0.5}, int(df["seed"].iloc[0]))["trajectory"]
    np.testing.assert_array_equal(traj["v"].iloc[:3], first["v"])
    with pytest.raises(KeyError, match="'nope'"):
        res.table("nope")


def test_a_runs_seed_depends_on_root_seed_parameters_and_index_only():
    assert run_seed(0, {"a": 1, "b": 0.5}, 3) == run_seed(0, {"b": 0.5, "a": 1}, 3)     # order of keys
    seeds = {run_seed(r, p, i) for r in (0, 1) for p in ({"a": 1}, {"a": 2}, {"a": 1.0}) for i in (0, 1)}
    assert len(seeds) == 12 and all(0 <= s < 2**63 for s in seeds)
    # adding a case and a seed changes no other run
    small = run_sweep(sc.cheap, {"a": [0, 1], "b": [0.0]}, seeds=2, executor="serial", quiet=True).runs
    big = run_sweep(sc.cheap, {"a": [5, 0, 1], "b": [0.0]}, seeds=3, executor="serial", quiet=True).runs
    kept = big[(big["a"] != 5) & (big["seed_index"] < 2)].reset_index(drop=True)
    pdt.assert_frame_equal(small.drop(columns="wall_time"), kept.drop(columns="wall_time"))


def test_explicit_seeds_are_used_as_given_for_every_case():
    df = run_sweep(sc.cheap, {"a": [0, 1], "b": [0.0]}, seeds=[11, 5], executor="serial", quiet=True).runs
    assert df["seed"].tolist() == [11, 5, 11, 5] and df["seed_index"].tolist() == [0, 1, 0, 1]
    assert df["x"].iloc[0] == sc.cheap({"a": 0, "b": 0.0}, 11)["x"]


def test_grids_as_product_list_and_dataframe_give_the_same_runs():
    as_dict = run_sweep(sc.cheap, {"a": [0, 1], "b": [0.0, 0.5]}, 2, executor="serial", quiet=True)
    cases = [{"a": a, "b": b} for a in (0, 1) for b in (0.0, 0.5)]
    as_list = run_sweep(sc.cheap, cases, 2, executor="serial", quiet=True)
    as_frame = run_sweep(sc.cheap, pd.DataFrame(cases), 2, executor="serial", quiet=True)
    _same(as_dict, as_list)
    _same(as_dict, as_frame)


def test_serial_and_a_two_worker_pool_give_identical_tables():
    serial = run_sweep(sc.cheap, GRID, 3, executor="serial", quiet=True)
    pool = run_sweep(sc.cheap, GRID, 3, executor="pool", workers=2, quiet=True)
    assert len(serial.runs) == 60
    _same(serial, pool)
    pdt.assert_frame_equal(serial.table("trajectory"), pool.table("trajectory"))


@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_a_raising_run_a_bad_return_and_a_timeout_are_recorded_and_the_others_complete(executor):
    cases = [{"mode": m, "i": i} for i, m in enumerate(["ok", "raise", "ok", "hang", "list", "ok"])]
    res = run_sweep(sc.flaky, cases, 1, executor=executor, workers=2, timeout=2.0, quiet=True)
    df = res.runs
    assert df["status"].tolist() == ["ok", "error", "ok", "timeout", "error", "ok"]
    assert df.loc[df["status"] == "ok", "value"].tolist() == [0, 4, 10]
    assert df["error"].iloc[1] == "FloatingPointError: diverged at case 1"
    assert "sweep_scenarios.py" in df["traceback"].iloc[1] and "raise FloatingPointError" in df["traceback"].iloc[1]
    assert "scenario returned list [1, 2], not a dict of metrics" in df["error"].iloc[4]
    assert "timeout of 2 s" in df["error"].iloc[3] and df["wall_time"].iloc[3] == 2.0
    assert res.summary == {"total": 6, "ok": 3, "error": 2, "timeout": 1, "skipped": 0, "missing": 0, "nan": 0}


def test_a_pool_worker_that_dies_records_its_run_and_is_replaced():
    cases = [{"mode": m, "i": i} for i, m in enumerate(["ok", "die", "ok", "ok", "die", "ok"])]
    res = run_sweep(sc.flaky, cases, 1, executor="pool", workers=2, quiet=True)
    assert res.runs["status"].tolist() == ["ok", "error", "ok", "ok", "error", "ok"]
    assert res.runs["error"].iloc[1] == "the worker process died during the run (exit code 3)"
    assert res.runs["value"].iloc[[0, 2, 3, 5]].tolist() == [0, 4, 6, 10]


def test_a_script_without_a_main_guard_gets_an_error_not_a_hang(tmp_path):
    import subprocess
    import sys

    script = tmp_path / "unguarded.py"
    script.write_text("from netcosim.sweep import run_sweep\n"
                      "def f(params, seed):\n    return {'x': 1}\n"
                      "run_sweep(f, {'a': [1, 2]}, 1, workers=1, quiet=True)\n")
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert 'under `if __name__ == "__main__":`' in result.stderr


def test_each_run_is_followed_by_a_collection_so_cycles_left_behind_are_freed():
    import gc

    sc.REFS.clear()
    full = []

    def count(phase, info):
        if phase == "start" and info["generation"] == 2:
            full.append(len(sc.REFS))

    gc.callbacks.append(count)
    try:
        res = run_sweep(sc.cyclic, {"i": [0, 1, 2]}, 2, executor="serial", quiet=True)
    finally:
        gc.callbacks.remove(count)
    assert res.summary["ok"] == 6 and len(sc.REFS) == 6
    assert {1, 2, 3, 4, 5, 6} <= set(full)          # a full collection after each run
    assert all(ref() is None for ref in sc.REFS)


def test_the_progress_bar_counts_runs_and_failures_on_a_terminal(monkeypatch):
    import io
    import sys

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    cases = [{"mode": m, "i": i} for i, m in enumerate(["ok", "raise", "ok"])]
    run_sweep(sc.flaky, cases, 2, executor="serial")
    text = term.getvalue()
    assert "6/6" in text and "failed=2" in text
    quiet = Terminal()
    monkeypatch.setattr(sys, "stderr", quiet)
    run_sweep(sc.flaky, cases, 2, executor="serial", quiet=True)
    assert quiet.getvalue() == ""


def test_the_dataset_on_disk_reads_back_and_a_rerun_skips_every_finished_run(tmp_path):
    out = tmp_path / "sweep"
    res = run_sweep(sc.cheap, {"a": [0, 1], "b": [0.5]}, 2, executor="serial", out=out, quiet=True)
    assert sorted(p.name for p in (out / "parts").iterdir()) == [
        "run-000000-000000.parquet", "run-000000-000001.parquet", "run-000001-000000.parquet",
        "run-000001-000001.parquet"]
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["scenario"] == "sweep_scenarios:cheap" and meta["root_seed"] == 0 and meta["seeds"] == 2
    assert meta["cases"] == [{"a": 0, "b": 0.5}, {"a": 1, "b": 0.5}] and len(meta["scenario_sha256"]) == 64
    pdt.assert_frame_equal(pd.read_parquet(out / "runs.parquet"), res.runs)
    loaded = load_sweep(out)
    pdt.assert_frame_equal(loaded.runs, res.runs)
    pdt.assert_frame_equal(loaded.table("trajectory"), res.table("trajectory"))
    (out / "parts" / ".run-000000-000000.parquet.dead.tmp").write_bytes(b"half a file")   # a killed write
    again = run_sweep(sc.cheap, {"a": [0, 1], "b": [0.5]}, 2, executor="serial", out=out, quiet=True)
    assert again.summary["skipped"] == 4 and again.summary["ok"] == 4
    assert not list(out.rglob("*.tmp"))
    pdt.assert_frame_equal(again.runs, res.runs)


def test_a_directory_holding_another_sweep_is_refused_naming_the_difference_or_started_fresh(tmp_path):
    out = tmp_path / "sweep"
    run_sweep(sc.cheap, {"a": [0, 1], "b": [0.5]}, 2, executor="serial", out=out, quiet=True)
    with pytest.raises(ConfigurationError, match="holds a different sweep: cases differs"):
        run_sweep(sc.cheap, {"a": [0, 2], "b": [0.5]}, 2, executor="serial", out=out, quiet=True)
    with pytest.raises(ConfigurationError, match="root_seed differs .stored 0, now 3."):
        run_sweep(sc.cheap, {"a": [0, 1], "b": [0.5]}, 2, root_seed=3, executor="serial", out=out, quiet=True)
    with pytest.raises(ConfigurationError, match="scenario differs"):
        run_sweep(sc.logged, {"a": [0, 1], "b": [0.5]}, 2, executor="serial", out=out, quiet=True)
    res = run_sweep(sc.cheap, {"a": [0, 2], "b": [0.5]}, 1, executor="serial", out=out, fresh=True, quiet=True)
    assert res.summary["skipped"] == 0 and len(list((out / "parts").iterdir())) == 2
    assert load_sweep(out).runs["a"].tolist() == [0, 2]


SCRIPT = """
from netcosim.sweep import run_sweep

def square(params, seed):
    return {"y": params["x"] ** 2, "seed_mod": seed % 1000}

if __name__ == "__main__":
    import sys
    res = run_sweep(square, {"x": [1, 2, 3]}, 2, executor=sys.argv[1], workers=2, quiet=True)
    print(res.runs["y"].tolist(), res.runs["seed_mod"].tolist())
"""


def test_a_scenario_in_a_file_or_in_the_running_script_runs_on_the_pool(tmp_path):
    import subprocess
    import sys

    script = tmp_path / "study.py"
    script.write_text(SCRIPT)
    by_file = run_sweep(f"{script}:square", {"x": [1, 2, 3]}, 2, executor="pool", workers=2, quiet=True)
    assert by_file.runs["y"].tolist() == [1, 1, 4, 4, 9, 9]
    assert by_file.meta["scenario"] == "study:square" and by_file.meta["scenario_file"] == str(script)
    expected = f"{by_file.runs['y'].tolist()} {by_file.runs['seed_mod'].tolist()}"
    for executor in ("serial", "pool"):            # the function defined in __main__
        out = subprocess.run([sys.executable, str(script), executor], capture_output=True, text=True, timeout=120,
                             cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        assert out.stdout.strip() == expected
