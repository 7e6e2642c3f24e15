"""The networked servo with its controller in a real process, over Zenoh (hardware in the loop).

The scenario of ``netcosim.experiments.networked_servo`` (CSMA/CD at 80 kbit/s, no interferer):
the plant, the sensor node and the network are simulated in real time; the
``controller`` node is remote: ``netcosim.experiments.hil_servo_controller`` runs its PID in a
separate OS process, connected over a hermetic Zenoh session (loopback, port chosen by
the OS, a fresh run id).  The script starts that process itself (``--no-spawn``: it
prints the command and waits for you to start it, e.g. on a board), runs the
simulation in real time, then the same scenario all-simulated, and writes both
outputs (``outputs.png``), the comparison (``summary.parquet``), the ``hil`` trace
table and the real-time lateness histogram.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd

from netcosim.transport.harness import RemoteRun, remote_command, run_with_remote
from netcosim.transport.remote import RemoteNode
from netcosim.transport.session import LOOPBACK, new_run_id, open_session

from . import networked_servo
from .networked_servo import FRAME_BITS

ROOT = Path(__file__).resolve().parent.parent


#: what the remote controller exchanges (handed to the process by the info query)
SCHEMA = {"request": ["t_sample [s]", "y [rad]"], "reply": ["t_sample [s]", "u [V]"]}


def controller_command(run: str, endpoints: Sequence[str], *, node: str = "controller", idle: float = 10.0,
                       lease: float = 1.0, session: int | None = None, python: str = sys.executable) -> list[str]:
    """The command that starts the remote controller process for run *run* (and session
    *session*, if given)."""
    return remote_command([python, "-m", "netcosim.experiments.hil_servo_controller", "--idle", repr(idle)],
                          run=run, node=node, endpoints=endpoints, lease=lease, session=session)


def attach_controller(sim, session, run: str, **options: Any) -> RemoteNode:
    """Make node ``controller`` of a networked-servo *sim* remote: requests every 10 ms
    (the sensor's period, the default deadline), replies of 2 values; *options* go to
    :class:`~netcosim.transport.remote.RemoteNode` (``loss_policy``, ``deadline``,
    ``abort_on``, ``max_lag``, ...)."""
    return RemoteNode(sim, "controller", session, run=run, size_bits=FRAME_BITS, period=networked_servo.PERIOD,
                      reply_values=2, schema=SCHEMA, **options)


class HilRun(RemoteRun):
    """One hardware-in-the-loop run of the networked servo (``remote``: the
    :class:`~netcosim.transport.remote.RemoteNode` of the controller; the fields of
    :class:`~netcosim.transport.harness.RemoteRun`)."""

    def output(self) -> pd.DataFrame:
        """The servo angle: columns ``time`` (s) and ``value`` (rad)."""
        return servo_output(self.sim)


def servo_output(sim) -> pd.DataFrame:
    """The servo angle of a networked-servo simulation: ``time`` (s), ``value`` (rad)."""
    sig = sim.trace.signals()
    y = sig[(sig["source"] == "servo") & (sig["signal"] == "y.y")]
    return y[["time", "value"]].reset_index(drop=True)


def run_hil(until: float, *, spawn: bool = True, loss_policy: Any = "hold", kill_at: float | None = None,
            lease: float = 1.0, connect_timeout: float = 20.0, max_lag: float = 0.005,
            listen: Sequence[str] = (LOOPBACK,), connect: Sequence[str] = (), seed: int = 0,
            stop_signal: int | None = None, before_run: Any = None, program: Sequence[str] | None = None,
            zenoh_config: str | None = None, **remote_options: Any) -> HilRun:
    """Run the networked servo for *until* s of real time with the controller remote.

    ``spawn``: start the controller process here (else print its command and wait up to
    ``connect_timeout`` s for it); ``kill_at``: simulated time (s) at which the process
    gets ``stop_signal`` (default SIGKILL), to exercise the ``loss_policy``; ``lease``:
    liveliness lease (s) of both sessions; ``max_lag``: lateness (s) counted as an overrun;
    ``before_run(session, remote)``: called once the process is connected, before the run;
    ``program``: another controller program (its command line without the options
    :func:`~netcosim.transport.harness.remote_command` appends); ``zenoh_config``: a Zenoh
    configuration file for both sides; *remote_options*: more
    :class:`~netcosim.transport.remote.RemoteNode` options (``deadline``, ``abort_on``, ...).
    """
    import signal
    run = new_run_id()
    kw = {} if zenoh_config is None else {"config": zenoh_config}
    session = open_session(listen=listen, connect=connect, lease=lease, **kw)
    try:
        sim, _net = networked_servo.build("csma_cd", 0.0, seed=seed)
        remote = attach_controller(sim, session, run, loss_policy=loss_policy, max_lag=max_lag, **remote_options)
        if program is None:
            cmd = controller_command(run, session.endpoints, lease=lease, session=remote.session_id)
        else:
            cmd = remote_command(program, run=run, node="controller", endpoints=session.endpoints, lease=lease,
                                 session=remote.session_id)
        if zenoh_config is not None:
            cmd += ["--zenoh-config", str(zenoh_config)]
        info = run_with_remote(
            sim, remote, until, cmd, spawn=spawn, connect_timeout=connect_timeout, cwd=ROOT,
            before_run=None if before_run is None else lambda: before_run(session, remote),
            signal_at=None if kill_at is None else (kill_at, signal.SIGKILL if stop_signal is None else stop_signal))
        return HilRun.of(info)
    finally:
        session.close()


def run_simulated(until: float, *, seed: int = 0):
    """The all-simulated networked servo (the controller's 0.5 ms of CPU time simulated)."""
    sim, _ = networked_servo.build("csma_cd", 0.0, seed=seed)
    sim.run(until=until)
    return sim


def deviation(a: pd.DataFrame, b: pd.DataFrame) -> float:
    """Largest ``|a - b|`` of two outputs on *a*'s time grid (b interpolated linearly)."""
    return float(np.max(np.abs(a["value"].to_numpy() - np.interp(a["time"], b["time"], b["value"]))))


def run_replay(until: float, requests: Any, *, seed: int = 0):
    """The all-simulated networked servo replaying a HIL run's timing: the controller
    computes for the *k*-th measurement it receives only if request ``seq == k`` was
    published to the process, and answers it after the measured response time if a reply
    was applied (none otherwise).  *requests*: the remote's
    :meth:`~netcosim.transport.remote.RemoteNode.requests` frame, or response times (s)
    of requests all published and replied, in order.  What the HIL run must reproduce."""
    from netcosim.controllers.pid import PID

    from .servo import square_wave
    if isinstance(requests, pd.DataFrame):
        seen = requests[requests["outcome"].isin(["replied", "expired", "open"])]
        plan = dict(zip(seen["seq"].astype(int).tolist(), seen["response"].astype(float).tolist()))
    else:
        plan = {i: float(d) for i, d in enumerate(requests)}
    sim, net = networked_servo.build("csma_cd", 0.0, seed=seed)
    iface = net.interface("controller")
    pid, ref = PID(h=networked_servo.PERIOD), square_wave(1.0, 1.0)
    k = iter(range(1 << 62))

    def answer(msg):
        d = plan.get(next(k))
        if d is None:                   # never published to the process
            return
        t_sample, y = msg.payload
        u = pid.compute(ref(t_sample), y)
        if not np.isnan(d):
            sim.call_in(d, lambda: iface.send(msg.src, (t_sample, u), FRAME_BITS))

    iface.handlers[:] = [answer]
    iface.use_mailbox = False
    sim.run(until=until)
    return sim


def tolerance(until: float, requests: Any) -> float:
    """How far the HIL output may lie from the all-simulated one (rad): 1.5 times the
    deviation the measured response times alone explain (the all-simulated run replayed
    with them, :func:`run_replay`, against the nominal one), plus 1e-4 rad."""
    nominal = servo_output(run_simulated(until))
    replay = servo_output(run_replay(until, requests))
    return 1.5 * deviation(replay, nominal) + 1e-4


def compare_loss_policies(until: float = 3.0, stop_at: float = 0.5, lease: float = 1.0) -> pd.DataFrame:
    """The loss policies on the servo: the controller process is stopped (SIGSTOP: hung,
    its token goes after the lease) or killed (SIGKILL) at *stop_at* s, for ``"hold"`` and
    ``"zero"``; one row per run: ``fault``, ``policy``, the simulated time the loss was
    declared (``lost_at``, s), requests ``expired`` before it, and the largest deviation of
    the angle from the all-simulated run after the fault (``deviation``, rad) and at the end
    (``final_deviation``, rad)."""
    import signal
    nominal = servo_output(run_simulated(until))
    rows = []
    for fault, sig in (("stopped", signal.SIGSTOP), ("killed", signal.SIGKILL)):
        for policy in ("hold", "zero"):
            run = run_hil(until, loss_policy=policy, kill_at=stop_at, stop_signal=sig, lease=lease)
            ev = run.remote.events()
            lost = ev.loc[ev["event"] == "lost", "time"]
            y = run.output()
            after = y["time"] >= stop_at
            err = np.abs(y["value"].to_numpy() - np.interp(y["time"], nominal["time"], nominal["value"]))
            rows.append({"fault": fault, "policy": policy, "lost_at": float(lost.iloc[0]) if len(lost) else np.nan,
                         "expired": run.remote.expired, "deviation": float(err[after.to_numpy()].max()),
                         "final_deviation": float(err[-1])})
    return pd.DataFrame(rows)


def main(outdir: str = "results/hil_servo", quick: bool = False, spawn: bool = True,
         policies: bool = False) -> pd.DataFrame:
    """Run 5 s (``quick``: 2 s) in real time with the remote controller, compare with the
    all-simulated run; returns the one-row summary (also ``summary.parquet``).  ``policies``:
    also :func:`compare_loss_policies` (``loss_policies.parquet``)."""
    import matplotlib.pyplot as plt
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    until = 2.0 if quick else 5.0
    hil = run_hil(until, spawn=spawn)
    ref = servo_output(run_simulated(until))
    tol = tolerance(until, hil.remote.requests())
    dev = deviation(hil.output(), ref)
    summary = pd.DataFrame([{"until": until, "deviation": dev, "tolerance": tol, **hil.summary()}])
    summary.to_parquet(out / "summary.parquet", index=False)
    hil.save(out)
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(ref["time"], ref["value"], lw=1.0, label="all simulated")
    y = hil.output()
    ax.plot(y["time"], y["value"], "--", lw=1.0, label="controller in a real process (Zenoh)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("angle [rad]")
    ax.set_title(f"networked servo: max deviation {dev:.2e} rad (tolerance {tol:.2e})")
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "outputs.png", dpi=120)
    plt.close(fig)
    print(summary.to_string(index=False))
    if policies:
        table = compare_loss_policies()
        table.to_parquet(out / "loss_policies.parquet", index=False)
        print(table.to_string(index=False))
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    p = experiment_parser(__doc__, "results/hil_servo", quick="2 s instead of 5 s of real time")
    p.add_argument("--no-spawn", action="store_true", help="print the remote command instead of starting it")
    p.add_argument("--policies", action="store_true",
                   help="also compare the loss policies hold and zero with the process stopped or killed at 0.5 s")
    a = p.parse_args()
    main(a.outdir, a.quick, spawn=not a.no_spawn, policies=a.policies)
