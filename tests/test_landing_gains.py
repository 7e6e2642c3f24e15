"""The low-level loop of the 2LC as the thesis's scheme needs it (issue 27, ch. 2).

The numbers below were measured with the recorded NMPC solve times
(``experiments/data/ch2_nmpc_cpu_times.csv``) replayed from 10 offsets into the
recording (0, 15, ..., 135 jobs; ``solve_time_band.parquet`` of ``python -m
netcosim.experiments.ch2_landing``; docs/nmpc.md, "Low-level gains"):

* thesis's scheme (x₀ = the whole measured state, poles at -120 rad/s): min d_PG
  1.406 – 1.453 mm, peak f_L 8.960 – 8.992 N, settled at 0.465 s in every replay;
* former default (f_R, τ_R from the plan, poles at -60 rad/s): min d_PG -69.4 to
  -18.3 mm, peak f_L 10.58 – 14.80 N, one replay of 10 ends singular ((2.16)).

Tolerances are the spread over those replays (not one run's digits).
"""

from __future__ import annotations

import numpy as np
import pytest

from netcosim.controllers.landing import (
    DEFAULT_FL_GAINS,
    DEFAULT_FL_POLE,
    SCHEMES,
    SIM_PARAMS,
    SLOW_FL_GAINS,
    LandingConfig,
    LandingScenario,
    PIDGains,
    landing_metrics,
)
from netcosim.experiments._ch2_sweeps import OFFSETS, THESIS_RECORDING, recorded_timing, run_scheme, solve_time_band

#: (min, max) over the 10 replays, thesis's scheme: d_PG_min [m], f_L_max [N]
THESIS_D_PG = (1.406e-3, 1.453e-3)
THESIS_F_L = (8.960, 8.992)
#: and the former default's
FORMER_D_PG = (-69.4e-3, -18.3e-3)
FORMER_F_L = (10.58, 14.80)


def _spread(band):
    return band[1] - band[0]


def test_default_pole_sits_between_the_nmpc_period_and_the_500hz_sampling():
    Ts, T = LandingConfig().Ts, 0.002
    w = DEFAULT_FL_POLE
    assert w == 120.0 and 1.0 / w < Ts and w * T <= 0.3  # faster than 100 Hz, within the 500 Hz emulation
    assert (DEFAULT_FL_GAINS.kp, DEFAULT_FL_GAINS.kd, DEFAULT_FL_GAINS.ki) == (43200.0, 360.0, 1728000.0)
    assert SLOW_FL_GAINS == PIDGains.triple_pole(60.0) and 1.0 / 60.0 > Ts  # the former gains: slower than Ts
    # the discrete closed loop of the controller's PID (forward-Euler integral, held input)
    # on the double integrator (2.15): poles at z = 0.55, 0.78, 0.86 (docstring)
    kp, kd, ki = DEFAULT_FL_GAINS.kp, DEFAULT_FL_GAINS.kd, DEFAULT_FL_GAINS.ki
    A = np.array([[1.0, T, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    B = np.array([T * T / 2, T, 0.0])
    Acl = A - np.outer(B, [kp + ki * T, kd, ki])
    Acl[2] = [T, 0.0, 1.0]
    assert sorted(np.abs(np.linalg.eigvals(Acl))) == pytest.approx([0.5457, 0.7781, 0.8629], abs=1e-4)


def test_the_defaults_are_the_thesis_scheme():
    sc = LandingScenario()
    assert (sc.nmpc_init, sc.actuator_state, sc.fl_gains) == ("measured", "measured", DEFAULT_FL_GAINS)
    assert SCHEMES["thesis"] == {}
    assert SCHEMES["former_default"] == {"actuator_state": "plan", "fl_gains": SLOW_FL_GAINS}


def test_thesis_scheme_under_the_recorded_solve_times_keeps_d_PG_and_f_L_within_bounds():
    """§2.6.2 with the NMPC computed on line: the recorded solve times (feedback median
    ≈ 2 ms, max 4.7 ms; preparation max 8.0 ms) replayed job by job on one node."""
    m = landing_metrics(run_scheme("thesis", duration=1.5, timing=recorded_timing(THESIS_RECORDING)))
    tol_d, tol_f = _spread(THESIS_D_PG), _spread(THESIS_F_L)
    assert THESIS_D_PG[0] - tol_d <= m["d_PG_min"] <= THESIS_D_PG[1] + tol_d
    assert THESIS_F_L[0] - tol_f <= m["f_L_max"] <= THESIS_F_L[1] + tol_f
    # the margins: propellers above the slope by > 1.3 mm, cable 1 N under f_L,max
    assert m["d_PG_min"] >= 1.3e-3 and m["f_L_max"] <= SIM_PARAMS.f_L_max - 1.0
    assert m["t_settle"] == pytest.approx(0.465, abs=0.005) and m["n_fallback"] == 0


def test_former_default_under_the_recorded_solve_times_hits_the_slope():
    m = landing_metrics(run_scheme("former_default", duration=1.5, timing=recorded_timing(THESIS_RECORDING)))
    assert FORMER_D_PG[0] <= m["d_PG_min"] <= FORMER_D_PG[1]  # offset 0: -56.1 mm
    assert m["d_PG_min"] == pytest.approx(-56.1e-3, abs=0.5e-3)
    assert m["f_L_max"] == pytest.approx(14.60, abs=0.05) and m["f_L_max"] > SIM_PARAMS.f_L_max


def test_recorded_timing_offset_rotates_the_recording():
    t0, t5 = recorded_timing(THESIS_RECORDING), recorded_timing(THESIS_RECORDING, offset=5)
    a, b = t0.nmpc_exec.values["feedback"], t5.nmpc_exec.values["feedback"]
    assert b == a[5:] + a[:5] and len(a) == 150
    with pytest.raises(ValueError, match="offset must be a non-negative integer"):
        recorded_timing(THESIS_RECORDING, offset=-1)


@pytest.mark.slow
def test_every_replay_offset_keeps_the_thesis_scheme_clear_and_the_former_default_does_not():
    band = solve_time_band(offsets=OFFSETS)
    th = band[band["scheme"] == "thesis"]
    assert len(th) == 10 and (th["failed"] == "").all()
    assert th["d_PG_min"].min() == pytest.approx(THESIS_D_PG[0], abs=1e-5)
    assert th["f_L_max"].max() == pytest.approx(THESIS_F_L[1], abs=1e-3)
    fo = band[(band["scheme"] == "former_default") & (band["failed"] == "")]
    assert len(fo) == 9 and (fo["d_PG_min"] < -0.015).all() and (fo["f_L_max"] > SIM_PARAMS.f_L_max).all()


@pytest.mark.slow
def test_delay_table_of_docs_nmpc():
    """docs/nmpc.md, the delay table: the thesis's scheme keeps d_PG ≈ 1.4 mm from 0 to
    2 ms; the former default is 43 mm into the slope from 1 ms on."""
    from netcosim.experiments._ch2_sweeps import delay_sweep
    sw = delay_sweep(schemes=("thesis", "former_default", "plan")).set_index(["delay", "scheme", "wind"])
    for d in (0.0, 0.0001, 0.0005, 0.001, 0.002):
        assert 1.3e-3 <= sw.loc[(d, "thesis", False), "d_PG_min"] <= 1.6e-3
        assert sw.loc[(d, "thesis", False), "f_L_max"] < 9.0
    assert sw.loc[(0.001, "former_default", False), "d_PG_min"] == pytest.approx(-43.2e-3, abs=1e-3)
