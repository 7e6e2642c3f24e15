"""The auxiliary flow (3.12)/(4.17) behind the online gain, against a SciPy reference.

``solve_auxiliary_flow`` integrates the flow with its own DOP853 driver (SciPy's tableau,
step-size control and error norm) whose stages come from one compiled CasADi function
per step for systems with a symbolic Jacobian, and locates ``tau_s`` and ``tau_o`` by
safeguarded Newton on the dense output.  :func:`reference_flow` below is the plain
SciPy computation it replaces (``solve_ivp`` DOP853 with a terminal event, scan of the
dense output, bounded Brent); the two must agree to the integration tolerance for the
trajectory and ``tau_s``, and to Brent's tolerance for ``tau_o``.
"""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar
from test_controllers_systems import CRANE4_QREF, PlanarCrane

import netcosim.controllers.planner.flow as aux_flow
import netcosim.plants.casadi_tools as ct
from netcosim.controllers.planner import (
    SingularConfigurationError,
    WeightedNorm,
    diag_gain,
    jacobian,
    online_gain,
    pinv_solve,
    solve_auxiliary_flow,
)
from netcosim.controllers.planner.dop853 import root_increasing


def reference_flow(system, q_ref, e_h, *, kbar=None, norm=None, tau_max=None, n_grid=64):
    """``(tau_s, tau_o, min_norm, sol)`` with SciPy only: solve_ivp (DOP853, rtol 1e-10,
    atol 1e-12 ||e_h||, terminal event on the return of the norm), the norm scanned on
    ``n_grid`` points plus the steps, the best bracket refined by bounded Brent (xatol 1e-10)."""
    m = system.m
    q_ref, e_h = np.asarray(q_ref, float), np.asarray(e_h, float)
    kd = diag_gain(kbar, m)
    nrm = WeightedNorm.of(norm)
    tau_max = 10.0 / kd.min() if tau_max is None else tau_max
    n0 = nrm(e_h)
    c = jacobian(system, q_ref + e_h) @ (kd * e_h)

    def rhs(tau, x):
        return -pinv_solve(jacobian(system, q_ref + x), c, q_ref + x)

    def back(tau, x):
        return nrm(x) - n0
    back.terminal, back.direction = True, 1.0
    sol = solve_ivp(rhs, (0.0, tau_max), e_h, method="DOP853", rtol=1e-10, atol=1e-12 * np.linalg.norm(e_h),
                    events=back, dense_output=True)
    assert sol.status >= 0
    tau_s = float(sol.t_events[0][0]) if sol.status == 1 else math.inf
    tau_end = tau_s if sol.status == 1 else float(sol.t[-1])
    grid = np.union1d(np.linspace(0.0, tau_end, n_grid), sol.t[sol.t <= tau_end])
    vals = nrm.many(sol.sol(grid).T)
    j = int(np.argmin(vals))
    lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    tau_o, best = float(grid[j]), float(vals[j])
    res = minimize_scalar(lambda t: nrm(sol.sol(t)), bounds=(lo, hi), method="bounded", options={"xatol": 1e-10})
    if res.fun < best:
        tau_o, best = float(res.x), float(res.fun)
    return tau_s, tau_o, best, sol.sol


class NumericOnly:
    """*system* seen through ``n, m, h, jacobian`` only (no CasADi Jacobian): the flow then
    uses the SVD right-hand side."""

    def __init__(self, system):
        self.s, self.n, self.m = system, system.n, system.m

    def h(self, q):
        return self.s.h(q)

    def jacobian(self, q):
        return self.s.jacobian(q)


def _flycranes():
    from netcosim.plants.flycrane.configurations import four_robot_nonsquare, thesis_flycrane
    s3, s4 = thesis_flycrane(cable_length=1.5), four_robot_nonsquare()
    q4 = s4.q_from([60] * 4, [0] * 6)
    w4 = (1.0,) * 4 + (4.0,) * 6
    return [("3-robot", s3, s3.q_nominal, None, None),
            ("4-robot D", s4, q4, WeightedNorm(w4, 2), None),
            ("4-robot inf", s4, q4, WeightedNorm(w4, math.inf), None),
            ("4-robot Kbar", s4, q4, None, np.linspace(0.5, 2.0, 10))]


CASES = _flycranes() + [("planar 4", PlanarCrane(4), CRANE4_QREF, WeightedNorm((1, 1, 1, 1, 4, 4, 4), 2), None)]


@pytest.mark.parametrize("name, sys_, qr, norm, kbar", CASES, ids=[c[0] for c in CASES])
def test_flow_matches_the_scipy_reference(name, sys_, qr, norm, kbar):
    rng = np.random.default_rng(11)
    for r in (1e-6, 0.02, 0.15, 0.4):
        for _ in range(2):
            e = rng.standard_normal(sys_.m)
            e *= r / np.linalg.norm(e)
            f = solve_auxiliary_flow(sys_, qr, e, norm=norm, kbar=kbar)
            ts, to, mn, sol = reference_flow(sys_, qr, e, norm=norm, kbar=kbar)
            assert f.tau_s == pytest.approx(ts, rel=1e-11), (name, r)
            tau = np.linspace(0.0, f.tau_end, 41)
            assert np.max(np.abs(f(tau) - sol(tau).T)) < 1e-11 * r, (name, r)
            # bounded Brent stops within sqrt(eps) tau_o + xatol of the minimiser
            assert abs(f.tau_o - to) < 3e-8 * to, (name, r)
            assert f.min_norm <= mn + 1e-13 * r, (name, r)
            assert f.nfev > 0


def test_compiled_and_svd_right_hand_sides_agree():
    """The QR right-hand side (compiled, and in CasADi's virtual machine) and the SVD one
    give the same flow to round-off."""
    for name, sys_, qr, norm, kbar in _flycranes():
        e = 0.3 * np.cos(np.arange(sys_.m))
        fast = solve_auxiliary_flow(sys_, qr, e, norm=norm, kbar=kbar)
        svd = solve_auxiliary_flow(NumericOnly(sys_), qr, e, norm=norm, kbar=kbar)
        assert aux_flow._compiled_flow(sys_) is not None and aux_flow._compiled_flow(NumericOnly(sys_)) is None
        assert fast.tau_s == pytest.approx(svd.tau_s, rel=1e-13), name
        assert fast.tau_o == pytest.approx(svd.tau_o, rel=1e-11), name
        tau = np.linspace(0.0, fast.tau_end, 21)
        assert np.max(np.abs(fast(tau) - svd(tau))) < 1e-13, name
        # the same symbolic functions, uncompiled
        funs = aux_flow._casadi_flow_functions(sys_)
        c = np.ones(sys_.n)
        vm, compiled = aux_flow._CompiledFlow(funs).start(qr, c), aux_flow._compiled_flow(sys_).start(qr, c)
        y, f0 = 0.1 * e, vm.rhs(0.1 * e)
        assert np.max(np.abs(f0 - compiled.rhs(0.1 * e))) < 1e-13
        for a, b in zip(vm.step(y, f0, 0.4), compiled.step(y, f0, 0.4)):
            assert np.max(np.abs(a - b)) < 1e-13, name
        assert np.max(np.abs(vm.dense(None) - compiled.dense(None))) < 1e-13


def test_compilation_cache_and_fallback_without_compiler(tmp_path, monkeypatch):
    from netcosim.plants.flycrane.configurations import thesis_flycrane
    funs = aux_flow._casadi_flow_functions(thesis_flycrane(cable_length=1.5))
    monkeypatch.setenv("NETCOSIM_CACHE", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    assert ct.compile_functions(funs, "t") is funs          # no compiler: CasADi's virtual machine
    monkeypatch.delenv("CC")
    monkeypatch.setattr(ct, "COMPILE", False)
    assert ct.compile_functions(funs, "t") is funs
    monkeypatch.setattr(ct, "COMPILE", True)
    if shutil.which("cc") is None:
        pytest.skip("no C compiler")
    out = ct.compile_functions(funs, "t")
    libs = list(tmp_path.glob("t_*.so"))
    assert out is not funs and len(libs) == 1
    mtime = libs[0].stat().st_mtime_ns
    ct.compile_functions(funs, "t")                           # second time: loaded from the cache
    assert libs[0].stat().st_mtime_ns == mtime and list(tmp_path.glob("t_*.so")) == libs


def test_singular_configuration_raises_through_the_fallback():
    from netcosim.plants.flycrane.configurations import four_robot_nonsquare, thesis_flycrane
    for s in (thesis_flycrane(cable_length=1.5), four_robot_nonsquare()):
        qr = s.q_nominal
        q = qr.copy()
        q[-2] = math.pi / 2  # Euler angles at gimbal lock: A_q loses a rank
        with pytest.raises(SingularConfigurationError, match=r"singular .*at q="):
            online_gain(s, q, qr, 0.01)
        assert aux_flow._compiled_flow(s) is not None
    with pytest.raises(ValueError, match="e_h must be finite"):
        solve_auxiliary_flow(s, qr, np.full(s.m, np.nan))
    with pytest.raises(ValueError, match="tau_max must be a finite positive.*-2"):
        solve_auxiliary_flow(s, qr, 0.1 * np.ones(s.m), tau_max=-2)


def test_dense_output_and_its_derivatives():
    from netcosim.plants.flycrane.configurations import four_robot_nonsquare
    s = four_robot_nonsquare()
    qr = s.q_from([60] * 4, [0] * 6)
    f = solve_auxiliary_flow(s, qr, s.q_from([75] * 4, [0.05, 0, 0, 0, 0, 0]) - qr)
    sol = f.sol
    assert np.array_equal(sol.values(sol.t), sol.y) or np.max(np.abs(sol.values(sol.t) - sol.y)) < 1e-15
    c = jacobian(s, qr + f.e_h) @ f.e_h
    for tau in np.linspace(0.0, f.tau_end, 13):
        Y = sol.derivatives(tau)
        assert np.max(np.abs(Y[0] - f(tau))) < 1e-15
        # the dense output satisfies the flow equation to the integration tolerance
        rhs = -pinv_solve(jacobian(s, qr + Y[0]), c, qr + Y[0])
        assert np.max(np.abs(Y[1] - rhs)) < 1e-8 * np.linalg.norm(rhs)
        d = 1e-5
        fd = (sol.derivatives(tau + d)[1] - sol.derivatives(tau - d)[1]) / (2 * d)
        assert np.max(np.abs(Y[2] - fd)) < 1e-6 * np.max(np.abs(fd)) + 1e-12
    assert sol(0.5).shape == (s.m,) and sol(np.array([0.1, 0.2])).shape == (s.m, 2)
    assert f(np.zeros((2, 3))).shape == (2, 3, s.m)


def test_bracketed_newton_root():
    r = root_increasing(lambda x: (x ** 3 - 2.0, 3 * x * x), 0.0, 3.0, 1e-15)
    assert r == pytest.approx(2 ** (1 / 3), abs=4e-15)
    # a jump (max-norm kink): bisection down to the tolerance
    r = root_increasing(lambda x: (-1.0 if x < 0.3 else 1.0, 0.0), 0.0, 1.0, 1e-10)
    assert abs(r - 0.3) < 2e-10
    # g(lo) = 0 at the start of the bracket is not taken as the root (tau_s > 0)
    r = root_increasing(lambda x: (x * (x - 1.5), 2 * x - 1.5), 0.0, 2.0, 1e-14)
    assert r == pytest.approx(1.5, abs=1e-13)
