"""A frame's life cycle at its sender, and the MAC seam: :class:`Attempt`.

A MAC drives each frame through one life cycle, enforced by the state of the sender
interface's :class:`Attempt` (``iface.attempt``, one per interface, reused)::

    f = net._next_frame(iface)               head of the queue into service (None: busy/empty)
    a = net.begin_attempt(iface, f)          IDLE/FAILED -> ON: attempt counted + traced, carrier on
        a.suspend() / a.resume()             ON <-> SUSPENDED: carrier off/on mid-attempt (TDMA)
    a.end()            or a.end("reason")    ON -> OK / FAILED: carrier off, ``attempt_end`` row
        a.deliver(rx), a.deliver_all()       OK only (ON only if the carrier is the medium's):
                                             loss drawn (:meth:`frame_lost`), delivery
    a.finish(restart=True)                   OK -> IDLE: sent; stats, ``on_done``, queue served
    a.drop(reason, restart=True)             OK/FAILED -> IDLE: ``lost`` row, dropped, ``on_done``
    a.requeue()                              FAILED -> IDLE: the frame back at the head of the queue
    a.fail(reason)                           IDLE/FAILED -> FAILED: access failed, nothing sent
    (after FAILED: net.begin_attempt(iface, f) again for a retry)

Who turns the carrier on and off is the network's ``carrier`` setting (one of three):

* :data:`CARRIER_LINK` (default): the sender is ``sending`` and the frame's receivers
  ``receiving`` from ``begin_attempt`` to ``end`` (a shared bus or link);
* :data:`CARRIER_SENDER`: only the sender is ``sending`` (a full-duplex uplink: the
  switched Ethernet, whose output ports make the receivers ``receiving``);
* :data:`CARRIER_MEDIUM`: the medium owns the carrier (the radio networks: power on the
  air, per-listener reception and lock, :mod:`netcosim.network.medium`); the steps count,
  trace and enforce the order but touch neither ``sending`` nor ``receiving``.  A
  reception completes at each receiver as the frame leaves the air, while the sender's
  attempt is still on (a unicast frame is received, acknowledged, and only then does the
  sender's attempt end), so there ``deliver`` is legal in state ``on`` and only there.

One more step serves a MAC whose medium access can fail before anything is sent (the
802.15.4 CSMA-CA giving up): ``a.fail(reason)``, IDLE (frame in service)/FAILED ->
FAILED, an ``attempt_end`` row with *reason* and no attempt counted; ``a.drop`` follows.

A call out of this order (``end`` twice, ``deliver`` after a collision, ``finish`` of a
failed attempt, a new attempt while one is on the medium) raises :class:`MacOrderError`
naming the network, the station, the frame and the state, before any counter or row
is touched.  Every MAC, wired or radio, goes through these steps: there is no other way
to count an attempt or to let the frame in service go.

:class:`FrameLifecycle` is a part of :class:`~netcosim.network.base.Network` (a mixin);
it also holds the single frame-loss draw :meth:`FrameLifecycle.frame_lost` and the
hand-over to the receivers.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

from ..errors import ConfigurationError
from ..kernel.task import Task
from ..timebase import RESOLUTION
from .frame import BROADCAST, Frame
from .tracing import LINK_BITS


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
    _tw_start: int
    _tw_ok: int
    _tw_sent: int
    _tw_delivered: int

    def _state(self) -> None: ...

_NAN = math.nan

#: states of an :class:`Attempt`
IDLE, ON, SUSPENDED, OK, FAILED = "idle", "on", "suspended", "ok", "failed"

#: values of a network's ``carrier`` (who is ``sending``/``receiving`` during an attempt)
CARRIER_LINK, CARRIER_SENDER, CARRIER_MEDIUM = "link", "sender", "medium"
CARRIERS = (CARRIER_LINK, CARRIER_SENDER, CARRIER_MEDIUM)

_SUCCESS = ("ok", "sent")       # the outcomes of end() that are no failure


class MacOrderError(RuntimeError):
    """A MAC called a life-cycle step of :class:`Attempt` out of order."""


class Attempt:
    """The frame in service at one sender interface and the state of its current attempt
    (see the module docstring for the order).  Got from :meth:`FrameLifecycle.begin_attempt`.
    ``net``: the network (its ``carrier`` one of :data:`CARRIERS`); ``iface``: the sender
    interface it belongs to."""

    __slots__ = ("net", "iface", "frame", "state", "_rx_state")

    def __init__(self, net, iface: Interface):
        if net.carrier not in CARRIERS:
            raise ConfigurationError(f"network {net.name!r} ({type(net).__name__}): carrier must be one of "
                                     f"{CARRIERS}, got {net.carrier!r}")
        self.net = net
        self.iface = iface
        self.frame: Any = None     # the frame in service (None when idle)
        self.state = IDLE
        # the state in which the frame is received (deliver): over (OK), or still on the air
        # (ON) where the medium owns the carrier
        self._rx_state = ON if net.carrier == CARRIER_MEDIUM else OK

    def _order(self, step: str, allowed: str):
        net = self.net
        raise MacOrderError(f"network {net.name!r} ({type(net).__name__}): {step} of {self.frame!r} at "
                            f"{self.iface.name!r} in state {self.state!r}; allowed only {allowed}")

    def end(self, outcome: str | None = None) -> None:
        """The attempt is over: carrier off, ``attempt_end`` row with ``ok``/``sent``
        (broadcast) when *outcome* is None (-> OK); ``"ok"`` or ``"sent"`` (a unicast frame
        nobody acknowledges) are successes too (-> OK); any other *outcome* is the reason
        the attempt failed (-> FAILED)."""
        if self.state is not ON:
            self._order("end", "after begin_attempt (state 'on')")
        net, iface, frame = self.net, self.iface, self.frame
        carrier = net.carrier
        if carrier != CARRIER_MEDIUM:
            iface.sending = 0
            if carrier == CARRIER_LINK:
                for r in net.receivers(frame):
                    r.receiving -= 1
                    r._state()
        if net._trace_on:
            # kept as the newest attempt_end, for a delivery right after it to merge with (_hand_over)
            net._tend = row = (net._env.now, frame.tkey,
                               (iface._tw_sent if frame.dst is BROADCAST else iface._tw_ok) if outcome is None
                               else net._tnames.what("attempt_end", iface.name, outcome), frame.attempts, _NAN, _NAN)
            append = net._rows.append       # a slot read: cheaper than a method lookup on the Sink
            append(row)
        self.state = OK if outcome is None or outcome in _SUCCESS else FAILED

    def fail(self, reason: str) -> None:
        """Medium access failed before the frame in service went on the air (802.15.4:
        CSMA-CA gave up): ``attempt_end`` row with *reason*, no attempt counted (-> FAILED;
        :meth:`drop` or a new attempt follows)."""
        iface = self.iface
        if (self.state is not IDLE and self.state is not FAILED) or iface.current is None:
            self._order("fail", "with a frame in service and no attempt on the medium")
        self.frame = frame = iface.current
        self.net._trace("attempt_end", frame, iface.name, reason)
        self.state = FAILED

    def suspend(self) -> None:
        """Carrier off in the middle of the attempt (``suspended`` row); :meth:`resume` goes on."""
        if self.state is not ON:
            self._order("suspend", "while on the medium (state 'on')")
        net, iface = self.net, self.iface
        if net.carrier != CARRIER_MEDIUM:
            iface.sending = 0
            if net.carrier == CARRIER_LINK:
                for r in net.receivers(self.frame):
                    r.receiving -= 1
                    r._state()
        net._trace("suspended", self.frame, iface.name)
        self.state = SUSPENDED

    def resume(self) -> None:
        """Carrier on again after :meth:`suspend` (``resumed`` row)."""
        if self.state is not SUSPENDED:
            self._order("resume", "after suspend")
        net, iface = self.net, self.iface
        net._trace("resumed", self.frame, iface.name)
        if net.carrier != CARRIER_MEDIUM:
            iface.sending = 1
            iface._state()
            if net.carrier == CARRIER_LINK:
                for r in net.receivers(self.frame):
                    r.receiving += 1
                    r._state()
        self.state = ON

    def _rx_order(self, step: str):
        if self._rx_state is ON:
            self._order(step, "while the frame is on the air (state 'on': the carrier is the medium's)")
        self._order(step, "after a successful end()")

    def deliver(self, rx: Interface) -> bool:
        """*rx* received the frame now: loss drawn (:meth:`FrameLifecycle.frame_lost`), then
        handed over after the delays; False if lost.  Legal after a successful :meth:`end`,
        or, where the carrier is the medium's, while the attempt is on (the reception
        completes as the frame leaves the air, before the sender's attempt ends)."""
        if self.state is not self._rx_state:
            self._rx_order("deliver")
        return self.net._deliver(self.frame, rx)

    def deliver_all(self) -> None:
        """Every receiver of the frame received it now (:meth:`deliver` to each)."""
        if self.state is not self._rx_state:
            self._rx_order("deliver_all")
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
        the sender, or at the node named *where*): counted dropped, ``on_done`` called; then,
        if *restart* (default), the sender serves its next queued frame."""
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
    #: who carries an attempt (see the module docstring): :data:`CARRIER_LINK` (the sender
    #: ``sending``, the frame's receivers ``receiving``), :data:`CARRIER_SENDER` (the sender
    #: alone: a full-duplex uplink to a switch) or :data:`CARRIER_MEDIUM` (the radio
    #: medium's power and locks; the steps leave ``sending``/``receiving`` alone)
    carrier = CARRIER_LINK

    if TYPE_CHECKING:       # provided by Network
        sim: Any
        name: str
        loss: Any
        _env: Any
        _trace_on: bool
        _rows: Any
        _tend: Any
        _tnames: Any
        _links: dict
        _post: int
        _prop: int

        def receivers(self, frame: Frame) -> Any: ...
        def _restart(self, iface: Any) -> None: ...   # a Network's interface

    def begin_attempt(self, iface: Interface, frame: Frame, bits=None, backoff=_NAN) -> Attempt:
        """A new attempt of *frame* (in service at *iface*) starts now: counted, traced
        (``bits`` on the air, default the frame's; ``backoff`` slots drawn before it), the
        carrier on (sender ``sending``, receivers ``receiving``, as ``carrier`` says).
        Returns ``iface.attempt`` in state ``on``."""
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
            append = self._rows.append      # a slot read: cheaper than a method lookup on the Sink
            append((now, frame.tkey if iface is frame.src else self._key(frame, iface), iface._tw_start,
                    frame.attempts, frame.bits if bits is None else bits, backoff))
        carrier = self.carrier
        if carrier == CARRIER_MEDIUM:
            return a
        iface.sending = 1
        if not self.receivers_first:
            iface._state()
        if carrier == CARRIER_LINK:
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

    def _not_in_service(self, iface: Interface, frame: Frame, what: str):
        # the invariant of the life cycle: an attempt is of the frame in service at the interface
        raise RuntimeError(f"network {self.name!r} ({type(self).__name__}): {iface.name!r} {what} {frame!r}, "
                           f"but the frame in service there is {iface.current!r}")

    # helpers for MACs ---------------------------------------------------------
    def _trace(self, event: str, frame: Frame, node: str, outcome: str = "", bits=_NAN, backoff=_NAN) -> None:
        """A ``frames`` row of *frame*: *event* at the node named *node*, with *outcome*, *bits*
        and *backoff* (NaN: not applicable)."""
        if self._trace_on:
            self._rows.append((self._env.now, frame.tkey, self._tnames.what(event, node, outcome), frame.attempts,
                               bits, backoff))

    def _key(self, frame: Frame, iface: Any) -> int:
        """The stored key of *frame* sent by *iface* (not its sender: its rows name *iface* as ``src``)."""
        return frame.id << LINK_BITS | self._tnames.link(self.name, iface.name, frame.dname)

    def _lost(self, frame: Frame, where: Interface | str, reason: str) -> None:
        """Trace *frame* lost for *reason* at *where* (an interface or a node name such as ``"switch"``)."""
        if self._trace_on:
            self._rows.append((self._env.now, frame.tkey,
                               self._tnames.what("lost", where if isinstance(where, str) else where.name, reason),
                               frame.attempts, _NAN, _NAN))

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
        :meth:`Attempt.deliver_all` (drawn at delivery: the wired MACs, and a radio
        broadcast at each listener), or directly before an acknowledgement (the radio MACs'
        unicast, so a frame lost so is not acknowledged).  Callers on the hot path test
        ``self.loss is not None`` first (no call on a lossless network); without a loss
        model it returns False.  Override it for a loss that depends on more than the link
        (the frame, the instant).
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
            end = self._tend
            if end is not None and end[0] == now and end[1] == frame.tkey and (tail := self._rows.tail) \
                    and tail[n := len(tail) - 1] is end:      # (a positive index: the specialised path)
                # keep mode, the frame's attempt_end is the newest row: one row for both
                # (tracing.NetworkNames.two: the delivery's bits in the backoff column)
                self._tend = None
                two = rx._tw_joined.get(end[2])
                if two is None:
                    two = rx._tw_joined[end[2]] = self._tnames.two(end[2], rx._tw_delivered)
                tail[n] = (now, end[1], two, end[3], _NAN, frame.bits)
            else:
                append = self._rows.append
                append((now, frame.tkey, rx._tw_delivered, frame.attempts, frame.bits, _NAN))
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
