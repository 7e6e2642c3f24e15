"""The exact zero-order-hold step of a linear time-invariant plant."""

from __future__ import annotations

import weakref
from collections import OrderedDict

import numpy as np

from ..errors import ConfigurationError, ConfigurationTypeError
from ..timebase import TICKS_PER_SECOND
from .integrator import BoundPlant
from .values import _check_count

__all__ = ["SHARED_TRANSITIONS_SIZE", "ExactZOH"]

#: most ``(Φ, Γ)`` pairs kept by the process-wide transition cache (see :class:`ExactZOH`)
SHARED_TRANSITIONS_SIZE = 1024
#: ``(augmented matrix, ticks) -> (Φ, Γ)``, least recently used first; the pairs are never
#: written to, so plants and simulations share them
_SHARED_TRANSITIONS: OrderedDict[tuple, tuple[np.ndarray, np.ndarray]] = OrderedDict()


class ExactZOH:
    """Exact zero-order-hold step for a linear time-invariant plant ``dx/dt = A x + B u``.

    Over an interval of *h* seconds with the input held at ``u`` (the plant's inputs
    only change at I/O instants), the state moves by the exact transition::

        x(t + h) = e^{A h} x(t) + (∫_0^h e^{A s} ds) B u = Φ(h) x(t) + Γ(h) u

    with ``Φ`` and ``Γ`` read off ONE matrix exponential of the augmented matrix
    ``[[A, B], [0, 0]] · h`` (:func:`scipy.linalg.expm`, imported on first use): its
    top rows are ``[Φ, Γ]``.  The pair is cached per interval length, keyed by the
    length in integer ticks (:data:`netcosim.RESOLUTION` = 1 ps), in a least-recently
    used cache of ``cache_size`` entries per plant, so a periodic loop computes a few
    exponentials and then only two small matrix-vector products per advance, whatever
    the interval.  Behind the plants' caches, one process-wide cache of
    :data:`SHARED_TRANSITIONS_SIZE` pairs, keyed by the augmented matrix and the
    interval, lets every plant with the same ``A`` and ``B`` (the next run of a sweep,
    another simulation) reuse an exponential once computed.  The result has no discretisation error: it equals
    ``scipy.signal.cont2discrete((A, B, C, D), h, method="zoh")`` to rounding.

    A plant is accepted when its system exposes ``A`` (nx × nx) and ``B`` (nx × nu)
    and its ``f`` is ``A x + B u`` (checked once, at two points, when the plant is
    created): :class:`netcosim.plants.dc_servo.DCServo` and the converted python-control
    ``StateSpace`` / ``TransferFunction`` plants (:class:`netcosim.plant.pycontrol.LinearPlant`).
    Outputs still come from the system's ``h`` (``C x + D u`` for those).  A system
    without ``A``/``B`` raises :class:`~netcosim.errors.ConfigurationTypeError`
    naming the plant.

    The *fallback* integrator (e.g. ``RK4(dt=1e-4)`` or ``SolveIVP()``) integrates the
    plant instead, for the whole run, when the exact step does not apply:

    * the system has hybrid events (``system.events`` non-empty): crossings must be
      located, and resets make the dynamics piecewise;
    * the plant has disturbance inputs (``system.nd > 0``) or a ``disturbance=``
      function: ``d(t)`` is not held between I/O instants.

    The plant then behaves exactly as with ``integrator=fallback``.  Without a
    fallback, such a plant raises :class:`~netcosim.errors.ConfigurationError` when it
    is created.  The choice is made once per plant; one ``ExactZOH`` may serve several
    plants (each has its own cache).

    Parameters
    ----------
    fallback: integrator for plants with events or disturbances (None: refuse them).
    cache_size: most interval lengths whose ``(Φ, Γ)`` are kept per plant (>= 1,
        default 64).

    Attributes
    ----------
    expm_calls: matrix exponentials computed so far by the plants using this instance;
        ``cache_hits``: advances served from a plant's cache; ``shared_hits``:
        transitions a plant's cache missed but the process-wide cache held.

    Raises
    ------
    ConfigurationTypeError
        *fallback* has no ``integrate`` method, or *cache_size* is not an integer; when
        a plant is created with it, a system without ``A`` or ``B``.
    ConfigurationError
        *cache_size* is below 1; when a plant is created with it, a plant with hybrid
        events or disturbances and no *fallback*, ``A`` or ``B`` of the wrong shape or
        not finite, or an ``f`` that is not ``A x + B u``.

    Examples
    --------
    The DC servo ``1000 / (s (s + 1))`` under +1 V for 50 ms, then -1 V for 50 ms, the
    input written every 10 ms: the angle at 0.1 s is ``s(0.1) - 2 s(0.05)`` rad with
    ``s(t) = 1000 (t - 1 + e^-t)`` the step response, from one matrix exponential (the
    ten 10 ms intervals share it):

    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.plant import ExactZOH
    >>> from netcosim.plants.dc_servo import DCServo
    >>> zoh = ExactZOH()
    >>> sim = Simulation()
    >>> servo = sim.plant(DCServo(), [0.0, 0.0], integrator=zoh)
    >>> u = servo.input("u")
    >>> for k in range(10):
    ...     _ = sim.call_at(0.01 * k, lambda k=k: u.write(1.0 if k < 5 else -1.0))
    >>> sim.run(until=0.1)
    >>> round(float(servo.state[0]), 9)
    2.378569035
    >>> s = lambda t: 1000 * (t - 1 + math.exp(-t))
    >>> round(s(0.1) - 2 * s(0.05), 9)
    2.378569035
    >>> zoh.expm_calls + zoh.shared_hits, zoh.cache_hits   # computed (or found process-wide) once, then cached
    (1, 9)
    """

    def __init__(self, fallback=None, cache_size: int = 64):
        if fallback is not None and not callable(getattr(fallback, "integrate", None)):
            raise ConfigurationTypeError(f"ExactZOH fallback must be an integrator (RK4, SolveIVP or an object "
                                         f"with an integrate method), got {fallback!r}")
        _check_count(cache_size, "ExactZOH cache_size")
        self.fallback = fallback
        self.cache_size = int(cache_size)
        self.expm_calls = 0
        self.cache_hits = 0
        self.shared_hits = 0

    def __repr__(self):
        return f"ExactZOH(fallback={self.fallback!r})" if self.fallback is not None else "ExactZOH()"

    def bind(self, plant: BoundPlant):
        """The integrator that advances *plant*: an exact stepper for it, or the fallback.

        Called once by :class:`~netcosim.plant.instance.PlantInstance` when the plant is created.
        """
        system, name = plant.system, plant.name
        A, B = getattr(system, "A", None), getattr(system, "B", None)
        if A is None or B is None:
            raise ConfigurationTypeError(
                f"plant {name!r}: ExactZOH needs a linear time-invariant system exposing A and B "
                f"(dx/dt = A x + B u), {type(system).__name__} has no {'A' if A is None else 'B'}; "
                f"use RK4 or SolveIVP")
        reasons = []
        if system.events:
            reasons.append(f"hybrid events {[e.name for e in system.events]}")
        if plant.disturbance is not None:
            reasons.append("a disturbance input d(t)")
        if reasons:
            if self.fallback is None:
                raise ConfigurationError(
                    f"plant {name!r} has {' and '.join(reasons)}, which the exact ZOH step cannot hold "
                    f"constant; give ExactZOH(fallback=...) an integrator for it (e.g. RK4 or SolveIVP)")
            return self.fallback
        return _ExactZOHStepper(self, plant, A, B)

    def integrate(self, rhs, t0, x0, t1, gs):
        """Not callable unbound (*rhs*, *t0*, *x0*, *t1*, *gs*: as :meth:`SolveIVP.integrate`): the exact
        step needs the plant's ``A``, ``B`` and held input.

        :class:`~netcosim.plant.instance.PlantInstance` calls :meth:`bind` and integrates with what it returns.
        """
        raise ConfigurationError("ExactZOH advances a plant it is bound to (PlantInstance calls "
                                 "ExactZOH.bind(plant)); it cannot integrate a bare right-hand side")


class _ExactZOHStepper:
    """:class:`ExactZOH` bound to one plant: its ``A``, ``B`` and a cache of ``(Φ, Γ)``."""

    def __init__(self, owner: ExactZOH, plant: BoundPlant, A, B):
        system, name = plant.system, plant.name
        nx, nu = system.nx, system.nu
        A = np.array(A, dtype=float)
        B = np.array(B, dtype=float)
        if B.ndim == 1 and nu == 1:
            B = B.reshape(nx, 1)
        if A.shape != (nx, nx) or B.shape != (nx, nu):
            raise ConfigurationError(
                f"plant {name!r}: ExactZOH needs A of shape {(nx, nx)} and B of shape {(nx, nu)} "
                f"({nx} states, {nu} inputs), got A {A.shape} and B {B.shape}")
        if not (np.isfinite(A).all() and np.isfinite(B).all()):
            raise ConfigurationError(f"plant {name!r}: ExactZOH needs finite A and B, got A={A.tolist()!r}, "
                                     f"B={B.tolist()!r}")
        # f must be the linear map A x + B u; a plant exposing a linearisation only is refused
        for x, u in ((1.0 + np.arange(nx), 0.5 + np.arange(nu)), (np.zeros(nx), np.zeros(nu))):
            got = np.asarray(system.f(0.0, x, u, plant.params), dtype=float).reshape(-1)
            want = A @ x + B @ u
            if got.shape != want.shape or not np.allclose(got, want, rtol=1e-9, atol=1e-12):
                raise ConfigurationError(
                    f"plant {name!r}: ExactZOH needs f(t, x, u) = A x + B u, but at x={x.tolist()!r}, "
                    f"u={u.tolist()!r} f returned {got.tolist()!r} and A x + B u is {want.tolist()!r}; "
                    f"use RK4 or SolveIVP for a nonlinear plant")
        self.owner, self.name = owner, name
        # weak: the plant holds this stepper, and a run must leave no reference cycle behind
        self._plant = weakref.ref(plant)
        self.nx = nx
        self.M = np.zeros((nx + nu, nx + nu))
        self.M[:nx, :nx] = A
        self.M[:nx, nx:] = B
        self._key = (self.M.shape, self.M.tobytes())
        self._cache: OrderedDict[int, tuple[np.ndarray, np.ndarray]] = OrderedDict()

    def __repr__(self):
        return f"{self.owner!r} bound to plant {self.name!r}"

    def transition(self, ticks: int) -> tuple[np.ndarray, np.ndarray]:
        """``(Φ, Γ)`` for an interval of *ticks* ticks (cached per plant, then per process)."""
        cache = self._cache
        pair = cache.get(ticks)
        if pair is not None:
            cache.move_to_end(ticks)
            self.owner.cache_hits += 1
            return pair
        key = (self._key, ticks)
        pair = _SHARED_TRANSITIONS.get(key)
        if pair is not None:
            _SHARED_TRANSITIONS.move_to_end(key)
            self.owner.shared_hits += 1
        else:
            from scipy.linalg import expm  # loaded on first use
            E = expm(self.M * (ticks / TICKS_PER_SECOND))
            self.owner.expm_calls += 1
            pair = (E[:self.nx, :self.nx].copy(), E[:self.nx, self.nx:].copy())
            _SHARED_TRANSITIONS[key] = pair
            if len(_SHARED_TRANSITIONS) > SHARED_TRANSITIONS_SIZE:
                _SHARED_TRANSITIONS.popitem(last=False)
        cache[ticks] = pair
        if len(cache) > self.owner.cache_size:
            cache.popitem(last=False)
        return pair

    def integrate(self, rhs, t0, x0, t1, gs):
        """Advance from ``(t0, x0)`` to *t1* (s) by the exact ZOH transition under the plant's held input.

        *rhs* is not evaluated; *gs* is empty (a plant with events uses the fallback).
        The interval is rounded to whole ticks (every I/O instant lies on a tick).
        """
        ticks = round((t1 - t0) * TICKS_PER_SECOND)
        if ticks <= 0:
            return t1, x0, None
        pair = self._cache.get(ticks)
        if pair is None:
            Phi, Gamma = self.transition(ticks)
        else:
            self._cache.move_to_end(ticks)
            self.owner.cache_hits += 1
            Phi, Gamma = pair
        plant = self._plant()
        assert plant is not None, "a stepper is only called by its (live) plant"
        return t1, Phi.dot(x0) + Gamma.dot(plant.u), None
