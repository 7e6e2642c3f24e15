"""Hybrid events: the guards the integrators watch and the location of their crossings.

A guard is a pair ``(g(t, x), direction)`` (see :class:`~netcosim.plant.system.HybridEvent`);
an integrator stops at the first crossing of one of its guards.  :class:`RK4
<netcosim.plant.rk4.RK4>` locates a crossing on its own step map
(:func:`locate_in_step`); :class:`SolveIVP <netcosim.plant.solve_ivp.SolveIVP>` hands the
guards to ``solve_ivp`` as terminal events (:func:`terminal_events`,
:func:`first_event`).  Both use the same crossing rule (:func:`crossed`).
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

__all__ = ["EVENT_REARM", "Guard", "crossed", "locate_in_step", "terminal_events", "first_event"]

#: Events firing again within this many seconds of the previous firing of the same
#: event are treated as the same crossing (numerical chatter at the located root).
EVENT_REARM = 1e-9

#: a guard: ``(g(t, x) -> float, direction)``, direction +1 rising, -1 falling, 0 both
Guard = tuple[Callable[[float, Any], float], int]


def crossed(g0: float, g1: float, direction: int) -> bool:
    """True when a guard going from *g0* to *g1* crosses zero in *direction* (+1, -1 or 0)."""
    if direction >= 0 and g0 < 0.0 <= g1:
        return True
    if direction <= 0 and g0 > 0.0 >= g1:
        return True
    return False


def locate_in_step(step: Callable[[float], Any], t: float, h: float, gs: Sequence[Guard], g0s: list,
                   xtol: float) -> tuple[float, int]:
    """The earliest crossing among the guards *gs* within one step of length *h* (s) from *t*.

    ``step(s)`` is the state after a step of ``s`` s (0 <= s <= h) of the integrator's own
    step map; *g0s* are the guards' values at *t*.  Each crossing is located with Brent's
    method to *xtol* s, on the side after the crossing (so that it is not found again).
    Returns ``(s, index of the guard)``.
    """
    best = None
    for j, (g, d) in enumerate(gs):
        def phi(s, g=g):
            return g(t + s, step(s))
        gh = phi(h)
        if not crossed(g0s[j], gh, d):
            continue
        if g0s[j] == 0.0:
            s = 0.0
        else:
            from scipy.optimize import brentq  # loaded on first event location
            s = brentq(phi, 0.0, h, xtol=xtol)
            # take the side after the crossing so that the event is not re-found
            if not crossed(g0s[j], phi(s), d):
                s = min(h, s + xtol)
        if best is None or s < best[0]:
            best = (s, j)
    assert best is not None  # the caller saw a crossing in this step
    return best


def terminal_events(gs: Sequence[Guard]) -> list:
    """The guards *gs* as terminal events of ``scipy.integrate.solve_ivp``."""
    events = []
    for g, d in gs:
        def ev(t, x, g=g):
            return g(t, x)
        ev.terminal = True  # type: ignore[attr-defined]
        ev.direction = d  # type: ignore[attr-defined]
        events.append(ev)
    return events


def first_event(sol) -> tuple[float, int, np.ndarray]:
    """``(t, index, x)`` of the earliest terminal event of *sol*, a ``solve_ivp`` solution stopped
    by one (status 1): its time (s), the index of its event function and the state there."""
    first = None
    for j, te in enumerate(sol.t_events):
        if len(te) and (first is None or te[0] < first[0]):
            first = (te[0], j, sol.y_events[j][0])
    assert first is not None  # status 1: an event stopped the solver
    return first
