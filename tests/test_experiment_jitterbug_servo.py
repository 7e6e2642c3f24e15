"""The Jitterbug servo example (netcosim.experiments.jitterbug_servo): its curves and figure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netcosim.experiments import jitterbug_servo as jb


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("jitterbug_servo")
    return out, jb.main(str(out), quick=True)


def test_it_writes_the_figure_and_the_tables(run):
    out, tables = run
    assert (out / "jitterbug_servo.png").stat().st_size > 10_000
    assert (out / "delay.parquet").exists() and (out / "period.parquet").exists()
    assert list(tables["delay"]["tau_s"]) == pytest.approx([0.0, 0.002, 0.004, 0.006, 0.008])


def test_the_curves(run):
    _, t = run
    d, p = t["delay"], t["period"]
    # no delay: the random and constant models coincide; a longer delay costs more;
    # a random delay uniform on [0, tau] costs less than the constant delay tau
    assert d["uniform_delay_up_to_tau"].iloc[0] == pytest.approx(d["constant_delay"].iloc[0], rel=1e-9)
    assert np.all(np.diff(d["constant_delay"]) > 0)
    assert np.all(d["uniform_delay_up_to_tau"].iloc[1:] < d["constant_delay"].iloc[1:])
    # the value of tests/test_lq_jitterbug.py's closed form at tau = 4 ms (same setup)
    assert d["constant_delay"].iloc[2] == pytest.approx(12.5115295812, rel=1e-9)
    # a longer period costs more, until the loop goes unstable (inf), sooner with a delay
    assert np.all(np.diff(p["no_delay"][np.isfinite(p["no_delay"])]) > 0)
    assert math.isinf(p["no_delay"].iloc[-1]) and math.isinf(p["delay_h_over_2"].iloc[2])
    assert np.all(p["delay_h_over_2"] >= p["no_delay"])
