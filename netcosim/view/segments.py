"""What a timeline draws, computed once from the trace tables: the one definition the static
PNG plots (:mod:`netcosim.plot`, :mod:`netcosim.network.plot`) and the interactive view
(:mod:`netcosim.view.bokeh_timeline`) and the trace-event export
(:mod:`netcosim.view.chrome_trace`) all read.

Conventions: times in seconds (float), as in the trace tables; an interval is
``[start, end)``; a row's label is ``"node.task"`` for a task, the node's name for a
network row.  Only numpy and pandas are used here (no plotting library).

* **Task states** (:data:`TASK_STATES`): TrueTime's staircase levels above a task's row:
  running 0.5, ready 0.25 (preempted or waiting for the CPU), blocked 0.125, idle 0.
* **Network states** (:data:`NETWORK_STATES`): idle 0, receiving 0.2, waiting 0.4, sending 0.7.
* **Frame outcomes** (:data:`FRAME_OUTCOMES`), one per transmission attempt: ``delivered``
  (the attempt ended ``ok``/``sent`` and the frame was not lost at its receiver),
  ``lost`` (it ended ``ok`` but the frame was lost at the receiver: bit errors, random
  loss, ...), ``collided`` (the attempt ended with reason ``collision``), ``retried``
  (another failure, followed by a further attempt of the same frame) and ``dropped``
  (a failure after which the frame was given up).
* **Marks** (:data:`MARK_KINDS`): ``deadline_miss`` (at the job's deadline, jobs table),
  ``budget_overrun`` (at the job's finish), ``watchdog`` (a logged signal whose name starts
  with ``watchdog``, at its time), ``hil`` (a row of the ``hil`` table: late or lost
  replies, overruns, faults of a remote node).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["TASK_STATES", "TASK_COLOURS", "NETWORK_STATES", "NETWORK_COLOURS", "FRAME_OUTCOMES", "OUTCOME_COLOURS",
           "MARK_KINDS", "MARK_COLOURS", "staircase", "state_intervals", "task_segments", "frame_attempts",
           "medium_busy", "frame_markers", "marks", "task_order"]

#: Task states of the kernel's schedule table, with TrueTime's plotting level offsets (the
#: kernel's table codes a state by its position here, :data:`netcosim.kernel.tables.STATE_CODES`).
TASK_STATES = {"idle": 0.0, "blocked": 0.125, "ready": 0.25, "running": 0.5}
#: Fill colour of each drawn (non-idle) task state.
TASK_COLOURS = {"running": "#1f77b4", "ready": "#ff7f0e", "blocked": "#7f7f7f"}
#: Network-schedule states with their levels above a node's row (idle lowest, sending highest).
NETWORK_STATES = {"idle": 0.0, "receiving": 0.2, "waiting": 0.4, "sending": 0.7}
#: Fill colour of each non-idle network state (idle is not shaded).
NETWORK_COLOURS = {"receiving": "tab:green", "waiting": "tab:orange", "sending": "tab:blue"}
#: Outcome classes of a transmission attempt, in drawing order.
FRAME_OUTCOMES = ("delivered", "lost", "collided", "retried", "dropped")
#: Fill colour of each attempt outcome.
OUTCOME_COLOURS = {"delivered": "#2ca02c", "lost": "#d62728", "collided": "#9467bd", "retried": "#ff7f0e",
                   "dropped": "#8c564b"}
#: Kinds of event marks.
MARK_KINDS = ("deadline_miss", "budget_overrun", "watchdog", "hil")
#: Colour of each kind of mark.
MARK_COLOURS = {"deadline_miss": "#d62728", "budget_overrun": "#e377c2", "watchdog": "#bcbd22", "hil": "#17becf"}


def staircase(times: np.ndarray, levels: np.ndarray, t0: float, t1: float, floor: float):
    """The points ``(ts, ls)`` of one staircase drawn over ``[t0, t1]`` (s) with steps
    after each point (``where="post"``): the level in force at *t0* (*floor* if no change
    came before), then the changes inside the window, the last level held to *t1*.
    *times* (s, ascending) are the changes, *levels* the heights they switch to."""
    before = times <= t0
    start_level = levels[before][-1] if before.any() else floor
    inside = (times > t0) & (times < t1)
    ts = np.concatenate(([t0], times[inside], [t1]))
    ls = np.concatenate(([start_level], levels[inside], [levels[inside][-1] if inside.any() else start_level]))
    return ts, ls


def state_intervals(times: np.ndarray, states: np.ndarray, t_end: float):
    """``(start, end, state)`` arrays of one row's state changes (*states*, the state entered
    at each time of *times*): each change at
    ``times[i]`` (s) lasts until the next one, the last until *t_end* (s)."""
    ends = np.append(times[1:], t_end)
    return times, ends, states


def task_order(schedule: pd.DataFrame) -> list[str]:
    """Row labels ``"node.task"`` of a schedule table, in order of first appearance."""
    labels = schedule["node"].astype(str) + "." + schedule["task"].astype(str)
    return list(dict.fromkeys(labels))


def task_segments(schedule: pd.DataFrame, jobs: pd.DataFrame | None = None,
                  t_end: float | None = None) -> pd.DataFrame:
    """Every non-idle interval of every task of *schedule* (the ``schedule`` table): columns
    ``label`` (``"node.task"``), ``node``, ``task``, ``state`` (running / ready / blocked),
    ``start``, ``end`` (s),
    ``level`` (:data:`TASK_STATES`) and ``job`` (the job number of the ``jobs`` row whose
    ``[release, finish]`` holds the interval; -1 without *jobs* or none found).

    The last state of a task lasts until *t_end* (default: the latest time of the
    table).  Rows are sorted by ``start``."""
    import pandas as pd
    times = schedule["time"].to_numpy(dtype=float)
    if t_end is None:
        t_end = float(times.max()) if len(times) else 0.0
    node = schedule["node"].astype(str).to_numpy()
    task = schedule["task"].astype(str).to_numpy()
    state = schedule["state"].astype(str).to_numpy()
    label = np.char.add(np.char.add(node.astype(str), "."), task.astype(str)) if len(node) else node
    out = []
    order = task_order(schedule) if len(times) else []
    for lab in order:
        sel = np.flatnonzero(label == lab)
        t = times[sel]
        start, end, st = state_intervals(t, state[sel], t_end)
        keep = (st != "idle") & (end > start)
        part = pd.DataFrame({"label": lab, "node": node[sel][0], "task": task[sel][0], "state": st[keep],
                             "start": start[keep], "end": end[keep]})
        part["job"] = _job_of(part, jobs, node[sel][0], task[sel][0])
        out.append(part)
    if not out:
        return pd.DataFrame({c: [] for c in ("label", "node", "task", "state", "start", "end", "level", "job")})
    seg = pd.concat(out, ignore_index=True)
    seg["level"] = seg["state"].map(TASK_STATES).astype(float)
    return seg.sort_values("start", kind="stable").reset_index(drop=True)


def _job_of(part: pd.DataFrame, jobs: pd.DataFrame | None, node: str, task: str) -> np.ndarray:
    """Job number holding each interval of *part* (one task's), -1 where none does."""
    if jobs is None or part.empty:
        return np.full(len(part), -1, dtype=np.int64)
    mine = jobs[(jobs["node"].astype(str).to_numpy() == node) & (jobs["task"].astype(str).to_numpy() == task)]
    if mine.empty:
        return np.full(len(part), -1, dtype=np.int64)
    mine = mine.sort_values("release", kind="stable")
    release = mine["release"].to_numpy(dtype=float)
    finish = mine["finish"].to_numpy(dtype=float)
    finish = np.where(np.isnan(finish), np.inf, finish)
    s = part["start"].to_numpy(dtype=float)
    i = np.searchsorted(release, s, side="right") - 1
    ok = (i >= 0) & (s < finish[np.clip(i, 0, None)])
    return np.where(ok, mine["job"].to_numpy()[np.clip(i, 0, None)], -1).astype(np.int64)


def frame_attempts(frames: pd.DataFrame) -> pd.DataFrame:
    """One row per transmission attempt of the ``frames`` table: ``network``, ``frame``,
    ``src``, ``dst``, ``attempt``, ``start``, ``end`` (s), ``bits`` (on the air),
    ``reason`` (the ``attempt_end`` outcome) and ``outcome`` (:data:`FRAME_OUTCOMES`).
    Attempts without an end (still on the air when the run stopped) are left out.
    Rows are sorted by ``start``."""
    import pandas as pd
    cols = ("network", "frame", "src", "dst", "attempt", "start", "end", "bits", "reason", "outcome")
    ev = frames["event"].astype(str).to_numpy()
    key = ["network", "frame", "attempt"]
    starts = frames.loc[ev == "attempt_start", key + ["time", "src", "dst", "bits"]]
    ends = frames.loc[ev == "attempt_end", key + ["time", "outcome"]]
    if starts.empty or ends.empty:
        return pd.DataFrame({c: [] for c in cols})
    starts = starts.assign(network=starts["network"].astype(str)).drop_duplicates(key, keep="last")
    ends = ends.assign(network=ends["network"].astype(str)).drop_duplicates(key, keep="last")
    a = starts.merge(ends, on=key, suffixes=("_s", "_e"))
    a = a.rename(columns={"time_s": "start", "time_e": "end", "outcome": "reason"})
    a["src"], a["dst"], a["reason"] = a["src"].astype(str), a["dst"].astype(str), a["reason"].astype(str)
    lost = frames.loc[ev == "lost", ["network", "frame"]].astype({"network": str})
    lost_ids = set(zip(lost["network"], lost["frame"]))
    last = a.groupby(["network", "frame"])["attempt"].transform("max").to_numpy()
    is_lost = np.fromiter((k in lost_ids for k in zip(a["network"], a["frame"])), bool, len(a))
    ok = a["reason"].isin(("ok", "sent")).to_numpy()
    outcome = np.where(ok, np.where(is_lost, "lost", "delivered"),
                       np.where(a["reason"].to_numpy() == "collision", "collided",
                                np.where(a["attempt"].to_numpy() < last, "retried", "dropped")))
    a["outcome"] = outcome
    a = a[list(cols)].astype({"start": float, "end": float, "bits": float})
    return a.sort_values("start", kind="stable").reset_index(drop=True)


def medium_busy(attempts: pd.DataFrame) -> pd.DataFrame:
    """The medium's busy periods per network: the union of its attempts' ``[start, end)``
    intervals; columns ``network``, ``start``, ``end`` (s), ``frames`` (attempts in it)."""
    import pandas as pd
    out = []
    for net, g in attempts.groupby("network", sort=False):
        s = g["start"].to_numpy(dtype=float)
        e = g["end"].to_numpy(dtype=float)
        o = np.argsort(s, kind="stable")
        s, e = s[o], e[o]
        reach = np.maximum.accumulate(e)
        new = np.ones(len(s), bool)
        new[1:] = s[1:] > reach[:-1]
        idx = np.flatnonzero(new)
        ends = reach[np.append(idx[1:] - 1, len(s) - 1)]
        out.append(pd.DataFrame({"network": net, "start": s[idx], "end": ends,
                                 "frames": np.diff(np.append(idx, len(s)))}))
    if not out:
        return pd.DataFrame({"network": [], "start": [], "end": [], "frames": []})
    return pd.concat(out, ignore_index=True)


def frame_markers(frames: pd.DataFrame, t0: float, t1: float):
    """The network plot's markers inside ``[t0, t1]`` (s) of *frames* (the ``frames`` table):
    ``(lost, retransmissions)``:
    the ``lost`` rows (time, node where lost, sender) and the ``attempt_start`` rows with
    ``attempt > 1`` (time, sender)."""
    fr = frames[(frames["time"] >= t0) & (frames["time"] <= t1)]
    lost = fr[fr["event"] == "lost"]
    rt = fr[(fr["event"] == "attempt_start") & (fr["attempt"] > 1)]
    return lost, rt


def marks(tables: dict) -> pd.DataFrame:
    """Event marks of a run's tables (a dict of DataFrames by table name, as
    :meth:`netcosim.trace.Trace.to_pandas` returns): columns ``time`` (s), ``kind``
    (:data:`MARK_KINDS`), ``where`` (the row label: ``"node.task"`` for job marks, else
    the node or source) and ``text`` (what happened)."""
    import pandas as pd
    parts = []
    jobs = tables.get("jobs")
    if jobs is not None and len(jobs):
        label = jobs["node"].astype(str) + "." + jobs["task"].astype(str)
        for kind, flag, at in (("deadline_miss", "deadline_miss", "deadline"), ("budget_overrun", "budget_overrun",
                                                                                 "finish")):
            if flag in jobs.columns:
                sel = jobs[flag].fillna(False).to_numpy(dtype=bool)
                t = jobs[at].to_numpy(dtype=float)[sel]
                if at == "finish":   # an unfinished overrunning job: mark it at its start
                    t = np.where(np.isnan(t), jobs["start"].to_numpy(dtype=float)[sel], t)
                parts.append(pd.DataFrame({"time": t, "kind": kind, "where": label.to_numpy()[sel],
                                           "text": [f"{kind.replace('_', ' ')}: job {j}"
                                                    for j in jobs["job"].to_numpy()[sel]]}))
    sig = tables.get("signals")
    if sig is not None and len(sig):
        name = sig["signal"].astype(str)
        sel = name.str.startswith("watchdog").to_numpy()
        if sel.any():
            parts.append(pd.DataFrame({"time": sig["time"].to_numpy(dtype=float)[sel], "kind": "watchdog",
                                       "where": sig["source"].astype(str).to_numpy()[sel],
                                       "text": (name[sel] + " = " + sig["value"][sel].astype(str)).to_numpy()}))
    hil = tables.get("hil")
    if hil is not None and len(hil):
        parts.append(pd.DataFrame({"time": hil["time"].to_numpy(dtype=float), "kind": "hil",
                                   "where": hil["node"].astype(str).to_numpy(),
                                   "text": (hil["event"].astype(str) + " " + hil["detail"].astype(str) + " x"
                                            + hil["count"].astype(str)).to_numpy()}))
    parts = [p for p in parts if len(p)]
    if not parts:
        return pd.DataFrame({"time": [], "kind": [], "where": [], "text": []})
    return pd.concat(parts, ignore_index=True).sort_values("time", kind="stable").reset_index(drop=True)
