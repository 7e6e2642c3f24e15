"""How much simulated CPU time a controller job's real computation costs.

A task whose body runs real code (an NMPC solve, a planner's online gain) must say how
much CPU time that code takes on the simulated node: ``yield ctx.execute(c)``.  Where
*c* comes from decides whether the run is reproducible:

:class:`FixedCPUTime`
    A fixed budget per phase (seconds).  Reproducible.
:class:`RecordedCPUTime`
    Replays a table of per-job costs recorded once (for instance by a calibration run
    with :class:`WallClockCPUTime`), job by job.  Reproducible: the same table gives the
    same schedule on any machine, however loaded.  The table is stored with the
    results (:meth:`CPUTimeModel.record`), so a run can be replayed exactly later.
:class:`WallClockCPUTime`
    The wall-clock time the computation just took on *this* host, times ``factor``.
    **Not reproducible**: the schedule, and so the control results, change with the
    host's speed and load.  Opt-in only; constructing one emits a
    :class:`NonReproducibleWarning`, and ``reproducible`` is False.

Usage in a task body::

    with cpu_model.measure("feedback") as m:
        r = solver.feedback(x)          # the real computation
    yield ctx.execute(m.seconds)        # charged to the simulated CPU

Every charge is logged; :meth:`CPUTimeModel.record` returns them as a DataFrame with
columns ``phase, index, wall, cpu`` (``index``: the n-th charge of that phase, from 0;
``wall``: measured wall-clock seconds, NaN where no clock was read; ``cpu``: the
seconds charged).  All times are in seconds of CPU at node speed 1.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

from . import validate
from .errors import ConfigurationError, ConfigurationTypeError, NetcosimError

__all__ = ["CPUTimeModel", "FixedCPUTime", "RecordedCPUTime", "WallClockCPUTime", "NonReproducibleWarning",
           "RECORD_COLUMNS", "RecordingNotFoundError", "RecordingWriteError", "ClockError"]

#: Columns of :meth:`CPUTimeModel.record`.
RECORD_COLUMNS = ("phase", "index", "wall", "cpu")


class RecordingNotFoundError(NetcosimError, FileNotFoundError):
    """:meth:`RecordedCPUTime.load` found no file at the path (the message names it; a
    ``FileNotFoundError`` too)."""


class RecordingWriteError(NetcosimError, OSError):
    """:meth:`CPUTimeModel.save` could not write the table (the message names the path and why)."""


class ClockError(NetcosimError, RuntimeError):
    """A model's ``clock`` gave a reading that is not a finite number of seconds, or a
    negative (non-monotonic) or non-finite duration."""


class NonReproducibleWarning(UserWarning):
    """Results of this run depend on the host's speed and load (wall-clock CPU times)."""


def _seconds(value: Any, what: str) -> float:
    if not validate.is_real(value):
        raise ConfigurationTypeError(f"{what} must be a number of seconds, got {value!r}")
    return validate.non_negative(value, what, kind="a finite, non-negative number of seconds")


class Measurement:
    """Context manager returned by :meth:`CPUTimeModel.measure`; ``seconds`` is the CPU
    time to charge once the block has exited (reading it earlier raises).  ``model``: the
    :class:`CPUTimeModel` that measures; ``phase``: the name the execution is timed as."""

    __slots__ = ("model", "phase", "_t0", "_seconds")

    def __init__(self, model: "CPUTimeModel", phase: str):
        self.model, self.phase = model, phase
        self._t0 = math.nan  # clock reading at __enter__ (only when the model reads the clock)
        self._seconds: float | None = None

    def _read(self) -> float:
        value = self.model.clock()
        if not validate.is_real(value):
            raise ConfigurationTypeError(f"clock {self.model.clock!r} returned {value!r} timing phase "
                                         f"{self.phase!r}: a clock must return a number of seconds")
        if not math.isfinite(value):
            raise ClockError(f"clock {self.model.clock!r} returned {value!r} timing phase {self.phase!r}: "
                             f"a clock must return a finite number of seconds")
        return float(value)

    def __enter__(self) -> "Measurement":
        if self.model.reads_clock:
            self._t0 = self._read()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            return
        wall = self._read() - self._t0 if self.model.reads_clock else math.nan
        self._seconds = self.model._charge(self.phase, wall)

    @property
    def seconds(self) -> float:
        """CPU seconds (at node speed 1) the measured block costs on the simulated node."""
        if self._seconds is None:
            raise RuntimeError(f"CPU time of phase {self.phase!r} read before its measured block finished")
        return self._seconds


class CPUTimeModel:
    """Base: subclasses implement :meth:`~CPUTimeModel.cost`; the base logs every charge.

    ``reproducible``: True when the charged times do not depend on the host.
    ``reads_clock``: True when :meth:`measure` reads ``clock`` around the block.

    Examples
    --------
    A model of one's own: the first solve of an optimiser is a cold start (5 ms), the next
    ones are warm-started (2 ms); every charge is logged (seconds of CPU at speed 1).  A
    task body charges it with ``yield ctx.execute(model.charge("solve"))``.

    >>> from netcosim import CPUTimeModel
    >>> class ColdStart(CPUTimeModel):
    ...     def cost(self, phase, index, wall):
    ...         return 0.005 if index == 0 else 0.002
    >>> model = ColdStart()
    >>> [model.charge("solve") for _ in range(3)]
    [0.005, 0.002, 0.002]
    >>> model.record()
       phase  index  wall    cpu
    0  solve      0   NaN  0.005
    1  solve      1   NaN  0.002
    2  solve      2   NaN  0.002
    """

    reproducible = True
    reads_clock = False

    def __init__(self, clock: Callable[[], float] = time.perf_counter):
        validate.callable_(clock, "clock", kind="a callable returning seconds")
        self.clock = clock
        self._log: list[tuple[str, int, float, float]] = []
        self._counts: dict[str, int] = {}

    def cost(self, phase: str, index: int, wall: float) -> float:
        """CPU seconds of the *index*-th execution of *phase* that took *wall* s (NaN if unmeasured)."""
        raise NotImplementedError(f"{type(self).__name__} does not say what a job costs: CPUTimeModel is the base "
                                  f"class; use FixedCPUTime, RecordedCPUTime or WallClockCPUTime, or a subclass "
                                  f"that implements cost(phase, index, wall)")

    def fresh(self) -> "CPUTimeModel":
        """A copy with the same settings and an empty log (charge counts back at 0), so
        that one model object can configure several runs that each start alike."""
        import copy
        other = copy.copy(self)
        other._log = []
        other._counts = {}
        return other

    def measure(self, phase: str) -> Measurement:
        """Time the ``with`` block as one execution of *phase* (a name such as ``"feedback"``)."""
        validate.name(phase, "phase")
        self._check_concrete()
        return Measurement(self, phase)

    def _check_concrete(self) -> None:
        """Refuse the bare base class at once (its :meth:`cost` says nothing), naming the models to use."""
        if type(self).cost is CPUTimeModel.cost:
            self.cost("", 0, math.nan)

    def charge(self, phase: str) -> float:
        """CPU seconds of one execution of *phase* without timing anything (fixed or
        recorded models; a wall-clock model has nothing to measure and raises)."""
        validate.name(phase, "phase")
        self._check_concrete()
        if self.reads_clock:
            raise RuntimeError(f"{type(self).__name__} must time the computation: use measure({phase!r})")
        return self._charge(phase, math.nan)

    def _charge(self, phase: str, wall: float) -> float:
        k = self._counts.get(phase, 0)
        self._counts[phase] = k + 1
        c = self.cost(phase, k, wall)
        self._log.append((phase, k, wall, c))
        return c

    def record(self):
        """Every charge so far as a DataFrame (columns :data:`RECORD_COLUMNS`)."""
        import pandas as pd
        return pd.DataFrame(self._log, columns=list(RECORD_COLUMNS))

    def save(self, path: str | PathLike) -> Path:
        """Write :meth:`record` to *path* (``.csv`` or ``.parquet``) for :meth:`RecordedCPUTime.load`."""
        validate.path(path, "path")
        p = Path(path)
        df = self.record()
        if not p.parent.is_dir():
            why = "is a file" if p.parent.exists() else "does not exist"
            raise RecordingWriteError(f"cannot save the CPU-time record to {str(p)!r}: the folder {str(p.parent)!r} "
                                      f"{why}")
        try:
            if p.suffix == ".csv":
                df.to_csv(p, index=False, float_format="%.17g")
            else:
                df.to_parquet(p, index=False)
        except OSError as exc:
            raise RecordingWriteError(f"cannot save the CPU-time record to {str(p)!r}: "
                                      f"{exc.strerror or exc}") from None
        return p


class FixedCPUTime(CPUTimeModel):
    """A fixed CPU time per phase: ``seconds`` (same for every phase) or a mapping
    ``{phase: seconds}`` (a phase missing from it raises when charged).

    Raises
    ------
    ConfigurationTypeError
        If *seconds* (or a value of the mapping) is not a number.
    ConfigurationError
        If a time is negative or not finite; when charged, a phase missing from the mapping.

    Examples
    --------
    A controller whose state estimate costs 1 ms and whose control law costs 2 ms of CPU,
    whatever the host: each job's response time is 3 ms (times in seconds).

    >>> from netcosim import FixedCPUTime, Simulation
    >>> model = FixedCPUTime({"estimate": 0.001, "control": 0.002})
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def ctrl(ctx):
    ...     with model.measure("control") as m:
    ...         u = -2.0 * 0.5                   # the real computation
    ...     yield ctx.execute(model.charge("estimate") + m.seconds)
    >>> sim.run(until=0.020)
    >>> sim.trace.jobs().response_time.round(6).tolist()
    [0.003, 0.003]
    """

    def __init__(self, seconds: float | Mapping[str, float]):
        super().__init__()
        if isinstance(seconds, Mapping):
            self.seconds: float | dict[str, float] = {
                str(k): _seconds(v, f"CPU time of phase {k!r}") for k, v in seconds.items()}
        else:
            self.seconds = _seconds(seconds, "CPU time")

    def cost(self, phase, index, wall):
        if isinstance(self.seconds, dict):
            try:
                return self.seconds[phase]
            except KeyError:
                raise ConfigurationError(f"no fixed CPU time for phase {phase!r}; have {sorted(self.seconds)}") \
                    from None
        return self.seconds


class RecordedCPUTime(CPUTimeModel):
    """Replays recorded CPU times, job by job.

    ``table``: a DataFrame with columns ``phase`` and ``cpu`` (and optionally ``index``,
    as written by :meth:`CPUTimeModel.record`), or a mapping ``{phase: [seconds, ...]}``.
    The n-th charge of a phase costs the n-th recorded value of that phase times
    ``scale``.  ``beyond`` says what happens after the recording runs out: ``"cycle"``
    (start again from the first value), ``"last"`` (repeat the last value) or
    ``"error"`` (raise).

    Raises
    ------
    ConfigurationTypeError
        If *table* is neither a DataFrame nor a mapping, or *scale* or a recorded time is
        not a number.
    ConfigurationError
        If the table lacks the ``phase`` or ``cpu`` column, is empty or has a phase without
        values, a time or *scale* is negative or not finite, or *beyond* is not one of
        ``"cycle"``, ``"last"``, ``"error"``.  When charged: a phase that was not recorded,
        or (``beyond="error"``) a charge past the end of the recording.

    Examples
    --------
    Two recorded solve times replayed job by job, and cycled when they run out: the
    schedule is the same on any host (times in seconds).

    >>> from netcosim import RecordedCPUTime, Simulation
    >>> model = RecordedCPUTime({"solve": [0.002, 0.004]}, beyond="cycle")
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def mpc(ctx):
    ...     yield ctx.execute(model.charge("solve"))
    >>> sim.run(until=0.030)
    >>> sim.trace.jobs().response_time.round(6).tolist()
    [0.002, 0.004, 0.002]

    A table of charges (a model's :meth:`~CPUTimeModel.record`, or one saved with
    :meth:`~CPUTimeModel.save` and read with :meth:`load`) replays them the same way:

    >>> RecordedCPUTime(model.record()).charge("solve")
    0.002
    """

    def __init__(self, table: Any, *, scale: float = 1.0, beyond: str = "cycle"):
        super().__init__()
        self.scale = _seconds(scale, "scale")
        validate.choice(beyond, "beyond", ("cycle", "last", "error"))
        self.beyond = beyond
        if isinstance(table, Mapping):
            values = {}
            for k, v in table.items():
                if isinstance(v, (str, bytes)) or not hasattr(v, "__iter__"):
                    raise ConfigurationTypeError(f"recorded CPU times of phase {k!r} must be a sequence of seconds "
                                                 f"(e.g. [0.002, 0.004]), got {v!r}")
                values[str(k)] = list(v)
        elif hasattr(table, "columns"):
            missing = {"phase", "cpu"} - set(table.columns)
            if missing:
                raise ConfigurationError(f"recorded CPU-time table lacks columns {sorted(missing)}; "
                                         f"has {list(table.columns)}")
            df = table.sort_values(["phase", "index"]) if "index" in table.columns else table
            values = {str(p): g["cpu"].tolist() for p, g in df.groupby("phase", sort=False)}
        else:
            raise ConfigurationTypeError(f"table must be a DataFrame or a mapping phase -> seconds, got {table!r}")
        if not values:
            raise ConfigurationError("recorded CPU-time table is empty")
        self.values: dict[str, list[float]] = {}
        for phase, seq in values.items():
            if not isinstance(seq, Sequence) or len(seq) == 0:
                raise ConfigurationError(f"phase {phase!r} has no recorded CPU times")
            self.values[phase] = [_seconds(v, f"recorded CPU time of phase {phase!r}") for v in seq]

    @classmethod
    def load(cls, path: str | PathLike, **kw) -> "RecordedCPUTime":
        """Read a table written by :meth:`CPUTimeModel.save` from *path* (``.csv`` or ``.parquet``)."""
        import pandas as pd
        p = Path(path)
        if not p.is_file():
            raise RecordingNotFoundError(f"no recorded CPU-time table at {str(p)!r}"
                                         + (" (it is a directory)" if p.is_dir() else ""))
        df = pd.read_csv(p) if p.suffix == ".csv" else pd.read_parquet(p)
        return cls(df, **kw)

    def cost(self, phase, index, wall):
        try:
            seq = self.values[phase]
        except KeyError:
            raise ConfigurationError(f"no recorded CPU times for phase {phase!r}; have {sorted(self.values)}") \
                from None
        n = len(seq)
        if index >= n:
            if self.beyond == "error":
                raise ConfigurationError(f"recorded CPU times of phase {phase!r} run out: charge {index} "
                                         f"of a recording of {n}")
            index = index % n if self.beyond == "cycle" else n - 1
        return seq[index] * self.scale


class WallClockCPUTime(CPUTimeModel):
    """The wall-clock time the computation took on this host × ``factor``.

    Not reproducible: emits :class:`NonReproducibleWarning` when constructed.  ``clock``
    (default :func:`time.perf_counter`) is injectable, so a test can drive it with a
    fake clock and get a deterministic schedule.  ``warn=False`` silences the warning
    (the results are flagged all the same).

    Raises
    ------
    ConfigurationTypeError
        If *factor* is not a number or *clock* is not callable.
    ConfigurationError
        If *factor* is not positive and finite.
    ClockError
        When the clock reads a value that is not finite, or a measured block's duration is
        negative (a non-monotonic clock).

    Warns
    -----
    NonReproducibleWarning
        When constructed, unless ``warn=False``.

    Examples
    --------
    With an injected clock the measurement is deterministic: a block that took 3 ms of
    wall-clock time on this host is charged 1.5 ms with ``factor=0.5`` (a target twice as
    fast; times in seconds).  In a task body: ``yield ctx.execute(m.seconds)``.

    >>> from netcosim import WallClockCPUTime
    >>> readings = iter([10.000, 10.003])
    >>> model = WallClockCPUTime(factor=0.5, clock=lambda: next(readings), warn=False)
    >>> with model.measure("solve") as m:
    ...     pass                                 # the real computation
    >>> round(m.seconds, 6), model.reproducible
    (0.0015, False)
    """

    reproducible = False
    reads_clock = True

    def __init__(self, factor: float = 1.0, *, clock: Callable[[], float] = time.perf_counter, warn: bool = True):
        super().__init__(clock)
        if not validate.is_real(factor):
            raise ConfigurationTypeError(f"factor must be a number of seconds, got {factor!r}")
        self.factor = validate.positive(factor, "factor", kind="positive")
        if warn:
            warnings.warn("CPU times are the measured wall-clock times of this host: the schedule and the "
                          "results depend on the host's speed and load and are not reproducible "
                          "(use FixedCPUTime or RecordedCPUTime for reproducible runs)",
                          NonReproducibleWarning, stacklevel=2)

    def cost(self, phase, index, wall):
        if not math.isfinite(wall) or wall < 0:
            raise ClockError(f"clock gave a non-monotonic or non-finite duration {wall!r} for phase {phase!r}")
        return wall * self.factor
