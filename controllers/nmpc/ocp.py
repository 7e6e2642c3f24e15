"""The optimal control problem: :class:`OCP`, its input checks, :func:`rk4_discretize`.

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

Units are those of the model; time in seconds.  All angles are whatever the model
uses (radians for the models of this project).
"""

from __future__ import annotations

from typing import Sequence

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

__all__ = ["OCP", "rk4_discretize"]


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
    """``F(x, u, p)``: *steps* classical RK4 steps of ``xdot`` over *Ts* seconds (ZOH on u), a
    CasADi ``Function`` called *name*."""
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

    All parameters are keyword-only.

    Parameters
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
