"""The DC servo of TrueTime's examples: G(s) = k / (s (s + a)), default k = 1000, a = 1.

State x = (angle, angular velocity), input u (V), output y = angle (rad).
    dx0/dt = x1,    dx1/dt = -a x1 + k u
"""

from __future__ import annotations

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.plant import ContinuousSystem


def _real(v, what: str) -> float:
    if not validate.is_real(v):
        raise ConfigurationTypeError(f"{what} must be a real number, got {v!r}")
    return float(v)


class DCServo(ContinuousSystem):
    """DC servo ``k / (s (s + a))`` as a netcosim plant (``A``, ``B``, ``C`` for analysis).

    ``k``: gain in rad/(V·s²), finite and non-zero; ``a``: pole in 1/s, finite and >= 0.
    :meth:`jac` returns ``A``, so the implicit ``SolveIVP`` methods need no finite
    differences; ``A`` and ``B`` let ``integrator=ExactZOH()`` advance it by the exact
    zero-order-hold transition (no step size, no discretisation error).
    """

    name = "servo"
    state_names = ("angle", "velocity")
    input_names = ("u",)
    output_names = ("y",)

    def __init__(self, k: float = 1000.0, a: float = 1.0):
        super().__init__()
        kf, af = _real(k, "DC servo gain k"), _real(a, "DC servo pole a")
        if not (np.isfinite(kf) and kf != 0):
            raise ConfigurationError(f"DC servo gain k must be finite and non-zero, got {k!r}")
        if not (np.isfinite(af) and af >= 0):
            raise ConfigurationError(f"DC servo pole a must be finite and >= 0, got {a!r}")
        self.k, self.a = kf, af
        self.A = np.array([[0.0, 1.0], [0.0, -self.a]])
        self.B = np.array([[0.0], [self.k]])
        self.C = np.array([[1.0, 0.0]])

    def f(self, t, x, u, params):
        return np.array([x[1], -self.a * x[1] + self.k * u[0]])

    def h(self, t, x, u, params):
        return x[:1]

    def jac(self, t, x, u, params):
        """The Jacobian ``df/dx`` (:meth:`f` is linear): the constant ``A``, whatever the time *t*
        (s), state *x*, input *u* and *params*; what the implicit ``SolveIVP`` methods call."""
        return self.A
