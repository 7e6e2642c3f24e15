"""The real-time-iteration controller :class:`RTINMPC` and its per-sample result :class:`RTIStep`.

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
from typing import Any

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

from .full import FullSolution, IpoptOCP
from .ocp import OCP
from .qp import QP_SOLVERS, _qp_options, _status_text
from .transcription import _Transcription

__all__ = ["RTINMPC", "RTIStep"]


# ---------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class RTIStep:
    """Outcome of one real-time iteration.

    ``u``: first input of the plan (apply over the next interval); ``x_ref``: the plan's
    state at node 1, i.e. the predicted state one interval ahead; ``X``: the whole
    planned state trajectory (N+1, nx); ``status``: the QP solver's return status as
    text (a solver's bare status number is named, e.g. HPIPM's 2 is ``"minimum step
    length reached (hpipm status 2)"``); ``fallback``: True when the QP failed and the
    shifted previous plan was used instead; ``success``: the QP solve succeeded (``not
    fallback``); ``qp_iter``: QP solver iterations;
    ``step_norm``: max-norm of the SQP step; ``t_feedback`` / ``t_prepare``: wall-clock
    seconds of the two phases (``t_prepare`` refers to the preparation done *after* this
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
        """``t_feedback + t_prepare`` [s]: the wall-clock time of the whole iteration."""
        return self.t_feedback + self.t_prepare



# ---------------------------------------------------------------------------
# RTI controller
# ---------------------------------------------------------------------------

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
        Options merged over the defaults of :mod:`~netcosim.controllers.nmpc.qp` for the plugin.
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
        """Restart from the guess ``x_k = x0`` for all k and ``u_k = u_guess`` (default 0); *p*:
        the OCP's parameter vector (None: the current one)."""
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
        """Set the linearization point (e.g. a converged solution) and prepare: states *X*
        (N+1, nx), inputs *U* (N, nu), slacks *S* (N, ns) and *SN* (nsN,) (None: zeros);
        *p*: the OCP's parameter vector (None: the current one)."""
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
        """Current slack variables of the soft stage constraints, shape (N, ns)."""
        return self._w[self.tr.isg].copy() if self.tr.ns else np.zeros((self.ocp.N, 0))

    @property
    def p(self) -> np.ndarray:
        """The OCP's current parameter vector (a copy)."""
        return self._p.copy()

    # -- phases ---------------------------------------------------------------------------
    def prepare(self, p=None) -> float:
        """Linearize around the current trajectory (with the parameters *p*, None: the current
        ones); returns wall-clock seconds taken."""
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
        """One sample: :meth:`feedback` with *x0* (and *p*, None: the current parameters), then
        :meth:`preparation` for the next."""
        self.feedback(x0, p)
        self.preparation()
        return self.last

    # -- converged solves --------------------------------------------------------------------
    def cost(self, X=None, U=None, S=None, SN=None) -> float:
        """Objective value at the given (default: current) trajectory: states *X* (N+1, nx),
        inputs *U* (N, nu), stage slacks *S* (N, ns) and terminal slacks *SN* (nsN,)
        (slacks default to zero when *X* is given)."""
        tr = self.tr
        w = self._w if X is None else tr.pack(np.asarray(X), np.asarray(U),
                                              np.zeros((self.ocp.N, tr.ns)) if S is None else np.asarray(S),
                                              np.zeros(tr.nsN) if SN is None else np.asarray(SN))
        return float(self._lin(w, self._p)[4])

    def solve_sqp(self, x0, p=None, *, tol: float = 1e-9, max_iter: int = 100) -> FullSolution:
        """Full Gauss–Newton SQP from the current trajectory until ``|dw|_inf < tol``.

        Leaves the converged trajectory as the controller's linearization point.  *x0*: the
        measured state; *p*: the OCP's parameter vector (None: the current one); *max_iter*: the iteration limit.
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
        """An IPOPT solver of the same NLP (exact Hessian), for comparisons; *options* as for
        :class:`~netcosim.controllers.nmpc.full.IpoptOCP`."""
        return IpoptOCP(self, options)
