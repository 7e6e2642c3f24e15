"""The compiled DOP853 of the dynamic Fly-crane (controllers/planner/plant_dop853.py):
SciPy's DOP853 to rounding, one compiled call per step, the grid from the dense output,
LSODA where the compiled step cannot go, and the former LSODA within the tolerance."""

import math

import numpy as np
import pytest

from netcosim import Simulation
from netcosim.controllers.planner import networked as nw
from netcosim.controllers.planner.plant_dop853 import CompiledDOP853
from netcosim.controllers.planner.plant_models import VelocityTrackingModel
from netcosim.errors import ConfigurationError
from netcosim.plant import SolveIVP
from netcosim.plants.flycrane import SingularConfigurationError


def _plant(sim, method="dop853", u=0.05, x0=None, **kw):
    sys_, q0, _ = nw.setting(nw.FlyCraneNetworkConfig())
    model = VelocityTrackingModel(30.0, method=method, **kw)
    plant = model.build(sys_, "p")
    x0 = plant.initial_state(q0) if x0 is None else x0
    inst = sim.plant(plant, x0, name="p", integrator=model.integrator(), log="none")
    inst.u[:] = u * np.cos(np.arange(sys_.n))
    return inst


def test_an_advance_equals_scipys_dop853_to_rounding_with_one_call_per_step():
    """0.5 s of the loaded crane from rest under u_j = 0.05 cos(j) m/s: the compiled
    stepper and ``solve_ivp(method="DOP853")`` with the same tolerances on the plant's own
    right-hand side agree to 1e-12 (the same steps; only the rounding of the stages differs);
    12 stage evaluations per step attempt plus 2 to start, as SciPy counts them."""
    sim = Simulation(0)
    p = _plant(sim)
    st = p._stepper
    assert type(st).__name__ == "_BoundDOP853"
    t1, x1, j = st.integrate(p._rhs, 0.0, p.x, 0.5, [])
    ref = SolveIVP("DOP853", 1e-8, 1e-10)
    calls = []
    rhs = lambda t, x: calls.append(t) or p._rhs(t, x)  # noqa: E731
    t1r, x1r, _ = ref.integrate(rhs, 0.0, p.x, 0.5, [])
    assert (t1, j, t1r) == (0.5, None, 0.5)
    assert np.abs(x1 - x1r).max() < 1e-12
    assert np.abs(x1 - p.x).max() > 1e-3          # it moved
    assert st.nfev == len(calls) and st.fallbacks == 0
    assert (st.nfev - 2) % 12 == 0


def test_grid_instants_come_from_the_dense_output_within_the_tolerance():
    """GridRecorder on the compiled stepper: q every 0.1 s over 1 s, equal to SciPy
    DOP853's dense output (t_eval) to 1e-12 and to LSODA's to 1e-8 (rtol 1e-8 of q ~ 1)."""
    rows = {}
    for method in ("dop853", "lsoda"):
        sim = Simulation(0)
        cfg = nw.FlyCraneNetworkConfig(seed=0, horizon=1.0)
        model = VelocityTrackingModel(cfg.alpha, method=method)
        sys_, q0, _ = nw.setting(cfg)
        rec = nw.GridRecorder(model.integrator(), 0.1, sys_.m)
        plant = sim.plant(model.build(sys_, "p"), model.initial_state(model.build(sys_, "p"), q0), name="p",
                          integrator=rec, log="none")
        plant.u[:] = 0.05
        rec.start(plant)
        for k in range(1, 4):
            plant.advance(0.33 * k)
        plant.advance(1.0)
        rows[method] = rec.arrays()
    t, q, _ = rows["dop853"]
    assert np.allclose(t, np.arange(11) * 0.1, atol=1e-12)
    assert np.abs(q - rows["lsoda"][1]).max() < 1e-8
    assert np.abs(q[-1] - q[0]).max() > 1e-3


def test_a_singular_start_is_named_by_the_plant():
    """Euler gimbal lock (platform pitch 90 deg, M singular): the compiled stages report a
    QR pivot ratio below PIVOT_RTOL, LSODA redoes the advance through the plant's checked
    right-hand side, which names q at the first evaluation."""
    sys_, _, _ = nw.setting(nw.FlyCraneNetworkConfig())
    q = sys_.q_from([55] * 4, [0, 0, 0.4, 0, 90, 0])
    sim = Simulation(0)
    p = _plant(sim, x0=np.concatenate([q, np.zeros(sys_.m)]))
    named = r"dynamics not defined at q = \[0\.959931088597, 0\.959931088597, .*0\.4, 0\.0, 1\.570796326795, 0\.0\]"
    with pytest.raises(SingularConfigurationError, match=named):
        p.advance(0.1)
    assert p._stepper.fallbacks == 1


def test_lsoda_where_asked_and_where_the_compiled_step_does_not_apply():
    """``method="lsoda"``, the cable-slack event and the uncompensated dynamics integrate
    with LSODA; the compiled stepper falls back to SolveIVP's DOP853 for a plant with events."""
    assert VelocityTrackingModel(method="lsoda").integrator().method == "LSODA"
    assert VelocityTrackingModel(cable_slack_event=True).integrator().method == "LSODA"
    assert VelocityTrackingModel(gravity_compensation=False).integrator().method == "LSODA"
    assert isinstance(VelocityTrackingModel().integrator(), CompiledDOP853)
    sim = Simulation(0)
    sys_, q0, _ = nw.setting(nw.FlyCraneNetworkConfig())
    model = VelocityTrackingModel(cable_slack_event=True)
    plant = model.build(sys_, "p")
    inst = sim.plant(plant, plant.initial_state(q0), name="p", integrator=CompiledDOP853(), log="none")
    assert isinstance(inst._stepper, SolveIVP) and inst._stepper.method == "DOP853"
    with pytest.raises(ConfigurationError, match="method must be 'dop853' or 'lsoda'"):
        VelocityTrackingModel(method="rk4")
    with pytest.raises(ConfigurationError, match="rtol must be at least"):
        CompiledDOP853(rtol=1e-20)


def test_networked_runs_keep_their_frames_and_schedules_and_q_within_the_tolerance():
    """The 5-node scenario (30 % loss, 8 s): the frame, network-schedule, kernel-schedule
    and job tables are those of the former LSODA run bit for bit (they do not depend on
    the plant state), and q on the 0.1 s grid within 1e-8 of it (measured 3e-9 over 30 s)."""
    cfg = nw.FlyCraneNetworkConfig(loss=0.3, strategy="online", seed=1, horizon=8.0)
    a = nw.run(cfg)
    orig = nw.VelocityTrackingModel
    nw.VelocityTrackingModel = lambda alpha: VelocityTrackingModel(alpha, method="lsoda")  # type: ignore
    try:
        b = nw.run(cfg)
    finally:
        nw.VelocityTrackingModel = orig
    for table in ("frames", "network_schedule", "schedule", "jobs"):
        assert getattr(a, table).equals(getattr(b, table)), table
    assert len(a.frames) > 0 and a.q.shape == b.q.shape == (81, 10)
    d = np.abs(a.q - b.q).max()
    assert 0.0 < d < 1e-8 and math.isfinite(d)
