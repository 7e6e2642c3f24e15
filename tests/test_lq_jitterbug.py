"""Jitterbug's DC servo (netcosim.lq.TimingModel) against references derived here.

The servo of the Jitterbug manual and of TrueTime, G(s) = 1000 / (s (s + 1)), under a
discrete PD controller (u_k = -K (y_k + Td (y_k - y_{k-1}) / h)) with period h and a
sampling-to-actuation delay.  Jitterbug's published numbers are not available offline;
the references are derived here from the documented setup: the servo's exponentials in
closed form, the cost integrals by quadrature, and the per-period Markov jump linear
system (i.i.d. delays / dropouts) solved as one linear equation -- no Monte Carlo (not
good enough for 1e-9), no Van Loan, no iteration.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad_vec

from netcosim import lq

H, K, TD = 0.01, 1.5, 0.035
DELTA = H / 10
B = np.array([[0.0], [1000.0]])
A = np.array([[0.0, 1.0], [0.0, -1.0]])
C = np.array([[1.0, 0.0]])
RC = B @ B.T                                   # unit-intensity noise at the input
QC = np.diag([1.0, 0.0, 1e-6])                 # J = E ∫ y^2 + 1e-6 u^2 dt


def expA(t):
    return np.array([[1.0, 1.0 - math.exp(-t)], [0.0, math.exp(-t)]])


def G(t, a, b):
    """∫_a^b e^{A(t-s)} B ds (closed form)."""
    ea, eb = math.exp(-(t - a)), math.exp(-(t - b))
    return 1000.0 * np.array([[(b - a) + ea - eb], [eb - ea]])


def R(t):
    """∫_0^t e^{As} RC e^{A^T s} ds (closed form)."""
    e1, e2 = 1.0 - math.exp(-t), (1.0 - math.exp(-2 * t)) / 2
    return 1e6 * np.array([[t - 2 * e1 + e2, e1 - e2], [e1 - e2, e2]])


def servo_loop():
    plant = lq.ContinuousSystem(A, B, C, R_c=RC, Q_c=QC)
    pd = lq.DiscreteSystem([[0.0]], [[1.0]], [[K * TD / H]], [[-K * (1 + TD / H)]])   # x_c = y_{k-1}
    return (lq.Interconnection().add(1, plant, inputs=3)
            .add(2, lq.DiscreteSystem.gain(1.0), inputs=1)
            .add(3, pd, inputs=2))


def mode(tau, executes=True):
    """One period with the controller at tau (or skipped): z = [x (2); x_c; u_prev],
    z_{k+1} = F z_k + noise, cost = tr(Qz E[z z^T]) + noise cost."""
    n = 5 - 1
    Ku = np.array([[-K * (1 + TD / H) * 1.0, 0.0, K * TD / H, 0.0]])   # u_k from z (y = x1)
    keep = np.array([[0.0, 0.0, 0.0, 1.0]])
    u_new = Ku if executes else keep

    def Mz(t):
        after = executes and t >= tau
        x = np.hstack([expA(t), np.zeros((2, 2))])
        x += G(t, 0.0, min(t, tau) if executes else t) @ keep
        if after:
            x += G(t, tau, t) @ Ku
        u = u_new if after else keep
        return np.vstack([x[:, :n], u])

    pts = [tau] if executes and 0 < tau < H else None
    Qz = quad_vec(lambda t: Mz(t).T @ QC @ Mz(t), 0.0, H, epsabs=0, epsrel=1e-14, points=pts)[0]
    xc_new = np.array([[1.0, 0.0, 0.0, 0.0]]) if executes else np.array([[0.0, 0.0, 1.0, 0.0]])
    F = np.vstack([Mz(H)[:2], xc_new, u_new])
    return F, Qz


def reference(modes):
    """Stationary cost per second of i.i.d. modes [(probability, tau, executes)]."""
    n = 4
    W = np.zeros((n, n))
    W[:2, :2] = R(H)
    parts = [(p, *mode(tau, ex)) for p, tau, ex in modes]
    L = np.eye(n * n) - sum(p * np.kron(F, F) for p, F, _ in parts)
    X = np.linalg.solve(L, W.reshape(-1)).reshape(n, n)
    Jn = quad_vec(lambda t: np.trace(QC[:2, :2] @ R(t)), 0.0, H, epsabs=0, epsrel=1e-14)[0]
    return (sum(p * np.trace(Qz @ X) for p, _, Qz in parts) + Jn) / H


def pmf(*pairs):
    d = np.zeros(11)
    for k, p in pairs:
        d[k] = p
    return d


@pytest.mark.parametrize("k", [0, 3, 7])
def test_constant_delay_equals_the_closed_form_and_the_periodic_analysis(k):
    tau = k * DELTA
    ref = reference([(1.0, tau, True)])
    tm = lq.TimingModel(servo_loop(), delta=DELTA, period=H)
    tm.add_node(1, delay=pmf((k, 1.0)), next=2, execute=2).add_node(2, execute=3)
    jb = tm.cost()
    periodic = lq.periodic_cost(servo_loop(), [lq.Execute(2), lq.Wait(tau), lq.Execute(3), lq.Wait(H - tau)])
    assert jb.stable and jb.period == pytest.approx(H, rel=1e-15)
    assert jb.cost_rate == pytest.approx(ref, rel=1e-9)
    assert periodic.cost_rate == pytest.approx(ref, rel=1e-10)


def test_random_delay_equals_the_markov_jump_closed_form():
    tm = lq.TimingModel(servo_loop(), delta=DELTA, period=H)
    tm.add_node(1, delay=pmf((2, 0.3), (5, 0.5), (9, 0.2)), next=2, execute=2).add_node(2, execute=3)
    ref = reference([(0.3, 2 * DELTA, True), (0.5, 5 * DELTA, True), (0.2, 9 * DELTA, True)])
    assert tm.cost().cost_rate == pytest.approx(ref, rel=1e-9)
    # a random delay costs more than its mean as a constant delay? not in general; but it lies
    # between the costs of its extreme constant delays here
    assert reference([(1.0, 2 * DELTA, True)]) < ref < reference([(1.0, 9 * DELTA, True)])


def test_dropouts_equal_the_markov_jump_closed_form():
    p_loss = 0.1
    tm = lq.TimingModel(servo_loop(), delta=DELTA, period=H)
    tm.add_node(1, delay=pmf((4, 1.0)), next=[2, 3], probabilities=[1 - p_loss, p_loss], execute=2)
    tm.add_node(2, execute=3).add_node(3)
    ref = reference([(1 - p_loss, 4 * DELTA, True), (p_loss, 4 * DELTA, False)])
    assert tm.cost().cost_rate == pytest.approx(ref, rel=1e-9)
    # the direct solve and the iteration find the same fixed point
    solved, iterated = tm.cost(method="solve"), tm.cost(method="iterate")
    assert solved.iterations == 0 and iterated.iterations > 10
    assert iterated.cost_rate == pytest.approx(solved.cost_rate, rel=1e-9)
    assert 0.0 < iterated.spectral_radius < 1.0 and solved.spectral_radius == pytest.approx(
        iterated.spectral_radius, rel=0.05)
    assert ref > reference([(1.0, 4 * DELTA, True)])


def test_an_unstable_timing_returns_inf_and_says_so():
    # losing 10 % of the controls is fine (above); losing 95 % destabilises this servo
    tm = lq.TimingModel(servo_loop(), delta=DELTA, period=H)
    tm.add_node(1, delay=pmf((4, 1.0)), next=[2, 3], probabilities=[0.05, 0.95], execute=2)
    tm.add_node(2, execute=3).add_node(3)
    got = tm.cost()
    assert got.cost_rate == math.inf and not got.stable and "not mean-square stable" in got.note
    assert got.spectral_radius > 1.0 and "spectral radius of the second-moment map" in got.note
    it = tm.cost(method="iterate", max_iterations=20_000)
    assert it.cost_rate == math.inf and it.spectral_radius == pytest.approx(got.spectral_radius, rel=0.01)
    slow = lq.periodic_cost(servo_loop(), [lq.Execute(2), lq.Wait(0.0), lq.Execute(3), lq.Wait(0.2)])
    assert slow.cost_rate == math.inf and slow.spectral_radius > 1 and "spectral radius" in slow.note


def test_an_aperiodic_model_alternating_intervals():
    # aperiodic: sample+control, wait 3 grains, sample+control, wait 7 grains, repeat --
    # the same as the periodic schedule of period 10 grains with two updates
    tm = lq.TimingModel(servo_loop(), delta=DELTA)
    tm.add_node("a", delay=pmf((3, 1.0)), next="b", execute=[2, 3])
    tm.add_node("b", delay=pmf((7, 1.0)), next="a", execute=[2, 3])
    sched = [lq.Execute(2), lq.Execute(3), lq.Wait(3 * DELTA), lq.Execute(2), lq.Execute(3), lq.Wait(7 * DELTA)]
    got, ref = tm.cost(), lq.periodic_cost(servo_loop(), sched)
    assert got.cost_rate == pytest.approx(ref.cost_rate, rel=1e-9)
    assert got.period == pytest.approx(H, rel=1e-12)
