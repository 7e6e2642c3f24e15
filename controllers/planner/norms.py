"""Weighted norms of configuration errors (ch. 3 and 4)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["WeightedNorm"]


@dataclass(frozen=True)
class WeightedNorm:
    """``||e||_{D,p} = ||D e||_p`` with ``D = diag(weights)``, ``p`` in {2, inf} (ch. 4).

    ``weights=None`` is the Euclidean (or max) norm of ch. 3.  The weights multiply the
    error components (e.g. ``D = diag(I_4, 4 I_6)`` of Sec. 4.6 weighs pose errors 4x).
    """

    weights: tuple[float, ...] | None = None
    p: float = 2

    def __post_init__(self):
        if self.p not in (2, math.inf):
            raise ValueError(f"norm order p must be 2 or inf, got {self.p!r}")
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=float).reshape(-1)
            if not np.all(np.isfinite(w)) or np.any(w <= 0):
                raise ValueError(f"norm weights must be positive and finite, got {w.tolist()}")
            object.__setattr__(self, "weights", tuple(float(x) for x in w))

    @classmethod
    def of(cls, norm: "WeightedNorm | float | str | None") -> "WeightedNorm":
        """Coerce *norm*: ``None`` / ``2`` / ``"inf"`` / ``math.inf`` / a WeightedNorm."""
        if norm is None:
            return cls()
        if isinstance(norm, WeightedNorm):
            return norm
        if isinstance(norm, str):
            if norm.lower() in ("inf", "infinity", "max"):
                return cls(p=math.inf)
            if norm == "2":
                return cls()
        if norm in (2, math.inf):
            return cls(p=norm)
        raise ValueError(f"unknown norm {norm!r}; use 2, 'inf' or a WeightedNorm")

    def w(self, m: int) -> np.ndarray:
        """The weights as a length-*m* array (ones without weights; ``ValueError`` for another length)."""
        if self.weights is None:
            return np.ones(m)
        if len(self.weights) != m:
            raise ValueError(f"norm has {len(self.weights)} weights, the configuration has {m} entries")
        return np.asarray(self.weights)

    def __call__(self, e: np.ndarray) -> float:
        e = np.asarray(e, dtype=float)
        x = e if self.weights is None else self.w(e.shape[-1]) * e
        if self.p == 2:
            return float(np.sqrt(np.dot(x, x)))
        return float(np.max(np.abs(x)))

    def many(self, E: np.ndarray) -> np.ndarray:
        """Norms of the rows of *E* (shape ``(k, m)``)."""
        E = np.asarray(E, dtype=float)
        X = E if self.weights is None else E * self.w(E.shape[-1])
        if self.p == 2:
            return np.sqrt(np.einsum("ij,ij->i", X, X))
        return np.max(np.abs(X), axis=1)

    def sample_ball(self, rng: np.random.Generator, m: int, radius: float, size: int) -> np.ndarray:
        """*size* points drawn uniformly in ``{e : ||e|| < radius}`` (shape ``(size, m)``) from
        *rng* (a ``numpy.random.Generator``)."""
        if self.p == 2:
            x = rng.standard_normal((size, m))
            x /= np.linalg.norm(x, axis=1, keepdims=True)
            x *= radius * rng.random((size, 1)) ** (1.0 / m)
        else:
            x = rng.uniform(-radius, radius, (size, m))
        return x / self.w(m)
