"""The landing NMPC's QP under HPIPM's partial condensing: the condensing choice of docs/nmpc.md.

The RTI's QP (N = 30 stages of 6 states and 4 inputs -- 2 rates and 2 slacks) is solved
by HPIPM's Riccati-based interior-point method stage by stage (N2 = N).  Partial
condensing eliminates the states inside blocks of stages and hands HPIPM a QP of N2 < N
stages with larger inputs; the condensing of the matrices depends only on the
linearization, so in an RTI it belongs to the preparation phase (``d_part_cond_qp_cond_lhs``),
and only the vectors (the measured state enters the bounds of ``Δx_0``) are condensed in
the feedback phase (``d_part_cond_qp_cond_rhs``), before the solve and the expansion of
the solution.

For each N2 the same closed-loop landing (100 samples, the default controller driving
it) gives, at every sample: the CPU time of the thread for the preparation part
(``cond_lhs``) and for the feedback part (``cond_rhs`` + interior-point solve + expansion),
the iterations, and the largest difference of the step, and of its first input (the
one applied), from the uncondensed one (the steps are not bit-identical: condensing
changes the rounding, and the interior-point method stops at a different point within
its tolerance; the largest differences are in the thrust rate of the last intervals,
weighted 1e-4).  Run
``python -m benchmarks.nmpc_condensing``; the library is CasADi's ``libhpipm.so`` (BLASFEO
built for the generic target); ``LD_LIBRARY_PATH`` pointing to another ``libblasfeo.so.0``
times the same with it.
"""

from __future__ import annotations

import ctypes
import gc
import time

import numpy as np
import pandas as pd

from netcosim.controllers.landing import initial_state, landing_nmpc
from netcosim.controllers.nmpc.hpipm import _MODES, _Mem

STEPS = 100
#: Horizons of the condensed QP (30: no condensing, through the same code path).
N2S = (30, 15, 10, 6, 5, 3, 2, 1)


class _Condensed:
    """HPIPM's partial condensing of a :class:`~netcosim.controllers.nmpc.hpipm.DirectHPIPM`'s QP to N2 stages."""

    def __init__(self, direct, N2: int, mode: str = "speed", iter_max: int = 100, tol: float = 1e-6):
        lib = direct._lib
        self.lib, self.d = lib, direct
        ci = ctypes.c_int
        self.bs = (ci * (N2 + 1))()
        lib.d_part_cond_qp_compute_block_size(ci(direct.N), ci(N2), self.bs)
        self.dim = _Mem(lib.d_ocp_qp_dim_strsize())
        self.dim_mem = _Mem(lib.d_ocp_qp_dim_memsize(N2))
        lib.d_ocp_qp_dim_create(ci(N2), self.dim.ptr, self.dim_mem.ptr)
        lib.d_part_cond_qp_compute_dim(direct._dim.ptr, self.bs, self.dim.ptr)
        self.qp = _Mem(lib.d_ocp_qp_strsize())
        self.qp_mem = _Mem(lib.d_ocp_qp_memsize(self.dim.ptr))
        lib.d_ocp_qp_create(self.dim.ptr, self.qp.ptr, self.qp_mem.ptr)
        self.sol = _Mem(lib.d_ocp_qp_sol_strsize())
        self.sol_mem = _Mem(lib.d_ocp_qp_sol_memsize(self.dim.ptr))
        lib.d_ocp_qp_sol_create(self.dim.ptr, self.sol.ptr, self.sol_mem.ptr)
        lib.d_part_cond_qp_arg_memsize.restype = ctypes.c_size_t
        lib.d_part_cond_qp_ws_memsize.restype = ctypes.c_size_t
        self.carg = _Mem(4096)
        self.carg_mem = _Mem(lib.d_part_cond_qp_arg_memsize(ci(N2)))
        lib.d_part_cond_qp_arg_create(ci(N2), self.carg.ptr, self.carg_mem.ptr)
        lib.d_part_cond_qp_arg_set_default(self.carg.ptr)
        self.cws = _Mem(4096)
        self.cws_mem = _Mem(lib.d_part_cond_qp_ws_memsize(direct._dim.ptr, self.bs, self.dim.ptr, self.carg.ptr))
        lib.d_part_cond_qp_ws_create(direct._dim.ptr, self.bs, self.dim.ptr, self.carg.ptr, self.cws.ptr,
                                     self.cws_mem.ptr)
        self.arg = _Mem(lib.d_ocp_qp_ipm_arg_strsize())
        self.arg_mem = _Mem(lib.d_ocp_qp_ipm_arg_memsize(self.dim.ptr))
        lib.d_ocp_qp_ipm_arg_create(self.dim.ptr, self.arg.ptr, self.arg_mem.ptr)
        lib.d_ocp_qp_ipm_arg_set_default(ci(_MODES[mode]), self.arg.ptr)
        lib.d_ocp_qp_ipm_arg_set_iter_max(ctypes.byref(ci(iter_max)), self.arg.ptr)
        for name in ("stat", "eq", "ineq", "comp"):
            getattr(lib, f"d_ocp_qp_ipm_arg_set_tol_{name}")(ctypes.byref(ctypes.c_double(tol)), self.arg.ptr)
        self.ws = _Mem(lib.d_ocp_qp_ipm_ws_strsize())
        self.ws_mem = _Mem(lib.d_ocp_qp_ipm_ws_memsize(self.dim.ptr, self.arg.ptr))
        lib.d_ocp_qp_ipm_ws_create(self.dim.ptr, self.arg.ptr, self.ws.ptr, self.ws_mem.ptr)
        self.it = ci(0)

    def prepare(self) -> None:
        """The matrices (everything the measurement does not enter)."""
        self.lib.d_part_cond_qp_cond_lhs(self.d._qp.ptr, self.qp.ptr, self.carg.ptr, self.cws.ptr)

    def feedback(self, d0: np.ndarray) -> tuple[int, np.ndarray]:
        """Bounds of ``Δx_0``, the vectors condensed, solve, expand; returns (iterations, Δw)."""
        d, lib = self.d, self.lib
        d._lbx0[:] = d0
        d._ubx0[:] = d0
        lib.d_ocp_qp_set_lbx(d._stage0, d._p_lbx0, d._qp.ptr)
        lib.d_ocp_qp_set_ubx(d._stage0, d._p_ubx0, d._qp.ptr)
        lib.d_part_cond_qp_cond_rhs(d._qp.ptr, self.qp.ptr, self.carg.ptr, self.cws.ptr)
        lib.d_ocp_qp_ipm_solve(self.qp.ptr, self.sol.ptr, self.arg.ptr, self.ws.ptr)
        lib.d_part_cond_qp_expand_sol(d._qp.ptr, self.sol.ptr, d._sol.ptr, self.carg.ptr, self.cws.ptr)
        lib.d_ocp_qp_ipm_get_iter(self.ws.ptr, ctypes.byref(self.it))
        lib.d_ocp_qp_sol_get_all(d._sol.ptr, d.pu, d.px, d.pnull, d.pnull, d.ppi, d.plam_lb, d.plam_ub,
                                 d.plam_lg, d.plam_ug, d.pnull, d.pnull)
        dw = np.empty(d.nw)
        dw[d._ix] = d.x
        dw[d._iu] = d.u
        return self.it.value, dw


def measure(steps: int = STEPS, n2s=N2S) -> pd.DataFrame:
    """One closed loop driven by the default RTI; at each sample every N2 solves the same QP."""
    ctrl = landing_nmpc()
    d = ctrl._direct
    conds = {n2: _Condensed(d, n2) for n2 in n2s}
    cpu = time.thread_time
    iu0 = ctrl.tr.iu[0]
    rows = []
    x = initial_state()
    gc.collect()
    gc.disable()
    try:
        for k in range(steps):
            d0 = x - ctrl._w[ctrl.tr.ix[0]]
            c0 = cpu()
            _, it_ref, dw_ref = d.solve(d0, d0)
            t_ref = cpu() - c0
            rows.append(dict(sample=k, N2="none (direct)", prepare=0.0, feedback=t_ref, iterations=it_ref, dev=0.0,
                             dev_u0=0.0))
            for n2, c in conds.items():
                c0 = cpu()
                c.prepare()
                c1 = cpu()
                it, dw = c.feedback(d0)
                c2 = cpu()
                rows.append(dict(sample=k, N2=str(n2), prepare=c1 - c0, feedback=c2 - c1, iterations=it,
                                 dev=float(np.max(np.abs(dw - dw_ref))),
                                 dev_u0=float(np.max(np.abs(dw[iu0] - dw_ref[iu0])))))
            r = ctrl.feedback(x)
            ctrl.preparation()
            x = np.asarray(ctrl.ocp.F(x, r.u, ctrl.p)).ravel()
    finally:
        gc.enable()
    return pd.DataFrame(rows)


def main() -> pd.DataFrame:
    df = measure()
    g = df.groupby("N2", sort=False)
    table = pd.DataFrame({
        "prepare median [ms]": 1e3 * g["prepare"].median(),
        "feedback median [ms]": 1e3 * g["feedback"].median(),
        "feedback max [ms]": 1e3 * g["feedback"].max(),
        "iterations median": g["iterations"].median(),
        "max |Δw - Δw_direct|": g["dev"].max(),
        "max |Δu_0 - Δu_0,direct|": g["dev_u0"].max(),
    })
    print(f"landing QP, {STEPS} samples, CPU time of the thread (HPIPM speed mode, tolerances 1e-6):")
    print(table.to_string(float_format=lambda v: f"{v:.3g}"))
    return table


if __name__ == "__main__":
    main()
