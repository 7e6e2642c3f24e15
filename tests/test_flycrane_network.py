"""The networked Fly-crane (thesis §4.6.1, appendix A): the planners on five nodes over
802.11b with loss (:mod:`controllers.planner.networked`, :mod:`experiments.flycrane_network`)."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.planner import OfflineGain, OnlineGain, WeightedNorm
from controllers.planner.tasks import DeploymentConfig, PlannerLaw, VelocityTrackingModel, deploy
from experiments.ch4_fig4_8_9 import KBAR, T, WEIGHTS, setting
from experiments.ch4_fig4_10 import simulate_dynamic
from netcosim import Simulation
from plants.flycrane.input_modes import VelocityTrackingPlant


@pytest.mark.parametrize("architecture, gain", [("centralized", OnlineGain()), ("sparse", OfflineGain(0.2163))])
def test_ideal_network_dynamic_plant_equals_fig4_10_simulation(architecture, gain):
    """Zero delays and execution times: the deployment on the dynamic plant (alpha = 3 N s/m)
    gives the samples of experiments.ch4_fig4_10.simulate_dynamic (same LSODA settings;
    the deployment integrates over [hT, (h+1)T] in absolute time, the reference over
    [0, T]: the only difference is the rounding of t, measured below 1e-10)."""
    sys_, q_ref, q0s = setting()
    q0, nrm, n = q0s["q2"], WeightedNorm(WEIGHTS, 2), 6
    ref = simulate_dynamic(sys_, VelocityTrackingPlant(sys_, 3.0), q0, q_ref, gain, nrm, n)
    sim = Simulation(0)
    cfg = DeploymentConfig(T, PlannerLaw(gain, q_ref=q_ref, kbar=KBAR, norm=nrm), architecture=architecture,
                           plant=VelocityTrackingModel(3.0))
    dep = deploy(sim, sys_, q0, cfg)
    sim.run(n * T + 1e-6)
    r = dep.response()
    assert len(r.t) == n + 1
    np.testing.assert_allclose(nrm.many(r.q - q_ref), ref.err.to_numpy(), rtol=0, atol=1e-9)
    assert ref.err.iloc[-1] < 0.1 * ref.err.iloc[0]          # the samples do move
    if architecture == "centralized":
        np.testing.assert_allclose(r.k[:n], ref.k.to_numpy()[:n], rtol=1e-9)
