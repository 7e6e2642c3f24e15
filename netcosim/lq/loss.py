"""The stationary expected cost of a periodic loop whose messages are lost, exactly.

A loop that repeats every ``period`` seconds is described by its **stages**: at offset
``at`` (s) into the period the discrete systems ``execute`` run -- the sampler at 0, the
controller when the measurement arrives, the actuator when the control arrives.  A stage
marked ``lossy`` is reached by a message sent as a frame on a **link** (``Stage.link``;
stages naming the same link share its channel, None: a link of its own).  When the
frame is lost it is sent again up to ``retries`` times, each attempt ``retry_delay``
seconds after the previous one (a retrying MAC: 802.11 unicast; the delay taken as
fixed), which shifts this stage and every later one of the period by that much; when
every attempt is lost the message is lost: that stage and every later one of the same
period do not execute -- the systems keep their state and held output (hold), until the
next period's stages run.

The **channel** of each link is a loss model (``loss``): a probability (independent
frame losses: Bernoulli), or any model that describes itself as a finite Markov chain
stepping once per frame on its link (``markov()``: :class:`~netcosim.network.Bernoulli`,
:class:`~netcosim.network.GilbertElliott` bursts, :class:`~netcosim.network.AnyLoss` of
those) -- the same models, with the same per-link, per-frame semantics, as a network's
``loss=`` in the simulation.  A channel only steps when a frame is sent: a message that
is never sent (its stage was not reached) does not move it.  ``loss`` may also map link
names to models.

The loss pattern makes the loop a Markov jump linear system (the mode: how far the
period's chain of messages got, and the channels' states).  :func:`loss_model` builds it
as a Jitterbug :class:`~netcosim.lq.timing.TimingModel` -- per stage, attempt and joint
channel state a timing node, from it a branch to the next stage (the frame arrived) or to
the next attempt or to a "lost" node (no execution, wait for the period's end), with the
channel's probabilities; the channels' states pass to the next period through its start
node -- and :func:`loss_cost` returns its exact stationary cost per second: the
expectation over the plant noise *and* over the loss realisations, no Monte Carlo.
:func:`loss_cost_curve` does it for several losses (a cost-versus-loss curve in one call).
The result is the long-run (stationary) cost; a channel's initial state matters only if
its chain is reducible, and then its most likely initial state is taken.

The time grain of the timing model is the largest one on which the period, every stage
offset and every retry delay lie (found on the simulator's 1 ps grid), unless ``delta``
is given.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Hashable, Iterable, Mapping, Sequence

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
    """At ``at`` seconds into the period the discrete systems ``execute`` run, if the
    message that triggers them arrived (``lossy``) or always (``lossy=False``).

    ``at`` is the offset when every earlier message arrived at its first attempt.
    ``link``: the link the message is sent on (stages on one link share its channel;
    None: a link of its own).  ``retries``: how many times a lost frame is sent again
    (0: sent once); ``retry_delay``: seconds from one attempt's arrival time to the next's.

    Raises
    ------
    ConfigurationTypeError
        ``at``, ``retries`` or ``retry_delay`` is not a number.
    ConfigurationError
        ``at`` or ``retry_delay`` is negative or not finite, ``retries`` is negative or not
        an integer, or a stage with ``lossy=False`` is given ``retries`` or a ``link``.

    Examples
    --------
    The deadbeat-controlled integrator of :func:`loss_cost`: the sampler runs at the start
    of every period, the controller when the measurement's frame arrives.  With one retry
    sent at once a message is lost with probability ``0.2**2 = 0.04`` when frames are lost
    with 0.2, so its cost is that of a single attempt at loss 0.04; a retry 10 ms later
    costs a little more (the control comes late).

    >>> import numpy as np
    >>> from netcosim import lq
    >>> h = 0.1
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...              inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    >>> sample = lq.Stage(0.0, "sampler", lossy=False)
    >>> def cost(control, loss):
    ...     return round(lq.loss_cost(loop, h, [sample, control], loss).cost_rate, 6)
    >>> cost(lq.Stage(0.0, "ctrl", retries=1), 0.2), cost(lq.Stage(0.0, "ctrl"), 0.04)
    (0.090909, 0.090909)
    >>> cost(lq.Stage(0.0, "ctrl", retries=1, retry_delay=0.01), 0.2)
    0.092873
    >>> lq.Stage(0.0, "sampler", lossy=False, retries=1)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: Stage at 0.0 s: retries and link are for a lossy stage ...
    """

    at: float
    execute: tuple[Hashable, ...] = field(default=())
    lossy: bool = True
    link: Hashable = None
    retries: int = 0
    retry_delay: float = 0.0

    def __post_init__(self) -> None:
        validate.non_negative(self.at, "Stage: at", kind="a non-negative offset in seconds")
        ex = self.execute
        if isinstance(ex, (str, bytes)) or not isinstance(ex, Iterable):
            ex = (ex,)
        object.__setattr__(self, "execute", tuple(ex))
        validate.count(self.retries, "Stage: retries")
        validate.non_negative(self.retry_delay, "Stage: retry_delay", kind="a non-negative number of seconds")
        if not self.lossy and (self.retries or self.link is not None):
            raise ConfigurationError(f"Stage at {self.at!r} s: retries and link are for a lossy stage "
                                     f"(reached by a message), got lossy=False with retries={self.retries!r}, "
                                     f"link={self.link!r}")


def _grain(period: float, offsets: Sequence[float]) -> float:
    ticks = [round(t / PICOSECOND) for t in (period, *offsets)]
    g = 0
    for k in ticks:
        g = math.gcd(g, k)
    return g * PICOSECOND


def _chain(loss: Any, link: Hashable) -> tuple[np.ndarray, np.ndarray, int]:
    """(transition, per-state loss, start state) of the channel *loss* on *link*."""
    what = f"loss_cost: loss of link {link!r}"
    if validate.is_real(loss):
        p = validate.probability(loss, f"{what} (frame loss probability)")
        return np.ones((1, 1)), np.array([p]), 0
    chain = loss.markov() if callable(getattr(loss, "markov", None)) else None
    if chain is None:
        raise ConfigurationTypeError(f"{what} must be a probability or a loss model that is a finite Markov "
                                     f"chain (Bernoulli, GilbertElliott, AnyLoss of those), got {show(loss)}; "
                                     f"for another channel, run the simulation and use ExpectedCost along it")
    P, lo, init = (np.asarray(a, dtype=float) for a in (chain.transition, chain.loss, chain.initial))
    return P, lo, int(np.argmax(init))


def loss_model(model: Interconnection, period: float, stages: Sequence[Stage], loss: Any,
               delta: float | None = None) -> TimingModel:
    """The :class:`TimingModel` of *stages* repeated every *period* seconds, their messages
    lost by *loss* (a frame loss probability, a Markov loss model, or a mapping from link
    to those; see the module); ``delta``: its time grain (s), None to find it."""
    h = validate.positive(period, "loss_cost: period", kind="a positive number of seconds")
    st = list(stages)
    if not st or not all(isinstance(s, Stage) for s in st):
        raise ConfigurationTypeError(f"loss_cost: stages must be a non-empty list of Stage, got {show(stages)}")
    at = [s.at for s in st]
    late = sum(s.retries * s.retry_delay for s in st)
    if any(b < a for a, b in zip(at, at[1:])) or at[-1] + late >= h:
        raise ConfigurationError(f"loss_cost: the stage offsets must be non-decreasing and, with every retry "
                                 f"({late!r} s), below the period {h!r} s, got {at}")
    links = list(dict.fromkeys((s.link if s.link is not None else ("stage", i))
                               for i, s in enumerate(st) if s.lossy))
    of = {i: links.index(s.link if s.link is not None else ("stage", i)) for i, s in enumerate(st) if s.lossy}
    if isinstance(loss, Mapping):
        missing = [lk for lk in links if lk not in loss and not isinstance(lk, tuple)]
        if missing or any(isinstance(lk, tuple) for lk in links):
            raise ConfigurationError(f"loss_cost: a loss mapping needs every lossy stage to name its link and "
                                     f"the mapping to give each link's loss; links {links}, given {list(loss)}")
        chains = [_chain(loss[lk], lk) for lk in links]
    else:
        chains = [_chain(loss, lk) for lk in links]
    d = _grain(h, at + [s.retry_delay for s in st if s.retries]) if delta is None else \
        validate.positive(delta, "loss_cost: delta")
    steps = [round(a / d) for a in at]
    retry = [round(s.retry_delay / d) for s in st]
    if any(abs(k * d - a) > 1e-9 * h for k, a in zip(steps + retry, at + [s.retry_delay for s in st])):
        raise ConfigurationError(f"loss_cost: the stage offsets {at} and retry delays do not lie on the grain "
                                 f"delta = {d!r} s")
    tm = TimingModel(model, delta=d, period=h)
    joint = list(itertools.product(*(range(P.shape[0]) for P, _, _ in chains)))
    start = tuple(c for _, _, c in chains)
    joint.remove(start)
    joint.insert(0, start)                  # node 1: the start node of the channels' start states
    for cs in joint:
        tm.add_node(("start", cs), delay=_pmf(steps[0]), next=[_arrival(st, 0, cs)])
    for i, s in enumerate(st):
        for cs in joint:
            if i + 1 < len(st):
                tm.add_node((i, cs), delay=_pmf(steps[i + 1] - steps[i]), next=[_arrival(st, i + 1, cs)],
                            execute=s.execute)
            else:
                tm.add_node((i, cs), execute=s.execute, then=("start", cs))
            if not s.lossy:
                continue
            P, lo, _ = chains[of[i]]
            c = cs[of[i]]
            for j in range(s.retries + 1):
                nxt, prob = [], []
                for c2 in range(P.shape[0]):
                    moved = cs[:of[i]] + (c2,) + cs[of[i] + 1:]
                    nxt += [(i, moved), ("retry", i, j + 1, moved) if j < s.retries else ("lost", i, moved)]
                    prob += [(1.0 - lo[c]) * P[c, c2], lo[c] * P[c, c2]]
                tm.add_node(("try", i, j, cs), next=nxt, probabilities=prob)
                if j:
                    tm.add_node(("retry", i, j, cs), delay=_pmf(retry[i]), next=[("try", i, j, cs)])
            tm.add_node(("lost", i, cs), then=("start", cs))
    return tm


def _pmf(k: int) -> np.ndarray:
    pmf = np.zeros(k + 1)
    pmf[-1] = 1.0
    return pmf


def _arrival(st: list[Stage], i: int, cs: tuple) -> tuple:
    return ("try", i, 0, cs) if st[i].lossy else (i, cs)


def loss_cost(model: Interconnection, period: float, stages: Sequence[Stage], loss: Any,
              delta: float | None = None) -> StationaryCost:
    """The exact stationary expected cost per second of *model* under *stages* repeated
    every *period* seconds, their messages lost by *loss*: a frame loss probability
    (Bernoulli), a Markov loss model (e.g. :class:`~netcosim.network.GilbertElliott`) or a
    mapping from link to those (hold on loss; see the module).  ``cost_rate`` is ``inf``
    (``stable=False``) when the loop is not mean-square stable under that loss.  ``delta``:
    the timing model's time grain (s), None to find it (:func:`loss_model`).

    Raises
    ------
    ConfigurationTypeError
        *stages* is not a non-empty list of :class:`Stage`; a loss is neither a probability
        nor a loss model that is a finite Markov chain; *period* or ``delta`` is not a
        number.
    ConfigurationError
        *period* or ``delta`` is not positive; the stage offsets decrease or, with every
        retry, reach the period; a loss mapping misses a link or a lossy stage names no
        link; a probability outside [0, 1]; offsets that do not lie on the grain ``delta``;
        a stage executes a system that is not a discrete system of *model*.

    Examples
    --------
    An integrator ``dx = u dt + dv`` (noise intensity r = 1, cost rate ``x^2``) sampled
    every h = 0.1 s under the deadbeat gain ``u = -x / h``, the control's frame lost with
    probability p (the actuator then holds the last control).  Solving the jump system's
    second moments by hand gives ``J = r h ((1 + 2p) / (3 (1 - 3p)) + 1/2)`` per second:
    ``5 r h / 6`` without loss, twice that at p = 0.2.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> h = 0.1
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...              inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    >>> stages = [lq.Stage(0.0, "sampler", lossy=False), lq.Stage(0.0, "ctrl")]
    >>> cost = lq.loss_cost(loop, h, stages, 0.2)
    >>> cost.stable, round(cost.cost_rate, 6), round(h * ((1 + 2 * 0.2) / (3 * (1 - 3 * 0.2)) + 0.5), 6)
    (True, 0.166667, 0.166667)

    Losses in bursts cost more than independent ones at the same rate.  A
    :class:`~netcosim.network.GilbertElliott` channel that loses every frame in its bad
    state, entered with probability 0.05 and left with 0.45 per frame, loses 10 % of the
    frames in bursts of 1 / 0.45 = 2.2 frames on average; with 0.1 and 0.9 it forgets its
    state at every frame and is Bernoulli loss of 0.1:

    >>> from netcosim.network import GilbertElliott
    >>> def bursty(enter, leave):
    ...     return round(lq.loss_cost(loop, h, stages, GilbertElliott(p_gb=enter, p_bg=leave)).cost_rate, 6)
    >>> round(lq.loss_cost(loop, h, stages, 0.1).cost_rate, 6), bursty(0.1, 0.9), bursty(0.05, 0.45)
    (0.107143, 0.107143, 0.23)
    """
    return loss_model(model, period, stages, loss, delta).cost()


def loss_cost_curve(model: Interconnection, period: float, stages: Sequence[Stage], losses: Iterable[Any],
                    delta: float | None = None) -> np.ndarray:
    """:func:`loss_cost`'s ``cost_rate`` for each loss of *losses* (probabilities or loss
    models; cost per second, ``inf`` where not mean-square stable), with the same *model*,
    *period* (s), *stages* and *delta* (s) for every one.

    Examples
    --------
    The deadbeat-controlled integrator of :func:`loss_cost`, whose cost
    ``r h ((1 + 2p) / (3 (1 - 3p)) + 1/2)`` doubles at p = 0.2 and has no stationary value
    from p = 1/3 on (the loop is not mean-square stable):

    >>> import numpy as np
    >>> from netcosim import lq
    >>> h = 0.1
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...              inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    >>> stages = [lq.Stage(0.0, "sampler", lossy=False), lq.Stage(0.0, "ctrl")]
    >>> lq.loss_cost_curve(loop, h, stages, [0.0, 0.2, 0.3, 0.4]).round(6).tolist()
    [0.083333, 0.166667, 0.583333, inf]
    """
    return np.array([loss_cost(model, period, stages, p, delta).cost_rate for p in losses])
