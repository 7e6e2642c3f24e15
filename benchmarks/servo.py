"""The README quick start: simulated seconds per wall second, RK4 against the exact ZOH step.

The DC servo under a PID task (period 6 ms, 2 ms of execution, 20 µs context switch)
for 1 simulated second, integrated by ``RK4(dt=1e-4)`` (the README's choice) and by
``ExactZOH()`` (exact for this linear plant), measured in the same run; the ratio is
what the exact step saves.  The first run of each is a warm-up (imports, the first
matrix exponentials; ExactZOH's process-wide cache then holds them, as it does for
every run of a sweep after the first).  Each run reports its wall time and the CPU time
of this process (``time.process_time``): on a machine shared with other jobs the wall
time includes waiting for a core, the CPU time does not.  Run: ``python -m benchmarks.servo``.
"""

from __future__ import annotations

import statistics
import time

from netcosim import RK4, ExactZOH, Simulation
from netcosim.controllers.pid import PID
from netcosim.plants.dc_servo import DCServo

UNTIL = 1.0  # simulated seconds per run


def quick_start(integrator) -> tuple[float, float]:
    """(wall s, CPU s) to simulate the README quick start for UNTIL s with *integrator*."""
    sim = Simulation(seed=1)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], integrator=integrator)
    cpu = sim.node("controller", scheduler="fixed_priority", context_switch=20e-6)
    pid = PID(h=0.006)

    @cpu.periodic(period=0.006, priority=1)
    def control(ctx):
        y = ctx.read(servo.output("y"))
        u = pid.compute(1.0, y)
        yield ctx.execute(0.002)
        ctx.write(servo.input("u"), u)

    t0, c0 = time.perf_counter(), time.process_time()
    sim.run(until=UNTIL)
    return time.perf_counter() - t0, time.process_time() - c0


def main(repeats: int = 7) -> dict:
    makers = {"RK4(dt=1e-4)": lambda: RK4(dt=1e-4), "ExactZOH()": ExactZOH}
    for make in makers.values():
        quick_start(make())  # warm-up
    walls: dict[str, list[float]] = {k: [] for k in makers}
    cpus: dict[str, list[float]] = {k: [] for k in makers}
    for _ in range(repeats):  # interleaved, so both see the same machine load
        for k, make in makers.items():
            w, c = quick_start(make())
            walls[k].append(w)
            cpus[k].append(c)
    med = {k: statistics.median(v) for k, v in walls.items()}
    cpu = {k: statistics.median(v) for k, v in cpus.items()}
    print(f"README quick start, {UNTIL:g} simulated s, median of {repeats}")
    print(f"{'integrator':<14} {'wall [ms]':>10} {'x real time':>12} {'CPU [ms]':>9} {'x real time per CPU s':>22}")
    for k, w in med.items():
        print(f"{k:<14} {w * 1e3:>10.1f} {UNTIL / w:>12.1f} {cpu[k] * 1e3:>9.1f} {UNTIL / cpu[k]:>22.1f}")
    print(f"speed-up of ExactZOH over RK4: {med['RK4(dt=1e-4)'] / med['ExactZOH()']:.1f}x (target: ExactZOH "
          f">= 200x real time)")
    return {"wall": med, "cpu": cpu}


if __name__ == "__main__":
    main()
