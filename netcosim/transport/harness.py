"""Running a simulation with its remote side: the commands that start the processes, and
one run from connection to the last reply.

:func:`remote_command` builds the command line every remote program accepts
(``--run``, ``--node``, ``--session``, ``--lease``, ``--connect`` once per endpoint, after
the program's own arguments; the program itself runs with the running interpreter,
``sys.executable``, when it is given as ``python``).  :func:`run_with_remotes` starts those
processes (or prints the commands for someone to start them by hand, on another
machine), waits until each has claimed its node, runs the simulation, ends the run
(:meth:`finish` sends END, also when the run failed), reads each process's counters from
the last line of its stdout (a JSON object, the convention of the example processes) and
counts the replies that arrived after the stop time (:func:`~netcosim.transport.base.drain`).  A run that fails
(an exception of a simulated component, or a :class:`~netcosim.transport.remote.RemoteFault`
asked for with ``abort_on``) is returned with ``failure`` set and its trace intact.  The
processes are killed and reaped in every case.
"""

from __future__ import annotations

import json
import shlex
import signal as _signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

from .remote import drain

__all__ = ["remote_command", "run_with_remote", "run_with_remotes", "RemoteRun"]


def remote_command(program: Sequence[str], *, run: str, node: str, endpoints: Sequence[str], lease: float,
                   session: int | None = None, zenoh_config: str | None = None, encoding: str = "ncsm") -> list[str]:
    """``program`` (e.g. ``[sys.executable, "-m", "my.controller", "--gain", "2"]``; a
    leading ``python`` or ``python3`` is replaced by :data:`sys.executable`, the running
    interpreter) followed by ``--run RUN --node NODE [--session HEX] --lease LEASE``,
    ``--zenoh-config PATH`` and ``--encoding ENC`` if given (not ``ncsm``), and ``--connect E``
    for each endpoint of *endpoints* (the simulation's session's, e.g.
    ``tcp/127.0.0.1:7447``); ``zenoh_config``: the path of a Zenoh configuration file."""
    program = list(program)
    if program and program[0] in ("python", "python3"):
        program[0] = sys.executable
    cmd = [*program, "--run", run, "--node", node]
    if session is not None:
        cmd += ["--session", f"{session:016x}"]
    cmd += ["--lease", repr(float(lease))]
    if zenoh_config is not None:
        cmd += ["--zenoh-config", str(zenoh_config)]
    if encoding != "ncsm":
        cmd += ["--encoding", encoding]
    for e in endpoints:
        cmd += ["--connect", e]
    return cmd


def _quantiles(resp) -> dict:
    import numpy as np
    some = len(resp) > 0
    return {f"response_{name}": float(fn(resp)) if some else float("nan")
            for name, fn in (("median", np.median), ("p90", lambda r: np.quantile(r, 0.9)),
                             ("p99", lambda r: np.quantile(r, 0.99)), ("max", np.max))}


@dataclass
class RemoteRun:
    """One run with remote sides (what :func:`run_with_remotes` returns): ``sim``,
    ``remote`` (the first :class:`~netcosim.transport.remote.RemoteNode` or
    :class:`~netcosim.transport.remote.RemotePlantIO`), ``lateness`` (the real-time
    clock's histogram, :class:`~netcosim.transport.realtime.Lateness`), ``process`` (the
    first process's counters from the last line of its stdout, a dict; None when it was
    not started here, was signalled, or printed none), ``wall`` (s of wall clock of
    ``sim.run``), ``remotes`` and ``processes`` (all of them, in order), ``exit_codes``
    (of the processes started here; None for those signalled), ``failure`` (the exception
    that ended ``sim.run`` early, or None)."""

    sim: Any
    remote: Any
    lateness: Any
    process: dict | None
    wall: float
    remotes: list = field(default_factory=list)
    processes: list = field(default_factory=list)
    exit_codes: list = field(default_factory=list)
    failure: BaseException | None = None

    def __post_init__(self):
        if not self.remotes:
            self.remotes = [self.remote]
            self.processes = [self.process]

    @classmethod
    def of(cls, run: "RemoteRun", **extra: Any) -> Any:
        """A *cls* (a subclass adding fields, e.g. an example's result) holding *run*'s fields and *extra*."""
        from dataclasses import fields
        return cls(**{f.name: getattr(run, f.name) for f in fields(RemoteRun)}, **extra)

    def response_times(self) -> Any:
        """Simulated response time (s) of every reply of the first remote, in request order."""
        return self.remote.response_times()

    def summary(self) -> dict:
        """The run in numbers (times in s): for the first remote, response times
        (median, p90, p99, max; NaN without replies) and its counters (requests
        published, replies applied, expired, overruns, unserved, after the end, drops in
        all); the lateness histogram's median, p99 and max, overruns, events, late
        injections; the wall-clock time of the run; the failure (empty if none)."""
        lat, r = self.lateness, self.remote
        c = r.counters()
        return {**_quantiles(self.response_times()),
                **{k: c[k] for k in ("published", "received", "expired", "overruns", "unserved", "after_end")},
                "dropped": sum(c["dropped"].values()),
                "late_median": lat.quantile(0.5), "late_p99": lat.quantile(0.99), "late_max": lat.max,
                "late_overruns": lat.overruns, "events": lat.events, "late_injections": lat.late_injections,
                "wall": self.wall, "failure": "" if self.failure is None else f"{type(self.failure).__name__}: "
                                                                               f"{self.failure}"}

    def per_remote(self):
        """One row per remote (a DataFrame): name, its counters (drops by reason as
        ``dropped_<reason>``), response-time quantiles (s), and its process's counters
        (``process_<name>``) when read."""
        import pandas as pd
        rows = []
        for r, p in zip(self.remotes, self.processes):
            c = r.counters()
            row = {"remote": r.name, **{k: v for k, v in c.items() if k != "dropped"},
                   **{f"dropped_{k}": v for k, v in sorted(c["dropped"].items())}, **_quantiles(r.response_times())}
            for k, v in (p or {}).items():
                if not isinstance(v, dict):
                    row[f"process_{k}"] = v
            rows.append(row)
        return pd.DataFrame(rows)

    def save(self, out: Any) -> None:
        """Write into the directory *out* (created if needed): the lateness histogram
        (``lateness.parquet``), the trace tables ``hil`` (``hil_events.parquet``) and
        ``hil_requests`` (``hil_requests.parquet``), the per-remote counters
        (``remotes.parquet``) and the whole trace (``trace/``, ``Trace.to_parquet``)."""
        from pathlib import Path
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        self.lateness.to_pandas().to_parquet(out / "lateness.parquet", index=False)
        self.sim.trace.frame("hil").to_parquet(out / "hil_events.parquet", index=False)
        self.sim.trace.frame("hil_requests").to_parquet(out / "hil_requests.parquet", index=False)
        self.per_remote().to_parquet(out / "remotes.parquet", index=False)
        self.sim.trace.to_parquet(out / "trace")


def _counters(child: subprocess.Popen) -> tuple[dict | None, int | None]:
    try:
        out, _ = child.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        child.kill()
        out, _ = child.communicate(timeout=10)
    lines = (out or "").strip().splitlines()
    last = lines[-1] if lines else ""
    try:
        counters = json.loads(last) if last.startswith("{") else None
    except json.JSONDecodeError:
        counters = None
    return counters, child.returncode


def run_with_remotes(sim: Any, remotes: Sequence[Any], until: float, commands: Sequence[Sequence[str]], *,
                     spawn: bool = True, connect_timeout: float = 30.0, cwd: Any = None,
                     before_run: Callable[[], None] | None = None,
                     signal_at: tuple[float, int] | None = None) -> RemoteRun:
    """Run *sim* until *until* (s) with one process per remote of *remotes*.

    ``commands``: one command line per remote (:func:`remote_command`).  ``spawn``:
    start them here (stdout captured); else print them and wait for someone to start
    them.  ``connect_timeout``: seconds to wait until every node is claimed
    (:class:`TimeoutError` naming the nodes that were not).  ``before_run()``: called once
    all are connected.  ``signal_at=(t, sig)``: send signal *sig* (e.g.
    ``signal.SIGKILL``, ``signal.SIGSTOP``) to the first spawned process at simulated time
    *t* (s), to exercise the loss policy; its counters are then not read.  ``cwd``: the
    spawned processes' working directory (None: this one's).

    A failure of ``sim.run`` does not propagate: the run is ended as usual (END sent,
    trace kept) and returned with ``failure`` set.
    """
    if len(commands) != len(remotes):
        raise ValueError(f"one command per remote: {len(remotes)} remotes, {len(commands)} commands")
    children: list[subprocess.Popen] = []
    failure: BaseException | None = None
    try:
        if spawn:
            children = [subprocess.Popen(list(c), cwd=cwd, stdout=subprocess.PIPE, text=True) for c in commands]
        else:
            print("start the remote side with:" if len(commands) == 1 else "start the remote sides with:",
                  flush=True)
            for c in commands:
                print("  " + shlex.join(c), flush=True)
        deadline = time.monotonic() + connect_timeout
        missing = [r.name for r in remotes if not r.wait_connected(max(0.0, deadline - time.monotonic()))]
        if missing:
            raise TimeoutError(f"the remote side of {', '.join(map(repr, missing))} did not connect within "
                               f"{connect_timeout} s")
        if before_run is not None:
            before_run()
        if signal_at is not None and children:
            proc, (t, sig) = children[0], signal_at
            sim.call_at(t, lambda: proc.send_signal(sig))
        t0 = time.monotonic()
        try:
            sim.run(until=until)
        except Exception as exc:    # the trace is kept and the processes are told the run is over
            failure = exc
        wall = time.monotonic() - t0
        for r in remotes:
            r.finish()
        processes: list[dict | None] = [None] * len(remotes)
        codes: list[int | None] = [None] * len(remotes)
        for i, child in enumerate(children):
            if signal_at is not None and i == 0:
                continue
            processes[i], codes[i] = _counters(child)
        drain([r for i, r in enumerate(remotes) if signal_at is None or i > 0])
        return RemoteRun(sim, remotes[0], remotes[0].clock.lateness, processes[0], wall, list(remotes), processes,
                         codes, failure)
    finally:
        for r in remotes:
            r.close()
        for child in children:
            if child.poll() is None:
                if signal_at is not None and signal_at[1] == _signal.SIGSTOP:
                    child.send_signal(_signal.SIGCONT)
                child.kill()
            child.wait(timeout=10)
            if child.stdout is not None:
                child.stdout.close()


def run_with_remote(sim: Any, remote: Any, until: float, command: Sequence[str], **options: Any) -> RemoteRun:
    """:func:`run_with_remotes` of *sim* with one remote and its command (*until* in s of simulated time)."""
    return run_with_remotes(sim, [remote], until, [command], **options)
