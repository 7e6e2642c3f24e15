"""Tethered UAV (thesis ch. 2): model equations, stress, geometry, landers, wind."""

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from netcosim.plant import RK4, SolveIVP
from netcosim.plants.tethered_uav import (
    TetheredUAV,
    TetheredUAVParams,
    cable_stress,
    casadi_model,
    hover_thrust,
    input_map,
    lander_reaction,
    propeller_forces,
    wind,
    wind_disturbance,
)
from netcosim.sim import Simulation

P = TetheredUAVParams()
RNG = np.random.default_rng(4)


def random_states(n):
    x = RNG.uniform([-0.4, -2, -0.8, -3, 0, -1.2], [1.2, 2, 0.8, 3, 15, 1.2], size=(n, 6))
    return x


@pytest.mark.parametrize("name,value", [("m_B", 0.0), ("J_B", -1e-3), ("l", 0.0), ("d", -0.1),
                                        ("lander_height", 0.0), ("k_el", -1.0), ("alpha", 2.0),
                                        ("g", float("nan"))])
def test_bad_params_raise_naming_the_value(name, value):
    with pytest.raises(ValueError, match=name):
        TetheredUAVParams(**{name: value})


def test_table_2_1_consistency():
    # (2.1) with each propeller at f_R,max/2 gives exactly the torque bound.
    f1, f2 = propeller_forces(P.f_R_max / 2, P.tau_R_max, P)
    assert f1 == pytest.approx(0.0, abs=1e-12) and f2 == pytest.approx(P.f_R_max / 2)
    assert input_map(f1, f2, P) == pytest.approx((P.f_R_max / 2, P.tau_R_max))
    assert P.m_B * P.g < P.f_R_max


def test_casadi_functions_match_float_evaluation():
    m = casadi_model(P)
    assert casadi_model(P) is m  # built once, cached
    for x in random_states(20):
        u = RNG.normal(size=2)
        # (2.5) by hand
        a1, a2, a3 = -P.g / P.l, 1 / (P.m_B * P.l), 1 / P.J_B
        ref = [x[1], a1 * math.cos(x[0]) + a2 * math.cos(x[0] + x[2]) * x[4], x[3], a3 * x[5], u[0], u[1]]
        np.testing.assert_allclose(np.array(m.f_smooth(x, u)).ravel(), ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.array(m.f_force(x[:4], x[4:])).ravel(), ref[:4], rtol=0, atol=1e-12)
        fl = x[1] ** 2 / a2 + a1 / a2 * math.sin(x[0]) + math.sin(x[0] + x[2]) * x[4]
        assert float(m.stress(x)) == pytest.approx(fl, abs=1e-12)
        assert float(m.stress_force(x[:4], x[4:])) == pytest.approx(fl, abs=1e-12)
        # the plant (numeric path of the same equations) agrees with the simulation Function
        d = RNG.normal(size=2)
        sys = TetheredUAV(P)
        np.testing.assert_allclose(sys.f(0.0, x, np.r_[u, d], P),
                                   np.array(m.f_sim_smooth(x, u, d)).ravel(), atol=1e-12)
    # symbolic reuse on MX: the same equations build an MX graph
    xm, um = ca.MX.sym("x", 6), ca.MX.sym("u", 2)
    fm = ca.Function("fm", [xm, um], [m.f_smooth(xm, um)])
    x = random_states(1)[0]
    np.testing.assert_allclose(np.array(fm(x, [1, 2])), np.array(m.f_smooth(x, [1, 2])), atol=1e-14)


@pytest.mark.parametrize("theta", [0.0, 0.25, -0.3])
def test_hover_is_an_equilibrium(theta):
    phi = 0.4
    f_R = hover_thrust(phi, theta, P)
    if theta == 0.0:
        assert f_R == pytest.approx(P.m_B * P.g, rel=1e-14)
    x0 = [phi, 0.0, theta, 0.0, f_R, 0.0]
    sys = TetheredUAV(P)
    assert np.max(np.abs(sys.f(0, np.array(x0), np.zeros(4), P))) < 1e-12
    sim = Simulation()
    plant = sim.plant(sys, x0, integrator=RK4(dt=1e-3), log="none")
    sim.run(until=2.0)
    np.testing.assert_allclose(plant.state, x0, atol=1e-10)


def test_stress_equals_newton_euler_tension():
    # Independent balance on the point mass: m p_ddot = gravity + thrust + external + cable,
    # with the cable force along -r.  The model's phi_ddot fixes p_ddot; the force left
    # over must be purely radial and its magnitude is f_L.
    sys = TetheredUAV(P, inputs="forces", landers=False)
    for x6 in random_states(25):
        x, u = x6[:4], x6[4:]
        d = RNG.normal(scale=2.0, size=2)
        phi, dphi, th = x[0], x[1], x[2]
        ddphi = sys.f(0.0, x, np.r_[u, d], P)[1]
        r = np.array([math.cos(phi), math.sin(phi)])
        t = np.array([-math.sin(phi), math.cos(phi)])
        p_ddot = P.l * ddphi * t - P.l * dphi ** 2 * r
        thrust = u[0] * np.array([math.sin(th), math.cos(th)])
        cable = P.m_B * p_ddot - np.array([0.0, -P.m_B * P.g]) - thrust - d
        assert abs(cable @ t) < 1e-10
        f_L = sys.h(0.0, x, np.r_[u, d], P)[sys.output_names.index("f_L")]
        assert f_L == pytest.approx(-(cable @ r), abs=1e-10)
        if not d.any():
            assert f_L == pytest.approx(float(casadi_model(P).stress(x6)), abs=1e-12)


def test_propeller_ground_distances_match_geometry():
    m = casadi_model(P)
    for alpha in (0.0, math.pi / 6, -0.2):
        e = np.array([math.cos(alpha), -math.sin(alpha)])  # slope direction through O_W
        for x in random_states(15):
            phi, th = x[0], x[2]
            pB = P.l * np.array([math.cos(phi), math.sin(phi)])
            xB = np.array([math.cos(th), -math.sin(th)])
            dists = []
            for P_i in (pB + P.d * xB, pB - P.d * xB):
                foot = (P_i @ e) * e
                sign = 1.0 if (P_i - foot)[1] > 0 else -1.0  # above the line when z is higher
                dists.append(sign * np.linalg.norm(P_i - foot))
            np.testing.assert_allclose(np.array(m.propeller_ground_distances(x, alpha)).ravel(), dists,
                                       atol=1e-12)


def test_input_map_matches_moment_of_propeller_thrusts():
    m = casadi_model(P)
    for f1, f2, th in RNG.uniform([0, 0, -1], [7.5, 7.5, 1], size=(10, 3)):
        f_R, tau = np.array(m.input_map([f1, f2])).ravel()
        xB, zB = np.array([math.cos(th), -math.sin(th)]), np.array([math.sin(th), math.cos(th)])
        # moment about +y_W of force F at arm r in the (x, z) plane: r_z F_x - r_x F_z
        mom = lambda r, F: r[1] * F[0] - r[0] * F[1]  # noqa: E731
        assert tau == pytest.approx(mom(P.d * xB, f1 * zB) + mom(-P.d * xB, f2 * zB), abs=1e-12)
        assert f_R == pytest.approx(f1 + f2)
        np.testing.assert_allclose(np.array(m.propeller_forces([f_R, tau])).ravel(), [f1, f2], atol=1e-12)


def test_smooth_and_force_models_agree_with_constant_thrust():
    x0 = [0.2, 0.5, 0.1, -0.4]
    u = [11.0, 0.05]
    sys6 = TetheredUAV(P, landers=False)
    sys4 = TetheredUAV(P, inputs="forces", landers=False)
    ig = RK4(dt=1e-3)
    _, x6, _ = ig.integrate(lambda t, x: sys6.f(t, x, np.zeros(4), P), 0.0, np.r_[x0, u], 0.5, [])
    _, x4, _ = ig.integrate(lambda t, x: sys4.f(t, x, np.r_[u, 0, 0], P), 0.0, np.array(x0), 0.5, [])
    np.testing.assert_allclose(x6[:4], x4, atol=1e-13)
    np.testing.assert_allclose(x6[4:], u, atol=0)


def test_wind_profile_and_attitude_independence():
    assert wind(0.0, P)[0] == 0.0
    assert wind(P.wind_pulse_duration / 2, P)[0] == pytest.approx(P.wind_pulse_amplitude, rel=1e-15)
    assert wind(P.wind_pulse_duration / 4, P)[0] == pytest.approx(P.wind_pulse_amplitude / 2, rel=1e-12)
    assert wind(P.wind_pulse_duration, P)[0] == pytest.approx(0.0, abs=1e-15)
    assert wind(0.09, P).tolist() == [0.0, 0.0]
    t = P.wind_sine_start + 0.25 / P.wind_sine_frequency
    assert wind(t, P)[0] == pytest.approx(P.wind_sine_amplitude, rel=1e-12)
    # wind acts at the CoM: attitude dynamics unchanged, elevation dynamics changed
    sys = TetheredUAV(P, landers=False)
    x = np.array([0.3, 0.0, 0.2, 0.0, 9.0, 0.3])
    a = sys.f(0, x, np.r_[0, 0, 0, 0], P)
    b = sys.f(0, x, np.r_[0, 0, wind(P.wind_pulse_duration / 2, P)], P)
    assert a[3] == b[3]
    assert b[1] - a[1] == pytest.approx(-math.sin(0.3) * P.wind_pulse_amplitude / (P.m_B * P.l), rel=1e-12)


def test_wind_edges_are_integration_events():
    sim = Simulation()
    x0 = [0.4, 0.0, 0.0, 0.0, P.m_B * P.g, 0.0]
    plant = sim.plant(TetheredUAV(P), x0, integrator=RK4(dt=3e-3), disturbance=wind_disturbance(P),
                      log="none")
    sim.run(until=0.2)
    times = dict((n, t) for t, n in plant.event_log)
    assert times["wind_pulse_end"] == pytest.approx(P.wind_pulse_duration, abs=1e-11)
    assert times["wind_sine_start"] == pytest.approx(P.wind_sine_start, abs=1e-11)
    # the RK4 answer with restarts at the edges matches a tight reference
    ref = solve_ivp(lambda t, x: TetheredUAV(P).f(t, x, np.r_[0, 0, wind(t, P)], P), (0, 0.05), x0,
                    rtol=1e-12, atol=1e-12)
    ref = solve_ivp(lambda t, x: TetheredUAV(P).f(t, x, np.r_[0, 0, wind(t, P)], P), (0.05, 0.2),
                    ref.y[:, -1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(plant.state, ref.y[:, -1], atol=1e-8)


def test_touchdown_event_at_first_contact_and_reaction_non_negative():
    # Thrust off: the vehicle swings down onto the slope.  Before contact the motion is
    # the free pendulum, so the first-contact instant is known from a tight reference.
    phi0 = -P.alpha + 0.35
    x0 = [phi0, 0.0, P.alpha, 0.0, 0.0, 0.0]
    phi_c = math.asin(P.lander_height / P.l) - P.alpha

    def pend(t, x):
        return [x[1], -P.g / P.l * math.cos(x[0])]
    ev = lambda t, x: x[0] - phi_c  # noqa: E731
    ev.terminal, ev.direction = True, -1
    ref = solve_ivp(pend, (0, 2), [phi0, 0.0], events=ev, rtol=1e-12, atol=1e-13)
    t_contact = ref.t_events[0][0]

    sim = Simulation()
    plant = sim.plant(TetheredUAV(P), x0, integrator=RK4(dt=1e-3), log_interval=2e-3)
    ys = []
    y = plant.output()

    def probe():
        while True:
            ys.append(y.read())
            yield sim.timeout(1e-3)
    sim.process(probe())
    sim.run(until=1.5)
    first = [t for t, n in plant.event_log if n == "touchdown"][0]
    assert first == pytest.approx(t_contact, abs=1e-8)
    assert [n for _, n in plant.event_log if n in ("touchdown", "liftoff")][0] == "touchdown"
    ys = np.array(ys)
    names = TetheredUAV(P).output_names
    f_rf = ys[:, names.index("f_RF")]
    assert np.all(f_rf >= 0.0) and f_rf.max() > 0.0
    # at rest on the landers the reaction balances the normal weight component, tension
    # takes the rest: lander compression = m g cos(phi) / k_el along the normal ...
    x_end = plant.state
    z_end = P.l * math.sin(x_end[0] + P.alpha)
    assert abs(x_end[1]) < 1e-3
    # static balance along the circle tangent: gravity vs lander reaction
    f_static = P.m_B * P.g * math.cos(x_end[0]) / math.cos(x_end[0] + P.alpha)
    assert float(lander_reaction(x_end[0], 0.0, P)) == pytest.approx(f_static, rel=2e-2)
    assert 0.0 < P.lander_height - z_end < 0.02


def test_contact_event_with_adaptive_integrator():
    x0 = [-P.alpha + 0.2, -0.5, P.alpha, 0.0, 0.0, 0.0]
    sim = Simulation()
    plant = sim.plant(TetheredUAV(P), x0, integrator=SolveIVP(rtol=1e-10, atol=1e-12), log="none")
    sim.run(until=0.3)
    assert plant.event_counts["touchdown"] >= 1
    t_first = [t for t, n in plant.event_log if n == "touchdown"][0]
    assert t_first < 0.3


def test_bad_system_arguments():
    with pytest.raises(ValueError, match="bogus"):
        TetheredUAV(P, inputs="bogus")
    with pytest.raises(ValueError, match="phi \\+ theta"):
        hover_thrust(0.5, math.pi / 2 - 0.5, P)
    assert cable_stress(0.0, 0.0, 0.0, 0.0, P) == 0.0
