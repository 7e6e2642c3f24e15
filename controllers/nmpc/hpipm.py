"""HPIPM called directly (``ctypes``), with the QP data set in the preparation phase.

CasADi's ``conic`` plugin ``"hpipm"`` does everything in one call: it splits the sparse
``H``, ``A``, bounds and gradient into HPIPM's stage blocks, allocates HPIPM's
dimension, QP, solution and workspace structures, solves, and frees them.  In a real-time
iteration only the bounds of the first state increment depend on the measurement, so
everything else can be done before it arrives.  :class:`DirectHPIPM` calls the HPIPM
library shipped inside the CasADi wheel (``libhpipm.so``, with its ``libblasfeo.so``):

* once (constructor): dimensions, QP, solution, options and workspace structures;
* :meth:`DirectHPIPM.set_qp` (preparation phase): the stage blocks of the prepared QP,
  packed into HPIPM's panel-major storage by ``d_ocp_qp_set_all``;
* :meth:`DirectHPIPM.solve` (feedback phase): the bounds of ``Δx_0`` and the interior-point
  solve itself, then the solution read back in one call.

The data HPIPM receives are those the CasADi plugin builds (the same blocks, the
``1/2`` factor of HPIPM's cost on ``H`` and ``g``, the sign of the gap rows, infinite
bounds replaced by ``±inf``), and the solver is the same library with the same options,
so the step is the plugin's bit for bit (``tests/test_nmpc_hpipm.py`` compares every
QP of a closed-loop landing).  Only a subset of the plugin's options is understood
(:data:`DIRECT_OPTIONS`); :func:`direct_hpipm_supported` says whether a set of options
can use this path, the RTI uses the plugin otherwise.

The interior-point iteration itself cannot move to the preparation phase: every
iteration factorises a KKT matrix whose barrier terms depend on the iterate, hence on
the measurement (docs/nmpc.md, "Where the time goes").

Units: whatever the QP's are; the QP is that of :mod:`~netcosim.controllers.nmpc.rti`
(variables in stage-wise order ``[x_0, u_0, x_1, u_1, ..., x_N]``).
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import casadi as ca
import numpy as np

__all__ = ["DirectHPIPM", "direct_hpipm_supported", "DIRECT_OPTIONS"]

#: HPIPM's ``enum hpipm_mode``.
_MODES = {"speed_abs": 0, "speed": 1, "balance": 2, "robust": 3}
#: The options of CasADi's plugin the direct path understands: the plugin's ``inf`` and
#: ``error_on_fail`` (False only), the stage sizes, and these entries of its ``hpipm`` dict
#: (each set with HPIPM's own setter, as the plugin sets the field).
_DOUBLE_SETTERS = {"mu0": "mu0", "alpha_min": "alpha_min", "res_g_max": "tol_stat", "res_b_max": "tol_eq",
                   "res_d_max": "tol_ineq", "res_m_max": "tol_comp", "reg_prim": "reg_prim",
                   "lam_min": "lam_min", "t_min": "t_min"}
_INT_SETTERS = {"iter_max": "iter_max"}
DIRECT_OPTIONS = ("N", "nx", "nu", "ng", "inf", "error_on_fail", "hpipm")

_lib_cache: dict[str, ctypes.CDLL | None] = {}


def _library() -> ctypes.CDLL | None:
    """CasADi's ``libhpipm.so`` (None when this CasADi build does not ship it)."""
    if "hpipm" not in _lib_cache:
        path = Path(ca.__file__).parent / "libhpipm.so"
        lib: ctypes.CDLL | None
        try:
            # PyDLL: the calls keep the GIL, as CasADi's own (SWIG) calls do.  Releasing it
            # for each of the ~10 short calls per sample lets another busy Python thread
            # (a HIL transport's, say) take it for up to sys.getswitchinterval() each time.
            lib = ctypes.PyDLL(str(path))
            for name in ("d_ocp_qp_dim_strsize", "d_ocp_qp_dim_memsize", "d_ocp_qp_strsize", "d_ocp_qp_memsize",
                         "d_ocp_qp_sol_strsize", "d_ocp_qp_sol_memsize", "d_ocp_qp_ipm_arg_strsize",
                         "d_ocp_qp_ipm_arg_memsize", "d_ocp_qp_ipm_ws_strsize", "d_ocp_qp_ipm_ws_memsize"):
                getattr(lib, name).restype = ctypes.c_size_t
            lib.d_ocp_qp_dim_memsize.argtypes = [ctypes.c_int]
            for name in ("d_ocp_qp_set_all", "d_ocp_qp_set_lbx", "d_ocp_qp_set_ubx", "d_ocp_qp_ipm_solve",
                         "d_ocp_qp_sol_get_all", "d_ocp_qp_ipm_get_status", "d_ocp_qp_ipm_get_iter"):
                getattr(lib, name)
        except (OSError, AttributeError):   # no library, or one without the functions used here
            lib = None
        _lib_cache["hpipm"] = lib
    return _lib_cache["hpipm"]


def direct_hpipm_supported(qp_options: dict) -> bool:
    """Whether *qp_options* (the full options of CasADi's ``hpipm`` plugin, as
    :func:`~netcosim.controllers.nmpc.qp._qp_options` builds them) can be honoured by
    :class:`DirectHPIPM`, and whether the library is there."""
    if set(qp_options) - set(DIRECT_OPTIONS) or qp_options.get("error_on_fail", False):
        return False
    h = qp_options.get("hpipm", {})
    if not isinstance(h, dict) or set(h) - {"mode", *_DOUBLE_SETTERS, *_INT_SETTERS}:
        return False
    if "mode" in h and h["mode"] not in _MODES:
        return False
    return _library() is not None


class _Mem:
    """A block of zeroed bytes, its address aligned to 64 bytes (HPIPM aligns again)."""

    def __init__(self, size: int):
        self._buf = np.zeros(int(size) + 128, dtype=np.uint8)
        addr = self._buf.ctypes.data
        self.ptr = ctypes.c_void_p((addr + 63) // 64 * 64)


def _ptrs(arrays) -> ctypes.Array:
    """A C array ``double*[]`` pointing at each array's data (arrays kept alive by the caller)."""
    out = (ctypes.c_void_p * len(arrays))()
    for i, a in enumerate(arrays):
        out[i] = a.ctypes.data if a is not None else None
    return out


class DirectHPIPM:
    """HPIPM's OCP-QP interior-point solver with persistent structures.

    Parameters
    ----------
    H_sparsity, A_sparsity:
        Sparsity of the QP's Hessian (nw × nw) and constraint matrix (ng × nw), in the
        stage-wise order CasADi's plugin expects: per stage ``[x_k, u_k]`` columns, per
        stage the gap rows ``x_{k+1} = A x_k + B u_k + b`` (with ``-I`` on ``x_{k+1}``)
        then the stage's general rows.
    qp_options:
        The options of CasADi's plugin: ``N``, ``nx``, ``nu``, ``ng`` (lists of stage
        sizes), ``inf`` (default 1e8) and ``hpipm`` (``mode`` and the entries of
        :data:`DIRECT_OPTIONS`).

    Raises
    ------
    ValueError
        If the options are not supported (see :func:`direct_hpipm_supported`) or the
        sparsities do not fit the stage sizes.
    """

    def __init__(self, H_sparsity: ca.Sparsity, A_sparsity: ca.Sparsity, qp_options: dict):
        if not direct_hpipm_supported(qp_options):
            raise ValueError(f"options {sorted(qp_options)} not supported by the direct HPIPM path")
        lib = _library()
        assert lib is not None                        # direct_hpipm_supported checked it
        self._lib: ctypes.CDLL = lib
        N = int(qp_options["N"])
        nx = [int(v) for v in qp_options["nx"]]
        nu = [int(v) for v in qp_options["nu"]]
        ng = [int(v) for v in qp_options["ng"]]
        if not (len(nx) == len(nu) == len(ng) == N + 1):
            raise ValueError(f"stage sizes must have N+1 = {N + 1} entries, got nx {nx}, nu {nu}, ng {ng}")
        self.N, self.nx, self.nu, self.ng = N, nx, nu, ng
        self.inf = float(qp_options.get("inf", 1e8))
        self.nw = sum(nx) + sum(nu)
        self.na = sum(nx[1:]) + sum(ng)
        if H_sparsity.shape != (self.nw, self.nw) or A_sparsity.shape != (self.na, self.nw):
            raise ValueError(f"H {H_sparsity.shape} / A {A_sparsity.shape} do not fit the stage sizes "
                             f"({self.nw} variables, {self.na} constraints)")
        self._index_maps(H_sparsity, A_sparsity)
        self._buffers()
        self._structures(qp_options.get("hpipm", {}))

    # -- construction ------------------------------------------------------------------------
    def _index_maps(self, Hsp: ca.Sparsity, Asp: ca.Sparsity) -> None:
        """Where each entry of each HPIPM block (column-major) is among the nonzeros of H
        or A (index ``nnz``: a structural zero)."""
        N, nx, nu, ng = self.N, self.nx, self.nu, self.ng

        def nz_map(sp):
            m = np.full(sp.shape, sp.nnz(), dtype=np.int64)
            r, c = sp.get_triplet()
            m[np.asarray(r, dtype=int), np.asarray(c, dtype=int)] = np.arange(sp.nnz())
            return m

        Hm, Am = nz_map(Hsp), nz_map(Asp)

        def block(m, r0, c0, rows, cols):
            return m[r0:r0 + rows, c0:c0 + cols].ravel(order="F")

        iA, iB, iI, iC, iD, ib, ilug = [], [], [], [], [], [], []
        row, col = 0, 0
        for k in range(N):
            iA.append(block(Am, row, col, nx[k + 1], nx[k]))
            iB.append(block(Am, row, col + nx[k], nx[k + 1], nu[k]))
            iC.append(block(Am, row + nx[k + 1], col, ng[k], nx[k]))
            iD.append(block(Am, row + nx[k + 1], col + nx[k], ng[k], nu[k]))
            c_next = col + nx[k] + nu[k]
            iI.append(Am[np.arange(row, row + nx[k + 1]), np.arange(c_next, c_next + nx[k + 1])])
            ib.append(np.arange(row, row + nx[k + 1]))
            ilug.append(np.arange(row + nx[k + 1], row + nx[k + 1] + ng[k]))
            col = c_next
            row += nx[k + 1] + ng[k]
        iC.append(block(Am, row, col, ng[N], nx[N]))
        iD.append(block(Am, row, col + nx[N], ng[N], nu[N]))
        ilug.append(np.arange(row, row + ng[N]))
        iQ, iS, iR, ix, iu = [], [], [], [], []
        off = 0
        for k in range(N + 1):
            iR.append(block(Hm, off + nx[k], off + nx[k], nu[k], nu[k]))
            iS.append(block(Hm, off + nx[k], off, nu[k], nx[k]))
            iQ.append(block(Hm, off, off, nx[k], nx[k]))
            ix.append(np.arange(off, off + nx[k]))
            iu.append(np.arange(off + nx[k], off + nx[k] + nu[k]))
            off += nx[k] + nu[k]
        cat = np.concatenate
        self._iA, self._iB, self._iI = cat(iA), cat(iB), cat(iI)
        self._iC, self._iD = cat(iC), cat(iD)
        self._iQ, self._iS, self._iR = cat(iQ), cat(iS), cat(iR)
        self._ib, self._ilug = cat(ib), cat(ilug)
        self._ix, self._iu = cat(ix), cat(iu)
        self._nnzH, self._nnzA = Hsp.nnz(), Asp.nnz()
        # one gather each for the blocks of H and of A: [Q, S, R] and [A, B, C, D]
        self._iH = cat([self._iQ, self._iS, self._iR])
        self._iAll = cat([self._iA, self._iB, self._iC, self._iD])
        # the gap row (index into the stacked gap rows) of each entry of A_k and B_k (column-major)
        rowA = cat([np.tile(np.arange(nx[k + 1]), nx[k]) + sum(nx[1:k + 1]) for k in range(N)])
        rowB = cat([np.tile(np.arange(nx[k + 1]), nu[k]) + sum(nx[1:k + 1]) for k in range(N)])
        self._rowAB = cat([rowA, rowB]).astype(np.intp)
        self._ixu = cat([self._ix, self._iu])

    def _buffers(self) -> None:
        """The arrays HPIPM reads (set_all) and writes (the solution), and their pointer tables."""
        nx, nu, ng = self.nx, self.nu, self.ng
        z = np.zeros
        self._HB = z(self._iH.size)                   # [Q, S, R] of all stages
        self.Q, self.S, self.R = np.split(self._HB, np.cumsum([self._iQ.size, self._iS.size]))
        self._AB = z(self._iAll.size)                 # [A, B, C, D] of all stages
        nAB = self._iA.size + self._iB.size
        self._AB_gap = self._AB[:nAB]
        self.A, self.B, self.C, self.D = np.split(
            self._AB, np.cumsum([self._iA.size, self._iB.size, self._iC.size]))
        self.b = z(self._ib.size)
        self._qr = z(sum(nx) + sum(nu))               # [q, r] of all stages
        self.q, self.r = self._qr[:sum(nx)], self._qr[sum(nx):]
        self._lb, self._ub = z(sum(nx) + sum(nu)), z(sum(nx) + sum(nu))   # [x bounds, u bounds]
        self.lbx, self.lbu = self._lb[:sum(nx)], self._lb[sum(nx):]
        self.ubx, self.ubu = self._ub[:sum(nx)], self._ub[sum(nx):]
        self.lg, self.ug = z(sum(ng)), z(sum(ng))
        self.x, self.u = z(sum(nx)), z(sum(nu))
        self.pi = z(max(sum(nx[1:]), 1))
        self.lam_lb, self.lam_ub = z(sum(nx) + sum(nu) + 1), z(sum(nx) + sum(nu) + 1)
        self.lam_lg, self.lam_ug = z(sum(ng) + 1), z(sum(ng) + 1)
        self._keep: list = []                          # the stage slices the tables point into
        self._data_tables()
        self._solution_tables()

    def _table(self, buf: np.ndarray, sizes) -> ctypes.Array:
        """A ``double*[]`` pointing at consecutive slices of *buf* of the given *sizes* (a
        one-element dummy for size 0); the slices are kept alive with the object."""
        parts, off = [], 0
        for size in sizes:
            parts.append(buf[off:off + size] if size else np.zeros(1))
            off += size
        self._keep.append(parts)
        return _ptrs(parts)

    def _data_tables(self) -> None:
        """The pointer tables of the QP data (``d_ocp_qp_set_all``'s arguments)."""
        N, nx, nu, ng = self.N, self.nx, self.nu, self.ng
        t, st, all_st = self._table, range(N), range(N + 1)
        self.pA = t(self.A, [nx[k + 1] * nx[k] for k in st])
        self.pB = t(self.B, [nx[k + 1] * nu[k] for k in st])
        self.pb = t(self.b, nx[1:])
        self.pQ = t(self.Q, [n * n for n in nx])
        self.pS = t(self.S, [nu[k] * nx[k] for k in all_st])
        self.pR = t(self.R, [n * n for n in nu])
        self.pq, self.pr = t(self.q, nx), t(self.r, nu)
        self.plbx, self.pubx = t(self.lbx, nx), t(self.ubx, nx)
        self.plbu, self.pubu = t(self.lbu, nu), t(self.ubu, nu)
        self.pC = t(self.C, [ng[k] * nx[k] for k in all_st])
        self.pD = t(self.D, [ng[k] * nu[k] for k in all_st])
        self.plg, self.pug = t(self.lg, ng), t(self.ug, ng)

    def _solution_tables(self) -> None:
        """The pointer tables of the solution (``d_ocp_qp_sol_get_all``), of the box indices
        and the slacks (none), and the bounds of ``Δx_0``."""
        nx, nu, ng = self.nx, self.nu, self.ng
        t = self._table
        self._idxbx = [np.arange(max(n, 1), dtype=np.int32) for n in nx]   # every variable box-bounded
        self._idxbu = [np.arange(max(n, 1), dtype=np.int32) for n in nu]
        self.pidxbx, self.pidxbu = _ptrs(self._idxbx), _ptrs(self._idxbu)
        self.pnull = (ctypes.c_void_p * (self.N + 1))()   # slacks: none (ns = 0)
        self.px, self.pu = t(self.x, nx), t(self.u, nu)
        self.ppi = t(self.pi, nx[1:])
        nb = [a + b for a, b in zip(nx, nu)]
        self.plam_lb, self.plam_ub = t(self.lam_lb, nb), t(self.lam_ub, nb)
        self.plam_lg, self.plam_ug = t(self.lam_lg, ng), t(self.lam_ug, ng)
        self._lbx0 = np.zeros(nx[0])
        self._ubx0 = np.zeros(nx[0])
        self._p_lbx0 = ctypes.c_void_p(self._lbx0.ctypes.data)
        self._p_ubx0 = ctypes.c_void_p(self._ubx0.ctypes.data)

    def _structures(self, hopts: dict) -> None:
        """HPIPM's dimension, QP, solution, option and workspace structures (once)."""
        lib, N = self._lib, self.N
        ci = ctypes.c_int
        self._nx_c = (ci * (N + 1))(*self.nx)
        self._nu_c = (ci * (N + 1))(*self.nu)
        self._ng_c = (ci * (N + 1))(*self.ng)
        self._ns_c = (ci * (N + 1))(*([0] * (N + 1)))
        self._dim = _Mem(lib.d_ocp_qp_dim_strsize())
        self._dim_mem = _Mem(lib.d_ocp_qp_dim_memsize(N))
        lib.d_ocp_qp_dim_create(ci(N), self._dim.ptr, self._dim_mem.ptr)
        lib.d_ocp_qp_dim_set_all(self._nx_c, self._nu_c, self._nx_c, self._nu_c, self._ng_c, self._ns_c,
                                 self._dim.ptr)
        self._qp = _Mem(lib.d_ocp_qp_strsize())
        self._qp_mem = _Mem(lib.d_ocp_qp_memsize(self._dim.ptr))
        lib.d_ocp_qp_create(self._dim.ptr, self._qp.ptr, self._qp_mem.ptr)
        self._sol = _Mem(lib.d_ocp_qp_sol_strsize())
        self._sol_mem = _Mem(lib.d_ocp_qp_sol_memsize(self._dim.ptr))
        lib.d_ocp_qp_sol_create(self._dim.ptr, self._sol.ptr, self._sol_mem.ptr)
        self._arg = _Mem(lib.d_ocp_qp_ipm_arg_strsize())
        self._arg_mem = _Mem(lib.d_ocp_qp_ipm_arg_memsize(self._dim.ptr))
        lib.d_ocp_qp_ipm_arg_create(self._dim.ptr, self._arg.ptr, self._arg_mem.ptr)
        # as CasADi's plugin: defaults of the mode (its own default: robust), then the fields
        lib.d_ocp_qp_ipm_arg_set_default(ci(_MODES[hopts.get("mode", "robust")]), self._arg.ptr)
        for key, value in hopts.items():
            if key in _DOUBLE_SETTERS:
                getattr(lib, f"d_ocp_qp_ipm_arg_set_{_DOUBLE_SETTERS[key]}")(
                    ctypes.byref(ctypes.c_double(float(value))), self._arg.ptr)
            elif key in _INT_SETTERS:
                getattr(lib, f"d_ocp_qp_ipm_arg_set_{_INT_SETTERS[key]}")(ctypes.byref(ci(int(value))), self._arg.ptr)
        self._ws = _Mem(lib.d_ocp_qp_ipm_ws_strsize())
        self._ws_mem = _Mem(lib.d_ocp_qp_ipm_ws_memsize(self._dim.ptr, self._arg.ptr))
        lib.d_ocp_qp_ipm_ws_create(self._dim.ptr, self._arg.ptr, self._ws.ptr, self._ws_mem.ptr)
        self._status = ci(0)
        self._iter = ci(0)
        self._stage0 = ci(0)
        self._f_set_lbx, self._f_set_ubx = lib.d_ocp_qp_set_lbx, lib.d_ocp_qp_set_ubx
        self._f_solve, self._f_get_all = lib.d_ocp_qp_ipm_solve, lib.d_ocp_qp_sol_get_all
        self._f_status, self._f_iter = lib.d_ocp_qp_ipm_get_status, lib.d_ocp_qp_ipm_get_iter
        self._ref_status, self._ref_iter = ctypes.byref(self._status), ctypes.byref(self._iter)

    # -- phases --------------------------------------------------------------------------------
    def set_qp(self, H_nz: np.ndarray, g: np.ndarray, A_nz: np.ndarray, lba: np.ndarray, uba: np.ndarray,
               lbx: np.ndarray, ubx: np.ndarray) -> None:
        """Preparation: hand the QP ``min ½ΔwᵀHΔw + gᵀΔw, lba <= AΔw <= uba, lbx <= Δw <= ubx``
        to HPIPM; *H_nz*, *A_nz*: the nonzeros of H and A (CasADi's column-major order);
        *g*: the dense gradient; *lba*, *uba*, *lbx*, *ubx*: dense bounds (±inf allowed, replaced
        by ``±inf`` of the options); the bounds of ``Δx_0`` in *lbx*/*ubx* are replaced at
        :meth:`solve`.  Units: the QP's."""
        Hx = np.empty(self._nnzH + 1)
        Hx[:-1] = H_nz
        Hx[-1] = 0.0                                   # structural zeros of the blocks
        Ax = np.empty(self._nnzA + 1)
        Ax[:-1] = A_nz
        Ax[-1] = 0.0
        np.take(Hx, self._iH, out=self._HB)
        self._HB *= 0.5                                # HPIPM's cost is ½ΔwᵀHΔw without CasADi's 2
        np.take(g, self._ixu, out=self._qr)
        self._qr *= 0.5
        np.take(Ax, self._iAll, out=self._AB)
        inv_I = -1 / Ax[self._iI]                      # -1/I of the gap rows (1.0 for -I)
        self._AB_gap *= inv_I[self._rowAB]             # gap rows as x_{k+1} = A x_k + B u_k + b
        np.multiply(-1.0 * lba[self._ib], inv_I, out=self.b)
        inf = self.inf
        np.take(lba, self._ilug, out=self.lg)
        np.take(uba, self._ilug, out=self.ug)
        np.maximum(self.lg, -inf, out=self.lg)
        np.minimum(self.ug, inf, out=self.ug)
        np.take(lbx, self._ixu, out=self._lb)
        self._lb += 0.0                                # 0 + v, as the plugin's transfer (-0.0 -> 0.0)
        np.maximum(self._lb, -inf, out=self._lb)
        np.take(ubx, self._ixu, out=self._ub)
        self._ub += 0.0
        np.minimum(self._ub, inf, out=self._ub)
        self._lib.d_ocp_qp_set_all(self.pA, self.pB, self.pb, self.pQ, self.pS, self.pR, self.pq, self.pr,
                                   self.pidxbx, self.plbx, self.pubx, self.pidxbu, self.plbu, self.pubu,
                                   self.pC, self.pD, self.plg, self.pug, self.pnull, self.pnull, self.pnull,
                                   self.pnull, self.pnull, None, self.pnull, self.pnull, self._qp.ptr)

    def solve(self, lbx0: np.ndarray, ubx0: np.ndarray) -> tuple[int, int, np.ndarray]:
        """Feedback: set the bounds *lbx0* <= ``Δx_0`` <= *ubx0* (equal for an RTI: the
        measured state minus the planned one, in the states' units) and solve; returns
        ``(status, iterations, Δw)`` with HPIPM's status number (0: success) and the step in
        the QP's variable order (a fresh array)."""
        inf = self.inf
        lb, ub = self._lbx0, self._ubx0
        lb.fill(0.0)
        lb += lbx0
        np.maximum(lb, -inf, out=lb)
        ub.fill(0.0)
        ub += ubx0
        np.minimum(ub, inf, out=ub)
        qp = self._qp.ptr
        self._f_set_lbx(self._stage0, self._p_lbx0, qp)
        self._f_set_ubx(self._stage0, self._p_ubx0, qp)
        self._f_solve(qp, self._sol.ptr, self._arg.ptr, self._ws.ptr)
        self._f_status(self._ws.ptr, self._ref_status)
        self._f_iter(self._ws.ptr, self._ref_iter)
        self._f_get_all(self._sol.ptr, self.pu, self.px, self.pnull, self.pnull, self.ppi, self.plam_lb,
                        self.plam_ub, self.plam_lg, self.plam_ug, self.pnull, self.pnull)
        dw = np.empty(self.nw)
        dw[self._ix] = self.x + 0.0                      # 0 + v, as the plugin's transfer
        dw[self._iu] = self.u + 0.0
        return self._status.value, self._iter.value, dw
