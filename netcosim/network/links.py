"""Per-link accounting of a network: each message counted on its links when it is sent,
``message_loss`` drawn there (the silenced links), the once-per-network note of a frame
loss hidden by retries, and the ``stats`` / ``link_stats`` results.

:class:`LinkAccounting` is a part of :class:`~netcosim.network.base.Network` (a mixin:
it uses the network's ``sim``, ``name``, ``loss``, ``message_loss`` and ``_lost``).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

from ..errors import ConfigurationTypeError
from .loss import Bernoulli, LossModel, MaskedLossWarning, as_loss_model
from .stats import LinkStats, stats_frame, total

if TYPE_CHECKING:
    import pandas as pd

    from .frame import Frame
    from .interface import Interface

_UNSET = object()


def _message_loss(value: Any, what: str) -> LossModel | dict | None:
    """``message_loss``: None, a probability / model / list (every link), or a dict per link."""
    if not isinstance(value, dict):
        return as_loss_model(value)
    links = {}
    for key, m in value.items():
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(k, str) for k in key)):
            raise ConfigurationTypeError(f"{what}: message_loss per link needs (src, dst) node-name pairs as keys, "
                                         f"got {key!r}")
        model = as_loss_model(m)
        if model is not None:
            links[key] = model
    return links or None


class LinkAccounting:
    """Counting messages per link and drawing ``message_loss`` (part of :class:`Network`)."""

    _lstats: dict
    _mlinks: dict

    if TYPE_CHECKING:       # provided by Network
        sim: Any
        name: str
        loss: Any
        message_loss: Any

        def _lost(self, frame: Frame, where: Interface | str, reason: str) -> None: ...

    def _open_link(self, frame: Frame, src: Interface, rx: Interface) -> None:
        """Count *frame*'s message on the link *src* -> *rx*; draw ``message_loss`` for it."""
        key = (src.index, rx.index)
        ls = self._lstats.get(key)
        if ls is None:
            ls = self._lstats[key] = LinkStats(src.name, rx.name)
        ls.sent += 1
        ml = self.message_loss
        if ml is not None:
            lk = self._mlinks.get(key, _UNSET)
            if lk is _UNSET:                # first message on the link
                model = ml.get((src.name, rx.name)) if isinstance(ml, dict) else ml
                lk = self._mlinks[key] = None if model is None else model.link(
                    self.sim.rng(f"{self.name}/message_loss/{src.name}->{rx.name}"))
            if lk is not None and lk.lost():
                ls.lost += 1
                ls.silenced += 1
                if frame.silenced is None:
                    frame.silenced = set()
                frame.silenced.add(rx.index)
                self._lost(frame, rx, "message_loss")
                return
        frame.lstats[rx.index] = ls
        frame.pend.add(rx.index)

    def _check_masked_loss(self) -> None:
        """Note once if retries hide the frame loss: the expected message loss (all attempts
        lost, :meth:`LossModel.consecutive_loss`) below a tenth of the frame loss."""
        self._mask_check = False
        if not getattr(self, "use_ack", False):
            return
        model = self.loss
        assert model is not None        # checked only when the model states a frame loss
        p, n = model.frame_loss(), int(getattr(self, "max_attempts", 1) or 1)
        q = model.consecutive_loss(n) if n > 1 else None
        if p is None or q is None or not q < 0.1 * p:
            return
        if isinstance(model, Bernoulli):
            what, expected, suggest = f"loss={p:g}", f"{p:g}**{n} = {q:.3g}", f"message_loss={p:g}"
        else:
            what, expected, suggest = f"loss={model!r} (long-run {p:.3g} per frame)", f"{q:.3g}", "message_loss="
        warnings.warn(
            f"network {self.name!r}: {what} is a frame loss, drawn per attempt; with up to {n} attempts per "
            f"unicast message the expected message loss is only {expected} if nothing else fails an "
            f"attempt.  For a loss of whole messages use {suggest} (silenced before medium access, as "
            f"TrueTime's wireless loss); network.stats reports both losses", MaskedLossWarning, stacklevel=4)

    # ------------------------------------------------------------------ results
    @property
    def stats(self) -> dict:
        """Message loss next to frame loss: ``{"links": {"src->dst": counters}, "total": counters}``.

        Counters (see :mod:`netcosim.network.stats`): ``messages_sent`` (a broadcast
        counts once per receiver), ``messages_delivered`` (handed to the receiver's
        interface: mailbox and handlers), ``messages_lost`` (never delivered, after every
        retry; includes ``messages_silenced`` by ``message_loss``),
        ``messages_in_flight``, ``message_loss`` = lost / (delivered + lost);
        ``frame_attempts`` (completed transmission attempts), ``frames_lost`` (attempts the
        receiver did not receive), ``frame_loss`` = frames_lost / frame_attempts.  Links
        appear once a message was sent on them.
        """
        links = sorted(self._lstats.items())
        return {"links": {f"{ls.src}->{ls.dst}": ls.as_dict() for _, ls in links},
                "total": total(ls for _, ls in links)}

    def link_stats(self) -> pd.DataFrame:
        """:attr:`stats` of every link as a DataFrame (one row per link, ``src``, ``dst`` first)."""
        return stats_frame(ls for _, ls in sorted(self._lstats.items()))

