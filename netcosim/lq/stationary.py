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
    """Time passes: *duration* seconds (>= 0).

    Raises
    ------
    ConfigurationTypeError
        *duration* is not a number.
    ConfigurationError
        *duration* is negative, NaN or infinite.

    Examples
    --------
    One step of a schedule for :func:`periodic_cost`; the waits of a schedule add up to its
    period.

    >>> from netcosim import lq
    >>> schedule = [lq.Execute("sampler"), lq.Wait(0.02), lq.Execute("ctrl"), lq.Wait(0.08)]
    >>> sum(step.duration for step in schedule if isinstance(step, lq.Wait))
    0.1
    >>> lq.Wait(-0.1)
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: Wait: duration must be a non-negative number of seconds, got -0.1
    """

    duration: float

    def __post_init__(self) -> None:
        validate.non_negative(self.duration, "Wait: duration", kind="a non-negative number of seconds")


@dataclass(frozen=True)
class Execute:
    """Discrete system *system* executes (JitterTime's ``execSys``).

    Examples
    --------
    The order of the executions in a period matters.  An integrator ``dx = u dt + dv``
    (noise intensity 1, cost rate ``x^2``) under ``u = -5 x`` sampled every 0.1 s: executing
    the controller *before* the sampler makes it use the previous period's sample, a full
    period of delay, ``x_(k+1) = x_k - 0.5 x_(k-1) + w_k``, whose spectral radius is
    ``√0.5``; with the sample first the loop is ``x_(k+1) = 0.5 x_k + w_k``.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> def loop(gain):
    ...     return (lq.Interconnection()
    ...             .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...                  inputs="ctrl")
    ...             .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...             .add("ctrl", lq.DiscreteSystem.gain(-gain), inputs="sampler"))
    >>> late = lq.periodic_cost(loop(5.0), [lq.Execute("ctrl"), lq.Execute("sampler"), lq.Wait(0.1)])
    >>> round(late.spectral_radius, 9), round(0.5 ** 0.5, 9), round(late.cost_rate, 6)
    (0.707106781, 0.707106781, 0.23)
    >>> now = lq.periodic_cost(loop(5.0), [lq.Execute("sampler"), lq.Execute("ctrl"), lq.Wait(0.1)])
    >>> round(now.spectral_radius, 9), round(now.cost_rate, 6)
    (0.5, 0.127778)
    """

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

    Raises
    ------
    ConfigurationTypeError
        A step of *schedule* is not a :class:`Wait` or an :class:`Execute`.
    ConfigurationError
        The waits do not add up to a positive period; an :class:`Execute` names a system that
        is not a discrete system of *model*.

    Examples
    --------
    An integrator ``dx = u dt + dv`` (noise intensity 1, cost rate ``x^2``) sampled every
    h = 0.1 s under the deadbeat gain ``u = -x / h``, the control applied tau seconds after
    the sample.  Without delay ``J = 5 h / 6`` per second (see
    :class:`~netcosim.lq.result.StationaryCost`); with a delay the samples follow
    ``x_(k+1) = (tau/h) (x_k - x_(k-1)) + w_k``, spectral radius ``√(tau/h)``, and the
    cost grows.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> def loop(gain):
    ...     return (lq.Interconnection()
    ...             .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...                  inputs="ctrl")
    ...             .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...             .add("ctrl", lq.DiscreteSystem.gain(-gain), inputs="sampler"))
    >>> for tau in (0.0, 0.02, 0.05):
    ...     st = lq.periodic_cost(loop(10.0), [lq.Execute("sampler"), lq.Wait(tau),
    ...                                        lq.Execute("ctrl"), lq.Wait(0.1 - tau)])
    ...     print(tau, round(st.cost_rate, 6), round(st.spectral_radius, 6), round((tau / 0.1) ** 0.5, 6))
    0.0 0.083333 0.0 0.0
    0.02 0.106429 0.447214 0.447214
    0.05 0.1625 0.707107 0.707107
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
