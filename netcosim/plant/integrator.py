"""What an integrator is to a plant: the protocol every integrator follows.

An integrator advances a plant's state between two I/O instants::

    integrate(rhs, t0, x0, t1, gs) -> (t_end, x_end, index of the fired guard or None)

``rhs(t, x)`` is the plant's checked right-hand side, *gs* its guards (pairs ``(g(t, x),
direction)``, see :mod:`netcosim.plant.events`); integration stops at *t1* (s) or at the
first crossing of a guard.  An integrator may also have ``bind(plant) -> stepper``:
:class:`~netcosim.plant.instance.PlantInstance` calls it once, when the plant is
created, and integrates with the stepper it returns (an integrator specialised to the
plant, or another integrator).  One module per integrator: :mod:`~netcosim.plant.rk4`,
:mod:`~netcosim.plant.solve_ivp`, :mod:`~netcosim.plant.exact_zoh`.
"""

from __future__ import annotations

from typing import Any, Callable, Protocol, Sequence

import numpy as np

from .events import Guard
from .system import ContinuousSystem

__all__ = ["Stepper", "Integrator", "BoundPlant"]


class Stepper(Protocol):
    """Advances a state from *t0* to *t1* (s), stopping at the first crossing of a guard.

    A protocol: any object with this :meth:`integrate` method is a stepper, and can be
    given as a plant's ``integrator=`` (:class:`~netcosim.plant.instance.PlantInstance`).

    Raises
    ------
    TypeError
        on ``Stepper()``: a protocol describes steppers, it is not one.

    Examples
    --------
    Forward Euler with a step of 0.1 s (no guards) as the integrator of
    ``dx/dt = -x``: after 1 s the state is ``(1 - 0.1)^10``, against ``e^-1`` = 0.367879
    exactly:

    >>> from netcosim import Simulation
    >>> from netcosim.plant import ContinuousSystem
    >>> class Euler:
    ...     def __init__(self, dt):
    ...         self.dt = dt
    ...     def integrate(self, rhs, t0, x0, t1, gs):
    ...         t, x = t0, x0
    ...         while t < t1:
    ...             h = min(self.dt, t1 - t)
    ...             x, t = x + h * rhs(t, x), t + h
    ...         return t1, x, None
    >>> decay = ContinuousSystem(f=lambda t, x, u, p: -x, states=["x"], name="decay")
    >>> sim = Simulation()
    >>> plant = sim.plant(decay, [1.0], integrator=Euler(dt=0.1), log="none")
    >>> sim.run(until=1.0)
    >>> round(float(plant.state[0]), 6), round(0.9 ** 10, 6)
    (0.348678, 0.348678)
    """

    def integrate(self, rhs: Callable[[float, np.ndarray], np.ndarray], t0: float, x0: np.ndarray, t1: float,
                  gs: Sequence[Guard]) -> tuple[float, np.ndarray, int | None]:
        """``(t_end, x_end, index of the fired guard or None)`` after integrating ``dx/dt = rhs(t, x)``
        from ``(t0, x0)`` to *t1* (s) or to the first crossing of a guard of *gs*."""
        ...


class Integrator(Stepper, Protocol):
    """A stepper that may bind itself to the plant it advances.

    :class:`~netcosim.plant.rk4.RK4`, :class:`~netcosim.plant.solve_ivp.SolveIVP`,
    :class:`~netcosim.plant.exact_zoh.ExactZOH` and
    :class:`~netcosim.plant.noisy_zoh.NoisyZOH` are integrators.

    Examples
    --------
    ``integrate`` called directly on ``dx/dt = -x`` from ``x(0) = 1``, with the guard
    ``x - 0.5`` (falling): both integrators stop at its crossing, ``t = ln 2`` s,
    and report guard 0:

    >>> import math
    >>> import numpy as np
    >>> from netcosim.plant import RK4, SolveIVP
    >>> half = [(lambda t, x: x[0] - 0.5, -1)]
    >>> for integrator in (RK4(dt=0.01), SolveIVP()):
    ...     t, x, fired = integrator.integrate(lambda t, x: -x, 0.0, np.array([1.0]), 1.0, half)
    ...     print(integrator, round(t, 6), round(float(x[0]), 6), fired)
    RK4(dt=0.01) 0.693147 0.5 0
    SolveIVP(method='RK45') 0.693147 0.5 0
    >>> round(math.log(2), 6)
    0.693147
    """

    def bind(self, plant: BoundPlant) -> Stepper:
        """The stepper that advances *plant* (called once, when the plant is created)."""
        ...


class BoundPlant(Protocol):
    """What a bound stepper reads of its plant (:class:`~netcosim.plant.instance.PlantInstance`)."""

    name: str
    system: ContinuousSystem
    params: Any
    u: np.ndarray
    disturbance: Callable[[float], Any] | None

    def _u_full(self, t: float) -> np.ndarray: ...

    def _rhs(self, t: float, x: np.ndarray) -> np.ndarray: ...
