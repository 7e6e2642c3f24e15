"""The exact step of a linear plant driven by white noise, with its exact quadratic cost.

:class:`NoisyZOH` integrates ``dx = (A x + B u) dt + dv`` (``E[dv dv^T] = R_c dt``: R_c is
the noise *intensity*, units of x² per second, as in :mod:`netcosim.lq`) with the input u
held between I/O instants, exactly: over an interval of T seconds from x0::

    x(T) = Phi x0 + Gamma u + w,     w ~ N(0, R(T)),   R(T) = ∫_0^T e^{As} R_c e^{A^T s} ds

(Phi, Gamma, R from Van Loan's exponentials, :func:`netcosim.lq.integrals.interval_matrices`
on the augmented state [x; u]).  w is drawn from a named random stream of the simulation,
``sim.rng(stream)``, or from its own generator if ``seed`` is given, so a run is
deterministic.  Splitting an interval in two and drawing twice gives the same law (the
increments are independent): where the I/O instants fall changes nothing.

It also accumulates the run's cost ``∫ [x; u]^T Q_c [x; u] dt`` (``cost``, units of Q_c
times seconds), interval by interval, as the **conditional expectation given the state at
the start of the interval** (the noise inside the interval averaged out, exactly)::

    cost += [x0; u]^T Q(T) [x0; u] + J_noise(T)

(Q(T), J_noise(T) as in :mod:`netcosim.lq.integrals`).  Its expectation over the noise is
the expected cost itself (tower rule): a per-run cost that is unbiased, has less spread
than the pathwise integral and no quadrature error.  With ``R_c = 0`` it is the exact
deterministic cost integral.

A plant with hybrid events or disturbance inputs is refused.  One NoisyZOH serves one
plant (its ``cost`` is that plant's).  The plant must not be re-integrated from the past:
a plant on the default logging grid integrates copies between I/O instants, so create it
with ``log="none"`` or a ``log_interval`` (a copy is refused with an error saying so).
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from ..lq.integrals import IntervalMatrices, interval_matrices
from ..lq.matrices import covariance
from ..timebase import TICKS_PER_SECOND
from .integrator import BoundPlant

__all__ = ["NoisyZOH"]

#: interval matrices kept process-wide (by plant matrices and interval), shared by every run
SHARED_SIZE = 4096
_SHARED: OrderedDict[tuple, tuple[IntervalMatrices, np.ndarray]] = OrderedDict()


class NoisyZOH:
    """Exact ZOH step of a linear plant with white process noise of intensity ``R_c``
    (nx x nx, x²/s; None: no noise), and the exact per-run quadratic cost with weight
    ``Q_c`` on [x; u] ((nx + nu) square, per second; None: no cost).  ``stream``: the
    simulation's random stream the noise is drawn from; ``seed``: an own generator instead
    (a Monte Carlo over the noise alone, the simulation's other streams -- losses, delays --
    fixed by its seed).  See the module.

    Attributes: ``cost`` (the cost so far, up to the plant's time ``t``), ``draws``
    (noise vectors drawn).

    Examples
    --------
    The lag ``dx = (-x + u) dt + dv`` from ``x(0) = 1`` with ``u = 0`` over one interval
    of 1 s, cost weight 1 on ``x``: without noise the cost is ``∫ e^-2t dt =
    (1 - e^-2) / 2``; with noise of intensity ``R_c = 0.5`` x²/s the expected cost adds
    ``R_c (1/2 - (1 - e^-2) / 4)``, exactly, whatever the draw:

    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.plant import LinearPlant, NoisyZOH
    >>> lag = LinearPlant([[-1.0]], [[1.0]], [[1.0]], [[0.0]], states=["x"], inputs=["u"], outputs=["y"],
    ...                   name="lag")
    >>> for R_c in (None, 0.5):
    ...     noisy = NoisyZOH(R_c=R_c, Q_c=[[1.0, 0.0], [0.0, 0.0]], seed=1)
    ...     sim = Simulation()
    ...     plant = sim.plant(lag, [1.0], integrator=noisy, log="none")
    ...     sim.run(until=1.0)
    ...     print(round(noisy.cost, 6), noisy.draws)
    0.432332 0
    0.574249 1
    >>> q = (1 - math.exp(-2)) / 2
    >>> round(q, 6), round(q + 0.5 * (0.5 - (1 - math.exp(-2)) / 4), 6)
    (0.432332, 0.574249)
    """

    def __init__(self, R_c: Any = None, Q_c: Any = None, *, stream: str = "plant noise",
                 seed: int | None = None):
        self._R_c, self._Q_c = R_c, Q_c
        self.stream = validate.name(stream, "NoisyZOH: stream")
        if seed is not None:
            validate.integer(seed, "NoisyZOH: seed", lo=0)
        self.seed = seed
        self.cost = 0.0
        self.draws = 0
        self._bound: str | None = None

    def __repr__(self) -> str:
        return f"NoisyZOH(stream={self.stream!r})" if self.seed is None else f"NoisyZOH(seed={self.seed!r})"

    def bind(self, plant: BoundPlant) -> "_NoisyStepper":
        """The stepper of *plant* (called once by the plant; a second plant is refused)."""
        if self._bound is not None:
            raise ConfigurationError(f"NoisyZOH already integrates plant {self._bound!r}; give plant "
                                     f"{plant.name!r} its own NoisyZOH (its cost is one plant's)")
        system, name = plant.system, plant.name
        A, B = getattr(system, "A", None), getattr(system, "B", None)
        if A is None or B is None:
            raise ConfigurationTypeError(f"plant {name!r}: NoisyZOH needs a linear system exposing A and B, "
                                         f"{type(system).__name__} has no {'A' if A is None else 'B'}")
        if system.events or plant.disturbance is not None:
            raise ConfigurationError(f"plant {name!r}: NoisyZOH cannot integrate hybrid events or "
                                     f"disturbance inputs")
        nx, nu = system.nx, system.nu
        A = np.array(A, dtype=float).reshape(nx, nx)
        B = np.array(B, dtype=float).reshape(nx, nu)
        for x, u in ((1.0 + np.arange(nx), 0.5 + np.arange(nu)), (np.zeros(nx), np.zeros(nu))):
            got = np.asarray(system.f(0.0, x, u, plant.params), dtype=float).reshape(-1)
            if not np.allclose(got, A @ x + B @ u, rtol=1e-9, atol=1e-12):
                raise ConfigurationError(f"plant {name!r}: NoisyZOH needs f(t, x, u) = A x + B u "
                                         f"(a linear plant), got f = {got.tolist()!r} at x = {x.tolist()!r}")
        R = covariance(self._R_c, f"NoisyZOH for plant {name!r}: R_c", nx)
        Q = covariance(self._Q_c, f"NoisyZOH for plant {name!r}: Q_c", nx + nu)
        if self.seed is not None:
            rng = np.random.default_rng(self.seed)
        else:
            sim = getattr(plant, "sim", None)
            if sim is None:
                raise ConfigurationTypeError(f"plant {name!r}: NoisyZOH needs the plant's simulation for "
                                             f"its random stream, or a seed")
            rng = sim.rng(self.stream)
        self._bound = name
        return _NoisyStepper(self, plant, A, B, R, Q, rng)

    def integrate(self, rhs, t0, x0, t1, gs):
        """Not callable unbound (the plant calls :meth:`bind`): raises
        :class:`~netcosim.errors.ConfigurationError` whatever the integrator interface's
        arguments, ``rhs``, ``t0``, ``x0``, ``t1`` (s) and ``gs``
        (:meth:`SolveIVP.integrate <netcosim.plant.solve_ivp.SolveIVP.integrate>`)."""
        raise ConfigurationError("NoisyZOH advances the plant it is bound to (PlantInstance calls "
                                 "NoisyZOH.bind(plant)); it cannot integrate a bare right-hand side")


class _NoisyStepper:
    """:class:`NoisyZOH` bound to one plant: the augmented [x; u] matrices per interval length."""

    def __init__(self, owner: NoisyZOH, plant: Any, A: np.ndarray, B: np.ndarray, R_c: np.ndarray,
                 Q_c: np.ndarray, rng: np.random.Generator):
        nx, nu = B.shape
        self.owner, self.plant, self.nx, self.rng = owner, plant, nx, rng
        self.A = np.zeros((nx + nu, nx + nu))
        self.A[:nx, :nx], self.A[:nx, nx:] = A, B
        self.R_c = np.zeros((nx + nu, nx + nu))
        self.R_c[:nx, :nx] = R_c
        self.Q_c = Q_c
        self._cache: dict[int, tuple[IntervalMatrices, np.ndarray]] = {}
        self._key = self.A.tobytes() + self.R_c.tobytes() + Q_c.tobytes() + str(self.A.shape).encode()
        self._t_end: float | None = None

    def _matrices(self, ticks: int) -> tuple[IntervalMatrices, np.ndarray]:
        got = self._cache.get(ticks)
        if got is None:
            got = _SHARED.get((self._key, ticks))
            if got is None:
                M = interval_matrices(self.A, self.R_c, self.Q_c, ticks / TICKS_PER_SECOND)
                w, V = np.linalg.eigh(M.R[:self.nx, :self.nx])
                got = _SHARED[(self._key, ticks)] = (M, V * np.sqrt(np.clip(w, 0.0, None)))   # L L^T = R
                if len(_SHARED) > SHARED_SIZE:
                    _SHARED.popitem(last=False)
            if len(self._cache) >= SHARED_SIZE:
                self._cache.clear()
            self._cache[ticks] = got
        return got

    def integrate(self, rhs, t0, x0, t1, gs):
        """Advance from ``(t0, x0)`` to *t1* (s): the exact mean step plus one noise draw; adds
        the interval's conditional expected cost to the owner's ``cost``."""
        ticks = round((t1 - t0) * TICKS_PER_SECOND)
        if ticks <= 0:
            return t1, x0, None
        if self._t_end is not None and t0 < self._t_end - 0.5 / TICKS_PER_SECOND:
            raise ConfigurationError(f"plant {self.plant.name!r}: NoisyZOH was asked to integrate again from "
                                     f"t = {t0!r} s, before the end of its last step {self._t_end!r} s (the "
                                     f"default logging grid integrates copies): create the plant with "
                                     f"log='none' or a log_interval")
        M, L = self._matrices(ticks)
        z = np.concatenate([np.asarray(x0, dtype=float), self.plant.u])
        self.owner.cost += float(z @ M.Q @ z) + M.J_noise
        x1 = M.Phi[:self.nx] @ z
        if L.any():
            x1 = x1 + L @ self.rng.standard_normal(self.nx)
            self.owner.draws += 1
        self._t_end = t1
        return t1, x1, None
