"""python-control systems as netcosim plants.

``Simulation.plant(system, x0)`` accepts, besides a
:class:`~netcosim.plant.ContinuousSystem`, the continuous-time systems of
`python-control <https://python-control.readthedocs.io>`_ (an optional dependency:
``pip install netcosim[control]``):

* ``control.StateSpace``: ``dx/dt = A x + B u``, ``y = C x + D u``;
* ``control.TransferFunction``: realised by ``control.ss(tf)`` (so the states are
  those of python-control's realisation), then as a state-space system;
* ``control.NonlinearIOSystem`` (and its subclasses, e.g. interconnections):
  ``dx/dt = sys.dynamics(t, x, u, params)``, ``y = sys.output(t, x, u, params)``.

The port names are python-control's labels (``state_labels``, ``input_labels``,
``output_labels``, e.g. ``'x[0]'``, ``'u[0]'``, ``'y[0]'``), so
``plant.output('y[0]')`` and ``plant.input('u[0]')`` work; the plant's default name
is the system's ``name``.  Parameters follow python-control: the system's ``params``
are the defaults and a ``params`` dict given to ``Simulation.plant`` updates them.
Discrete-time systems (``dt`` other than 0 or None) are refused: a netcosim plant is
continuous, and the discrete side belongs in a task.

This module imports ``control``; netcosim imports it only when it meets such a system.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigurationError, ConfigurationTypeError
from .system import ContinuousSystem

__all__ = ["is_control_system", "from_control", "LinearPlant", "NonlinearPlant"]


def is_control_system(obj: Any) -> bool:
    """True if *obj* is a python-control system (without importing python-control).

    Examples
    --------
    >>> import control
    >>> from netcosim.plant import is_control_system
    >>> from netcosim.plants.dc_servo import DCServo
    >>> is_control_system(control.tf([1000.0], [1.0, 1.0, 0.0])), is_control_system(DCServo())
    (True, False)
    """
    return any(c.__module__.split(".")[0] == "control" for c in type(obj).__mro__)


class LinearPlant(ContinuousSystem):
    """``dx/dt = A x + B u``, ``y = C x + D u`` (a converted ``control.StateSpace``).

    ``A`` (nx×nx), ``B`` (nx×nu), ``C`` (ny×nx), ``D`` (ny×nu) are float arrays in the
    system's own units; :meth:`jac` returns ``A`` (used by the implicit methods of
    :class:`~netcosim.plant.SolveIVP`).  Being linear time-invariant, it can
    advance by the exact zero-order-hold step, ``integrator=ExactZOH()``
    (:class:`~netcosim.plant.ExactZOH`).

    Examples
    --------
    The transfer function ``1 / (s + 1)`` converted, then stepped from rest: its output
    after 1 s is ``1 - e^-1``:

    >>> import math
    >>> import control
    >>> from netcosim import Simulation
    >>> from netcosim.plant import ExactZOH, from_control
    >>> lag = from_control(control.tf([1.0], [1.0, 1.0], name="lag"))
    >>> type(lag).__name__, lag.A.tolist(), lag.B.tolist(), lag.input_names, lag.output_names
    ('LinearPlant', [[-1.0]], [[1.0]], ('u[0]',), ('y[0]',))
    >>> sim = Simulation()
    >>> plant = sim.plant(lag, [0.0], integrator=ExactZOH())
    >>> plant.input("u[0]").write(1.0)
    >>> sim.run(until=1.0)
    >>> round(plant.output("y[0]").read(), 9), round(1 - math.exp(-1), 9)
    (0.632120559, 0.632120559)
    """

    def __init__(self, A, B, C, D, *, states, inputs, outputs, name):
        super().__init__(states=list(states), inputs=list(inputs), outputs=list(outputs), name=name)
        self.A, self.B, self.C, self.D = (np.array(M, dtype=float) for M in (A, B, C, D))

    def f(self, t, x, u, params):
        return self.A @ x + self.B @ u

    def h(self, t, x, u, params):
        return self.C @ x + self.D @ u

    def jac(self, t, x, u, params):
        """The Jacobian ``df/dx = A`` (constant: *t* in s, *x*, *u* and *params* are not used)."""
        return self.A


class NonlinearPlant(ContinuousSystem):
    """A converted ``control.NonlinearIOSystem``: f and h call the system's public
    ``dynamics(t, x, u, params)`` and ``output(t, x, u, params)``.  ``sys``: the
    continuous-time system (its labels name the states and ports, its ``params`` are
    copied to ``self.params``); ``name``: the plant's name.

    Examples
    --------
    ``dx/dt = -k x^3`` from ``x(0) = 1`` is ``x(t) = 1 / sqrt(1 + 2 k t)``: 0.5 at
    1.5 s for the default ``k = 1``, and ``params`` given to the plant override it:

    >>> import control
    >>> from netcosim import Simulation
    >>> cubic = control.nlsys(lambda t, x, u, params: -params["k"] * x**3, None, states=["x"], inputs=0,
    ...                       outputs=["x"], params={"k": 1.0}, name="cubic")
    >>> sim = Simulation()
    >>> plant = sim.plant(cubic, [1.0])
    >>> slow = sim.plant(cubic, [1.0], name="faster", params={"k": 4.0})
    >>> type(plant.system).__name__, plant.system.params
    ('NonlinearPlant', {'k': 1.0})
    >>> sim.run(until=1.5)
    >>> round(float(plant.state[0]), 6), round(float(slow.state[0]), 6), round(1 / (1 + 2 * 4.0 * 1.5) ** 0.5, 6)
    (0.5, 0.27735, 0.27735)
    """

    def __init__(self, sys, *, name):
        super().__init__(states=list(sys.state_labels), inputs=list(sys.input_labels),
                         outputs=list(sys.output_labels), name=name)
        self.iosys = sys
        self.params = dict(sys.params)

    def f(self, t, x, u, params):
        return self.iosys.dynamics(t, x, u, params)

    def h(self, t, x, u, params):
        return self.iosys.output(t, x, u, params)


def _check_continuous(sys, what: str) -> None:
    dt = sys.dt
    if dt is None or (not isinstance(dt, bool) and dt == 0):
        return
    raise ConfigurationError(
        f"{what} {sys.name!r} is discrete-time (dt={dt!r}); a netcosim plant must be continuous-time "
        f"(dt=0): implement the discrete part as a periodic task, or convert it with control.d2c")


def from_control(sys: Any) -> ContinuousSystem:
    """A :class:`~netcosim.plant.ContinuousSystem` equivalent to python-control *sys*.

    A ``TransferFunction`` or ``StateSpace`` becomes a :class:`LinearPlant`, a
    ``NonlinearIOSystem`` a :class:`NonlinearPlant`.

    Raises
    ------
    ConfigurationError
        *sys* is discrete-time (its ``dt`` is neither 0 nor None).
    ConfigurationTypeError
        *sys* is a python-control object that is not a system (e.g. a frequency
        response).

    Examples
    --------
    >>> import control
    >>> from netcosim.plant import from_control
    >>> servo = from_control(control.tf([1000.0], [1.0, 1.0, 0.0], name="servo"))
    >>> type(servo).__name__, servo.name, servo.nx, servo.input_names, servo.output_names
    ('LinearPlant', 'servo', 2, ('u[0]',), ('y[0]',))
    >>> from_control(control.tf([1.0], [1.0, -0.5], dt=0.1, name="filter"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
      ...
    netcosim.errors.ConfigurationError: transfer function 'filter' is discrete-time (dt=0.1); a netcosim plant ...
    """
    import control

    if isinstance(sys, control.TransferFunction):
        _check_continuous(sys, "transfer function")
        ss = control.ss(sys)
        return LinearPlant(ss.A, ss.B, ss.C, ss.D, states=ss.state_labels, inputs=sys.input_labels,
                           outputs=sys.output_labels, name=sys.name)
    if isinstance(sys, control.StateSpace):
        _check_continuous(sys, "state-space system")
        return LinearPlant(sys.A, sys.B, sys.C, sys.D, states=sys.state_labels, inputs=sys.input_labels,
                           outputs=sys.output_labels, name=sys.name)
    if isinstance(sys, control.NonlinearIOSystem):
        _check_continuous(sys, "nonlinear I/O system")
        return NonlinearPlant(sys, name=sys.name)
    raise ConfigurationTypeError(
        f"cannot use python-control object {sys!r} of type {type(sys).__name__} as a plant; "
        f"pass a StateSpace, TransferFunction or NonlinearIOSystem")
