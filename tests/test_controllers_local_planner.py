"""Local planners of ch. 3/4 on small systems of the class: laws, sparsity, sampled loops."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from test_controllers_systems import CRANE3_QREF, CRANE4_QREF, FORMATION_QREF, Formation2D, PlanarCrane

from netcosim.controllers.planner import (
    OfflineGain,
    OnlineGain,
    SingularConfigurationError,
    StarStructure,
    WeightedNorm,
    check_gain_matrix,
    configuration_rate,
    online_gain,
    planner_velocity,
    project,
    robot_velocity,
    simulate_sampled,
    solve_auxiliary_flow,
)
from netcosim.controllers.planner.gain_design import design, design_nonsquare, estimate_mu

SYSTEMS = [(Formation2D(), FORMATION_QREF), (PlanarCrane(3), CRANE3_QREF), (PlanarCrane(4), CRANE4_QREF)]


@pytest.mark.parametrize("sys_, qr", SYSTEMS)
def test_sparse_per_robot_law_equals_centralized_law(sys_, qr):
    rng = np.random.default_rng(1)
    q = qr + 0.1 * rng.standard_normal(sys_.m)
    kdiag = rng.uniform(0.5, 2.0, sys_.m)
    u = planner_velocity(sys_, q, qr, kdiag)
    st = sys_.structure
    for i in range(st.N):
        ui = robot_velocity(sys_, st, i, q[list(st.cols[i])], q[list(st.pivot)], qr, kdiag)
        assert np.max(np.abs(ui - u[list(st.rows[i])])) < 1e-14


@pytest.mark.parametrize("sys_, qr", SYSTEMS)
def test_continuous_planner_gives_linear_error_dynamics(sys_, qr):
    # (3.9)/(4.15): q_dot = -K (q - q_r) for any K with K + K^T > 0 (here non-symmetric)
    m = sys_.m
    rng = np.random.default_rng(2)
    S = rng.standard_normal((m, m))
    K = np.eye(m) + 0.8 * (S - S.T)
    e0 = 0.1 * rng.standard_normal(m)
    sol = solve_ivp(lambda t, q: configuration_rate(sys_, q, planner_velocity(sys_, q, qr, K)),
                    (0, 2.0), qr + e0, method="DOP853", rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(sol.y[:, -1] - qr - expm(-2.0 * K) @ e0)) < 1e-9
    norms = np.linalg.norm(sol.y - qr[:, None], axis=0)
    assert np.all(np.diff(norms) < 0)  # Proposition 3.3.1: V = ||e||^2 decreases


def test_gain_matrix_and_input_checks():
    with pytest.raises(ValueError, match="K \\+ K\\^T > 0"):
        check_gain_matrix(np.array([[1.0, 3.0], [-1.0, -0.5]]))
    with pytest.raises(ValueError, match="K \\+ K\\^T"):
        planner_velocity(Formation2D(), FORMATION_QREF, FORMATION_QREF, -1.0)
    with pytest.raises(ValueError, match="T must be a finite positive.*-0.5"):
        online_gain(Formation2D(), FORMATION_QREF, FORMATION_QREF, -0.5)
    with pytest.raises(ValueError, match="T must be a finite positive"):
        simulate_sampled(Formation2D(), FORMATION_QREF, FORMATION_QREF, 0.0, OfflineGain(1.0))
    with pytest.raises(ValueError, match="offline gain k"):
        OfflineGain(-2.0)
    with pytest.raises(ValueError, match=r"gain k=300.0 1/s with T=0.01 s gives kT=3, outside"):
        simulate_sampled(Formation2D(), FORMATION_QREF, FORMATION_QREF, 0.01, OfflineGain(300.0),
                         guarantee=design(0.2))
    with pytest.raises(TypeError, match="not a kinematic system"):
        planner_velocity(object(), [0], [0])
    with pytest.raises(ValueError, match="q must have 9"):
        planner_velocity(Formation2D(), [0, 1], FORMATION_QREF)
    q = FORMATION_QREF.copy()
    q[[0, 2, 4]] = 0.0  # all robots on the pivot: the pivot rotation is not observable
    with pytest.raises(SingularConfigurationError, match="singular"):
        configuration_rate(Formation2D(), q, np.ones(9))


def test_projection_onto_image_of_jacobian():
    sys_ = PlanarCrane(4)
    A = sys_.jacobian(CRANE4_QREF)
    u = np.arange(8.0)
    pu = project(sys_, CRANE4_QREF, u)
    assert np.allclose(project(sys_, CRANE4_QREF, pu), pu, atol=1e-12)      # Pi^2 = Pi
    assert np.allclose(A.T @ (u - pu), 0.0, atol=1e-12)                     # residual _|_ Im A
    assert np.allclose(project(Formation2D(), FORMATION_QREF, np.arange(9.0)), np.arange(9.0), atol=1e-12)


def test_structure_helpers():
    st = StarStructure.uniform(3, 3, 1, 6)
    assert (st.N, st.n, st.m) == (3, 9, 9) and st.pivot == (3, 4, 5, 6, 7, 8)
    with pytest.raises(ValueError, match="overlap"):
        StarStructure(((0,), (1,)), ((0,), (0,)), (1,))


# ---------------------------------------------------------------------------
# Sampled planners (ch. 3 square, ch. 4 non-square)
# ---------------------------------------------------------------------------

def test_offline_vs_online_square_crane():
    sys_, qr = PlanarCrane(3), CRANE3_QREF
    T = 0.01
    r = 0.2
    est = estimate_mu(sys_, qr, r, n_samples=40, seed=0)
    d = design(est.mu_hat)
    e0 = np.array([0.1, -0.08, 0.05, 0.04, -0.03, 0.06])
    assert np.linalg.norm(e0) < r
    off = simulate_sampled(sys_, qr + e0, qr, T, OfflineGain(d.gain(T)), n_samples=60, tol=1e-6)
    on = simulate_sampled(sys_, qr + e0, qr, T, OnlineGain(), n_samples=60, tol=1e-6)
    assert off.err.iloc[-1] < 1e-6 and on.err.iloc[-1] < 1e-6
    assert len(on) < len(off)
    # Proposition 3.4.5: per-sample contraction never exceeds rho(mu_hat)
    assert np.all(off.err.values[1:] / off.err.values[:-1] <= d.rho + 1e-9)
    # Proposition 3.4.6: ||e_{h+1}|| <= c ||e_h||^2 and k_h -> 1/T
    ratio = on.err.values[1:] / on.err.values[:-1] ** 2
    assert np.all(ratio < 5.0)
    assert on.k.iloc[-2] == pytest.approx(1 / T, rel=1e-3)
    assert np.all(on.err.values[1:] <= d.rho * on.err.values[:-1])


@pytest.mark.parametrize("p", [2, math.inf])
def test_nonsquare_offline_and_online_converge_in_weighted_norms(p):
    sys_, qr = PlanarCrane(4), CRANE4_QREF
    norm = WeightedNorm((1, 1, 1, 1, 4, 4, 4), p)
    kbar = np.ones(7)
    est = estimate_mu(sys_, qr, 0.25, n_samples=30, kbar=kbar, norm=norm, seed=1)
    d = design_nonsquare(est.mu_hat, kbar)
    e0 = np.array([0.05, -0.04, 0.03, 0.02, 0.02, -0.01, 0.015])
    assert norm(e0) < 0.25
    T = 1.5
    off = simulate_sampled(sys_, qr + e0, qr, T, OfflineGain(d.gain(T)), kbar=kbar, norm=norm, n_samples=40, tol=1e-7)
    on = simulate_sampled(sys_, qr + e0, qr, T, OnlineGain(), kbar=kbar, norm=norm, n_samples=40, tol=1e-7)
    for df in (off, on):
        assert df.err.iloc[-1] < 1e-7
        assert np.all(df.err.values[1:] <= d.rho * df.err.values[:-1] + 1e-12)
    assert len(on) <= len(off)


def test_online_gain_uses_the_norm_minimiser_of_the_flow():
    sys_, qr = PlanarCrane(3), CRANE3_QREF
    e = np.array([0.2, 0.1, -0.1, 0.05, 0.0, 0.1])
    k, flow = online_gain(sys_, qr + e, qr, 0.5)
    assert k == pytest.approx(flow.tau_o / 0.5)
    tau = np.linspace(0, flow.tau_s, 4001)
    nrm = np.linalg.norm(flow(tau), axis=1)
    assert flow.min_norm <= nrm.min() + 1e-12
    assert abs(nrm[-1] - np.linalg.norm(e)) < 1e-9        # tau_s: back on the sphere
    assert np.all(nrm[1:-1] < np.linalg.norm(e))           # Proposition 3.4.1 (ii)
    f0 = solve_auxiliary_flow(sys_, qr, np.zeros(6))
    assert f0.tau_o == 1.0 and f0.min_norm == 0.0


def _plant_systems():
    from netcosim.plants.flycrane import configurations as c
    return [c.thesis_flycrane(), c.four_robot_nonsquare(), c.formation_2d()] + \
        [c.square_family(a, b) for a, b, _ in c.SQUARE_FAMILY[1:]]


def test_laws_work_on_every_system_of_the_class():
    for sys_ in _plant_systems():
        qr = sys_.q_nominal
        st = StarStructure.for_system(sys_)
        rng = np.random.default_rng(7)
        q = qr + 0.02 * rng.standard_normal(sys_.m)
        kd = rng.uniform(0.5, 2, sys_.m)
        u = planner_velocity(sys_, q, qr, kd)
        for i in range(st.N):
            ui = robot_velocity(sys_, st, i, q[list(st.cols[i])], q[list(st.pivot)], qr, kd)
            assert np.max(np.abs(ui - u[list(st.rows[i])])) < 1e-13, sys_.name
        e0 = 0.02 * np.cos(np.arange(sys_.m))
        on = simulate_sampled(sys_, qr + e0, qr, 1.0, OnlineGain(), n_samples=8, tol=1e-9)
        off = simulate_sampled(sys_, qr + e0, qr, 1.0, OfflineGain(1.0), n_samples=8, tol=1e-9)
        assert on.err.iloc[-1] < 1e-9 and off.err.iloc[-1] < 1e-6, sys_.name
        assert len(on) <= len(off), sys_.name
