"""The exact mean, covariance and expected cost of a linear-quadratic model, event by event.

:class:`Propagator` holds the mean m and covariance P of the total state z of an
:class:`~netcosim.lq.systems.Interconnection` and the expected cost J accumulated so far
(JitterTime's ``N.m``, ``N.P``, ``N.J``).  A caller drives it through time:

* :meth:`~Propagator.advance` ``(t)`` / :meth:`~Propagator.pass_time` ``(T)`` -- the
  continuous systems run for T seconds (JitterTime's ``passTime``)::

      J <- J + tr(Q(T) P) + m^T Q(T) m + J_noise(T)
      m <- Phi m,    P <- Phi P Phi^T + R(T)

  with ``Phi``, ``R``, ``Q``, ``J_noise`` from :mod:`netcosim.lq.integrals` (exact, Van
  Loan), cached per interval length (intervals repeat in a periodic schedule);
* :meth:`~Propagator.update` ``(key)`` -- discrete system *key* executes (``execSys``):
  ``m <- E m``, ``P <- E P E^T + W`` (no cost: the update is instantaneous);
* :meth:`~Propagator.impulse` ``(v, V)`` -- a deterministic (and/or random) impulse
  disturbance: ``m <- m + v``, ``P <- P + V``;
* :meth:`~Propagator.jump` ``(E, W)`` / :meth:`~Propagator.reset` -- any reset map
  ``z -> E z + e`` (JitterTime's reset dynamics).

:attr:`~Propagator.cost` is J, :attr:`~Propagator.cost_rate` the rate ``dJ/dt =
tr(Q_c P) + m^T Q_c m`` at the present instant.  J is the *expected* cost
``E ∫ z^T Q_c z dt`` over the noise, for the given sequence of events: no Monte Carlo.
A kernel coupling calls ``advance(t)`` at each sampling, computing or actuation instant
and ``update(key)`` there.
"""

from __future__ import annotations

import math
from typing import Any, Hashable

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError, IntegrationError
from .integrals import IntervalMatrices, interval_matrices
from .matrices import covariance, square, vector
from .result import CostTrace
from .systems import Interconnection

__all__ = ["Propagator"]

#: interval lengths whose matrices a propagator keeps (the oldest go first)
CACHE_SIZE = 4096


class Propagator:
    """Mean, covariance and expected cost of *model* along a sequence of events.

    ``m0``, ``P0``: initial mean and covariance of the total state (default zero, as in
    JitterTime); ``t0``: initial time (s).  ``record``: keep a :class:`CostTrace` of every
    event (:meth:`trace`).

    Raises
    ------
    ConfigurationTypeError
        *model* is not an :class:`~netcosim.lq.systems.Interconnection`; ``m0``, ``P0`` or
        ``t0`` is not numeric.
    ConfigurationError
        ``m0`` is not a finite vector of the total state's length, ``P0`` not a symmetric
        positive semidefinite matrix of its size, ``t0`` not finite; the model has no system
        or is not connected consistently (:meth:`Interconnection.dynamics
        <netcosim.lq.systems.Interconnection.dynamics>`).
    IntegrationError
        Later, from an event: the covariance or the cost is no longer finite (the model
        diverged).

    Examples
    --------
    An uncontrolled integrator ``dx = dv`` (noise intensity r = 0.3, cost rate ``2 x^2``)
    starting from the mean x = 1.5: ``E ∫_0^T 2 x^2 dt = 2 (1.5^2 T + r T^2 / 2)``, which is
    3.792 for T = 0.8 s, and the cost rate is then ``2 (1.5^2 + r T) = 4.98`` per second.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> plant = lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=0.3, Q_c=np.diag([2.0, 0.0]))
    >>> p = lq.Propagator(lq.Interconnection().add("plant", plant))
    >>> p.impulse([1.5], system="plant").pass_time(0.4).advance(0.8).time
    0.8
    >>> round(p.cost, 9), round(p.cost_rate, 9)
    (3.792, 4.98)
    >>> mean, var = p.state("plant")
    >>> mean.tolist(), round(var.item(), 9)
    ([1.5], 0.24)
    """

    def __init__(self, model: Interconnection, *, m0: Any = None, P0: Any = None, t0: float = 0.0,
                 record: bool = True):
        if not isinstance(model, Interconnection):
            raise ConfigurationTypeError(f"Propagator: model must be an Interconnection, got {model!r}")
        self.model = model
        self.dynamics = model.dynamics()
        N = self.dynamics.size
        self.mean = np.zeros(N) if m0 is None else vector(m0, "Propagator: m0", N)
        self.covariance = covariance(P0, "Propagator: P0", N)
        self.time = validate.finite(t0, "Propagator: t0", "seconds")
        self.cost = 0.0
        self._cache: dict[float, IntervalMatrices] = {}
        self._record = bool(record)
        self._log: list[tuple[float, float, float, str]] = []
        self._note("start")

    # --- the events -------------------------------------------------------------------

    def matrices(self, T: float) -> IntervalMatrices:
        """The (cached) exact matrices of an interval of *T* seconds."""
        got = self._cache.get(T)
        if got is None:
            if len(self._cache) >= CACHE_SIZE:
                self._cache.pop(next(iter(self._cache)))
            d = self.dynamics
            got = self._cache[T] = interval_matrices(d.A, d.R_c, d.Q_c, T)
        return got

    def pass_time(self, T: float) -> "Propagator":
        """Let *T* >= 0 seconds pass (JitterTime's ``passTime``); returns self."""
        T = validate.non_negative(T, "Propagator.pass_time: T", kind="a non-negative number of seconds")
        if T > 0.0:
            M = self.matrices(T)
            m, P = self.mean, self.covariance
            self.cost += float(np.sum(M.Q * P) + m @ M.Q @ m + M.J_noise)
            self.mean = M.Phi @ m
            P = M.Phi @ P @ M.Phi.T + M.R
            self.covariance = 0.5 * (P + P.T)
            self.time += T
        self._note("advance")
        return self

    def advance(self, t: float) -> "Propagator":
        """Let time pass until the absolute time *t* (s), which may not lie in the past."""
        t = validate.finite(t, "Propagator.advance: t", "seconds")
        if t < self.time:
            raise ConfigurationError(f"Propagator.advance: t must not be before the present time "
                                     f"{self.time!r} s, got {t!r}")
        return self.pass_time(t - self.time)

    def update(self, key: Hashable) -> "Propagator":
        """Execute discrete system *key* now (JitterTime's ``execSys``); returns self."""
        E, W = self.model.update_of(key)
        self._map(E, W)
        self._note(f"update {key}")
        return self

    # JitterTime's names
    passTime = pass_time
    execSys = update

    def impulse(self, v: Any = None, V: Any = None, *, system: Hashable | None = None) -> "Propagator":
        """An impulse disturbance now: ``m <- m + v`` (a deterministic jump of the state),
        ``P <- P + V`` (a random one, covariance V).  On the total state, or on the entries of
        *system* if given (its [x; y] for a discrete system)."""
        if system is None:
            sl = slice(0, self.dynamics.size)
        else:
            sl = self.model.slice_of(system)
        n = sl.stop - sl.start
        what = "Propagator.impulse" + ("" if system is None else f" on {system!r}")
        if v is not None:
            self.mean = self.mean.copy()
            self.mean[sl] += vector(v, f"{what}: v", n)
        if V is not None:
            P = self.covariance.copy()
            P[sl, sl] += covariance(V, f"{what}: V", n)
            self.covariance = P
        self._note("impulse")
        return self

    def jump(self, E: Any, W: Any = None) -> "Propagator":
        """A reset map of the total state now: ``z <- E z + e``, ``E[e e^T] = W``."""
        N = self.dynamics.size
        self._map(square(E, "Propagator.jump: E", N), covariance(W, "Propagator.jump: W", N))
        self._note("jump")
        return self

    def reset(self, key: Hashable, A: Any, B: Any = None, inputs: tuple = (), R: Any = None) -> "Propagator":
        """Jump system *key*'s entries now: ``x+ = A x + B u + e`` (see
        :meth:`Interconnection.reset_map <netcosim.lq.systems.Interconnection.reset_map>`: *B*
        acts on u, the stacked outputs of the systems *inputs*; *R* is the covariance of e,
        None: no noise)."""
        E, W = self.model.reset_map(key, A, B, inputs, R)
        self._map(E, W)
        self._note(f"reset {key}")
        return self

    # --- what it knows ----------------------------------------------------------------

    @property
    def cost_rate(self) -> float:
        """dJ/dt now: ``tr(Q_c P) + m^T Q_c m`` (cost per second)."""
        Q = self.dynamics.Q_c
        return float(np.sum(Q * self.covariance) + self.mean @ Q @ self.mean)

    def state(self, key: Hashable) -> tuple[np.ndarray, np.ndarray]:
        """Mean and covariance of system *key*'s entries of the total state."""
        sl = self.model.slice_of(key)
        return self.mean[sl].copy(), self.covariance[sl, sl].copy()

    def trace(self) -> CostTrace:
        """The recorded history (every event since the start, if ``record``)."""
        log = self._log
        return CostTrace(time=np.array([r[0] for r in log]), cost=np.array([r[1] for r in log]),
                         cost_rate=np.array([r[2] for r in log]), event=tuple(r[3] for r in log))

    def _map(self, E: np.ndarray, W: np.ndarray) -> None:
        self.mean = E @ self.mean
        P = E @ self.covariance @ E.T + W
        self.covariance = 0.5 * (P + P.T)

    def _note(self, event: str) -> None:
        if not math.isfinite(self.cost) or not np.all(np.isfinite(self.covariance)):
            raise IntegrationError(f"Propagator: the covariance or the cost is no longer finite at t = "
                                     f"{self.time!r} s (after {event}): the model diverged")
        if self._record:
            self._log.append((self.time, self.cost, self.cost_rate, event))
