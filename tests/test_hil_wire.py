"""The HIL wire format and the real-time clock, without Zenoh (fake clocks, threads)."""

from __future__ import annotations

import struct
import threading

import pytest

from netcosim import Simulation
from netcosim.transport import wire
from netcosim.transport.realtime import LATENESS_EDGES, RealtimeClock


def test_encode_layout_is_the_documented_one():
    b = wire.encode(wire.DATA, 3, 7, 10_000_000_000, (1.5, -2.0))
    assert len(b) == 24 + 16
    assert b[:4] == b"NCSM" and b[4] == 1 and b[5] == wire.DATA
    assert struct.unpack_from("<H", b, 6)[0] == 3
    assert struct.unpack_from("<I", b, 8)[0] == 7
    assert struct.unpack_from("<q", b, 12)[0] == 10_000_000_000
    assert struct.unpack_from("<I", b, 20)[0] == 2
    assert struct.unpack_from("<2d", b, 24) == (1.5, -2.0)


def test_round_trip_keeps_every_field_bit_for_bit():
    values = (0.1, -0.0, 1e308, 5e-324, float("inf"))
    m = wire.decode(wire.encode(wire.DATA, 65535, 2**32 + 5, -42, values))
    assert m == wire.Message(wire.DATA, 65535, 5, -42, values)
    assert struct.pack("<5d", *m.values) == struct.pack("<5d", *values)
    assert wire.decode(wire.encode(wire.END, 0, 0, 0)).values == ()


@pytest.mark.parametrize("data, reason", [
    (b"", "short"),
    (b"NCSM\x01", "short"),
    (b"XXXX" + wire.encode(wire.DATA, 0, 0, 0)[4:], "magic"),
    (b"NCSM\x02" + wire.encode(wire.DATA, 0, 0, 0)[5:], "version"),
    (b"NCSM\x01\x09" + wire.encode(wire.DATA, 0, 0, 0)[6:], "kind"),
    (wire.HEADER.pack(b"NCSM", 1, wire.DATA, 0, 0, 0, wire.MAX_VALUES + 1), "oversized"),
    (wire.encode(wire.DATA, 0, 0, 0, (1.0,))[:-1], "length"),
    (wire.encode(wire.DATA, 0, 0, 0, (1.0,)) + b"\0", "length"),
])
def test_decode_rejects_with_a_reason(data, reason):
    with pytest.raises(wire.WireError, match=reason) as e:
        wire.decode(data)
    assert e.value.reason == reason


def test_encode_rejects_out_of_range_fields():
    with pytest.raises(ValueError, match="kind"):
        wire.encode(7, 0, 0, 0)
    with pytest.raises(ValueError, match="node index"):
        wire.encode(wire.DATA, 70000, 0, 0)
    with pytest.raises(ValueError, match="at most 1024"):
        wire.encode(wire.DATA, 0, 0, 0, [0.0] * 1025)


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

    def publisher(self, key_expr):
        session = self

        class Pub:
            def put(self, data):
                session.sent.append(bytes(data))
        return Pub()

    def subscribe(self, key_expr, callback):
        self.callbacks[key_expr] = callback
        return object()

    def watch(self, key_expr, callback):
        self.callbacks[key_expr] = callback
        return object()


def _plant_io(extra, reply_after=0.0003, factor=1.0):
    """A DC servo sampled every 10 ms by RemotePlantIO over a fake session; a fake process
    answers every sample *reply_after* s (wall clock) later with u = 2 * (last value)."""
    from netcosim import RK4
    from netcosim.transport.remote import RemotePlantIO
    from plants.dc_servo import DCServo
    sim = Simulation()
    plant = sim.plant(DCServo(), x0=[0.5, 0.0], name="servo", integrator=RK4(dt=1e-3), log_interval=None)
    fake = FakeClock(0.0)
    session = FakeSession()
    answered = [0]

    def wait(inbox, timeout):
        # the process answers each new sample reply_after s after it was published
        if len(session.sent) > answered[0] and timeout >= reply_after:
            m = wire.decode(session.sent[answered[0]])
            answered[0] += 1
            fake.t += reply_after
            session.callbacks["netcosim/r1/servo/tx"](wire.encode(wire.DATA, 0, m.seq, m.ticks, (2.0 * m.values[-1],)))
            return inbox.get()
        fake.t += timeout
        return None
    io = RemotePlantIO(sim, plant, session, run="r1", period=0.01, outputs=0, inputs=0, extra=extra,
                       factor=factor, clock=fake, wait=wait)
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
    # first the selected output (the servo angle, 0.5 rad at t = 0), then extra(t)'s values
    assert msgs[0].values == (0.5, 0.0, 0.0, -1.0)
    assert msgs[1].values[1:] == (0.01, 0.1, -1.0)
    assert io.published == 4 and io.received == 4 and not io.rejected
    # every reply (u = 2 * last value = -2) was written to the input 0.3 ms after its sample
    assert plant.u[0] == -2.0
    sig = sim.trace.signals()
    resp = sig[(sig["source"] == "servo.remote") & (sig["signal"] == "response")]["value"].to_numpy()
    assert resp == pytest.approx([0.0003] * 4, abs=1e-12)


def test_remote_plant_io_without_extra_sends_the_outputs_only():
    sim, plant, io, session = _plant_io(None)
    sim.run(until=0.005)
    assert [wire.decode(b).values for b in session.sent] == [(0.5,)]


def test_remote_plant_io_extra_must_be_callable():
    from netcosim.errors import ConfigurationTypeError
    with pytest.raises(ConfigurationTypeError, match=r"extra must be None or a callable .* got \[1\.0\]"):
        _plant_io([1.0])
