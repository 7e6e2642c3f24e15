"""netcosim.metrics: integral criteria, quadratic cost, settling time and divergence,
against closed forms of a first-order step response and python-control's LQR cost."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.linalg import expm

from netcosim import Simulation, metrics
from netcosim.errors import ConfigurationError, ConfigurationTypeError, IntegrationError

TAU = 0.5
T_END = 20 * TAU            # truncation: exp(-20) ~ 2e-9 of each integral
TRUNC = 1e-8


def first_order(h: float):
    t = np.arange(0.0, T_END + h / 2, h)
    return t, np.exp(-t / TAU)


# Tolerances from the sampling: for the decreasing e(t) = exp(-t/tau) the zero-order hold
# over-estimates |e| on each step by at most |e'| h, so each integral is off by at most
# h times (integral of |d/dt integrand|) = h * integrand(0) (IAE, ISE: h, ITAE: h tau);
# linear interpolation of a function of curvature f'' errs by h^2/12 * integral of |f''|,
# at most h^2/(6 tau) here (f = e or e^2: integral |f''| <= 2/tau).
@pytest.mark.parametrize("h", [1e-2, 1e-3])
def test_first_order_step_response_integrals(h):
    t, e = first_order(h)
    zoh_tol = {"iae": h, "ise": h, "itae": h * TAU}
    lin_tol = h * h / (6 * TAU)
    exact = {"iae": TAU, "ise": TAU / 2, "itae": TAU ** 2}
    for name, value in exact.items():
        fn = getattr(metrics, name)
        z = fn(t, e)                   # hold="zoh" is the default
        assert value - TRUNC <= z <= value + zoh_tol[name], (name, z)
        assert z - value >= 0.4 * zoh_tol[name]     # the hold's O(h) bias (about half the bound) is there
        lin = fn(t, e, hold="linear")
        assert abs(lin - value) <= lin_tol + TRUNC, (name, lin)


def test_zoh_is_the_exact_integral_of_the_held_signal():
    # a non-uniform grid; the held signal's integrals written out term by term
    t = np.array([0.0, 0.1, 0.35, 0.4, 1.0])
    e = np.array([1.0, -2.0, 0.5, 0.0, 3.0])
    dt = np.diff(t)
    assert metrics.iae(t, e) == pytest.approx(1 * 0.1 + 2 * 0.25 + 0.5 * 0.05 + 0 * 0.6, abs=1e-15)
    assert metrics.ise(t, e) == pytest.approx(np.sum(e[:-1] ** 2 * dt), abs=1e-15)
    assert metrics.itae(t, e) == pytest.approx(sum(abs(e[k]) * (t[k + 1] ** 2 - t[k] ** 2) / 2 for k in range(4)))
    # the window cuts a held step exactly and holds the last value beyond the samples
    assert metrics.iae(t, e, start=0.05, until=0.2) == pytest.approx(1 * 0.05 + 2 * 0.1)
    assert metrics.iae(t, e, until=1.5) == pytest.approx(metrics.iae(t, e) + 3 * 0.5)


def test_linear_hold_finds_zero_crossings():
    # e goes 1 -> -1 over 1 s: |e| is two triangles of area 1/4; e^2 integrates to 1/3
    t, e = np.array([0.0, 1.0]), np.array([1.0, -1.0])
    assert metrics.iae(t, e, hold="linear") == pytest.approx(0.5)
    assert metrics.ise(t, e, hold="linear") == pytest.approx(1 / 3)
    # ITAE: integral_0^1 t |1 - 2t| dt = 1/4
    assert metrics.itae(t, e, hold="linear") == pytest.approx(0.25)
    assert np.trapezoid(np.abs(e), t) == 1.0      # what the trapezoidal rule would say


def test_quadratic_cost_first_order_closed_form():
    # dx/dt = -a x + b u, u = -k x: x = x0 exp(-(a + b k) t), J = (Q + R k^2) x0^2 / (2 (a + b k))
    a, b, k, x0, q, r = 1.0, 2.0, 0.5, 1.5, 3.0, 0.4
    lam = a + b * k
    exact = (q + r * k * k) * x0 * x0 / (2 * lam)
    h = 1e-3
    t = np.arange(0.0, 25 / lam, h)
    x = x0 * np.exp(-lam * t)
    u = -k * x
    zoh = metrics.quadratic_cost(t, x, u, Q=q, R=r)
    lin = metrics.quadratic_cost(t, x, u, Q=[[q]], R=[[r]], hold="linear")
    integrand0 = (q + r * k * k) * x0 * x0
    assert exact <= zoh <= exact + h * integrand0
    assert lin == pytest.approx(exact, abs=h * h / 12 * 2 * lam * integrand0 + 1e-9)
    # ISE is J with Q = 1 and no input
    assert metrics.quadratic_cost(t, x) == pytest.approx(metrics.ise(t, x), rel=1e-14)


def test_quadratic_cost_of_the_lqr_loop_is_x0_S_x0():
    # python-control's convention: the LQR gain minimises integral x'Qx + u'Ru + 2x'Nu dt,
    # and the minimum from x0 is x0' S x0.  The loop is simulated exactly (expm) on a 1 ms
    # grid for 30 s (poles at -1.35 +- 1.15j: the tail is below 1e-30).
    control = pytest.importorskip("control")
    A = np.array([[0.0, 1.0], [0.0, -1.0]])
    B = np.array([[0.0], [1.0]])
    Q, R, N = np.diag([1.0, 0.1]), np.array([[0.1]]), np.array([[0.05], [0.0]])
    K, S, _ = control.lqr(A, B, Q, R, N)
    x0 = np.array([1.0, 0.0])
    h = 1e-3
    t = np.arange(0.0, 30.0, h)
    Phi = expm((A - B @ K) * h)
    x = np.empty((t.size, 2))
    x[0] = x0
    for i in range(1, t.size):
        x[i] = Phi @ x[i - 1]
    u = -(x @ K.T)
    optimum = float(x0 @ S @ x0)
    assert metrics.quadratic_cost(t, x, u, Q=Q, R=R, N=N, hold="linear") == pytest.approx(optimum, rel=1e-6)
    # the held signal costs O(h) more: here 0.1 % at h = 1 ms
    assert metrics.quadratic_cost(t, x, u, Q=Q, R=R, N=N) == pytest.approx(optimum * (1 + 1.05e-3), rel=1e-4)


def test_settling_time_first_order():
    h = 1e-3
    t, e = first_order(h)
    y = 1 - e
    exact = TAU * math.log(50)
    zoh = metrics.settling_time(t, y)
    assert exact <= zoh <= exact + h
    assert metrics.settling_time(t, y, hold="linear") == pytest.approx(exact, abs=h * h / TAU)
    # an error decaying to 0: the band is 2 % of the step from e(0) = 1
    assert metrics.settling_time(t, e) == zoh
    assert metrics.settling_time(t, y, band=0.05) == pytest.approx(TAU * math.log(20), abs=h)
    assert metrics.settling_time(t, y, abs_band=0.1, final=1.0) == pytest.approx(TAU * math.log(10), abs=h)
    # counted from start (an absolute band: the step from y(start) would be smaller)
    assert metrics.settling_time(t, y, start=1.0, final=1.0, abs_band=0.02) == pytest.approx(zoh - 1.0, abs=1e-12)


def test_settling_time_is_python_controls_for_a_step_from_zero():
    control = pytest.importorskip("control")
    sys = control.tf([1.0], [0.2, 0.3, 1.0])        # underdamped: leaves the band several times
    t = np.linspace(0.0, 15.0, 3001)
    resp = control.step_response(sys, t)
    y = np.squeeze(resp.outputs)
    info = control.step_info(y, t, SettlingTimeThreshold=0.02)
    assert metrics.settling_time(t, y, final=float(y[-1])) == pytest.approx(info["SettlingTime"], abs=1e-12)


def test_settling_time_never_or_always():
    t = np.array([0.0, 1.0, 2.0])
    assert metrics.settling_time(t, [0.0, 1.0, 2.0], final=1.0) == math.inf
    assert metrics.settling_time(t, [1.0, 1.0, 1.0], abs_band=0.1) == 0.0
    assert metrics.settling_time(t, [0.0, np.nan, 1.0]) == math.inf


def test_inputs_from_a_simulation_trace():
    sim = Simulation(seed=0)
    node = sim.node("n")
    tau = TAU

    @node.periodic(period=0.01, priority=1, name="log")
    def log(ctx):
        ctx.log("e", math.exp(-ctx.now / tau))
        yield ctx.execute(0.0)

    sim.run(until=T_END)
    sig = sim.trace.signals()
    t, e = metrics.samples(sig, "n.log.e")
    assert t[0] == 0.0 and t.size == 1000   # t = 0, 0.01, ..., 9.99 s
    expected = metrics.iae(t, e)
    assert metrics.iae(sig, "n.log.e") == expected
    assert metrics.iae(sim.trace.signal("n.log", "e")) == expected
    assert metrics.iae(sim.trace.signals(wide=True), "n.log.e") == expected
    assert TAU <= expected <= TAU + 0.01
    # reference turns an output into an error: r - (1 - e) = e for r = 1
    y = pd.Series(1 - e, index=t)
    assert metrics.iae(y, reference=1.0) == pytest.approx(expected, abs=1e-12)
    assert metrics.iae(y, reference=lambda s: 1.0) == pytest.approx(expected, abs=1e-12)
    # quadratic cost of table signals on the union of their instants
    assert metrics.quadratic_cost(sig, "n.log.e", Q=2.0) == pytest.approx(2 * metrics.ise(sig, "n.log.e"))


def test_table_signals_on_different_instants_are_held():
    sig = pd.DataFrame({"time": [0.0, 1.0, 2.0, 0.5, 1.5],
                        "source": ["p"] * 3 + ["c"] * 2, "signal": ["x"] * 3 + ["u"] * 2,
                        "value": [1.0, 2.0, 3.0, 10.0, 20.0]})
    # from t = 0.5 (u's first sample): x = 1, 2, 2, 3 ; u = 10, 10, 20, 20 on [0.5, 1, 1.5, 2]
    J = metrics.quadratic_cost(sig, ["p.x"], ["c.u"], Q=1.0, R=0.01)
    assert J == pytest.approx(0.5 * (1 + 1) + 0.5 * (4 + 1) + 0.5 * (4 + 4))


def test_diverged():
    assert not metrics.diverged([0.0, 1.0, -2.0])
    assert metrics.diverged([0.0, np.nan])
    assert metrics.diverged([0.0, -np.inf])
    assert metrics.diverged([0.0, -5.0], bound=4.0)
    assert not metrics.diverged([0.0, -4.0], bound=4.0)
    assert metrics.diverged(error=FloatingPointError("overflow"))
    assert metrics.diverged(error=IntegrationError("state is not finite"))
    assert not metrics.diverged([1.0], error=KeyError("x"))     # not a divergence
    table = pd.DataFrame({"time": [0.0, 1.0], "source": ["p", "p"], "signal": ["y", "y"], "value": [0.0, 1e17]})
    assert metrics.diverged(table, bound=1e16)
    assert not metrics.diverged(table)


@pytest.mark.parametrize("call, match", [
    (lambda: metrics.iae([0.0, 1.0, 2.0], [1.0, 2.0]), "2 values for 3 sample times"),
    (lambda: metrics.iae([0.0, 2.0, 1.0], [1.0, 2.0, 3.0]), r"sorted.*t\[2\]=1\.0 < t\[1\]=2\.0"),
    (lambda: metrics.ise([0.0, np.nan], [1.0, 2.0]), r"t\[1\]=nan is not finite"),
    (lambda: metrics.iae([], []), "no samples"),
    (lambda: metrics.iae([0.0, 1.0], [1.0, 2.0], hold="cubic"), "'cubic'"),
    (lambda: metrics.iae([0.0, 1.0], [1.0, 2.0], start=-1.0), "start=-1.0"),
    (lambda: metrics.iae([0.0, 1.0], [1.0, 2.0], start=0.5, until=0.2), "until=0.2"),
    (lambda: metrics.quadratic_cost([0.0, 1.0], [1.0, 2.0], Q=-1.0), r"Q must be positive semidefinite.*-1\.0"),
    (lambda: metrics.quadratic_cost([0.0, 1.0], [1.0, 2.0], [0.0, 0.0], Q=1.0, R=[[-0.5]]), r"R must be.*-0\.5"),
    (lambda: metrics.quadratic_cost([0.0, 1.0], [[1.0, 0.0], [2.0, 0.0]], Q=[[1.0, 2.0], [0.0, 1.0]]),
     "Q must be symmetric"),
    (lambda: metrics.quadratic_cost([0.0, 1.0], [1.0, 2.0], Q=np.eye(2)), r"Q must be 1 x 1.*shape \(2, 2\)"),
    (lambda: metrics.quadratic_cost([0.0, 1.0], [1.0, 2.0], [0.0, 0.0], Q=1.0, R=1.0, N=5.0),
     r"\[\[Q, N\], \[N', R\]\] must be positive semidefinite.*5\.0"),
    (lambda: metrics.quadratic_cost([0.0, 1.0], [1.0, 2.0], R=1.0), "R=1.0 given but no input"),
    (lambda: metrics.settling_time([0.0, 1.0], [1.0, 1.0]), "no step to settle"),
    (lambda: metrics.settling_time([0.0, 1.0], [0.0, 1.0], band=-0.1), "band.*-0.1"),
    (lambda: metrics.diverged([1.0], bound=0.0), "bound.*0.0"),
])
def test_bad_input_names_the_value(call, match):
    with pytest.raises(ConfigurationError, match=match):
        call()


def test_bad_input_types_and_names():
    with pytest.raises(ConfigurationTypeError, match="'abc'"):
        metrics.iae(["abc"], [1.0])
    with pytest.raises(ConfigurationTypeError, match="got ndarray alone"):
        metrics.iae(np.zeros(3))
    table = pd.DataFrame({"time": [0.0], "source": ["p"], "signal": ["y"], "value": [1.0]})
    with pytest.raises(KeyError, match=r"'p\.z'.*\['p\.y'\]"):
        metrics.iae(table, "p.z")
    with pytest.raises(ConfigurationTypeError, match="name the signal"):
        metrics.iae(table)
