"""The integrals of a linear system over an interval, by Van Loan's block exponentials.

For ``dz = A z dt + dv`` (noise intensity R_c) with cost rate ``z^T Q_c z``, over an
interval of length T (seconds) starting from mean m and covariance P:

* ``Phi(T) = e^{A T}``                                  -- the transition (m <- Phi m);
* ``R(T) = ∫_0^T e^{A s} R_c e^{A^T s} ds``             -- the noise covariance added
  (P <- Phi P Phi^T + R);
* ``Q(T) = ∫_0^T e^{A^T s} Q_c e^{A s} ds``             -- the cost of the initial state
  (J += tr(Q P) + m^T Q m);
* ``J_noise(T) = ∫_0^T tr(Q_c R(s)) ds = tr(R_c ∫_0^T Q(s) ds)`` -- the cost of the
  noise entering during the interval.

Computed exactly (to rounding) with ``scipy.linalg.expm`` of block-triangular matrices
(C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans.
Automatic Control 23(3), 1978, Theorem 1):

* ``expm([[-A, R_c], [0, A^T]] T) = [[F1, G1], [0, F2]]``: ``F2 = Phi^T``, ``R = Phi G1``
  (Phi itself from ``expm(A T)``, which rounds less than the larger block);
* ``expm([[-A^T, I, 0], [0, -A^T, Q_c], [0, 0, A]] T) = [[., ., H], [0, ., G], [0, 0, Phi]]``:
  ``Q = Phi^T G`` and ``∫_0^T Q(s) ds = Phi^T H`` (the block (1,3) is the double
  integral ``∫_0^T ∫_0^s e^{-A^T (T - r)} Q_c e^{A r} dr ds``), as in Jitterbug's and
  JitterTime's ``calcc2d`` and Åström & Wittenmark's sampled loss function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

__all__ = ["IntervalMatrices", "interval_matrices"]


@dataclass(frozen=True)
class IntervalMatrices:
    """The exact transition, noise and cost matrices of one interval length ``T`` (s):
    ``Phi`` = Phi(T), ``R`` = R(T) (noise covariance added), ``Q`` = Q(T) (cost of the
    initial state) and ``J_noise`` = J_noise(T) (cost of the noise entering), as defined in
    the module docstring.

    Examples
    --------
    A scalar integrator (A = 0) with noise intensity 0.5 and cost rate ``2 z^2``, over
    T = 0.8 s: ``Phi = 1``, ``R = 0.5 T = 0.4``, ``Q = 2 T = 1.6`` and
    ``J_noise = 2 * 0.5 * T^2 / 2 = 0.32``.

    >>> import numpy as np
    >>> from netcosim.lq import interval_matrices
    >>> m = interval_matrices(np.zeros((1, 1)), np.array([[0.5]]), np.array([[2.0]]), 0.8)
    >>> m.T, m.Phi.item(), round(m.R.item(), 12), round(m.Q.item(), 12), round(m.J_noise, 12)
    (0.8, 1.0, 0.4, 1.6, 0.32)
    """

    T: float
    Phi: np.ndarray
    R: np.ndarray
    Q: np.ndarray
    J_noise: float


def interval_matrices(A: np.ndarray, R_c: np.ndarray, Q_c: np.ndarray, T: float) -> IntervalMatrices:
    """``Phi(T)``, ``R(T)``, ``Q(T)`` and ``J_noise(T)`` (see the module) for ``T >= 0`` (s)
    of ``dz = A z dt + dv`` with noise intensity *R_c* and cost rate ``z^T Q_c z`` (all n x n);
    the caller has checked the arguments.  T = 0 gives ``(I, 0, 0, 0)`` exactly.

    Examples
    --------
    A double integrator (position, velocity) driven by a white-noise force of intensity 1,
    with cost rate position^2, over T = 1 s.  The closed forms: ``Phi = [[1, T], [0, 1]]``,
    ``R = [[T^3/3, T^2/2], [T^2/2, T]]``, ``Q = [[T, T^2/2], [T^2/2, T^3/3]]`` and
    ``J_noise = ∫_0^T s^3/3 ds = T^4/12``.

    >>> import numpy as np
    >>> from netcosim.lq import interval_matrices
    >>> A = np.array([[0.0, 1.0], [0.0, 0.0]])
    >>> m = interval_matrices(A, np.diag([0.0, 1.0]), np.diag([1.0, 0.0]), 1.0)
    >>> m.Phi.tolist()
    [[1.0, 1.0], [0.0, 1.0]]
    >>> m.R.round(9).tolist(), m.Q.round(9).tolist()
    ([[0.333333333, 0.5], [0.5, 1.0]], [[1.0, 0.5], [0.5, 0.333333333]])
    >>> round(m.J_noise, 9)
    0.083333333
    """
    n = A.shape[0]
    if T == 0.0 or n == 0:
        return IntervalMatrices(T, np.eye(n), np.zeros((n, n)), np.zeros((n, n)), 0.0)
    M1 = np.zeros((2 * n, 2 * n))
    M1[:n, :n] = -A
    M1[:n, n:] = R_c
    M1[n:, n:] = A.T
    E1 = expm(M1 * T)
    Phi = expm(A * T)       # the same as E1[n:, n:].T, without the rounding of the larger block
    R = Phi @ E1[:n, n:]
    M2 = np.zeros((3 * n, 3 * n))
    M2[:n, :n] = -A.T
    M2[:n, n:2 * n] = np.eye(n)
    M2[n:2 * n, n:2 * n] = -A.T
    M2[n:2 * n, 2 * n:] = Q_c
    M2[2 * n:, 2 * n:] = A
    E2 = expm(M2 * T)
    PhiT = Phi.T
    Q = PhiT @ E2[n:2 * n, 2 * n:]
    K = PhiT @ E2[:n, 2 * n:]
    J_noise = float(np.trace(R_c @ K))
    return IntervalMatrices(T, Phi, 0.5 * (R + R.T), 0.5 * (Q + Q.T), J_noise)
