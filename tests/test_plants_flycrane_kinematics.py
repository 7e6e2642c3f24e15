"""Fly-crane family kinematics: h(q), A_q (3.1)-(3.3), pseudo-inverse and projector (4.4)-(4.6)."""

import math

import casadi as ca
import numpy as np
import pytest

from netcosim.plants.flycrane import (
    ConfigurationDomainError,
    GeometryError,
    MultiRobotSystem,
    OneCable,
    SingularConfigurationError,
    TwoCable,
    plate_inertia,
)
from netcosim.plants.flycrane import configurations as C
from netcosim.plants.flycrane.rotations import body_rate_matrix, euler_zyx

RNG = np.random.default_rng(7)

SYSTEMS = {
    "thesis": (C.thesis_flycrane, 9, 9),
    "rig": (C.experimental_flycrane, 9, 9),
    "four": (C.four_robot_nonsquare, 12, 10),
    "sq_0_3": (lambda: C.square_family(0, 3), 9, 9),
    "sq_2_2": (lambda: C.square_family(2, 2), 12, 12),
    "sq_4_1": (lambda: C.square_family(4, 1), 15, 15),
    "sq_6_0": (lambda: C.square_family(6, 0), 18, 18),
    "formation": (C.formation_2d, 9, 9),
}
_cache = {}


def get(key):
    if key not in _cache:
        _cache[key] = SYSTEMS[key][0]()
    return _cache[key]


@pytest.mark.parametrize("key", SYSTEMS)
def test_dimensions_match_the_thesis(key):
    sys = get(key)
    assert (sys.n, sys.m) == SYSTEMS[key][1:]
    assert sys.jacobian(sys.q_nominal).shape == (sys.n, sys.m)
    assert sys.h(sys.q_nominal).shape == (sys.n,)


@pytest.mark.parametrize("key", SYSTEMS)
def test_jacobian_equals_central_differences(key):
    sys = get(key)
    eps = 1e-6
    for q in sys.random_configurations(RNG, 4, spread=0.3):
        A = sys.jacobian(q)
        fd = np.empty_like(A)
        for j in range(sys.m):
            dq = np.zeros(sys.m)
            dq[j] = eps
            fd[:, j] = (sys.h(q + dq) - sys.h(q - dq)) / (2 * eps)
        assert np.max(np.abs(A - fd)) < 1e-7


@pytest.mark.parametrize("key", SYSTEMS)
def test_zero_blocks_of_3_3_are_exact(key):
    sys = get(key)
    rows, cols, pivot = sys.block_indices()
    sp = sys.A_fun.sparsity_out(0)
    for q in sys.random_configurations(RNG, 3):
        A = sys.jacobian(q)
        for i, r in enumerate(rows):
            for j, c in enumerate(cols):
                blk = A[np.ix_(r, c)]
                if i != j:
                    assert np.all(blk == 0.0)
                else:
                    assert np.any(blk != 0.0)
    # the zeros are structural: CasADi does not even store them
    nnz_max = sum(len(r) * (len(c) + len(pivot)) for r, c in zip(rows, cols))
    assert sp.nnz() <= nnz_max


@pytest.mark.parametrize("key", [k for k in SYSTEMS if k != "formation"])
def test_cables_keep_their_length(key):
    sys = get(key)
    for q in sys.random_configurations(RNG, 5, spread=0.4):
        p = sys.h(q).reshape(sys.N, 3)
        qV = q[list(sys.pivot_cols)]
        R = np.asarray(euler_zyx(*qV[3:]))
        for i, a in enumerate(sys.attachments):
            for anchor, length in zip(a.anchors, a.lengths):
                assert np.linalg.norm(p[i] - (qV[:3] + R @ anchor)) == pytest.approx(length, abs=1e-12)


def _Rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _Ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _Rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_flycrane_matches_appendix_b_formula():
    # p_Ai = p_V + R_V R_Vi (l_C e2 + R_Ci l sin(beta) e3), R_Ci = R_x(-(pi/2 - alpha_i)) (B.1.1)
    for L in (1.5, 1.2):
        sys = C.thesis_flycrane(cable_length=L)
        l_C = 1.0 / (2 * math.sqrt(3))
        beta = math.acos(0.5 / L)
        for q in sys.random_configurations(RNG, 5, spread=0.5):
            qV = q[3:]
            RV = _Rz(qV[3]) @ _Ry(qV[4]) @ _Rx(qV[5])
            p = []
            for i in range(3):
                RVi = _Rz(2 * math.pi * i / 3)
                loc = (l_C * np.array([0, 1, 0])
                       + _Rx(-(math.pi / 2 - q[i])) @ (L * math.sin(beta) * np.array([0, 0, 1])))
                p.append(qV[:3] + RV @ RVi @ loc)
            np.testing.assert_allclose(sys.h(q), np.concatenate(p), atol=1e-13)
        assert sys.attachments[0].beta == pytest.approx(beta, abs=1e-12)


def test_formation_matches_section_3_2_2():
    sys = get("formation")
    for q in sys.random_configurations(RNG, 5, spread=0.5):
        xV, yV, phV = q[6:]
        R = np.array([[math.cos(phV), -math.sin(phV)], [math.sin(phV), math.cos(phV)]])
        for i in range(3):
            d, ph = q[2 * i], q[2 * i + 1]
            xy = np.array([xV, yV]) + R @ (d * np.array([math.cos(ph), math.sin(ph)]))
            np.testing.assert_allclose(sys.h(q)[3 * i:3 * i + 3], [*xy, ph], atol=1e-14)
    A = sys.jacobian(sys.q_nominal)
    # the appended rows pick phi_1, phi_2, phi_3 (the thesis's augmented Jacobian)
    for i in range(3):
        e = np.zeros(9)
        e[2 * i + 1] = 1.0
        np.testing.assert_array_equal(A[3 * i + 2], e)


@pytest.mark.parametrize("key", SYSTEMS)
def test_pseudo_inverse_and_projector(key):
    sys = get(key)
    for q in sys.random_configurations(RNG, 3):
        A, Ad, P = sys.jacobian(q), sys.pinv(q), sys.projector(q)
        np.testing.assert_allclose(Ad, np.linalg.pinv(A), atol=1e-10)
        np.testing.assert_allclose(Ad @ A, np.eye(sys.m), atol=1e-10)  # full column rank
        np.testing.assert_allclose(P @ P, P, atol=1e-10)
        np.testing.assert_allclose(P, P.T, atol=1e-12)
        np.testing.assert_allclose(P @ A, A, atol=1e-10)
        assert np.trace(P) == pytest.approx(sys.m, abs=1e-9)  # rank m
        if sys.n == sys.m:
            np.testing.assert_allclose(P, np.eye(sys.n), atol=1e-10)
            np.testing.assert_allclose(Ad, np.linalg.inv(A), atol=1e-9)
        else:
            # an infeasible u is projected: the residual is orthogonal to Im A_q
            u = RNG.normal(size=sys.n)
            r = u - P @ u
            assert np.linalg.norm(A.T @ r) < 1e-10 and np.linalg.norm(r) > 1e-3
            np.testing.assert_allclose(A @ sys.configuration_rate(q, u), P @ u, atol=1e-10)
        s = np.linalg.svd(A, compute_uv=False)
        assert sys.singularity_measure(q) == pytest.approx(s[-1], rel=1e-12)


def test_singular_configuration_raises_naming_it():
    sys = get("thesis")
    q = sys.q_from([0, 0, 0], [0, 0, 0, 0, 0, 0])  # all robots in the platform plane
    assert sys.singularity_measure(q) < 1e-12
    with pytest.raises(SingularConfigurationError, match="smallest singular value"):
        sys.check_configuration(q)
    with pytest.raises(SingularConfigurationError, match=r"q = \[0\.0, 0\.0, 0\.0"):
        sys.pinv(q)
    # the one-cable square family is singular without the sideways tilt
    sq = get("sq_6_0")
    q = sq.q_nominal.copy()
    q[1:12:2] = 0.0
    with pytest.raises(SingularConfigurationError):
        sq.check_configuration(q, what="q0")


def test_bad_configurations_raise():
    sys = get("thesis")
    with pytest.raises(ConfigurationDomainError, match="m=9"):
        sys.h(np.zeros(8))
    with pytest.raises(ConfigurationDomainError, match="finite"):
        sys.jacobian([np.nan] + [0.0] * 8)
    q = sys.q_nominal.copy()
    q[7] = math.pi / 2  # theta_V
    with pytest.raises(ConfigurationDomainError, match="gimbal lock"):
        sys.check_configuration(q)
    form = get("formation")
    q = form.q_nominal.copy()
    q[0] = -1.0
    with pytest.raises(ConfigurationDomainError, match="distance d must be positive, got -1.0"):
        form.check_configuration(q)


def test_bad_geometry_raises_naming_the_value():
    with pytest.raises(GeometryError, match="l_a=0.4"):
        TwoCable((0, 0, 0), (1, 0, 0), 0.4)  # two 0.4 m cables cannot span 1 m
    with pytest.raises(GeometryError, match="l_a=0.2 m, l_b=1.5 m"):
        TwoCable((0, 0, 0), (1, 0, 0), 0.2, 1.5)
    with pytest.raises(GeometryError, match="cable length l_a must be a positive length in metres, got -1.5"):
        TwoCable((0, 0, 0), (1, 0, 0), -1.5)
    with pytest.raises(GeometryError, match="cable length l must be a positive length in metres, got 0"):
        OneCable((1, 0, 0), 0)
    with pytest.raises(GeometryError, match="coincide"):
        TwoCable((1, 0, 0), (1, 0, 0), 1.0)
    with pytest.raises(ValueError, match="platform_mass must be positive, got -0.338"):
        C.thesis_flycrane(platform_mass=-0.338)
    with pytest.raises(ValueError, match="robot_masses\\[0\\] must be positive, got 0"):
        C.thesis_flycrane(robot_mass=0)
    with pytest.raises(GeometryError, match="l_a=0.5"):
        C.thesis_flycrane(cable_length=0.5)  # cannot reach the ends of a 1 m edge
    with pytest.raises(ValueError, match=r"\(1, 1\) is not square"):
        C.square_family(1, 1)
    with pytest.raises(SingularConfigurationError, match="q_nominal"):
        MultiRobotSystem([TwoCable((0, 1, 0), (1, 1, 0), 1.0)] * 3, q_nominal=np.zeros(9))
    with pytest.raises(GeometryError, match="ambiguous"):
        TwoCable((-1, 0, 0), (1, 0, 0), 1.5)  # axis through the pivot origin: no 'outward'


def test_plate_inertia_closed_forms():
    m = 0.338
    tri = C.regular_polygon(3, 1.0)[:, :2]
    np.testing.assert_allclose(plate_inertia(tri, m), np.diag([m / 24, m / 24, m / 12]), atol=1e-14)
    sq = C.regular_polygon(4, 2.0, first_midpoint_deg=0.0)[:, :2]  # axis-aligned square
    np.testing.assert_allclose(plate_inertia(sq[::-1] + 5.0, m), np.diag([m * 4 / 12, m * 4 / 12, m * 4 / 6]),
                               atol=1e-12)


def test_units_at_the_edge():
    sys = get("thesis")
    q = sys.q_from([75, 60, 55], [0.3, 0, 0.7, 20, 10, 45])
    np.testing.assert_allclose(q[:3], np.radians([75, 60, 55]))
    np.testing.assert_allclose(q[3:6], [0.3, 0, 0.7])
    np.testing.assert_allclose(q[6:], np.radians([20, 10, 45]))
    np.testing.assert_allclose(sys.q_to_edge(q), [75, 60, 55, 0.3, 0, 0.7, 20, 10, 45])
    assert sys.coordinate_names[:4] == ("alpha_1", "alpha_2", "alpha_3", "x_V")
    with pytest.raises(ValueError, match="N=3"):
        sys.q_from([75, 60], [0] * 6)


def test_euler_rates_give_the_body_angular_velocity():
    eta = RNG.uniform(-1, 1, 3)
    deta = RNG.normal(size=3)
    R = lambda e: np.asarray(euler_zyx(*e))  # noqa: E731
    h = 1e-6
    Rdot = (R(eta + h * deta) - R(eta - h * deta)) / (2 * h)
    W = R(eta).T @ Rdot
    w = np.array([W[2, 1], W[0, 2], W[1, 0]])
    np.testing.assert_allclose(np.asarray(body_rate_matrix(eta[1], eta[2])) @ deta, w, atol=1e-8)
    # B.1: the first Euler angle rotates about z_O
    np.testing.assert_allclose(R([0.3, 0, 0]) @ [0, 0, 1], [0, 0, 1], atol=1e-15)


def test_functions_are_built_once():
    sys = get("thesis")
    f1, A1 = sys.h_fun, sys.A_fun
    sys.h(sys.q_nominal)
    sys.jacobian(sys.q_nominal)
    assert sys.h_fun is f1 and sys.A_fun is A1
    assert isinstance(f1, ca.Function) and f1.n_in() == 1 and A1.size_out(0) == (9, 9)


def test_buffered_evaluation_matches_casadi_call():
    from netcosim.plants.casadi_tools import BufferedFunction
    sys = get("four")
    for q in sys.random_configurations(RNG, 3):
        np.testing.assert_array_equal(sys.jacobian(q), np.asarray(sys.A_fun(q)))
        np.testing.assert_array_equal(sys.h(q), np.asarray(sys.h_fun(q)).ravel())
    x, y = ca.SX.sym("x", 2), ca.SX.sym("y")
    f = ca.Function("f", [x, y], [ca.vertcat(x[0] * y, 0, x[1]), ca.diag(x), y])  # sparse outputs
    a, D, s = BufferedFunction(f)([2.0, 3.0], 4.0)
    np.testing.assert_array_equal(a, [8.0, 0.0, 3.0])
    np.testing.assert_array_equal(D, [[2.0, 0.0], [0.0, 3.0]])
    np.testing.assert_array_equal(s, [4.0])
    with pytest.raises(TypeError, match="takes 2 arguments"):
        BufferedFunction(f)([1.0, 2.0])
