"""A cable that breaks during the manoeuvre: the post-break model and its statics (§6.3).

Before the break, robot *i* hangs on two cables (:class:`TwoCable`, one angle).  When
one of them breaks at ``t_b`` the robot keeps the other one: it becomes a
:class:`OneCable` robot (two angles) on the remaining anchor, and the system gains one
coordinate (``m -> m + 1``, n unchanged).  The broken cable carries nothing from then
on; the remaining cables are modelled taut (bilateral) and their tensions are watched:
a tension that would have to become negative means that cable goes slack, which the
taut model cannot represent -- a failure mode reported, not simulated further.

* :func:`system_after_break` -- the post-break :class:`MultiRobotSystem` (same masses);
* :func:`state_after_break` -- the hybrid reset: ``(q, q_dot)`` in the new chart with
  every robot's position and velocity and the platform's pose and rates continuous;
  :func:`configuration_after_break` the same for a configuration alone (a reference);
* :class:`PostBreakDynamics` -- (4.10) of the new system under the velocity-tracking
  force (4.11) with least-squares gravity compensation, the cable tensions, and the
  best tensions the robots can reach by internal forces (:meth:`~PostBreakDynamics.best_min_tension`);
* :func:`platform_wrench_matrix`, :func:`static_balance` -- the statics of the platform:
  can the remaining cables hold it at rest in a given configuration, all taut?

Statics (robots hovering, platform at rest).  Cable c pulls the platform at its anchor
``r_c = R a_c`` (from the CoM) along the unit vector ``u_c`` towards its robot, with
tension ``t_c``.  Equilibrium of the platform: ``W t = w_g``,
``W = [u_c ; r_c x u_c]`` (6 x k), ``w_g = (0, 0, m_V g, 0, 0, 0)``.  The robots are
force-controlled point masses: they can supply any force, so this is the whole
condition.  :func:`static_balance` solves the linear programme ``max s`` subject to
``W t = w_g``, ``t >= s``: a positive optimum means all remaining cables can stay taut,
zero means one of them must go slack, infeasible means no cable tensions hold the
platform in that configuration at all.  See docs/models.md for the analytic cases
(3 robots: no level equilibrium after a break; 4 robots, square: the opposite robot's
cable at the diagonally opposite vertex is forced to zero tension).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from .attachments import OneCable, TwoCable
from .kinematics import MultiRobotSystem, SingularConfigurationError

__all__ = ["CableBreak", "cables", "cable_labels", "system_after_break", "configuration_after_break",
           "state_after_break", "platform_rotation", "platform_wrench_matrix", "static_balance", "StaticBalance",
           "PostBreakDynamics"]


@dataclass(frozen=True)
class CableBreak:
    """Cable ``cable`` (0: anchor ``a``, 1: anchor ``b``) of robot ``robot`` (0-based)
    breaks at time ``time`` [s]."""

    robot: int
    cable: int
    time: float

    def __post_init__(self):
        if int(self.robot) != self.robot or self.robot < 0:
            raise ValueError(f"robot must be a robot index >= 0, got {self.robot!r}")
        if self.cable not in (0, 1):
            raise ValueError(f"cable must be 0 (anchor a) or 1 (anchor b) of a two-cable robot, got {self.cable!r}")
        if not np.isfinite(self.time) or self.time < 0:
            raise ValueError(f"break time must be a finite time >= 0 in seconds, got {self.time!r}")

    @property
    def label(self) -> str:
        """Short name of the cable, ``r<robot>a`` or ``r<robot>b`` (robots numbered from 1)."""
        return f"r{self.robot + 1}{'ab'[self.cable]}"


def cables(system: MultiRobotSystem) -> list[tuple[int, int]]:
    """``(robot, cable)`` of every cable of *system*, in attachment order (the order of the tensions)."""
    return [(i, c) for i, a in enumerate(system.attachments) for c in range(len(a.anchors))]


def cable_labels(system: MultiRobotSystem) -> list[str]:
    """Labels ``r<robot><a|b>`` (1-based robot, anchor a or b of its original two-cable
    attachment) of the cables of *system* in attachment order; after a break the broken
    robot's remaining cable keeps its original letter."""
    lost = dict(getattr(system, "breaks", ()))
    out = []
    for i, c in cables(system):
        if i in lost:
            c = 1 - lost[i]
        out.append(f"r{i + 1}{'ab'[c]}")
    return out


def _check_break(system, robot, cable):
    if not isinstance(system, MultiRobotSystem) or system.pivot != "spatial":
        raise TypeError(f"a cable break needs a spatial cable system, got {system!r}")
    if not 0 <= robot < system.N:
        raise ValueError(f"robot {robot} out of range for {system.name} with {system.N} robots")
    if not isinstance(system.attachments[robot], TwoCable):
        raise ValueError(f"robot {robot} of {system.name} is not on two cables: breaking its only cable "
                         "detaches it (not modelled)")
    if cable not in (0, 1):
        raise ValueError(f"cable must be 0 (anchor a) or 1 (anchor b), got {cable!r}")


def system_after_break(system: MultiRobotSystem, robot: int, cable: int) -> MultiRobotSystem:
    """The system once cable *cable* of *robot* is gone: that robot on a
    :class:`OneCable` of the remaining length from the remaining anchor (its angle
    chart measured from the horizontal direction of that anchor), everything else and
    the masses unchanged.  ``n`` stays, ``m`` grows by one."""
    _check_break(system, robot, cable)
    att = system.attachments[robot]
    keep = 1 - cable
    one = OneCable(tuple(att.anchors[keep]), att.lengths[keep])
    atts = list(system.attachments)
    atts[robot] = one
    new = MultiRobotSystem(atts, mass=system.mass, name=f"{system.name}_broken_r{robot + 1}{'ab'[cable]}",
                           singular_tol=system.singular_tol)
    new.broken = (robot, cable)
    #: every cable lost so far, (robot, cable of its original two), in order
    new.breaks = tuple(getattr(system, "breaks", ())) + ((robot, cable),)
    if hasattr(system, "platform_vertices"):
        new.platform_vertices = system.platform_vertices
    return new


def _split(system, q):
    return [q[list(c)] for c in system.cols], q[list(system.pivot_cols)]


def _one_cable_angles(att: OneCable, local) -> np.ndarray:
    d = (np.asarray(local, dtype=float) - np.asarray(att.a)) / att.l
    q2 = float(np.arcsin(np.clip(d @ att._e_side, -1.0, 1.0)))
    q1 = float(np.arctan2(d @ att._e_up, d @ att._e_out))
    return np.array([q1, q2])


def configuration_after_break(before: MultiRobotSystem, after: MultiRobotSystem, q) -> np.ndarray:
    """*q* of *before* in the chart of *after* (same robot positions and platform pose)."""
    robot = after.broken[0]
    q = before._q(q)
    parts, qV = _split(before, q)
    p = before.h(q)
    R = np.asarray(platform_rotation(before, q))
    local = R.T @ (p[list(before.rows[robot])] - qV[:3])
    parts[robot] = _one_cable_angles(after.attachments[robot], local)
    return np.concatenate(parts + [qV])


def platform_rotation(system: MultiRobotSystem, q) -> np.ndarray:
    """The platform's rotation matrix ``R_V^O`` (B.1) of *system* at configuration *q* (3 x 3)."""
    import casadi as ca
    if not hasattr(system, "_R_fun"):
        system._R_fun = ca.Function(f"{system.name}_R", [system.q_sym], [system.R_expr])
    return np.array(system._R_fun(q))


def state_after_break(before: MultiRobotSystem, after: MultiRobotSystem, x) -> np.ndarray:
    """The hybrid reset: state ``(q, q_dot)`` of *before* mapped to *after*.

    Positions and velocities of all robots and the platform pose and its rates are
    continuous across the break; the broken robot's two new angle rates solve its own
    rows ``p_dot_i = A_i q_dot_i + A_iV q_dot_V`` (exact: the motion before the break
    is a motion the post-break system can make).  *x*: the state ``(q, q_dot)`` of *before*."""
    x = np.asarray(x, dtype=float)
    m0 = before.m
    q, qd = x[:m0], x[m0:]
    robot = after.broken[0]
    q1 = configuration_after_break(before, after, q)
    pdot = before.jacobian(q) @ qd
    parts_d, qdV = _split(before, qd)
    A1 = after.jacobian(q1)
    rows, cols, pc = list(after.rows[robot]), list(after.cols[robot]), list(after.pivot_cols)
    rhs = pdot[rows] - A1[np.ix_(rows, pc)] @ qdV
    parts_d[robot] = np.linalg.lstsq(A1[np.ix_(rows, cols)], rhs, rcond=None)[0]
    return np.concatenate([q1, np.concatenate(parts_d + [qdV])])


def platform_wrench_matrix(system: MultiRobotSystem, q) -> np.ndarray:
    """``W`` (6 x k): column c is the wrench ``[u_c; r_c x u_c]`` (per newton of tension)
    that cable c applies to the platform about its CoM, world frame (k cables of *system*
    in attachment order), at configuration *q*."""
    q = system._q(q)
    p = system.h(q)
    qV = q[list(system.pivot_cols)]
    R = platform_rotation(system, q)
    cols = []
    for att, r in zip(system.attachments, system.rows):
        for anchor in att.anchors:
            ra = R @ anchor
            d = p[list(r)] - (qV[:3] + ra)
            u = d / np.linalg.norm(d)
            cols.append(np.concatenate([u, np.cross(ra, u)]))
    return np.array(cols).T


@dataclass(frozen=True)
class StaticBalance:
    """Result of :func:`static_balance`.

    ``feasible``: some tensions (of any sign) hold the platform (``W t = w_g`` solvable);
    ``margin`` [N]: the largest achievable smallest tension (``-inf`` if not feasible);
    ``tensions`` [N]: a maximiser (least squares if not feasible); ``residual`` [N, N m]:
    ``|W t - w_g|`` of the least-squares tensions (0 when feasible).
    ``holds`` = feasible and margin > ``tol``; ``forced_slack``: when the margin is
    not positive, the indices of the cables whose tension no equilibrium with
    non-negative tensions can make positive (they must go slack).
    """

    feasible: bool
    margin: float
    tensions: np.ndarray
    residual: float
    tol: float = 1e-9
    forced_slack: tuple = ()

    @property
    def holds(self) -> bool:
        """True when the cables hold the platform with every tension above ``tol`` [N]."""
        return bool(self.feasible and self.margin > self.tol)


def static_balance(system: MultiRobotSystem, q, *, tol: float = 1e-9) -> StaticBalance:
    """Can the cables of *system* hold the platform at rest in configuration *q*?  The linear
    programme ``max s`` s.t. ``W t = w_g``, ``t_c >= s`` (module docstring); *tol*
    [N, N m] decides feasibility of ``W t = w_g`` and positivity of the margin."""
    W = platform_wrench_matrix(system, q)
    k = W.shape[1]
    w = np.array([0.0, 0.0, system.mass.platform_mass * system.mass.g, 0.0, 0.0, 0.0])
    t_ls = np.linalg.lstsq(W, w, rcond=None)[0]
    res = float(np.linalg.norm(W @ t_ls - w))
    if res > tol * max(1.0, float(np.linalg.norm(w))):
        return StaticBalance(False, -np.inf, t_ls, res, tol)
    cap = 10.0 * float(np.linalg.norm(w))  # the margin is bounded: sum of u_c,z t_c = m_V g
    c = np.zeros(k + 1)
    c[-1] = -1.0
    A_eq = np.hstack([W, np.zeros((6, 1))])
    r = linprog(c, A_ub=np.hstack([-np.eye(k), np.ones((k, 1))]), b_ub=np.zeros(k),
                A_eq=A_eq, b_eq=w, bounds=[(None, None)] * k + [(None, cap)], method="highs")
    if r.status != 0:
        return StaticBalance(False, -np.inf, t_ls, res, tol)
    margin = float(-r.fun)
    # a representative maximiser: the largest total tension with every t_c >= margin
    r2 = linprog(-np.ones(k), A_eq=W, b_eq=w, bounds=[(margin - 1e-12, cap)] * k, method="highs")
    t = r2.x if r2.status == 0 else r.x[:k]
    forced = ()
    if margin <= tol:
        # cables that no equilibrium with non-negative tensions can tighten
        forced = tuple(j for j in range(k)
                       if (rj := linprog(-np.eye(k)[j], A_eq=W, b_eq=w, bounds=[(0.0, cap)] * k,
                                         method="highs")).status == 0 and -rj.fun <= tol)
    return StaticBalance(True, margin, t, 0.0, tol, forced)


class PostBreakDynamics:
    """(4.10) of a (post-break) system under ``F = -alpha (A_q q_dot - u) + F_g(q)``
    (4.11), with ``F_g`` the least-squares gravity compensation
    ``argmin |F| among argmin |A_q^T F - g(q)|`` (``= A_q (A_q^T A_q)^{-1} g`` when
    ``m <= n``, as :class:`~netcosim.plants.flycrane.input_modes.VelocityTrackingPlant`;
    when ``n < m`` the robots cannot balance gravity along the directions in which the
    platform moves with the robots still, and the platform swings freely there).

    State ``x = (q, q_dot)``; ``u`` the robot velocities (n, m/s); ``alpha`` [N s/m].
    """

    def __init__(self, system: MultiRobotSystem, alpha: float):
        if not np.isfinite(alpha) or alpha <= 0:
            raise ValueError(f"velocity-tracking gain alpha must be a positive number (N s/m), got {alpha!r}")
        self.system, self.alpha = system, float(alpha)
        self.model = system.dynamics
        mp = system.mass
        #: bound on each internal-force coordinate [N]: the whole system's weight
        self.internal_force_bound = (mp.platform_mass + sum(mp.robot_masses)) * mp.g

    def _parts(self, x, u):
        m = self.system.m
        q, qd = x[:m], x[m:]
        A = self.system.jacobian(q)
        M = self.model.M_eval(q)[0]
        c = self.model.Cqd_eval(q, qd)[0]
        g = self.model.g_eval(q)[0]
        Fg = np.linalg.lstsq(A.T, g, rcond=None)[0]
        F = -self.alpha * (A @ qd - np.asarray(u, dtype=float)) + Fg
        qdd = np.linalg.solve(M, A.T @ F - c - g)
        if not np.all(np.isfinite(qdd)):
            raise SingularConfigurationError(f"{self.system.name}: dynamics not defined at q = "
                                             f"{np.round(q, 12).tolist()}")
        return q, qd, qdd, F, A

    def f(self, t, x, u):
        """``x_dot = (q_dot, q_ddot)`` at the state *x* ``(q, q_dot)`` under the robot velocities
        *u* (n, m/s) (time-invariant: *t* [s] is not read)."""
        q, qd, qdd, _, _ = self._parts(x, u)
        return np.concatenate([qd, qdd])

    def tensions(self, x, u) -> np.ndarray:
        """Cable tensions [N] (positive = taut), one per remaining cable, under the
        minimum-norm force allocation above, at the state *x* ``(q, q_dot)`` under the robot velocities *u* (n, m/s)."""
        q, qd, qdd, F, _ = self._parts(x, u)
        return self.model.tensions_eval(q, qd, qdd, F)[0]

    def _internal(self, x, u):
        q, qd, qdd, F, A = self._parts(x, u)
        t0 = self.model.tensions_eval(q, qd, qdd, F)[0]
        s = np.linalg.svd(A.T)
        rank = int((s[1] > s[1][0] * 1e-10).sum())
        Nsp = s[2][rank:].T
        Tm = np.column_stack([self.model.tensions_eval(q, qd, qdd, F + Nsp[:, j])[0] - t0
                              for j in range(Nsp.shape[1])]) if Nsp.shape[1] else np.zeros((t0.size, 0))
        return t0, Tm

    def best_min_tension(self, x, u) -> tuple[float, np.ndarray]:
        """The largest smallest tension [N] the robots can reach at state *x* by adding
        internal forces ``F_0 = N lambda`` with ``A_q^T F_0 = 0`` (they change no
        motion, only how the load is shared; ``|lambda_j| <=``
        :attr:`internal_force_bound`), and those tensions (among the best allocations,
        the one with the largest total tension).  Equals the smallest minimum-norm
        tension when ``A_q^T`` has no null space (``n <= m``).  *u*: the robot velocities
        (n, m/s) of the velocity-tracking law."""
        t0, Tm = self._internal(x, u)
        r = Tm.shape[1]
        if r == 0:
            return float(t0.min()), t0
        lam = self.internal_force_bound
        c = np.zeros(r + 1)
        c[-1] = -1.0
        res = linprog(c, A_ub=np.hstack([-Tm, np.ones((t0.size, 1))]), b_ub=t0,
                      bounds=[(-lam, lam)] * r + [(None, None)], method="highs")
        if res.status != 0:
            return float(t0.min()), t0
        best = float(-res.fun)
        res2 = linprog(-Tm.sum(axis=0), A_ub=-Tm, b_ub=t0 - (best - 1e-12), bounds=[(-lam, lam)] * r,
                       method="highs")
        t = t0 + Tm @ (res2.x if res2.status == 0 else res.x[:r])
        return best, t

    def bottleneck(self, x, u, tol: float = 1e-9) -> tuple[int, ...]:
        """Indices of the cables that stay at the smallest tension in *every* best
        allocation of :meth:`best_min_tension` (the ones that go slack first), at the state
        *x* ``(q, q_dot)`` under the robot velocities *u* (n, m/s); a tension within *tol* [N]
        of the best counts as the smallest."""
        best, _ = self.best_min_tension(x, u)
        t0, Tm = self._internal(x, u)
        r = Tm.shape[1]
        if r == 0:
            return tuple(int(j) for j in np.flatnonzero(t0 <= best + tol))
        lam = self.internal_force_bound
        out = []
        for j in range(t0.size):
            res = linprog(-Tm[j], A_ub=-Tm, b_ub=t0 - (best - 1e-12), bounds=[(-lam, lam)] * r, method="highs")
            if res.status == 0 and t0[j] - res.fun <= best + tol:
                out.append(j)
        return tuple(out)
