"""Named variants of the two-layer landing controller, beside the thesis's scheme.

Each entry of :data:`SCHEMES` is the keyword arguments of
:func:`~netcosim.controllers.landing.run_landing` (with ``controller="2lc"``) that make
the variant; ``"thesis"`` is empty because the defaults are the thesis's scheme:

``"thesis"``          (2.13) with x₀ = x̂₀: the NMPC starts every plan from the whole
                      measured state (angles, rates and the applied thrust and torque,
                      ``nmpc_init="measured"``, ``actuator_state="measured"``); low-level
                      poles at -120 rad/s (:data:`DEFAULT_FL_GAINS`).
``"plan"``            departure: (f_R, τ_R) of the NMPC's initial state from its
                      previous plan (``actuator_state="plan"``), same gains.
``"slow_gains"``      departure: the thesis's scheme with the project's former poles at
                      -60 rad/s (:data:`SLOW_FL_GAINS`).
``"former_default"``  departure: the project's former default, ``"plan"`` with the
                      -60 rad/s poles (the "fragile under delay" scheme of the audit).
``"reference"``       departure: each plan starts from the low-level reference and
                      its previous plan's (f_R, τ_R) (``nmpc_init="reference"``,
                      ``actuator_state="plan"``), for delayed plans.

Their numbers against the NMPC delay are in docs/nmpc.md.
"""

from __future__ import annotations

from .feedback_linearization import SLOW_FL_GAINS

__all__ = ["SCHEMES", "SCHEME_LABELS"]

#: Variant name -> keyword arguments of ``run_landing("2lc", ...)``.
SCHEMES: dict[str, dict] = {
    "thesis": {},
    "plan": {"actuator_state": "plan"},
    "slow_gains": {"fl_gains": SLOW_FL_GAINS},
    "former_default": {"actuator_state": "plan", "fl_gains": SLOW_FL_GAINS},
    "reference": {"nmpc_init": "reference", "actuator_state": "plan"},
}

#: Variant name -> a label for tables and figures.
SCHEME_LABELS: dict[str, str] = {
    "thesis": "2LC, thesis scheme (x0 = measured state, poles -120 rad/s)",
    "plan": "2LC, (f_R, tau_R) from the plan (variant)",
    "slow_gains": "2LC, thesis scheme with poles -60 rad/s (variant)",
    "former_default": "2LC, plan + poles -60 rad/s (former default)",
    "reference": "2LC, NMPC from the reference (variant)",
    "nmpc": "NMPC alone",
}
