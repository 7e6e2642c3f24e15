"""Singular Fly-crane configurations: one exception class, one rank rule, and a kinematic
plant that stops where its trajectory reaches the singular set instead of jumping over it.

Scenario (thesis Fly-crane, 1.5 m cables): start at alpha_i = 30 deg and hold the robot
velocities that lower every alpha at 1 rad/s at the start, u = A_q0 qdot0.  By symmetry
the platform only moves vertically and each robot's outward horizontal speed
r sin(30 deg) stays constant, so ``cos alpha(t) = cos 30 deg + t/2``: alpha reaches 0
(all robots in the platform plane, A_q singular) at ``t* = 2 - sqrt(3)`` s, with
``alpha_dot = -1 / (2 sin alpha)`` blowing up there.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import netcosim.controllers.planner as lp
from netcosim import Simulation
from netcosim.plant import RK4, SolveIVP
from netcosim.plants.flycrane import kinematics as kin
from netcosim.plants.flycrane.configurations import thesis_flycrane
from netcosim.plants.flycrane.input_modes import KinematicPlant
from netcosim.plants.kinematic import SingularConfigurationError

T_STAR = 2.0 - math.sqrt(3.0)


def _scenario():
    s = thesis_flycrane(1.5)
    q0 = s.q_from([30, 30, 30], [0.5, 0.5, 0.5, 0, 0, 0])
    qd = np.zeros(9)
    qd[:3] = -1.0
    return s, q0, s.jacobian(q0) @ qd


def _run(integrator, until):
    s, q0, u = _scenario()
    sim = Simulation(seed=1)
    plant = KinematicPlant(s)
    inst = sim.plant(plant, plant.initial_state(q0), integrator=integrator, log="none")
    inst.input().write(u)
    sim.run(until)
    return inst


def _time_in(msg: str) -> float:
    return float(re.search(r"t = ([0-9.]+) s", msg).group(1))


def test_one_exception_class_for_the_whole_project():
    from netcosim.plants.flycrane import SingularConfigurationError as from_package
    assert kin.SingularConfigurationError is SingularConfigurationError
    assert lp.SingularConfigurationError is SingularConfigurationError
    assert from_package is SingularConfigurationError
    assert issubclass(SingularConfigurationError, ValueError)


def test_the_plant_follows_the_analytic_solution_before_the_singularity():
    inst = _run(SolveIVP(rtol=1e-12, atol=1e-14), 0.2)
    alpha = math.acos(math.sqrt(3.0) / 2 + 0.1)
    np.testing.assert_allclose(inst.state[:3], [alpha] * 3, atol=1e-9)
    np.testing.assert_allclose(inst.state[[3, 4, 6, 7, 8]], [0.5, 0.5, 0.0, 0.0, 0.0], atol=1e-9)


@pytest.mark.parametrize("integrator, tol", [
    (RK4(dt=1e-2), 0.011),              # jumped over the singular set before (alpha -0.8 deg -> -49 deg)
    (RK4(dt=1e-3), 5e-5),
    (SolveIVP(rtol=1e-12, atol=1e-14), 1e-8),
])
def test_driving_through_the_singularity_raises_there_naming_time_q_and_measure(integrator, tol):
    with pytest.raises(SingularConfigurationError) as info:
        _run(integrator, 0.35)
    msg = str(info.value)
    assert abs(_time_in(msg) - T_STAR) < tol, msg
    assert "q = [" in msg and "smallest singular value" in msg and "condition number" in msg


def test_the_fixed_step_plant_is_regular_just_before_the_singularity():
    """The same RK4 run up to just before t*: still on the regular side, alpha > 0."""
    inst = _run(RK4(dt=1e-2), 0.26)
    assert np.all(inst.state[:3] > 0)
    assert math.degrees(inst.state[0]) == pytest.approx(math.degrees(math.acos(math.sqrt(3) / 2 + 0.13)),
                                                        abs=0.05)


# alpha = 4e-8 rad: sigma_min / sigma_max = 1.12e-8 (condition number 8.9e7): regular;
# alpha = 3e-8 rad: 8.4e-9 (1.19e8): singular.  The old plant rule (sigma_min <= 1e-8
# absolute) and the old planner rule (rcond 1e-10) both accepted 3e-8.
def _near(alpha):
    s = thesis_flycrane(1.5)
    q = s.q_from([0, 0, 0], [0.5, 0.5, 0.5, 0, 0, 0])
    q[:3] = alpha
    return s, q


def test_one_rule_for_plant_and_planner_at_the_threshold():
    s, q = _near(4e-8)
    rank, smin, cond, singular = kin.conditioning(s.singular_values(q))
    assert (rank, singular) == (9, False) and cond == pytest.approx(8.909e7, rel=1e-3)
    qd = np.linspace(-1.0, 1.0, 9)
    u = s.jacobian(q) @ qd
    # relative error ~ eps * cond = 2e-8: both pseudo-inverses recover the known rate
    np.testing.assert_allclose(s.pinv(q) @ u, qd, atol=1e-7)
    np.testing.assert_allclose(lp.configuration_rate(s, q, u), qd, atol=1e-7)
    s, q = _near(3e-8)
    with pytest.raises(SingularConfigurationError, match=r"rank 7 < 9.*condition number 1\.188e\+08"):
        s.pinv(q)
    with pytest.raises(SingularConfigurationError, match=r"rank 7 < 9.*condition number 1\.188e\+08"):
        lp.configuration_rate(s, q, np.ones(9))
    with pytest.raises(SingularConfigurationError, match="q0"):
        s.check_configuration(q, what="q0")


def test_just_off_the_singular_set_the_plant_still_moves_exactly():
    """alpha = 1e-6 rad (condition number 3.6e6): a pure vertical translation keeps A_q
    constant and the plant moves exactly q0 + qdot t."""
    s, q0 = _near(1e-6)
    qd = np.zeros(9)
    qd[5] = 0.1
    u = s.jacobian(q0) @ qd
    sim = Simulation(seed=1)
    plant = KinematicPlant(s)
    inst = sim.plant(plant, plant.initial_state(q0), integrator=RK4(dt=1e-2), log="none")
    inst.input().write(u)
    sim.run(1.0)
    np.testing.assert_allclose(inst.state, q0 + qd * 1.0, atol=1e-9)
    assert plant.events[0].name == "singular_configuration"


def test_conditioning_of_a_known_matrix():
    rank, smin, cond, singular = kin.conditioning([2.0, 1.0, 1e-9])
    assert (rank, smin, singular) == (2, 1e-9, True) and cond == pytest.approx(2e9)
    assert kin.conditioning([3.0, 1.0]) == (2, 1.0, 3.0, False)
    assert kin.conditioning([np.nan, 1.0])[3] is True
