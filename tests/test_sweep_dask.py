"""``netcosim.sweep`` on Dask: the same table as serially and on the pool, a given client
or a local cluster, an unreachable scheduler refused within a bounded time.

One ``LocalCluster`` (2 single-threaded worker processes) serves the module.
"""

from __future__ import annotations

import socket

import pandas.testing as pdt
import pytest
import sweep_scenarios as sc

from netcosim.errors import ConfigurationError
from netcosim.sweep import run_sweep

distributed = pytest.importorskip("distributed")

GRID = {"a": [0, 1, 2, 3, 4], "b": [0.0, 0.5, 1.0, 1.5]}


@pytest.fixture(scope="module")
def client():
    from netcosim.sweep.executors import local_cluster

    cluster = local_cluster(2)
    c = distributed.Client(cluster, set_as_default=False)
    yield c
    c.close()
    cluster.close()


def test_serial_pool_and_dask_give_identical_tables_for_a_5x4_grid_and_3_seeds(client):
    serial = run_sweep(sc.cheap, GRID, 3, executor="serial", quiet=True)
    pool = run_sweep(sc.cheap, GRID, 3, executor="pool", workers=2, quiet=True)
    dask = run_sweep(sc.cheap, GRID, 3, executor=client, quiet=True)
    assert len(serial.runs) == 60 and (serial.runs["status"] == "ok").all()
    for other in (pool, dask):
        pdt.assert_frame_equal(serial.runs.drop(columns="wall_time"), other.runs.drop(columns="wall_time"))
        pdt.assert_frame_equal(serial.table("trajectory"), other.table("trajectory"))


def test_errors_and_a_timeout_on_dask_are_recorded(client, tmp_path):
    cases = [{"mode": m, "i": i} for i, m in enumerate(["ok", "raise", "hang", "ok"])]
    res = run_sweep(sc.flaky, cases, 1, executor=client, timeout=3.0, out=tmp_path / "s", quiet=True)
    assert res.runs["status"].tolist() == ["ok", "error", "timeout", "ok"]
    assert res.runs["error"].iloc[1] == "FloatingPointError: diverged at case 1"
    assert client.status == "running"          # a given client stays open


def test_a_scheduler_address_is_used_and_the_client_closed(client):
    address = client.scheduler.address
    res = run_sweep(sc.cheap, {"a": [1], "b": [0.5]}, 2, scheduler=address, quiet=True)
    serial = run_sweep(sc.cheap, {"a": [1], "b": [0.5]}, 2, executor="serial", quiet=True)
    pdt.assert_frame_equal(serial.runs.drop(columns="wall_time"), res.runs.drop(columns="wall_time"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.timeout(60)
def test_an_unreachable_scheduler_is_refused_naming_its_address_before_any_run(tmp_path, monkeypatch):
    monkeypatch.setattr("netcosim.sweep.executors.CONNECT_TIMEOUT", 2.0)
    address = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(ConfigurationError, match=f"cannot reach the Dask scheduler '{address}' within 2 s"):
        run_sweep(sc.cheap, {"a": [1], "b": [0.5]}, 1, scheduler=address, out=tmp_path / "s", quiet=True)
    assert not (tmp_path / "s").exists()


def test_executor_dask_starts_a_local_cluster_and_closes_it():
    import threading

    def open_clients():
        return {id(c) for c in list(distributed.Client._instances) if c.status not in ("closed", "closing")}
    before, clients_before = threading.active_count(), open_clients()
    res = run_sweep(sc.cheap, {"a": [1, 2], "b": [0.5]}, 2, executor="dask", workers=2, quiet=True)
    serial = run_sweep(sc.cheap, {"a": [1, 2], "b": [0.5]}, 2, executor="serial", quiet=True)
    pdt.assert_frame_equal(serial.runs.drop(columns="wall_time"), res.runs.drop(columns="wall_time"))
    assert open_clients() == clients_before    # the sweep's own client is closed (others stay open)
    assert threading.active_count() <= before + 2


def test_a_cluster_in_the_callers_process_leaves_its_heap_unfrozen(monkeypatch):
    """A Dask worker process freezes its own heap after loading the scenario (its imports stay
    out of every later collection); a worker that is a thread of the caller's process
    (``LocalCluster(processes=False)``) must not freeze the caller's heap for good."""
    import gc

    from netcosim.sweep import executors
    monkeypatch.setattr(executors, "_loaded", {})         # the scenario is loaded (and the freeze tried) anew
    before = gc.get_freeze_count()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) \
            as cluster, distributed.Client(cluster, set_as_default=False) as c:
        res = run_sweep(sc.cheap, {"a": [1, 2], "b": [0.5]}, 2, executor=c, quiet=True)
    assert (res.runs["status"] == "ok").all() and len(res.runs) == 4
    assert gc.get_freeze_count() == before
