"""Stationary costs of sampled loops (netcosim.lq) against closed forms derived here.

The references discretise the plant themselves: for a nilpotent A (A^2 = 0: the
integrator and the double integrator) ``e^{At} = I + A t`` and every integral is a
polynomial, integrated by ``scipy.integrate.quad_vec`` with the break at the actuation
instant, so nothing below uses Van Loan's exponentials or the package's own code.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import solve_discrete_are, solve_discrete_lyapunov

from netcosim import lq

INTEGRATOR = (np.zeros((1, 1)), np.ones((1, 1)))
DOUBLE = (np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]))


def _expA(A, t):
    assert not (A @ A).any()        # nilpotent of order 2
    return np.eye(len(A)) + A * t


def _G(A, B, t, a, b):
    """∫_a^b e^{A(t-s)} B ds for nilpotent A."""
    return (b - a) * B + A @ B * (((t - a) ** 2 - (t - b) ** 2) / 2)


def _R(A, Rc, t):
    """∫_0^t e^{As} Rc e^{A^T s} ds for nilpotent A."""
    return Rc * t + (A @ Rc + Rc @ A.T) * t ** 2 / 2 + A @ Rc @ A.T * t ** 3 / 3


def _quad(f, h, points=()):
    return quad_vec(f, 0.0, h, epsabs=0.0, epsrel=1e-14, points=[p for p in points if 0 < p < h] or None)[0]


def delayed_state_feedback_reference(A, B, Rc, Qc, K, h, tau):
    """Stationary cost per second of x sampled at kh, u = -K x applied at kh + tau (held)."""
    n, m = B.shape
    Qx = Qc[:n, :n]

    def Mz(t):        # [x(t); u(t)] = Mz(t) [x_k; u_{k-1}] (+ noise)
        after = t >= tau
        own = _expA(A, t) - _G(A, B, t, tau, t) @ K if after else _expA(A, t)
        Mx = np.hstack([own, _G(A, B, t, 0.0, min(t, tau))])
        Mu = np.hstack([-K, np.zeros((m, m))]) if after else np.hstack([np.zeros((m, n)), np.eye(m)])
        return np.vstack([Mx, Mu])

    Qz = _quad(lambda t: Mz(t).T @ Qc @ Mz(t), h, [tau])
    Jn = _quad(lambda t: np.trace(Qx @ _R(A, Rc, t)), h)
    F = np.vstack([Mz(h)[:n], np.hstack([-K, np.zeros((m, m))])])
    W = np.zeros((n + m, n + m))
    W[:n, :n] = _R(A, Rc, h)
    Sigma = solve_discrete_lyapunov(F, W)
    return (np.trace(Qz @ Sigma) + Jn) / h


def loop_of(A, B, Rc, Qc, K):
    n = A.shape[0]
    plant = lq.ContinuousSystem(A, B, np.eye(n), R_c=Rc, Q_c=Qc)
    return (lq.Interconnection().add("plant", plant, inputs="ctrl")
            .add("sampler", lq.DiscreteSystem.gain(np.eye(n)), inputs="plant")
            .add("ctrl", lq.DiscreteSystem.gain(-np.atleast_2d(K)), inputs="sampler"))


def schedule(h, tau):
    return [lq.Execute("sampler"), lq.Wait(tau), lq.Execute("ctrl"), lq.Wait(h - tau)]


@pytest.mark.parametrize("tau", [0.0, 0.13, 0.4])
def test_sampled_integrator_with_delay_under_p_control(tau):
    A, B = INTEGRATOR
    h, K = 0.5, np.array([[1.1]])
    Rc, Qc = np.array([[0.7]]), np.array([[1.0, 0.2], [0.2, 0.3]])
    ref = delayed_state_feedback_reference(A, B, Rc, Qc, K, h, tau)
    got = lq.periodic_cost(loop_of(A, B, Rc, Qc, K), schedule(h, tau))
    assert got.stable and got.period == h
    assert got.cost_rate == pytest.approx(ref, rel=1e-10)


@pytest.mark.parametrize("tau", [0.0, 0.02, 0.07])
def test_sampled_double_integrator_with_delay_under_pd_control(tau):
    A, B = DOUBLE
    h, K = 0.1, np.array([[20.0, 6.0]])          # u = -(20 position + 6 velocity): a PD law
    Rc = np.diag([0.0, 1.0])                     # white-noise force
    Qc = np.diag([1.0, 0.01, 0.001])
    ref = delayed_state_feedback_reference(A, B, Rc, Qc, K, h, tau)
    got = lq.periodic_cost(loop_of(A, B, Rc, Qc, K), schedule(h, tau))
    assert got.cost_rate == pytest.approx(ref, rel=1e-10)
    # and longer delays cost more here (the closed forms agree on the trend too)
    if tau > 0:
        assert got.cost_rate > lq.periodic_cost(loop_of(A, B, Rc, Qc, K), schedule(h, 0.0)).cost_rate


def _sampled_lq(A, B, Rc, Qc, h):
    n, m = B.shape
    Ms = lambda t: np.vstack([np.hstack([_expA(A, t), _G(A, B, t, 0.0, t)]),       # noqa: E731
                              np.hstack([np.zeros((m, n)), np.eye(m)])])
    Qs = _quad(lambda t: Ms(t).T @ Qc @ Ms(t), h)
    Q1, Q12, Q2 = Qs[:n, :n], Qs[:n, n:], Qs[n:, n:]
    Phi, Gam = _expA(A, h), _G(A, B, h, 0.0, h)
    S = solve_discrete_are(Phi, Gam, Q1, Q2, s=Q12)
    L = np.linalg.solve(Q2 + Gam.T @ S @ Gam, Gam.T @ S @ Phi + Q12.T)
    Jn = _quad(lambda t: np.trace(Qc[:n, :n] @ _R(A, Rc, t)), h)
    return L, (np.trace(S @ _R(A, Rc, h)) + Jn) / h


@pytest.mark.parametrize("plant", ["integrator", "double"])
def test_zero_delay_loop_with_the_sampled_lq_optimum(plant):
    A, B = INTEGRATOR if plant == "integrator" else DOUBLE
    n = A.shape[0]
    h = 0.2
    Rc = np.eye(n) * 0.5 if plant == "integrator" else np.diag([0.1, 1.0])
    Qc = np.diag([1.0] * n + [0.05])
    Qc[0, n] = Qc[n, 0] = 0.02                   # a cross weight between x1 and u, too
    L, optimum = _sampled_lq(A, B, Rc, Qc, h)    # Åström & Wittenmark, ch. 11: min J/h
    cost = lambda K: lq.periodic_cost(loop_of(A, B, Rc, Qc, K), schedule(h, 0.0)).cost_rate  # noqa: E731
    assert cost(L) == pytest.approx(optimum, rel=1e-10)
    for dK in (0.05, -0.05):                     # and any other gain costs more
        assert cost(L * (1 + dK)) > optimum * (1 + 1e-6)


def test_propagating_one_period_from_the_stationary_covariance_gives_its_cost():
    A, B = DOUBLE
    h, tau, K = 0.1, 0.04, np.array([[20.0, 6.0]])
    Rc, Qc = np.diag([0.0, 1.0]), np.diag([1.0, 0.01, 0.001])
    loop = loop_of(A, B, Rc, Qc, K)
    st = lq.periodic_cost(loop, schedule(h, tau))
    p = lq.Propagator(loop, P0=st.covariance, t0=2.0)
    p.update("sampler").advance(2.0 + tau).update("ctrl").advance(2.0 + h)
    assert p.cost / h == pytest.approx(st.cost_rate, rel=1e-12)
    assert np.allclose(p.covariance, st.covariance, rtol=0, atol=1e-12 * np.abs(st.covariance).max())
    # from rest, the average over many periods approaches the stationary rate
    q = lq.Propagator(loop)
    for k in range(400):
        q.update("sampler").pass_time(tau).update("ctrl").pass_time(h - tau)
    assert q.cost / q.time == pytest.approx(st.cost_rate, rel=0.02)
    assert q.cost / q.time < st.cost_rate       # it started with no variance


def test_transient_of_an_uncontrolled_integrator_with_an_impulse():
    # dx = dv (intensity r), x(0) = m0: E ∫_0^T q x^2 = q (m0^2 T + r T^2 / 2), dJ/dt = q (m0^2 + r T)
    q, r, m0, T = 2.0, 0.3, 1.5, 0.8
    loop = lq.Interconnection().add("p", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=r, Q_c=np.diag([q, 0.0])))
    p = lq.Propagator(loop).impulse([m0], system="p")
    p.pass_time(T / 2).pass_time(T / 2)
    assert p.cost == pytest.approx(q * (m0 ** 2 * T + r * T ** 2 / 2), rel=1e-13)
    assert p.cost_rate == pytest.approx(q * (m0 ** 2 + r * T), rel=1e-13)
    tr = p.trace().to_pandas()
    assert list(tr["event"]) == ["start", "impulse", "advance", "advance"]
    assert tr["cost"].iloc[-1] == p.cost and tr["time"].iloc[-1] == pytest.approx(T)
    # a random impulse of variance V adds q V T; a reset to zero stops the growth of the mean's cost
    p2 = lq.Propagator(loop).impulse(V=[[0.5]], system="p").pass_time(T)
    assert p2.cost == pytest.approx(q * (0.5 * T + r * T ** 2 / 2), rel=1e-13)
    p3 = lq.Propagator(loop).impulse([m0]).reset("p", [[0.0]]).pass_time(T)
    assert p3.cost == pytest.approx(q * r * T ** 2 / 2, rel=1e-13)


def test_a_discrete_controller_state_updates_as_written():
    # x+ = 0.5 x + 2 u, y+ = 3 x + 4 u: from x = 1 (mean) with u = 0, then u held = 1
    ctrl = lq.DiscreteSystem([[0.5]], [[2.0]], [[3.0]], [[4.0]], R_d=np.diag([0.1, 0.2]))
    src = lq.DiscreteSystem.gain(1.0)
    loop = lq.Interconnection().add("src", src).add("c", ctrl, inputs="src")
    p = lq.Propagator(loop).impulse([1.0, 0.0], system="c").impulse([1.0], system="src")
    p.update("c")
    m, P = p.state("c")
    assert m == pytest.approx([0.5 + 2.0, 3.0 + 4.0]) and P == pytest.approx(np.diag([0.1, 0.2]))
