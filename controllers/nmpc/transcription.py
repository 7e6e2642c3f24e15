"""The multiple-shooting transcription of an :class:`~netcosim.controllers.nmpc.ocp.OCP` into an NLP
(shared by the RTI and the full solvers)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from .ocp import OCP


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
