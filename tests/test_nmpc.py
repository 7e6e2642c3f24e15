"""The general RTI NMPC on a textbook problem: the inverted pendulum on a cart.

Cart position p [m], pole angle θ [rad] from upright, rates; force F [N] on the cart.
Lagrange's equations for a point mass m on a massless rod of length l give
    p̈ = (F + m sin θ (l θ̇² - g cos θ)) / (M + m sin² θ),   θ̈ = (g sin θ - p̈ cos θ) / l.
"""

import casadi as ca
import numpy as np
import pytest

from netcosim.controllers.nmpc import OCP, RTINMPC

M, m, L, G = 1.0, 0.1, 0.5, 9.81


def cartpole_xdot(x, u):
    _, th, v, om = x[0], x[1], x[2], x[3]
    s, c = ca.sin(th), ca.cos(th)
    acc = (u[0] + m * s * (L * om ** 2 - G * c)) / (M + m * s ** 2)
    return ca.vertcat(v, om, acc, (G * s - acc * c) / L)


def cartpole_ocp(N=20, Ts=0.05, **kw):
    x = ca.SX.sym("x", 4)
    u = ca.SX.sym("u", 1)
    args = dict(x=x, u=u, xdot=cartpole_xdot(x, u), N=N, Ts=Ts,
                residual=ca.vertcat(x, u), weights=[10.0, 10.0, 1.0, 1.0, 0.1],
                terminal_residual=x, terminal_weights=[100.0] * 4,
                lbu=[-10.0], ubu=[10.0],
                h=x[0], lbh=[-0.3], ubh=[0.3], soft=[0], soft_weights=[1e6],
                state_names=["p", "theta", "v", "omega"], input_names=["F"])
    args.update(kw)
    return OCP(**args)


def simulate(ctrl, ocp, x0, steps, full=False):
    """Closed loop on the exact discretized model; returns states and inputs.

    ``full=True``: solve the OCP to convergence with IPOPT at every step (warm started).
    """
    x = np.array(x0, dtype=float)
    xs, us = [x.copy()], []
    ipopt = ctrl.ipopt_solver() if full else None
    for _ in range(steps):
        if full:
            sol = ipopt.solve(x)
            assert sol.success, sol.status
            u = sol.U[0]
        else:
            u = ctrl.step(x).u
        x = np.asarray(ocp.F(x, u, [])).ravel()
        xs.append(x.copy())
        us.append(np.array(u))
    return np.array(xs), np.array(us)


@pytest.fixture(scope="module")
def ocp():
    return cartpole_ocp()


@pytest.fixture(scope="module")
def rti_loop(ocp):
    ctrl = RTINMPC(ocp, x_guess=[0, 0.3, 0, 0])
    xs, us = simulate(ctrl, ocp, [0.0, 0.3, 0.0, 0.0], 100)
    return ctrl, xs, us


def test_rti_stabilizes_the_pendulum_within_bounds(rti_loop):
    ctrl, xs, us = rti_loop
    assert ctrl.n_fail == 0
    assert all(r.success for r in ctrl.history)
    # upright and at rest after 5 s
    assert np.max(np.abs(xs[-1])) < 0.03
    # the input bound is hard, and it is active at the start
    assert np.max(np.abs(us)) <= 10.0 + 1e-6
    assert np.max(np.abs(us)) > 9.9
    # the soft cart-position bound |p| <= 0.3 m: without it the cart travels 0.43 m; with
    # it, the quadratic penalty lets the cart exceed 0.3 m only by centimetres
    assert 0.3 < np.max(np.abs(xs[:, 0])) < 0.35


def test_rti_at_the_optimum_reproduces_the_ipopt_solution(ocp):
    x0 = np.array([0.1, 0.4, 0.0, -0.5])
    ctrl = RTINMPC(ocp, x_guess=x0)
    sol = ctrl.ipopt_solver().solve(x0)
    assert sol.success, sol.status
    ctrl.set_trajectory(sol.X, sol.U, sol.S, sol.SN)
    r = ctrl.feedback(x0)
    assert r.success and not r.fallback
    assert r.step_norm < 1e-5  # the optimum is a fixed point of the Gauss-Newton iteration
    np.testing.assert_allclose(r.u, sol.U[0], atol=1e-5)
    np.testing.assert_allclose(r.x_ref, sol.X[1], atol=1e-6)


def test_converged_sqp_equals_ipopt(ocp):
    x0 = np.array([0.0, 0.15, 0.0, 0.0])
    ctrl = RTINMPC(ocp, x_guess=x0)
    sqp = ctrl.solve_sqp(x0, tol=1e-9, max_iter=400)
    ip = ctrl.ipopt_solver().solve(x0, w_init=None)
    assert sqp.success and ip.success
    assert sqp.iterations < 20
    assert sqp.cost == pytest.approx(ip.cost, rel=1e-8)
    np.testing.assert_allclose(sqp.U, ip.U, atol=1e-5)
    np.testing.assert_allclose(sqp.X, ip.X, atol=1e-6)


def test_closed_loop_rti_stays_close_to_closed_loop_full_solve(ocp):
    # both start from the converged solution at x0; then the RTI does one Gauss-Newton
    # iteration per sample while the reference solves to convergence with IPOPT
    x0 = np.array([0.0, 0.15, 0.0, 0.0])
    rti = RTINMPC(ocp, x_guess=x0)
    assert rti.solve_sqp(x0).success
    xs_rti, us_rti = simulate(rti, ocp, x0, 60)
    xs_full, us_full = simulate(RTINMPC(ocp, x_guess=x0), ocp, x0, 60, full=True)
    # stated tolerance: 1e-3 (m, rad, m/s, rad/s) on the states, 1e-2 N on the force
    assert np.max(np.abs(xs_rti - xs_full)) < 1e-3
    assert np.max(np.abs(us_rti - us_full)) < 1e-2
    # and they do differ: the RTI is not a full solve
    assert np.max(np.abs(us_rti - us_full)) > 1e-7


@pytest.mark.parametrize("solver", ["osqp", "qpoases"])
def test_other_qp_solvers_give_the_same_step(ocp, solver):
    x0 = np.array([0.0, 0.3, 0.0, 0.0])
    ref = RTINMPC(ocp, x_guess=x0).step(x0)
    other = RTINMPC(ocp, x_guess=x0, qp_solver=solver).step(x0)
    assert other.success
    np.testing.assert_allclose(other.u, ref.u, atol=1e-3)


def test_failed_qp_falls_back_to_the_shifted_plan_and_is_counted():
    # hard |v| <= 1 m/s with |F| <= 1 N: from v = 5 m/s node 1 cannot satisfy it
    ocp = cartpole_ocp(lbx=[-np.inf, -np.inf, -1.0, -np.inf], ubx=[np.inf, np.inf, 1.0, np.inf],
                       lbu=[-1.0], ubu=[1.0])
    x_ok = np.array([0.0, 0.05, 0.0, 0.0])
    ctrl = RTINMPC(ocp, x_guess=x_ok)
    first = ctrl.step(x_ok)
    assert first.success
    planned_u1 = ctrl.U[0].copy()  # after the shift: the previous plan's second input
    bad = ctrl.step(np.array([0.0, 0.05, 5.0, 0.0]))
    assert not bad.success and bad.fallback
    assert ctrl.n_fail == 1
    # HPIPM reports the bare number 2: the step names it
    assert bad.status == "minimum step length reached (hpipm status 2)"
    assert np.all(np.isfinite(bad.u)) and np.all(np.isfinite(bad.X))
    np.testing.assert_allclose(bad.u, planned_u1)
    again = ctrl.step(ctrl.X[0] * 0 + x_ok)
    assert again.success and ctrl.n_fail == 1


def test_terminal_soft_constraint_and_node0_rule():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u", 1)
    # double integrator; terminal position must be >= 7 (soft); the x-only path row is not
    # imposed at node 0 (the measured state violates it), the row with u is
    ocp = OCP(x=x, u=u, xdot=ca.vertcat(x[1], u[0]), N=10, Ts=0.1,
              residual=u, weights=[1.0], h=ca.vertcat(x[0], x[0] + 0.001 * u[0]), lbh=[-5.0, -np.inf],
              ubh=[5.0, 10.0],
              h_N=x[0], lbh_N=[7.0], soft_N=[0], soft_weights_N=[1e6])
    assert ocp.h_rows_node0 == (1,)
    ctrl = RTINMPC(ocp)
    sol = ctrl.solve_sqp(np.array([-6.0, 0.0]))  # x0 violates the x-only row: still solvable
    assert sol.success, sol.status
    assert sol.X[1, 0] >= -5.0 - 1e-6  # row 0 holds from node 1 on
    # without the terminal row the optimum ends at x_N = 5.87 m; the soft row moves it to
    # the bound, up to the violation a quadratic penalty of 1e6 allows
    assert 7.0 - 1e-2 < sol.X[-1, 0] < 7.0 + 1e-6
    assert sol.SN[0] == pytest.approx(sol.X[-1, 0] - 7.0, abs=1e-6)


def test_soft_constraint_changes_the_closed_loop():
    ocp = cartpole_ocp(h=None, lbh=None, ubh=None, soft=(), soft_weights=None)
    ctrl = RTINMPC(ocp, x_guess=[0, 0.3, 0, 0])
    xs, _ = simulate(ctrl, ocp, [0.0, 0.3, 0.0, 0.0], 40)
    assert np.max(np.abs(xs[:, 0])) > 0.4


def test_full_weight_matrix_equals_diagonal_vector(ocp):
    x0 = np.array([0.0, 0.3, 0.0, 0.0])
    W = np.diag([10.0, 10.0, 1.0, 1.0, 0.1])
    a = RTINMPC(cartpole_ocp(weights=W), x_guess=x0).solve_sqp(x0)
    b = RTINMPC(ocp, x_guess=x0).solve_sqp(x0)
    np.testing.assert_allclose(a.U, b.U, atol=1e-6)


@pytest.mark.parametrize("kw, match", [
    (dict(weights=[1.0, 2.0]), r"weights must have shape \(5,\)"),
    (dict(weights=np.eye(4)), r"weights must have shape"),
    (dict(weights=np.diag([1.0, 1.0, 1.0, 1.0, -1.0])), "positive semidefinite"),
    (dict(terminal_weights=[1.0] * 3), r"terminal_weights must have shape \(4,\)"),
    (dict(N=0), "horizon N must be a positive integer.*0"),
    (dict(N=-3), "horizon N must be a positive integer.*-3"),
    (dict(Ts=0.0), "Ts must be a positive number.*0.0"),
    (dict(lbu=[5.0], ubu=[1.0]), r"infeasible bounds for u\[0\]: lower 5.0 > upper 1.0"),
    (dict(lbx=[0, 0, 2.0, 0], ubx=[1, 1, 1.0, 1]), r"infeasible bounds for x\[2\]: lower 2.0 > upper 1.0"),
    (dict(lbh=[0.5], ubh=[0.1]), r"infeasible bounds for h\[0\]"),
    (dict(soft=[3]), "soft row index 3 out of range"),
    (dict(soft_weights=[-1.0]), "soft_weights must be finite and positive"),
    (dict(rk4_steps=0), "rk4_steps must be a positive integer, got 0"),
])
def test_bad_problem_definitions_raise_naming_the_value(kw, match):
    with pytest.raises(ValueError, match=match):
        cartpole_ocp(**kw)


def test_bad_solver_and_state_raise(ocp):
    with pytest.raises(ValueError, match="unknown qp_solver 'gurobi2'"):
        RTINMPC(ocp, qp_solver="gurobi2")
    ctrl = RTINMPC(ocp)
    with pytest.raises(ValueError, match="x0 must have 4 entries"):
        ctrl.step([0.0, 0.0])
    with pytest.raises(ValueError, match="x0 must be finite"):
        ctrl.step([0.0, np.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match="free|not states"):
        y = ca.SX.sym("y")
        x = ca.SX.sym("x", 1)
        u = ca.SX.sym("u", 1)
        OCP(x=x, u=u, xdot=x + y, N=5, Ts=0.1)


@pytest.mark.parametrize("solver, status, text", [
    ("hpipm", 1, "maximum iterations reached (hpipm status 1)"),
    ("hpipm", "4", "inconsistent equality constraints (hpipm status 4)"),
    ("daqp", -1, "infeasible (daqp status -1)"),
    ("daqp", 99, "daqp status 99 (no name known)"),
    ("osqp", "primal infeasible", "primal infeasible"),
])
def test_bare_qp_status_numbers_are_named(solver, status, text):
    from netcosim.controllers.nmpc.qp import _status_text
    assert _status_text(solver, status) == text


def test_a_failed_daqp_step_is_named_infeasible():
    ocp = cartpole_ocp(lbx=[-np.inf, -np.inf, -1.0, -np.inf], ubx=[np.inf, np.inf, 1.0, np.inf],
                       lbu=[-1.0], ubu=[1.0])
    x_ok = np.array([0.0, 0.05, 0.0, 0.0])
    ctrl = RTINMPC(ocp, x_guess=x_ok, qp_solver="daqp")
    assert ctrl.step(x_ok).success
    bad = ctrl.step(np.array([0.0, 0.05, 5.0, 0.0]))
    assert not bad.success and bad.status == "infeasible (daqp status -1)"
