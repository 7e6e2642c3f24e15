"""``run_sweep``: check everything, then run every (case, seed) on an executor and keep the results.

Everything that can be checked is checked before the first run (grid, seeds, scenario,
executor, output directory, Dask scheduler), each error naming the value.  Then runs
go to the executor in grid order; each finished run is stored at once (in memory, and
in the output directory if one is given) and counted on the progress bar.  The run
table is assembled from the runs' records in grid order, then seed index, whatever
order they finished in, so every executor gives the same table.
"""

from __future__ import annotations

import os
import re
import sys
from typing import Any, Callable

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from . import grid as _grid
from .executors import DaskExecutor, PoolExecutor, SerialExecutor, SweepExecutor
from .grid import MAX_RUNS
from .result import SweepResult, run_frame
from .run import Outcome
from .scenario import code_digest, reference
from .seeds import run_seed, seed_list
from .store import FORMAT, Damage, DamagedSweepError, Lock, Store, describe_damage, param_dtypes

__all__ = ["run_sweep", "load_sweep", "verify_sweep", "validate_cases", "check_scheduler", "EXECUTORS",
           "MAX_RUNS", "MAX_TIMEOUT"]

#: Executors by name, shorthands for :class:`~netcosim.sweep.executors.SerialExecutor`,
#: :class:`~netcosim.sweep.executors.PoolExecutor` and
#: :class:`~netcosim.sweep.executors.DaskExecutor` (a ``dask.distributed.Client`` or any
#: :class:`~netcosim.sweep.executors.SweepExecutor` may be given instead).
EXECUTORS = ("serial", "pool", "dask")

#: The longest per-run ``timeout`` accepted, 10**9 s (about 32 years): beyond it the
#: executors' waits overflow (``1e300`` raised ``OverflowError``).
MAX_TIMEOUT = 1e9

#: A Dask scheduler address: ``host:port`` or ``scheme://host:port`` (IPv6 hosts in
#: brackets), or an ``inproc://`` address.
_ADDRESS = re.compile(r"^(?:[A-Za-z][A-Za-z0-9+.-]*://)?(?:\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+):(\d{1,5})/?$")


def check_scheduler(address: Any) -> str:
    """*address* if it has the form of a Dask scheduler address (``tcp://host:8786``,
    ``host:8786``, ``inproc://...``); raises naming it otherwise (a missing port, no host),
    at once, before any connection is tried."""
    if not isinstance(address, str) or not address.strip():
        raise ConfigurationTypeError(f"scheduler must be an address such as 'tcp://host:8786', got {address!r}")
    if address.startswith("inproc://"):
        return address
    m = _ADDRESS.match(address.strip())
    if m is None or not 0 < int(m.group(1)) < 65536:
        raise ConfigurationError(f"scheduler {address!r} is not a Dask scheduler address: give host:port or "
                                 f"scheme://host:port, e.g. 'tcp://host:8786' (a port from 1 to 65535)")
    return address.strip()


def _version() -> str:
    from .. import __version__
    return __version__


def _is_dask_client(obj: Any) -> bool:
    return type(obj).__name__ == "Client" and type(obj).__module__.startswith("distributed")


def _long(frame, params: dict[str, Any], seed_index: int, seed: int):
    frame = frame.reset_index(drop=True)
    for i, (col, val) in enumerate([*params.items(), ("seed_index", seed_index), ("seed", seed)]):
        frame.insert(i, col, val)
    return frame


def _record(params: dict[str, Any], seed_index: int, seed: int, outcome: Outcome) -> dict[str, Any]:
    return {**params, "seed_index": seed_index, "seed": seed, **outcome.metrics, "status": outcome.status,
            "error": outcome.error, "traceback": outcome.traceback, "wall_time": float(outcome.wall_time)}


#: columns of a run's record that are not its parameters or metrics
_RECORD_FIELDS = frozenset({"seed_index", "seed", "status", "error", "traceback", "wall_time"})


def _nan_keys(record: dict[str, Any], params) -> list[str]:
    """The metrics a finished run returned as NaN (none for a failed run)."""
    if record["status"] != "ok":
        return []
    return [k for k, v in record.items()
            if type(v) is float and v != v and k not in _RECORD_FIELDS and k not in params]


def _summary(records: list[dict[str, Any]], total: int, skipped: int, params=()) -> dict[str, int]:
    """Counts of the runs: ``total``, ``ok``, ``error``, ``timeout``, ``skipped``,
    ``missing``, and ``nan``: finished runs with a NaN metric."""
    status = [r["status"] for r in records]
    nan = sum(1 for r in records if _nan_keys(r, params))
    return {"total": total, "ok": status.count("ok"), "error": status.count("error"),
            "timeout": status.count("timeout"), "skipped": skipped, "missing": total - len(records), "nan": nan}


def _warn_nan(records: list[dict[str, Any]], params) -> None:
    """Name, once, the metrics finished runs returned as NaN (kept as returned)."""
    counts: dict[str, int] = {}
    for r in records:
        for k in _nan_keys(r, params):
            counts[k] = counts.get(k, 0) + 1
    if counts:
        import warnings

        from ..errors import NaNMetricWarning
        what = ", ".join(f"{k!r} in {n} run(s)" for k, n in sorted(counts.items()))
        warnings.warn(f"sweep: finished runs returned NaN for metrics {what}; they are kept as returned, "
                      f"with status 'ok' (summary['nan'] counts them): check the scenario, or filter them "
                      f"before aggregating", NaNMetricWarning, stacklevel=3)


def validate_cases(fn: Callable, cases: list[dict[str, Any]]) -> None:
    """Call the scenario *fn*'s optional ``validate(params)`` attribute for every case of
    *cases* (dicts of parameter name -> value), before
    any run; raise one :class:`~netcosim.errors.ConfigurationError` listing every case
    it refused (it raises) with the reason.  A scenario without ``validate`` is not
    checked."""
    check = getattr(fn, "validate", None)
    if check is None:
        return
    if not callable(check):
        raise ConfigurationTypeError(f"scenario {getattr(fn, '__name__', fn)!r}: its 'validate' attribute must be "
                                     f"a function validate(params), got {check!r}")
    bad = []
    for i, params in enumerate(cases):
        try:
            check(dict(params))
        except Exception as exc:
            bad.append(f"case {i} {params}: {type(exc).__name__}: {exc}")
    if bad:
        shown = bad[:20] + ([f"... and {len(bad) - 20} more"] if len(bad) > 20 else [])
        raise ConfigurationError(f"{len(bad)} of {len(cases)} grid cases are refused by the scenario's validate(); "
                                 f"no run started:\n  " + "\n  ".join(shown))


def _stderr(message: str) -> None:
    print(f"sweep: {message}", file=sys.stderr, flush=True)


def run_sweep(scenario: Callable | str, grid: Any, seeds: int | list[int] = 1, *, root_seed: int = 0,
              executor: Any = "pool", workers: int | None = None, scheduler: str | None = None,
              out: str | os.PathLike | None = None, fresh: bool = False, timeout: float | None = None,
              retry_errors: bool = False, quiet: bool = False,
              notify: Callable[[str], None] | None = None) -> SweepResult:
    """Run *scenario* for every case of *grid* and every seed; returns a :class:`SweepResult`.

    Parameters
    ----------
    scenario:
        ``fn(params: dict, seed: int) -> dict``, or its name ``"package.module:function"``
        / ``"path/to/file.py:function"``.  The returned dict's scalar values (int, float,
        bool, str, None) are the run's metrics, its pandas DataFrames the run's tables;
        anything else, or a return value that is not a dict, records the run as an
        error naming the type.  A scenario may declare the parameters it accepts as
        ``fn.params = {...}``; a grid parameter outside it is refused before any run.
        It may also have ``fn.validate = check``, ``check(params)`` raising for a case
        it cannot run: every case is checked before any run, and the sweep stops with
        one error listing the refused cases.
    grid:
        The cases (:mod:`netcosim.sweep.grid`): a dict of lists (their product), a list
        of dicts, or a DataFrame (one case per row).
    seeds:
        Runs per case: a count ``n`` (seed indices ``0..n-1``, each run's seed derived
        from *root_seed*, the case's parameters and the index, see
        :mod:`netcosim.sweep.seeds`), or an explicit list of seeds used as given.
    root_seed:
        Non-negative integer from which every run's seed is derived.
    executor:
        ``"serial"`` (this process), ``"pool"`` (local worker processes, default),
        ``"dask"`` (a Dask ``LocalCluster`` started and closed here, or the scheduler at
        *scheduler*), a ``dask.distributed.Client``, or a
        :class:`~netcosim.sweep.executors.SweepExecutor` object (the built-in ones or a
        plug-in, see ``docs/sweeps.md``); anything else raises
        :class:`~netcosim.errors.ConfigurationTypeError` naming it.
    workers:
        Number of worker processes for ``"pool"`` and the local Dask cluster (default:
        the CPUs this process may use); an executor object is given its own.
    scheduler:
        Address of a Dask scheduler (``"tcp://host:8786"``), implies ``executor="dask"``;
        unreachable within :data:`~netcosim.sweep.executors.CONNECT_TIMEOUT` seconds
        raises naming the address.
    out:
        Directory of the sweep's Parquet dataset (:mod:`netcosim.sweep.store`), written
        as runs finish.  If it already holds this sweep, its finished runs are kept and
        not rerun (a run whose files do not match their recorded SHA-256 is run again,
        and said so); if it holds another sweep, ``ConfigurationError`` names what
        differs; if another sweep is writing into it, :class:`~netcosim.sweep.store.SweepLockedError`
        names that process.  None: results in memory only.
    fresh:
        Discard a different (or the same) sweep found in *out* and start over.
    timeout:
        Wall-clock seconds one run may take (None: unlimited); a run still going then is
        stopped and recorded with status ``"timeout"``.
    retry_errors:
        Run again the runs stored in *out* with status ``"error"`` or ``"timeout"``.
    quiet:
        No progress bar (it is also off when stderr is not a terminal) and no messages.
    notify:
        Called with each message (runs found done, damaged files re-run); default: a
        line on stderr unless *quiet*.

    A sweep holds at most :data:`MAX_RUNS` (10**7) runs, cases times seeds: a larger one
    is refused, naming the count, before anything is listed.

    Raises
    ------
    ConfigurationError
        Before any run, naming the value: an invalid grid or seeds, more than
        :data:`MAX_RUNS` runs, a negative *root_seed*, a *timeout* not in (0,
        :data:`MAX_TIMEOUT`], *workers* below 1, an unknown executor name, a malformed
        *scheduler* (or one given with another executor; unreachable: when connecting), a
        scenario that cannot be found or that worker processes cannot load (a lambda or a
        nested function off ``"serial"``, or with a *timeout*), a grid parameter the
        scenario does not accept, cases its ``validate`` refuses, *workers* with an executor
        object, an *out* that cannot be written or holds another sweep
        (:class:`~netcosim.sweep.store.SweepLockedError` if another sweep is writing there);
        later, a worker process that cannot load the scenario.
    ConfigurationTypeError
        A value of the wrong kind: an *executor* that is not a name, a Dask ``Client`` or a
        :class:`~netcosim.sweep.executors.SweepExecutor` object (or is the class itself),
        a scenario that is not callable, a grid or a grid value of the wrong type, *notify*
        not callable, *fresh* or *retry_errors* not a bool, a count not an integer.
    RuntimeError
        During the sweep: an executor reported a task twice, one it was not given, or not
        all of them; pool workers that cannot start (a script without the ``__main__``
        guard).  The runs stored so far are kept.

    Examples
    --------
    Two cases, two seeds each, in this process; one row per run:

    >>> from netcosim.sweep import run_sweep
    >>> def scenario(params, seed):
    ...     return {"double": 2 * params["x"]}
    >>> result = run_sweep(scenario, grid={"x": [1, 2]}, seeds=2, executor="serial", quiet=True)
    >>> result.to_pandas()[["x", "seed_index", "double"]].values.tolist()
    [[1, 0, 2], [1, 1, 2], [2, 0, 4], [2, 1, 4]]
    """
    if notify is not None and not callable(notify):
        raise ConfigurationTypeError(f"notify must be a function notify(message: str) or None, got {notify!r}")
    say: Callable[[str], None] = notify if notify is not None else ((lambda m: None) if quiet else _stderr)
    # --- check everything before the first run ---------------------------------------
    n_seeds, explicit = seed_list(seeds)
    if n_seeds > MAX_RUNS:
        raise ConfigurationError(f"seeds gives {n_seeds} runs per case, more than a sweep may run "
                                 f"(MAX_RUNS = {MAX_RUNS} runs)")
    cases = _grid.cases(grid)
    if len(cases) * n_seeds > MAX_RUNS:
        raise ConfigurationError(f"the sweep would make {len(cases) * n_seeds} runs ({len(cases)} cases x "
                                 f"{n_seeds} seeds), more than a sweep may run (MAX_RUNS = {MAX_RUNS} runs)")
    names = list(cases[0])
    root_seed = validate.integer(root_seed, "root_seed", lo=0, kind="a non-negative integer")
    if timeout is not None:
        timeout = validate.real(timeout, "timeout", lo=0.0, lo_open=True, hi=MAX_TIMEOUT,
                                kind=f"a positive number of seconds, at most {MAX_TIMEOUT:g}")
    if workers is not None:
        workers = validate.integer(workers, "workers", lo=1, kind="a number of worker processes (an integer >= 1)")
    for flag, value in (("fresh", fresh), ("retry_errors", retry_errors)):
        if not isinstance(value, bool):
            raise ConfigurationTypeError(f"{flag} must be True or False, got {value!r}")
    if scheduler is not None:
        scheduler = check_scheduler(scheduler)
        if executor == "pool":
            executor = "dask"
        elif executor != "dask":
            raise ConfigurationError(f"scheduler {scheduler!r} is a Dask address, but executor is {executor!r}")
    ex = _executor(executor, workers, scheduler)
    fn, ref = reference(scenario)
    _grid.check_accepted(names, fn)
    if ref is None and (not ex.in_process or timeout is not None):
        raise ConfigurationError(f"scenario {fn!r} cannot be found by a worker process (a lambda, a nested "
                                 f"function, a function typed in an interactive session): define it at the top "
                                 f"level of a module or file, or use executor='serial' "
                                 f"without a timeout")
    validate_cases(fn, cases)

    code_sha, code_parts = code_digest(fn)
    meta = {"format": FORMAT, "scenario": ref.spec if ref else repr(fn),
            "scenario_file": ref.file if ref else None, "scenario_sha256": code_sha, "scenario_code": code_parts,
            "params": names, "cases": cases, "seeds": explicit if explicit is not None else n_seeds,
            "root_seed": root_seed, "netcosim_version": _version()}
    tasks_all = []
    for c, params in enumerate(cases):
        for s in range(n_seeds):
            seed = explicit[s] if explicit is not None else run_seed(root_seed, params, s)
            tasks_all.append((c, s, params, seed))

    store = lock = None
    done: set[tuple[int, int]] = set()
    repaired: list[Damage] = []
    if out is not None:
        validate.path(out, "out")
        _check_out(out)
        store = Store(out)
        store.dtypes = param_dtypes(cases)
        store.check(meta, fresh)
        lock = Lock(store.root)
        lock.check()                      # a live sweep there: stop before starting anything
    # connect before touching the directory: an unreachable scheduler changes nothing
    ex.bind(fn, ref, timeout)
    ex.start()
    try:
        if store is not None and lock is not None:
            store.root.mkdir(parents=True, exist_ok=True)
            lock.acquire()
            done = store.open(meta, fresh)
            repaired = store.verify()
            done = _repair(store, meta, done, repaired, say)
        return _execute(ex, tasks_all, done, store, names, meta, quiet, retry_errors, say, repaired)
    finally:
        try:
            ex.close()
        finally:
            if lock is not None:
                lock.release()


def _executor(executor: Any, workers: int | None, scheduler: str | None) -> SweepExecutor:
    """The :class:`SweepExecutor` *executor* names or is; raises naming anything else."""
    if isinstance(executor, SweepExecutor):
        if workers is not None:
            raise ConfigurationError(f"workers={workers} applies to the executors named by a string; give "
                                     f"the executor object {executor!r} its own")
        return executor
    if _is_dask_client(executor):
        return DaskExecutor(client=executor)
    choices = f"one of {list(EXECUTORS)}, a dask.distributed.Client or a netcosim.sweep.SweepExecutor"
    if isinstance(executor, str):
        if executor == "serial":
            return SerialExecutor()
        if executor == "pool":
            return PoolExecutor(workers)
        if executor == "dask":
            return DaskExecutor(scheduler=scheduler, workers=workers)
        raise ConfigurationError(f"executor must be {choices}, got {executor!r}")
    if isinstance(executor, type) and issubclass(executor, SweepExecutor):
        raise ConfigurationTypeError(f"executor must be {choices} object, got the class {executor.__name__} "
                                     f"itself: pass an instance, {executor.__name__}(...)")
    raise ConfigurationTypeError(f"executor must be {choices}, got {type(executor).__name__} {executor!r}")


def _check_out(out: str | os.PathLike) -> None:
    """Refuse an output directory that cannot be made or written (``/proc/x``, a file),
    naming it, before anything is run or created."""
    from ..cli._common import UsageError, check_writable_dir
    try:
        check_writable_dir(out, "out")
    except UsageError as exc:
        raise ConfigurationError(str(exc)) from None


def _repair(store: Store, meta: dict[str, Any], done: set[tuple[int, int]], damage: list[Damage],
            say: Callable[[str], None]) -> set[tuple[int, int]]:
    """Delete the runs of the *damage* found in the directory (they are run again) and
    say so.  Returns the runs still done."""
    if not damage:
        return done
    keys = {k for d in damage if d.file != "runs.parquet" for k in d.keys}
    for d in damage:
        if d.file == "runs.parquet":
            (store.root / "runs.parquet").unlink(missing_ok=True)      # rebuilt at the end
    for key in keys:
        store.remove_run(*key)
    lines = describe_damage(meta, damage)
    rebuilt = " and rebuilding runs.parquet" if any(d.file == "runs.parquet" for d in damage) else ""
    say(f"{len(damage)} damaged file(s) in {store.root}; re-running {len(keys)} run(s){rebuilt}:\n  "
        + "\n  ".join(lines))
    return done - keys


def _execute(ex, tasks_all, done, store, names, meta, quiet, retry_errors=False, say=None,
             repaired=None) -> SweepResult:
    from tqdm.auto import tqdm

    records: dict[tuple[int, int], dict[str, Any]] = {}
    tables: dict[tuple[int, int], dict[str, Any]] = {}
    unreadable: list[Damage] = []
    for c, s, _params, _seed in tasks_all:
        if (c, s) in done:
            try:
                records[(c, s)] = store.read_run(c, s)
            except Exception as exc:          # matched its digest yet cannot be read: written damaged
                unreadable.append(Damage(f"parts/{store.part_name(c, s)}", f"cannot be read: {exc}", ((c, s),)))
    if unreadable:
        repaired = [*(repaired or []), *unreadable]
        for d in unreadable:
            store.remove_run(*d.keys[0])
        if say is not None:
            say(f"re-running {len(unreadable)} run(s) whose file cannot be read:\n  "
                + "\n  ".join(describe_damage(meta, unreadable)))
    if retry_errors:
        again = [k for k, r in records.items() if r["status"] in ("error", "timeout")]
        for k in again:
            del records[k]
        if again and say is not None:
            say(f"retrying {len(again)} run(s) that failed (error or timeout)")
    skipped = len(records)
    todo = [(c, s, p, seed) for c, s, p, seed in tasks_all if (c, s) not in records]
    if store is not None and say is not None and skipped:
        if todo:
            say(f"resuming: {len(todo)} of {len(tasks_all)} runs to do ({store.root})")
        else:
            say(f"{skipped} of {len(tasks_all)} runs already done; nothing to run ({store.root})")
    keys = {i: (c, s, p, seed) for i, (c, s, p, seed) in enumerate(todo)}
    failed = sum(r["status"] != "ok" for r in records.values())
    bar = tqdm(total=len(tasks_all), initial=len(records), disable=True if quiet else None, unit="run",
               desc="sweep", dynamic_ncols=True)
    bar.set_postfix(failed=failed, refresh=False)
    runs = ex.results([(i, p, seed) for i, (c, s, p, seed) in keys.items()]) if todo else iter(())
    try:
        for i, outcome in runs:
            c, s, params, seed = keys[i]
            record = _record(params, s, seed, outcome)
            long = {name: _long(frame, params, s, seed) for name, frame in outcome.tables.items()}
            if store is not None:
                store.write_run(c, s, record, long)
            elif long:
                tables[(c, s)] = long
            records[(c, s)] = record
            if outcome.status != "ok":
                failed += 1
                bar.set_postfix(failed=failed, refresh=False)
            bar.update(1)
    finally:
        close = getattr(runs, "close", None)
        if close is not None:
            close()
        bar.close()
    order = [(c, s) for c, s, _, _ in tasks_all]
    frame = run_frame([records[k] for k in order], names)
    if store is not None:
        store.write_runs(frame)
    summary = _summary(list(records.values()), len(tasks_all), skipped, names)
    _warn_nan(list(records.values()), names)
    result = SweepResult(frame, names, meta, summary, tables=tables, store=store, keys=order)
    result.repaired = list(repaired or [])
    return result


def verify_sweep(path: str | os.PathLike) -> list[Damage]:
    """The damaged files of the sweep stored in directory *path* (empty: intact): each
    finished run's files are compared with the SHA-256 recorded when they were written
    (:meth:`~netcosim.sweep.store.Store.verify`).

    Raises
    ------
    ConfigurationError
        *path* holds no sweep (no ``sweep.json``), or its metadata cannot be read.
    ConfigurationTypeError
        *path* is not a str or an ``os.PathLike``.

    Examples
    --------
    A stored sweep with one byte of a run's file flipped: the damaged file and the run
    ``(case, seed_index)`` it holds are named, and running the sweep again re-runs that
    run only.

    >>> import pathlib, tempfile
    >>> from netcosim.sweep import run_sweep, verify_sweep
    >>> def scenario(params, seed):
    ...     return {"double": 2 * params["x"]}
    >>> tmp = tempfile.TemporaryDirectory()
    >>> out = pathlib.Path(tmp.name, "sweep")
    >>> _ = run_sweep(scenario, {"x": [1, 2]}, seeds=2, executor="serial", out=out, quiet=True)
    >>> verify_sweep(out)
    []
    >>> part = out / "parts" / "run-000001-000000.parquet"
    >>> data = bytearray(part.read_bytes())
    >>> data[100] ^= 0xFF
    >>> _ = part.write_bytes(data)
    >>> [(d.file, d.keys) for d in verify_sweep(out)]
    [('parts/run-000001-000000.parquet', ((1, 0),))]
    >>> again = run_sweep(scenario, {"x": [1, 2]}, seeds=2, executor="serial", out=out, quiet=True)
    >>> again.summary["skipped"], [d.file for d in again.repaired], verify_sweep(out)
    (3, ['parts/run-000001-000000.parquet'], [])
    >>> tmp.cleanup()
    """
    store = Store(validate.path(path, "path"))
    if store.read_metadata() is None:
        raise ConfigurationError(f"{str(path)!r} holds no sweep (no {store.root / 'sweep.json'})")
    return store.verify()


def load_sweep(path: str | os.PathLike, verify: bool = True) -> SweepResult:
    """The sweep stored in directory *path* (finished or not: runs not finished are
    missing from ``runs`` and counted in ``summary["missing"]``).

    With *verify* (default) every file is first compared with the SHA-256 recorded when
    it was written; a damaged, truncated or missing file raises
    :class:`~netcosim.sweep.store.DamagedSweepError` naming the files and the runs they
    hold (``.damage``, ``.keys``).  ``verify=False`` skips that (a file that cannot be
    read still raises it).

    Raises
    ------
    ConfigurationError
        *path* holds no sweep (no ``sweep.json``), or its metadata cannot be read.
    ConfigurationTypeError
        *path* is not a str or an ``os.PathLike``.
    DamagedSweepError
        (:class:`~netcosim.sweep.store.DamagedSweepError`) A file does not match its
        recorded SHA-256 (with *verify*) or cannot be read.

    Examples
    --------
    Messages over a lossy link, two loss probabilities, two seeds each, stored in a
    directory and read back:

    >>> import pathlib, tempfile
    >>> from netcosim.sweep import load_sweep, run_sweep
    >>> from netcosim.sweep.demo import lossy_link   # 100 messages; frames lost with params["loss"]
    >>> tmp = tempfile.TemporaryDirectory()
    >>> out = pathlib.Path(tmp.name, "sweep")
    >>> ran = run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial", out=out, quiet=True)
    >>> back = load_sweep(out)
    >>> back.runs["received"].tolist(), back.runs.equals(ran.runs), back.summary["missing"]
    ([88, 87, 53, 54], True, 0)
    >>> part = out / "parts" / "run-000001-000000.parquet"      # one byte of a run's file flipped
    >>> data = bytearray(part.read_bytes())
    >>> data[100] ^= 0xFF
    >>> _ = part.write_bytes(data)
    >>> load_sweep(out)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.sweep.store.DamagedSweepError: sweep '...' is damaged: 1 file(s) do not match the SHA-256 ...
    >>> tmp.cleanup()
    """
    store = Store(validate.path(path, "path"))
    meta = store.read_metadata()
    if meta is None:
        raise ConfigurationError(f"{str(path)!r} holds no sweep (no {store.root / 'sweep.json'})")
    if verify:
        damage = store.verify()
        if damage:
            raise DamagedSweepError(store.root, damage, meta)
    finished = store.finished()
    seeds = meta["seeds"]
    n = len(seeds) if isinstance(seeds, list) else int(seeds)
    order = [(c, s) for c in range(len(meta["cases"])) for s in range(n) if (c, s) in finished]
    records = []
    for c, s in order:
        try:
            records.append(store.read_run(c, s))
        except Exception as exc:
            raise DamagedSweepError(store.root, [Damage(f"parts/{store.part_name(c, s)}",
                                                        f"cannot be read: {exc}", ((c, s),))], meta) from None
    frame = run_frame(records, meta["params"])
    summary = _summary(records, len(meta["cases"]) * n, 0, meta["params"])
    return SweepResult(frame, meta["params"], meta, summary, store=store, keys=order)
