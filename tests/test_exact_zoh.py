"""ExactZOH: the exact zero-order-hold step of linear time-invariant plants.

The references are independent of netcosim's step: ``scipy.signal.cont2discrete(...,
method="zoh")`` discretises the plant over each interval between the loop's I/O
instants (recorded by the task), and the discrete model is chained with the inputs
the task wrote.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import cont2discrete

import netcosim.plant.exact_zoh
from netcosim import RK4, ContinuousSystem, ExactZOH, HybridEvent, Simulation
from netcosim.controllers.pid import PID
from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.plants.dc_servo import DCServo

UNTIL = 1.0  # s: ~167 PID samples


def pid_loop(system, integrator, *, x0, output="y", input="u", **plant_kw):
    """The README quick start: PID every 6 ms, 2 ms of execution, on *system*.

    Returns the plant and the I/O log: ``reads`` [(t, y)], ``writes`` [(t, u)].
    """
    sim = Simulation(seed=1)
    plant = sim.plant(system, x0=x0, integrator=integrator, **plant_kw)
    cpu = sim.node("controller", scheduler="fixed_priority", context_switch=20e-6)
    pid = PID(h=0.006)
    y_port, u_port = plant.output(output), plant.input(input)
    reads, writes = [], []

    @cpu.periodic(period=0.006, priority=1)
    def control(ctx):
        y = ctx.read(y_port)
        reads.append((sim.now, y))
        u = pid.compute(1.0, y)
        yield ctx.execute(0.002)
        ctx.write(u_port, u)
        writes.append((sim.now, u))

    sim.run(until=UNTIL)
    return plant, reads, writes


def zoh_reference(A, B, C, D, x0, reads, writes):
    """Outputs at the read instants from the discrete ZOH model chained over every interval."""
    events = sorted([(t, 0, None) for t, _ in reads] + [(t, 1, u) for t, u in writes], key=lambda e: (e[0], e[1]))
    x, u, t = np.array(x0, dtype=float), np.zeros(B.shape[1]), 0.0
    ys = []
    for te, kind, val in events:
        if te > t:
            Ad, Bd, _, _, _ = cont2discrete((A, B, C, D), te - t, method="zoh")
            x = Ad @ x + Bd @ u
            t = te
        if kind == 0:
            ys.append((C @ x + D @ u)[0])
        else:
            u = np.atleast_1d(float(val))
    return np.array(ys), x, t


def test_dc_servo_equals_the_analytic_zoh_model():
    servo = DCServo()
    plant, reads, writes = pid_loop(servo, ExactZOH(), x0=[0.0, 0.0])
    assert len(reads) >= 160 and len(writes) >= 160
    D = np.zeros((1, 1))
    y_ref, x_ref, t_ref = zoh_reference(servo.A, servo.B, servo.C, D, [0.0, 0.0], reads, writes)
    y = np.array([v for _, v in reads])
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-12)
    # the loop settles near the reference 1 rad, so this is not a trivial comparison
    assert abs(y[-1] - 1.0) < 0.05 and np.ptp(y) > 0.9
    # the final state, after the last interval up to the end of the run
    Ad, Bd, _, _, _ = cont2discrete((servo.A, servo.B, servo.C, D), UNTIL - t_ref, method="zoh")
    x_end = Ad @ x_ref + Bd @ np.array([writes[-1][1]])
    np.testing.assert_allclose(plant.state, x_end, rtol=1e-12, atol=1e-12)


def test_dc_servo_exact_step_agrees_with_rk4_to_its_error():
    _, reads_exact, _ = pid_loop(DCServo(), ExactZOH(), x0=[0.0, 0.0])
    _, reads_rk4, _ = pid_loop(DCServo(), RK4(dt=1e-4), x0=[0.0, 0.0])
    assert [t for t, _ in reads_exact] == [t for t, _ in reads_rk4]
    np.testing.assert_allclose([y for _, y in reads_exact], [y for _, y in reads_rk4], atol=1e-8)


def test_python_control_state_space_equals_the_analytic_zoh_model():
    control = pytest.importorskip("control")
    # third-order, lightly damped, with a direct term: 1000 / ((s + 2) (s^2 + 4 s + 400)) + 0.01
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-800.0, -408.0, -6.0]])
    B = np.array([[0.0], [0.0], [1000.0]])
    C = np.array([[1.0, 0.0, 0.0]])
    D = np.array([[0.01]])
    sys = control.ss(A, B, C, D)
    plant, reads, writes = pid_loop(sys, ExactZOH(), x0=[0.1, 0.0, 0.0], output="y[0]", input="u[0]")
    y_ref, _, _ = zoh_reference(A, B, C, D, [0.1, 0.0, 0.0], reads, writes)
    y = np.array([v for _, v in reads])
    assert np.ptp(y) > 0.1
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-12)


def test_transitions_are_cached_per_interval_length(monkeypatch):
    import scipy.linalg
    calls = []
    real = scipy.linalg.expm

    def counting(M):
        calls.append(M.copy())
        return real(M)
    monkeypatch.setattr(scipy.linalg, "expm", counting)
    zoh = ExactZOH()
    plant, reads, writes = pid_loop(DCServo(), zoh, x0=[0.0, 0.0])
    lengths = sorted(plant._stepper._cache)
    # a periodic loop has a handful of distinct intervals: one exponential each, ever (in this
    # process: another test may already have computed some for the same servo)
    assert len(calls) == zoh.expm_calls and zoh.expm_calls + zoh.shared_hits == len(lengths) <= 6
    advances = zoh.expm_calls + zoh.shared_hits + zoh.cache_hits
    assert advances >= len(reads) + len(writes) and zoh.cache_hits > 0.9 * advances
    # one exponential of the augmented matrix [[A, B], [0, 0]] h
    assert all(M.shape == (3, 3) and not M[2].any() for M in calls)


def test_cache_is_bounded_least_recently_used():
    zoh = ExactZOH(cache_size=2)
    sim = Simulation()
    plant = sim.plant(DCServo(), x0=[0.0, 0.0], integrator=zoh, log="none")
    stepper = plant._stepper
    for ticks in (1, 2, 1, 3, 1, 2):
        stepper.transition(ticks * 10**9)
    # 1 stays (recently used); 2 is evicted by 3, then fetched again (from the process-wide cache)
    assert list(stepper._cache) == [1 * 10**9, 2 * 10**9]
    assert zoh.expm_calls + zoh.shared_hits == 4 and zoh.cache_hits == 2


def test_a_second_simulation_reuses_the_exponentials_of_the_first():
    from netcosim.plant.exact_zoh import _SHARED_TRANSITIONS
    servo = DCServo(k=987.5)  # parameters no other test uses: the process-wide cache is cold
    first, second = ExactZOH(), ExactZOH()
    plant1, reads1, _ = pid_loop(servo, first, x0=[0.0, 0.0])
    assert first.expm_calls == len(plant1._stepper._cache) >= 2 and first.shared_hits == 0
    plant2, reads2, _ = pid_loop(servo, second, x0=[0.0, 0.0])
    assert second.expm_calls == 0 and second.shared_hits == len(plant2._stepper._cache)
    assert reads2 == reads1                     # the same matrices: the same numbers, bit for bit
    assert all(plant2._stepper._cache[k][0] is plant1._stepper._cache[k][0] for k in plant2._stepper._cache)
    assert len(_SHARED_TRANSITIONS) <= netcosim.plant.exact_zoh.SHARED_TRANSITIONS_SIZE == 1024


class DisturbedLinear(ContinuousSystem):
    """DC servo with a torque disturbance: dx/dt = A x + B u + E d (A and B as the servo's)."""

    name = "disturbed"
    state_names = ("angle", "velocity")
    input_names = ("u",)
    output_names = ("y",)
    disturbance_names = ("torque",)

    def __init__(self):
        super().__init__()
        self.A = np.array([[0.0, 1.0], [0.0, -1.0]])
        self.B = np.array([[0.0], [1000.0]])

    def f(self, t, x, u, params):
        return self.A @ x + self.B @ u[:1] + np.array([0.0, 50.0]) * u[1]

    def h(self, t, x, u, params):
        return x[:1]


def test_disturbance_falls_back_and_equals_the_fallback_alone():
    def d(t):
        return [np.sin(40.0 * t)]
    a, reads_a, _ = pid_loop(DisturbedLinear(), ExactZOH(fallback=RK4(dt=1e-4)), x0=[0.0, 0.0], disturbance=d)
    b, reads_b, _ = pid_loop(DisturbedLinear(), RK4(dt=1e-4), x0=[0.0, 0.0], disturbance=d)
    assert isinstance(a._stepper, RK4)
    assert reads_a == reads_b  # bit for bit
    assert a.state.tolist() == b.state.tolist()


def test_disturbance_without_fallback_is_refused():
    with pytest.raises(ConfigurationError, match="plant 'disturbed'.*disturbance.*fallback"):
        Simulation().plant(DisturbedLinear(), x0=[0.0, 0.0], integrator=ExactZOH())


def test_hybrid_events_fall_back():
    class Stop(DCServo):
        events = (HybridEvent("half", lambda t, x, u, p: x[0] - 0.5, direction=1),)
    with pytest.raises(ConfigurationError, match="plant 'servo' has hybrid events \\['half'\\]"):
        Simulation().plant(Stop(), x0=[0.0, 0.0], integrator=ExactZOH())
    a, reads_a, _ = pid_loop(Stop(), ExactZOH(fallback=RK4(dt=1e-4)), x0=[0.0, 0.0])
    b, reads_b, _ = pid_loop(Stop(), RK4(dt=1e-4), x0=[0.0, 0.0])
    assert reads_a == reads_b and a.event_counts == b.event_counts == {"half": 1}


def test_non_lti_plant_is_refused_naming_it():
    pend = ContinuousSystem(f=lambda t, x, u, p: np.array([x[1], -np.sin(x[0]) + u[0]]), states=2, inputs=1,
                            name="pendulum")
    with pytest.raises(ConfigurationTypeError, match="plant 'pendulum'.*A and B"):
        Simulation().plant(pend, x0=[0.0, 0.0], integrator=ExactZOH())
    pend.A, pend.B = np.array([[0.0, 1.0], [-1.0, 0.0]]), np.array([[0.0], [1.0]])  # a linearisation only
    with pytest.raises(ConfigurationError, match="plant 'pendulum'.*f\\(t, x, u\\) = A x \\+ B u"):
        Simulation().plant(pend, x0=[0.0, 0.0], integrator=ExactZOH())


def test_bad_arguments():
    with pytest.raises(ConfigurationTypeError, match="fallback"):
        ExactZOH(fallback="RK4")
    with pytest.raises((ConfigurationError, ConfigurationTypeError), match="cache_size"):
        ExactZOH(cache_size=0)
    with pytest.raises(ConfigurationError, match="bind"):
        ExactZOH().integrate(lambda t, x: x, 0.0, np.zeros(1), 1.0, [])


def test_a_plant_and_its_exact_stepper_form_no_reference_cycle():
    import weakref
    sim = Simulation()
    plant = sim.plant(DCServo(), x0=[0.0, 0.0], integrator=ExactZOH(), log="none")
    stepper = plant._stepper
    assert "bound to plant 'servo'" in repr(stepper)
    # the stepper reaches its plant through a weak reference only
    assert all(v is not plant for v in vars(stepper).values())
    assert isinstance(stepper._plant, weakref.ref) and stepper._plant() is plant
