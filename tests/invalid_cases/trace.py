"""Bad trace configurations: modes, ring sizes, windows, decimation, stream paths, table names."""

from __future__ import annotations

import tempfile
from pathlib import Path

from invalid_cases import Case
from netcosim import Simulation
from netcosim.errors import ConfigurationError, ConfigurationTypeError, TraceWriteError


def _conf(*args, **kw):
    Simulation().trace.configure(*args, **kw)


def _conf_all(*args, **kw):
    Simulation().trace.configure_all(*args, **kw)


def _stream_into_a_file():
    with tempfile.NamedTemporaryFile(suffix=".parquet") as f:
        _conf("signals", mode="stream", path=f.name)


def _stream_below_a_file():
    with tempfile.NamedTemporaryFile() as f:
        _conf("signals", mode="stream", path=str(Path(f.name) / "sub"))


def _stream_into_old_parts():
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "part-000000.parquet").write_bytes(b"")
        _conf("signals", mode="stream", path=d)


def _clear_unknown():
    Simulation().trace.clear("sginals")


def _conf_tmp(*args, **kw):
    """configure(..., path=<a fresh temporary directory>, ...)."""
    with tempfile.TemporaryDirectory() as d:
        _conf(*args, path=d, **kw)


def _conf_all_tmp(*args, **kw):
    with tempfile.TemporaryDirectory() as d:
        _conf_all(*args, path=d, **kw)


def _rti(history_length):
    from test_nmpc import cartpole_ocp

    from netcosim.controllers.nmpc import RTINMPC
    RTINMPC(cartpole_ocp(N=5), history_length=history_length)


CASES = [
    Case(id="trace-mode-unknown", call=lambda: _conf("signals", mode="fast"), exc=ConfigurationError,
         names="'fast'"),
    Case(id="trace-mode-case", call=lambda: _conf("signals", mode="Ring", rows=3), exc=ConfigurationError,
         names="'Ring'"),
    Case(id="trace-mode-none", call=lambda: _conf("signals", mode=None), exc=ValueError, names="None"),
    Case(id="trace-table-unknown", call=lambda: _conf("sginals", mode="off"), exc=ConfigurationError,
         names="'sginals'"),
    Case(id="trace-table-frames-before-network", call=lambda: _conf("frames", mode="off"),
         exc=ValueError, names="'frames'"),
    Case(id="trace-table-not-str", call=lambda: _conf(3, mode="off"), exc=ConfigurationTypeError, names="3"),
    Case(id="trace-clear-unknown", call=_clear_unknown, exc=ValueError, names="'sginals'"),
    Case(id="trace-ring-zero", call=lambda: _conf("jobs", mode="ring", rows=0), exc=ConfigurationError,
         names="got 0"),
    Case(id="trace-ring-negative", call=lambda: _conf("jobs", mode="ring", rows=-1), exc=ConfigurationError,
         names="-1"),
    Case(id="trace-ring-fraction", call=lambda: _conf("jobs", mode="ring", rows=2.5), exc=ConfigurationError,
         names="2.5"),
    Case(id="trace-ring-nan", call=lambda: _conf("jobs", mode="ring", rows=float("nan")),
         exc=ConfigurationError, names="nan"),
    Case(id="trace-ring-string", call=lambda: _conf("jobs", mode="ring", rows="100"),
         exc=ConfigurationTypeError, names="'100'"),
    Case(id="trace-ring-bool", call=lambda: _conf("jobs", mode="ring", rows=True), exc=ConfigurationTypeError,
         names="True"),
    Case(id="trace-ring-missing-rows", call=lambda: _conf("jobs", mode="ring"), exc=ConfigurationError,
         names="rows"),
    Case(id="trace-window-negative", call=lambda: _conf("signals", mode="window", seconds=-0.5),
         exc=ConfigurationError, names="-0.5"),
    Case(id="trace-window-nan", call=lambda: _conf("signals", mode="window", seconds=float("nan")),
         exc=ConfigurationError, names="nan"),
    Case(id="trace-window-inf", call=lambda: _conf("signals", mode="window", seconds=float("inf")),
         exc=ConfigurationError, names="inf"),
    Case(id="trace-window-zero", call=lambda: _conf("schedule", mode="window", seconds=0.0),
         exc=ConfigurationError, names="0.0"),
    Case(id="trace-window-below-resolution", call=lambda: _conf("schedule", mode="window", seconds=1e-13),
         exc=ConfigurationError, names="1e-13"),
    Case(id="trace-window-string", call=lambda: _conf("schedule", mode="window", seconds="5"),
         exc=ConfigurationTypeError, names="'5'"),
    Case(id="trace-window-with-rows", call=lambda: _conf("jobs", mode="window", seconds=1.0, rows=10),
         exc=ConfigurationError, names="rows=10"),
    Case(id="trace-keep-with-seconds", call=lambda: _conf("jobs", mode="keep", seconds=2.0),
         exc=ConfigurationError, names="seconds=2.0"),
    Case(id="trace-every-zero", call=lambda: _conf("signals", every=0), exc=ConfigurationError, names="got 0"),
    Case(id="trace-every-negative", call=lambda: _conf("signals", every=-2), exc=ConfigurationError,
         names="-2"),
    Case(id="trace-every-fraction", call=lambda: _conf("signals", every=1.5), exc=ConfigurationError,
         names="1.5"),
    Case(id="trace-every-on-jobs", call=lambda: _conf("jobs", every=10), exc=ConfigurationError,
         names="every=10"),
    Case(id="trace-every-with-off", call=lambda: _conf("signals", mode="off", every=4), exc=ConfigurationError,
         names="every=4"),
    Case(id="trace-stream-no-path", call=lambda: _conf("signals", mode="stream"), exc=ConfigurationError,
         names="path"),
    Case(id="trace-stream-path-int", call=lambda: _conf("signals", mode="stream", path=42),
         exc=ConfigurationTypeError, names="42"),
    Case(id="trace-stream-path-empty", call=lambda: _conf("signals", mode="stream", path=""),
         exc=ConfigurationTypeError, names="''"),
    Case(id="trace-stream-path-is-a-file", call=_stream_into_a_file, exc=ConfigurationError,
         names=".parquet'"),
    Case(id="trace-stream-path-below-a-file", call=_stream_below_a_file, exc=ConfigurationError,
         names="sub'"),
    Case(id="trace-stream-old-parts", call=_stream_into_old_parts, exc=ConfigurationError,
         names="part-000000.parquet"),
    Case(id="trace-stream-row-group-zero",
         call=lambda: _conf_tmp("signals", mode="stream", row_group=0),
         exc=ConfigurationError, names="got 0"),
    Case(id="trace-stream-overwrite-str",
         call=lambda: _conf_tmp("signals", mode="stream", overwrite="yes"),
         exc=ConfigurationTypeError, names="'yes'"),
    Case(id="trace-path-with-ring", call=lambda: _conf("signals", mode="ring", rows=5, path="/tmp/x"),
         exc=ConfigurationError, names="'/tmp/x'"),
    Case(id="trace-all-mode-unknown", call=lambda: _conf_all("rings", rows=5), exc=ConfigurationError,
         names="'rings'"),
    Case(id="trace-all-ring-zero", call=lambda: _conf_all("ring", rows=0), exc=ConfigurationError,
         names="got 0"),
    Case(id="trace-all-window-nan", call=lambda: _conf_all("window", seconds=float("nan")),
         exc=ConfigurationError, names="nan"),
    Case(id="trace-all-stream-no-path", call=lambda: _conf_all("stream"), exc=ConfigurationError, names="path"),
    Case(id="trace-all-stream-row-group-fraction",
         call=lambda: _conf_all_tmp("stream", row_group=0.5), exc=ConfigurationError,
         names="0.5"),
    Case(id="trace-rti-history-negative", call=lambda: _rti(-1), exc=ConfigurationError, names="-1"),
    Case(id="trace-rti-history-fraction", call=lambda: _rti(2.5), exc=ConfigurationError, names="2.5"),
]


# Audit fixes: an unwritable to_parquet directory, a ring size beyond any memory.
def _to_parquet(directory):
    sim = Simulation()

    def b(ctx):
        yield ctx.execute(0.001)
    sim.node("cpu").periodic(b, period=0.01, priority=1, name="t")
    sim.run(0.02)
    sim.trace.to_parquet(directory)


def _to_parquet_below_a_file():
    with tempfile.NamedTemporaryFile() as f:
        _to_parquet(str(Path(f.name) / "sub"))


CASES += [
    Case(id="trace-to-parquet-unwritable-dir", call=lambda: _to_parquet("/proc/x"), exc=TraceWriteError,
         names="'/proc/x'"),
    Case(id="trace-to-parquet-is-oserror", call=lambda: _to_parquet("/proc/x"), exc=OSError, names="/proc/x"),
    Case(id="trace-to-parquet-below-a-file", call=_to_parquet_below_a_file, exc=TraceWriteError, names="sub"),
    Case(id="trace-ring-rows-huge", call=lambda: _conf("jobs", mode="ring", rows=2**70), exc=ConfigurationError,
         names=str(2**70)),
    Case(id="trace-ring-rows-above-max", call=lambda: _conf("jobs", mode="ring", rows=2**40 + 1),
         exc=ConfigurationError, names=str(2**40 + 1)),
]
