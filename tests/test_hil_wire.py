"""The HIL wire format and the real-time clock, without Zenoh (fake clocks, threads)."""

from __future__ import annotations

import struct
import threading

import pytest

from netcosim import Simulation
from netcosim.transport import wire
from netcosim.transport.realtime import LATENESS_EDGES, RealtimeClock


def test_encode_layout_is_the_documented_one():
    b = wire.encode(wire.DATA, 3, 0x0123456789ABCDEF, 0xFEDCBA9876543210, -10_000_000_000, 7, (1.5, -2.0))
    assert len(b) == 40 + 16 and wire.HEADER.size == 40
    assert b[:4] == b"NCSM" and b[4] == 2 and b[5] == wire.DATA
    assert struct.unpack_from("<H", b, 6)[0] == 3
    assert struct.unpack_from("<Q", b, 8)[0] == 0x0123456789ABCDEF
    assert struct.unpack_from("<Q", b, 16)[0] == 0xFEDCBA9876543210
    assert struct.unpack_from("<q", b, 24)[0] == -10_000_000_000
    assert struct.unpack_from("<I", b, 32)[0] == 7
    assert struct.unpack_from("<I", b, 36)[0] == 2
    assert struct.unpack_from("<2d", b, 40) == (1.5, -2.0)


def test_every_header_field_is_naturally_aligned():
    # what lets a C struct of the same fields have no padding (sizeof 40)
    offsets = {"magic": (0, 1), "version": (4, 1), "kind": (5, 1), "node": (6, 2), "session": (8, 8),
               "peer": (16, 8), "ticks": (24, 8), "seq": (32, 4), "count": (36, 4)}
    for off, size in offsets.values():
        assert off % size == 0
    assert struct.calcsize("@4sBBHQQqII") == struct.calcsize("<4sBBHQQqII") == 40   # native alignment: no padding


def test_round_trip_keeps_every_field_bit_for_bit():
    values = (0.1, -0.0, 1e308, 5e-324, float("inf"))
    m = wire.decode(wire.encode(wire.DATA, 65535, 2**64 - 1, 1, -42, 2**32 + 5, values))
    assert m == wire.Message(wire.DATA, 65535, 2**64 - 1, 1, -42, 5, values)
    assert struct.pack("<5d", *m.values) == struct.pack("<5d", *values)
    assert wire.decode(wire.encode(wire.END, 0, 1, 0, 0, 0)).values == ()
    assert not wire.finite((1.0, float("nan"))) and not wire.finite((float("-inf"),)) and wire.finite((1.0, -0.0))


@pytest.mark.parametrize("data, reason", [
    (b"", "short"),
    (b"NCSM\x02", "short"),
    (b"XXXX" + wire.encode(wire.DATA, 0, 1, 1, 0, 0)[4:], "magic"),
    (b"NCSM\x01" + wire.encode(wire.DATA, 0, 1, 1, 0, 0)[5:], "version"),
    (b"NCSM\x02\x09" + wire.encode(wire.DATA, 0, 1, 1, 0, 0)[6:], "kind"),
    (wire.HEADER.pack(b"NCSM", 2, wire.DATA, 0, 1, 1, 0, 0, wire.MAX_VALUES + 1), "oversized"),
    (wire.encode(wire.DATA, 0, 1, 1, 0, 0, (1.0,))[:-1], "length"),
    (wire.encode(wire.DATA, 0, 1, 1, 0, 0, (1.0,)) + b"\0", "length"),
])
def test_decode_rejects_with_a_reason(data, reason):
    with pytest.raises(wire.WireError, match=reason) as e:
        wire.decode(data)
    assert e.value.reason == reason


def test_encode_rejects_out_of_range_fields():
    with pytest.raises(ValueError, match="kind"):
        wire.encode(7, 0, 1, 1, 0, 0)
    with pytest.raises(ValueError, match="node index"):
        wire.encode(wire.DATA, 70000, 1, 1, 0, 0)
    with pytest.raises(ValueError, match="session id"):
        wire.encode(wire.DATA, 0, 2**64, 1, 0, 0)
    with pytest.raises(ValueError, match="peer id"):
        wire.encode(wire.DATA, 0, 1, -1, 0, 0)
    with pytest.raises(ValueError, match="ticks"):
        wire.encode(wire.DATA, 0, 1, 1, 2**63, 0)
    with pytest.raises(ValueError, match="at most 1024"):
        wire.encode(wire.DATA, 0, 1, 1, 0, 0, [0.0] * 1025)


class FakeClock:
    """A wall clock that advances only when the simulation waits (never sleeps)."""

    def __init__(self, t0: float = 100.0):
        self.t = t0
        self.waits: list[float] = []

    def __call__(self) -> float:
        return self.t

    def wait(self, inbox, timeout):
        self.waits.append(timeout)
        self.t += timeout
        return None


def test_events_are_paced_to_the_wall_clock():
    sim = Simulation()
    fake = FakeClock()
    rt = RealtimeClock(sim, factor=2.0, clock=fake, wait=fake.wait)
    seen = []
    for t in (0.25, 0.5, 1.0):
        sim.call_at(t, lambda t=t: seen.append((t, fake())))
    sim.run(until=1.5)
    # factor 2: simulated t is due 2 t wall seconds after the start (100 s)
    assert seen == [(0.25, pytest.approx(100.5)), (0.5, pytest.approx(101.0)), (1.0, pytest.approx(102.0))]
    assert fake() == pytest.approx(103.0)
    lat = rt.lateness
    assert lat.events == 4 and lat.overruns == 0 and lat.counts[0] == 4  # every event on time
    assert lat.to_pandas()["events"].sum() == 4


def test_late_events_are_counted_as_overruns():
    sim = Simulation()
    fake = FakeClock(0.0)
    rt = RealtimeClock(sim, max_lag=0.01, clock=fake, wait=fake.wait)

    def slow():
        fake.t += 0.05    # this callback takes 50 ms of wall time
    sim.call_at(0.1, slow)
    sim.call_at(0.12, lambda: None)    # due at 0.12, processed at 0.15: 30 ms late
    sim.call_at(0.2, lambda: None)     # due at 0.2: on time again
    sim.run(until=0.3)
    lat = rt.lateness
    assert lat.overruns == 1
    assert lat.max == pytest.approx(0.03)
    i = int((LATENESS_EDGES <= 0.03).sum()) - 1
    assert lat.counts[i] == 1 and lat.counts[0] == 3
    assert lat.quantile(1.0) == pytest.approx(LATENESS_EDGES[i + 1])


def test_posted_messages_are_injected_at_their_arrival_time():
    sim = Simulation()
    fake = FakeClock(0.0)
    pending = [0.0123, 0.5, 0.9]     # wall times (s) at which another thread posts
    got = []

    def wait(inbox, timeout):
        # a message arrives during this wait if its wall time falls in the waited interval
        if pending and fake.t + timeout >= pending[0]:
            fake.t = pending.pop(0)
            rt.post(lambda v: got.append((sim.now_ticks, v)), fake.t)
            return inbox.get()
        fake.t += timeout
        return None

    rt = RealtimeClock(sim, clock=fake, wait=wait)
    sim.call_at(1.0, lambda: None)
    sim.run(until=1.2)
    assert got == [(12_300_000_000, 0.0123), (500_000_000_000, 0.5), (900_000_000_000, 0.9)]
    assert rt.lateness.injections == 3 and rt.lateness.late_injections == 0


def test_messages_from_another_thread_all_arrive_in_order():
    sim = Simulation()
    rt = RealtimeClock(sim)     # real monotonic clock: the sender is a real thread
    got: list[tuple[int, int]] = []
    n = 200

    def sender():
        for i in range(n):
            rt.post(lambda i: got.append((sim.now_ticks, i)), i)

    rt.start()
    th = threading.Thread(target=sender)
    th.start()
    th.join(timeout=10)
    sim.run(until=0.05)
    assert [i for _, i in got] == list(range(n))
    ticks = [t for t, _ in got]
    assert ticks == sorted(ticks) and ticks[-1] <= 50_000_000_000
    assert rt.lateness.injections == n


def test_clock_rejects_bad_parameters_and_a_second_clock():
    sim = Simulation()
    with pytest.raises(ValueError, match="real-time factor"):
        RealtimeClock(sim, factor=0)
    with pytest.raises(ValueError, match="max_lag"):
        RealtimeClock(sim, max_lag=-1)
    RealtimeClock(sim)
    with pytest.raises(ValueError, match="already has a real-time clock"):
        RealtimeClock(sim)


def test_messages_due_after_the_stop_are_withdrawn_not_lost():
    sim = Simulation()
    fake = FakeClock(0.0)
    rt = RealtimeClock(sim, clock=fake, wait=fake.wait)
    got: list[str] = []

    def slow():
        fake.t += 0.5                  # the simulation falls 0.5 s behind the wall clock
        rt.post(got.append, "late")    # arrives at wall 1.4 s: simulated 1.4 s, after the stop
    sim.call_at(0.9, slow)
    sim.run(until=1.0)
    assert got == [] and rt.lateness.injections == 1
    assert rt.take_pending() == [(got.append, "late")]
    assert rt.take_pending() == []
    sim.run(until=2.0)
    assert got == []                   # withdrawn: it never runs


class TickingClock:
    """A fake wall clock that advances *step* s on every reading (a polling loop ends)."""

    def __init__(self, step: float):
        self.t, self.step, self.waits = 0.0, step, []

    def __call__(self) -> float:
        self.t += self.step
        return self.t

    def wait(self, inbox, timeout):
        self.waits.append(timeout)
        self.t += timeout
        return None


def test_the_last_spin_seconds_before_an_event_are_polled_not_waited():
    sim = Simulation()
    fake = TickingClock(1e-6)
    rt = RealtimeClock(sim, clock=fake, wait=fake.wait, spin=1e-3)
    ran = []
    sim.call_at(0.01, lambda: ran.append(fake.t))
    sim.run(until=0.02)
    # one blocking wait up to 1 ms before the due time (the clock started at 1 us and read
    # 2 us before the wait), then polling in steps of the clock until due: the event runs
    # within a few clock steps after 10 ms
    assert fake.waits[0] == pytest.approx(0.01 - 1e-3 - 1e-6)
    assert 0.01 + 1e-6 <= ran[0] <= 0.01 + 5e-6
    assert rt.spin == 1e-3


def test_spin_defaults_to_zero_with_an_injected_clock_and_rejects_bad_values():
    from netcosim.transport.realtime import DEFAULT_SPIN
    fake = FakeClock()
    assert RealtimeClock(Simulation(), clock=fake, wait=fake.wait).spin == 0.0
    assert RealtimeClock(Simulation()).spin == DEFAULT_SPIN == 100e-6
    with pytest.raises(ValueError, match="spin"):
        RealtimeClock(Simulation(), spin=-1e-6)


def test_trace_maintenance_runs_in_the_slack_before_an_event(monkeypatch):
    from netcosim.transport import realtime
    monkeypatch.setattr(realtime, "MAINTAIN_EVERY", 10)
    monkeypatch.setattr(realtime, "MAINTAIN_FORCE", 25)
    sim = Simulation()
    fake = FakeClock(0.0)
    rt = RealtimeClock(sim, clock=fake, wait=fake.wait)
    at = []
    monkeypatch.setattr(sim.trace, "maintain", lambda more=None: at.append(round(fake() * 1e4)) or True)
    for k in range(30):             # events 0.1 ms apart (slack < 1 ms), then 5 ms of slack
        sim.call_at(k * 1e-4, lambda: None)
    for k in range(12):
        sim.call_at(0.01 + k * 1e-4, lambda: None)
    sim.run(until=0.02)
    # no slack for 25 events: forced right after the 25th (2.4 ms); in the slack before
    # 10 ms only 5 more events had passed; the 10th came at 10.4 ms with no slack, so the
    # next is in the slack after the last one (11.1 ms); then the end of the run (20 ms)
    assert at == [24, 111, 200]
    assert rt.lateness.overruns == 0


def test_housekeeping_waits_for_an_announced_reply(monkeypatch):
    """After expect_reply(), the slack is left alone until reply_arrived() (or reply_window)."""
    from netcosim.transport import realtime
    monkeypatch.setattr(realtime, "MAINTAIN_EVERY", 3)
    sim = Simulation()
    fake = FakeClock(0.0)
    rt = RealtimeClock(sim, clock=fake, wait=fake.wait, reply_window=0.004)
    at = []
    monkeypatch.setattr(sim.trace, "maintain", lambda more=None: at.append(round(fake() * 1e4)) or True)
    for k in range(3):
        sim.call_at(k * 1e-4, lambda: None)
    sim.call_at(2e-4, rt.expect_reply)            # a message out at 0.2 ms, its answer at 1.5 ms
    sim.call_at(1.5e-3, rt.reply_arrived)
    sim.call_at(1.6e-3, lambda: None)
    sim.call_at(1e-2, lambda: None)
    for k in range(4):                              # again, and no answer: the window (4 ms) ends it
        sim.call_at(0.02 + k * 1e-4, lambda: None)
    sim.call_at(0.0203, rt.expect_reply)
    sim.call_at(0.03, lambda: None)
    sim.run(until=0.05)
    # not in the slack after 0.2 ms (the answer is awaited), right after it at 1.6 ms;
    # after the unanswered message of 20.3 ms, once the window has passed (24.3 ms)
    assert at == [16, 243, 500]
    with pytest.raises(ValueError, match="reply_window"):
        RealtimeClock(Simulation(), reply_window=-1.0)


def test_automatic_garbage_collection_is_off_during_a_run_and_done_in_the_slack():
    import gc

    class Cycle:
        def __init__(self):
            self.me = self
    sim = Simulation()
    fake = FakeClock(0.0)
    rt = RealtimeClock(sim, clock=fake, wait=fake.wait)
    seen = []

    def garbage():
        seen.append(gc.isenabled())
        for _ in range(2000):       # cycles: only the collector frees them
            Cycle()
    for k in range(20):
        sim.call_at(k * 0.01, garbage)
    assert gc.isenabled()
    sim.run(until=0.5)
    assert seen == [False] * 20 and gc.isenabled() and not gc.get_freeze_count()
    assert rt.collections[0] >= 19 and sum(rt.collections) <= 40       # one per 2000 cycles
    gc.disable()                    # the state before the run is what comes back
    try:
        sim.call_at(0.6, garbage)
        sim.run(until=0.7)
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_automatic_garbage_collection_comes_back_after_a_failed_run():
    import gc
    sim = Simulation()
    fake = FakeClock(0.0)
    RealtimeClock(sim, clock=fake, wait=fake.wait)

    def boom():
        raise RuntimeError("boom")
    sim.call_at(0.01, boom)
    with pytest.raises(RuntimeError, match="boom"):
        sim.run(until=0.1)
    assert gc.isenabled() and not gc.get_freeze_count()


class FakeSession:
    """Stands in for a Zenoh session: records what is published, keeps the callbacks."""

    def __init__(self):
        self.sent: list[bytes] = []
        self.callbacks: dict[str, object] = {}
        self.zenoh = self

    def publisher(self, key_expr, encoding=None):
        session = self

        class Pub:
            def put(self, data):
                session.sent.append(bytes(data))
        return Pub()

    def subscribe(self, key_expr, callback):
        self.callbacks[key_expr] = callback
        return _Decl()

    def watch_keys(self, key_expr, callback):
        self.callbacks[key_expr] = callback
        return _Decl()

    def token(self, key_expr):
        self.callbacks[key_expr] = None
        return _Decl()

    def declare_queryable(self, key_expr, callback):
        self.callbacks[key_expr] = callback
        return _Decl()


class _Decl:
    def undeclare(self):
        pass


PEER = 0xAB


class FakeProcess:
    """A process answering each request of a remote over a :class:`FakeSession`:
    ``answer(m)`` returns ``[(delay s, bytes), ...]`` to deliver on ``tx`` that many
    wall-clock seconds after the request was published (None: the correct reply, u = 2 *
    the last value, after 0.3 ms).  Its ``wait`` drives a :class:`FakeClock`."""

    def __init__(self, session, fake, answer=None, reply_after=0.0003):
        self.session, self.fake, self.answer, self.reply_after = session, fake, answer, reply_after
        self.seen = 0
        self.due: list[tuple[float, bytes]] = []
        self.requests: list = []
        self.tx = None

    def reply(self, m, values, **fields):
        f = dict(kind=wire.DATA, node=m.node, session=m.session, peer=PEER, ticks=m.ticks, seq=m.seq)
        f.update(fields)
        return wire.encode(f["kind"], f["node"], f["session"], f["peer"], f["ticks"], f["seq"], values)

    def wait(self, inbox, timeout):
        sent = self.session.sent
        while self.seen < len(sent):
            m = wire.decode(sent[self.seen])
            self.seen += 1
            if m.kind != wire.DATA:
                continue
            self.requests.append(m)
            out = [(self.reply_after, self.reply(m, (2.0 * m.values[-1],)))] if self.answer is None else self.answer(m)
            self.due += [(self.fake.t + d, b) for d, b in out]
            self.due.sort(key=lambda x: x[0])
        end = self.fake.t + timeout
        while self.due and self.due[0][0] <= end:
            t, data = self.due.pop(0)
            self.fake.t = max(self.fake.t, t)
            self.tx(data)                   # the "Zenoh thread": filters, may post to the inbox
            if not inbox.empty():
                return inbox.get()
        self.fake.t = end
        return None


def _plant_io(extra, reply_after=0.0003, factor=1.0, answer=None, **options):
    """A DC servo sampled every 10 ms by RemotePlantIO over a fake session, claimed by a
    fake process that answers every sample *reply_after* s (wall clock) later with
    u = 2 * (last value), or as *answer* says (:class:`FakeProcess`)."""
    from netcosim import RK4
    from netcosim.plants.dc_servo import DCServo
    from netcosim.transport.remote import RemotePlantIO
    sim = Simulation()
    plant = sim.plant(DCServo(), x0=[0.5, 0.0], name="servo", integrator=RK4(dt=1e-3), log_interval=None)
    fake = FakeClock(0.0)
    session = FakeSession()
    proc = FakeProcess(session, fake, answer, reply_after)
    io = RemotePlantIO(sim, plant, session, run="r1", period=0.01, outputs=0, inputs=0, extra=extra,
                       factor=factor, clock=fake, wait=proc.wait, **options)
    proc.tx = session.callbacks["netcosim/r1/servo/tx"]
    session.callbacks["netcosim/r1/servo/alive/*"](f"netcosim/r1/servo/alive/{PEER:016x}", True)   # the claim
    io.proc = proc
    return sim, plant, io, session


def test_remote_plant_io_sends_the_outputs_then_the_extra_values():
    calls = []

    def extra(t):
        calls.append(t)
        return (t, [10.0 * t, -1.0])        # any nesting: flattened in order
    sim, plant, io, session = _plant_io(extra)
    sim.run(until=0.035)
    msgs = [wire.decode(b) for b in session.sent]
    assert calls == [0.0, 0.01, 0.02, 0.03]
    assert [m.ticks for m in msgs] == [0, 10_000_000_000, 20_000_000_000, 30_000_000_000]
    assert [m.seq for m in msgs] == [0, 1, 2, 3]
    assert {(m.node, m.session, m.peer) for m in msgs} == {(wire.LOCAL, io.session_id, PEER)}
    # first the selected output (the servo angle, 0.5 rad at t = 0), then extra(t)'s values
    assert msgs[0].values == (0.5, 0.0, 0.0, -1.0)
    assert msgs[1].values[1:] == (0.01, 0.1, -1.0)
    assert io.published == 4 and io.received == 4 and not io.dropped
    # every reply (u = 2 * last value = -2) was written to the input 0.3 ms after its sample
    assert plant.u[0] == -2.0
    assert io.response_times() == pytest.approx([0.0003] * 4, abs=1e-12)
    assert list(io.requests()["outcome"]) == ["replied"] * 4


def test_remote_plant_io_without_extra_sends_the_outputs_only():
    sim, plant, io, session = _plant_io(None)
    sim.run(until=0.005)
    assert [wire.decode(b).values for b in session.sent] == [(0.5,)]


def test_remote_plant_io_extra_must_be_callable():
    from netcosim.errors import ConfigurationTypeError
    with pytest.raises(ConfigurationTypeError, match=r"extra must be None or a callable .* got \[1\.0\]"):
        _plant_io([1.0])


def _faulty(m, proc_reply):
    """The replies of a misbehaving process to request *m* (seq k): the fault of each k."""
    k, ok = m.seq, proc_reply(m, (1.0,))
    return {0: [(0.001, ok)],
            1: [(0.001, ok), (0.002, ok)],                                  # duplicate
            2: [(0.001, proc_reply(m, (float("nan"),))), (0.002, ok)],        # NaN first, then a good one in time
            3: [(0.001, proc_reply(m, (1.0, 2.0)))],                         # wrong length: expires
            4: [(0.015, ok)],                                                 # after the 10 ms deadline: late
            5: [(0.001, proc_reply(m, (1.0,), seq=m.seq + 100))],            # unsolicited, then expires
            6: [(0.001, proc_reply(m, (1.0,), ticks=m.ticks + 1))],          # names another request: mismatch
            # forged by others before the process's own reply: dropped, the reply applied
            7: [(0.001, proc_reply(m, (5.0,), session=m.session ^ 1)), (0.002, ok)],   # another session
            8: [(0.001, proc_reply(m, (5.0,), peer=PEER + 1)), (0.002, ok)],           # another process
            9: [(0.001, proc_reply(m, (1.0,), node=3))],                     # not to LOCAL: expires
            10: [(0.001, b"NCSM"), (0.002, ok)],                              # short
            11: [(0.001, ok), (1.5, ok)],                                     # replayed 1.5 s later: stale
            }.get(k, [(0.001, ok)])


def test_replies_are_matched_to_outstanding_requests_and_everything_else_is_dropped_by_reason():
    sim, plant, io, session = _plant_io(None, answer=lambda m: _faulty(m, io.proc.reply))
    sim.run(until=1.7)
    c = io.counters()
    assert c["dropped"] == {"duplicate": 1, "nonfinite": 1, "values": 1, "late": 1, "unsolicited": 1,
                            "mismatch": 1, "session": 1, "peer": 1, "destination": 1, "short": 1, "stale": 1}
    r = io.requests().set_index("seq")
    assert list(r.loc[[3, 4, 5, 6, 9], "outcome"]) == ["expired"] * 5
    assert list(r.loc[[2, 7, 8, 10, 11], "outcome"]) == ["replied"] * 5
    assert r.loc[2, "response"] == pytest.approx(0.002) and r.loc[11, "response"] == pytest.approx(0.001)
    assert c["expired"] == 5 and c["received"] == c["published"] - 5 and c["published"] == 170
    assert c["overruns"] == 0 and c["unserved"] == 0
    ev = io.events()
    assert ev.loc[ev["event"] == "dropped", "count"].sum() == 11
    assert ev.loc[ev["event"] == "expired", "count"].sum() == 5
    # the command written is only ever what was asked: 2 * the sample, never the forged 5.0
    assert plant.u[0] == 1.0


def test_a_silent_process_fills_the_outstanding_requests_then_overruns_are_counted():
    sim, plant, io, session = _plant_io(
        None, answer=lambda m: [] if m.seq >= 5 else [(0.001, io.proc.reply(m, (1.0,)))])
    sim.run(until=0.2)
    c = io.counters()
    # max_outstanding = ceil(deadline / period) + 1 = 2: requests 5 and 6 expire, 7..19 are overruns
    assert io.max_outstanding == 2
    assert (c["published"], c["received"], c["expired"], c["overruns"]) == (7, 5, 2, 13)
    assert [m.seq for m in io.proc.requests] == list(range(7))      # the process never saw more
    # forgotten after stale_after (100 deadlines = 1 s): requests flow again
    sim.run(until=1.2)
    assert io.counters()["published"] > 7


def test_loss_policy_callable_and_abort_on():
    from netcosim.transport.remote import RemoteFault
    calls = []
    sim, plant, io, session = _plant_io(
        None, answer=lambda m: [] if m.seq == 3 else [(0.001, io.proc.reply(m, (1.0,)))],
        loss_policy=lambda remote, why: calls.append((remote.sim.now, why)))
    sim.run(until=0.1)
    assert calls == [(pytest.approx(0.04), "expired")]
    sim, plant, io, session = _plant_io(None, answer=lambda m: [(0.001, io.proc.reply(m, (float("nan"),)))]
                                        if m.seq == 3 else [(0.001, io.proc.reply(m, (1.0,)))],
                                        abort_on={"nonfinite"})
    with pytest.raises(RemoteFault, match="nonfinite"):
        sim.run(until=0.1)
    assert sim.now == pytest.approx(0.04)       # folded at the next request, 10 ms later
    ev = io.events()
    assert list(ev.loc[ev["event"] == "aborted", "detail"]) == ["a reply was dropped (nonfinite)"]


def test_a_second_claimant_is_refused_and_told_so():
    sim, plant, io, session = _plant_io(None)
    session.callbacks["netcosim/r1/servo/alive/*"](f"netcosim/r1/servo/alive/{PEER + 1:016x}", True)
    refused = wire.decode(session.sent[-1])
    assert (refused.kind, refused.peer, refused.session) == (wire.REFUSED, PEER + 1, io.session_id)
    sim.run(until=0.05)
    assert io.refused == [PEER + 1] and io.peer == PEER
    ev = io.events()
    assert list(ev["event"][:2]) == ["alive", "refused"]
    assert io.counters()["received"] == 5


def test_remote_options_are_checked():
    from netcosim.errors import ConfigurationError
    with pytest.raises(ConfigurationError, match="loss_policy"):
        _plant_io(None, loss_policy="drop")
    with pytest.raises(ConfigurationError, match="abort_on"):
        _plant_io(None, abort_on={"nan"})
    with pytest.raises(ConfigurationError, match="abort_on"):
        _plant_io(None, abort_on="nonfinite")
    with pytest.raises(ConfigurationError, match="deadline"):
        _plant_io(None, deadline=-1.0)


def test_remote_node_without_reply_values_says_so_at_construction(caplog):
    from netcosim.experiments import networked_servo
    from netcosim.transport.remote import RemoteNode
    for kw, warned in (({}, True), ({"reply_values": 2}, False)):
        caplog.clear()
        sim, _ = networked_servo.build("csma_cd", 0.0)
        fake = FakeClock(0.0)
        RemoteNode(sim, "controller", FakeSession(), run="r1", size_bits=80, period=0.01, clock=fake,
                   wait=fake.wait, **kw)
        assert ("give reply_values=" in caplog.text) == warned


def test_remote_node_replies_go_only_where_destinations_allow():
    from netcosim.errors import ConfigurationError
    from netcosim.experiments import networked_servo
    from netcosim.transport.remote import RemoteNode

    def node(**kw):
        sim, _ = networked_servo.build("csma_cd", 0.0)
        fake = FakeClock(0.0)
        return RemoteNode(sim, "controller", FakeSession(), run="r1", size_bits=80, period=0.01, clock=fake,
                          wait=fake.wait, **kw)

    def to(r, dst, n=2):
        return r._check_reply(wire.Message(wire.DATA, dst, 1, PEER, 0, 0, (0.0,) * n))
    r = node()          # sensor 0, controller 1 (itself), interferer 2, sink 3
    assert [to(r, d) for d in (0, 1, 2, 3, 4, wire.BROADCAST, wire.LOCAL)] == [
        None, "destination", None, None, "destination", None, "destination"]   # no inputs: no LOCAL
    r = node(destinations=("sensor",), reply_values=2)
    assert [to(r, d) for d in (0, 2, wire.BROADCAST)] == [None, "destination", "destination"]
    assert to(r, 0, n=1) == "values"
    assert r.info()["network"] == {"sensor": 0, "controller": 1, "interferer": 2, "sink": 3}
    with pytest.raises(ConfigurationError, match=r"destination 'local' is none of \['interferer', 'sensor', 'sink', "
                                                 r"'broadcast'\]"):
        node(destinations=("local",))
    with pytest.raises(ConfigurationError, match="destinations must be a collection"):
        node(destinations="sensor")
