"""The kernel's trace tables: ``schedule`` (every task state change) and ``jobs`` (one row
per finished or killed job), their stored rows and how they are reported.

The kernel stores compact rows on the hot path (integer ticks, the task object, a
one-byte state code) and :func:`register` hands the :class:`~netcosim.trace.Trace` the
transforms that turn them into the reported frames (times in seconds, node and task
names).  :class:`~netcosim.Simulation` registers both tables when it is built, so they
exist (empty) before any node does; a :class:`~netcosim.kernel.Node` fetches them with
:func:`schedule_table` and :func:`jobs_table`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..plot import TASK_STATES, plot_schedule
from ..timebase import TICKS_PER_SECOND

if TYPE_CHECKING:  # pandas is imported on first use: a simulation does not need it
    import pandas as pd

    from ..trace import Recorder, Trace

__all__ = ["JOB_COLUMNS", "JOB_RAW", "SCHEDULE_RAW", "STATE_CODES", "TASK_STATES", "jobs_table", "register",
           "schedule_table"]

#: Code of each task state in the schedule table's stored rows (its position in TASK_STATES).
STATE_CODES = {state: code for code, state in enumerate(TASK_STATES)}

#: Columns of the schedule table as stored by the kernel: time in integer ticks, the
#: kernel's task object (its node and name are read when the table is), the state's code
#: (:data:`STATE_CODES`).  Reported as ``time`` (s), ``node``, ``task``, ``state``.
SCHEDULE_RAW = ("time", "task", "state")

#: Columns of the jobs table as reported (times in seconds; NaN where not applicable).
JOB_COLUMNS = (
    "node", "task", "job", "release", "deadline", "start", "finish",
    "response_time", "release_latency", "start_latency", "execution_time",
    "lateness", "deadline_miss", "budget_overrun", "killed",
)
#: Columns of the jobs table as stored by the kernel: the kernel's task object (its node,
#: name and relative deadline are read when the table is), times in integer ticks (None
#: if unset).  The deadline is not stored: it is the release plus the task's deadline.
JOB_RAW = ("task", "job", "release", "start", "finish", "execution_time", "deadline_miss", "budget_overrun",
           "killed")


def _ticks_to_seconds(df: pd.DataFrame, cols) -> pd.DataFrame:
    import pandas as pd
    for c in cols:
        df[c] = pd.to_numeric(df[c], errors="coerce").astype(float) / TICKS_PER_SECOND
    return df


def _task_names(tasks: pd.Series) -> tuple[pd.Series, pd.Series]:
    """The node name and task name of each kernel task object in *tasks* (object columns)."""
    import numpy as np
    import pandas as pd
    # one name object per task, shared by its rows (``map`` then ``astype(object)`` would make
    # a string object per row: some 100 bytes a row when a long table is read back)
    codes, unique = pd.factorize(tasks.to_numpy(dtype=object))
    nodes, names = np.empty(len(unique), dtype=object), np.empty(len(unique), dtype=object)
    for i, t in enumerate(unique):
        nodes[i], names[i] = t.node.name, t.name
    return (pd.Series(nodes[codes], index=tasks.index, dtype=object),
            pd.Series(names[codes], index=tasks.index, dtype=object))


def _schedule_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Stored schedule rows (:data:`SCHEDULE_RAW`) as reported: time (s), node, task and
    state names."""
    import numpy as np
    import pandas as pd
    node, task = _task_names(df["task"])
    states = np.asarray(list(TASK_STATES), dtype=object)
    return pd.DataFrame({
        "time": pd.to_numeric(df["time"], errors="coerce").astype(float) / TICKS_PER_SECOND,
        "node": node, "task": task,
        "state": pd.Series(states[df["state"].to_numpy(dtype=np.int64)], dtype=object),
    })


def _jobs_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Stored job rows (:data:`JOB_RAW`) as reported (:data:`JOB_COLUMNS`, times in s)."""
    import numpy as np
    import pandas as pd
    tasks = df["task"]
    node, name = _task_names(tasks)
    release = pd.to_numeric(df["release"], errors="coerce")
    unique = pd.unique(tasks)
    relative = tasks.map({t: np.nan if t.deadline_ticks is None else t.deadline_ticks for t in unique})
    if len(df) and relative.notna().all() and release.notna().all():
        deadline = (release.astype("int64") + relative.astype("int64")).astype(float)   # exact in ticks
    else:
        deadline = release.astype(float) + relative.astype(float)
    df = pd.DataFrame({
        "node": node, "task": name,
        "job": df["job"],
        "release": release.astype(float) / TICKS_PER_SECOND,
        "deadline": deadline / TICKS_PER_SECOND,
        "start": df["start"], "finish": df["finish"], "execution_time": df["execution_time"],
        "deadline_miss": df["deadline_miss"], "budget_overrun": df["budget_overrun"], "killed": df["killed"]})
    df = _ticks_to_seconds(df, ("start", "finish", "execution_time"))
    df["response_time"] = df["finish"] - df["release"]
    df["release_latency"] = 0.0
    df["start_latency"] = df["start"] - df["release"]
    df["lateness"] = df["finish"] - df["deadline"]
    for c in ("deadline_miss", "budget_overrun", "killed"):
        df[c] = df[c].astype(bool)
    df["job"] = df["job"].astype(int)
    return df[list(JOB_COLUMNS)]


def schedule_table(trace: Trace) -> Recorder:
    """The ``schedule`` table of *trace* (created on first call): stored as
    :data:`SCHEDULE_RAW`, reported as ``time`` (s), ``node``, ``task``, ``state``."""
    # stored in ticks, reported in seconds; the task column holds the kernel's task
    # objects: coded like names, by identity
    return trace.table("schedule", SCHEDULE_RAW, categorical=("node", "task", "state"),
                       transform=_schedule_frame, dtypes=("int", None, "uint8"))


def jobs_table(trace: Trace) -> Recorder:
    """The ``jobs`` table of *trace* (created on first call): stored as :data:`JOB_RAW`,
    reported as :data:`JOB_COLUMNS`; the ``window`` mode measures ``release``."""
    return trace.table("jobs", JOB_RAW, categorical=("node", "task"), transform=_jobs_frame,
                       time="release", dtypes=(None,) + ("int",) * 5 + ("bool",) * 3)


def _plot_schedule(trace: Trace, **options):
    """``Trace.plot("schedule")``: :func:`netcosim.plot.plot_schedule` of the schedule table."""
    return plot_schedule(trace.frame("schedule"), **options)


def register(trace: Trace) -> None:
    """Create the kernel's tables in *trace* (``schedule`` then ``jobs``) and its
    ``trace.plot("schedule")``; idempotent."""
    schedule_table(trace)
    jobs_table(trace)
    trace.add_plot("schedule", _plot_schedule)
