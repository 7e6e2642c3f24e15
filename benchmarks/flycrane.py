"""Real-time factor of the networked Fly-crane (5 nodes on 802.11b, §4.6.1) per plant.

One run of :func:`netcosim.controllers.planner.networked.run` (45 s simulated, 30 % loss,
broadcast, both strategies) is timed on this core, best of ``--repeats``; the real-time
factor is simulated seconds per wall second.  Baseline measured in the same run: the
same scenario on the dynamic plant whose dynamics run uncompiled in CasADi's virtual
machine (what the plant costs without :class:`VelocityTrackingModel`'s compiled code),
reported as a ratio; beside it the dynamic plant on the former integrator
(``VelocityTrackingModel(method="lsoda")``: LSODA calling the compiled right-hand side
stage by stage) against the default (DOP853 with each step one compiled call).  Target:
the dynamic plant at >= 500x real time.

``--sweep`` also times the default ``python -m netcosim.experiments.flycrane_network`` sweep
(10 losses x 2 strategies x 20 seeds on 2 processes; several minutes).
``--profile`` prints the functions that dominate one dynamic run.
``--trajectories`` compares the default integrator with the former one: the largest
``|q_DOP853 - q_LSODA|`` on the 0.1 s grid over the 30 s runs of 5 seeds x losses 0, 30 %,
70 % x both strategies, and whether every frame, network-schedule, kernel-schedule and
job table is identical (no timing).

Run: ``python -m benchmarks.flycrane``.
"""

from __future__ import annotations

import argparse
import time

HORIZON = 45.0


def _best(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main(repeats: int = 3, sweep: bool = False, profile: bool = False) -> list[tuple[str, float]]:
    import netcosim.controllers.planner.networked as nw
    from netcosim.controllers.planner.plant_models import VelocityTrackingModel

    rows = []
    cfg = nw.FlyCraneNetworkConfig(loss=0.3, horizon=HORIZON)
    nw.run(cfg.replace(horizon=3.0))                       # imports, compiled code, offline gain
    orig = nw.VelocityTrackingModel
    nw.VelocityTrackingModel = lambda alpha: VelocityTrackingModel(alpha, compiled=False, method="lsoda")  # type: ignore
    try:
        base = _best(lambda: nw.run(cfg.replace(strategy="online")), repeats)
    finally:
        nw.VelocityTrackingModel = orig
    rows.append(("baseline: dynamic, online, uncompiled dynamics", base))
    nw.VelocityTrackingModel = lambda alpha: VelocityTrackingModel(alpha, method="lsoda")  # type: ignore
    try:
        for strategy in ("online", "offline"):
            rows.append((f"dynamic, {strategy}, LSODA (former integrator)",
                         _best(lambda: nw.run(cfg.replace(strategy=strategy)), repeats)))
    finally:
        nw.VelocityTrackingModel = orig
    for plant in ("dynamic", "kinematic"):
        for strategy in ("online", "offline"):
            wall = _best(lambda: nw.run(cfg.replace(plant=plant, strategy=strategy)), repeats)
            rows.append((f"{plant}, {strategy}", wall))
    w = max(len(r[0]) for r in rows)
    print(f"{'45 s of the 5-node scenario, 30 % loss':<{w}}  {'wall':>8}  {'x real time':>11}  {'vs baseline':>11}")
    for name, t in rows:
        print(f"{name:<{w}}  {t:7.3f}s  {HORIZON / t:11.0f}  {base / t:11.2f}")
    if profile:
        import cProfile
        import pstats
        pr = cProfile.Profile()
        pr.enable()
        nw.run(cfg.replace(strategy="online"))
        pr.disable()
        pstats.Stats(pr).sort_stats("tottime").print_stats(12)
    if sweep:
        import tempfile

        from netcosim.experiments import flycrane_network as fn
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            fn.main(d)
            wall = time.perf_counter() - t0
        print(f"default sweep ({len(fn.GRID_LOSSES)} losses x 2 strategies x 20 seeds, 2 processes) and figures: "
              f"{wall:.0f} s")
        rows.append(("default sweep", wall))
    return rows


def trajectories(seeds: int = 5, losses=(0.0, 0.3, 0.7)) -> dict:
    """``{(strategy, loss): max |q_dop853 - q_lsoda|}`` over *seeds* 30 s runs each; prints
    the table and whether the frame and schedule tables are all identical."""
    import numpy as np

    import netcosim.controllers.planner.networked as nw
    from netcosim.controllers.planner.plant_models import VelocityTrackingModel
    orig = nw.VelocityTrackingModel
    worst: dict = {}
    same = True
    for strategy in ("online", "offline"):
        for loss in losses:
            for seed in range(seeds):
                cfg = nw.FlyCraneNetworkConfig(loss=loss, strategy=strategy, seed=seed)
                a = nw.run(cfg)
                nw.VelocityTrackingModel = lambda alpha: VelocityTrackingModel(alpha, method="lsoda")  # type: ignore
                try:
                    b = nw.run(cfg)
                finally:
                    nw.VelocityTrackingModel = orig
                key = (strategy, loss)
                worst[key] = max(worst.get(key, 0.0), float(np.abs(a.q - b.q).max()))
                same &= all(getattr(a, t).equals(getattr(b, t)) for t in ("frames", "network_schedule", "schedule",
                                                                           "jobs"))
    print(f"max |q_DOP853 - q_LSODA| (rad, m) over {seeds} seeds, 30 s runs")
    print("strategy  " + "  ".join(f"loss {x:<6g}" for x in losses))
    for strategy in ("online", "offline"):
        print(f"{strategy:<8}  " + "  ".join(f"{worst[(strategy, x)]:<11.2g}" for x in losses))
    print("frame, network-schedule, schedule and job tables identical:", same)
    return worst


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sweep", action="store_true", help="also time the default sweep (minutes)")
    ap.add_argument("--profile", action="store_true", help="profile one dynamic run")
    ap.add_argument("--trajectories", action="store_true", help="only compare q of the default integrator "
                    "with LSODA's (no timing)")
    a = ap.parse_args()
    if a.trajectories:
        trajectories()
    else:
        main(a.repeats, a.sweep, a.profile)
