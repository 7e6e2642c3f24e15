"""The classical fixed-step Runge-Kutta 4 integrator, and its stepper bound to a small plant."""

from __future__ import annotations

import math
import weakref
from itertools import chain
from typing import Iterator

import numpy as np

from .. import validate
from ..errors import ConfigurationError, IntegrationError
from ..timebase import RESOLUTION
from .events import crossed, locate_in_step
from .integrator import BoundPlant
from .values import _FLOAT, _check_count, _floats

__all__ = ["RK4"]


class RK4:
    """Classical fixed-step Runge–Kutta 4 with step *dt* seconds.

    The last step before an I/O instant is shortened so that every I/O instant is hit
    exactly.  Events are located on the RK4 step map with Brent's method to ``xtol``
    seconds.  Cost: 4 evaluations of ``f`` per step, ``ceil(interval / dt)`` steps per
    advance.  Explicit: stable only if ``dt`` is below about ``2.8 / |λ|`` for the
    fastest mode λ of the plant, so a stiff plant needs :class:`SolveIVP` with an
    implicit method instead.

    Parameters
    ----------
    dt: step in seconds; finite, positive and at least the time resolution
        (:data:`netcosim.RESOLUTION` = 1e-12 s).
    xtol: absolute tolerance in seconds on located event instants (> 0).
    max_steps: most steps one advance (one call of :meth:`integrate`) may take; an
        advance needing more raises :class:`~netcosim.errors.IntegrationError` before
        any step is taken (default 10**6, about 4·10**6 evaluations of ``f``).

    Raises
    ------
    ConfigurationTypeError
        *dt* is not a number, or *max_steps* is not an integer.
    ConfigurationError
        *dt* is not finite and positive, or is below :data:`netcosim.RESOLUTION`;
        *xtol* is not a positive finite number; *max_steps* is below 1.
    IntegrationError
        later, when an advance of the plant would take more than *max_steps* steps.

    Examples
    --------
    ``dx/dt = -x`` from ``x(0) = 1`` in steps of 0.1 s: after 1 s the state is
    ``e^-1`` = 0.367879441 to the method's fourth-order error (3.3e-7):

    >>> from netcosim import Simulation
    >>> from netcosim.plant import RK4, ContinuousSystem
    >>> decay = ContinuousSystem(f=lambda t, x, u, p: -x, states=["x"], name="decay")
    >>> sim = Simulation()
    >>> plant = sim.plant(decay, [1.0], integrator=RK4(dt=0.1))
    >>> sim.run(until=1.0)
    >>> round(float(plant.state[0]), 9)
    0.367879774
    >>> RK4(dt=1e-13)
    Traceback (most recent call last):
      ...
    netcosim.errors.ConfigurationError: RK4 step dt=1e-13 s is below the time resolution 1e-12 s (netcosim.RESOLUTION)
    """

    #: the most states a plant may have to be stepped on Python floats (see :meth:`bind`);
    #: measured: 1.4x faster at 2 states, even at about 18, slower beyond
    FLOAT_STEP_MAX_STATES = 16

    def __init__(self, dt: float = 1e-3, xtol: float = 1e-12, max_steps: int = 10**6):
        validate.positive(dt, "RK4 step dt", kind="a positive number of seconds")
        if dt < RESOLUTION:
            raise ConfigurationError(f"RK4 step dt={dt!r} s is below the time resolution {RESOLUTION} s "
                                     f"(netcosim.RESOLUTION)")
        validate.positive(xtol, "RK4 xtol", kind="a positive number of seconds", type_error=ConfigurationError)
        _check_count(max_steps, "RK4 max_steps")
        self.dt = float(dt)
        self.xtol = float(xtol)
        self.max_steps = int(max_steps)

    def __repr__(self):
        return f"RK4(dt={self.dt!r})"

    @staticmethod
    def step(rhs, t, x, h):
        """One classical Runge-Kutta step of ``rhs(t, x)`` of length *h* (s) from ``(t, x)`` (t in s);
        returns the new state."""
        k1 = rhs(t, x)
        k2 = rhs(t + 0.5 * h, x + (0.5 * h) * k1)
        k3 = rhs(t + 0.5 * h, x + (0.5 * h) * k2)
        k4 = rhs(t + h, x + h * k3)
        return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def integrate(self, rhs, t0, x0, t1, gs):
        """Integrate ``dx/dt = rhs(t, x)`` from ``(t0, x0)`` to *t1* (s) in steps of at most ``dt``.

        Stops at the first zero crossing of a guard ``g(t, x)`` of *gs* (pairs ``(g,
        direction)``), located within ``xtol`` s.  Returns ``(t_end, x_end, index of the
        fired guard or None)``.
        """
        t, x = t0, x0
        gvals = [g(t, x) for g, _ in gs] if gs else None  # guard values at the step's start
        for tn in self._instants(t0, t1):
            h = tn - t
            xn = self.step(rhs, t, x, h)
            if gvals is not None:  # i.e. there are guards
                for j, (g, d) in enumerate(gs):
                    g1 = g(tn, xn)
                    if crossed(gvals[j], g1, d):
                        s, j = locate_in_step(lambda s: self.step(rhs, t, x, s), t, h, gs, gvals, self.xtol)
                        return t + s, self.step(rhs, t, x, s), j
                    gvals[j] = g1
            t, x = tn, xn
        return t1, x, None

    def _instants(self, t0: float, t1: float) -> Iterator[float]:
        """The ends of the steps from *t0* to *t1* (s), ``t0 + i dt`` then *t1*, one at a
        time; raises beyond ``max_steps`` steps, before any is taken."""
        n = self._steps(t0, t1)
        dt = self.dt
        return chain((t0 + (i + 1) * dt for i in range(n - 1)), (t1,))

    def _steps(self, t0: float, t1: float) -> int:
        """Number of steps from *t0* to *t1* (s); raises beyond ``max_steps``."""
        dt = self.dt
        n = max(1, math.ceil((t1 - t0) / dt - 1e-9))
        if n > self.max_steps:
            raise IntegrationError(
                f"RK4(dt={dt!r}) would need {n} steps to advance from t={t0!r} to t={t1!r} s "
                f"({t1 - t0!r} s), more than max_steps={self.max_steps}; use a larger dt, "
                f"SolveIVP(method='Radau') for a stiff plant, or raise max_steps")
        return n

    def bind(self, plant: BoundPlant):
        """The integrator that advances *plant*: this RK4 bound to the plant's own ``f``
        (:class:`_RK4Stepper`: same steps, same arithmetic, no array built per stage).

        Called once by :class:`~netcosim.plant.instance.PlantInstance` when the plant is created.  A plant with
        more than :attr:`FLOAT_STEP_MAX_STATES` states (where NumPy's arrays beat lists of
        floats), or a subclass that overrides :meth:`step` or :meth:`integrate`, is
        integrated by :meth:`integrate` itself.
        """
        if (type(self).step is not RK4.step or type(self).integrate is not RK4.integrate
                or plant.system.nx > self.FLOAT_STEP_MAX_STATES):
            return self
        return _RK4Stepper(self, plant)


class _RK4Stepper:
    """:class:`RK4` bound to one plant: the same steps as :meth:`RK4.integrate`, computed on
    Python floats.

    The classical step allocates four NumPy temporaries per stage (``x + (h/2) k``) and
    checks ``np.isfinite`` on each derivative; for the few states of a small plant that
    costs more than the plant's own ``f``.  Here the state and the stage values are lists
    of floats, each stage state is copied into one preallocated array that ``f`` receives
    (valid during the call only: ``f`` must not keep it), and the derivative is checked
    through the sum of its entries (as :func:`_all_finite`).  Every operation is the
    same IEEE double operation in the same order as the NumPy expressions of
    :meth:`RK4.step` (``x + (0.5*h)*k1``, ``x + (h/6)*(((k1 + 2 k2) + 2 k3) + k4)``), so
    the results are the same to the bit.  The plant's input is read once per advance
    (it is held between I/O instants); with a disturbance ``d(t)`` the input is built
    per stage, as before.  A plant with hybrid events is integrated by the unbound
    :meth:`RK4.integrate` (event location needs the stage map on arrays).
    """

    def __init__(self, owner: RK4, plant: BoundPlant):
        self.owner, self.name = owner, plant.name
        # weak: the plant holds this stepper, and a run must leave no reference cycle behind
        self._plant = weakref.ref(plant)
        self.nx = plant.system.nx
        self._x = np.empty(self.nx)  # the state f receives at each stage

    def __repr__(self):
        return f"{self.owner!r} bound to plant {self.name!r}"

    def _deriv(self, plant: BoundPlant, t: float, x: list, u) -> list:
        """``f(t, x, u)`` as a list of floats, checked (``nx`` entries, all finite)."""
        buf = self._x
        buf[:] = x
        dx = plant.system.f(t, buf, plant._u_full(t) if u is None else u, plant.params)
        if type(dx) is not np.ndarray or dx.dtype != _FLOAT or dx.ndim != 1:
            dx = _floats(dx, f"plant {self.name!r}: f(t={t!r})")
        k = dx.tolist()
        if len(k) != self.nx:
            raise ConfigurationError(
                f"plant {self.name!r}: f returned {len(k)} values {k!r} at t={t!r} s, the system has "
                f"{self.nx} states {list(plant.system.state_names)}")
        if not math.isfinite(sum(k)) and not all(map(math.isfinite, k)):
            plant._rhs(t, buf)  # raises the IntegrationError naming the non-finite derivatives
            raise IntegrationError(f"plant {self.name!r}: derivative {k!r} is non-finite at t={t!r} s")
        return k

    def integrate(self, rhs, t0, x0, t1, gs, dense=None):
        """:meth:`RK4.integrate` of the bound plant (*rhs* is the plant's; not called when *gs* is empty).

        *dense* (optional, without *gs*): ``(times, report)`` as for
        :meth:`SolveIVP.integrate`, with *times* among the step instants ``t0 + i dt``
        (and *t1*): ``report`` receives the states of those steps, as computed."""
        owner = self.owner
        if gs:
            return owner.integrate(rhs, t0, x0, t1, gs)
        dt = owner.dt
        plant = self._plant()
        assert plant is not None, "a stepper is only called by its (live) plant"
        u = plant.u if plant.disturbance is None else None  # held: read once per advance
        deriv = self._deriv
        t, x = t0, x0.tolist()
        wanted = dense[0].tolist() if dense is not None else []
        j, seen_t, seen_x = 0, [], []
        for tn in owner._instants(t0, t1):
            h = tn - t
            hh = 0.5 * h
            k1 = deriv(plant, t, x, u)
            k2 = deriv(plant, t + hh, [a + hh * b for a, b in zip(x, k1)], u)
            k3 = deriv(plant, t + hh, [a + hh * b for a, b in zip(x, k2)], u)
            k4 = deriv(plant, t + h, [a + h * b for a, b in zip(x, k3)], u)
            h6 = h / 6.0
            x = [a + h6 * (((p + 2.0 * q) + 2.0 * r) + s) for a, p, q, r, s in zip(x, k1, k2, k3, k4)]
            t = tn
            while j < len(wanted) and wanted[j] <= tn + 1e-6 * dt:
                if abs(wanted[j] - tn) <= 1e-6 * dt:
                    seen_t.append(wanted[j])
                    seen_x.append(x)
                j += 1
        if seen_t:
            dense[1](np.array(seen_t), np.array(seen_x).T)
        return t1, np.array(x), None
