"""Gain design of ch. 3/4: closed forms (3.21)-(3.24), numerical g (4.29), mu estimate (3.19)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netcosim.controllers.planner import WeightedNorm, solve_auxiliary_flow
from netcosim.controllers.planner.gain_design import (
    design,
    design_nonsquare,
    estimate_mu,
    g_nonsquare,
    g_square,
    offline_gain,
    rho,
    tau_o_bar,
    tau_s_bar,
)

MUS = [0.0, 0.1, 0.3, 0.49, 0.5, 0.6, 0.75, 0.99, 1.0, 1.5, 2.0]


def test_closed_forms_published_values():
    # mu = 0: dead-beat, tau_s = 2
    assert tau_s_bar(0.0) == 2.0 and tau_o_bar(0.0) == 1.0 and rho(0.0) == 0.0
    # mu < 1/2: tau_o = 1, rho = mu
    assert tau_s_bar(0.2) == pytest.approx(4 / (1 + math.sqrt(2.6)), abs=1e-15)
    assert tau_o_bar(0.2) == 1.0 and rho(0.2) == 0.2
    # 1/2 <= mu < 1
    assert tau_s_bar(0.75) == pytest.approx(4 / (1 + math.sqrt(7.0)), abs=1e-15)
    assert tau_o_bar(0.75) == pytest.approx(2 / 3, abs=1e-15)
    assert rho(0.75) == pytest.approx(2 / 3, abs=1e-15)
    # mu >= 1: tau_s = 1/mu
    assert tau_s_bar(2.0) == 0.5 and tau_o_bar(2.0) == 0.25 and rho(2.0) == 0.875
    # continuity at the switching points
    assert tau_s_bar(1.0 - 1e-12) == pytest.approx(tau_s_bar(1.0), abs=1e-11)
    assert rho(0.5 - 1e-12) == pytest.approx(rho(0.5), abs=1e-11)
    assert offline_gain(0.2, 0.01) == pytest.approx(100.0)


@pytest.mark.parametrize("mu", MUS)
def test_closed_forms_are_the_extremes_of_g(mu):
    ts, to, r = tau_s_bar(mu), tau_o_bar(mu), rho(mu)
    assert g_square(ts, mu) == pytest.approx(1.0, abs=1e-12)
    tau = np.linspace(1e-6, ts * (1 - 1e-9), 200001)
    assert np.all(g_square(tau, mu) < 1.0)
    assert g_square(ts * 1.001, mu) > 1.0
    j = np.argmin(g_square(tau, mu))
    assert tau[j] == pytest.approx(to, abs=2e-5)
    assert g_square(to, mu) == pytest.approx(r, abs=1e-15)
    assert 0.0 <= r < 1.0


@pytest.mark.parametrize("mu", MUS)
def test_numerical_minimisation_of_4_29_matches_closed_forms_for_identity(mu):
    for kw in ({}, {"d": np.ones(5), "form": "thesis"}):
        d = design_nonsquare(mu, np.ones(5), **kw)
        assert d.tau_s == pytest.approx(tau_s_bar(mu), abs=1e-9)
        assert d.tau_o == pytest.approx(tau_o_bar(mu), abs=1e-7)
        assert d.rho == pytest.approx(rho(mu), abs=1e-10)
    c = design(mu)
    assert (c.tau_s, c.tau_o, c.rho) == (tau_s_bar(mu), tau_o_bar(mu), rho(mu))


@pytest.mark.parametrize("mu", [0.0, 0.05, 0.3, 1.2])
def test_numerical_design_with_unequal_gains_matches_brute_force(mu):
    k = np.array([1.0, 2.0, 0.7, 1.5])
    d = design_nonsquare(mu, k)
    tau = np.linspace(0, 3, 300001)
    g = g_nonsquare(tau, mu, k)
    assert g.min() - 3e-5 <= d.rho <= g.min() + 1e-12
    assert d.tau_o == pytest.approx(tau[np.argmin(g)], abs=2e-5)
    assert g_nonsquare(d.tau_s, mu, k) == pytest.approx(1.0, abs=1e-10)
    assert np.all(g[(tau > 0) & (tau < d.tau_s - 1e-9)] < 1.0)
    # K_bar = k_min I is not better: for mu = 0, rho = max_i |1 - tau k_i| minimised
    if mu == 0.0:
        # the optimum balances the smallest and largest gains: tau = 2/(k_min + k_max)
        assert d.tau_o == pytest.approx(2 / (0.7 + 2.0), abs=1e-7)
        assert d.rho == pytest.approx((2.0 - 0.7) / (2.0 + 0.7), abs=1e-12)


def test_thesis_form_of_4_29_is_smaller_than_the_induced_norm():
    k = np.array([1.0, 1.0, 2.0])
    d = np.array([1.0, 2.0, 2.0])
    tau = np.linspace(0, 2, 101)
    assert np.all(g_nonsquare(tau, 0.1, k, d, form="thesis") <= g_nonsquare(tau, 0.1, k) + 1e-15)
    with pytest.raises(ValueError, match="d must"):
        g_nonsquare(0.5, 0.1, k, [0.5, 1, 1], form="thesis")


def test_design_bad_input():
    for bad in (-0.1, math.nan, math.inf, "x"):
        with pytest.raises(ValueError, match="mu must"):
            tau_s_bar(bad)
    with pytest.raises(ValueError, match="T must be a finite positive"):
        offline_gain(0.2, 0.0)
    with pytest.raises(ValueError, match=r"-1"):
        offline_gain(0.2, -1)
    with pytest.raises(ValueError, match="stability interval"):
        design(0.2).check_gain(200.0, 0.01)


# ---------------------------------------------------------------------------
# Flow and mu estimate against closed forms
# ---------------------------------------------------------------------------

class Quadratic1D:
    """``p = q^2 / 2`` (n = m = 1, A_q = q): the flow (3.12) has the closed form
    ``q'(tau)^2 = q_h^2 - 2 q_h e_h tau``."""

    n = m = 1

    def h(self, q):
        return 0.5 * np.asarray(q) ** 2

    def jacobian(self, q):
        return np.array([[float(np.asarray(q).reshape(-1)[0])]])


def _exact_flow(qr, e, tau):
    qh = qr + e
    return np.sqrt(qh * qh - 2 * qh * e * tau) - qr


@pytest.mark.parametrize("e", [0.3, -0.3, 0.05, -0.6])
def test_auxiliary_flow_matches_closed_form(e):
    qr = 1.0
    f = solve_auxiliary_flow(Quadratic1D(), [qr], [e])
    # tau_s: ||e'|| returns to |e| at e' = -e; tau_o: e' = 0 (dead-beat in 1-D)
    assert f.tau_s == pytest.approx(2 * qr / (qr + e), rel=1e-10)
    # Newton on d||e'||/dtau over the dense output: limited by the integration (rtol 1e-10)
    assert f.tau_o == pytest.approx((2 * qr + e) / (2 * (qr + e)), rel=1e-10)
    assert f.min_norm < 1e-8
    tau = np.linspace(0, f.tau_s, 50)
    assert np.max(np.abs(f(tau)[:, 0] - _exact_flow(qr, e, tau))) < 1e-10 * abs(e) + 1e-15


def test_mu_estimate_matches_closed_form_per_sample_and_is_zero_for_linear_maps():
    qr = 1.0
    est = estimate_mu(Quadratic1D(), [qr], 0.4, n_samples=12, seed=3)
    assert est.n == 12 and np.all(np.abs(est.samples[:6, 0]) == pytest.approx(0.4, rel=1e-8))
    for e, mu_i, ts in zip(est.samples[:, 0], est.mu_i, est.tau_s):
        assert ts == pytest.approx(2 * qr / (qr + e), rel=1e-9)
        tau = np.linspace(ts * 1e-4, ts, 20001)
        exact = np.max(np.abs(_exact_flow(qr, e, tau) - (1 - tau) * e) / (tau ** 2 * abs(e)))
        assert mu_i == pytest.approx(exact, rel=2e-3)
        assert mu_i <= exact * (1 + 1e-7)
    assert est.mu_hat == est.mu_i.max()

    class Linear:  # constant Jacobian: e'(tau) = (1 - tau) e exactly -> mu* = 0, tau_s = 2
        n = m = 3
        M = np.array([[2.0, 0.3, 0], [0.1, 1.0, 0.2], [0, -0.4, 1.5]])

        def h(self, q):
            return self.M @ q

        def jacobian(self, q):
            return self.M

    lin = estimate_mu(Linear(), np.zeros(3), 1.0, n_samples=5, norm=WeightedNorm((1, 2, 3), math.inf))
    assert lin.mu_hat < 1e-8
    assert np.allclose(lin.tau_s, 2.0, rtol=1e-9)


def test_mu_estimate_bad_input():
    with pytest.raises(ValueError, match="n_samples=0"):
        estimate_mu(Quadratic1D(), [1.0], 0.1, n_samples=0)
    with pytest.raises(ValueError, match="radius"):
        estimate_mu(Quadratic1D(), [1.0], -0.1, n_samples=3)
