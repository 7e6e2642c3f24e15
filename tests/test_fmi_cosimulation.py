"""Co-simulation FMUs (FMI 2.0 and 3.0) as plants stepped by doStep to the exact instants
the simulation needs: the DC servo FMU against the Python servo under one schedule, rejected
(FMI 2) and partial (FMI 3) steps, the default logging grid, and failures.

The test FMU integrates with RK4 sub-steps of at most 1 ms inside each doStep (netcosim/fmi/csrc/):
its step error on the servo is below 1e-12 rad over these runs, so the co-simulation
trajectory must match the exact zero-order-hold solution of the Python plant to 1e-8.
"""

import numpy as np
import pytest

from netcosim import Simulation
from netcosim.errors import ConfigurationError, FMUError
from netcosim.plant import ExactZOH, SolveIVP
from netcosim.plants.dc_servo import DCServo

fmi = pytest.importorskip("netcosim.fmi")


def servo_loop(system, x0, integrator=None, until=0.5):
    """P control on a node (period 10 ms, 2 ms of CPU, the input written at the end of the
    job); returns the outputs read by the task and the logged output trajectory."""
    sim = Simulation(seed=1)
    plant = sim.plant(system, x0, name="servo", integrator=integrator)
    reads = []

    def body(ctx):
        y = float(plant.output("y").read())
        reads.append((ctx.now, y))
        yield ctx.execute(0.002)
        plant.input("u").write(float(0.02 * (1.0 - y)))
    sim.node("cpu").periodic(body, period=0.01, name="ctl", priority=1)
    sim.run(until)
    sig = sim.trace.signals()
    y = sig[sig["signal"] == "y.y"]
    return np.array(reads), y["time"].to_numpy(), y["value"].to_numpy()


@pytest.mark.parametrize("version", [2, 3])
def test_dc_servo_cosimulation_follows_the_python_plant(fmu_builder, version):
    servo = fmi.CoSimulationFMU(fmu_builder("servo", version))
    got, t_got, y_got = servo_loop(servo, servo.x0)
    want, t_want, y_want = servo_loop(DCServo(), [0.0, 0.0], ExactZOH())
    assert got.shape == want.shape == (50, 2)
    assert np.max(np.abs(got[:, 1] - want[:, 1])) <= 1e-8
    assert want[:, 1].max() > 0.9
    np.testing.assert_array_equal(t_got, t_want)
    assert np.max(np.abs(y_got - y_want)) <= 1e-8
    # one doStep per read and per write: from each release to the write 2 ms later, then on
    assert servo.steps == 100 and servo.rejected == 0 and servo.partial == 0
    assert servo.units == {"u": "V", "y": "rad"}


def test_rejected_steps_are_retried_from_the_restored_state(fmu_builder):
    # the FMI 2 servo rejects steps longer than 3 ms (fmi2Discard, nothing computed): the
    # 8 ms step from each write to the next release is rejected, then 4 ms, and taken in 2 ms steps
    servo = fmi.CoSimulationFMU(fmu_builder("servo", 2), parameters={"max_step": 0.003})
    got, _, y_got = servo_loop(servo, servo.x0)
    want, _, y_want = servo_loop(DCServo(), [0.0, 0.0], ExactZOH())
    assert np.max(np.abs(got[:, 1] - want[:, 1])) <= 1e-8
    assert servo.rejected == 100          # two rejections per period
    assert servo.steps == 50 * (1 + 4)    # 2 ms to the write, four 2 ms steps to the next release


def test_partial_steps_continue_from_the_last_successful_time(fmu_builder):
    # the FMI 3 servo returns early after 3 ms: the 8 ms advance takes 3 + 3 + 2 ms
    servo = fmi.CoSimulationFMU(fmu_builder("servo", 3), parameters={"max_step": 0.003})
    got, _, _ = servo_loop(servo, servo.x0)
    want, _, _ = servo_loop(DCServo(), [0.0, 0.0], ExactZOH())
    assert np.max(np.abs(got[:, 1] - want[:, 1])) <= 1e-8
    assert servo.partial == 100 and servo.rejected == 0 and servo.steps == 200


@pytest.mark.parametrize("version", [2, 3])
def test_an_untouched_plant_is_logged_on_the_default_grid(fmu_builder, version):
    # no task: the FMU steps to each 1 ms grid instant; u = 0.5 V held from the start
    servo = fmi.CoSimulationFMU(fmu_builder("servo", version), parameters={"k": 200.0})
    sim = Simulation()
    sim.plant(servo, servo.x0)
    sim.run(0.01)
    assert servo.steps == 10
    servo2 = fmi.CoSimulationFMU(fmu_builder("servo", version), parameters={"k": 200.0})
    sim2 = Simulation()
    plant = sim2.plant(servo2, servo2.x0)
    plant.input("u").write(0.5)
    sim2.run(0.3)
    t = 0.3
    assert float(plant.output("y").read()) == pytest.approx(100.0 * (t - 1 + np.exp(-t)), rel=1e-10)


def test_min_step_holds_the_outputs_of_short_advances(fmu_builder):
    servo = fmi.CoSimulationFMU(fmu_builder("servo", 3), min_step=0.005)
    sim = Simulation()
    plant = sim.plant(servo, servo.x0, log="none")
    plant.input("u").write(1.0)
    sim.run(0.003)
    assert float(plant.output("y").read()) == 0.0 and servo.time == 0.0     # 3 ms < min_step: not stepped
    sim.run(0.006)
    t = 0.006
    assert float(plant.output("y").read()) == pytest.approx(1000 * (t - 1 + np.exp(-t)), rel=1e-10)
    assert servo.steps == 1


def test_a_cosimulation_fmu_refuses_an_integrator(fmu_builder):
    servo = fmi.CoSimulationFMU(fmu_builder("servo", 2))
    sim = Simulation()
    sim.plant(servo, servo.x0, integrator=SolveIVP())
    with pytest.raises(ConfigurationError, match="advances by doStep, not by an integrator"):
        sim.run(0.01)


@pytest.mark.parametrize("version", [2, 3])
def test_an_error_status_in_dostep_names_the_fmu_and_keeps_the_partial_trace(fmu_builder, version):
    servo = fmi.CoSimulationFMU(fmu_builder("servo", version), parameters={"fail_at": 0.05})
    sim = Simulation()
    plant = sim.plant(servo, servo.x0, log_interval=0.01)
    plant.input("u").write(1.0)
    with pytest.raises(FMUError, match=rf"servo{version}\.fmu'.*doStep from t=0\.05 s by 0\.0099+\d* s failed "
                                       r"\(inputs \['u'\], outputs \['y'\]\)"):
        sim.run(0.2)
    sig = sim.trace.signals()
    y = sig[sig["signal"] == "y.y"]
    np.testing.assert_allclose(y["time"], [0.0, 0.01, 0.02, 0.03, 0.04, 0.05], atol=1e-12)
    t = y["time"].to_numpy()
    np.testing.assert_allclose(y["value"], 1000 * (t - 1 + np.exp(-t)), rtol=1e-10, atol=1e-12)


def test_a_rejected_step_without_state_restore_is_an_error(fmu_builder, tmp_path):
    import zipfile
    src = fmu_builder("servo", 2)
    path = tmp_path / "norestore.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(path, "w") as zout:
        for item in zin.namelist():
            data = zin.read(item)
            if item == "modelDescription.xml":
                data = data.replace(b'canGetAndSetFMUstate="true"', b'canGetAndSetFMUstate="false"')
            zout.writestr(item, data)
    servo = fmi.CoSimulationFMU(path, parameters={"max_step": 0.001})
    sim = Simulation()
    sim.plant(servo, servo.x0, log="none")
    with pytest.raises(FMUError, match=r"norestore\.fmu'.*rejected and the FMU cannot restore its state"):
        sim.run(0.01)
