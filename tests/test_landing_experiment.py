"""The ch. 2 landing experiment runs end to end (quick mode) and writes its outputs."""

import pandas as pd
import pytest

from netcosim.experiments import ch2_landing


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("ch2")
    return out, ch2_landing.main(outdir=out, quick=True)


def test_ch2_landing_quick(quick):
    tmp_path, metrics = quick
    for name in ("fig2_8_angles.png", "fig2_9_inputs.png", "fig2_10_constraints.png", "fig2_11_wind_angles.png",
                 "fig2_12_wind_inputs.png", "fig2_13_wind_constraints.png", "schedule_2lc.png",
                 "scheduled_landing.png", "delay_sweep.png", "fig2_5_sigmoid.png", "signals.parquet",
                 "nmpc_steps.parquet", "jobs.parquet", "metrics.parquet", "delay_sweep.parquet"):
        assert (tmp_path / name).stat().st_size > 1000, name
    # the host's wall-clock times are kept apart from what the run reproduces
    steps = pd.read_parquet(tmp_path / "nmpc_steps.parquet")
    wall = pd.read_parquet(tmp_path / "nmpc_wall_clock.parquet")
    assert not {"t_feedback", "t_prepare"} & set(steps.columns) and {"c_feedback", "c_prepare"} <= set(steps.columns)
    assert list(wall.columns) == ["run", "time", "t_feedback", "t_prepare"] and len(wall) == len(steps)
    saved = pd.read_parquet(tmp_path / "metrics.parquet").set_index("run")
    assert set(saved.index) == set(metrics.index)
    # Fig. 2.11 with the thesis's scheme (1 s runs): the 2LC reduces the wind-induced
    # deviation to 0.72 of NMPC alone's; the reference-start variant to 0.014
    assert saved.loc["ideal_2lc_wind", "wind_deviation_ratio"] == pytest.approx(0.722, abs=0.02)
    assert saved.loc["ideal_2lcref_wind", "wind_deviation_ratio"] < 0.05
    assert saved.loc["ideal_2lc_wind", "rms_ratio_2lc_over_nmpc"] == pytest.approx(1.0, abs=1e-3)
    assert (saved["n_fallback"] == 0).all()
    # the scheduled runs replay the recorded solve times, job by job: what they charged is
    # the head of the recording, whatever this host's speed or load
    charged = pd.read_parquet(tmp_path / "cpu_times.parquet")
    recorded = pd.read_csv(ch2_landing.CALIBRATION)
    assert set(charged["run"]) == {"NMPC alone", "2LC (NMPC from measurement)", "2LC (NMPC from reference)"}
    for (run, phase), got in charged.groupby(["run", "phase"]):
        want = recorded[(recorded["run"] == run) & (recorded["phase"] == phase)].sort_values("index")
        assert len(got) >= 90  # one job per 10 ms over 1 s, less the last ones still queued
        assert got.sort_values("index")["cpu"].tolist() == want["cpu"].tolist()[:len(got)]
        assert got["wall"].isna().all()  # no clock was read
    assert saved.loc["scheduled_2LC (NMPC from reference)", "nmpc_response_max"] > 0
    sig = pd.read_parquet(tmp_path / "signals.parquet")
    assert {"run", "controller", "time", "phi", "theta", "f_R", "tau_R", "f_L", "d_PG1", "d_PG2"} <= set(sig.columns)


def test_ch2_delay_sweep_shows_where_the_reference_start_pays_off(quick):
    tmp_path, metrics = quick
    sweep = pd.read_parquet(tmp_path / "delay_sweep.parquet").set_index(["delay", "scheme", "wind"])
    # delay 0 reuses the ideal runs: the same numbers as the metrics table
    assert sweep.loc[(0.0, "measured", True), "wind_deviation"] == metrics.loc["ideal_2lc_wind", "wind_deviation"]
    assert sweep.loc[(0.0, "measured", False), "d_PG_min"] == pytest.approx(1.7e-3, abs=0.2e-3)
    # 5 ms of NMPC time (the thesis's bound on its solve time, §2.6.2): the thesis's
    # scheme puts the propellers 16 mm into the slope, the reference start still lands
    assert sweep.loc[(0.005, "measured", False), "d_PG_min"] == pytest.approx(-0.0158, abs=1e-3)
    assert sweep.loc[(0.005, "reference", False), "d_PG_min"] == pytest.approx(0.7e-3, abs=0.2e-3)
    assert sweep.loc[(0.005, "reference", False), "t_settle"] < 0.5


@pytest.mark.slow
def test_ch2_delay_sweep_full_grid():
    """The delay figure's grid (0, 1, 2, 5 ms, 1.5 s runs): from 1 ms on the thesis's
    scheme puts the propellers more than 1.5 cm into the slope; the reference start and
    NMPC alone keep them above it at every delay."""
    sweep = ch2_landing.delay_sweep().set_index(["delay", "scheme", "wind"])
    for delay in (0.001, 0.002, 0.005):
        for wind in (False, True):
            assert sweep.loc[(delay, "measured", wind), "d_PG_min"] < -0.015
            assert sweep.loc[(delay, "reference", wind), "d_PG_min"] > 0.5e-3
            assert sweep.loc[(delay, "nmpc", wind), "d_PG_min"] > 6e-3
    assert sweep.loc[(0.001, "measured", False), "d_PG_min"] == pytest.approx(-0.0432, abs=1e-3)
    assert sweep.loc[(0.0, "measured", False), "d_PG_min"] == pytest.approx(1.7e-3, abs=0.2e-3)
