"""Bad input to ``netcosim.sweep.run_sweep``, ``load_sweep`` and ``netcosim sweep``: refused
before any run, naming the value."""

from __future__ import annotations

import socket
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from invalid_cases import Case
from invalid_cases.cli import CommandFailed, netcosim
from netcosim.errors import ConfigurationError, ConfigurationTypeError

GRID = {"a": [1], "b": [0.5]}


def sweep(scenario="sweep_scenarios:cheap", grid=None, seeds=1, **kw):
    from netcosim.sweep import run_sweep
    kw.setdefault("executor", "serial")
    run_sweep(scenario, GRID if grid is None else grid, seeds, quiet=True, **kw)


def into_dir(setup, **kw):
    """``sweep(**kw)`` into a temporary directory prepared by ``setup(path)``."""
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "sweep"
        setup(out)
        sweep(out=out, **kw)


def _other_sweep(out):
    sweep(out=out, grid={"a": [1, 2], "b": [0.5]})


def _foreign_files(out):
    out.mkdir()
    (out / "notes.txt").write_text("mine")


def unreachable_scheduler():
    import netcosim.sweep.executors as ex
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    saved, ex.CONNECT_TIMEOUT = ex.CONNECT_TIMEOUT, 1.0
    try:
        sweep(scheduler=f"tcp://127.0.0.1:{port}", executor="dask")
    finally:
        ex.CONNECT_TIMEOUT = saved


def load(path):
    from netcosim.sweep import load_sweep
    load_sweep(path)


def cli_in_dir(*argv):
    with tempfile.TemporaryDirectory() as d:
        netcosim(*[a.replace("DIR", d) for a in argv])


CE, CTE = ConfigurationError, ConfigurationTypeError

CASES = [
    # the grid
    Case(id="sweep-grid-empty-dict", call=lambda: sweep(grid={}), exc=CE, names="{}"),
    Case(id="sweep-grid-empty-list", call=lambda: sweep(grid=[]), exc=CE, names="[]"),
    Case(id="sweep-grid-empty-frame", call=lambda: sweep(grid=pd.DataFrame()), exc=CE, names="(0, 0)"),
    Case(id="sweep-grid-parameter-without-values", call=lambda: sweep(grid={"a": [], "b": [1]}), exc=CE,
         names="grid['a']"),
    Case(id="sweep-grid-values-not-a-list", call=lambda: sweep(grid={"a": 0.1, "b": [1]}), exc=CTE, names="0.1"),
    Case(id="sweep-grid-values-a-string", call=lambda: sweep(grid={"a": "0,1", "b": [1]}), exc=CTE, names="'0,1'"),
    Case(id="sweep-grid-not-a-grid", call=lambda: sweep(grid=42), exc=CTE, names="42"),
    Case(id="sweep-grid-list-of-non-dicts", call=lambda: sweep(grid=[{"a": 1, "b": 1}, 3]), exc=CTE, names="3"),
    Case(id="sweep-grid-cases-with-other-keys", call=lambda: sweep(grid=[{"a": 1, "b": 1}, {"a": 2}]), exc=CE,
         names="{'a': 2}"),
    Case(id="sweep-grid-case-twice", call=lambda: sweep(grid=[{"a": 1, "b": 1}, {"a": 1, "b": 1}]), exc=CE,
         names="{'a': 1, 'b': 1}"),
    Case(id="sweep-grid-key-not-accepted", call=lambda: sweep(grid={"a": [1], "c": [2]}), exc=CE, names="'c'"),
    Case(id="sweep-grid-value-a-list", call=lambda: sweep(grid={"a": [[1, 2]], "b": [0]}), exc=CTE, names="[1, 2]"),
    Case(id="sweep-grid-value-nan", call=lambda: sweep(grid={"a": [float("nan")], "b": [0]}), exc=CE, names="nan"),
    Case(id="sweep-grid-value-kinds-mixed", call=lambda: sweep(grid={"a": [1, "x"], "b": [0]}), exc=CTE,
         names="'x'"),
    Case(id="sweep-grid-reserved-name", call=lambda: sweep(grid={"a": [1], "seed": [0]}), exc=CE, names="'seed'"),
    Case(id="sweep-grid-name-not-a-string", call=lambda: sweep(grid={1: [1]}), exc=CTE, names="1"),
    # seeds and the other numbers
    Case(id="sweep-seeds-zero", call=lambda: sweep(seeds=0), exc=CE, names="got 0"),
    Case(id="sweep-seeds-negative", call=lambda: sweep(seeds=-3), exc=CE, names="-3"),
    Case(id="sweep-seeds-fraction", call=lambda: sweep(seeds=2.5), exc=CE, names="2.5"),
    Case(id="sweep-seeds-text", call=lambda: sweep(seeds="20"), exc=CTE, names="'20'"),
    Case(id="sweep-seeds-bool", call=lambda: sweep(seeds=True), exc=CTE, names="True"),
    Case(id="sweep-seeds-empty-list", call=lambda: sweep(seeds=[]), exc=CE, names="[]"),
    Case(id="sweep-seeds-negative-seed", call=lambda: sweep(seeds=[1, -1]), exc=CE, names="-1"),
    Case(id="sweep-seeds-seed-twice", call=lambda: sweep(seeds=[4, 4]), exc=CE, names="seed 4 twice"),
    Case(id="sweep-root-seed-negative", call=lambda: sweep(root_seed=-1), exc=CE, names="-1"),
    Case(id="sweep-timeout-zero", call=lambda: sweep(timeout=0), exc=CE, names="got 0"),
    Case(id="sweep-timeout-nan", call=lambda: sweep(timeout=float("nan")), exc=CE, names="nan"),
    Case(id="sweep-timeout-text", call=lambda: sweep(timeout="5"), exc=CTE, names="'5'"),
    Case(id="sweep-workers-zero", call=lambda: sweep(workers=0, executor="pool"), exc=CE, names="got 0"),
    Case(id="sweep-executor-unknown", call=lambda: sweep(executor="threads"), exc=CE, names="'threads'"),
    Case(id="sweep-fresh-not-bool", call=lambda: sweep(fresh="yes"), exc=CTE, names="'yes'"),
    Case(id="sweep-scheduler-with-serial", call=lambda: sweep(scheduler="tcp://h:8786"), exc=CE,
         names="'tcp://h:8786'"),
    # the scenario
    Case(id="sweep-scenario-no-module", call=lambda: sweep("no_such_pkg.mod:run"), exc=CE, names="'no_such_pkg.mod'"),
    Case(id="sweep-scenario-no-function", call=lambda: sweep("sweep_scenarios:nope"), exc=CE, names="'nope'"),
    Case(id="sweep-scenario-no-colon", call=lambda: sweep("sweep_scenarios"), exc=CE, names="'sweep_scenarios'"),
    Case(id="sweep-scenario-no-file", call=lambda: sweep("./no_such_file.py:run"), exc=CE,
         names="'./no_such_file.py'"),
    Case(id="sweep-scenario-not-callable", call=lambda: sweep("math:pi"), exc=CTE, names="'math:pi'"),
    Case(id="sweep-scenario-not-a-function", call=lambda: sweep(42), exc=CTE, names="42"),
    Case(id="sweep-scenario-lambda-on-a-pool", call=lambda: sweep(lambda p, s: {}, executor="pool"), exc=CE,
         names="<lambda>"),
    Case(id="sweep-scenario-params-not-a-collection",
         call=lambda: sweep(type("S", (), {"params": "a", "__call__": lambda self, p, s: {}})()), exc=CTE,
         names="'a'"),
    # where it runs and where it goes
    Case(id="sweep-dask-scheduler-unreachable", call=unreachable_scheduler, exc=CE, names="tcp://127.0.0.1:"),
    Case(id="sweep-out-holds-another-sweep", call=lambda: into_dir(_other_sweep), exc=CE, names="cases differs"),
    Case(id="sweep-out-holds-other-files", call=lambda: into_dir(_foreign_files), exc=CE, names="holds no sweep.json"),
    Case(id="sweep-out-is-a-file", call=lambda: into_dir(lambda p: p.write_text("x")), exc=CE, names="is a file"),
    Case(id="sweep-load-not-a-sweep", call=lambda: load(tempfile.gettempdir()), exc=CE,
         names=repr(tempfile.gettempdir())),
    # netcosim sweep
    Case(id="cli-sweep-grid-without-values", call=lambda: cli_in_dir("sweep", "sweep_scenarios:cheap", "--grid",
                                                                     "loss", "--out", "DIR/s"),
         exc=CommandFailed, names="'loss'"),
    Case(id="cli-sweep-grid-twice", call=lambda: cli_in_dir("sweep", "sweep_scenarios:cheap", "--grid", "a=1",
                                                            "--grid", "a=2", "--out", "DIR/s"),
         exc=CommandFailed, names="'a'"),
    Case(id="cli-sweep-no-scenario", call=lambda: netcosim("sweep", "--grid", "a=1"), exc=CommandFailed,
         names="SCENARIO"),
    Case(id="cli-sweep-no-out", call=lambda: netcosim("sweep", "sweep_scenarios:cheap", "--grid", "a=1"),
         exc=CommandFailed, names="--out"),
    Case(id="cli-sweep-seeds-zero", call=lambda: cli_in_dir("sweep", "sweep_scenarios:cheap", "--grid", "a=1",
                                                            "--grid", "b=2", "--seeds", "0", "--out", "DIR/s"),
         exc=CommandFailed, names="got 0"),
    Case(id="cli-sweep-resume-not-a-sweep", call=lambda: cli_in_dir("sweep", "--resume", "DIR"),
         exc=CommandFailed, names="holds no sweep"),
    Case(id="cli-sweep-resume-with-grid", call=lambda: cli_in_dir("sweep", "--resume", "DIR", "--grid", "a=1"),
         exc=CommandFailed, names="--resume DIR"),
    Case(id="cli-sweep-unknown-executor", call=lambda: netcosim("sweep", "x:y", "--executor", "threads"),
         exc=CommandFailed, names="'threads'"),
]

# the audit's cases: sizes beyond MAX_RUNS, a non-callable notify, an unwritable output, an
# unbounded timeout, a scenario file that does not parse, a malformed scheduler address


def _bad_syntax_file(d):
    path = Path(d) / "bad_syntax_scenario.py"
    path.write_text("def main(params, seed)\n    return {}\n")
    return path


def cli_bad_syntax():
    with tempfile.TemporaryDirectory() as d:
        netcosim("sweep", f"{_bad_syntax_file(d)}:main", "--grid", "a=1", "--out", f"{d}/s")


def _timed(call, limit=5.0):
    """*call* must fail within *limit* seconds (the audit's versions stalled or waited 10-22 s)."""
    import time
    t0 = time.monotonic()
    try:
        call()
    finally:
        assert time.monotonic() - t0 < limit, f"took {time.monotonic() - t0:.1f} s"


CASES += [
    Case(id="sweep-seeds-beyond-max-runs", call=lambda: _timed(lambda: sweep(grid={"a": [1]}, seeds=10**13)),
         exc=CE, names="10000000000000"),
    Case(id="sweep-grid-times-seeds-beyond-max-runs",
         call=lambda: _timed(lambda: sweep(grid={"a": list(range(1000)), "b": [0.5]}, seeds=10**5)),
         exc=CE, names="100000000 runs"),
    Case(id="sweep-grid-product-beyond-max-runs",
         call=lambda: _timed(lambda: sweep(grid={"a": list(range(10**4)), "b": list(range(10**4))})),
         exc=CE, names="100000000 cases"),
    Case(id="sweep-notify-not-callable", call=lambda: sweep(notify=5), exc=CTE, names="got 5"),
    Case(id="sweep-out-unwritable", call=lambda: sweep(out="/proc/x"), exc=CE, names="'/proc/x'"),
    Case(id="sweep-out-under-a-file", call=lambda: sweep(out=__file__ + "/s"), exc=CE,
         names=repr(__file__ + "/s")),
    Case(id="sweep-timeout-beyond-max", call=lambda: sweep(timeout=1e300), exc=CE, names="1e+300"),
    Case(id="sweep-scheduler-no-port", call=lambda: _timed(lambda: sweep(scheduler="notanaddress")), exc=CE,
         names="'notanaddress'"),
    Case(id="sweep-scheduler-url-no-port", call=lambda: _timed(lambda: sweep(scheduler="tcp://host")), exc=CE,
         names="'tcp://host'"),
    Case(id="sweep-scheduler-port-out-of-range", call=lambda: sweep(scheduler="tcp://host:99999"), exc=CE,
         names="'tcp://host:99999'"),
    Case(id="cli-sweep-seeds-beyond-max-runs",
         call=lambda: _timed(lambda: cli_in_dir("sweep", "sweep_scenarios:cheap", "--grid", "a=1", "--grid", "b=2",
                                                "--seeds", "1000000000000", "--out", "DIR/s")),
         exc=CommandFailed, names="1000000000000"),
    Case(id="cli-sweep-out-unwritable", call=lambda: netcosim("sweep", "sweep_scenarios:cheap", "--grid", "a=1",
                                                              "--grid", "b=2", "--out", "/proc/x"),
         exc=CommandFailed, names="--out '/proc/x'"),
    Case(id="cli-sweep-timeout-beyond-max",
         call=lambda: cli_in_dir("sweep", "sweep_scenarios:cheap", "--grid", "a=1", "--grid", "b=2",
                                 "--timeout", "1e300", "--out", "DIR/s"),
         exc=CommandFailed, names="1e+300"),
    Case(id="cli-sweep-scenario-syntax-error", call=cli_bad_syntax, exc=CommandFailed,
         names="bad_syntax_scenario.py:1: SyntaxError"),
    Case(id="cli-sweep-scheduler-not-an-address",
         call=lambda: _timed(lambda: cli_in_dir("sweep", "sweep_scenarios:cheap", "--grid", "a=1", "--grid", "b=2",
                                                "--scheduler", "notanaddress", "--out", "DIR/s")),
         exc=CommandFailed, names="'notanaddress'"),
]

CASES += [
    Case(id="sweep-seed-list-beyond-max-runs",
         call=lambda: _timed(lambda: sweep(seeds=np.broadcast_to(np.int64(0), (10**7 + 1,)))), exc=CE,
         names="10000001 seeds"),
    Case(id="sweep-long-seed-list-with-a-duplicate",
         call=lambda: _timed(lambda: sweep(seeds=[*range(10**5), 7])), exc=CE, names="seed 7 twice"),
]
