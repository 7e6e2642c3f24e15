"""The networked Fly-crane with its five nodes in five real processes, over Zenoh (HIL).

The offline strategy of thesis §4.6.1 / appendix A (sparse architecture): every T = 1.5 s
the load (node ``pivot``) samples its pose ``q_V`` and broadcasts it over the simulated
IEEE 802.11b network (1.2 Mbit/s); each robot, on receiving it, reads its own cable angle
``q_i`` and applies the velocity of the sparse law (3.10) with the offline gain (zero-order
hold).  Here the plant (the dynamic model (4.10) under velocity tracking (4.11)) and the
network stay simulated, in real time; the five nodes' computations run in five OS
processes (``netcosim.experiments.hil_flycrane_node``), one
:class:`~netcosim.transport.remote.RemoteNode` each: the pivot's samples are LOCAL
requests answered with a broadcast, a robot's requests are the frames the network
delivers to it (plus its ``q_i``), answered with ``u_i`` to its plant inputs.

The script starts the processes itself (``--no-spawn``: prints their commands and waits up
to 10 minutes for them), runs ``--until`` s (default 15 s = 10 periods; ``--quick``: 6 s)
in real time, then the all-simulated run and the **replay**: the all-simulated run in
which every node's computation takes exactly the response time measured for the
matching request (request k of a remote is its k-th request; the simulated pose and
command tasks' execution times).  The HIL output equals the replay bit for bit; its
deviation from the all-simulated run must stay within 1.5 times the deviation the replay
explains (plus 1e-9).  Writes ``summary.parquet``, ``remotes.parquet`` (per-remote
counters and response times), ``outputs.png``, ``hil_events.parquet``,
``hil_requests.parquet``, ``lateness.parquet``, ``trace/`` and the law file the robot
processes read (``flycrane_law.json``).

Real time: the plant is integrated by LSODA on the simulation thread, 3.5-5 ms of wall
clock per period (one ``solve_ivp`` call from the last command to the next sample); by
default (``--no-prefetch`` to switch it off) that integration runs in the idle middle of
each period (:class:`PlantPrefetch`), not when the next sample reads the plant, so it
neither delays the sample nor counts in the pivot's response time.
"""

from __future__ import annotations

import json
import math
import shutil
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd

from netcosim.controllers.planner.networked import FlyCraneNetworkConfig, FlyCraneRun, build
from netcosim.timebase import TICKS_PER_SECOND, to_ticks
from netcosim.transport.harness import RemoteRun, remote_command, run_with_remotes
from netcosim.transport.remote import RemoteNode
from netcosim.transport.session import LOOPBACK, new_run_id, open_session

from .hil_flycrane_node import HEADER_VALUES, LAW_FORMAT, JacobianTape

ROOT = Path(__file__).resolve().parent.parent
#: default horizon (s): 10 periods of T = 1.5 s, in real time
UNTIL = 15.0
#: the ``--quick`` horizon (s): 4 periods
QUICK = 6.0
#: floor of the tolerance (rad and m): the HIL run equals the replay bit for bit, so it only
#: keeps a tolerance of 1.5 x 0 from failing a run whose response times equal the nominal ones
FLOOR = 1e-9
#: what each role exchanges (handed to the process by the info query)
SCHEMA = {"pivot": {"request": ["q_V[6] (m, rad)"], "reply": ["h", "t_h [s]", "q_V[6] (m, rad)"], "to": "broadcast"},
          "robot": {"request": ["h", "t_h [s]", "q_V[6] (m, rad)", "q_i (rad)"], "reply": ["u_i[3] (m/s)"],
                    "to": "local"}}


def flycrane_config(until: float = UNTIL, *, loss: float = 0.0, seed: int = 0) -> FlyCraneNetworkConfig:
    """The offline networked Fly-crane of Fig. 4.11 (broadcast, dynamic plant, 1.2 Mbit/s,
    T = 1.5 s) for *until* s with frame-loss probability *loss*."""
    return FlyCraneNetworkConfig(strategy="offline", loss=loss, horizon=until, seed=seed)


# ----------------------------------------------------------------------------- the law file

def law_spec(dep: Any, system: Any) -> dict:
    """What a robot process needs to compute the sparse law of deployment *dep* without
    CasADi (:data:`~netcosim.experiments.hil_flycrane_node.LAW_FORMAT`): ``kd`` (the offline gain
    times ``K_bar``'s diagonal, as ``_sparse_feedback`` passes it to ``robot_velocity``),
    ``q_ref``, the star structure and the system's Jacobian as its SX instruction list;
    checked: the tape gives the system's ``A_q`` bit for bit at ``q_ref``."""
    import casadi as ca

    from netcosim.controllers.planner.kinematics import diag_gain
    from netcosim.controllers.planner.laws import OfflineGain
    law, st = dep.law, dep.structure
    if not isinstance(law.gain, OfflineGain) or law.trajectory is not None or law.feedforward != "none":
        raise ValueError("the remote robots run the offline sparse law with a constant reference only")
    f = system.A_fun
    if f.n_in() != 1 or f.n_out() != 1 or not f.sparsity_in(0).is_dense() or f.nnz_in(0) != system.m:
        raise ValueError(f"{f.name()}: expected one dense input of {system.m} values and one output")
    ops = {}
    for name in dir(ca):
        if name.startswith("OP_") and isinstance(getattr(ca, name), int):
            ops.setdefault(getattr(ca, name), name[3:])
    tape, work = [], 0
    for k in range(f.n_instructions()):
        op = ops[f.instruction_id(k)]
        i, o = [int(v) for v in f.instruction_input(k)], [int(v) for v in f.instruction_output(k)]
        if op == "INPUT":
            tape.append([op, o[0], i[0], i[1], None])
            work = max(work, o[0] + 1)
        elif op == "OUTPUT":
            tape.append([op, o[0], i[0], o[1], None])
            work = max(work, i[0] + 1)
        elif op == "CONST":
            tape.append([op, o[0], 0, 0, float(f.instruction_constant(k))])
            work = max(work, o[0] + 1)
        else:
            tape.append([op, o[0], i[0], i[1] if len(i) > 1 else 0, None])
            work = max(work, o[0] + 1, *(v + 1 for v in i))
    sp = f.sparsity_out(0)
    spec = {"format": LAW_FORMAT, "system": system.name, "n": system.n, "m": system.m,
            "kd": (float(law.gain.k) * diag_gain(law.kbar, system.m)).tolist(),
            "q_ref": np.asarray(law.reference(0.0), dtype=float).tolist(),
            "rows": [list(r) for r in st.rows], "cols": [list(c) for c in st.cols], "pivot": list(st.pivot),
            "jacobian": {"n_in": system.m, "shape": [sp.size1(), sp.size2()], "work": work, "tape": tape,
                         "nz": [[int(r), int(c)] for r, c in zip(sp.row(), sp.get_col())]}}
    tape_fn = JacobianTape(spec["jacobian"])
    q = np.asarray(spec["q_ref"])
    if not np.array_equal(tape_fn(q), system.jacobian(q)):
        raise ValueError(f"the instruction list of {f.name()} does not reproduce A_q bit for bit")
    return spec


def write_law(path: Any, dep: Any, system: Any) -> Path:
    """Write :func:`law_spec` as JSON to *path* (floats round-trip exactly); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(law_spec(dep, system)))
    return path


# ----------------------------------------------------------------------------- the HIL run

def node_command(run: str, endpoints: Sequence[str], node: str, law_path: Any, *, idle: float = 10.0,
                 lease: float = 1.0, session: int | None = None, python: str = sys.executable) -> list[str]:
    """The command that starts the process of *node* (``pivot`` or ``robotI``) for run *run*."""
    role = ["--role", "pivot"] if node == "pivot" else ["--role", "robot", "--index", node[len("robot"):],
                                                          "--law", str(Path(law_path).resolve())]
    return remote_command([python, "-m", "netcosim.experiments.hil_flycrane_node", *role, "--idle", repr(idle)],
                          run=run, node=node, endpoints=endpoints, lease=lease, session=session)


def attach_remotes(sim: Any, dep: Any, config: FlyCraneNetworkConfig, session: Any, run: str,
                   **clock_options: Any) -> list[RemoteNode]:
    """Make the five nodes of the deployment *dep* remote: their simulated tasks are stopped
    (the pivot's periodic pose task; the robots' command tasks are released by frames, which
    the remote nodes now take), the pivot samples ``q_V`` every T (LOCAL requests, replies
    broadcast with ``(h, t_h, q_V)``: 8 values of ``size_bits``, the simulated pose message's
    size) and each robot publishes the frames delivered to it followed by its ``q_i`` and
    writes the reply to its rows of the plant's inputs.  *clock_options* go to the
    :class:`~netcosim.transport.realtime.RealtimeClock` (``max_lag``, ``spin``, ...)."""
    st, plant, T = dep.structure, dep.plant, config.T
    for node in (dep.pivot, *dep.robots):
        for task in node.tasks.values():
            task.stop()
    n_V = len(st.pivot)
    remotes = [RemoteNode(sim, "pivot", session, run=run, size_bits=config.size_bits * (n_V + 1), period=T,
                          sample_period=T, plant=plant, outputs=list(st.pivot), reply_values=HEADER_VALUES + n_V,
                          destinations=("broadcast",), schema=SCHEMA["pivot"], **clock_options)]
    for i, node in enumerate(dep.robots):
        # a robot answers its plant inputs only
        remotes.append(RemoteNode(sim, node.name, session, run=run, size_bits=config.size_bits, period=T,
                                  plant=plant, outputs=list(st.cols[i]), inputs=list(st.rows[i]),
                                  destinations=("local",), schema=SCHEMA["robot"]))
    return remotes


class PlantPrefetch:
    """Integrate the plant up to the next sampling instant in the idle middle of each period.

    Every *period* s, *offset* s after a sample, if no remote has a request waiting for its
    reply: ``plant.advance(t_next)`` with ``t_next`` the next sampling instant (or the end of
    the run), computed as the sample's own read would compute it (``ticks /
    TICKS_PER_SECOND``).  The plant's next read then integrates nothing; the one
    ``solve_ivp`` call from the last I/O instant to ``t_next`` is the call that read would
    have made (same interval, state and held input), so the result is the same to the bit
    -- provided nothing reads or writes the plant between the prefetch and ``t_next``, which
    :meth:`violations` checks afterwards against the remotes' requests and replies.
    ``wall``: seconds of wall clock of every prefetch; ``skipped``: prefetches not done."""

    def __init__(self, sim: Any, plant: Any, remotes: Sequence[Any], period: float, until: float,
                 offset: float | None = None):
        self.sim, self.plant, self.remotes = sim, plant, list(remotes)
        self.period_ticks = to_ticks(period, "period")
        self.until_ticks = to_ticks(until, "until")
        self.offset_ticks = to_ticks(period / 2 if offset is None else offset, "offset")
        self.wall: list[float] = []
        self.windows: list[tuple[int, int]] = []
        self.skipped = 0
        sim.call_at_ticks(self.offset_ticks, self._prefetch)

    def _busy(self) -> bool:
        return any(r.published > r.received + r.expired for r in self.remotes)

    def _prefetch(self) -> None:
        now = self.sim.now_ticks
        target = min((now // self.period_ticks + 1) * self.period_ticks, self.until_ticks)
        if self._busy() or target <= now:
            self.skipped += 1
        else:
            t0 = time.perf_counter()
            self.plant.advance(target / TICKS_PER_SECOND)
            self.wall.append(time.perf_counter() - t0)
            self.windows.append((now, target))
        if now + self.period_ticks < self.until_ticks:
            self.sim.call_in_ticks(self.period_ticks, self._prefetch)

    def violations(self) -> int:
        """Requests published or replies applied strictly inside a prefetched interval
        (prefetch instant, target): 0 for a run whose plant I/O the prefetch left alone."""
        instants = []
        for r in self.remotes:
            req = r.requests()
            t, resp = req["time"].to_numpy(), req["response"].to_numpy()
            instants += [t, (t + resp)[np.isfinite(resp)]]
        x = np.round(np.concatenate(instants) * TICKS_PER_SECOND) if instants else np.zeros(0)
        return int(sum(np.count_nonzero((x > a) & (x < b)) for a, b in self.windows))


@dataclass
class HilFlyCraneRun(RemoteRun):
    """One HIL run of the networked Fly-crane: the fields of
    :class:`~netcosim.transport.harness.RemoteRun` (``remotes``: pivot, robot1..robot4),
    ``config``, ``recorder`` (q and u on the ``sample_dt`` grid), ``prefetch``
    (:class:`PlantPrefetch` or None) and ``tasks_released`` (jobs the stopped simulated tasks
    released: 0)."""

    config: Any = None
    recorder: Any = None
    prefetch: Any = None
    tasks_released: int = 0

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, q, u)`` on the grid (s; rad and m; m/s)."""
        return self.recorder.arrays()

    def responses(self) -> dict[str, dict[int, float]]:
        """``{node: {seq: response (s)}}`` of every request whose reply was applied
        (:meth:`~netcosim.transport.remote.RemoteNode.requests`, outcome ``replied``)."""
        out = {}
        for r in self.remotes:
            req = r.requests()
            req = req[req["outcome"] == "replied"]
            out[r.name] = dict(zip(req["seq"].astype(int).tolist(), req["response"].astype(float).tolist()))
        return out


def run_hil(config: FlyCraneNetworkConfig, *, law_path: Any = None, spawn: bool = True, prefetch: bool = True,
            lease: float = 1.0, idle: float = 10.0, connect_timeout: float = 30.0, max_lag: float = 0.005,
            listen: Sequence[str] = (LOOPBACK,), connect: Sequence[str] = ()) -> HilFlyCraneRun:
    """Run *config* for ``config.horizon`` s in real time with its five nodes in five
    processes (started here; ``spawn=False`` prints their commands and waits up to
    ``connect_timeout`` s).  ``law_path``: where to write the robots' law file (default: a
    temporary file, removed after the run); ``prefetch``: :class:`PlantPrefetch`."""
    from netcosim import Simulation
    from netcosim.controllers.planner.networked import setting
    tmp = None
    if law_path is None:
        tmp = Path(tempfile.mkdtemp(prefix="hil_flycrane_"))
        law_path = tmp / "flycrane_law.json"
    run = new_run_id()
    session = open_session(listen=listen, connect=connect, lease=lease)
    try:
        sim = Simulation(config.seed)
        dep, recorder = build(sim, config)
        write_law(law_path, dep, setting(config)[0])
        remotes = attach_remotes(sim, dep, config, session, run, max_lag=max_lag)
        pf = PlantPrefetch(sim, dep.plant, remotes, config.T, config.horizon) if prefetch else None
        cmds = [node_command(run, session.endpoints, r.name, law_path, idle=idle, lease=lease, session=r.session_id)
                for r in remotes]
        info = run_with_remotes(sim, remotes, config.horizon, cmds, spawn=spawn, connect_timeout=connect_timeout,
                                cwd=ROOT)
        released = sum(t.jobs_released for n in (dep.pivot, *dep.robots) for t in n.tasks.values())
        return HilFlyCraneRun.of(info, config=config, recorder=recorder, prefetch=pf, tasks_released=released)
    finally:
        session.close()
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


# ----------------------------------------------------------------------------- the comparison

def run_simulated(config: FlyCraneNetworkConfig) -> FlyCraneRun:
    """The all-simulated run (:func:`netcosim.controllers.planner.networked.run`)."""
    from netcosim.controllers.planner.networked import run
    return run(config)


class ReplayTimes:
    """Execution times ``fn(rng) -> s`` for the simulated pose and command tasks: the
    *k*-th job of a node's task takes the response time measured for request ``seq == k``
    of that node's remote (*responses*: ``{node: {seq: s}}``).  Which node a call is for
    is told by the random stream it is given (the task's execution-time stream
    ``node/task/execution``, see ``TaskContext.execute``).  A request without a reply
    takes *missing* s (default: the deadline) and is listed in ``missing``; the replay is
    then exact only if that job would not have ended within the run either."""

    def __init__(self, sim: Any, responses: dict[str, dict[int, float]], missing: float):
        self.sim, self.responses, self.default = sim, responses, float(missing)
        self._node: dict[int, str] = {}
        self._k: Counter[str] = Counter()
        self.missing: list[tuple[str, int, float]] = []

    def bind(self, nodes: Sequence[Any]) -> None:
        """Learn the execution-time streams of the tasks of *nodes* (after they are built)."""
        for node in nodes:
            for task in node.tasks:
                self._node[id(self.sim.rng(f"{node.name}/{task}/execution"))] = node.name

    def __call__(self, rng: Any) -> float:
        name = self._node[id(rng)]
        k = self._k[name]
        self._k[name] += 1
        d = self.responses.get(name, {}).get(k)
        if d is None:
            self.missing.append((name, k, self.sim.now))
            return self.default
        return d

    def jobs(self) -> dict[str, int]:
        """Jobs timed so far, per node."""
        return dict(self._k)


def run_replay(config: FlyCraneNetworkConfig, responses: dict[str, dict[int, float]]) -> tuple[FlyCraneRun, list]:
    """The all-simulated run in which the *k*-th pose job of the pivot and the *k*-th
    command job of robot I take the response time (s) measured for request ``seq == k``
    of that node (*responses*: :meth:`HilFlyCraneRun.responses`): what the HIL run
    must reproduce.  Returns the run and the requests that had no reply (node, k, t)."""
    from netcosim import Simulation
    sim = Simulation(config.seed)
    times = ReplayTimes(sim, responses, config.T)
    if config.strategy != "offline":
        raise ValueError("the replay is for the offline strategy")
    dep, recorder = build(sim, config, exec_pivot=times, exec_robot=times)
    times.bind([dep.pivot, *dep.robots])
    failure = None
    try:
        sim.run(config.horizon)
    except Exception as exc:  # the plant left its domain: keep what was recorded
        failure = f"{type(exc).__name__}: {exc}"
    return FlyCraneRun.collect(config, sim, dep, recorder, failure), times.missing


def deviation(q_a: np.ndarray, q_b: np.ndarray) -> float:
    """Largest ``|q_a - q_b|`` (rad and m) of two runs on the same grid."""
    if q_a.shape != q_b.shape:
        raise ValueError(f"the runs' grids differ: {q_a.shape} and {q_b.shape}")
    return float(np.max(np.abs(q_a - q_b)))


@dataclass
class Comparison:
    """The HIL run against the all-simulated run and the replay: ``nominal`` and ``replay``
    (:class:`~netcosim.controllers.planner.networked.FlyCraneRun`), ``missing`` (requests without a
    reply), ``deviation`` (HIL vs nominal), ``explained`` (replay vs nominal),
    ``tolerance`` (1.5 x explained + :data:`FLOOR`), ``residual`` (HIL vs replay) and
    ``bit_exact`` (HIL q and u equal the replay's to the bit)."""

    nominal: Any
    replay: Any
    missing: list
    deviation: float
    explained: float
    tolerance: float
    residual: float
    bit_exact: bool


def compare(hil: HilFlyCraneRun, nominal: FlyCraneRun | None = None) -> Comparison:
    """Run the all-simulated run (unless given) and the replay of *hil*, and compare."""
    config = hil.config
    nominal = nominal if nominal is not None else run_simulated(config)
    replay, missing = run_replay(config, hil.responses())
    t, q, u = hil.arrays()
    if not np.array_equal(t, nominal.t) or not np.array_equal(t, replay.t):
        raise ValueError("the HIL run's grid differs from the simulated runs'")
    explained = deviation(replay.q, nominal.q)
    return Comparison(nominal, replay, missing, deviation(q, nominal.q), explained, 1.5 * explained + FLOOR,
                      deviation(q, replay.q), bool(np.array_equal(q, replay.q) and np.array_equal(u, replay.u)))


def summary(hil: HilFlyCraneRun, cmp: Comparison) -> dict:
    """One row: horizon, loss, deviation, tolerance, residual, bit_exact, message counts of
    all remotes, response times (s, robots pooled and the pivot), lateness (s), prefetch
    (count, wall median and max in s, skipped, violations), wall clock of the run (s)."""
    lat, cfg = hil.lateness, hil.config
    per = hil.per_remote()
    robot_resp = np.concatenate([r.response_times() for r in hil.remotes[1:]])
    pivot_resp = hil.remotes[0].response_times()
    pf = hil.prefetch
    row = {"until": cfg.horizon, "loss": cfg.loss, "seed": cfg.seed, "deviation": cmp.deviation,
           "explained": cmp.explained, "tolerance": cmp.tolerance, "residual": cmp.residual,
           "bit_exact": cmp.bit_exact, "missing_replies": len(cmp.missing),
           **{k: int(per[k].sum()) for k in ("published", "received", "expired", "overruns", "unserved", "after_end")},
           "dropped": int(per.filter(like="dropped_").to_numpy().sum()),
           "process_published": int(per["process_published"].sum()) if "process_published" in per else -1,
           "process_received": int(per["process_received"].sum()) if "process_received" in per else -1,
           "statuses": ",".join(str(s) for s in per.get("process_status", pd.Series(dtype=str)).tolist()),
           "tasks_released": hil.tasks_released}
    for name, resp in (("pivot", pivot_resp), ("robot", robot_resp)):
        for q, label in ((0.5, "median"), (0.9, "p90"), (0.99, "p99"), (1.0, "max")):
            row[f"{name}_response_{label}"] = float(np.quantile(resp, q)) if len(resp) else math.nan
    row.update({"late_median": lat.quantile(0.5), "late_p99": lat.quantile(0.99), "late_max": lat.max,
                "late_overruns": lat.overruns, "events": lat.events, "late_injections": lat.late_injections,
                "prefetches": len(pf.wall) if pf else 0,
                "prefetch_wall_median": float(np.median(pf.wall)) if pf and pf.wall else math.nan,
                "prefetch_wall_max": float(np.max(pf.wall)) if pf and pf.wall else math.nan,
                "prefetch_skipped": pf.skipped if pf else 0, "prefetch_violations": pf.violations() if pf else 0,
                "wall": hil.wall, "failure": "" if hil.failure is None else f"{type(hil.failure).__name__}: "
                                                                            f"{hil.failure}"})
    return row


def plot(path: Any, hil: HilFlyCraneRun, cmp: Comparison) -> None:
    """``||q - q^r||`` and the cable angles of the HIL run and the all-simulated run, and
    the HIL run's deviation from both simulated runs."""
    import matplotlib.pyplot as plt
    t, q, _ = hil.arrays()
    nom = cmp.nominal
    fig, (ax_e, ax_a, ax_d) = plt.subplots(3, 1, sharex=True, figsize=(8, 8))
    ax_e.semilogy(nom.t, nom.norm_e, lw=1.0, label="all simulated")
    ax_e.semilogy(t, np.linalg.norm(q - nom.q_ref, axis=1), "--", lw=1.0, label="five nodes in real processes (Zenoh)")
    ax_e.set_ylabel("||q - q^r||")
    ax_e.legend(loc="upper right")
    ax_a.plot(nom.t, nom.alpha, lw=1.0)
    ax_a.set_prop_cycle(None)
    ax_a.plot(t, np.degrees(q[:, :4]), "--", lw=1.0)
    ax_a.set_ylabel("cable angles (deg)")
    ax_d.semilogy(t, np.maximum(np.max(np.abs(q - nom.q), axis=1), 1e-18), lw=1.0, label="HIL - all simulated")
    ax_d.semilogy(t, np.maximum(np.max(np.abs(cmp.replay.q - nom.q), axis=1), 1e-18), ":", lw=1.5,
                  label="replay - all simulated")
    ax_d.axhline(cmp.tolerance, color="k", lw=0.8, label="tolerance")
    ax_d.set_ylabel("max |Δq| (rad, m)")
    ax_d.set_xlabel("t (s)")
    ax_d.legend(loc="lower right")
    for ax in (ax_e, ax_a, ax_d):
        ax.grid(alpha=0.3)
    fig.suptitle(f"networked Fly-crane, offline, loss {hil.config.loss:g}: deviation {cmp.deviation:.2e} "
                 f"(tolerance {cmp.tolerance:.2e}), HIL {'==' if cmp.bit_exact else '!='} replay")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(outdir: str = "results/hil_flycrane", quick: bool = False, spawn: bool = True, until: float | None = None,
         loss: float = 0.0, seed: int = 0, prefetch: bool = True) -> pd.DataFrame:
    """Run the five remote nodes for *until* s (default :data:`UNTIL`, ``quick``:
    :data:`QUICK`) in real time, compare with the all-simulated run and the replay; returns
    the one-row summary (also ``summary.parquet``)."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    config = flycrane_config(until if until is not None else (QUICK if quick else UNTIL), loss=loss, seed=seed)
    nominal = run_simulated(config)         # first: also warms the caches (gain, compiled plant, solvers)
    hil = run_hil(config, law_path=out / "flycrane_law.json", spawn=spawn, prefetch=prefetch,
                  connect_timeout=30.0 if spawn else 600.0)
    cmp = compare(hil, nominal)
    row = summary(hil, cmp)
    table = pd.DataFrame([row])
    table.to_parquet(out / "summary.parquet", index=False)
    hil.save(out)
    plot(out / "outputs.png", hil, cmp)
    per = hil.per_remote()
    cols = [c for c in ("remote", "published", "received", "expired", "after_end", "response_median", "response_p99",
                        "response_max", "process_received", "process_published", "process_status",
                        "process_law_max_us") if c in per]
    with pd.option_context("display.width", 200, "display.max_columns", 50):
        print(per[cols].to_string(index=False))
        print(table.T.to_string(header=False))
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    p = experiment_parser(__doc__, "results/hil_flycrane", quick=f"{QUICK:g} s instead of {UNTIL:g} s of real time")
    p.add_argument("--no-spawn", action="store_true", help="print the five remote commands instead of starting them")
    p.add_argument("--until", type=float, help=f"simulated (= real) seconds (default {UNTIL:g}; --quick {QUICK:g})")
    p.add_argument("--loss", type=float, default=0.0, help="frame-loss probability per receiver (default 0)")
    p.add_argument("--seed", type=int, default=0, help="the simulation's seed (default 0)")
    p.add_argument("--no-prefetch", action="store_true",
                   help="integrate the plant when the sample reads it (its wall time then counts in the pivot's "
                        "response time)")
    a = p.parse_args()
    main(a.outdir, a.quick, spawn=not a.no_spawn, until=a.until, loss=a.loss, seed=a.seed,
         prefetch=not a.no_prefetch)
