"""Kinematics of star-shaped multi-robot systems (thesis (3.1)-(3.3), (4.4)-(4.6), B.1.1).

A :class:`MultiRobotSystem` is a pivot (a rigid platform with pose ``q_V``) and N
agents, each attached by a :mod:`~netcosim.plants.flycrane.attachments` element.  Layout:

* ``q = [q_1, …, q_N, q_V]`` (length m): each agent's own coordinates, then the pivot
  pose.  Spatial pivot: ``q_V = (x_V, y_V, z_V, φ_V, θ_V, ψ_V)`` [m, rad] with
  ``R_V^O = R_z(φ_V) R_y(θ_V) R_x(ψ_V)`` (B.1).  Planar pivot: ``q_V = (x_V, y_V, φ_V)``.
* ``p = [p_1, …, p_N]`` (length n): agent positions in the world [m] (plus the
  formation bearings, rad).

``h(q)`` is built once symbolically with CasADi; ``A_q = ∂h/∂q`` is its exact symbolic
Jacobian, so the zero blocks of (3.3) are structural zeros.  ``h_fun`` and ``A_fun``
are the CasADi ``Function`` objects; the numpy methods wrap them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import casadi as ca
import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

from ..casadi_tools import BufferedFunction

# the rank rule is the project's one rule, defined with the kinematic model
from ..kinematic import SINGULAR_RTOL, SingularConfigurationError, check_singular_values, conditioning, pinv_solve
from .attachments import GeometryError, OneCable, PlanarAgent, TwoCable
from .rotations import euler_zyx, rot_2d

__all__ = ["MultiRobotSystem", "MassProperties", "SingularConfigurationError", "ConfigurationDomainError",
           "plate_inertia", "SINGULAR_RTOL", "conditioning", "check_singular_values"]


class ConfigurationDomainError(ValueError):
    """A configuration outside the valid domain of the chart (wrong size, non-finite,
    Euler gimbal lock, singular one-cable chart, non-positive formation distance)."""


def plate_inertia(vertices, mass: float) -> np.ndarray:
    """Inertia [kg·m²] of a thin homogeneous polygonal plate about its centroid.

    *vertices*: (k, 2) polygon in the plate plane (z = 0, m), any orientation; *mass*: the
    plate's mass (kg, > 0); the
    result is 3×3 in the same axes.  Computed with the standard second moments of
    area of a polygon (shoelace sums), shifted to the centroid.
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
        raise GeometryError(f"plate vertices must be (k >= 3, 2), got shape {v.shape}")
    validate.positive(mass, "plate mass", kind="positive", type_error=ConfigurationError)
    x, y = v[:, 0], v[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    area = cr.sum() / 2
    if abs(area) < 1e-12:
        raise GeometryError("plate polygon has zero area")
    cx = ((x + xn) * cr).sum() / (6 * area)
    cy = ((y + yn) * cr).sum() / (6 * area)
    Ixx = ((y * y + y * yn + yn * yn) * cr).sum() / 12  # ∫ y² dA about the origin
    Iyy = ((x * x + x * xn + xn * xn) * cr).sum() / 12
    Ixy = ((x * yn + 2 * x * y + 2 * xn * yn + xn * y) * cr).sum() / 24
    sgn = np.sign(area)
    area, Ixx, Iyy, Ixy = abs(area), sgn * Ixx, sgn * Iyy, sgn * Ixy
    Ixx -= area * cy * cy
    Iyy -= area * cx * cx
    Ixy -= area * cx * cy
    rho = mass / area
    # body inertia: J_xx = ρ∫y², J_yy = ρ∫x², J_zz = ρ∫(x²+y²), J_xy = -ρ∫xy
    return rho * np.array([[Ixx, -Ixy, 0.0], [-Ixy, Iyy, 0.0], [0.0, 0.0, Ixx + Iyy]])


@dataclass(frozen=True)
class MassProperties:
    """Masses of the mechanical model of B.1.2 (SI units).

    ``platform_mass`` [kg], ``platform_inertia`` (3×3, kg·m², about the platform CoM in
    F_V), ``robot_masses`` [kg] (one per robot, point masses at the cable ends),
    ``g`` [m/s²] along -z_O.
    """

    platform_mass: float
    platform_inertia: tuple
    robot_masses: tuple
    g: float = 9.81

    def __post_init__(self):
        validate.positive(self.platform_mass, "platform_mass", kind="positive")
        J = np.asarray(self.platform_inertia, dtype=float)
        if J.shape != (3, 3) or not np.all(np.isfinite(J)) or not np.allclose(J, J.T, atol=1e-12):
            raise ValueError(f"platform_inertia must be a finite symmetric 3x3 matrix, got {J.tolist()}")
        if np.linalg.eigvalsh(J).min() <= 0:
            raise ValueError(f"platform_inertia must be positive definite, eigenvalues {np.linalg.eigvalsh(J)}")
        for i, mr in enumerate(self.robot_masses):
            validate.positive(mr, f"robot_masses[{i}]", kind="positive", type_error=ConfigurationError)
        validate.non_negative(self.g, "g", kind="non-negative")
        object.__setattr__(self, "platform_inertia", tuple(map(tuple, J)))
        object.__setattr__(self, "robot_masses", tuple(float(m) for m in self.robot_masses))


class MultiRobotSystem:
    """A pivot plus N attached agents; kinematics (3.1)-(3.3) and (4.4)-(4.6).

    Parameters
    ----------
    attachments: one :class:`TwoCable`, :class:`OneCable` or :class:`PlanarAgent` per
        agent (planar agents need ``pivot="planar"``).
    pivot: ``"spatial"`` (q_V in R^6, Euler angles of (B.1)) or ``"planar"`` (R^3).
    mass: :class:`MassProperties` for the dynamics (spatial cable systems only).
    q_nominal: a valid, non-singular reference configuration (rad/m), checked.
    name: the system's name (in messages; default ``"multi_robot"``).
    singular_tol: relative rank tolerance: configurations where the smallest singular
        value of ``A_q`` is at most ``singular_tol`` times the largest are singular
        (default :data:`SINGULAR_RTOL` = 1e-8, the project's one rule; in [0, 1)).
    """

    def __init__(self, attachments: Sequence, *, pivot: str = "spatial", mass: MassProperties | None = None,
                 q_nominal=None, name: str = "multi_robot", singular_tol: float = SINGULAR_RTOL):
        validate.choice(pivot, "pivot", ("spatial", "planar"))
        atts = tuple(attachments)
        if not atts:
            raise ValueError("a multi-robot system needs at least one agent")
        for i, a in enumerate(atts):
            if not isinstance(a, (TwoCable, OneCable, PlanarAgent)):
                raise TypeError(f"attachment {i} must be TwoCable, OneCable or PlanarAgent, got {a!r}")
            if (pivot == "planar") != isinstance(a, PlanarAgent):
                raise ValueError(f"attachment {i} ({type(a).__name__}) does not fit a {pivot} pivot")
        if mass is not None:
            if pivot != "spatial":
                raise ValueError("mass properties (dynamics) are defined for spatial cable systems only")
            if len(mass.robot_masses) != len(atts):
                raise ValueError(f"mass.robot_masses has {len(mass.robot_masses)} entries for {len(atts)} robots")
        validate.real(singular_tol, "singular_tol", lo=0.0, hi=1.0, hi_open=True,
                      kind="a relative tolerance in [0, 1)", type_error=ConfigurationError)
        self.name, self.pivot, self.attachments, self.mass = name, pivot, atts, mass
        self.singular_tol = float(singular_tol)
        self.N = len(atts)
        self.m_V = 6 if pivot == "spatial" else 3
        rows, cols, r0, c0 = [], [], 0, 0
        for a in atts:
            rows.append(tuple(range(r0, r0 + a.n_i)))
            cols.append(tuple(range(c0, c0 + a.m_i)))
            r0 += a.n_i
            c0 += a.m_i
        self.rows, self.cols = tuple(rows), tuple(cols)
        self.pivot_cols = tuple(range(c0, c0 + self.m_V))
        self.n, self.m = r0, c0 + self.m_V

        names, angle = [], []
        for i, a in enumerate(atts, start=1):
            for nm, ang in zip(a.coord_names, a.coord_is_angle):
                names.append(f"{nm}_{i}")
                angle.append(ang)
        if pivot == "spatial":
            names += ["x_V", "y_V", "z_V", "phi_V", "theta_V", "psi_V"]
            angle += [False, False, False, True, True, True]
        else:
            names += ["x_V", "y_V", "phi_V"]
            angle += [False, False, True]
        self.coordinate_names = tuple(names)
        self.coordinate_is_angle = tuple(angle)
        pn = []
        for i, a in enumerate(atts, start=1):
            axes = ("x", "y", "z") if a.n_i == 3 and not isinstance(a, PlanarAgent) else ("x", "y", "phi")[:a.n_i]
            pn += [f"p{i}_{ax}" for ax in axes]
        #: names of the entries of p (agent i's x, y, z; formation agents x, y, phi)
        self.position_names = tuple(pn)

        # Symbolic model, built once.
        self.q_sym = q = ca.SX.sym("q", self.m)
        qV = q[c0:]
        if pivot == "spatial":
            self.p_V_expr, self.R_expr = qV[0:3], euler_zyx(qV[3], qV[4], qV[5])
        else:
            self.p_V_expr, self.R_expr = qV[0:2], rot_2d(qV[2])
        parts = [a.position(q[list(c)], self.p_V_expr, self.R_expr) for a, c in zip(atts, self.cols)]
        self.h_expr = ca.vertcat(*parts)
        self.A_expr = ca.jacobian(self.h_expr, q)
        self.h_fun = ca.Function(f"{name}_h", [q], [self.h_expr], ["q"], ["p"])
        self.A_fun = ca.Function(f"{name}_A", [q], [self.A_expr], ["q"], ["A_q"])
        self._h_eval, self._A_eval = BufferedFunction(self.h_fun), BufferedFunction(self.A_fun)
        self._dynamics = None

        self.q_nominal = None
        if q_nominal is not None:
            self.q_nominal = self.check_configuration(q_nominal, what="q_nominal")

    def __repr__(self):
        return f"<MultiRobotSystem {self.name!r}: N={self.N}, n={self.n}, m={self.m}>"

    # -- validation -----------------------------------------------------------
    def _q(self, q, what="q") -> np.ndarray:
        a = np.asarray(q, dtype=float).reshape(-1)
        if a.shape != (self.m,):
            raise ConfigurationDomainError(f"{what} must have m={self.m} entries {list(self.coordinate_names)}, "
                                           f"got {np.shape(q)}")
        if not np.all(np.isfinite(a)):
            raise ConfigurationDomainError(f"{what} must be finite, got {a.tolist()}")
        return a

    def domain_error(self, q) -> str | None:
        """Why *q* lies outside the valid domain of the chart, or None."""
        q = self._q(q)
        for i, (a, c) in enumerate(zip(self.attachments, self.cols), start=1):
            msg = a.domain_error(q[list(c)])
            if msg:
                return f"robot {i}: {msg}"
        if self.pivot == "spatial":
            th = q[self.pivot_cols[4]]
            if abs(math.cos(th)) < 1e-6:
                return f"Euler angles at gimbal lock: theta_V = {th!r} rad (cos theta_V = 0)"
        return None

    def check_configuration(self, q, what: str = "q") -> np.ndarray:
        """Return *q* as an array, or raise :class:`ConfigurationDomainError` /
        :class:`SingularConfigurationError` naming the value as *what* (e.g. ``"q_nominal"``)."""
        q = self._q(q, what)
        msg = self.domain_error(q)
        if msg:
            raise ConfigurationDomainError(f"{what} = {np.round(q, 12).tolist()} is outside the valid domain: {msg}")
        check_singular_values(self.singular_values(q), f"{what} = {np.round(q, 12).tolist()} for {self.name}",
                              self.singular_tol)
        return q

    # -- kinematics (numpy in/out) --------------------------------------------
    def h(self, q) -> np.ndarray:
        """Agent positions ``p = h(q)`` (3.1)/(B.2), shape (n,)."""
        return self._h_eval(self._q(q))[0]

    def jacobian(self, q) -> np.ndarray:
        """``A_q = ∂h/∂q`` (3.2), shape (n, m), with the block structure (3.3)."""
        return self._A_eval(self._q(q))[0]

    def singular_values(self, q) -> np.ndarray:
        """Singular values of ``A_q`` at the configuration *q*, descending."""
        return np.linalg.svd(self.jacobian(q), compute_uv=False)

    def singularity_measure(self, q) -> float:
        """Smallest singular value of ``A_q`` at the configuration *q* (the min(n, m)-th); 0 at singularities."""
        return float(self.singular_values(q)[-1])

    def pinv(self, q) -> np.ndarray:
        """Moore–Penrose inverse ``A_q^† = (A_qᵀA_q)^{-1} A_qᵀ`` (ch. 4), shape (m, n);
        equals ``A_q^{-1}`` for square systems.  Raises
        :class:`SingularConfigurationError` (naming q, the rank, the smallest singular
        value and the condition number) when A_q is singular by the rule of
        :data:`SINGULAR_RTOL` (``singular_tol``)."""
        return pinv_solve(self.jacobian(q), np.eye(self.n), lambda: f"q = {np.round(self._q(q), 12).tolist()}",
                          self.singular_tol)

    def signed_conditioning(self, q) -> float:
        """``sign(det A_q) * sigma_min / sigma_max`` for square systems: continuous in q,
        zero exactly on the singular set and of opposite signs on its two sides, so a
        trajectory that crosses the singular set between two integration steps changes its
        sign (the plain ``sigma_min`` touches zero without changing sign).  Only defined
        for ``n == m``."""
        if self.n != self.m:
            raise ValueError(f"{self.name}: signed conditioning needs a square A_q, got n={self.n}, m={self.m}")
        A = self.jacobian(q)
        s = np.linalg.svd(A, compute_uv=False)
        if not s[0] > 0.0:
            return 0.0
        return float(np.sign(np.linalg.det(A)) * s[-1] / s[0])

    def projector(self, q) -> np.ndarray:
        """Orthogonal projector ``Π_q = A_q A_q^†`` onto Im A_q (4.4) at the configuration *q*, shape (n, n)."""
        return self.jacobian(q) @ self.pinv(q)

    def configuration_rate(self, q, u) -> np.ndarray:
        """``q̇ = A_q^† u`` (3.7)/(4.6) [rad/s, m/s] for robot velocities *u* (n,)."""
        u = np.asarray(u, dtype=float).reshape(-1)
        if u.shape != (self.n,):
            raise ValueError(f"u must have n={self.n} entries, got {u.shape}")
        return pinv_solve(self.jacobian(q), u, lambda: f"q = {np.round(self._q(q), 12).tolist()}",
                          self.singular_tol)

    def block_indices(self):
        """``(rows, cols, pivot_cols)``: index tuples of p_i, q_i and q_V (the layout of (3.3))."""
        return self.rows, self.cols, self.pivot_cols

    # -- units at the edge ------------------------------------------------------
    def q_from(self, robots: Sequence, pose: Sequence) -> np.ndarray:
        """Build q [rad, m] from thesis-style values: *robots* one entry per agent
        (scalar or tuple of its coordinates; angles in degrees, lengths in metres)
        and *pose* = the pivot pose (position in metres, angles in degrees)."""
        robots = list(robots)
        if len(robots) != self.N:
            raise ValueError(f"robots must have N={self.N} entries, got {len(robots)}")
        vals = []
        for i, (a, r) in enumerate(zip(self.attachments, robots), start=1):
            r = np.atleast_1d(np.asarray(r, dtype=float)).tolist()
            if len(r) != a.m_i:
                raise ValueError(f"robot {i} takes {a.m_i} coordinate(s) {a.coord_names}, got {r}")
            vals += r
        pose = np.atleast_1d(np.asarray(pose, dtype=float)).tolist()
        if len(pose) != self.m_V:
            raise ValueError(f"pose must have m_V={self.m_V} entries, got {pose}")
        vals += pose
        q = np.array([math.radians(v) if ang else v for v, ang in zip(vals, self.coordinate_is_angle)])
        return self._q(q)

    def q_to_edge(self, q) -> np.ndarray:
        """Inverse of :meth:`q_from` on the flat vector *q* (rad/m): angles in degrees, lengths in m."""
        q = self._q(q)
        return np.array([math.degrees(v) if ang else v for v, ang in zip(q, self.coordinate_is_angle)])

    # -- sampling ------------------------------------------------------------------
    def random_configurations(self, rng: np.random.Generator, k: int, spread: float = 0.2,
                              min_singular: float = 1e-3) -> np.ndarray:
        """*k* valid non-singular configurations ``q_nominal + U(-spread, spread)`` (rad/m), drawn
        from *rng* (a ``numpy.random.Generator``); a draw is kept when it lies in the domain and
        the smallest singular value of ``A_q`` exceeds *min_singular*."""
        if self.q_nominal is None:
            raise ValueError(f"{self.name} has no q_nominal to sample around")
        out = []
        tries = 0
        while len(out) < k:
            tries += 1
            if tries > 100 * k:
                raise RuntimeError(f"could not sample {k} regular configurations of {self.name}")
            q = self.q_nominal + rng.uniform(-spread, spread, self.m)
            if self.domain_error(q) is None and self.singularity_measure(q) > min_singular:
                out.append(q)
        return np.array(out)

    # -- dynamics ----------------------------------------------------------------------
    @property
    def dynamics(self):
        """The Lagrangian model (B.1.2)/(4.10), built on first use and cached."""
        if self._dynamics is None:
            if self.mass is None or self.pivot != "spatial":
                raise ValueError(f"{self.name} has no mechanical model (needs a spatial pivot and MassProperties)")
            from .dynamics import LagrangianModel
            self._dynamics = LagrangianModel(self)
        return self._dynamics
