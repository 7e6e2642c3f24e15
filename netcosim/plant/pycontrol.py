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
    """True if *obj* is a python-control system (without importing python-control)."""
    return any(c.__module__.split(".")[0] == "control" for c in type(obj).__mro__)


class LinearPlant(ContinuousSystem):
    """``dx/dt = A x + B u``, ``y = C x + D u`` (a converted ``control.StateSpace``).

    ``A`` (nx×nx), ``B`` (nx×nu), ``C`` (ny×nx), ``D`` (ny×nu) are float arrays in the
    system's own units; :meth:`jac` returns ``A`` (used by the implicit methods of
    :class:`~netcosim.plant.SolveIVP`).  Being linear time-invariant, it can
    advance by the exact zero-order-hold step, ``integrator=ExactZOH()``
    (:class:`~netcosim.plant.ExactZOH`).
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
    copied to ``self.params``); ``name``: the plant's name."""

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

    Raises :class:`~netcosim.errors.ConfigurationError` for a discrete-time system and
    :class:`~netcosim.errors.ConfigurationTypeError` for a python-control object that is
    not a system (e.g. a frequency response).
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
