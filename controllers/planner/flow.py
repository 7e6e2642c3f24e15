"""The auxiliary flow (3.12)/(4.17) and the online gain (3.26)/(4.30).

The flow ``e'_dot = -A^+_{q_r + e'} A_{q_r + e_h} K_bar e_h``, ``e'(0) = e_h`` gives the
sampled closed loop by time rescaling (3.13)/(4.18); ``tau_s`` is its return time
(event detection) and ``tau_o`` the minimiser of the error norm over ``[0, tau_s]``.

Two right-hand sides give the DOP853 stages (:mod:`.dop853`):

* for systems with a CasADi Jacobian ``A_fun`` (every
  :class:`netcosim.plants.flycrane.MultiRobotSystem`), one CasADi Function per step (QR solve,
  all stages and the dense output), compiled to machine code by
  :func:`netcosim.plants.casadi_tools.compile_functions` when a C compiler is available;
* otherwise, or where a QR pivot falls below :data:`PIVOT_RTOL`, the SVD least squares
  of :func:`netcosim.plants.kinematic.pinv_solve`, which raises
  :class:`~netcosim.plants.kinematic.SingularConfigurationError` at rank loss.
"""

from __future__ import annotations

import math
import warnings
import weakref
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

import netcosim.plants.casadi_tools as casadi_tools
from netcosim.plants.casadi_tools import FunctionBuffers, compile_functions
from netcosim.plants.kinematic import conditioning

from .dop853 import E3 as _E3
from .dop853 import E5 as _E5
from .dop853 import N_STAGES as _NS
from .dop853 import N_STAGES_EXTENDED as _NSX
from .dop853 import A as _A
from .dop853 import B as _B
from .dop853 import D as _D
from .dop853 import DenseFlow, integrate_until_return, root_increasing
from .kinematics import as_vector, check_period, check_system, diag_gain, jacobian, pinv_solve, rank_rtol
from .norms import WeightedNorm

__all__ = ["AuxiliaryFlow", "solve_auxiliary_flow", "online_gain", "DenseFlow", "FLOW_RTOL", "FLOW_ATOL_REL",
           "TAU_XTOL", "PIVOT_RTOL"]

#: Default integrator tolerances for the auxiliary flow: relative, and absolute as a
#: fraction of ||e_h||_2 (the flow scales with e_h).
FLOW_RTOL = 1e-10
FLOW_ATOL_REL = 1e-12
#: Absolute tolerance (in tau) of the minimisation giving tau_o.
TAU_XTOL = 1e-10
#: A QR pivot of ``A_q`` below this fraction of the largest one anywhere in a step of the
#: CasADi flow sends the whole flow back to the SVD right-hand side (rank rule of
#: :func:`netcosim.plants.kinematic.rank_rtol`), which raises
#: :class:`~netcosim.plants.kinematic.SingularConfigurationError` if needed.  Whether the CasADi
#: flow is compiled: :data:`netcosim.plants.casadi_tools.COMPILE` (read when a system's flow is
#: first prepared; libraries cached in :func:`netcosim.plants.casadi_tools.cache_dir`).
PIVOT_RTOL = 1e-7


class _FallBack(Exception):
    """The compiled flow met a (near-)singular A_q or a non-finite value."""


class _SVDFlow:
    """DOP853 stages of the flow with the SVD right-hand side ``-A^+_{q_r + x} c``
    (:func:`netcosim.plants.kinematic.pinv_solve`): works for any kinematic system and raises
    :class:`SingularConfigurationError` where ``A_q`` loses rank."""

    def __init__(self, system, q_ref, c):
        self.system, self.q_ref, self.c = system, q_ref, c
        self.rank_tol = rank_rtol(system)
        self.K = np.empty((_NSX, q_ref.shape[0]))
        self.nfev = 0

    def rhs(self, x):
        self.nfev += 1
        q = self.q_ref + x
        return -pinv_solve(jacobian(self.system, q), self.c, q, self.rank_tol)

    def step(self, y, f, h):
        K = self.K
        K[0] = f
        for s in range(1, _NS):
            K[s] = self.rhs(y + h * (K[:s].T @ _A[s, :s]))
        y_new = y + h * (K[:_NS].T @ _B)
        K[_NS] = f_new = self.rhs(y_new)
        self._y, self._h = y, h
        return y_new, f_new, K[:_NS + 1].T @ _E5, K[:_NS + 1].T @ _E3

    def dense(self, y_new):
        """The 7 dense-output vectors of the last step (3 more stages)."""
        K, y, h = self.K, self._y, self._h
        for s in range(_NS + 1, _NSX):
            K[s] = self.rhs(y + h * (K[:s].T @ _A[s, :s]))
        dy = y_new - y
        F = np.empty((7, y.shape[0]))
        F[0] = dy
        F[1] = h * K[0] - dy
        F[2] = 2.0 * dy - h * (K[_NS] + K[0])
        F[3:] = h * (_D @ K)
        return F


def _casadi_flow_functions(system):
    """CasADi Functions ``rhs(x, c, q_r) -> (f, piv)`` and ``step(y, f, h, c, q_r) ->
    (y_new, f_new, err5, err3, F, piv)`` of the flow, or None if *system* has no
    symbolic Jacobian ``A_fun``.  ``f = -A^+ c`` by QR (modified Gram-Schmidt),
    ``piv = min |R_ii| / max |R_ii|``; ``step`` is one DOP853 step with its dense output,
    the smallest ``piv`` of its stages and the sum of all stages (not finite if one is not)."""
    A_fun = getattr(system, "A_fun", None)
    n, m = int(system.n), int(system.m)
    if not isinstance(A_fun, ca.Function) or n < m or A_fun.n_in() != 1 or A_fun.n_out() < 1 \
            or A_fun.size_in(0) != (m, 1) or A_fun.size_out(0) != (n, m):
        return None
    x, c, qr = ca.SX.sym("x", m), ca.SX.sym("c", n), ca.SX.sym("q_r", m)
    try:
        A = ca.densify(A_fun(qr + x))
    except (RuntimeError, NotImplementedError) as exc:  # e.g. an MX-only Function (CasADi raises RuntimeError)
        warnings.warn(f"{getattr(system, 'name', system)!r}: A_fun cannot be evaluated symbolically ({exc}); "
                      f"the auxiliary flow uses the SVD right-hand side (same rule, slower)",
                      casadi_tools.CompiledCodeWarning, stacklevel=3)
        return None
    Q, R = ca.qr(A)
    dR = ca.fabs(ca.diag(R))
    rhs = ca.Function("flow_rhs", [x, c, qr], [-ca.solve(R, Q.T @ c), ca.mmin(dR) / ca.mmax(dR)],
                      {"never_inline": True})
    y, f0, h = ca.SX.sym("y", m), ca.SX.sym("f", m), ca.SX.sym("h")
    K, piv = [f0], []

    def stage(s):
        dy = ca.SX.zeros(m)
        for j in range(s):
            if _A[s, j] != 0.0:
                dy += float(_A[s, j]) * K[j]
        fs, ps = rhs(y + h * dy, c, qr)
        K.append(fs)
        piv.append(ps)

    for s in range(1, _NS):
        stage(s)
    y_new = y + h * sum(float(_B[j]) * K[j] for j in range(_NS) if _B[j] != 0.0)
    f_new, p_new = rhs(y_new, c, qr)
    K.append(f_new)
    piv.append(p_new)
    for s in range(_NS + 1, _NSX):
        stage(s)
    err5 = sum(float(_E5[j]) * K[j] for j in range(_NS + 1) if _E5[j] != 0.0)
    err3 = sum(float(_E3[j]) * K[j] for j in range(_NS + 1) if _E3[j] != 0.0)
    dy = y_new - y
    F = [dy, h * K[0] - dy, 2.0 * dy - h * (f_new + K[0])]
    for r in range(_D.shape[0]):
        F.append(h * sum(float(_D[r, j]) * K[j] for j in range(_NSX) if _D[r, j] != 0.0))
    step = ca.Function("flow_step", [y, f0, h, c, qr],
                       [y_new, f_new, err5, err3, ca.horzcat(*F), ca.mmin(ca.vertcat(*piv)),
                        ca.sum1(ca.sum2(ca.horzcat(*K)))])
    return rhs, step


class _CompiledFlow:
    """DOP853 stages of the flow from the CasADi Functions of :func:`_casadi_flow_functions`
    (one call per step, dense output included).  Raises :class:`_FallBack` when a QR pivot
    drops below :data:`PIVOT_RTOL` or a value is not finite."""

    def __init__(self, funs):
        self.rhs_buf, self.step_buf = FunctionBuffers(funs[0]), FunctionBuffers(funs[1])
        self.nfev = 0

    def start(self, q_ref, c):
        self.rhs_buf.args[1][:] = c
        self.rhs_buf.args[2][:] = q_ref
        self.step_buf.args[3][:] = c
        self.step_buf.args[4][:] = q_ref
        self.nfev = 0
        return self

    def rhs(self, x):
        b = self.rhs_buf
        b.args[0][:] = x
        b.eval()
        self.nfev += 1
        if not (b.res[1][0] > PIVOT_RTOL and math.isfinite(b.res[0].sum())):
            raise _FallBack
        return b.res[0].copy()

    def step(self, y, f, h):
        b = self.step_buf
        b.args[0][:] = y
        b.args[1][:] = f
        b.args[2][0] = h
        b.eval()
        self.nfev += _NSX - 1
        if not (b.res[5][0] > PIVOT_RTOL and math.isfinite(b.res[6][0])):
            raise _FallBack
        return b.res[0].copy(), b.res[1].copy(), b.res[2].copy(), b.res[3].copy()

    def dense(self, y_new):
        return self.step_buf.res[4].reshape(7, -1)  # column-major m x 7 -> rows F_0..F_6


_COMPILED_FLOWS = weakref.WeakKeyDictionary()      # system -> _CompiledFlow or None
_BY_SOURCE: dict = {}  # (serialized symbolic step, casadi_tools.COMPILE) -> Functions, shared by equal systems


def _compiled_flow(system):
    """The :class:`_CompiledFlow` of *system* (built and compiled once), or None."""
    try:
        return _COMPILED_FLOWS[system]
    except KeyError:
        pass
    except TypeError:  # not weakly referenceable: build every time would be too slow
        return None
    funs = _casadi_flow_functions(system)
    flow = None
    if funs is not None:
        key = funs[1].serialize()
        key = (key, casadi_tools.COMPILE)
        if key not in _BY_SOURCE:
            _BY_SOURCE[key] = compile_functions(list(funs), f"netcosim_flow_{system.n}x{system.m}")
        flow = _CompiledFlow(_BY_SOURCE[key])
    _COMPILED_FLOWS[system] = flow
    return flow


class _FlowNorm:
    """The flow's norm ``||D y||_p`` with ``||e_h||``: the event ``||y|| - ||e_h||`` and the
    derivatives along the dense output that locate ``tau_s`` and ``tau_o``."""

    def __init__(self, nrm: WeightedNorm, m: int, n0: float):
        self.w = None if nrm.weights is None else nrm.w(m)
        self.two = nrm.p == 2
        self.n0 = n0

    def __call__(self, y) -> float:
        z = y if self.w is None else self.w * y
        if self.two:
            return math.sqrt(float(np.dot(z, z)))
        return float(np.max(np.abs(z)))

    def event(self, y) -> float:
        return self(y) - self.n0

    def event_slope(self, Y):
        """``(||e'|| - ||e_h||, d||e'||/dtau)`` from the rows ``e', e'_tau, e'_tautau``
        (one-sided derivative for the max-norm)."""
        Z = Y if self.w is None else self.w * Y
        if self.two:
            r = math.sqrt(float(np.dot(Z[0], Z[0])))
            return r - self.n0, (float(np.dot(Z[0], Z[1])) / r if r > 0.0 else 0.0)
        k = int(np.argmax(np.abs(Z[0])))
        return abs(Z[0, k]) - self.n0, math.copysign(1.0, Z[0, k]) * Z[1, k]

    def slope_curvature(self, Y):
        """A function with the sign of ``d||e'||/dtau`` and its derivative: for the 2-norm
        ``(z . z', z' . z' + z . z'')`` with ``z = D e'``; for the max-norm the one-sided
        derivative of the largest ``|z_k|`` and its own derivative."""
        Z = Y if self.w is None else self.w * Y
        if self.two:
            return float(np.dot(Z[0], Z[1])), float(np.dot(Z[1], Z[1]) + np.dot(Z[0], Z[2]))
        k = int(np.argmax(np.abs(Z[0])))
        s = math.copysign(1.0, Z[0, k])
        return s * Z[1, k], s * Z[2, k]


@dataclass
class AuxiliaryFlow:
    """Solution ``e'(tau; e_h)`` of the auxiliary flow (3.12)/(4.17) on ``[0, tau_end]``
    (tau is the rescaled time ``k t``: dimensionless).

    ``tau_s``: first ``tau > 0`` with ``||e'(tau)|| = ||e_h||`` (``inf`` if the norm
    stays below ``||e_h||`` up to ``tau_max``); ``tau_o``: argmin of ``||e'||`` over
    ``[0, min(tau_s, tau_max)]``; ``min_norm = ||e'(tau_o)||``.  Calling the object
    evaluates ``e'`` (dense output) at one or many tau.  ``sol``: the :class:`DenseFlow`;
    ``nfev``: right-hand-side evaluations used.
    """

    e_h: np.ndarray
    tau_s: float
    tau_o: float
    min_norm: float
    tau_end: float
    norm: WeightedNorm
    sol: Any = field(repr=False, default=None)
    nfev: int = 0

    def __call__(self, tau):
        tau = np.asarray(tau, dtype=float)
        if self.sol is None:
            return np.broadcast_to(self.e_h, tau.shape + self.e_h.shape).copy() if tau.ndim else self.e_h.copy()
        if np.any(tau < -1e-15) or np.any(tau > self.tau_end * (1 + 1e-12) + 1e-15):
            raise ValueError(f"tau outside the solved range [0, {self.tau_end}]")
        y = self.sol.values(np.clip(tau, 0.0, self.tau_end).reshape(-1))
        return y.reshape(tau.shape + self.e_h.shape)


def solve_auxiliary_flow(system: Any, q_ref: Any, e_h: Any, *, kbar: Any = None, norm: Any = None,
                         tau_max: float | None = None, rtol: float = FLOW_RTOL,
                         atol_rel: float = FLOW_ATOL_REL, n_grid: int = 64) -> AuxiliaryFlow:
    """Integrate ``e'_dot = -A^+_{q_r + e'} A_{q_r + e_h} K_bar e_h``, ``e'(0) = e_h``.

    *system*: the kinematic system; *q_ref*: q_r (rad, m); *kbar*: the diagonal of K_bar
    (None: ones).

    This is (3.12) for square systems with ``K_bar = I`` and (4.17) in general.  The
    integration (DOP853 with SciPy's step-size control, ``rtol``,
    ``atol = atol_rel * ||e_h||_2``, dense output on every step) stops at the first return
    of the norm to ``||e_h||`` (a rise through zero of ``||e'|| - ||e_h||`` at the end of a
    step, located on the dense output by safeguarded Newton to :data:`EVENT_XTOL`) or at ``tau_max``
    (default ``10 / min(K_bar)``).  ``tau_o`` is found by scanning the dense output on
    ``n_grid`` points plus the step ends and solving ``d||e'||/dtau = 0`` (for the
    max-norm: its one-sided version) on the best bracket by safeguarded Newton to
    :data:`TAU_XTOL`.  For ``e_h = 0`` the flow is at rest and ``tau_o := 1`` (the limit of
    Proposition 3.4.6).

    Right-hand side: for systems with a CasADi Jacobian ``A_fun`` (every
    :class:`netcosim.plants.flycrane.MultiRobotSystem`) ``A^+ c`` comes from a QR factorisation in
    one compiled function per step (see :data:`netcosim.plants.casadi_tools.COMPILE`); otherwise, or where a QR
    pivot falls below :data:`PIVOT_RTOL`, from the SVD least squares of
    :func:`netcosim.plants.kinematic.pinv_solve`, which raises :class:`SingularConfigurationError` at rank loss.
    """
    check_system(system)
    m = system.m
    q_ref = as_vector(q_ref, m, "q_ref")
    e_h = as_vector(e_h, m, "e_h")
    kd = diag_gain(kbar, m)
    nrm = WeightedNorm.of(norm)
    nrm.w(m)
    if tau_max is None:
        tau_max = 10.0 / float(kd.min())
    tau_max = check_period(tau_max, "tau_max")
    n0 = nrm(e_h)
    scale = float(np.linalg.norm(e_h))
    if scale == 0.0:
        return AuxiliaryFlow(e_h, math.inf, 1.0, 0.0, tau_max, nrm, None, 0)
    c = jacobian(system, q_ref + e_h) @ (kd * e_h)
    fn = _FlowNorm(nrm, m, n0)
    stages = _compiled_flow(system)
    sol = None
    if stages is not None:
        try:
            sol, tau_s = integrate_until_return(stages.start(q_ref, c), e_h, tau_max, rtol, atol_rel * scale, fn)
        except _FallBack:
            sol = None
        # the QR pivot test is only a trigger; the rank rule itself is checked at every step end
        if sol is not None and not _regular_along(system, q_ref, sol.y):
            sol = None
    if sol is None:
        stages = _SVDFlow(system, q_ref, c)
        sol, tau_s = integrate_until_return(stages, e_h, tau_max, rtol, atol_rel * scale, fn)
    tau_end = tau_s if math.isfinite(tau_s) else float(sol.t[-1])
    grid = np.union1d(np.linspace(0.0, tau_end, n_grid), sol.t[sol.t <= tau_end])
    vals = nrm.many(sol.values(grid))
    j = int(np.argmin(vals))
    lo = float(grid[max(j - 1, 0)])
    hi = float(grid[min(j + 1, len(grid) - 1)])
    tau_o, best = float(grid[j]), float(vals[j])
    if hi > lo:
        slope = lambda s: fn.slope_curvature(sol.derivatives(s))  # noqa: E731
        if slope(hi)[0] <= 0.0:      # still decreasing at the end of the bracket
            t = hi
        elif slope(lo)[0] >= 0.0:
            t = lo
        else:
            t = root_increasing(slope, lo, hi, TAU_XTOL)
        v = fn(sol.derivatives(t)[0])
        if v < best:
            tau_o, best = t, v
    return AuxiliaryFlow(e_h, tau_s, tau_o, best, tau_end, nrm, sol, int(stages.nfev))


def _regular_along(system, q_ref, ys) -> bool:
    """Whether ``A_q`` passes the rank rule (:func:`~netcosim.plants.kinematic.rank_rtol`) at every ``q_ref + y``."""
    tol = rank_rtol(system)
    for y in ys:
        if conditioning(np.linalg.svd(jacobian(system, q_ref + y), compute_uv=False), tol)[3]:
            return False
    return True


def online_gain(system: Any, q: Any, q_ref: Any, T: float, *, kbar: Any = None, norm: Any = None,
                **flow_kw) -> tuple[float, AuxiliaryFlow]:
    """Online gain ``k_h = tau_o(e_h) / T`` (3.26)/(4.30), in 1/s, and the flow used, at the
    configuration *q* with the period *T* [s]: the flow of :func:`solve_auxiliary_flow`
    from ``e_h = q - q_ref``.  *system*: the kinematic system; *q_ref*: the reference
    configuration q_r (rad, m); *kbar*: the diagonal of K_bar (None: ones); *norm*: the
    :class:`~netcosim.controllers.planner.norms.WeightedNorm` (or what
    :meth:`~netcosim.controllers.planner.norms.WeightedNorm.of` accepts); other keywords
    go to :func:`solve_auxiliary_flow`."""
    T = check_period(T)
    q = as_vector(q, system.m, "q")
    q_ref = as_vector(q_ref, system.m, "q_ref")
    flow = solve_auxiliary_flow(system, q_ref, q - q_ref, kbar=kbar, norm=norm, **flow_kw)
    return flow.tau_o / T, flow
