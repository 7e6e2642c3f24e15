"""Faults on the reply channel of a hardware-in-the-loop run: each is dropped and counted
(or refused, or ends the run when asked), the run finishes with its trace, and nothing is
applied that was not asked for -- the HIL output equals, bit for bit, the all-simulated
run replayed with the timing of the requests that were answered.

The remote is ``tests/hil_independent_remote.py``: written from docs/hil.md with
``struct`` and ``zenoh`` only (no netcosim), its own copy of the PID; ``--fault`` makes it
misbehave from request 20 on.  Runs of 1 s of real time (100 requests) on loopback.
Where the fault is not about time, the deadline is 0.1 s (ten periods), so that a reply
held up by a loaded machine is not counted late; the tests about time allow for it.
"""

from __future__ import annotations

import ast
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_every_request_accounted, wait_until

from netcosim.transport.session import key, open_session, zenoh_available

pytestmark = pytest.mark.skipif(not zenoh_available(), reason="the zenoh extra (eclipse-zenoh) is not installed")

ROOT = Path(__file__).resolve().parent.parent
REMOTE = Path(__file__).resolve().parent / "hil_independent_remote.py"
AT = 20          # the request at which the fault starts


def _hs():
    from netcosim.experiments import hil_servo
    return hil_servo


#: deadline (s) of the runs whose fault is not about time
SLACK = 0.1


def run_fault(fault: str, until: float = 1.0, *extra: str, **options):
    program = [sys.executable, str(REMOTE), "--fault", fault, "--at", str(AT), *extra]
    options.setdefault("deadline", SLACK)
    return _hs().run_hil(until, program=program, **options)


def outcomes(run) -> dict:
    return run.remote.requests()["outcome"].astype(str).value_counts().to_dict()


def assert_nothing_unasked_applied(run, until):
    """The output is the all-simulated run replayed with the HIL run's requests: only the
    replies the remote applied, after their measured response times, bit for bit."""
    hs = _hs()
    y = run.output()["value"].to_numpy()
    replay = hs.servo_output(hs.run_replay(until, run.remote.requests()))["value"].to_numpy()
    assert np.array_equal(y, replay)


def assert_consistent(run, requests=100):
    """Every request has one outcome, and the counters agree with the outcomes."""
    c, o = run.remote.counters(), outcomes(run)
    assert sum(o.values()) == requests
    assert o.get("replied", 0) == c["received"]
    assert o.get("expired", 0) == c["expired"]
    assert o.get("overrun", 0) == c["overruns"]
    assert o.get("unserved", 0) == c["unserved"] == 0
    assert c["published"] == requests - c["overruns"]
    # the hil rows add up to the counters
    ev = run.remote.events()
    for reason, n in c["dropped"].items():
        assert ev.loc[(ev["event"] == "dropped") & (ev["detail"] == reason), "count"].sum() == n
    assert ev.loc[ev["event"] == "expired", "count"].sum() == c["expired"]
    assert ev.loc[ev["event"] == "overrun", "count"].sum() == c["overruns"]


def test_the_independent_remote_imports_only_struct_and_zenoh():
    tree = ast.parse(REMOTE.read_text())
    mods = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    mods |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert mods <= {"__future__", "argparse", "json", "math", "os", "queue", "secrets", "struct", "sys",
                    "threading", "time", "zenoh"}


def test_independent_remote_runs_the_servo_bit_for_bit():
    run = run_fault("none")
    c = run.remote.counters()
    assert run.failure is None and run.sim.now == 1.0
    assert_every_request_accounted(c, 100, process=run.process)
    assert run.process["status"] == "ended" and run.exit_codes == [0]
    assert_nothing_unasked_applied(run, 1.0)
    hs = _hs()
    assert hs.deviation(run.output(), hs.servo_output(hs.run_simulated(1.0))) <= hs.tolerance(
        1.0, run.remote.requests())


@pytest.mark.parametrize("fault, reason", [("nan", "nonfinite"), ("short", "values")])
def test_a_malformed_reply_is_dropped_and_its_request_is_a_lost_reply(fault, reason):
    run = run_fault(fault)
    c = run.remote.counters()
    assert run.failure is None and run.sim.now == 1.0           # the run finished
    assert c["dropped"] == {reason: 1}
    assert c["expired"] == 1 and c["received"] + c["after_end"] == 99 and c["overruns"] == 0
    r = run.remote.requests()
    assert r.loc[r["seq"] == AT, "outcome"].item() == "expired"   # the request of the bad reply
    assert run.process["status"] == "ended"                       # the process got END
    assert_consistent(run)
    assert_nothing_unasked_applied(run, 1.0)


def test_abort_on_ends_the_run_keeps_the_trace_and_sends_end(tmp_path):
    from netcosim.transport.remote import RemoteFault
    run = run_fault("nan", abort_on={"nonfinite"})
    assert isinstance(run.failure, RemoteFault) and "nonfinite" in str(run.failure)
    assert 0.2 <= run.sim.now < 0.2 + SLACK                       # reply 20 came after 0.2 s
    ev = run.remote.events()
    assert list(ev.loc[ev["event"] == "aborted", "detail"]) == ["a reply was dropped (nonfinite)"]
    assert run.process["status"] == "ended" and run.exit_codes == [0]
    y = run.output()
    assert len(y) > 0 and y["time"].max() == pytest.approx(run.sim.now, abs=1e-3)
    run.save(tmp_path)
    assert {"hil_events.parquet", "hil_requests.parquet", "remotes.parquet", "trace"} <= {
        p.name for p in tmp_path.iterdir()}
    assert run.summary()["failure"].startswith("RemoteFault")


@pytest.mark.parametrize("fault", ["mute", "hang"])
def test_a_remote_alive_but_silent_is_flagged_and_never_applied(fault):
    run = run_fault(fault, 1.0, "--idle", "1.5", deadline=None)
    c = run.remote.counters()
    assert run.failure is None and run.sim.now == 1.0
    # deadline = period: requests 20 and 21 expire, then max_outstanding (2) are unanswered
    # and the rest are overruns (on an idle machine exactly 2 and 78; a reply before 20
    # held up beyond 10 ms by load is late and counted as such)
    assert c["received"] <= AT and c["expired"] >= 2 and c["overruns"] >= 100 - AT - 2 - 5
    assert set(c["dropped"]) <= {"late"}
    r = run.remote.requests()
    assert (r.loc[r["seq"] >= AT, "outcome"] != "replied").all()
    assert_consistent(run)
    assert_nothing_unasked_applied(run, 1.0)


def test_zero_policy_zeroes_the_command_at_each_lost_reply():
    run = run_fault("mute", 1.0, loss_policy="zero", deadline=None)
    sig = run.sim.trace.signals()
    u = sig[(sig["source"] == "sensor.actuate") & (sig["signal"] == "u")]
    after = u[u["time"] > 0.2 + 0.01]
    assert len(after) >= 70 and (after["value"] == 0.0).all()     # one zero per expired/overrun request
    assert (u.loc[u["time"] < 0.2, "value"] != 0.0).any()


@pytest.mark.parametrize("fault, reason", [("duplicate", "duplicate"), ("unsolicited", "unsolicited"),
                                           ("forge-session", "session"), ("forge-peer", "peer")])
def test_unasked_replies_are_dropped_and_counted(fault, reason):
    run = run_fault(fault)
    c = run.remote.counters()
    assert c["dropped"] == {reason: run.process["extra_sent"]} and run.process["extra_sent"] >= 10
    assert c["received"] + c["after_end"] == 100
    assert_consistent(run)
    assert_nothing_unasked_applied(run, 1.0)


def test_late_replies_are_dropped_and_their_requests_expire():
    # every reply 15 ms after its request, deadline 10 ms
    run = run_fault("late", 1.0, "--delay", "0.015", deadline=None)
    c = run.remote.counters()
    r = run.remote.requests()
    assert (r.loc[r["seq"] >= AT, "outcome"] != "replied").all()
    # on an idle machine all 80 expire and 78-80 are dropped late; a loaded one holds some
    # replies back beyond 20 ms, and the requests after them are overruns
    assert c["expired"] + c["overruns"] >= 100 - AT - 2 and c["dropped"].get("late", 0) >= 30
    assert set(c["dropped"]) == {"late"}
    assert_consistent(run)
    assert_nothing_unasked_applied(run, 1.0)


def test_replies_replayed_later_than_stale_after_are_stale():
    # from request 20 on, each reply is sent again 1.5 s later; stale_after = 100 deadlines = 1 s
    run = run_fault("stale", 2.5, deadline=None)
    c = run.remote.counters()
    assert run.process["extra_sent"] >= 50
    # forgotten answers are purged when the next request is published: a simulation lagging
    # on a loaded machine may still remember a few, which are then duplicates -- dropped either way
    d = c["dropped"]
    assert d["stale"] + d.get("duplicate", 0) == run.process["extra_sent"]
    assert d["stale"] >= 0.5 * run.process["extra_sent"]         # idle machine: all of them
    assert set(d) <= {"stale", "duplicate", "late"}
    assert c["received"] + c["after_end"] + c["dropped"].get("late", 0) == 250
    assert_consistent(run, 250)
    assert_nothing_unasked_applied(run, 2.5)


def test_a_remote_slower_than_the_period_is_flagged_and_its_queue_stays_bounded():
    run = run_fault("slow", 1.0, "--delay", "0.025", deadline=None)     # 25 ms of work per request, period 10 ms
    c = run.remote.counters()
    assert c["overruns"] >= 20 and c["expired"] >= 20
    assert c["received"] <= AT + 1
    # the process was given only what it could answer: never more than max_outstanding ahead
    assert run.process["received"] == c["published"] <= run.process["published"] + run.remote.max_outstanding
    ev = run.remote.events()
    assert {"overrun", "expired"} <= set(ev["event"])
    assert_consistent(run)
    assert_nothing_unasked_applied(run, 1.0)


def test_a_garbage_flood_is_dropped_off_the_event_queue():
    from netcosim.transport import wire
    junk = os.urandom(64)
    sent, peers = [], []

    def flood(session, remote):
        peer = open_session(listen=(), connect=session.endpoints)
        peers.append(peer)      # closed after the run: nothing the flood queued is cut off
        pub = peer.publisher(remote.keys["tx"])
        wait_until(lambda: pub.matching_status.matching, what="the flooding peer's publisher on tx to match")

        def go():
            # the flood comes while the run is under way: once the first request is out
            wait_until(lambda: remote.published > 0, what="the run's first request")
            for i in range(5000):
                pub.put(junk[: i % 64] if i % 2 else b"NCSM" + bytes([wire.VERSION]) + junk[5:40])
                sent.append(i)
        threading.Thread(target=go, daemon=True).start()
    try:
        run = _hs().run_hil(1.0, before_run=flood, deadline=SLACK)
    finally:
        for peer in peers:
            peer.close()
    c = run.remote.counters()
    assert len(sent) == 5000
    assert sum(c["dropped"].values()) == 5000 and set(c["dropped"]) <= {"short", "magic", "kind", "oversized"}
    assert c["received"] + c["after_end"] == 100
    # no simulation event per bad message: only the 100 replies and the claim were injected
    assert run.lateness.injections <= 100 + 2
    assert_consistent(run)


def test_a_second_process_claiming_the_node_is_refused_and_both_sides_say_so():
    second = []

    def start_second(session, remote):
        cmd = [sys.executable, str(REMOTE), "--run", remote.run_id, "--node", "controller", "--connect",
               session.endpoints[0], "--idle", "5"]
        second.append(subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        wait_until(lambda: remote.refused, timeout=20, what="the second process to be refused")
    try:
        run = run_fault("none", before_run=start_second)
        out, err = second[0].communicate(timeout=30)
    finally:
        for p in second:
            if p.poll() is None:
                p.kill()
                p.wait(timeout=10)
    assert second[0].returncode == 4 and json.loads(out.strip().splitlines()[-1])["status"] == "refused"
    assert "another process serves this node" in err
    assert len(run.remote.refused) == 1
    ev = run.remote.events()
    assert list(ev.loc[ev["event"] == "refused", "detail"]) == [f"{run.remote.refused[0]:016x}"]
    c = run.remote.counters()
    assert c["received"] + c["after_end"] == 100 and not c["dropped"]     # nothing sent twice, nothing dropped
    assert run.process["received"] == 100
    assert_nothing_unasked_applied(run, 1.0)


@pytest.mark.parametrize("remote, how", [("independent", signal.SIGKILL), ("library", signal.SIGKILL),
                                         ("independent", signal.SIGSTOP), ("library", signal.SIGSTOP)])
def test_the_remote_exits_non_zero_within_a_lease_when_the_simulation_is_gone(remote, how):
    lease = 1.0
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    prog = f"{sys.executable} {REMOTE}" if remote == "independent" else \
        f"{sys.executable} -m netcosim.experiments.hil_servo_controller"
    sim_side = subprocess.Popen(
        [sys.executable, "-m", "netcosim.cli", "hil", "netcosim.experiments.networked_servo:build",
         "--remote", "controller",
         "--period", "0.01", "--until", "30", "--wait", "30", "--remote-cmd", prog],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc = observer = None
    try:
        assert sim_side.stdout is not None
        assert sim_side.stdout.readline().strip() == "start the remote side with:"
        cmd = sim_side.stdout.readline().split()
        assert cmd[0] == sys.executable
        # an observer on the simulation's endpoint counts the requests it publishes to the remote
        observer = open_session(listen=(), connect=[cmd[cmd.index("--connect") + 1]])
        requests = []
        _sub = observer.subscribe(key(cmd[cmd.index("--run") + 1], "controller", "rx"), requests.append)
        proc = subprocess.Popen(cmd + ["--idle", "20"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "ready"
        # the run is under way: the remote is claimed and being sent requests
        wait_until(lambda: len(requests) >= 10, timeout=30, what="ten requests of the simulation to the remote")
        sim_side.send_signal(how)       # killed, or hung (its token goes after the lease)
        killed = time.monotonic()
        out, err = proc.communicate(timeout=20)
        took = time.monotonic() - killed
    finally:
        if how == signal.SIGSTOP:
            sim_side.send_signal(signal.SIGCONT)
        if observer is not None:
            observer.close()
        for p in (sim_side, proc):
            if p is not None and p.poll() is None:
                p.kill()
            if p is not None:
                p.wait(timeout=10)
    assert proc.returncode == 3, err
    assert re.search(r"simulation.*gone", err) and len(err.strip().splitlines()) == 1
    assert json.loads(out.strip().splitlines()[-1])["status"] == "gone"
    # killed: its link closes at once; hung: the lease (1 s), plus scheduling slack
    assert took <= (0.5 if how == signal.SIGKILL else lease) + 1.0
