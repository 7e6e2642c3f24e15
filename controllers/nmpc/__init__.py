"""Real-time-iteration nonlinear MPC (multiple shooting, Gauss–Newton, CasADi).

Modules, from the problem to its solvers:

===============================================  =====================================================
:mod:`~netcosim.controllers.nmpc.ocp`            :class:`OCP` (the least-squares optimal control
                                                 problem, its input checks) and :func:`rk4_discretize`
:mod:`~netcosim.controllers.nmpc.transcription`  its multiple-shooting NLP in stage-wise order
:mod:`~netcosim.controllers.nmpc.qp`             the QP solvers (:data:`QP_SOLVERS`), their default
                                                 options and status names
:mod:`~netcosim.controllers.nmpc.hpipm`          HPIPM called directly, its QP data set in the
                                                 preparation phase (the RTI's default path)
:mod:`~netcosim.controllers.nmpc.rti`            the real-time iteration :class:`RTINMPC` (Diehl et
                                                 al., 2002) and its per-sample :class:`RTIStep`
:mod:`~netcosim.controllers.nmpc.full`           converged solves: :class:`FullSolution`, IPOPT
===============================================  =====================================================

Every public name is re-exported here: ``from netcosim.controllers.nmpc import OCP, RTINMPC``.

Units are those of the model; time in seconds.  All angles are whatever the model
uses (radians for the models of this project).
"""

from .full import FullSolution
from .ocp import OCP, rk4_discretize
from .qp import QP_SOLVERS
from .rti import RTINMPC, RTIStep

__all__ = ["OCP", "RTINMPC", "RTIStep", "FullSolution", "QP_SOLVERS", "rk4_discretize"]
