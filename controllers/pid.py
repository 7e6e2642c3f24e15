"""Discrete PID with set-point weighting and filtered derivative (TrueTime's ``pidcode``).

The law, each sample::

    P = K (beta r - y)
    D = Td/(N h + Td) D_old + N K Td/(N h + Td) (y_old - y)     (derivative on y,
                                                                 backward difference)
    u = P + I + D
    I <- I + K h / Ti (r - y)                                  (forward Euler)

``h`` is the sampling period in seconds.  The defaults are TrueTime's servo example
(K = 0.96, Ti = 0.12, Td = 0.049, beta = 0.5, N = 10) for G(s) = 1000 / (s (s + 1)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from netcosim import validate
from netcosim.errors import ConfigurationError


@dataclass
class PID:
    """State and parameters of one PID loop. Call :meth:`compute` once per sample.

    ``h``: the sampling period [s]; ``K``: the proportional gain (control units per
    measurement unit); ``Ti``: the integral time [s]; ``Td``: the derivative time [s]
    (>= 0; 0: no derivative action); ``beta``: the set-point weight of the proportional
    part; ``N``: the derivative filter's bound on the derivative gain (the filter's time
    constant is ``Td / N``).  All finite; ``h``, ``K``, ``Ti``, ``N`` positive.  The law:
    the module docstring.

    Examples
    --------
    The first sample from rest: only the proportional part acts, ``K * beta * r``.

    >>> from netcosim.controllers.pid import PID
    >>> pid = PID(h=0.006)
    >>> round(pid.compute(1.0, 0.0), 6)
    0.48
    """

    h: float
    K: float = 0.96
    Ti: float = 0.12
    Td: float = 0.049
    beta: float = 0.5
    N: float = 10.0
    I: float = field(default=0.0, init=False)
    D: float = field(default=0.0, init=False)
    y_old: float = field(default=0.0, init=False)

    def __post_init__(self):
        for name in ("h", "K", "Ti", "N"):
            validate.positive(getattr(self, name), f"PID {name}", type_error=ConfigurationError)
        validate.non_negative(self.Td, "PID Td")
        validate.finite(self.beta, "PID beta", kind="a finite number (the set-point weight)")
        self._ad = self.Td / (self.N * self.h + self.Td)
        self._bd = self.N * self.K * self.Td / (self.N * self.h + self.Td)

    def compute(self, r: float, y: float) -> float:
        """Control signal for reference *r* and measurement *y*; updates the state.

        *r* and *y* must be finite real numbers: anything else raises naming it
        (ConfigurationTypeError / ConfigurationError) and leaves the state unchanged."""
        for what, v in (("r", r), ("y", y)):
            if not (validate.is_real(v) and math.isfinite(v)):
                validate.finite(v, f"PID.compute: {what}")
        P = self.K * (self.beta * r - y)
        self.D = self._ad * self.D + self._bd * (self.y_old - y)
        u = P + self.I + self.D
        self.I += self.K * self.h / self.Ti * (r - y)
        self.y_old = y
        return u
