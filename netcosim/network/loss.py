"""Random loss models, composable with the physical-layer models.

A loss model decides, frame by frame and link by link, whether a frame that the
physics let through is dropped anyway (a fading dip, interference the model does not
simulate, a recorded channel).  Each directed link (sender, receiver) gets its own
state and its own random stream, so adding a node never changes another link's draws.

Where the draw happens:

* wired networks: at delivery, per receiver (TrueTime's semantics);
* WLAN: at the receiver after a successful decode, *before* the ACK -- a unicast frame
  lost this way is not acknowledged and is retried like any other failed attempt.

A loss model gives *frame* loss (per attempt and receiver).  The *message* loss seen
by the application is the same on networks that send a frame once, and far smaller
on WLAN unicast, which retries: ``p**retry_limit`` for independent losses (see
``retry_limit`` of :class:`~netcosim.network.wlan.WLAN80211b` and "Frame loss and
message loss" in ``docs/networks.md``).  A network's ``message_loss=`` takes the same
models but draws them once per message and link, before medium access (TrueTime's
wireless loss); ``network.stats`` counts both losses (:mod:`netcosim.network.stats`).

Models: :class:`Bernoulli` (independent losses), :class:`GilbertElliott` (a two-state
Markov channel for bursts), :class:`TraceLoss` (replay a recorded 0/1 sequence).
Several models can be combined by passing a list; the frame is lost if any says so.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError, LossTraceExhaustedError


class MaskedLossWarning(UserWarning):
    """A frame loss that the MAC's retries hide almost completely: the expected message loss
    (every attempt lost: ``p**attempts`` for Bernoulli, more with bursts, see
    :meth:`LossModel.consecutive_loss`) is below a tenth of the frame loss ``p``
    (issued once per network, for models that state both)."""


class MarkovChannel(NamedTuple):
    """A loss model as a finite Markov chain, one step per frame on a link: in state i a
    frame is lost with probability ``loss[i]``, then the chain moves by ``transition``
    (row-stochastic, ``transition[i, j]``: i -> j); ``initial``: the distribution of the
    first frame's state.  What :mod:`netcosim.lq.loss` needs for the expected cost over
    loss realisations.

    Examples
    --------
    A Gilbert channel (good: no loss, bad: all lost) that goes bad after 5 % of the frames
    and stays bad for 2 frames on average; from its stationary start two frames in a row
    are lost with probability ``pi_bad (1 - p_bg) = (1/11) 0.5``, five times more than
    two independent losses at the same rate (``(1/11)**2``):

    >>> import numpy as np
    >>> from netcosim.network import MarkovChannel
    >>> chain = MarkovChannel(transition=np.array([[0.95, 0.05], [0.5, 0.5]]),
    ...                       loss=np.array([0.0, 1.0]), initial=np.array([10 / 11, 1 / 11]))
    >>> round(chain.consecutive_loss(2), 6), round((1 / 11) * 0.5, 6), round((1 / 11) ** 2, 6)
    (0.045455, 0.045455, 0.008264)

    Every loss model that is a finite chain gives its own (:meth:`LossModel.markov`):

    >>> from netcosim.network import GilbertElliott
    >>> round(GilbertElliott(p_gb=0.05, p_bg=0.5).markov().consecutive_loss(2), 6)
    0.045455
    """

    transition: np.ndarray
    loss: np.ndarray
    initial: np.ndarray

    def consecutive_loss(self, n: int) -> float:
        """Probability that *n* consecutive frames from ``initial`` are all lost:
        ``initial L (P L)**(n-1) 1``."""
        v = self.initial * self.loss
        for _ in range(n - 1):
            v = (v @ self.transition) * self.loss
        return float(v.sum())


class LossModel:
    """Base class.  :meth:`link` returns the per-link state object with ``lost() -> bool``.

    A model may also state its long-run statistics, which the networks use to note a
    frame loss hidden by retries (:class:`MaskedLossWarning`): :meth:`frame_loss` and
    :meth:`consecutive_loss` (both None: not known, no notice); and itself as a finite
    Markov chain (:meth:`markov`, None: not one), which the expected-cost analysis of
    :mod:`netcosim.lq.loss` uses.

    Examples
    --------
    A model of one's own: every third frame on a link is lost.  :meth:`link` gives each
    directed link its own state object, whose ``lost()`` a network calls once per frame
    and receiver (here at delivery on an ideal link):

    >>> from netcosim import Simulation
    >>> from netcosim.network import IdealLink
    >>> from netcosim.network.loss import LinkLoss, LossModel
    >>> class EveryThird(LossModel):
    ...     def link(self, rng):
    ...         return EveryThirdLink()
    >>> class EveryThirdLink(LinkLoss):
    ...     def __init__(self):
    ...         self.frames = 0
    ...     def lost(self):
    ...         self.frames += 1
    ...         return self.frames % 3 == 0
    >>> sim = Simulation(seed=0)
    >>> net = IdealLink(sim, "link", data_rate=1e6, loss=EveryThird())
    >>> a, b = net.attach("a"), net.attach("b")
    >>> got = []
    >>> _ = b.on_receive(lambda msg: got.append(msg.payload))
    >>> for k in range(9):
    ...     _ = a.send("b", k, size_bits=100)
    >>> sim.run(until=0.01)
    >>> got
    [0, 1, 3, 4, 6, 7]
    >>> net.stats["total"]["message_loss"]
    0.3333333333333333
    """

    def link(self, rng: np.random.Generator) -> "LinkLoss":
        """A fresh per-link state object (a :class:`LinkLoss`) for one directed link, drawing from *rng*."""
        raise NotImplementedError

    def frame_loss(self) -> float | None:
        """Long-run probability that a frame on a link is lost; None when the model cannot say."""
        return None

    def consecutive_loss(self, n: int) -> float | None:
        """Long-run probability that *n* consecutive frames on one link are all lost (what a
        unicast message with *n* attempts suffers when nothing else fails them); None
        when the model cannot say."""
        return None

    def markov(self) -> MarkovChannel | None:
        """The model as a :class:`MarkovChannel` (the same draws as :meth:`link` makes, in
        distribution); None when it is not a finite Markov chain."""
        return None


class LinkLoss:
    """State of one directed link under a loss model."""

    __slots__ = ()

    def lost(self) -> bool:
        """Decide the fate of the next frame on this link: True if it is lost (advances the link's state)."""
        raise NotImplementedError


class _BernoulliLink(LinkLoss):
    __slots__ = ("p", "rng")

    def __init__(self, p, rng):
        self.p, self.rng = p, rng

    def lost(self) -> bool:
        return self.p > 0.0 and self.rng.random() < self.p


class Bernoulli(LossModel):
    """Each frame is lost independently with probability *p*.

    ``loss=p`` on a network is ``loss=Bernoulli(p)``.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        *p* outside [0, 1] or NaN.
    :class:`~netcosim.errors.ConfigurationTypeError`
        *p* not a number.

    Examples
    --------
    The loss rate over 10 000 draws of one link is close to *p* = 0.2:

    >>> import numpy as np
    >>> from netcosim.network import Bernoulli
    >>> link = Bernoulli(0.2).link(np.random.default_rng(1))
    >>> sum(link.lost() for _ in range(10_000)) / 10_000
    0.1999
    >>> round(Bernoulli(0.2).consecutive_loss(3), 6)     # all 3 attempts of a message lost: p**3
    0.008
    """

    def __init__(self, p: float):
        self.p = validate.probability(p, "Bernoulli loss probability p")

    @classmethod
    def _checked(cls, p: float) -> Bernoulli:
        """A Bernoulli(*p*) of a *p* already validated (``as_loss_model``: one check)."""
        model = cls.__new__(cls)
        model.p = p
        return model

    def link(self, rng):
        """An independent Bernoulli(``p``) loss state for one link, drawing from *rng*."""
        return _BernoulliLink(self.p, rng)

    def frame_loss(self) -> float:
        """``p``."""
        return self.p

    def consecutive_loss(self, n: int) -> float:
        """``p**n``."""
        return self.p ** n

    def markov(self) -> MarkovChannel:
        """One state, losing with probability ``p``."""
        return MarkovChannel(np.ones((1, 1)), np.array([self.p]), np.ones(1))

    def __repr__(self):
        return f"Bernoulli(p={self.p})"


class _GELink(LinkLoss):
    __slots__ = ("m", "rng", "bad")

    def __init__(self, m, rng):
        self.m, self.rng = m, rng
        if m.start == "stationary":
            self.bad = bool(rng.random() < m.stationary_bad)
        else:
            self.bad = m.start == "bad"

    def lost(self) -> bool:
        m, rng = self.m, self.rng
        p_loss = m.loss_bad if self.bad else m.loss_good
        lost = p_loss > 0.0 and (p_loss >= 1.0 or rng.random() < p_loss)
        # then the channel moves for the next frame
        if self.bad:
            if rng.random() < m.p_bg:
                self.bad = False
        elif rng.random() < m.p_gb:
            self.bad = True
        return lost


class GilbertElliott(LossModel):
    """Two-state Markov (Gilbert–Elliott) channel, one step per frame on the link.

    ``p_gb``: probability good -> bad after a frame; ``p_bg``: bad -> good.  In the
    good state a frame is lost with probability ``loss_good``, in the bad state with
    ``loss_bad`` (the classical Gilbert channel: 0 and 1).  The sojourn in the bad
    state is geometric with mean ``1 / p_bg`` frames, which with ``loss_bad = 1`` and
    ``loss_good = 0`` is the mean length of a loss burst.  ``start``: ``"stationary"``
    (draw the first state from the stationary distribution), ``"good"`` or ``"bad"``.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        A probability (``p_gb``, ``p_bg``, ``loss_good``, ``loss_bad``) outside [0, 1] or
        NaN; ``start`` not one of the three; ``p_gb = p_bg = 0`` with
        ``start="stationary"`` (no stationary distribution).
    :class:`~netcosim.errors.ConfigurationTypeError`
        A probability that is not a number.

    Examples
    --------
    Bad after 5 % of the frames, bad for 2 frames on average: the long-run loss
    ``p_gb / (p_gb + p_bg) = 1/11``, and 20 000 draws of one link come close to it:

    >>> import numpy as np
    >>> from netcosim.network import GilbertElliott
    >>> ge = GilbertElliott(p_gb=0.05, p_bg=0.5)
    >>> round(ge.loss_rate, 6), ge.mean_burst
    (0.090909, 2.0)
    >>> link = ge.link(np.random.default_rng(1))
    >>> sum(link.lost() for _ in range(20_000)) / 20_000
    0.08955

    On a network: ``IdealLink(sim, "link", loss=ge)`` (one chain per directed link).
    """

    def __init__(self, p_gb: float, p_bg: float, loss_good: float = 0.0, loss_bad: float = 1.0,
                 start: str = "stationary"):
        self.p_gb = validate.probability(p_gb, "Gilbert-Elliott p_gb (good->bad)")
        self.p_bg = validate.probability(p_bg, "Gilbert-Elliott p_bg (bad->good)")
        self.loss_good = validate.probability(loss_good, "Gilbert-Elliott loss_good")
        self.loss_bad = validate.probability(loss_bad, "Gilbert-Elliott loss_bad")
        validate.choice(start, "Gilbert-Elliott start", ("stationary", "good", "bad"))
        if self.p_gb + self.p_bg == 0.0 and start == "stationary":
            raise ConfigurationError("Gilbert-Elliott with p_gb = p_bg = 0 has no stationary distribution; "
                             "pass start='good' or 'bad'")
        self.start = start

    @property
    def stationary_bad(self) -> float:
        """Long-run fraction of frames seen in the bad state: p_gb / (p_gb + p_bg)."""
        return self.p_gb / (self.p_gb + self.p_bg)

    @property
    def loss_rate(self) -> float:
        """Long-run loss probability."""
        b = self.stationary_bad
        return b * self.loss_bad + (1.0 - b) * self.loss_good

    @property
    def mean_burst(self) -> float:
        """Mean number of consecutive frames in the bad state, 1 / p_bg."""
        return math.inf if self.p_bg == 0 else 1.0 / self.p_bg

    def link(self, rng):
        """A two-state Markov loss state for one link (initial state by ``start``), drawing from *rng*."""
        return _GELink(self, rng)

    def frame_loss(self) -> float | None:
        """:attr:`loss_rate` (None when the chain has no stationary distribution)."""
        return None if self.p_gb + self.p_bg == 0.0 else self.loss_rate

    def consecutive_loss(self, n: int) -> float | None:
        """``pi L (P L)**(n-1) 1``: stationary start ``pi``, loss per state ``L``, one
        transition ``P`` after each frame (as :meth:`link` draws them).  Bursts make it far
        larger than ``frame_loss()**n``."""
        if self.p_gb + self.p_bg == 0.0:
            return None
        b = self.stationary_bad
        return self.markov()._replace(initial=np.array([1.0 - b, b])).consecutive_loss(n)

    def markov(self) -> MarkovChannel:
        """States (good, bad), losses (``loss_good``, ``loss_bad``), the initial state by
        ``start`` (stationary: ``(1 - stationary_bad, stationary_bad)``)."""
        P = np.array([[1.0 - self.p_gb, self.p_gb], [self.p_bg, 1.0 - self.p_bg]])
        if self.start == "stationary":
            b = self.stationary_bad
            initial = np.array([1.0 - b, b])
        else:
            initial = np.array([1.0, 0.0]) if self.start == "good" else np.array([0.0, 1.0])
        return MarkovChannel(P, np.array([self.loss_good, self.loss_bad]), initial)

    def __repr__(self):
        return (f"GilbertElliott(p_gb={self.p_gb}, p_bg={self.p_bg}, loss_good={self.loss_good}, "
                f"loss_bad={self.loss_bad})")


class _TraceLink(LinkLoss):
    __slots__ = ("seq", "i", "repeat")

    def __init__(self, seq, repeat):
        self.seq, self.i, self.repeat = seq, 0, repeat

    def lost(self) -> bool:
        if self.i >= len(self.seq):
            if not self.repeat:
                raise LossTraceExhaustedError(f"TraceLoss: recorded loss sequence of {len(self.seq)} frames "
                                              f"exhausted (pass repeat=True to replay it cyclically)")
            self.i = 0
        v = self.seq[self.i]
        self.i += 1
        return v


class TraceLoss(LossModel):
    """Replay a recorded channel: ``sequence[k]`` true/1 means the k-th frame on the link is lost.

    Every link replays the sequence from its start.  ``repeat=True`` cycles through
    it; otherwise running past its end raises
    :class:`~netcosim.errors.LossTraceExhaustedError` (at the frame that finds it exhausted).

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationTypeError`
        *sequence* is a string or not iterable.
    :class:`~netcosim.errors.ConfigurationError`
        *sequence* is empty, not one-dimensional (ragged or nested), or holds a value
        other than 0/1 or a boolean (the message names the first such value).

    Examples
    --------
    A recorded channel that loses the 2nd and 3rd of every 4 frames:

    >>> from netcosim.network import TraceLoss
    >>> trace = TraceLoss([0, 1, 1, 0])
    >>> link = trace.link(None)              # a replay needs no random stream
    >>> [link.lost() for _ in range(6)]
    [False, True, True, False, False, True]
    >>> trace.frame_loss(), trace.consecutive_loss(2)
    (0.5, 0.25)
    >>> TraceLoss([0, 2])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: TraceLoss sequence must contain only 0/1 or booleans, got ...2...
    """

    def __init__(self, sequence: Sequence, repeat: bool = True):
        if isinstance(sequence, (str, bytes)) or not hasattr(sequence, "__iter__"):
            raise ConfigurationTypeError(f"TraceLoss sequence must be a 1-D sequence of 0/1, got {sequence!r}")
        try:
            seq = np.asarray(sequence)
        except ValueError:          # ragged: an entry is itself a sequence
            raise ConfigurationError(f"TraceLoss sequence must be a 1-D sequence of 0/1, got {sequence!r}") \
                from None
        if seq.ndim != 1 or seq.size == 0:
            raise ConfigurationError(
                f"TraceLoss sequence must be a non-empty 1-D sequence of 0/1, got shape {seq.shape}")
        if not np.all((seq == 0) | (seq == 1)):
            bad = seq[~((seq == 0) | (seq == 1))][0]
            raise ConfigurationError(f"TraceLoss sequence must contain only 0/1 or booleans, got {bad!r}")
        self.sequence = tuple(bool(v) for v in seq)
        self.repeat = bool(repeat)

    def link(self, rng):
        """A replay of ``sequence`` for one link, from its start (*rng* is not used)."""
        return _TraceLink(self.sequence, self.repeat)

    def frame_loss(self) -> float:
        """The fraction of lost frames in the sequence."""
        return sum(self.sequence) / len(self.sequence)

    def consecutive_loss(self, n: int) -> float:
        """The fraction of positions where *n* consecutive frames are lost (cyclically with
        ``repeat``)."""
        seq = np.asarray(self.sequence, dtype=bool)
        m = len(seq)
        if self.repeat:
            ext, starts = np.resize(seq, m + n - 1), m    # np.resize repeats the sequence cyclically
        else:
            ext, starts = seq, m - n + 1
            if starts <= 0:
                return 0.0
        windows = np.lib.stride_tricks.sliding_window_view(ext, n)[:starts]
        return float(windows.all(axis=1).mean())

    def __repr__(self):
        return f"TraceLoss({len(self.sequence)} frames, repeat={self.repeat})"


class _AnyLink(LinkLoss):
    __slots__ = ("links",)

    def __init__(self, links):
        self.links = links

    def lost(self) -> bool:
        lost = False
        for lk in self.links:          # every model advances its state on every frame
            lost = lk.lost() or lost
        return lost


class AnyLoss(LossModel):
    """Combination: the frame is lost if any of the models loses it.

    *models*: a list or tuple of loss models or probabilities (a probability *p* is
    :class:`Bernoulli` (*p*), 0 loses nothing).  A network's ``loss=[...]`` builds one.
    Each model draws from its own stream and advances on every frame.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationTypeError`
        *models* is not a list (a single model, a string), or an entry is neither a
        probability nor a :class:`LossModel`.
    :class:`~netcosim.errors.ConfigurationError`
        *models* is empty, or a probability is outside [0, 1].

    Examples
    --------
    Two independent losses of 10 % and 20 % lose ``1 - 0.9 * 0.8 = 0.28`` of the frames:

    >>> import numpy as np
    >>> from netcosim.network import AnyLoss
    >>> both = AnyLoss([0.1, 0.2])
    >>> round(float(both.markov().loss[0]), 6)
    0.28
    >>> link = both.link(np.random.default_rng(2))
    >>> sum(link.lost() for _ in range(20_000)) / 20_000
    0.2878
    """

    def __init__(self, models: Sequence[LossModel]):
        if isinstance(models, (str, bytes, LossModel)) or not hasattr(models, "__iter__"):
            raise ConfigurationTypeError(f"AnyLoss needs a list of loss models (or probabilities), got {models!r}")
        models = tuple(models)
        if not models:
            raise ConfigurationError("AnyLoss needs at least one loss model, got an empty list")
        converted = tuple(as_loss_model(m) for m in models)
        for m, given in zip(converted, models):
            if m is None and given is not None:
                continue                       # a probability of 0: never loses
            if m is None:
                raise ConfigurationTypeError(f"AnyLoss: each entry must be a probability or a LossModel, "
                                             f"got {given!r}")
        self.models: tuple[LossModel, ...] = tuple(m for m in converted if m is not None)

    def link(self, rng):
        # independent child streams, derived deterministically from the link stream
        """One link state per combined model, each drawing from its own child stream of *rng*."""
        seeds = rng.integers(0, 2**63, size=len(self.models))
        return _AnyLink([m.link(np.random.Generator(np.random.PCG64(int(s))))
                         for m, s in zip(self.models, seeds)])

    def markov(self) -> MarkovChannel | None:
        """The product chain of the models' chains (they move independently): a frame is
        kept only if every model keeps it; None if one model is not a Markov chain."""
        P: np.ndarray = np.ones((1, 1))
        keep: np.ndarray = np.ones(1)
        initial: np.ndarray = np.ones(1)
        for m in self.models:
            c = m.markov()
            if c is None:
                return None
            P, keep, initial = np.kron(P, c.transition), np.kron(keep, 1.0 - c.loss), np.kron(initial, c.initial)
        return MarkovChannel(P, 1.0 - keep, initial)


def as_loss_model(loss) -> LossModel | None:
    """The :class:`LossModel` a network's ``loss=`` / ``message_loss=`` argument *loss* stands for:
    None or 0.0 (no loss: None), a probability in [0, 1] (a :class:`Bernoulli` model), a
    model (as is), or a list or tuple of those (an :class:`AnyLoss`: lost if any says so)."""
    if loss is None:
        return None
    if isinstance(loss, LossModel):
        return loss
    if validate.is_real(loss):
        p = validate.probability(loss, "loss probability")     # the one check of loss=p
        return None if p == 0.0 else Bernoulli._checked(p)
    if isinstance(loss, (list, tuple)):
        return AnyLoss(loss)
    raise ConfigurationTypeError(f"loss must be a probability, a LossModel or a list of them, got {loss!r}")
