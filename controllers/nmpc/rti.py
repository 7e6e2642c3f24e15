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
from .hpipm import DirectHPIPM, direct_hpipm_supported
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


class _Linearization:
    """The preparation function evaluated into preallocated arrays (CasADi's function
    buffer: no conversion to and from ``DM``): call with ``(w, p)``, read :attr:`H`,
    :attr:`A` (the nonzeros of the sparse ``H`` and ``A``, CasADi's column-major order),
    :attr:`g`, :attr:`c` (dense: structural zeros are 0.0, as ``DM.full()`` gives them)
    and :attr:`cost` (all overwritten by the next call)."""

    def __init__(self, lin: ca.Function):
        self.w = np.zeros(lin.nnz_in(0))
        self.p = np.zeros(lin.nnz_in(1))
        nz = [np.zeros(lin.nnz_out(i)) for i in range(5)]
        self.H, self.A, self.cost = nz[0], nz[2], nz[4]
        self._g_nz, self._c_nz = nz[1], nz[3]
        self.g, self.c = np.zeros(lin.size1_out(1)), np.zeros(lin.size1_out(3))
        self._g_rows = np.asarray(lin.sparsity_out(1).row(), dtype=int)
        self._c_rows = np.asarray(lin.sparsity_out(3).row(), dtype=int)
        self._buf, self._eval = lin.buffer()
        self._buf.set_arg(0, memoryview(self.w))
        self._buf.set_arg(1, memoryview(self.p))
        for i, a in enumerate(nz):
            self._buf.set_res(i, memoryview(a))

    def __call__(self, w: np.ndarray, p: np.ndarray) -> None:
        self.w[:] = w
        self.p[:] = p
        self._eval()
        for dense, nz, rows in ((self.g, self._g_nz, self._g_rows), (self.c, self._c_nz, self._c_rows)):
            dense.fill(0.0)
            dense[rows] = nz


class _ModelStep:
    """``F(x, u, p)`` (the OCP's discrete model) evaluated into preallocated arrays:
    fill :attr:`x`, :attr:`u`, :attr:`p`, call :meth:`eval`, read :attr:`out`."""

    def __init__(self, F: ca.Function):
        self.x, self.u, self.p = (np.zeros(F.nnz_in(i)) for i in range(3))
        self.out = np.zeros(F.nnz_out(0))
        if not F.sparsity_out(0).is_dense():
            raise ValueError("the discrete model's output must be dense")
        self._buf, self.eval = F.buffer()
        for i, a in enumerate((self.x, self.u, self.p)):
            self._buf.set_arg(i, memoryview(a))
        self._buf.set_res(0, memoryview(self.out))


def _shift_indices(tr: _Transcription) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(perm, ix_N, iu_last)``: ``w[perm]`` is *w* shifted by one interval (``x_k <- x_{k+1}``,
    ``u_k, σ_k <- u_{k+1}, σ_{k+1}``, the last input and slacks repeated, ``x_N`` and
    ``σ_N`` kept), ``ix_N``/``iu_last`` where ``x_N`` and ``u_{N-1}`` are."""
    perm = np.arange(tr.nw)
    perm[tr.ix[:-1].reshape(-1)] = tr.ix[1:].reshape(-1)
    if tr.iu.shape[0] > 1:
        perm[tr.iu[:-1].reshape(-1)] = tr.iu[1:].reshape(-1)
        if tr.ns:
            perm[tr.isg[:-1].reshape(-1)] = tr.isg[1:].reshape(-1)
    return perm, tr.ix[-1].copy(), tr.iu[-1].copy()


def _ill_posed(lbdw, ubdw, lba, uba, ix0) -> str:
    """What CasADi's conic input check would reject in the prepared bounds (``""``: nothing);
    the bounds of ``Δx_0`` (indices *ix0*) are set at feedback and checked then."""
    keep = np.ones(lbdw.size, dtype=bool)
    keep[ix0] = False
    for name, lb, ub in (("LBX <= UBX", lbdw[keep], ubdw[keep]), ("LBA <= UBA", lba, uba)):
        bad = ~((lb <= ub) & (lb != np.inf) & (ub != -np.inf))
        if bad.any():
            return f"{name} violated ({int(bad.sum())} rows)"
    return ""


def _ill_posed_x0(d0) -> str:
    """The same check on the bounds ``Δx_0 = d0`` (x0 is checked finite before)."""
    return "" if np.all(np.isfinite(d0)) else "LBX <= UBX violated (initial state)"


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
    direct_hpipm:
        With ``qp_solver="hpipm"``: call HPIPM directly (:mod:`~netcosim.controllers.nmpc.hpipm`),
        its QP data set in the preparation phase so that the feedback phase is the
        interior-point solve alone (default); the steps are CasADi's plugin's bit for bit.
        ``False``, or options the direct path does not understand, or a CasADi build
        without ``libhpipm.so``: CasADi's ``conic`` plugin.  Ignored for other solvers.
    history_length:
        How many of the latest :class:`RTIStep` results :attr:`history` keeps (a
        ``deque`` that drops the oldest): default 1, enough for :attr:`last`; ``0``
        keeps none; ``None`` keeps every step (grows by one step, with its whole
        plan, per sample -- for offline analysis only).  :attr:`last` always holds
        the latest step.
    """

    def __init__(self, ocp: OCP, *, qp_solver: str = "hpipm", qp_options: dict | None = None,
                 hessian_reg: float = 1e-8, jit: bool = False, x_guess=None, u_guess=None,
                 history_length: int | None = 1, direct_hpipm: bool = True):
        _check_rti_arguments(ocp, qp_solver, hessian_reg, history_length)
        self.ocp = ocp
        self.qp_solver = qp_solver
        self.tr = tr = _Transcription(ocp)
        self.hessian_reg = float(hessian_reg)
        self.jit = bool(jit)
        self._lin, H, A = _linearization(tr, hessian_reg, jit)
        self.H_sparsity, self.A_sparsity = H.sparsity(), A.sparsity()
        self._lin_buf = _Linearization(self._lin)
        self._shift_perm, self._ix_last, self._iu_last = _shift_indices(tr)
        self._F_buf = _ModelStep(ocp.F)
        qopts = _qp_options(qp_solver, ocp, tr, qp_options)
        self._qp_options = qopts
        #: HPIPM called directly, its data set in the preparation phase (same steps as
        #: CasADi's plugin, bit for bit; None: the plugin is used, see :mod:`.hpipm`)
        self._direct: DirectHPIPM | None = None
        self._qp: ca.Function | None = None
        if direct_hpipm and qp_solver == "hpipm" and direct_hpipm_supported(qopts):
            self._direct = DirectHPIPM(self.H_sparsity, self.A_sparsity, qopts)
        else:
            self._qp = ca.conic("rti_qp", qp_solver, {"h": self.H_sparsity, "a": self.A_sparsity}, qopts)
        # with a finite trajectory and constraint values, the QP's bounds pass CasADi's input
        # check exactly when the NLP's do (subtracting one finite number keeps the order)
        self._static_bounds_ok = not _ill_posed(tr.lbw, tr.ubw, tr.lbg, tr.ubg, tr.ix[0])
        self._qp_accurate: ca.Function | None = None

        self.n_steps = 0
        self.n_fail = 0
        self.history_length = None if history_length is None else int(history_length)
        #: the latest steps, oldest first (at most ``history_length``)
        self.history: deque[RTIStep] = deque(maxlen=self.history_length)
        #: the latest step (None before the first :meth:`feedback`)
        self.last: RTIStep | None = None
        self._p = ocp.p_default.copy()
        self._qpdata: dict | None = None
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
        lin = self._lin_buf
        lin(self._w, self._p)
        tr = self.tr
        lba, uba = tr.lbg - lin.c, tr.ubg - lin.c
        self._lbdw = tr.lbw - self._w
        self._ubdw = tr.ubw - self._w
        self._cost = float(lin.cost[0])
        # the linearization's buffers (overwritten by the next prepare only)
        self._qp_arrays = (lin.H, lin.g, lin.A, lba, uba)
        self._qpdata = None                # the DM form, built if a CasADi conic solves this QP
        if self._direct is not None:
            fine = self._static_bounds_ok and np.isfinite(lin.c).all() and np.isfinite(self._w).all()
            self._ill_posed = "" if fine else _ill_posed(self._lbdw, self._ubdw, lba, uba, tr.ix[0])
            self._direct.set_qp(lin.H, lin.g, lin.A, lba, uba, self._lbdw, self._ubdw)
        return time.perf_counter() - t0

    def _casadi_qpdata(self) -> dict:
        """The prepared QP as the inputs of a CasADi ``conic`` (built on first use)."""
        if self._qpdata is None:
            H, g, A, lba, uba = self._qp_arrays
            self._qpdata = dict(h=ca.DM(self.H_sparsity, H), g=g, a=ca.DM(self.A_sparsity, A), lba=lba, uba=uba)
        return self._qpdata

    def _casadi_qp(self):
        """The CasADi ``conic`` of this controller's solver and options (built on first use;
        with the direct HPIPM path it is only built if asked for)."""
        if self._qp is None:
            self._qp = ca.conic("rti_qp", self.qp_solver, {"h": self.H_sparsity, "a": self.A_sparsity},
                                self._qp_options)
        return self._qp

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
                self._qp_accurate = self._casadi_qp()
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
        d0 = x0 - self._w[ix0]
        if qp is None and self._direct is not None:
            ok, status, it, dw = self._direct_step(d0)
        else:
            lbx = self._lbdw.copy()
            ubx = self._ubdw.copy()
            lbx[ix0] = d0
            ubx[ix0] = d0
            ok, status, it, dw = self._casadi_step(self._casadi_qp() if qp is None else qp, lbx, ubx)
        if ok:
            assert dw is not None
            step = float(np.max(np.abs(dw))) if dw.size else 0.0
            self._w = self._w + dw
            self._w[ix0] = x0
            return True, status, it, step
        self._w[ix0] = x0
        return False, status, it, float("nan")

    def _casadi_step(self, qp, lbx, ubx) -> tuple[bool, str, int, np.ndarray | None]:
        """The prepared QP solved by the CasADi ``conic`` *qp* with the bounds *lbx*, *ubx*."""
        try:
            sol = qp(lbx=lbx, ubx=ubx, **self._casadi_qpdata())
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
        return ok, status, it, dw

    def _direct_step(self, d0) -> tuple[bool, str, int, np.ndarray | None]:
        """The prepared QP solved by :class:`~.hpipm.DirectHPIPM` with ``Δx_0 = d0``; an
        ill-posed QP (a lower bound above its upper bound, or NaN) fails as CasADi's
        input check makes the plugin fail."""
        bad = self._ill_posed or _ill_posed_x0(d0)
        if bad:
            return False, f"error: ill-posed QP: {bad}", -1, None
        assert self._direct is not None
        code, it, dw = self._direct.solve(d0, d0)
        ok = code == 0
        status = _status_text("hpipm", code)
        if ok and not np.all(np.isfinite(dw)):
            ok, status = False, "non-finite QP solution"
        return ok, status, it, dw

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
        u = np.minimum(np.maximum(self._w[tr.iu[0]], self.ocp.lbu), self.ocp.ubu)   # np.clip, faster
        X = self._w[tr.ix]                 # a fresh array (fancy indexing)
        self.n_steps += 1
        t1 = time.perf_counter()
        r = RTIStep(u=u, x_ref=X[1].copy(), X=X, status=status, success=ok, fallback=not ok, qp_iter=it,
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
        w = self._w[self._shift_perm]                 # x_k <- x_{k+1}, v_k <- v_{k+1}, last v repeated
        F = self._F_buf
        F.x[:] = w[self._ix_last]                     # x_N (kept if the extra step is not finite)
        F.u[:] = w[self._iu_last]
        F.p[:] = self._p
        F.eval()
        if np.all(np.isfinite(F.out)):
            w[self._ix_last] = F.out
        self._w = w

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
