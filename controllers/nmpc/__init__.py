"""Real-time-iteration nonlinear MPC (multiple shooting, Gauss–Newton, CasADi).

The code is in :mod:`controllers.nmpc.rti`; every public name is re-exported here.
"""

from .rti import OCP, QP_SOLVERS, RTINMPC, FullSolution, RTIStep, rk4_discretize
from .rti import _status_text as _status_text  # imported by tests

__all__ = ["OCP", "RTINMPC", "RTIStep", "FullSolution", "QP_SOLVERS", "rk4_discretize"]
