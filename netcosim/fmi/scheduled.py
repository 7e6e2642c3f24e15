"""FMI 3.0 Scheduled Execution: an FMU's clocked model partitions as kernel tasks on a node.

In Scheduled Execution the importer decides when each model partition (the code behind
one input clock) runs, by calling ``fmi3ActivateModelPartition(clock, activationTime)``.
:class:`ScheduledExecutionFMU` lets netcosim's kernel be that scheduler: each periodic
input clock becomes a periodic task of a node, under the node's scheduling policy (fixed
priority, RM, DM, EDF, servers), with the usual schedule traces and plots.

The timing model (documented, and the one TrueTime uses for a task's I/O):

* the task of clock *c* is released every ``interval(c)`` s (the clock's constant
  ``intervalDecimal`` of modelDescription.xml), from its ``shiftDecimal`` (or 0) plus
  the given offset;
* each job asks the CPU for the execution time given for *c*: a number of seconds, a
  frozen ``scipy.stats`` distribution or a callable ``c(rng) -> s`` drawn from the task's
  stream (exactly as ``ctx.execute`` takes it), preempted as the policy says;
* when the job has received its execution time, the partition is activated with
  ``activationTime`` = the job's release time (the clock tick), so its outputs appear
  at the job's completion: the response time of the task is the latency the partition's
  computation adds;
* the default priorities are rate-monotonic (the shorter interval, the smaller, i.e.
  higher, priority); pass ``priority`` for others; ``deadline`` defaults to the interval.
"""

from __future__ import annotations

import zipfile
from typing import Any, Callable

from ..errors import ConfigurationError, FMUError
from .description import FMUFile

__all__ = ["ScheduledExecutionFMU", "Activation"]

#: one activation: (clock name, activation time (s), completion time (s))
Activation = tuple[str, float, float]


class ScheduledExecutionFMU:
    """The Scheduled Execution interface of the FMI 3.0 FMU at *path*.

    ``clocks`` maps each periodic input clock to its interval (s); ``shifts`` to its
    shift (s); ``activations`` lists every activation made, ``(clock, activation time,
    completion time)`` in s; :meth:`output` reads an output (or any Float64 variable).
    *parameters*: ``{FMI name: value}`` set before initialisation; *start_time* (s): the
    FMU's time at initialisation; *name*: the instance's name (default the model's).

    Raises
    ------
    FMUError
        (:class:`~netcosim.errors.FMUError`) the file is not a usable FMU with a
        Scheduled Execution interface (see
        :class:`~netcosim.fmi.description.FMUFile`); it has no input clock with a
        constant interval, or an input clock without one (``intervalDecimal``) or with
        an interval that is not > 0 s; its binary cannot be loaded, instantiated or
        initialised.
    ConfigurationError
        *parameters* names an unknown variable, one that cannot be set, or gives a
        value that is not a finite number.

    Examples
    --------
    The demo Scheduled Execution FMU (compiled with gcc by
    :func:`netcosim.fmi.demo.build_se_fmu`): clock ``fast`` every 5 ms, ``slow`` every
    8 ms, as rate-monotonic tasks of 1 ms and 2 ms on one CPU.  At t = 0 ``slow`` waits
    for ``fast``, so its partition completes at 3 ms; ``(clock, activation time,
    completion time)`` in s:

    >>> import shutil, tempfile
    >>> import pytest
    >>> if shutil.which("gcc") is None:      # the demo FMUs are compiled on this machine
    ...     pytest.skip("building the demo FMU needs gcc")
    >>> from netcosim import Simulation
    >>> from netcosim.fmi import ScheduledExecutionFMU
    >>> from netcosim.fmi.demo import build_se_fmu
    >>> tmp = tempfile.TemporaryDirectory()
    >>> se = ScheduledExecutionFMU(build_se_fmu(tmp.name))
    >>> se.clocks
    {'fast': 0.005, 'slow': 0.008}
    >>> sim = Simulation()
    >>> tasks = se.add_tasks(sim.node("ecu"), {"fast": 0.001, "slow": 0.002})
    >>> sim.run(until=0.012)
    >>> [(clock, round(t_act, 6), round(t_done, 6)) for clock, t_act, t_done in se.activations]
    [('fast', 0.0, 0.001), ('slow', 0.0, 0.003), ('fast', 0.005, 0.006), ('slow', 0.008, 0.01), ('fast', 0.01, 0.011)]
    >>> se.output("fast_count"), se.output("slow_count")
    (3.0, 2.0)
    >>> tmp.cleanup()
    """

    def __init__(self, path: Any, *, parameters: dict | None = None, start_time: float = 0.0,
                 name: str | None = None):
        self.file = file = FMUFile(path, kind="scheduled execution")
        if file.fmi_version != 3:  # pragma: no cover - FMI 2 has no scheduled execution interface
            raise FMUError(f"{file.label}: Scheduled Execution needs FMI 3.0")
        self.name = name or file.model_name
        self.clocks, self.shifts, self._clock_vr = _input_clocks(file)
        if not self.clocks:
            raise FMUError(f"{file.label}: no input clock with a constant interval (intervalDecimal): nothing "
                           f"to schedule")
        self.activations: list[Activation] = []
        fmu = self._fmu = file.instantiate(self.name, "FMU3ScheduledExecution")
        file.set_values(parameters or {})
        file.call("fmi3EnterInitializationMode", fmu.enterInitializationMode, None, start_time, t=start_time)
        file.call("fmi3ExitInitializationMode", fmu.exitInitializationMode, t=start_time)

    def add_tasks(self, node, execution_time: dict, *, priority: dict | None = None,
                  deadline: dict | None = None, offset: float = 0.0) -> dict:
        """One periodic task per input clock on *node*; returns ``{clock: task}``.

        *execution_time*: ``{clock: seconds, distribution or callable c(rng)}`` for every
        clock.  *priority*: ``{clock: priority}`` (small = high; default rate-monotonic
        ranks 1, 2, ...); *deadline*: ``{clock: relative deadline (s)}`` (default: the
        interval); *offset* (s) is added to every clock's shift.  The tasks are named after
        the clocks."""
        if not isinstance(execution_time, dict):
            raise ConfigurationError(f"{self.file.label}: execution_time must be a dict {{clock: seconds}}, "
                                     f"got {execution_time!r}")
        for what, given in (("execution_time", execution_time), ("priority", priority or {}),
                            ("deadline", deadline or {})):
            unknown = [c for c in given if c not in self.clocks]
            if unknown:
                raise ConfigurationError(f"{self.file.label}: {what} names clock {unknown[0]!r}, the FMU's input "
                                         f"clocks are {sorted(self.clocks)}")
        missing = [c for c in self.clocks if c not in execution_time]
        if missing:
            raise ConfigurationError(f"{self.file.label}: no execution time for clock {missing[0]!r} "
                                     f"(execution_time must give every clock: {sorted(self.clocks)})")
        ranks = {c: k + 1 for k, c in enumerate(sorted(self.clocks, key=lambda c: (self.clocks[c], c)))}
        prio = dict(ranks, **(priority or {}))
        tasks = {}
        for clock, interval in self.clocks.items():
            tasks[clock] = node.periodic(self._body(clock, execution_time[clock]), period=interval,
                                         offset=self.shifts[clock] + offset, priority=prio[clock],
                                         deadline=(deadline or {}).get(clock), name=clock)
        return tasks

    def _body(self, clock: str, c: Any) -> Callable:
        vr = self._clock_vr[clock]

        def body(ctx):
            yield ctx.execute(c)
            self.activate(clock, ctx.job.release_time, vr=vr, now=ctx.now)
        body.__name__ = f"partition_{clock}"
        return body

    def activate(self, clock: str, activation_time: float, *, vr: int | None = None,
                 now: float | None = None) -> None:
        """Run the partition of *clock* for the tick at *activation_time* (s).  ``vr``: the
        clock's value reference (None: looked up by name); ``now`` (s): the completion time
        recorded in :attr:`activations` (None: the activation time)."""
        vr = self._clock_vr[clock] if vr is None else vr
        self.file.call("fmi3ActivateModelPartition", self._fmu.activateModelPartition, vr, activation_time,
                       t=activation_time, names=[clock])
        self.activations.append((clock, activation_time, activation_time if now is None else now))

    def output(self, name: str) -> float:
        """The current value of the Float64 variable *name*."""
        vr = self.file.real([name], "output")
        return float(self.file.call("fmi3GetFloat64", self._fmu.getFloat64, vr, names=[name])[0])


def _input_clocks(file: FMUFile) -> tuple[dict[str, float], dict[str, float], dict[str, int]]:
    """The input clocks with a constant or fixed interval: name -> interval (s), shift (s), value reference.

    Read from modelDescription.xml directly (FMPy keeps no ``intervalDecimal``)."""
    import xml.etree.ElementTree as ET
    with zipfile.ZipFile(file.path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    intervals, shifts, vrs = {}, {}, {}
    for el in root.iter("Clock"):
        if el.get("causality") != "input":
            continue
        name = el.get("name", "")
        if el.get("intervalVariability") not in ("constant", "fixed") or el.get("intervalDecimal") is None:
            raise FMUError(f"{file.label}: input clock {name!r} has interval variability "
                           f"{el.get('intervalVariability')!r} without intervalDecimal: only periodic clocks with "
                           f"a constant interval are scheduled")
        interval = float(el.get("intervalDecimal", "nan"))
        if not interval > 0:
            raise FMUError(f"{file.label}: input clock {name!r} has interval {interval!r}, not > 0 s")
        intervals[name] = interval
        shifts[name] = float(el.get("shiftDecimal", "0"))
        vrs[name] = int(el.get("valueReference", "-1"))
    return intervals, shifts, vrs
