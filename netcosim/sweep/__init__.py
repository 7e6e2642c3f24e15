"""Parameter sweeps: a scenario over a grid of cases and seeds, on a process pool or Dask.

A *scenario* is a function ``fn(params: dict, seed: int) -> dict`` that builds and runs
one simulation and returns its metrics (scalars) and, optionally, tidy tables
(DataFrames).  :func:`run_sweep` runs it for every case of a grid and every seed, on
this process, a local process pool or a Dask cluster, with the same results bit for bit
on each; it can write a resumable Parquet dataset as runs finish.  See ``docs/sweeps.md``.

Modules: :mod:`~netcosim.sweep.grid` (cases), :mod:`~netcosim.sweep.seeds` (run seeds),
:mod:`~netcosim.sweep.scenario` (finding the function), :mod:`~netcosim.sweep.run` (one run),
:mod:`~netcosim.sweep.executors` (:class:`~netcosim.sweep.executors.SweepExecutor`, the
base of every executor, and the built-in ones), :mod:`~netcosim.sweep.store` (the dataset on disk),
:mod:`~netcosim.sweep.result`, :mod:`~netcosim.sweep.runner`, :mod:`~netcosim.sweep.aggregate` (medians,
bands and counts across seeds; :func:`~netcosim.sweep.aggregate.plot_sweep`).
"""

from .aggregate import plot_sweep, summarize
from .executors import DaskExecutor, PoolExecutor, SerialExecutor, SweepExecutor
from .result import SweepResult
from .runner import load_sweep, run_sweep, verify_sweep

__all__ = ["run_sweep", "load_sweep", "verify_sweep", "SweepResult", "summarize", "plot_sweep", "SweepExecutor",
           "SerialExecutor", "PoolExecutor", "DaskExecutor"]
