"""The landing scenario as configuration: validation, wiring per topology, result object."""

import dataclasses
import math

import matplotlib
import numpy as np
import pandas as pd
import pytest

from netcosim.controllers.landing import (
    DEFAULT_FL_GAINS,
    SIM_PARAMS,
    LandingConfig,
    LandingScenario,
    LandingTiming,
    run_landing,
    simulate_landing,
)
from netcosim.controllers.landing.scenario import TOPOLOGIES
from netcosim.controllers.landing.topology import WIRINGS

matplotlib.use("Agg")


@pytest.mark.parametrize("kw, message", [
    (dict(controller="pid"), "controller must be 'nmpc' or '2lc', got 'pid'"),
    (dict(topology="star"), "topology must be 'single' or 'two_nodes', got 'star'"),
    (dict(controller="nmpc", topology="two_nodes"),
     "the two-node variant needs the two-layer controller, got controller='nmpc'"),
    (dict(nmpc_init="zero"), "nmpc_init must be 'measured' or 'reference', got 'zero'"),
    (dict(actuator_state="guess"), "actuator_state must be 'plan' or 'measured', got 'guess'"),
    (dict(duration=-1.0), "duration must be a positive number of seconds, got -1.0"),
    (dict(duration=math.inf), "duration must be a positive number of seconds, got inf"),
    (dict(ref_knots=0), "ref_knots must be an integer between 1 and N, got 0"),
    (dict(ref_knots=31), "ref_knots must be an integer between 1 and N, got 31"),
    (dict(ref_knots=True), "ref_knots must be an integer between 1 and N, got True"),
    (dict(ff_lead=0.02), "ff_lead must be a number of seconds in \\[0, nmpc_period\\], got 0.02"),
    (dict(nmpc_period=0.02), "nmpc_period=0.02 s must equal the shooting interval Ts=0.01 s"),
])
def test_scenario_and_run_landing_reject_the_same_values_with_the_same_message(kw, message):
    with pytest.raises(ValueError, match=f"^{message}$"):
        LandingScenario(**kw)
    with pytest.raises(ValueError, match=f"^{message}$"):
        run_landing(**kw)


def test_the_first_bad_value_in_check_order_is_reported():
    # topology is checked before the controller, as run_landing always did
    with pytest.raises(ValueError, match="two-node variant"):
        LandingScenario(controller="pid", topology="two_nodes")
    with pytest.raises(ValueError, match="^nmpc_init"):
        LandingScenario(nmpc_init="zero", controller="pid")


def test_scenario_fills_in_the_defaults():
    sc = LandingScenario()
    assert sc.params is SIM_PARAMS and sc.fl_gains is DEFAULT_FL_GAINS
    assert sc.config == LandingConfig() and sc.timing == LandingTiming() and sc.nmpc_kw == {}
    assert sc.ff_lead is None and sc.feedforward_lead == pytest.approx(0.001)  # half the 2 ms period
    assert dataclasses.replace(sc, fl_period=0.004).feedforward_lead == pytest.approx(0.002)
    assert LandingScenario(ff_lead=0.0).feedforward_lead == 0.0
    np.testing.assert_array_equal(sc.x0, np.zeros(4))
    assert sc.plant_inputs == "forces" and LandingScenario(controller="nmpc").plant_inputs == "rates"
    xs0 = LandingScenario(x0=[0.1, 0.2, -0.1, 0.3]).initial_state()
    assert xs0.shape == (6,) and xs0[[0, 1, 2, 3]].tolist() == [0.1, 0.2, -0.1, 0.3]
    assert xs0[4] > 0 and xs0[5] == 0.0  # hover thrust, zero torque
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.duration = 2.0
    assert dataclasses.replace(sc, duration=0.5).duration == 0.5


def test_one_wiring_function_per_topology():
    assert set(WIRINGS) == set(TOPOLOGIES) == {"single", "two_nodes"}


def test_run_landing_is_simulate_landing_of_its_scenario():
    kw = dict(duration=0.1, timing=LandingTiming(nmpc_exec=0.002, fl_exec=1e-4))
    a = run_landing("2lc", **kw)
    b = simulate_landing(LandingScenario(controller="2lc", **kw))
    assert isinstance(a.scenario, LandingScenario) and a.scenario.duration == 0.1
    for name in ("signals", "reference", "jobs"):
        pd.testing.assert_frame_equal(getattr(a, name), getattr(b, name))
    pd.testing.assert_frame_equal(a.steps.drop(columns=["t_feedback", "t_prepare"]),
                                  b.steps.drop(columns=["t_feedback", "t_prepare"]))
    assert a.meta["params"] is SIM_PARAMS and a.meta["topology"] == "single"


def test_tasks_per_topology():
    single = run_landing("2lc", duration=0.05)
    assert set(single.jobs["task"].astype(str)) == {"nmpc", "fl"}
    nmpc = run_landing("nmpc", duration=0.05)
    assert set(nmpc.jobs["task"].astype(str)) == {"nmpc"} and nmpc.reference.empty and nmpc.fl is None
    two = run_landing("2lc", duration=0.05, topology="two_nodes")
    by_node = two.jobs.groupby(two.jobs["node"].astype(str))["task"].agg(lambda t: set(t.astype(str)))
    assert by_node.to_dict() == {"onboard": {"sensor", "fl"}, "ground": {"nmpc"}}


def test_to_pandas_is_one_tidy_row_per_logged_instant():
    run = run_landing("nmpc", wind=True, duration=0.05)
    df = run.to_pandas()
    assert list(df.columns[:3]) == ["controller", "wind_on", "time"]
    assert len(df) == len(run.signals) and (df["controller"] == "nmpc").all() and df["wind_on"].all()
    pd.testing.assert_frame_equal(df.drop(columns=["controller", "wind_on"]), run.signals)
    assert "controller" not in run.signals  # the run's own table is left alone


def test_plot_draws_the_four_angles_in_degrees_and_the_targets():
    import matplotlib.pyplot as plt
    run = run_landing("2lc", wind=True, duration=0.05)
    axes = run.plot()
    try:
        assert axes.shape == (2, 2)
        line = axes[0, 0].get_lines()[0]
        np.testing.assert_allclose(line.get_ydata(), np.degrees(run.signals["phi"]))
        targets = [ln.get_ydata()[0] for ln in axes[0, 0].get_lines()[1:]]
        assert targets == pytest.approx([-30.0])  # φ* = -α
        assert len(axes[0, 0].figure.axes) == 5  # the wind force on a second axis
        again = run.plot(axes, label="again", targets=False, wind=False)
        assert again is not None and len(axes[1, 1].get_lines()) == 2
    finally:
        plt.close("all")


def test_every_function_of_the_landing_package_and_the_nmpc_is_below_complexity_10():
    radon = pytest.importorskip("radon.complexity")
    from pathlib import Path

    import netcosim.controllers.landing as pkg
    import netcosim.controllers.nmpc as nmpc
    worst = {}
    for path in [*Path(pkg.__file__).parent.glob("*.py"), *Path(nmpc.__file__).parent.glob("*.py")]:
        for block in radon.cc_visit(path.read_text()):
            worst[f"{path.name}:{block.fullname}"] = block.complexity
    too_complex = {k: v for k, v in worst.items() if v >= 10}
    assert not too_complex
