"""Plant models: :class:`ContinuousSystem` (dynamics, outputs, names) and :class:`HybridEvent`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError

__all__ = ["HybridEvent", "MAX_DIMENSION", "ContinuousSystem"]


@dataclass(frozen=True)
class HybridEvent:
    """A zero crossing ``g(t, x, u, params) = 0`` of a plant, called *name* in the trace.

    ``direction``: +1 fires on rising crossings (g goes from < 0 to >= 0), -1 on
    falling ones, 0 on both.  ``reset(t, x, u, params) -> x_new`` (optional) replaces
    the state at the crossing; without it the event only restarts the integrator there
    (use it at the edges of piecewise-defined dynamics, e.g. ground contact).

    Raises
    ------
    ConfigurationTypeError
        *name* is not a non-empty string, *g* is not callable, or *reset* is neither
        None nor callable.
    ConfigurationError
        *direction* is not -1, 0 or +1.

    Examples
    --------
    A ball dropped from 1 m (``h`` in m, ``v`` in m/s) hits the ground, falling, at
    ``sqrt(2 h0 / g)`` s; the reset bounces it back with 80 % of its speed:

    >>> import math
    >>> import numpy as np
    >>> from netcosim import Simulation
    >>> from netcosim.plant import ContinuousSystem, HybridEvent
    >>> ground = HybridEvent("ground", lambda t, x, u, p: x[0], direction=-1,
    ...                      reset=lambda t, x, u, p: np.array([0.0, -0.8 * x[1]]))
    >>> ball = ContinuousSystem(f=lambda t, x, u, p: np.array([x[1], -9.81]),
    ...                         states=["h", "v"], events=[ground], name="ball")
    >>> sim = Simulation()
    >>> plant = sim.plant(ball, [1.0, 0.0])
    >>> sim.run(until=0.5)
    >>> [(round(float(t), 6), name) for t, name in plant.event_log]
    [(0.451524, 'ground')]
    >>> round(math.sqrt(2 * 1.0 / 9.81), 6)
    0.451524
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

    ``disturbances`` (a count or names) are extra inputs set by the plant's disturbance
    function, not by tasks; ``name`` is the default name of its instances.
    ``h`` must return ``ny`` finite values.  A subclass may also define
    ``jac(t, x, u, params) -> d f / d x`` (an ``nx`` × ``nx`` array); the implicit
    methods of :class:`~netcosim.plant.solve_ivp.SolveIVP` (Radau, BDF, LSODA) then use
    it instead of finite differences.

    Raises
    ------
    ConfigurationTypeError
        *f* or *h* is not callable; *states*, *inputs*, *outputs* or *disturbances* is
        neither a count nor a sequence of names (e.g. a string, a bool, a float);
        *events* is not a sequence of :class:`HybridEvent`.
    ConfigurationError
        a count is negative or above :data:`MAX_DIMENSION`, or a name repeats.

    Examples
    --------
    A first-order lag ``dx/dt = -x + u`` (time constant 1 s) from callables; held at
    ``u = 1`` from rest, it reaches ``1 - e^-1`` after 1 s:

    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.plant import ContinuousSystem
    >>> lag = ContinuousSystem(f=lambda t, x, u, p: -x + u, states=["x"], inputs=["u"], name="lag")
    >>> lag.nx, lag.nu, lag.output_names       # without h, the output is the state
    (1, 1, ('x',))
    >>> sim = Simulation()
    >>> plant = sim.plant(lag, [0.0])
    >>> plant.input("u").write(1.0)
    >>> sim.run(until=1.0)
    >>> round(plant.output("x").read(), 6), round(1 - math.exp(-1), 6)
    (0.632121, 0.632121)
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
        """State derivative ``dx/dt`` at time *t* (s), state *x*, input *u* (controls then
        disturbances), *params*.

        Uses the ``f`` given to the constructor (or a subclass override); raises
        :class:`NotImplementedError` when there is none.
        """
        fn = getattr(self, "_f", None)
        if fn is None:
            raise NotImplementedError(f"{type(self).__name__} defines no dynamics f(t, x, u, params)")
        return fn(t, x, u, params)

    def h(self, t: float, x: np.ndarray, u: np.ndarray, params: Any) -> np.ndarray:
        """Output ``y`` at time *t* (s), state *x*, input *u*, *params*; the state itself when no ``h``
        was given."""
        fn = getattr(self, "_h", None)
        if fn is None:
            return x
        return fn(t, x, u, params)


# ---------------------------------------------------------------------------


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
