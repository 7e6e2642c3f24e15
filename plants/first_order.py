"""A first-order lag: G(s) = k / (tau s + 1), the process of TrueTime's gateway example
(k = 10, tau = 10 s).

State x = output y, input u.   dx/dt = (k u - x) / tau
"""

from __future__ import annotations

import numpy as np

from netcosim import validate
from netcosim.plant import ContinuousSystem


class FirstOrder(ContinuousSystem):
    """First-order lag ``k / (tau s + 1)`` as a netcosim plant (``A``, ``B``, ``C`` for analysis).

    ``k``: static gain (output units per input unit), finite; ``tau``: time constant in
    seconds, finite and > 0.  Bad values raise naming them.
    """

    name = "first_order"
    state_names = ("y",)
    input_names = ("u",)
    output_names = ("y",)

    def __init__(self, k: float = 10.0, tau: float = 10.0):
        super().__init__()
        self.k = validate.finite(k, "first-order plant gain k")
        self.tau = validate.positive(tau, "first-order plant time constant tau (s)")
        self.A = np.array([[-1.0 / self.tau]])
        self.B = np.array([[self.k / self.tau]])
        self.C = np.array([[1.0]])

    def f(self, t, x, u, params):
        return np.array([(self.k * u[0] - x[0]) / self.tau])

    def h(self, t, x, u, params):
        return x[:1]

    def jac(self, t, x, u, params):
        """The Jacobian ``df/dx`` (:meth:`f` is linear): the constant ``A``, whatever the time *t*
        (s), state *x*, input *u* and *params*; what the implicit ``SolveIVP`` methods call."""
        return self.A
