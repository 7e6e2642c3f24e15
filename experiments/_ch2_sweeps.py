"""Sweeps of the ch. 2 landing experiment (helpers of :mod:`netcosim.experiments.ch2_landing`).

* :func:`delay_sweep`: the 2LC variants (:data:`~netcosim.controllers.landing.SCHEMES`)
  and NMPC alone against a fixed NMPC computation delay;
* :func:`solve_time_band`: a variant under the recorded solve times replayed from
  several offsets into the recording (the spread the tests' tolerances come from);
* :func:`gain_sweep`: the thesis's scheme against the low-level pole;
* :func:`cable_stress_sweep`: peak f_L over vehicle mass and cable length, and the
  wind's radial share of it.

Distances in m, forces in N, angles in degrees, times in s.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd

from netcosim.controllers.landing import SCHEMES, SIM_PARAMS, LandingTiming, PIDGains, landing_metrics, run_landing
from netcosim.cputime import RecordedCPUTime

DEG = 180.0 / math.pi
#: Solve times of the RTI phases ("feedback", "prepare") recorded by ``calibrate``,
#: one block per scheduled run (column ``run``), replayed by the scheduled runs.
CALIBRATION = Path(__file__).resolve().parent / "data" / "ch2_nmpc_cpu_times.csv"
#: Low-level job CPU time and context switch of the scheduled runs (s).
FL_EXEC, CONTEXT_SWITCH = 1e-4, 2e-5
#: The recording the 2LC variants that start from the measurement replay.
THESIS_RECORDING = "2LC (NMPC from measurement)"
#: Fixed NMPC computation delays of the delay sweep (s): the feedback phase costs all of it.
DELAYS = (0.0, 0.0001, 0.0005, 0.001, 0.002)
#: Offsets (jobs) into the recording of :func:`solve_time_band`.
OFFSETS = tuple(range(0, 150, 15))


def recorded_timing(name: str, path: Path = CALIBRATION, offset: int = 0) -> LandingTiming:
    """The timing of scheduled run *name*: its recorded solve times, replayed from job
    *offset* on (the recording rotated by *offset* jobs, the same for both phases)."""
    table = pd.read_csv(path)
    rows = table[table["run"] == name]
    if rows.empty:
        raise KeyError(f"no recorded CPU times for run {name!r} in {str(path)!r}; "
                       f"have {sorted(table['run'].unique())}")
    if not isinstance(offset, int) or offset < 0:
        raise ValueError(f"offset must be a non-negative integer number of jobs, got {offset!r}")
    if offset:
        values = {ph: g.sort_values("index")["cpu"].tolist() for ph, g in rows.groupby("phase")}
        rec = RecordedCPUTime({ph: v[offset % len(v):] + v[:offset % len(v)] for ph, v in values.items()},
                              beyond="error")
    else:
        rec = RecordedCPUTime(rows, beyond="error")
    return LandingTiming(nmpc_exec=rec, fl_exec=FL_EXEC, context_switch=CONTEXT_SWITCH)


def run_scheme(scheme: str, **kw):
    """One landing of variant *scheme* (a key of ``SCHEMES`` or ``"nmpc"``)."""
    if scheme == "nmpc":
        return run_landing("nmpc", **kw)
    return run_landing("2lc", **{**SCHEMES[scheme], **kw})


def _metrics(fn) -> dict:
    """:func:`landing_metrics` of the run *fn()*, with ``failed = ""``; a run the
    feedback linearization cannot finish (cos(φ+ϑ) ≈ 0, (2.16)) gives NaN metrics and
    ``failed`` naming the exception."""
    try:
        return dict(landing_metrics(fn()), failed="")
    except ArithmeticError as exc:
        return dict(d_PG_min=np.nan, f_L_max=np.nan, t_settle=np.nan, failed=type(exc).__name__)


def wind_deviation(calm, windy) -> float:
    """RMS over the run of (run with wind - run without) in φ and ϑ [deg]."""
    a, b = calm.signals, windy.signals
    return float(DEG * np.sqrt(np.mean((a["phi"] - b["phi"]) ** 2 + (a["theta"] - b["theta"]) ** 2)))


def delay_sweep(delays=DELAYS, duration: float = 1.5,
                schemes=("thesis", "plan", "former_default", "reference", "nmpc"),
                ideal: dict | None = None) -> pd.DataFrame:
    """The variants *schemes* and NMPC alone, calm and with wind, with a fixed NMPC
    computation delay [s] (all of it in the feedback phase, so the plan reaches the
    plant *delay* seconds after its sample).

    One row per (``delay`` [s], ``scheme``, ``wind``) with :func:`landing_metrics`,
    plus on the wind rows ``wind_deviation`` [deg] (RMS over the run of the wind run
    minus the calm run, same delay and scheme) and ``wind_ratio`` (that deviation over
    NMPC alone's at the same delay, when ``"nmpc"`` is swept).  *ideal* maps
    ``(scheme, wind)`` to a zero-delay run of the same *duration* to reuse for delay 0.
    A run that ends singular ((2.16), cos(φ+ϑ) ≈ 0) has NaN metrics and ``failed``
    naming the exception.
    """
    rows = []
    for delay in delays:
        timing = LandingTiming(nmpc_exec=float(delay), feedback_share=1.0)
        reuse = ideal if delay == 0 and ideal is not None else {}
        for scheme in schemes:
            pair = {}
            for w in (False, True):
                try:
                    pair[w] = reuse.get((scheme, w)) or run_scheme(scheme, wind=w, duration=duration, timing=timing)
                    m = dict(landing_metrics(pair[w]), failed="")
                except ArithmeticError as exc:  # a singular feedback linearization ends the run
                    m = dict(d_PG_min=np.nan, f_L_max=np.nan, t_settle=np.nan, failed=type(exc).__name__)
                rows.append(dict(m, delay=float(delay), scheme=scheme, wind=w))
            rows[-1]["wind_deviation"] = wind_deviation(pair[False], pair[True]) if len(pair) == 2 else np.nan
    df = pd.DataFrame(rows)
    if "nmpc" in schemes:
        ref = df[df["wind"] & (df["scheme"] == "nmpc")].set_index("delay")["wind_deviation"]
        df["wind_ratio"] = df["wind_deviation"] / df["delay"].map(ref)
    return df


def solve_time_band(schemes=("thesis", "former_default"), offsets=OFFSETS, duration: float = 1.5) -> pd.DataFrame:
    """Each variant of *schemes* under the recorded solve times of
    :data:`THESIS_RECORDING`, replayed from each of *offsets*: one row per (``scheme``,
    ``offset``) with :func:`landing_metrics` (``d_PG_min`` [m], ``f_L_max`` [N], ...;
    NaN and ``failed`` naming the exception when the run ends singular)."""
    rows = []
    for scheme in schemes:
        for off in offsets:
            timing = recorded_timing(THESIS_RECORDING, offset=off)
            m = _metrics(lambda: run_scheme(scheme, duration=duration, timing=timing))
            rows.append(dict(m, scheme=scheme, offset=int(off)))
    return pd.DataFrame(rows)


def gain_sweep(poles=(60.0, 80.0, 100.0, 120.0, 150.0, 200.0), delays=(0.0, 0.001, 0.002),
               offsets=(0, 50, 100), duration: float = 1.5) -> pd.DataFrame:
    """The thesis's scheme with the low-level triple pole at each of *poles* [rad/s]:
    one row per (``pole``, ``timing``) -- ``"delay <ms>"`` fixed delays and ``"recorded
    +<offset>"`` replays -- with ``d_PG_min`` [m], ``f_L_max`` [N], ``t_settle`` [s], or
    ``failed`` naming the exception (a singular feedback linearization)."""
    rows = []
    for pole in poles:
        g = PIDGains.triple_pole(float(pole))
        cases = [(f"delay {1e3 * d:g} ms", LandingTiming(nmpc_exec=d, feedback_share=1.0)) for d in delays]
        cases += [(f"recorded +{o}", recorded_timing(THESIS_RECORDING, offset=o)) for o in offsets]
        for name, timing in cases:
            m = _metrics(lambda: run_landing("2lc", duration=duration, timing=timing, fl_gains=g))
            rows.append(dict(pole=float(pole), timing=name, d_PG_min=m["d_PG_min"], f_L_max=m["f_L_max"],
                             t_settle=m["t_settle"], failed=m["failed"]))
    return pd.DataFrame(rows)


def cable_stress_sweep(masses=(0.5, 0.7, 1.0, 1.3), lengths=(0.5, 1.0, 2.0), duration: float = 1.5,
                       winds=((3.0, 1.0), (1.0, 0.3))) -> pd.DataFrame:
    """Peak cable stress f_L of the 2LC (thesis's scheme, zero delay) for vehicle masses
    ``m_B`` [kg] and cable lengths ``l`` [m] the thesis leaves open (every other
    parameter from :data:`SIM_PARAMS`), calm and under each wind of *winds* = (pulse
    amplitude, sine amplitude) [N].

    One row per (``m_B``, ``l``, ``wind``: ``"calm"`` or ``"<pulse>/<sine> N"``):
    ``f_L_max`` [N], ``wind_radial_max`` [N] (largest |cos φ · F_wind|, the wind's
    share of (2.4)), ``d_PG_min`` [m], ``t_settle`` [s], ``dphi_max`` [deg/s].
    """
    from netcosim.plants.tethered_uav import wind as wind_force
    rows = []
    for m_B in masses:
        for length in lengths:
            base = dataclasses.replace(SIM_PARAMS, m_B=float(m_B), l=float(length))
            cases = [("calm", base, False)] + [
                (f"{a:g}/{b:g} N", dataclasses.replace(base, wind_pulse_amplitude=a, wind_sine_amplitude=b), True)
                for a, b in winds]
            for name, p, w in cases:
                run = run_landing("2lc", wind=w, duration=duration, params=p)
                m = landing_metrics(run)
                s = run.signals
                radial = (max(abs(math.cos(ph) * wind_force(t, p)[0]) for t, ph in zip(s["time"], s["phi"]))
                          if w else 0.0)
                rows.append(dict(m_B=float(m_B), l=float(length), wind=name, f_L_max=m["f_L_max"],
                                 wind_radial_max=radial, d_PG_min=m["d_PG_min"], t_settle=m["t_settle"],
                                 dphi_max=float(DEG * s["dphi"].abs().max())))
    return pd.DataFrame(rows)
