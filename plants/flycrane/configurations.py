"""Ready-made systems of the class: the thesis Fly-crane and its relatives.

Every function returns a :class:`~netcosim.plants.flycrane.kinematics.MultiRobotSystem` with a
checked, non-singular ``q_nominal``.  Values the thesis gives are quoted with their
section; the others are chosen here and justified next to them (see also
``docs/models.md``).
"""

from __future__ import annotations

import math

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

from .attachments import OneCable, PlanarAgent, TwoCable
from .kinematics import MassProperties, MultiRobotSystem, plate_inertia

__all__ = ["thesis_flycrane", "experimental_flycrane", "four_robot_nonsquare", "two_cable_polygon", "square_family",
           "formation_2d", "regular_polygon", "SQUARE_FAMILY"]

#: Robot mass of the LAAS Fly-crane [kg] (§3.6).
ROBOT_MASS = 1.03
#: Platform mass of the LAAS Fly-crane [kg] (§3.6): a triangular plate of edge 1 m.
PLATFORM_MASS = 0.338
#: Areal density of that plate [kg/m²], used for the other platforms.
PLATE_DENSITY = PLATFORM_MASS / (math.sqrt(3) / 4)

#: The square systems of §3.2.2: (N_1c, N_2c, N).
SQUARE_FAMILY = ((0, 3, 3), (2, 2, 4), (4, 1, 5), (6, 0, 6))


def regular_polygon(k: int, edge: float, first_midpoint_deg: float = 90.0) -> np.ndarray:
    """Vertices (k, 3) of a regular k-gon of side *edge* [m] centred at the origin in
    the z = 0 plane, ordered counter-clockwise, with the midpoint of edge 0 (between
    vertices 0 and 1) in the direction *first_midpoint_deg* from x."""
    if k < 3:
        raise ValueError(f"a polygon needs k >= 3 vertices, got {k}")
    validate.positive(edge, "polygon edge (m)", kind="positive")
    R = edge / (2 * math.sin(math.pi / k))
    half = math.pi / k
    mid = math.radians(first_midpoint_deg)
    ang = [mid - half + 2 * math.pi * j / k for j in range(k)]
    return np.array([[R * math.cos(a), R * math.sin(a), 0.0] for a in ang])


def _plate_mass(vertices) -> float:
    x, y = vertices[:, 0], vertices[:, 1]
    area = abs((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) / 2
    return PLATE_DENSITY * area


def _mass(vertices, n_robots, platform_mass=None, robot_mass=ROBOT_MASS, g=9.81):
    pm = _plate_mass(vertices) if platform_mass is None else platform_mass
    validate.positive(pm, "platform_mass", kind="positive", type_error=ConfigurationError)
    return MassProperties(pm, plate_inertia(vertices[:, :2], pm), (robot_mass,) * n_robots, g)


def thesis_flycrane(cable_length: float = 1.5, edge: float = 1.0, robot_mass: float = ROBOT_MASS,
                    platform_mass: float = PLATFORM_MASS, g: float = 9.81) -> MultiRobotSystem:
    """The Fly-crane of B.1 / §3.5: 3 robots, each on two cables to the ends of one edge
    of an equilateral platform (edge 1 m, cables 1.5 m in simulation, §3.5).

    Robot i sits on edge i whose midpoint O_Ci lies at ``l_C = edge/(2√3)`` from O_V in
    the direction σ_i + 90° (σ = 0°, 120°, 240°: y_Vi points to O_Ci, B.1.1), so
    ``p_i^Vi = (0, l_C + l sin β cos α_i, l sin β sin α_i)`` with ``cos β = edge/(2l)``.
    Masses: robot 1.03 kg, platform 0.338 kg (§3.6), thin-plate inertia.
    ``q_nominal``: α_i = 75°, q_V = ½(1, 1, 1, 0, 0, 0) (the reference of §3.5).
    n = m = 9.  ``cable_length`` (m), ``edge`` (m), ``robot_mass`` (kg, each robot),
    ``platform_mass`` (kg) and ``g`` (gravity, m/s²) override those values.
    """
    V = regular_polygon(3, edge)
    atts = [TwoCable(V[i], V[(i + 1) % 3], cable_length) for i in range(3)]
    sys = MultiRobotSystem(atts, mass=_mass(V, 3, platform_mass, robot_mass, g), name="flycrane_3",
                           q_nominal=None)
    sys.q_nominal = sys.check_configuration(sys.q_from([75, 75, 75], [0.5, 0.5, 0.5, 0, 0, 0]), "q_nominal")
    sys.platform_vertices = V
    return sys


def experimental_flycrane() -> MultiRobotSystem:
    """The LAAS rig of §3.6: as :func:`thesis_flycrane` with 1.2 m cables;
    ``q_nominal`` = the experiment's start, α_i = 55°, q_V = (0, 0, 0.4 m, 0, 0, 0)."""
    sys = thesis_flycrane(cable_length=1.2)
    sys.name = "flycrane_3_rig"
    sys.q_nominal = sys.check_configuration(sys.q_from([55, 55, 55], [0, 0, 0.4, 0, 0, 0]), "q_nominal")
    return sys


def four_robot_nonsquare(cable_length: float = 1.5, edge: float = 1.0, robot_mass: float = ROBOT_MASS,
                         g: float = 9.81) -> MultiRobotSystem:
    """The 4-robot system of ch. 4 (Fig. 4.3a, §4.6): four robots, each on two cables to
    one edge of a square platform; q = [q_1..q_4, q_V], n = 12, m = 10.

    The thesis gives neither the platform nor the cables: a 1 m square plate (the
    Fly-crane's edge, 0.78 kg at the same areal density) and 1.5 m cables (as §3.5).
    ``q_nominal``: q_i = 80°, q_V = 0 (the initial configuration of §4.6.1).
    ``cable_length`` (m), ``edge`` (the platform's side, m), ``robot_mass`` (kg, each
    robot) and ``g`` (gravity, m/s²) set the system's geometry and masses.
    """
    V = regular_polygon(4, edge)
    atts = [TwoCable(V[i], V[(i + 1) % 4], cable_length) for i in range(4)]
    sys = MultiRobotSystem(atts, mass=_mass(V, 4, None, robot_mass, g), name="flycrane_4")
    sys.q_nominal = sys.check_configuration(sys.q_from([80] * 4, [0, 0, 0, 0, 0, 0]), "q_nominal")
    sys.platform_vertices = V
    return sys


def two_cable_polygon(n_robots: int, cable_length: float = 1.5, edge: float = 1.0,
                      robot_mass: float = ROBOT_MASS, g: float = 9.81) -> MultiRobotSystem:
    """*n_robots* robots, each on two cables to one edge of a regular polygon platform
    (edge 1 m, cables 1.5 m, plate at the Fly-crane's areal density): the family of the
    Fly-crane (3 robots, square, n = m = 9; the platform mass is then the LAAS 0.338 kg)
    and of the ch. 4 system (4 robots: :func:`four_robot_nonsquare`), rectangular for
    4 or more robots (n = 3N > m = N + 6).  ``q_nominal``: cable angles 80 deg, q_V = 0.
    ``cable_length`` (m), ``edge`` (the platform's side, m), ``robot_mass`` (kg, each
    robot) and ``g`` (gravity, m/s²) set the system's geometry and masses.
    """
    k = int(n_robots)
    if k != n_robots or k < 3:
        raise ValueError(f"a two-cable polygon needs an integer number of robots >= 3, got {n_robots!r}")
    V = regular_polygon(k, edge)
    atts = [TwoCable(V[i], V[(i + 1) % k], cable_length) for i in range(k)]
    sys = MultiRobotSystem(atts, mass=_mass(V, k, None, robot_mass, g), name=f"flycrane_{k}")
    sys.q_nominal = sys.check_configuration(sys.q_from([80] * k, [0, 0, 0, 0, 0, 0]), "q_nominal")
    sys.platform_vertices = V
    return sys


def square_family(n1c: int, n2c: int, cable_length: float = 1.5, edge: float = 1.0,
                  robot_mass: float = ROBOT_MASS, g: float = 9.81) -> MultiRobotSystem:
    """The square systems of §3.2.2 (Fig. 3.1): N_1c one-cable and N_2c two-cable robots
    with 3N = 6 + 2 N_1c + N_2c, i.e. (N_1c, N_2c) ∈ {(0,3), (2,2), (4,1), (6,0)}
    (*n1c* = N_1c, *n2c* = N_2c).
    ``cable_length`` (m), ``edge`` (the platform's side, m), ``robot_mass`` (kg, each
    robot) and ``g`` (gravity, m/s²) set the system's geometry and masses.

    The thesis draws them without dimensions; the layouts chosen here (edge 1 m,
    cables 1.5 m, plates at the Fly-crane's areal density):

    * (0, 3): :func:`thesis_flycrane`.
    * (2, 2): square plate; two-cable robots on edges 0 and 2, one-cable robots at the
      midpoints of edges 1 and 3.
    * (4, 1): square plate; a two-cable robot on edge 0, one-cable robots at
      vertices 2, 3 and at the midpoints of edges 1 and 3.
    * (6, 0): regular hexagon; one-cable robots at the six vertices.

    ``q_nominal``: cable elevations 75°, and one-cable sideways tilts γ of alternating
    sign (±20°).  With γ = 0 all one-cable robots lie in radial vertical planes, so
    every cable line meets the vertical axis through O_V: a singular (linear line
    complex) arrangement, which the tilt avoids — like the legs of a Stewart platform.
    """
    key = (int(n1c), int(n2c))
    if key == (0, 3):
        return thesis_flycrane(cable_length, edge, robot_mass, g=g)
    if key not in {(a, b) for a, b, _ in SQUARE_FAMILY}:
        raise ValueError(f"(N_1c, N_2c) = {key} is not square: need 3N = 6 + 2 N_1c + N_2c, one of "
                         f"{[(a, b) for a, b, _ in SQUARE_FAMILY]}")
    L = cable_length
    if key == (2, 2):
        V = regular_polygon(4, edge)
        mid = lambda j: (V[j] + V[(j + 1) % 4]) / 2  # noqa: E731
        atts = [TwoCable(V[0], V[1], L), OneCable(mid(1), L), TwoCable(V[2], V[3], L), OneCable(mid(3), L)]
    elif key == (4, 1):
        V = regular_polygon(4, edge)
        mid = lambda j: (V[j] + V[(j + 1) % 4]) / 2  # noqa: E731
        atts = [TwoCable(V[0], V[1], L), OneCable(mid(1), L), OneCable(V[2], L), OneCable(V[3], L),
                OneCable(mid(3), L)]
    else:
        V = regular_polygon(6, edge)
        atts = [OneCable(V[j], L) for j in range(6)]
    robots, sign = [], 1.0
    for a in atts:
        if isinstance(a, TwoCable):
            robots.append(75.0)
        else:
            robots.append((75.0, sign * 20.0))
            sign = -sign
    sys = MultiRobotSystem(atts, mass=_mass(V, len(atts), None, robot_mass, g),
                           name=f"square_{key[0]}_{key[1]}_{len(atts)}")
    sys.q_nominal = sys.check_configuration(sys.q_from(robots, [0, 0, 0, 0, 0, 0]), "q_nominal")
    sys.platform_vertices = V
    return sys


def formation_2d(with_bearing: bool = True) -> MultiRobotSystem:
    """The 2-D formation of §3.2.2 (Fig. 3.2): three ground robots around a pivot.

    ``q_i = (d_i [m], φ_i [rad])``, ``q_V = (x_V, y_V, φ_V)``,
    ``p_i = p_V + R(φ_V) d_i (cos φ_i, sin φ_i)``, with the bearings φ_i appended to
    each robot's coordinates (``with_bearing``) so that n = m = 9 as in the thesis.
    ``q_nominal``: d_i = 1 m, φ_i = 90°, 210°, 330°, pivot at the origin.  No
    mechanical model: the constraints are virtual.
    """
    atts = [PlanarAgent(with_bearing) for _ in range(3)]
    sys = MultiRobotSystem(atts, pivot="planar", name="formation_2d")
    if with_bearing:
        sys.q_nominal = sys.check_configuration(sys.q_from([(1, 90), (1, 210), (1, 330)], [0, 0, 0]), "q_nominal")
    else:
        sys.q_nominal = sys.q_from([(1, 90), (1, 210), (1, 330)], [0, 0, 0])
    return sys
