"""TrueTime's servo example: a PID task controlling the DC servo 1000/(s(s+1)).

The task samples the servo angle at job start, computes for ``execution`` seconds of
CPU, then writes the control signal -- so the computational delay (2 ms by default)
appears between sampling and actuation, as in TrueTime.

Run: ``python -m netcosim.experiments.servo`` (writes PNG and Parquet under results/servo/).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from netcosim import RK4, Simulation
from netcosim.controllers.pid import PID
from netcosim.plants.dc_servo import DCServo
from netcosim.plot import plot_schedule, plot_signals


def square_wave(amplitude: float = 1.0, period: float = 1.0):
    """Square reference r(t): +amplitude on the first half of each period, then -amplitude."""
    half = period / 2.0

    def r(t: float) -> float:
        return amplitude if int(np.floor(t / half + 1e-12)) % 2 == 0 else -amplitude
    return r


def add_pid_loop(node, plant, *, period=0.006, execution=0.002, priority=1, name="pid",
                 reference=None, offset=0.0, **task_options):
    """A periodic PID task on *node* controlling *plant* (output 0 -> input 0). Returns the task."""
    pid = PID(h=period)
    r_of_t = reference or square_wave()
    y_port, u_port = plant.output(0), plant.input(0)

    def body(ctx):
        r = r_of_t(ctx.now)
        y = ctx.read(y_port)
        u = pid.compute(r, y)
        ctx.log("r", r)
        ctx.log("y", y)
        yield ctx.execute(execution)
        ctx.write(u_port, u)
        ctx.log("u", u)

    task = node.periodic(body, period=period, priority=priority, name=name, offset=offset, **task_options)
    task.pid = pid
    return task


def build(seed=0, *, integrator=None, period=0.006, execution=0.002, log_interval=None):
    """The servo scenario: one node, one PID task, one DC servo."""
    sim = Simulation(seed=seed)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=integrator or RK4(dt=1e-4),
                      log_interval=log_interval)
    cpu = sim.node("controller", scheduler="fixed_priority")
    add_pid_loop(cpu, servo, period=period, execution=execution)
    return sim


def main(outdir="results/servo", until=2.0, quick=False):
    """Simulate *until* seconds (0.5 s if *quick*); write the trace (Parquet) and two PNGs to *outdir*.

    Returns the :class:`~netcosim.Simulation`.
    """
    if quick:
        until = min(until, 0.5)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    sim = build()
    try:
        sim.run(until=until)
    finally:
        sim.trace.to_parquet(out)
    sig = sim.trace.signals()
    plot_signals(sig, [("controller.pid", "r"), ("controller.pid", "y")], drawstyle="steps-post",
                 path=out / "servo_output.png", title="PID servo: reference and sampled output")
    plot_schedule(sim.trace.schedule(), t_range=(0.0, 0.05), path=out / "servo_schedule.png")
    return sim


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/servo", quick="simulate 0.5 s instead of 2 s").parse_args()
    jobs = main(a.outdir, quick=a.quick).trace.jobs()
    print(f"{len(jobs)} PID jobs, mean response {jobs['response_time'].mean() * 1e3:.3f} ms")
