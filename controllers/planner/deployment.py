"""What a planner deployment (:func:`netcosim.controllers.planner.tasks.deploy`) built and recorded.

Every computation of a task leaves one typed record (named fields, no optional keys):

* :class:`PlannerRecord` -- the centralized planner on the pivot (whole q, u, gain k);
* :class:`PoseRecord` -- the sparse architecture's pivot reading and sending its pose q_V;
* :class:`CommandRecord` -- a robot computing (sparse) or receiving (centralized) its command.

:meth:`Deployment.response` assembles them into a :class:`PlannerResponse`, one row per
sample h, with ``.to_pandas()`` and ``.plot()`` (as python-control's ``TimeResponseData``).
Units: t in s, q in rad and m, u in m/s, k in 1/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .structure import StarStructure

__all__ = ["PlannerRecord", "PoseRecord", "CommandRecord", "PlannerResponse", "Deployment"]


class _Fields:
    """``record["name"]`` reads field ``name`` (records were dicts before; kept for old code)."""

    def __getitem__(self, name: str):
        if name not in self._names():
            raise KeyError(name)
        return getattr(self, name)

    def __contains__(self, name: str) -> bool:
        return name in self._names()

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


@dataclass(frozen=True)
class PlannerRecord(_Fields):
    """One sample of the centralized planner: ``q`` read at the nominal sample time ``t``
    = hT (s), gain ``k`` (1/s), feedback ``u`` (m/s, all robots); ``t_done`` (s): when
    the commands left; ``node``: the name of the node that computed it; ``h``: the sample
    index."""

    node: str
    h: int
    t: float
    t_done: float
    q: np.ndarray
    u: np.ndarray
    k: float


@dataclass(frozen=True)
class PoseRecord(_Fields):
    """One sample of the sparse architecture's pivot: its pose ``q_V`` read at ``t`` = hT (s)
    and sent to every robot at ``t_done`` (s); ``node``: the pivot node's name; ``h``: the
    sample index."""

    node: str
    h: int
    t: float
    t_done: float
    q_V: np.ndarray


@dataclass(frozen=True)
class CommandRecord(_Fields):
    """Robot ``robot`` (0-based) applying the feedback ``u_i`` (m/s) of sample h (nominal
    time ``t`` = hT, s) at ``t_done`` (s).  In the sparse architecture the robot read its
    own ``q_i`` and used the offline gain ``k`` (1/s); in the centralized one it received
    ``u_i`` and ``q_i`` is empty, ``k`` NaN.  ``node``: the name of the node that computed
    it; ``h``: the sample index."""

    node: str
    robot: int
    h: int
    t: float
    t_done: float
    u_i: np.ndarray
    q_i: np.ndarray = field(default_factory=lambda: np.zeros(0))
    k: float = math.nan


@dataclass(frozen=True)
class PlannerResponse:
    """The sample sequence of a deployment, one entry per sample h, as read and computed
    by the tasks (the feedback part of the commands).

    ``h`` (H,), ``t`` (H,) nominal sample times hT (s), ``k`` (H,) gain (1/s; NaN where no
    task computed one), ``q`` (H, m) configuration (rad, m), ``u`` (H, n) robot velocities
    (m/s).  Entries no task recorded are NaN.
    """

    h: np.ndarray
    t: np.ndarray
    k: np.ndarray
    q: np.ndarray
    u: np.ndarray

    def to_pandas(self):
        """``pandas.DataFrame`` with columns ``h``, ``t``, ``k``, ``q0..q{m-1}``, ``u0..u{n-1}``."""
        import pandas as pd

        m, n = self.q.shape[1], self.u.shape[1]
        rows = [(int(h), float(t), float(k), *q, *u) for h, t, k, q, u in zip(self.h, self.t, self.k, self.q, self.u)]
        return pd.DataFrame(rows, columns=["h", "t", "k"] + [f"q{i}" for i in range(m)] + [f"u{i}" for i in range(n)])

    def plot(self, axes=None):
        """Plot q and u (stairs, held over each period) against t (s) on *axes*, a pair of matplotlib
        axes (None: a new figure); returns the two axes."""
        import matplotlib.pyplot as plt

        if axes is None:
            _, axes = plt.subplots(2, 1, sharex=True)
        ax_q, ax_u = axes
        ax_q.plot(self.t, self.q, marker=".")
        ax_q.set_ylabel("q (rad, m)")
        ax_u.step(self.t, self.u, where="post")
        ax_u.set_ylabel("u (m/s)")
        ax_u.set_xlabel("t (s)")
        return axes


class _Sample:
    """Accumulates the records of one sample h into one row."""

    def __init__(self, r, m: int, n: int):
        self.t, self.k = r.t, math.nan
        self.q, self.u = np.full(m, math.nan), np.full(n, math.nan)

    def add(self, r, st: StarStructure) -> None:
        if isinstance(r, PlannerRecord):
            self.q[:], self.u[:], self.k = r.q, r.u, r.k
        elif isinstance(r, PoseRecord):
            self.q[list(st.pivot)] = r.q_V
        else:
            if r.q_i.size:
                self.q[list(st.cols[r.robot])] = r.q_i
                self.k = r.k
            self.u[list(st.rows[r.robot])] = r.u_i


@dataclass
class Deployment:
    """What :func:`~netcosim.controllers.planner.tasks.deploy` built: the plant, nodes, network and
    the records of every computation (:class:`PlannerRecord`, :class:`PoseRecord`,
    :class:`CommandRecord`, in the order they completed): ``sim``, ``plant``, the ``pivot``
    node and the ``robots``' nodes, the ``network``, the ``architecture`` (``"sparse"`` or
    ``"centralized"``), the planner ``law`` and the :class:`StarStructure` ``structure``."""

    sim: Any
    plant: Any
    pivot: Any
    robots: list
    network: Any
    architecture: str
    law: Any
    structure: StarStructure
    records: list = field(default_factory=list)

    def response(self) -> PlannerResponse:
        """The records assembled into one row per sample h (see :class:`PlannerResponse`)."""
        st = self.structure
        by_h: dict[int, _Sample] = {}
        for r in self.records:
            by_h.setdefault(r.h, _Sample(r, st.m, st.n)).add(r, st)
        hs = sorted(by_h)
        rows = [by_h[h] for h in hs]
        return PlannerResponse(np.asarray(hs, dtype=int), np.array([s.t for s in rows], dtype=float),
                               np.array([s.k for s in rows], dtype=float),
                               np.array([s.q for s in rows], dtype=float).reshape(len(rows), st.m),
                               np.array([s.u for s in rows], dtype=float).reshape(len(rows), st.n))

    def to_pandas(self):
        """:meth:`PlannerResponse.to_pandas` of :meth:`response`."""
        return self.response().to_pandas()

    def samples(self):
        """One row per sample h: ``h``, ``t`` (hT, s), ``k`` (1/s), ``q0..``, ``u0..`` as read
        and computed by the tasks (the feedback part of the command); same as :meth:`to_pandas`."""
        return self.to_pandas()

    def plot(self, axes=None):
        """:meth:`PlannerResponse.plot` of :meth:`response` (on *axes*, None: new ones)."""
        return self.response().plot(axes)
