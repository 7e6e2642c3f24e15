"""The ch. 2 landing with its 500 Hz low-level controller in a real process, over Zenoh.

The two-layer controller of thesis §2.5 on one node (``topology="single"``, ideal CPU
times): the tethered-UAV plant with landers, the 100 Hz NMPC task and the C²
interpolator of Fig. 2.6 stay simulated; the feedback linearization (2.14)-(2.16) with
PID and feed-forward runs in a separate OS process
(``netcosim.experiments.hil_landing_llc_controller``) against the simulated plant through
:class:`~netcosim.transport.remote.RemotePlantIO` -- the fast local loop, no simulated
network in between.  Every 2 ms of simulated time the simulation publishes the
measured ``φ, φ̇, ϑ, ϑ̇`` followed (``extra``) by the interpolator's reference at that
instant; the process answers with ``(f_R, τ_R)``, written to the plant (zero-order
hold) at the simulated instant of its arrival.

Real time: simulating the plant (RK4 at 0.1 ms, landers) and solving the NMPC take
about 2 s of this machine's time per simulated second, so the run is paced at a
real-time factor (``--factor``, default 10: one simulated second takes 10 s of wall
clock; the process then answers 50 samples per wall-clock second, each sample still
2 ms apart in simulated time, and its round trip counts a tenth in simulated time).
The script starts the process itself (``--no-spawn``: prints its command and waits up
to 10 minutes), runs the landing, then the all-simulated 2LC, and writes
``outputs.png``, ``summary.parquet`` (deviation and its tolerance, response times,
lateness), ``hil_events.parquet`` and ``lateness.parquet`` to the output directory.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd

from netcosim.controllers.landing import LandingScenario
from netcosim.controllers.landing.result import plant_signals
from netcosim.controllers.landing.topology import build_landing, simulate_landing
from netcosim.plants.tethered_uav_params import TetheredUAVParams
from netcosim.timebase import RESOLUTION, to_ticks
from netcosim.transport.harness import RemoteRun, remote_command, run_with_remote
from netcosim.transport.remote import RemotePlantIO
from netcosim.transport.session import LOOPBACK, new_run_id, open_session

ROOT = Path(__file__).resolve().parent.parent
#: the plant outputs a sample carries, before the reference
OUTPUTS = ["phi", "dphi", "theta", "dtheta"]
#: the states compared between runs (rad, rad/s)
STATES = ("phi", "dphi", "theta", "dtheta")
#: default real-time factor (wall-clock seconds per simulated second)
FACTOR = 10.0


def scenario(until: float) -> LandingScenario:
    """The 2LC landing of §2.6.2 on one node, calm, ideal CPU times, *until* s long."""
    return LandingScenario(controller="2lc", topology="single", duration=until)


#: what the low-level process exchanges (handed to it by the info query)
SCHEMA = {"request": ["phi [rad]", "dphi [rad/s]", "theta [rad]", "dtheta [rad/s]", "phi_d [rad]", "theta_d [rad]",
                      "dphi_d [rad/s]", "dtheta_d [rad/s]", "ddphi_d [rad/s2]", "ddtheta_d [rad/s2]"],
          "reply": ["f_R [N]", "tau_R [N m]"]}


def controller_command(run: str, endpoints: Sequence[str], sc: LandingScenario, *, node: str = "uav",
                       idle: float = 10.0, lease: float = 1.0, session: int | None = None,
                       python: str = sys.executable) -> list[str]:
    """The command that starts the low-level controller process for run *run* (and session
    *session*, if given), with the sampling period and PID gains of scenario *sc*."""
    if sc.params != TetheredUAVParams():
        raise ValueError("the low-level process uses the default TetheredUAVParams; "
                         f"the scenario has {sc.params!r}")
    g = sc.fl_gains
    return remote_command([python, "-m", "netcosim.experiments.hil_landing_llc_controller",
                           "--period", repr(sc.fl_period),
                           "--gains", repr(g.kp), repr(g.kd), repr(g.ki), "--idle", repr(idle)],
                          run=run, node=node, endpoints=endpoints, lease=lease, session=session)


def attach_remote_llc(sim, uav, loop, session, *, run: str, factor: float = FACTOR, max_lag: float = 0.005,
                      loss_policy: Any = "hold", **options: Any) -> RemotePlantIO:
    """Make the landing's low-level loop remote: samples every ``fl_period`` s of the
    measured state then the reference (``loop.low_level_reference``), replies written
    to the force inputs; the deadline is the period (simulated: a factor of 10 gives the
    process 20 ms of wall clock).  ``factor``/``max_lag``: the :class:`RealtimeClock`'s;
    *options*: more :class:`RemotePlantIO` options (``deadline``, ``abort_on``, ...)."""
    return RemotePlantIO(sim, uav, session, run=run, period=loop.scenario.fl_period, outputs=OUTPUTS,
                         inputs=None, extra=loop.low_level_reference, loss_policy=loss_policy,
                         factor=factor, max_lag=max_lag, schema=SCHEMA, **options)


def build(until: float = 1.5):
    """The landing for ``netcosim hil`` (``netcosim.experiments.hil_landing_llc:build``): ``(sim,
    uav, loop)`` of :func:`scenario` without the low-level task, to be driven by the
    process through plant ``uav``; pair with ``--extra netcosim.experiments.hil_landing_llc:reference``."""
    import scipy.optimize  # noqa: F401  (see run_hil)
    return build_landing(scenario(until), low_level=False)


def reference(built) -> Any:
    """``extra(t)`` for ``netcosim hil``: the low-level reference of the landing *built*
    by :func:`build` (``loop.low_level_reference``)."""
    return built[2].low_level_reference


@dataclass
class HilLandingRun(RemoteRun):
    """One landing with the remote low-level controller: the fields of
    :class:`~netcosim.transport.harness.RemoteRun` (``remote``: the
    :class:`~netcosim.transport.remote.RemotePlantIO`), ``loop`` (the simulated NMPC's
    :class:`~netcosim.controllers.landing.tasks.LandingLoop`) and ``factor`` (the real-time factor)."""

    loop: Any = None
    factor: float = 1.0

    def output(self) -> pd.DataFrame:
        """The plant's logged outputs (``plant_signals``: ``time`` s, ``phi`` rad, ...)."""
        return landing_output(self.sim)


def landing_output(sim) -> pd.DataFrame:
    """The logged outputs of plant ``uav`` of a landing simulation, one column each."""
    return plant_signals(sim, "uav", False, TetheredUAVParams())


def run_hil(until: float, *, factor: float = FACTOR, spawn: bool = True, lease: float = 1.0,
            connect_timeout: float = 30.0, max_lag: float = 0.005, listen: Sequence[str] = (LOOPBACK,),
            connect: Sequence[str] = (), loss_policy: Any = "hold") -> HilLandingRun:
    """Land for *until* s of simulated time, paced at *factor* wall-clock s per simulated
    s, with the low-level controller in a separate process (started here, or its command
    printed with ``spawn=False``)."""
    # the plant's first event location imports SciPy (0.3-0.5 s): not in the middle of a real-time run
    import scipy.optimize  # noqa: F401
    run = new_run_id()
    session = open_session(listen=listen, connect=connect, lease=lease)
    try:
        sc = scenario(until)
        sim, uav, loop = build_landing(sc, low_level=False)
        io = attach_remote_llc(sim, uav, loop, session, run=run, factor=factor, max_lag=max_lag,
                               loss_policy=loss_policy)
        info = run_with_remote(sim, io, until, controller_command(run, session.endpoints, sc, lease=lease,
                                                                  session=io.session_id),
                               spawn=spawn, connect_timeout=connect_timeout, cwd=ROOT)
        return HilLandingRun.of(info, loop=loop, factor=factor)
    finally:
        session.close()


def run_simulated(until: float):
    """The all-simulated 2LC (the low-level task on the node, zero CPU time)."""
    return simulate_landing(scenario(until)).sim


def run_replay(until: float, requests: Any):
    """The all-simulated landing with the low-level controller sampling like the remote
    one (every ``fl_period`` s, same outputs and reference): sample *k* is computed if
    request ``seq == k`` was published to the process, and its command written after the
    response time (s) measured for it if a reply was applied.  *requests*: the
    :meth:`~netcosim.transport.remote.RemotePlantIO.requests` frame of a HIL run, or
    response times of requests all published and replied, in order.  What the HIL run
    must reproduce bit for bit."""
    if isinstance(requests, pd.DataFrame):
        seen = requests[requests["outcome"].isin(["replied", "expired", "open"])]
        plan = dict(zip(seen["seq"].astype(int).tolist(), seen["response"].astype(float).tolist()))
    else:
        plan = {i: float(d) for i, d in enumerate(requests)}
    sc = scenario(until)
    sim, uav, loop = build_landing(sc, low_level=False)
    y_port, u_port = uav.output(OUTPUTS), uav.input(None)
    period, k = to_ticks(sc.fl_period), iter(range(1 << 62))

    def sample():
        d = plan.get(next(k))
        if d is not None:
            u = loop.low_level_command(sim.now, y_port.read())
            if not np.isnan(d):
                sim.call_in_ticks(round(d / RESOLUTION), lambda: u_port.write(u))
        sim.call_in_ticks(period, sample)
    sim.call_at_ticks(sim.now_ticks, sample)
    sim.run(until=until)
    return sim


def deviation(a: pd.DataFrame, b: pd.DataFrame) -> float:
    """Largest ``|a - b|`` of φ and ϑ (rad) of two landing outputs on the same time grid."""
    return float(max(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy())) for c in ("phi", "theta")))


def tolerance(until: float, requests: Any) -> float:
    """How far the HIL landing may lie from the all-simulated one (rad): 1.5 times the
    deviation the measured response times alone explain (:func:`run_replay` against the
    nominal run), plus 1e-6 rad."""
    nominal = landing_output(run_simulated(until))
    replay = landing_output(run_replay(until, requests))
    return 1.5 * deviation(replay, nominal) + 1e-6


def main(outdir: str = "results/hil_landing_llc", quick: bool = False, spawn: bool = True,
         factor: float = FACTOR) -> pd.DataFrame:
    """Land for 1.5 s (``quick``: 0.5 s) of simulated time with the remote low-level
    controller, compare with the all-simulated 2LC; returns the one-row summary (also
    ``summary.parquet``)."""
    import matplotlib.pyplot as plt
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    until = 0.5 if quick else 1.5
    hil = run_hil(until, factor=factor, spawn=spawn, connect_timeout=30.0 if spawn else 600.0)
    nominal = landing_output(run_simulated(until))
    tol = tolerance(until, hil.remote.requests())
    y = hil.output()
    dev = deviation(y, nominal)
    summary = pd.DataFrame([{"until": until, "factor": factor, "deviation": dev, "tolerance": tol,
                             **hil.summary()}])
    summary.to_parquet(out / "summary.parquet", index=False)
    hil.save(out)
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for ax, c, label in ((axes[0], "phi", "elevation φ [deg]"), (axes[1], "theta", "attitude ϑ [deg]")):
        ax.plot(nominal["time"], np.degrees(nominal[c]), lw=1.0, label="all simulated")
        ax.plot(y["time"], np.degrees(y[c]), "--", lw=1.0, label="low-level controller in a real process (Zenoh)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best")
    axes[1].set_xlabel("time [s]")
    fig.suptitle(f"ch. 2 landing, 2LC: max deviation {dev:.2e} rad (tolerance {tol:.2e}), factor {factor:g}")
    fig.tight_layout()
    fig.savefig(out / "outputs.png", dpi=120)
    plt.close(fig)
    print(summary.to_string(index=False))
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    p = experiment_parser(__doc__, "results/hil_landing_llc", quick="0.5 s instead of 1.5 s of simulated landing")
    p.add_argument("--no-spawn", action="store_true", help="print the remote command instead of starting it")
    p.add_argument("--factor", type=float, default=FACTOR,
                   help=f"wall-clock seconds per simulated second (default {FACTOR:g})")
    a = p.parse_args()
    main(a.outdir, a.quick, spawn=not a.no_spawn, factor=a.factor)
