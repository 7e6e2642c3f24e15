"""Loss sweep of the networked DC servo over 802.11b: frame loss versus message loss.

The loop of experiments/networked_servo.py (TrueTime's PID, h = 10 ms, sensor/actuator
node and controller node) closed over an IEEE 802.11b WLAN at 11 Mbit/s with nothing
else on the air.  The network's ``loss`` is a frame loss probability p, drawn for
every transmitted frame.  Two ways to send:

* ``broadcast``: no ACK, no retry -- every lost frame is a lost message (loss p);
* ``unicast``: ACK and up to 6 transmission attempts (``retry_limit=6``: the first
  attempt plus TrueTime's retry limit of 5 retransmissions) -- a message is lost only
  if all its attempts are, p**6 for independent losses.

Swept: p = 0, 0.1, ..., 0.9 for both modes, 20 seeds each (quick: p = 0, 0.5, 0.9,
3 seeds), with netcosim.sweep.run_sweep.  Per run: the quadratic cost
J = integral of e^2 + 0.01 u^2 dt over 2 s (e = r - y, square-wave reference), IAE,
the measured frame and message loss, and a divergence flag (|y| > 10 rad or a
blown-up integration).

What it shows (full run): broadcast degrades at once (median J 0.555 -> 0.94 at
p = 0.2) and diverges in most runs from p = 0.3; unicast stays within 15 % of the
loss-free J up to p = 0.5 (message loss 1.6 %), then the retries' growing backoff
delays and the remaining losses make it diverge too (p = 0.6).  At p = 0.9 broadcast
most control signals never arrive: the servo stays put and J = 2 (the reference's
own energy), a "good" number that is no control at all.  The message-loss plot shows
the mechanism: measured message loss = p for broadcast, ~ p**6 for unicast.

Output (under --outdir): dataset/ (the sweep's Parquet dataset), cost.png (median J
and quartile band per mode, diverged runs counted), message_loss.png (measured
message loss against frame loss, with p and p**6), summary.parquet.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from netcosim import RK4, Simulation, metrics, validate
from netcosim.controllers.networked_loop import networked_loop
from netcosim.controllers.pid import PID
from netcosim.errors import ConfigurationError
from netcosim.experiments.servo import square_wave  # absolute: the file also loads as "path.py:scenario"
from netcosim.network import WLAN80211b
from netcosim.plants.dc_servo import DCServo

PERIOD = 0.010          # sampling period (s)
CONTROL_EXEC = 0.0005   # PID execution time (s)
IO_EXEC = 0.0002        # sampling / actuation execution time (s)
FRAME_BITS = 400        # payload of each message (bits)
DATA_RATE = 11e6        # bit/s
DURATION = 2.0          # simulated time per run (s)
LOG_INTERVAL = 1e-3     # plant output log (s): the grid of the cost integrals
#: TrueTime's retry limit of 5 counts retransmissions: 6 attempts in netcosim's terms.
RETRY_LIMIT = 6
#: Weight of u^2 in J (rad^2 per V^2).
R_WEIGHT = 0.01
#: |y| beyond this (rad) counts as diverged.
DIVERGENCE_BOUND = 10.0
#: Decimation of the per-run error trajectory (every k-th plant log sample: 20 ms).
TRAJECTORY_EVERY = 20
MODES = ("broadcast", "unicast")
LOSSES = tuple(round(0.1 * k, 1) for k in range(10))
PARAMS = ("loss", "mode")  # the keys of scenario()'s params


def build(loss: float, mode: str, seed: int):
    """The loop on a two-node 802.11b network; returns ``(sim, net, reference)``.

    ``loss``: frame loss probability; ``mode``: ``"broadcast"`` or ``"unicast"``.
    """
    loss = validate.probability(loss, "loss (frame loss probability)")
    validate.choice(mode, "mode", MODES)
    sim = Simulation(seed=seed)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=RK4(dt=1e-4),
                      log_interval=LOG_INTERVAL, log="none")
    net = WLAN80211b(sim, "wlan", data_rate=DATA_RATE, loss=loss, retry_limit=RETRY_LIMIT)
    sensor, controller = sim.node("sensor"), sim.node("controller")
    s_if = net.attach(sensor, position=(0.0, 0.0))
    c_if = net.attach(controller, position=(10.0, 0.0))
    reference = square_wave(amplitude=1.0, period=1.0)
    networked_loop(servo, sensor, controller, s_if, c_if, law=PID(h=PERIOD).compute, reference=reference,
                   period=PERIOD, io_exec=IO_EXEC, control_exec=CONTROL_EXEC, frame_bits=FRAME_BITS,
                   log_reference=False, broadcast=(mode == "broadcast"))
    return sim, net, reference


def _counts(net) -> dict[str, int]:
    """Frames and messages of the run so far: ``attempts`` (frames transmitted),
    ``frames_lost`` (by the loss draw), ``messages`` (finished at their sender: sent,
    acknowledged or dropped) and ``messages_lost`` (of those, never delivered)."""
    fr = net.frames()
    finished = sum(i.stats["sent"] + i.stats["dropped"] for i in net.interfaces.values())
    received = sum(i.stats["received"] for i in net.interfaces.values())
    return {"attempts": int((fr["event"] == "attempt_start").sum()),
            "frames_lost": int((fr["outcome"] == "random_loss").sum()),
            "messages": finished, "messages_lost": finished - received}


def check_params(params: dict) -> None:
    """Raise :class:`~netcosim.errors.ConfigurationError` naming what is wrong with one
    case's *params* (keys, the loss probability, the mode); the sweep calls it for every
    case before any run (``scenario.validate``)."""
    if not isinstance(params, dict):
        raise ConfigurationError(f"params must be a dict with keys {PARAMS}, got {params!r}")
    unknown = sorted(set(params) - set(PARAMS))
    missing = sorted(set(PARAMS) - set(params))
    if unknown or missing:
        raise ConfigurationError(f"params {params!r}: unknown key(s) {unknown}, missing {missing}; "
                                 f"expected {PARAMS}")
    validate.probability(params["loss"], "loss (frame loss probability)")
    validate.choice(params["mode"], "mode", MODES)


def scenario(params: dict, seed: int) -> dict[str, Any]:
    """One run: ``params`` = ``{"loss": p, "mode": "broadcast" | "unicast"}``; ``seed``
    the simulation's root seed.

    Returns the scalars ``J`` (integral of e^2 + 0.01 u^2 dt over 2 s; e in rad, u in V),
    ``IAE`` (rad s), ``frame_loss`` and ``message_loss`` (measured fractions) with the
    counts they come from (``attempts``, ``frames_lost``, ``messages``,
    ``messages_lost``), ``diverged`` (bool), and ``trajectory``: a DataFrame of the error every 20 ms
    (columns ``time`` in s, ``error`` in rad).
    """
    check_params(params)
    sim, net, reference = build(params["loss"], params["mode"], seed)
    for table in ("schedule", "jobs", "network_schedule"):     # only signals and frames are read
        sim.trace.configure(table, mode="off")
    error = None
    try:
        sim.run(until=DURATION)
    except metrics.DIVERGENCE_ERRORS as exc:
        error = exc
    y = sim.trace.signal("servo", "y.y")
    t = y.index.to_numpy()
    e = np.array([reference(x) for x in t]) - y.to_numpy()
    # u is held by the actuator: its value at each plant log instant (0 before the first one)
    u_sig = sim.trace.signals()
    u_sig = u_sig[(u_sig["source"] == "sensor.actuate") & (u_sig["signal"] == "u")]
    tu, uv = u_sig["time"].to_numpy(), u_sig["value"].to_numpy()
    k = np.searchsorted(tu, t, side="right") - 1
    u = np.where(k >= 0, uv[np.maximum(k, 0)], 0.0) if tu.size else np.zeros_like(t)
    c = _counts(net)
    return {
        "J": metrics.quadratic_cost(t, e, u, Q=1.0, R=R_WEIGHT),
        "IAE": metrics.iae(t, e),
        "frame_loss": c["frames_lost"] / c["attempts"] if c["attempts"] else math.nan,
        "message_loss": c["messages_lost"] / c["messages"] if c["messages"] else math.nan,
        **c,
        "diverged": metrics.diverged(y.to_numpy(), DIVERGENCE_BOUND, error=error),
        "trajectory": pd.DataFrame({"time": t[::TRAJECTORY_EVERY], "error": e[::TRAJECTORY_EVERY]}),
    }


#: The parameters the scenario reads (a sweep refuses any other grid key before running).
scenario.params = PARAMS  # type: ignore[attr-defined]
scenario.validate = check_params  # type: ignore[attr-defined]


def main(outdir: str = "results/loss_sweep_servo", quick: bool = False, executor: str = "pool") -> pd.DataFrame:
    """Sweep ``loss`` x ``mode`` over seeds with :func:`netcosim.sweep.run_sweep` into
    ``outdir/dataset`` (resumable: finished runs are kept); write the plots and
    ``summary.parquet``.  Full: losses 0, 0.1, ..., 0.9, 20 seeds; ``quick``: losses 0,
    0.5, 0.9, 3 seeds.  ``executor``: as ``run_sweep``'s (``"pool"``: all cores).
    Returns the runs table.
    """
    import matplotlib.pyplot as plt

    from netcosim.sweep import run_sweep
    from netcosim.sweep.aggregate import plot_sweep, summarize

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    losses = (0.0, 0.5, 0.9) if quick else LOSSES
    seeds = 3 if quick else 20
    # by import path: run as `python -m`, this module is __main__, which workers cannot import
    result = run_sweep("netcosim.experiments.loss_sweep_servo:scenario",
                       grid={"loss": list(losses), "mode": list(MODES)},
                       seeds=seeds, out=out / "dataset", executor=executor)
    runs = result.to_pandas()
    summary = summarize(runs, "loss", "J", hue="mode")
    summary.to_parquet(out / "summary.parquet", index=False)

    ax = plot_sweep(runs, x="loss", y="J", hue="mode", logy=True)
    ax.set_xlabel("frame loss probability p")
    ax.set_title(f"servo over 802.11b: J ({DURATION:g} s), {seeds} seeds per point")
    ax.legend(loc="lower right", fontsize=8)
    ax.figure.tight_layout()
    ax.figure.savefig(out / "cost.png", dpi=120)
    plt.close(ax.figure)

    ok = runs[runs["status"] == "ok"]
    fig, ax = plt.subplots(figsize=(6, 4))
    p = np.linspace(0.0, 0.9, 91)
    ax.plot(p, p, "k--", lw=0.8, label="p (one attempt)")
    ax.plot(p, p ** RETRY_LIMIT, "k:", lw=0.8, label=f"p^{RETRY_LIMIT} ({RETRY_LIMIT} attempts)")
    for mode, g in ok.groupby("mode"):
        ax.plot(g["frame_loss"], g["message_loss"], "o", ms=3, alpha=0.6, label=f"{mode} (measured, per run)")
    ax.set_xlabel("measured frame loss")
    ax.set_ylabel("measured message loss")
    ax.set_title("802.11b: message loss vs frame loss")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "message_loss.png", dpi=120)
    plt.close(fig)
    print(summary.to_string(index=False))
    return runs


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/loss_sweep_servo",
                          quick="losses 0, 0.5, 0.9 and 3 seeds (instead of 0..0.9 and 20 seeds)").parse_args()
    main(a.outdir, a.quick)
