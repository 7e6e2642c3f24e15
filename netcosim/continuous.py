"""Continuous plants coupled to the discrete world by lazy integration.

A plant is a :class:`ContinuousSystem`: ``f(t, x, u, params) -> dx/dt`` and outputs
``h(t, x, u, params) -> y`` (python-control's argument order), optional hybrid events
(zero crossings of ``g(t, x, u, params)`` that may reset the state), and optional
disturbance inputs.  ``u`` passed to ``f``, ``h`` and ``g`` is the concatenation of the
control inputs (held by zero-order hold since their last write) and the disturbance
vector ``d(t)``.

:class:`PlantInstance` advances the state to ``now`` only when something reads or
writes it, when the logger samples, or when a subscribed hybrid event is due; there is
no fixed-step loop over the horizon.  Integrators (:class:`RK4`, :class:`SolveIVP`) all
stop exactly at I/O instants, so the choice of integrator never changes the I/O
semantics, only the numerical error between them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .timebase import TICKS_PER_SECOND, to_ticks

#: Events firing again within this many seconds of the previous firing of the same
#: event are treated as the same crossing (numerical chatter at the located root).
EVENT_REARM = 1e-9


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
        if self.direction not in (-1, 0, 1):
            raise ValueError(f"event {self.name!r}: direction must be -1, 0 or +1, got {self.direction!r}")


class ContinuousSystem:
    """Base class for plant models.

    Subclasses set ``state_names``, ``input_names``, ``output_names`` (and optionally
    ``disturbance_names``, ``events``, ``params``) and implement :meth:`f` (and
    :meth:`h`; the default output is the full state).  Alternatively pass callables::

        ContinuousSystem(f=lambda t, x, u, p: ..., states=2, inputs=1, outputs=1,
                         h=lambda t, x, u, p: x[:1])
    """

    name: str = "plant"
    state_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()
    disturbance_names: tuple[str, ...] = ()
    events: tuple[HybridEvent, ...] = ()
    params: Any = None

    def __init__(self, f: Callable | None = None, h: Callable | None = None, *,
                 states: int | Sequence[str] | None = None, inputs: int | Sequence[str] | None = None,
                 outputs: int | Sequence[str] | None = None, disturbances: int | Sequence[str] = (),
                 events: Sequence[HybridEvent] = (), params: Any = None, name: str | None = None):
        if f is not None:
            self._f = f
        if h is not None:
            self._h = h
        for attr, spec, prefix in (("state_names", states, "x"), ("input_names", inputs, "u"),
                                   ("output_names", outputs, "y"), ("disturbance_names", disturbances, "d")):
            if spec is None:
                continue
            if isinstance(spec, (int, np.integer)):
                if spec < 0:
                    raise ValueError(f"number of {attr.split('_')[0]}s must be >= 0, got {spec}")
                spec = tuple(f"{prefix}{i}" for i in range(spec)) if spec else ()
            setattr(self, attr, tuple(spec))
        if events:
            self.events = tuple(events)
        if params is not None:
            self.params = params
        if name is not None:
            self.name = name
        if outputs is None and not self.output_names and f is not None:
            self.output_names = self.state_names

    @property
    def nx(self) -> int:
        return len(self.state_names)

    @property
    def nu(self) -> int:
        return len(self.input_names)

    @property
    def nd(self) -> int:
        return len(self.disturbance_names)

    @property
    def ny(self) -> int:
        return len(self.output_names)

    def f(self, t: float, x: np.ndarray, u: np.ndarray, params: Any) -> np.ndarray:
        fn = getattr(self, "_f", None)
        if fn is None:
            raise NotImplementedError(f"{type(self).__name__} defines no dynamics f(t, x, u, params)")
        return fn(t, x, u, params)

    def h(self, t: float, x: np.ndarray, u: np.ndarray, params: Any) -> np.ndarray:
        fn = getattr(self, "_h", None)
        if fn is None:
            return x
        return fn(t, x, u, params)


# ---------------------------------------------------------------------------
# Integrators: integrate(rhs, t0, x0, t1, gs) -> (t_end, x_end, fired index or None)
# ``gs`` is a list of (g(t, x), direction).  Integration stops at the first crossing.
# ---------------------------------------------------------------------------

def _crossed(g0: float, g1: float, direction: int) -> bool:
    if direction >= 0 and g0 < 0.0 <= g1:
        return True
    if direction <= 0 and g0 > 0.0 >= g1:
        return True
    return False


class RK4:
    """Classical fixed-step Runge–Kutta 4 with step *dt* seconds.

    The last step before an I/O instant is shortened so that every I/O instant is hit
    exactly.  Events are located on the RK4 step map with Brent's method to ``xtol``.
    """

    def __init__(self, dt: float = 1e-3, xtol: float = 1e-12):
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"RK4 step dt must be a positive number of seconds, got {dt!r}")
        self.dt = float(dt)
        self.xtol = xtol

    @staticmethod
    def step(rhs, t, x, h):
        k1 = rhs(t, x)
        k2 = rhs(t + 0.5 * h, x + (0.5 * h) * k1)
        k3 = rhs(t + 0.5 * h, x + (0.5 * h) * k2)
        k4 = rhs(t + h, x + h * k3)
        return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def integrate(self, rhs, t0, x0, t1, gs):
        t, x = t0, x0
        dt = self.dt
        gvals = [g(t, x) for g, _ in gs] if gs else None
        n = max(1, math.ceil((t1 - t0) / dt - 1e-9))
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
                s = brentq(phi, 0.0, h, xtol=self.xtol)
                # take the side after the crossing so that the event is not re-found
                if not _crossed(g0s[j], phi(s), d):
                    s = min(h, s + self.xtol)
            if best is None or s < best[0]:
                best = (s, j)
        s, j = best
        return t + s, self.step(rhs, t, x, s), j


class SolveIVP:
    """SciPy ``solve_ivp`` with event location (default integrator).

    Each lazy advance is one ``solve_ivp`` call from the last I/O instant to the next,
    stopped at the first event.  ``method``, ``rtol``, ``atol`` and ``max_step`` are
    passed through.
    """

    def __init__(self, method: str = "RK45", rtol: float = 1e-8, atol: float = 1e-10,
                 max_step: float = math.inf):
        for nm, v in (("rtol", rtol), ("atol", atol)):
            if not (isinstance(v, (int, float)) and v > 0):
                raise ValueError(f"SolveIVP {nm} must be positive, got {v!r}")
        self.method, self.rtol, self.atol, self.max_step = method, rtol, atol, max_step

    def integrate(self, rhs, t0, x0, t1, gs):
        events = []
        for g, d in gs:
            ev = (lambda t, x, g=g: g(t, x))
            ev.terminal = True
            ev.direction = d
            events.append(ev)
        sol = solve_ivp(rhs, (t0, t1), x0, method=self.method, rtol=self.rtol, atol=self.atol,
                        max_step=self.max_step, events=events or None)
        if sol.status == -1:
            raise RuntimeError(f"solve_ivp failed between t={t0} and t={t1} s: {sol.message}")
        if sol.status == 1:
            first = None
            for j, te in enumerate(sol.t_events):
                if len(te) and (first is None or te[0] < first[0]):
                    first = (te[0], j, sol.y_events[j][0])
            return first[0], np.asarray(first[2], dtype=float), first[1]
        return t1, sol.y[:, -1].copy(), None


# ---------------------------------------------------------------------------
# Ports
# ---------------------------------------------------------------------------

from .errors import NotConnectedError  # noqa: E402,F401 (re-exported; defined in netcosim.errors)


class OutputPort:
    """Read side of a plant: samples ``h(t, x, u)`` (selected outputs) at ``now``."""

    def __init__(self, plant: "PlantInstance", index, label: str):
        self.plant, self.index, self.label = plant, index, label

    def read(self):
        y = self.plant.output_now()
        v = y[self.index]
        return float(v) if np.ndim(v) == 0 else v.copy()

    def __repr__(self):
        return f"<OutputPort {self.plant.name}.{self.label}>"


class InputPort:
    """Write side of a plant: the value written is held (ZOH) until the next write."""

    def __init__(self, plant: "PlantInstance", index, label: str):
        self.plant, self.index, self.label = plant, index, label

    def write(self, value) -> None:
        self.plant.set_input(self.index, value, self.label)

    def __repr__(self):
        return f"<InputPort {self.plant.name}.{self.label}>"


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
            raise KeyError(f"plant {plant!r} has no {kind} {key!r}; {kind}s are {list(names)}") from None
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if not -len(names) <= key < len(names):
            raise IndexError(f"plant {plant!r} has {len(names)} {kind}s, index {key} is out of range")
        return int(key), names[key]
    raise TypeError(f"{kind} selector must be a name, index, slice or list, got {key!r}")


# ---------------------------------------------------------------------------
# Plant instance
# ---------------------------------------------------------------------------

class PlantInstance:
    """A :class:`ContinuousSystem` living in a :class:`~netcosim.sim.Simulation`.

    Parameters
    ----------
    x0: initial state (length ``system.nx``).
    integrator: :class:`SolveIVP` (default) or :class:`RK4`, or anything with the
        same ``integrate`` method.
    params: passed as ``params`` to f, h and events (default ``system.params``).
    disturbance: ``d(t) -> array`` of length ``system.nd`` (default zeros).
    log_interval: log states, inputs and outputs every ``log_interval`` s; when None,
        ``log="io"`` logs at every read and write instant, ``log="none"`` not at all.
    """

    def __init__(self, sim, name, system, x0, *, integrator=None, params=None, disturbance=None,
                 log_interval=None, log="io"):
        self.sim, self.name, self.system = sim, name, system
        x0 = np.array(x0, dtype=float).reshape(-1)
        if x0.shape[0] != system.nx:
            raise ValueError(f"plant {name!r}: x0 has {x0.shape[0]} entries, the system has "
                             f"{system.nx} states {list(system.state_names)}")
        if not np.all(np.isfinite(x0)):
            raise ValueError(f"plant {name!r}: x0 must be finite, got {x0.tolist()}")
        self.x = x0
        self.t = sim.now  # seconds the state refers to
        self.u = np.zeros(system.nu)
        self.params = system.params if params is None else params
        self.integrator = integrator if integrator is not None else SolveIVP()
        if disturbance is not None and not callable(disturbance):
            raise TypeError(f"plant {name!r}: disturbance must be a callable d(t), got {disturbance!r}")
        if disturbance is None and system.nd:
            zeros = np.zeros(system.nd)
            disturbance = lambda t: zeros  # noqa: E731
        self.disturbance = disturbance
        self.event_counts: dict[str, int] = {e.name: 0 for e in system.events}
        self.event_log: list[tuple[float, str]] = []
        self._last_fire: dict[int, float] = {}
        self._subscribers: dict[str, list[Callable[[float], None]]] = {}
        self._predict_timer = None
        self.prediction_horizon = 0.05
        if log not in ("io", "none"):
            raise ValueError(f"plant {name!r}: log must be 'io' or 'none', got {log!r}")
        self._log_io = log_interval is None and log == "io"
        self._rec = sim.trace.signal_rec
        self._log_names = ([f"x.{s}" for s in system.state_names] + [f"u.{s}" for s in system.input_names]
                           + [f"y.{s}" for s in system.output_names])
        self.outputs = OutputPort(self, slice(None), "outputs")
        self.inputs = InputPort(self, slice(None), "inputs")
        if log_interval is not None:
            self._log_every = to_ticks(log_interval, f"plant {name!r} log_interval")
            if self._log_every <= 0:
                raise ValueError(f"plant {name!r}: log_interval must be positive, got {log_interval!r}")
            self._log_k = 0
            sim.call_at_ticks(sim.now_ticks, self._log_tick)
        sim.add_finalizer(self._finish)

    # Ports -------------------------------------------------------------------
    def output(self, key=None) -> OutputPort:
        """A read port on one output (name or index), several, or all (None)."""
        idx, label = _select(self.system.output_names, key, "output", self.name)
        return OutputPort(self, idx, label)

    def input(self, key=None) -> InputPort:
        """A write port on one input (name or index), several, or all (None)."""
        idx, label = _select(self.system.input_names, key, "input", self.name)
        return InputPort(self, idx, label)

    # Core --------------------------------------------------------------------
    def _u_full(self, t):
        if self.disturbance is None:
            return self.u
        d = np.asarray(self.disturbance(t), dtype=float).reshape(-1)
        return np.concatenate((self.u, d))

    def _rhs(self, t, x):
        return np.asarray(self.system.f(t, x, self._u_full(t), self.params), dtype=float)

    def _gs(self):
        out = []
        for e in self.system.events:
            out.append(((lambda t, x, e=e: float(e.g(t, x, self._u_full(t), self.params))), e.direction))
        return out

    def advance(self, t_target: float | None = None) -> None:
        """Integrate the state up to *t_target* seconds (default: now)."""
        if t_target is None:
            t_target = self.sim.now
        if t_target <= self.t:
            return
        gs = self._gs()
        t, x = self.t, self.x
        progress_guard = 0
        while t < t_target:
            t_new, x_new, j = self.integrator.integrate(self._rhs, t, x, t_target, gs)
            if not np.all(np.isfinite(x_new)):
                raise FloatingPointError(
                    f"plant {self.name!r}: state became non-finite between t={t} and t={t_new} s: {x_new}")
            if j is not None:
                ev = self.system.events[j]
                last = self._last_fire.get(j)
                if last is None or t_new - last > EVENT_REARM:
                    self._last_fire[j] = t_new
                    if ev.reset is not None:
                        x_new = np.asarray(ev.reset(t_new, x_new, self._u_full(t_new), self.params), dtype=float)
                    self.event_counts[ev.name] += 1
                    self.event_log.append((t_new, ev.name))
                    for cb in self._subscribers.get(ev.name, ()):
                        cb(t_new)
                if t_new <= t:
                    progress_guard += 1
                    if progress_guard > 100:
                        raise RuntimeError(f"plant {self.name!r}: event {ev.name!r} chatters at t={t} s")
                    # step over the located root on the integrator's own scale
                    t_new = min(t_target, t + EVENT_REARM)
                    x_new = x_new + (t_new - t) * self._rhs(t, x_new)
                else:
                    progress_guard = 0
            t, x = t_new, x_new
        self.t, self.x = t_target, x

    def output_now(self) -> np.ndarray:
        """Advance to now and return ``h(t, x, u)``."""
        self.advance()
        t = self.t
        y = np.asarray(self.system.h(t, self.x, self._u_full(t), self.params), dtype=float).reshape(-1)
        if self._log_io:
            self._log(t, y)
        return y

    @property
    def state(self) -> np.ndarray:
        """The state at ``now`` (advances the plant)."""
        self.advance()
        return self.x.copy()

    def set_input(self, index, value, label="inputs") -> None:
        v = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(v)):
            raise ValueError(f"plant {self.name!r}: non-finite value {value!r} written to input {label}")
        target_shape = np.shape(self.u[index])
        if v.shape != target_shape and v.size != int(np.prod(target_shape)):
            raise ValueError(f"plant {self.name!r}: input {label} takes {int(np.prod(target_shape))} "
                             f"value(s), got {value!r}")
        self.advance()
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
            y = np.asarray(self.system.h(t, self.x, self._u_full(t), self.params), dtype=float).reshape(-1)
        vals = np.concatenate((self.x, self.u, y))
        app = self._rec.rows.append
        name = self.name
        for n, v in zip(self._log_names, vals.tolist()):
            app((t, name, n, v))

    def _log_tick(self):
        ticks = self._log_k * self._log_every
        self.advance(ticks / TICKS_PER_SECOND)
        self._log(self.t)
        self._log_k += 1
        self.sim.call_at_ticks((self._log_k) * self._log_every, self._log_tick)

    def _finish(self):
        self.advance()

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
        t_end, _, j = self.integrator.integrate(self._rhs, t0, self.x.copy(), t0 + self.prediction_horizon, gs)
        ticks = math.ceil(t_end * TICKS_PER_SECOND)
        if j is not None and ticks <= self.sim.now_ticks:
            ticks = self.sim.now_ticks + 1
        self._predict_timer = self.sim.call_at_ticks(ticks, self._wake)

    def _wake(self):
        self._predict_timer = None
        self.advance()
        self._schedule_prediction()
