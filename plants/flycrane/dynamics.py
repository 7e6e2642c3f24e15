"""Lagrangian dynamics of cable-suspended platforms (thesis B.1.2, (4.10)).

Model: a rigid platform (mass ``m_V``, inertia ``I_V`` about its CoM in F_V) and N
robots modelled as point masses ``m_i`` at the cable ends, joined by massless taut
cables (bilateral constraints built into the coordinates ``q``).  With::

    K = ½ m_V |ṗ_V|² + ½ ω_Vᵀ I_V ω_V + Σ ½ m_i |ṗ_i|²,   ω_V = E(θ_V, ψ_V) η̇_V,
    U = g (m_V z_V + Σ m_i z_i),

the Euler–Lagrange equations read

    M(q) q̈ + C(q, q̇) q̇ + g(q) = A_qᵀ F                                    (4.10)

with ``M = ∂²K/∂q̇²``, ``C(q, q̇) q̇ = (∂(M q̇)/∂q) q̇ - ∂K/∂q``, ``g = ∂U/∂q`` and
``F ∈ R^n`` the stacked world-frame forces [N] applied at the robots (thrusts, or the
external forces of the last paragraph of B.1.2); ``A_qᵀ F`` is their generalized force
because ``ṗ = A_q q̇``.  Robot attitude dynamics are not modelled (point masses).

All of it is derived symbolically with CasADi once per system; the ``Function``
objects below are what plants and controllers evaluate.

Cable tensions follow from Newton's law on each robot: ``Σ_c t_c u_c = F_i - m_i g e_3 -
m_i p̈_i`` with ``u_c`` the unit vector from the anchor to the robot; ``t_c > 0`` means the
cable pulls.  A negative tension means the taut-cable model is no longer valid.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..casadi_tools import BufferedFunction
from .rotations import body_rate_matrix

__all__ = ["LagrangianModel"]


class LagrangianModel:
    """Symbolic and numeric dynamics of a spatial :class:`MultiRobotSystem` with masses.

    CasADi Functions (built once):

    * ``M_fun(q) -> M`` (m×m), ``Cqd_fun(q, qd) -> C(q, q̇) q̇`` (m), ``g_fun(q) -> g`` (m)
    * ``energy_fun(q, qd) -> [K, U]`` [J]
    * ``forward_fun(q, qd, F) -> q̈``: (4.10) solved for q̈
    * ``velocity_tracking_fun(q, qd, u, alpha) -> [q̈, F]``: F = -α(A_q q̇ - u) + F_g
      (4.11) with gravity compensation ``F_g = A_q (A_qᵀA_q)^{-1} g(q)`` (the minimum-norm
      robot forces with ``A_qᵀ F_g = g``)
    * ``gravity_compensation_fun(q) -> F_g``
    * ``robot_accel_fun(q, qd, qdd) -> p̈`` (n) and ``tensions_fun(q, qd, qdd, F) -> t``
      (one per cable, in attachment order) with ``tension_residual_fun`` the part of the
      robots' force balance the cables cannot carry (zero for a consistent motion).

    ``system``: a spatial :class:`MultiRobotSystem` with mass properties (``ValueError``
    otherwise).
    """

    def __init__(self, system):
        if system.mass is None or system.pivot != "spatial":
            raise ValueError(f"{system.name} has no mechanical model")
        self.system = sys = system
        mp = sys.mass
        m, n = sys.m, sys.n
        q = sys.q_sym
        self.qd_sym = qd = ca.SX.sym("qd", m)
        pc = list(sys.pivot_cols)
        qV, qdV = q[pc], qd[pc]
        A = sys.A_expr
        I_V = ca.DM(np.asarray(mp.platform_inertia))
        omega = body_rate_matrix(qV[4], qV[5]) @ qdV[3:6]
        pdot = A @ qd
        K = 0.5 * mp.platform_mass * ca.sumsqr(qdV[0:3]) + 0.5 * ca.dot(omega, I_V @ omega)
        U = mp.g * mp.platform_mass * qV[2]
        p = sys.h_expr
        for i, r in enumerate(sys.rows):
            K = K + 0.5 * mp.robot_masses[i] * ca.sumsqr(pdot[list(r)])
            U = U + mp.g * mp.robot_masses[i] * p[r[2]]
        self.K_expr, self.U_expr = K, U
        M = ca.hessian(K, qd)[0]
        self.M_expr = M
        self.Cqd_expr = ca.jacobian(M @ qd, q) @ qd - ca.gradient(K, q)
        self.g_expr = ca.gradient(U, q)
        self.M_fun = ca.Function(f"{sys.name}_M", [q], [M], ["q"], ["M"])
        self.Cqd_fun = ca.Function(f"{sys.name}_Cqd", [q, qd], [self.Cqd_expr], ["q", "qd"], ["Cqd"])
        self.g_fun = ca.Function(f"{sys.name}_g", [q], [self.g_expr], ["q"], ["g"])
        self.energy_fun = ca.Function(f"{sys.name}_energy", [q, qd], [K, U], ["q", "qd"], ["K", "U"])

        # robot accelerations and cable tensions (SX, small per-robot solves)
        qdd = ca.SX.sym("qdd", m)
        F = ca.SX.sym("F", n)
        pdd = A @ qdd + ca.jacobian(pdot, q) @ qd
        e3 = ca.DM([0.0, 0.0, 1.0])
        ts, res = [], []
        qV_p, R = sys.p_V_expr, sys.R_expr
        for i, (att, r) in enumerate(zip(sys.attachments, sys.rows)):
            ri = list(r)
            mi = mp.robot_masses[i]
            need = F[ri] - mi * mp.g * e3 - mi * pdd[ri]
            Ucols = []
            for anchor in att.anchors:
                d = p[ri] - (qV_p + R @ ca.DM(anchor))
                Ucols.append(d / ca.norm_2(d))
            Ui = ca.horzcat(*Ucols)
            t = ca.solve(Ui.T @ Ui, Ui.T @ need)
            ts.append(t)
            res.append(need - Ui @ t)
        self.n_cables = sum(len(a.anchors) for a in sys.attachments)
        self.robot_accel_fun = ca.Function(f"{sys.name}_pdd", [q, qd, qdd], [pdd], ["q", "qd", "qdd"], ["pdd"])
        self.tensions_fun = ca.Function(f"{sys.name}_tensions", [q, qd, qdd, F], [ca.vertcat(*ts)],
                                        ["q", "qd", "qdd", "F"], ["t"])
        self.tension_residual_fun = ca.Function(f"{sys.name}_tension_residual", [q, qd, qdd, F],
                                                [ca.vertcat(*res)], ["q", "qd", "qdd", "F"], ["r"])

        # forward dynamics (MX graph around the SX Functions; numeric linear solves)
        qm, qdm = ca.MX.sym("q", m), ca.MX.sym("qd", m)
        Fm, um, am = ca.MX.sym("F", n), ca.MX.sym("u", n), ca.MX.sym("alpha")
        Mm, cm, gm, Am = self.M_fun(qm), self.Cqd_fun(qm, qdm), self.g_fun(qm), sys.A_fun(qm)
        qdd_f = ca.solve(Mm, Am.T @ Fm - cm - gm)
        self.forward_fun = ca.Function(f"{sys.name}_forward", [qm, qdm, Fm], [qdd_f], ["q", "qd", "F"], ["qdd"])
        Fg = Am @ ca.solve(Am.T @ Am, gm)
        self.gravity_compensation_fun = ca.Function(f"{sys.name}_Fg", [qm], [Fg], ["q"], ["F_g"])
        Fv = -am * (Am @ qdm - um) + Fg
        qdd_v = ca.solve(Mm, Am.T @ Fv - cm - gm)
        self.velocity_tracking_fun = ca.Function(f"{sys.name}_velocity_tracking", [qm, qdm, um, am],
                                                 [qdd_v, Fv], ["q", "qd", "u", "alpha"], ["qdd", "F"])

        # numeric evaluators (CasADi buffer interface, no per-call conversions)
        self.M_eval = BufferedFunction(self.M_fun)
        self.Cqd_eval = BufferedFunction(self.Cqd_fun)
        self.g_eval = BufferedFunction(self.g_fun)
        self.energy_eval = BufferedFunction(self.energy_fun)
        self.forward_eval = BufferedFunction(self.forward_fun)
        self.velocity_tracking_eval = BufferedFunction(self.velocity_tracking_fun)
        self.gravity_compensation_eval = BufferedFunction(self.gravity_compensation_fun)
        self.tensions_eval = BufferedFunction(self.tensions_fun)
        self.tension_residual_eval = BufferedFunction(self.tension_residual_fun)

    # numpy conveniences -----------------------------------------------------------
    def mass_matrix(self, q) -> np.ndarray:
        """M(q) (m×m) [kg, kg·m, kg·m²]."""
        return self.M_eval(self.system._q(q))[0]

    def coriolis(self, q, qd) -> np.ndarray:
        """``C(q, q̇) q̇`` (m,) at the configuration *q* (m,) [rad/m] and velocity *qd* (q̇, m,)."""
        return self.Cqd_eval(self.system._q(q), qd)[0]

    def gravity(self, q) -> np.ndarray:
        """g(q) = ∂U/∂q (m,)."""
        return self.g_eval(self.system._q(q))[0]

    def gravity_compensation(self, q) -> np.ndarray:
        """Minimum-norm robot forces F_g (n,) [N] with A_qᵀ F_g = g(q)."""
        return self.gravity_compensation_eval(self.system._q(q))[0]

    def energy(self, q, qd) -> tuple[float, float]:
        """(kinetic, potential) energy [J] at the configuration *q* (m,) [rad/m] and velocity *qd* (q̇, m,)."""
        K, U = self.energy_eval(self.system._q(q), qd)
        return float(K[0]), float(U[0])

    def accelerations(self, q, qd, F) -> np.ndarray:
        """q̈ of (4.10) for robot forces F (n,) [N] at the configuration *q* (m,) [rad/m] and velocity *qd* (q̇, m,)."""
        return self.forward_eval(self.system._q(q), qd, F)[0]

    def tensions(self, q, qd, qdd, F) -> np.ndarray:
        """Cable tensions [N] (positive = taut), one per cable in attachment order, for the
        motion *q*, *qd*, *qdd* (configuration, its first and second derivatives) under the
        robot forces *F* (n,) [N]."""
        return self.tensions_eval(self.system._q(q), qd, qdd, F)[0]

    def tension_residual(self, q, qd, qdd, F) -> np.ndarray:
        """Force on each robot the cables cannot carry (3 per robot) [N]; ~0 when consistent:
        for the motion *q*, *qd*, *qdd* (configuration, its first and second derivatives)
        under the robot forces *F* (n,) [N]."""
        return self.tension_residual_eval(self.system._q(q), qd, qdd, F)[0]
