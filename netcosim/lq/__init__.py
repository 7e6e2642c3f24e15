"""Linear-quadratic analysis: the exact expected cost of a control loop, without Monte Carlo.

A Python counterpart of Lund's JitterTime and Jitterbug, on numpy/scipy only (see
``docs/lq.md``):

* :mod:`~netcosim.lq.systems` -- :class:`ContinuousSystem` (plants, white noise R_c, cost
  Q_c), :class:`DiscreteSystem` (samplers, controllers, holds), :class:`Interconnection`;
* :mod:`~netcosim.lq.integrals` -- Van Loan's exact interval matrices;
* :mod:`~netcosim.lq.propagation` -- :class:`Propagator`: mean, covariance and expected
  cost event by event (``advance(t)``, ``update(key)``, impulses, reset maps);
* :mod:`~netcosim.lq.stationary` -- :func:`periodic_cost` of a repeating schedule
  (:class:`Wait`, :class:`Execute`);
* :mod:`~netcosim.lq.timing` -- :class:`TimingModel`, Jitterbug's Markov chain of timing
  nodes (random delays, dropouts);
* :mod:`~netcosim.lq.along` -- :class:`ExpectedCost`: the propagator driven by a simulation's
  clock, from inside its tasks (the expected cost along a simulated schedule);
* :mod:`~netcosim.lq.loss` -- :func:`loss_cost`, :func:`loss_cost_curve`: the stationary
  cost under Bernoulli message loss, exactly (a Markov jump linear system);
* :mod:`~netcosim.lq.result` -- :class:`CostTrace`, :class:`StationaryCost`.

This package imports no simulation module (kernel, networks, SimPy): a kernel coupling
drives a :class:`Propagator` from outside.
"""

from .along import ExpectedCost
from .integrals import IntervalMatrices, interval_matrices
from .loss import Stage, loss_cost, loss_cost_curve
from .propagation import Propagator
from .result import CostTrace, StationaryCost
from .stationary import Execute, Wait, periodic_cost
from .systems import ContinuousSystem, DiscreteSystem, Interconnection, TotalDynamics
from .timing import TimingModel

__all__ = ["ContinuousSystem", "DiscreteSystem", "Interconnection", "TotalDynamics",
           "IntervalMatrices", "interval_matrices", "Propagator", "CostTrace", "StationaryCost",
           "Wait", "Execute", "periodic_cost", "TimingModel",
           "ExpectedCost", "Stage", "loss_cost", "loss_cost_curve"]
