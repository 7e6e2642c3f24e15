"""An explicit DOP853 integrator with dense output and event location, for the auxiliary flow.

The auxiliary flow (:mod:`.flow`) is autonomous and is integrated from ``tau = 0`` until
its norm returns to its initial value; every step's dense output is kept.  SciPy's
``solve_ivp(method="DOP853")`` does the same with more overhead per step; this loop has
SciPy's step-size control, initial step and error norm (Hairer, Norsett & Wanner II.4
and II.10), so it takes the same steps, and it lets the stages come either from a
Python right-hand side or from one compiled CasADi call per step (:mod:`.flow`).

A *stages* object provides ``rhs(y) -> f``, ``step(y, f, h) -> (y_new, f_new, err5,
err3)`` and ``dense(y_new) -> F`` (the 7 dense-output vectors of the last step), and
counts its evaluations in ``nfev``.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from . import dop853_coefficients as _dop

__all__ = ["DenseFlow", "integrate_until_return", "root_increasing", "EVENT_XTOL", "N_STAGES",
           "N_STAGES_EXTENDED", "A", "B", "E3", "E5", "D"]

N_STAGES = _dop.N_STAGES                    # 12 stages; the 13th is f at the new point
A, B = _dop.A, _dop.B                       # the flow is autonomous: no C
E3, E5, D = _dop.E3, _dop.E5, _dop.D
N_STAGES_EXTENDED = _dop.N_STAGES_EXTENDED  # + 3 stages for the dense output

#: Relative tolerance of the event location (tau_s) on the dense output.
EVENT_XTOL = 64 * np.finfo(float).eps


def _dense_to_monomial() -> np.ndarray:
    """Matrix M (7x7) with ``y(x) - y_old = sum_k (M F)_k x^(k+1)`` for DOP853's dense
    output ``x(F0 + (1-x)(F1 + x(F2 + (1-x)(F3 + x(F4 + (1-x)(F5 + x F6))))))``."""
    P = np.polynomial.polynomial
    M = np.zeros((7, 7))
    for j in range(7):
        poly = np.zeros(1)
        for i in range(6, -1, -1):
            poly = P.polyadd(poly, [1.0 if i == j else 0.0])
            poly = P.polymul(poly, [0.0, 1.0] if i % 2 == 0 else [1.0, -1.0])
        M[:len(poly) - 1, j] = poly[1:]
    return M


MONO = _dense_to_monomial()
_POWERS = np.arange(1, 8)


class DenseFlow:
    """Continuous DOP853 solution of the flow: one degree-7 polynomial per step.

    ``t``: step boundaries (k+1,); ``y``: states there (k+1, m); ``P``: monomial
    coefficients (k, 7, m) with ``y(t_i + x h_i) = y_i + sum_j P[i, j] x^(j+1)``, x in [0, 1].
    Called like SciPy's ``OdeSolution``: ``sol(tau)`` is ``(m,)`` for a scalar tau and
    ``(m, len(tau))`` for an array (tau outside ``[t_0, t_k]`` extrapolates the end pieces).
    """

    def __init__(self, t, y, P):
        self.t = np.asarray(t, dtype=float)
        self.y = np.asarray(y, dtype=float)
        self.P = np.asarray(P, dtype=float)
        self.h = np.diff(self.t)
        self._tl, self._hl = self.t.tolist(), self.h.tolist()

    def values(self, tau) -> np.ndarray:
        """``e'(tau)`` for a 1-D array of tau, shape ``(len(tau), m)``."""
        tau = np.asarray(tau, dtype=float)
        i = np.searchsorted(self.t[1:-1], tau, side="right")  # piece, end pieces extended
        x = (tau - self.t[i]) / self.h[i]
        return self.y[i] + np.einsum("kj,kjm->km", x[:, None] ** _POWERS, self.P[i])

    def derivatives(self, tau: float) -> np.ndarray:
        """Rows ``e'``, ``de'/dtau``, ``d2e'/dtau2`` at a scalar tau, shape ``(3, m)``."""
        i = min(max(bisect.bisect_right(self._tl, tau) - 1, 0), len(self._hl) - 1)
        h = self._hl[i]
        x = (tau - self._tl[i]) / h
        p = [1.0, x]
        for _ in range(6):
            p.append(p[-1] * x)
        h2 = h * h
        V = np.array((p[1:], [k * p[k - 1] / h for k in range(1, 8)],
                      [0.0] + [k * (k - 1) * p[k - 2] / h2 for k in range(2, 8)]))
        Y = V @ self.P[i]
        Y[0] += self.y[i]
        return Y

    def __call__(self, tau):
        tau = np.asarray(tau, dtype=float)
        if tau.ndim == 0:
            return self.values(tau[None])[0]
        return self.values(tau.reshape(-1)).T.reshape((self.y.shape[1],) + tau.shape)


def _rms(x):
    return math.sqrt(float(np.dot(x, x)) / x.shape[0])


def _initial_step(stages, y0, f, t_bound, rtol, atol):
    """SciPy's ``select_initial_step`` (Hairer, Norsett & Wanner II.4), error order 7."""
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(f / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_bound)
    d2 = _rms((stages.rhs(y0 + h0 * f) - f) / scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1 / 8)
    return min(100 * h0, h1, t_bound)


def _accepted_step(stages, t, y, f, h_abs, t_bound, rtol, atol):
    """One accepted step from ``(t, y)`` with SciPy's error control: returns
    ``(t_new, y_new, f_new, h_abs_next)``."""
    m = y.shape[0]
    min_step = 10 * abs(math.nextafter(t, math.inf) - t)
    h_abs = max(h_abs, min_step)
    rejected = False
    while True:
        if h_abs < min_step:
            raise RuntimeError(f"auxiliary flow integration failed: step size too small at tau={t}")
        t_new = min(t + h_abs, t_bound)
        h = t_new - t
        h_abs = abs(h)
        y_new, f_new, e5, e3 = stages.step(y, f, h)
        scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
        e5 = e5 / scale
        e3 = e3 / scale
        n5, n3 = float(np.dot(e5, e5)), float(np.dot(e3, e3))
        err = 0.0 if n5 == 0.0 and n3 == 0.0 else h_abs * n5 / math.sqrt((n5 + 0.01 * n3) * m)
        if err < 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** -0.125)
            h_abs *= min(1.0, factor) if rejected else factor
            return t_new, y_new, f_new, h_abs
        h_abs *= max(0.2, 0.9 * err ** -0.125)
        rejected = True


def integrate_until_return(stages, y0, t_bound, rtol, atol, fn):
    """Integrate from ``tau = 0`` with DOP853 until ``fn.event(y)`` rises through zero at
    the end of a step, or until ``t_bound``.

    *stages*: the stages object (module docstring); *y0*: the initial state; *rtol*, *atol*:
    the step-size control's relative and absolute tolerances.  Returns ``(DenseFlow,
    tau_s)`` (``tau_s = inf`` without event).  The event is located
    on the dense output of the step where it occurs by :func:`root_increasing` on
    ``fn.event_slope`` (value and slope from the rows of :meth:`DenseFlow.derivatives`),
    to :data:`EVENT_XTOL` (SciPy's ``solve_ivp`` uses Brent's method there, to 4 ulp).
    """
    f = stages.rhs(y0)
    h_abs = _initial_step(stages, y0, f, t_bound, rtol, atol)
    t, y, g = 0.0, y0, 0.0
    ts, ys, Ps = [0.0], [y0], []
    while True:
        t_new, y_new, f_new, h_abs = _accepted_step(stages, t, y, f, h_abs, t_bound, rtol, atol)
        Ps.append(MONO @ stages.dense(y_new))
        ts.append(t_new)
        ys.append(y_new)
        g_new = fn.event(y_new)
        if g <= 0.0 <= g_new:
            sol = DenseFlow(ts, ys, Ps)
            return sol, root_increasing(lambda s: fn.event_slope(sol.derivatives(s)), t, t_new, EVENT_XTOL)
        if t_new >= t_bound:
            return DenseFlow(ts, ys, Ps), math.inf
        t, y, f, g = t_new, y_new, f_new, g_new


def root_increasing(fun, lo, hi, xtol, maxiter=200):
    """A zero of ``g`` on ``[lo, hi]`` where ``g(lo) <= 0 <= g(hi)``; ``fun(x) -> (g, g')``.

    Newton's method safeguarded by the bracket: a step that leaves the bracket, or does
    not halve the previous step, is replaced by bisection.  Returns once a Newton step
    or the bracket is below ``xtol * max(1, |x|)``, or after *maxiter* iterations (the last
    iterate).
    """
    x = 0.5 * (lo + hi)
    dx_old = hi - lo
    for _ in range(maxiter):
        g, dg = fun(x)
        if g == 0.0:
            return x
        if g < 0.0:
            lo = x
        else:
            hi = x
        tol = xtol * max(1.0, abs(x))
        xn = x - g / dg if dg > 0.0 else math.nan
        if lo <= xn <= hi:
            dx = abs(xn - x)
            if dx <= tol:
                return xn
            if dx < 0.5 * dx_old:
                dx_old, x = dx, xn
                continue
        dx_old = 0.5 * (hi - lo)
        x = lo + dx_old
        if dx_old <= tol:
            return x
    return x
