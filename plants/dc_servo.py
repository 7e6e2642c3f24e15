"""The DC servo of TrueTime's examples: G(s) = k / (s (s + a)), default k = 1000, a = 1.

State x = (angle, angular velocity), input u (V), output y = angle (rad).
    dx0/dt = x1,    dx1/dt = -a x1 + k u
"""

from __future__ import annotations

import numpy as np

from netcosim.continuous import ContinuousSystem


class DCServo(ContinuousSystem):
    """DC servo ``k / (s (s + a))`` as a netcosim plant (``A``, ``B``, ``C`` for analysis)."""

    name = "servo"
    state_names = ("angle", "velocity")
    input_names = ("u",)
    output_names = ("y",)

    def __init__(self, k: float = 1000.0, a: float = 1.0):
        super().__init__()
        if not (np.isfinite(k) and k != 0):
            raise ValueError(f"DC servo gain k must be finite and non-zero, got {k!r}")
        if not (np.isfinite(a) and a >= 0):
            raise ValueError(f"DC servo pole a must be finite and >= 0, got {a!r}")
        self.k, self.a = float(k), float(a)
        self.A = np.array([[0.0, 1.0], [0.0, -self.a]])
        self.B = np.array([[0.0], [self.k]])
        self.C = np.array([[1.0, 0.0]])

    def f(self, t, x, u, params):
        return np.array([x[1], -self.a * x[1] + self.k * u[0]])

    def h(self, t, x, u, params):
        return x[:1]
