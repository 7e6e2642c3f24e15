"""Model-exchange FMUs (FMI 2.0 and 3.0) as ordinary continuous plants.

:class:`ModelExchangeFMU` is a :class:`~netcosim.plant.ContinuousSystem` whose ``f`` and
``h`` are the FMU's own equations: the project's integrators (SolveIVP, RK4) integrate the
derivatives the FMU returns, exactly as they integrate a Python plant, and stop at the I/O
instants of the kernel.  How the FMI calls map onto a plant:

* ``f(t, x, u)``: ``SetTime(t)``, ``SetContinuousStates(x)``, ``Set{Real,Float64}(inputs, u)``,
  ``Get{Derivatives,ContinuousStateDerivatives}``.  The inputs are those the plant holds
  (zero-order hold between the tasks' writes).
* ``h(t, x, u)``: the same settings, then ``Get{Real,Float64}(outputs)``: outputs are read
  at the exact instant a task reads the plant.
* every event indicator ``z_i`` is a :class:`~netcosim.plant.HybridEvent` firing on a sign
  change (either direction); a time event (``nextEventTime`` of the last event iteration)
  is the event ``"time_event"`` (``g = t - nextEventTime``).  At an event the FMU enters
  event mode at the located instant and iterates ``NewDiscreteStates`` /
  ``UpdateDiscreteStates`` until it needs no more (at most :data:`MAX_EVENT_ITERATIONS`),
  then returns to continuous-time mode; its continuous states, re-initialised or not, are
  the plant's state after the event.
* ``CompletedIntegratorStep`` is not called: the integrators restart from the state the
  plant holds, so an FMU that needs it for step events (dynamic state selection) is not
  supported.

One FMU instance lives in one :class:`ModelExchangeFMU`: give each plant its own object.
"""

from __future__ import annotations

import ctypes
from typing import Any, Sequence

import numpy as np

from ..errors import ConfigurationError, FMUError
from ..plant.system import ContinuousSystem, HybridEvent
from .description import FMUFile, Variable

__all__ = ["ModelExchangeFMU", "MAX_EVENT_ITERATIONS"]

#: event iterations (NewDiscreteStates / UpdateDiscreteStates calls) allowed at one instant
MAX_EVENT_ITERATIONS = 1000

_DOUBLE_P = ctypes.POINTER(ctypes.c_double)


class ModelExchangeFMU(ContinuousSystem):
    """The model-exchange interface of the FMU at *path* (FMI 2.0 or 3.0) as a plant model.

    Parameters
    ----------
    path: the ``.fmu`` file.
    inputs, outputs: FMI names of the real variables the plant's inputs and outputs are
        (default: every variable of causality ``input``, resp. ``output``, in the
        description's order).  Their order is the order of ``u`` and ``y``.
    parameters: ``{FMI name: value}`` set before initialisation (parameters, start values
        of inputs or states): a sweep builds one object per run with its own values.
    start_time: the time (s) the FMU is initialised at (the plant's creation time).
    tolerance: the relative tolerance passed to the FMU's initialisation (None: not given).
    name: the plant's name (default: the FMU's model name).

    ``x0`` is the state after initialisation (pass it to :meth:`Simulation.plant
    <netcosim.sim.Simulation.plant>`); ``signals`` maps every state, input and output name
    to its :class:`~netcosim.fmi.description.Variable` (unit, start value, description);
    ``units`` maps them to their units; ``parameters`` holds the values of the FMU's
    parameters (their start values, overridden by *parameters*).

    Raises
    ------
    FMUError
        (:class:`~netcosim.errors.FMUError`) the file is not a usable FMU with a model
        exchange interface (see :class:`~netcosim.fmi.description.FMUFile`); a
        derivative of its ``ModelStructure`` names no state; its binary cannot be loaded
        for this platform, or instantiating or initialising it fails (e.g. a GUID that
        is not the binary's), or it asks to terminate at initialisation.
    ConfigurationError
        *inputs* or *outputs* is a string, or names a variable the FMU does not have or
        one that is not real (Real/Float64), or a name twice; *parameters* names an
        unknown variable, one that cannot be set, or gives a value that is not a finite
        number.

    Examples
    --------
    The demo DC servo ``k / (s (s + a))`` FMU (FMI 2.0, compiled with gcc by
    :func:`netcosim.fmi.demo.build_fmu`) integrated by netcosim's default integrator
    under 1 V for 0.1 s from rest: the angle is ``1000 (t - 1 + e^-t)`` rad; with
    ``k = 500`` given as a parameter it is half that:

    >>> import shutil, tempfile
    >>> import pytest
    >>> if shutil.which("gcc") is None:      # the demo FMUs are compiled on this machine
    ...     pytest.skip("building the demo FMU needs gcc")
    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.fmi import ModelExchangeFMU
    >>> from netcosim.fmi.demo import build_fmu
    >>> tmp = tempfile.TemporaryDirectory()
    >>> path = build_fmu("servo", 2, tmp.name)
    >>> servo = ModelExchangeFMU(path)
    >>> servo.state_names, servo.input_names, servo.output_names, servo.units["u"]
    (('angle', 'velocity'), ('u',), ('y',), 'V')
    >>> half = ModelExchangeFMU(path, parameters={"k": 500.0}, name="half")
    >>> sim = Simulation()
    >>> plants = [sim.plant(system, system.x0) for system in (servo, half)]
    >>> for plant in plants:
    ...     plant.input("u").write(1.0)
    >>> sim.run(until=0.1)
    >>> [round(plant.output("y").read(), 6) for plant in plants]
    [4.837418, 2.418709]
    >>> round(1000 * (0.1 - 1 + math.exp(-0.1)), 6)
    4.837418
    >>> tmp.cleanup()
    """

    def __init__(self, path: Any, *, inputs: Sequence[str] | None = None, outputs: Sequence[str] | None = None,
                 parameters: dict | None = None, start_time: float = 0.0, tolerance: float | None = None,
                 name: str | None = None):
        self.file = file = FMUFile(path, kind="model exchange")
        md = file.model_description
        states = [d.variable.derivative for d in md.derivatives]
        if any(s is None for s in states):
            raise FMUError(f"{file.label}: a derivative in ModelStructure names no state")
        state_names = [s.name for s in states]
        _check_names(inputs, "inputs")
        _check_names(outputs, "outputs")
        input_names = list(file.names("input") if inputs is None else inputs)
        output_names = list(file.names("output") if outputs is None else outputs)
        self._u_vr = (ctypes.c_uint * len(input_names))(*file.real(input_names, "input"))
        y_vr = file.real(output_names, "output")
        self._y_vr = (ctypes.c_uint * len(y_vr))(*y_vr)
        super().__init__(states=state_names, inputs=input_names, outputs=output_names,
                         name=name or md.modelName)
        self.signals: dict[str, Variable] = file.signal_info(state_names + input_names + output_names)
        self.units = {n: v.unit for n, v in self.signals.items()}
        params = {n: v.start for n, v in file.variables.items() if v.causality == "parameter"}
        for key in (parameters or {}):
            file.variable(key, "parameter")
        params.update(parameters or {})
        self.parameters = params
        self._nx, self._nz = len(state_names), int(md.numberOfEventIndicators or 0)
        self._ny = len(output_names)
        self.fmi_version = file.fmi_version
        self._x = np.zeros(self._nx)
        self._dx = np.zeros(self._nx)
        self._z = np.zeros(self._nz)
        self._y = (ctypes.c_double * self._ny)()
        self.next_event_time: float | None = None
        self._initialise(parameters or {}, start_time, tolerance)
        events = [HybridEvent(self._indicator_name(i), (lambda t, x, u, p, i=i: self._indicator(t, x, u, i)),
                              0, self._event) for i in range(self._nz)]
        if self._nz or self.next_event_time is not None:
            events.append(HybridEvent("time_event", self._time_guard, 1, self._event))
        self.events = tuple(events)

    # Initialisation ----------------------------------------------------------------
    def _initialise(self, values: dict, t0: float, tolerance: float | None) -> None:
        file = self.file
        cls = "FMU2Model" if self.fmi_version == 2 else "FMU3Model"
        fmu = self._fmu = file.instantiate(self.name, cls)
        c = fmu.component
        if self.fmi_version == 2:
            file.call("fmi2SetupExperiment", fmu.setupExperiment, tolerance, t0, t=t0)
            file.set_values(values)
            file.call("fmi2EnterInitializationMode", fmu.enterInitializationMode, t=t0)
            file.call("fmi2ExitInitializationMode", fmu.exitInitializationMode, t=t0)
            self._get_x = lambda p: fmu.fmi2GetContinuousStates(c, p, self._nx)  # noqa: E731
            self._get_y = lambda: fmu.fmi2GetReal(c, self._y_vr, self._ny, self._y)  # noqa: E731
        else:
            file.set_values(values)
            file.call("fmi3EnterInitializationMode", fmu.enterInitializationMode, tolerance, t0, t=t0)
            file.call("fmi3ExitInitializationMode", fmu.exitInitializationMode, t=t0)
            self._get_x = lambda p: fmu.fmi3GetContinuousStates(c, p, self._nx)  # noqa: E731
            self._get_y = lambda: fmu.fmi3GetFloat64(c, self._y_vr, self._ny, self._y, self._ny)  # noqa: E731
        self._bind_hot_path(fmu)
        self._iterate(t0)
        file.call("EnterContinuousTimeMode", fmu.enterContinuousTimeMode, t=t0)
        file.call("GetContinuousStates", self._get_x, self._x.ctypes.data_as(_DOUBLE_P), t=t0)
        self.x0 = self._x.copy()
        self._get_y()  # outputs computable after initialisation (raises on an error status)

    def _bind_hot_path(self, fmu) -> None:
        """The FMI functions every evaluation calls, taken as FMPy's ctypes functions (their
        argument types set) and called with preallocated buffers; their status is checked
        here (> fmiWarning is an error) instead of in FMPy's wrapper, which costs as much
        as the call itself.  Falls back to FMPy's wrappers if it keeps them elsewhere."""
        v = self.fmi_version
        raw = getattr(fmu, "_functions", None) or {}

        def get(name):
            fn = raw.get(name)
            if fn is None:      # pragma: no cover - FMPy versions that keep them elsewhere
                wrapped = getattr(fmu, name)
                return lambda *a: (wrapped(*a), 0)[1]
            return fn
        self._c = fmu.component
        self._f_time = get(f"fmi{v}SetTime")
        self._f_set_x = get(f"fmi{v}SetContinuousStates")
        self._f_get_dx = get("fmi2GetDerivatives" if v == 2 else "fmi3GetContinuousStateDerivatives")
        self._f_get_z = get(f"fmi{v}GetEventIndicators")
        self._f_set_u = get("fmi2SetReal" if v == 2 else "fmi3SetFloat64")
        self._f_get_y = get("fmi2GetReal" if v == 2 else "fmi3GetFloat64")
        self._xbuf = np.zeros(self._nx)
        self._xptr = self._xbuf.ctypes.data_as(_DOUBLE_P)
        self._dxptr = self._dx.ctypes.data_as(_DOUBLE_P)
        self._zptr = self._z.ctypes.data_as(_DOUBLE_P)
        self._n_u = len(self._u_vr)
        self._u_np = np.zeros(self._n_u)
        self._uptr = self._u_np.ctypes.data_as(_DOUBLE_P)
        self._extra = (self._n_u,) if v == 3 else ()
        self._extra_y = (self._ny,) if v == 3 else ()

    def _iterate(self, t: float) -> None:
        """Event iteration at *t* (s): discrete-state updates until the FMU needs none."""
        fmu, file = self._fmu, self.file
        update = fmu.newDiscreteStates if self.fmi_version == 2 else fmu.updateDiscreteStates
        for _ in range(MAX_EVENT_ITERATIONS):
            need, terminate, _nominals, _values, defined, t_next = file.call("event iteration", update, t=t)
            if terminate:
                raise FMUError(f"{file.label}: the FMU asked to terminate the simulation at t={t!r} s")
            if not need:
                self.next_event_time = float(t_next) if defined else None
                return
        raise FMUError(f"{file.label}: event iteration did not converge in {MAX_EVENT_ITERATIONS} "
                       f"iterations at t={t!r} s")

    def _indicator_name(self, i: int) -> str:
        md = self.file.model_description
        ev = getattr(md, "eventIndicators", None) or []
        if i < len(ev) and getattr(ev[i], "variable", None) is not None:
            return f"z.{ev[i].variable.name}"
        return f"z{i}"

    # The model's equations -------------------------------------------------------
    def _set(self, t: float, x, u) -> None:
        """Time, continuous states and inputs of the FMU (an error status raises FMUError)."""
        c = self._c
        self._xbuf[:] = x
        status = self._f_time(c, t) | self._f_set_x(c, self._xptr, self._nx)
        if self._n_u:
            self._u_np[:] = u[:self._n_u]
            status |= self._f_set_u(c, self._u_vr, self._n_u, self._uptr, *self._extra)
        if status > 1:
            raise FMUError(f"{self.file.label}: setting time, states {list(self.state_names)} and inputs "
                           f"{list(self.input_names)} failed at t={t!r} s (status {status})")

    def f(self, t, x, u, params):
        self._set(t, x, u)
        status = self._f_get_dx(self._c, self._dxptr, self._nx)
        if status > 1:
            raise FMUError(f"{self.file.label}: getting the derivatives of {list(self.state_names)} failed at "
                           f"t={t!r} s: {_status_text(status)}")
        return self._dx.copy()

    def h(self, t, x, u, params):
        self._set(t, x, u)
        status = self._f_get_y(self._c, self._y_vr, self._ny, self._y, *self._extra_y)
        if status > 1:
            raise FMUError(f"{self.file.label}: reading outputs {list(self.output_names)} failed at t={t!r} s: "
                           f"{_status_text(status)}")
        return np.array(self._y, dtype=float)

    def _indicator(self, t, x, u, i: int) -> float:
        self._set(t, x, u)
        status = self._f_get_z(self._c, self._zptr, self._nz)
        if status > 1:
            raise FMUError(f"{self.file.label}: getting the event indicators failed at t={t!r} s: "
                           f"{_status_text(status)}")
        return float(self._z[i])

    def _time_guard(self, t, x, u, params) -> float:
        return -1.0 if self.next_event_time is None else t - self.next_event_time

    def _event(self, t, x, u, params):
        """An event at *t* (s): event mode, event iteration, back to continuous time; the
        continuous states after it (re-initialised or not)."""
        fmu, file = self._fmu, self.file
        self._set(t, x, u)
        file.call("EnterEventMode", fmu.enterEventMode, t=t)
        self._iterate(t)
        file.call("EnterContinuousTimeMode", fmu.enterContinuousTimeMode, t=t)
        out = np.zeros(self._nx)
        file.call("GetContinuousStates", self._get_x, out.ctypes.data_as(_DOUBLE_P), t=t)
        return out

    def __repr__(self) -> str:
        return (f"ModelExchangeFMU({str(self.file.path)!r}, FMI {self.fmi_version}, states={list(self.state_names)}, "
                f"inputs={list(self.input_names)}, outputs={list(self.output_names)})")


def _status_text(status: int) -> str:
    """An FMI status for messages: ``status 3 (error)``."""
    label = {2: "discard", 3: "error", 4: "fatal", 5: "pending"}.get(status, "illegal")
    return f"status {status} ({label})"


def _check_names(names, what) -> None:
    if isinstance(names, str):
        raise ConfigurationError(f"{what} must be a sequence of FMI names, got the string {names!r}")
