"""Former location of the ch. 2 low-level controller and interpolator (kept as an alias).

The code lives in :mod:`controllers.landing.feedback_linearization` and
:mod:`controllers.landing.interpolation`.
"""

from .landing.feedback_linearization import FeedbackLinearization, PIDGains, SingularityError
from .landing.interpolation import C2Interpolator, quintic_coefficients

__all__ = ["FeedbackLinearization", "C2Interpolator", "PIDGains", "SingularityError", "quintic_coefficients"]
