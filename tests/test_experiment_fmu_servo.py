"""The example ``fmu_servo``: the DC servo as model-exchange and co-simulation FMUs (FMI 2 and
3) through the networked loop of ``networked_servo`` gives the Python servo's output; the
tethered UAV as a CasADi-generated model-exchange FMU gives the Python UAV's in the 2LC landing."""

import pandas as pd
import pytest


def test_fmu_servo_quick_matches_the_python_plant(fmu_builder, tmp_path):
    fmu_builder("servo", 2)          # skips without FMPy or gcc
    from netcosim.experiments.fmu_servo import main
    table = main(str(tmp_path), quick=True).set_index("plant")
    assert list(table.index) == ["python", "me2", "me3", "cs2", "cs3"]
    assert (table["samples"] == 500).all()
    # the same RK4 on the same derivatives: the model-exchange FMUs give the very same numbers
    assert table.loc["me2", "max_diff_from_python"] <= 1e-12
    assert table.loc["me3", "max_diff_from_python"] <= 1e-12
    # the co-simulation FMUs integrate inside (RK4, 1 ms sub-steps): within their step error
    assert 0 < table.loc["cs2", "max_diff_from_python"] <= 1e-9
    assert table.loc["cs3", "max_diff_from_python"] <= 1e-9
    assert table["cost"].to_numpy() == pytest.approx(table.loc["python", "cost"], rel=1e-9)
    assert table.loc["python", "cost"] > 0.01          # the first step of the reference costs
    assert (tmp_path / "fmu_servo.png").stat().st_size > 10_000
    assert (tmp_path / "summary.parquet").exists()
    uav = pd.read_parquet(tmp_path / "uav_summary.parquet").set_index("plant")
    assert list(uav.index) == ["python", "me2", "me3"]
    assert (uav["samples"] == 600).all()
    assert (uav["max_diff_from_python"] <= 1e-8).all()      # observed 8.9e-16 (f_L), the rest equal
    # wind pulse end, wind sine start, touchdown on the landers: the same instants
    assert (uav["events"] == uav.loc["python", "events"]).all()
    assert uav.loc["python", "events"].startswith("0.050000, 0.100000, 0.47")
    assert (tmp_path / "fmu_uav.png").stat().st_size > 10_000
