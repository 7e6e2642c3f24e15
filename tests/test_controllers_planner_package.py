"""The planner package's seams: the vendored DOP853 tableau, the one kinematic model shared
with the plants, and deployments as configuration + task factories
with a typed result (DeploymentConfig, PlannerResponse)."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
from test_controllers_systems import CRANE3_QREF, PlanarCrane

from netcosim import Simulation
from netcosim.controllers.planner import OfflineGain, OnlineGain, configuration_rate, simulate_sampled
from netcosim.controllers.planner import dop853_coefficients as vendored
from netcosim.controllers.planner.deployment import CommandRecord, PlannerRecord, PlannerResponse, PoseRecord
from netcosim.controllers.planner.tasks import DeploymentConfig, KinematicVelocityPlant, PlannerLaw, deploy
from netcosim.plants import kinematic
from netcosim.plants.flycrane.configurations import thesis_flycrane
from netcosim.plants.flycrane.input_modes import KinematicPlant

ROOT = pathlib.Path(__file__).resolve().parents[1]
E3 = np.array([0.1, -0.08, 0.05, 0.04, -0.03, 0.06])


def test_the_dop853_tableau_is_scipys_and_nothing_imports_scipys_private_package():
    from scipy.integrate._ivp import dop853_coefficients as scipy_tableau
    for name in ("A", "B", "C", "E3", "E5", "D", "N_STAGES", "N_STAGES_EXTENDED"):
        assert np.array_equal(getattr(vendored, name), getattr(scipy_tableau, name)), name
    for pkg in ("netcosim", "plants", "controllers", "experiments"):
        for f in (ROOT / pkg).rglob("*.py"):
            assert "integrate._ivp" not in f.read_text(), f


def test_one_plant_and_one_pseudo_inverse_for_plants_and_planners():
    assert KinematicPlant is kinematic.KinematicPlant
    assert issubclass(KinematicVelocityPlant, KinematicPlant)
    s = thesis_flycrane(1.5)
    q = s.q_nominal + 0.05 * np.cos(np.arange(s.m))
    u = np.linspace(-0.2, 0.3, s.n)
    rate = kinematic.configuration_rate(s, q, u)
    # the system's pinv, the planner's rate and both plants give the same numbers (one computation)
    assert np.array_equal(configuration_rate(s, q, u), rate)
    assert np.array_equal(s.configuration_rate(q, u), rate)
    assert np.array_equal(KinematicPlant(s).f(0.0, q, u, None), rate)
    assert np.array_equal(KinematicVelocityPlant(s).f(0.0, q, u, None), rate)
    np.testing.assert_allclose(s.pinv(q) @ u, rate, rtol=0, atol=1e-12)
    # any kinematic system gets the generic plant, with indexed names
    crane = PlanarCrane(3)
    p = KinematicPlant(crane)
    assert p.state_names == tuple(f"q{i}" for i in range(crane.m)) and p.events[0].name == "singular_configuration"
    assert isinstance(s, kinematic.KinematicSystem)


def test_deployment_configuration_is_validated_before_anything_is_built():
    law = PlannerLaw(OfflineGain(1.0), q_ref=CRANE3_QREF)
    with pytest.raises(ValueError, match="architecture must be 'sparse' or 'centralized', got 'star'"):
        DeploymentConfig(0.5, law, architecture="star")
    with pytest.raises(ValueError, match="size_bits must be a positive integer, got 0"):
        DeploymentConfig(0.5, law, size_bits=0)
    with pytest.raises(ValueError, match="watchdog_timeout.*-2"):
        DeploymentConfig(0.5, law, watchdog_timeout=-2)
    with pytest.raises(ValueError, match="centralized"):
        DeploymentConfig(0.5, PlannerLaw(OnlineGain(), q_ref=CRANE3_QREF))
    cfg = DeploymentConfig(0.5, law)
    assert cfg.timeout == 0.5 and DeploymentConfig(0.5, law, watchdog_timeout=1).timeout == 1.0


@pytest.mark.parametrize("arch", ["sparse", "centralized"])
def test_deploy_with_a_configuration_gives_a_typed_response(arch):
    sys_, qr, T, H = PlanarCrane(3), CRANE3_QREF, 0.5, 6
    sim = Simulation(seed=1)
    dep = deploy(sim, sys_, qr + E3, DeploymentConfig(T, PlannerLaw(OfflineGain(1.6), q_ref=qr), architecture=arch))
    sim.run(until=H * T + 1e-9)
    kinds = {type(r) for r in dep.records}
    assert kinds == ({PlannerRecord, CommandRecord} if arch == "centralized" else {PoseRecord, CommandRecord})
    resp = dep.response()
    assert isinstance(resp, PlannerResponse)
    assert resp.q.shape == (H + 1, sys_.m) and resp.u.shape == (H + 1, sys_.n)
    assert np.array_equal(resp.h, np.arange(H + 1)) and np.allclose(resp.t, resp.h * T, rtol=0, atol=1e-12)
    ref = simulate_sampled(sys_, qr + E3, qr, T, OfflineGain(1.6), n_samples=H)
    assert np.max(np.abs(resp.q - ref[[f"q{i}" for i in range(sys_.m)]].values)) < 1e-12
    df = resp.to_pandas()
    assert df.equals(dep.samples()) and list(df.columns[:3]) == ["h", "t", "k"]
    rec = dep.records[-1]
    assert rec["t_done"] == rec.t_done and "u_i" in rec
    ax_q, ax_u = dep.plot()
    assert len(ax_q.lines) == sys_.m and ax_u.get_xlabel() == "t (s)"
    import matplotlib.pyplot as plt
    plt.close("all")
