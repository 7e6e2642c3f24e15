"""CPU-time models: fixed, recorded (replayed job by job) and wall-clock (opt-in)."""

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from conftest import SteppingClock

from netcosim import Simulation
from netcosim.cputime import FixedCPUTime, NonReproducibleWarning, RecordedCPUTime, WallClockCPUTime


def test_fixed_budget_per_phase_and_the_log():
    m = FixedCPUTime({"feedback": 2e-3, "prepare": 5e-4})
    with m.measure("feedback") as a:
        pass
    assert a.seconds == 2e-3
    assert m.charge("prepare") == 5e-4
    assert m.charge("feedback") == 2e-3
    rec = m.record()
    assert rec[["phase", "index", "cpu"]].values.tolist() == [["feedback", 0, 2e-3], ["prepare", 0, 5e-4],
                                                              ["feedback", 1, 2e-3]]
    assert rec["wall"].isna().all()
    with pytest.raises(ValueError, match="no fixed CPU time for phase 'solve'"):
        m.charge("solve")


def test_recorded_times_replay_in_order_then_cycle_repeat_or_stop():
    table = {"solve": [1e-3, 2e-3, 3e-3]}
    assert [RecordedCPUTime(table).charge("solve") for _ in range(1)] == [1e-3]
    cyc, last, err = (RecordedCPUTime(table, beyond=b) for b in ("cycle", "last", "error"))
    assert [cyc.charge("solve") for _ in range(5)] == [1e-3, 2e-3, 3e-3, 1e-3, 2e-3]
    assert [last.charge("solve") for _ in range(5)] == [1e-3, 2e-3, 3e-3, 3e-3, 3e-3]
    assert [err.charge("solve") for _ in range(3)] == [1e-3, 2e-3, 3e-3]
    with pytest.raises(ValueError, match="run out: charge 3 of a recording of 3"):
        err.charge("solve")
    assert RecordedCPUTime(table, scale=2.0).charge("solve") == 2e-3


def test_wall_clock_charges_factor_times_the_injected_clock_and_warns():
    with pytest.warns(NonReproducibleWarning, match="not reproducible"):
        m = WallClockCPUTime(3.0, clock=SteppingClock([1e-3, 4e-3]))
    assert not m.reproducible
    with m.measure("a") as x:
        pass
    with m.measure("a") as y:
        pass
    assert (x.seconds, y.seconds) == (3e-3, pytest.approx(12e-3, rel=1e-15))
    np.testing.assert_allclose(m.record()["wall"], [1e-3, 4e-3], rtol=1e-15)
    with pytest.raises(RuntimeError, match="must time the computation"):
        m.charge("a")


def test_a_recording_saved_and_loaded_replays_exactly(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonReproducibleWarning)
        m = WallClockCPUTime(1.0, clock=SteppingClock([1 / 3, 2 / 7, 1e-3 / 9]))
    for _ in range(3):
        with m.measure("solve"):
            pass
    for suffix in (".csv", ".parquet"):
        path = m.save(tmp_path / f"rec{suffix}")
        replay = RecordedCPUTime.load(path)
        assert [replay.charge("solve") for _ in range(3)] == m.record()["cpu"].tolist()


def test_fresh_copy_starts_the_replay_again():
    m = RecordedCPUTime({"solve": [1e-3, 2e-3]})
    m.charge("solve")
    f = m.fresh()
    assert f.charge("solve") == 1e-3 and len(f.record()) == 1 and len(m.record()) == 1


def test_a_task_charged_by_a_recorded_model_gives_the_known_schedule():
    """Three jobs of a 10 ms task cost 2, 7 and 3 ms: finishes at 2, 17 and 23 ms."""
    sim = Simulation(seed=0)
    cpu = sim.node("cpu")
    model = RecordedCPUTime({"job": [2e-3, 7e-3, 3e-3]})

    @cpu.periodic(period=0.01, priority=1)
    def task(ctx):
        yield ctx.execute(model.charge("job"))

    sim.run(until=0.03)
    jobs = sim.trace.jobs()
    np.testing.assert_allclose(jobs["finish"].to_numpy()[:3], [0.002, 0.017, 0.023], atol=1e-12)


def test_measurement_read_before_its_block_ends_raises():
    m = FixedCPUTime(1e-3)
    with m.measure("x") as a:
        with pytest.raises(RuntimeError, match="phase 'x' read before its measured block finished"):
            a.seconds
    assert not math.isnan(a.seconds)


def test_recorded_table_from_a_dataframe_sorts_by_index():
    df = pd.DataFrame({"phase": ["p", "p", "q"], "index": [1, 0, 0], "cpu": [2e-3, 1e-3, 5e-3]})
    m = RecordedCPUTime(df)
    assert [m.charge("p"), m.charge("p"), m.charge("q")] == [1e-3, 2e-3, 5e-3]


@pytest.mark.parametrize("times", [0.002, "0.002", None])
def test_recorded_times_of_a_phase_must_be_a_sequence(times):
    from netcosim.errors import ConfigurationTypeError
    with pytest.raises(ConfigurationTypeError, match=r"phase 'solve' must be a sequence of seconds .*got "
                       + repr(times).replace(".", r"\.")):
        RecordedCPUTime({"solve": times})
