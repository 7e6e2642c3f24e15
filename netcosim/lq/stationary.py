"""The stationary cost of a schedule that repeats (JitterTime's periodic analysis).

A schedule is one period of events, a sequence of :class:`Wait` (time passes, seconds)
and :class:`Execute` (a discrete system executes), repeated for ever.  Over one period the
covariance maps affinely: ``P <- Psi P Psi^T + W`` (Psi and W composed step by step from
the exact interval matrices of :mod:`netcosim.lq.integrals` and the update maps).  If the
spectral radius of Psi is below 1 the loop is stable and the covariance at the start of
the period converges to the solution of the discrete Lyapunov equation
``P = Psi P Psi^T + W`` (``scipy.linalg.solve_discrete_lyapunov``); the mean decays to 0
(the model has no deterministic input).  The stationary cost per unit time is the cost of
one period from that P, divided by the period.  Otherwise (spectral radius >= 1) the
cost is ``inf``, with ``stable=False`` and a note.

This is what JitterTime's ``beginPeriodicAnalysis``/``endPeriodicAnalysis`` compute
(Cervin, Pazzaglia, Barzegaran, Mahfouzi, "Using JitterTime to analyze transient
performance in adaptive and reconfigurable control systems", ETFA 2019).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Hashable, Iterable

import numpy as np
from scipy.linalg import solve_discrete_lyapunov

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from .matrices import show
from .propagation import Propagator
from .result import StationaryCost
from .systems import Interconnection

__all__ = ["Wait", "Execute", "periodic_cost"]


@dataclass(frozen=True)
class Wait:
    """Time passes: *duration* seconds (>= 0)."""

    duration: float

    def __post_init__(self) -> None:
        validate.non_negative(self.duration, "Wait: duration", kind="a non-negative number of seconds")


@dataclass(frozen=True)
class Execute:
    """Discrete system *system* executes (JitterTime's ``execSys``)."""

    system: Hashable


def _steps(schedule: Iterable) -> list[Wait | Execute]:
    steps = list(schedule)
    for s in steps:
        if not isinstance(s, (Wait, Execute)):
            raise ConfigurationTypeError(f"periodic_cost: every step must be a Wait or an Execute, got {show(s)}")
    return steps


def periodic_cost(model: Interconnection, schedule: Iterable[Wait | Execute]) -> StationaryCost:
    """The stationary expected cost per second of *model* under *schedule* repeated for ever.

    The schedule's waits must add up to a positive period.  Returns a
    :class:`~netcosim.lq.result.StationaryCost` whose ``covariance`` is the stationary
    covariance of the total state at the start of the period.
    """
    steps = _steps(schedule)
    period = sum(s.duration for s in steps if isinstance(s, Wait))
    if not period > 0.0:
        raise ConfigurationError(f"periodic_cost: the schedule's waits must add up to a positive period, "
                                 f"got {period!r} s from {show(steps)}")
    prop = Propagator(model, record=False)
    N = prop.dynamics.size
    Psi = np.eye(N)
    W = np.zeros((N, N))
    for s in steps:
        if isinstance(s, Wait):
            M = prop.matrices(s.duration)
            E, V = M.Phi, M.R
        else:
            E, V = model.update_of(s.system)
        Psi = E @ Psi
        W = E @ W @ E.T + V
    rho = float(np.max(np.abs(np.linalg.eigvals(Psi)))) if N else 0.0
    if not rho < 1.0:
        return StationaryCost(math.inf, period, False, rho,
                              note=f"the lifted map over one period has spectral radius {rho:.6g} >= 1: "
                                   f"the loop is not stable under this schedule, the cost grows without bound")
    P0 = solve_discrete_lyapunov(Psi, W)
    P0 = 0.5 * (P0 + P0.T)
    prop.covariance = P0
    for s in steps:
        if isinstance(s, Wait):
            prop.pass_time(s.duration)
        else:
            prop.update(s.system)
    return StationaryCost(prop.cost / period, period, True, rho, covariance=P0)
