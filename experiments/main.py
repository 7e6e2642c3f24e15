"""The main job (``make run``): TrueTime's servo and three-servo examples.

Writes plots (PNG) and traces (Parquet) under ``results/``.
"""

from __future__ import annotations

import sys

from . import servo, threeservos


def main(outdir: str = "results") -> int:
    sim = servo.main(f"{outdir}/servo")
    jobs = sim.trace.jobs()
    print(f"servo: {len(jobs)} PID jobs, mean response {jobs['response_time'].mean()*1e3:.3f} ms "
          f"-> {outdir}/servo/")
    sims = threeservos.main(f"{outdir}/threeservos")
    for policy, s in sims.items():
        j = s.trace.jobs()
        summary = ", ".join(
            f"{t}: {int((g['finish'].notna()).sum())} done / {int(g['deadline_miss'].sum())} missed"
            for t, g in j.groupby("task", observed=True))
        print(f"threeservos {policy}: {summary}")
    print(f"threeservos -> {outdir}/threeservos/")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
