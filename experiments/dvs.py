"""Dynamic voltage/frequency scaling (DVS) of a control task set: energy saved against control cost.

Three PID loops on DC servos (TrueTime's servo PID, periods 6, 5 and 4 ms as in the
three-servo example) share one CPU under EDF.  Each job needs a random amount of CPU work,
uniform between 40 % and 100 % of its WCET of 0.5 ms at speed 1 (the same draws in every
run: the execution-time streams are named per task), so the worst-case utilisation at speed
1 is U = 0.5/6 + 0.5/5 + 0.5/4 = 0.308.

The CPU's power is :class:`~netcosim.energy.DvsPower` ``P = 0.05 W + busy * 1 W * s^3``
(voltage proportional to frequency, hence the cubic law): a job of work c at speed s costs
``c * s^2`` J of dynamic energy and lasts ``c / s``.  Runs:

* fixed speeds from 1 down to U (the lowest speed at which EDF still meets every deadline
  in the worst case, *static DVS*) and below it (overload);
* *cycle-conserving EDF* (Pillai and Shin, 2001): the speed is the sum of the tasks'
  utilisations, counting a task's WCET from its release until its job finishes and the
  work the job actually used afterwards; each PID job sets it from its own code with
  ``ctx.node.set_speed`` at its start and its end (run-time DVS).

Lowering the speed stretches each job, so the delay from sampling to actuation grows,
while the energy falls roughly with s^2 until the static power over the whole run
dominates.  What it costs in control (sum of the loops' IAE against a square reference):
next to nothing down to U -- this PID was tuned (by TrueTime) for a 2 ms computational
delay, and the longer delays, up to about 2 ms here, even lower the IAE by about 1 % --;
below U (speed 0.2) jobs miss their deadlines and the cost grows.  Cycle-conserving DVS
saves a little more than static DVS (the jobs use 70 % of their WCET on average).

Run: ``python -m netcosim.experiments.dvs`` (PNG + Parquet under results/dvs/).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim import ExactZOH, Simulation
from netcosim.controllers.pid import PID
from netcosim.energy import DvsPower
from netcosim.metrics import iae
from netcosim.plants.dc_servo import DCServo

from .servo import square_wave

PERIODS = (0.006, 0.005, 0.004)
WCET = 0.0005
U_WORST = sum(WCET / h for h in PERIODS)
POWER = DvsPower(static=0.05, dynamic=1.0)


def build(speed: float | None = 1.0, *, seed: int = 0):
    """The task set at a fixed *speed*, or with cycle-conserving DVS if *speed* is None."""
    sim = Simulation(seed=seed)
    cpu = sim.node("cpu", scheduler="edf", speed=1.0 if speed is None else speed)
    cpu.set_power_model(POWER)
    util = {}
    reference = square_wave(amplitude=1.0, period=0.5)

    def set_speed(ctx):
        ctx.node.set_speed(min(1.0, sum(util.values())))

    for i, h in enumerate(PERIODS, start=1):
        servo = sim.plant(DCServo(), x0=[0.0, 0.0], name=f"servo{i}", integrator=ExactZOH())
        pid = PID(h=h)
        y_port, u_port = servo.output(0), servo.input(0)
        name = f"pid{i}"
        util[name] = WCET / h

        def body(ctx, pid=pid, y_port=y_port, u_port=u_port, name=name, h=h):
            work = WCET * float(ctx.rng.uniform(0.4, 1.0))
            if speed is None:           # released: count the WCET until the job is done
                util[name] = WCET / h
                set_speed(ctx)
            r = reference(ctx.now)
            y = ctx.read(y_port)
            u = pid.compute(r, y)
            ctx.log("y", y)
            yield ctx.execute(work)
            ctx.write(u_port, u)
            if speed is None:           # done: count the work actually used
                util[name] = work / h
                set_speed(ctx)
        cpu.periodic(body, period=h, name=name)
    sim.reference = reference
    return sim, cpu


def run_one(speed: float | None, until: float) -> dict:
    sim, cpu = build(speed)
    sim.run(until)
    sig = sim.trace.signals()
    cost = 0.0
    for i in range(1, 4):
        y = sig[(sig["source"] == f"cpu.pid{i}") & (sig["signal"] == "y")]
        cost += float(iae(pd.Series(y["value"].to_numpy(), index=y["time"].to_numpy()),
                          reference=sim.reference, until=until))
    jobs = sim.trace.jobs()
    return {"mode": "cycle-conserving" if speed is None else "fixed",
            "speed": np.nan if speed is None else speed,
            "energy_J": cpu.energy, "iae": cost,
            "misses": int(jobs["deadline_miss"].sum()),
            "mean_response_ms": float(jobs["response_time"].mean() * 1e3)}


def main(outdir="results/dvs", until=1.0, quick=False):
    """Fixed speeds and cycle-conserving DVS for *until* s (0.3 s if *quick*); writes a Parquet table and a
    figure to *outdir*; returns the results table (energy saved against speed 1 in ``saved_%``)."""
    if quick:
        until = min(until, 0.3)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    speeds = [1.0, 0.8, 0.6, 0.45, U_WORST, 0.2]
    rows = [run_one(s, until) for s in speeds] + [run_one(None, until)]
    table = pd.DataFrame(rows)
    table["saved_%"] = 100.0 * (1.0 - table["energy_J"] / table["energy_J"].iloc[0])
    table.to_parquet(out / "dvs.parquet", index=False)

    fixed = table[table["mode"] == "fixed"]
    cc = table[table["mode"] != "fixed"].iloc[0]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(fixed["speed"], fixed["energy_J"] * 1e3, "o-", label="fixed speed")
    ax[0].axhline(cc["energy_J"] * 1e3, color="C1", ls="--", label="cycle-conserving EDF")
    ax[0].axvline(U_WORST, color="grey", ls=":", label=f"U = {U_WORST:.3f}")
    ax[0].set_xlabel("CPU speed")
    ax[0].set_ylabel("CPU energy (mJ)")
    ax[0].legend(fontsize=8)
    ax[1].plot(fixed["speed"], fixed["iae"], "o-", label="fixed speed")
    ax[1].axhline(cc["iae"], color="C1", ls="--", label="cycle-conserving EDF")
    ax[1].axvline(U_WORST, color="grey", ls=":")
    ax[1].set_xlabel("CPU speed")
    ax[1].set_ylabel("control cost (sum of IAE)")
    ax[1].legend(fontsize=8)
    fig.suptitle(f"three PID loops under EDF, {until:g} s: energy against control cost")
    fig.tight_layout()
    fig.savefig(out / "dvs.png", dpi=120)
    plt.close(fig)
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/dvs", quick="simulate 0.3 s instead of 1 s").parse_args()
    with pd.option_context("display.width", 160):
        print(main(a.outdir, quick=a.quick).to_string(index=False))
