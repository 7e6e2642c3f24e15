"""Physical parameters of the tethered UAV of thesis ch. 2 (SI units, no CasADi).

:class:`TetheredUAVParams` lives here, apart from the equations of
:mod:`netcosim.plants.tethered_uav` (which need CasADi), so that code running on a vehicle --
the low-level controller of §2.5 in a separate process -- can use the parameters with
NumPy alone.  :mod:`netcosim.plants.tethered_uav` re-exports it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from netcosim.validate import numeric_fields

__all__ = ["TetheredUAVParams"]


@dataclass(frozen=True)
class TetheredUAVParams:
    """Physical parameters of the tethered UAV and of its simulation model (SI units).

    The thesis gives only the bounds of Table 2.1 (0 ≤ f_R ≤ 15 N, ``|τ_R| ≤ 1.2`` N·m,
    0 ≤ f_L ≤ 10 N), the slope of §2.6.2 (ϑ* = 30° = -φ*) and the structure of the
    simulation non-idealities (§2.6.1).  Everything else is chosen here for a ~1 kg
    vehicle; the reason for each value is next to it.

    Fields: ``m_B`` vehicle mass [kg]; ``J_B`` inertia about y_B [kg·m²]; ``l`` cable
    length [m]; ``d`` propeller-CoM distance [m]; ``g`` gravity [m/s²]; ``alpha`` slope
    of the landing plane [rad, in (-π/2, π/2)]; ``f_R_max`` thrust [N], ``tau_R_max``
    torque [N·m] and ``f_L_max`` cable stress [N] bounds of Table 2.1; ``lander_height``
    h [m, < l], ``k_el`` stiffness [N/m] and ``xi`` damping [N·s/m] of the landers
    (2.17); the wind of §2.6.1: a 1 - cosine pulse of ``wind_pulse_amplitude`` [N]
    lasting ``wind_pulse_duration`` [s] from t = 0, and a sinusoid of
    ``wind_sine_amplitude`` [N] at ``wind_sine_frequency`` [Hz] from
    ``wind_sine_start`` [s].  Lengths, masses, the thrust bounds and g are positive,
    the lander and wind timing non-negative.
    """

    #: Vehicle mass [kg]: a ~1 kg quadrotor.  Hover needs 9.81 N, 65 % of the 15 N
    #: thrust bound of Table 2.1 (thrust-to-weight 1.5, typical of such vehicles).
    m_B: float = 1.0
    #: Inertia about y_B [kg·m²]: 1 kg frame with 0.16 m arms (motors of ~0.1 kg at
    #: the arm tips give 2·0.1·0.16² ≈ 5e-3, the body about as much again).
    J_B: float = 0.01
    #: Cable length [m]: a short tether as in laboratory rigs; with l = 1 m the
    #: centripetal load at the ~100 °/s of §2.6.2 is m l φ̇² ≈ 3 N, inside f_L ≤ 10 N.
    l: float = 1.0  # noqa: E741 (the thesis's name)
    #: Distance propeller–CoM [m]: with each propeller limited to f_R,max/2 = 7.5 N,
    #: (2.1) gives ``|τ_R| ≤ d · 7.5`` N = 1.2 N·m, the torque bound of Table 2.1.
    d: float = 0.16
    #: Gravity [m/s²].
    g: float = 9.81
    #: Slope of the landing plane [rad]: 30°, the final attitude ϑ* = -φ* of §2.6.2.
    alpha: float = math.pi / 6
    #: Table 2.1 bounds: thrust [N], torque [N·m], cable stress [N].
    f_R_max: float = 15.0
    tau_R_max: float = 1.2
    f_L_max: float = 10.0
    #: Lander height h of (2.17) [m]: 1 cm legs.  With l = 1 m the landers stop the CoM
    #: at φ ≈ -α + asin(h/l), so 1 cm lets the landing reach φ* = -α within 1° as in
    #: Fig. 2.8 (5 cm would stop it ~2.7° short); the propellers sit in the body plane,
    #: so they still clear the slope when the body is parallel to it.
    lander_height: float = 0.01
    #: Lander stiffness k_el of (2.17) [N/m]: deflects ~8 mm under the normal weight
    #: component m g cos α ≈ 8.5 N; contact natural frequency sqrt(k/m) ≈ 5 Hz.
    k_el: float = 1000.0
    #: Lander damping ξ of (2.17) [N·s/m], multiplying the CoM velocity normal to the
    #: slope: 2·0.7·sqrt(k_el m_B) ≈ 44, i.e. a damping ratio of ~0.7.
    xi: float = 45.0
    #: Wind of §2.6.1 along x_W at the CoM (model structure of Sandino et al. 2014).
    #: Pulse: a "1 - cosine" gust peaking at 3 N (drag 0.5·ρ·C_d·A·v² of a ~0.05 m²
    #: frontal area at ~10 m/s) lasting 50 ms from t = 0 [N, s].  The 1 - cosine shape
    #: (the discrete-gust shape of flight-dynamics standards) is continuous with a
    #: continuous slope, so fixed-step integrators keep their order across it.
    wind_pulse_amplitude: float = 3.0
    wind_pulse_duration: float = 0.05
    #: Sinusoid from t = 0.1 s: ±1 N (gusts of ~±6 m/s) at 1 Hz, slow with respect to
    #: the 500 Hz inner loop and visible within the ~1 s landing [N, Hz, s].
    wind_sine_amplitude: float = 1.0
    wind_sine_frequency: float = 1.0
    wind_sine_start: float = 0.1

    def __post_init__(self):
        numeric_fields(
            self, positive=("m_B", "J_B", "l", "d", "g", "f_R_max", "tau_R_max", "f_L_max", "lander_height"),
            non_negative=("k_el", "xi", "wind_pulse_duration", "wind_sine_frequency", "wind_sine_start"))
        if not -math.pi / 2 < self.alpha < math.pi / 2:
            raise ValueError(f"TetheredUAVParams.alpha must lie in (-pi/2, pi/2) rad, got {self.alpha!r}")
        if self.lander_height >= self.l:
            raise ValueError(f"TetheredUAVParams.lander_height={self.lander_height!r} m must be shorter "
                             f"than the cable l={self.l!r} m")

    # Coefficients of (2.3).
    @property
    def a1(self) -> float:
        """a_1 = -g / l [1/s²]."""
        return -self.g / self.l

    @property
    def a2(self) -> float:
        """a_2 = 1 / (m_B l) [1/(kg·m)]."""
        return 1.0 / (self.m_B * self.l)

    @property
    def a3(self) -> float:
        """a_3 = 1 / J_B [1/(kg·m²)]."""
        return 1.0 / self.J_B
