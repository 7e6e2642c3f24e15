"""The DC servo and the tethered UAV as FMUs, through the same loops as their Python versions.

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

Second part: the tethered UAV's landing (2LC: NMPC every 10 ms and the low-level controller
every 2 ms on one node, wind on, RK4 0.1 ms) runs with the Python plant
(:class:`netcosim.plants.tethered_uav.TetheredUAV`) and with the UAV as a model-exchange FMU
(FMI 2.0, 3.0) generated from its CasADi model (:mod:`netcosim.plants.tethered_uav_fmu`,
:func:`netcosim.fmi.casadi_fmu.build_casadi_fmu`); the run prints the largest output
difference and the hybrid events' instants (wind edges, touchdown) of each.

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


UAV_PLANTS = ("python", "me2", "me3")


def uav_landing(kind: str, fmus: dict, until: float):
    """The 2LC landing with wind for *until* s with the UAV plant *kind*: ``(times, outputs
    (one column per output), event instants)``."""
    from netcosim.controllers.landing.scenario import LandingScenario
    from netcosim.controllers.landing.topology import build_landing
    from netcosim.fmi import ModelExchangeFMU
    sc = LandingScenario(controller="2lc", wind=True, duration=until)
    system = None if kind == "python" else ModelExchangeFMU(fmus[int(kind[-1])], name="tethered_uav")
    sim, uav, _loop = build_landing(sc, system=system)
    sim.run(until)
    s = sim.trace.signals()
    s = s[(s["source"] == "uav") & s["signal"].str.startswith("y.")]
    cols = [s[s["signal"] == n] for n in dict.fromkeys(s["signal"])]
    return (cols[0]["time"].to_numpy(), np.column_stack([c["value"].to_numpy() for c in cols]),
            [t for t, _ in uav.event_log])


def uav_part(out: Path, quick: bool) -> pd.DataFrame:
    """The UAV's landing for 1.5 s (0.6 s if *quick*: touchdown at 0.47 s) with the three
    plants; writes ``fmu_uav.png`` and ``uav_summary.parquet``; returns the table (per plant:
    samples, largest output difference from the Python plant, event instants)."""
    from netcosim.plants.tethered_uav_fmu import build_uav_fmu
    until = 0.6 if quick else 1.5
    with tempfile.TemporaryDirectory() as tmp:
        fmus = {v: build_uav_fmu(tmp, inputs="forces", wind=True, fmi=v) for v in (2, 3)}
        runs = {kind: uav_landing(kind, fmus, until) for kind in UAV_PLANTS}
    t_ref, y_ref, _ = runs["python"]
    table = pd.DataFrame([{"plant": kind, "samples": len(t), "max_diff_from_python": float(np.max(np.abs(y - y_ref))),
                           "events": ", ".join(f"{e:.6f}" for e in ev)} for kind, (t, y, ev) in runs.items()])
    table.to_parquet(out / "uav_summary.parquet")
    fig, (ax, ax_d) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for kind, (t, y, _) in runs.items():
        ax.plot(t, np.degrees(y[:, 0]), label=f"{kind}: phi", lw=1.0)
        ax.plot(t, np.degrees(y[:, 2]), "--", label=f"{kind}: theta", lw=1.0)
        if kind != "python":
            ax_d.semilogy(t, np.maximum(np.max(np.abs(y - y_ref), axis=1), 1e-17), label=kind, lw=0.8)
    for e in runs["python"][2]:
        ax.axvline(e, color="0.6", lw=0.6)
    ax.set_ylabel("angle (deg)")
    ax.legend(ncol=3, fontsize=8)
    ax.set_title("tethered UAV landing (2LC, wind): Python plant and CasADi-generated FMUs")
    ax_d.set_ylabel("max |y - y_python| over outputs")
    ax_d.set_xlabel("time (s)")
    ax_d.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "fmu_uav.png", dpi=120)
    plt.close(fig)
    return table


def main(outdir: str = "results/fmu_servo", quick: bool = False) -> pd.DataFrame:
    """Run the five servo plants for 2 s (0.5 s if *quick*) and the UAV part (:func:`uav_part`);
    write the outputs' plots and tables (the UAV's: ``uav_summary.parquet``).

    Returns the servo's table: per plant, the control cost ``integral (r - y)^2 dt`` and the
    largest difference of its output from the Python plant's on the 1 ms log grid."""
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
    uav_part(out, quick)
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/fmu_servo", quick="simulate 0.5 s instead of 2 s").parse_args()
    print(main(a.outdir, quick=a.quick).to_string(index=False))
    print(pd.read_parquet(Path(a.outdir) / "uav_summary.parquet").to_string(index=False))
