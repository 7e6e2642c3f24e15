"""AODV routing (Ad hoc On-Demand Distance Vector) as application tasks on netcosim nodes.

A port of the routing code of TrueTime's ``examples/AODV`` (itself a subset of RFC 3561):
the protocol is application code running in kernel tasks, on top of any network MAC
(e.g. ``WLAN80211b``); nothing here is part of a MAC.  Per node (:class:`AODVRouter`):

* ``rcv`` (aperiodic, priority 1): one job per delivered message; data are delivered or
  forwarded to the next hop; RREQ (route request, broadcast) are cached by ``(source,
  RREQ id)`` so that each is processed once, create or refresh the reverse route to the
  source (``hop count + 1``) and are answered with a RREP when the node is the destination
  or has a valid route to it, else re-broadcast with the hop count increased; RREP (route
  reply, unicast along the reverse path) create or update the forward route if it is new,
  was invalid, or carries a newer destination sequence number, add the previous hop to the
  route's precursor list and travel on to the source; RERR (route error) invalidate the
  routes to the lost destination through the sender and are passed on to the precursors;
  HELLO record the neighbour's last hello time.
* ``send`` (aperiodic, priority 5): a data message from the application goes to the next
  hop if a valid route exists, else it is buffered and a RREQ is broadcast (new RREQ id,
  own sequence number + 1); when the RREP reaches the source the buffer is flushed, one
  message per ms.
* ``hello`` (periodic, ``hello_interval``, offset drawn in [0, 0.1) s, priority 3): a node
  with a valid route broadcasts HELLO; a neighbour silent for ``allowed_hello_loss *
  hello_interval`` (DELETE_PERIOD) is lost: the routes through it are invalidated and a
  RERR goes to each of their precursors (one per ms).

Routes expire ``active_route_timeout`` after their last use (checked when read; TrueTime
arms a timer, same effect).  Execution times are TrueTime's: 0.1 ms per handled message.
Message sizes (bits, before the network's minimum frame): data = application size + 4,
RREQ 24, RREP 20, RERR 12, HELLO 24.  Node ids are integers; node ``i`` is the kernel node
named ``name_of(i)`` (default ``f"n{i}"``).  Like TrueTime's code the MAC's own delivery
failures are not used: a broken link is noticed only by missing HELLOs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from netcosim import validate
from netcosim.network import BROADCAST

__all__ = ["AODVParams", "AODVRouter", "Route", "DATA_OVERHEAD_BITS"]

DATA_OVERHEAD_BITS = 4
RREQ_BITS, RREP_BITS, RERR_BITS, HELLO_BITS = 24, 20, 12, 24


@dataclass(frozen=True)
class AODVParams:
    """Protocol constants (s): ``hello_interval`` (1 s), ``active_route_timeout`` (3 s),
    ``allowed_hello_loss`` (2 hellos), ``exec_time`` (0.1 ms of CPU per handled message),
    ``spacing`` (1 ms between buffered data or RERR messages sent in a row)."""

    hello_interval: float = 1.0
    active_route_timeout: float = 3.0
    allowed_hello_loss: int = 2
    exec_time: float = 1e-4
    spacing: float = 1e-3

    def __post_init__(self):
        validate.positive(self.hello_interval, "AODV hello_interval (s)")
        validate.positive(self.active_route_timeout, "AODV active_route_timeout (s)")
        validate.count(self.allowed_hello_loss, "AODV allowed_hello_loss", minimum=1)
        validate.positive(self.exec_time, "AODV exec_time (s)")
        validate.positive(self.spacing, "AODV spacing (s)")

    @property
    def delete_period(self) -> float:
        """Silence (s) after which a neighbour counts as lost: ``allowed_hello_loss * hello_interval``."""
        return self.allowed_hello_loss * self.hello_interval


@dataclass
class Route:
    """A routing-table entry: next hop, hop count, destination sequence number, expiry time
    (s), precursors (neighbours that route through this node to the destination), valid.

    ``next_hop``: the node id the messages for the destination go to; ``hops``: the hop
    count to the destination; ``seq``: the destination's sequence number the route was
    learnt with; ``expires``: the simulation time [s] after which the route is stale."""

    next_hop: int
    hops: int
    seq: int
    expires: float
    precursors: set = field(default_factory=set)
    valid: bool = True


class AODVRouter:
    """AODV on one node: its three tasks (see the module docstring).

    ``node``: a kernel node; ``iface``: its interface on the ad hoc network; ``node_id``:
    its integer id; ``params``: :class:`AODVParams`; ``on_data(ctx, msg)``: called at the
    destination with each data message (a dict with ``src``, ``dest``, ``data``, ``path``:
    the node ids it visited); ``name_of(i)``: the node name of id ``i``.  ``events`` lists
    ``(time, node_id, what, detail)`` tuples: route found, route invalidated, data dropped.
    """

    def __init__(self, node: Any, iface: Any, node_id: int, *, params: AODVParams | None = None,
                 on_data: Callable | None = None, name_of: Callable[[int], str] = lambda i: f"n{i}",
                 events: list | None = None):
        self.node, self.iface, self.id = node, iface, int(node_id)
        self.p = params if params is not None else AODVParams()
        self.on_data = on_data
        self.name_of = name_of
        self.events = events if events is not None else []
        self.table: dict[int, Route] = {}
        self.seq = 0                      # own sequence number
        self.rreq_id = 0
        self.seen: set = set()            # (source, RREQ id) processed
        self.neighbours: dict[int, float] = {}   # id -> time of the last HELLO
        self.buffer: dict[int, list] = {}        # destination -> data waiting for a route
        self.outbox: list = []            # application messages for the send task
        self.flush: list = []             # destinations whose buffer is to be flushed
        self.rerrs: list = []             # (neighbour, destination, seq) to send
        self.sent_rreqs = 0
        self._add_tasks()

    # -- routing table
    def route(self, dest: int, now: float) -> Route | None:
        """The valid, unexpired route to *dest* at time *now* (s), or None."""
        r = self.table.get(dest)
        if r is None or not r.valid:
            return None
        if now >= r.expires:
            r.valid = False
            self.events.append((now, self.id, "route_expired", dest))
            return None
        return r

    def _refresh(self, r: Route | None, now: float) -> None:
        if r is not None:
            r.expires = max(r.expires, now + self.p.active_route_timeout)

    def _send(self, ctx, dst, msg: dict, bits: int) -> None:
        ctx.send(BROADCAST if dst == 0 else self.name_of(dst), msg, bits)

    # -- application side
    def submit(self, dest: int, data: Any, size_bits: int) -> None:
        """Hand a data message *data* for node *dest* to the routing layer (from a task of this node);
        *size_bits*: its size on the network [bits]."""
        self.outbox.append({"type": "data", "src": self.id, "dest": int(dest), "data": data,
                            "size": int(size_bits), "path": [self.id]})
        self._send_task.release()

    # -- tasks
    def _add_tasks(self) -> None:
        p, node = self.p, self.node

        @node.aperiodic(priority=1, name="aodv_rcv")
        def rcv(ctx):
            msg = self.iface.mailbox.try_fetch()
            if msg is None:
                return
            yield from self._receive(ctx, msg.payload)

        self.iface.on_receive(rcv)

        @node.aperiodic(priority=5, name="aodv_send")
        def send(ctx):
            if self.outbox:
                self._from_application(ctx, self.outbox.pop(0))
                yield ctx.execute(p.exec_time)
            while self.flush:
                dest = self.flush.pop(0)
                yield ctx.execute(p.exec_time)
                for m in self.buffer.pop(dest, []):
                    r = self.route(dest, ctx.now)
                    if r is None:         # lost again meanwhile: wait for the next RREP
                        self.buffer.setdefault(dest, []).append(m)
                        continue
                    self._send(ctx, r.next_hop, m, m["size"] + DATA_OVERHEAD_BITS)
                    yield ctx.sleep(p.spacing)

        self._send_task = send

        @node.periodic(period=p.hello_interval, offset=0.1 * float(node.sim.rng(f"aodv/{self.id}/hello").random()),
                       priority=3, name="aodv_hello")
        def hello(ctx):
            now = ctx.now
            if any(self.route(d, now) is not None for d in list(self.table)):
                self._send(ctx, 0, {"type": "hello", "from": self.id, "seq": self.seq}, HELLO_BITS)
            for nb, last in list(self.neighbours.items()):
                if now - last > p.delete_period:
                    del self.neighbours[nb]
                    self.events.append((now, self.id, "neighbour_lost", nb))
                    self._break_routes_via(nb, now)
            yield ctx.execute(p.exec_time)
            yield from self._send_rerrs(ctx)

    def _break_routes_via(self, nb: int, now: float, dest: int | None = None) -> None:
        for d, r in self.table.items():
            if r.valid and r.next_hop == nb and (dest is None or d == dest):
                self.rerrs.extend((pre, d, r.seq) for pre in sorted(r.precursors))
                r.valid = False
                self.events.append((now, self.id, "route_invalidated", d))

    def _send_rerrs(self, ctx):
        while self.rerrs:
            nb, d, seq = self.rerrs.pop(0)
            self._send(ctx, nb, {"type": "rerr", "dest": d, "seq": seq, "from": self.id}, RERR_BITS)
            yield ctx.sleep(self.p.spacing)

    def _from_application(self, ctx, m: dict) -> None:
        now = ctx.now
        r = self.route(m["dest"], now)
        if r is not None:
            self._refresh(r, now)
            self._send(ctx, r.next_hop, m, m["size"] + DATA_OVERHEAD_BITS)
            return
        self.buffer.setdefault(m["dest"], []).append(m)
        self.rreq_id += 1
        self.seq += 1
        known = self.table.get(m["dest"])
        rreq = {"type": "rreq", "src": self.id, "src_seq": self.seq, "id": self.rreq_id, "dest": m["dest"],
                "dest_seq": known.seq if known is not None else 0, "hops": 0, "from": self.id}
        self.seen.add((self.id, self.rreq_id))
        self.sent_rreqs += 1
        self.events.append((now, self.id, "rreq", m["dest"]))
        self._send(ctx, 0, rreq, RREQ_BITS)

    def _receive(self, ctx, m: dict):
        now, p = ctx.now, self.p
        kind = m["type"]
        if kind == "data":
            self._refresh(self.route(m["src"], now), now)
            m = dict(m, path=m["path"] + [self.id])
            if m["dest"] == self.id:
                if self.on_data is not None:
                    self.on_data(ctx, m)
            else:
                r = self.route(m["dest"], now)
                if r is None:
                    self.events.append((now, self.id, "data_dropped_no_route", m["dest"]))
                else:
                    self._refresh(r, now)
                    self._send(ctx, r.next_hop, m, m["size"] + DATA_OVERHEAD_BITS)
        elif kind == "rreq":
            self._on_rreq(ctx, m, now)
        elif kind == "rrep":
            self._on_rrep(ctx, m, now)
        elif kind == "rerr":
            self._break_routes_via(m["from"], now, dest=m["dest"])
        elif kind == "hello":
            self.neighbours[m["from"]] = now
        yield ctx.execute(p.exec_time)
        if self.rerrs:
            yield from self._send_rerrs(ctx)

    def _on_rreq(self, ctx, m: dict, now: float) -> None:
        key = (m["src"], m["id"])
        if m["src"] == self.id or key in self.seen:
            return
        self.seen.add(key)
        rev = self.table.get(m["src"])
        if rev is None:
            self.table[m["src"]] = Route(m["from"], m["hops"] + 1, m["src_seq"], now + self.p.active_route_timeout)
        else:
            rev.next_hop, rev.hops, rev.seq = m["from"], m["hops"] + 1, max(rev.seq, m["src_seq"])
            rev.expires, rev.valid = now + self.p.active_route_timeout, True
        fwd = self.route(m["dest"], now)
        if m["dest"] == self.id or fwd is not None:
            if fwd is not None:             # intermediate node with a route
                fwd.precursors.add(m["from"])
                seq, hops, life = fwd.seq, fwd.hops, fwd.expires - now
            else:
                self.seq = max(self.seq, m["dest_seq"])
                seq, hops, life = self.seq, 0, self.p.active_route_timeout
            rrep = {"type": "rrep", "src": m["src"], "dest": m["dest"], "dest_seq": seq, "hops": hops,
                    "lifetime": life, "from": self.id}
            self._send(ctx, m["from"], rrep, RREP_BITS)
        else:
            self._send(ctx, 0, dict(m, hops=m["hops"] + 1, **{"from": self.id}), RREQ_BITS)

    def _on_rrep(self, ctx, m: dict, now: float) -> None:
        d = m["dest"]
        r = self.table.get(d)
        if r is None:
            r = self.table[d] = Route(m["from"], m["hops"] + 1, m["dest_seq"], now + m["lifetime"])
            updated = True
        elif (not r.valid) or m["dest_seq"] > r.seq or (m["dest_seq"] == r.seq and m["hops"] + 1 < r.hops):
            if not r.valid:
                r.precursors = set()
            r.next_hop, r.hops, r.seq = m["from"], m["hops"] + 1, m["dest_seq"]
            r.expires, r.valid = now + m["lifetime"], True
            updated = True
        else:
            updated = False
        if m["src"] == self.id:
            if updated:
                self.events.append((now, self.id, "route_found", d))
                self.flush.append(d)
                self._send_task.release()
            return
        if not updated:
            return
        rev = self.route(m["src"], now)
        if rev is None:
            self.events.append((now, self.id, "rrep_dropped_no_reverse_route", m["src"]))
            return
        rev.expires = max(rev.expires, now + m["lifetime"])
        rev.precursors.add(m["from"])
        r.precursors.add(rev.next_hop)
        self._send(ctx, rev.next_hop, dict(m, hops=m["hops"] + 1, **{"from": self.id}), RREP_BITS)
