"""Co-simulation FMUs (FMI 2.0 and 3.0) as plants that advance by ``doStep``.

A co-simulation FMU carries its own solver: netcosim does not integrate it, it asks it
to step.  :class:`CoSimulationFMU` is a :class:`~netcosim.plant.ContinuousSystem` whose
state is the vector of the FMU's outputs at its last communication point, and whose own
stepper (:class:`DoStepper`, the plant's default integrator) calls ``doStep`` from the
FMU's time to exactly the instant the plant is advanced to: a task's read or write, a
logging instant, the end of a run.  No communication step is imposed, except

* ``min_step`` (s): an advance shorter than it does not step the FMU; the outputs stay
  those of the last communication point and the FMU catches up at the next advance of at
  least ``min_step``.  Default: the FMU's ``fixedInternalStepSize`` (FMI 3) if it
  declares one, else 0 (every advance steps);
* a rejected step (FMI 2 ``fmi2Discard``, FMI 3 ``fmi3Discard``): when the FMU can get
  and set its state, the state saved before the step is restored and the step retried
  with half the size (down to :data:`MIN_RETRY_STEP`), until the target is reached;
  without that capability a rejected step is an :class:`~netcosim.errors.FMUError`;
* a partial step (FMI 2 ``fmi2Discard`` with ``lastSuccessfulTime`` after the start,
  FMI 3 ``earlyReturn``): the FMU's time is the last successful time and the stepper
  steps on from there.

The inputs are set before every ``doStep`` to the values the plant holds (zero-order hold
between writes, as for every plant); outputs read at the FMU's current instant are read
from it after setting the inputs (direct feedthrough is seen at once).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, FMUError
from ..plant.system import ContinuousSystem
from .description import FMUFile, Variable
from .model_exchange import _check_names

__all__ = ["CoSimulationFMU", "DoStepper", "MIN_RETRY_STEP"]

#: the smallest step (s) a rejected step is retried with before the rejection is an error
MIN_RETRY_STEP = 1e-12

_DISCARD = 2


class CoSimulationFMU(ContinuousSystem):
    """The co-simulation interface of the FMU at *path* (FMI 2.0 or 3.0) as a plant model.

    *inputs*, *outputs*, *parameters*, *start_time*, *tolerance* and *name* as for
    :class:`~netcosim.fmi.ModelExchangeFMU`; *min_step* (s) see the module's text.  The
    state names are the output names (the state is the outputs at the FMU's last
    communication point); ``x0`` the outputs after initialisation; ``signals``,
    ``units`` and ``parameters`` as for model exchange.  ``steps`` counts the ``doStep``
    calls that succeeded, ``rejected`` those rejected and retried, ``partial`` those that
    ended early.

    Raises
    ------
    FMUError
        (:class:`~netcosim.errors.FMUError`) the file is not a usable FMU with a
        co-simulation interface (see :class:`~netcosim.fmi.description.FMUFile`); its
        binary cannot be loaded, instantiated or initialised.
    ConfigurationError
        *inputs*, *outputs* or *parameters* as for
        :class:`~netcosim.fmi.model_exchange.ModelExchangeFMU`; *min_step* is outside
        [0, 1e9] s.
    ConfigurationTypeError
        *min_step* is not a number.

    Examples
    --------
    The demo DC servo FMU (compiled with gcc by :func:`netcosim.fmi.demo.build_fmu`)
    stepped by its own solver (RK4 substeps of 1 ms) under 1 V for 0.1 s from rest:
    the angle is ``1000 (t - 1 + e^-t)`` rad:

    >>> import shutil, tempfile
    >>> import pytest
    >>> if shutil.which("gcc") is None:      # the demo FMUs are compiled on this machine
    ...     pytest.skip("building the demo FMU needs gcc")
    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.fmi import CoSimulationFMU
    >>> from netcosim.fmi.demo import build_fmu
    >>> tmp = tempfile.TemporaryDirectory()
    >>> servo = CoSimulationFMU(build_fmu("servo", 2, tmp.name))
    >>> servo.state_names, servo.x0.tolist()        # the state is the outputs
    (('y',), [0.0])
    >>> sim = Simulation()
    >>> plant = sim.plant(servo, servo.x0, log="none")
    >>> plant.input("u").write(1.0)
    >>> sim.run(until=0.1)
    >>> round(plant.output("y").read(), 6), round(1000 * (0.1 - 1 + math.exp(-0.1)), 6)
    (4.837418, 4.837418)
    >>> servo.steps, servo.rejected
    (1, 0)
    >>> tmp.cleanup()
    """

    def __init__(self, path: Any, *, inputs: Sequence[str] | None = None, outputs: Sequence[str] | None = None,
                 parameters: dict | None = None, start_time: float = 0.0, tolerance: float | None = None,
                 min_step: float | None = None, name: str | None = None):
        self.file = file = FMUFile(path, kind="co-simulation")
        md = file.model_description
        _check_names(inputs, "inputs")
        _check_names(outputs, "outputs")
        input_names = list(file.names("input") if inputs is None else inputs)
        output_names = list(file.names("output") if outputs is None else outputs)
        self._u_vr = file.real(input_names, "input")
        self._y_vr = file.real(output_names, "output")
        super().__init__(states=output_names, inputs=input_names, outputs=output_names, name=name or md.modelName)
        self.signals: dict[str, Variable] = file.signal_info(input_names + output_names)
        self.units = {n: v.unit for n, v in self.signals.items()}
        params = {n: v.start for n, v in file.variables.items() if v.causality == "parameter"}
        for key in (parameters or {}):
            file.variable(key, "parameter")
        params.update(parameters or {})
        self.parameters = params
        self.fmi_version = file.fmi_version
        if min_step is None:
            min_step = float(getattr(file.interface, "fixedInternalStepSize", None) or 0.0)
        self.min_step = validate.real(min_step, f"{file.label}: min_step (s)", lo=0.0, hi=1e9,
                                      kind="a duration in [0, 1e9] s")
        self.can_restore = bool(getattr(file.interface, "canGetAndSetFMUstate", False))
        self.steps = self.rejected = self.partial = 0
        self._initialise(parameters or {}, float(start_time), tolerance)
        self.default_integrator = DoStepper(self)

    def _initialise(self, values: dict, t0: float, tolerance: float | None) -> None:
        file = self.file
        if self.fmi_version == 2:
            fmu = self._fmu = file.instantiate(self.name, "FMU2Slave")
            file.call("fmi2SetupExperiment", fmu.setupExperiment, tolerance, t0, t=t0)
            file.set_values(values)
            file.call("fmi2EnterInitializationMode", fmu.enterInitializationMode, t=t0)
            file.call("fmi2ExitInitializationMode", fmu.exitInitializationMode, t=t0)
            self._get, self._set = fmu.getReal, fmu.setReal
        else:
            fmu = self._fmu = file.instantiate(self.name, "FMU3Slave", earlyReturnAllowed=True)
            file.set_values(values)
            file.call("fmi3EnterInitializationMode", fmu.enterInitializationMode, tolerance, t0, t=t0)
            file.call("fmi3ExitInitializationMode", fmu.exitInitializationMode, t=t0)
            self._get, self._set = fmu.getFloat64, fmu.setFloat64
        self.time = t0
        self.x0 = self._outputs(t0)

    # The FMU's side --------------------------------------------------------------
    def _outputs(self, t: float) -> np.ndarray:
        if not self._y_vr:
            return np.zeros(0)
        return np.array(self.file.call("reading outputs", self._get, self._y_vr, t=t, names=self.output_names),
                        dtype=float)

    def _inputs(self, t: float, u) -> None:
        if self._u_vr:
            self.file.call("setting inputs", self._set, self._u_vr, [float(v) for v in u[:len(self._u_vr)]],
                           t=t, names=self.input_names)

    def f(self, t, x, u, params):
        raise ConfigurationError(f"plant {self.name!r}: a co-simulation FMU advances by doStep, not by an "
                                 f"integrator: create the plant without integrator= (its own stepper is used)")

    def h(self, t, x, u, params):
        if t == self.time:      # the FMU is at this instant: outputs after the held inputs
            self._inputs(t, u)
            return self._outputs(t)
        return np.asarray(x, dtype=float)

    def step_to(self, target: float, u) -> np.ndarray:
        """Step the FMU from its time to *target* (s) with inputs *u* held; the outputs there.

        An advance shorter than ``min_step`` leaves the FMU where it is (outputs held)."""
        t = self.time
        if target - t < self.min_step or target <= t:
            return self._outputs(t)
        self._inputs(t, u)
        h = target - t
        while t < target:
            h = min(h, target - t)
            state = self._save(t) if self.can_restore else None
            try:
                reached, rejected = self._do_step(t, h)
                if rejected:
                    self.rejected += 1
                    if state is None:
                        raise FMUError(f"{self.file.label}: doStep from t={t!r} s by {h!r} s was rejected and the "
                                       f"FMU cannot restore its state to retry (canGetAndSetFMUstate is false)")
                    self.file.call("setFMUstate", self._restore, state, t=t)
                    # FMI 2: computed up to lastSuccessfulTime: retry to there, else with half the step
                    h = reached - t if reached > t else h / 2
                    if h < MIN_RETRY_STEP:
                        raise FMUError(f"{self.file.label}: doStep from t={t!r} s rejected down to steps of "
                                       f"{h!r} s")
                    continue
            finally:
                if state is not None:
                    self._free(state)
            self.steps += 1
            if reached < t + h:
                self.partial += 1
            t = self.time = reached
        return self._outputs(t)

    def _do_step(self, t: float, h: float) -> tuple[float, bool]:
        """One doStep from *t* by *h* (s): ``(the time the FMU reached, rejected)``."""
        fmu, file = self._fmu, self.file
        try:
            if self.fmi_version == 2:
                fmu.doStep(t, h)
                return t + h, False
            _event, terminate, early, last = fmu.doStep(t, h)
            if terminate:
                raise FMUError(f"{file.label}: the FMU asked to terminate the simulation at t={last!r} s")
            return (float(last) if early else t + h), False
        except FMUError:
            raise
        except Exception as exc:
            if getattr(exc, "status", None) == _DISCARD:
                if self.fmi_version == 2:
                    return float(file.call("fmi2GetRealStatus", fmu.getRealStatus, 2, t=t)), True
                return t, True
            raise FMUError(f"{file.label}: doStep from t={t!r} s by {h!r} s failed (inputs "
                           f"{list(self.input_names)}, outputs {list(self.output_names)}): {exc}") from None

    def _save(self, t):
        get = self._fmu.getFMUstate if self.fmi_version == 2 else self._fmu.getFMUState
        return self.file.call("getFMUstate", get, t=t)

    def _restore(self, state):
        (self._fmu.setFMUstate if self.fmi_version == 2 else self._fmu.setFMUState)(state)

    def _free(self, state):
        (self._fmu.freeFMUstate if self.fmi_version == 2 else self._fmu.freeFMUState)(state)

    def __repr__(self) -> str:
        return (f"CoSimulationFMU({str(self.file.path)!r}, FMI {self.fmi_version}, inputs={list(self.input_names)}, "
                f"outputs={list(self.output_names)})")


class DoStepper:
    """The integrator of a :class:`CoSimulationFMU` plant: ``doStep`` to the exact instants
    the plant is advanced to (the plant's default; bound to it when the plant is created).
    ``system``: the :class:`CoSimulationFMU` it steps.

    Examples
    --------
    A controller task reads the demo DC servo FMU (compiled with gcc by
    :func:`netcosim.fmi.demo.build_fmu`) every 10 ms and writes 1 V 2 ms into each job:
    the FMU steps from one read or write to the next (19 ``doStep`` calls up to the last
    write at 92 ms, one more to the end of the run at 0.1 s), and each read sees the
    step response ``s(t) = 1000 (t - 1 + e^-t)`` delayed by the first write, 2 ms:

    >>> import shutil, tempfile
    >>> import pytest
    >>> if shutil.which("gcc") is None:      # the demo FMUs are compiled on this machine
    ...     pytest.skip("building the demo FMU needs gcc")
    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.fmi import CoSimulationFMU
    >>> from netcosim.fmi.demo import build_fmu
    >>> tmp = tempfile.TemporaryDirectory()
    >>> servo = CoSimulationFMU(build_fmu("servo", 2, tmp.name))
    >>> sim = Simulation()
    >>> plant = sim.plant(servo, servo.x0, log="none")
    >>> type(plant.integrator).__name__
    'DoStepper'
    >>> reads = []
    >>> @sim.node("cpu").periodic(period=0.01, priority=1, name="ctl")
    ... def ctl(ctx):
    ...     reads.append(plant.output("y").read())
    ...     yield ctx.execute(0.002)
    ...     plant.input("u").write(1.0)
    >>> sim.run(until=0.1)
    >>> servo.steps
    20
    >>> round(reads[-1], 6), round(1000 * (0.088 - 1 + math.exp(-0.088)), 6)
    (3.760877, 3.760877)
    >>> tmp.cleanup()
    """

    reports_dense = True

    def __init__(self, system: CoSimulationFMU):
        self.system = system
        self.plant: Any = None

    def bind(self, plant) -> "DoStepper":
        """This stepper, bound to *plant* (one plant per FMU)."""
        if self.plant is not None and self.plant is not plant:
            raise ConfigurationError(f"{self.system.file.label}: one co-simulation FMU object drives one plant; "
                                     f"it already drives {self.plant.name!r}")
        self.plant = plant
        return self

    def integrate(self, rhs, t0, x0, t1, gs, dense=None):
        """Step the FMU from *t0* to *t1* (s) (through the instants of *dense*, reported) with the
        plant's held input; no guards.  The integrator interface's *rhs* and *gs* are
        ignored (the FMU has its own dynamics, guards are not supported) and *x0* gives the
        state's size only; *t0* must be the FMU's own time (it cannot go back)."""
        fmu = self.system
        if t0 != fmu.time and not (t0 > fmu.time and t0 - fmu.time < fmu.min_step):
            raise FMUError(f"{fmu.file.label}: asked to advance from t={t0!r} s but the FMU is at "
                           f"t={fmu.time!r} s (a co-simulation FMU cannot go back in time)")
        u = self.plant.u
        if dense is not None:
            times, report = dense
            times = times[(times > t0) & (times < t1)]
            if times.size:
                xs = np.column_stack([fmu.step_to(float(tk), u) for tk in times.tolist()])
                report(times, xs.reshape(len(x0), times.size))
        return t1, fmu.step_to(t1, u), None
