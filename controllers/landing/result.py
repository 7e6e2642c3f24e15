"""The result of one landing run, its summary numbers and its Fig. 2.8-style plot.

Angles in radians in the tables (degrees in the plot and the metrics), forces in N,
torques in N·m, times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from netcosim import Simulation
from netcosim.plants.tethered_uav import wind_disturbance

__all__ = ["LandingRun", "landing_metrics", "plant_signals", "REFERENCE_COLUMNS"]

#: Columns of :attr:`LandingRun.reference`: the low-level reference (rad, rad/s,
#: rad/s²) and the command it produced (N, N·m), one row per 500 Hz job.
REFERENCE_COLUMNS = ["time", "phi_ref", "theta_ref", "dphi_ref", "dtheta_ref", "ddphi_ref", "ddtheta_ref",
                     "f_R_cmd", "tau_R_cmd"]


def plant_signals(sim: Simulation, plant_name: str, wind_on: bool, params) -> pd.DataFrame:
    """The logged outputs ``y.*`` of plant *plant_name* as a wide table (column ``time``
    then one column per output, prefix dropped) plus the wind force ``wind`` [N]
    (zero when *wind_on* is false) of the vehicle *params*, from *sim*'s signals trace."""
    df = sim.trace.signals()
    df = df[df["source"] == plant_name]
    df = df[df["signal"].astype(str).str.startswith("y.")]
    wide = df.pivot_table(index="time", columns="signal", values="value", aggfunc="last", observed=True)
    wide.columns = [str(c)[2:] for c in wide.columns]
    wide = wide.reset_index()
    wd = wind_disturbance(params)
    wide["wind"] = [float(wd(t)[0]) if wind_on else 0.0 for t in wide["time"]]
    return wide


@dataclass
class LandingRun:
    """Result of :func:`~netcosim.controllers.landing.run_landing`.

    ``signals``: wide DataFrame sampled every ``log_interval`` s, columns ``time,
    phi, dphi, theta, dtheta, f_R, tau_R, f_L, d_PG1, d_PG2, f_RF, wind`` (plant
    outputs, SI units, radians); ``steps``: one row per NMPC job (``time`` of the
    sample, ``status``, ``success``, ``fallback``, ``qp_iter``, ``t_feedback``,
    ``t_prepare`` wall-clock seconds, ``c_feedback``, ``c_prepare`` simulated CPU
    seconds); ``reference``: the 500 Hz reference of the low-level task (2LC only,
    :data:`REFERENCE_COLUMNS`); ``jobs``/``schedule``: kernel traces; ``sim``: the
    simulation; ``cpu_times``: every CPU time charged to the NMPC
    (:meth:`netcosim.cputime.CPUTimeModel.record`: replay it with
    :class:`~netcosim.cputime.RecordedCPUTime` to reproduce the run);
    ``reproducible``: False when the CPU times were measured on the wall clock;
    ``scenario``: the :class:`~netcosim.controllers.landing.LandingScenario` that was run;
    ``controller``: ``"nmpc"`` or ``"2lc"``; ``wind``: whether the wind acted; ``nmpc``:
    the :class:`~netcosim.controllers.nmpc.rti.RTINMPC` used; ``fl``: the low-level
    feedback-linearization controller (2LC; None otherwise); ``meta``: the run's
    parameters, tuning, timing, topology, ``nmpc_init`` and NMPC re-initialisation count.
    The ``t_feedback``/``t_prepare`` columns of ``steps`` are the solver's own
    wall-clock diagnostics; only ``c_feedback``/``c_prepare`` enter the simulation.
    """

    controller: str
    wind: bool
    signals: pd.DataFrame
    steps: pd.DataFrame
    reference: pd.DataFrame
    jobs: pd.DataFrame
    schedule: pd.DataFrame
    sim: Simulation
    nmpc: Any
    fl: Any = None
    meta: dict = field(default_factory=dict)
    cpu_times: pd.DataFrame | None = None
    reproducible: bool = True
    scenario: Any = None

    def to_pandas(self) -> pd.DataFrame:
        """The plant signals as one tidy table: one row per logged instant, columns
        ``controller``, ``wind_on``, then those of :attr:`signals` (``time`` [s],
        angles [rad], rates [rad/s], forces [N], torques [N·m], distances [m])."""
        s = self.signals.copy()
        s.insert(0, "controller", self.controller)
        s.insert(1, "wind_on", self.wind)
        return s

    def plot(self, axes=None, *, label: str | None = None, targets: bool = True, wind: bool = True,
             **line_kw):
        """Plot φ, ϑ, φ̇, ϑ̇ [deg, deg/s] against time [s] as in Fig. 2.8.

        ``axes``: a 2 × 2 array of Matplotlib axes to draw into (default: a new figure),
        so that several runs share one figure.  ``label``: legend entry (default the
        controller's name).  ``targets``: draw φ* = -α and ϑ* = α.  ``wind``: draw the
        wind force [N] on a second axis of the φ panel when the run had wind.
        ``line_kw``: passed to :meth:`matplotlib.axes.Axes.plot`.  Returns ``axes``.
        """
        import matplotlib.pyplot as plt
        if axes is None:
            _, axes = plt.subplots(2, 2, figsize=(11, 6), sharex=True)
        axes = np.asarray(axes)
        label = self.controller.upper() if label is None else label
        s = self.signals
        for ax, col in zip(axes.ravel(), ("phi", "theta", "dphi", "dtheta")):
            ax.plot(s["time"], np.degrees(s[col]), label=label, **line_kw)
        if targets:
            alpha = math.degrees(self.meta["params"].alpha)
            axes[0, 0].axhline(-alpha, color="gold", lw=1.5, label="$\\varphi^*$")
            axes[0, 1].axhline(alpha, color="gold", lw=1.5, label="$\\vartheta^*$")
        if wind and self.wind:
            ax2 = axes[0, 0].twinx()
            ax2.plot(s["time"], s["wind"], color="grey", lw=1)
            ax2.set_ylabel("wind force [N]", color="grey")
        for ax, lab in zip(axes.ravel(), ["elevation φ [deg]", "attitude ϑ [deg]", "φ̇ [deg/s]", "ϑ̇ [deg/s]"]):
            ax.set_ylabel(lab)
            ax.grid(alpha=0.3)
            ax.legend(loc="best", fontsize=8)
        for ax in axes[1]:
            ax.set_xlabel("time [s]")
        return axes


def landing_metrics(run: LandingRun, tol_deg: float = 1.0) -> dict:
    """Summary numbers of a landing run (angles in degrees, times in s, SI otherwise).

    ``t_reach``: first instant both ``|φ - φ*|`` and ``|ϑ - ϑ*|`` are within *tol_deg*;
    ``t_settle``: instant after which they stay within it until the end (NaN if never);
    ``rms_phi``, ``rms_theta``: RMS over the run of the errors against the final
    reference (φ* = -α, ϑ* = α); ``rms`` = sqrt(mean(e_φ² + e_ϑ²)); extremes of the
    thrust, torque, cable stress and propeller–ground distances; QP fallbacks.
    """
    s = run.signals
    alpha = run.meta["params"].alpha
    e_phi = np.degrees(s["phi"].to_numpy() + alpha)
    e_theta = np.degrees(s["theta"].to_numpy() - alpha)
    t = s["time"].to_numpy()
    inside = (np.abs(e_phi) <= tol_deg) & (np.abs(e_theta) <= tol_deg)
    t_reach = float(t[np.argmax(inside)]) if inside.any() else math.nan
    if inside[-1]:
        outside = np.nonzero(~inside)[0]
        t_settle = float(t[outside[-1] + 1]) if outside.size else float(t[0])
    else:
        t_settle = math.nan
    steps = run.steps
    return dict(
        controller=run.controller, wind=run.wind, t_reach=t_reach, t_settle=t_settle,
        phi_final=float(np.degrees(s["phi"].iloc[-1])), theta_final=float(np.degrees(s["theta"].iloc[-1])),
        rms_phi=float(np.sqrt(np.mean(e_phi ** 2))), rms_theta=float(np.sqrt(np.mean(e_theta ** 2))),
        rms=float(np.sqrt(np.mean(e_phi ** 2 + e_theta ** 2))),
        f_R_min=float(s["f_R"].min()), f_R_max=float(s["f_R"].max()),
        tau_R_min=float(s["tau_R"].min()), tau_R_max=float(s["tau_R"].max()),
        f_L_min=float(s["f_L"].min()), f_L_max=float(s["f_L"].max()),
        d_PG_min=float(min(s["d_PG1"].min(), s["d_PG2"].min())),
        n_steps=int(len(steps)), n_fallback=int(steps["fallback"].sum()) if len(steps) else 0,
        qp_iter_max=int(steps["qp_iter"].max()) if len(steps) else 0,
    )
