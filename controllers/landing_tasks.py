"""Former location of the ch. 2 landing tasks (kept as an alias).

The code lives in the package :mod:`controllers.landing`.
"""

from .landing import DEFAULT_FL_GAINS, SIM_PARAMS, LandingRun, LandingTiming, landing_metrics, run_landing

__all__ = ["LandingTiming", "LandingRun", "run_landing", "landing_metrics", "SIM_PARAMS", "DEFAULT_FL_GAINS"]
