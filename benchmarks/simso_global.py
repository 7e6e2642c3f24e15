"""Global multicore scheduling against SimSo 0.8.5 (G-EDF, G-FP): the reference answers.

Random implicit-deadline periodic task sets (periods from a few integers of ms, so the
hyperperiod is 40 ms; WCETs multiples of 0.25 ms; utilisation 0.5--0.9 M) are run by
SimSo's ``simso.schedulers.EDF`` / ``simso.schedulers.FP`` and by a netcosim node with
``cores=M, scheduling="global"``.  A set is kept when SimSo meets every deadline (SimSo
aborts late jobs, netcosim does not).  Under G-EDF each task gets a distinct offset
``i/16`` ms, so no two jobs ever share an absolute deadline (SimSo breaks deadline ties
by task order, netcosim by release order); under G-FP priorities are distinct.

The compared answer is each task's CPU time as intervals (start, end) in ns, merged and
without zero-length runs (SimSo records a job that a decision at the same instant
preempts again at once).  ``python -m benchmarks.simso_global`` (needs ``pip install
simso==0.8.5``) writes :data:`REFERENCE`, which ``tests/test_multicore.py`` compares
with netcosim's schedules; it also reports whether netcosim matches SimSo now.
"""

from __future__ import annotations

import contextlib
import io
import json
import random
from pathlib import Path

REFERENCE = Path(__file__).with_name("simso_global_reference.json")
REPO = Path(__file__).resolve().parents[1]
#: where ``make`` installs SimSo 0.8.5 and SimPy 2 (apart from SimPy 4: same distribution name)
SIMSO_PATH = REPO / ".venv" / "simso"
RUN_WITH_ALL = False        # a tool, not a timing benchmark (and SimSo is optional)
PERIODS_MS = (2, 4, 5, 8, 10, 20)
HORIZON_MS = 80             # two hyperperiods
SETS = 20                   # per (policy, cores)


def random_task_set(rng: random.Random, m: int, edf: bool) -> list[dict]:
    """Tasks ``{"c", "t", "offset", "priority"}`` (ms; priority: larger = higher, SimSo's
    FP convention) with total utilisation drawn from 0.5 M .. 0.9 M."""
    n = rng.randint(m + 1, 3 * m)
    target = rng.uniform(0.5, 0.9) * m
    while True:                 # UUniFast-discard: each utilisation at most 1
        us, left = [], target
        for i in range(1, n):
            nxt = left * rng.random() ** (1 / (n - i))
            us.append(left - nxt)
            left = nxt
        us.append(left)
        if max(us) <= 1:
            break
    tasks = []
    for i, u in enumerate(us):
        t = rng.choice(PERIODS_MS)
        c = max(1, min(4 * t, round(u * t * 4))) / 4
        tasks.append({"c": c, "t": t, "offset": i / 16 if edf else 0.0, "priority": 0})
    for p, i in enumerate(sorted(range(n), key=lambda k: (tasks[k]["t"], k))):
        tasks[i]["priority"] = n - p    # rate-monotonic order, distinct
    return tasks


def simso_intervals(tasks: list[dict], m: int, policy: str) -> list[list[list[int]]] | None:
    """SimSo's execution intervals (ns) per task, or None when a deadline was missed."""
    from simso.configuration import Configuration
    from simso.core import Model
    from simso.core.JobEvent import JobEvent
    cfg = Configuration()
    cfg.duration = HORIZON_MS * cfg.cycles_per_ms
    for i, tk in enumerate(tasks):
        cfg.add_task(name=f"t{i}", identifier=i + 1, period=tk["t"], activation_date=tk["offset"],
                     wcet=tk["c"], deadline=tk["t"], data={"priority": tk["priority"]})
    for k in range(m):
        cfg.add_processor(name=f"cpu{k}", identifier=k + 1)
    cfg.scheduler_info.clas = {"edf": "simso.schedulers.EDF", "fp": "simso.schedulers.FP"}[policy]
    cfg.check_all()
    model = Model(cfg)
    with contextlib.redirect_stdout(io.StringIO()):
        model.run_model()
    out = []
    for task in model.task_list:
        if any(j.aborted for j in task.jobs):
            return None
        runs: list[list[int]] = []
        start = None
        for date, ev in task.monitor:
            if ev.event == JobEvent.EXECUTE:
                start = int(date)
            elif ev.event in (JobEvent.PREEMPTED, JobEvent.TERMINATED) and start is not None:
                runs.append([start, int(date)])
                start = None
        if start is not None:
            runs.append([start, HORIZON_MS * 1_000_000])
        out.append(_merge(runs))
    return out


def _merge(runs: list[list[int]]) -> list[list[int]]:
    merged: list[list[int]] = []
    for a, b in runs:
        if b <= a:
            continue
        if merged and merged[-1][1] == a:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return merged


def netcosim_intervals(tasks: list[dict], m: int, policy: str, horizon_ms: float = HORIZON_MS):
    """netcosim's execution intervals (ns) per task on a global node with *m* cores,
    cut at *horizon_ms* (a run still going then ends there)."""
    from netcosim import Simulation
    sim = Simulation()
    node = sim.node("cpu", policy if policy == "edf" else "fixed_priority", cores=m, scheduling="global")
    n = len(tasks)
    for i, tk in enumerate(tasks):
        def body(ctx, c=tk["c"] * 1e-3):
            yield ctx.execute(c)
        node.periodic(body, period=tk["t"] * 1e-3, offset=tk["offset"] * 1e-3, name=f"t{i}",
                      priority=n + 1 - tk["priority"])      # small = high
    sim.run(horizon_ms * 1e-3)
    return schedule_intervals(sim.trace.frame("schedule"), [f"t{i}" for i in range(n)], horizon_ms)


def schedule_intervals(sched, names: list[str], horizon_ms: float) -> list[list[list[int]]]:
    """Each task's running intervals (ns) from a schedule table, merged, cut at the horizon."""
    end_ns = round(horizon_ms * 1e6)
    out = []
    for name in names:
        rows = sched[sched["task"] == name]
        times = [round(t * 1e9) for t in rows["time"]]
        states = list(rows["state"])
        runs = []
        for k, st in enumerate(states):
            if st == "running":
                runs.append([times[k], times[k + 1] if k + 1 < len(times) else end_ns])
        out.append(_merge(runs))
    return out


def reference_cases(seed: int = 2025) -> list[dict]:
    """The task sets and SimSo's intervals (needs SimSo)."""
    rng = random.Random(seed)
    cases = []
    for policy in ("edf", "fp"):
        for m in (2, 4):
            kept = 0
            while kept < SETS:
                tasks = random_task_set(rng, m, policy == "edf")
                runs = simso_intervals(tasks, m, policy)
                if runs is None:
                    continue
                cases.append({"policy": policy, "cores": m, "tasks": tasks, "intervals": runs})
                kept += 1
    return cases


def simso_intervals_apart(tasks: list[dict], m: int, policy: str) -> list[list[list[int]]] | None:
    """:func:`simso_intervals` in a subprocess with :data:`SIMSO_PATH` on its path (SimSo's
    SimPy 2 never meets netcosim's SimPy 4).  FileNotFoundError if SimSo is not there."""
    import subprocess
    import sys
    if not (SIMSO_PATH / "simso").is_dir():
        raise FileNotFoundError(f"SimSo is not installed in {SIMSO_PATH} (make installs it)")
    code = ("import json, sys; from benchmarks import simso_global as s; a = json.loads(sys.argv[1]); "
            "print(json.dumps(s.simso_intervals(a['tasks'], a['m'], a['policy'])))")
    out = subprocess.run([sys.executable, "-c", code, json.dumps({"tasks": tasks, "m": m, "policy": policy})],
                         env={"PYTHONPATH": f"{SIMSO_PATH}:{REPO}", "PATH": "/usr/bin:/bin"}, cwd=REPO,
                         capture_output=True, text=True, timeout=300, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def main() -> None:
    cases = reference_cases()
    REFERENCE.write_text(json.dumps({"horizon_ms": HORIZON_MS, "simso": "0.8.5", "cases": cases}, indent=None))
    same = sum(netcosim_intervals(c["tasks"], c["cores"], c["policy"]) == c["intervals"] for c in cases)
    print(f"{len(cases)} task sets written to {REFERENCE.name}; netcosim matches SimSo on {same}")


if __name__ == "__main__":
    main()
