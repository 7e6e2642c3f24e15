"""python-control systems as plants, checked against python-control's own simulators.

A netcosim periodic task samples the plant output and writes a piecewise-constant input
(zero-order hold).  The references chain python-control responses interval by interval
with that input held constant, so both sides simulate exactly the same signal.
"""

from __future__ import annotations

import numpy as np
import pytest

from netcosim import Simulation, SolveIVP
from netcosim.errors import ConfigurationError

control = pytest.importorskip("control")

H = 0.01  # s, sampling period
N = 60    # samples compared


def closed_loop(system, x0, *, params=None, gain=0.02):
    """Run *system* under ``u_k = gain * (1 - y_k)`` sampled every H; return (y_k, u_k)."""
    sim = Simulation()
    kw = {} if params is None else {"params": params}
    plant = sim.plant(system, x0=x0, integrator=SolveIVP(method="DOP853", rtol=1e-12, atol=1e-14),
                      log="none", **kw)
    y_port, u_port = plant.output("y[0]"), plant.input("u[0]")
    ys, us = [], []

    def body(ctx):
        y = ctx.read(y_port)
        u = gain * (1.0 - y)
        ctx.write(u_port, u)
        ys.append(y)
        us.append(u)
        yield ctx.execute(0.0)
    sim.node("ctrl").periodic(body, period=H, priority=1, name="p")
    sim.run(until=(N - 0.5) * H)
    assert len(ys) == N
    return plant, np.array(ys), np.array(us)


def forced_chain(ss, us, x0):
    """y_k of *ss* under ZOH input u_k: one ``forced_response`` per sampling interval."""
    x = np.asarray(x0, dtype=float)
    ys = []
    for u in us:
        r = control.forced_response(ss, timepts=[0.0, H], inputs=[[u, u]], initial_state=x,
                                    return_states=True)
        ys.append(r.outputs[0])
        x = r.states[:, -1]
    return np.array(ys)


def servo_ss():
    return control.ss([[0.0, 1.0], [0.0, -1.0]], [[0.0], [1000.0]], [[1.0, 0.0]], [[0.0]], name="servo")


def test_state_space_servo_matches_forced_response():
    ss = servo_ss()
    plant, ys, us = closed_loop(ss, [0.1, 0.0])
    assert plant.name == "servo"
    assert plant.system.state_names == ("x[0]", "x[1]")
    ref = forced_chain(ss, us, [0.1, 0.0])
    assert np.max(np.abs(ys)) > 0.5  # the loop really moves the servo
    np.testing.assert_allclose(ys, ref, rtol=1e-8, atol=1e-8 * np.max(np.abs(ref)))


def test_transfer_function_matches_forced_response():
    tf = control.tf([1000.0], [1.0, 1.0, 0.0], name="servo_tf")  # k / (s (s + a))
    plant, ys, us = closed_loop(tf, [0.0, 0.0])
    assert plant.name == "servo_tf"
    ref = forced_chain(control.ss(tf), us, [0.0, 0.0])
    assert np.max(np.abs(ys)) > 0.5
    np.testing.assert_allclose(ys, ref, rtol=1e-8, atol=1e-8 * np.max(np.abs(ref)))


def pendulum_update(t, x, u, params):
    g, length, b = params["g"], params["l"], params["b"]
    return [x[1], -g / length * np.sin(x[0]) - b * x[1] + u[0]]


def pendulum():
    return control.nlsys(pendulum_update, lambda t, x, u, p: x[:1], states=["theta", "omega"],
                         inputs=["u[0]"], outputs=["y[0]"], params={"g": 9.81, "l": 1.0, "b": 0.5},
                         name="pendulum")


def test_nonlinear_pendulum_matches_input_output_response_with_updated_params():
    sys = pendulum()
    params = {"b": 2.0}  # updates the system's defaults, as in python-control
    plant, ys, us = closed_loop(sys, [2.5, 0.0], params=params, gain=5.0)
    assert plant.system.state_names == ("theta", "omega")
    x = np.array([2.5, 0.0])
    ref = []
    for u in us:
        r = control.input_output_response(sys, timepts=[0.0, H], inputs=u, initial_state=x, params=params,
                                          return_states=True, solve_ivp_method="DOP853",
                                          solve_ivp_kwargs={"rtol": 1e-12, "atol": 1e-14})
        ref.append(r.outputs[0])
        x = r.states[:, -1]
    ref = np.array(ref)
    assert np.ptp(ys) > 1.0  # a large swing: the nonlinearity matters
    np.testing.assert_allclose(ys, ref, rtol=1e-8, atol=1e-8 * np.max(np.abs(ref)))
    # and the updated damping really applies: with the default b the trajectory differs
    _, ys_default, _ = closed_loop(pendulum(), [2.5, 0.0], gain=5.0)
    assert np.max(np.abs(ys_default - ys)) > 0.1


def test_discrete_time_system_is_refused_naming_its_dt():
    sim = Simulation()
    with pytest.raises(ConfigurationError, match=r"'servo_d' is discrete-time \(dt=0\.1\)"):
        sim.plant(control.ss(control.c2d(servo_ss(), 0.1), name="servo_d"), x0=[0.0, 0.0])
