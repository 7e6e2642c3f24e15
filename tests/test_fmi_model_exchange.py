"""Model-exchange FMUs (FMI 2.0 and 3.0) as plants: the DC servo FMU against the Python
DC servo under one schedule, the bouncing ball's state events at the analytic instants,
units and start values from modelDescription.xml, parameters per run, and bad FMUs.

The FMUs are compiled from ``netcosim/fmi/csrc/`` by the ``fmu_builder`` fixture (conftest.py).
"""

import math
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError, FMUError
from netcosim.plant import RK4, SolveIVP
from netcosim.plants.dc_servo import DCServo

fmi = pytest.importorskip("netcosim.fmi")


def servo_loop(system, x0, integrator, until=0.5):
    """The servo under a PD controller on a node: period 10 ms, 2 ms of CPU per job, the
    input written at the end of each job.  Returns the read outputs and the plant."""
    sim = Simulation(seed=1)
    plant = sim.plant(system, x0, name="servo", integrator=integrator)
    reads = []

    def body(ctx):
        y = float(plant.output("y").read())
        reads.append((ctx.now, y))
        yield ctx.execute(0.002)
        plant.input("u").write(float(0.02 * (1.0 - y) - 0.0005 * plant.state[1]))
    sim.node("cpu").periodic(body, period=0.01, name="ctl", priority=1)
    sim.run(until)
    return np.array(reads), plant, sim


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("integrator", [lambda: SolveIVP(rtol=1e-9, atol=1e-12), lambda: RK4(dt=1e-3)],
                         ids=["solve_ivp", "rk4"])
def test_dc_servo_fmu_follows_the_python_plant(fmu_builder, version, integrator):
    servo = fmi.ModelExchangeFMU(fmu_builder("servo", version))
    got, p_fmu, sim_fmu = servo_loop(servo, servo.x0, integrator())
    want, p_py, sim_py = servo_loop(DCServo(), [0.0, 0.0], integrator())
    assert got.shape == want.shape == (50, 2)
    np.testing.assert_array_equal(got[:, 0], want[:, 0])
    assert np.max(np.abs(got[:, 1] - want[:, 1])) <= 1e-8
    assert want[:, 1].max() > 0.9          # the loop does move the servo towards its set point (1 rad)
    sig_fmu, sig_py = sim_fmu.trace.signals(), sim_py.trace.signals()
    y_fmu = sig_fmu[sig_fmu["signal"] == "y.y"]["value"].to_numpy()
    y_py = sig_py[sig_py["signal"] == "y.y"]["value"].to_numpy()
    assert len(y_fmu) == len(y_py) > 100
    assert np.max(np.abs(y_fmu - y_py)) <= 1e-8


@pytest.mark.parametrize("version", [2, 3])
def test_open_loop_step_matches_the_analytic_response(fmu_builder, version):
    # u = 1 V from t = 0: angle(t) = k (t - (1 - e^{-a t}) / a) / a
    servo = fmi.ModelExchangeFMU(fmu_builder("servo", version), parameters={"k": 500.0, "a": 2.0})
    sim = Simulation()
    plant = sim.plant(servo, servo.x0, integrator=SolveIVP(rtol=1e-11, atol=1e-12))
    plant.input("u").write(1.0)
    for t in (0.1, 0.5, 1.0):
        sim.run(t)
        want = 500.0 * (t - (1 - math.exp(-2.0 * t)) / 2.0) / 2.0
        assert float(plant.output("y").read()) == pytest.approx(want, rel=1e-8)


@pytest.mark.parametrize("version", [2, 3])
def test_bouncing_ball_hits_the_analytic_instants(fmu_builder, version):
    ball = fmi.ModelExchangeFMU(fmu_builder("ball", version))
    assert [e.name for e in ball.events][0] == ("z0" if version == 2 else "z.h")
    sim = Simulation()
    plant = sim.plant(ball, ball.x0, integrator=SolveIVP(rtol=1e-10, atol=1e-12))
    sim.run(2.0)
    g, e, h0 = 9.81, 0.7, 1.0
    v = math.sqrt(2 * g * h0)
    want = [math.sqrt(2 * h0 / g)]
    while True:                       # each flight after a bounce lasts 2 e v / g
        v *= e
        if want[-1] + 2 * v / g > 2.0:
            break
        want.append(want[-1] + 2 * v / g)
    got = [t for t, name in plant.event_log]
    assert len(got) == len(want) == 4
    np.testing.assert_allclose(got, want, atol=1e-9, rtol=0)
    # after the 4th bounce the ball rises with e^4 of the first impact speed
    assert plant.state[1] == pytest.approx(math.sqrt(2 * g * h0) * e ** 4 - g * (2.0 - want[-1]), abs=1e-7)


@pytest.mark.parametrize("version", [2, 3])
def test_units_start_values_and_parameters_come_from_the_description(fmu_builder, version):
    servo = fmi.ModelExchangeFMU(fmu_builder("servo", version), parameters={"k": 250.0})
    assert servo.state_names == ("angle", "velocity")
    assert servo.input_names == ("u",) and servo.output_names == ("y",)
    assert servo.units == {"angle": "rad", "velocity": "rad/s", "u": "V", "y": "rad"}
    assert servo.signals["angle"].start == 0.0 and servo.signals["u"].causality == "input"
    assert servo.parameters["k"] == 250.0 and servo.parameters["a"] == 1.0
    # the overridden gain is the one the FMU integrates: the same as DCServo(k=250)
    got, _, _ = servo_loop(servo, servo.x0, SolveIVP(rtol=1e-9, atol=1e-12), until=0.2)
    want, _, _ = servo_loop(DCServo(k=250.0), [0.0, 0.0], SolveIVP(rtol=1e-9, atol=1e-12), until=0.2)
    assert np.max(np.abs(got[:, 1] - want[:, 1])) <= 1e-8
    assert want[-1, 1] > 0.01


def test_importing_netcosim_does_not_import_fmpy():
    code = "import sys, netcosim, netcosim.fmi; print('fmpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


# Bad FMUs ------------------------------------------------------------------------------

def test_a_missing_fmu_is_named(tmp_path):
    pytest.importorskip("fmpy")
    path = tmp_path / "nowhere.fmu"
    with pytest.raises(FMUError, match=r"FMU '.*nowhere\.fmu': no such file"):
        fmi.ModelExchangeFMU(path)


def test_a_file_that_is_not_an_fmu_is_named(tmp_path):
    pytest.importorskip("fmpy")
    path = tmp_path / "text.fmu"
    path.write_text("not a zip")
    with pytest.raises(FMUError, match=r"text\.fmu'.*not an FMU"):
        fmi.ModelExchangeFMU(path)


def test_a_wrong_fmi_version_is_named(fmu_builder):
    path = fmu_builder("servo", 2, fmi_version="1.0", name="servo_v1")
    with pytest.raises(FMUError, match=r"servo_v1\.fmu'.*FMI version '1\.0' is not supported"):
        fmi.ModelExchangeFMU(path)


def test_an_unknown_variable_is_named_with_the_close_names(fmu_builder):
    path = fmu_builder("servo", 3)
    with pytest.raises(ConfigurationError, match=r"servo3\.fmu'.*unknown output variable 'angel'.*'angle'"):
        fmi.ModelExchangeFMU(path, outputs=["angel"])
    with pytest.raises(ConfigurationError, match=r"unknown parameter variable 'K'.*'k'"):
        fmi.ModelExchangeFMU(path, parameters={"K": 3.0})
    with pytest.raises(ConfigurationError, match=r"outputs must be a sequence of FMI names, got the string 'y'"):
        fmi.ModelExchangeFMU(path, outputs="y")


def test_an_fmu_without_the_interface_is_named(fmu_builder, tmp_path):
    src = fmu_builder("servo", 2)
    path = tmp_path / "cs_only.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(path, "w") as zout:
        for item in zin.namelist():
            data = zin.read(item)
            if item == "modelDescription.xml":
                data = data.replace(b'<ModelExchange modelIdentifier="servo2"/>', b"")
            zout.writestr(item, data)
    with pytest.raises(FMUError, match=r"cs_only\.fmu'.*has no model exchange interface \(it offers co-simulation\)"):
        fmi.ModelExchangeFMU(path)


@pytest.mark.parametrize("version", [2, 3])
def test_a_failed_instantiation_is_named(fmu_builder, version):
    path = fmu_builder("servo", version, guid="{another-guid}", name=f"servo_guid{version}")
    with pytest.raises(FMUError, match=rf"servo_guid{version}\.fmu'.*instantiation failed"):
        fmi.ModelExchangeFMU(path)


@pytest.mark.parametrize("version", [2, 3])
def test_an_error_status_mid_run_names_the_fmu_and_keeps_the_partial_trace(fmu_builder, version):
    servo = fmi.ModelExchangeFMU(fmu_builder("servo", version), parameters={"fail_at": 0.2005})
    sim = Simulation()
    plant = sim.plant(servo, servo.x0, integrator=RK4(dt=1e-3), log_interval=0.01)
    plant.input("u").write(1.0)
    # the FMU fails from t = 0.2005 s on: in the RK4 step from 0.2 s, at its midpoint stage
    with pytest.raises(FMUError, match=rf"servo{version}\.fmu'.*derivatives of \['angle', 'velocity'\] failed "
                                       r"at t=0\.2005 s"):
        sim.run(0.5)
    assert isinstance(sim.failure, FMUError) and plant.failure is sim.failure
    sig = sim.trace.signals()
    angle = sig[sig["signal"] == "x.angle"]
    assert angle["time"].max() == pytest.approx(0.2, abs=1e-12) and len(angle) == 21  # the grid up to the failure
    # up to the failure the state is the analytic step response, 1000 (t - 1 + e^-t)
    t = angle["time"].to_numpy()
    np.testing.assert_allclose(angle["value"].to_numpy(), 1000 * (t - 1 + np.exp(-t)), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("integrator", [lambda: SolveIVP(rtol=1e-10, atol=1e-12), lambda: RK4(dt=3e-3)],
                         ids=["solve_ivp", "rk4"])
def test_a_time_event_switches_the_slope_at_the_announced_instant(fmu_builder, version, integrator):
    # x' = +1 until T = 0.37 s (the FMU's nextEventTime), then -1: x(t) = 2 T - t after T
    ramp = fmi.ModelExchangeFMU(fmu_builder("ramp", version), parameters={"T": 0.37})
    assert [e.name for e in ramp.events] == ["time_event"] and ramp.next_event_time == 0.37
    sim = Simulation()
    plant = sim.plant(ramp, ramp.x0, integrator=integrator())
    sim.run(0.2)
    assert float(plant.output("y").read()) == pytest.approx(0.2, abs=1e-12)
    sim.run(1.0)
    assert plant.event_log == [(pytest.approx(0.37, abs=1e-12), "time_event")]
    assert float(plant.output("y").read()) == pytest.approx(2 * 0.37 - 1.0, abs=1e-9)
    assert ramp.next_event_time is None          # no further time event after the switch


@pytest.mark.parametrize("kind, value, expected", [
    ("Integer", 2.5, "takes a whole number, got 2.5"),
    ("Integer", "3", "takes a whole number, got '3'"),
    ("Integer", float("nan"), "takes a whole number, got nan"),
    ("Integer", True, "takes a whole number, got True"),
    ("Boolean", "no", r"takes True or False \(or 1, 0\), got 'no'"),
    ("Boolean", 2, r"takes True or False \(or 1, 0\), got 2"),
])
def test_integer_and_boolean_values_are_checked_before_they_are_set(fmu_builder, kind, value, expected):
    # the demo FMUs have only real variables: the parameter k is declared Integer or Boolean here,
    # so the check runs where it would for such a variable (nothing reaches the FMU)
    import dataclasses

    from netcosim.fmi.description import FMUFile
    file = FMUFile(fmu_builder("servo", 2), kind="model exchange")
    file.variables["k"] = dataclasses.replace(file.variables["k"], type=kind)
    with pytest.raises(ConfigurationError, match=f"parameter 'k' .*{expected}"):
        file.set_values({"k": value})
