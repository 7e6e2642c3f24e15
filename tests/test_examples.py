"""The shipped TrueTime examples: three servos under overload, the main job, real-time mode."""

import time

import numpy as np
import pytest

from netcosim import Simulation
from netcosim.experiments import main as main_job
from netcosim.experiments import threeservos
from netcosim.plot import plot_schedule
from netcosim.testing import running_intervals


def run(policy, until=1.0):
    sim = threeservos.build(policy)
    sim.run(until=until)
    return sim


def finished_per_window(jobs, task, windows):
    f = jobs[(jobs["task"] == task) & jobs["finish"].notna()]["finish"].to_numpy()
    return np.histogram(f, bins=windows)[0]


def test_deadline_monotonic_starves_the_lowest_priority_loop():
    sim = run("deadline_monotonic")
    jobs = sim.trace.jobs()
    pid1 = jobs[jobs["task"] == "pid1"]       # 6 ms period: lowest DM priority
    # utilisation of the two others is 0.9: pid1 gets 10 % of the CPU, i.e. one 2 ms job
    # per 20 ms, while it releases one per 6 ms -- its backlog grows without bound
    due = pid1[pid1["deadline"] <= 1.0]
    assert due["deadline_miss"].iloc[1:].all()    # after the first job, every job misses
    late = pid1[pid1["finish"].notna()]
    assert late["response_time"].is_monotonic_increasing
    assert late["response_time"].iloc[-1] > 0.5
    assert 45 <= len(late) <= 52
    for t in ("pid2", "pid3"):
        assert not jobs[jobs["task"] == t]["deadline_miss"].any()
    # the starved loop has lost control of its servo
    y = sim.trace.signal("cpu.pid1", "y").to_numpy()
    assert np.max(np.abs(y)) > 3.0


def test_edf_keeps_every_loop_running():
    sim = run("edf")
    jobs = sim.trace.jobs()
    windows = np.arange(0.0, 1.0001, 0.1)
    for task, h in (("pid1", 0.006), ("pid2", 0.005), ("pid3", 0.004)):
        counts = finished_per_window(jobs, task, windows)
        assert (counts >= 10).all(), (task, counts)       # every loop runs in every 100 ms
        assert jobs[jobs["task"] == task]["deadline_miss"].mean() > 0.9  # but overloaded
        y = sim.trace.signal(f"cpu.{task}", "y").to_numpy()
        assert np.max(np.abs(y)) < 1.5                    # control stays acceptable


def test_schedule_plot_is_written(tmp_path):
    sim = run("edf", until=0.05)
    path = tmp_path / "s.png"
    ax = plot_schedule(sim.trace.schedule(), t_range=(0, 0.03), path=path)
    assert path.stat().st_size > 10_000
    assert [t.get_text() for t in ax.get_yticklabels()] == ["cpu.pid3", "cpu.pid2", "cpu.pid1"]


def test_main_job_writes_results(tmp_path, capsys):
    assert main_job.main(str(tmp_path), only=["servo", "threeservos"]) == 0
    out = capsys.readouterr().out
    assert "edf [pid1:" in out
    for f in ("servo/servo_output.png", "servo/servo_schedule.png", "servo/jobs.parquet",
              "threeservos/edf_schedule.png", "threeservos/deadline_monotonic_outputs.png",
              "threeservos/edf_signals.parquet"):
        assert (tmp_path / f).exists(), f


def test_realtime_mode_paces_against_the_wall_clock():
    sim = Simulation(realtime=True, factor=1.0, strict=False)
    cpu = sim.node("cpu")
    stamps = []

    def body(ctx):
        stamps.append(time.monotonic())
        yield ctx.execute(0.001)
    cpu.periodic(body, period=0.02, priority=1)
    time.sleep(0.05)        # set-up time before the run does not count: pacing starts at run()
    t0 = time.monotonic()
    sim.run(until=0.1)
    assert time.monotonic() - t0 >= 0.1 - 1e-3
    assert stamps[-1] - stamps[0] >= 0.08 - 1e-3  # five releases 20 ms apart in wall time


def test_realtime_bad_factor():
    with pytest.raises(ValueError, match="factor.*-1"):
        Simulation(realtime=True, factor=-1)


def test_every_main_job_entry_is_a_runnable_experiment():
    import importlib
    import inspect
    for name, what in main_job.EXPERIMENTS:
        mod = importlib.import_module(f"experiments.{name}")
        assert "outdir" in inspect.signature(mod.main).parameters, name
        assert what


@pytest.mark.parametrize("server", ["cbs", "tbs"])
def test_a_server_on_the_4ms_loop_isolates_the_other_two(server):
    """TrueTime's modes 5 (CBS, Qs = 1 ms, Ts = 4 ms) and 6 (TBS, Us = 0.25): loops 1 and 2
    (73 % of the CPU) meet every deadline; loop 3 gets 25 % of the 50 % it needs."""
    sim = threeservos.build("edf", server=server)
    sim.run(until=1.0)
    jobs = sim.trace.jobs()
    done = jobs[jobs["finish"].notna()].groupby("task", observed=True).size()
    assert done["pid1"] == 167 and done["pid2"] == 200          # every job of 1 s (ceil(1/h))
    assert not jobs[jobs["task"].isin(["pid1", "pid2"])]["deadline_miss"].any()
    # loop 3 gets its 25 % and the CPU the others leave idle, 1 - 2/6 - 2/5 = 26.7 %:
    # one 2 ms job per 7.5 ms, 133 in 1 s at most
    assert 120 <= done["pid3"] <= 133
    run3 = sum(e - b for b, e in running_intervals(
        sim.trace.schedule(), node="cpu", until=1.0)["pid3"])
    assert 0.25 - 0.002 <= run3 <= 1 - 2 / 6 - 2 / 5 + 1e-9
    for i in (1, 2):                                            # and both control well
        y = sim.trace.signal(f"cpu.pid{i}", "y").to_numpy()
        assert np.abs(y).max() < 1.5
