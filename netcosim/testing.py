"""Assertions for tests of schedules: compare what a kernel did with a hand-derived timeline.

``running_intervals(schedule)`` turns the ``schedule`` trace (one row per task state
change) into the intervals during which each task held the CPU;
``assert_schedule(schedule, expected)`` compares them with a timeline written by hand
and, on a mismatch, says which task differs and where, e.g.::

    assert_schedule(sim.trace.schedule(), {
        "t1": [(0, 1), (4, 5), (8, 9)],
        "t2": [(1, 3), (6, 8)],
        "t3": [(3, 4), (5, 6), (9, 10)],
    }, t_range=(0, 10))

Times in seconds.  Intervals of a task that touch (one ends when the next begins, the
task never leaving the CPU in between) are one interval.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["running_intervals", "assert_schedule"]


def running_intervals(schedule: Any, *, node: str | None = None, until: float | None = None
                      ) -> dict[str, list[tuple[float, float]]]:
    """``{task: [(start, end), ...]}``: when each task was in state ``running`` (s).

    *schedule* is the ``schedule`` trace (``sim.trace.schedule()``: columns ``time,
    node, task, state``); *node* restricts it to one node (required when several
    nodes have tasks of the same name).  A task still running at the end of the trace
    gets the end *until* (default: ``inf``).
    """
    df = schedule
    if node is not None:
        df = df[df["node"].astype(str) == node]
    elif "node" in df.columns and df["node"].nunique() > 1:
        dup = df.groupby("task", observed=True)["node"].nunique()
        if (dup > 1).any():
            raise ValueError(f"tasks {sorted(map(str, dup[dup > 1].index))} exist on several nodes; pass node=")
    end = math.inf if until is None else float(until)
    out: dict[str, list[tuple[float, float]]] = {}
    for task, rows in df.groupby("task", sort=False, observed=True):
        ivs: list[tuple[float, float]] = []
        start = None
        for t, state in zip(rows["time"].to_numpy(dtype=float).tolist(), rows["state"].astype(str)):
            if state == "running" and start is None:
                start = t
            elif state != "running" and start is not None:
                if t > start:
                    if ivs and ivs[-1][1] == start:
                        ivs[-1] = (ivs[-1][0], t)
                    else:
                        ivs.append((start, t))
                start = None
        if start is not None:
            ivs.append((start, end))
        out[str(task)] = ivs
    return out


def _clip(ivs, lo, hi):
    out = []
    for a, b in ivs:
        a, b = float(max(a, lo)), float(min(b, hi))
        if b > a:
            out.append((a, b))
    return out


def assert_schedule(schedule: Any, expected: Mapping[str, Sequence[tuple[float, float]]], *,
                    node: str | None = None, t_range: tuple[float, float] | None = None,
                    atol: float = 1e-12) -> None:
    """Assert that each task of *expected* ran exactly in the given intervals (s).

    *schedule*: the ``schedule`` trace (``sim.trace.schedule()``); *node* restricts it to
    one node (see :func:`running_intervals`).

    Only the tasks named in *expected* are checked (a task expected never to run is
    given ``[]``).  With ``t_range=(t0, t1)`` both sides are clipped to that window, so
    a timeline can be written for the first hyperperiod of a longer run.  Interval ends
    match within *atol* seconds.  Raises ``AssertionError`` naming the first task whose
    intervals differ, with both timelines.
    """
    actual = running_intervals(schedule, node=node)
    lo, hi = (-math.inf, math.inf) if t_range is None else (float(t_range[0]), float(t_range[1]))
    for task, want in expected.items():
        got = _clip(actual.get(task, []), lo, hi)
        want = _clip([(float(a), float(b)) for a, b in want], lo, hi)
        same = len(got) == len(want) and all(abs(a - c) <= atol and abs(b - d) <= atol
                                             for (a, b), (c, d) in zip(got, want))
        if not same:
            first = next((k for k, (g, w) in enumerate(zip(got, want))
                          if abs(g[0] - w[0]) > atol or abs(g[1] - w[1]) > atol), min(len(got), len(want)))
            raise AssertionError(f"task {task!r} ran in {got}, expected {want} "
                                 f"(first difference at interval {first})")
