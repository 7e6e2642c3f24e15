"""The executor seam: a user-written :class:`~netcosim.sweep.SweepExecutor` (a thread pool,
written here from the base's contract alone) runs a sweep whose stored dataset is the
serial executor's bit for bit, resumes an interrupted sweep, and a non-executor is
refused naming it.  The plug-in below is the one ``docs/sweeps.md`` shows.
"""

from __future__ import annotations

import hashlib
import inspect
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import pandas as pd
import pytest
import sweep_scenarios as sc

from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.sweep import PoolExecutor, SerialExecutor, SweepExecutor, load_sweep, run_sweep

GRID = {"a": [0, 1, 2], "b": [0, 1]}
SEEDS = 3
TOTAL = 3 * 2 * SEEDS


class ThreadExecutor(SweepExecutor):
    """Runs the tasks on a pool of threads of this process."""

    in_process = True                  # a lambda may be swept: nothing is sent to another process

    def __init__(self, threads: int = 4):
        self.threads = threads

    def start(self):
        self.pool = ThreadPoolExecutor(self.threads)

    def close(self):
        self.pool.shutdown(cancel_futures=True)

    def run(self, tasks):
        futures = {self.pool.submit(self.run_task, params, seed): index for index, params, seed in tasks}
        for future in as_completed(futures):
            yield futures[future], future.result()


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _same_dataset(d1: Path, d2: Path) -> None:
    """The two sweep directories hold the same results bit for bit: sweep.json and every
    table file byte for byte, the run table's every column but ``wall_time`` (a
    measurement, also in the run files) value for value, floats by their bits."""
    assert _digest(d1 / "sweep.json") == _digest(d2 / "sweep.json")
    t1 = sorted(p.relative_to(d1) for p in (d1 / "tables").rglob("*.parquet"))
    assert t1 == sorted(p.relative_to(d2) for p in (d2 / "tables").rglob("*.parquet")) and len(t1) == TOTAL
    for rel in t1:
        assert _digest(d1 / rel) == _digest(d2 / rel), rel
    assert sorted(p.name for p in (d1 / "parts").iterdir()) == sorted(p.name for p in (d2 / "parts").iterdir())
    r1, r2 = (pd.read_parquet(d / "runs.parquet").drop(columns="wall_time") for d in (d1, d2))
    assert list(r1.columns) == list(r2.columns) and list(r1.dtypes) == list(r2.dtypes)
    for col in r1.columns:
        v1, v2 = r1[col].to_numpy(), r2[col].to_numpy()
        if v1.dtype.kind == "f":
            assert v1.tobytes() == v2.tobytes(), col
        else:
            assert r1[col].equals(r2[col]), col


def test_the_plugin_is_a_few_dozen_lines_and_is_the_one_docs_sweeps_md_shows():
    source = inspect.getsource(ThreadExecutor)
    assert len([line for line in source.splitlines() if line.strip()]) == 13   # non-blank, docstring included
    docs = (Path(__file__).resolve().parent.parent / "docs" / "sweeps.md").read_text()
    assert source in docs and "A thread pool, 13 lines" in docs


def test_a_user_written_thread_executor_stores_the_serial_executors_dataset_bit_for_bit(tmp_path):
    serial, threads = tmp_path / "serial", tmp_path / "threads"
    run_sweep(sc.cheap, GRID, SEEDS, root_seed=7, executor="serial", out=serial, quiet=True)
    res = run_sweep(sc.cheap, GRID, SEEDS, root_seed=7, executor=ThreadExecutor(3), out=threads, quiet=True)
    assert res.summary["ok"] == TOTAL
    _same_dataset(serial, threads)


def test_the_builtin_executors_are_objects_too_and_the_strings_their_shorthands(tmp_path):
    run_sweep(sc.cheap, GRID, SEEDS, executor="serial", out=tmp_path / "s", quiet=True)
    run_sweep(sc.cheap, GRID, SEEDS, executor=SerialExecutor(), out=tmp_path / "so", quiet=True)
    run_sweep(sc.cheap, GRID, SEEDS, executor=PoolExecutor(workers=2), out=tmp_path / "po", quiet=True)
    _same_dataset(tmp_path / "s", tmp_path / "so")
    _same_dataset(tmp_path / "s", tmp_path / "po")


class _Interrupted(ThreadExecutor):
    """Ctrl-C after five runs were stored."""

    def run(self, tasks):
        for n, item in enumerate(super().run(tasks)):
            if n == 5:
                raise KeyboardInterrupt
            yield item


def test_an_interrupted_sweep_on_the_plugin_resumes_running_exactly_the_missing_runs(tmp_path, monkeypatch):
    out, log = tmp_path / "sweep", tmp_path / "runs.log"
    monkeypatch.setenv("SWEEP_TEST_LOG", str(log))
    with pytest.raises(KeyboardInterrupt):
        run_sweep(sc.logged, GRID, SEEDS, executor=_Interrupted(2), out=out, quiet=True)
    assert len(list((out / "parts").glob("run-*.parquet"))) == 5
    assert not (out / "sweep.lock").exists()
    kept = load_sweep(out).runs
    log.unlink()
    messages = []
    res = run_sweep(sc.logged, GRID, SEEDS, executor=ThreadExecutor(2), out=out, notify=messages.append)
    assert res.summary["skipped"] == 5 and res.summary["ok"] == TOTAL
    assert messages == [f"resuming: {TOTAL - 5} of {TOTAL} runs to do ({out})"]
    ran = sorted(log.read_text().splitlines())
    done = sorted(f"{a} {b} {seed}" for a, b, seed in kept[["a", "b", "seed"]].itertuples(index=False))
    everything = sorted(f"{a} {b} {seed}" for a, b, seed in res.runs[["a", "b", "seed"]].itertuples(index=False))
    assert len(ran) == TOTAL - 5 and sorted(ran + done) == everything
    run_sweep(sc.logged, GRID, SEEDS, executor="serial", out=tmp_path / "serial", quiet=True)
    _same_dataset(out, tmp_path / "serial")       # as a sweep never interrupted

def test_an_in_process_plugin_sweeps_a_lambda():
    res = run_sweep(lambda p, s: {"y": p["a"] * 2}, {"a": [1, 2, 3]}, executor=ThreadExecutor(), quiet=True)
    assert list(res.runs["y"]) == [2, 4, 6]


class _DuckTyped:
    """Has run(tasks), but is not a SweepExecutor."""

    def run(self, tasks):
        return iter(())


@pytest.mark.parametrize("bad, named", [(object(), "object <object object at"), (_DuckTyped(), "_DuckTyped <"),
                                        (3, "int 3"), (ThreadExecutor, "the class ThreadExecutor itself")])
def test_a_non_executor_is_refused_naming_it(bad, named):
    with pytest.raises(ConfigurationTypeError, match="executor must be one of") as info:
        run_sweep(sc.cheap, GRID, executor=bad, quiet=True)
    assert named in str(info.value) and "SweepExecutor" in str(info.value)


def test_workers_with_an_executor_object_is_refused():
    with pytest.raises(ConfigurationError, match="workers=2 applies to the executors named by a string"):
        run_sweep(sc.cheap, GRID, executor=ThreadExecutor(), workers=2, quiet=True)


class _Forgetful(ThreadExecutor):
    """Reports every task but the last: a broken plug-in."""

    def run(self, tasks):
        yield from super().run(tasks[:-1])


class _Repeating(ThreadExecutor):
    """Reports the first task twice: a broken plug-in."""

    def run(self, tasks):
        index, params, seed = tasks[0]
        yield index, self.run_task(params, seed)
        yield index, self.run_task(params, seed)


@pytest.mark.parametrize("executor, message", [(_Forgetful(), "finished without reporting 1 of 18 runs"),
                                               (_Repeating(), "reported task 0, which it was not given or already")])
def test_a_plugin_breaking_the_contract_is_named_and_its_stored_runs_are_kept(tmp_path, executor, message):
    with pytest.raises(RuntimeError, match=f"executor {type(executor).__name__} .*{message}"):
        run_sweep(sc.cheap, GRID, SEEDS, executor=executor, out=tmp_path / "s", quiet=True)
    assert not (tmp_path / "s" / "sweep.lock").exists()
    res = run_sweep(sc.cheap, GRID, SEEDS, executor=ThreadExecutor(), out=tmp_path / "s", quiet=True)
    assert res.summary["ok"] == TOTAL and res.summary["skipped"] >= 1


def test_a_nan_metric_is_kept_counted_and_named_once():
    import math
    import warnings

    from netcosim.errors import NaNMetricWarning
    from netcosim.sweep import run_sweep

    def scenario(params, seed):
        return {"J": math.nan if params["a"] == 2 else 1.0, "ok": 1.0}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = run_sweep(scenario, {"a": [1, 2]}, seeds=3, executor="serial", quiet=True)
    notes = [w for w in caught if issubclass(w.category, NaNMetricWarning)]
    assert len(notes) == 1 and "'J' in 3 run(s)" in str(notes[0].message)
    assert res.summary["nan"] == 3 and res.summary["ok"] == 6
    assert res.runs["J"].isna().sum() == 3 and (res.runs["status"] == "ok").all()
    assert "6 ok (3 with a NaN metric)" in repr(res)
