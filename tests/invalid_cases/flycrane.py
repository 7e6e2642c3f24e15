"""Invalid Fly-crane inputs: configurations, kinematics at singular or invalid q, plants,
planner gains and periods.  Each case builds its own system."""

from __future__ import annotations

import math

from invalid_cases import Case

NAN = float("nan")


def _sys():
    from netcosim.plants.flycrane.configurations import thesis_flycrane
    return thesis_flycrane(1.5)


def _near_singular(alpha=3e-8):
    """alpha_i = 3e-8 rad: sigma_min / sigma_max = 8.4e-9, singular by the 1e-8 rule."""
    s = _sys()
    q = s.q_from([0, 0, 0], [0.5, 0.5, 0.5, 0, 0, 0])
    q[:3] = alpha
    return s, q


def _pinv_near():
    s, q = _near_singular()
    return s.pinv(q)


def _rate_near():
    from netcosim.controllers.planner import configuration_rate
    s, q = _near_singular()
    return configuration_rate(s, q, [1.0] * 9)


def _check_near():
    s, q = _near_singular()
    return s.check_configuration(q, what="q0")


def _plant_start_near():
    from netcosim.plants.flycrane.input_modes import KinematicPlant
    s, q = _near_singular()
    return KinematicPlant(s).initial_state(q)


def _system(**kw):
    from netcosim.plants.flycrane import MultiRobotSystem, TwoCable
    from netcosim.plants.flycrane.configurations import regular_polygon
    V = regular_polygon(3, 1.0)
    return MultiRobotSystem([TwoCable(V[i], V[(i + 1) % 3], 1.5) for i in range(3)], **kw)


def _gimbal():
    s = _sys()
    q = s.q_nominal.copy()
    q[7] = math.pi / 2
    return s.check_configuration(q)


def _h_nan():
    s = _sys()
    q = s.q_nominal.copy()
    q[2] = NAN
    return s.h(q)


def _jac_short():
    return _sys().jacobian([0.0] * 8)


def _velocity_tracking(alpha):
    from netcosim.plants.flycrane.input_modes import VelocityTrackingPlant
    return VelocityTrackingPlant(_sys(), alpha)


def _kin_noise(std):
    import numpy as np

    from netcosim.plants.flycrane.input_modes import KinematicPlant
    return KinematicPlant(_sys(), noise_std=std, rng=np.random.default_rng(0))


def _mass(**kw):
    from netcosim.plants.flycrane import MassProperties
    base = dict(platform_mass=0.3, platform_inertia=[[1, 0, 0], [0, 1, 0], [0, 0, 2]], robot_masses=(1.0,) * 3)
    base.update(kw)
    return MassProperties(**base)


def _planner_velocity(K):
    from netcosim.controllers.planner import planner_velocity
    s = _sys()
    return planner_velocity(s, s.q_nominal, s.q_nominal, K)


def _simulate(T):
    from netcosim.controllers.planner import OfflineGain, simulate_sampled
    s = _sys()
    return simulate_sampled(s, s.q_nominal, s.q_nominal, T, OfflineGain(1.0), n_samples=1)


def _offline(k):
    from netcosim.controllers.planner import OfflineGain
    return OfflineGain(k)


def _law(**kw):
    from netcosim.controllers.planner import OfflineGain
    from netcosim.controllers.planner.tasks import PlannerLaw
    base = dict(gain=OfflineGain(1.0), q_ref=[0.0] * 9)
    base.update(kw)
    return PlannerLaw(**base)


def _deploy(**kw):
    from netcosim import Simulation
    from netcosim.controllers.planner import OfflineGain
    from netcosim.controllers.planner.tasks import PlannerLaw, deploy_planner
    s = _sys()
    base = dict(architecture="centralized")
    base.update(kw)
    return deploy_planner(Simulation(), s, s.q_nominal, 0.1, PlannerLaw(gain=OfflineGain(1.0), q_ref=s.q_nominal),
                          **base)


def _polygon(k, edge):
    from netcosim.plants.flycrane.configurations import regular_polygon
    return regular_polygon(k, edge)


def _thesis(**kw):
    from netcosim.plants.flycrane.configurations import thesis_flycrane
    return thesis_flycrane(**kw)


def _square(a, b):
    from netcosim.plants.flycrane.configurations import square_family
    return square_family(a, b)


def _mu(mu):
    from netcosim.controllers.planner.gain_design import design
    return design(mu)


E = ValueError
T = TypeError

CASES = [
    # singular by the one rule (condition number 1.19e8 > 1e8): accepted before
    Case("flycrane-pinv-near-singular", _pinv_near, E, "3e-08"),
    Case("flycrane-planner-rate-near-singular", _rate_near, E, "3e-08"),
    Case("flycrane-check-configuration-near-singular", _check_near, E, "q0 = [3e-08"),
    Case("flycrane-kinematic-plant-start-near-singular", _plant_start_near, E, "3e-08"),
    Case("flycrane-singular-tol-above-one", lambda: _system(singular_tol=1.5), E, "1.5"),
    Case("flycrane-singular-tol-nan", lambda: _system(singular_tol=NAN), E, "nan"),
    Case("flycrane-singular-tol-string", lambda: _system(singular_tol="1e-8"), E, "'1e-8'"),
    # invalid configurations and geometry
    Case("flycrane-gimbal-lock", _gimbal, E, "1.5707963267948966"),
    Case("flycrane-h-nan", _h_nan, E, "nan"),
    Case("flycrane-jacobian-wrong-size", _jac_short, E, "(8,)"),
    Case("flycrane-cable-length-negative", lambda: _thesis(cable_length=-1.5), E, "-1.5"),
    Case("flycrane-cable-too-short", lambda: _thesis(cable_length=0.4), E, "0.4"),
    Case("flycrane-polygon-two-vertices", lambda: _polygon(2, 1.0), E, "2"),
    Case("flycrane-polygon-edge-nan", lambda: _polygon(3, NAN), E, "nan"),
    Case("flycrane-square-family-not-square", lambda: _square(1, 1), E, "(1, 1)"),
    Case("flycrane-platform-mass-nan", lambda: _mass(platform_mass=NAN), E, "nan"),
    Case("flycrane-robot-mass-negative", lambda: _mass(robot_masses=(1.0, -1.0, 1.0)), E, "-1.0"),
    # plants
    Case("flycrane-velocity-tracking-alpha-nan", lambda: _velocity_tracking(NAN), E, "nan"),
    Case("flycrane-velocity-tracking-alpha-string", lambda: _velocity_tracking("500"), E, "'500'"),
    Case("flycrane-kinematic-noise-negative", lambda: _kin_noise(-0.1), E, "-0.1"),
    # planners
    Case("flycrane-planner-gain-nan", lambda: _planner_velocity(NAN), E, "nan"),
    Case("flycrane-planner-period-nan", lambda: _simulate(NAN), E, "nan"),
    Case("flycrane-planner-period-negative", lambda: _simulate(-0.1), E, "-0.1"),
    Case("flycrane-offline-gain-zero", lambda: _offline(0.0), E, "0.0"),
    Case("flycrane-planner-law-gain-type", lambda: _law(gain="fast"), T, "'fast'"),
    Case("flycrane-planner-law-feedforward", lambda: _law(feedforward="later"), E, "'later'"),
    Case("flycrane-deploy-architecture", lambda: _deploy(architecture="mesh"), E, "'mesh'"),
    Case("flycrane-deploy-size-bits", lambda: _deploy(size_bits=-64), E, "-64"),
    Case("flycrane-gain-design-mu-negative", lambda: _mu(-0.5), E, "-0.5"),
]
