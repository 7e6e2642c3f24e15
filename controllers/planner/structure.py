"""Star structure of the multi-robot systems: which entries of p and q belong to which robot (3.3)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .kinematics import check_system

__all__ = ["StarStructure"]


@dataclass(frozen=True)
class StarStructure:
    """Which rows of ``p`` and columns of ``q`` belong to each robot, and the pivot's columns.

    ``rows[i]``: indices of robot *i*'s entries of ``p`` (``p_i``);
    ``cols[i]``: indices of ``q_i`` (its cable angles, may be empty);
    ``pivot``: indices of ``q_V`` (pivot pose).  Robot *i*'s rows of ``A_q`` are zero
    outside ``cols[i]`` and ``pivot`` (3.3).
    """

    rows: tuple[tuple[int, ...], ...]
    cols: tuple[tuple[int, ...], ...]
    pivot: tuple[int, ...]

    def __post_init__(self):
        if len(self.rows) != len(self.cols) or not self.rows:
            raise ValueError(f"need one row set and one column set per robot, got {len(self.rows)} and "
                             f"{len(self.cols)}")
        object.__setattr__(self, "rows", tuple(tuple(int(i) for i in r) for r in self.rows))
        object.__setattr__(self, "cols", tuple(tuple(int(i) for i in c) for c in self.cols))
        object.__setattr__(self, "pivot", tuple(int(i) for i in self.pivot))
        allc = [c for cs in self.cols for c in cs] + list(self.pivot)
        if len(set(allc)) != len(allc):
            raise ValueError(f"robot and pivot columns overlap: {self.cols}, {self.pivot}")
        allr = [r for rs in self.rows for r in rs]
        if len(set(allr)) != len(allr):
            raise ValueError(f"robot rows overlap: {self.rows}")

    @property
    def N(self) -> int:
        """Number of robots."""
        return len(self.rows)

    @property
    def n(self) -> int:
        """The length of ``p`` (all robots' entries)."""
        return sum(len(r) for r in self.rows)

    @property
    def m(self) -> int:
        """The length of ``q`` (every robot's ``q_i`` and the pivot's ``q_V``)."""
        return sum(len(c) for c in self.cols) + len(self.pivot)

    @classmethod
    def uniform(cls, N: int, n_i: int = 3, m_i: int = 1, m_V: int = 6) -> "StarStructure":
        """``p = [p_1..p_N]`` with ``n_i`` entries each, ``q = [q_1..q_N, q_V]`` (Fly-crane layout):
        *N* robots (>= 1) of ``m_i`` coordinates each (>= 0) and a pivot of ``m_V`` (>= 1)."""
        if N < 1 or n_i < 1 or m_i < 0 or m_V < 1:
            raise ValueError(f"invalid structure N={N}, n_i={n_i}, m_i={m_i}, m_V={m_V}")
        rows = tuple(tuple(range(i * n_i, (i + 1) * n_i)) for i in range(N))
        cols = tuple(tuple(range(i * m_i, (i + 1) * m_i)) for i in range(N))
        pivot = tuple(range(N * m_i, N * m_i + m_V))
        return cls(rows, cols, pivot)

    @classmethod
    def for_system(cls, system: Any, m_V: int | None = None) -> "StarStructure":
        """The structure of *system*: its ``structure`` attribute or ``block_indices()``
        if it has one, else the uniform layout with ``N = m - m_V`` one-angle robots (``m_V`` = 6 unless given)."""
        s = getattr(system, "structure", None)
        if isinstance(s, StarStructure):
            return s
        if hasattr(system, "block_indices"):  # netcosim.plants.flycrane.MultiRobotSystem
            rows, cols, pivot = system.block_indices()
            return cls(rows, cols, pivot)
        check_system(system)
        m_V = 6 if m_V is None else m_V
        N = system.m - m_V
        if N < 1 or system.n % N:
            raise ValueError(f"cannot infer a star structure for n={system.n}, m={system.m}, m_V={m_V}; "
                             "pass a StarStructure")
        return cls.uniform(N, system.n // N, 1, m_V)

    def agent_q(self, i: int) -> np.ndarray:
        """Indices of ``(q_i, q_V)`` in ``q``: what robot *i*'s law reads."""
        return np.asarray(self.cols[i] + self.pivot, dtype=int)
