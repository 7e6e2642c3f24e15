"""The one kinematic model of star-shaped multi-robot systems, shared by plants and planners.

A *kinematic system* (:class:`KinematicSystem`) is any object with

* ``n``, ``m``: the dimensions of ``p`` (stacked robot positions, m) and ``q``
  (configuration: cable angles in rad, pivot pose in m and rad);
* ``h(q) -> p`` (shape ``(n,)``) and ``jacobian(q) -> A_q`` (shape ``(n, m)``);
* ``pinv(q) -> A_q^+`` (shape ``(m, n)``), the Moore-Penrose inverse (``A_q^{-1}``
  when ``n == m``); optional: :func:`pinv` computes it from ``jacobian`` otherwise.

The Fly-crane configurations (:class:`netcosim.plants.flycrane.MultiRobotSystem`) implement all
five; the planners of :mod:`netcosim.controllers.planner` only need ``n, m, h, jacobian``.

One rank rule (:data:`SINGULAR_RTOL`, :func:`conditioning`), one exception
(:class:`SingularConfigurationError`, defined here), one pseudo-inverse
(:func:`pinv_solve`: SVD least squares, then the rank rule) and one plant
``q_dot = A_q^+ u`` (:class:`KinematicPlant`, thesis (3.7), (4.6), (4.13)) serve every
system and every caller.  A system may carry its own relative tolerance
``singular_tol`` (default :data:`SINGULAR_RTOL`); :func:`rank_rtol` reads it.
"""

from __future__ import annotations

import math
from typing import Any, Protocol, runtime_checkable

import numpy as np

from netcosim.errors import NetcosimError
from netcosim.plant import ContinuousSystem, HybridEvent

__all__ = ["KinematicSystem", "SINGULAR_RTOL", "conditioning", "check_singular_values", "rank_rtol",
           "check_system", "as_vector", "jacobian", "pinv_solve", "pinv", "configuration_rate", "project",
           "signed_conditioning", "KinematicPlant", "SingularConfigurationError"]

class SingularConfigurationError(NetcosimError, ValueError):
    """A kinematic Jacobian ``A_q`` lost column rank (or is too ill-conditioned to use)
    at the configuration where it was needed (the message names q, the rank, the smallest
    singular value and the condition number).  Raised by the kinematic plants and
    planners (Fly-crane, :mod:`netcosim.controllers.planner`), re-exported by :mod:`netcosim.plants.flycrane`
    and :mod:`netcosim.controllers.planner`: one class."""


#: The one rank rule of the project (plants and planners): ``A_q`` counts as singular
#: when its smallest singular value is at most ``SINGULAR_RTOL`` times its largest,
#: i.e. when its condition number reaches ``1 / SINGULAR_RTOL = 1e8``.  Why 1e-8: it is
#: about sqrt(machine epsilon) (1.5e-8); ``A_q^+ u`` computed in double precision has a
#: relative error of about ``eps * cond(A_q)``, so beyond ``cond = 1e8`` fewer than half
#: of the digits of ``q_dot`` are right and no integrator tolerance used here (1e-8 to
#: 1e-13) can be met.  Near such a configuration ``|q_dot| ~ |u| / sigma_min`` grows
#: without bound (the platform is not determined by the robot positions).  The rule is
#: relative, so it does not depend on the units of q (rad and m mixed) or on the size
#: of the platform.
SINGULAR_RTOL = 1e-8


@runtime_checkable
class KinematicSystem(Protocol):
    """What plants and planners need of a kinematic system (see the module docstring)."""

    n: int
    m: int

    def h(self, q) -> np.ndarray:
        """Robot positions ``p = h(q)`` (m, rad), shape ``(n,)``."""

    def jacobian(self, q) -> np.ndarray:
        """``A_q = dh/dq`` at the configuration *q* (shape ``(m,)``; rad and m), shape ``(n, m)``."""

    def pinv(self, q) -> np.ndarray:
        """``A_q^+`` at the configuration *q*, shape ``(m, n)``; raises
        :class:`SingularConfigurationError` by the rank rule."""


def conditioning(singular_values, rtol: float = SINGULAR_RTOL) -> tuple[int, float, float, bool]:
    """``(rank, sigma_min, cond, singular)`` of a matrix from its *singular_values* (any order).

    ``rank`` counts the singular values above ``rtol * sigma_max``; ``cond =
    sigma_max / sigma_min`` (inf when ``sigma_min = 0``); ``singular`` is true when the
    rank is below the number of singular values (``min(n, m)``), i.e. when
    ``sigma_min <= rtol * sigma_max`` -- or when a value is not finite.
    """
    sv = np.sort(np.abs(np.asarray(singular_values, dtype=float).reshape(-1)))[::-1]
    if sv.size == 0 or not np.all(np.isfinite(sv)) or not sv[0] > 0.0:
        return 0, (float(sv[-1]) if sv.size else 0.0), math.inf, True
    smax, smin = float(sv[0]), float(sv[-1])
    rank = int(np.count_nonzero(sv > rtol * smax))
    cond = smax / smin if smin > 0.0 else math.inf
    return rank, smin, cond, rank < sv.size


def check_singular_values(singular_values, at: str, rtol: float = SINGULAR_RTOL) -> None:
    """Raise :class:`SingularConfigurationError` if the rule of :data:`SINGULAR_RTOL` (with the
    relative tolerance *rtol*) calls the matrix of *singular_values* (any order)
    singular; *at* names where (``"q = [...]"``) -- see :func:`conditioning`."""
    rank, smin, cond, singular = conditioning(singular_values, rtol)
    if singular:
        k = np.asarray(singular_values).size
        raise SingularConfigurationError(
            f"A_q is singular at {at}: rank {rank} < {k}, smallest singular value {smin:.3e}, "
            f"condition number {cond:.3e} (singular when sigma_min <= {rtol:g} * sigma_max)")


def rank_rtol(system: Any) -> float:
    """The relative rank tolerance of *system*: its ``singular_tol`` or :data:`SINGULAR_RTOL`."""
    return float(getattr(system, "singular_tol", SINGULAR_RTOL))


def check_system(system: Any) -> Any:
    """Return *system*, raising ``TypeError`` unless it has ``n``, ``m``, ``h`` and
    ``jacobian``, and ``ValueError`` unless ``n`` and ``m`` are positive integers."""
    missing = [a for a in ("n", "m", "h", "jacobian") if not hasattr(system, a)]
    if missing:
        raise TypeError(f"{system!r} is not a kinematic system: missing {missing} "
                        "(need n, m, h(q) and jacobian(q))")
    n, m = system.n, system.m
    if not (isinstance(n, (int, np.integer)) and isinstance(m, (int, np.integer)) and n > 0 and m > 0):
        raise ValueError(f"system dimensions must be positive integers, got n={n!r}, m={m!r}")
    return system


def as_vector(x: Any, size: int, what: str) -> np.ndarray:
    """*x* as a finite float vector of *size* entries, or ``ValueError`` naming *what*."""
    v = np.asarray(x, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise ValueError(f"{what} must have {size} entries, got {v.shape[0]}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be finite, got {v.tolist()}")
    return v


def jacobian(system: Any, q: np.ndarray) -> np.ndarray:
    """``A_q`` of *system* at the configuration *q* as a float array, checked: shape ``(n, m)`` (``ValueError``)
    and finite (:class:`SingularConfigurationError` otherwise, e.g. at a chart singularity)."""
    A = np.asarray(system.jacobian(q), dtype=float)
    if A.shape != (system.n, system.m):
        raise ValueError(f"jacobian returned shape {A.shape}, expected ({system.n}, {system.m})")
    if not np.all(np.isfinite(A)):
        raise SingularConfigurationError(f"jacobian is not finite at q={np.asarray(q).tolist()}")
    return A


def pinv_solve(A: np.ndarray, v: np.ndarray, at: Any = None, rtol: float = SINGULAR_RTOL) -> np.ndarray:
    """``A^+ v`` for a full-rank A (``A^{-1} v`` when square): the project's one pseudo-inverse.

    Solved by SVD least squares (``numpy.linalg.lstsq``, ``rcond = rtol``); *v* may be a
    vector or a matrix (``v = I`` gives ``A^+``).  Raises
    :class:`SingularConfigurationError` by the rank rule (singular when
    ``sigma_min <= rtol * sigma_max``, :func:`check_singular_values`), naming where, the
    rank, the smallest singular value and the condition number.  *at* names where: the
    configuration q with ``A = A_q`` (shown as ``q=[...]``), a string, or a callable
    returning one (only called on failure, so callers in inner loops pay nothing for it).
    """
    x, _, _, sv = np.linalg.lstsq(A, v, rcond=rtol)
    if conditioning(sv, rtol)[3]:
        check_singular_values(sv, _where(at), rtol)
    return x


def _where(at) -> str:
    if callable(at):
        return at()
    if isinstance(at, str):
        return at
    return "an unnamed configuration" if at is None else f"q={np.asarray(at).tolist()}"


def _rounded(q) -> str:
    return f"q = {np.round(np.asarray(q, dtype=float), 12).tolist()}"


def pinv(system: Any, q: Any) -> np.ndarray:
    """``A_q^+`` (shape ``(m, n)``) of any kinematic *system* at the configuration *q*, by
    :func:`pinv_solve`."""
    return pinv_solve(jacobian(system, q), np.eye(system.n), q, rank_rtol(system))


def configuration_rate(system: Any, q: Any, u: Any) -> np.ndarray:
    """``q_dot = A_q^+ u`` (3.7)/(4.6)/(4.13) in rad/s and m/s of the kinematic *system* at the
    configuration *q* (shape ``(m,)``), for robot velocities u (m/s, shape ``(n,)``)."""
    check_system(system)
    q = as_vector(q, system.m, "q")
    u = as_vector(u, system.n, "u")
    return pinv_solve(jacobian(system, q), u, q, rank_rtol(system))


def project(system: Any, q: Any, u: Any) -> np.ndarray:
    """``Pi_q u = A_q A_q^+ u`` (m/s): the closest feasible robot velocity to u (4.4), for the
    kinematic *system* at the configuration *q*."""
    q = as_vector(q, system.m, "q")
    A = jacobian(system, q)
    return A @ pinv_solve(A, as_vector(u, system.n, "u"), q, rank_rtol(system))


def signed_conditioning(system: Any, q: Any) -> float:
    """``sign(det A_q) sigma_min / sigma_max`` of a square system: continuous in q, zero on
    the singular set and of opposite signs on its two sides (so a step that jumps over
    the set changes its sign).  Uses the system's own method when it has one."""
    own = getattr(system, "signed_conditioning", None)
    if own is not None:
        return float(own(q))
    A = jacobian(system, q)
    s = np.linalg.svd(A, compute_uv=False)
    if not s[0] > 0.0:
        return 0.0
    return float(np.sign(np.linalg.det(A)) * s[-1] / s[0])


def _signal_names(system: Any, indexed: bool) -> tuple[list, list, list, list]:
    """``(states, inputs, outputs, noisy outputs)`` of :class:`KinematicPlant`."""
    if not indexed and hasattr(system, "coordinate_names") and hasattr(system, "position_names"):
        coords = list(system.coordinate_names)
        return (coords, [f"u.{c}" for c in system.position_names], [f"q.{c}" for c in coords],
                [f"meas.{c}" for c in coords])
    q = [f"q{i}" for i in range(system.m)]
    return q, [f"u{i}" for i in range(system.n)], q, [f"meas{i}" for i in range(system.m)]


def _noise_std(noise_std, rng, m: int) -> np.ndarray | None:
    """The per-coordinate measurement noise standard deviations, checked, or None."""
    if noise_std is None:
        return None
    std = np.broadcast_to(np.asarray(noise_std, dtype=float), (m,)).copy()
    if not np.all(np.isfinite(std)) or np.any(std < 0):
        raise ValueError(f"noise_std must be finite and non-negative, got {noise_std!r}")
    if rng is None or not isinstance(rng, np.random.Generator):
        raise ValueError(f"noisy measurements need rng=numpy.random.Generator (e.g. sim.rng(name)), got {rng!r}")
    return std


class KinematicPlant(ContinuousSystem):
    """The netcosim plant ``q_dot = A_q^+ u`` (3.4)/(4.5)-(4.6)/(4.13): the robots realise
    ``p_dot = Pi_q u`` (``p_dot = u`` when square), for any kinematic system.

    State q (rad, m); input u (n robot velocities, m/s).  Names: with
    ``indexed=False`` (default) and a system that names its coordinates
    (``coordinate_names``, ``position_names``, as the Fly-crane systems do), states are
    the coordinate names, inputs ``u.<position>`` and outputs ``q.<coordinate>``;
    otherwise states and outputs are ``q0..q{m-1}`` and inputs ``u0..u{n-1}``.

    ``noise_std`` (scalar or per coordinate) adds a Gaussian-noisy copy of q to the
    outputs (``meas.<coordinate>`` or ``meas{i}``) drawn from *rng* (a
    ``numpy.random.Generator``, e.g. ``sim.rng(name)``); each output evaluation draws
    fresh noise.

    Raises :class:`SingularConfigurationError` naming the time (s), q
    and the measure (rank, smallest singular value, condition number) by the one rank
    rule (:func:`rank_rtol`):

    * wherever the integrator evaluates ``A_q^+`` at a configuration the rule calls
      singular (adaptive integrators shrink their steps towards the blow-up of q_dot);
    * with ``singular_event=True`` (default) and a square system, also when a step
      *jumps over* the singular set, as a fixed-step integrator does: the hybrid event
      ``singular_configuration`` watches :func:`signed_conditioning`, the integrator
      locates its zero crossing and the plant raises there.
    """

    def __init__(self, system: Any, *, noise_std=None, rng=None, name: str | None = None,
                 indexed: bool = False, singular_event: bool = True):
        check_system(system)
        self.system = system
        self.rtol = rank_rtol(system)
        states, inputs, outs, meas = _signal_names(system, indexed)
        self.noise_std = _noise_std(noise_std, rng, system.m)
        if self.noise_std is not None:
            self.rng = rng
            outs = outs + meas
        events = ()
        if singular_event and system.n == system.m:
            events = (HybridEvent("singular_configuration", self._signed_conditioning, 0, self._crossed),)
        super().__init__(states=states, inputs=inputs, outputs=outs, events=events,
                         name=name or getattr(system, "name", "plant"))

    def _signed_conditioning(self, t, x, u, params):
        return signed_conditioning(self.system, x)

    def _crossed(self, t, x, u, params):
        q = np.asarray(x, dtype=float)
        sv = np.linalg.svd(jacobian(self.system, q), compute_uv=False)
        rank, smin, cond, _ = conditioning(sv, self.rtol)
        raise SingularConfigurationError(
            f"{self.name}: the trajectory reached a singular configuration at t = {t:.9f} s, "
            f"q = {np.round(q, 9).tolist()}: det A_q changed sign (rank {rank} of {self.system.m} there, "
            f"smallest singular value {smin:.3e}, condition number {cond:.3e})")

    def initial_state(self, q0) -> np.ndarray:
        """x0 = q0 after checking domain (systems with ``check_configuration``) and singularity."""
        check = getattr(self.system, "check_configuration", None)
        if check is not None:
            return check(q0, what="q0")
        q0 = as_vector(q0, self.system.m, "q0")
        check_singular_values(np.linalg.svd(jacobian(self.system, q0), compute_uv=False),
                              f"q0 = {np.round(q0, 12).tolist()}", self.rtol)
        return q0

    def f(self, t, x, u, params):
        """``q_dot = A_q^+ u`` (rad/s, m/s) by :func:`pinv_solve`."""
        try:
            return pinv_solve(jacobian(self.system, x), u[: self.system.n], lambda: _rounded(x), self.rtol)
        except SingularConfigurationError as exc:
            raise SingularConfigurationError(f"{self.name}: at t = {t:.9f} s, {exc}") from None

    def h(self, t, x, u, params):
        """q, and its noisy copy when ``noise_std`` was given (at time *t*, s: unused)."""
        q = np.array(x, dtype=float)
        if self.noise_std is None:
            return q
        return np.concatenate([q, q + self.noise_std * self.rng.standard_normal(q.shape[0])])
