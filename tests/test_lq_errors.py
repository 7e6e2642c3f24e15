"""Bad input to netcosim.lq: each error names the parameter and the value."""

from __future__ import annotations

import numpy as np
import pytest

from netcosim import lq
from netcosim.errors import ConfigurationError, ConfigurationTypeError


def plant(**kw):
    args = dict(A=[[0.0, 1.0], [0.0, -1.0]], B=[[0.0], [1.0]], C=[[1.0, 0.0]], R_c=np.eye(2), Q_c=np.eye(3))
    args.update(kw)
    return lq.ContinuousSystem(**args)


@pytest.mark.parametrize("kw, match", [
    (dict(A=[[0.0, 1.0, 2.0], [0.0, -1.0, 0.0]]), r"ContinuousSystem: A must be square, got shape 2x3"),
    (dict(A=[[0.0, np.nan], [0.0, -1.0]]), r"ContinuousSystem: A must be finite.*nan"),
    (dict(B=[[0.0], [1.0], [2.0]]), r"ContinuousSystem: B must be 2xany, got shape 3x1"),
    (dict(B=[0.0, 1.0]), r"ContinuousSystem: B must be a 2-D matrix"),
    (dict(C=[[1.0, 0.0, 0.0]]), r"ContinuousSystem: C must be anyx2, got shape 1x3"),
    (dict(D=[[1.0]]), r"ContinuousSystem: D must be zero"),
    (dict(R_c=[[1.0, 0.0], [0.0, -1.0]]), r"ContinuousSystem: R_c must be positive semidefinite.*-1"),
    (dict(R_c=[[1.0, 0.5], [0.0, 1.0]]), r"ContinuousSystem: R_c must be symmetric"),
    (dict(Q_c=np.eye(2)), r"ContinuousSystem: Q_c must be 3x3, got shape 2x2"),
    (dict(Q_c=np.diag([1.0, np.inf, 0.0])), r"ContinuousSystem: Q_c must be finite"),
])
def test_bad_continuous_systems(kw, match):
    with pytest.raises(ConfigurationError, match=match):
        plant(**kw)


def test_bad_kinds_and_discrete_systems():
    with pytest.raises(ConfigurationTypeError, match=r"ContinuousSystem: A must be a real matrix, got 'x'"):
        plant(A="x")
    with pytest.raises(ConfigurationTypeError, match=r"ContinuousSystem: B must be a real matrix, got None"):
        plant(B=None)
    with pytest.raises(ConfigurationError, match=r"DiscreteSystem: Gamma must be 1x1, got shape 1x2"):
        lq.DiscreteSystem([[0.5]], [[1.0, 2.0]], [[1.0]], [[0.0]])
    with pytest.raises(ConfigurationError, match=r"DiscreteSystem: R_d must be 2x2"):
        lq.DiscreteSystem([[0.5]], [[1.0]], [[1.0]], [[0.0]], R_d=[[1.0]])
    with pytest.raises(ConfigurationError, match=r"DiscreteSystem: R_d must be positive semidefinite"):
        lq.DiscreteSystem.gain(1.0, R_d=-0.1)
    with pytest.raises(ConfigurationTypeError, match=r"from_ss: sys must have A, B, C, D, got 3"):
        lq.ContinuousSystem.from_ss(3)


def loop():
    return (lq.Interconnection().add("p", plant(), inputs="c")
            .add("c", lq.DiscreteSystem.gain(-1.0), inputs="p"))


def test_bad_interconnections():
    with pytest.raises(ConfigurationError, match=r"system 'p' is already defined"):
        loop().add("p", plant())
    with pytest.raises(ConfigurationError, match=r"system 'c' cannot be its own input"):
        lq.Interconnection().add("c", lq.DiscreteSystem.gain(1.0), inputs="c")
    with pytest.raises(ConfigurationError, match=r"takes its input from 'nope', which is not defined"):
        lq.Interconnection().add("p", plant(), inputs="nope").dynamics()
    two = lq.DiscreteSystem.gain(np.eye(2))
    with pytest.raises(ConfigurationError, match=r"system 'p' has 1 input\(s\) but its inputs \['c'\] give 2"):
        lq.Interconnection().add("p", plant(), inputs="c").add("c", two).dynamics()
    with pytest.raises(ConfigurationTypeError, match=r"system 'x' must be a ContinuousSystem or a DiscreteSystem"):
        lq.Interconnection().add("x", np.eye(2))
    with pytest.raises(ConfigurationError, match=r"system 'p' cannot be executed: it is a continuous system"):
        lq.Propagator(loop()).update("p")
    with pytest.raises(ConfigurationError, match=r"system 'q' cannot be executed: it is not defined"):
        lq.Propagator(loop()).update("q")


def test_bad_times_and_disturbances():
    p = lq.Propagator(loop())
    with pytest.raises(ConfigurationError, match=r"pass_time: T must be a non-negative number of seconds, got -0.1"):
        p.pass_time(-0.1)
    with pytest.raises(ConfigurationError, match=r"pass_time: T must be .*, got nan"):
        p.pass_time(float("nan"))
    p.advance(1.0)
    with pytest.raises(ConfigurationError, match=r"advance: t must not be before the present time 1.0 s, got 0.5"):
        p.advance(0.5)
    with pytest.raises(ConfigurationError, match=r"impulse on 'p': v must be a vector of length 2"):
        p.impulse([1.0, 2.0, 3.0], system="p")
    with pytest.raises(ConfigurationError, match=r"impulse: V must be positive semidefinite"):
        p.impulse(V=-np.eye(3))
    with pytest.raises(ConfigurationError, match=r"Propagator: P0 must be 3x3"):
        lq.Propagator(loop(), P0=np.eye(2))
    assert p.time == 1.0            # nothing moved on a refused call


def test_bad_schedules_and_timing_models():
    with pytest.raises(ConfigurationError, match=r"Wait: duration must be a non-negative number of seconds, got -1"):
        lq.Wait(-1)
    with pytest.raises(ConfigurationTypeError, match=r"every step must be a Wait or an Execute, got 0.1"):
        lq.periodic_cost(loop(), [lq.Execute("c"), 0.1])
    with pytest.raises(ConfigurationError, match=r"waits must add up to a positive period, got 0"):
        lq.periodic_cost(loop(), [lq.Execute("c")])
    with pytest.raises(ConfigurationError, match=r"period must be a whole multiple of delta 0.003 s, got 0.01"):
        lq.TimingModel(loop(), delta=0.003, period=0.01)
    tm = lq.TimingModel(loop(), delta=0.001, period=0.01)
    with pytest.raises(ConfigurationError, match=r"node 1: delay must be probabilities .* got \[0.5, 0.4\]"):
        tm.add_node(1, delay=[0.5, 0.4])
    with pytest.raises(ConfigurationError, match=r"node 1: probabilities must be one per next node \[2, 3\]"):
        tm.add_node(1, next=[2, 3], probabilities=[1.0])
    with pytest.raises(ConfigurationError, match=r"system 'p' cannot be executed"):
        tm.add_node(1, execute="p")
    tm.add_node(1, delay=np.eye(1, 12, 11).ravel(), next=2, execute="c").add_node(2)
    with pytest.raises(ConfigurationError, match=r"a delay of 11 grain\(s\) after 0 reaches past the period of 10"):
        tm.cost()
