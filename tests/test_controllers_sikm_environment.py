"""The realistic environment of thesis Fig. 5.6: dynamic Fly-crane, velocity-tracking robots,
noisy MoCap, UKF (netcosim.controllers.planner.sikm_environment)."""

from __future__ import annotations

import numpy as np
import pytest

from netcosim.controllers.planner.sikm import SIKMParams, simulate_tracking
from netcosim.controllers.planner.sikm_environment import RealisticEnvironment
from netcosim.errors import ConfigurationError
from netcosim.experiments.ch5_fig5_8_9 import E0, reference
from netcosim.plants.flycrane.configurations import thesis_flycrane

Q = [f"q{i}" for i in range(9)]
QHAT = [f"qhat{i}" for i in range(9)]


@pytest.fixture(scope="module")
def setting():
    sys_ = thesis_flycrane(cable_length=1.5)
    tr = reference(sys_)
    return sys_, tr, tr(0.0)[0] + E0


def test_stiff_velocity_tracking_without_noise_reproduces_the_kinematic_model(setting):
    # alpha -> inf: q_dot -> A_q^{-1} u (Sec. 4.3), so the dynamic environment tends to the
    # kinematic simulation of the same law (5.15); the residual is the robots' lag 1.03/alpha s
    # and the 120 Hz hold of u.
    sys_, tr, q0 = setting
    _, kin = simulate_tracking(sys_, tr, q0, 0.75, 3.0, 2, k_off=1.0, n_dense=90)
    gaps = {}
    for alpha in (30.0, 300.0):
        env = RealisticEnvironment(alpha=alpha, noise_std=0.0, use_filter=False)
        _, dyn = env.track(sys_, tr, q0, 0.75, 3.0, 2, k_off=1.0, n_dense=90)
        assert np.allclose(dyn.t.values, kin.t.values, atol=1e-12)
        gaps[alpha] = float(np.abs(dyn.err.values - kin.err.values).max())
    assert gaps[300.0] < 5e-4 < gaps[30.0] < 2.5e-3      # against ||e(0)|| = 0.05
    assert gaps[300.0] < gaps[30.0] / 4


def test_noise_std_is_the_per_coordinate_mocap_deviation_and_the_ukf_reduces_it(setting):
    sys_, tr, q0 = setting
    spread = {}
    for use_filter in (False, True):
        env = RealisticEnvironment(noise_std=0.01, use_filter=use_filter)
        _, d = env.track(sys_, tr, q0, 0.75, 3.0, 2, k_off=1.0, n_dense=90, seed=3)
        d = d[d.t > 0]
        spread[use_filter] = float((d[QHAT].values - d[Q].values).std())
    assert spread[False] == pytest.approx(0.01, rel=0.05)   # raw MoCap: sigma on every coordinate
    assert spread[True] < 0.4 * spread[False]              # the UKF's estimate the controller reads


def test_same_seed_same_run_bit_for_bit(setting):
    sys_, tr, q0 = setting
    env = RealisticEnvironment()
    a = env.track(sys_, tr, q0, 0.75, 1.5, 1, seed=7)[1]
    b = env.track(sys_, tr, q0, 0.75, 1.5, 1, seed=7)[1]
    c = env.track(sys_, tr, q0, 0.75, 1.5, 1, seed=8)[1]
    assert a.equals(b) and not a.equals(c)


def test_bad_settings_are_named(setting):
    sys_, tr, q0 = setting
    with pytest.raises(ConfigurationError, match="alpha"):
        RealisticEnvironment(alpha=0.0)
    with pytest.raises(ConfigurationError, match="noise_std"):
        RealisticEnvironment(noise_std=-0.01)
    with pytest.raises(ConfigurationError, match="mocap_rate"):
        RealisticEnvironment(mocap_rate=float("nan"))
    env = RealisticEnvironment()
    with pytest.raises(ConfigurationError, match=r"T=0\.701 s is not a multiple"):
        env.track(sys_, tr, q0, 0.701, 1.5, 1)
    with pytest.raises(ValueError, match="outside the stability set"):
        env.track(sys_, tr, q0, 4.0, 8.0, 2, k_off=0.25, params=SIKMParams(0.02, 0.13, 0.1, 0.2))
    with pytest.raises(ValueError, match="needs k_off"):
        env.track(sys_, tr, q0, 0.75, 1.5, 2)
    with pytest.raises(ConfigurationError, match="errors.*'estimate'"):
        env.interval_samples(sys_, tr, [(1.0, 0.75)], [0.0], 0.05, errors="estimate")
