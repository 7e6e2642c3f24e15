"""Continuous plants coupled to the discrete world by lazy integration.

A plant is a :class:`ContinuousSystem`: ``f(t, x, u, params) -> dx/dt`` and outputs
``h(t, x, u, params) -> y`` (python-control's argument order), optional hybrid events
(zero crossings of ``g(t, x, u, params)`` that may reset the state), and optional
disturbance inputs.  ``u`` passed to ``f``, ``h`` and ``g`` is the concatenation of the
control inputs (held by zero-order hold since their last write) and the disturbance
vector ``d(t)``.

:class:`PlantInstance` advances the state to ``now`` only when something reads or
writes it, when the logger samples, or when a subscribed hybrid event is due; there is
no fixed-step loop over the horizon.  Integrators (:class:`RK4`, :class:`SolveIVP`,
:class:`ExactZOH` for linear time-invariant plants) all stop exactly at I/O instants,
so the choice of integrator never changes the I/O semantics, only the numerical error
between them.

Every advance is bounded: :class:`RK4` refuses an advance of more than ``max_steps``
steps and :class:`SolveIVP` one of more than ``max_evaluations`` evaluations of ``f``,
raising :class:`~netcosim.errors.IntegrationError` (a stiff plant under an explicit
method is the usual cause; use ``SolveIVP(method="Radau")`` or ``"BDF"``).  A
non-finite state, derivative or output also raises ``IntegrationError``, naming the
plant, the signal and the time, so NaN never reaches a task or a trace.

Systems of python-control (``StateSpace``, ``TransferFunction``,
``NonlinearIOSystem``) are accepted by ``Simulation.plant``, which converts them with
:mod:`netcosim.plant.pycontrol` (it imports ``control`` only then).
"""

from __future__ import annotations

import math
import weakref
from collections import OrderedDict
from dataclasses import dataclass
from itertools import repeat
from typing import Any, Callable, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError, IntegrationError, NetcosimError, NotConnectedError
from ..timebase import MAX_SECONDS, RESOLUTION, TICKS_PER_SECOND, to_seconds, to_ticks

__all__ = ["EVENT_REARM", "DEFAULT_LOG_INTERVAL", "default_log_interval", "HybridEvent", "ContinuousSystem", "RK4",
           "SolveIVP", "ExactZOH", "SOLVE_IVP_METHODS",
           "OutputPort", "InputPort", "PlantInstance", "NotConnectedError", "IntegrationError"]

#: Events firing again within this many seconds of the previous firing of the same
#: event are treated as the same crossing (numerical chatter at the located root).
EVENT_REARM = 1e-9

#: Grid (s) on which a plant is logged while no task has read or written it yet, when
#: neither ``log_interval`` nor ``log="none"`` is given (see :func:`default_log_interval`).
DEFAULT_LOG_INTERVAL = 1e-3


def default_log_interval(integrator: Any) -> float:
    """The default logging grid (s) of a plant integrated by *integrator* (the one that
    advances it: an :class:`ExactZOH` that falls back is its fallback):
    ``max(DEFAULT_LOG_INTERVAL, dt)`` for a fixed-step integrator with a step ``dt``
    (:class:`RK4`), else :data:`DEFAULT_LOG_INTERVAL` (1 ms).

    1 ms is the grid the project's experiments log on when they choose one
    (``log_interval=1e-3``) and ten or more samples per period of the loops they run;
    a fixed-step integrator is not sampled finer than its own step (there is no state
    between its steps, only an interpolation).
    """
    dt = getattr(integrator, "dt", None)
    if isinstance(dt, (int, float)) and not isinstance(dt, bool) and math.isfinite(dt) and dt > 0:
        return max(DEFAULT_LOG_INTERVAL, float(dt))
    return DEFAULT_LOG_INTERVAL


@dataclass(frozen=True)
class HybridEvent:
    """A zero crossing ``g(t, x, u, params) = 0`` of a plant.

    ``direction``: +1 fires on rising crossings (g goes from < 0 to >= 0), -1 on
    falling ones, 0 on both.  ``reset(t, x, u, params) -> x_new`` (optional) replaces
    the state at the crossing; without it the event only restarts the integrator there
    (use it at the edges of piecewise-defined dynamics, e.g. ground contact).
    """

    name: str
    g: Callable[..., float]
    direction: int = 0
    reset: Callable[..., Any] | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ConfigurationTypeError(f"event name must be a non-empty string, got {self.name!r}")
        if not callable(self.g):
            raise ConfigurationTypeError(f"event {self.name!r}: g must be callable g(t, x, u, params) -> float, "
                                         f"got {self.g!r}")
        if self.reset is not None and not callable(self.reset):
            raise ConfigurationTypeError(f"event {self.name!r}: reset must be None or callable "
                                         f"reset(t, x, u, params) -> x_new, got {self.reset!r}")
        validate.choice(self.direction, f"event {self.name!r}: direction", (-1, 0, 1), kind="-1, 0 or +1")


#: the most states, inputs, outputs or disturbances a system may declare (a larger count
#: is a typo: 10**9 states would fill the memory before the first step)
MAX_DIMENSION = 100_000


class ContinuousSystem:
    """Base class for plant models.

    Subclasses set ``state_names``, ``input_names``, ``output_names`` (and optionally
    ``disturbance_names``, ``events``, ``params``) and implement :meth:`f` (and
    :meth:`h`; the default output is the full state).  Alternatively pass callables::

        ContinuousSystem(f=lambda t, x, u, p: ..., states=2, inputs=1, outputs=1,
                         h=lambda t, x, u, p: x[:1])

    ``h`` must return ``ny`` finite values.  A subclass may also define
    ``jac(t, x, u, params) -> d f / d x`` (an ``nx`` × ``nx`` array); the implicit
    methods of :class:`SolveIVP` (Radau, BDF, LSODA) then use it instead of finite
    differences.
    """

    name: str = "plant"
    state_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()
    disturbance_names: tuple[str, ...] = ()
    events: tuple[HybridEvent, ...] = ()
    params: Any = None
    #: Optional ``jac(t, x, u, params) -> df/dx``; None: the integrator estimates it.
    jac: Callable[..., Any] | None = None

    def __init__(self, f: Callable | None = None, h: Callable | None = None, *,
                 states: int | Sequence[str] | None = None, inputs: int | Sequence[str] | None = None,
                 outputs: int | Sequence[str] | None = None, disturbances: int | Sequence[str] | None = None,
                 events: Sequence[HybridEvent] = (), params: Any = None, name: str | None = None):
        for what, fn in (("f", f), ("h", h)):
            if fn is not None:
                validate.callable_(fn, f"ContinuousSystem {what}", kind=f"a callable {what}(t, x, u, params)")
        if f is not None:
            self._f = f
        if h is not None:
            self._h = h
        for attr, spec, prefix in (("state_names", states, "x"), ("input_names", inputs, "u"),
                                   ("output_names", outputs, "y"), ("disturbance_names", disturbances, "d")):
            if spec is None:
                continue
            if isinstance(spec, (str, bool)) or not isinstance(spec, (int, np.integer, Sequence, np.ndarray)):
                raise ConfigurationTypeError(f"{attr.split('_')[0]}s must be a count or a sequence of names, "
                                             f"got {spec!r}")
            if isinstance(spec, (int, np.integer)):
                validate.count(spec, f"number of {attr.split('_')[0]}s", maximum=MAX_DIMENSION)
                spec = tuple(f"{prefix}{i}" for i in range(spec)) if spec else ()
            spec = tuple(spec)
            dup = sorted({n for n in spec if spec.count(n) > 1})
            if dup:
                raise ConfigurationError(f"{attr.split('_')[0]} names must be unique, {dup[0]!r} repeats in {spec!r}")
            setattr(self, attr, spec)
        if events:
            if isinstance(events, (str, bytes)) or not isinstance(events, (Sequence, np.ndarray)):
                raise ConfigurationTypeError(f"events must be a sequence of HybridEvent, got {events!r}")
            bad = [e for e in events if not isinstance(e, HybridEvent)]
            if bad:
                raise ConfigurationTypeError(f"events must be HybridEvent objects, got {bad[0]!r}")
            self.events = tuple(events)
        if params is not None:
            self.params = params
        if name is not None:
            self.name = name
        if outputs is None and not self.output_names and f is not None:
            self.output_names = self.state_names

    @property
    def nx(self) -> int:
        """Number of states."""
        return len(self.state_names)

    @property
    def nu(self) -> int:
        """Number of control inputs."""
        return len(self.input_names)

    @property
    def nd(self) -> int:
        """Number of disturbance inputs."""
        return len(self.disturbance_names)

    @property
    def ny(self) -> int:
        """Number of outputs."""
        return len(self.output_names)

    def f(self, t: float, x: np.ndarray, u: np.ndarray, params: Any) -> np.ndarray:
        """State derivative ``dx/dt`` at time *t* (s), state *x*, input *u* (controls then disturbances).

        Uses the ``f`` given to the constructor (or a subclass override); raises
        :class:`NotImplementedError` when there is none.
        """
        fn = getattr(self, "_f", None)
        if fn is None:
            raise NotImplementedError(f"{type(self).__name__} defines no dynamics f(t, x, u, params)")
        return fn(t, x, u, params)

    def h(self, t: float, x: np.ndarray, u: np.ndarray, params: Any) -> np.ndarray:
        """Output ``y`` at time *t* (s), state *x*, input *u*; the state itself when no ``h`` was given."""
        fn = getattr(self, "_h", None)
        if fn is None:
            return x
        return fn(t, x, u, params)


# ---------------------------------------------------------------------------
# Integrators: integrate(rhs, t0, x0, t1, gs) -> (t_end, x_end, fired index or None)
# ``gs`` is a list of (g(t, x), direction).  Integration stops at the first crossing.
# ---------------------------------------------------------------------------

def _all_finite(a: np.ndarray) -> bool:
    """True when every entry of the float array *a* is finite.

    The sum of the entries (as Python floats) is finite whenever every entry is, and
    costs far less than ``np.isfinite(a).all()`` for the few entries of a plant state;
    only a non-finite (or overflowing) sum needs the exact check.
    """
    return math.isfinite(sum(a.tolist())) or bool(np.isfinite(a).all())


def _floats(value, what: str) -> np.ndarray:
    """*value*, returned by a user's function (*what* names it), as a 1-D float array;
    :class:`ConfigurationTypeError` naming the value when it is not numbers (None, text,
    complex numbers: none of them silently becomes NaN or loses its imaginary part)."""
    if value is None or (isinstance(value, np.ndarray) and value.dtype.kind not in "fiub"):
        raise ConfigurationTypeError(f"{what} returned {value!r}, not real numbers")
    try:
        return np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ConfigurationTypeError(f"{what} returned {value!r}, not real numbers ({exc})") from None


def _crossed(g0: float, g1: float, direction: int) -> bool:
    if direction >= 0 and g0 < 0.0 <= g1:
        return True
    if direction <= 0 and g0 > 0.0 >= g1:
        return True
    return False


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
        """One classical Runge-Kutta step of length *h* (s) from ``(t, x)`` (t in s); returns the new state."""
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
        dt = self.dt
        gvals = [g(t, x) for g, _ in gs] if gs else None
        n = self._steps(t0, t1)
        for i in range(n):
            tn = t1 if i == n - 1 else t0 + (i + 1) * dt
            h = tn - t
            xn = self.step(rhs, t, x, h)
            if gs:
                for j, (g, d) in enumerate(gs):
                    g1 = g(tn, xn)
                    if _crossed(gvals[j], g1, d):
                        return self._locate(rhs, t, x, h, gs, gvals)
                    gvals[j] = g1
            t, x = tn, xn
        return t1, x, None

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

    def bind(self, plant: "PlantInstance"):
        """The integrator that advances *plant*: this RK4 bound to the plant's own ``f``
        (:class:`_RK4Stepper`: same steps, same arithmetic, no array built per stage).

        Called once by :class:`PlantInstance` when the plant is created.  A plant with
        more than :attr:`FLOAT_STEP_MAX_STATES` states (where NumPy's arrays beat lists of
        floats), or a subclass that overrides :meth:`step` or :meth:`integrate`, is
        integrated by :meth:`integrate` itself.
        """
        if (type(self).step is not RK4.step or type(self).integrate is not RK4.integrate
                or plant.system.nx > self.FLOAT_STEP_MAX_STATES):
            return self
        return _RK4Stepper(self, plant)

    def _locate(self, rhs, t, x, h, gs, g0s):
        # Earliest crossing among all events within this step.
        best = None
        for j, (g, d) in enumerate(gs):
            def phi(s, g=g):
                return g(t + s, self.step(rhs, t, x, s))
            gh = phi(h)
            if not _crossed(g0s[j], gh, d):
                continue
            if g0s[j] == 0.0:
                s = 0.0
            else:
                from scipy.optimize import brentq  # loaded on first event location
                s = brentq(phi, 0.0, h, xtol=self.xtol)
                # take the side after the crossing so that the event is not re-found
                if not _crossed(g0s[j], phi(s), d):
                    s = min(h, s + self.xtol)
            if best is None or s < best[0]:
                best = (s, j)
        s, j = best
        return t + s, self.step(rhs, t, x, s), j


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

    def __init__(self, owner: RK4, plant: "PlantInstance"):
        self.owner, self.name = owner, plant.name
        # weak: the plant holds this stepper, and a run must leave no reference cycle behind
        self._plant = weakref.ref(plant)
        self.nx = plant.system.nx
        self._x = np.empty(self.nx)  # the state f receives at each stage

    def __repr__(self):
        return f"{self.owner!r} bound to plant {self.name!r}"

    def _deriv(self, plant: "PlantInstance", t: float, x: list, u) -> list:
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
        n = owner._steps(t0, t1)
        dt = owner.dt
        plant = self._plant()
        u = plant.u if plant.disturbance is None else None  # held: read once per advance
        deriv = self._deriv
        t, x = t0, x0.tolist()
        wanted = dense[0].tolist() if dense is not None else []
        j, seen_t, seen_x = 0, [], []
        for i in range(n):
            tn = t1 if i == n - 1 else t0 + (i + 1) * dt
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


_FLOAT = np.dtype(float)

#: The ``method`` names ``scipy.integrate.solve_ivp`` accepts (a subclass of
#: ``scipy.integrate.OdeSolver`` is accepted too).
SOLVE_IVP_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")

#: The implicit (stiff-capable) ones among them.
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA")


def _check_count(v, what: str) -> None:
    validate.integer(v, what, lo=1, kind="a positive integer", fraction_error=ConfigurationTypeError)


class _BudgetExceeded(Exception):
    """Raised inside ``solve_ivp`` to stop it; turned into an IntegrationError."""


#: the smallest relative tolerance :class:`SolveIVP` accepts: SciPy's solvers raise a
#: smaller one to this (``100 * np.finfo(float).eps``)
RTOL_MIN = 100 * float(np.finfo(float).eps)


class SolveIVP:
    """SciPy ``solve_ivp`` with event location (the default integrator).

    Each lazy advance is one ``solve_ivp`` call from the last I/O instant to the next,
    stopped at the first event.

    Parameters
    ----------
    method: one of :data:`SOLVE_IVP_METHODS` or an ``OdeSolver`` subclass.

        * ``"RK45"`` (default), ``"DOP853"`` (tight tolerances), ``"RK23"``: explicit,
          cheap per step, for non-stiff plants.
        * ``"Radau"``, ``"BDF"``, ``"LSODA"``: implicit (LSODA switches
          automatically), for **stiff** plants, whose fastest modes (|λ| of the
          Jacobian) are far faster than the sampling and than the dynamics of
          interest, e.g. λ = 10**6 1/s under 1 ms sampling.  An explicit method must
          then take steps of about 1/|λ| whatever the tolerance (one simulated second
          at λ = 10**6 takes RK45 about 10**6 steps); an implicit one takes steps set by
          the accuracy only.  Each implicit step costs a Jacobian (``system.jac`` if the
          system defines it, else ``nx`` extra evaluations of ``f``) and a linear solve.
    rtol, atol: relative and absolute error tolerances (finite, > 0), per state, in
        the state's units; ``rtol`` from :data:`RTOL_MIN` (100 machine epsilons, below
        which SciPy's solvers cannot go) to below 1.
    max_step: longest step in seconds (> 0, ``inf`` = no limit).
    max_evaluations: most evaluations of ``f`` one advance (one call of
        :meth:`integrate`) may use; beyond it the advance stops with
        :class:`~netcosim.errors.IntegrationError` suggesting an implicit method.
        Default 50 000 (about 8 000 RK45 steps).
    """

    def __init__(self, method: str = "RK45", rtol: float = 1e-8, atol: float = 1e-10,
                 max_step: float = math.inf, max_evaluations: int = 50_000):
        from scipy.integrate import OdeSolver
        if isinstance(method, type) and issubclass(method, OdeSolver):
            pass
        elif not isinstance(method, str) or method not in SOLVE_IVP_METHODS:
            raise ConfigurationError(f"SolveIVP method must be one of {list(SOLVE_IVP_METHODS)} "
                                     f"(or an OdeSolver subclass), got {method!r}")
        for nm, v in (("rtol", rtol), ("atol", atol), ("max_step", max_step)):
            validate.positive(v, f"SolveIVP {nm}", kind="a positive number", type_error=ConfigurationError,
                              allow_inf=nm == "max_step")
        if not RTOL_MIN <= rtol < 1.0:
            # SciPy would raise a smaller rtol to 100 * eps with a warning at the first step
            raise ConfigurationError(f"SolveIVP rtol must be at least {RTOL_MIN!r} (100 machine epsilons, the "
                                     f"smallest SciPy's solvers use) and below 1, got {rtol!r}")
        _check_count(max_evaluations, "SolveIVP max_evaluations")
        self.method, self.rtol, self.atol, self.max_step = method, rtol, atol, max_step
        self.max_evaluations = int(max_evaluations)

    def __repr__(self):
        m = self.method if isinstance(self.method, str) else self.method.__name__
        return f"SolveIVP(method={m!r})"

    @property
    def implicit(self) -> bool:
        """True for the stiff-capable methods (Radau, BDF, LSODA)."""
        return self.method in IMPLICIT_METHODS

    def t_eval(self, t0: float, t1: float):
        """Hook for subclasses: instants (s, increasing, in ``(t0, t1]``, ending with *t1*)
        at which one advance from *t0* to *t1* should also report the state through
        :meth:`observe` (from the solver's dense output: the steps do not change).  The
        default, None, reports nothing."""
        return None

    def observe(self, t, x) -> None:
        """Hook for subclasses: the states ``x`` (nx, k; in the states' units) at the
        instants ``t`` (k,; s) asked by :meth:`t_eval` (up to a terminal event)."""

    def integrate(self, rhs, t0, x0, t1, gs, jac=None, dense=None):
        """Integrate ``dx/dt = rhs(t, x)`` from ``(t0, x0)`` to *t1* (s) with :func:`scipy.integrate.solve_ivp`.

        The guards *gs* (pairs ``(g, direction)``) are terminal events; *jac* is the
        Jacobian of *rhs* for the implicit methods.  *dense* (optional) is a pair
        ``(times, report)``: *times* increasing instants (s) in ``(t0, t1]``, and
        ``report(t, x)`` receives those up to the end of this advance with the states
        there (x: nx by k) from the solver's dense output -- the steps, and so
        ``x_end``, are the same as without it.  Returns ``(t_end, x_end, index of the
        fired guard or None)``.
        """
        events = []
        for g, d in gs:
            def ev(t, x, g=g):
                return g(t, x)
            ev.terminal = True
            ev.direction = d
            events.append(ev)
        budget = self.max_evaluations
        count = 0
        reached = [t0]

        def counted(t, x):
            nonlocal count
            count += 1
            if count > budget:
                raise _BudgetExceeded
            reached[0] = t
            return rhs(t, x)
        kw = {"jac": jac} if jac is not None and self.implicit else {}
        t_eval = self.t_eval(t0, t1)
        if t_eval is not None:
            kw["t_eval"] = t_eval
        if dense is not None:
            kw["dense_output"] = True
        try:
            from scipy.integrate import solve_ivp  # loaded on first use
            sol = solve_ivp(counted, (t0, t1), x0, method=self.method, rtol=self.rtol, atol=self.atol,
                            max_step=self.max_step, events=events or None, **kw)
        except _BudgetExceeded:
            hint = ("the plant is probably stiff (modes much faster than this interval): use "
                    "SolveIVP(method='Radau') or SolveIVP(method='BDF')" if not self.implicit else
                    "the plant may be very stiff or discontinuous")
            raise IntegrationError(
                f"{self!r} used more than max_evaluations={budget} evaluations of f advancing from "
                f"t={t0!r} to t={t1!r} s and got only to t={reached[0]!r} s; {hint}, "
                f"or raise max_evaluations") from None
        if sol.status == -1:
            raise IntegrationError(f"solve_ivp ({self!r}) failed between t={t0!r} and t={t1!r} s: "
                                   f"{sol.message}")
        if t_eval is not None:
            self.observe(sol.t, sol.y)
        if sol.status == 1:
            first = None
            for j, te in enumerate(sol.t_events):
                if len(te) and (first is None or te[0] < first[0]):
                    first = (te[0], j, sol.y_events[j][0])
            if dense is not None:
                _report_dense(sol, dense, first[0])
            return first[0], np.asarray(first[2], dtype=float), first[1]
        if dense is not None:
            _report_dense(sol, dense, t1)
        return t1, sol.y[:, -1].copy(), None


def _report_dense(sol, dense, t_end: float) -> None:
    """Hand ``dense = (times, report)`` the states at the *times* up to *t_end* (s)."""
    times, report = dense
    ts = np.asarray(times, dtype=float)
    ts = ts[ts <= t_end]
    if ts.size and sol.sol is not None:
        report(ts, np.asarray(sol.sol(ts), dtype=float).reshape(-1, ts.size))


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
    created): :class:`plants.dc_servo.DCServo` and the converted python-control
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

    def bind(self, plant: "PlantInstance"):
        """The integrator that advances *plant*: an exact stepper for it, or the fallback.

        Called once by :class:`PlantInstance` when the plant is created.
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
        """Not callable unbound: the exact step needs the plant's ``A``, ``B`` and held input.

        :class:`PlantInstance` calls :meth:`bind` and integrates with what it returns.
        """
        raise ConfigurationError("ExactZOH advances a plant it is bound to (PlantInstance calls "
                                 "ExactZOH.bind(plant)); it cannot integrate a bare right-hand side")


class _ExactZOHStepper:
    """:class:`ExactZOH` bound to one plant: its ``A``, ``B`` and a cache of ``(Φ, Γ)``."""

    def __init__(self, owner: ExactZOH, plant: "PlantInstance", A, B):
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
        return t1, Phi.dot(x0) + Gamma.dot(self._plant().u), None


# ---------------------------------------------------------------------------
# Ports
# ---------------------------------------------------------------------------

class OutputPort:
    """Read side of a plant: samples ``h(t, x, u)`` (selected outputs) at ``now``."""

    def __init__(self, plant: "PlantInstance", index, label: str):
        self.plant, self.index, self.label = plant, index, label

    def read(self):
        """The selected outputs at the current simulated time: a float for one output, else a copy of
        the array (the plant's units)."""
        y = self.plant.output_now()
        if type(self.index) is int:
            return float(y[self.index])
        v = y[self.index]
        return float(v) if np.ndim(v) == 0 else v.copy()

    def __repr__(self):
        return f"<OutputPort {self.plant.name}.{self.label}>"


class InputPort:
    """Write side of a plant: the value written is held (ZOH) until the next write."""

    def __init__(self, plant: "PlantInstance", index, label: str):
        self.plant, self.index, self.label = plant, index, label

    def write(self, value) -> None:
        """Hold *value* on the selected inputs from now until the next write (zero-order hold; the plant's units)."""
        self.plant.set_input(self.index, value, self.label)

    def __repr__(self):
        return f"<InputPort {self.plant.name}.{self.label}>"


class UnknownPortError(NetcosimError, KeyError, IndexError):
    """A plant has no such input or output (a name it does not have, an index out of
    range); the message lists the ones it has.  A :class:`KeyError` and an
    :class:`IndexError`, as before."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def _select(names: Sequence[str], key, kind: str, plant: str):
    """Map a name, an index, a slice or a list of those to an index into *names*."""
    if key is None:
        return slice(None), "all"
    if isinstance(key, slice):
        return key, f"[{key.start}:{key.stop}]"
    if isinstance(key, (list, tuple)):
        idx = [(_select(names, k, kind, plant)[0]) for k in key]
        return np.asarray(idx, dtype=int), ",".join(str(k) for k in key)
    if isinstance(key, str):
        try:
            return names.index(key), key
        except ValueError:
            raise UnknownPortError(f"plant {plant!r} has no {kind} {key!r}; {kind}s are {list(names)}") from None
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if not -len(names) <= key < len(names):
            raise UnknownPortError(f"plant {plant!r} has {len(names)} {kind}s {list(names)}, index {key} is out "
                                   "of range")
        return int(key), names[int(key)]
    raise ConfigurationTypeError(f"{kind} selector must be a name, index, slice or list, got {key!r}")


# ---------------------------------------------------------------------------
# Plant instance
# ---------------------------------------------------------------------------

class PlantInstance:
    """A :class:`ContinuousSystem` living in a :class:`~netcosim.sim.Simulation`.

    Parameters
    ----------
    system: a :class:`ContinuousSystem` (:meth:`Simulation.plant
        <netcosim.sim.Simulation.plant>` converts python-control systems with
        :func:`netcosim.plant.pycontrol.from_control` before they get here).
    x0: initial state (length ``system.nx``, finite, in the states' units).
    integrator: :class:`SolveIVP` (default), :class:`RK4` or :class:`ExactZOH`, or
        anything with the same ``integrate`` method (and optionally a ``bind(plant)``
        method returning the integrator to use for this plant).
    params: passed as ``params`` to f, h and events (default ``system.params``).
    disturbance: ``d(t) -> array`` of length ``system.nd`` (default zeros); ``t`` in s.
    log_interval: log states, inputs and outputs every ``log_interval`` s (the plant
        is advanced to each grid instant); when None, ``log="io"`` (the default) logs at
        every read and write instant and, until a task first reads or writes the plant,
        on the default grid of :func:`default_log_interval` (1 ms, or the RK4 step if
        longer) and at the end of each run, so that a plant no task touches (a starved
        loop, an open-loop plant) still has a trajectory; ``log="none"`` logs nothing.
        The default grid is read off the integration (SolveIVP's dense output, RK4's own
        steps when the grid falls on them, else a second integration from grid point to
        grid point on a copy of the state): it never changes the plant's own steps or
        states.  Nothing is computed for it while the ``signals`` table is ``off``.

    A non-finite state, derivative ``f`` or output ``h`` (returned by a read or
    logged) raises :class:`~netcosim.errors.IntegrationError` naming the plant, the
    signals and the time.
    """

    def __init__(self, sim, name, system, x0, *, integrator=None, params=None, disturbance=None,
                 log_interval=None, log="io"):
        system = _as_system(system, name)
        self.sim, self.name, self.system = sim, name, system
        if x0 is None or isinstance(x0, (str, bytes, dict)):
            raise ConfigurationTypeError(f"plant {name!r}: x0 must be {system.nx} numbers, got {x0!r}")
        try:
            x0a = np.array(x0, dtype=float).reshape(-1)
        except OverflowError:
            raise ConfigurationError(f"plant {name!r}: x0 must be finite numbers, got {x0!r}") from None
        except (TypeError, ValueError):
            raise ConfigurationError(f"plant {name!r}: x0 must be {system.nx} numbers, got {x0!r}") from None
        if x0a.shape[0] != system.nx:
            raise ConfigurationError(f"plant {name!r}: x0 has {x0a.shape[0]} entries, the system has "
                                     f"{system.nx} states {list(system.state_names)}")
        if not np.all(np.isfinite(x0a)):
            raise ConfigurationError(f"plant {name!r}: x0 must be finite, got {x0a.tolist()}")
        self.x = x0a
        self.t = sim.now  # seconds the state refers to
        self.u = np.zeros(system.nu)
        self.params = system.params if params is None else params
        if integrator is not None and not callable(getattr(integrator, "integrate", None)):
            raise ConfigurationTypeError(f"plant {name!r}: integrator must be an RK4, a SolveIVP or an object "
                                         f"with an integrate method, got {integrator!r}")
        self.integrator = integrator if integrator is not None else SolveIVP()
        if disturbance is not None:
            validate.callable_(disturbance, f"plant {name!r}: disturbance", kind="a callable d(t)")
        if disturbance is None and system.nd:
            zeros = np.zeros(system.nd)
            disturbance = lambda t: zeros  # noqa: E731
        self.disturbance = disturbance
        # an integrator may bind itself to the plant (ExactZOH needs A, B and the held input)
        bind = getattr(self.integrator, "bind", None)
        self._stepper = bind(self) if callable(bind) else self.integrator
        jac = getattr(system, "jac", None)
        self._jac = None
        if callable(jac) and isinstance(self._stepper, SolveIVP):
            self._jac = lambda t, x: jac(t, x, self._u_full(t), self.params)  # noqa: E731
        self.event_counts: dict[str, int] = {e.name: 0 for e in system.events}
        self.event_log: list[tuple[float, str]] = []
        #: the exception that stopped this plant's integration (None while it integrates fine)
        self.failure: BaseException | None = None
        self._last_fire: dict[int, float] = {}
        self._subscribers: dict[str, list[Callable[[float], None]]] = {}
        self._predict_timer = None
        self.prediction_horizon = 0.05
        validate.choice(log, f"plant {name!r}: log", ("io", "none"))
        if log_interval is not None:    # checked before anything prints it
            validate.duration(log_interval, f"plant {name!r}: log_interval", positive=True, kind="positive")
        self._log_io = log_interval is None and log == "io"
        #: default grid in ticks while no task has read or written the plant (None: off)
        self._grid: int | None = None
        self._grid_last: float | None = None  # time (s) of the last row logged on it
        self._grid_dense = False
        if self._log_io:
            stepper = self._stepper
            every = default_log_interval(stepper.owner if isinstance(stepper, _RK4Stepper) else stepper)
            self._grid = max(1, round(every * TICKS_PER_SECOND))
            # SolveIVP reports grid states from its dense output, RK4 those of its own steps
            # when the grid falls on them; others integrate a copy
            self._grid_dense = ((isinstance(stepper, SolveIVP) and type(stepper).integrate is SolveIVP.integrate)
                                or type(stepper) is _RK4Stepper)
        #: how this plant's signals are sampled (also in ``sim.trace.grids``)
        self.log_grid = (f"log_interval {_seconds_text(log_interval)}" if log_interval is not None
                         else "none" if log == "none" else
                         f"default grid {_seconds_text(self._grid / TICKS_PER_SECOND)} until the first read or "
                         f"write, then read/write instants")
        grids = getattr(sim.trace, "grids", None)
        if isinstance(grids, dict):
            grids[name] = self.log_grid
        self._rec = sim.trace.signal_rec
        self._log_names = ([f"x.{s}" for s in system.state_names] + [f"u.{s}" for s in system.input_names]
                           + [f"y.{s}" for s in system.output_names])
        self._ports: dict = {}  # output name -> port, (" in", input name) -> port
        self.outputs = OutputPort(self, slice(None), "outputs")
        self.inputs = InputPort(self, slice(None), "inputs")
        if log_interval is not None:
            self._log_every = validate.duration(log_interval, f"plant {name!r}: log_interval", positive=True,
                                                kind="positive")
            self._log_k = 0
            sim.call_at_ticks(sim.now_ticks, self._log_tick)
        sim.add_finalizer(self._finish)

    # Ports -------------------------------------------------------------------
    def output(self, key=None) -> OutputPort:
        """A read port on one output (name or index), several, or all (None)."""
        if type(key) is str and key in self._ports:  # a task body may ask for its port every job
            return self._ports[key]
        idx, label = _select(self.system.output_names, key, "output", self.name)
        port = OutputPort(self, idx, label)
        if type(key) is str:
            self._ports[key] = port
        return port

    def input(self, key=None) -> InputPort:
        """A write port on one input (name or index), several, or all (None)."""
        if type(key) is str and (" in", key) in self._ports:
            return self._ports[(" in", key)]
        idx, label = _select(self.system.input_names, key, "input", self.name)
        port = InputPort(self, idx, label)
        if type(key) is str:
            self._ports[(" in", key)] = port
        return port

    # Core --------------------------------------------------------------------
    def _u_full(self, t):
        if self.disturbance is None:
            return self.u
        d = _floats(self.disturbance(t), f"plant {self.name!r}: disturbance d(t={t!r})")
        if d.shape[0] != self.system.nd:
            raise ConfigurationError(
                f"plant {self.name!r}: disturbance d(t={t!r}) returned {d.shape[0]} values {d.tolist()!r}, "
                f"the system has {self.system.nd} disturbances {list(self.system.disturbance_names)}")
        if not _all_finite(d):
            raise ConfigurationError(f"plant {self.name!r}: disturbance d(t={t!r}) returned non-finite values "
                                     f"{d.tolist()!r} for {list(self.system.disturbance_names)}")
        return np.concatenate((self.u, d))

    def _rhs(self, t, x):
        dx = self.system.f(t, x, self._u_full(t), self.params)
        if type(dx) is not np.ndarray or dx.dtype != _FLOAT or dx.ndim != 1:
            dx = _floats(dx, f"plant {self.name!r}: f(t={t!r})")
        if dx.shape[0] != self.system.nx:
            raise ConfigurationError(
                f"plant {self.name!r}: f returned {dx.shape[0]} values {dx.tolist()!r} at t={t!r} s, the system "
                f"has {self.system.nx} states {list(self.system.state_names)}")
        if not np.isfinite(dx).all():
            bad = [n for n, v in zip(self.system.state_names, np.ravel(dx)) if not math.isfinite(v)]
            raise IntegrationError(
                f"plant {self.name!r}: derivative of {bad} is non-finite at t={t!r} s "
                f"(x={np.asarray(x).tolist()!r}, u={self._u_full(t).tolist()!r}): f returned {dx.tolist()!r}")
        return dx

    def _integrate(self, t0, x0, t1, gs, dense=None):
        """One integrator call, with the plant named in any IntegrationError (*dense*: see
        :meth:`SolveIVP.integrate`; only for a SolveIVP or an RK4 bound to the plant)."""
        try:
            if dense is not None:
                if self._jac is not None:
                    return self._stepper.integrate(self._rhs, t0, x0, t1, gs, jac=self._jac, dense=dense)
                return self._stepper.integrate(self._rhs, t0, x0, t1, gs, dense=dense)
            if self._jac is not None:
                return self._stepper.integrate(self._rhs, t0, x0, t1, gs, jac=self._jac)
            return self._stepper.integrate(self._rhs, t0, x0, t1, gs)
        except IntegrationError as exc:
            if str(exc).startswith(f"plant {self.name!r}"):
                raise
            raise IntegrationError(f"plant {self.name!r}: {exc}") from None

    def _outputs(self, t, x=None) -> np.ndarray:
        """``h(t, x, u, params)`` at the current state (or at *x*), checked (length ``ny``, finite)."""
        if x is None:
            x = self.x
        u = self.u if self.disturbance is None else self._u_full(t)
        y = _floats(self.system.h(t, x, u, self.params), f"plant {self.name!r}: h(t={t!r})")
        if y.shape[0] != self.system.ny:
            raise ConfigurationError(
                f"plant {self.name!r}: h returned {y.shape[0]} values {y.tolist()!r} at t={t!r} s, the system "
                f"has {self.system.ny} outputs {list(self.system.output_names)}")
        if not _all_finite(y):
            bad = [n for n, v in zip(self.system.output_names, y.tolist()) if not math.isfinite(v)]
            raise IntegrationError(
                f"plant {self.name!r}: output {', '.join(bad)} is non-finite at t={t!r} s: y={y.tolist()!r} "
                f"(x={np.asarray(x).tolist()!r}, u={self._u_full(t).tolist()!r})")
        return y

    def _gs(self):
        out = []
        for e in self.system.events:
            out.append(((lambda t, x, e=e: self._g(e, t, x)), e.direction))
        return out

    def _g(self, e: HybridEvent, t, x) -> float:
        """Event function *e* at (t, x) as a float; a clear error when it is not one real number."""
        v = e.g(t, x, self._u_full(t), self.params)
        try:
            return float(v)
        except (TypeError, ValueError):
            raise ConfigurationTypeError(f"plant {self.name!r}: event {e.name!r}: g(t={t!r}) returned {v!r}, "
                                         f"not one real number") from None

    def advance(self, t_target: float | None = None) -> None:
        """Integrate the state up to *t_target* seconds (default: now)."""
        if t_target is None:
            t_target = self.sim.env.now / TICKS_PER_SECOND
        elif type(t_target) is not float or not 0.0 <= t_target <= MAX_SECONDS:
            t_target = to_seconds(to_ticks(t_target, f"plant {self.name!r}: advance time"))
        if t_target <= self.t:
            return
        if self._grid is not None:
            self._advance_on_grid(t_target)
            return
        self.t, self.x = t_target, self._flow(self.t, self.x, t_target)

    def _flow(self, t, x, t_target, effects: bool = True, dense=None):
        """The state at *t_target* (s) integrated from ``(t, x)``, hybrid events handled.

        ``effects=False`` integrates a copy: events reset the state but are neither
        counted, logged nor notified, and a failure is not recorded on the plant.
        *dense*: ``(times, report)`` for the dense output of a SolveIVP or the steps of
        an RK4 (see :meth:`SolveIVP.integrate`)."""
        gs = self._gs() if self.system.events else []
        last_fire = self._last_fire if effects else dict(self._last_fire)
        progress_guard = 0
        while t < t_target:
            try:
                part = None
                if dense is not None:
                    times = dense[0]
                    times = times[times > t]
                    part = (times, dense[1]) if times.size else None
                t_new, x_new, j = self._integrate(t, x, t_target, gs, part)
                if not _all_finite(x_new):
                    bad = [n for n, v in zip(self.system.state_names, np.ravel(x_new)) if not math.isfinite(v)]
                    raise IntegrationError(
                        f"plant {self.name!r}: state {bad} became non-finite between t={t!r} and t={t_new!r} s: "
                        f"x={np.asarray(x_new).tolist()!r}")
            except Exception as exc:
                # the state stays the last finite one (at self.t); the end-of-run update skips this plant
                if effects:
                    self.failure = exc
                raise
            if j is not None:
                ev = self.system.events[j]
                last = last_fire.get(j)
                if last is None or t_new - last > EVENT_REARM:
                    last_fire[j] = t_new
                    if ev.reset is not None:
                        x_new = _floats(ev.reset(t_new, x_new, self._u_full(t_new), self.params),
                                        f"plant {self.name!r}: event {ev.name!r}: reset(t={t_new!r})")
                        if x_new.shape[0] != self.system.nx:
                            raise ConfigurationError(
                                f"plant {self.name!r}: event {ev.name!r}: reset returned {x_new.shape[0]} values "
                                f"{x_new.tolist()!r}, the system has {self.system.nx} states")
                    if effects:
                        self.event_counts[ev.name] += 1
                        self.event_log.append((t_new, ev.name))
                        for cb in self._subscribers.get(ev.name, ()):
                            cb(t_new)
                if t_new <= t:
                    progress_guard += 1
                    if progress_guard > 100:
                        chatter = IntegrationError(f"plant {self.name!r}: event {ev.name!r} chatters at t={t} s")
                        if effects:
                            self.failure = chatter
                        raise chatter
                    # step over the located root on the integrator's own scale
                    t_new = min(t_target, t + EVENT_REARM)
                    x_new = x_new + (t_new - t) * self._rhs(t, x_new)
                else:
                    progress_guard = 0
            t, x = t_new, x_new
        return x

    def _advance_on_grid(self, t_target: float) -> None:
        """:meth:`advance` while no task has read or written the plant: the same
        integration, and rows on the default grid strictly between the last row and
        *t_target* (the state the plant starts from first)."""
        t0, x0 = self.t, self.x
        if self._rec.mode == "off":  # nothing would be kept: integrate only
            self.t, self.x = t_target, self._flow(t0, x0, t_target)
            return
        if self._grid_last is None:
            self._log_state(t0, x0)
            self._grid_last = t0
        every = self._grid
        assert every is not None
        first = round(self._grid_last * TICKS_PER_SECOND) // every + 1
        end = math.ceil(round(t_target * TICKS_PER_SECOND) / every)  # grid index of the first instant >= t_target
        times = np.arange(first, end, dtype=np.int64) * every / TICKS_PER_SECOND
        times = times[times < t_target]
        if not times.size:
            self.t, self.x = t_target, self._flow(t0, x0, t_target)
            return
        if self._grid_dense and not self.system.events and self._on_steps(t0, times):
            seen: list = []
            x1 = self._flow(t0, x0, t_target, dense=(times, lambda ts, xs: seen.append((ts, xs))))
            self.t, self.x = t_target, x1
            for ts, xs in seen:
                for k, tk in enumerate(ts.tolist()):
                    self._log_state(tk, xs[:, k])
        else:
            self.t, self.x = t_target, self._flow(t0, x0, t_target)
            t, x = t0, x0
            for tk in times.tolist():
                x = self._flow(t, x, tk, effects=False)
                t = tk
                self._log_state(tk, x)
        self._grid_last = float(times[-1])

    def _on_steps(self, t0: float, times: np.ndarray) -> bool:
        """True unless the plant is stepped by RK4 and some of *times* (s) are not among the
        step instants ``t0 + i dt`` of an advance from *t0*."""
        stepper = self._stepper
        if type(stepper) is not _RK4Stepper:
            return True
        k = (times - t0) / stepper.owner.dt
        return bool(np.all(np.abs(k - np.round(k)) <= 1e-6))

    def _touched(self) -> None:
        """A task read or wrote the plant: from now on it is logged at its I/O instants."""
        self._grid = None

    def output_now(self) -> np.ndarray:
        """Advance to now and return ``h(t, x, u)``."""
        self.advance()
        if self._grid is not None:
            self._touched()
        t = self.t
        y = self._outputs(t)
        if self._log_io:
            self._log(t, y)
        return y

    @property
    def state(self) -> np.ndarray:
        """The state at ``now`` (advances the plant).  After the plant's integration
        failed (``failure`` set), its last finite state, at ``t`` (s), without advancing."""
        if self.failure is None:
            self.advance()
        return self.x.copy()

    def set_input(self, index, value, label="inputs") -> None:
        """Hold *value* (in the input's units) on input(s) *index* from now on (ZOH)."""
        if type(value) is float and type(index) is int and math.isfinite(value) and -len(self.u) <= index < len(self.u):
            # one finite number on one input: what the generic path below would accept as is
            self.advance()
            if self._grid is not None:
                self._touched()
            if self._log_io:
                self._log(self.t)
            self.u[index] = value
            if self._log_io:
                self._log(self.t)
            if self._subscribers:
                self._schedule_prediction()
            return
        if value is None or isinstance(value, (str, bytes)):
            raise ConfigurationTypeError(f"plant {self.name!r}: input {label} takes numbers, got {value!r}")
        try:
            v = np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ConfigurationError(f"plant {self.name!r}: input {label} takes finite numbers, "
                                     f"got {value!r}") from None
        if not np.all(np.isfinite(v)):
            raise ConfigurationError(f"plant {self.name!r}: non-finite value {value!r} written to input {label}")
        target_shape = np.shape(self.u[index])
        if v.shape != target_shape and v.size != int(np.prod(target_shape)):
            raise ConfigurationError(f"plant {self.name!r}: input {label} takes {int(np.prod(target_shape))} "
                                     f"value(s), got {value!r}")
        self.advance()
        if self._grid is not None:
            self._touched()
        if self._log_io:
            self._log(self.t)
        self.u[index] = v.reshape(target_shape)
        if self._log_io:
            self._log(self.t)
        if self._subscribers:
            self._schedule_prediction()

    # Logging -------------------------------------------------------------------
    def _log(self, t, y=None):
        if y is None:
            y = self._outputs(t)
        # rows (t, plant, signal, value), built by zip in C
        self._rec.rows.extend(zip(repeat(t), repeat(self.name), self._log_names,
                                  self.x.tolist() + self.u.tolist() + y.tolist()))

    def _log_state(self, t, x):
        """Log the state *x* at *t* (s) under the input held now (a default-grid row)."""
        y = self._outputs(t, x)
        self._rec.rows.extend(zip(repeat(t), repeat(self.name), self._log_names,
                                  np.asarray(x, dtype=float).tolist() + self.u.tolist() + y.tolist()))

    def _log_tick(self):
        ticks = self._log_k * self._log_every
        self.advance(ticks / TICKS_PER_SECOND)
        self._log(self.t)
        self._log_k += 1
        self.sim.call_at_ticks((self._log_k) * self._log_every, self._log_tick)

    def _finish(self):
        """End of a run (or the failure instant of a failed one): bring the state to now,
        unless this plant's own integration failed (its state stays the last finite one)."""
        if self.failure is None:
            self.advance()
            if self._grid is not None and (self._grid_last is None or self.t > self._grid_last):
                # close the default grid at the end of the run, so that its window ends there
                self._log_state(self.t, self.x)
                self._grid_last = self.t

    # Event subscription -------------------------------------------------------
    def on_event(self, name: str, callback: Callable[[float], None]) -> None:
        """Call ``callback(t)`` at the simulated instant hybrid event *name* fires.

        With a subscriber, the plant predicts its next event under the currently held
        inputs and wakes itself at that instant (re-predicting after every write).
        """
        names = [e.name for e in self.system.events]
        if name not in names:
            raise KeyError(f"plant {self.name!r} has no event {name!r}; events are {names}")
        self._subscribers.setdefault(name, []).append(callback)
        self._schedule_prediction()

    def _schedule_prediction(self):
        if self._predict_timer is not None:
            self._predict_timer.cancel()
        self.advance()
        gs = self._gs()
        t0 = self.t
        t_end, _, j = self._integrate(t0, self.x.copy(), t0 + self.prediction_horizon, gs)
        ticks = math.ceil(t_end * TICKS_PER_SECOND)
        if j is not None and ticks <= self.sim.now_ticks:
            ticks = self.sim.now_ticks + 1
        self._predict_timer = self.sim.call_at_ticks(ticks, self._wake)

    def _wake(self):
        self._predict_timer = None
        self.advance()
        self._schedule_prediction()


def _seconds_text(seconds: float) -> str:
    """A duration for people: ``1 ms``, ``100 us``, ``0.25 s``."""
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)):
        if seconds >= scale or unit == "ns":
            return f"{seconds / scale:g} {unit}"
    return f"{seconds:g} s"  # pragma: no cover


def _as_system(system, name) -> ContinuousSystem:
    """*system* itself, if it has what a plant needs."""
    if isinstance(system, ContinuousSystem):
        return system
    needed = ("f", "h", "state_names", "input_names", "output_names", "nx", "nu", "nd", "ny", "events", "params")
    missing = [a for a in needed if not hasattr(system, a)]
    if missing:
        raise ConfigurationTypeError(
            f"plant {name!r}: system must be a ContinuousSystem or a python-control StateSpace, "
            f"TransferFunction or NonlinearIOSystem, got {system!r} (it has no {', '.join(missing)})")
    return system
