"""What the linear-quadratic analysis returns: named fields, a table, a plot.

:class:`CostTrace` -- the expected cost accumulated along a sequence of events (the
history of a :class:`~netcosim.lq.propagation.Propagator`), plotted as cost against time.
:class:`StationaryCost` -- the stationary cost per unit time of a periodic schedule or of a
Jitterbug timing model.  pandas and matplotlib are imported only by ``to_pandas`` and
``plot``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["CostTrace", "StationaryCost"]


@dataclass(frozen=True)
class CostTrace:
    """The expected cost J (accumulated since the start) and its rate dJ/dt at each
    recorded instant ``time`` (s), with the event that was recorded there (``"start"``,
    ``"advance"``, ``"update <key>"``, ``"impulse"``, ``"jump"``): ``cost`` holds J,
    ``cost_rate`` dJ/dt (cost per second), ``event`` the events, one per instant.

    Examples
    --------
    What :meth:`Propagator.trace <netcosim.lq.propagation.Propagator.trace>` returns: an
    uncontrolled integrator (noise intensity 0.3, cost rate ``2 x^2``) from the mean 1.5,
    whose cost after t seconds is ``2 (1.5^2 t + 0.3 t^2 / 2)``: 1.848 at 0.4 s, 3.792 at 0.8 s.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> plant = lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=0.3, Q_c=np.diag([2.0, 0.0]))
    >>> p = lq.Propagator(lq.Interconnection().add("plant", plant))
    >>> trace = p.impulse([1.5]).pass_time(0.4).pass_time(0.4).trace()
    >>> trace.event
    ('start', 'impulse', 'advance', 'advance')
    >>> trace.cost.round(9).tolist()
    [0.0, 0.0, 1.848, 3.792]
    >>> trace.to_pandas()["cost_rate"].round(9).tolist()
    [0.0, 4.5, 4.74, 4.98]
    """

    time: np.ndarray
    cost: np.ndarray
    cost_rate: np.ndarray
    event: tuple[str, ...]

    def to_pandas(self) -> Any:
        """A DataFrame with columns ``time``, ``cost``, ``cost_rate``, ``event``."""
        import pandas as pd
        return pd.DataFrame({"time": self.time, "cost": self.cost, "cost_rate": self.cost_rate,
                             "event": list(self.event)})

    def plot(self, ax: Any = None, **kw: Any) -> Any:
        """Expected cost against time on *ax* (a new figure if None); returns the axes."""
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots()
        ax.plot(self.time, self.cost, **kw)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("expected cost J")
        return ax


@dataclass(frozen=True)
class StationaryCost:
    """The stationary expected cost of a repeating schedule or a timing model.

    ``cost_rate``: J per second in stationarity (``inf`` when the loop is not mean-square
    stable: ``stable`` is then False and ``note`` says why).  ``period``: the schedule's
    period (s), or the mean time between two entries of node 1 of a timing model (its
    period if periodic).  ``cost_per_period``:
    ``cost_rate * period``.  ``spectral_radius``: of the lifted map over one period (the
    periodic analysis; 1 or more means unstable), or of the mean-square operator estimated
    by the iteration (timing models).  ``covariance``: the stationary covariance of the total state at the
    start of the period (periodic analysis), or per timing state (timing models: a dict).
    ``iterations``: iterations the timing model took (0 for the periodic analysis).

    Examples
    --------
    What :func:`~netcosim.lq.stationary.periodic_cost` returns for an integrator
    ``dx = u dt + dv`` (noise intensity 1, cost rate ``x^2``) sampled every h = 0.1 s under
    the deadbeat gain ``u = -x / h``: ``x(t) = x_k (1 - t/h) + w(t)`` with ``E x_k^2 = h``
    and ``E w(t)^2 = t``, so ``J = (h^2/3 + h^2/2) / h = 5 h / 6`` per second.  A gain three
    times larger maps x_k to ``-2 x_k``: not stable, spectral radius 2.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> def loop(gain):
    ...     return (lq.Interconnection()
    ...             .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...                  inputs="ctrl")
    ...             .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...             .add("ctrl", lq.DiscreteSystem.gain(-gain), inputs="sampler"))
    >>> period = [lq.Execute("sampler"), lq.Execute("ctrl"), lq.Wait(0.1)]
    >>> st = lq.periodic_cost(loop(10.0), period)
    >>> st.stable, round(st.cost_rate, 9), round(5 * 0.1 / 6, 9), round(st.cost_per_period, 9)
    (True, 0.083333333, 0.083333333, 0.008333333)
    >>> bad = lq.periodic_cost(loop(30.0), period)
    >>> bad.stable, bad.cost_rate, round(bad.spectral_radius, 9)
    (False, inf, 2.0)
    """

    cost_rate: float
    period: float
    stable: bool
    spectral_radius: float
    covariance: Any = field(repr=False, default=None)
    iterations: int = 0
    note: str = ""

    @property
    def cost_per_period(self) -> float:
        """``cost_rate * period``: the expected cost of one period (inf if unstable)."""
        return self.cost_rate * self.period if math.isfinite(self.cost_rate) else math.inf

    def to_pandas(self) -> Any:
        """One row: ``cost_rate``, ``cost_per_period``, ``period``, ``stable``, ``spectral_radius``,
        ``iterations``, ``note``."""
        import pandas as pd
        return pd.DataFrame([{"cost_rate": self.cost_rate, "cost_per_period": self.cost_per_period,
                              "period": self.period, "stable": self.stable,
                              "spectral_radius": self.spectral_radius, "iterations": self.iterations,
                              "note": self.note}])
