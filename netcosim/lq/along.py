"""The exact expected cost along a simulated schedule: a :class:`Propagator` driven by a clock.

:class:`ExpectedCost` couples the linear-quadratic model to a running simulation without
importing it: it reads only a time source -- a :class:`~netcosim.Simulation` (its ``now``,
seconds) or any callable returning the present time in seconds.  Task code declares where
the model's discrete systems execute by calling :meth:`ExpectedCost.execute` at that point
of its body; the propagator is advanced to the present instant and the system executed
there.  With TrueTime's segment semantics (the code after ``yield ctx.execute(c)`` runs at
the end of the segment), a control task reads::

    @node.periodic(period=h, priority=2)
    def control(ctx):
        y = ctx.read(y_port)
        ec.execute("sampler")            # the sample, at the job's start
        u = law(y)
        ec.execute("ctrl")               # the controller's update (same instant here)
        yield ctx.execute(c)             # c s of CPU time, preemptible
        ctx.write(u_port, u)
        ec.execute("act")                # the actuation, at the end of the segment

Over a network the actuator node's handler calls ``ec.execute("act")`` when the message
arrives and is written.  **A lost message** executes nothing: the receiving system keeps
its state and held output (*hold*) -- a controller that is not run keeps its state and
its last output, an actuator that is not run keeps the last control.  "Zero on loss"
(the actuator outputs 0 when a control does not arrive) is a different discrete event:
at the instant the simulation decides the control is missing (e.g. an actuator timeout),
call ``ec.reset("act", 0)`` (the actuator's held output set to zero) or execute an
alternative system.  Preemption, network delays and losses of the *ordinary* simulation
thus set the instants at which the covariance is updated, and :meth:`cost_until` gives
the exact expected cost ``E ∫ z^T Q_c z dt`` of that schedule over the plant noise.

The interval between two events is the difference of two clock readings, rounded to 1 ps
(:data:`GRAIN`, the simulator's resolution) so that repeated intervals share their
matrices; the propagator's time is set to the clock reading itself (no drift).  Errors:
a key that is not a discrete system of the model, a clock reading that is not finite or
lies before the last event (an ExpectedCost reused in a second simulation: make one per
run), a covariance or cost that stops being finite.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Any, Callable, Hashable

from ..errors import ConfigurationError, ConfigurationTypeError
from .propagation import Propagator
from .result import CostTrace
from .systems import Interconnection

__all__ = ["ExpectedCost", "GRAIN"]

#: intervals are rounded to this many seconds (the simulator's resolution, 1 ps)
GRAIN = 1e-12
#: models (by their total dynamics) whose interval matrices are shared by every ExpectedCost
SHARED_MODELS = 16
#: ``dynamics key -> {T: IntervalMatrices}``, least recently used first: the runs of a Monte
#: Carlo or a sweep (one ExpectedCost each) compute each interval's exponentials once
_SHARED: OrderedDict[bytes, dict] = OrderedDict()


def _shared_cache(propagator: Propagator) -> dict:
    d = propagator.dynamics
    key = d.A.tobytes() + d.R_c.tobytes() + d.Q_c.tobytes() + str(d.A.shape).encode()
    got = _SHARED.get(key)
    if got is None:
        got = _SHARED[key] = {}
        if len(_SHARED) > SHARED_MODELS:
            _SHARED.popitem(last=False)
    else:
        _SHARED.move_to_end(key)
    return got


class ExpectedCost:
    """The exact expected cost of *model* along the events of a running simulation.

    ``clock``: a simulation (anything with a ``now`` attribute in seconds) or a callable
    returning the present time (s).  ``m0``, ``P0``: initial mean and covariance of the
    total state (default zero; set one system's mean with ``ec.propagator.impulse(v,
    system=key)``).  ``t0``: the time they hold at (default: the clock's reading now).
    ``record``: keep the event history (:meth:`trace`).

    Raises
    ------
    ConfigurationTypeError
        *clock* is neither a callable nor an object with a ``now`` attribute, or its reading
        is not a number; *model* is not an :class:`~netcosim.lq.systems.Interconnection`.
    ConfigurationError
        The clock's reading is not finite; ``m0``, ``P0`` or ``t0`` is not valid for the
        model (as for :class:`~netcosim.lq.propagation.Propagator`).

    Examples
    --------
    A control task samples an integrator ``dx = u dt + dv`` (noise intensity 1, cost rate
    ``x^2``) every h = 0.1 s and applies the deadbeat gain ``u = -x / h`` at once.  From
    rest the first period costs only the noise, ``h^2 / 2``, every later one
    ``5 h^2 / 6`` (see :class:`~netcosim.lq.result.StationaryCost`), so 1 s (10 periods)
    costs ``h^2 (10 * 5/6 - 1/3) = 0.08``:

    >>> import numpy as np
    >>> from netcosim import Simulation, lq
    >>> h = 0.1
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...              inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    >>> sim = Simulation(seed=0)
    >>> ec = lq.ExpectedCost(sim, loop)
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=h, priority=1)
    ... def control(ctx):
    ...     ec.execute("sampler", "ctrl")      # sample and actuate at the job's start
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=1.0)
    >>> round(ec.cost_until(1.0), 9), round(h ** 2 * (10 * 5 / 6 - 1 / 3), 9)
    (0.08, 0.08)
    >>> trace = ec.trace()
    >>> trace.time[[event == "update ctrl" for event in trace.event]].round(6).tolist()
    [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]
    """

    def __init__(self, clock: Any, model: Interconnection, *, m0: Any = None, P0: Any = None,
                 t0: float | None = None, record: bool = True):
        if callable(clock):
            self._clock: Callable[[], float] = clock
        elif hasattr(clock, "now"):
            self._clock = lambda: clock.now
        else:
            raise ConfigurationTypeError(f"ExpectedCost: clock must be a simulation (with a now attribute, s) "
                                         f"or a callable returning the time in seconds, got {clock!r}")
        start = self._read() if t0 is None else t0
        self.propagator = Propagator(model, m0=m0, P0=P0, t0=start, record=record)
        self.propagator._cache = _shared_cache(self.propagator)     # one per model, across runs
        self.model = model

    def _read(self) -> float:
        t = self._clock()
        try:
            t = float(t)
        except (TypeError, ValueError):
            raise ConfigurationTypeError(f"ExpectedCost: the clock returned {t!r}, not a time in seconds") from None
        if not math.isfinite(t):
            raise ConfigurationError(f"ExpectedCost: the clock returned {t!r}, not a finite time in seconds")
        return t

    def _advance(self, t: float, what: str) -> None:
        p = self.propagator
        if t < p.time:
            raise ConfigurationError(f"ExpectedCost.{what}: time went backwards, from {p.time!r} s to {t!r} s "
                                     f"(an ExpectedCost reused in another simulation? make one per run)")
        if t > p.time:
            p.pass_time(round((t - p.time) / GRAIN) * GRAIN)
            p.time = t

    @property
    def time(self) -> float:
        """The instant (s) of the last event."""
        return self.propagator.time

    def execute(self, *keys: Hashable) -> "ExpectedCost":
        """Advance to the clock's present instant and execute the discrete systems *keys*
        there, in order (each must be a discrete system of the model); returns self."""
        if not keys:
            raise ConfigurationError("ExpectedCost.execute: name at least one discrete system to execute")
        self._advance(self._read(), "execute")
        for k in keys:
            self.model.update_of(k)         # a clear error for an unknown key, before any update
        for k in keys:
            self.propagator.update(k)
        return self

    def reset(self, key: Hashable, A: Any, B: Any = None, inputs: tuple = (), R: Any = None) -> "ExpectedCost":
        """Advance to now and jump system *key*'s entries, ``x+ = A x + B u + e`` (e.g.
        ``reset("act", 0)``: an actuator that outputs zero, "zero on loss"): *A* on the
        system's entries, *B* on u, the stacked outputs of the systems *inputs*, and *R*
        the covariance of e (None: no noise), as
        :meth:`Interconnection.reset_map <netcosim.lq.systems.Interconnection.reset_map>`."""
        self._advance(self._read(), "reset")
        self.propagator.reset(key, A, B, inputs, R)
        return self

    def advance(self) -> "ExpectedCost":
        """Let time pass to the clock's present instant (no system executes)."""
        self._advance(self._read(), "advance")
        return self

    @property
    def cost(self) -> float:
        """The expected cost accumulated up to the last event (units of Q_c times seconds)."""
        return self.propagator.cost

    def cost_until(self, t: float) -> float:
        """Advance to *t* (s; e.g. the end of the run) and return the expected cost from the
        start to *t*."""
        try:
            t = float(t)
        except (TypeError, ValueError):
            raise ConfigurationTypeError(f"ExpectedCost.cost_until: t must be a time in seconds, got {t!r}") from None
        if not math.isfinite(t):
            raise ConfigurationError(f"ExpectedCost.cost_until: t must be finite, got {t!r}")
        self._advance(t, "cost_until")
        return self.propagator.cost

    @property
    def cost_rate(self) -> float:
        """dJ/dt at the last event (cost per second)."""
        return self.propagator.cost_rate

    def trace(self) -> CostTrace:
        """The history of events: time, cost, cost rate, event name."""
        return self.propagator.trace()
