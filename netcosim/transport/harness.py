"""Running a simulation with its remote side: the command that starts the process, and
one run from connection to the last reply.

:func:`remote_command` builds the command line every remote program accepts
(``--run``, ``--node``, ``--lease``, ``--connect`` once per endpoint, after the program's
own arguments).  :func:`run_with_remote` starts that process (or prints the command for
someone to start it by hand, on another machine), waits for its liveliness token, runs
the simulation, ends the run (:meth:`finish`), reads the process's counters from the
last line of its stdout (a JSON object, the convention of the example processes) and
counts the replies that arrived after the stop time (:meth:`drain`).  The process is
killed and reaped in every case, also when the run fails.
"""

from __future__ import annotations

import json
import shlex
import signal as _signal
import subprocess
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

__all__ = ["remote_command", "run_with_remote", "RemoteRun"]


def remote_command(program: Sequence[str], *, run: str, node: str, endpoints: Sequence[str],
                   lease: float) -> list[str]:
    """``program`` (e.g. ``[sys.executable, "-m", "my.controller", "--gain", "2"]``) followed
    by ``--run RUN --node NODE --lease LEASE`` and ``--connect E`` for each endpoint."""
    cmd = [*program, "--run", run, "--node", node, "--lease", repr(float(lease))]
    for e in endpoints:
        cmd += ["--connect", e]
    return cmd


@dataclass
class RemoteRun:
    """One run with a remote side (what :func:`run_with_remote` returns): ``sim``,
    ``remote`` (the :class:`~netcosim.transport.remote.RemoteNode` or
    :class:`~netcosim.transport.remote.RemotePlantIO`), ``lateness`` (the real-time
    clock's histogram, :class:`~netcosim.transport.realtime.Lateness`), ``process`` (the
    process's counters from the last line of its stdout, a dict; None when it was not
    started here, was signalled, or printed none), ``wall`` (s of wall clock of
    ``sim.run``)."""

    sim: Any
    remote: Any
    lateness: Any
    process: dict | None
    wall: float

    def response_times(self) -> Any:
        """Simulated response time (s) of every reply (``remote.response_times()``)."""
        return self.remote.response_times()

    def summary(self) -> dict:
        """The run in numbers (times in s): response times (median, p99, max; NaN without
        replies), messages published to the process, received from it and arrived after
        the end, the lateness histogram's median, p99 and max, overruns, events, late
        injections, and the wall-clock time of the run."""
        import numpy as np
        resp, lat, r = self.response_times(), self.lateness, self.remote
        some = len(resp) > 0
        return {"response_median": float(np.median(resp)) if some else float("nan"),
                "response_p99": float(np.quantile(resp, 0.99)) if some else float("nan"),
                "response_max": float(np.max(resp)) if some else float("nan"),
                "published": r.published, "received": r.received, "after_end": r.after_end,
                "late_median": lat.quantile(0.5), "late_p99": lat.quantile(0.99), "late_max": lat.max,
                "overruns": lat.overruns, "events": lat.events, "late_injections": lat.late_injections,
                "wall": self.wall}

    def save(self, out: Any) -> None:
        """Write the lateness histogram (``lateness.parquet``) and the trace table ``hil``
        (``hil_events.parquet``) into the existing directory *out*."""
        from pathlib import Path
        out = Path(out)
        self.lateness.to_pandas().to_parquet(out / "lateness.parquet", index=False)
        self.sim.trace.frame("hil").to_parquet(out / "hil_events.parquet", index=False)


def run_with_remote(sim: Any, remote: Any, until: float, command: Sequence[str], *, spawn: bool = True,
                    connect_timeout: float = 30.0, cwd: Any = None,
                    before_run: Callable[[], None] | None = None,
                    signal_at: tuple[float, int] | None = None) -> RemoteRun:
    """Run *sim* until *until* (s) with *remote*'s process on the other side.

    ``spawn``: start *command* here (stdout captured); else print it and wait for someone
    to start it.  ``connect_timeout``: seconds to wait for the process's liveliness token
    (:class:`TimeoutError` naming the node after that).
    ``before_run()``: called once it is connected.  ``signal_at=(t, sig)``: send signal
    *sig* (e.g. ``signal.SIGKILL``, ``signal.SIGSTOP``) to the spawned process at simulated
    time *t* (s), to exercise the loss policy; its counters are then not read.
    """
    child: subprocess.Popen | None = None
    try:
        if spawn:
            child = subprocess.Popen(list(command), cwd=cwd, stdout=subprocess.PIPE, text=True)
        else:
            print("start the remote side with:\n  " + shlex.join(command), flush=True)
        if not remote.wait_connected(connect_timeout):
            raise TimeoutError(f"the remote side of {remote.name!r} did not connect within "
                                    f"{connect_timeout} s")
        if before_run is not None:
            before_run()
        if signal_at is not None and child is not None:
            proc, (t, sig) = child, signal_at
            sim.call_at(t, lambda: proc.send_signal(sig))
        t0 = time.monotonic()
        sim.run(until=until)
        wall = time.monotonic() - t0
        remote.finish()
        counters = None
        if child is not None and signal_at is None:
            out, _ = child.communicate(timeout=30)
            last = out.strip().splitlines()[-1] if out.strip() else ""
            counters = json.loads(last) if last.startswith("{") else None
        if signal_at is None:
            remote.drain()
        return RemoteRun(sim, remote, remote.clock.lateness, counters, wall)
    finally:
        if child is not None:
            if child.poll() is None:
                if signal_at is not None and signal_at[1] == _signal.SIGSTOP:
                    child.send_signal(_signal.SIGCONT)
                child.kill()
            child.wait(timeout=10)
            if child.stdout is not None:
                child.stdout.close()
