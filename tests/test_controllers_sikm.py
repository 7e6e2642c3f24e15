"""SIKM (ch. 5): closed forms of Props 5.4.2-5.4.4, Table 5.2, QP (5.27), Props 5.3.1-5.3.3."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize
from test_controllers_systems import FORMATION_QREF, Formation2D

from netcosim.controllers.planner.gain_design import design, estimate_mu
from netcosim.controllers.planner.sikm import (
    SIKMParams,
    Strategy,
    Trajectory,
    check_offline_gain,
    collect_interval_samples,
    estimate_parameters,
    in_stability_set,
    k_bar,
    k_barbar,
    k_o,
    optimal_offline_gain,
    rho_of_k,
    rho_of_tau,
    simulate_tracking,
    tau_critical,
    tau_o,
    tau_s,
    z,
)

THESIS = SIKMParams(0.02, 0.13, 0.1, 0.2)
PARAMS = [THESIS, SIKMParams(0.7, 0.05, 0.1, 0.05), SIKMParams(1.5, 0.05, 0.1, 0.05),
          SIKMParams(0.3, 0.0, 0.0, 0.0)]


def test_table_5_2_optimal_offline_gains_and_critical_period():
    # Prop. 5.4.4 with mu < 1/2 and T < (1 - 2 mu)/gamma1 = 9.6 s gives k_o(T) = 1/T
    assert optimal_offline_gain(0.5, THESIS) == pytest.approx(2.0, abs=1e-15)      # thesis: 2
    assert optimal_offline_gain(1.5, THESIS) == pytest.approx(2 / 3, abs=1e-15)    # thesis: 0.67
    # thesis prints 1.28 for T = 0.75 s; the closed form gives 1/0.75 = 1.333 (see docs)
    assert optimal_offline_gain(0.75, THESIS) == pytest.approx(4 / 3, abs=1e-15)
    assert z(1.28, 0.75, THESIS) > z(4 / 3, 0.75, THESIS)
    # rho_o(T) on the k = 1/T branch: gamma2 T^2 + (alpha + gamma1) T + mu
    assert rho_of_tau(0.75, THESIS) == pytest.approx(0.305, abs=1e-14)
    # tau_CR: the root of 0.2 T^2 + 0.23 T + 0.02 = 1, i.e. 1 / k_bar
    t_cr = (-0.23 + math.sqrt(0.23 ** 2 + 4 * 0.2 * 0.98)) / (2 * 0.2)
    assert tau_critical(THESIS) == pytest.approx(t_cr, abs=1e-14)
    assert tau_critical(THESIS) == pytest.approx(1.7120559678, abs=1e-9)
    assert 1 / k_bar(THESIS) == pytest.approx(t_cr, abs=1e-14)
    with pytest.raises(ValueError, match=r"T=4.0 s is outside the stability set.*tau_CR=1.71206"):
        optimal_offline_gain(4.0, THESIS)
    assert optimal_offline_gain(4.0, THESIS, require_stable=False) == 0.25
    with pytest.raises(ValueError, match=r"k=3.0 1/s, T=1.5 s"):
        check_offline_gain(3.0, 1.5, THESIS)
    with pytest.raises(ValueError, match="T must be a finite positive"):
        optimal_offline_gain(0.0, THESIS)


@pytest.mark.parametrize("p", PARAMS)
def test_stability_bound_and_optimal_time_match_brute_force(p):
    for k in np.concatenate([p.alpha + np.geomspace(1e-3, 10, 12), [k_bar(p), k_barbar(p)]]):
        if not math.isfinite(k) or k <= p.alpha:
            continue
        ts = tau_s(k, p)
        span = 2 * max(ts, 1 / k)
        taus = np.linspace(0, span, 400001)[1:]
        zz = z(k, taus, p)
        assert z(k, ts, p) == pytest.approx(1.0, abs=1e-10)
        assert taus[zz < 1.0].max() == pytest.approx(ts, abs=span * 1e-5)
        to = tau_o(k, p)
        assert to == pytest.approx(taus[np.argmin(zz)], abs=span * 1e-5)
        assert rho_of_k(k, p) == pytest.approx(z(k, to, p), abs=1e-12)
        assert rho_of_k(k, p) <= zz.min() + 1e-12
    assert tau_s(p.alpha, p) == 0.0
    with pytest.raises(ValueError, match="must exceed alpha"):
        tau_o(p.alpha * 0.5, p)


@pytest.mark.parametrize("p", PARAMS[:3])
def test_optimal_gain_and_critical_period_match_brute_force(p):
    ks = np.linspace(p.alpha + 1e-6, 60, 600001)
    for T in (0.1, 0.3, 0.8, 1.5, 3.0):
        try:
            k = k_o(T, p)
        except ValueError:
            assert T >= 1 / p.gamma1
            continue
        zz = z(ks, T, p)
        assert k == pytest.approx(ks[np.argmin(zz)], abs=2e-4)
        assert rho_of_tau(T, p) == pytest.approx(z(k, T, p), abs=1e-12)
        assert rho_of_tau(T, p) <= zz.min() + 1e-12
    tcr = tau_critical(p)
    kk = np.linspace(p.alpha + 1e-6, 8, 100001)
    ts = np.array([tau_s(k, p) for k in kk])
    assert ts.max() <= tcr * (1 + 1e-12)
    assert tcr == pytest.approx(ts.max(), rel=2e-5)
    assert in_stability_set(kk[np.argmax(ts)], 0.999 * tcr, p)
    assert not any(in_stability_set(k, 1.0001 * tcr, p) for k in ks[::200])


def test_parameter_qp_closed_form_and_against_scipy():
    # one constraint a.theta >= c with a >= 0: theta = c a / ||a||^2
    k, T, eh, en = 1.0, 0.5, 1.0, 0.7
    a = np.array([T * T * k * k, T, T * T * k, T * T]) * eh
    c = en - abs(1 - k * T) * eh
    th = estimate_parameters([k], [T], [eh], [en])
    assert np.allclose(th.as_array(), c * a / (a @ a), atol=1e-12)
    # many samples: same optimum as SciPy's SLSQP
    rng = np.random.default_rng(4)
    N = 40
    ks, Ts = rng.uniform(0.3, 3, N), rng.uniform(0.1, 2, N)
    ehs = rng.uniform(0.01, 0.2, N)
    ens = ehs * (np.abs(1 - ks * Ts) + rng.uniform(0, 0.5, N) * Ts)
    th = estimate_parameters(ks, Ts, ehs, ens)
    A = np.stack([Ts ** 2 * ks ** 2, Ts, Ts ** 2 * ks, Ts ** 2], 1) * ehs[:, None]
    b = np.abs(1 - ks * Ts) * ehs
    ref = minimize(lambda x: x @ x, np.ones(4), jac=lambda x: 2 * x, method="SLSQP", bounds=[(0, None)] * 4,
                   constraints=[{"type": "ineq", "fun": lambda x: A @ x + b - ens, "jac": lambda x: A}],
                   options={"ftol": 1e-14, "maxiter": 500})
    assert ref.success
    assert np.allclose(th.as_array(), ref.x, atol=1e-6)
    assert np.all(A @ th.as_array() + b >= ens - 1e-10)
    with pytest.raises(ValueError, match="at least one sample, got 0"):
        estimate_parameters([], [], [], [])
    with pytest.raises(ValueError, match="equal lengths"):
        estimate_parameters([1, 2], [1], [1], [1])
    with pytest.raises(ValueError, match="parameter gamma1"):
        SIKMParams(0.1, 0.1, -0.1, 0.1)


# ---------------------------------------------------------------------------
# Tracking laws on the 2-D formation
# ---------------------------------------------------------------------------

AMP = np.array([0.1, 0.15, 0.05, -0.1, 0.08, 0.12, 0.3, 0.2, 0.25])
OMEGA = 0.6


def _traj():
    return Trajectory(lambda t: FORMATION_QREF + AMP * np.sin(OMEGA * t),
                      lambda t: AMP * OMEGA * np.cos(OMEGA * t))


def test_reference_feedforward_keeps_the_reference_and_sampled_jacobian_drifts():
    sys_, tr = Formation2D(), _traj()
    q0 = tr(0.0)[0]
    # Proposition 5.3.3: law (5.15) has q_r(t) as an equilibrium trajectory
    _, dense = simulate_tracking(sys_, tr, q0, 0.5, 10.0, 2, k_off=1.0)
    assert dense.err.max() < 1e-9
    # Proposition 5.3.2: law (5.14) does not
    _, dense3 = simulate_tracking(sys_, tr, q0, 0.5, 10.0, 3)
    assert dense3.err.max() > 1e-3


def test_point_stabilization_tracking_error_bound():
    # Proposition 5.3.1: ||e_h|| <= rho^h ||e_0|| + beta (1 - rho^h) / (1 - rho)
    sys_, tr = Formation2D(), _traj()
    T, r = 0.5, 0.3
    mu = max(estimate_mu(sys_, tr(t)[0], r, n_samples=16, seed=int(10 * t)).mu_hat
             for t in np.linspace(0, 2 * np.pi / OMEGA, 5))
    d = design(mu)
    e0 = 0.1 * np.ones(9) / 3
    samples, _ = simulate_tracking(sys_, tr, tr(0)[0] + e0, T, 20.0, Strategy("offline", "none"), k_off=d.gain(T))
    ts = samples.t.values
    beta = max(np.linalg.norm(tr(t + T)[0] - tr(t)[0]) for t in np.arange(0, 20.0, 0.01))
    h = np.arange(len(ts))
    bound = d.rho ** h * np.linalg.norm(e0) + beta * (1 - d.rho ** h) / (1 - d.rho)
    assert beta / (1 - d.rho) < r
    assert np.all(samples.err.values <= bound + 1e-9)
    assert samples.err.values[-10:].min() > 1e-3  # no zero tracking error without feed-forward


def test_table_5_1_strategies_converge_with_feedforward():
    sys_, tr = Formation2D(), _traj()
    e0 = np.array([0.05, -0.05, 0.03, 0.02, -0.04, 0.05, 0.05, -0.03, 0.04])
    T = 0.5
    errs = {}
    for s in (1, 2, 3, 4):
        samples, dense = simulate_tracking(sys_, tr, tr(0)[0] + e0, T, 12.0, s, k_off=1.2, n_dense=4)
        errs[s] = dense.err.values[-20:].max()
    assert errs[1] < 1e-6 and errs[2] < 1e-6          # asymptotic zero tracking error (5.15)
    assert errs[3] > 10 * max(errs[1], errs[2])         # sampled Jacobian (5.14): residual error
    assert errs[4] > 10 * errs[3]                        # no feed-forward: lagging (5.13)
    with pytest.raises(ValueError, match="outside the stability set"):
        simulate_tracking(sys_, tr, tr(0)[0], 4.0, 8.0, 2, k_off=0.25, params=THESIS)
    with pytest.raises(ValueError, match="needs k_off"):
        simulate_tracking(sys_, tr, tr(0)[0], 0.5, 1.0, 2)


def test_parameters_estimated_from_sampled_trajectories_bound_the_samples():
    sys_, tr = Formation2D(), _traj()
    pairs = [(k, T) for T in (0.25, 0.5, 1.0) for k in (0.5 / T, 1.0 / T)]
    df = collect_interval_samples(sys_, tr, pairs, starts=np.linspace(0, 10, 4), radius=0.1, n_per=2, seed=5)
    th = estimate_parameters(df.k, df["T"], df.e_h, df.e_next)
    zz = z(df.k.values, df["T"].values, th)
    assert np.all(df.e_next.values <= zz * df.e_h.values + 1e-10)
    assert th.alpha > 0 or th.gamma1 > 0 or th.gamma2 > 0  # a moving reference needs the extra terms
