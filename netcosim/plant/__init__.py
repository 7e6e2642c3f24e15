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
:class:`ExactZOH` for linear time-invariant plants, :class:`NoisyZOH` for linear plants
with white process noise and their exact quadratic cost) all stop exactly at I/O instants,
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

One module per concept:

* :mod:`~netcosim.plant.system` -- the model: :class:`ContinuousSystem`, :class:`HybridEvent`;
* :mod:`~netcosim.plant.integrator` -- the protocol of an integrator (``integrate``,
  ``bind(plant) -> stepper``); one module per integrator: :mod:`~netcosim.plant.rk4`,
  :mod:`~netcosim.plant.solve_ivp`, :mod:`~netcosim.plant.exact_zoh`;
* :mod:`~netcosim.plant.events` -- guards and the location of their crossings;
* :mod:`~netcosim.plant.ports` -- :class:`InputPort`, :class:`OutputPort`;
* :mod:`~netcosim.plant.instance` -- the runtime: :class:`PlantInstance` (advance,
  events, logging grid, failures);
* :mod:`~netcosim.plant.values` -- checks on the numbers the user's functions return;
* :mod:`~netcosim.plant.pycontrol` -- python-control systems as plants.
"""

from ..errors import IntegrationError, NotConnectedError
from .events import EVENT_REARM
from .exact_zoh import SHARED_TRANSITIONS_SIZE, ExactZOH
from .instance import DEFAULT_LOG_INTERVAL, PlantInstance, default_log_interval
from .integrator import Integrator, Stepper
from .noisy_zoh import NoisyZOH
from .ports import InputPort, OutputPort, UnknownPortError
from .pycontrol import LinearPlant, NonlinearPlant, from_control, is_control_system
from .rk4 import RK4
from .solve_ivp import IMPLICIT_METHODS, RTOL_MIN, SOLVE_IVP_METHODS, SolveIVP
from .system import MAX_DIMENSION, ContinuousSystem, HybridEvent

__all__ = ["EVENT_REARM", "DEFAULT_LOG_INTERVAL", "default_log_interval", "HybridEvent", "ContinuousSystem",
           "MAX_DIMENSION", "RK4", "SolveIVP", "ExactZOH", "NoisyZOH",
           "SOLVE_IVP_METHODS", "IMPLICIT_METHODS", "RTOL_MIN",
           "SHARED_TRANSITIONS_SIZE", "Integrator", "Stepper", "OutputPort", "InputPort", "UnknownPortError",
           "PlantInstance", "NotConnectedError", "IntegrationError",
           "from_control", "is_control_system", "LinearPlant", "NonlinearPlant"]
