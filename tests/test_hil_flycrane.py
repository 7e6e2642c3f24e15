"""The networked Fly-crane with its five nodes in five real processes over Zenoh
(``netcosim.experiments.hil_flycrane`` and ``netcosim.experiments.hil_flycrane_node``): loopback only,
bounded in time, every child reaped and every session closed by the harness.

The robots' law in the process is the simulated one to the bit (a CasADi-free copy fed
the same inputs); the replay (the all-simulated run with the measured response times as
the tasks' execution times) with the nominal times is the all-simulated run to the bit;
the HIL run equals its replay bit for bit and lies within 1.5 times the deviation the
replay explains from the all-simulated run.  The Zenoh tests skip without the ``zenoh``
extra.  Wall time of the five-remote test (measured 6-21 s): 4.5 s of real-time
run, about 2 s of process start-up and comparison, and (for now) 0.5-15.5 s of
``RemoteNode.drain`` waiting, after the run, for END messages and token losses that a
sibling remote's ``drain`` consumed from the clock's shared inbox (5 s per remote whose
END went to another).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from netcosim.transport.session import zenoh_available

ROOT = Path(__file__).resolve().parent.parent
needs_zenoh = pytest.mark.skipif(not zenoh_available(), reason="the zenoh extra (eclipse-zenoh) is not installed")
#: horizon of the default five-remote test (s): three periods of T = 1.5 s
UNTIL = 4.5


def _h():
    from netcosim.experiments import hil_flycrane
    return hil_flycrane


def _deployment(until=3.0):
    from netcosim import Simulation
    from netcosim.controllers.planner.networked import build, setting
    config = _h().flycrane_config(until)
    sim = Simulation(config.seed)
    dep, recorder = build(sim, config)
    return config, sim, dep, recorder, setting(config)[0]


def test_node_process_loads_neither_simpy_nor_casadi():
    code = ("import sys, netcosim.transport.client, netcosim.experiments.hil_flycrane_node; "
            "print(sorted(m for m in ('simpy', 'casadi', 'numpy', 'pandas', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                         capture_output=True, text=True, timeout=60, check=True).stdout
    assert out.strip() == "['numpy']"


def test_the_process_computes_the_simulated_robot_law_bit_for_bit(tmp_path):
    from netcosim.controllers.planner.deployment import CommandRecord, PoseRecord
    from netcosim.controllers.planner.kinematics import diag_gain
    from netcosim.controllers.planner.laws import robot_velocity
    from netcosim.experiments.hil_flycrane_node import SparseLaw, pivot_reply, robot_command
    from netcosim.transport import wire
    config, sim, dep, _, system = _deployment(3.0)
    law = SparseLaw.load(_h().write_law(tmp_path / "law.json", dep, system))   # through the JSON file
    st, q_ref = dep.structure, dep.law.reference(0.0)
    K = float(dep.law.gain.k) * diag_gain(dep.law.kbar, system.m)
    rng = np.random.default_rng(7)
    for _ in range(300):
        q = q_ref + rng.normal(0.0, 0.15, system.m)
        for i in range(st.N):
            q_i, q_V = q[list(st.cols[i])], q[list(st.pivot)]
            expected = robot_velocity(system, st, i, q_i, q_V, q_ref, K)
            assert np.array_equal(law.velocity(i, q_i, q_V), expected)
    # what the simulated tasks computed in a run, fed to the process's handlers as messages
    sim.run(config.horizon)
    poses = {r.h: r for r in dep.records if isinstance(r, PoseRecord)}
    commands = [r for r in dep.records if isinstance(r, CommandRecord)]
    assert len(poses) == 2 and len(commands) == 8
    for c in commands:
        p = poses[c.h]
        sample = wire.Message(wire.DATA, wire.LOCAL, 1, 1, round(p.t * 1e12), p.h, tuple(p.q_V.tolist()))
        frame = pivot_reply(sample)
        assert frame == (float(p.h), p.t, *p.q_V.tolist())
        assert robot_command(law, c.robot, frame + tuple(c.q_i.tolist())) == tuple(c.u_i.tolist())
    with pytest.raises(ValueError, match="takes 9 values"):
        robot_command(law, 0, frame)


def test_jacobian_tape_refuses_unknown_operations():
    from netcosim.experiments.hil_flycrane_node import JacobianTape
    spec = {"n_in": 1, "shape": [1, 1], "work": 2, "nz": [[0, 0]],
            "tape": [["INPUT", 0, 0, 0, None], ["ERF", 1, 0, 0, None], ["OUTPUT", 0, 1, 0, None]]}
    with pytest.raises(ValueError, match="'ERF' is not supported"):
        JacobianTape(spec)
    spec["tape"][1][0] = "SIN"
    assert JacobianTape(spec)([0.5]).tolist() == [[np.sin(0.5)]]


def test_the_replay_with_nominal_times_is_the_simulated_run():
    # networked.build with the execution times given (as the replay gives them) is run(config)
    # for config's constants; ReplayTimes tells the nodes apart by their tasks' execution-time streams
    from netcosim import Simulation
    from netcosim.controllers.planner.networked import build, run
    h = _h()
    config = h.flycrane_config(4.5)
    nominal = run(config)
    sim = Simulation(config.seed)
    dep, rec = build(sim, config, exec_pivot=lambda rng: config.exec_pose, exec_robot=lambda rng: config.exec_robot)
    sim.run(config.horizon)
    t, q, u = rec.arrays()
    assert np.array_equal(t, nominal.t) and np.array_equal(q, nominal.q) and np.array_equal(u, nominal.u)
    times = {"pivot": {k: config.exec_pose for k in range(3)},
             **{f"robot{i}": {k: config.exec_robot for k in range(3)} for i in range(1, 5)}}
    replay, missing = h.run_replay(config, times)
    assert missing == [] and np.array_equal(replay.q, nominal.q) and np.array_equal(replay.u, nominal.u)
    # one robot's second command 2 ms late: the replay moves, the others' times are untouched
    times["robot3"][1] = 2e-3
    late, _ = h.run_replay(config, times)
    assert 0 < h.deviation(late.q, nominal.q) < 1e-4
    del times["robot3"][2]
    _, missing = h.run_replay(config, times)
    assert [(n, k) for n, k, _ in missing] == [("robot3", 2)]


def _check_five_remotes(until, loss=0.0):
    h = _h()
    config = h.flycrane_config(until, loss=loss)
    nominal = h.run_simulated(config)       # first: warms the caches the real-time run would otherwise fill
    hil = h.run_hil(config, connect_timeout=60.0)
    assert hil.failure is None and hil.sim.now == until
    periods = round(until / config.T)
    per = hil.per_remote().set_index("remote")
    assert list(per.index) == ["pivot", "robot1", "robot2", "robot3", "robot4"]
    assert per.loc["pivot", "published"] + per.loc["pivot", "overruns"] == periods
    for name, r in per.iterrows():
        # both sides count the same messages; every published request answered in time, too
        # late (dropped, counted: a loaded machine) or after the end; nothing unserved or refused
        assert r["published"] == r["process_received"] == r["process_published"], name
        late = r.get("dropped_late", 0)
        assert r["received"] + r["after_end"] + late == r["published"], name
        assert r["unserved"] == r["refused"] == 0, name
        assert not [c for c in per.columns if c.startswith("dropped_") and c != "dropped_late" and r[c]], name
        assert r["process_status"] == "ended" and r["response_max"] > 0, name
        if loss == 0:
            assert r["published"] + r["overruns"] == periods, name
    assert all(p["dropped"] == {} for p in hil.processes)
    assert hil.exit_codes == [0] * 5          # every process ended by itself and was reaped
    assert hil.tasks_released == 0            # the simulated tasks of the remote nodes never ran
    pf = hil.prefetch
    assert len(pf.wall) == periods and pf.skipped == 0 and pf.violations() == 0
    # real time: no event processed anywhere near a period late (measured: max 1.5-2 ms)
    assert hil.lateness.max < 0.1 and hil.lateness.events > 10 * periods
    cmp = h.compare(hil, nominal)
    assert cmp.missing == []
    assert cmp.bit_exact and cmp.residual == 0.0
    assert 0 < cmp.explained and cmp.deviation <= cmp.tolerance
    return hil, cmp


@needs_zenoh
@pytest.mark.timeout(180)
def test_five_remote_nodes_reproduce_the_replay_bit_for_bit():
    _check_five_remotes(UNTIL)


@needs_zenoh
@pytest.mark.slow
@pytest.mark.timeout(300)
def test_five_remote_nodes_for_ten_periods_with_losses():
    hil, _ = _check_five_remotes(15.0, loss=0.3)
    per = hil.per_remote().set_index("remote")
    assert per.loc[["robot1", "robot2", "robot3", "robot4"], "published"].sum() < 40    # some frames were lost


@needs_zenoh
@pytest.mark.slow
@pytest.mark.timeout(300)
def test_hil_flycrane_example_writes_its_results(tmp_path):
    import pandas as pd
    table = _h().main(str(tmp_path), quick=True)
    assert {p.name for p in tmp_path.iterdir()} >= {"flycrane_law.json", "outputs.png", "remotes.parquet",
                                                    "summary.parquet", "hil_requests.parquet", "lateness.parquet"}
    row = table.iloc[0]
    assert row["bit_exact"] and row["deviation"] <= row["tolerance"] and row["statuses"] == ",".join(["ended"] * 5)
    assert len(pd.read_parquet(tmp_path / "remotes.parquet")) == 5
    assert json.loads((tmp_path / "flycrane_law.json").read_text())["format"] == "netcosim.flycrane.sparse_law/1"


@pytest.mark.parametrize("module", ["netcosim.experiments.hil_flycrane", "netcosim.experiments.hil_flycrane_node"])
def test_help_answers_without_running(module, tmp_path):
    r = subprocess.run([sys.executable, "-m", module, "--help"], cwd=tmp_path,
                       env=dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg"), capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and f"usage: python -m {module}" in r.stdout, r.stderr
    assert ("--outdir" in r.stdout) == (module == "netcosim.experiments.hil_flycrane")
    assert "--no-spawn" in r.stdout or "--role" in r.stdout
    assert list(tmp_path.iterdir()) == []
