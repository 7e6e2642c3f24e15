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
    """Advances a state from *t0* to *t1* (s), stopping at the first crossing of a guard."""

    def integrate(self, rhs: Callable[[float, np.ndarray], np.ndarray], t0: float, x0: np.ndarray, t1: float,
                  gs: Sequence[Guard]) -> tuple[float, np.ndarray, int | None]:
        """``(t_end, x_end, index of the fired guard or None)`` after integrating ``dx/dt = rhs(t, x)``
        from ``(t0, x0)`` to *t1* (s) or to the first crossing of a guard of *gs*."""
        ...


class Integrator(Stepper, Protocol):
    """A stepper that may bind itself to the plant it advances."""

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
