"""How one agent hangs from the pivot: the per-robot map ``p_i = h^(i)(q_i, q_V)`` (3.1).

Three kinds, each a small frozen dataclass with its geometry in the *pivot frame*
F_V (metres) and a method ``position(q_i, p_V, R)`` that returns the agent's
coordinates given its own ``q_i`` and the pivot position/rotation (CasADi symbols or
numbers):

* :class:`TwoCable` — a robot held by two taut cables from anchors ``a`` and ``b``
  (B.1.1).  It can only rotate about the axis a→b: one angle ``q_i`` (the thesis's
  α_i).  ``q_i = 0`` puts the robot in the platform plane, on the side away from the
  pivot origin; ``q_i = π/2`` puts it straight "above" the axis (towards +z_V).
* :class:`OneCable` — a robot on one cable from anchor ``a``: two angles.  ``q_i1``
  rotates the cable from the outward horizontal direction ``e_out`` towards +z_V (as
  for :class:`TwoCable`), ``q_i2`` tilts it sideways towards ``e_side = e_out × z_V``;
  cable direction ``cos q2 (cos q1 e_out + sin q1 z_V) + sin q2 e_side``.  This chart
  is regular for every ``q_i1`` (including a vertical cable) and singular only at
  ``|q_i2| = π/2``.
* :class:`PlanarAgent` — the 2-D formation of §3.2.2: ``q_i = (d_i, φ_i)``,
  ``p_i = p_V + R(φ_V) d_i (cos φ_i, sin φ_i)``, optionally followed by ``φ_i`` itself
  (the thesis appends the bearings so that the system is square).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from netcosim import validate

__all__ = ["TwoCable", "OneCable", "PlanarAgent", "GeometryError"]


class GeometryError(ValueError):
    """Attachment geometry that cannot exist (cables unable to reach, zero lengths, ...)."""


def _vec3(v, what):
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise GeometryError(f"{what} must be 3 finite coordinates in metres, got {v!r}")
    return a


def _positive(v, what):
    return validate.positive(v, what, kind="a positive length in metres", type_error=GeometryError,
                             value_error=GeometryError)


def _outward_frame(point, axis_dir=None, outward=None):
    """Unit vectors (e_out, e_up) for an attachment at *point* (pivot frame).

    With an axis (two cables): e_up is z_V made normal to the axis, e_out = ±(e_up ×
    axis), the sign making it point away from the pivot origin (or along *outward*).
    Without (one cable): e_up = z_V and e_out is the horizontal direction of *point*
    (or of *outward*)."""
    z = np.array([0.0, 0.0, 1.0])
    ref = point if outward is None else _vec3(outward, "outward")
    if axis_dir is None:
        e_up = z
        cand = ref - (ref @ z) * z
        sign = 1.0
    else:
        e_up = z - (z @ axis_dir) * axis_dir
        if np.linalg.norm(e_up) < 1e-9:
            raise GeometryError(f"attachment axis {axis_dir.tolist()} is vertical: the angle's zero "
                                "(the platform plane) is undefined")
        e_up = e_up / np.linalg.norm(e_up)
        cand = np.cross(e_up, axis_dir)
        sign = math.copysign(1.0, ref @ cand)
        if abs(ref @ cand) < 1e-12:
            cand = np.zeros(3)
    if np.linalg.norm(cand) < 1e-12:
        raise GeometryError(f"cannot tell 'outward' for the attachment at {point.tolist()} (the direction away "
                            "from the pivot's vertical axis is ambiguous); pass outward=(x, y, z)")
    e_out = sign * cand / np.linalg.norm(cand)
    return e_out, e_up


@dataclass(frozen=True)
class TwoCable:
    """A robot on two cables of lengths ``l_a``, ``l_b`` [m] from anchors ``a``, ``b``
    (pivot frame, m).  One coordinate: the rotation ``q_i`` [rad] about the axis a→b.

    Geometry: the robot lies on the circle of centre ``c = a + s e_ab`` and radius
    ``r`` with ``s = (l_a² - l_b² + L²) / (2L)``, ``r = sqrt(l_a² - s²)``, ``L = |b - a|``;
    for equal cables ``r = l sin β`` with ``cos β = L / (2 l)``, the β of B.1.1.
    Raises :class:`GeometryError` if the cables cannot both be taut (triangle
    inequality fails or is degenerate).  ``l_b`` defaults to ``l_a``; ``outward`` (a
    pivot-frame direction, None: away from the pivot origin) picks the side ``q_i = 0``
    points to, where the pivot's geometry leaves it ambiguous.
    """

    a: tuple
    b: tuple
    l_a: float
    l_b: float | None = None
    outward: tuple | None = None
    m_i: int = field(default=1, init=False)
    n_i: int = field(default=3, init=False)

    def __post_init__(self):
        a, b = _vec3(self.a, "anchor a"), _vec3(self.b, "anchor b")
        la = _positive(self.l_a, "cable length l_a")
        lb = la if self.l_b is None else _positive(self.l_b, "cable length l_b")
        L = float(np.linalg.norm(b - a))
        if L <= 1e-12:
            raise GeometryError(f"anchors a={a.tolist()} and b={b.tolist()} coincide")
        s = (la * la - lb * lb + L * L) / (2 * L)
        r2 = la * la - s * s
        if not (la + lb > L and abs(la - lb) < L) or r2 <= 1e-12:
            raise GeometryError(f"cables l_a={la} m, l_b={lb} m cannot reach anchors {L:.6g} m apart "
                                f"(need |l_a - l_b| < {L:.6g} < l_a + l_b)")
        e_ab = (b - a) / L
        c = a + s * e_ab
        e_out, e_up = _outward_frame(c, e_ab, self.outward)
        object.__setattr__(self, "a", tuple(a))
        object.__setattr__(self, "b", tuple(b))
        object.__setattr__(self, "l_b", lb)
        object.__setattr__(self, "_c", c)
        object.__setattr__(self, "_r", math.sqrt(r2))
        object.__setattr__(self, "_e_out", e_out)
        object.__setattr__(self, "_e_up", e_up)

    @property
    def radius(self) -> float:
        """Distance [m] from the a–b axis to the robot (``l sin β`` in B.1.1)."""
        return self._r

    @property
    def beta(self) -> float:
        """Angle [rad] between cable a and the axis a→b (the β of B.1.1)."""
        return math.acos(float(np.clip((self._c - np.asarray(self.a)) @ (np.asarray(self.b) - np.asarray(self.a))
                                       / (np.linalg.norm(np.asarray(self.b) - np.asarray(self.a)) * self.l_a), -1, 1)))

    @property
    def anchors(self):
        """The anchors ``(a, b)`` (pivot frame, m) as arrays."""
        return (np.asarray(self.a), np.asarray(self.b))

    @property
    def lengths(self):
        """The cable lengths ``(l_a, l_b)`` [m]."""
        return (self.l_a, self.l_b)

    coord_names = ("alpha",)
    coord_is_angle = (True,)

    def local(self, q_i):
        """Robot position in the pivot frame [m] (CasADi column) at the angle ``q_i[0]`` [rad]."""
        q = q_i[0]
        return ca.DM(self._c) + self._r * (ca.cos(q) * ca.DM(self._e_out) + ca.sin(q) * ca.DM(self._e_up))

    def position(self, q_i, p_V, R):
        """World position ``p_V + R (c + r (cos q e_out + sin q e_up))`` [m] for the robot's
        angle ``q = q_i[0]`` [rad], the pivot position *p_V* [m] and rotation *R* (world
        from pivot frame)."""
        return p_V + R @ self.local(q_i)

    def domain_error(self, q_i) -> str | None:
        """Why the coordinates *q_i* lie outside the chart's domain, or None: every angle is
        valid for two cables."""
        return None


@dataclass(frozen=True)
class OneCable:
    """A robot on one cable of length ``l`` [m] from anchor ``a`` (pivot frame, m).
    Two coordinates ``(q_i1, q_i2)`` [rad], see the module docstring.  ``outward`` (a
    pivot-frame direction, None: the horizontal direction of ``a``) sets ``e_out``."""

    a: tuple
    l: float
    outward: tuple | None = None
    m_i: int = field(default=2, init=False)
    n_i: int = field(default=3, init=False)

    def __post_init__(self):
        a = _vec3(self.a, "anchor a")
        l = _positive(self.l, "cable length l")
        e_out, e_up = _outward_frame(a, None, self.outward)
        object.__setattr__(self, "a", tuple(a))
        object.__setattr__(self, "l", l)
        object.__setattr__(self, "_e_out", e_out)
        object.__setattr__(self, "_e_up", e_up)
        object.__setattr__(self, "_e_side", np.cross(e_out, e_up))

    coord_names = ("alpha", "gamma")
    coord_is_angle = (True, True)

    @property
    def anchors(self):
        """The anchor ``(a,)`` (pivot frame, m) as an array."""
        return (np.asarray(self.a),)

    @property
    def lengths(self):
        """The cable length ``(l,)`` [m]."""
        return (self.l,)

    def local(self, q_i):
        """Robot position in the pivot frame [m] (CasADi column) at the angles
        ``q_i = (q_i1, q_i2)`` [rad]."""
        q1, q2 = q_i[0], q_i[1]
        d = ca.cos(q2) * (ca.cos(q1) * ca.DM(self._e_out) + ca.sin(q1) * ca.DM(self._e_up)) \
            + ca.sin(q2) * ca.DM(self._e_side)
        return ca.DM(self.a) + self.l * d

    def position(self, q_i, p_V, R):
        """World position ``p_V + R local(q_i)`` [m] for the robot's angles *q_i* [rad], the
        pivot position *p_V* [m] and rotation *R* (world from pivot frame)."""
        return p_V + R @ self.local(q_i)

    def domain_error(self, q_i) -> str | None:
        """Why the angles *q_i* lie outside the chart's domain (``|q_i2| = π/2``), or None."""
        if abs(math.cos(float(q_i[1]))) < 1e-9:
            return f"one-cable chart is singular at gamma = {float(q_i[1])!r} rad (|gamma| = pi/2)"
        return None


@dataclass(frozen=True)
class PlanarAgent:
    """A ground robot of the 2-D formation (§3.2.2), ``q_i = (d_i [m], φ_i [rad])``.

    ``p_i = p_V + R(φ_V) d_i (cos φ_i, sin φ_i)``; with ``with_bearing=True`` the
    agent's coordinates are ``(x_i, y_i, φ_i)`` (the thesis's augmented p')."""

    with_bearing: bool = True
    m_i: int = field(default=2, init=False)

    @property
    def n_i(self) -> int:
        """Coordinates of the agent: 3 ``(x_i, y_i, φ_i)`` with the bearing, else 2."""
        return 3 if self.with_bearing else 2

    coord_names = ("d", "phi")
    coord_is_angle = (False, True)
    anchors = ()
    lengths = ()

    def position(self, q_i, p_V, R):
        """The agent's coordinates for ``q_i = (d_i [m], φ_i [rad])``, the pivot position *p_V*
        [m, 2-D] and rotation *R* (2 x 2, world from pivot frame)."""
        d, ph = q_i[0], q_i[1]
        xy = p_V + R @ ca.vertcat(d * ca.cos(ph), d * ca.sin(ph))
        return ca.vertcat(xy, ph) if self.with_bearing else xy

    def domain_error(self, q_i) -> str | None:
        """Why *q_i* lies outside the domain (a distance ``d_i <= 0``), or None."""
        if float(q_i[0]) <= 0:
            return f"formation distance d must be positive, got {float(q_i[0])!r} m"
        return None
