"""DOP853 for CasADi plants: every integrator step one compiled call, no Python per stage.

:class:`CompiledDOP853` is a plant integrator (:mod:`netcosim.plant.integrator`) for
plants whose system offers ``casadi_dynamics() -> (F, pack)``: ``F(x, p) -> dx/dt`` a
CasADi Function of the state and of a parameter vector ``p = pack(u)`` built from the
held input (the right-hand side does not depend on t), with optionally a second output
``r``, a regularity margin that is negative where the expression may not be trusted (e.g.
a near-singular linear solve; e.g.
:meth:`netcosim.plants.flycrane.input_modes.VelocityTrackingPlant.casadi_dynamics`).  At
:meth:`~CompiledDOP853.bind` it builds, from F, one CasADi Function per step -- the 12
stages of DOP853, the new point, the error norm and a finiteness check -- and one for the 3
extra stages of the dense output, compiled to C by
:func:`netcosim.plants.casadi_tools.compile_functions` (cached on disk; uncompiled, in
CasADi's virtual machine, without a C compiler or with ``compiled=False``).  Python then
only chooses the step sizes.

The method is SciPy's ``solve_ivp(method="DOP853")``: the same coefficients (Hairer,
Norsett & Wanner, Sec. II.10, as :mod:`.dop853_coefficients`), the same initial step,
error norm (the 5th/3rd-order estimates, RMS over the states of ``err / (atol + rtol
max(|y|, |y_new|))``) and step-size control, and the same 7th-order dense output; so
``rtol`` and ``atol`` mean what they mean there, and the steps agree with SciPy's to
rounding (tests/test_plant_dop853.py).

Finiteness, regularity and stiffness: every step's stages are summed in the compiled
code and their smallest ``r`` kept; an advance meeting a non-finite sum or ``r <= 0``,
or using more than ``stiff_evaluations``, is done again from its start by
``solve_ivp``'s LSODA with the same tolerances, through the plant's own checked
right-hand side (``PlantInstance._rhs``), which raises the plant's error naming the
state at once where the dynamics are undefined (for the Fly-crane,
:class:`~netcosim.plants.flycrane.kinematics.SingularConfigurationError` naming q).  A
plant with hybrid events, a disturbance or no ``casadi_dynamics`` is advanced by
``SolveIVP(method="DOP853")`` with the same tolerances instead (the same method, its
stages evaluated one by one in Python).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

import netcosim.plants.casadi_tools as casadi_tools
from netcosim import validate
from netcosim.errors import ConfigurationError, IntegrationError
from netcosim.plant import SolveIVP
from netcosim.plant.solve_ivp import RTOL_MIN
from netcosim.plant.values import _check_count

from . import dop853_coefficients as _dop

__all__ = ["CompiledDOP853", "dop853_functions"]

_NS, _NSX = _dop.N_STAGES, _dop.N_STAGES_EXTENDED
_A, _B, _E3, _E5, _D = _dop.A, _dop.B, _dop.E3, _dop.E5, _dop.D


def dop853_functions(F: ca.Function) -> tuple[ca.Function, ca.Function]:
    """CasADi Functions of one DOP853 step of ``dx/dt = F(x, p)``.

    ``step(y, f, h, p, tol) -> (y_new, f_new, err, check, K)``: from ``(y, f = F(y, p))``
    over h (s), ``tol = (rtol, atol)``; ``err`` is SciPy's error norm (accept when < 1),
    ``check`` the sum of every stage and of y_new (non-finite if one of them is, or if
    F's second output ``r``, when it has one, is not positive at a stage), ``K``
    the 13 stages (nx by 13).  ``dense(y, y_new, h, p, K) -> (Fd, check)``: ``Fd`` (nx
    by 7) the coefficients of the 7th-order dense output (3 more stages), as SciPy's
    ``Dop853DenseOutput`` reads them, ``check`` as the step's for those stages."""
    nx, npar = F.size1_in(0), F.size1_in(1)
    y, f0, h = ca.MX.sym("y", nx), ca.MX.sym("f", nx), ca.MX.sym("h")
    p, tol = ca.MX.sym("p", npar), ca.MX.sym("tol", 2)
    K = [f0]
    regular = F.n_out() > 1
    rs = []

    def stage_value(x):
        out = F(x, p)
        if regular:
            rs.append(out[1])
            return out[0]
        return out

    def combo(row, upto):
        terms = [float(row[j]) * K[j] for j in range(upto) if row[j] != 0.0]
        return sum(terms[1:], terms[0])

    for s in range(1, _NS):
        K.append(stage_value(y + h * combo(_A[s], s)))
    y_new = y + h * combo(_B, _NS)
    f_new = stage_value(y_new)
    K.append(f_new)
    Kmat = ca.horzcat(*K)
    scale = tol[1] + ca.fmax(ca.fabs(y), ca.fabs(y_new)) * tol[0]
    n5 = ca.sumsqr(combo(_E5, _NS + 1) / scale)
    n3 = ca.sumsqr(combo(_E3, _NS + 1) / scale)
    err = ca.if_else(n5 + n3 == 0, 0, ca.fabs(h) * n5 / ca.sqrt((n5 + 0.01 * n3) * nx))
    check = ca.sum1(ca.sum2(Kmat)) + ca.sum1(y_new)
    if regular:   # NaN where a stage is not regular
        check = ca.if_else(ca.mmin(ca.vertcat(*rs)) > 0, check, np.nan)
    step = ca.Function("dop853_step", [y, f0, h, p, tol], [y_new, f_new, err, check, Kmat],
                       ["y", "f", "h", "p", "tol"], ["y_new", "f_new", "err", "check", "K"])
    ynew_d, Kin = ca.MX.sym("y_new", nx), ca.MX.sym("K", nx, _NS + 1)
    K = [Kin[:, j] for j in range(_NS + 1)]
    for s in range(_NS + 1, _NSX):
        K.append(stage_value(y + h * combo(_A[s], s)))
    dy = ynew_d - y
    cols = [dy, h * K[0] - dy, 2.0 * dy - h * (K[_NS] + K[0])]
    cols += [h * combo(_D[r], _NSX) for r in range(_D.shape[0])]
    Fd = ca.horzcat(*cols)
    dcheck = ca.sum1(ca.sum2(Fd))
    if regular:
        dcheck = ca.if_else(ca.mmin(ca.vertcat(*rs[-(_NSX - _NS - 1):])) > 0, dcheck, np.nan)
    dense = ca.Function("dop853_dense", [y, ynew_d, h, p, Kin], [Fd, dcheck],
                        ["y", "y_new", "h", "p", "K"], ["F", "check"])
    return step, dense


_BUILT: dict = {}  # id(F) -> (F, compiled?, (rhs, step, dense)): F is held, so the id stays its own


def _functions(F: ca.Function, compiled: bool):
    key = (id(F), compiled)
    hit = _BUILT.get(key)
    if hit is None or hit[0] is not F:
        step, dense = dop853_functions(F)
        funs = [F, step, dense]
        if compiled:
            funs = casadi_tools.compile_functions(funs, f"netcosim_dop853_{F.name()}")
        hit = _BUILT[key] = (F, funs)
    return hit[1]


class CompiledDOP853:
    """DOP853 with SciPy's control, each step one call of compiled CasADi code.

    ``rtol``, ``atol``: tolerances as in ``solve_ivp`` (per state, in the state's units;
    ``rtol`` from :data:`~netcosim.plant.solve_ivp.RTOL_MIN` to below 1);
    ``stiff_evaluations``: most stage evaluations one compiled advance may use (12 per
    step attempt, 3 more per step holding a dense-output instant, 2 to start; default
    6000, about 500 steps where an advance of the Fly-crane takes about 10): beyond it the
    plant is taken to be stiff there and the advance is done again, from its start, by
    ``solve_ivp``'s LSODA with the same tolerances (stiffness switching, as the former
    integrator); so is an advance meeting a non-finite stage (LSODA then evaluates the
    plant's checked right-hand side, which names a singular configuration at once).
    ``max_evaluations``: LSODA's budget (:class:`~netcosim.plant.SolveIVP`);
    ``compiled``: compile the step to C (default; False evaluates it in CasADi's
    virtual machine: the same steps, slower).
    See the module docstring for what it needs of the plant and when it falls back to
    ``SolveIVP(method="DOP853")``.

    Hooks as :class:`~netcosim.plant.SolveIVP`'s: :meth:`t_eval` instants in an advance
    are reported through :meth:`observe` from the dense output (a
    :class:`~netcosim.controllers.planner.networked.GridRecorder` passes its own).
    """

    def __init__(self, rtol: float = 1e-8, atol: float = 1e-10, max_evaluations: int = 50_000,
                 compiled: bool = True, stiff_evaluations: int = 6_000):
        for nm, v in (("rtol", rtol), ("atol", atol)):
            validate.positive(v, f"CompiledDOP853 {nm}", kind="a positive number", type_error=ConfigurationError)
        if not RTOL_MIN <= rtol < 1.0:
            raise ConfigurationError(f"CompiledDOP853 rtol must be at least {RTOL_MIN!r} and below 1, got {rtol!r}")
        _check_count(max_evaluations, "CompiledDOP853 max_evaluations")
        _check_count(stiff_evaluations, "CompiledDOP853 stiff_evaluations")
        self.rtol, self.atol, self.max_evaluations = float(rtol), float(atol), int(max_evaluations)
        self.stiff_evaluations = int(stiff_evaluations)
        self.compiled = bool(compiled)

    def __repr__(self):
        return f"CompiledDOP853(rtol={self.rtol!r}, atol={self.atol!r})"

    def t_eval(self, t0: float, t1: float):
        """Instants (s) in ``(t0, t1]`` to report through :meth:`observe` (default None)."""
        return None

    def observe(self, t, x) -> None:
        """Receives the states ``x`` (nx by k) at the instants ``t`` (s) asked by :meth:`t_eval`."""

    def bind(self, plant: Any, hooks: Any = None) -> Any:
        """The stepper advancing *plant*: a :class:`_BoundDOP853` when the plant's system
        has ``casadi_dynamics()`` (not None) and the plant has no hybrid events and no
        disturbance, else ``SolveIVP(method="DOP853")`` with these tolerances.  *hooks*
        (default this integrator) provides ``t_eval`` and ``observe``."""
        hooks = self if hooks is None else hooks
        seam = getattr(plant.system, "casadi_dynamics", None)
        dyn = seam() if callable(seam) else None
        if dyn is None or plant.system.events or plant.disturbance is not None:
            return _HookedSolveIVP(self, hooks)
        F, pack = dyn
        return _BoundDOP853(self, plant, _functions(F, self.compiled), pack, hooks)

    def integrate(self, rhs, t0, x0, t1, gs, jac=None, dense=None):
        """Unbound use (no plant): ``SolveIVP(method="DOP853")`` with these tolerances, with the
        integrator interface's arguments (*rhs*, *t0*, *x0*, *t1* [s], guards *gs*, *dense*;
        :meth:`SolveIVP.integrate <netcosim.plant.solve_ivp.SolveIVP.integrate>`); *jac* is
        not used (DOP853 is explicit)."""
        return _HookedSolveIVP(self, self).integrate(rhs, t0, x0, t1, gs, dense=dense)


class _HookedSolveIVP(SolveIVP):
    """``SolveIVP(method)`` (DOP853 by default) with the tolerances and hooks of a :class:`CompiledDOP853`."""

    def __init__(self, owner: CompiledDOP853, hooks: Any, method: str = "DOP853"):
        super().__init__(method, owner.rtol, owner.atol, max_evaluations=owner.max_evaluations)
        self.hooks = hooks

    def t_eval(self, t0, t1):
        return self.hooks.t_eval(t0, t1)

    def observe(self, t, x) -> None:
        self.hooks.observe(t, x)


class _Fallback(Exception):
    """The compiled advance met a non-finite stage or its stiffness budget: LSODA redoes it."""


def _rms(v: np.ndarray) -> float:
    return math.sqrt(float(np.dot(v, v)) / v.shape[0])


class _BoundDOP853:
    """:class:`CompiledDOP853` bound to one plant (see :meth:`CompiledDOP853.bind`).

    ``nfev``: compiled stage evaluations so far, over all advances (LSODA's not included);
    ``fallbacks``: advances redone by LSODA."""

    #: reports :meth:`integrate`'s ``dense=`` instants from its dense output (PlantInstance's default grid)
    reports_dense = True

    def __init__(self, owner: CompiledDOP853, plant: Any, funs, pack, hooks: Any):
        self.owner, self.plant, self.pack, self.hooks = owner, plant, pack, hooks
        self._f, self._step, self._dense = (casadi_tools.FunctionBuffers(fn) for fn in funs)
        self._step.args[4][:] = (owner.rtol, owner.atol)
        self._lsoda = _HookedSolveIVP(owner, hooks, "LSODA")
        self.nfev = 0
        #: advances redone by LSODA (a non-finite stage, or stiff)
        self.fallbacks = 0

    def __repr__(self):
        return f"{self.owner!r} bound to plant {self.plant.name!r}"

    def _eval_f(self, x: np.ndarray, t: float, rhs) -> np.ndarray:
        b = self._f
        b.args[0][:] = x
        b.eval()
        self.nfev += 1
        f = b.res[0]
        if not math.isfinite(float(f.sum())) or (len(b.res) > 1 and not b.res[1][0] > 0.0):
            raise _Fallback
        return f.copy()

    def integrate(self, rhs, t0, x0, t1, gs, jac=None, dense=None):
        """Advance from ``(t0, x0)`` to *t1* (s) under the input held now: ``(t1, x1, None)``.
        *gs* must be empty (a plant with events is bound to SolveIVP); *dense* as in
        :meth:`netcosim.plant.SolveIVP.integrate`.  An advance that meets a non-finite
        stage or uses more than ``stiff_evaluations`` is done again by LSODA (see
        :class:`CompiledDOP853`)."""
        if gs:
            raise ConfigurationError(f"{self!r}: hybrid events need SolveIVP (bind() chooses it for such plants)")
        try:
            return self._integrate(rhs, t0, x0, t1, dense)
        except _Fallback:
            self.fallbacks += 1
            return self._lsoda.integrate(rhs, t0, np.asarray(x0, dtype=float), t1, gs, dense=dense)

    def _integrate(self, rhs, t0, x0, t1, dense):
        owner = self.owner
        rtol, atol, budget = owner.rtol, owner.atol, owner.stiff_evaluations
        p = np.asarray(self.pack(self.plant.u), dtype=float)
        self._f.args[1][:] = p
        sb, db = self._step, self._dense
        sa, sr = sb.args, sb.res
        sa[3][:] = p
        db.args[3][:] = p
        used0 = self.nfev
        x0 = np.asarray(x0, dtype=float)
        t_eval = self.hooks.t_eval(t0, t1)
        want = [] if t_eval is None else list(t_eval)
        dense_t = [] if dense is None else [float(v) for v in np.asarray(dense[0], dtype=float)]
        times = sorted(set(want) | set(dense_t))
        got: dict[float, np.ndarray] = {}
        # SciPy's select_initial_step, error order 7
        f0 = self._eval_f(x0, t0, rhs)
        interval = abs(t1 - t0)
        scale = atol + np.abs(x0) * rtol
        d0, d1 = _rms(x0 / scale), _rms(f0 / scale)
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, interval)
        d2 = _rms((self._eval_f(x0 + h0 * f0, t0 + h0, rhs) - f0) / scale) / h0
        h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** 0.125
        h_abs = min(100 * h0, h1, interval)
        sa[0][:] = x0
        sa[1][:] = f0
        t, ti = t0, 0
        while ti < len(times) and times[ti] <= t0:
            ti += 1
        while t < t1:
            min_step = 10 * abs(math.nextafter(t, math.inf) - t)
            if h_abs < min_step:
                h_abs = min_step
            rejected = False
            while True:
                if h_abs < min_step:
                    raise IntegrationError(f"{owner!r}: step size below {min_step!r} s at t={t!r} s")
                t_new = t + h_abs
                if t_new > t1:
                    t_new = t1
                h = t_new - t
                h_abs = abs(h)
                sa[2][0] = h
                sb.eval()
                self.nfev += _NS
                if not math.isfinite(sr[3][0]) or self.nfev - used0 > budget:
                    raise _Fallback
                err = sr[2][0]
                if err < 1.0:
                    factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** -0.125)
                    h_abs *= min(1.0, factor) if rejected else factor
                    break
                h_abs *= max(0.2, 0.9 * err ** -0.125)
                rejected = True
            if ti < len(times) and times[ti] <= t_new:
                db.args[0][:] = sa[0]
                db.args[1][:] = sr[0]
                db.args[2][0] = h
                db.args[4][:] = sr[4]
                db.eval()
                self.nfev += _NSX - _NS - 1
                if not math.isfinite(db.res[1][0]):
                    raise _Fallback
                Fd = db.res[0].reshape(7, -1)   # column-major nx x 7 -> rows F0..F6
                while ti < len(times) and times[ti] <= t_new:
                    tk = times[ti]
                    got[tk] = sr[0].copy() if tk == t_new else _dense_value(Fd, sa[0], (tk - t) / h)
                    ti += 1
            sa[0][:] = sr[0]
            sa[1][:] = sr[1]
            t = t_new
        x1 = sa[0].copy()
        if want:
            self.hooks.observe(np.array(want), np.array([got[tk] for tk in want]).T)
        if dense is not None and dense_t:
            dense[1](np.array(dense_t), np.array([got[tk] for tk in dense_t]).T)
        return t1, x1, None


def _dense_value(Fd: np.ndarray, y_old: np.ndarray, x: float) -> np.ndarray:
    """SciPy's ``Dop853DenseOutput`` at the fraction *x* of the step: ``y_old + x (F0 + (1-x)
    (F1 + x (F2 + (1-x) (F3 + x (F4 + (1-x) (F5 + x F6))))))``, as one weighted sum of the rows."""
    z = 1.0 - x
    w0 = x
    w1 = w0 * z
    w2 = w1 * x
    w3 = w2 * z
    w4 = w3 * x
    w5 = w4 * z
    return y_old + np.array((w0, w1, w2, w3, w4, w5, w5 * x)) @ Fd
