"""Real-time-iteration nonlinear MPC (multiple shooting, Gauss–Newton, CasADi).

Two objects:

:class:`OCP`
    A discrete-time optimal control problem obtained from a continuous model
    ``xdot = f(x, u, p)`` by multiple shooting (thesis eq. 2.13): ``N`` shooting
    intervals of ``Ts`` seconds, each integrated by ``rk4_steps`` fixed steps of the
    classical Runge–Kutta 4 method.  Cost: a least-squares sum of stage residuals
    ``eta(x_k, u_k, p)`` weighted by ``W`` and a terminal residual ``eta_N(x_N, p)``
    weighted by ``W_N`` (eqs. 2.9–2.10), plus quadratic penalties on slack variables
    of soft constraints (eq. 2.8)::

        min   1/2 sum_k ||eta(x_k,u_k,p)||_W^2 + 1/2 ||eta_N(x_N,p)||_{W_N}^2
              + 1/2 sum_k sum_i w_i sigma_{k,i}^2
        s.t.  x_0 = x_hat
              x_{k+1} = F(x_k, u_k, p)                       k = 0..N-1
              lbx <= x_k <= ubx                              k = 1..N
              lbu <= u_k <= ubu                              k = 0..N-1
              lbh <= h(x_k, u_k, p) - sigma_k <= ubh         k = 0..N-1
              lbh_N <= h_N(x_N, p) - sigma_N <= ubh_N

    where ``sigma`` is non-zero only on the rows declared soft.  A soft row carries
    one free slack: at the optimum ``sigma = 0`` whenever the row is satisfied and
    ``|sigma|`` is the violation otherwise, which is (2.8) with ``s = max(0, -sigma)``
    for a lower bound.  ``||v||_W^2 = v^T W v``.

    Conventions: rows of ``h`` that do not depend on ``u`` are not imposed at node 0
    (they are fixed by the measurement and could only make the problem infeasible);
    state bounds are not imposed at node 0 either.  Soft terminal rows are imposed on
    ``h_N(F(x_{N-1}, u_{N-1}, p), p)``, which equals ``h_N(x_N, p)`` on every feasible
    point, so that their slack lives in the last stage (this keeps the QP in the
    stage-wise form that structure-exploiting solvers need); hard terminal rows are
    imposed on ``x_N`` directly.

:class:`RTINMPC`
    The real-time iteration (Diehl et al., 2002): one Gauss–Newton SQP iteration per
    sample.  Each sample is split into a *feedback* phase (solve the QP prepared
    beforehand, with the new measurement entering only through the bounds of the
    first state increment) and a *preparation* phase (shift the trajectory by one
    interval and linearize around it for the next sample).  The QP is solved by a
    CasADi ``conic`` plugin; the default HPIPM exploits the stage-wise structure.
    A QP failure never produces NaN: the controller falls back to the shifted
    previous solution, reports the step as a fallback and counts it.

Units are those of the model; time in seconds.  All angles are whatever the model
uses (radians for the models of this project).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, replace
from typing import Any, Sequence

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

__all__ = ["OCP", "RTINMPC", "RTIStep", "FullSolution", "QP_SOLVERS", "rk4_discretize"]

#: QP solvers the RTI can use (those this CasADi build provides are checked at use).
QP_SOLVERS = ("hpipm", "qpoases", "osqp", "daqp", "proxqp", "qrqp", "highs")

#: The solvers that report a bare number as their return status, with the names their
#: headers give the numbers (HPIPM ``hpipm_common.h``, ``enum hpipm_status``; DAQP
#: ``constants.h``, ``EXIT_*``).  The others report text already.
_STATUS_CODES = {
    "hpipm": {0: "success", 1: "maximum iterations reached", 2: "minimum step length reached",
              3: "NaN in the solution", 4: "inconsistent equality constraints"},
    "daqp": {2: "soft optimal", 1: "optimal", -1: "infeasible", -2: "cycling", -3: "unbounded",
             -4: "iteration limit reached", -5: "nonconvex", -6: "overdetermined initial active set"},
}


def _status_text(solver: str, status) -> str:
    """A QP solver's return status as text: the name of a bare status number (kept in
    brackets, e.g. ``"minimum step length reached (hpipm status 2)"``), other text as it is."""
    text = str(status)
    try:
        code = int(text)
    except ValueError:
        return text
    name = _STATUS_CODES.get(solver, {}).get(code)
    return f"{name} ({solver} status {code})" if name else f"{solver} status {code} (no name known)"


# ---------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------

def _symbol(v, what: str) -> ca.SX:
    if v is None:
        return ca.SX(0, 1)
    if not isinstance(v, ca.SX) or not v.is_symbolic() or v.size2() != 1:
        raise TypeError(f"{what} must be a CasADi SX column of pure symbols (ca.SX.sym), got {v!r}")
    return v


def _expr(v, what: str, rows: int | None = None) -> ca.SX:
    if v is None:
        return ca.SX(0, 1)
    if isinstance(v, (ca.MX,)):
        raise TypeError(f"{what} must be an SX expression (build the model with SX symbols), got MX")
    v = ca.SX(v)
    if v.size2() != 1:
        if v.size1() == 1:
            v = v.T
        else:
            raise ValueError(f"{what} must be a column vector, got shape {v.shape}")
    if rows is not None and v.size1() != rows:
        raise ValueError(f"{what} must have {rows} rows, got {v.size1()}")
    return v


def _vec(v, n: int, default: float, what: str) -> np.ndarray:
    if v is None:
        return np.full(n, default, dtype=float)
    a = np.asarray(v, dtype=float)
    if a.ndim == 0:
        a = np.full(n, float(a))
    a = a.reshape(-1)
    if a.shape[0] != n:
        raise ValueError(f"{what} must have {n} entries, got {a.shape[0]}: {np.asarray(v).tolist()}")
    if np.any(np.isnan(a)):
        raise ValueError(f"{what} contains NaN: {a.tolist()}")
    return a


def _check_bounds(lb: np.ndarray, ub: np.ndarray, what: str) -> None:
    bad = np.nonzero(lb > ub)[0]
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"infeasible bounds for {what}[{i}]: lower {float(lb[i])!r} > upper {float(ub[i])!r}")


def _weight_sqrt(w, n: int, what: str) -> np.ndarray:
    """Square root L^T (n x n) of a weight given as a vector (diagonal) or a matrix.

    ``||v||_W^2 = v^T W v = ||L^T v||^2``.
    """
    if n == 0:
        if w is not None and np.asarray(w).size not in (0,):
            raise ValueError(f"{what} given ({np.asarray(w).shape}) but the residual is empty")
        return np.zeros((0, 0))
    if w is None:
        raise ValueError(f"{what} is required for a residual of {n} entries")
    a = np.asarray(w, dtype=float)
    if a.ndim == 0 or a.ndim == 1:
        return _diagonal_weight_sqrt(w, a, n, what)
    return _matrix_weight_sqrt(a, n, what)


def _diagonal_weight_sqrt(w, a: np.ndarray, n: int, what: str) -> np.ndarray:
    """:func:`_weight_sqrt` of a scalar or vector weight *a* (given as *w*)."""
    a = np.broadcast_to(a, (n,)) if a.ndim == 0 else a
    if a.shape != (n,):
        raise ValueError(f"{what} must have shape ({n},) or ({n}, {n}), got {np.asarray(w).shape}")
    if np.any(~np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"{what} must be finite and non-negative, got {a.tolist()}")
    return np.diag(np.sqrt(a))


def _matrix_weight_sqrt(a: np.ndarray, n: int, what: str) -> np.ndarray:
    """:func:`_weight_sqrt` of a weight matrix *a*: its symmetric PSD square root."""
    if a.shape != (n, n):
        raise ValueError(f"{what} must have shape ({n},) or ({n}, {n}), got {a.shape}")
    if not np.all(np.isfinite(a)) or not np.allclose(a, a.T, rtol=1e-10, atol=1e-12):
        raise ValueError(f"{what} must be a finite symmetric matrix, got {a.tolist()}")
    lam, V = np.linalg.eigh(a)
    if lam.min() < -1e-10 * max(1.0, abs(lam).max()):
        raise ValueError(f"{what} must be positive semidefinite; smallest eigenvalue {lam.min()!r}")
    return (V * np.sqrt(np.clip(lam, 0.0, None))) @ V.T  # symmetric square root


def _check_discretization(N, Ts, rk4_steps) -> None:
    """Horizon *N* (intervals), interval *Ts* [s] and *rk4_steps* per interval."""
    validate.integer(N, "horizon N", lo=1, kind="a positive integer number of intervals", type_error=ConfigurationError)
    validate.positive(Ts, "shooting interval Ts", kind="a positive number of seconds", type_error=ConfigurationError)
    validate.integer(rk4_steps, "rk4_steps", lo=1, kind="a positive integer", type_error=ConfigurationError)


def rk4_discretize(x: ca.SX, u: ca.SX, p: ca.SX, xdot: ca.SX, Ts: float, steps: int = 1,
                   name: str = "F") -> ca.Function:
    """``F(x, u, p)``: *steps* classical RK4 steps of ``xdot`` over *Ts* seconds (ZOH on u)."""
    f = ca.Function("f", [x, u, p], [xdot])
    h = Ts / steps
    xk = x
    for _ in range(steps):
        k1 = f(xk, u, p)
        k2 = f(xk + 0.5 * h * k1, u, p)
        k3 = f(xk + 0.5 * h * k2, u, p)
        k4 = f(xk + h * k3, u, p)
        xk = xk + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function(name, [x, u, p], [xk], ["x", "u", "p"], ["xf"])


# ---------------------------------------------------------------------------
# Problem definition
# ---------------------------------------------------------------------------

class OCP:
    """A least-squares optimal control problem for :class:`RTINMPC` (see module doc).

    Parameters (keyword only)
    ----------
    x, u, p:
        CasADi ``SX.sym`` column vectors of states, inputs and parameters (``p`` may
        be omitted).  Parameters are constant over the horizon (e.g. references).
    xdot:
        SX expression of the continuous dynamics in ``x, u, p``.
    N, Ts, rk4_steps:
        Number of shooting intervals, interval length (s), RK4 steps per interval.
    residual, weights:
        Stage residual ``eta(x, u, p)`` and its weight: a vector (diagonal) or a
        symmetric PSD matrix.
    terminal_residual, terminal_weights:
        Terminal residual ``eta_N(x, p)`` (function of ``x`` and ``p`` only).
    lbx, ubx, lbu, ubu:
        Box bounds on states (nodes 1..N) and inputs (nodes 0..N-1); ``±inf`` allowed.
    h, lbh, ubh, soft, soft_weights:
        Path constraints ``lbh <= h(x, u, p) <= ubh`` at nodes 0..N-1; ``soft`` lists
        row indices that are soft, penalised by ``1/2 * soft_weights[i] * sigma^2``.
    h_N, lbh_N, ubh_N, soft_N, soft_weights_N:
        Terminal constraints on ``x_N`` (function of ``x`` and ``p``).
    p_default:
        Parameter values used when none are given at solve time.
    state_names, input_names:
        Labels for results (default ``x0, x1, ...``).
    """

    def __init__(self, *, x: ca.SX, u: ca.SX, xdot: ca.SX, N: int, Ts: float, p: ca.SX | None = None,
                 rk4_steps: int = 1, residual=None, weights=None, terminal_residual=None,
                 terminal_weights=None, lbx=None, ubx=None, lbu=None, ubu=None,
                 h=None, lbh=None, ubh=None, soft: Sequence[int] = (), soft_weights=None,
                 h_N=None, lbh_N=None, ubh_N=None, soft_N: Sequence[int] = (), soft_weights_N=None,
                 p_default=None, state_names: Sequence[str] | None = None,
                 input_names: Sequence[str] | None = None):
        _check_discretization(N, Ts, rk4_steps)
        self.N, self.Ts, self.rk4_steps = int(N), float(Ts), int(rk4_steps)
        self.x = _symbol(x, "x")
        self.u = _symbol(u, "u")
        self.p = _symbol(p, "p")
        self.nx, self.nu, self.np = self.x.size1(), self.u.size1(), self.p.size1()
        if self.nx == 0:
            raise ValueError("the model needs at least one state")
        self.xdot = _expr(xdot, "xdot", self.nx)
        allowed = ca.vertcat(self.x, self.u, self.p)
        self._check_free(self.xdot, allowed, "xdot")
        self._set_costs(allowed, residual, weights, terminal_residual, terminal_weights)
        self._set_boxes(lbx, ubx, lbu, ubu)
        self._set_path(allowed, h, lbh, ubh, soft, soft_weights)
        self._set_terminal(h_N, lbh_N, ubh_N, soft_N, soft_weights_N)
        self._set_names(p_default, state_names, input_names)
        self.F = rk4_discretize(self.x, self.u, self.p, self.xdot, self.Ts, self.rk4_steps)
        # rows of h imposed at node 0: those that depend on u
        self.h_rows_node0 = tuple(i for i in range(self.h.size1()) if ca.depends_on(self.h[i], self.u))

    # -- the parts of the problem, in the order they are checked -------------------------
    def _set_costs(self, allowed, residual, weights, terminal_residual, terminal_weights) -> None:
        self.residual = _expr(residual, "residual")
        self._check_free(self.residual, allowed, "residual")
        self.terminal_residual = _expr(terminal_residual, "terminal_residual")
        self._check_free(self.terminal_residual, ca.vertcat(self.x, self.p), "terminal_residual")
        self.L = _weight_sqrt(weights, self.residual.size1(), "weights")
        self.L_N = _weight_sqrt(terminal_weights, self.terminal_residual.size1(), "terminal_weights")
        self.weights = np.asarray(weights, dtype=float) if weights is not None else None
        self.terminal_weights = np.asarray(terminal_weights, dtype=float) if terminal_weights is not None else None

    def _set_boxes(self, lbx, ubx, lbu, ubu) -> None:
        self.lbx = _vec(lbx, self.nx, -np.inf, "lbx")
        self.ubx = _vec(ubx, self.nx, np.inf, "ubx")
        self.lbu = _vec(lbu, self.nu, -np.inf, "lbu")
        self.ubu = _vec(ubu, self.nu, np.inf, "ubu")
        _check_bounds(self.lbx, self.ubx, "x")
        _check_bounds(self.lbu, self.ubu, "u")

    def _set_path(self, allowed, h, lbh, ubh, soft, soft_weights) -> None:
        self.h = _expr(h, "h")
        self._check_free(self.h, allowed, "h")
        nh = self.h.size1()
        self.lbh = _vec(lbh, nh, -np.inf, "lbh")
        self.ubh = _vec(ubh, nh, np.inf, "ubh")
        _check_bounds(self.lbh, self.ubh, "h")
        self.soft = self._soft_rows(soft, nh, "soft")
        self.soft_weights = self._soft_weights(soft_weights, len(self.soft), "soft_weights")

    def _set_terminal(self, h_N, lbh_N, ubh_N, soft_N, soft_weights_N) -> None:
        self.h_N = _expr(h_N, "h_N")
        self._check_free(self.h_N, ca.vertcat(self.x, self.p), "h_N")
        nhN = self.h_N.size1()
        self.lbh_N = _vec(lbh_N, nhN, -np.inf, "lbh_N")
        self.ubh_N = _vec(ubh_N, nhN, np.inf, "ubh_N")
        _check_bounds(self.lbh_N, self.ubh_N, "h_N")
        self.soft_N = self._soft_rows(soft_N, nhN, "soft_N")
        self.soft_weights_N = self._soft_weights(soft_weights_N, len(self.soft_N), "soft_weights_N")

    def _set_names(self, p_default, state_names, input_names) -> None:
        self.p_default = _vec(p_default, self.np, 0.0, "p_default")
        if not np.all(np.isfinite(self.p_default)):
            raise ValueError(f"p_default must be finite, got {self.p_default.tolist()}")
        self.state_names = tuple(state_names) if state_names is not None else tuple(f"x{i}" for i in range(self.nx))
        self.input_names = tuple(input_names) if input_names is not None else tuple(f"u{i}" for i in range(self.nu))
        if len(self.state_names) != self.nx:
            raise ValueError(f"state_names must have {self.nx} entries, got {list(self.state_names)}")
        if len(self.input_names) != self.nu:
            raise ValueError(f"input_names must have {self.nu} entries, got {list(self.input_names)}")

    # -- validation helpers ------------------------------------------------------------
    @staticmethod
    def _check_free(e: ca.SX, allowed: ca.SX, what: str) -> None:
        if e.numel() == 0:
            return
        free = set(str(s) for s in ca.symvar(e)) - set(str(s) for s in ca.symvar(allowed))
        if free:
            raise ValueError(f"{what} depends on symbols that are not states/inputs/parameters: {sorted(free)}")

    @staticmethod
    def _soft_rows(rows, n: int, what: str) -> tuple[int, ...]:
        out = []
        for r in rows:
            if isinstance(r, bool) or not isinstance(r, (int, np.integer)) or not 0 <= r < n:
                raise ValueError(f"{what} row index {r!r} out of range for {n} constraint rows")
            if r in out:
                raise ValueError(f"{what} row index {r!r} listed twice")
            out.append(int(r))
        return tuple(out)

    @staticmethod
    def _soft_weights(w, n: int, what: str) -> np.ndarray:
        if n == 0:
            return np.zeros(0)
        if w is None:
            raise ValueError(f"{what} is required for {n} soft rows")
        a = _vec(w, n, 0.0, what)
        if np.any(~np.isfinite(a)) or np.any(a <= 0):
            raise ValueError(f"{what} must be finite and positive, got {a.tolist()}")
        return a

    def __repr__(self) -> str:
        return (f"OCP(nx={self.nx}, nu={self.nu}, np={self.np}, N={self.N}, Ts={self.Ts}, "
                f"nh={self.h.size1()} ({len(self.soft)} soft), nh_N={self.h_N.size1()} ({len(self.soft_N)} soft))")


# ---------------------------------------------------------------------------
# Transcription (shared by the RTI and the full solvers)
# ---------------------------------------------------------------------------

class _NLPParts:
    """The lists a transcription is assembled from: variables with their bounds,
    constraints with their bounds, weighted residuals."""

    def __init__(self):
        self.w, self.lbw, self.ubw = [], [], []
        self.g, self.lbg, self.ubg = [], [], []
        self.res = []

    def bound_w(self, lb, ub) -> None:
        self.lbw.append(lb)
        self.ubw.append(ub)

    def constrain(self, g, lb, ub) -> None:
        self.g.append(g)
        self.lbg.append(lb)
        self.ubg.append(ub)


class _Transcription:
    """The multiple-shooting NLP of an :class:`OCP` in stage-wise variable order.

    Variables: ``w = [x_0, v_0, x_1, v_1, ..., x_{N-1}, v_{N-1}, x_N]`` with
    ``v_k = [u_k, sigma_k]`` (and ``sigma_N`` appended to ``v_{N-1}``).
    Constraints: ``[gap_0, c_0, gap_1, c_1, ..., gap_{N-1}, c_{N-1}, c_N]``.
    """

    def __init__(self, ocp: OCP):
        self.ocp = o = ocp
        N, nx, nu = o.N, o.nx, o.nu
        ns, nsN = len(o.soft), len(o.soft_N)
        self.ns, self.nsN = ns, nsN
        p = ca.SX.sym("p", o.np)
        self.p_sym = p
        X = [ca.SX.sym(f"x_{k}", nx) for k in range(N + 1)]
        U = [ca.SX.sym(f"u_{k}", nu) for k in range(N)]
        S = [ca.SX.sym(f"s_{k}", ns) for k in range(N)]
        SN = ca.SX.sym("s_N", nsN)
        self._fh = ca.Function("h", [o.x, o.u, o.p], [o.h])
        self._fr = ca.Function("eta", [o.x, o.u, o.p], [o.residual])
        self._frN = ca.Function("eta_N", [o.x, o.p], [o.terminal_residual])
        self._fhN = ca.Function("h_N", [o.x, o.p], [o.h_N])

        nlp = _NLPParts()
        self.nu_stage, self.ng_stage = [], []
        for k in range(N):
            self._stage(nlp, k, X[k], U[k], S[k], X[k + 1], SN, p)
        self._terminal(nlp, X[N], SN, p)
        self._assemble(nlp)
        self._index_maps()
        self.cost = 0.5 * ca.dot(self.r, self.r)

    def _stage(self, nlp: "_NLPParts", k: int, xk, uk, sk, x_next, SN, p) -> None:
        """Variables, gap, constraint rows and residuals of stage *k* (< N)."""
        o = self.ocp
        last = k == o.N - 1
        self._stage_variables(nlp, k, xk, uk, sk, SN)
        xn = o.F(xk, uk, p)
        nlp.constrain(xn - x_next, np.zeros(o.nx), np.zeros(o.nx))  # gap
        rows = self._path_rows(k, xk, uk, sk, p)
        if last and self.nsN:
            rows += self._soft_terminal_rows(xn, SN, p)
        rows_g = [r[0] for r in rows]
        nlp.constrain(ca.vertcat(*rows_g) if rows_g else ca.SX(0, 1),
                      np.array([r[1] for r in rows], dtype=float), np.array([r[2] for r in rows], dtype=float))
        self.ng_stage.append(len(rows_g))
        if o.residual.size1():
            nlp.res.append(ca.mtimes(o.L.T, self._fr(xk, uk, p)))
        if self.ns:
            nlp.res.append(np.sqrt(o.soft_weights) * sk)

    def _stage_variables(self, nlp: "_NLPParts", k: int, xk, uk, sk, SN) -> None:
        """``x_k`` and ``v_k = [u_k, sigma_k (, sigma_N)]`` with their bounds."""
        o = self.ocp
        last = k == o.N - 1
        inf = np.inf
        nlp.w.append(xk)
        if k == 0:
            nlp.bound_w(np.full(o.nx, -inf), np.full(o.nx, inf))  # set to x_hat at solve time
        else:
            nlp.bound_w(o.lbx, o.ubx)
        nlp.w.extend([uk, sk] + ([SN] if last else []))
        nlp.bound_w(o.lbu, o.ubu)
        nlp.bound_w(np.full(self.ns, -inf), np.full(self.ns, inf))
        if last:
            nlp.bound_w(np.full(self.nsN, -inf), np.full(self.nsN, inf))
        self.nu_stage.append(o.nu + self.ns + (self.nsN if last else 0))

    def _path_rows(self, k: int, xk, uk, sk, p) -> list:
        """``(h_i - sigma_i, lbh_i, ubh_i)`` of the path constraints imposed at node *k*."""
        o = self.ocp
        nh = o.h.size1()
        if not nh:
            return []
        hk = self._fh(xk, uk, p)
        sigma = ca.SX.zeros(nh)
        for j, i in enumerate(o.soft):
            sigma[i] = sk[j]
        rows = range(nh) if k > 0 else o.h_rows_node0
        return [(hk[i] - sigma[i], o.lbh[i], o.ubh[i]) for i in rows]

    def _soft_terminal_rows(self, xn, SN, p) -> list:
        """The soft terminal rows, imposed on ``h_N(F(x_{N-1}, u_{N-1}))`` in the last stage."""
        o = self.ocp
        hN_pred = self._fhN(xn, p)
        return [(hN_pred[i] - SN[j], o.lbh_N[i], o.ubh_N[i]) for j, i in enumerate(o.soft_N)]

    def _terminal(self, nlp: "_NLPParts", xN, SN, p) -> None:
        """The last node: its bounds, hard terminal rows and terminal residuals."""
        o = self.ocp
        hard_N = [i for i in range(o.h_N.size1()) if i not in o.soft_N]
        nlp.w.append(xN)
        nlp.bound_w(o.lbx, o.ubx)
        if hard_N:
            hN = self._fhN(xN, p)
            nlp.constrain(ca.vertcat(*[hN[i] for i in hard_N]), o.lbh_N[hard_N], o.ubh_N[hard_N])
        self.ng_stage.append(len(hard_N))
        if o.terminal_residual.size1():
            nlp.res.append(ca.mtimes(o.L_N.T, self._frN(xN, p)))
        if self.nsN:
            nlp.res.append(np.sqrt(o.soft_weights_N) * SN)

    def _assemble(self, nlp: "_NLPParts") -> None:
        self.w = ca.vertcat(*nlp.w)
        self.g = ca.vertcat(*nlp.g)
        self.r = ca.vertcat(*nlp.res) if nlp.res else ca.SX(0, 1)
        self.lbw = np.concatenate(nlp.lbw)
        self.ubw = np.concatenate(nlp.ubw)
        self.lbg = np.concatenate(nlp.lbg) if nlp.lbg else np.zeros(0)
        self.ubg = np.concatenate(nlp.ubg) if nlp.ubg else np.zeros(0)
        self.nw, self.ng = self.w.size1(), self.g.size1()

    def _index_maps(self) -> None:
        """Where x_k, u_k, sigma_k and sigma_N live in w."""
        N, nx, nu, ns, nsN = self.ocp.N, self.ocp.nx, self.ocp.nu, self.ns, self.nsN
        stride = [nx + n for n in self.nu_stage]
        starts = np.concatenate(([0], np.cumsum(stride)))
        self.ix = np.array([np.arange(starts[k], starts[k] + nx) for k in range(N + 1)])
        self.iu = np.array([np.arange(starts[k] + nx, starts[k] + nx + nu) for k in range(N)]).reshape(N, nu)
        self.isg = np.array([np.arange(starts[k] + nx + nu, starts[k] + nx + nu + ns) for k in range(N)]).reshape(N, ns)
        sN0 = starts[N - 1] + nx + nu + ns
        self.isN = np.arange(sN0, sN0 + nsN)

    def pack(self, X: np.ndarray, U: np.ndarray, S: np.ndarray, SN: np.ndarray) -> np.ndarray:
        w = np.empty(self.nw)
        w[self.ix.reshape(-1)] = X.reshape(-1)
        w[self.iu.reshape(-1)] = U.reshape(-1)
        if self.ns:
            w[self.isg.reshape(-1)] = S.reshape(-1)
        w[self.isN] = SN
        return w

    def unpack(self, w: np.ndarray):
        return (w[self.ix], w[self.iu], w[self.isg] if self.ns else np.zeros((self.ocp.N, 0)), w[self.isN])


# ---------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class RTIStep:
    """Outcome of one real-time iteration.

    ``u``: first input of the plan (apply over the next interval); ``x_ref``: the plan's
    state at node 1, i.e. the predicted state one interval ahead; ``X``: the whole
    planned state trajectory (N+1, nx); ``status``: the QP
    solver's return status as text (a solver's bare status number is named, e.g.
    HPIPM's 2 is ``"minimum step length reached (hpipm status 2)"``); ``fallback``: True when the QP failed and the shifted
    previous plan was used instead; ``qp_iter``: QP solver iterations; ``step_norm``:
    max-norm of the SQP step; ``t_feedback`` / ``t_prepare``: wall-clock seconds of
    the two phases (``t_prepare`` refers to the preparation done *after* this
    feedback, for the next sample).
    """

    u: np.ndarray
    x_ref: np.ndarray
    X: np.ndarray
    status: str
    success: bool
    fallback: bool
    qp_iter: int
    step_norm: float
    t_feedback: float
    t_prepare: float

    @property
    def t_total(self) -> float:
        return self.t_feedback + self.t_prepare


@dataclass(frozen=True)
class FullSolution:
    """A fully converged solve of the OCP (``method`` 'ipopt' or 'sqp').

    ``X`` (N+1, nx), ``U`` (N, nu), ``S`` (N, ns), ``SN`` (nsN,), ``cost`` (objective),
    ``iterations``, ``success``, ``status``, ``t_wall`` (s).
    """

    X: np.ndarray
    U: np.ndarray
    S: np.ndarray
    SN: np.ndarray
    cost: float
    iterations: int
    success: bool
    status: str
    method: str
    t_wall: float


# ---------------------------------------------------------------------------
# RTI controller
# ---------------------------------------------------------------------------

_DEFAULT_QP_OPTIONS: dict[str, dict[str, Any]] = {
    "hpipm": {"inf": 1e6, "hpipm": {"mode": "speed", "iter_max": 100, "res_g_max": 1e-6, "res_b_max": 1e-6,
                                     "res_d_max": 1e-6, "res_m_max": 1e-6}},
    "qpoases": {"printLevel": "none", "sparse": False, "hessian_type": "semidef"},
    "osqp": {"osqp": {"verbose": False, "eps_abs": 1e-7, "eps_rel": 1e-7, "max_iter": 100000,
                      "polish": True}, "warm_start_primal": True},
    "daqp": {},
    "proxqp": {"proxqp": {"eps_abs": 1e-9}},
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False},
    "highs": {"highs": {"output_flag": False}},
}


def _check_rti_arguments(ocp, qp_solver, hessian_reg, history_length) -> None:
    """The arguments of :class:`RTINMPC` that are checked before anything is built."""
    if not isinstance(ocp, OCP):
        raise TypeError(f"ocp must be an OCP, got {type(ocp).__name__}")
    if qp_solver not in QP_SOLVERS:
        raise ValueError(f"unknown qp_solver {qp_solver!r}; choose one of {QP_SOLVERS}")
    if not ca.has_conic(qp_solver):
        raise ValueError(f"qp_solver {qp_solver!r} is not available in this CasADi build")
    validate.non_negative(hessian_reg, "hessian_reg", kind="a non-negative number", type_error=ConfigurationError)
    _check_history_length(history_length)


def _check_history_length(history_length) -> None:
    """``None`` or a non-negative integer."""
    if history_length is not None:
        validate.integer(history_length, "history_length", lo=0, kind="a non-negative integer or None",
                         type_error=ConfigurationError)


def _linearization(tr: _Transcription, hessian_reg: float, jit: bool):
    """The preparation function ``(w, p) -> (H, g, A, c, cost)`` of the Gauss–Newton QP,
    and the SX expressions of ``H`` and ``A`` (for their sparsity)."""
    Jr = ca.jacobian(tr.r, tr.w)
    H = ca.mtimes(Jr.T, Jr)
    if hessian_reg > 0:
        H = H + hessian_reg * ca.SX.eye(tr.nw)
    gradient = ca.mtimes(Jr.T, tr.r)
    A = ca.jacobian(tr.g, tr.w)
    opts: dict[str, Any] = {}
    if jit:
        opts = {"jit": True, "compiler": "shell",
                "jit_options": {"flags": ["-O2"], "verbose": False}, "jit_temp_suffix": True}
    lin = ca.Function("rti_linearize", [tr.w, tr.p_sym], [H, gradient, A, tr.g, tr.cost],
                      ["w", "p"], ["H", "g", "A", "c", "cost"], opts)
    return lin, H, A


def _qp_options(qp_solver: str, ocp: OCP, tr: _Transcription, qp_options: dict | None) -> dict:
    """This module's defaults for *qp_solver* (with HPIPM's stage dimensions), the
    user's *qp_options* merged over them (one level deep for nested dicts)."""
    qopts = dict(_DEFAULT_QP_OPTIONS.get(qp_solver, {}))
    if qp_solver == "hpipm":
        qopts.update({"N": ocp.N, "nx": [ocp.nx] * (ocp.N + 1), "nu": list(tr.nu_stage) + [0],
                      "ng": list(tr.ng_stage)})
    for k, v in (qp_options or {}).items():
        if isinstance(v, dict) and isinstance(qopts.get(k), dict):
            qopts[k] = {**qopts[k], **v}
        else:
            qopts[k] = v
    qopts.setdefault("error_on_fail", False)
    return qopts


class RTINMPC:
    """Real-time-iteration NMPC for an :class:`OCP` (see module doc).

    Parameters
    ----------
    ocp:
        The problem.
    qp_solver:
        CasADi ``conic`` plugin: ``"hpipm"`` (default, structure-exploiting IPM),
        ``"qpoases"``, ``"osqp"``, ``"daqp"``, ``"proxqp"``, ``"qrqp"``, ``"highs"``.
    qp_options:
        Options merged over this module's defaults for the plugin.
    hessian_reg:
        Levenberg–Marquardt term added to the Gauss–Newton Hessian (does not change
        the fixed point of the iteration, only the step).
    jit:
        Compile the linearization function to C with the system compiler (CasADi
        ``jit`` with the ``shell`` compiler); ``False`` uses CasADi's virtual machine.
    x_guess, u_guess:
        Initial guess (state repeated over the horizon, inputs repeated); defaults
        to zeros; :meth:`reset` sets them later.
    history_length:
        How many of the latest :class:`RTIStep` results :attr:`history` keeps (a
        ``deque`` that drops the oldest): default 1, enough for :attr:`last`; ``0``
        keeps none; ``None`` keeps every step (grows by one step, with its whole
        plan, per sample -- for offline analysis only).  :attr:`last` always holds
        the latest step.
    """

    def __init__(self, ocp: OCP, *, qp_solver: str = "hpipm", qp_options: dict | None = None,
                 hessian_reg: float = 1e-8, jit: bool = False, x_guess=None, u_guess=None,
                 history_length: int | None = 1):
        _check_rti_arguments(ocp, qp_solver, hessian_reg, history_length)
        self.ocp = ocp
        self.qp_solver = qp_solver
        self.tr = tr = _Transcription(ocp)
        self.hessian_reg = float(hessian_reg)
        self.jit = bool(jit)
        self._lin, H, A = _linearization(tr, hessian_reg, jit)
        self.H_sparsity, self.A_sparsity = H.sparsity(), A.sparsity()
        qopts = _qp_options(qp_solver, ocp, tr, qp_options)
        self._qp_options = qopts
        self._qp = ca.conic("rti_qp", qp_solver, {"h": self.H_sparsity, "a": self.A_sparsity}, qopts)
        self._qp_accurate = None

        self.n_steps = 0
        self.n_fail = 0
        self.history_length = None if history_length is None else int(history_length)
        #: the latest steps, oldest first (at most ``history_length``)
        self.history: deque[RTIStep] = deque(maxlen=self.history_length)
        #: the latest step (None before the first :meth:`feedback`)
        self.last: RTIStep | None = None
        self._p = ocp.p_default.copy()
        self._qpdata = None
        self.reset(x_guess if x_guess is not None else np.zeros(ocp.nx), u_guess)

    # -- state ----------------------------------------------------------------------------
    def _check_x(self, x0, what="x0") -> np.ndarray:
        a = np.asarray(x0, dtype=float).reshape(-1)
        if a.shape[0] != self.ocp.nx:
            raise ValueError(f"{what} must have {self.ocp.nx} entries {list(self.ocp.state_names)}, "
                             f"got {np.asarray(x0).tolist()}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{what} must be finite, got {a.tolist()}")
        return a

    def _check_p(self, p) -> np.ndarray:
        if p is None:
            return self._p
        a = np.asarray(p, dtype=float).reshape(-1)
        if a.shape[0] != self.ocp.np or not np.all(np.isfinite(a)):
            raise ValueError(f"parameters must be {self.ocp.np} finite values, got {np.asarray(p).tolist()}")
        return a

    def reset(self, x0, u_guess=None, p=None) -> None:
        """Restart from the guess ``x_k = x0`` for all k and ``u_k = u_guess`` (default 0)."""
        o = self.ocp
        x0 = self._check_x(x0)
        u = np.zeros(o.nu) if u_guess is None else np.asarray(u_guess, dtype=float).reshape(-1)
        if u.shape[0] != o.nu or not np.all(np.isfinite(u)):
            raise ValueError(f"u_guess must be {o.nu} finite values, got {np.asarray(u_guess).tolist()}")
        u = np.clip(u, o.lbu, o.ubu)
        X = np.tile(x0, (o.N + 1, 1))
        U = np.tile(u, (o.N, 1))
        self._w = self.tr.pack(X, U, np.zeros((o.N, self.tr.ns)), np.zeros(self.tr.nsN))
        self._p = self._check_p(p)
        self.prepare()

    def set_trajectory(self, X, U, S=None, SN=None, p=None) -> None:
        """Set the linearization point (e.g. a converged solution) and prepare."""
        o, tr = self.ocp, self.tr
        X = np.asarray(X, dtype=float).reshape(o.N + 1, o.nx)
        U = np.asarray(U, dtype=float).reshape(o.N, o.nu)
        S = np.zeros((o.N, tr.ns)) if S is None else np.asarray(S, dtype=float).reshape(o.N, tr.ns)
        SN = np.zeros(tr.nsN) if SN is None else np.asarray(SN, dtype=float).reshape(tr.nsN)
        self._w = tr.pack(X, U, S, SN)
        if p is not None:
            self._p = self._check_p(p)
        self.prepare()

    @property
    def X(self) -> np.ndarray:
        """Current planned states, shape (N+1, nx)."""
        return self._w[self.tr.ix].copy()

    @property
    def U(self) -> np.ndarray:
        """Current planned inputs, shape (N, nu)."""
        return self._w[self.tr.iu].copy()

    @property
    def S(self) -> np.ndarray:
        return self._w[self.tr.isg].copy() if self.tr.ns else np.zeros((self.ocp.N, 0))

    @property
    def p(self) -> np.ndarray:
        return self._p.copy()

    # -- phases ---------------------------------------------------------------------------
    def prepare(self, p=None) -> float:
        """Linearize around the current trajectory; returns wall-clock seconds taken."""
        t0 = time.perf_counter()
        if p is not None:
            self._p = self._check_p(p)
        H, g, A, c, cost = self._lin(self._w, self._p)
        tr = self.tr
        self._qpdata = dict(h=H, g=g, a=A, lba=tr.lbg - c.full().ravel(), uba=tr.ubg - c.full().ravel())
        self._lbdw = tr.lbw - self._w
        self._ubdw = tr.ubw - self._w
        self._cost = float(cost)
        return time.perf_counter() - t0

    def _accurate_qp(self):
        """The QP solver with tight tolerances used by :meth:`solve_sqp` (built on first use)."""
        if self._qp_accurate is None:
            if self.qp_solver == "hpipm":
                opts = dict(self._qp_options)
                opts["hpipm"] = {**opts.get("hpipm", {}), "mode": "balance", "iter_max": 200,
                                 "res_g_max": 1e-9, "res_b_max": 1e-9, "res_d_max": 1e-9, "res_m_max": 1e-9}
                self._qp_accurate = ca.conic("rti_qp_accurate", "hpipm",
                                             {"h": self.H_sparsity, "a": self.A_sparsity}, opts)
            else:
                self._qp_accurate = self._qp
        return self._qp_accurate

    def _qp_step(self, x0, qp=None) -> tuple[bool, str, int, float]:
        """Solve the prepared QP with measured *x0* and take the full step.

        Returns ``(success, status, qp_iterations, step_norm)``.  On failure the
        trajectory is left as prepared (the shifted previous solution), with node 0
        set to *x0*.
        """
        x0 = self._check_x(x0)
        tr = self.tr
        ix0 = tr.ix[0]
        lbx = self._lbdw.copy()
        ubx = self._ubdw.copy()
        d0 = x0 - self._w[ix0]
        lbx[ix0] = d0
        ubx[ix0] = d0
        qp = self._qp if qp is None else qp
        try:
            sol = qp(lbx=lbx, ubx=ubx, **self._qpdata)
            stats = qp.stats()
            ok = bool(stats.get("success", False))
            status = _status_text(self.qp_solver, stats.get("return_status", "unknown"))
            it = stats.get("iter_count", stats.get("iter", -1))
            it = -1 if it is None else int(it)
            dw = sol["x"].full().ravel()
            if ok and not np.all(np.isfinite(dw)):
                ok, status = False, "non-finite QP solution"
        except RuntimeError as exc:  # solver error: treat as a failed QP
            ok, status, it, dw = False, f"error: {exc}".splitlines()[0], -1, None
        if ok:
            step = float(np.max(np.abs(dw))) if dw.size else 0.0
            self._w = self._w + dw
            self._w[ix0] = x0
            return True, status, it, step
        self._w[ix0] = x0
        return False, status, it, float("nan")

    def feedback(self, x0, p=None) -> RTIStep:
        """Feedback phase: solve the prepared QP for the measured state *x0*.

        Returns the first input and the plan (``t_prepare`` is 0 here).  If *p*
        differs from the parameters the QP was prepared with, the QP is prepared
        again first (its time counts in ``t_feedback``).  On QP failure the shifted
        previous plan is used (``fallback=True``) and ``n_fail`` is incremented.
        """
        t0 = time.perf_counter()
        if p is not None:
            p = self._check_p(p)
            if not np.array_equal(p, self._p):
                self.prepare(p)
        ok, status, it, step = self._qp_step(x0)
        tr = self.tr
        if not ok:
            self.n_fail += 1
        u = np.clip(self._w[tr.iu[0]], self.ocp.lbu, self.ocp.ubu)
        X = self._w[tr.ix]
        self.n_steps += 1
        t1 = time.perf_counter()
        r = RTIStep(u=u, x_ref=X[1].copy(), X=X.copy(), status=status, success=ok, fallback=not ok, qp_iter=it,
                    step_norm=step, t_feedback=t1 - t0, t_prepare=0.0)
        self.last = r
        self.history.append(r)
        return r

    def preparation(self) -> float:
        """Preparation phase: shift the plan by one interval and linearize around it.

        Returns the wall-clock seconds taken.
        """
        t0 = time.perf_counter()
        self.shift()
        self.prepare()
        dt = time.perf_counter() - t0
        if self.last is not None:
            r = replace(self.last, t_prepare=dt)
            if self.history and self.history[-1] is self.last:
                self.history[-1] = r
            self.last = r
        return dt

    def shift(self) -> None:
        """Shift the trajectory by one interval (last state: one more model step)."""
        o, tr = self.ocp, self.tr
        X, U, S, SN = tr.unpack(self._w)
        Xs = np.empty_like(X)
        Xs[:-1] = X[1:]
        Xs[-1] = np.asarray(o.F(X[-1], U[-1], self._p)).ravel()
        if not np.all(np.isfinite(Xs[-1])):
            Xs[-1] = X[-1]
        Us = np.empty_like(U)
        Us[:-1] = U[1:]
        Us[-1] = U[-1]
        Ss = np.empty_like(S)
        if S.size:
            Ss[:-1] = S[1:]
            Ss[-1] = S[-1]
        self._w = tr.pack(Xs, Us, Ss, SN)

    def step(self, x0, p=None) -> RTIStep:
        """One sample: :meth:`feedback` with *x0*, then :meth:`preparation` for the next."""
        self.feedback(x0, p)
        self.preparation()
        return self.last

    # -- converged solves --------------------------------------------------------------------
    def cost(self, X=None, U=None, S=None, SN=None) -> float:
        """Objective value at the given (default: current) trajectory."""
        tr = self.tr
        w = self._w if X is None else tr.pack(np.asarray(X), np.asarray(U),
                                              np.zeros((self.ocp.N, tr.ns)) if S is None else np.asarray(S),
                                              np.zeros(tr.nsN) if SN is None else np.asarray(SN))
        return float(self._lin(w, self._p)[4])

    def solve_sqp(self, x0, p=None, *, tol: float = 1e-9, max_iter: int = 100) -> FullSolution:
        """Full Gauss–Newton SQP from the current trajectory until ``|dw|_inf < tol``.

        Leaves the converged trajectory as the controller's linearization point.
        """
        t0 = time.perf_counter()
        x0 = self._check_x(x0)
        if p is not None:
            self._p = self._check_p(p)
        self.prepare()
        qp = self._accurate_qp()
        ok, status, it_total = False, "max_iter", 0
        for it_total in range(1, max_iter + 1):
            qok, qstatus, _, step = self._qp_step(x0, qp)
            self.prepare()
            if not qok:
                status = f"QP failed: {qstatus}"
                break
            if step < tol:
                ok, status = True, "converged"
                break
        X, U, S, SN = self.tr.unpack(self._w)
        return FullSolution(X.copy(), U.copy(), S.copy(), SN.copy(), self._cost, it_total, ok, status,
                            "sqp", time.perf_counter() - t0)

    def ipopt_solver(self, options: dict | None = None) -> "IpoptOCP":
        """An IPOPT solver of the same NLP (exact Hessian), for comparisons."""
        return IpoptOCP(self, options)


class IpoptOCP:
    """Full IPOPT solve of the multiple-shooting NLP of an :class:`RTINMPC`.

    Same variables, constraints and objective as the RTI; exact Hessian of the
    Lagrangian.  Warm-started from the previous solution when called repeatedly.
    """

    def __init__(self, rti: RTINMPC, options: dict | None = None):
        tr = rti.tr
        self.rti = rti
        opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-10,
                "ipopt.acceptable_tol": 1e-8, "ipopt.max_iter": 500, "ipopt.sb": "yes",
                "ipopt.mu_strategy": "adaptive"}
        opts.update(options or {})
        self.solver = ca.nlpsol("full_ipopt", "ipopt", {"x": tr.w, "p": tr.p_sym, "f": tr.cost, "g": tr.g},
                                opts)
        self._w = None

    def solve(self, x0, p=None, w_init=None) -> FullSolution:
        rti, tr = self.rti, self.rti.tr
        x0 = rti._check_x(x0)
        p = rti._p if p is None else rti._check_p(p)
        lbw, ubw = tr.lbw.copy(), tr.ubw.copy()
        lbw[tr.ix[0]] = x0
        ubw[tr.ix[0]] = x0
        if w_init is None:
            w_init = self._w if self._w is not None else rti._w
        w_init = np.array(w_init, dtype=float)
        w_init[tr.ix[0]] = x0
        t0 = time.perf_counter()
        sol = self.solver(x0=w_init, p=p, lbx=lbw, ubx=ubw, lbg=tr.lbg, ubg=tr.ubg)
        t = time.perf_counter() - t0
        st = self.solver.stats()
        w = sol["x"].full().ravel()
        ok = bool(st.get("success", False)) and np.all(np.isfinite(w))
        if ok:
            self._w = w
        X, U, S, SN = tr.unpack(w)
        return FullSolution(X.copy(), U.copy(), S.copy(), SN.copy(), float(sol["f"]),
                            int(st.get("iter_count", -1)), ok, str(st.get("return_status")), "ipopt", t)
