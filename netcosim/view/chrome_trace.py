"""A run in the Chrome / Perfetto trace-event format (JSON), to open unchanged in
https://ui.perfetto.dev or ``chrome://tracing``.

Mapping (docs/viewer.md):

* each **node** is a process (``pid`` 1, 2, ... in order of appearance, named
  ``node NAME``), each of its **tasks** a thread (``tid`` 1, 2, ..., named after the
  task); every non-idle interval of the schedule is a complete event (``ph: "X"``) with
  ``cat`` its state (``running``, ``ready``, ``blocked``), ``name`` ``"TASK job N"`` when
  running (else the state) and ``args`` the job's release, deadline, finish and
  response time (s);
* each **network** is a process (``network NAME``) with a thread per sender and one
  ``medium`` thread: every transmission attempt is a complete event named
  ``frame ID -> DST`` with ``cat`` its outcome (:data:`~netcosim.view.segments.FRAME_OUTCOMES`)
  and ``args`` bits, attempt and how it ended; the medium's busy periods are complete
  events named ``busy``;
* **signals** are counter events (``ph: "C"``) of one process ``signals``, one counter
  track per ``source.signal``, ``args: {"value": v}``;
* **marks** (deadline misses, budget overruns, watchdog firings, HIL events) are
  instant events (``ph: "i"``, ``s: "t"``) on their task's thread (else the node's first).

Times: ``ts`` and ``dur`` in microseconds of simulated time (floats, so picosecond
ticks survive to 1e-6 us); ``displayTimeUnit`` is ``"ns"``.  Within a track (pid, tid)
the events are written in ascending ``ts``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ..errors import ConfigurationError
from . import segments as sg
from .tables import end_time, read_tables

__all__ = ["chrome_trace_events", "write_chrome_trace", "check_chrome_trace", "REQUIRED"]

#: Fields every event must have.
REQUIRED = ("ph", "ts", "pid", "tid", "name")
_US = 1e6


def _meta(pid: int, tid: int, kind: str, name: str) -> dict:
    return {"ph": "M", "ts": 0, "pid": pid, "tid": tid, "name": kind, "args": {"name": name}}


def _num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def chrome_trace_events(tables: dict) -> list[dict]:
    """The trace events of *tables* (``{name: DataFrame}``), metadata first, then each
    track's events in ascending time."""
    events: list[dict] = []
    pid_of: dict[str, int] = {}
    tid_of: dict[str, tuple[int, int]] = {}
    sched = tables.get("schedule")
    if sched is not None and len(sched):
        seg = sg.task_segments(sched, tables.get("jobs"), t_end=end_time(tables))
        for lab in sg.task_order(sched):
            node, task = lab.split(".", 1)
            if node not in pid_of:
                pid_of[node] = len(pid_of) + 1
                events.append(_meta(pid_of[node], 0, "process_name", f"node {node}"))
            tid = 1 + sum(1 for k in tid_of if k.split(".", 1)[0] == node)
            tid_of[lab] = (pid_of[node], tid)
            events.append(_meta(pid_of[node], tid, "thread_name", task))
        jobs = tables.get("jobs")
        jinfo: dict[tuple[str, int], dict] = {}
        if jobs is not None and len(jobs):
            for lab, j, r, d, f, rt in zip(jobs["node"].astype(str) + "." + jobs["task"].astype(str), jobs["job"],
                                           jobs["release"], jobs["deadline"], jobs["finish"], jobs["response_time"]):
                jinfo[(lab, int(j))] = {"release_s": _num(r), "deadline_s": _num(d), "finish_s": _num(f),
                                        "response_time_s": _num(rt)}
        for lab, task, st, a, b, j in zip(seg["label"], seg["task"], seg["state"], seg["start"], seg["end"],
                                          seg["job"]):
            pid, tid = tid_of[lab]
            name = f"{task} job {j}" if st == "running" and j >= 0 else st
            ev = {"ph": "X", "ts": a * _US, "dur": (b - a) * _US, "pid": pid, "tid": tid, "name": name, "cat": st}
            if j >= 0:
                ev["args"] = {"job": int(j), **jinfo.get((lab, int(j)), {})}
            events.append(ev)
    frames = tables.get("frames")
    if frames is not None and len(frames):
        att = sg.frame_attempts(frames)
        busy = sg.medium_busy(att)
        for net in dict.fromkeys(frames["network"].astype(str)):
            pid = len(pid_of) + 1
            pid_of[f"network {net}"] = pid
            events.append(_meta(pid, 0, "process_name", f"network {net}"))
            a = att[att["network"] == net]
            senders = list(dict.fromkeys(a["src"]))
            for i, s in enumerate(senders):
                events.append(_meta(pid, i + 1, "thread_name", s))
            medium = len(senders) + 1
            events.append(_meta(pid, medium, "thread_name", "medium"))
            sender_tid = {s: i + 1 for i, s in enumerate(senders)}
            for fr, src, dst, att_n, s, e, bits, reason, outcome in zip(
                    a["frame"], a["src"], a["dst"], a["attempt"], a["start"], a["end"], a["bits"], a["reason"],
                    a["outcome"]):
                events.append({"ph": "X", "ts": s * _US, "dur": (e - s) * _US, "pid": pid, "tid": sender_tid[src],
                               "name": f"frame {int(fr)} -> {dst}", "cat": outcome,
                               "args": {"frame": int(fr), "attempt": int(att_n), "bits": _num(bits), "end": reason}})
            b = busy[busy["network"] == net]
            for s, e, n in zip(b["start"], b["end"], b["frames"]):
                events.append({"ph": "X", "ts": s * _US, "dur": (e - s) * _US, "pid": pid, "tid": medium,
                               "name": "busy", "cat": "medium", "args": {"attempts": int(n)}})
    sig = tables.get("signals")
    if sig is not None and len(sig):
        pid = len(pid_of) + 1
        events.append(_meta(pid, 0, "process_name", "signals"))
        names = (sig["source"].astype(str) + "." + sig["signal"].astype(str)).to_numpy()
        t = sig["time"].to_numpy(dtype=float)
        v = sig["value"].to_numpy(dtype=float)
        for i in np.argsort(t, kind="stable"):
            if math.isfinite(v[i]):
                events.append({"ph": "C", "ts": t[i] * _US, "pid": pid, "tid": 0, "name": names[i],
                               "args": {"value": float(v[i])}})
    mk = sg.marks(tables)
    if len(mk):
        first_of_node: dict[str, tuple[int, int]] = {}
        for lab, track in tid_of.items():
            first_of_node.setdefault(lab.split(".", 1)[0], track)
        fallback = next(iter(tid_of.values()), (1, 0))
        for t, kind, where, text in zip(mk["time"], mk["kind"], mk["where"], mk["text"]):
            pid, tid = tid_of.get(where) or first_of_node.get(where) or first_of_node.get(
                where.split(".", 1)[0], fallback)
            events.append({"ph": "i", "s": "t", "ts": t * _US, "pid": pid, "tid": tid, "name": kind,
                           "cat": "mark", "args": {"what": text, "where": where}})
    meta = [e for e in events if e["ph"] == "M"]
    rest = [e for e in events if e["ph"] != "M"]
    rest.sort(key=lambda e: (e["pid"], e["tid"], e["ts"]))
    return meta + rest


def write_chrome_trace(source: Any, path: str | os.PathLike, *, prefix: str = "") -> Path:
    """Write *source*'s trace (a Trace, a Simulation, a dict of DataFrames or a directory
    of ``Trace.to_parquet`` files, whose names start with *prefix*) as trace-event JSON to
    *path*; returns the path."""
    tables = read_tables(source, prefix=prefix)
    out = Path(path)
    if not out.parent.is_dir():
        raise ConfigurationError(f"cannot write {os.fspath(path)!r}: the folder {str(out.parent)!r} does not exist")
    doc = {"traceEvents": chrome_trace_events(tables), "displayTimeUnit": "ns",
           "otherData": {"producer": "netcosim", "time_unit": "ts and dur in microseconds of simulated time"}}
    with open(out, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, separators=(",", ":"))
    return out


def check_chrome_trace(doc: dict | Iterable[dict]) -> int:
    """Check the trace events of *doc* (a ``{"traceEvents": [...]}`` document or the list): every event
    has :data:`REQUIRED`, ``ts`` is a finite number, ``dur`` (complete events) is >= 0,
    and within each track ``(pid, tid)`` the timestamps never decrease.  Returns the
    number of events; raises :class:`ValueError` naming the first bad event."""
    events = doc["traceEvents"] if isinstance(doc, dict) else list(doc)
    last: dict[tuple, float] = {}
    for i, e in enumerate(events):
        missing = [k for k in REQUIRED if k not in e]
        if missing:
            raise ValueError(f"event {i} {e!r:.120} lacks {missing}")
        ts = e["ts"]
        if not isinstance(ts, (int, float)) or not math.isfinite(ts):
            raise ValueError(f"event {i} has ts {ts!r}: need a finite number of microseconds")
        if e["ph"] == "X" and not (isinstance(e.get("dur"), (int, float)) and e["dur"] >= 0):
            raise ValueError(f"event {i} ({e['name']!r}) has dur {e.get('dur')!r}: need a number >= 0")
        if e["ph"] == "M":
            continue
        track = (e["pid"], e["tid"]) if e["ph"] != "C" else (e["pid"], e["tid"], e["name"])
        if ts < last.get(track, -math.inf):
            raise ValueError(f"event {i} ({e['name']!r}) at ts {ts} comes before the previous event of track "
                             f"{track} at {last[track]}")
        last[track] = ts
    return len(events)
