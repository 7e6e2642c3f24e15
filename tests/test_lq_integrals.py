"""Van Loan's interval matrices (netcosim.lq.integrals) against direct quadrature and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm

from netcosim.lq import interval_matrices

RNG = np.random.default_rng(26)


def _psd(n):
    M = RNG.normal(size=(n, n))
    return M @ M.T


CASES = {
    "stable": np.array([[-1.0, 2.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.3, -3.0]]),
    "unstable": np.array([[0.4, 1.0, 0.0], [0.0, 0.2, 1.0], [-0.1, 0.0, 0.1]]),
    "servo": np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 1000.0], [0.0, 0.0, 0.0]]),
}


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("T", [0.01, 0.7])
def test_van_loan_integrals_equal_direct_quadrature(name, T):
    A = CASES[name]
    n = A.shape[0]
    Rc, Qc = _psd(n), _psd(n)
    M = interval_matrices(A, Rc, Qc, T)

    def R_of(s):        # ∫_0^s e^{Ar} Rc e^{A^T r} dr
        return quad_vec(lambda r: expm(A * r) @ Rc @ expm(A * r).T, 0.0, s, epsabs=0, epsrel=1e-13)[0]

    R = R_of(T)
    Q = quad_vec(lambda s: expm(A * s).T @ Qc @ expm(A * s), 0.0, T, epsabs=0, epsrel=1e-13)[0]
    Jn = quad_vec(lambda s: np.trace(Qc @ R_of(s)), 0.0, T, epsabs=0, epsrel=1e-12)[0]
    assert np.allclose(M.Phi, expm(A * T), rtol=1e-12, atol=0)
    assert np.max(np.abs(M.R - R)) <= 1e-9 * np.max(np.abs(R))
    assert np.max(np.abs(M.Q - Q)) <= 1e-9 * np.max(np.abs(Q))
    assert abs(M.J_noise - Jn) <= 1e-9 * abs(Jn)


@pytest.mark.parametrize("a", [-2.0, 0.5])
def test_scalar_closed_forms(a):
    r, q, T = 0.3, 2.0, 1.3
    M = interval_matrices(np.array([[a]]), np.array([[r]]), np.array([[q]]), T)
    assert M.Phi[0, 0] == pytest.approx(np.exp(a * T), rel=1e-14)
    assert M.R[0, 0] == pytest.approx(r * (np.exp(2 * a * T) - 1) / (2 * a), rel=1e-12)
    assert M.Q[0, 0] == pytest.approx(q * (np.exp(2 * a * T) - 1) / (2 * a), rel=1e-12)
    # ∫_0^T q r (e^{2as} - 1)/(2a) ds
    Jn = q * r * ((np.exp(2 * a * T) - 1) / (4 * a * a) - T / (2 * a))
    assert M.J_noise == pytest.approx(Jn, rel=1e-12)


def test_integrator_closed_form_and_zero_interval():
    M = interval_matrices(np.zeros((1, 1)), np.array([[2.0]]), np.array([[3.0]]), 0.5)
    assert (M.Phi[0, 0], M.R[0, 0], M.Q[0, 0]) == pytest.approx((1.0, 1.0, 1.5), rel=1e-14)
    assert M.J_noise == pytest.approx(3.0 * 2.0 * 0.5 ** 2 / 2, rel=1e-14)    # ∫ q r s ds
    Z = interval_matrices(CASES["stable"], _psd(3), _psd(3), 0.0)
    assert np.array_equal(Z.Phi, np.eye(3)) and not Z.R.any() and not Z.Q.any() and Z.J_noise == 0.0
