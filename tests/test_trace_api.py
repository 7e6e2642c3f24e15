"""Trace.to_pandas and Trace.plot: the tables as DataFrames and the plots drawn from them."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from conftest import lossy_link as _lossy_link  # noqa: E402

from netcosim import Simulation  # noqa: E402
from netcosim.errors import ConfigurationError  # noqa: E402
from netcosim.network.plot import LOST_LABEL  # noqa: E402


def two_tasks():
    """hi (priority 1) runs 2 ms every 10 ms, lo (priority 2) 5 ms every 20 ms, both released at 0."""
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(c, name):
        def run(ctx):
            ctx.log("c", c)
            yield ctx.execute(c)
        return run
    cpu.periodic(body(0.002, "hi"), period=0.01, priority=1, name="hi")
    cpu.periodic(body(0.005, "lo"), period=0.02, priority=2, name="lo")
    sim.run(until=0.02)
    return sim


def test_to_pandas_gives_one_table_or_every_table():
    sim = two_tasks()
    tables = sim.trace.to_pandas()
    assert list(tables) == ["signals", "schedule", "jobs"]
    pd.testing.assert_frame_equal(sim.trace.to_pandas("schedule"), sim.trace.schedule())
    pd.testing.assert_frame_equal(tables["jobs"], sim.trace.jobs())
    sched = tables["schedule"]
    assert sched["time"].tolist() == [0.0, 0.0, 0.0, 0.002, 0.002, 0.007, 0.01, 0.01, 0.012]
    assert sched["state"].tolist() == ["ready", "ready", "running", "idle", "running", "idle", "ready",
                                       "running", "idle"]
    jobs = tables["jobs"].sort_values(["release", "task"])
    assert jobs["response_time"].tolist() == pytest.approx([0.002, 0.007, 0.002])
    assert tables["signals"].attrs["grids"] == {}
    with pytest.raises(KeyError, match="no trace table 'nope'"):
        sim.trace.to_pandas("nope")


def test_a_simulation_without_nodes_still_has_the_kernel_tables():
    sim = Simulation()
    sim.run(0.01)
    assert sim.trace.tables == ["signals", "schedule", "jobs"]
    assert list(sim.trace.to_pandas("schedule").columns) == ["time", "node", "task", "state"]
    assert len(sim.trace.jobs()) == 0


def test_schedule_plot_of_two_tasks():
    sim = two_tasks()
    ax = sim.trace.plot("schedule", t_range=(0.0, 0.02))
    assert [t.get_text() for t in ax.get_yticklabels()] == ["cpu.lo", "cpu.hi"]   # bottom first: hi on top
    lo, hi = ax.get_lines()        # bottom row (0) first
    # TrueTime levels above the row: running 0.5, ready 0.25, idle 0
    x, y = hi.get_data()
    np.testing.assert_array_equal(x, [0.0, 0.002, 0.01, 0.01, 0.012, 0.02])
    np.testing.assert_array_equal(y, [1.5, 1.0, 1.25, 1.5, 1.0, 1.0])
    x, y = lo.get_data()
    np.testing.assert_array_equal(x, [0.0, 0.002, 0.007, 0.02])
    np.testing.assert_array_equal(y, [0.25, 0.5, 0.0, 0.0])
    assert ax.get_xlim() == (0.0, 0.02)
    ax = sim.trace.plot("schedule", node="cpu", tasks=["lo", "hi"])     # top row first
    assert [t.get_text() for t in ax.get_yticklabels()] == ["hi", "lo"]  # tick labels bottom first


def test_signals_plot_draws_every_logged_signal_in_seconds():
    sim = two_tasks()
    ax = sim.trace.plot("signals")
    lines = {ln.get_label(): ln.get_data() for ln in ax.get_lines()}
    assert list(lines) == ["cpu.hi.c", "cpu.lo.c"]
    np.testing.assert_array_equal(lines["cpu.hi.c"][0], [0.0, 0.01])
    np.testing.assert_array_equal(lines["cpu.hi.c"][1], [0.002, 0.002])
    np.testing.assert_array_equal(lines["cpu.lo.c"][0], [0.002])
    ax = sim.trace.plot("signals", columns=[("cpu.lo", "c")], drawstyle="steps-post")
    assert [ln.get_label() for ln in ax.get_lines()] == ["cpu.lo.c"]
    assert ax.get_xlabel() == "time [s]"


def test_network_plot_marks_the_lost_frames():
    sim = _lossy_link()             # a sends 300 bits every ms over a link losing half the frames
    ax = sim.trace.plot("network")
    assert [t.get_text() for t in ax.get_yticklabels()] == ["b", "a"]
    lost = sim.trace.frame("frames")
    lost = lost[lost["event"] == "lost"]
    (marker,) = [ln for ln in ax.get_lines() if ln.get_label() == LOST_LABEL]
    np.testing.assert_array_equal(marker.get_data()[0], lost["time"].to_numpy())
    ax = sim.trace.plot("network", frames=None)
    assert LOST_LABEL not in [ln.get_label() for ln in ax.get_lines()]


def test_unknown_plot_kind_names_the_kinds():
    sim = Simulation()
    with pytest.raises(ConfigurationError, match=r"no plot kind 'network'; have \['schedule', 'signals'\]"):
        sim.trace.plot("network")
    with pytest.raises(ValueError, match="no logged signal"):
        sim.trace.plot("signals")
