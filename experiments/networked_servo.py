"""TrueTime's networked example: a DC servo closed over a shared network with interference.

Nodes (TrueTime's "networked" demo, with sensor and actuator on one node):

* ``sensor`` -- a periodic task (h = 10 ms) samples the servo angle and sends it with
  the sampling instant to the controller; a receive handler task writes the control
  signal it gets back to the servo (zero-order hold);
* ``controller`` -- an event-driven task released by each arriving measurement runs
  TrueTime's PID (K = 0.96, Ti = 0.12, Td = 0.049, beta = 0.5, N = 10) for 0.5 ms of
  CPU and sends the control signal back;
* ``interferer`` -- sends 80-bit frames with exponential inter-arrival times to a passive
  ``sink`` station; its *share* is the fraction of the bandwidth it offers.

The network runs at 80 kbit/s with 80-bit frames (1 ms per frame): CSMA/CD (TrueTime's
semantics, 80-bit minimum frame, hence 1 ms backoff slots) or CAN (interferer frames
with the highest priority, as in a bus shared with a more important stream).  The control
cost ``J = integral of (r - y)^2 dt`` grows with the interferer's share.

Run: ``python -m netcosim.experiments.networked_servo`` (PNG + Parquet under results/networked_servo/).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim import RK4, Simulation
from netcosim.controllers.networked_loop import networked_loop
from netcosim.controllers.pid import PID
from netcosim.network import CAN, CSMACD
from netcosim.network.plot import plot_network_schedule
from netcosim.plants.dc_servo import DCServo
from netcosim.plot import plot_schedule

from .servo import square_wave

DATA_RATE = 80e3        # bit/s
FRAME_BITS = 80         # bits per message
PERIOD = 0.010          # sampling period (s)
CONTROL_EXEC = 0.0005   # PID execution time (s)
IO_EXEC = 0.0002        # sampling / actuation task execution (s)


def build(network: str = "csma_cd", share: float = 0.0, seed: int = 0, log_interval: float = 1e-3):
    """Assemble the scenario; returns ``(sim, net)``.  ``network``: ``"csma_cd"`` or ``"can"``."""
    if not 0.0 <= share < 1.0:
        raise ValueError(f"interferer share must be in [0, 1), got {share!r}")
    sim = Simulation(seed=seed)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=RK4(dt=1e-4),
                      log_interval=log_interval, log="none")
    if network == "csma_cd":
        net = CSMACD(sim, "net", data_rate=DATA_RATE, min_frame_bits=FRAME_BITS)
    elif network == "can":
        net = CAN(sim, "net", data_rate=DATA_RATE)
    else:
        raise ValueError(f"network must be 'csma_cd' or 'can', got {network!r}")
    sensor = sim.node("sensor")
    controller = sim.node("controller")
    interferer = sim.node("interferer")
    s_if = net.attach(sensor, priority=2)          # measurements
    c_if = net.attach(controller, priority=1)      # control signals
    net.attach(interferer, priority=0)             # on CAN the interfering stream wins arbitration
    net.attach("sink", mailbox=False)
    reference = square_wave(amplitude=1.0, period=1.0)
    pid = PID(h=PERIOD)
    networked_loop(servo, sensor, controller, s_if, c_if, law=pid.compute, reference=reference, period=PERIOD,
                   io_exec=IO_EXEC, control_exec=CONTROL_EXEC, frame_bits=FRAME_BITS)

    if share > 0.0:
        mean_gap = FRAME_BITS / (share * DATA_RATE)

        @interferer.aperiodic(priority=1, name="traffic")
        def traffic(ctx):
            rng = ctx.rng
            while True:
                yield ctx.sleep(float(rng.exponential(mean_gap)))
                ctx.send("sink", None, FRAME_BITS)

        traffic.release()
    sim.reference = reference
    return sim, net


def control_cost(sim, until: float) -> float:
    """``J = integral_0^until (r - y)^2 dt`` from the plant log (trapezoidal rule)."""
    sig = sim.trace.signals()
    y = sig[(sig["source"] == "servo") & (sig["signal"] == "y.y")]
    t = y["time"].to_numpy()
    e2 = (np.array([sim.reference(ti) for ti in t]) - y["value"].to_numpy()) ** 2
    keep = t <= until
    return float(np.trapezoid(e2[keep], t[keep]))


def run_one(network: str, share: float, until: float, seed: int = 0):
    sim, net = build(network, share, seed=seed)
    sim.run(until=until)
    sig = sim.trace.signals()
    delay = sig[(sig["source"] == "sensor.actuate") & (sig["signal"] == "delay")]["value"]
    fr = net.frames()
    return sim, {
        "network": network, "share": share, "seed": seed, "cost": control_cost(sim, until),
        "mean_delay": float(delay.mean()) if len(delay) else float("nan"),
        "max_delay": float(delay.max()) if len(delay) else float("nan"),
        "actuations": int(len(delay)),
        "collisions": int((fr["outcome"] == "collision").sum()),
    }


def main(outdir: str = "results/networked_servo", quick: bool = False) -> pd.DataFrame:
    """Sweep the interferer's share on CSMA/CD and CAN; write plots and a summary table.

    Full run: shares 0 to 0.7, three seeds each, 3 s.  ``quick``: shares 0 and 0.6,
    one seed, 1.5 s.  Returns the per-run table (also ``summary.parquet``).
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    until = 1.5 if quick else 3.0
    shares = (0.0, 0.6) if quick else (0.0, 0.2, 0.4, 0.5, 0.6, 0.7)
    seeds = (0,) if quick else (0, 1, 2)
    rows, outputs = [], {}
    for network in ("csma_cd", "can"):
        for share in shares:
            print(f"  {network}, interferer share {share}: {len(seeds)} run(s) of {until} s", flush=True)
            for seed in seeds:
                sim, row = run_one(network, share, until, seed=seed)
                rows.append(row)
                if seed != seeds[0]:
                    continue
                sig = sim.trace.signals()
                outputs[(network, share)] = sig[(sig["source"] == "servo") & (sig["signal"] == "y.y")]
                if share == 0.6:
                    window = (0.0, 0.1)
                    plot_schedule(sim.trace.schedule(), t_range=window, path=out / f"{network}_schedule.png",
                                  title=f"{network}, interferer share {share}: task schedule")
                    plot_network_schedule(sim.trace.frame("network_schedule"), network="net", t_range=window,
                                          frames=sim.trace.frame("frames"),
                                          path=out / f"{network}_network_schedule.png",
                                          title=f"{network}, interferer share {share}: network schedule")
                    sim.trace.to_parquet(out, prefix=f"{network}_{share}_")
    runs = pd.DataFrame(rows)
    runs.to_parquet(out / "summary.parquet", index=False)
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    r = square_wave(amplitude=1.0, period=1.0)
    t = np.linspace(0, until, 2000)
    for ax, network in zip(axes, ("csma_cd", "can")):
        ax.plot(t, [r(x) for x in t], "k--", lw=0.8, label="reference")
        for share in shares:
            y = outputs[(network, share)]
            ax.plot(y["time"], y["value"], lw=1.0, label=f"share {share}")
        ax.set_ylim(-2.5, 2.5)
        ax.set_ylabel("angle [rad]")
        ax.set_title(f"{network}: servo output (seed {seeds[0]})")
        ax.legend(loc="lower right", fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(out / "outputs.png", dpi=120)
    plt.close(fig)
    mean = runs.groupby(["network", "share"], as_index=False)[["cost", "mean_delay"]].median()
    fig, ax = plt.subplots(figsize=(6, 4))
    for network, g in mean.groupby("network"):
        ax.semilogy(g["share"], g["cost"], "o-", label=network)
    ax.set_xlabel("interferer bandwidth share")
    ax.set_ylabel("median J = ∫(r − y)² dt")
    ax.set_title("control cost vs interference (large J: unstable loop)")
    ax.legend()
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(out / "cost.png", dpi=120)
    plt.close(fig)
    print(mean.to_string(index=False))
    return runs


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/networked_servo",
                          quick="shares 0 and 0.6, one seed, 1.5 s (instead of six shares, three seeds, 3 s)"
                          ).parse_args()
    main(a.outdir, a.quick)
