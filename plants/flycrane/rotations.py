"""Rotation matrices and Euler-angle kinematics of the pivot pose (thesis (B.1)).

The platform orientation is ``R_V^O = R_z(φ_V) R_y(θ_V) R_x(ψ_V)`` (B.1), with the
Euler angles stored in ``q_V`` in the order ``(φ_V, θ_V, ψ_V)``: the *first* angle
rotates about z, the second about the (new) y, the third about the (newest) x
(intrinsic z-y'-x'' sequence).  The thesis calls them roll, pitch and yaw; by (B.1)
the first one is the rotation about the vertical.  The representation is singular
(gimbal lock) at ``cos θ_V = 0``.

Every function accepts CasADi symbols (SX/MX) or numbers; with numbers it returns a
CasADi ``DM`` (use ``np.asarray``).
"""

from __future__ import annotations

import casadi as ca

__all__ = ["rot_x", "rot_y", "rot_z", "rot_2d", "euler_zyx", "body_rate_matrix", "skew", "vee"]


def rot_x(a):
    """Rotation by *a* [rad] about x."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(a):
    """Rotation by *a* [rad] about y."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot_z(a):
    """Rotation by *a* [rad] about z."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def rot_2d(a):
    """Planar rotation by *a* [rad] (counter-clockwise)."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))


def euler_zyx(phi, theta, psi):
    """``R_V^O = R_z(φ) R_y(θ) R_x(ψ)`` of (B.1): maps platform-frame vectors to the world; the
    angles *phi* (φ, about z), *theta* (θ, about y) and *psi* (ψ, about x) in rad."""
    return rot_z(phi) @ rot_y(theta) @ rot_x(psi)


def body_rate_matrix(theta, psi):
    """``E`` with ``ω_V = E(θ, ψ) [φ̇, θ̇, ψ̇]ᵀ``: the angular velocity of F_V in F_V (*theta* = θ,
    *psi* = ψ, rad).

    For R = R_z(φ) R_y(θ) R_x(ψ): ω = R_xᵀ R_yᵀ e_z φ̇ + R_xᵀ e_y θ̇ + e_x ψ̇, i.e.

        E = [[-sin θ,          0,      1],
             [ cos θ sin ψ,  cos ψ,   0],
             [ cos θ cos ψ, -sin ψ,   0]].

    (The thesis writes ω_V = [φ̇, θ̇, ψ̇]ᵀ in B.1.2, which holds only near θ = ψ = 0;
    the exact map is used here.)  det E = -cos θ: singular at gimbal lock.
    """
    ct, st, cp, sp = ca.cos(theta), ca.sin(theta), ca.cos(psi), ca.sin(psi)
    return ca.vertcat(ca.horzcat(-st, 0, 1), ca.horzcat(ct * sp, cp, 0), ca.horzcat(ct * cp, -sp, 0))


def skew(w):
    """The 3×3 matrix ``[w]×`` with ``[w]× v = w × v``."""
    return ca.vertcat(ca.horzcat(0, -w[2], w[1]), ca.horzcat(w[2], 0, -w[0]), ca.horzcat(-w[1], w[0], 0))


def vee(W):
    """Inverse of :func:`skew`: the vector w with ``skew(w) = W`` for a 3 x 3 antisymmetric *W*
    (reads the antisymmetric part's lower entries)."""
    return ca.vertcat(W[2, 1], W[0, 2], W[1, 0])
