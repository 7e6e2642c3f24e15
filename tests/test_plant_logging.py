"""Plants logged on the default grid until a task touches them (issue 23): a starved loop
still has a trajectory and a cost, metrics say which samples they used, and
``Trace.signal`` names the signals that exist."""

from __future__ import annotations

import math
import pickle
import warnings

import numpy as np
import pytest

from netcosim import RK4, Simulation, metrics
from netcosim.experiments.servo import add_pid_loop
from netcosim.plant import (
    DEFAULT_LOG_INTERVAL,
    ContinuousSystem,
    ExactZOH,
    HybridEvent,
    SolveIVP,
    default_log_interval,
)
from netcosim.plants.dc_servo import DCServo
from netcosim.trace import UnknownSignalError

G = DEFAULT_LOG_INTERVAL
INTEGRATORS = [lambda: None, lambda: RK4(dt=1e-4), lambda: ExactZOH(), lambda: SolveIVP(method="Radau")]
IDS = ["solve_ivp", "rk4", "exact_zoh", "radau"]


class FirstOrder(ContinuousSystem):
    """dx/dt = -x/tau + u/tau, y = x (A and B for ExactZOH)."""

    state_names = ("x",)
    input_names = ("u",)
    output_names = ("y",)

    def __init__(self, tau: float):
        super().__init__()
        self.tau = tau
        self.A = np.array([[-1.0 / tau]])
        self.B = np.array([[1.0 / tau]])

    def f(self, t, x, u, p):
        return (u[:1] - x) / self.tau


class Ball(ContinuousSystem):
    """Falling ball bouncing on y = 0 (restitution 0.5)."""

    state_names = ("y", "v")
    input_names = ()
    output_names = ("y",)

    def __init__(self):
        super().__init__()
        self.events = (HybridEvent("ground", lambda t, x, u, p: x[0], direction=-1,
                                   reset=lambda t, x, u, p: np.array([0.0, -0.5 * x[1]])),)

    def f(self, t, x, u, p):
        return np.array([x[1], -9.81])

    def h(self, t, x, u, p):
        return x[:1]


def starved_servo(integrator, x0=(0.3, 0.0), until=0.3):
    """A PID loop whose task never runs: a higher-priority task holds the CPU all the run."""
    sim = Simulation()
    servo = sim.plant(DCServo(), x0=list(x0), name="servo", integrator=integrator)
    cpu = sim.node("controller", scheduler="fixed_priority")

    @cpu.periodic(period=10.0, priority=0, name="hog")
    def hog(ctx):
        yield ctx.execute(10.0)
    add_pid_loop(cpu, servo, priority=1, reference=lambda t: 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the starved task's jobs queue up
        sim.run(until=until)
    return sim, servo


@pytest.mark.parametrize("make", INTEGRATORS, ids=IDS)
def test_starved_loop_has_a_cost_the_open_loop_constant_output(make):
    T, y0, r = 0.3, 0.3, 1.0
    sim, servo = starved_servo(make(), x0=(y0, 0.0), until=T)
    jobs = sim.trace.jobs()
    assert not (jobs["task"] == "pid").any() or jobs.loc[jobs["task"] == "pid", "start"].isna().all()
    assert "controller.pid" not in set(sim.trace.signals()["source"].astype(str))  # the controller never ran
    y = sim.trace.signal("servo", "y.y")
    n = round(T / G)
    np.testing.assert_allclose(y.index.to_numpy(), np.arange(n + 1) * G, rtol=0, atol=1e-15)
    assert (y.to_numpy() == y0).all()  # no input, no velocity: the angle stays
    cost = metrics.iae(y, reference=r)
    assert math.isfinite(cost)
    assert cost == pytest.approx(abs(r - y0) * T, rel=1e-12)
    assert cost.grid.startswith("servo: default grid 1 ms until the first read or write")
    assert f"{n + 1} samples on [0, 0.3] s, every 1 ms" in cost.grid
    np.testing.assert_allclose(cost.times, np.arange(n + 1) * G, atol=1e-15)
    # the other metrics work on it too
    assert metrics.ise(y, reference=r) == pytest.approx((r - y0) ** 2 * T, rel=1e-12)
    assert metrics.itae(y, reference=r) == pytest.approx(abs(r - y0) * T * T / 2, rel=1e-12)
    table = sim.trace.signals()
    assert metrics.iae(table, "servo.y.y", reference=r) == pytest.approx(cost, rel=0, abs=0)
    assert metrics.iae(table, "servo.y.y", reference=r).grid == cost.grid


def test_starved_first_order_iae_is_the_sum_on_the_documented_grid():
    """y = exp(-t/tau) logged every G: IAE (hold) = G (1 - q^N)/(1 - q), q = exp(-G/tau);
    linear: G (1 + q)/2 (1 - q^N)/(1 - q); the continuous integral tau (1 - exp(-T/tau)) lies
    between, within G."""
    tau, T = 0.05, 0.2
    sim = Simulation()
    sim.plant(FirstOrder(tau), x0=[1.0], name="lag", integrator=ExactZOH())
    sim.run(until=T)
    y = sim.trace.signal("lag", "y.y")
    N = round(T / G)
    q = math.exp(-G / tau)
    zoh = G * (1 - q ** N) / (1 - q)
    lin = G * (1 + q) / 2 * (1 - q ** N) / (1 - q)
    assert metrics.iae(y) == pytest.approx(zoh, rel=1e-12)
    assert metrics.iae(y, hold="linear") == pytest.approx(lin, rel=1e-12)
    exact = tau * (1 - math.exp(-T / tau))
    assert lin > exact > zoh - G and zoh - exact <= G  # the grid decides the last digits
    np.testing.assert_allclose(y.to_numpy(), np.exp(-np.arange(N + 1) * G / tau), rtol=1e-12)


@pytest.mark.parametrize("make", INTEGRATORS + [lambda: RK4(dt=3e-3)], ids=IDS + ["rk4_coarse"])
@pytest.mark.parametrize("system, x0", [(DCServo, [1.0, 0.5]), (Ball, [1.0, 0.0])], ids=["servo", "ball"])
def test_default_grid_does_not_change_the_plant(make, system, x0):
    if system is Ball and isinstance(make(), ExactZOH):
        pytest.skip("ExactZOH needs a linear plant")
    out = []
    for log in ("io", "none"):
        sim = Simulation()
        p = sim.plant(system(), x0=x0, name="p", integrator=make(), log=log)
        for T in (0.3, 0.7, 1.2345):
            sim.run(until=T)
        out.append((p.x.tobytes(), dict(p.event_counts), len(sim.trace.signals())))
    assert out[0][:2] == out[1][:2]  # the same states, bit for bit, and the same events
    assert out[1][2] == 0
    step = default_log_interval(make() if isinstance(make(), RK4) else None)
    per_instant = len(system.state_names) + len(system.input_names) + len(system.output_names)
    # the grid up to 1.2345 s, plus the end of each run that is off the grid
    n = math.floor(1.2345 / step + 1e-9) + 1 + sum(1 for T in (0.3, 0.7, 1.2345)
                                                   if abs(T / step - round(T / step)) > 1e-9)
    assert out[0][2] == per_instant * n


def test_grid_states_follow_the_trajectory():
    """The DC servo from velocity 1 with no input: angle = 1 - exp(-t) (k = 1000, a = 1)."""
    for integrator, tol in ((None, 1e-7), (RK4(dt=1e-4), 1e-10), (ExactZOH(), 1e-12)):
        sim = Simulation()
        sim.plant(DCServo(), x0=[0.0, 1.0], name="servo", integrator=integrator)
        sim.run(until=0.5)
        a = sim.trace.signal("servo", "x.angle")
        np.testing.assert_allclose(a.to_numpy(), 1 - np.exp(-a.index.to_numpy()), rtol=0, atol=tol)


def test_a_loop_is_logged_at_its_io_instants_only_from_its_first_touch():
    sim = Simulation()
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=RK4(dt=1e-4))
    cpu = sim.node("controller", scheduler="fixed_priority")
    add_pid_loop(cpu, servo, period=0.006, execution=0.002, offset=0.0105)
    sim.run(until=0.05)
    t = np.unique(sim.trace.signal("servo", "x.angle").index.to_numpy())
    grid = np.arange(11) * G  # 0 .. 10 ms, before the first read at 10.5 ms
    io = 0.0105 + np.concatenate([[k * 0.006, k * 0.006 + 0.002] for k in range(7)])
    np.testing.assert_allclose(t, np.sort(np.concatenate([grid, io[io <= 0.05]])), atol=1e-12)


def test_a_loop_touching_the_plant_at_zero_gets_no_grid_row():
    sim = Simulation()
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=RK4(dt=1e-4))
    add_pid_loop(sim.node("controller", scheduler="fixed_priority"), servo)
    sim.run(until=0.05)
    t = np.unique(sim.trace.signal("servo", "x.angle").index.to_numpy())
    io = np.concatenate([[k * 0.006, k * 0.006 + 0.002] for k in range(9)])
    np.testing.assert_allclose(t, np.sort(io[io < 0.05 - 1e-9]), atol=1e-12)  # the write at 50 ms is not run


def test_grid_rule_and_description():
    assert default_log_interval(None) == G == 1e-3
    assert default_log_interval(SolveIVP()) == G
    assert default_log_interval(RK4(dt=1e-4)) == G
    assert default_log_interval(RK4(dt=5e-3)) == 5e-3
    sim = Simulation()
    a = sim.plant(DCServo(), x0=[0, 0], name="a", integrator=RK4(dt=5e-3))
    b = sim.plant(DCServo(), x0=[0, 0], name="b", log_interval=0.01)
    c = sim.plant(DCServo(), x0=[0, 0], name="c", log="none")
    d = sim.plant(DCServo(), x0=[0, 0], name="d", integrator=ExactZOH(fallback=RK4(dt=2e-3)))
    assert a.log_grid.startswith("default grid 5 ms until the first read or write")
    assert b.log_grid == "log_interval 10 ms"
    assert c.log_grid == "none"
    assert d.log_grid.startswith("default grid 1 ms")  # the exact step applies: no step size
    assert sim.trace.grids == {p.name: p.log_grid for p in (a, b, c, d)}
    sim.run(until=0.02)
    assert metrics.iae(sim.trace.signal("b", "y.y")).grid.startswith("b: log_interval 10 ms; 2 samples")
    assert len(sim.trace.signal("a", "y.y")) == 5


def test_default_grid_rows_are_bounded_by_the_trace_mode():
    sim = Simulation()
    sim.trace.configure("signals", "ring", rows=100)
    sim.plant(DCServo(), x0=[0.3, 0.0], name="servo")
    sim.run(until=1.0)
    sig = sim.trace.signals()
    assert len(sig) == 100
    assert sig["time"].max() == 1.0
    off = Simulation()
    off.trace.configure("signals", "off")
    p = off.plant(DCServo(), x0=[0.3, 1.0], name="servo")
    off.run(until=1.0)  # no grid work at all, and the same state
    assert len(off.trace.signals()) == 0
    quiet = Simulation()
    q = quiet.plant(DCServo(), x0=[0.3, 1.0], name="servo", log="none")
    quiet.run(until=1.0)
    assert p.x.tobytes() == q.x.tobytes()


def test_unknown_signal_names_the_signals_that_exist():
    sim = Simulation()
    sim.plant(DCServo(), x0=[0.0, 0.0], name="servo")
    sim.run(until=0.01)
    with pytest.raises(KeyError) as info:
        sim.trace.signal("servo", "y")
    err = info.value
    assert isinstance(err, UnknownSignalError)
    msg = str(err)
    assert msg == ("no signal 'y' logged by 'servo'; its signals are ['u.u', 'x.angle', 'x.velocity', 'y.y'] "
                   "(did you mean 'y.y'?)")
    with pytest.raises(UnknownSignalError, match=r"no source 'srvo' in the signals table; sources are "
                                                 r"\['servo'\] \(did you mean 'servo'\?\)"):
        sim.trace.signal("srvo", "y.y")
    empty = Simulation()
    empty.plant(DCServo(), x0=[0.0, 0.0], name="quiet", log="none")
    with pytest.raises(UnknownSignalError, match=r"nothing was logged; 'quiet' is logged: none"):
        empty.trace.signal("quiet", "y.y")


def test_cost_is_a_float_that_names_its_samples():
    c = metrics.iae([0.0, 1.0, 2.0], [1.0, -2.0, 5.0])
    assert c == 3.0 and isinstance(c, float) and isinstance(c, metrics.Cost)
    assert c.grid == "3 samples on [0, 2] s, every 1 s"
    np.testing.assert_array_equal(c.times, [0.0, 1.0, 2.0])
    assert type(c + 1.0) is float
    back = pickle.loads(pickle.dumps(c))
    assert back == c and back.grid == c.grid
    s = metrics.settling_time([0.0, 0.5, 2.0], [0.0, 0.99, 1.0])
    assert s == 0.5 and s.grid == "3 samples on [0, 2] s, spacing 500 ms to 1.5 s"
    q = metrics.quadratic_cost([0.0, 1.0], [1.0, 1.0], until=3.0)
    assert q == 3.0 and q.grid == "3 samples on [0, 3] s, spacing 1 s to 2 s"  # the window end held
