"""The main job (``make run``): the TrueTime examples and the thesis reproductions.

Runs every experiment of :data:`EXPERIMENTS` (or those named with ``--only``), each in
its own Python process (``python -m netcosim.experiments.NAME --outdir OUTDIR/NAME``) with a
time limit, so an experiment that exits, crashes or hangs cannot stop the others.
Its output streams through as it runs; it writes its plots (PNG) and data (Parquet)
under ``OUTDIR/NAME/``, and nothing it wrote is ever deleted, also when it fails.  At
the end a table gives each experiment's status (ok, failed, timeout), its duration and
its output directory; the exit status is 1 if any experiment failed or timed out.
"""

from __future__ import annotations

import argparse
import math
import numbers
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence, TextIO

from netcosim.errors import ConfigurationError, ConfigurationTypeError

#: (module in experiments/, what it reproduces).  A name with a dot is a full module
#: name (its last component names the output folder).
EXPERIMENTS = [
    ("flycrane_network", "§4.6.1, Fig. 4.11, App. A: networked Fly-crane over lossy 802.11b, offline vs online"),
    ("servo", "TrueTime servo example: PID with 2 ms computational delay"),
    ("threeservos", "TrueTime three-servo overload: deadline monotonic vs EDF, task 3 in a CBS or a TBS"),
    ("networked_servo", "TrueTime networked servo on CSMA/CD and CAN with an interfering node"),
    ("gateway", "TrueTime gateway example: a loop over three CAN buses, end-to-end delay with and without disturbance"),
    ("aodv", "TrueTime AODV example: ad hoc routing over 802.11b, route break and repair, hello intervals"),
    ("clock_sync", "Local clocks: two-way time transfer over a network, residual offset vs drift, period, asymmetry"),
    ("multicore_dhall", "Multicore: Dhall's effect, global vs partitioned EDF and RM on M cores"),
    ("wireless_tpc", "TrueTime wireless example: 802.15.4 servo loop on batteries, transmit-power control"),
    ("dvs", "DVS of three PID loops under EDF: CPU energy against control cost over speeds"),
    ("threeservos_cost", "Three servos scored by exact expected cost per loop: DM, EDF, CBS, TBS"),
    ("jitterbug_servo", "Jitterbug's DC servo, exact LQ analysis: expected cost vs delay and vs period"),
    ("expected_cost_loss", "Networked servo, Bernoulli loss: exact expected cost vs loss over a Monte-Carlo band"),
    ("loss_sweep_servo", "Networked servo over 802.11b: loss sweep, broadcast vs unicast, frame vs message loss"),
    ("ch2_landing", "Ch. 2: tethered-UAV landing, NMPC alone vs two-layer controller, calm and wind"),
    ("ch3_fig3_8", "Fig. 3.8: offline vs online gain, Fly-crane, small and large ball"),
    ("ch3_fig3_10_12", "Figs. 3.10-3.12: the LAAS rig's waypoint path, dynamic model over lossy 802.11b"),
    ("ch4_fig4_8_9", "Figs. 4.8/4.9: 4-robot non-square system, 2-norm and inf-norm"),
    ("ch4_fig4_10", "Fig. 4.10: dynamic model with velocity tracking, three alphas"),
    ("flycrane_cable_break", "Beyond the thesis (6.3): a cable breaks mid-manoeuvre; which configurations hold"),
    ("ch5_table5_2", "Table 5.2, Figs. 5.3-5.7: stability set, optimal gain and period"),
    ("ch5_fig5_8_9", "Figs. 5.8/5.9a: SIKM tracking strategies on the Fly-crane"),
]

#: Seconds one experiment may run before it is stopped (the longest takes about a minute).
DEFAULT_TIMEOUT = 1800.0

#: Seconds between asking a timed-out experiment to stop (SIGTERM) and killing it.
KILL_GRACE = 5.0


@dataclass(frozen=True)
class Outcome:
    """How one experiment ended: ``status`` is ``"ok"``, ``"failed"`` or ``"timeout"``;
    ``returncode`` the process's exit status (``None`` after a timeout); ``seconds`` its
    wall-clock duration; ``outdir`` where it wrote."""

    name: str
    status: str
    returncode: int | None
    seconds: float
    outdir: Path


def module_of(name: str) -> str:
    """The module run for an experiment entry: ``netcosim.experiments.NAME`` unless NAME has a dot."""
    return name if "." in name else f"experiments.{name}"


def check_timeout(timeout) -> float:
    """*timeout* (seconds) as a float.

    Raises :class:`~netcosim.errors.ConfigurationTypeError` (a ``TypeError``) if it is
    not a real number and :class:`~netcosim.errors.ConfigurationError` (a
    ``ValueError``) naming it unless it is finite and positive.
    """
    if isinstance(timeout, bool) or not isinstance(timeout, numbers.Real):
        raise ConfigurationTypeError(f"timeout must be a number of seconds, got {timeout!r}")
    if not (math.isfinite(timeout) and timeout > 0):
        raise ConfigurationError(f"timeout must be a finite positive number of seconds, got {timeout!r}")
    return float(timeout)


def _child_env() -> dict[str, str]:
    """The environment of an experiment process: it imports what this process imports."""
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"            # its output streams through line by line
    env.setdefault("MPLBACKEND", "Agg")       # experiments only save figures
    prefixes = {os.path.realpath(p) for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)}
    extra = []
    for entry in sys.path:
        path = os.path.realpath(entry or os.getcwd())
        if os.path.isdir(path) and not any(path == p or path.startswith(p + os.sep) for p in prefixes):
            extra.append(path)
    if env.get("PYTHONPATH"):
        extra.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(extra))
    return env


def _stop(proc: subprocess.Popen) -> None:
    """Stop *proc* and everything it started (its own process group): SIGTERM, then SIGKILL."""
    if os.name == "posix":
        for sig, wait in ((signal.SIGTERM, KILL_GRACE), (signal.SIGKILL, None)):
            try:
                os.killpg(proc.pid, sig)
            except ProcessLookupError:
                return
            try:
                proc.wait(timeout=wait)
                return
            except subprocess.TimeoutExpired:
                continue
    else:                                     # pragma: no cover - no process groups
        proc.kill()
        proc.wait()


def run_one(name: str, outdir: Path, *, timeout: float, quick: bool = False, out: TextIO | None = None,
            python: str = sys.executable, clock: Callable[[], float] = time.monotonic) -> Outcome:
    """Run one experiment in its own process; stream its output to *out* (default stdout).

    The process runs ``python -m MODULE --outdir OUTDIR/NAME [--quick]`` and is stopped
    after *timeout* seconds.  Returns its :class:`Outcome`.
    """
    out = out or sys.stdout
    folder = Path(outdir) / name.rsplit(".", 1)[-1]
    cmd = [python, "-m", module_of(name), "--outdir", str(folder)] + (["--quick"] if quick else [])
    start = clock()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            env=_child_env(), text=True, errors="replace", bufsize=1,
                            start_new_session=(os.name == "posix"))

    def pump():
        for line in proc.stdout:
            out.write(line)
            out.flush()

    reader = threading.Thread(target=pump, daemon=True)
    reader.start()
    try:
        returncode = proc.wait(timeout=timeout)
        status = "ok" if returncode == 0 else "failed"
    except subprocess.TimeoutExpired:
        _stop(proc)
        returncode, status = None, "timeout"
    finally:
        reader.join(timeout=KILL_GRACE)
        proc.stdout.close()
    return Outcome(name, status, returncode, clock() - start, folder)


def summary_table(outcomes: Sequence[Outcome], timeout: float) -> str:
    """The end-of-job table: name, status, seconds, output directory (one line each)."""
    rows = [("experiment", "status", "seconds", "output")]
    for o in outcomes:
        status = o.status
        if o.status == "failed":
            status = f"failed (exit {o.returncode})"
        elif o.status == "timeout":
            status = f"timeout (> {timeout:g} s)"
        rows.append((o.name, status, f"{o.seconds:.1f}", f"{o.outdir}/"))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    return "\n".join(f"{r[0]:<{widths[0]}}  {r[1]:<{widths[1]}}  {r[2]:>{widths[2]}}  {r[3]}" for r in rows)


def run_all(experiments: Sequence[tuple[str, str]], outdir: str | Path = "results", *,
            timeout: float = DEFAULT_TIMEOUT, quick: bool = False, out: TextIO | None = None,
            python: str = sys.executable) -> list[Outcome]:
    """Run each ``(name, description)`` of *experiments* in turn (see :func:`run_one`).

    Prints a start line per experiment (name, description, output folder) and its
    output as it comes.  Returns the outcomes, in order.
    """
    out = out or sys.stdout
    timeout = check_timeout(timeout)
    outcomes = []
    for i, (name, what) in enumerate(experiments, start=1):
        folder = Path(outdir) / name.rsplit(".", 1)[-1]
        out.write(f"[{i}/{len(experiments)} {name}] {what} -> {folder}/\n")
        out.flush()
        o = run_one(name, Path(outdir), timeout=timeout, quick=quick, out=out, python=python)
        note = {"ok": "ok", "failed": f"FAILED (exit {o.returncode})", "timeout": f"TIMEOUT after {timeout:g} s"}
        out.write(f"[{name}] {note[o.status]} ({o.seconds:.1f} s)\n")
        out.flush()
        outcomes.append(o)
    return outcomes


def main(outdir: str | Path = "results", only: Sequence[str] | None = None, *,
         timeout: float = DEFAULT_TIMEOUT, quick: bool = False,
         experiments: Sequence[tuple[str, str]] | None = None) -> int:
    """Run the main job; returns the exit status (0 if every experiment succeeded, else 1).

    ``outdir``: parent of the per-experiment folders; ``only``: names to run (default
    all); ``timeout``: seconds per experiment; ``quick``: pass ``--quick`` to each;
    ``experiments``: the ``(name, description)`` list (default :data:`EXPERIMENTS`).
    Raises ``ValueError`` naming any name of *only* that is not in the list, a bad
    *timeout* (see :func:`check_timeout`) or an empty *outdir*.
    """
    experiments = list(EXPERIMENTS if experiments is None else experiments)
    timeout = check_timeout(timeout)
    if not str(outdir).strip():
        raise ConfigurationError(f"outdir must name a directory, got {outdir!r}")
    if only:
        known = [n for n, _ in experiments]
        unknown = [n for n in only if n not in known]
        if unknown:
            raise ConfigurationError(f"unknown experiment(s) {unknown}; choose from {known}")
        experiments = [e for e in experiments if e[0] in only]
    outcomes = run_all(experiments, outdir, timeout=timeout, quick=quick)
    print("\n" + summary_table(outcomes, timeout), flush=True)
    bad = [o for o in outcomes if o.status != "ok"]
    if bad:
        print("failed: " + ", ".join(f"{o.name} ({o.status})" for o in bad), file=sys.stderr, flush=True)
        return 1
    return 0


def _positive_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    try:
        return check_timeout(value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _directory(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError(f"must name a directory, got {text!r}")
    return text


def cli(argv: Sequence[str] | None = None) -> int:
    """``python -m netcosim.experiments.main [--outdir DIR] [--only NAME ...] [--timeout S] [--quick]``."""
    names = [n for n, _ in EXPERIMENTS]
    p = argparse.ArgumentParser(prog="python -m netcosim.experiments.main", description=__doc__.splitlines()[0],
                                epilog="\n".join(__doc__.splitlines()[2:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--outdir", type=_directory, default="results",
                   help="parent of the per-experiment folders (default: results)")
    p.add_argument("--only", nargs="+", metavar="NAME", choices=names,
                   help=f"run only these experiments, among: {', '.join(names)}")
    p.add_argument("--timeout", type=_positive_seconds, default=DEFAULT_TIMEOUT, metavar="S",
                   help=f"seconds one experiment may run before it is stopped (default: {DEFAULT_TIMEOUT:g})")
    p.add_argument("--quick", action="store_true", help="each experiment's short run")
    a = p.parse_args(argv)
    return main(a.outdir, a.only, timeout=a.timeout, quick=a.quick)


if __name__ == "__main__":
    sys.exit(cli())
