"""Where the runs of a sweep execute: in this process, on a local process pool, on Dask,
or on any :class:`SweepExecutor` plug-in.

Every executor is a :class:`SweepExecutor`: its :meth:`~SweepExecutor.run` takes the
list of tasks ``(index, params, seed)`` and yields ``(index, Outcome)`` as runs finish,
in any order (the runner puts them back in grid order).  Each run is
:func:`~netcosim.sweep.run.run_one`, so the results do not depend on the executor.  The
built-in ones are :class:`SerialExecutor`, :class:`PoolExecutor` and
:class:`DaskExecutor`, named ``"serial"``, ``"pool"`` and ``"dask"`` in
:func:`~netcosim.sweep.run_sweep`.

The local pool is written here rather than taken from :mod:`concurrent.futures`:
``ProcessPoolExecutor`` cannot stop one run that exceeds its timeout (a running future
cannot be cancelled, and its worker cannot be told apart from the others to kill it).
Here each worker is a ``multiprocessing`` process with its own pipe; the pool hands a
worker one run at a time, so it knows which run each worker executes since when, and
on a timeout it kills that worker and starts a new one.  Workers use the ``spawn``
start method: they inherit nothing from the calling process (no threads, locks or
random state of the caller, which ``fork`` would copy), it is the one method on every
platform, and its start-up cost (a fresh interpreter importing netcosim, about a
second) is paid once per worker, not per run.  A worker that dies during a run (killed,
out of memory) records that run as an error and is replaced.

A run with a timeout on the serial or the Dask executor runs in a child process of its
own (``python -m netcosim.sweep._child``), killed when the timeout expires: a Python
thread cannot be stopped, and a Dask worker serves other runs.  That costs a process
start (about a second) per run; the pool has no such cost.
"""

from __future__ import annotations

import collections
import gc
import os
import pickle
import signal
import socket
import subprocess
import sys
import time
from typing import Any, Callable, Iterator

from .. import validate
from ..errors import ConfigurationError, NetcosimError
from .run import Outcome, run_one
from .scenario import ScenarioRef, resolve

__all__ = ["Task", "SweepExecutor", "SerialExecutor", "PoolExecutor", "DaskExecutor", "load", "run_in_child",
           "cpu_count", "CONNECT_TIMEOUT"]

#: One run to execute: ``(index, params, seed)``.
Task = tuple[int, dict[str, Any], int]

#: Seconds allowed to connect to a Dask scheduler before the sweep gives up.
CONNECT_TIMEOUT = 10.0

_loaded: dict[ScenarioRef, Callable] = {}


def cpu_count() -> int:
    """The number of CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:       # not on Linux
        return os.cpu_count() or 1


def load(ref: ScenarioRef) -> Callable:
    """The scenario *ref* names, loaded once per process (by module name, else from its file)."""
    fn = _loaded.get(ref)
    if fn is None:
        fn = _loaded[ref] = resolve(f"{ref.module}:{ref.function}", ref.file)
    return fn


def _workers(workers: Any) -> int:
    return validate.integer(workers, "workers", lo=1, kind="a number of worker processes (an integer >= 1)")


def _timeout_outcome(timeout: float) -> Outcome:
    return Outcome("timeout", error=f"the run did not finish within the timeout of {timeout:g} s",
                   wall_time=float(timeout))


def run_in_child(ref: ScenarioRef, params: dict[str, Any], seed: int, timeout: float) -> Outcome:
    """Run one task in a child process, killed after *timeout* seconds of running
    (the child's start-up and the scenario's import are not counted): the scenario at
    *ref* (a :class:`~netcosim.sweep.scenario.ScenarioRef`, imported in the child) with the
    case *params* and the run's *seed*.  Returns its outcome, or an error or timeout
    outcome."""
    payload = pickle.dumps((list(sys.path), ref, params, seed))
    proc = subprocess.Popen([sys.executable, "-m", "netcosim.sweep._child"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    assert proc.stdin is not None and proc.stdout is not None
    try:
        proc.stdin.write(payload)
        proc.stdin.close()
        proc.stdin = None           # communicate() below must not touch it again
        if proc.stdout.read(1) != b"R":
            proc.wait()
            return Outcome("error", error=f"the run's child process exited with status {proc.returncode} "
                                          f"before loading the scenario")
        try:
            out, _ = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            return _timeout_outcome(timeout)
        if proc.returncode != 0 or not out:
            return Outcome("error", error=f"the run's child process exited with status {proc.returncode}")
        outcome = pickle.loads(out)
        assert isinstance(outcome, Outcome)
        return outcome
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


class SweepExecutor:
    """Where the runs of a sweep execute: the base of every executor (``run_sweep(executor=...)``).

    A plug-in implements :meth:`run` and, if it holds resources (threads, a connection),
    :meth:`start` and :meth:`close`.  The base owns the rest:

    * the scenario: :func:`~netcosim.sweep.run_sweep` calls :meth:`bind` before
      :meth:`start`, setting ``self.fn`` (the function), ``self.ref`` (its
      :class:`~netcosim.sweep.scenario.ScenarioRef`, by which another process loads it;
      None for a lambda) and ``self.timeout`` (seconds per run, or None);
    * one run, :meth:`run_task`: the scenario called by
      :func:`~netcosim.sweep.run.run_one` in the calling thread, or in a child process
      killed at the timeout if there is one (a thread cannot be stopped);
    * the contract, :meth:`results`, what the runner iterates: every task reported once,
      as an :class:`~netcosim.sweep.run.Outcome`, none invented, none forgotten;
    * the life cycle: :meth:`start` is called before the output directory is touched (an
      executor that cannot start changes nothing), :meth:`close` always after the last run.

    ``in_process = True`` declares that :meth:`run` calls the scenario in this process (a
    thread pool): a lambda or a nested function may then be swept, as on the serial executor.

    Examples
    --------
    A plug-in running the tasks here, last first: the runner puts the results back in grid
    order, so the table is the serial one (``wall_time``, a measurement, aside).

    >>> from netcosim.sweep import SweepExecutor, run_sweep
    >>> class Backwards(SweepExecutor):
    ...     in_process = True                  # calls the scenario here: a nested function may be swept
    ...     def run(self, tasks):
    ...         for index, params, seed in reversed(tasks):
    ...             yield index, self.run_task(params, seed)
    >>> def draw(params, seed): return {"x": params["a"] + seed % 1000}
    >>> back = run_sweep(draw, {"a": [0, 1]}, seeds=2, executor=Backwards(), quiet=True)
    >>> serial = run_sweep(draw, {"a": [0, 1]}, seeds=2, executor="serial", quiet=True)
    >>> back.runs.drop(columns="wall_time").equals(serial.runs.drop(columns="wall_time"))
    True
    """

    #: True if :meth:`run` calls the scenario function in this process (threads).
    in_process: bool = False
    fn: Callable | None = None
    ref: ScenarioRef | None = None
    timeout: float | None = None

    def bind(self, fn: Callable, ref: ScenarioRef | None, timeout: float | None) -> None:
        """Set the scenario the next sweep runs (called by ``run_sweep`` before :meth:`start`):
        *fn*, the scenario function ``fn(**params, seed=...)``; *ref*, where it lives (a
        :class:`~netcosim.sweep.scenario.ScenarioRef`, for runs in other processes; None for an
        unimportable function run in this process); *timeout*, the limit (s) on one run's
        wall time, None: none."""
        self.fn, self.ref, self.timeout = fn, ref, timeout

    def start(self) -> None:
        """Acquire what :meth:`run` needs; raise naming what is wrong (nothing has run yet)."""

    def close(self) -> None:
        """Release what :meth:`start` acquired (called even if the sweep failed)."""

    def run(self, tasks: list[Task]) -> Iterator[tuple[int, Outcome]]:
        """Yield ``(index, outcome)`` for every task ``(index, params, seed)`` of *tasks*, in any order."""
        raise NotImplementedError(f"{type(self).__name__} must implement run(tasks)")

    def run_task(self, params: dict[str, Any], seed: int) -> Outcome:
        """One run of the bound scenario with the case *params* (parameter name -> value) and the
        run's *seed*, in this thread (in a child process if there is a timeout)."""
        if self.timeout is not None:
            assert self.ref is not None
            return run_in_child(self.ref, params, seed, self.timeout)
        assert self.fn is not None
        return run_one(self.fn, params, seed)

    def results(self, tasks: list[Task]) -> Iterator[tuple[int, Outcome]]:
        """:meth:`run`, checked: raises ``RuntimeError`` naming the executor if it reports a
        task it was not given, one twice, something that is not an ``Outcome``, or ends
        with tasks unreported (the runs reported so far are kept)."""
        left = {task[0] for task in tasks}
        name = type(self).__name__
        runs = self.run(tasks)
        try:
            for item in runs:
                if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], Outcome)):
                    raise RuntimeError(f"executor {name} yielded {item!r}, not (index, Outcome)")
                if item[0] not in left:
                    raise RuntimeError(f"executor {name} reported task {item[0]!r}, which it was not given "
                                       f"or already reported")
                left.discard(item[0])
                yield item
        finally:
            close = getattr(runs, "close", None)
            if close is not None:
                close()
        if left:
            raise RuntimeError(f"executor {name} finished without reporting {len(left)} of {len(tasks)} "
                               f"runs (task {min(left)} among them)")


class SerialExecutor(SweepExecutor):
    """Runs every task in this process, one after another (timed runs in a child process);
    ``executor="serial"``.  The one built-in executor that runs a scenario typed in a
    session, a lambda or a nested function (without a ``timeout``).

    Examples
    --------
    100 messages over a link that loses frames with probability p, two values of p, two
    seeds each, the runs stored in a directory: about ``100 (1 - p)`` arrive.

    >>> import os, tempfile
    >>> from netcosim.sweep import SerialExecutor, run_sweep
    >>> from netcosim.sweep.demo import lossy_link   # 100 messages; frames lost with params["loss"]
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     res = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor=SerialExecutor(),
    ...                     out=os.path.join(tmp, "sweep"), quiet=True)
    ...     parts = sorted(os.listdir(os.path.join(tmp, "sweep", "parts")))
    >>> res.runs["received"].tolist(), parts[0], len(parts)   # grid order: loss 0.1 (seeds 0, 1), then 0.5
    ([88, 87, 53, 54], 'run-000000-000000.parquet', 4)
    """

    in_process = True

    def run(self, tasks: list[Task]) -> Iterator[tuple[int, Outcome]]:
        """Yield ``(index, outcome)`` for each task ``(index, params, seed)`` of *tasks*, in order.

        The objects alive before the first run are frozen (:func:`gc.freeze`) for the
        duration, so the collection after each run skips them and stays cheap."""
        own_freeze = gc.get_freeze_count() == 0        # a caller's own freeze is left as it is
        if own_freeze:
            gc.freeze()
        try:
            for index, params, seed in tasks:
                yield index, self.run_task(params, seed)
        finally:
            if own_freeze:
                gc.unfreeze()


def _pool_worker(conn, ref: ScenarioRef) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)      # Ctrl-C is the caller's to handle
    try:
        fn = load(ref)
    except BaseException as exc:
        conn.send(("failed", f"{type(exc).__name__}: {exc}"))
        return
    import pandas  # noqa: F401  (run_one needs it: imported before the freeze, it stays out of every collection)
    gc.collect()
    gc.freeze()          # the imports stay out of every later collection: gc.collect() after a run stays cheap
    conn.send(("ready",))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):     # the caller is gone
            return
        if msg is None:
            return
        index, params, seed = msg
        outcome = run_one(fn, params, seed)
        try:
            conn.send(("done", index, outcome))
        except (BrokenPipeError, OSError):
            return
        except Exception as exc:        # an unpicklable table
            conn.send(("done", index, Outcome("error", error=f"cannot send the run's result to the sweep: "
                                                             f"{type(exc).__name__}: {exc}",
                                              wall_time=outcome.wall_time)))


class _Worker:
    def __init__(self, ctx, ref: ScenarioRef):
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_pool_worker, args=(child, ref), name="netcosim-sweep-worker")
        self.proc.start()
        child.close()
        self.ready = False
        self.task: Task | None = None
        self.started = 0.0

    def stop(self, kill: bool = False) -> None:
        if kill or self.task is not None or not self.ready:
            self.proc.kill()
        else:
            try:
                self.conn.send(None)
            except OSError:
                self.proc.kill()
        self.proc.join(5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()


class PoolExecutor(SweepExecutor):
    """Runs the tasks on *workers* local processes (default: the CPUs this process may
    use; see the module docstring); ``executor="pool"``.  The workers load the scenario by
    name: it lives at the top level of a module or a file, and a script starts the sweep
    under ``if __name__ == "__main__":``.

    Raises
    ------
    ConfigurationError
        *workers* is not an integer >= 1 (ConfigurationTypeError if not a number).

    Examples
    --------
    :class:`SerialExecutor`'s sweep on two worker processes (the scenario named by its module, which the
    workers import: :mod:`netcosim.sweep.demo`):

    >>> from netcosim.sweep import PoolExecutor, run_sweep
    >>> res = run_sweep("netcosim.sweep.demo:lossy_link", {"loss": [0.1, 0.5]}, seeds=2,
    ...                 executor=PoolExecutor(workers=2), quiet=True)
    >>> res.runs["received"].tolist()
    [88, 87, 53, 54]
    """

    ref: ScenarioRef

    def __init__(self, workers: int | None = None):
        if workers is not None:
            workers = _workers(workers)
        self.workers = workers

    def run(self, tasks: list[Task]) -> Iterator[tuple[int, Outcome]]:
        """Yield ``(index, outcome)`` for each task ``(index, params, seed)`` of *tasks* as it finishes."""
        import multiprocessing
        from multiprocessing.connection import wait

        ctx = multiprocessing.get_context("spawn")
        queue = collections.deque(tasks)
        pool = [_Worker(ctx, self.ref) for _ in range(min(self.workers or cpu_count(), len(tasks)))]
        try:
            while queue or any(w.task is not None for w in pool):
                for w in pool:
                    if w.ready and w.task is None and queue:
                        w.task = queue.popleft()
                        w.conn.send(w.task)
                        w.started = time.monotonic()
                waits = [w.started + self.timeout - time.monotonic() for w in pool
                         if self.timeout is not None and w.task is not None]
                ready = wait([w.conn for w in pool] + [w.proc.sentinel for w in pool],
                             timeout=max(0.0, min(waits)) if waits else None)
                for i, w in enumerate(pool):
                    done = self._poll(w, ready)
                    if done is not None:
                        yield done
                    if not w.proc.is_alive():
                        yield from self._drain(w)
                        if not w.ready:
                            raise RuntimeError(
                                f"a sweep worker process exited with code {w.proc.exitcode} while starting; a "
                                f"script that starts a sweep must do so under `if __name__ == \"__main__\":` "
                                f"(worker processes import the script's module)")
                        if w.task is not None:
                            task = w.task
                            w.task = None
                            yield task[0], Outcome("error", error=f"the worker process died during the run "
                                                                  f"(exit code {w.proc.exitcode})")
                        w.stop(kill=True)
                        pool[i] = _Worker(ctx, self.ref)
                    elif (self.timeout is not None and w.task is not None
                          and time.monotonic() - w.started >= self.timeout):
                        index = w.task[0]
                        w.stop(kill=True)
                        pool[i] = _Worker(ctx, self.ref)
                        yield index, _timeout_outcome(self.timeout)
        finally:
            for w in pool:
                w.stop()

    def _drain(self, w: _Worker) -> list[tuple[int, Outcome]]:
        """The results a dead worker sent before it died (poll() is also true at end of file)."""
        out: list[tuple[int, Outcome]] = []
        while True:
            try:
                if not w.conn.poll():
                    return out
                msg = w.conn.recv()
            except (EOFError, OSError):
                return out
            done = self._handle(w, msg)
            if done is not None:
                out.append(done)

    def _poll(self, w: _Worker, ready: list) -> tuple[int, Outcome] | None:
        if w.conn not in ready and not w.conn.poll():
            return None
        try:
            msg = w.conn.recv()
        except (EOFError, OSError):        # the worker is gone; its sentinel tells the loop
            w.proc.join(5)
            return None
        return self._handle(w, msg)

    def _handle(self, w: _Worker, msg: tuple) -> tuple[int, Outcome] | None:
        if msg[0] == "ready":
            w.ready = True
            return None
        if msg[0] == "failed":
            raise ConfigurationError(f"a worker process cannot load scenario {self.ref.spec!r}: {msg[1]}")
        w.task = None
        return msg[1], msg[2]


def _process() -> str:
    return f"{socket.gethostname()}/{os.getpid()}"


def _dask_task(ref: ScenarioRef, params: dict[str, Any], seed: int, timeout: float | None,
               caller: str | None = None) -> Outcome:
    if timeout is not None:
        return run_in_child(ref, params, seed, timeout)
    if ref not in _loaded:
        load(ref)
        if _process() != caller:        # a worker thread of the caller's process: leave its heap unfrozen
            import pandas  # noqa: F401  (see _pool_worker)
            gc.collect()
            gc.freeze()  # the worker's own objects stay out of the collection after each run
    return run_one(load(ref), params, seed)


#: Dask settings of the clusters :func:`local_cluster` starts.  A worker samples its
#: own stack every 10 ms for Dask's profiler and wakes its event loop every 20 ms; for
#: CPU-bound runs of a second or more that made each run about 10 % slower than on the
#: process pool (``python -m benchmarks.sweep``).  A sweep needs neither.
LOCAL_CLUSTER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}


def local_cluster(workers: int, cluster_class: Any = None) -> Any:
    """A ``LocalCluster`` of *workers* single-threaded worker processes, dashboard on a
    free port, logs at ERROR, with :data:`LOCAL_CLUSTER_CONFIG` (the caller closes it).
    ``cluster_class``: the cluster class to instantiate (default
    ``dask.distributed.LocalCluster``)."""
    import logging

    import dask
    if cluster_class is None:
        from dask.distributed import LocalCluster as cluster_class
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        return cluster_class(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                             silence_logs=logging.ERROR)


class DaskExecutor(SweepExecutor):
    """Runs the tasks on a Dask cluster: a given ``Client`` (left open), a scheduler
    address, or a ``LocalCluster`` of *workers* single-threaded processes started and
    closed here; ``executor="dask"``.  ``client``: a ``dask.distributed.Client``, used and left
    open; else ``scheduler``: a scheduler address to connect to; else a local cluster of
    ``workers`` processes (default: the CPU count).  The workers load the scenario by name
    (module, else file): it lives at the top level of a module or a file.

    Raises
    ------
    ConfigurationError
        *workers* is not an integer >= 1 (ConfigurationTypeError if not a number); an
        unreachable scheduler, or no ``dask.distributed``, at :meth:`start`.

    Examples
    --------
    :class:`SerialExecutor`'s sweep on a Dask cluster in this process (the scenario named by its module:
    :mod:`netcosim.sweep.demo`):

    >>> from dask.distributed import Client, LocalCluster
    >>> from netcosim.sweep import DaskExecutor, run_sweep
    >>> with LocalCluster(processes=False, dashboard_address=None) as cluster, Client(cluster) as client:
    ...     res = run_sweep("netcosim.sweep.demo:lossy_link", {"loss": [0.1, 0.5]}, seeds=2,
    ...                     executor=DaskExecutor(client=client), quiet=True)
    >>> res.runs["received"].tolist()
    [88, 87, 53, 54]
    """

    ref: ScenarioRef

    def __init__(self, *, client: Any = None, scheduler: str | None = None, workers: int | None = None):
        if workers is not None:
            workers = _workers(workers)
        self.client, self.scheduler, self.n_workers = client, scheduler, workers
        self._owned: list[Any] = []

    def start(self) -> None:
        """Connect (or start the local cluster); raises naming an unreachable scheduler."""
        if self.client is not None:
            return
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:
            raise ConfigurationError(f"executor 'dask' needs dask.distributed (pip install 'netcosim[dask]'): "
                                     f"{exc}") from None
        if self.scheduler is not None:
            try:
                self.client = Client(self.scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
            except Exception as exc:
                raise ConfigurationError(f"cannot reach the Dask scheduler {self.scheduler!r} within "
                                         f"{CONNECT_TIMEOUT:g} s: {type(exc).__name__}: {exc}") from None
            self._owned.append(self.client)
            return
        cluster = local_cluster(self.n_workers or cpu_count(), LocalCluster)
        self.client = Client(cluster, set_as_default=False)
        self._owned += [self.client, cluster]

    def close(self) -> None:
        """Close what :meth:`start` opened (a given client stays open)."""
        for obj in self._owned:
            try:
                obj.close()
            except Exception:
                pass
        if self._owned:
            self.client = None
        self._owned = []

    def run(self, tasks: list[Task]) -> Iterator[tuple[int, Outcome]]:
        """Yield ``(index, outcome)`` for each task ``(index, params, seed)`` of *tasks* as it finishes."""
        from dask.distributed import as_completed

        here = _process()        # the caller (host/pid): a worker in this process does not freeze it
        futures = {self.client.submit(_dask_task, self.ref, params, seed, self.timeout, here, pure=False): index
                   for index, params, seed in tasks}
        try:
            # results are gathered in batches as they complete (one round trip per batch, not per run)
            for fut, outcome in as_completed(list(futures), loop=self.client.loop, with_results=True,
                                             raise_errors=False):
                index = futures.pop(fut)
                if not isinstance(outcome, Outcome):     # the worker died (KilledWorker), the cluster went away
                    exc = outcome[1] if isinstance(outcome, tuple) and len(outcome) == 3 else outcome
                    if isinstance(exc, NetcosimError):
                        raise exc
                    outcome = Outcome("error", error=f"{type(exc).__name__}: {exc}")
                fut.release()
                yield index, outcome
        finally:
            for fut in futures:
                fut.cancel()
