"""Feedback linearization (2.14)-(2.16) with PID + feed-forward, and the C² interpolator."""

import math

import numpy as np
import pytest

from netcosim.controllers.landing import (
    C2Interpolator,
    FeedbackLinearization,
    PIDGains,
    SingularityError,
    quintic_coefficients,
)
from netcosim.plants.tethered_uav import TetheredUAVParams, ddphi_ddtheta, force_dynamics

P = TetheredUAVParams()


def test_inversion_gives_the_requested_accelerations():
    fl = FeedbackLinearization(P, saturate=False)
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = np.array([rng.uniform(-0.6, 0.2), rng.normal(), rng.uniform(-0.2, 0.7), rng.normal()])
        ubar = rng.normal(size=2) * 5.0
        f_R, tau_R = fl.invert(x, ubar)
        acc = ddphi_ddtheta(x[0], x[1], x[2], f_R, tau_R, P)  # (2.14) forward
        np.testing.assert_allclose(acc, ubar, atol=1e-12)


def _closed_loop(fl, ref, T=1.0, x0=(0.0, 0.0, 0.0, 0.0), f_ext=None, dt_sim=1e-4, lead=0.0):
    """Force model (2.3) under the 500 Hz FL with ZOH; returns times, states, inputs."""
    x = np.array(x0, dtype=float)
    n_sub = int(round(fl.dt / dt_sim))
    ts, xs, us = [], [], []
    for k in range(int(round(T / fl.dt))):
        t = k * fl.dt
        pos, vel, _ = ref(t)
        acc = ref(t + lead)[2]
        u = fl(x, pos, vel, acc)
        for _ in range(n_sub):
            def f(xx):
                return force_dynamics(xx, u, P, f_ext)
            k1 = f(x)
            k2 = f(x + 0.5 * dt_sim * k1)
            k3 = f(x + 0.5 * dt_sim * k2)
            k4 = f(x + dt_sim * k3)
            x = x + dt_sim / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        ts.append(t + fl.dt)
        xs.append(x.copy())
        us.append(u)
    return np.array(ts), np.array(xs), np.array(us)


def _sine_ref(t):
    w = 2 * math.pi * 1.0
    a = np.array([0.05, 0.3])
    return a * np.sin(w * t) - np.array([0.2, 0.0]), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)


def test_tracks_a_smooth_reference_on_the_force_model():
    fl = FeedbackLinearization(P, 0.002, gains_phi=PIDGains.triple_pole(60), gains_theta=PIDGains.triple_pole(60))
    ts, xs, us = _closed_loop(fl, _sine_ref, x0=(-0.2, 0.05 * 2 * math.pi, 0.0, 0.3 * 2 * math.pi), lead=0.001)
    pos = np.array([_sine_ref(t)[0] for t in ts])
    err = np.abs(xs[:, [0, 2]] - pos)
    assert err[len(ts) // 2:].max() < 2e-4  # rad, after the start-up
    assert fl.n_saturated == 0


def test_mid_period_feed_forward_reduces_the_hold_error():
    errs = []
    for lead in (0.0, 0.001):
        fl = FeedbackLinearization(P, 0.002, gains_phi=PIDGains.triple_pole(25), gains_theta=PIDGains.triple_pole(25))
        ts, xs, _ = _closed_loop(fl, _sine_ref, x0=(-0.2, 0.05 * 2 * math.pi, 0.0, 0.3 * 2 * math.pi), lead=lead)
        pos = np.array([_sine_ref(t)[0] for t in ts])
        errs.append(np.sqrt(np.mean((xs[:, [0, 2]] - pos) ** 2)))
    assert errs[1] < 0.3 * errs[0]


def test_integral_action_removes_a_constant_disturbance():
    hold = lambda t: (np.array([-0.3, 0.4]), np.zeros(2), np.zeros(2))  # noqa: E731
    fl = FeedbackLinearization(P, 0.002)
    x0 = (-0.3, 0.0, 0.4, 0.0)
    ts, xs, _ = _closed_loop(fl, hold, T=2.0, x0=x0, f_ext=np.array([2.0, 0.0]), dt_sim=5e-4)
    assert abs(xs[-1, 0] + 0.3) < 1e-5
    fl_pd = FeedbackLinearization(P, 0.002, gains_phi=PIDGains(kp=1875.0, kd=75.0, ki=0.0))
    _, xs_pd, _ = _closed_loop(fl_pd, hold, T=2.0, x0=x0, f_ext=np.array([2.0, 0.0]), dt_sim=5e-4)
    assert abs(xs_pd[-1, 0] + 0.3) > 1e-4  # without K_I a steady-state offset remains


def test_outputs_are_saturated_to_table_2_1():
    fl = FeedbackLinearization(P, 0.002)
    u = fl([0.0, 0.0, 0.0, 0.0], [1.0, 1.0], [0.0, 0.0], [100.0, 100.0])
    np.testing.assert_allclose(u, [15.0, 1.2])
    u = fl([0.0, 0.0, 0.0, 0.0], [-1.0, -1.0], [0.0, 0.0], [-100.0, -100.0])
    np.testing.assert_allclose(u, [0.0, -1.2])
    assert fl.n_saturated == 2
    # anti-windup: the integral did not move while saturated in the error's direction
    np.testing.assert_allclose(fl.integral, [0.0, 0.0])


def test_singularity_raises_naming_the_configuration():
    fl = FeedbackLinearization(P, 0.002)
    with pytest.raises(SingularityError, match=r"cos\(phi \+ theta\) = .* phi = 0.5 rad, theta = 1.0717"):
        fl([0.5, 0.0, math.pi / 2 - 0.5 + 1e-3, 0.0], [0.5, 1.0], [0.0, 0.0], [0.0, 0.0])
    sat = FeedbackLinearization(P, 0.002, on_singular="saturate")
    u = sat([0.5, 0.0, math.pi / 2 - 0.5, 0.0], [0.5, 1.0], [0.0, 0.0], [0.0, 0.0])
    assert np.all(np.isfinite(u)) and 0.0 <= u[0] <= 15.0
    assert sat.n_singular == 1


@pytest.mark.parametrize("kw, match", [
    (dict(dt=0.0), "dt must be a positive number of seconds, got 0.0"),
    (dict(dt=-0.002), "got -0.002"),
    (dict(cos_min=1.5), "cos_min must lie in"),
    (dict(on_singular="ignore"), "on_singular must be 'raise' or 'saturate', got 'ignore'"),
])
def test_bad_controller_arguments(kw, match):
    with pytest.raises(ValueError, match=match):
        FeedbackLinearization(P, **kw)


def test_bad_gains_and_states():
    with pytest.raises(ValueError, match="PIDGains.kp must be a finite non-negative number, got -1.0"):
        PIDGains(kp=-1.0, kd=1.0, ki=1.0)
    with pytest.raises(ValueError, match="state must start with 4 finite values"):
        FeedbackLinearization(P)([0.0, np.nan, 0.0, 0.0], [0, 0], [0, 0], [0, 0])


# ---------------------------------------------------------------------------
# Interpolator
# ---------------------------------------------------------------------------

def test_quintic_matches_both_ends():
    c = quintic_coefficients(0.01, 1.0, -2.0, 30.0, 0.98, -1.5, -10.0)
    s = 0.01
    pos = sum(c[i] * s ** i for i in range(6))
    vel = sum(i * c[i] * s ** (i - 1) for i in range(1, 6))
    acc = sum(i * (i - 1) * c[i] * s ** (i - 2) for i in range(2, 6))
    assert (pos, vel, acc) == pytest.approx((0.98, -1.5, -10.0), rel=1e-9)


def test_interpolator_reproduces_a_quintic_trajectory_exactly():
    def q(t):
        return (0.3 - t + 2 * t ** 2 - 5 * t ** 3 + 4 * t ** 4 - t ** 5,
                -1 + 4 * t - 15 * t ** 2 + 16 * t ** 3 - 5 * t ** 4,
                4 - 30 * t + 48 * t ** 2 - 20 * t ** 3)
    it = C2Interpolator(1)
    it.reset(0.0, [q(0)[0]], [q(0)[1]], [q(0)[2]])
    it.update(0.0, 0.5, [q(0.5)[0]], [q(0.5)[1]], [q(0.5)[2]])
    for t in np.linspace(0, 0.5, 11):
        p, v, a = it.evaluate(t)
        assert (p[0], v[0], a[0]) == pytest.approx(q(t), abs=1e-12)


def test_interpolator_is_c2_across_late_updates():
    it = C2Interpolator(2)
    it.reset(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    rng = np.random.default_rng(0)
    t = 0.0
    for k in range(20):
        t_update = t + rng.uniform(0.0, 0.004)  # the new target arrives late
        before = it.evaluate(t_update)
        it.update(t_update, t + 0.01, rng.normal(size=2), rng.normal(size=2), rng.normal(size=2))
        after = it.evaluate(t_update)
        for b, a in zip(before, after):
            np.testing.assert_allclose(a, b, atol=1e-12)
        t += 0.01
    # past the target the reference continues with constant acceleration
    p, v, a = it.evaluate(t)
    p2, v2, a2 = it.evaluate(t + 0.002)
    np.testing.assert_allclose(a2, a)
    np.testing.assert_allclose(v2, v + 0.002 * a)


def test_interpolator_bad_input():
    it = C2Interpolator(2)
    with pytest.raises(RuntimeError, match="before reset"):
        it.evaluate(0.0)
    it.reset(0.0, [0.0, 0.0])
    with pytest.raises(ValueError, match=r"target time 0.01 s must be after the update time 0.02 s"):
        it.update(0.02, 0.01, [0, 0], [0, 0], [0, 0])
    with pytest.raises(ValueError, match=r"pos must be 1 x 2 finite values \(one row per knot\), got \[0.0\]"):
        it.update(0.0, 0.01, [0.0], [0, 0], [0, 0])
    with pytest.raises(ValueError, match="number of channels must be a positive integer, got 0"):
        C2Interpolator(0)


def test_interpolator_follows_the_plan_knots_after_a_late_update():
    # knots sampled from a smooth trajectory; the update comes 3 ms after the sample
    def f(t):
        return np.array([math.sin(5 * t)]), np.array([5 * math.cos(5 * t)]), np.array([-25 * math.sin(5 * t)])
    it = C2Interpolator(1)
    it.reset(0.0, *f(0.0))
    worst = 0.0
    for k in range(30):
        ts = 0.01 * k
        knots = ts + 0.01 * np.arange(1, 4)
        it.update(ts + 0.003, knots, [f(t)[0] for t in knots], [f(t)[1] for t in knots], [f(t)[2] for t in knots])
        for t in (ts + 0.004, ts + 0.012, ts + 0.02):  # inside, and past the next sample
            worst = max(worst, abs(it.evaluate(t)[2][0] - f(t)[2][0]))
    assert worst < 0.5  # rad/s², 2 % of the acceleration amplitude of 25
    assert it.end_time == pytest.approx(0.32)
    with pytest.raises(ValueError, match=r"knot times must increase, got \[0.5, 0.4\]"):
        it.update(0.3, [0.5, 0.4], [[0.0], [0.0]], [[0.0], [0.0]], [[0.0], [0.0]])
