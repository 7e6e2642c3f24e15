"""CPU times of the landing tasks: what one NMPC job and one low-level job cost.

Times in seconds of CPU at node speed 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from netcosim import validate
from netcosim.cputime import CPUTimeModel, FixedCPUTime, WallClockCPUTime
from netcosim.errors import ConfigurationError

__all__ = ["LandingTiming"]


def _is_finite_number(v) -> bool:
    """True for a finite real number (bools excluded)."""
    return validate.is_real(v) and math.isfinite(v)


def _check_nmpc_exec(e) -> None:
    """``nmpc_exec``: ``"measured"``, a :class:`CPUTimeModel` or a number of seconds >= 0."""
    if isinstance(e, str):
        if e != "measured":
            raise ValueError(f"nmpc_exec must be a number of seconds or 'measured', got {e!r} "
                             f"(or a netcosim.cputime.CPUTimeModel)")
    elif not isinstance(e, CPUTimeModel) and (not _is_finite_number(e) or e < 0):
        raise ValueError(f"nmpc_exec must be a non-negative number of seconds, a CPUTimeModel or 'measured', "
                         f"got {e!r}")


@dataclass(frozen=True)
class LandingTiming:
    """CPU times of the tasks (seconds at node speed 1).

    ``nmpc_exec`` says what one NMPC job costs:

    * ``0.0`` (ideal) or a number: a fixed budget for the whole job, split between the
      feedback and preparation phases in proportion ``feedback_share``;
    * a :class:`netcosim.cputime.CPUTimeModel` with phases ``"feedback"`` and
      ``"prepare"``, e.g. :class:`~netcosim.cputime.RecordedCPUTime` replaying solve
      times recorded once (reproducible); each run starts from a fresh copy of it;
    * ``"measured"``: the wall-clock time each phase took on this host ×
      ``cpu_factor`` (:class:`~netcosim.cputime.WallClockCPUTime`).  Opt-in only: the
      results then depend on the host's speed and load; each run warns
      (:class:`~netcosim.cputime.NonReproducibleWarning`) and reports
      ``reproducible=False``.  ``clock`` replaces :func:`time.perf_counter` for it
      (tests inject a fake clock).

    ``fl_exec``: CPU time of one low-level job (also charged by the sensor job of the
    two-node variant).  ``context_switch``: kernel context-switch time.
    """

    nmpc_exec: Any = 0.0
    cpu_factor: float = 1.0
    feedback_share: float = 0.8
    fl_exec: float = 0.0
    context_switch: float = 0.0
    clock: Any = None

    def __post_init__(self):
        _check_nmpc_exec(self.nmpc_exec)
        validate.positive(self.cpu_factor, "cpu_factor", kind="a positive number", type_error=ConfigurationError)
        if not (0.0 <= self.feedback_share <= 1.0):
            raise ValueError(f"feedback_share must lie in [0, 1], got {self.feedback_share!r}")
        for name in ("fl_exec", "context_switch"):
            validate.non_negative(getattr(self, name), name, kind="a non-negative number of seconds",
                                  type_error=ConfigurationError)
        if self.clock is not None:
            validate.callable_(self.clock, "clock", kind="a callable returning seconds", type_error=ConfigurationError)

    def nmpc_model(self) -> CPUTimeModel:
        """A fresh CPU-time model for one run (phases ``"feedback"`` and ``"prepare"``, seconds)."""
        e = self.nmpc_exec
        if isinstance(e, CPUTimeModel):
            return e.fresh()
        if e == "measured":
            kw = {} if self.clock is None else {"clock": self.clock}
            return WallClockCPUTime(self.cpu_factor, **kw)
        return FixedCPUTime({"feedback": float(e) * self.feedback_share,
                             "prepare": float(e) * (1.0 - self.feedback_share)})
