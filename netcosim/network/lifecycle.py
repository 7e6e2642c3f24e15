"""A frame's life cycle at its sender, and the MAC seam: :class:`Attempt`.

A MAC drives each frame through one life cycle, enforced by the state of the sender
interface's :class:`Attempt` (``iface.attempt``, one per interface, reused)::

    f = net._next_frame(iface)               head of the queue into service (None: busy/empty)
    a = net.begin_attempt(iface, f)          IDLE/FAILED -> ON: attempt counted + traced, carrier on
        a.suspend() / a.resume()             ON <-> SUSPENDED: carrier off/on mid-attempt (TDMA)
    a.end()            or a.end("reason")    ON -> OK / FAILED: carrier off, ``attempt_end`` row
        a.deliver(rx), a.deliver_all()       OK only: loss drawn (:meth:`frame_lost`), delivery
    a.finish(restart=True)                   OK -> IDLE: sent; stats, ``on_done``, queue served
    a.drop(reason, restart=True)             OK/FAILED -> IDLE: ``lost`` row, dropped, ``on_done``
    a.requeue()                              FAILED -> IDLE: the frame back at the head of the queue
    (after FAILED: net.begin_attempt(iface, f) again for a retry)

On a network with ``carrier_reaches_receivers = False`` (a full-duplex uplink: the
switched Ethernet, whose output ports make the receivers ``receiving``), the carrier of
an attempt is the sender's alone.

A call out of this order (``end`` twice, ``deliver`` after a collision, ``finish`` of a
failed attempt, a new attempt while one is on the medium) raises :class:`MacOrderError`
naming the network, the station, the frame and the state, before any counter or row
is touched.  The steps below the seam (``_attempt_start``, ``_carrier_on`` ...,
``_done``) remain for the radio MACs, whose medium model interleaves them.

:class:`FrameLifecycle` is a part of :class:`~netcosim.network.base.Network` (a mixin);
it also holds the single frame-loss draw :meth:`FrameLifecycle.frame_lost` and the
hand-over to the receivers.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

from ..kernel.task import Task
from ..timebase import RESOLUTION
from .frame import BROADCAST, Frame


class Interface(Protocol):
    """What the life cycle reads and sets on a network interface
    (:class:`netcosim.network.interface.Interface`, which builds this module's
    :class:`Attempt`: a protocol here keeps the import one way)."""

    name: str
    index: int
    current: Any            # the frame in service, or None
    sending: Any
    receiving: Any
    queue: Any
    attempt: Any
    use_mailbox: bool
    mailbox: Any
    handlers: Any
    stats: Any

    def _state(self) -> None: ...

_NAN = math.nan

#: states of an :class:`Attempt`
IDLE, ON, SUSPENDED, OK, FAILED = "idle", "on", "suspended", "ok", "failed"


class MacOrderError(RuntimeError):
    """A MAC called a life-cycle step of :class:`Attempt` out of order."""


class Attempt:
    """The frame in service at one sender interface and the state of its current attempt
    (see the module docstring for the order).  Got from :meth:`FrameLifecycle.begin_attempt`."""

    __slots__ = ("net", "iface", "frame", "state")

    def __init__(self, net, iface: Interface):
        self.net = net
        self.iface = iface
        self.frame: Any = None     # the frame in service (None when idle)
        self.state = IDLE

    def _order(self, step: str, allowed: str):
        net = self.net
        raise MacOrderError(f"network {net.name!r} ({type(net).__name__}): {step} of {self.frame!r} at "
                            f"{self.iface.name!r} in state {self.state!r}; allowed only {allowed}")

    def end(self, outcome: str | None = None) -> None:
        """The attempt is over: carrier off, ``attempt_end`` row with ``ok``/``sent``
        (broadcast) when *outcome* is None (-> OK), else the failure *outcome* (-> FAILED)."""
        if self.state is not ON:
            self._order("end", "after begin_attempt (state 'on')")
        net, iface, frame = self.net, self.iface, self.frame
        iface.sending = 0
        if net.carrier_reaches_receivers:
            for r in net.receivers(frame):
                r.receiving -= 1
                r._state()
        if net._trace_on:
            net._rows.append((net._env.now, net.name, frame.id, "attempt_end", frame.src.name, frame.dname,
                              iface.name, frame.attempts,
                              ("sent" if frame.dst is BROADCAST else "ok") if outcome is None else outcome,
                              _NAN, _NAN))
        self.state = OK if outcome is None else FAILED

    def suspend(self) -> None:
        """Carrier off in the middle of the attempt (``suspended`` row); :meth:`resume` goes on."""
        if self.state is not ON:
            self._order("suspend", "while on the medium (state 'on')")
        self.net._carrier_off(self.iface, self.frame)
        self.net._trace("suspended", self.frame, self.iface.name)
        self.state = SUSPENDED

    def resume(self) -> None:
        """Carrier on again after :meth:`suspend` (``resumed`` row)."""
        if self.state is not SUSPENDED:
            self._order("resume", "after suspend")
        self.net._trace("resumed", self.frame, self.iface.name)
        self.net._carrier_on(self.iface, self.frame)
        self.state = ON

    def deliver(self, rx: Interface) -> bool:
        """*rx* received the frame now: loss drawn (:meth:`FrameLifecycle.frame_lost`), then
        handed over after the delays; False if lost."""
        if self.state is not OK:
            self._order("deliver", "after a successful end()")
        return self.net._deliver(self.frame, rx)

    def deliver_all(self) -> None:
        """Every receiver of the frame received it now (:meth:`deliver` to each)."""
        if self.state is not OK:
            self._order("deliver_all", "after a successful end()")
        net, frame = self.net, self.frame
        for r in net.receivers(frame):
            net._deliver(frame, r)

    def finish(self, restart: bool = True) -> None:
        """The sender is done with the frame, sent: free the interface, count it, call the
        ``on_done`` callbacks, then serve the queue (``_restart``) unless ``restart=False``."""
        if self.state is not OK:
            self._order("finish", "after a successful end()")
        net, iface, frame = self.net, self.iface, self.frame
        self.state, self.frame = IDLE, None
        iface.current = None
        iface._state()
        net._finish(frame, True)
        if restart:
            net._restart(iface)

    def drop(self, reason: str, restart: bool = True, where: str | None = None) -> None:
        """The sender gives the frame up after its last attempt (``lost`` row with *reason* at
        the sender, or at the node named *where*): counted dropped, ``on_done`` called."""
        if self.state is not FAILED and self.state is not OK:
            self._order("drop", "after end()")
        net, iface, frame = self.net, self.iface, self.frame
        self.state, self.frame = IDLE, None
        net._lost(frame, iface if where is None else where, reason)
        iface.current = None
        iface._state()
        net._finish(frame, False)
        if restart:
            net._restart(iface)

    def requeue(self) -> None:
        """After a failed :meth:`end`, the sender takes the frame out of service and puts it
        back at the head of its queue, to try it again later (a switch that refused it).  No
        ``on_done``, no restart: the MAC serves the queue again itself."""
        if self.state is not FAILED:
            self._order("requeue", "after a failed end()")
        iface, frame = self.iface, self.frame
        self.state, self.frame = IDLE, None
        iface.current = None
        iface.queue.push_front(frame)
        iface._state()

    def __repr__(self) -> str:
        return f"<Attempt {self.iface.name} {self.state} {self.frame!r}>"


class FrameLifecycle:
    """The frame's life cycle, loss draw and hand-over (part of :class:`Network`)."""

    #: the ``network_schedule`` rows at carrier on list the receivers before the sender
    #: (the ideal link's historic order)
    receivers_first = False
    #: the carrier of an attempt makes the frame's receivers ``receiving`` (a shared medium
    #: or link); False: only the sender is ``sending`` (a full-duplex uplink to a switch)
    carrier_reaches_receivers = True

    if TYPE_CHECKING:       # provided by Network
        sim: Any
        name: str
        loss: Any
        _env: Any
        _trace_on: bool
        _rows: Any
        _links: dict
        _post: int
        _prop: int

        def receivers(self, frame: Frame) -> Any: ...
        def _restart(self, iface: Any) -> None: ...   # a Network's interface

    def begin_attempt(self, iface: Interface, frame: Frame, bits=None, backoff=_NAN) -> Attempt:
        """A new attempt of *frame* (in service at *iface*) starts now: counted, traced
        (``bits`` on the air, default the frame's; ``backoff`` slots drawn before it), the
        carrier on (sender ``sending``, receivers ``receiving``).  Returns ``iface.attempt``
        in state ``on``."""
        a = iface.attempt
        if iface.current is not frame:
            self._not_in_service(iface, frame, "starts an attempt of")
        if a.state is ON or a.state is SUSPENDED:
            a._order("begin_attempt", "when no attempt is on the medium")
        a.frame = frame
        a.state = ON
        if frame.attempts:
            self._attempt_over(frame)
        frame.attempts += 1
        frame.sent = now = self._env.now
        if self._trace_on:
            self._rows.append((now, self.name, frame.id, "attempt_start", iface.name, frame.dname,
                               iface.name, frame.attempts, "", frame.bits if bits is None else bits, backoff))
        iface.sending = 1
        if not self.receivers_first:
            iface._state()
        if self.carrier_reaches_receivers:
            for r in self.receivers(frame):
                r.receiving += 1
                r._state()
        if self.receivers_first:
            iface._state()
        return a

    def _next_frame(self, iface: Interface) -> Frame | None:
        """Take the head of *iface*'s queue into service (``iface.current``); None if busy or empty."""
        if iface.current is None and iface.queue._q:
            f = iface.current = iface.queue.pop()
            return f
        return None

    def _attempt_start(self, iface: Interface, frame: Frame, bits=None, backoff=_NAN) -> None:
        """Count a new attempt of *frame* starting now and trace it (``bits`` on the air,
        default the frame's; ``backoff`` slots drawn before it)."""
        if iface.current is not frame:
            self._not_in_service(iface, frame, "starts an attempt of")
        if frame.attempts:
            self._attempt_over(frame)
        frame.attempts += 1
        frame.sent = self._env.now
        if self._trace_on:
            self._rows.append((frame.sent, self.name, frame.id, "attempt_start", iface.name, frame.dname,
                               iface.name, frame.attempts, "", frame.bits if bits is None else bits, backoff))

    def _carrier_on(self, iface: Interface, frame: Frame) -> None:
        """*iface* puts *frame* on the medium: it is sending, its receivers are receiving."""
        iface.sending = 1
        iface._state()
        for r in self.receivers(frame):
            r.receiving += 1
            r._state()

    def _carrier_off(self, iface: Interface, frame: Frame) -> None:
        """*iface* stops sending *frame* (ended, cut or aborted)."""
        iface.sending = 0
        for r in self.receivers(frame):
            r.receiving -= 1
            r._state()

    def _attempt_end(self, iface: Interface, frame: Frame, outcome: str | None = None) -> None:
        """Trace the end of the current attempt: ``ok``/``sent`` (broadcast) by default, or the
        failure *outcome*."""
        if self._trace_on:
            if outcome is None:
                outcome = "sent" if frame.dst is BROADCAST else "ok"
            self._rows.append((self._env.now, self.name, frame.id, "attempt_end", frame.src.name, frame.dname,
                               iface.name, frame.attempts, outcome, _NAN, _NAN))

    def _deliver_all(self, frame: Frame) -> None:
        """Every receiver of *frame* got it now (loss drawn per receiver)."""
        for r in self.receivers(frame):
            self._deliver(frame, r)

    def _done(self, iface: Interface, frame: Frame, ok: bool, restart: bool = True) -> None:
        """The sender is done with *frame* (sent/acknowledged, or dropped): free the interface,
        count and notify (:meth:`_finish`), then serve the queue (:meth:`_restart`) unless
        ``restart=False`` (the MAC restarts it itself later)."""
        if iface.current is not frame:
            self._not_in_service(iface, frame, "is done with")
        iface.current = None
        iface._state()
        self._finish(frame, ok)
        if restart:
            self._restart(iface)

    def _not_in_service(self, iface: Interface, frame: Frame, what: str):
        # the invariant of the life cycle: a MAC works on the frame in service at the interface
        raise RuntimeError(f"network {self.name!r} ({type(self).__name__}): {iface.name!r} {what} {frame!r}, "
                           f"but the frame in service there is {iface.current!r}")

    # helpers for MACs ---------------------------------------------------------
    def _trace(self, event: str, frame: Frame, node: str, outcome: str = "", bits=_NAN, backoff=_NAN) -> None:
        if self._trace_on:
            self._rows.append((self._env.now, self.name, frame.id, event, frame.src.name, frame.dname, node,
                               frame.attempts, outcome, bits, backoff))

    def _lost(self, frame: Frame, where: Interface | str, reason: str) -> None:
        """Trace *frame* lost for *reason* at *where* (an interface or a node name such as ``"switch"``)."""
        if self._trace_on:
            self._rows.append((self._env.now, self.name, frame.id, "lost", frame.src.name, frame.dname,
                               where if isinstance(where, str) else where.name, frame.attempts, reason, _NAN, _NAN))

    def _finish(self, frame: Frame, ok: bool) -> None:
        """Count *frame* as sent or dropped at its sender and call the ``on_done`` callbacks."""
        src = frame.src
        src.stats["sent" if ok else "dropped"] += 1
        self._let_go(frame)
        for cb in src.on_done:
            cb(frame, ok)

    def _attempt_over(self, frame: Frame) -> None:
        """The last attempt of *frame* is over: count it per link, lost where not received."""
        rx = frame.rx_now
        for i, ls in frame.lstats.items():
            ls.attempts += 1
            if i not in rx:
                ls.frames_lost += 1
        rx.clear()

    def _let_go(self, frame: Frame) -> None:
        """One of the holders of *frame* (its sender, a pending hand-over, a copy in a switch) is
        done with it; when the last one is, its fate is final: the receivers it was not
        delivered to count a message loss."""
        frame.holds -= 1
        if frame.holds == 0:
            if frame.attempts:
                self._attempt_over(frame)
            for i in frame.pend:
                frame.lstats[i].lost += 1
            frame.pend.clear()

    def frame_lost(self, frame: Frame, rx: Interface) -> bool:
        """**The** place where frame loss (``loss=``) is drawn: is *frame*'s current attempt
        lost on the link to *rx*?  One draw from the link's own state (``<net>/loss/<src>-><rx>``).

        Every MAC reaches it in one of two ways: :meth:`Attempt.deliver` /
        :meth:`Attempt.deliver_all` (the wired MACs: drawn at delivery), or directly before
        an acknowledgement (the radio MACs' unicast, so a frame lost so is not
        acknowledged).  Callers on the hot path test ``self.loss is not None`` first (no
        call on a lossless network); without a loss model it returns False.  Override it
        for a loss that depends on more than the link (the frame, the instant).
        """
        loss = self.loss
        if loss is None:
            return False
        key = (frame.src.index, rx.index)
        lk = self._links.get(key)
        if lk is None:
            src = frame.src.name
            lk = self._links[key] = loss.link(self.sim.rng(f"{self.name}/loss/{src}->{rx.name}"))
        return lk.lost()

    def _deliver(self, frame: Frame, rx: Interface) -> bool:
        """The frame was received by *rx* now; draw the loss, then hand it over after the delays."""
        if self.loss is not None and self.frame_lost(frame, rx):
            self._lost(frame, rx, "random_loss")
            return False
        frame.rx_now.add(rx.index)
        delay = self._post + self._prop       # as _accept (inlined: once per frame and receiver)
        if delay:
            frame.holds += 1
            self.sim.call_in_ticks(delay, self._hand_over_later, arg=(frame, rx))
        else:
            self._hand_over((frame, rx))
        return True

    def _accept(self, frame: Frame, rx: Interface) -> None:
        """Hand *frame* to *rx* after the post-processing and propagation delays (no loss draw:
        MACs that draw the loss themselves, before an ACK, call this)."""
        delay = self._post + self._prop
        if delay:
            frame.holds += 1
            self.sim.call_in_ticks(delay, self._hand_over_later, arg=(frame, rx))
        else:
            self._hand_over((frame, rx))

    def _hand_over_later(self, item) -> None:
        self._hand_over(item)
        self._let_go(item[0])

    def _hand_over(self, item) -> None:
        frame, rx = item
        if frame.silenced is not None and rx.index in frame.silenced:
            return                            # this link was silenced at send (traced then)
        msg = frame.msg.copy() if frame.dst is BROADCAST else frame.msg
        now = self._env.now
        msg.delivered = now * RESOLUTION
        msg.attempts = frame.attempts
        if frame.sent is not None:
            msg.sent = frame.sent * RESOLUTION
        if rx.use_mailbox and not rx.mailbox.try_post(msg):
            self._lost(frame, rx, "mailbox_full")
            return
        if self._trace_on:
            self._rows.append((now, self.name, frame.id, "delivered", frame.src.name, frame.dname, rx.name,
                               frame.attempts, "", frame.bits, _NAN))
        rx.stats["received"] += 1
        pend = frame.pend
        if rx.index in pend:
            pend.discard(rx.index)
            frame.lstats[rx.index].delivered += 1
        for h in rx.handlers:
            if isinstance(h, Task):
                h.release()
            else:
                h(msg)
