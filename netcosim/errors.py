"""The exceptions netcosim raises, in one place.

Every error netcosim raises on purpose derives from :class:`NetcosimError`, so a
caller can catch the framework's errors without catching unrelated bugs.  Errors about
bad configuration values also derive from the built-in ``ValueError`` (or ``TypeError``
for a value of the wrong kind), so code written against the standard library keeps
working.  Each message names the offending value.
"""

from __future__ import annotations

__all__ = ["NetcosimError", "ConfigurationError", "ConfigurationTypeError", "NotConnectedError",
           "SimulationFailedError", "UnyieldedExecuteError",
           "IntegrationError", "LossTraceExhaustedError", "TraceWriteError", "FMUError"]


class NetcosimError(Exception):
    """Base class of every error netcosim raises deliberately.

    Examples
    --------
    One ``except`` catches every error netcosim raises on purpose, whatever its kind:

    >>> from netcosim import NetcosimError, Simulation
    >>> sim = Simulation()
    >>> try:
    ...     sim.node("cpu", scheduler="lottery")
    ... except NetcosimError as exc:
    ...     print(type(exc).__name__, isinstance(exc, ValueError))
    ConfigurationError True
    """


class ConfigurationError(NetcosimError, ValueError):
    """A parameter has a value the model cannot use (the message names the value).

    Examples
    --------
    A scheduling policy that does not exist, and a period (s) of zero:

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> sim.node("cpu", scheduler="lottery")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: unknown scheduling policy 'lottery'; choose one of [...]
    >>> cpu = sim.node("cpu")
    >>> cpu.periodic(lambda ctx: None, period=0.0, priority=1, name="ctrl")
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: task 'ctrl': period must be positive, got 0.0
    """


class ConfigurationTypeError(NetcosimError, TypeError):
    """A parameter has a value of the wrong kind (the message names the value).

    Examples
    --------
    A period given as text rather than a number of seconds:

    >>> from netcosim import Simulation
    >>> cpu = Simulation().node("cpu")
    >>> cpu.periodic(lambda ctx: None, period="10 ms", priority=1, name="ctrl")
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationTypeError: task 'ctrl': period must be a finite number of seconds, got '10 ms'
    """


class NotConnectedError(NetcosimError, RuntimeError):
    """Reading or writing an I/O channel that has no plant port attached.

    Examples
    --------
    Reading an analog input that was never connected to a plant output, and sending from a
    node on no network:

    >>> from netcosim import Simulation
    >>> cpu = Simulation().node("cpu")
    >>> cpu.analog_in(0).read()
    Traceback (most recent call last):
    ...
    netcosim.errors.NotConnectedError: analog input 0 of node 'cpu' is not connected
    >>> cpu.send("other", "hello")
    Traceback (most recent call last):
    ...
    netcosim.errors.NotConnectedError: node 'cpu' has no network interface; attach it to a network first
    """


class TraceWriteError(NetcosimError, OSError):
    """Trace tables could not be written to a path (the message names the path and the reason)."""


class SimulationFailedError(NetcosimError, RuntimeError):
    """The simulation raised earlier and cannot continue; build a new one.

    Examples
    --------
    A task body divides by zero at t = 1 ms: the run raises that error (the traces keep what
    was recorded); running the same simulation again raises this one, naming it.

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.aperiodic(priority=1)
    ... def bad(ctx):
    ...     yield ctx.execute(1 / 0)
    >>> _ = sim.call_at(0.001, bad.release)
    >>> try:
    ...     sim.run(until=0.010)
    ... except ZeroDivisionError as exc:
    ...     print("failed:", exc)
    failed: division by zero
    >>> sim.run(until=0.020)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.errors.SimulationFailedError: this simulation failed at t = 0.001000000 s with ZeroDivisionError: ...
    """


class UnyieldedExecuteError(NetcosimError, RuntimeError):
    """A task asked for CPU time with ``ctx.execute(c)`` but did not ``yield`` it.

    Examples
    --------
    ``ctx.execute(0.002)`` without ``yield`` consumes no CPU time: the kernel refuses it when
    the job goes on without yielding it (here, when it finishes):

    >>> import textwrap
    >>> from netcosim import Simulation, UnyieldedExecuteError
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def ctrl(ctx):
    ...     ctx.execute(0.002)                   # should be: yield ctx.execute(0.002)
    >>> try:
    ...     sim.run(until=0.010)
    ... except UnyieldedExecuteError as exc:
    ...     print(textwrap.fill(str(exc), 88))
    task 'ctrl' on node 'cpu' (job 0) called ctx.execute(0.002) without yielding it and
    finished at t = 0.000000000 s; write `yield ctx.execute(0.002)` (an unyielded request
    consumes no CPU time)
    """


class IntegrationError(NetcosimError, RuntimeError):
    """A plant could not be advanced (non-finite state or output, too many steps).

    Examples
    --------
    ``dx/dt = x**2`` from ``x(0) = 1`` has the solution ``1 / (1 - t)``, which escapes to
    infinity at t = 1 s; fixed 1 ms RK4 steps find a non-finite derivative just after it:

    >>> from netcosim import ContinuousSystem, IntegrationError, RK4, Simulation
    >>> def f(t, x, u, params):
    ...     v = float(x[0])
    ...     return [v * v]
    >>> sim = Simulation()
    >>> plant = sim.plant(ContinuousSystem(f, states=["x"], inputs=["u"], outputs=["y"]), x0=[1.0],
    ...                   name="blowup", integrator=RK4(0.001))
    >>> try:
    ...     sim.run(until=2.0)
    ... except IntegrationError as exc:
    ...     print(exc)  # doctest: +ELLIPSIS
    plant 'blowup': derivative of ['x'] is non-finite at t=1.002 s (x=[...]): f returned [inf]
    """


class FMUError(NetcosimError, RuntimeError):
    """An FMU could not be loaded, instantiated or advanced, or returned an error status
    (the message names the FMU file, the FMI function or variable, and the time)."""


class LossTraceExhaustedError(NetcosimError, RuntimeError):
    """A :class:`~netcosim.network.loss.TraceLoss` without ``repeat`` ran out of recorded
    frames: the run sent more frames on a link than the trace holds."""


class OverloadError(NetcosimError, RuntimeError):
    """A bounded queue overflowed where the user asked for an error rather than a counted
    drop (a task's pending jobs, ``on_queue_full="error"``)."""


class NaNMetricWarning(UserWarning):
    """Runs of a sweep finished (status ``"ok"``) but returned NaN for a metric: kept as
    returned, counted in ``SweepResult.summary["nan"]`` and named once per sweep."""


class OverloadWarning(UserWarning):
    """The first counted drop of a bounded queue (a task's pending jobs): the run goes on,
    the drops are counted (``task.dropped``)."""



class BatteryEmptyWarning(UserWarning):
    """A node's battery ran empty: the node stopped (its jobs and radios; see ``docs/kernel.md``,
    "Energy and batteries").  Warned once per battery."""
