"""The DC servo as an FMU, through the same networked loop as the Python servo.

TrueTime's networked servo (``networked_servo``: sensor and actuator on one node, a PID on
another, CSMA/CD at 80 kbit/s shared with an interferer offering 30 % of the bandwidth)
runs four times with one seed, with the plant

* ``python``: :class:`netcosim.plants.dc_servo.DCServo` (RK4, 0.1 ms);
* ``me2``, ``me3``: the DC servo as a model-exchange FMU (FMI 2.0, 3.0), integrated by the
  same RK4;
* ``cs2``, ``cs3``: the DC servo as a co-simulation FMU (FMI 2.0, 3.0), stepped by doStep to
  the loop's I/O instants (RK4 inside the FMU, 1 ms sub-steps).

The FMUs are compiled from C with gcc (:mod:`netcosim.fmi.demo`; FMPy is needed:
``pip install 'netcosim[fmi]'``).  Same seed, so the same network: the outputs must agree to
the integrators' error, which the run prints (``max |y - y_python|``) with the control cost.

Run: ``python -m netcosim.experiments.fmu_servo`` (PNG + Parquet under results/fmu_servo/).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim import RK4, Simulation
from netcosim.controllers.networked_loop import networked_loop
from netcosim.controllers.pid import PID
from netcosim.network import CSMACD
from netcosim.plants.dc_servo import DCServo

from .networked_servo import CONTROL_EXEC, DATA_RATE, FRAME_BITS, IO_EXEC, PERIOD
from .servo import square_wave

SHARE = 0.3        # the interferer's share of the bandwidth (0.4 destabilises the loop)
PLANTS = ("python", "me2", "me3", "cs2", "cs3")


def plant_system(kind: str, fmus: dict):
    """``(system, x0, integrator)`` of the servo as *kind* (see the module's text)."""
    from netcosim.fmi import CoSimulationFMU, ModelExchangeFMU
    if kind == "python":
        return DCServo(), [0.0, 0.0], RK4(dt=1e-4)
    version = int(kind[-1])
    if kind.startswith("me"):
        me = ModelExchangeFMU(fmus[version], name="servo")
        return me, me.x0, RK4(dt=1e-4)
    cs = CoSimulationFMU(fmus[version], name="servo")
    return cs, cs.x0, None


def build(kind: str, fmus: dict, seed: int = 0):
    """The networked servo with the plant *kind*; returns the simulation."""
    sim = Simulation(seed=seed)
    system, x0, integrator = plant_system(kind, fmus)
    servo = sim.plant(system, x0, name="servo", integrator=integrator, log_interval=1e-3, log="none")
    net = CSMACD(sim, "net", data_rate=DATA_RATE, min_frame_bits=FRAME_BITS)
    sensor, controller, interferer = sim.node("sensor"), sim.node("controller"), sim.node("interferer")
    s_if = net.attach(sensor, priority=2)
    c_if = net.attach(controller, priority=1)
    net.attach(interferer, priority=0)
    net.attach("sink", mailbox=False)
    reference = square_wave(amplitude=1.0, period=1.0)
    networked_loop(servo, sensor, controller, s_if, c_if, law=PID(h=PERIOD).compute, reference=reference,
                   period=PERIOD, io_exec=IO_EXEC, control_exec=CONTROL_EXEC, frame_bits=FRAME_BITS)
    mean_gap = FRAME_BITS / (SHARE * DATA_RATE)

    @interferer.aperiodic(priority=1, name="traffic")
    def traffic(ctx):
        while True:
            yield ctx.sleep(float(ctx.rng.exponential(mean_gap)))
            ctx.send("sink", None, FRAME_BITS)

    traffic.release()
    sim.reference = reference
    return sim


def main(outdir: str = "results/fmu_servo", quick: bool = False) -> pd.DataFrame:
    """Run the five plants for 2 s (0.5 s if *quick*); write the outputs' plot and a table.

    Returns the table: per plant, the control cost ``integral (r - y)^2 dt`` and the largest
    difference of its output from the Python plant's on the 1 ms log grid."""
    from netcosim.fmi.demo import build_fmu
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    until = 0.5 if quick else 2.0
    outputs = {}
    with tempfile.TemporaryDirectory() as tmp:
        fmus = {v: build_fmu("servo", v, tmp) for v in (2, 3)}
        for kind in PLANTS:
            sim = build(kind, fmus)
            sim.run(until)
            sig = sim.trace.signals()
            y = sig[(sig["source"] == "servo") & (sig["signal"] == "y.y")]
            outputs[kind] = (y["time"].to_numpy(), y["value"].to_numpy())
    t_ref, y_ref = outputs["python"]
    r = np.array([square_wave(1.0, 1.0)(t) for t in t_ref])
    rows = []
    for kind, (t, y) in outputs.items():
        rows.append({"plant": kind, "samples": len(y), "cost": float(np.trapezoid((r - y) ** 2, t)),
                     "max_diff_from_python": float(np.max(np.abs(y - y_ref)))})
    table = pd.DataFrame(rows)
    table.to_parquet(out / "summary.parquet")
    fig, (ax, ax_d) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for kind, (t, y) in outputs.items():
        ax.plot(t, y, label=kind, lw=1.0)
        if kind != "python":
            ax_d.semilogy(t, np.maximum(np.abs(y - y_ref), 1e-17), label=kind, lw=0.8)
    ax.step(t_ref, r, "k--", where="post", lw=0.8, label="reference")
    ax.set_ylabel("angle y (rad)")
    ax.legend(ncol=3, fontsize=8)
    ax.set_title(f"networked DC servo, CSMA/CD with {SHARE:.0%} interference: Python plant and FMUs")
    ax_d.set_ylabel("|y - y_python| (rad)")
    ax_d.set_xlabel("time (s)")
    ax_d.legend(ncol=4, fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "fmu_servo.png", dpi=120)
    plt.close(fig)
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/fmu_servo", quick="simulate 0.5 s instead of 2 s").parse_args()
    print(main(a.outdir, quick=a.quick).to_string(index=False))
