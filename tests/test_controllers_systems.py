"""Small kinematic systems of the class (3.1) used by the controller tests.

* :class:`Formation2D` -- the 2-D formation of Sec. 3.2.2 (three robots at distance
  ``d_i`` and bearing ``phi_i`` from a pivot ``(x_V, y_V, phi_V)``; the bearings are
  also outputs, so the system is square, 9 x 9).
* :class:`PlanarCrane` -- a planar analogue of the Fly-crane: a rigid load
  ``(x_V, y_V, psi_V)`` hanging from N robots by one rigid cable each (angle
  ``theta_i`` relative to the load).  ``n = 2N``, ``m = N + 3``: square for N = 3,
  over-actuated (non-square) for N = 4.

Both expose ``n, m, h(q), jacobian(q)`` and a ``structure`` (StarStructure), i.e. the
duck-typed interface the controllers are written against.
"""

from __future__ import annotations

import numpy as np
import pytest

from netcosim.controllers.planner import StarStructure


def _rot(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


class Formation2D:
    """Sec. 3.2.2: ``q = [d_1, phi_1, d_2, phi_2, d_3, phi_3, x_V, y_V, phi_V]``,
    ``p' = [p_1, p_2, p_3, phi_1, phi_2, phi_3]`` (m and rad)."""

    n = 9
    m = 9
    structure = StarStructure(rows=((0, 1, 6), (2, 3, 7), (4, 5, 8)),
                              cols=((0, 1), (2, 3), (4, 5)), pivot=(6, 7, 8))

    def h(self, q):
        q = np.asarray(q, dtype=float)
        pV, phV = q[6:8], q[8]
        out = np.empty(9)
        for i in range(3):
            d, ph = q[2 * i], q[2 * i + 1]
            out[2 * i:2 * i + 2] = pV + _rot(phV) @ np.array([d * np.cos(ph), d * np.sin(ph)])
            out[6 + i] = ph
        return out

    def jacobian(self, q):
        q = np.asarray(q, dtype=float)
        phV = q[8]
        A = np.zeros((9, 9))
        for i in range(3):
            d, ph = q[2 * i], q[2 * i + 1]
            w = np.array([np.cos(phV + ph), np.sin(phV + ph)])
            wp = np.array([-w[1], w[0]])
            r = slice(2 * i, 2 * i + 2)
            A[r, 2 * i] = w
            A[r, 2 * i + 1] = d * wp
            A[r, 6:8] = np.eye(2)
            A[r, 8] = d * wp
            A[6 + i, 2 * i + 1] = 1.0
        return A


class PlanarCrane:
    """Planar load ``(x_V, y_V, psi_V)`` carried by N robots on rigid cables of length l.

    Robot i: ``p_i = p_V + R(psi) a_i + l [cos(psi + theta_i), sin(psi + theta_i)]`` with
    attachment points ``a_i`` on a circle of radius ``rad`` in the load frame.
    ``q = [theta_1..theta_N, x_V, y_V, psi_V]``.
    """

    def __init__(self, N=3, l=1.5, rad=0.5):
        self.N, self.l = N, l
        ang = 2 * np.pi * np.arange(N) / N
        self.a = rad * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        self.n = 2 * N
        self.m = N + 3
        self.structure = StarStructure.uniform(N, n_i=2, m_i=1, m_V=3)

    def h(self, q):
        q = np.asarray(q, dtype=float)
        N, l = self.N, self.l
        pV, psi = q[N:N + 2], q[N + 2]
        R = _rot(psi)
        out = np.empty(2 * N)
        for i in range(N):
            th = q[i]
            out[2 * i:2 * i + 2] = pV + R @ self.a[i] + l * np.array([np.cos(psi + th), np.sin(psi + th)])
        return out

    def jacobian(self, q):
        q = np.asarray(q, dtype=float)
        N, l = self.N, self.l
        psi = q[N + 2]
        dR = np.array([[-np.sin(psi), -np.cos(psi)], [np.cos(psi), -np.sin(psi)]])
        A = np.zeros((2 * N, N + 3))
        for i in range(N):
            th = q[i]
            wp = np.array([-np.sin(psi + th), np.cos(psi + th)])
            r = slice(2 * i, 2 * i + 2)
            A[r, i] = l * wp
            A[r, N:N + 2] = np.eye(2)
            A[r, N + 2] = dR @ self.a[i] + l * wp
        return A


#: Reference configurations used across the tests (non-singular).
FORMATION_QREF = np.array([1.0, 0.3, 1.2, 2.4, 0.9, 4.2, 0.5, -0.2, 0.1])
CRANE3_QREF = np.array([1.9, 3.9, 6.2, 0.2, 0.1, 0.3])
CRANE4_QREF = np.array([0.9, 2.6, 3.9, 5.5, 0.2, 0.1, 0.3])


@pytest.mark.parametrize("sys_, q", [(Formation2D(), FORMATION_QREF), (PlanarCrane(3), CRANE3_QREF),
                                     (PlanarCrane(4), CRANE4_QREF)])
def test_jacobian_matches_finite_differences_and_is_full_rank(sys_, q):
    A = sys_.jacobian(q)
    eps = 1e-6
    F = np.empty_like(A)
    for j in range(sys_.m):
        dq = np.zeros(sys_.m)
        dq[j] = eps
        F[:, j] = (sys_.h(q + dq) - sys_.h(q - dq)) / (2 * eps)
    F[6:, :] = A[6:, :] if isinstance(sys_, Formation2D) else F[6:, :]  # selector rows of p'
    assert np.max(np.abs(A - F)) < 1e-8
    assert np.linalg.matrix_rank(A) == sys_.m
    # star sparsity (3.3): robot rows vanish outside its own and the pivot's columns
    st = sys_.structure
    for i in range(st.N):
        other = np.setdiff1d(np.arange(sys_.m), st.agent_q(i))
        assert np.all(A[np.ix_(st.rows[i], other)] == 0.0)
