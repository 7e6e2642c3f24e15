"""The plant runtime: a :class:`ContinuousSystem` living in a simulation (:class:`PlantInstance`).

A plant advances its state to ``now`` only when something reads or writes it, when the
logger samples, or when a subscribed hybrid event is due; there is no fixed-step loop
over the horizon.  Its integrator (:mod:`netcosim.plant.integrator`) stops exactly at
I/O instants, so the choice of integrator never changes the I/O semantics, only the
numerical error between them.
"""

from __future__ import annotations

import math
from itertools import repeat
from typing import Any, Callable

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError, IntegrationError
from ..timebase import MAX_SECONDS, TICKS_PER_SECOND, to_seconds, to_ticks
from .events import EVENT_REARM
from .ports import InputPort, OutputPort, _select
from .rk4 import _RK4Stepper
from .solve_ivp import SolveIVP
from .system import HybridEvent, _as_system
from .values import _FLOAT, _all_finite, _floats

__all__ = ["DEFAULT_LOG_INTERVAL", "default_log_interval", "PlantInstance"]

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

    Examples
    --------
    >>> from netcosim.plant import RK4, SolveIVP, default_log_interval
    >>> default_log_interval(SolveIVP()), default_log_interval(RK4(dt=1e-4)), default_log_interval(RK4(dt=0.005))
    (0.001, 0.001, 0.005)
    """
    dt = getattr(integrator, "dt", None)
    if isinstance(dt, (int, float)) and not isinstance(dt, bool) and math.isfinite(dt) and dt > 0:
        return max(DEFAULT_LOG_INTERVAL, float(dt))
    return DEFAULT_LOG_INTERVAL


class PlantInstance:
    """A :class:`ContinuousSystem` living in a :class:`~netcosim.sim.Simulation`.

    Parameters
    ----------
    name: the plant's name in traces and plots (``"servo"``: signals ``servo.y``, ...).
    system: a :class:`ContinuousSystem` (:meth:`Simulation.plant
        <netcosim.sim.Simulation.plant>` converts python-control systems with
        :func:`netcosim.plant.pycontrol.from_control` before they get here).
    x0: initial state (length ``system.nx``, finite, in the states' units).
    integrator: :class:`SolveIVP` (default), :class:`RK4` or :class:`ExactZOH`, or
        anything with the same ``integrate`` method (and optionally a ``bind(plant)``
        method returning the integrator to use for this plant; a stepper whose
        ``reports_dense`` is True reports the default logging grid's states through the
        ``dense=(times, report)`` argument, as SolveIVP does).  When None, the system's
        ``default_integrator`` if it has one (a co-simulation FMU's own stepper), else
        SolveIVP().
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

    Raises
    ------
    ConfigurationTypeError
        *system* is neither a :class:`~netcosim.plant.system.ContinuousSystem` nor an
        object with what a plant needs (``f``, ``h``, the names and sizes...); *x0* is
        None, a string, bytes or a dict; *integrator* has no ``integrate`` method;
        *disturbance* is not callable; *log_interval* is not a number of seconds.
    ConfigurationError
        *x0* is not numbers, not flat, not of length ``system.nx``, or not finite;
        *log* is not ``"io"`` or ``"none"``; *log_interval* is not a positive duration.
        The integrator's ``bind`` may refuse the plant too (e.g.
        :class:`~netcosim.plant.exact_zoh.ExactZOH` on a plant with hybrid events and
        no fallback).
    IntegrationError
        later, when the plant is advanced, read or logged: a non-finite state,
        derivative or output, or an integrator over its budget.

    Examples
    --------
    :meth:`Simulation.plant <netcosim.sim.Simulation.plant>` makes the instance.  The DC
    servo ``1000 / (s (s + 1))`` under 1 V for 0.1 s from rest: angle
    ``1000 (t - 1 + e^-t)`` rad, velocity ``1000 (1 - e^-t)`` rad/s:

    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.plants.dc_servo import DCServo
    >>> sim = Simulation()
    >>> servo = sim.plant(DCServo(), [0.0, 0.0])
    >>> servo.log_grid
    'default grid 1 ms until the first read or write, then read/write instants'
    >>> servo.input("u").write(1.0)
    >>> sim.run(until=0.1)
    >>> servo.state.round(6).tolist()
    [4.837418, 95.162582]
    >>> [round(1000 * (0.1 - 1 + math.exp(-0.1)), 6), round(1000 * (1 - math.exp(-0.1)), 6)]
    [4.837418, 95.162582]
    >>> sim.plant(DCServo(), [0.0], name="servo2")
    Traceback (most recent call last):
      ...
    netcosim.errors.ConfigurationError: plant 'servo2': x0 has 1 entries, the system has 2 states ['angle', 'velocity']
    """

    def __init__(self, sim, name, system, x0, *, integrator=None, params=None, disturbance=None,
                 log_interval=None, log="io"):
        system = _as_system(system, name)
        self.sim, self.name, self.system = sim, name, system
        if x0 is None or isinstance(x0, (str, bytes, dict)):
            raise ConfigurationTypeError(f"plant {name!r}: x0 must be {system.nx} numbers, got {x0!r}")
        try:
            x0a = np.array(x0, dtype=float)
        except OverflowError:
            raise ConfigurationError(f"plant {name!r}: x0 must be finite numbers, got {x0!r}") from None
        except (TypeError, ValueError):
            raise ConfigurationError(f"plant {name!r}: x0 must be {system.nx} numbers, got {x0!r}") from None
        if x0a.ndim > 1:
            raise ConfigurationError(f"plant {name!r}: x0 must be a flat sequence of {system.nx} numbers, "
                                     f"got shape {x0a.shape}: {x0!r}")
        x0a = x0a.reshape(-1)
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
        if integrator is None:  # a system may bring its own (a co-simulation FMU steps itself)
            integrator = getattr(system, "default_integrator", None) or SolveIVP()
        self.integrator = integrator
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
            # when the grid falls on them, a stepper with ``reports_dense = True`` (dense=
            # as SolveIVP's) its own; others integrate a copy
            self._grid_dense = ((isinstance(stepper, SolveIVP) and type(stepper).integrate is SolveIVP.integrate)
                                or type(stepper) is _RK4Stepper or getattr(stepper, "reports_dense", False) is True)
        #: how this plant's signals are sampled (also in ``sim.trace.grids``)
        self.log_grid = (f"log_interval {_seconds_text(log_interval)}" if log_interval is not None
                         # without log_interval, the default grid is on exactly when log="io"
                         else "none" if self._grid is None else
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
            sim._call_at_ticks(sim.now_ticks, self._log_tick)
        sim.add_finalizer(self._finish)

    # Ports -------------------------------------------------------------------
    def output(self, key=None) -> OutputPort:
        """A read port on output *key*: one output (name or index; a negative index counts
        from the end, as in Python), several (a list or a slice), or all (None)."""
        if type(key) is str and key in self._ports:  # a task body may ask for its port every job
            return self._ports[key]
        idx, label = _select(self.system.output_names, key, "output", self.name)
        port = OutputPort(self, idx, label)
        if type(key) is str:
            self._ports[key] = port
        return port

    def input(self, key=None) -> InputPort:
        """A write port on input *key*: one input (name or index; a negative index counts
        from the end, as in Python), several (a list or a slice), or all (None)."""
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
        """Hold *value* (in the input's units) on input(s) *index* from now on (ZOH); *label* names
        the inputs in error messages."""
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
        if v.ndim > 1 or (v.shape != target_shape and v.size != int(np.prod(target_shape))):
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
        if self._rec.mode == "off":  # nothing would be kept: the outputs are not evaluated for it
            return
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
        self.sim._call_at_ticks(self._log_k * self._log_every, self._log_tick)

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
        self._predict_timer = self.sim._call_at_ticks(ticks, self._wake)

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
