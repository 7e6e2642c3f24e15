"""Fully converged solves of the OCP: :class:`FullSolution` and the IPOPT solver
(:class:`IpoptOCP`); the Gauss–Newton SQP is :meth:`RTINMPC.solve_sqp
<netcosim.controllers.nmpc.rti.RTINMPC.solve_sqp>`."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import casadi as ca
import numpy as np

from .transcription import _Transcription

__all__ = ["FullSolution", "IpoptOCP"]


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


class _Iterate(Protocol):
    """What :class:`IpoptOCP` reads of its :class:`~netcosim.controllers.nmpc.rti.RTINMPC` (so this
    module need not import ``rti.py``, which imports it): the transcription, the current
    iterate and parameters, and the checks of ``x0`` and ``p``."""

    tr: _Transcription
    _w: np.ndarray
    _p: np.ndarray

    def _check_x(self, x0, what: str = ...) -> np.ndarray: ...

    def _check_p(self, p) -> np.ndarray: ...


class IpoptOCP:
    """Full IPOPT solve of the multiple-shooting NLP of an :class:`RTINMPC`.

    Same variables, constraints and objective as the RTI; exact Hessian of the
    Lagrangian.  Warm-started from the previous solution when called repeatedly.
    ``rti``: the :class:`RTINMPC` whose NLP is solved; ``options``: CasADi ``nlpsol``
    options merged over the defaults (IPOPT quiet, tol 1e-10, at most 500 iterations).
    """

    def __init__(self, rti: _Iterate, options: dict | None = None):
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
        """Solve the NLP from the measured state *x0* (fixed as the first node); *p*: the OCP's
        parameter vector (None: the current one);
        *w_init*: the initial guess of the stacked variables (None: the previous solution,
        else the RTI's current trajectory).  The solution is kept as the next warm start
        only when IPOPT succeeds."""
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
