"""The QP solvers the RTI can use: their names, this package's default options for each,
and the naming of their bare status numbers."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .ocp import OCP
    from .transcription import _Transcription

__all__ = ["QP_SOLVERS"]

#: QP solvers the RTI can use (those this CasADi build provides are checked at use).
QP_SOLVERS = ("hpipm", "qpoases", "osqp", "daqp", "proxqp", "qrqp", "highs")

#: The solvers that report a bare number as their return status, with the names their
#: headers give the numbers (HPIPM ``hpipm_common.h``, ``enum hpipm_status``; DAQP
#: ``constants.h``, ``EXIT_*``).  The others report text already.
_STATUS_CODES = {
    "hpipm": {0: "success", 1: "maximum iterations reached", 2: "minimum step length reached",
              3: "NaN in the solution", 4: "inconsistent equality constraints"},
    "daqp": {2: "soft optimal", 1: "optimal", -1: "infeasible", -2: "cycling", -3: "unbounded",
             -4: "iteration limit reached", -5: "nonconvex", -6: "overdetermined initial active set"},
}


def _status_text(solver: str, status) -> str:
    """A QP solver's return status as text: the name of a bare status number (kept in
    brackets, e.g. ``"minimum step length reached (hpipm status 2)"``), other text as it is."""
    text = str(status)
    try:
        code = int(text)
    except ValueError:
        return text
    name = _STATUS_CODES.get(solver, {}).get(code)
    return f"{name} ({solver} status {code})" if name else f"{solver} status {code} (no name known)"


_DEFAULT_QP_OPTIONS: dict[str, dict[str, Any]] = {
    "hpipm": {"inf": 1e6, "hpipm": {"mode": "speed", "iter_max": 100, "res_g_max": 1e-6, "res_b_max": 1e-6,
                                     "res_d_max": 1e-6, "res_m_max": 1e-6}},
    "qpoases": {"printLevel": "none", "sparse": False, "hessian_type": "semidef"},
    "osqp": {"osqp": {"verbose": False, "eps_abs": 1e-7, "eps_rel": 1e-7, "max_iter": 100000,
                      "polish": True}, "warm_start_primal": True},
    "daqp": {},
    "proxqp": {"proxqp": {"eps_abs": 1e-9}},
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False},
    "highs": {"highs": {"output_flag": False}},
}


def _qp_options(qp_solver: str, ocp: OCP, tr: _Transcription, qp_options: dict | None) -> dict:
    """This module's defaults for *qp_solver* (with HPIPM's stage dimensions), the
    user's *qp_options* merged over them (one level deep for nested dicts)."""
    qopts = dict(_DEFAULT_QP_OPTIONS.get(qp_solver, {}))
    if qp_solver == "hpipm":
        qopts.update({"N": ocp.N, "nx": [ocp.nx] * (ocp.N + 1), "nu": list(tr.nu_stage) + [0],
                      "ng": list(tr.ng_stage)})
    for k, v in (qp_options or {}).items():
        if isinstance(v, dict) and isinstance(qopts.get(k), dict):
            qopts[k] = {**qopts[k], **v}
        else:
            qopts[k] = v
    qopts.setdefault("error_on_fail", False)
    return qopts
