"""RK4 bound to a plant: the same steps as ``RK4.integrate`` on Python floats.

The reference is the unbound ``RK4.integrate`` (NumPy arrays per stage), reached
through a subclass that overrides ``integrate`` (``RK4.bind`` then leaves it unbound):
the bound stepper must give the very same bits, and one analytic case checks both
against the exact solution.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from netcosim import RK4, ContinuousSystem, Simulation
from netcosim.controllers.pid import PID
from netcosim.errors import ConfigurationError, IntegrationError
from netcosim.plant.rk4 import _RK4Stepper


class ArrayRK4(RK4):
    """RK4 integrated with NumPy arrays per stage (an override keeps ``bind`` from binding it)."""

    def integrate(self, rhs, t0, x0, t1, gs):
        return super().integrate(rhs, t0, x0, t1, gs)


def pendulum(**kw):
    # damped pendulum: x = (angle rad, rate rad/s), u = torque, d = a disturbance torque
    return ContinuousSystem(f=lambda t, x, u, p: np.array([x[1], -9.81 * np.sin(x[0]) - 0.3 * x[1] + u.sum()]),
                            h=lambda t, x, u, p: x[:1], states=2, inputs=1, outputs=1, name="pendulum", **kw)


def pid_loop(system, integrator, until=0.5, **plant_kw):
    """A 5 ms PID task on *system*; returns the plant and the angles it read."""
    sim = Simulation(seed=1)
    plant = sim.plant(system, x0=[0.3, 0.0], integrator=integrator, **plant_kw)
    cpu = sim.node("cpu", context_switch=10e-6)
    pid = PID(h=0.005, K=2.0, Ti=0.5, Td=0.05)
    reads = []

    @cpu.periodic(period=0.005, priority=1)
    def control(ctx):
        y = ctx.read(plant.output(0))
        reads.append(y)
        yield ctx.execute(0.0013)
        ctx.write(plant.input(0), pid.compute(0.0, y))

    sim.run(until=until)
    return plant, reads


def test_a_plain_rk4_is_bound_and_steps_the_same_bits_as_the_array_step():
    a, reads_a = pid_loop(pendulum(), RK4(dt=1e-3))
    b, reads_b = pid_loop(pendulum(), ArrayRK4(dt=1e-3))
    assert type(a._stepper) is _RK4Stepper and b._stepper is b.integrator
    assert len(reads_a) == 100
    assert reads_a == reads_b  # bit for bit, every sample
    assert a.state.tolist() == b.state.tolist()


def test_with_a_disturbance_the_input_is_built_per_stage_and_the_bits_agree():
    def d(t):
        return [0.5 * math.sin(40.0 * t)]
    a, reads_a = pid_loop(pendulum(disturbances=1), RK4(dt=1e-3), disturbance=d)
    b, reads_b = pid_loop(pendulum(disturbances=1), ArrayRK4(dt=1e-3), disturbance=d)
    c, reads_c = pid_loop(pendulum(disturbances=1), RK4(dt=1e-3))  # d = 0
    assert reads_a == reads_b and reads_a != reads_c


def test_an_exponential_decay_matches_the_exact_solution_to_rk4_accuracy():
    sim = Simulation()
    plant = sim.plant(ContinuousSystem(f=lambda t, x, u, p: -2.0 * x, states=1), x0=[1.0], integrator=RK4(dt=0.01))
    sim.run(until=1.0)
    # RK4's error per unit time is O(dt^4): (2 * 0.01)^4 / 120 * 2 s ~ 3e-9
    assert plant.state[0] == pytest.approx(math.exp(-2.0), rel=1e-8, abs=0)
    assert plant.state[0] != math.exp(-2.0)


def test_f_receives_one_preallocated_state_array_and_the_held_input_object():
    seen_x, seen_u = set(), set()

    def f(t, x, u, p):
        seen_x.add(id(x))
        seen_u.add(id(u))
        assert type(x) is np.ndarray and x.shape == (2,)
        return np.array([x[1], -x[0] + u[0]])
    sim = Simulation()
    plant = sim.plant(ContinuousSystem(f=f, states=2, inputs=1), x0=[1.0, 0.0], integrator=RK4(dt=1e-3))
    sim.run(until=0.1)  # 100 steps, 400 evaluations
    assert seen_x == {id(plant._stepper._x)}
    assert seen_u == {id(plant.u)}


def test_a_scalar_derivative_of_a_one_state_plant_and_a_list_are_accepted():
    for f in (lambda t, x, u, p: -float(x[0]), lambda t, x, u, p: [-x[0]]):
        sim = Simulation()
        plant = sim.plant(ContinuousSystem(f=f, states=1), x0=[1.0], integrator=RK4(dt=0.01))
        sim.run(until=1.0)
        assert plant.state[0] == pytest.approx(math.exp(-1.0), rel=1e-9)


def test_a_derivative_of_the_wrong_length_is_refused_naming_the_plant():
    sim = Simulation()
    sim.plant(ContinuousSystem(f=lambda t, x, u, p: np.zeros(3), states=2), x0=[0.0, 0.0], name="bad",
              integrator=RK4(dt=0.01))
    with pytest.raises(ConfigurationError, match=r"plant 'bad': f returned 3 values .* has 2 states"):
        sim.run(until=0.1)


def test_a_non_finite_derivative_names_the_state_as_the_array_step_does():
    def f(t, x, u, p):
        return np.array([1.0, math.inf if t > 0.05 else 0.0])
    messages = []
    for integ in (RK4(dt=0.01), ArrayRK4(dt=0.01)):
        sim = Simulation()
        sim.plant(ContinuousSystem(f=f, states=("a", "b")), x0=[0.0, 0.0], name="p",
                  integrator=integ)
        with pytest.raises(IntegrationError, match=r"plant 'p': derivative of \['b'\] is non-finite") as info:
            sim.run(until=0.1)
        messages.append(str(info.value))
    assert messages[0] == messages[1]


def test_large_plants_and_overriding_subclasses_stay_unbound():
    big = ContinuousSystem(f=lambda t, x, u, p: -x, states=RK4.FLOAT_STEP_MAX_STATES + 1)
    small = ContinuousSystem(f=lambda t, x, u, p: -x, states=RK4.FLOAT_STEP_MAX_STATES)
    sim = Simulation()
    p_big = sim.plant(big, x0=np.ones(big.nx), integrator=RK4(dt=0.01), name="big")
    p_small = sim.plant(small, x0=np.ones(small.nx), integrator=RK4(dt=0.01), name="small")
    p_sub = sim.plant(small, x0=np.ones(small.nx), integrator=ArrayRK4(dt=0.01), name="sub")
    assert p_big._stepper is p_big.integrator and p_sub._stepper is p_sub.integrator
    assert isinstance(p_small._stepper, _RK4Stepper)
    sim.run(until=0.5)
    assert p_small.state.tolist() == p_sub.state.tolist() == [p_big.state[0]] * small.nx


def test_the_stepper_reaches_its_plant_through_a_weak_reference():
    import weakref
    sim = Simulation()
    plant = sim.plant(pendulum(), x0=[0.0, 0.0], integrator=RK4(dt=1e-3), log="none")
    stepper = plant._stepper
    assert repr(stepper) == "RK4(dt=0.001) bound to plant 'pendulum'"
    assert all(v is not plant for v in vars(stepper).values())
    assert isinstance(stepper._plant, weakref.ref) and stepper._plant() is plant
