"""Fly-crane dynamics (B.1.2, (4.10)-(4.12)): M, C q̇, g, energy, tensions, input modes."""

import math

import numpy as np
import pytest

from netcosim.plant import RK4, SolveIVP
from netcosim.plants.flycrane import SingularConfigurationError
from netcosim.plants.flycrane import configurations as C
from netcosim.plants.flycrane.input_modes import ForcePlant, KinematicPlant, VelocityTrackingPlant
from netcosim.plants.flycrane.rotations import body_rate_matrix, euler_zyx
from netcosim.sim import Simulation

RNG = np.random.default_rng(11)
_cache = {}


def get(name):
    if name not in _cache:
        _cache[name] = {"thesis": C.thesis_flycrane, "four": C.four_robot_nonsquare,
                        "sq22": lambda: C.square_family(2, 2)}[name]()
    return _cache[name]


@pytest.mark.parametrize("name", ["thesis", "four", "sq22"])
def test_mass_matrix_and_gravity_against_direct_construction(name):
    sys = get(name)
    d, mp = sys.dynamics, sys.mass
    pc = list(sys.pivot_cols)
    for q in sys.random_configurations(RNG, 3, spread=0.4):
        A = sys.jacobian(q)
        P = np.zeros((3, sys.m))
        P[:, pc[:3]] = np.eye(3)
        E = np.zeros((3, sys.m))
        E[:, pc[3:]] = np.asarray(body_rate_matrix(q[pc[4]], q[pc[5]]))
        M = mp.platform_mass * P.T @ P + E.T @ np.asarray(mp.platform_inertia) @ E
        g = mp.g * mp.platform_mass * P[2]
        for i, r in enumerate(sys.rows):
            M += mp.robot_masses[i] * A[list(r)].T @ A[list(r)]
            g += mp.g * mp.robot_masses[i] * A[r[2]]
        Md = d.mass_matrix(q)
        np.testing.assert_allclose(Md, M, atol=1e-12)
        assert np.linalg.eigvalsh(Md).min() > 0
        np.testing.assert_allclose(d.gravity(q), g, atol=1e-12)


def test_coriolis_from_finite_differences_of_M():
    sys = get("four")
    d = sys.dynamics
    q = sys.random_configurations(RNG, 1, spread=0.4)[0]
    qd = RNG.normal(size=sys.m)
    h = 1e-6
    Mdot = (d.mass_matrix(q + h * qd) - d.mass_matrix(q - h * qd)) / (2 * h)
    dKdq = np.array([(qd @ d.mass_matrix(q + h * e) @ qd - qd @ d.mass_matrix(q - h * e) @ qd) / (4 * h)
                     for e in np.eye(sys.m)])
    np.testing.assert_allclose(d.coriolis(q, qd), Mdot @ qd - dKdq, atol=1e-7)
    # C q̇ is quadratic in q̇
    np.testing.assert_allclose(d.coriolis(q, 2 * qd), 4 * d.coriolis(q, qd), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", ["thesis", "four"])
def test_free_dynamics_conserve_energy(name):
    sys = get(name)
    d = sys.dynamics
    plant = ForcePlant(sys)
    x0 = plant.initial_state(sys.q_nominal, RNG.normal(scale=0.5, size=sys.m))
    zero = np.zeros(sys.n)
    ig = SolveIVP(method="DOP853", rtol=1e-12, atol=1e-12)
    E0 = sum(d.energy(x0[:sys.m], x0[sys.m:]))
    x, t = x0, 0.0
    for t1 in (2.5, 5.0, 7.5, 10.0):
        _, x, _ = ig.integrate(lambda t, x: plant.f(t, x, zero, None), t, x, t1, [])
        t = t1
        K, U = d.energy(x[:sys.m], x[sys.m:])
        assert abs(K + U - E0) <= 1e-6 * abs(E0)
    assert x[sys.pivot_cols[2]] < x0[sys.pivot_cols[2]] - 400  # it really fell for 10 s


def test_gravity_compensated_motion_conserves_kinetic_energy():
    sys = get("thesis")
    d = sys.dynamics
    plant = ForcePlant(sys)
    x0 = plant.initial_state(sys.q_nominal, RNG.normal(scale=0.4, size=sys.m))
    m = sys.m

    def rhs(t, x):
        Fg = d.gravity_compensation(x[:m])
        return plant.f(t, x, Fg, None)
    K0 = d.energy(x0[:m], x0[m:])[0]
    _, x, _ = SolveIVP(method="DOP853", rtol=1e-12, atol=1e-12).integrate(rhs, 0.0, x0, 2.0, [])
    assert d.energy(x[:m], x[m:])[0] == pytest.approx(K0, rel=1e-6)
    # and A_q^T F_g = g(q) (the compensation is exact), with minimum norm
    for q in sys.random_configurations(RNG, 3):
        Fg = np.asarray(d.gravity_compensation_fun(q)).ravel()
        np.testing.assert_allclose(sys.jacobian(q).T @ Fg, d.gravity(q), atol=1e-11)


def test_hover_tensions_match_statics():
    sys = get("thesis")
    d = sys.dynamics
    q = sys.q_nominal
    Fg = np.asarray(d.gravity_compensation_fun(q)).ravel()
    qdd = d.accelerations(q, np.zeros(9), Fg)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-12)
    t = d.tensions(q, np.zeros(9), qdd, Fg)
    a = math.radians(75)
    sin_beta = math.sqrt(1 - (0.5 / 1.5) ** 2)
    expected = sys.mass.platform_mass * sys.mass.g / (6 * sin_beta * math.sin(a))
    np.testing.assert_allclose(t, expected, rtol=1e-12)
    # the robots carry their own weight plus the platform: total lift = total weight
    assert Fg[2::3].sum() == pytest.approx((sys.mass.platform_mass + 3 * 1.03) * sys.mass.g, rel=1e-12)


@pytest.mark.parametrize("name", ["thesis", "sq22"])
def test_tensions_satisfy_newton_euler_on_the_platform(name):
    # The cables are the only forces on the platform besides gravity: their resultant
    # must equal m_V (p̈_V + g e3) and their moment I ω̇ + ω × I ω (body frame).
    sys = get(name)
    d, mp = sys.dynamics, sys.mass
    m, pc = sys.m, list(sys.pivot_cols)
    I = np.asarray(mp.platform_inertia)
    for q in sys.random_configurations(RNG, 3, spread=0.3):
        qd = RNG.normal(scale=0.5, size=m)
        F = RNG.normal(scale=3.0, size=sys.n) + np.asarray(d.gravity_compensation_fun(q)).ravel()
        qdd = d.accelerations(q, qd, F)
        t = d.tensions(q, qd, qdd, F)
        res = np.asarray(d.tension_residual_fun(q, qd, qdd, F)).ravel()
        assert np.max(np.abs(res)) < 1e-9
        R = np.asarray(euler_zyx(*q[pc[3:]]))
        p = sys.h(q).reshape(sys.N, 3)
        force, moment, k = np.zeros(3), np.zeros(3), 0
        for i, att in enumerate(sys.attachments):
            for anchor in att.anchors:
                r = R @ anchor
                u = p[i] - (q[pc[:3]] + r)
                f = t[k] * u / np.linalg.norm(u)
                force += f
                moment += np.cross(r, f)
                k += 1
        np.testing.assert_allclose(force, mp.platform_mass * (qdd[pc[:3]] + [0, 0, mp.g]), atol=1e-9)
        eta, deta, ddeta = q[pc[3:]], qd[pc[3:]], qdd[pc[3:]]
        E = lambda e: np.asarray(body_rate_matrix(e[1], e[2]))  # noqa: E731
        h = 1e-6
        Edot = (E(eta + h * deta) - E(eta - h * deta)) / (2 * h)
        w = E(eta) @ deta
        wdot = E(eta) @ ddeta + Edot @ deta
        np.testing.assert_allclose(R.T @ moment, I @ wdot + np.cross(w, I @ w), atol=1e-7)


def _rk4(plant, x0, u, T, dt):
    _, x, _ = RK4(dt=dt).integrate(lambda t, x: plant.f(t, x, u, None), 0.0, x0, T, [])
    return x


def test_velocity_tracking_converges_to_kinematic_model_as_alpha_grows():
    # §4.3: with gravity compensation and F = -alpha (p_dot - u), q_dot -> A^+ u.
    sys = get("thesis")
    m = sys.m
    qd_des = np.zeros(m)
    qd_des[:3] = 0.3
    qd_des[sys.pivot_cols[2]] = 0.2
    u = sys.jacobian(sys.q_nominal) @ qd_des
    errs = []
    for alpha in (10.0, 100.0, 1000.0):
        plant = VelocityTrackingPlant(sys, alpha)
        x = _rk4(plant, plant.initial_state(sys.q_nominal), u, 0.3, 2e-4)
        errs.append(np.linalg.norm(x[m:] - sys.pinv(x[:m]) @ u))
    assert errs[1] < errs[0] / 5 and errs[2] < errs[1] / 5
    assert errs[2] < 1e-2 * np.linalg.norm(qd_des)


def test_infeasible_velocity_is_projected_like_fig_4_4():
    # Four robots (n = 12 > m = 10): u = A_q0 q_dot_0 is feasible at q0 only.  As the
    # configuration moves (angles past 90 deg, platform yawing), u leaves Im A_q and the
    # robots realise Pi_q u instead (4.4)-(4.5).
    sys = get("four")
    m, pc = sys.m, sys.pivot_cols
    qd0 = np.zeros(m)
    qd0[:4] = [0.5, 0.3, 0.5, 0.3]
    qd0[pc[2]], qd0[pc[3]] = 0.2, 0.3  # climb and yaw
    u = sys.jacobian(sys.q_nominal) @ qd0
    plant = VelocityTrackingPlant(sys, 500.0)
    kin = KinematicPlant(sys)
    x = plant.initial_state(sys.q_nominal)
    qk = kin.initial_state(sys.q_nominal)
    gaps = []
    for k in range(6):
        x = RK4(dt=5e-4).integrate(lambda t, x: plant.f(t, x, u, None), 0.2 * k, x, 0.2 * (k + 1), [])[1]
        qk = RK4(dt=5e-3).integrate(lambda t, q: kin.f(t, q, u, None), 0.2 * k, qk, 0.2 * (k + 1), [])[1]
        q = x[:m]
        pdot = sys.jacobian(q) @ x[m:]
        Pu = sys.projector(q) @ u
        gaps.append(np.linalg.norm(u - Pu) / np.linalg.norm(u))
        assert np.linalg.norm(pdot - Pu) < 0.005 * np.linalg.norm(u)
        assert np.linalg.norm(pdot - Pu) < 0.05 * np.linalg.norm(pdot - u)
    assert max(gaps) > 0.5  # u became strongly infeasible
    assert np.degrees(x[:4]).max() > 100
    np.testing.assert_allclose(x[:m], qk, atol=5e-3)  # dynamics ~ kinematic model (4.6), O(1/alpha)
    # the rejected part of the force, -alpha (Pi_q u - u), lies in ker A_q^T: internal
    # forces only, which here push on cables -> the taut-cable model is flagged invalid
    assert plant.min_tension(x, u) < 0


def test_cable_slack_event_fires_when_tension_reaches_zero():
    sys = get("thesis")
    d = sys.dynamics
    plant = ForcePlant(sys)
    x0 = plant.initial_state(sys.q_nominal)
    Fg0 = np.asarray(d.gravity_compensation_fun(sys.q_nominal)).ravel()
    down = np.tile([0.0, 0.0, -1.0], 3)
    F = lambda t: Fg0 + 20.0 * t * down  # noqa: E731  robots pull down harder and harder
    ev = plant.events[0]
    assert ev.name == "cable_slack"
    gs = [(lambda t, x: ev.g(t, x, F(t), None), ev.direction)]
    t_ev, x_ev, j = RK4(dt=1e-3, xtol=1e-13).integrate(lambda t, x: plant.f(t, x, F(t), None), 0.0, x0, 2.0, gs)
    assert j == 0 and 0.0 < t_ev < 2.0
    assert abs(plant.min_tension(x_ev, F(t_ev))) < 1e-6
    x_before = RK4(dt=1e-3).integrate(lambda t, x: plant.f(t, x, F(t), None), 0.0, x0, 0.9 * t_ev, [])[1]
    assert plant.min_tension(x_before, F(0.9 * t_ev)) > 0
    # symmetric pull: the platform falls at g exactly when the cables go slack
    qdd = d.accelerations(x_ev[:9], x_ev[9:], F(t_ev))
    assert qdd[sys.pivot_cols[2]] == pytest.approx(-sys.mass.g, abs=1e-4)


def test_plants_in_a_simulation_with_noisy_measurements():
    sys = get("thesis")
    sim = Simulation(seed=3)
    plant = KinematicPlant(sys, noise_std=0.01, rng=sim.rng("flycrane.pose"))
    qd = np.zeros(9)
    qd[sys.pivot_cols[0]] = 0.1
    u = sys.jacobian(sys.q_nominal) @ qd  # a pure translation stays feasible
    inst = sim.plant(plant, plant.initial_state(sys.q_nominal), integrator=RK4(dt=1e-2), log="none")
    inst.input().write(u)
    sim.run(until=1.0)
    q_true = sys.q_nominal + qd * 1.0
    np.testing.assert_allclose(inst.state, q_true, atol=1e-12)
    ys = np.array([inst.output().read() for _ in range(400)])
    np.testing.assert_allclose(ys[:, :9], np.tile(q_true, (400, 1)), atol=1e-12)
    noise = ys[:, 9:] - q_true
    assert abs(noise.std() - 0.01) < 0.001 and abs(noise.mean()) < 0.002


def test_bad_plant_arguments_and_singular_start():
    sys = get("thesis")
    with pytest.raises(ValueError, match="alpha must be a positive number.*got -1"):
        VelocityTrackingPlant(sys, -1.0)
    with pytest.raises(ValueError, match="rng"):
        KinematicPlant(sys, noise_std=0.1)
    with pytest.raises(ValueError, match="noise_std must be finite and non-negative, got -0.1"):
        KinematicPlant(sys, noise_std=-0.1, rng=np.random.default_rng(0))
    q_sing = sys.q_from([0, 0, 0], [0] * 6)
    with pytest.raises(SingularConfigurationError, match="q0"):
        KinematicPlant(sys).initial_state(q_sing)
    with pytest.raises(SingularConfigurationError, match="q0"):
        ForcePlant(sys).initial_state(q_sing)
    with pytest.raises(ValueError, match="no mechanical model"):
        C.formation_2d().dynamics
