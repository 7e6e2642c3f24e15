"""The ch. 2 landing with its low-level controller in a real process over Zenoh
(``netcosim.experiments.hil_landing_llc``): loopback only, bounded in time, every child killed and
every session closed.

The process's law is the simulated one (same code, same numbers); the HIL landing must
equal, bit for bit, the all-simulated landing replayed with the measured response time
of every reply, and lie within 1.5 times the deviation those response times explain
from the nominal all-simulated 2LC.  The Zenoh tests skip without the ``zenoh`` extra.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_hil_cli

from netcosim.transport.session import zenoh_available

needs_zenoh = pytest.mark.skipif(not zenoh_available(), reason="the zenoh extra (eclipse-zenoh) is not installed")


def _h():
    from netcosim.experiments import hil_landing_llc
    return hil_landing_llc


def _states_equal(a, b) -> bool:
    return all(np.array_equal(a[c].to_numpy(), b[c].to_numpy()) for c in _h().STATES)


def test_replay_without_delay_is_the_simulated_two_layer_controller():
    # the replay samples like the remote loop (RemotePlantIO's schedule) and writes each
    # command after the given response time: with zero it is the 2LC's 500 Hz task, bit for bit
    h = _h()
    until = 0.1
    nominal = h.landing_output(h.run_simulated(until))
    zero = h.landing_output(h.run_replay(until, np.zeros(50)))
    assert len(nominal) == 100 and _states_equal(zero, nominal)
    late = h.landing_output(h.run_replay(until, np.full(50, 1e-4)))
    assert not _states_equal(late, nominal)
    assert 0 < h.deviation(late, nominal) < 0.01


def test_the_process_computes_the_simulated_low_level_command_bit_for_bit():
    from netcosim.controllers.landing.topology import build_landing
    from netcosim.experiments.hil_landing_llc_controller import SAMPLE_VALUES, command, controller
    h = _h()
    sc = h.scenario(0.1)
    sim, uav, loop = build_landing(sc, low_level=False)
    y = uav.output(h.OUTPUTS).read()
    y = y + np.array([1e-4, -1e-3, 2e-3, 1e-2])         # off the reference, unsaturated: every PID term acts
    fl = controller(sc.fl_period, sc.fl_gains)
    for t in (0.0, 0.002, 0.004):
        pos, vel, acc = loop.low_level_reference(t)
        values = tuple(y.tolist()) + tuple(pos) + tuple(vel) + tuple(acc)    # what a sample carries
        assert len(values) == SAMPLE_VALUES
        u = command(fl, values)
        assert u == tuple(loop.low_level_command(t, y).tolist())
    assert fl.integral.tolist() == loop.fl.integral.tolist() and np.any(fl.integral != 0)
    with pytest.raises(ValueError, match="10 values .* got 4"):
        command(fl, values[:4])


def test_controller_command_carries_the_scenario_gains_and_period():
    from dataclasses import replace

    from netcosim.controllers.landing import PIDGains
    h = _h()
    sc = replace(h.scenario(0.1), fl_gains=PIDGains(1.5, 2.25, 0.1))
    cmd = h.controller_command("abc", ["tcp/127.0.0.1:7447"], sc, python="py", session=0xABC)
    assert cmd[:3] == ["py", "-m", "netcosim.experiments.hil_landing_llc_controller"]
    assert cmd[cmd.index("--session") + 1] == "0000000000000abc"
    i = cmd.index("--gains")
    assert cmd[i + 1:i + 4] == ["1.5", "2.25", "0.1"] and cmd[cmd.index("--period") + 1] == "0.002"
    assert cmd[cmd.index("--node") + 1] == "uav" and cmd[cmd.index("--connect") + 1] == "tcp/127.0.0.1:7447"
    from netcosim.controllers.landing import SIM_PARAMS
    with pytest.raises(ValueError, match="default TetheredUAVParams"):
        h.controller_command("abc", [], replace(sc, params=replace(SIM_PARAMS, m_B=2.0)))


def _check_landing(until, factor):
    h = _h()
    run = h.run_hil(until, factor=factor)
    samples = round(until / 0.002)
    resp = run.response_times()
    # both sides count the same samples and replies (loss 0)
    assert run.remote.published == samples
    assert run.process is not None
    assert {k: run.process[k] for k in ("received", "published", "dropped", "status", "singular")} == {
        "received": samples, "published": samples, "dropped": {}, "status": "ended", "singular": 0}
    # a reply beyond the deadline (2 ms simulated, 20 ms of wall clock) is dropped as late
    late = run.remote.dropped.get("late", 0)
    assert run.remote.received + run.remote.after_end + late == samples and len(resp) == run.remote.received
    assert set(run.remote.dropped) <= {"late"} and run.sim.now == until
    assert np.all(resp > 0)
    y = run.output()
    # the HIL landing is the all-simulated one with the measured response times, bit for bit
    requests = run.remote.requests()
    replay = h.landing_output(h.run_replay(until, requests))
    assert _states_equal(y, replay)
    nominal = h.landing_output(h.run_simulated(until))
    assert h.deviation(y, nominal) <= h.tolerance(until, requests)
    assert set(run.remote.events()["event"]) <= {"alive", "dropped", "expired"}
    return run


@needs_zenoh
def test_landing_with_the_low_level_controller_in_a_process():
    _check_landing(0.3, 10.0)


@needs_zenoh
@pytest.mark.slow
def test_whole_landing_with_the_low_level_controller_in_a_process():
    run = _check_landing(1.5, 10.0)
    y = run.output()
    assert np.degrees(y["theta"].iloc[-1]) == pytest.approx(30.0, abs=1.0)     # landed on the 30° slope


@needs_zenoh
def test_hil_landing_example_writes_its_results(tmp_path):
    summary = _h().main(outdir=str(tmp_path), quick=True)
    row = summary.iloc[0]
    # 250 requests: each published, or (a loaded machine) an overrun counted instead; each
    # published one answered in time, after its deadline (expired) or after the end
    assert row["until"] == 0.5 and row["published"] + row["overruns"] == 250 and row["published"] > 0
    assert row["received"] + row["after_end"] + row["expired"] == row["published"]
    assert row["deviation"] <= row["tolerance"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hil_events.parquet", "hil_requests.parquet",
                                                         "lateness.parquet", "outputs.png", "remotes.parquet",
                                                         "summary.parquet", "trace"]


@needs_zenoh
def test_cli_runs_the_landing_with_a_remote_plant():
    r_out = run_hil_cli(
        ["netcosim.experiments.hil_landing_llc:build", "--remote", "uav", "--period", "0.002",
         "--outputs", "phi,dphi,theta,dtheta", "--extra", "netcosim.experiments.hil_landing_llc:reference",
         "--factor", "10", "--until", "0.2", "--deadline", "0.02", "--wait", "60"],
        module="netcosim.experiments.hil_landing_llc_controller", node="uav", messages=100)
    assert '"status": "ended"' in r_out


@pytest.mark.parametrize("args, message", [
    (["--remote", "nothing"], "has no node or plant 'nothing'"),
    (["--remote", "uav"], "'uav' is a plant: give its sampling period with --period"),
    (["--remote", "onboard", "--outputs", "phi"], "'onboard' is a node, not a plant: --outputs given"),
    (["--remote", "onboard"], "'onboard' is a node: give the period of the requests it serves with --period"),
    (["--remote", "onboard", "--period", "0.01"], "remote node 'onboard' must have exactly one network interface"),
    (["--remote", "uav", "--period", "0.002", "--abort-on", "nan"], "--abort-on nan: not one of"),
    (["--remote", "uav", "--period", "0.002", "--zenoh-config", "/nonexistent.json5"], "/nonexistent.json5"),
])
def test_cli_names_a_bad_remote(args, message, capsys):
    from netcosim.cli import main
    assert main(["hil", "netcosim.experiments.hil_landing_llc:build", *args]) == 2
    assert message in capsys.readouterr().err
