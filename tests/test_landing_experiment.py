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
    # Fig. 2.11 (1 s runs): the thesis's scheme has 3.37 times NMPC alone's wind-induced
    # deviation (not reproduced, docs/nmpc.md); the former default 0.72, the reference start < 0.1
    assert saved.loc["ideal_2lc_wind", "wind_deviation_ratio"] == pytest.approx(3.37, abs=0.05)
    assert saved.loc["ideal_2lcformer_wind", "wind_deviation_ratio"] == pytest.approx(0.722, abs=0.02)
    assert saved.loc["ideal_2lcref_wind", "wind_deviation_ratio"] < 0.1
    assert saved.loc["ideal_2lc_wind", "rms_ratio_2lc_over_nmpc"] == pytest.approx(1.0, abs=1e-3)
    assert (saved["n_fallback"] == 0).all()
    # the scheduled runs replay the recorded solve times, job by job: what they charged is
    # the head of the recording, whatever this host's speed or load
    charged = pd.read_parquet(tmp_path / "cpu_times.parquet")
    recorded = pd.read_csv(ch2_landing.CALIBRATION)
    former = "2LC former default (plan, -60 rad/s)"
    assert set(charged["run"]) == {"NMPC alone", "2LC (NMPC from measurement)", "2LC (NMPC from reference)", former}
    for (run, phase), got in charged.groupby(["run", "phase"]):
        source = "2LC (NMPC from measurement)" if run == former else run  # it replays the thesis's recording
        want = recorded[(recorded["run"] == source) & (recorded["phase"] == phase)].sort_values("index")
        assert len(got) >= 90  # one job per 10 ms over 1 s, less the last ones still queued
        assert got.sort_values("index")["cpu"].tolist() == want["cpu"].tolist()[:len(got)]
        assert got["wall"].isna().all()  # no clock was read
    assert saved.loc["scheduled_2LC (NMPC from reference)", "nmpc_response_max"] > 0
    sig = pd.read_parquet(tmp_path / "signals.parquet")
    assert {"run", "controller", "time", "phi", "theta", "f_R", "tau_R", "f_L", "d_PG1", "d_PG2"} <= set(sig.columns)


def test_ch2_delay_sweep_thesis_scheme_against_the_former_default(quick):
    tmp_path, metrics = quick
    sweep = pd.read_parquet(tmp_path / "delay_sweep.parquet").set_index(["delay", "scheme", "wind"])
    # delay 0 reuses the ideal runs: the same numbers as the metrics table
    assert sweep.loc[(0.0, "thesis", True), "wind_deviation"] == metrics.loc["ideal_2lc_wind", "wind_deviation"]
    assert sweep.loc[(0.0, "thesis", False), "d_PG_min"] == pytest.approx(1.5e-3, abs=0.2e-3)
    # 2 ms of NMPC time: the thesis's scheme (poles -120 rad/s) still lands clear of the
    # slope; the former default (plan, -60 rad/s) puts the propellers 43 mm into it
    assert sweep.loc[(0.002, "thesis", False), "d_PG_min"] == pytest.approx(1.4e-3, abs=0.2e-3)
    assert sweep.loc[(0.002, "former_default", False), "d_PG_min"] == pytest.approx(-0.043, abs=1e-3)
    # and under the recorded solve times, from two offsets into the recording
    band = pd.read_parquet(tmp_path / "solve_time_band.parquet")
    th = band[band["scheme"] == "thesis"]
    assert len(th) == 2 and (th["d_PG_min"] > 1.3e-3).all() and (th["f_L_max"] < 9.0).all()


@pytest.mark.slow
def test_ch2_delay_sweep_full_grid():
    """The delay table of docs/nmpc.md (0, 0.1, 0.5, 1, 2 ms, 1.5 s runs): the thesis's
    scheme keeps the propellers above the slope at every delay, calm and under wind;
    the former default is more than 1.5 cm into it from 1 ms on; NMPC alone keeps 6 mm."""
    sweep = ch2_landing.delay_sweep(schemes=("thesis", "former_default", "nmpc")).set_index(
        ["delay", "scheme", "wind"])
    for delay in ch2_landing.DELAYS:
        for wind in (False, True):
            assert sweep.loc[(delay, "thesis", wind), "d_PG_min"] > 0.9e-3
            assert sweep.loc[(delay, "nmpc", wind), "d_PG_min"] > 6e-3
    for delay in (0.001, 0.002):
        for wind in (False, True):
            assert sweep.loc[(delay, "former_default", wind), "d_PG_min"] < -0.015
    assert sweep.loc[(0.001, "former_default", False), "d_PG_min"] == pytest.approx(-0.0432, abs=1e-3)
