"""TrueTime's three-servo example: three PID loops on one overloaded CPU.

Periods 6, 5 and 4 ms, 2 ms of execution each: utilisation 2/6 + 2/5 + 2/4 = 1.23.
Under deadline monotonic the 6 ms loop has the lowest priority and starves; under EDF
every loop keeps running (all jobs are late, control degrades gracefully).

TrueTime's server modes put the 4 ms loop (task 3) in a server under EDF: mode 5 a
constant-bandwidth server with Qs = 1 ms, Ts = 4 ms (``edf_cbs``: 25 % of the CPU), mode 6
a total-bandwidth server with Us = 0.25 and the task's WCET 2 ms (``edf_tbs``).  The
server isolates the other two loops: with 2/6 + 2/5 + 0.25 = 0.98 <= 1 they meet every
deadline and control well, while loop 3, which needs 50 % and gets 25 %, is the one that
degrades (its jobs queue up: the queue bound drops the excess, counted).

Run: ``python -m netcosim.experiments.threeservos`` (PNG + Parquet under results/threeservos/).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from netcosim import RK4, Simulation
from netcosim.plants.dc_servo import DCServo
from netcosim.plot import plot_schedule

from .servo import add_pid_loop

PERIODS = (0.006, 0.005, 0.004)
EXECUTION = 0.002
#: TrueTime's mode 5: task 3 in a CBS (budget, period in s); mode 6: in a TBS (utilisation)
CBS_BUDGET, CBS_PERIOD = 0.001, 0.004
TBS_UTILIZATION = 0.25
#: the runs of :func:`main`: name -> (scheduling policy, server of task 3)
MODES = {"deadline_monotonic": ("deadline_monotonic", None), "edf": ("edf", None),
         "edf_cbs": ("edf", "cbs"), "edf_tbs": ("edf", "tbs")}


def build(policy="deadline_monotonic", seed=0, server=None, **task_options):
    """The three loops on one node scheduled by *policy*; *server* (``"cbs"``, ``"tbs"`` or
    None) serves the 4 ms loop (task 3) as TrueTime's modes 5 and 6 (EDF only)."""
    sim = Simulation(seed=seed)
    cpu = sim.node("cpu", scheduler=policy)
    served = {}
    if server == "cbs":
        served = {"server": cpu.cbs(budget=CBS_BUDGET, period=CBS_PERIOD, name="cbs")}
    elif server == "tbs":
        served = {"server": cpu.tbs(utilization=TBS_UTILIZATION, name="tbs"), "wcet": EXECUTION}
    elif server is not None:
        raise ValueError(f"server must be 'cbs', 'tbs' or None, got {server!r}")
    for i, h in enumerate(PERIODS, start=1):
        servo = sim.plant(DCServo(), x0=[0.0, 0.0], name=f"servo{i}", integrator=RK4(dt=1e-4))
        options = {**task_options, **served} if i == 3 else task_options
        add_pid_loop(cpu, servo, period=h, execution=EXECUTION, priority=i, name=f"pid{i}", **options)
    return sim


def main(outdir="results/threeservos", until=1.0, quick=False):
    """Simulate *until* seconds (0.3 s if *quick*) in every mode of :data:`MODES` (deadline
    monotonic, EDF, EDF with task 3 in a CBS, in a TBS); write traces (Parquet) and plots
    (PNG) to *outdir*.  Returns ``{mode: Simulation}``.
    """
    if quick:
        until = min(until, 0.3)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    sims = {}
    for policy, (scheduler, server) in MODES.items():
        sim = build(scheduler, server=server)
        try:
            sim.run(until=until)
        finally:
            sim.trace.to_parquet(out, prefix=f"{policy}_")
        sims[policy] = sim
        plot_schedule(sim.trace.schedule(), t_range=(0.0, 0.06), path=out / f"{policy}_schedule.png",
                      title=f"three servos, {policy}: schedule")
        fig, ax = plt.subplots(figsize=(10, 4))
        sig = sim.trace.signals()
        for i in range(1, 4):
            sel = sig[(sig["source"] == f"controller.pid{i}") | (sig["source"] == f"cpu.pid{i}")]
            sel = sel[sel["signal"] == "y"]
            ax.plot(sel["time"], sel["value"], label=f"servo {i} (h = {PERIODS[i-1]*1e3:.0f} ms)")
        ax.set_ylim(-3, 3)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("angle [rad]")
        ax.set_title(f"three servos, {policy}: outputs")
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / f"{policy}_outputs.png", dpi=120)
        plt.close(fig)
    return sims


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/threeservos", quick="simulate 0.3 s instead of 1 s").parse_args()
    for policy, sim in main(a.outdir, quick=a.quick).items():
        counts = ", ".join(f"{t}: {int(g['finish'].notna().sum())} done/{int(g['deadline_miss'].sum())} missed"
                           for t, g in sim.trace.jobs().groupby("task", observed=True))
        print(f"{policy} [{counts}]")
