"""The ch. 2 landing experiment runs end to end (quick mode) and writes its outputs."""

import pandas as pd

from experiments import ch2_landing


def test_ch2_landing_quick(tmp_path):
    metrics = ch2_landing.main(outdir=tmp_path, quick=True)
    for name in ("fig2_8_angles.png", "fig2_9_inputs.png", "fig2_10_constraints.png", "fig2_11_wind_angles.png",
                 "fig2_12_wind_inputs.png", "fig2_13_wind_constraints.png", "schedule_2lc.png",
                 "scheduled_landing.png", "signals.parquet", "nmpc_steps.parquet", "jobs.parquet",
                 "metrics.parquet"):
        assert (tmp_path / name).stat().st_size > 1000, name
    saved = pd.read_parquet(tmp_path / "metrics.parquet").set_index("run")
    assert set(saved.index) == set(metrics.index)
    w = saved.loc["ideal_2lc_wind"]
    assert w["rms_ratio_2lc_over_nmpc"] < 1.0
    assert w["wind_deviation_ratio"] < 0.5
    assert (saved["n_fallback"] == 0).all()
    # the scheduled runs replay the recorded solve times, job by job: what they charged is
    # the head of the recording, whatever this host's speed or load
    charged = pd.read_parquet(tmp_path / "cpu_times.parquet")
    recorded = pd.read_csv(ch2_landing.CALIBRATION)
    assert set(charged["run"]) == {"NMPC alone", "2LC (NMPC from reference)"}
    for (run, phase), got in charged.groupby(["run", "phase"]):
        want = recorded[(recorded["run"] == run) & (recorded["phase"] == phase)].sort_values("index")
        assert len(got) >= 90  # one job per 10 ms over 1 s, less the last ones still queued
        assert got.sort_values("index")["cpu"].tolist() == want["cpu"].tolist()[:len(got)]
        assert got["wall"].isna().all()  # no clock was read
    assert saved.loc["scheduled_2LC (NMPC from reference)", "nmpc_response_max"] > 0
    sig = pd.read_parquet(tmp_path / "signals.parquet")
    assert {"run", "controller", "time", "phi", "theta", "f_R", "tau_R", "f_L", "d_PG1", "d_PG2"} <= set(sig.columns)
