"""FMU plant overhead: the cost of one plant advance of the DC servo as an FMU against the
same plant in Python, as ratios measured in one run (absolute times on shared machines are
noisy; the ratios are not).

Each case runs the same loop: a periodic task (10 ms) reads the output and writes the input,
for 20 s simulated (2000 reads and 2000 writes, i.e. 4000 plant advances).  The plant is

* ``python``: :class:`netcosim.plants.dc_servo.DCServo` under ``RK4(dt=1e-3)`` (baseline);
* ``me2`` / ``me3``: the model-exchange FMU (FMI 2 / 3) under the same RK4 (FMPy calls for
  every derivative and output);
* ``cs2`` / ``cs3``: the co-simulation FMU (FMI 2 / 3), one ``doStep`` per advance (RK4 with
  1 ms sub-steps inside the FMU, in C).

Reported: CPU time per plant advance (us) and its ratio to the Python plant.  The FMUs are
compiled from C with gcc first (:mod:`netcosim.fmi.demo`).

Run: ``python -m benchmarks.fmu_overhead``.
"""

from __future__ import annotations

import tempfile
import time

from netcosim import Simulation
from netcosim.plant import RK4
from netcosim.plants.dc_servo import DCServo

SIM_TIME = 20.0
PERIOD = 0.01


def _run(system, x0, integrator) -> float:
    """CPU seconds of the loop (building the simulation excluded)."""
    sim = Simulation(seed=0)
    plant = sim.plant(system, x0, name="servo", integrator=integrator, log="none")
    out, inp = plant.output("y"), plant.input("u")

    def body(ctx):
        y = float(out.read())
        yield ctx.execute(0.002)
        inp.write(0.02 * (1.0 - y))
    sim.node("cpu").periodic(body, period=PERIOD, name="ctl", priority=1)
    t0 = time.process_time()
    sim.run(SIM_TIME)
    return time.process_time() - t0


def main() -> None:
    from netcosim.fmi import CoSimulationFMU, ModelExchangeFMU
    from netcosim.fmi.demo import build_fmu
    advances = 2 * round(SIM_TIME / PERIOD)
    with tempfile.TemporaryDirectory() as tmp:
        paths = {v: build_fmu("servo", v, tmp) for v in (2, 3)}
        cases = {
            "python": lambda: (DCServo(), [0.0, 0.0], RK4(dt=1e-3)),
            "me2": lambda: (lambda s: (s, s.x0, RK4(dt=1e-3)))(ModelExchangeFMU(paths[2])),
            "me3": lambda: (lambda s: (s, s.x0, RK4(dt=1e-3)))(ModelExchangeFMU(paths[3])),
            "cs2": lambda: (lambda s: (s, s.x0, None))(CoSimulationFMU(paths[2])),
            "cs3": lambda: (lambda s: (s, s.x0, None))(CoSimulationFMU(paths[3])),
        }
        best = {name: min(_run(*make()) for _ in range(3)) for name, make in cases.items()}
    base = best["python"]
    print(f"{'plant':8s} {'us/advance':>11s} {'ratio':>7s}   ({advances} advances, {SIM_TIME:g} s simulated, "
          f"best of 3)")
    for name, t in best.items():
        print(f"{name:8s} {1e6 * t / advances:11.1f} {t / base:7.2f}")


if __name__ == "__main__":
    main()
