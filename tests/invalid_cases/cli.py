"""Bad arguments to the ``netcosim`` command, the main job and the plot API.

A command-line case runs the command in-process and raises :class:`CommandFailed`
carrying the exit status and everything printed on stderr when the status is the
expected one (2 for usage errors); any other status is a test failure.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import pandas as pd

from invalid_cases import Case


class CommandFailed(Exception):
    """A command exited with its usage-error status; the message is its stderr."""


def _command(entry, argv, status=2):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = entry(list(argv))
        except SystemExit as e:
            code = e.code
    if code != status:
        raise AssertionError(f"{argv}: exit status {code!r}, expected {status}; stderr: {err.getvalue()!r}")
    raise CommandFailed(f"exit {code}: {err.getvalue()}")


def netcosim(*argv):
    from netcosim.cli import main
    _command(main, argv)


def main_job(*argv):
    from netcosim.experiments.main import cli
    _command(cli, argv)


def _schedule() -> pd.DataFrame:
    # one task running 0-2 ms and 10-12 ms on node "cpu"
    return pd.DataFrame({"time": [0.0, 0.002, 0.010, 0.012], "node": "cpu", "task": "t",
                         "state": ["running", "idle", "running", "idle"]})


def plot_file(*options, name="trace.parquet", content=None):
    """``netcosim plot schedule DIR/name [options]`` with a valid schedule (or *content* bytes)."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / name
        if content is None:
            _schedule().to_parquet(path)
        else:
            path.write_bytes(content)
        netcosim("plot", "schedule", str(path), "-o", str(Path(d) / "s.png"), *options)


def plot_frame(frame: pd.DataFrame, name="frame.parquet"):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / name
        frame.to_parquet(path)
        netcosim("plot", "schedule", str(path), "-o", str(Path(d) / "s.png"))


def plot_api(**kw):
    from netcosim.plot import plot_schedule
    plot_schedule(_schedule(), **kw)


def plot_network_api(**kw):
    from netcosim.network.plot import plot_network_schedule
    df = pd.DataFrame({"time": [0.0, 0.001], "network": "net", "node": "a", "state": ["sending", "idle"]})
    plot_network_schedule(df, **kw)


def job(**kw):
    from netcosim.experiments.main import main
    main(experiments=[("fake.never_run", "never run")], **kw)


NAN = float("nan")

CASES = [
    # netcosim run
    Case(id="cli-run-unknown-experiment", call=lambda: netcosim("run", "no_such_experiment"),
         exc=CommandFailed, names="'no_such_experiment'"),
    Case(id="cli-run-empty-name", call=lambda: netcosim("run", ""), exc=CommandFailed, names="''"),
    Case(id="cli-run-unknown-function", call=lambda: netcosim("run", "netcosim.experiments.servo:nope"),
         exc=CommandFailed, names="'nope'"),
    Case(id="cli-run-no-function-after-colon", call=lambda: netcosim("run", "servo:"),
         exc=CommandFailed, names="'servo:'"),
    Case(id="cli-run-missing-file", call=lambda: netcosim("run", "./no_such_file.py"),
         exc=CommandFailed, names="'./no_such_file.py'"),
    Case(id="cli-run-unknown-module", call=lambda: netcosim("run", "no_such_pkg.mod:run"),
         exc=CommandFailed, names="'no_such_pkg.mod'"),
    Case(id="cli-run-not-callable", call=lambda: netcosim("run", "math:pi"), exc=CommandFailed, names="'pi'"),
    Case(id="cli-run-module-without-main", call=lambda: netcosim("run", "json.decoder"),
         exc=CommandFailed, names="'main'"),
    Case(id="cli-run-no-quick-mode", call=lambda: netcosim("run", "math:sqrt", "--quick"),
         exc=CommandFailed, names="'math:sqrt'"),
    Case(id="cli-run-empty-outdir", call=lambda: netcosim("run", "servo", "--outdir", ""),
         exc=CommandFailed, names="''"),
    Case(id="cli-run-missing-experiment-argument", call=lambda: netcosim("run"), exc=CommandFailed,
         names="experiment"),
    Case(id="cli-run-unknown-option", call=lambda: netcosim("run", "servo", "--fast"), exc=CommandFailed,
         names="--fast"),
    Case(id="cli-unknown-command", call=lambda: netcosim("sweeep", "servo"), exc=CommandFailed, names="'sweeep'"),
    # netcosim plot
    Case(id="cli-plot-missing-trace", call=lambda: netcosim("plot", "schedule", "/no/such/dir/trace.parquet"),
         exc=CommandFailed, names="'/no/such/dir/trace.parquet'"),
    Case(id="cli-plot-corrupt-trace", call=lambda: plot_file(name="corrupt_trace.parquet", content=b"PAR1 junk"),
         exc=CommandFailed, names="corrupt_trace.parquet'"),
    Case(id="cli-plot-empty-file", call=lambda: plot_file(name="empty_trace.parquet", content=b""),
         exc=CommandFailed, names="empty_trace.parquet'"),
    Case(id="cli-plot-directory", call=lambda: netcosim("plot", "schedule", tempfile.gettempdir()),
         exc=CommandFailed, names=repr(tempfile.gettempdir())),
    Case(id="cli-plot-not-a-schedule", call=lambda: plot_frame(pd.DataFrame({"time": [0.0], "value": [1.0]})),
         exc=CommandFailed, names="['node', 'task', 'state']"),
    Case(id="cli-plot-unknown-kind", call=lambda: netcosim("plot", "jobs", "trace.parquet"), exc=CommandFailed,
         names="'jobs'"),
    Case(id="cli-plot-t0-nan", call=lambda: plot_file("--t0", "nan"), exc=CommandFailed, names="nan"),
    Case(id="cli-plot-t1-inf", call=lambda: plot_file("--t1", "inf"), exc=CommandFailed, names="inf"),
    Case(id="cli-plot-t0-minus-inf", call=lambda: plot_file("--t0=-inf", "--t1", "0.01"), exc=CommandFailed,
         names="-inf"),
    Case(id="cli-plot-reversed-window", call=lambda: plot_file("--t0", "0.01", "--t1", "0.005"),
         exc=CommandFailed, names="--t0 0.01 --t1 0.005"),
    Case(id="cli-plot-empty-window", call=lambda: plot_file("--t0", "0.004", "--t1", "0.004"),
         exc=CommandFailed, names="--t0 0.004 --t1 0.004"),
    Case(id="cli-plot-t0-after-the-end", call=lambda: plot_file("--t0", "5"), exc=CommandFailed,
         names="(5.0, None)"),
    Case(id="cli-plot-t1-before-the-start", call=lambda: plot_file("--t1", "-1"), exc=CommandFailed,
         names="(None, -1.0)"),
    Case(id="cli-plot-t0-not-a-number", call=lambda: plot_file("--t0", "soon"), exc=CommandFailed,
         names="'soon'"),
    Case(id="cli-plot-unknown-node", call=lambda: plot_file("--node", "gpu"), exc=CommandFailed, names="'gpu'"),
    Case(id="cli-plot-unwritable-output",
         call=lambda: plot_file("-o", "/no/such/dir/s.png"), exc=CommandFailed, names="'/no/such/dir/s.png'"),
    Case(id="cli-plot-unknown-image-format", call=lambda: plot_file("-o", "schedule.bmpx"), exc=CommandFailed,
         names="'bmpx'"),
    # python -m netcosim.experiments.main
    Case(id="cli-main-job-timeout-zero", call=lambda: main_job("--timeout", "0"), exc=CommandFailed,
         names="got 0.0"),
    Case(id="cli-main-job-timeout-nan", call=lambda: main_job("--timeout", "nan"), exc=CommandFailed, names="nan"),
    Case(id="cli-main-job-timeout-negative", call=lambda: main_job("--timeout=-5"), exc=CommandFailed,
         names="-5.0"),
    Case(id="cli-main-job-timeout-text", call=lambda: main_job("--timeout", "long"), exc=CommandFailed,
         names="'long'"),
    Case(id="cli-main-job-unknown-experiment", call=lambda: main_job("--only", "servo", "serv0"),
         exc=CommandFailed, names="'serv0'"),
    Case(id="cli-main-job-empty-outdir", call=lambda: main_job("--outdir", ""), exc=CommandFailed, names="''"),
    Case(id="cli-main-job-positional", call=lambda: main_job("results"), exc=CommandFailed, names="results"),
    # the main job from Python
    Case(id="cli-main-job-api-timeout-nan", call=lambda: job(timeout=NAN), exc=ValueError, names="nan"),
    Case(id="cli-main-job-api-timeout-negative", call=lambda: job(timeout=-1), exc=ValueError, names="-1"),
    Case(id="cli-main-job-api-timeout-text", call=lambda: job(timeout="60"), exc=TypeError, names="'60'"),
    Case(id="cli-main-job-api-unknown-only", call=lambda: job(only=["servo"]), exc=ValueError, names="'servo'"),
    # the plot API
    Case(id="cli-plot-api-t-range-nan", call=lambda: plot_api(t_range=(NAN, 0.01)), exc=ValueError, names="nan"),
    Case(id="cli-plot-api-t-range-inf", call=lambda: plot_api(t_range=(0.0, float("inf"))), exc=ValueError,
         names="inf"),
    Case(id="cli-plot-api-t-range-reversed", call=lambda: plot_api(t_range=(0.01, 0.005)), exc=ValueError,
         names="(0.01, 0.005)"),
    Case(id="cli-plot-api-t-range-empty", call=lambda: plot_api(t_range=(0.004, 0.004)), exc=ValueError,
         names="(0.004, 0.004)"),
    Case(id="cli-plot-api-t-range-open-after-end", call=lambda: plot_api(t_range=(1.0, None)), exc=ValueError,
         names="(1.0, None)"),
    Case(id="cli-plot-api-t-range-string", call=lambda: plot_api(t_range="0,1"), exc=TypeError, names="'0,1'"),
    Case(id="cli-plot-api-t-range-one-value", call=lambda: plot_api(t_range=(0.01,)), exc=TypeError,
         names="(0.01,)"),
    Case(id="cli-plot-api-t-range-text-end", call=lambda: plot_api(t_range=(0.0, "0.01")), exc=TypeError,
         names="'0.01'"),
    Case(id="cli-plot-api-t-range-bool", call=lambda: plot_api(t_range=(False, 0.01)), exc=TypeError,
         names="False"),
    Case(id="cli-plot-api-unknown-node", call=lambda: plot_api(node="gpu"), exc=ValueError, names="'gpu'"),
    Case(id="cli-plot-api-unknown-task", call=lambda: plot_api(tasks=["t", "u"]), exc=KeyError, names="'u'"),
    Case(id="cli-plot-network-api-t-range-nan", call=lambda: plot_network_api(t_range=(0.0, NAN)), exc=ValueError,
         names="nan"),
    Case(id="cli-plot-network-api-t-range-reversed", call=lambda: plot_network_api(t_range=(0.001, 0.0)),
         exc=ValueError, names="(0.001, 0.0)"),
]


def plot_signals_api(signals, **kw):
    from netcosim.plot import plot_signals
    plot_signals(signals, [("p", "y")], **kw)


def _plot_schedule(schedule, **kw):
    from netcosim.plot import plot_schedule
    plot_schedule(schedule, **kw)


def _plot_network(schedule, **kw):
    from netcosim.network.plot import plot_network_schedule
    plot_network_schedule(schedule, **kw)


_SIGNALS = pd.DataFrame({"time": [0.0, 0.1], "source": "p", "signal": "y", "value": [0.0, 1.0]})

# the audit's plot cases: what is missing named, an unwritable image path refused before drawing
CASES += [
    Case(id="plot-api-schedule-path-in-missing-folder", call=lambda: plot_api(path="/proc/x/y.png"),
         exc=ValueError, names="'/proc/x/y.png'"),
    Case(id="plot-api-schedule-path-a-folder", call=lambda: plot_api(path=tempfile.gettempdir()),
         exc=ValueError, names=repr(tempfile.gettempdir())),
    Case(id="plot-api-schedule-path-without-extension", call=lambda: plot_api(path="/tmp/noext"), exc=ValueError,
         names="'/tmp/noext' has no file extension"),
    Case(id="plot-api-schedule-missing-columns", call=lambda: _plot_schedule(pd.DataFrame({"a": [1]})),
         exc=KeyError, names="['time', 'node', 'task', 'state']"),
    Case(id="plot-api-schedule-not-a-frame", call=lambda: _plot_schedule(42), exc=TypeError, names="int 42"),
    Case(id="plot-api-schedule-window-outside-the-data", call=lambda: plot_api(t_range=(5.0, 6.0)), exc=ValueError,
         names="time span 0.0 to 0.012 s"),
    Case(id="plot-api-schedule-window-below-resolution", call=lambda: plot_api(t_range=(0.0, 1e-15)),
         exc=ValueError, names="(0.0, 1e-15)"),
    Case(id="plot-api-network-missing-columns", call=lambda: _plot_network(pd.DataFrame({"a": [1]})),
         exc=KeyError, names="['time', 'network', 'node', 'state']"),
    Case(id="plot-api-network-not-a-frame", call=lambda: _plot_network(42), exc=TypeError, names="int 42"),
    Case(id="plot-api-network-path-in-missing-folder", call=lambda: plot_network_api(path="/proc/x/y.png"),
         exc=ValueError, names="'/proc/x/y.png'"),
    Case(id="plot-api-signals-not-a-frame", call=lambda: plot_signals_api(42), exc=TypeError, names="int 42"),
    Case(id="plot-api-signals-missing-columns", call=lambda: plot_signals_api(pd.DataFrame({"time": [0.0]})),
         exc=KeyError, names="['source', 'signal', 'value']"),
    Case(id="plot-api-signals-path-in-missing-folder", call=lambda: plot_signals_api(_SIGNALS, path="/proc/x/y.png"),
         exc=ValueError, names="'/proc/x/y.png'"),
]
