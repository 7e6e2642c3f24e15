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
    """Base class of every error netcosim raises deliberately."""


class ConfigurationError(NetcosimError, ValueError):
    """A parameter has a value the model cannot use (the message names the value)."""


class ConfigurationTypeError(NetcosimError, TypeError):
    """A parameter has a value of the wrong kind (the message names the value)."""


class NotConnectedError(NetcosimError, RuntimeError):
    """Reading or writing an I/O channel that has no plant port attached."""


class TraceWriteError(NetcosimError, OSError):
    """Trace tables could not be written to a path (the message names the path and the reason)."""


class SimulationFailedError(NetcosimError, RuntimeError):
    """The simulation raised earlier and cannot continue; build a new one."""


class UnyieldedExecuteError(NetcosimError, RuntimeError):
    """A task asked for CPU time with ``ctx.execute(c)`` but did not ``yield`` it."""


class IntegrationError(NetcosimError, RuntimeError):
    """A plant could not be advanced (non-finite state or output, too many steps)."""


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
