"""Thesis ch. 2: the landing of a tethered UAV with NMPC and a two-layer controller.

Modules, from the problem to the scenario:

===========================================================  ===============================================
:mod:`~netcosim.controllers.landing.ocp`                     the landing OCP of §2.3 and its RTI NMPC (§2.4)
:mod:`~netcosim.controllers.landing.feedback_linearization`  low-level controller of §2.5
:mod:`~netcosim.controllers.landing.interpolation`           the C² reference interpolator of Fig. 2.6
:mod:`~netcosim.controllers.landing.timing`                  CPU times of the tasks
:mod:`~netcosim.controllers.landing.scenario`                one run's validated configuration
:mod:`~netcosim.controllers.landing.tasks`                   shared loop state and the task factories
:mod:`~netcosim.controllers.landing.topology`                wiring per topology, :func:`run_landing`
:mod:`~netcosim.controllers.landing.result`                  :class:`LandingRun`, metrics, plot
:mod:`~netcosim.controllers.landing.variants`                named variants of the 2LC (:data:`SCHEMES`)
===========================================================  ===============================================

Every public name is re-exported here, so ``from netcosim.controllers.landing import
LandingConfig, landing_nmpc, run_landing`` works whatever module holds it.  Names are imported on first
use, so that importing one module
(e.g. the low-level controller) does not load the others.
"""

from typing import TYPE_CHECKING

from netcosim.lazy import lazy_exports

if TYPE_CHECKING:
    from .feedback_linearization import (
        DEFAULT_FL_POLE,
        SLOW_FL_GAINS,
        FeedbackLinearization,
        PIDGains,
        SingularityError,
    )
    from .interpolation import C2Interpolator, quintic_coefficients
    from .ocp import LandingConfig, initial_state, landing_nmpc, landing_ocp, sigmoid
    from .result import LandingRun, landing_metrics
    from .scenario import DEFAULT_FL_GAINS, SIM_PARAMS, LandingScenario
    from .tasks import LandingLoop
    from .timing import LandingTiming
    from .topology import run_landing, simulate_landing
    from .variants import SCHEME_LABELS, SCHEMES

# Names are imported on first use (PEP 562): importing a light module such as
# netcosim.controllers.landing.feedback_linearization (the low-level controller, which runs in a
# process without SimPy or CasADi) does not load the NMPC or the simulation.
_LAZY = {
    "FeedbackLinearization": "feedback_linearization",
    "PIDGains": "feedback_linearization",
    "SingularityError": "feedback_linearization",
    "DEFAULT_FL_POLE": "feedback_linearization",
    "SLOW_FL_GAINS": "feedback_linearization",
    "C2Interpolator": "interpolation",
    "quintic_coefficients": "interpolation",
    "LandingConfig": "ocp",
    "initial_state": "ocp",
    "landing_nmpc": "ocp",
    "landing_ocp": "ocp",
    "sigmoid": "ocp",
    "LandingRun": "result",
    "landing_metrics": "result",
    "DEFAULT_FL_GAINS": "scenario",
    "SIM_PARAMS": "scenario",
    "LandingScenario": "scenario",
    "LandingLoop": "tasks",
    "LandingTiming": "timing",
    "run_landing": "topology",
    "simulate_landing": "topology",
    "SCHEMES": "variants",
    "SCHEME_LABELS": "variants",
}

__all__ = [
    # the optimal control problem
    "LandingConfig", "landing_ocp", "landing_nmpc", "sigmoid", "initial_state",
    # the low-level controller and its reference
    "FeedbackLinearization", "PIDGains", "SingularityError", "C2Interpolator", "quintic_coefficients",
    # the landing as netcosim tasks
    "LandingTiming", "LandingScenario", "LandingLoop", "LandingRun", "run_landing", "simulate_landing",
    "landing_metrics", "SIM_PARAMS", "DEFAULT_FL_GAINS", "DEFAULT_FL_POLE", "SLOW_FL_GAINS",
    # named variants of the 2LC beside the thesis's scheme
    "SCHEMES", "SCHEME_LABELS",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
