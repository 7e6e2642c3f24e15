"""Invalid inputs of the CPU-time models and the ch. 2 landing timing."""

import math

import pandas as pd

from invalid_cases import Case


def _cpu():
    import netcosim.cputime as c
    return c


def _landing():
    import netcosim.controllers.landing
    return netcosim.controllers.landing


def _recorded_run_out():
    m = _cpu().RecordedCPUTime({"solve": [1e-3]}, beyond="error")
    m.charge("solve")
    m.charge("solve")


CASES = [
    Case("cputime-fixed-negative", lambda: _cpu().FixedCPUTime(-1e-3), ValueError, "-0.001"),
    Case("cputime-fixed-nan", lambda: _cpu().FixedCPUTime(math.nan), ValueError, "nan"),
    Case("cputime-fixed-inf", lambda: _cpu().FixedCPUTime(math.inf), ValueError, "inf"),
    Case("cputime-fixed-string", lambda: _cpu().FixedCPUTime("2ms"), TypeError, "'2ms'"),
    Case("cputime-fixed-phase-negative", lambda: _cpu().FixedCPUTime({"solve": -2.0}), ValueError, "-2.0"),
    Case("cputime-fixed-unknown-phase", lambda: _cpu().FixedCPUTime({"solve": 1e-3}).charge("prepare"),
         ValueError, "'prepare'"),
    Case("cputime-recorded-beyond", lambda: _cpu().RecordedCPUTime({"a": [1e-3]}, beyond="wrap"),
         ValueError, "'wrap'"),
    Case("cputime-recorded-nan-value", lambda: _cpu().RecordedCPUTime({"a": [1e-3, math.nan]}),
         ValueError, "nan"),
    Case("cputime-recorded-empty-phase", lambda: _cpu().RecordedCPUTime({"a": []}), ValueError, "'a'"),
    Case("cputime-recorded-missing-column",
         lambda: _cpu().RecordedCPUTime(pd.DataFrame({"phase": ["a"], "seconds": [1e-3]})), ValueError, "'cpu'"),
    Case("cputime-recorded-not-a-table", lambda: _cpu().RecordedCPUTime(0.002), TypeError, "0.002"),
    Case("cputime-recorded-scale", lambda: _cpu().RecordedCPUTime({"a": [1e-3]}, scale=-1), ValueError, "-1"),
    Case("cputime-recorded-run-out", _recorded_run_out, ValueError, "'solve'"),
    Case("cputime-recorded-missing-file", lambda: _cpu().RecordedCPUTime.load("/nonexistent/rec.csv"),
         FileNotFoundError, "'/nonexistent/rec.csv'"),
    Case("cputime-wallclock-factor-zero", lambda: _cpu().WallClockCPUTime(0.0, warn=False), ValueError, "0.0"),
    Case("cputime-wallclock-clock", lambda: _cpu().WallClockCPUTime(1.0, clock=3.0, warn=False), TypeError, "3.0"),
    Case("cputime-measure-phase", lambda: _cpu().FixedCPUTime(1e-3).measure(""), TypeError, "''"),
    Case("landing-timing-exec-string", lambda: _landing().LandingTiming(nmpc_exec="fast"), ValueError, "'fast'"),
    Case("landing-timing-exec-negative", lambda: _landing().LandingTiming(nmpc_exec=-0.001), ValueError, "-0.001"),
    Case("landing-timing-cpu-factor", lambda: _landing().LandingTiming(cpu_factor=math.nan), ValueError, "nan"),
    Case("landing-timing-share", lambda: _landing().LandingTiming(feedback_share=1.5), ValueError, "1.5"),
    Case("landing-timing-fl-exec", lambda: _landing().LandingTiming(fl_exec=-1e-4), ValueError, "-0.0001"),
    Case("landing-timing-clock", lambda: _landing().LandingTiming(clock="wall"), ValueError, "'wall'"),
    Case("landing-controller", lambda: _landing().run_landing("pid"), ValueError, "'pid'"),
    Case("landing-topology", lambda: _landing().run_landing("2lc", topology="star"), ValueError, "'star'"),
    Case("landing-duration", lambda: _landing().run_landing("2lc", duration=-1.0), ValueError, "-1.0"),
    Case("landing-nmpc-init", lambda: _landing().run_landing("2lc", nmpc_init="zero"), ValueError, "'zero'"),
]


def _wallclock(clock):
    m = _cpu().WallClockCPUTime(clock=clock, warn=False)
    with m.measure("solve"):
        pass


def _backwards():
    readings = iter([1.0, 0.5])
    _wallclock(lambda: next(readings))


# the audit's cases: project errors (subclassing the builtin ones), messages that say what to do
CASES += [
    Case("cputime-load-missing-file", lambda: _cpu().RecordedCPUTime.load("/nonexistent.json"),
         _cpu().RecordingNotFoundError, "'/nonexistent.json'"),
    Case("cputime-load-missing-file-is-a-filenotfounderror",
         lambda: _cpu().RecordedCPUTime.load("/nonexistent.json"), FileNotFoundError, "'/nonexistent.json'"),
    Case("cputime-base-class-measure", lambda: _cpu().CPUTimeModel().measure("a"), NotImplementedError,
         "use FixedCPUTime, RecordedCPUTime or WallClockCPUTime"),
    Case("cputime-base-class-charge", lambda: _cpu().CPUTimeModel().charge("a"), NotImplementedError,
         "CPUTimeModel is the base class"),
    Case("cputime-save-into-missing-folder", lambda: _cpu().FixedCPUTime(0.001).save("/proc/x/y.json"),
         _cpu().RecordingWriteError, "'/proc/x/y.json'"),
    Case("cputime-save-into-missing-folder-is-an-oserror",
         lambda: _cpu().FixedCPUTime(0.001).save("/proc/x/y.json"), OSError, "'/proc/x'"),
    Case("cputime-wallclock-clock-returns-text", lambda: _wallclock(lambda: "x"), TypeError, "returned 'x'"),
    Case("cputime-wallclock-clock-returns-nan", lambda: _wallclock(lambda: math.nan), _cpu().ClockError,
         "returned nan"),
    Case("cputime-wallclock-clock-goes-back", lambda: _backwards(), _cpu().ClockError, "-0.5"),
]
