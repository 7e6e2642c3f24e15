"""Hardware in the loop over Zenoh: the networked servo with its controller in a real
process (loopback only, bounded in time, every child killed and every session closed).

The Zenoh tests skip when the ``zenoh`` extra is absent.  Tolerances come from what the
run measured: the HIL output must equal, bit for bit, the all-simulated run replayed
with the measured response time of every reply, and lie within 1.5 times the deviation
those response times explain from the nominal all-simulated run.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_every_request_accounted, run_hil_cli, wait_until

from netcosim.transport import wire
from netcosim.transport.client import periodic
from netcosim.transport.session import key, open_session, zenoh_available

ROOT = Path(__file__).resolve().parent.parent
SID = 0x5E5510A0C0FFEE01       # the session id of the hand-made simulation side
needs_zenoh = pytest.mark.skipif(not zenoh_available(), reason="the zenoh extra (eclipse-zenoh) is not installed")


@pytest.mark.parametrize("process, loaded", [
    ("netcosim.experiments.hil_servo_controller", []),
    # the ch. 2 low-level controller computes with NumPy, still without SimPy or CasADi
    ("netcosim.experiments.hil_landing_llc_controller", ["numpy"]),
])
def test_client_and_controller_processes_load_neither_simpy_nor_casadi(process, loaded):
    code = (f"import sys, netcosim.transport.client, {process}; "
            "print(sorted(m for m in ('simpy', 'casadi', 'numpy', 'pandas', 'scipy') if m in sys.modules))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=60, check=True).stdout
    assert out.strip() == str(loaded)


class FakeClock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.t += dt


def test_periodic_loop_counts_deadline_misses():
    fake = FakeClock()
    work = {3: 0.025, 7: 0.004}    # body k = 3 takes 25 ms (2.5 periods), k = 7 takes 4 ms

    def body(k):
        fake.t += work.get(k, 0.001)
    stats = periodic(0.010, body, duration=0.1, clock=fake, sleep=fake.sleep)
    assert stats.periods == 10
    # k = 3 runs from 30 to 55 ms: misses the start of period 4 (40 ms); k = 4 starts at 55 ms
    # (15 ms late) and ends at 56 ms: misses period 5 (50 ms); k = 5 ends at 57 ms < 60 ms: caught up
    assert stats.misses == 2
    assert stats.max_overrun == pytest.approx(0.015)
    assert stats.miss_ratio == pytest.approx(0.2)
    with pytest.raises(ValueError, match="period"):
        periodic(0, body)


def test_keys_are_namespaced_and_checked():
    assert key("r1", "controller", "tx") == "netcosim/r1/controller/tx"
    with pytest.raises(ValueError, match="node name"):
        key("r1", "a/b", "tx")
    with pytest.raises(ValueError, match="run id"):
        key("*", "a", "tx")


@needs_zenoh
def test_session_listens_on_a_real_loopback_port_and_closes():
    s = open_session()
    try:
        (endpoint,) = s.endpoints
        host, port = endpoint.rsplit(":", 1)
        assert host == "tcp/127.0.0.1" and 0 < int(port) < 65536
        assert s.lease == 1.0
    finally:
        s.close()
    assert s.zenoh.is_closed()
    s.close()   # idempotent


def _hil():
    from netcosim.experiments import hil_servo
    return hil_servo


def _check_servo(until):
    hs = _hil()
    run = hs.run_hil(until)
    resp = run.response_times()
    samples = round(until / 0.010)
    requests = run.remote.requests()
    # one request per sample; on a loaded machine a request still unanswered when the next
    # one is due is an overrun, not published (counted): every other one is, exactly once
    assert len(requests) == samples and set(requests["outcome"]) <= {"replied", "expired", "overrun", "open"}
    published = samples - int((requests["outcome"] == "overrun").sum())
    assert run.remote.published == published and published > 0
    # both sides count the same messages (loss 0): the process answered each one
    assert run.process == {"received": published, "published": published, "dropped": {}, "status": "ended"}
    assert run.exit_codes == [0]
    # replies still in flight at the stop time arrive after the run: counted, not applied; a
    # reply later than the deadline (10 ms, a loaded machine) is dropped as late
    late = run.remote.dropped.get("late", 0)
    assert run.remote.received + run.remote.after_end + late == published and len(resp) == run.remote.received
    assert set(run.remote.dropped) <= {"late"}
    assert int((requests["outcome"] == "replied").sum()) == run.remote.received
    assert run.sim.now == until
    assert np.all(resp > 0)
    y = run.output()
    # the HIL run is the all-simulated run with the measured response times, bit for bit
    replay = hs.servo_output(hs.run_replay(until, requests))
    assert np.array_equal(y["value"].to_numpy(), replay["value"].to_numpy())
    nominal = hs.servo_output(hs.run_simulated(until))
    tol = hs.tolerance(until, requests)
    assert hs.deviation(y, nominal) <= tol
    assert run.lateness.events > 10 * samples


@needs_zenoh
def test_servo_with_remote_controller_matches_the_simulated_run():
    _check_servo(1.0)


@needs_zenoh
@pytest.mark.slow
def test_servo_with_remote_controller_for_five_seconds():
    _check_servo(5.0)


def _actuations(sim):
    sig = sim.trace.signals()
    return sig[(sig["source"] == "sensor.actuate") & (sig["signal"] == "u")]


@needs_zenoh
def test_kill_of_the_remote_is_detected_and_the_zero_policy_applies():
    hs = _hil()
    run = hs.run_hil(1.5, loss_policy="zero", kill_at=0.5, lease=0.5)
    assert run.sim.now == 1.5                      # the run finished
    ev = run.remote.events()
    ev = ev[ev["event"].isin(["alive", "lost"])].reset_index(drop=True)
    assert list(ev["event"]) == ["alive", "lost"]
    t_lost = ev["time"].iloc[1]
    assert ev["detail"].iloc[1] == "zero"
    # after the loss no request is published (nobody claims the node)
    r = run.remote.requests()
    assert (r.loc[r["time"] > t_lost, "outcome"] == "unserved").all() and (r["time"] > t_lost).sum() >= 40
    assert 0.5 <= t_lost <= 0.5 + 0.5 + 0.5        # within the lease (plus scheduling slack)
    u = _actuations(run.sim)
    assert u["value"].iloc[-1] == 0.0             # the command was zeroed ...
    assert u["time"].iloc[-1] > t_lost             # ... after the loss, through the network
    assert (u["time"] > t_lost).sum() == 1         # and nothing came after


@needs_zenoh
def test_stopped_remote_is_detected_within_its_lease_and_hold_keeps_the_command():
    hs = _hil()
    lease = 0.5
    run = hs.run_hil(2.5, loss_policy="hold", kill_at=0.3, lease=lease, stop_signal=signal.SIGSTOP)
    ev = run.remote.events()
    # before the lease runs out, the requests to the stopped process expire (hold: nothing sent)
    assert ev.loc[ev["event"] == "expired", "count"].sum() >= 1
    ev = ev[ev["event"].isin(["alive", "lost"])].reset_index(drop=True)
    assert list(ev["event"]) == ["alive", "lost"]
    t_lost = ev["time"].iloc[1]
    # the lease runs from the last keep-alive (4 per lease) before the stop; plus scheduling slack
    assert 0.3 + 0.5 * lease <= t_lost <= 0.3 + lease + 1.0
    u = _actuations(run.sim)
    assert (u["time"] > t_lost).sum() == 0         # hold: nothing more is sent
    assert u["value"].iloc[-1] != 0.0


@needs_zenoh
def test_malformed_messages_are_dropped_counted_and_the_run_goes_on():
    hs = _hil()
    data = wire.encode(wire.DATA, 0, 1, 1, 0, 0, (1.0, 2.0))
    bad = [b"", b"NCSM", b"XXXX" + data[4:], b"NCSM\x01" + data[5:],
           wire.HEADER.pack(b"NCSM", wire.VERSION, wire.DATA, 0, 1, 1, 0, 0, 100_000)]

    peers = []

    def inject(session, remote):
        # on tx, a misbehaving peer: its own session, connected to the simulation's endpoint
        peer = open_session(listen=(), connect=session.endpoints)
        peers.append(peer)
        pub = peer.publisher(remote.keys["tx"])
        wait_until(lambda: pub.matching_status.matching, what="the injecting peer's publisher on tx to match")
        for b in bad:
            pub.put(b)
            remote._pub.put(b)     # on rx, through the simulation's own publisher
    try:
        run = hs.run_hil(0.5, before_run=inject, deadline=0.1)
    finally:
        for peer in peers:
            peer.close()
    assert dict(run.remote.dropped) == {"short": 2, "magic": 1, "version": 1, "oversized": 1}
    assert run.sim.now == 0.5
    assert_every_request_accounted(run.remote.counters(), 50, extra_drops={"short", "magic", "version", "oversized"},
                                   process=run.process)
    assert run.process["status"] == "ended"
    assert run.process["dropped"] == {"short": 2, "magic": 1, "version": 1, "oversized": 1}
    rows = run.remote.events()
    assert rows.loc[rows["event"] == "dropped", "count"].sum() == 5


@needs_zenoh
@pytest.mark.parametrize("encoding", [[], ["--encoding", "cdr"]])
def test_cli_prints_the_remote_command_and_runs_with_it(encoding):
    # a 0.1 s deadline: a loaded machine's timing is not what this test is about
    run_hil_cli(["netcosim.experiments.networked_servo:build", "--remote", "controller", "--period", "0.01",
                 "--until", "0.5",
                 "--deadline", "0.1", "--wait", "30", *encoding],
                module="netcosim.experiments.hil_servo_controller", node="controller", messages=50, timeout=60)


@needs_zenoh
def test_cli_compares_with_the_simulated_run_and_the_replay():
    # the replay reproduces the HIL run bit for bit; the all-simulated run differs by what the
    # measured response times (not the simulated 0.5 ms of CPU time) explain
    run_hil_cli(["netcosim.experiments.networked_servo:build", "--remote", "controller", "--period", "0.01",
                 "--until", "0.5",
                 "--reply-values", "2", "--deadline", "0.1", "--wait", "30", "--compare", "--replay",
                 "netcosim.experiments.hil_servo:run_replay"],
                module="netcosim.experiments.hil_servo_controller", node="controller", messages=50, timeout=60,
                expect=[r"max deviation from the all-simulated run: [1-9]\.\d+e-0\d \(servo\.y\.y\)",
                        r"max deviation from the replay with the measured response times: 0\.000e\+00"])


@needs_zenoh
def test_hil_servo_example_writes_its_results(tmp_path):
    summary = _hil().main(outdir=str(tmp_path), quick=True)
    row = summary.iloc[0]
    # 200 requests: each published, or (a loaded machine) an overrun counted instead
    assert row["until"] == 2.0 and row["published"] + row["overruns"] == 200 and row["published"] > 0
    assert row["unserved"] == 0 and row["failure"] == ""
    assert row["deviation"] <= row["tolerance"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hil_events.parquet", "hil_requests.parquet",
                                                         "lateness.parquet", "outputs.png", "remotes.parquet",
                                                         "summary.parquet", "trace"]


LOCAL_LOOP = """
import sys
from netcosim.transport.client import RemoteProcess
with RemoteProcess("servo", run=sys.argv[1], connect=[sys.argv[2]]) as rp:
    for m in rp.messages(timeout=10):
        rp.reply(m, (0.05 * (1.0 - m.values[0]),))
print(rp.received, rp.published)
"""


def _servo_sim():
    from netcosim import RK4, Simulation
    from netcosim.plants.dc_servo import DCServo
    sim = Simulation()
    plant = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=RK4(dt=1e-4), log_interval=1e-3)
    return sim, plant


@needs_zenoh
def test_remote_plant_io_runs_a_fast_local_loop_against_the_simulated_plant():
    from netcosim.transport.remote import RemotePlantIO
    from netcosim.transport.session import new_run_id
    h, until = 0.002, 1.0
    sim, plant = _servo_sim()
    run = new_run_id()
    child = None
    session = open_session()
    try:
        # a 0.1 s deadline: the loop's timing on a loaded machine is not what this test is about
        io = RemotePlantIO(sim, plant, session, run=run, period=h, outputs=0, inputs=0, deadline=0.1)
        child = subprocess.Popen([sys.executable, "-c", LOCAL_LOOP, run, session.endpoints[0]], cwd=ROOT,
                                 env=dict(os.environ, PYTHONPATH=str(ROOT)), stdout=subprocess.PIPE, text=True)
        assert io.wait_connected(30)
        sim.run(until=until)
        io.finish()
        out, _ = child.communicate(timeout=30)
        io.drain()
    finally:
        if child is not None and child.poll() is None:
            child.kill()
            child.wait(timeout=10)
        session.close()
    samples = round(until / h)                      # 0, h, ..., until - h (the run stops before `until`)
    # a loaded machine may still hold replies back beyond the deadline: the requests after them
    # are then overruns (not published), so the process is never handed more than it answers
    assert io.published + io.overruns == samples and io.published > 0
    assert out.split() == [str(io.published), str(io.published)]
    assert io.received + io.after_end + io.dropped.get("late", 0) == io.published
    assert set(io.dropped) <= {"late"}
    assert len(io.response_times()) == io.received
    plan = io.requests().set_index("seq")["response"]      # NaN: no reply applied
    # replayed all-simulated: sample every h, write u = 0.05 (1 - y) after the measured response time
    ref, rplant = _servo_sim()
    y_port, u_port, k = rplant.output(0), rplant.input(0), iter(range(10**9))

    def sample():
        u = 0.05 * (1.0 - y_port.read())
        d = plan.get(next(k), float("nan"))
        if not np.isnan(d):
            ref.call_in(float(d), lambda: u_port.write(u))
        ref.call_in(h, sample)
    ref.call_at(0.0, sample)
    ref.run(until=until)
    sig = sim.trace.signals()
    y = sig[(sig["source"] == "servo") & (sig["signal"] == "y.y")]["value"].to_numpy()
    rs = ref.trace.signals()
    assert np.array_equal(y, rs[(rs["source"] == "servo") & (rs["signal"] == "y.y")]["value"].to_numpy())
    assert y.max() > 0.5                            # the loop did move the servo towards 1


@needs_zenoh
def test_serve_answers_from_the_receiving_thread_echoing_seq():
    import queue
    import threading

    from netcosim.transport.client import RemoteProcess
    sim_side = open_session()
    rp = None
    try:
        run = "servetest"
        got: queue.SimpleQueue = queue.SimpleQueue()
        sub = sim_side.subscribe(key(run, "ctl", "tx"), got.put)
        pub = sim_side.publisher(key(run, "ctl", "rx"))
        rp = RemoteProcess("ctl", run=run, connect=sim_side.endpoints, session=SID)
        threads = set()

        def law(m):
            threads.add(threading.get_ident())
            return (2.0 * m.values[0],) if m.seq != 3 else None     # seq 3: no answer

        def feed():
            # after serving began: a message that arrives before is answered on the calling
            # thread (serve's documented catch-up), which is not what this test is about
            wait_until(lambda: rp._handler is not None, what="serve() to begin")
            for seq in range(5):
                pub.put(wire.encode(wire.DATA, 1, SID, rp.peer, 1000 * seq, seq, (seq + 0.5,)))
            pub.put(b"garbage")
            pub.put(wire.encode(wire.DATA, 1, SID + 1, rp.peer, 0, 9, (1.0,)))     # another session
            pub.put(wire.encode(wire.DATA, 1, SID, rp.peer + 1, 0, 9, (1.0,)))     # another process
            pub.put(wire.encode(wire.END, 0, SID, 0, 5000, 5))
        # the peers have met: each side's publisher reaches the other's subscriber
        wait_until(lambda: pub.matching_status.matching, what="the simulation side's rx publisher to match")
        wait_until(lambda: rp._pub.matching_status.matching, what="the remote's tx publisher to match")
        feeder = threading.Thread(target=feed)
        feeder.start()
        rp.serve(law, timeout=10)
        feeder.join(timeout=10)
        replies = [wire.decode(got.get(timeout=5)) for _ in range(5)]     # 4 answers and END
        sub.undeclare()
        assert [(m.kind, m.node, m.seq, m.ticks, m.values) for m in replies] == [
            (wire.DATA, 1, 0, 0, (1.0,)), (wire.DATA, 1, 1, 1000, (3.0,)), (wire.DATA, 1, 2, 2000, (5.0,)),
            (wire.DATA, 1, 4, 4000, (9.0,)), (wire.END, 0, 5, 5000, ())]
        assert {(m.session, m.peer) for m in replies} == {(SID, rp.peer)}
        assert threads and threading.get_ident() not in threads
        assert rp.ended and rp.received == 5 and rp.published == 4
        assert rp.dropped == {"short": 1, "session": 1, "peer": 1} and rp.exit_code == 0
    finally:
        if rp is not None:
            rp.close()
        sim_side.close()


@needs_zenoh
def test_serve_reraises_the_handler_error():
    from netcosim.transport.client import RemoteProcess
    sim_side = open_session()
    rp = None
    try:
        pub = sim_side.publisher(key("servefail", "ctl", "rx"))
        rp = RemoteProcess("ctl", run="servefail", connect=sim_side.endpoints, session=SID)
        wait_until(lambda: pub.matching_status.matching, what="the simulation side's rx publisher to match")
        t0 = time.monotonic()

        def law(m):
            raise ZeroDivisionError("bad law")

        def feed():
            pub.put(wire.encode(wire.DATA, 1, SID, rp.peer, 0, 0, (1.0,)))
        import threading
        feeder = threading.Thread(target=feed)
        feeder.start()
        with pytest.raises(ZeroDivisionError, match="bad law"):
            rp.serve(law, timeout=10)
        feeder.join(timeout=10)
        assert time.monotonic() - t0 < 5
    finally:
        if rp is not None:
            rp.close()
        sim_side.close()


@needs_zenoh
def test_serve_times_out_after_the_last_message_not_after_it_began():
    import threading

    from netcosim.transport.client import RemoteProcess
    sim_side = open_session()
    rp = None
    try:
        pub = sim_side.publisher(key("serveidle", "ctl", "rx"))
        rp = RemoteProcess("ctl", run="serveidle", connect=sim_side.endpoints, session=SID)
        sent = []
        wait_until(lambda: pub.matching_status.matching, what="the simulation side's rx publisher to match")

        def feed():
            for seq in range(12):      # a message every 0.1 s for 1.2 s: longer than the 0.9 s timeout
                pub.put(wire.encode(wire.DATA, 1, SID, rp.peer, 0, seq, (1.0,)))
                sent.append(time.monotonic())
                time.sleep(0.1)        # deliberate: the pace of the messages, not a wait for the peer
        feeder = threading.Thread(target=feed)
        feeder.start()
        rp.serve(lambda m: m.values, timeout=0.9)
        ended = time.monotonic()
        feeder.join(timeout=10)
        assert rp.received == 12 and not rp.ended and rp.status == "idle" and rp.exit_code == 5
        # it returned once 0.9 s had passed without a message (scheduling slack: 1 s)
        assert 0.9 - 0.05 <= ended - sent[-1] <= 0.9 + 1.0
    finally:
        if rp is not None:
            rp.close()
        sim_side.close()
