"""Dhall's effect on a multicore node: global EDF misses a deadline at utilisation just above 1.

M light tasks (C = 2 eps, T = 1) and one heavy task (C = 1, T = 1 + eps) on M cores, with a
unit of 10 ms and eps = 0.1 ms: total utilisation 2 M eps + 1/(1 + eps) (1.03 on 2 cores),
far below M.  Global EDF (and global rate monotonic) runs the light jobs first, their
deadlines being earlier, on every core; the heavy job starts at 2 eps = 0.2 ms and ends at
10.2 ms, after its 10.1 ms deadline.  Partitioned EDF with the heavy task alone on core 0
(TrueTime's affinity) meets every deadline, and so does global fixed priority with the
heavy task on top.  The schedules are drawn with each running interval in its core's colour.

Run: ``python -m netcosim.experiments.multicore_dhall [--cores M]`` (PNG + Parquet under
results/multicore_dhall/).
"""

from __future__ import annotations

from pathlib import Path

from netcosim import Simulation, validate
from netcosim.plot import plot_schedule

UNIT, EPS = 0.010, 0.0001
#: the runs of :func:`main`: name -> (policy, scheduling, heavy task's fixed priority)
MODES = {"global_edf": ("edf", "global", None), "global_rm": ("rate_monotonic", "global", None),
         "partitioned_edf": ("edf", "partitioned", None), "global_fp_heavy_first": ("fixed_priority", "global", 0)}


def build(cores=2, policy="edf", scheduling="global", heavy_priority=None):
    """Dhall's task set on a node with *cores* cores; partitioned: the heavy task alone on
    core 0, the light ones on core 1.  Fixed priorities: light tasks 1..M, the heavy task
    *heavy_priority* (default M + 1: last)."""
    sim = Simulation()
    node = sim.node("cpu", policy, cores=cores, scheduling=scheduling)

    def busy(c):
        def body(ctx):
            yield ctx.execute(c)
        return body
    pinned = scheduling == "partitioned"
    for i in range(cores):
        node.periodic(busy(2 * EPS), period=UNIT, priority=i + 1, name=f"light{i}",
                      **({"core": 1} if pinned else {}))
    node.periodic(busy(UNIT), period=UNIT + EPS, name="heavy",
                  priority=cores + 1 if heavy_priority is None else heavy_priority,
                  **({"core": 0} if pinned else {}))
    return sim


def main(outdir="results/multicore_dhall", cores=2, quick=False):
    """Run every mode of :data:`MODES` for 10 heavy periods (3 if *quick*); write each
    schedule plot (PNG) and trace (Parquet) to *outdir*.  Returns ``{mode: Simulation}``."""
    cores = validate.integer(cores, "cores", lo=2, hi=64)   # a light core and a heavy one at least
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    until = (3 if quick else 10) * (UNIT + EPS)
    sims = {}
    for mode, (policy, scheduling, prio) in MODES.items():
        sim = build(cores, policy, scheduling, prio)
        try:
            sim.run(until)
        finally:
            sim.trace.to_parquet(out, prefix=f"{mode}_")
        plot_schedule(sim.trace.schedule(), t_range=(0.0, 2.2 * UNIT), path=out / f"{mode}_schedule.png",
                      title=f"Dhall's effect on {cores} cores, {mode}")
        sims[mode] = sim
    return sims


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    p = experiment_parser(__doc__, "results/multicore_dhall", quick="3 heavy periods instead of 10")
    p.add_argument("--cores", type=int, default=2, help="number of cores M (default 2)")
    a = p.parse_args()
    for mode, sim in main(a.outdir, a.cores, quick=a.quick).items():
        jobs = sim.trace.jobs()
        heavy = jobs[jobs["task"] == "heavy"].iloc[0]
        print(f"{mode}: heavy job 0 ends at {heavy['finish'] * 1e3:.3f} ms (deadline "
              f"{heavy['deadline'] * 1e3:.3f} ms); deadline misses {int(jobs['deadline_miss'].sum())}")
