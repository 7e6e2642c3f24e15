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
from ..readback import categorical_from_codes
from ..timebase import MAX_TICKS, TICKS_PER_SECOND

if TYPE_CHECKING:  # pandas is imported on first use: a simulation does not need it
    import pandas as pd

    from ..recorder import Recorder
    from ..trace import Trace

__all__ = ["JOB_COLUMNS", "JOB_RAW", "SCHEDULE_RAW", "STATE_CODES", "TASK_STATES", "jobs_table", "register",
           "schedule_table"]

#: Code of each task state in the schedule table's stored rows (its position in TASK_STATES).
STATE_CODES = {state: code for code, state in enumerate(TASK_STATES)}

#: Stored code of ``running`` on core *k* of a multicore node: ``RUNNING_ON_CORE + k``
#: (a one-core node stores ``STATE_CODES["running"]``: core 0).
RUNNING_ON_CORE = 16

#: Columns of the schedule table as stored by the kernel: time in integer ticks, the
#: kernel's task object (its node and name are read when the table is), the state's code
#: (:data:`STATE_CODES`, or :data:`RUNNING_ON_CORE` + core).  Reported as ``time`` (s),
#: ``node``, ``task``, ``state``, and ``core`` when the table holds rows of a multicore
#: node's tasks.
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


def _per_task(tasks: pd.Series):
    """``(codes, unique)``: the distinct kernel task objects in *tasks* and each row's index
    into them -- from a Categorical of task objects (a table read back column by column,
    see ``identity`` of :meth:`~netcosim.trace.Trace.table`) without touching a row, or by
    factorizing an object column."""
    import pandas as pd
    if isinstance(tasks.dtype, pd.CategoricalDtype):
        return tasks.cat.codes.to_numpy(), list(tasks.cat.categories)
    codes, unique = pd.factorize(tasks.to_numpy(dtype=object))
    return codes, list(unique)


def _task_names(tasks: pd.Series) -> tuple[pd.Series, pd.Series]:
    """The node name and task name of each kernel task object in *tasks*, as categoricals
    (what ``astype("category")`` makes of the names, without a name per row)."""
    import pandas as pd
    codes, unique = _per_task(tasks)
    return (pd.Series(categorical_from_codes(codes, [t.node.name for t in unique]), index=tasks.index),
            pd.Series(categorical_from_codes(codes, [t.name for t in unique]), index=tasks.index))


def _multicore(unique: list) -> bool:
    """True when one of the kernel task objects *unique* is on a multicore node: the
    reported tables then get their ``core`` (and jobs ``migrations``) columns."""
    return any(t.node.multicore for t in unique)


def _seconds(ticks: pd.Series):
    """Integer ticks as float seconds, ``float(ticks) / TICKS_PER_SECOND`` (NaN where unset)."""
    import numpy as np
    import pandas as pd
    if ticks.dtype.kind in "iu":
        return np.true_divide(ticks.to_numpy(), TICKS_PER_SECOND)    # one array, same bits as below
    return pd.to_numeric(ticks, errors="coerce").astype(float) / TICKS_PER_SECOND


def _schedule_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Stored schedule rows (:data:`SCHEDULE_RAW`) as reported: time (s), node, task and
    state names (categoricals)."""
    import numpy as np
    import pandas as pd
    node, task = _task_names(df["task"])
    states = df["state"].to_numpy()
    if states.dtype == object:
        states = states.astype(np.intp, copy=False)
    core = None
    if _multicore(_per_task(df["task"])[1]):   # the core of each running row, -1 for other states
        running = STATE_CODES["running"]
        states = states.astype(np.intp)
        on_core = states >= RUNNING_ON_CORE
        core = np.where(on_core, states - RUNNING_ON_CORE, np.where(states == running, 0, -1))
        states = np.where(on_core, running, states)
    frame = pd.DataFrame({
        "time": _seconds(df["time"]),
        "node": node, "task": task,
        "state": categorical_from_codes(states, list(TASK_STATES)),
    })
    if core is not None:
        frame["core"] = core.astype(np.int64)
    return frame


def _local_deadlines(deadline: pd.Series, job: pd.Series, codes, unique: list) -> pd.Series:
    """*deadline* (ticks) with the rows of tasks on a local clock replaced by the absolute
    deadline their job got at its release (``netcosim.kernel.localtime``: relative to the
    release in local time, converted when released)."""
    import numpy as np
    for code, task in enumerate(unique):
        local = getattr(task.node, "_local", None)
        if local is None or task.deadline_ticks is None:
            continue
        rows = codes == code
        if rows.any():
            known = np.asarray(local.deadlines[task], dtype=float)
            deadline = deadline.copy()
            deadline[rows] = known[job[rows].to_numpy(dtype=np.int64)]
    return deadline


def _jobs_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Stored job rows (:data:`JOB_RAW`) as reported (:data:`JOB_COLUMNS`, times in s)."""
    import numpy as np
    import pandas as pd
    tasks = df["task"]
    node, name = _task_names(tasks)
    release = pd.to_numeric(df["release"], errors="coerce")
    codes, unique = _per_task(tasks)
    relative = pd.Series(np.array([np.nan if t.deadline_ticks is None else t.deadline_ticks for t in unique],
                                  dtype=object)[codes], index=tasks.index)
    if (len(df) and relative.notna().all() and release.notna().all()
            and int(release.max()) + int(relative.max()) <= MAX_TICKS):
        deadline = (release.astype("int64") + relative.astype("int64")).astype(float)   # exact in ticks
    else:
        deadline = release.astype(float) + relative.astype(float)
    deadline = _local_deadlines(deadline, df["job"], codes, unique)
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
    if _multicore(unique):
        jobs = df["job"].to_numpy()
        df["core"] = np.array([_job_core(unique[c], j) for c, j in zip(codes, jobs)], dtype=np.int64)
        df["migrations"] = np.array([_job_migrations(unique[c], j) for c, j in zip(codes, jobs)], dtype=np.int64)
        return df[list(JOB_COLUMNS) + ["core", "migrations"]]
    return df[list(JOB_COLUMNS)]


def _job_core(task, job: int) -> int:
    """The core job *job* of *task* finished on (0 on a one-core node; a multicore node's
    ``job_core``)."""
    return task.node.job_core(task, job) if task.node.multicore else 0


def _job_migrations(task, job: int) -> int:
    """The migrations of job *job* of *task* (0 on a one-core node)."""
    return task.node.job_migrations(task, job) if task.node.multicore else 0


def schedule_table(trace: Trace) -> Recorder:
    """The ``schedule`` table of *trace* (created on first call): stored as
    :data:`SCHEDULE_RAW`, reported as ``time`` (s), ``node``, ``task``, ``state``."""
    # stored in ticks, reported in seconds; the task column holds the kernel's task
    # objects: coded like names, by identity
    return trace.table("schedule", SCHEDULE_RAW, categorical=("node", "task", "state"),
                       transform=_schedule_frame, dtypes=("int", None, "uint8"), identity=("task",))


def jobs_table(trace: Trace) -> Recorder:
    """The ``jobs`` table of *trace* (created on first call): stored as :data:`JOB_RAW`,
    reported as :data:`JOB_COLUMNS`; the ``window`` mode measures ``release``."""
    return trace.table("jobs", JOB_RAW, categorical=("node", "task"), transform=_jobs_frame,
                       time="release", dtypes=(None,) + ("int",) * 5 + ("bool",) * 3, identity=("task",))


def _plot_schedule(trace: Trace, **options):
    """``Trace.plot("schedule")``: :func:`netcosim.plot.plot_schedule` of the schedule table."""
    return plot_schedule(trace.frame("schedule"), **options)


def register(trace: Trace) -> None:
    """Create the kernel's tables in *trace* (``schedule`` then ``jobs``) and its
    ``trace.plot("schedule")``; idempotent."""
    schedule_table(trace)
    jobs_table(trace)
    trace.add_plot("schedule", _plot_schedule)
