"""Cable break on the Fly-crane (plants/flycrane/cable_break.py,
experiments/flycrane_cable_break.py): the hybrid reset, the platform statics derived in
docs/models.md, and the simulated outcome against the statics."""

import math

import numpy as np
import pytest

from netcosim.experiments import flycrane_cable_break as ex
from netcosim.plants.flycrane.cable_break import (
    CableBreak,
    PostBreakDynamics,
    cable_labels,
    cables,
    configuration_after_break,
    platform_wrench_matrix,
    state_after_break,
    static_balance,
    system_after_break,
)


@pytest.fixture(scope="module")
def gains():
    out = {}
    for N in (3, 4, 5):
        sys_, q0, q_ref = ex.configuration(N)
        out[N] = ex.offline_gain(sys_, q0, q_ref, n_mu=16)
    return out


def test_reset_keeps_positions_and_velocities():
    sys0 = ex.configuration(4)[0]
    sys1 = system_after_break(sys0, 2, 1)
    assert (sys1.n, sys1.m) == (12, 11) and cable_labels(sys1)[4] == "r3a"
    rng = np.random.default_rng(1)
    q = sys0.q_from([70, 75, 65, 80], [0.1, -0.2, 0.3, 5, -4, 3])
    qd = rng.normal(size=sys0.m) * 0.3
    x1 = state_after_break(sys0, sys1, np.concatenate([q, qd]))
    q1, qd1 = x1[:11], x1[11:]
    assert np.allclose(sys1.h(q1), sys0.h(q), atol=1e-12)
    assert np.allclose(sys1.jacobian(q1) @ qd1, sys0.jacobian(q) @ qd, atol=1e-12)
    assert np.allclose(q1[-6:], q[-6:]) and np.allclose(qd1[-6:], qd[-6:])
    with pytest.raises(ValueError, match="robot 7 out of range"):
        system_after_break(sys0, 7, 0)
    with pytest.raises(ValueError, match="cable must be 0"):
        CableBreak(0, 2, 1.0)


def test_statics_three_robots_no_level_equilibrium_after_a_break():
    """6 cables, 6 wrench equations: the intact tensions are unique (all positive); drop
    one and the platform's weight leaves the span of the other five."""
    sys0, _, q_ref = ex.configuration(3)
    W = platform_wrench_matrix(sys0, q_ref)
    assert W.shape == (6, 6) and np.linalg.matrix_rank(W) == 6
    t = np.linalg.solve(W, [0, 0, sys0.mass.platform_mass * 9.81, 0, 0, 0])
    assert t.min() > 0 and static_balance(sys0, q_ref).margin == pytest.approx(t.min(), abs=1e-9)
    for i, c in cables(sys0):
        sys1 = system_after_break(sys0, i, c)
        sb = static_balance(sys1, configuration_after_break(sys0, sys1, q_ref))
        assert not sb.feasible and sb.residual > 0.1


def test_statics_square_forces_the_diagonal_cable_slack():
    """Square platform, all angles equal, level: every equilibrium has equal tensions in
    the cables of opposite robots at diagonally opposite vertices (t_{r1a} = t_{r3a});
    breaking r1a forces r3a to zero: the 7 remaining cables cannot all be taut."""
    sys0, _, q_ref = ex.configuration(4)
    W = platform_wrench_matrix(sys0, q_ref)
    null = np.linalg.svd(W)[2][6:]
    lab = cable_labels(sys0)
    for a, b in (("r1a", "r3a"), ("r1b", "r3b"), ("r2a", "r4a"), ("r2b", "r4b")):
        assert np.allclose(null[:, lab.index(a)], null[:, lab.index(b)], atol=1e-12)
    for i, c in cables(sys0):
        sys1 = system_after_break(sys0, i, c)
        sb = static_balance(sys1, configuration_after_break(sys0, sys1, q_ref))
        opposite = f"r{(i + 2) % 4 + 1}{'ab'[c]}"
        assert sb.feasible and abs(sb.margin) < 1e-9 and not sb.holds
        assert [cable_labels(sys1)[j] for j in sb.forced_slack] == [opposite]


def test_statics_five_robots_keep_a_positive_margin():
    sys0, _, q_ref = ex.configuration(5)
    sys1 = system_after_break(sys0, 0, 0)
    sb = static_balance(sys1, configuration_after_break(sys0, sys1, q_ref))
    assert sb.holds and sb.margin == pytest.approx(1.114929, abs=1e-5)


def test_no_break_equals_the_fig_4_10_run(gains):
    from netcosim.controllers.planner import OfflineGain, WeightedNorm
    from netcosim.experiments import ch4_fig4_10 as f410
    from netcosim.plants.flycrane.input_modes import VelocityTrackingPlant
    sys_, q0, q_ref = ex.configuration(4)
    ref = f410.simulate_dynamic(sys_, VelocityTrackingPlant(sys_, 30.0), q0, q_ref, OfflineGain(gains[4]),
                                WeightedNorm(f410.WEIGHTS, 2), 30)
    row, _ = ex.simulate(4, None, gains[4])
    assert row["outcome"] == "finishes" and row["final_err"] == ref.err.iloc[-1]
    assert row["final_err"] < 1e-7
    assert row["min_tension"] == pytest.approx(np.nanmin(ref.min_tension), rel=0.05)


def test_simulated_outcomes_agree_with_the_statics(gains):
    # 3 robots: no equilibrium at the level goal -> the five cables hold the load but the
    # platform swings and the goal is not reached
    r3, _ = ex.simulate(3, CableBreak(0, 0, 12.75), gains[3])
    assert r3["outcome"] == "holds" and r3["min_tension_best"] > 0.1 and r3["final_err"] > 0.5
    # 4 robots: the diagonally opposite cable is forced slack -> reported, run stopped
    r4, _ = ex.simulate(4, CableBreak(0, 0, 12.75), gains[4])
    assert r4["outcome"] == "slack" and r4["slack_cable"] == "r3a" and 12.75 < r4["t_slack"] < 15.0
    assert -1e-3 < r4["min_tension_best"] < 0.0
    # 5 robots: positive static margin -> carries the load to the goal; near the goal at
    # rest its best smallest tension is the static margin
    r5, _ = ex.simulate(5, CableBreak(0, 0, 12.75), gains[5])
    assert r5["outcome"] == "finishes" and r5["final_err"] < 1e-8
    assert r5["min_tension_best"] == pytest.approx(1.114929, abs=2e-3)


def test_best_allocation_never_below_minimum_norm():
    sys0, q0, _ = ex.configuration(5)
    sys1 = system_after_break(sys0, 1, 0)
    dyn = PostBreakDynamics(sys1, 30.0)
    x = state_after_break(sys0, sys1, np.concatenate([q0, np.zeros(sys0.m)]))
    u = np.zeros(sys1.n)
    best, t = dyn.best_min_tension(x, u)
    assert best >= dyn.tensions(x, u).min() - 1e-12 and best == pytest.approx(t.min(), abs=1e-9)
    assert math.isfinite(best)


def test_square_after_releasing_the_forced_slack_cable_is_singular(gains):
    """Release the forced-slack cable r3a as well: the six cables left can hold the weight
    (margin 1.172 N) but no longer fix the platform -- W has rank 5 and A_q (12 x 12) is
    singular at the goal, so the continued run fails at once (a second cable slack)."""
    sys0, _, q_ref = ex.configuration(4)
    s1 = system_after_break(sys0, 0, 0)
    s2 = system_after_break(s1, 2, 0)
    assert cable_labels(s2) == ["r1b", "r2a", "r2b", "r3b", "r4a", "r4b"] and (s2.n, s2.m) == (12, 12)
    q2 = configuration_after_break(s1, s2, configuration_after_break(sys0, s1, q_ref))
    assert np.linalg.matrix_rank(platform_wrench_matrix(s2, q2), tol=1e-9) == 5
    assert s2.singularity_measure(q2) < 1e-12
    sb = static_balance(s2, q2)
    assert sb.holds and sb.margin == pytest.approx(1.172305, abs=1e-5)
    row, _ = ex.simulate(4, CableBreak(0, 0, 12.75), gains[4], cascade=True)
    assert row["outcome"] == "slack" and row["slack_cable"] == "r3a" and row["after_slack"] == "slack"
    assert row["min_tension_best"] < -1.0
