"""Lazy plant integration, ZOH I/O semantics, hybrid events, logging."""

import math

import numpy as np
import pytest
from scipy.linalg import expm

from netcosim import RK4, ContinuousSystem, HybridEvent, Simulation, SolveIVP
from netcosim.experiments import servo as servo_example
from netcosim.plants.dc_servo import DCServo

H, TAU = 0.006, 0.002


def zoh(A, B, t):
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm(M * t)
    return E[:n, :n], E[:n, n:]


def discrete_delayed_outputs(u, n):
    """Outputs at t_k = k*H of the servo driven by u_k applied at t_k + TAU (ZOH)."""
    p = DCServo()
    Phi_tau, Gam_tau = zoh(p.A, p.B, TAU)
    Phi_rest, Gam_rest = zoh(p.A, p.B, H - TAU)
    x = np.zeros(2)
    u_prev = 0.0
    ys = []
    for k in range(n):
        ys.append(x[0])
        x = Phi_tau @ x + Gam_tau[:, 0] * u_prev
        x = Phi_rest @ x + Gam_rest[:, 0] * u[k]
        u_prev = u[k]
    return np.array(ys)


@pytest.mark.parametrize("integrator", [RK4(dt=1e-4), SolveIVP(method="DOP853", rtol=1e-13, atol=1e-13)],
                         ids=["rk4", "solve_ivp"])
def test_servo_samples_equal_discrete_model_with_delay(integrator):
    sim = servo_example.build(integrator=integrator)
    sim.run(until=1.0)
    sig = sim.trace.signals()
    pid = sig[sig["source"] == "controller.pid"]
    y = pid[pid["signal"] == "y"]["value"].to_numpy()
    u = pid[pid["signal"] == "u"]["value"].to_numpy()
    t_y = pid[pid["signal"] == "y"]["time"].to_numpy()
    n = len(u)
    assert n == 167  # jobs at 0, 6, ..., 996 ms
    np.testing.assert_allclose(t_y[:n], np.arange(n) * H, rtol=0, atol=1e-15)
    ref = discrete_delayed_outputs(u, n)
    scale = np.max(np.abs(ref))
    assert scale > 0.5  # the loop really moves the servo
    assert np.max(np.abs(y[:n] - ref)) <= 1e-9 * scale
    # the 2 ms computational delay is in the trace: u written at k*H + 2 ms
    t_u = pid[pid["signal"] == "u"]["time"].to_numpy()
    np.testing.assert_allclose(t_u, np.arange(n) * H + TAU, atol=1e-15)


def test_logging_rate_does_not_change_the_trajectory():
    ys = []
    for log_interval in (None, 1e-3, 3.7e-4):
        sim = servo_example.build(integrator=RK4(dt=1e-4), log_interval=log_interval)
        sim.run(until=0.5)
        ys.append(sim.trace.signal("controller.pid", "y").to_numpy())
    for other in ys[1:]:
        assert np.max(np.abs(other - ys[0])) <= 1e-9 * np.max(np.abs(ys[0]))


def test_log_interval_samples_on_grid():
    sim = servo_example.build(log_interval=0.01)
    sim.run(until=0.1)
    t = sim.trace.signal("servo", "x.angle").index.to_numpy()
    np.testing.assert_allclose(t, np.arange(10) * 0.01, atol=1e-15)


class Ball(ContinuousSystem):
    """Falling ball bouncing with restitution e on the ground y = 0."""

    state_names = ("y", "v")
    input_names = ()
    output_names = ("y",)

    def __init__(self, e=0.5, g=9.81):
        super().__init__()
        self.g = g
        self.events = (HybridEvent("ground", lambda t, x, u, p: x[0], direction=-1,
                                   reset=lambda t, x, u, p: np.array([0.0, -e * x[1]])),)

    def f(self, t, x, u, p):
        return np.array([x[1], -self.g])

    def h(self, t, x, u, p):
        return x[:1]


@pytest.mark.parametrize("integrator", [RK4(dt=1e-3), SolveIVP(rtol=1e-10, atol=1e-12)], ids=["rk4", "solve_ivp"])
def test_hybrid_event_located_and_notified_at_contact(integrator):
    sim = Simulation()
    ball = sim.plant(Ball(), x0=[1.0, 0.0], integrator=integrator, log="none")
    node = sim.node("watch")
    seen = []

    def on_contact(ctx):
        seen.append(ctx.now)
        yield ctx.execute(0.0)
    handler = node.handler(on_contact, priority=0, name="contact")
    ball.on_event("ground", lambda t: handler.release())
    sim.run(until=1.0)  # two contacts before 1 s (the bounces accumulate at 1.354 s)
    t1 = math.sqrt(2 * 1.0 / 9.81)
    t2 = t1 + 2 * 0.5 * math.sqrt(2 * 9.81 * 1.0) / 9.81  # second contact after the bounce
    evt = [t for t, _ in ball.event_log]
    assert evt == pytest.approx([t1, t2], abs=1e-9)
    assert seen == pytest.approx([t1, t2], abs=1e-9)  # the discrete world hears it on time
    assert ball.event_counts["ground"] == 2


def test_lazy_integration_does_not_advance_unread_plant():
    sim = Simulation()
    p = sim.plant(DCServo(), x0=[0.0, 1.0], log="none", integrator=RK4(dt=1e-3))
    seen = []
    sim.call_at(5.0, lambda: seen.append(p.t))
    sim.run(until=10.0)
    assert seen == [0.0]  # untouched until someone needed it
    assert p.t == 10.0 and p.x[0] == pytest.approx(1.0 - math.exp(-10.0), rel=1e-9)


def test_plant_bad_input():
    sim = Simulation()
    with pytest.raises(ValueError, match="x0 has 3 entries"):
        sim.plant(DCServo(), x0=[0, 0, 0])
    p = sim.plant(DCServo(), x0=[0, 0], name="s")
    with pytest.raises(ValueError, match="non-finite value nan"):
        p.input(0).write(float("nan"))
    with pytest.raises(KeyError, match="no output 'z'"):
        p.output("z")
    with pytest.raises(ValueError, match="RK4 step dt.*-0.1"):
        RK4(dt=-0.1)
