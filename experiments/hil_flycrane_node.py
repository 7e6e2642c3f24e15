"""One node of the networked Fly-crane as a real process (the remote side of ``hil_flycrane``).

The offline strategy of thesis §4.6.1 (sparse architecture (3.5)/(3.10)) on five nodes:
the load (``pivot``) and four robots (``robot1..robot4``).  One program serves either role:

* ``--role pivot``: every T the simulation samples the load's pose ``q_V`` (6 values:
  x, y, z in m, roll, pitch, yaw in rad) and sends it as a LOCAL request; the process
  answers with a **broadcast** ``(h, t_h, q_V...)`` (``h``: the sample's number, its
  ``seq``; ``t_h``: its simulated time in s), which the simulated 802.11b network carries
  to every robot, as the simulated pose task sends it.
* ``--role robot --index I``: a request is the frame the network delivered to robot I,
  ``(h, t_h, q_V...)``, followed by the robot's own cable angle ``q_I`` (rad) that the
  simulation read from the plant at the delivery instant; the process answers to LOCAL
  with the robot's velocity ``u_I`` (3 values, m/s), written to the plant's inputs
  (zero-order hold) at the simulated instant of its arrival.

The robot's law is the sparse law (3.10) with the offline gain, computed with the same
float operations, in the same order, as the simulated robot task
(``netcosim.controllers.planner.tasks._sparse_feedback`` -> ``netcosim.controllers.planner.laws.robot_velocity``).
That code cannot be imported here: ``netcosim.controllers.planner`` imports CasADi, and the
system's Jacobian ``A_q`` is a CasADi SX function.  So the simulation side writes a
**law file** (``--law PATH``, JSON, :data:`LAW_FORMAT`): the gains, ``q^r``, the star
structure and the Jacobian as the instruction list of that SX function, which
:class:`JacobianTape` evaluates instruction by instruction on Python floats (the same
IEEE operations and the same libm ``sin``/``cos`` as CasADi's virtual machine), and
:meth:`SparseLaw.velocity` repeats ``robot_velocity``'s NumPy steps.  The tests check it
bit for bit against the simulated law.

It stops at the simulation's END message (exit status 0), when the simulation is gone
without one (3), when another process already serves the node (4), or after ``--idle``
seconds without a message (5); the reason goes to stderr.  Its last line on stdout is a
JSON object of its counters (received, published, dropped by reason, status, role,
computed: requests answered, law_max_us: the longest computation of an answer in
microseconds).

Imports: the client library (stdlib and Zenoh) and NumPy; no SimPy, no CasADi.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any, Sequence

import numpy as np

from netcosim.transport import wire
from netcosim.transport.client import add_arguments, connect, finish

#: the law file's format tag (changes with any change of its fields or their meaning)
LAW_FORMAT = "netcosim.flycrane.sparse_law/1"
#: values of the pivot's broadcast before the pose: ``h`` and ``t_h`` (s)
HEADER_VALUES = 2
#: ticks per second of the wire's ``ticks`` (1 ps): ``t_h = ticks / TICKS_PER_SECOND``
#: as the simulated task's ``job.release_time``
TICKS_PER_SECOND = 10**12

_UNARY = {"NEG": lambda a: -a, "SIN": math.sin, "COS": math.cos, "TAN": math.tan, "SQRT": math.sqrt,
          "SQ": lambda a: a * a, "TWICE": lambda a: 2.0 * a, "INV": lambda a: 1.0 / a, "ASSIGN": lambda a: a,
          "EXP": math.exp, "LOG": math.log, "ASIN": math.asin, "ACOS": math.acos, "ATAN": math.atan,
          "FABS": abs}
_BINARY = {"ADD": lambda a, b: a + b, "SUB": lambda a, b: a - b, "MUL": lambda a, b: a * b,
           "DIV": lambda a, b: a / b, "ATAN2": math.atan2}


class JacobianTape:
    """A CasADi SX function of one dense vector input, evaluated without CasADi.

    ``spec``: ``{"n_in": m, "shape": [rows, cols], "work": size of the work vector,
    "tape": [[op, out, in1, in2, constant], ...], "nz": [[row, col], ...]}`` -- the
    function's instructions as ``Function.instruction_*`` lists them (``op`` without its
    ``OP_`` prefix: INPUT reads entry ``in2`` of the input into ``w[out]``, CONST stores
    ``constant``, OUTPUT stores ``w[in1]`` as nonzero ``in2`` of the output, the others
    compute ``w[out] = op(w[in1], w[in2])``) and the output's nonzeros in their order.
    Calling it returns the dense output (zeros outside the nonzeros), as
    ``netcosim.plants.casadi_tools.BufferedFunction`` returns a sparse output.
    """

    def __init__(self, spec: dict):
        self.n_in = int(spec["n_in"])
        self.shape = (int(spec["shape"][0]), int(spec["shape"][1]))
        self.work = int(spec["work"])
        self.n_out = len(spec["nz"])
        self._rows = np.asarray([r for r, _ in spec["nz"]], dtype=int)
        self._cols = np.asarray([c for _, c in spec["nz"]], dtype=int)
        prog = []
        for op, out, a, b, const in spec["tape"]:
            if op == "INPUT":
                prog.append((0, out, b, 0, None))
            elif op == "CONST":
                prog.append((1, out, 0, 0, float(const)))
            elif op == "OUTPUT":
                prog.append((2, b, a, 0, None))
            elif op in _BINARY:
                prog.append((3, out, a, b, _BINARY[op]))
            elif op in _UNARY:
                prog.append((4, out, a, 0, _UNARY[op]))
            else:
                raise ValueError(f"Jacobian tape: operation {op!r} is not supported (known: INPUT, CONST, OUTPUT, "
                                 f"{', '.join(sorted(_BINARY) + sorted(_UNARY))})")
        self._prog = prog

    def __call__(self, q: Sequence[float]) -> np.ndarray:
        x = [float(v) for v in q]
        if len(x) != self.n_in:
            raise ValueError(f"the Jacobian takes {self.n_in} values, got {len(x)}")
        w = [0.0] * self.work
        nz = [0.0] * self.n_out
        for kind, o, a, b, f in self._prog:
            if kind == 3:
                w[o] = f(w[a], w[b])
            elif kind == 4:
                w[o] = f(w[a])
            elif kind == 0:
                w[o] = x[a]
            elif kind == 1:
                w[o] = f
            else:
                nz[o] = w[a]
        A = np.zeros(self.shape)
        A[self._rows, self._cols] = nz
        return A


class SparseLaw:
    """The sparse law (3.10) of a law file (:data:`LAW_FORMAT`): ``velocity(i, q_i, q_V)``
    is ``netcosim.controllers.planner.laws.robot_velocity(system, structure, i, q_i, q_V, q_ref,
    K)`` with the file's ``K`` (the offline gain times ``K_bar``'s diagonal), step by step."""

    def __init__(self, spec: dict):
        if spec.get("format") != LAW_FORMAT:
            raise ValueError(f"not a {LAW_FORMAT} law file (format {spec.get('format')!r})")
        self.n, self.m = int(spec["n"]), int(spec["m"])
        self.kd = np.asarray(spec["kd"], dtype=float)
        self.q_ref = np.asarray(spec["q_ref"], dtype=float)
        self.rows = [tuple(int(v) for v in r) for r in spec["rows"]]
        self.cols = [tuple(int(v) for v in c) for c in spec["cols"]]
        self.pivot = tuple(int(v) for v in spec["pivot"])
        self.jacobian = JacobianTape(spec["jacobian"])
        if self.kd.shape != (self.m,) or self.q_ref.shape != (self.m,) or len(self.rows) != len(self.cols):
            raise ValueError(f"inconsistent law file: m={self.m}, kd {self.kd.shape}, q_ref {self.q_ref.shape}, "
                             f"{len(self.rows)} row sets, {len(self.cols)} column sets")
        if self.jacobian.shape != (self.n, self.m) or self.jacobian.n_in != self.m:
            raise ValueError(f"the law file's Jacobian is {self.jacobian.shape}, the system n={self.n}, m={self.m}")

    @classmethod
    def load(cls, path: str) -> "SparseLaw":
        with open(path, encoding="utf-8") as f:
            return cls(json.load(f))

    @property
    def N(self) -> int:
        """Number of robots."""
        return len(self.rows)

    def velocity(self, i: int, q_i: Any, q_V: Any) -> np.ndarray:
        """Robot *i*'s velocity (m/s, 0-based *i*) from its cable angle(s) *q_i* (rad)
        and the load's pose *q_V*: ``-A^(i)_{q_i} K_i (q_i - q_i^r) - A^(i)_{q_V} K_V (q_V - q_V^r)``."""
        if not 0 <= i < self.N:
            raise IndexError(f"robot index {i} out of range for {self.N} robots")
        q_ref, kd = self.q_ref, self.kd
        ci = np.asarray(self.cols[i], dtype=int)
        cv = np.asarray(self.pivot, dtype=int)
        q_i = _vector(q_i, len(ci), f"q_{i}")
        q_V = _vector(q_V, len(cv), "q_V")
        q = q_ref.copy()
        q[ci] = q_i
        q[cv] = q_V
        A = self.jacobian(q)
        if not np.all(np.isfinite(A)):
            raise ValueError(f"jacobian is not finite at q={q.tolist()}")
        rows = np.asarray(self.rows[i], dtype=int)
        idx = np.asarray(self.cols[i] + self.pivot, dtype=int)
        e = q[idx] - q_ref[idx]
        return A[np.ix_(rows, idx)] @ (-(kd[idx] * e))


def _vector(x: Any, size: int, what: str) -> np.ndarray:
    v = np.asarray(x, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise ValueError(f"{what} must have {size} entries, got {v.shape[0]}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be finite, got {v.tolist()}")
    return v


def pivot_reply(msg: wire.Message) -> tuple[float, ...]:
    """The pivot's broadcast for LOCAL sample *msg*: ``(h, t_h, q_V...)``."""
    if msg.node != wire.LOCAL:
        raise ValueError(f"the pivot serves LOCAL samples of its pose, got a request from node {msg.node}")
    return (float(msg.seq), msg.ticks / TICKS_PER_SECOND) + tuple(msg.values)


def robot_command(law: SparseLaw, i: int, values: Sequence[float], n_V: int | None = None) -> tuple[float, ...]:
    """Robot *i*'s (0-based) velocity for a request ``(h, t_h, q_V..., q_i...)``."""
    n_V = len(law.pivot) if n_V is None else n_V
    n_i = len(law.cols[i])
    if len(values) != HEADER_VALUES + n_V + n_i:
        raise ValueError(f"robot {i + 1} takes {HEADER_VALUES + n_V + n_i} values (h, t_h, q_V[{n_V}], "
                         f"q_{i + 1}[{n_i}]), got {len(values)}")
    q_V = values[HEADER_VALUES:HEADER_VALUES + n_V]
    q_i = values[HEADER_VALUES + n_V:]
    return tuple(law.velocity(i, q_i, q_V).tolist())


def serve(args: argparse.Namespace) -> int:
    """Answer requests until the run is over; returns the exit status."""
    law, i = None, None
    if args.role == "robot":
        if args.index is None or args.law is None:
            raise SystemExit("--role robot needs --index I and --law PATH")
        law = SparseLaw.load(args.law)
        i = args.index - 1
        if not 0 <= i < law.N:
            raise SystemExit(f"--index must be in 1..{law.N}, got {args.index}")
        # once at the reference before serving: checks the file and warms NumPy's first calls up
        robot_command(law, i, (0.0, 0.0) + tuple(law.q_ref[list(law.pivot)]) + tuple(law.q_ref[list(law.cols[i])]))
    stats = {"computed": 0, "law_max_us": 0.0}

    def answer(msg: wire.Message) -> None:
        t0 = time.perf_counter()
        values = pivot_reply(msg) if law is None else robot_command(law, i, msg.values)
        stats["law_max_us"] = max(stats["law_max_us"], 1e6 * (time.perf_counter() - t0))
        rp.reply(msg, values, to=wire.BROADCAST if law is None else wire.LOCAL)
        stats["computed"] += 1

    with connect(args) as rp:
        rp.serve(answer, timeout=args.idle)
        return finish(rp, {"role": args.role, **stats})


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m netcosim.experiments.hil_flycrane_node",
                                description=__doc__.splitlines()[0],
                                epilog="\n".join(__doc__.splitlines()[1:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--role", choices=("pivot", "robot"), required=True, help="the load (pivot) or a robot")
    p.add_argument("--index", type=int, help="robot number, 1..N (node robotI); --role robot only")
    p.add_argument("--law", help="the law file the simulation side wrote (JSON); --role robot only")
    add_arguments(p)
    return serve(p.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
