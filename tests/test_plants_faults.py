"""Plants under faults: non-finite outputs and states, stiff dynamics, absurd step counts.

Bounds are counted (evaluations of f, steps), never timed, so no test depends on the
host's speed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from netcosim import RK4, ContinuousSystem, Simulation, SolveIVP
from netcosim.errors import ConfigurationError, IntegrationError


class Ramp(ContinuousSystem):
    """x' = 1 (x = t), read through a calibration table defined on x in [0, 0.25]:
    outside it the table gives NaN (``np.interp(..., right=nan)``)."""

    state_names = ("x",)
    input_names = ()
    output_names = ("level",)

    def f(self, t, x, u, p):
        return np.array([1.0])

    def h(self, t, x, u, p):
        return np.array([np.interp(x[0], [0.0, 0.25], [0.0, 1.0], right=np.nan)])


def test_nan_output_raises_naming_plant_output_and_time_and_never_reaches_the_task():
    sim = Simulation()
    tank = sim.plant(Ramp(), x0=[0.0], name="tank", integrator=RK4(dt=1e-3))
    seen = []

    def body(ctx):
        seen.append(ctx.read(tank.output("level")))
        yield ctx.execute(0.0)
    sim.node("ctrl").periodic(body, period=0.1, priority=1, name="reader")
    with pytest.raises(IntegrationError, match=r"plant 'tank': output level is non-finite at t=0\.3 s"):
        sim.run(until=1.0)
    assert seen == pytest.approx([0.0, 0.4, 0.8], abs=1e-12)  # t = 0, 0.1, 0.2; no NaN delivered
    assert not sim.trace.signals()["value"].isna().any()


def test_nan_output_raises_from_the_logger_too():
    sim = Simulation()
    sim.plant(Ramp(), x0=[0.0], name="tank", integrator=RK4(dt=1e-3), log_interval=0.1)
    with pytest.raises(IntegrationError, match=r"plant 'tank': output level is non-finite at t=0\.3 s"):
        sim.run(until=1.0)
    sig = sim.trace.signals()
    assert sorted(sig[sig.signal == "y.level"]["time"]) == pytest.approx([0.0, 0.1, 0.2])
    assert not sig["value"].isna().any()


class TableDerivative(ContinuousSystem):
    """x' = table(x), a table defined on [0, 2] that gives NaN beyond (x = t here)."""

    state_names = ("x",)

    def f(self, t, x, u, p):
        return np.array([np.interp(x[0], [0.0, 2.0], [1.0, 1.0], right=np.nan)])


@pytest.mark.parametrize("integrator", [RK4(dt=0.01), SolveIVP()], ids=["rk4", "solve_ivp"])
def test_non_finite_derivative_raises_integration_error_naming_the_state(integrator):
    sim = Simulation()
    p = sim.plant(TableDerivative(), x0=[0.0], name="p", integrator=integrator, log="none")
    sim.call_at(3.0, lambda: p.state)
    with pytest.raises(IntegrationError, match=r"plant 'p': derivative of \['x'\] is non-finite at t="):
        sim.run(until=5.0)
    # afterwards the plant shows its last finite state -- where the failing advance (0 -> 3 s)
    # began -- and reading it does not raise again
    assert p.failure is not None
    assert p.state.tolist() == [0.0] and p.t == 0.0


LAMBDA = 1e9  # 1/s: a mode a million times faster than the 1 ms sampling
OMEGA = 2 * math.pi * 100.0


class FastLag(ContinuousSystem):
    """x' = -λ (x - u - d(t)) with d(t) = sin(ω t): the state follows u + d with lag 1/λ."""

    state_names = ("x",)
    input_names = ("u",)
    output_names = ("x",)
    disturbance_names = ("d",)

    def __init__(self, with_jacobian=False):
        super().__init__()
        self.calls = 0
        self.jac_calls = 0
        if with_jacobian:
            self.jac = self._jac

    def f(self, t, x, u, p):
        self.calls += 1
        return -LAMBDA * (x - u[0] - u[1])

    def _jac(self, t, x, u, p):
        self.jac_calls += 1
        return np.array([[-LAMBDA]])


def fast_lag_exact(t):
    """x(t) for x(0) = 0, u = 0, d = sin(ω t)."""
    k = LAMBDA / (LAMBDA**2 + OMEGA**2)
    return k * (LAMBDA * math.sin(OMEGA * t) - OMEGA * math.cos(OMEGA * t)) + k * OMEGA * math.exp(-LAMBDA * t)


def _fast_lag_sim(system, integrator):
    sim = Simulation()
    kw = {} if integrator is None else {"integrator": integrator}
    p = sim.plant(system, x0=[0.0], name="lag", disturbance=lambda t: [math.sin(OMEGA * t)], log="none", **kw)
    return sim, p


def _radau_run(system):
    sim, p = _fast_lag_sim(system, SolveIVP(method="Radau"))
    times = [0.5e-3 * k for k in range(1, 21)]  # every 0.5 ms up to 10 ms
    got = []
    for t in times:
        sim.call_at(t, lambda: got.append(p.output(0).read()))
    sim.run(until=0.011)
    exact = np.array([fast_lag_exact(t) for t in times])
    lagless = np.sin(OMEGA * np.array(times))
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-9)
    # the 1/λ lag (up to ω/λ = 6.3e-7) is resolved, not lost in the error
    assert np.max(np.abs(exact - lagless)) > 5e-7
    assert system.calls < 20_000  # vs. > 50 000 per millisecond for RK45


def test_stiff_plant_default_integrator_stops_after_its_evaluation_budget_suggesting_radau_which_works():
    system = FastLag()
    sim, p = _fast_lag_sim(system, None)
    with pytest.raises(IntegrationError, match=r"plant 'lag': SolveIVP\(method='RK45'\) used more than "
                                               r"max_evaluations=50000 .*from t=0\.0 to t=0\.001 s "
                                               r"and got only to t=\d[\d.e-]* s; .*"
                                               r"stiff.*SolveIVP\(method='Radau'\)"):
        p.advance(1e-3)  # what a read at 1 ms does first
    assert system.calls == SolveIVP().max_evaluations == 50_000
    assert p.t == 0.0  # the state was not moved
    # the suggested method runs the same plant and matches the analytic solution
    _radau_run(FastLag())


def test_radau_uses_the_jacobian_the_system_provides():
    system = FastLag(with_jacobian=True)
    _radau_run(system)
    assert system.jac_calls > 0


def test_rk4_refuses_an_advance_needing_more_than_max_steps_before_stepping():
    system = FastLag()
    sim, p = _fast_lag_sim(system, RK4(dt=1e-12))
    sim.call_at(1e-3, lambda: p.state)
    with pytest.raises(IntegrationError,
                       match=r"plant 'lag': RK4\(dt=1e-12\) would need 1000000000 steps .*from t=0\.0 to "
                             r"t=0\.001 s.*max_steps=1000000"):
        sim.run(until=0.002)
    assert system.calls == 0


class Decay(ContinuousSystem):
    """x' = -x, counting evaluations of f."""

    state_names = ("x",)

    def __init__(self):
        super().__init__()
        self.calls = 0

    def f(self, t, x, u, p):
        self.calls += 1
        return -x


def test_rk4_max_steps_is_the_documented_bound():
    # exactly max_steps steps pass (4 evaluations each), one more is refused
    sim = Simulation()
    system = Decay()
    p = sim.plant(system, x0=[1.0], integrator=RK4(dt=1e-3, max_steps=1000), log="none")
    p.advance(1.0)  # 1000 steps
    assert system.calls == 4000
    assert p.x[0] == pytest.approx(math.exp(-1.0), rel=1e-12)
    with pytest.raises(IntegrationError, match=r"RK4\(dt=0\.001\) would need 1001 steps .*from t=1\.0 to "
                                               r"t=2\.001 s.*max_steps=1000"):
        p.advance(2.001)
    assert system.calls == 4000


@pytest.mark.parametrize("dt", [1e-15, 5e-13])
def test_rk4_step_below_the_time_resolution_is_refused_at_construction(dt):
    with pytest.raises(ConfigurationError, match=f"RK4 step dt={dt!r} s is below the time resolution 1e-12 s"):
        RK4(dt=dt)


def test_solve_ivp_method_is_validated_and_the_implicit_ones_pass_through():
    with pytest.raises(ConfigurationError, match=r"SolveIVP method must be one of .*'Radau'.*got 'radau'"):
        SolveIVP(method="radau")
    assert [SolveIVP(method=m).implicit for m in ("RK45", "DOP853", "Radau", "BDF", "LSODA")] == \
        [False, False, True, True, True]


# -- what a user's function returns: numbers or a clear error, never a silent NaN ------

@pytest.mark.parametrize("integrator", [None, SolveIVP(), RK4(dt=1e-3)])
@pytest.mark.parametrize("returned, match", [
    ("abc", r"f\(t=0.0\) returned 'abc', not real numbers"),
    (None, r"f\(t=0.0\) returned None, not real numbers"),
    ([1j], r"returned \[1j\], not real numbers"),
    (np.array([1 + 2j]), r"not real numbers"),        # numpy would drop the imaginary part
    ([1.0, 2.0], r"f returned 2 values \[1.0, 2.0\] at t=0.0 s, the system has 1 states \['x'\]"),
])
def test_f_returning_what_is_not_its_derivative_is_refused_by_name(integrator, returned, match):
    from netcosim.errors import ConfigurationTypeError
    sim = Simulation()
    system = ContinuousSystem(f=lambda t, x, u, p: returned, states=["x"], inputs=0, outputs=1)
    sim.plant(system, [1.0], name="tank", integrator=integrator)
    with pytest.raises((ConfigurationError, ConfigurationTypeError), match=match) as info:
        sim.run(0.01)
    assert "plant 'tank'" in str(info.value)


@pytest.mark.parametrize("returned, match", [
    ("a", r"disturbance d\(t=0.0\) returned 'a', not real numbers"),
    (None, r"disturbance d\(t=0.0\) returned None, not real numbers"),
    ([math.nan], r"disturbance d\(t=0.0\) returned non-finite values \[nan\] for \['wind'\]"),
])
def test_a_disturbance_that_is_not_finite_numbers_is_refused(returned, match):
    from netcosim.errors import ConfigurationTypeError
    sim = Simulation()
    # f ignores the disturbance: a NaN would otherwise pass unseen
    system = ContinuousSystem(f=lambda t, x, u, p: [0.0], states=1, inputs=0, outputs=1, disturbances=["wind"])
    sim.plant(system, [1.0], name="boat", disturbance=lambda t: returned)
    with pytest.raises((ConfigurationError, ConfigurationTypeError), match=match):
        sim.run(0.01)


def test_event_functions_are_checked_at_construction_and_their_values_at_run_time():
    from netcosim.errors import ConfigurationTypeError
    from netcosim.plant import HybridEvent
    with pytest.raises(ConfigurationTypeError, match="event 'floor': g must be callable"):
        HybridEvent("floor", 3.0)
    with pytest.raises(ConfigurationTypeError, match=r"event name must be a non-empty string, got \['a'\]"):
        HybridEvent(["a"], lambda t, x, u, p: x[0])
    with pytest.raises(ConfigurationTypeError, match="event 'floor': reset must be None or callable"):
        HybridEvent("floor", lambda t, x, u, p: x[0], reset="zero")
    sim = Simulation()
    system = ContinuousSystem(f=lambda t, x, u, p: [-1.0], states=1, inputs=0, outputs=1,
                              events=[HybridEvent("floor", lambda t, x, u, p: "low")])
    sim.plant(system, [1.0], name="ball")
    with pytest.raises(ConfigurationTypeError, match=r"event 'floor': g\(t=0.0\) returned 'low', not one real"):
        sim.run(0.01)


def test_a_reset_returning_the_wrong_length_is_refused():
    from netcosim.plant import HybridEvent
    sim = Simulation()
    system = ContinuousSystem(f=lambda t, x, u, p: [-1.0], states=1, inputs=0, outputs=1,
                              events=[HybridEvent("floor", lambda t, x, u, p: x[0], direction=-1,
                                                  reset=lambda t, x, u, p: [1.0, 0.0])])
    sim.plant(system, [0.5], name="ball", integrator=RK4(dt=1e-3))
    with pytest.raises(ConfigurationError, match=r"event 'floor': reset returned 2 values \[1.0, 0.0\], the "
                                                 r"system has 1 states"):
        sim.run(1.0)


@pytest.mark.parametrize("rtol", [1e-300, 1e-15, 1.0, 2.0])
def test_solve_ivp_rtol_outside_what_scipy_uses_is_refused(rtol):
    with pytest.raises(ConfigurationError, match=r"rtol must be at least 2.22\d*e-14 .* below 1, got"):
        SolveIVP(rtol=rtol)
    assert SolveIVP(rtol=2.3e-14).rtol == 2.3e-14


def test_plant_name_shape_of_x0_and_of_a_written_value_are_checked():
    from netcosim.errors import ConfigurationError
    from netcosim.plants.dc_servo import DCServo
    sim = Simulation()
    with pytest.raises(ConfigurationError, match="component name"):
        sim.plant(DCServo(), [0.0, 0.0], name="")
    with pytest.raises(ConfigurationError, match=r"x0 must be a flat sequence of 2 numbers, got shape \(1, 2\)"):
        sim.plant(DCServo(), [[0.0, 0.0]], name="servo")
    servo = sim.plant(DCServo(), [0.0, 0.0], name="servo")
    with pytest.raises(ConfigurationError, match=r"input u takes 1 value\(s\), got array\(\[\[1.\]\]\)"):
        servo.input("u").write(np.array([[1.0]]))
    servo.input("u").write([0.5])           # one value as a 1-element sequence: fine
    assert servo.u.tolist() == [0.5]
    assert servo.input(-1).label == "u"      # a negative index counts from the end, as in Python
