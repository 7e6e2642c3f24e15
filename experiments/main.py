"""The main job (``make run``): the TrueTime examples and the thesis reproductions.

Each experiment writes its plots (PNG) and data (Parquet) under ``results/<name>/``.
A failing experiment does not stop the others; the job exits non-zero at the end if
any failed.
"""

from __future__ import annotations

import importlib
import sys
import time
import traceback

#: (module in experiments/, what it reproduces)
EXPERIMENTS = [
    ("servo", "TrueTime servo example: PID with 2 ms computational delay"),
    ("threeservos", "TrueTime three-servo overload: deadline monotonic vs EDF"),
    ("networked_servo", "TrueTime networked servo on CSMA/CD and CAN with an interfering node"),
    ("ch2_landing", "Ch. 2: tethered-UAV landing, NMPC alone vs two-layer controller, calm and wind"),
    ("ch3_fig3_8", "Fig. 3.8: offline vs online gain, Fly-crane, small and large ball"),
    ("ch4_fig4_8_9", "Figs. 4.8/4.9: 4-robot non-square system, 2-norm and inf-norm"),
    ("ch4_fig4_10", "Fig. 4.10: dynamic model with velocity tracking, three alphas"),
    ("ch5_table5_2", "Table 5.2, Figs. 5.3-5.7: stability set, optimal gain and period"),
    ("ch5_fig5_8_9", "Figs. 5.8/5.9a: SIKM tracking strategies on the Fly-crane"),
]


def _summary_servo(sim):
    jobs = sim.trace.jobs()
    return f"{len(jobs)} PID jobs, mean response {jobs['response_time'].mean() * 1e3:.3f} ms"


def _summary_threeservos(sims):
    parts = []
    for policy, s in sims.items():
        j = s.trace.jobs()
        counts = ", ".join(f"{t}: {int(g['finish'].notna().sum())} done/{int(g['deadline_miss'].sum())} missed"
                           for t, g in j.groupby("task", observed=True))
        parts.append(f"{policy} [{counts}]")
    return "; ".join(parts)


SUMMARIES = {"servo": _summary_servo, "threeservos": _summary_threeservos}


def main(outdir: str = "results", only: list[str] | None = None) -> int:
    failed = []
    for name, what in EXPERIMENTS:
        if only and name not in only:
            continue
        t0 = time.perf_counter()
        print(f"[{name}] {what}", flush=True)
        try:
            mod = importlib.import_module(f"experiments.{name}")
            result = mod.main(outdir=f"{outdir}/{name}")
        except Exception:
            traceback.print_exc()
            failed.append(name)
            continue
        summary = SUMMARIES.get(name)
        line = f" -> {outdir}/{name}/ ({time.perf_counter() - t0:.1f} s)"
        if summary is not None:
            line += " " + summary(result)
        print(line, flush=True)
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    args = sys.argv[1:]
    sys.exit(main(args[0] if args else "results", args[1:] or None))
