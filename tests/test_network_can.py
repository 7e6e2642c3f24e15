"""CAN: frame lengths, arbitration, and worst-case response times against CAN RTA.

The analysis is the revised one of Davis, Burns, Bril and Lukkien (2007), "Controller
Area Network (CAN) schedulability analysis: refuted, revisited and revised", eqs. (1),
(5)-(8), with zero queuing jitter:

    C_m = (55 + 10 s_m) tau_bit                      (11-bit ids, worst-case stuffing, with IFS)
    B_m = max_{k in lp(m)} C_k
    t_m = B_m + sum_{k in hep(m)} ceil(t_m / T_k) C_k       (priority level-m busy period)
    Q_m = ceil(t_m / T_m)
    w_m(q) = B_m + q C_m + sum_{k in hp(m)} ceil((w_m(q) + tau_bit) / T_k) C_k
    R_m = max_{q < Q_m} (w_m(q) - q T_m + C_m)

The simulated critical instant: the longest lower-priority frame starts at t = 0 on an
idle bus; one tick (1 ps) later message m and every higher-priority message are queued
together, then again every period.  The periods are chosen so that no release falls
within one bit time after an arbitration instant (the analysis' "+ tau_bit" counts such a
release, the simulation's exact-instant arbitration would not).
"""

import math

import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError
from netcosim.network import BROADCAST, CAN, can_frame_bits

# (data bytes, period s) in priority order (index 0 = highest priority)
MESSAGES = [(4, 2.764e-3), (4, 5.468e-3), (6, 6.397e-3), (8, 6.527e-3), (0, 7.723e-3), (1, 9.667e-3),
            (7, 10.365e-3)]


def rta(C, T, tau):
    """Per message: (R_m, Q_m, list of R_m(q)) by the revised CAN analysis (no jitter)."""
    out = []
    for m in range(len(C)):
        B = max(C[m + 1:], default=0.0)
        t = C[m]
        while True:
            t_new = B + sum(math.ceil(t / T[k] - 1e-12) * C[k] for k in range(m + 1))
            if abs(t_new - t) < 1e-15:
                break
            t = t_new
        Q = math.ceil(t / T[m] - 1e-12)
        Rq = []
        for q in range(Q):
            w = B + q * C[m]
            while True:
                w_new = B + q * C[m] + sum(math.ceil((w + tau) / T[k] - 1e-12) * C[k] for k in range(m))
                if abs(w_new - w) < 1e-15:
                    break
                w = w_new
            Rq.append(w - q * T[m] + C[m])
        out.append((max(Rq), Q, Rq))
    return out


def simulated_worst_response(rate, m, horizon=0.5):
    sim = Simulation(seed=0)
    can = CAN(sim, "can", data_rate=rate, frame_format="standard")
    nodes = [can.attach(f"n{i}", priority=i) for i in range(len(MESSAGES))]
    can.attach("sink", priority=99, mailbox=False)
    lower = range(m + 1, len(MESSAGES))
    if lower:
        k = max(lower, key=lambda i: MESSAGES[i][0])
        nodes[k].send("sink", None, 8 * MESSAGES[k][0])
    for i in range(m + 1):
        size, period = MESSAGES[i]
        T = int(round(period * 1e12))
        for t in range(1, int(horizon * 1e12), T):
            sim.call_at_ticks(t, lambda i=i, size=size: nodes[i].send("sink", None, 8 * size))
    sim.run(horizon + 0.05)
    df = can.frames()
    mine = df[df["src"] == f"n{m}"]
    created = mine[mine["event"] == "created"].set_index("frame")["time"]
    done = mine[mine["event"] == "attempt_end"].set_index("frame")["time"]
    resp = (done - created).dropna()
    assert len(resp) == len(created)
    return resp.max()


def test_worst_case_frame_lengths():
    for s in range(9):
        assert can_frame_bits(s) == 55 + 10 * s
        assert can_frame_bits(s, stuffing=False) == 47 + 8 * s
        assert can_frame_bits(s, extended=True) == 80 + 10 * s
    with pytest.raises(ValueError, match="9"):
        can_frame_bits(9)


@pytest.mark.parametrize("rate", [125e3, 500e3])
def test_simulated_critical_instant_equals_response_time_analysis(rate):
    tau = 1.0 / rate
    C = [(55 + 10 * s) * tau for s, _ in MESSAGES]
    T = [p for _, p in MESSAGES]
    analysis = rta(C, T, tau)
    for m in range(len(MESSAGES)):
        R_sim = simulated_worst_response(rate, m)
        # the blocking frame started one tick before the critical instant
        assert R_sim == pytest.approx(analysis[m][0], abs=2e-12), (m, R_sim, analysis[m])
    if rate == 125e3:
        # utilisation 0.93; the lowest-priority message's busy period spans two of its
        # instances and the *second* has the worst response: the case the original
        # (Tindell) analysis missed
        assert sum(c / t for c, t in zip(C, T)) == pytest.approx(0.930, abs=1e-3)
        R6, Q6, Rq6 = analysis[6]
        assert Q6 == 2 and Rq6[1] > Rq6[0]
        assert R6 == pytest.approx(6835e-6, abs=1e-12) and Rq6[0] == pytest.approx(6240e-6, abs=1e-12)


def test_arbitration_by_priority_at_each_idle_instant_and_no_preemption():
    sim = Simulation()
    can = CAN(sim, "can", data_rate=1e6, frame_format="truetime")
    a, b, c = (can.attach(n, priority=p) for n, p in (("a", 5), ("b", 1), ("c", 3)))
    can.attach("sink", priority=0)
    a.send("sink", "A", 100)                                   # alone: starts at once
    sim.call_at(10e-6, lambda: (c.send("sink", "C", 100), b.send("sink", "B", 100)))
    sim.run(1e-3)
    st = can.frames().query("event == 'attempt_start'")
    assert list(st["src"]) == ["a", "b", "c"]
    assert list(st["time"]) == pytest.approx([0.0, 100e-6, 200e-6], abs=1e-12)


def test_frames_queued_at_the_instant_the_bus_goes_idle_compete():
    sim = Simulation()
    can = CAN(sim, "can", data_rate=1e6)
    lo, hi = can.attach("lo", priority=9), can.attach("hi", priority=1)
    can.attach("sink", priority=0)
    lo.send("sink", None, 100)
    lo.send("sink", None, 100)
    sim.call_at(100e-6, lambda: hi.send("sink", None, 100))   # exactly at the end of lo's frame
    sim.run(1e-3)
    st = can.frames().query("event == 'attempt_start'")
    assert list(st["src"]) == ["lo", "hi", "lo"]


def test_standard_format_carries_at_most_eight_bytes_and_needs_priorities():
    sim = Simulation()
    can = CAN(sim, "can", data_rate=500e3, frame_format="standard")
    x = can.attach("x")
    can.attach("y", priority=2)
    with pytest.raises(ConfigurationError, match="needs a priority"):   # a netcosim error (a ValueError)
        x.send("y", None, 8)
    with pytest.raises(ValueError, match="size_bits=72"):
        x.send("y", None, 72, priority=1)
    x.send(BROADCAST, None, 64, priority=1)
    sim.run(1e-3)
    st = can.frames().query("event == 'attempt_start'")
    assert st["bits"].tolist() == [135.0]
    with pytest.raises(ValueError, match="frame_format"):
        CAN(sim, "can2", frame_format="fd")
