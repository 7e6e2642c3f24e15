"""HPIPM called directly (netcosim.controllers.nmpc.hpipm) against CasADi's hpipm plugin:
the same steps bit for bit, the same failures, and the plugin never built on the direct path."""

import numpy as np
import pytest
from test_nmpc import cartpole_ocp

from netcosim.controllers.landing import initial_state, landing_nmpc
from netcosim.controllers.nmpc import RTINMPC
from netcosim.controllers.nmpc.hpipm import DirectHPIPM, direct_hpipm_supported


def bits(a) -> np.ndarray:
    return np.asarray(a, dtype=float).view(np.int64)


def test_the_landing_closed_loop_is_the_plugins_bit_for_bit():
    direct, plugin = landing_nmpc(), landing_nmpc(direct_hpipm=False)
    assert direct._direct is not None and plugin._direct is None
    x = initial_state()
    iters = []
    for _ in range(40):   # 0.4 s: the landing's approach and the soft constraints becoming active
        a, b = direct.feedback(x), plugin.feedback(x)
        assert (a.status, a.success, a.qp_iter) == (b.status, b.success, b.qp_iter)
        np.testing.assert_array_equal(bits(direct._w), bits(plugin._w))
        np.testing.assert_array_equal(bits(a.u), bits(b.u))
        assert bits([a.step_norm]) == bits([b.step_norm])
        iters.append(a.qp_iter)
        direct.preparation()
        plugin.preparation()
        np.testing.assert_array_equal(bits(direct._w), bits(plugin._w))
        x = np.asarray(direct.ocp.F(x, a.u, direct.p)).ravel()
    assert direct.n_fail == plugin.n_fail == 0
    # HPIPM works: 8-15 interior-point iterations per sample on this problem
    assert 8 <= min(iters) and max(iters) <= 15
    # the feedback phase never called CasADi's conic: the plugin was not even built
    assert direct._qp is None


def test_a_failed_qp_fails_the_same_way():
    ocp = cartpole_ocp(lbx=[-np.inf, -np.inf, -1.0, -np.inf], ubx=[np.inf, np.inf, 1.0, np.inf],
                       lbu=[-1.0], ubu=[1.0])
    x_ok = np.array([0.0, 0.05, 0.0, 0.0])
    ctrls = [RTINMPC(ocp, x_guess=x_ok, direct_hpipm=d) for d in (True, False)]
    for x in (x_ok, np.array([0.0, 0.05, 5.0, 0.0]), x_ok):
        a, b = (c.step(x) for c in ctrls)
        assert (a.status, a.fallback, a.qp_iter) == (b.status, b.fallback, b.qp_iter)
        np.testing.assert_array_equal(bits(ctrls[0]._w), bits(ctrls[1]._w))
    assert [c.n_fail for c in ctrls] == [1, 1]
    assert a.success


def test_an_ill_posed_qp_is_a_fallback_as_with_the_plugin():
    ocp = cartpole_ocp()
    x0 = np.array([0.0, 0.1, 0.0, 0.0])
    ctrls = [RTINMPC(ocp, x_guess=x0, direct_hpipm=d) for d in (True, False)]
    X = np.tile(x0, (ocp.N + 1, 1))
    X[5, 2] = np.nan                                   # a NaN in the plan: NaN constraint values
    for c in ctrls:
        c.set_trajectory(X, np.zeros((ocp.N, 1)))
    a, b = (c.feedback(x0) for c in ctrls)
    assert a.fallback and b.fallback
    assert a.status.startswith("error: ill-posed QP")
    assert "Ill-posed problem detected" in b.status or b.status.startswith("error")
    assert [c.n_fail for c in ctrls] == [1, 1]


@pytest.mark.parametrize("options, direct", [
    (None, True),
    ({"hpipm": {"mode": "balance", "iter_max": 50}}, True),
    ({"inf": 1e7}, True),
    ({"hpipm": {"warm_start": 1}}, False),       # not understood by the direct path: the plugin
    ({"print_problem": False}, False),
])
def test_options_choose_the_path_and_keep_the_steps(options, direct):
    ocp = cartpole_ocp()
    x0 = np.array([0.0, 0.2, 0.0, 0.0])
    a = RTINMPC(ocp, x_guess=x0, qp_options=options)
    b = RTINMPC(ocp, x_guess=x0, qp_options=options, direct_hpipm=False)
    assert (a._direct is not None) is direct
    for _ in range(5):
        ra, rb = a.step(x0), b.step(x0)
        assert ra.qp_iter == rb.qp_iter
        np.testing.assert_array_equal(bits(a._w), bits(b._w))


def test_other_solvers_ignore_direct_hpipm():
    ctrl = RTINMPC(cartpole_ocp(), qp_solver="osqp")
    assert ctrl._direct is None and ctrl._qp is not None


def test_direct_hpipm_rejects_what_it_cannot_do():
    assert not direct_hpipm_supported({"N": 1, "nx": [1, 1], "nu": [1, 0], "ng": [0, 0], "error_on_fail": True})
    assert not direct_hpipm_supported({"hpipm": {"mode": "fastest"}})
    ctrl = RTINMPC(cartpole_ocp())
    with pytest.raises(ValueError, match="do not fit the stage sizes"):
        DirectHPIPM(ctrl.A_sparsity, ctrl.A_sparsity, ctrl._qp_options)
    with pytest.raises(ValueError, match="not supported"):
        DirectHPIPM(ctrl.H_sparsity, ctrl.A_sparsity, {**ctrl._qp_options, "error_on_fail": True})
