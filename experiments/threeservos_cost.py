"""TrueTime's three servos, scored by their exact expected cost per loop (``netcosim.lq``).

The three PID loops of :mod:`~netcosim.experiments.threeservos` (periods 6, 5, 4 ms, 2 ms
of execution each, utilisation 1.23) in each of its modes -- deadline monotonic, EDF, EDF
with loop 3 in a constant- or total-bandwidth server -- but instead of one noise
realisation each loop carries an :class:`~netcosim.lq.ExpectedCost`: the task samples and
computes at job start (``execute("sampler", "ctrl")``) and actuates at the end of its 2 ms
segment (``execute("act")``), so the schedule the kernel produces drives the exact mean
and covariance of the loop (plant, PID state, held control).

Model of each loop: the DC servo 1000/(s(s+1)) driven by white noise entering with the
control (``R_c = B Bᵀ``, unit intensity), TrueTime's PID (K = 0.96, Ti = 0.12, Td = 0.049,
N = 10, its nominal h; reference 0, so set-point weighting plays no part) in state-space
form (:func:`pid_system`), cost ``∫ y² dt``; reported as the expected cost per second over
the run.  Under deadline monotonic loop 1 starves and its cost grows without bound; under
EDF every loop keeps a moderate cost; a server caps loop 3 at 25 % of the CPU.

Run: ``python -m netcosim.experiments.threeservos_cost`` (PNG + Parquet under
results/threeservos_cost/).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim import Simulation
from netcosim.lq import ContinuousSystem, DiscreteSystem, ExpectedCost, Interconnection

from . import threeservos as ts

#: DC servo 1000/(s(s+1)): x = (angle, velocity)
A, B, C = [[0.0, 1.0], [0.0, -1.0]], [[0.0], [1000.0]], [[1.0, 0.0]]


def pid_system(h: float, K: float = 0.96, Ti: float = 0.12, Td: float = 0.049, N: float = 10.0) -> DiscreteSystem:
    """TrueTime's PID (:class:`netcosim.controllers.pid.PID`, reference 0) as a discrete
    system of state (I, D, y_old), input y, output u:
    ``D+ = ad D + bd (y_old - y)``, ``u = -K y + I + D+``, ``I+ = I - K h/Ti y``, ``y_old+ = y``."""
    ad = Td / (N * h + Td)
    bd = N * K * Td / (N * h + Td)
    return DiscreteSystem([[1.0, 0.0, 0.0], [0.0, ad, bd], [0.0, 0.0, 0.0]], [[-K * h / Ti], [-bd], [1.0]],
                          [[1.0, ad, bd]], [[-(K + bd)]])


def loop_model(h: float, noise: float = 1.0) -> Interconnection:
    """Plant, sampler, PID and actuator (hold) of one loop of period *h* (s); *noise*: the
    intensity of the white noise entering with the control (0: deterministic)."""
    b = np.asarray(B)
    plant = ContinuousSystem(A, B, C, R_c=noise * (b @ b.T), Q_c=np.diag([1.0, 0.0, 0.0]))
    m = Interconnection()
    m.add("plant", plant, inputs=["act"])
    m.add("sampler", DiscreteSystem.gain([[1.0]]), inputs=["plant"])
    m.add("ctrl", pid_system(h), inputs=["sampler"])
    m.add("act", DiscreteSystem.gain([[1.0]]), inputs=["ctrl"])
    return m


def build(mode: str, *, noise: float = 1.0, m0=None):
    """The three tasks of *mode* (a key of :data:`threeservos.MODES`), each with its
    :class:`ExpectedCost`; returns ``(sim, [ExpectedCost per loop])``.  *m0*: the initial
    mean of each loop's total state (default zero)."""
    policy, server = ts.MODES[mode]
    sim = Simulation()
    cpu = sim.node("cpu", scheduler=policy)
    served: dict = {}
    if server == "cbs":
        served = {"server": cpu.cbs(budget=ts.CBS_BUDGET, period=ts.CBS_PERIOD, name="cbs")}
    elif server == "tbs":
        served = {"server": cpu.tbs(utilization=ts.TBS_UTILIZATION, name="tbs"), "wcet": ts.EXECUTION}
    costs = []
    for i, h in enumerate(ts.PERIODS, start=1):
        ec = ExpectedCost(sim, loop_model(h, noise), m0=m0)
        costs.append(ec)

        def body(ctx, ec=ec):
            ec.execute("sampler", "ctrl")       # sample and compute at job start
            yield ctx.execute(ts.EXECUTION)
            ec.execute("act")                   # actuate at the end of the segment
        cpu.periodic(body, period=h, priority=i, name=f"pid{i}", **(served if i == 3 else {}))
    return sim, costs


def expected_costs(until: float = 1.0) -> pd.DataFrame:
    """One row per mode and loop: the expected cost per second over *until* s."""
    rows = []
    for mode in ts.MODES:
        sim, costs = build(mode)
        sim.run(until)
        for i, ec in enumerate(costs, start=1):
            rows.append({"mode": mode, "loop": i, "period": ts.PERIODS[i - 1],
                         "cost_per_s": ec.cost_until(until) / until})
    return pd.DataFrame(rows)


def main(outdir="results/threeservos_cost", until=1.0, quick=False):
    """Expected cost per loop in every mode over *until* s (0.3 s if *quick*); writes
    ``costs.parquet`` and ``costs.png`` to *outdir*; returns the table."""
    if quick:
        until = min(until, 0.3)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    table = expected_costs(until)
    table.to_parquet(out / "costs.parquet", index=False)
    fig, ax = plt.subplots(figsize=(8, 4))
    wide = table.pivot(index="mode", columns="loop", values="cost_per_s").loc[list(ts.MODES)]
    wide.plot.bar(ax=ax, logy=True, rot=0)
    ax.set_ylabel("expected cost per second  E[y²]")
    ax.set_title(f"three servos: exact expected cost per loop over {until:g} s")
    ax.legend([f"loop {i} (h = {h * 1e3:.0f} ms)" for i, h in enumerate(ts.PERIODS, start=1)])
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    fig.savefig(out / "costs.png", dpi=120)
    plt.close(fig)
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/threeservos_cost", quick="0.3 s instead of 1 s").parse_args()
    print(main(a.outdir, quick=a.quick).pivot(index="mode", columns="loop", values="cost_per_s").to_string())
