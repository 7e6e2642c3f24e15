"""The kinematic local planners of thesis ch. 3-5 for star-shaped multi-robot systems.

A kinematic system is any object with ``n``, ``m``, ``h(q)`` and ``jacobian(q)`` (and
``pinv(q)``): :class:`netcosim.plants.kinematic.KinematicSystem`, the one model shared with the
plants.  The robots are velocity controlled, ``p_dot = u`` (3.4); the configuration
moves as ``q_dot = A_q^+ u`` (3.7)/(4.6)/(4.13).

============================  ==========================================================
module                        holds
============================  ==========================================================
:mod:`.kinematics`            argument checks, the kinematic model re-exported from
                              :mod:`netcosim.plants.kinematic`, ``integrate_kinematics``
:mod:`.norms`                 :class:`WeightedNorm` ``||D e||_p``
:mod:`.structure`             :class:`StarStructure`, the sparsity (3.3)
:mod:`.laws`                  the laws (3.8)/(3.10)/(3.11)/(4.14)/(4.16), gains, closed loop
:mod:`.flow`                  auxiliary flow (3.12)/(4.17), online gain (3.26)/(4.30)
:mod:`.dop853`                the DOP853 stepper of the flow, dense output, event location
:mod:`.dop853_coefficients`   the DOP853 tableau (Hairer, Norsett & Wanner), vendored
:mod:`.gain_design`           offline gain design (3.21)-(3.25), (4.27)-(4.29)
:mod:`.clearance`             closest robot-robot approach of a planned motion, between
                              the samples too (§6.3)
:mod:`.sikm`                  sampled tracking, ch. 5 (SIKM)
:mod:`.sikm_environment`      the realistic environment of Fig. 5.6 (dynamic model, MoCap, UKF)
:mod:`.plant_models`          plants under the tasks: kinematic, dynamic (4.10)-(4.11)
:mod:`.plant_dop853`          DOP853 for CasADi plants, each step one compiled call
:mod:`.tasks`                 the laws as netcosim tasks in both architectures (Fig. 3.3/5.1)
:mod:`.networked`             the networked Fly-crane of §4.6.1 over lossy 802.11b
============================  ==========================================================

Units: q in rad and m, u in m/s, times and periods in s, gains in 1/s.
"""

from .flow import (
                         FLOW_ATOL_REL,
                         FLOW_RTOL,
                         PIVOT_RTOL,
                         TAU_XTOL,
                         AuxiliaryFlow,
                         DenseFlow,
                         online_gain,
                         solve_auxiliary_flow,
)
from .kinematics import (
                         RANK_RTOL,
                         KinematicSystem,
                         SingularConfigurationError,
                         as_vector,
                         check_gain_matrix,
                         check_period,
                         check_system,
                         configuration_rate,
                         diag_gain,
                         integrate_kinematics,
                         jacobian,
                         pinv_solve,
                         project,
)
from .laws import OfflineGain, OnlineGain, planner_velocity, robot_velocity, sampled_velocity, simulate_sampled
from .norms import WeightedNorm
from .structure import StarStructure

__all__ = ["KinematicSystem", "SingularConfigurationError", "RANK_RTOL", "check_system", "check_period",
           "check_gain_matrix", "diag_gain", "as_vector", "jacobian", "pinv_solve", "configuration_rate", "project",
           "integrate_kinematics", "WeightedNorm", "StarStructure", "planner_velocity", "robot_velocity",
           "sampled_velocity", "OfflineGain", "OnlineGain", "simulate_sampled", "AuxiliaryFlow", "DenseFlow",
           "solve_auxiliary_flow", "online_gain", "FLOW_RTOL", "FLOW_ATOL_REL", "TAU_XTOL", "PIVOT_RTOL"]
