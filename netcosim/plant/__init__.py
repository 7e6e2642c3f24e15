"""Continuous plants coupled to the discrete world by lazy integration (see :mod:`netcosim.plant.instance`).

Systems of python-control are converted by :mod:`netcosim.plant.pycontrol`.
"""

from .instance import (
    DEFAULT_LOG_INTERVAL,
    EVENT_REARM,
    IMPLICIT_METHODS,
    MAX_DIMENSION,
    RK4,
    RTOL_MIN,
    SHARED_TRANSITIONS_SIZE,
    SOLVE_IVP_METHODS,
    ContinuousSystem,
    ExactZOH,
    HybridEvent,
    InputPort,
    IntegrationError,
    NotConnectedError,
    OutputPort,
    PlantInstance,
    SolveIVP,
    UnknownPortError,
    default_log_interval,
)
from .pycontrol import LinearPlant, NonlinearPlant, from_control, is_control_system

__all__ = ["EVENT_REARM", "DEFAULT_LOG_INTERVAL", "default_log_interval", "HybridEvent", "ContinuousSystem",
           "MAX_DIMENSION", "RK4", "SolveIVP", "ExactZOH", "SOLVE_IVP_METHODS", "IMPLICIT_METHODS", "RTOL_MIN",
           "SHARED_TRANSITIONS_SIZE", "OutputPort", "InputPort", "UnknownPortError",
           "PlantInstance", "NotConnectedError", "IntegrationError",
           "from_control", "is_control_system", "LinearPlant", "NonlinearPlant"]
