"""``python -m netcosim.sweep._child``: one timed run in a process of its own.

Used for a run with a timeout where the executor cannot stop its own worker (serial,
Dask).  Protocol on the process's original stdout (the scenario's own output goes to
stderr): after loading the scenario, one byte ``R``; then the pickled
:class:`~netcosim.sweep.run.Outcome`.  Input on stdin: the pickled
``(sys_path, ref, params, seed)``.
"""

from __future__ import annotations

import os
import pickle
import sys


def main() -> None:
    """Read the task from stdin, run it, write the outcome (see the module docstring)."""
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)                         # the scenario's prints must not corrupt the protocol
    sys_path, ref, params, seed = pickle.loads(sys.stdin.buffer.read())
    sys.path[:] = sys_path
    # the result check (run.split_result) reads pandas: imported before the timed run starts,
    # so that the timeout counts the scenario, not start-up (seconds on a loaded machine)
    import pandas  # noqa: F401

    from netcosim.sweep.executors import load
    from netcosim.sweep.run import Outcome, run_one
    try:
        fn = load(ref)
    except BaseException as exc:
        out.write(b"R" + pickle.dumps(Outcome("error", error=f"cannot load scenario: {type(exc).__name__}: {exc}")))
        return
    out.write(b"R")
    out.flush()
    out.write(pickle.dumps(run_one(fn, params, seed)))
    out.flush()


if __name__ == "__main__":
    main()
