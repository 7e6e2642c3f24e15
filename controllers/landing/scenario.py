"""The configuration of one landing run (§2.6.2): which controller, where, how fast.

:class:`LandingScenario` gathers every choice :func:`~netcosim.controllers.landing.run_landing`
takes, checks it once when built (errors name the bad value) and fills in the
defaults, so the wiring and the tasks read plain, valid values.

All angles in radians, rates in rad/s, forces in N, torques in N·m, times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError
from netcosim.plants.tethered_uav import TetheredUAVParams

from .feedback_linearization import DEFAULT_FL_GAINS, PIDGains
from .ocp import LandingConfig, initial_state
from .timing import LandingTiming

__all__ = ["LandingScenario", "SIM_PARAMS", "DEFAULT_FL_GAINS", "CONTROLLERS", "TOPOLOGIES"]

#: Simulation-model parameters of the ch. 2 experiments: the project defaults (1 cm
#: landers, which stop the CoM within 1° of φ* = -α as in Fig. 2.8).
SIM_PARAMS = TetheredUAVParams()


#: The controllers: NMPC alone on the rate-input plant, or the two-layer controller.
CONTROLLERS = ("nmpc", "2lc")
#: Where the tasks run: all on node ``onboard``, or the NMPC on node ``ground``.
TOPOLOGIES = ("single", "two_nodes")

#: The string options and their two allowed values, in the order they are checked.
_CHOICES = {"nmpc_init": ("measured", "reference"), "topology": TOPOLOGIES,
            "actuator_state": ("plan", "measured"), "controller": CONTROLLERS}


@dataclass(frozen=True, eq=False)
class LandingScenario:
    """One landing run of §2.6.2, validated; see :func:`~netcosim.controllers.landing.run_landing`
    for the meaning of each field (``controller``, ``wind``, ``duration``, ``nmpc_period``,
    ``fl_period``, ``integrator_dt``, ``log_interval``, ``seed``, ``topology``, ``network``,
    ``ref_knots``, ``reset_tol`` and the others).

    Defaults left as ``None`` are filled in when the scenario is built: ``params`` →
    :data:`SIM_PARAMS`, ``config`` → ``LandingConfig()``, ``timing`` →
    ``LandingTiming()`` (ideal, zero CPU times), ``fl_gains`` →
    :data:`DEFAULT_FL_GAINS`, ``x0`` → hover at φ = ϑ = 0 (as an array
    ``[φ, φ̇, ϑ, ϑ̇]``), ``nmpc_kw`` → ``{}``.  ``nmpc_init`` defaults to
    ``"measured"`` and ``actuator_state`` to ``"measured"``: the thesis's scheme (§2.4:
    x₀ = x̂₀, the whole measured state, the applied thrust and torque included);
    ``nmpc_init="reference"`` is the reference-start variant for delayed plans and
    ``actuator_state="plan"`` the variant whose NMPC takes (f_R, τ_R) from its shifted
    previous plan (both departures, docs/nmpc.md).  ``ff_lead=None`` stays ``None``:
    :attr:`feedforward_lead` derives half the low-level period from it.  Vary one
    field with :func:`dataclasses.replace`.
    """

    controller: str = "2lc"
    wind: bool = False
    duration: float = 1.5
    params: TetheredUAVParams | None = None
    config: LandingConfig | None = None
    timing: LandingTiming | None = None
    fl_gains: PIDGains | None = None
    x0: Any = None
    nmpc_period: float = 0.01
    fl_period: float = 0.002
    integrator_dt: float = 1e-4
    log_interval: float = 1e-3
    seed: int = 0
    nmpc_kw: dict | None = None
    actuator_state: str = "measured"
    ff_lead: float | None = None
    topology: str = "single"
    network: Callable | None = None
    ref_knots: int = 3
    nmpc_init: str = "measured"
    reset_tol: tuple[float, float] = field(default=(math.radians(2.0), math.radians(20.0)))

    def __post_init__(self):
        # the checks run in this order, so that the first bad value is the one reported
        self._check_ref_knots()
        self._check_choice("nmpc_init")
        self._check_choice("topology")
        if self.topology == "two_nodes" and self.controller != "2lc":
            raise ValueError(f"the two-node variant needs the two-layer controller, "
                             f"got controller={self.controller!r}")
        self._check_ff_lead()
        self._check_choice("actuator_state")
        self._check_choice("controller")
        d = self.duration
        validate.positive(d, "duration", kind="a positive number of seconds", type_error=ConfigurationError)
        self._fill_defaults()
        if abs(self.nmpc_period - self.config.Ts) > 1e-12:
            raise ValueError(f"nmpc_period={self.nmpc_period!r} s must equal the shooting interval "
                             f"Ts={self.config.Ts!r} s")
        q0 = np.zeros(4) if self.x0 is None else np.asarray(self.x0, dtype=float).reshape(4)
        object.__setattr__(self, "x0", q0)

    def _check_ref_knots(self) -> None:
        k = self.ref_knots
        n = self.config.N if self.config is not None else LandingConfig().N
        validate.integer(k, "ref_knots", lo=1, hi=n, kind="an integer between 1 and N", type_error=ConfigurationError)

    def _check_choice(self, name: str) -> None:
        v, (a, b) = getattr(self, name), _CHOICES[name]
        validate.choice(v, name, (a, b), kind=f"{a!r} or {b!r}")

    def _check_ff_lead(self) -> None:
        v = self.feedforward_lead
        validate.real(v, "ff_lead", lo=0.0, hi=self.nmpc_period, kind="a number of seconds in [0, nmpc_period]",
                      type_error=ConfigurationError)

    def _fill_defaults(self) -> None:
        defaults = dict(params=SIM_PARAMS, config=LandingConfig(), timing=LandingTiming(),
                        fl_gains=DEFAULT_FL_GAINS, nmpc_kw={})
        for name, value in defaults.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, value)

    @property
    def feedforward_lead(self) -> float:
        """``ff_lead`` [s], or half the low-level period when it is ``None`` (derived on
        each read, so that :func:`dataclasses.replace` of ``fl_period`` moves it too)."""
        return 0.5 * self.fl_period if self.ff_lead is None else self.ff_lead

    @property
    def plant_inputs(self) -> str:
        """Input mode of the plant: ``"rates"`` (ḟ_R, τ̇_R) for NMPC alone, ``"forces"``
        (f_R, τ_R) for the two-layer controller."""
        return "rates" if self.controller == "nmpc" else "forces"

    def initial_state(self) -> np.ndarray:
        """The full initial state ``[φ, φ̇, ϑ, ϑ̇, f_R, τ_R]``: :attr:`x0` with the hover
        thrust at its angles and zero torque."""
        q0 = self.x0
        xs0 = initial_state(q0[0], q0[2], self.params)
        xs0[1], xs0[3] = q0[1], q0[3]
        return xs0
