"""The stationary expected cost of a periodic loop whose messages are lost, exactly.

A loop that repeats every ``period`` seconds is described by its **stages**: at offset
``at`` (s) into the period the discrete systems ``execute`` run -- the sampler at 0, the
controller when the measurement arrives, the actuator when the control arrives.  A stage
marked ``lossy`` is reached by a message that is lost with probability p, independently
of every other message (Bernoulli loss): when it is lost, that stage and every later one
of the same period do not execute -- the systems keep their state and held output (hold),
until the next period's stages run.

The loss pattern makes the loop a Markov jump linear system (the mode: how far the
period's chain of messages got).  :func:`loss_cost` builds it as a Jitterbug
:class:`~netcosim.lq.timing.TimingModel` -- per stage a timing node, from it a branch to
the next stage with probability 1 - p and to a "lost" node (no execution, wait for the
period's end) with probability p -- and returns its exact stationary cost per second:
the expectation over the plant noise *and* over the loss realisations, no Monte Carlo.
:func:`loss_cost_curve` does it for several p (a cost-versus-loss curve in one call).

The time grain of the timing model is the largest one on which the period and every
stage offset lie (found on the simulator's 1 ps grid), unless ``delta`` is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Hashable, Iterable, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from .matrices import show
from .result import StationaryCost
from .systems import Interconnection
from .timing import TimingModel

__all__ = ["Stage", "loss_model", "loss_cost", "loss_cost_curve"]

#: the grid (s) on which stage offsets are located when delta is not given
PICOSECOND = 1e-12


@dataclass(frozen=True)
class Stage:
    """At ``at`` seconds into the period, the discrete systems ``execute`` run, if the
    message that triggers them arrived (``lossy``) or always (``lossy=False``)."""

    at: float
    execute: tuple[Hashable, ...] = field(default=())
    lossy: bool = True

    def __post_init__(self) -> None:
        validate.non_negative(self.at, "Stage: at", kind="a non-negative offset in seconds")
        ex = self.execute
        if isinstance(ex, (str, bytes)) or not isinstance(ex, Iterable):
            ex = (ex,)
        object.__setattr__(self, "execute", tuple(ex))


def _grain(period: float, offsets: Sequence[float]) -> float:
    ticks = [round(t / PICOSECOND) for t in (period, *offsets)]
    g = 0
    for k in ticks:
        g = math.gcd(g, k)
    return g * PICOSECOND


def loss_model(model: Interconnection, period: float, stages: Sequence[Stage], loss: float,
               delta: float | None = None) -> TimingModel:
    """The :class:`TimingModel` of *stages* repeated every *period* seconds under Bernoulli
    message loss *loss* (a probability); ``delta``: its time grain (s), None to find it."""
    h = validate.positive(period, "loss_cost: period", kind="a positive number of seconds")
    p = validate.probability(loss, "loss_cost: loss (message loss probability)")
    st = list(stages)
    if not st or not all(isinstance(s, Stage) for s in st):
        raise ConfigurationTypeError(f"loss_cost: stages must be a non-empty list of Stage, got {show(stages)}")
    at = [s.at for s in st]
    if any(b < a for a, b in zip(at, at[1:])) or at[-1] >= h:
        raise ConfigurationError(f"loss_cost: the stage offsets must be non-decreasing and below the period "
                                 f"{h!r} s, got {at}")
    d = _grain(h, at) if delta is None else validate.positive(delta, "loss_cost: delta")
    steps = [round(a / d) for a in at]
    if any(abs(k * d - a) > 1e-9 * h for k, a in zip(steps, at)):
        raise ConfigurationError(f"loss_cost: the stage offsets {at} do not lie on the grain delta = {d!r} s")
    tm = TimingModel(model, delta=d, period=h)
    nodes: list[tuple[Any, int, tuple, bool]] = []
    if st[0].lossy or steps[0] > 0:
        nodes.append(("start", 0, (), False))
    nodes += [(i, k, s.execute, s.lossy) for i, (s, k) in enumerate(zip(st, steps))]
    for j, (key, k, ex, _) in enumerate(nodes):
        if j + 1 == len(nodes):
            tm.add_node(key, execute=ex)
            continue
        nkey, nk, _, nlossy = nodes[j + 1]
        pmf = np.zeros(nk - k + 1)
        pmf[-1] = 1.0
        if nlossy:
            tm.add_node(key, delay=pmf, next=(nkey, ("lost", nkey)), probabilities=(1.0 - p, p), execute=ex)
        else:
            tm.add_node(key, delay=pmf, next=nkey, execute=ex)
    for key, _, _, lossy in nodes:
        if lossy:
            tm.add_node(("lost", key))
    return tm


def loss_cost(model: Interconnection, period: float, stages: Sequence[Stage], loss: float,
              delta: float | None = None) -> StationaryCost:
    """The exact stationary expected cost per second of *model* under *stages* repeated
    every *period* seconds, each lossy stage's message lost with probability *loss*
    (Bernoulli, hold on loss).  ``cost_rate`` is ``inf`` (``stable=False``) when the loop
    is not mean-square stable at that loss."""
    return loss_model(model, period, stages, loss, delta).cost()


def loss_cost_curve(model: Interconnection, period: float, stages: Sequence[Stage], losses: Iterable[float],
                    delta: float | None = None) -> np.ndarray:
    """:func:`loss_cost`'s ``cost_rate`` for each loss probability of *losses* (cost per
    second; ``inf`` where not mean-square stable)."""
    return np.array([loss_cost(model, period, stages, p, delta).cost_rate for p in losses])
