"""A remote controller for the networked servo written from docs/hil.md alone: Python's
``struct`` and ``zenoh``, no import of netcosim (nor of the project's controllers).

It speaks wire version 2 (40-byte header ``<4sBBHQQqII``, then float64 values), declares
its liveliness token ``netcosim/<run>/<node>/alive/<peer>``, binds to the session of the
simulation's token ``netcosim/<run>/<node>/sim/<session>``, answers each request
``(t_sample, y)`` with ``(t_sample, u)`` from TrueTime's PID (K 0.96, Ti 0.12, Td 0.049,
beta 0.5, N 10, h 10 ms) on the square-wave reference, echoing ``seq`` and ``ticks``, and
answers the simulation's END with its own.  ``--fault`` makes it misbehave the way the
tests need (see FAULTS).  Its last stdout line is a JSON object of its counters; exit
status 0 after END, 3 when the simulation is gone without one, 4 when refused, 5 idle.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import secrets
import struct
import sys
import threading
import time

import zenoh

HEADER = struct.Struct("<4sBBHQQqII")
DATA, END, REFUSED = 1, 2, 3
ENCODING = "application/octet-stream;netcosim.ncsm.v2"
#: --fault modes (K = --at, the request index where the fault starts)
FAULTS = ("none", "nan", "short", "mute", "hang", "duplicate", "unsolicited", "late", "stale", "slow",
          "forge-session", "forge-peer")


def encode(kind, node, session, peer, ticks, seq, values=()):
    return HEADER.pack(b"NCSM", 2, kind, node, session, peer, ticks, seq & 0xFFFFFFFF, len(values)) + \
        struct.pack(f"<{len(values)}d", *values)


def decode(data):
    if len(data) < HEADER.size:
        return None
    magic, version, kind, node, session, peer, ticks, seq, n = HEADER.unpack_from(data)
    if magic != b"NCSM" or version != 2 or len(data) != HEADER.size + 8 * n:
        return None
    return kind, node, session, peer, ticks, seq, struct.unpack_from(f"<{n}d", data, HEADER.size)


class PID:
    """TrueTime's pidcode, the same operations in the same order as the simulated one."""

    def __init__(self, h=0.010, K=0.96, Ti=0.12, Td=0.049, beta=0.5, N=10.0):
        self.h, self.K, self.Ti, self.Td, self.beta, self.N = h, K, Ti, Td, beta, N
        self.I = self.D = self.y_old = 0.0
        self._ad = Td / (N * h + Td)
        self._bd = N * K * Td / (N * h + Td)

    def compute(self, r, y):
        P = self.K * (self.beta * r - y)
        self.D = self._ad * self.D + self._bd * (self.y_old - y)
        u = P + self.I + self.D
        self.I += self.K * self.h / self.Ti * (r - y)
        self.y_old = y
        return u


def reference(t):
    return 1.0 if int(math.floor(t / 0.5 + 1e-12)) % 2 == 0 else -1.0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", required=True)
    p.add_argument("--node", required=True)
    p.add_argument("--connect", action="append", required=True)
    p.add_argument("--session")
    p.add_argument("--lease", type=float, default=1.0)
    p.add_argument("--idle", type=float, default=10.0)
    p.add_argument("--zenoh-config")
    p.add_argument("--fault", choices=FAULTS, default="none")
    p.add_argument("--at", type=int, default=20, help="request (seq) at which the fault starts")
    p.add_argument("--delay", type=float, default=0.015, help="s: reply delay of 'late', work time of 'slow'")
    a = p.parse_args(argv)

    conf = zenoh.Config.from_file(a.zenoh_config) if a.zenoh_config else zenoh.Config()
    for k, v in (("mode", "peer"), ("scouting/multicast/enabled", False), ("scouting/gossip/enabled", False),
                 ("listen/endpoints", []), ("connect/endpoints", a.connect),
                 ("transport/link/tx/lease", int(a.lease * 1000)), ("transport/link/tx/keep_alive", 4)):
        conf.insert_json5(k, json.dumps(v))
    base = f"netcosim/{a.run}/{a.node}"
    peer = secrets.randbits(64) or 1
    state = {"session": int(a.session, 16) if a.session else None, "status": "running", "reason": ""}
    counts = {"received": 0, "published": 0, "foreign": 0, "extra_sent": 0}
    wake: queue.SimpleQueue = queue.SimpleQueue()
    pid = PID()
    sent = []                       # (wall time, bytes) of replies, for 'stale'
    lock = threading.Lock()
    s = zenoh.open(conf)
    try:
        pub = s.declare_publisher(f"{base}/tx", congestion_control=zenoh.CongestionControl.BLOCK, express=True,
                                  encoding=zenoh.Encoding(ENCODING))

        def stop(status, reason):
            if state["status"] == "running":
                state["status"], state["reason"] = status, reason
            wake.put(None)

        def on_sim(sample):
            sid = int(str(sample.key_expr).rsplit("/", 1)[1], 16)
            if sample.kind == zenoh.SampleKind.PUT:
                if state["session"] is None:
                    state["session"] = sid
            elif sid == state["session"]:
                stop("gone", "the simulation is gone without ending the run")

        def put(kind, node, ticks, seq, values, session=None, from_peer=None):
            pub.put(encode(kind, node, state["session"] if session is None else session,
                           peer if from_peer is None else from_peer, ticks, seq, values))

        def on_rx(sample):
            m = decode(sample.payload.to_bytes())
            if m is None:
                return
            kind, node, session, to, ticks, seq, values = m
            if to not in (peer, 0) or session != state["session"]:
                counts["foreign"] += 1
                return
            if kind == REFUSED:
                stop("refused", "another process serves this node")
                return
            if kind == END:
                if a.fault == "late":
                    time.sleep(2 * a.delay)     # the delayed replies first
                put(END, 0, ticks, seq, ())
                stop("ended", "the simulation ended the run")
                return
            with lock:
                counts["received"] += 1
            k = seq                     # the fault starts at request (seq) --at, whatever was withheld
            t_sample, y = values
            u = pid.compute(reference(t_sample), y)
            f, on = a.fault, k >= a.at
            reply = (t_sample, u)
            if on and f == "nan" and k == a.at:
                reply = (t_sample, float("nan"))
            elif on and f == "short" and k == a.at:
                reply = (t_sample,)
            elif on and f == "mute":
                return
            elif on and f == "hang":
                time.sleep(3600)        # blocks the receiving thread; Zenoh keeps the session alive
            elif on and f == "late":      # every reply sent --delay s after its request came
                data = encode(DATA, node, state["session"], peer, ticks, seq, reply)
                threading.Timer(a.delay, pub.put, (data,)).start()
                counts["published"] += 1
                return
            elif on and f == "slow":
                time.sleep(a.delay)
            data = encode(DATA, node, state["session"], peer, ticks, seq, reply)
            pub.put(data)
            counts["published"] += 1
            if on and f == "duplicate":
                pub.put(data)
                counts["extra_sent"] += 1
            elif on and f == "unsolicited":
                put(DATA, node, ticks, seq + 1000, (t_sample, 5.0))
                counts["extra_sent"] += 1
            elif on and f == "stale":
                now = time.monotonic()
                sent.append((now, data))
                while sent and now - sent[0][0] >= 1.5:     # replay what was answered 1.5 s ago
                    pub.put(sent.pop(0)[1])
                    counts["extra_sent"] += 1
            elif on and f == "forge-session" and k == a.at:
                for i in range(1, 11):
                    put(DATA, node, ticks, seq + i, (t_sample, 5.0), session=(state["session"] ^ 0x5A5A) or 1)
                    counts["extra_sent"] += 1
            elif on and f == "forge-peer" and k == a.at:
                for i in range(1, 11):
                    put(DATA, node, ticks, seq + i, (t_sample, 5.0), from_peer=peer ^ 0xA5A5)
                    counts["extra_sent"] += 1

        # keep the declarations referenced: zenoh-python undeclares an object when it is dropped
        declared = [s.declare_subscriber(f"{base}/rx", on_rx),
                    s.liveliness().declare_subscriber(f"{base}/sim/*", on_sim, history=True),
                    s.liveliness().declare_token(f"{base}/alive/{peer:016x}")]
        print("ready", flush=True)
        deadline = time.monotonic() + a.idle
        last = counts["received"]
        while state["status"] == "running":
            try:
                wake.get(timeout=0.1)
            except queue.Empty:
                pass
            if counts["received"] != last:
                last, deadline = counts["received"], time.monotonic() + a.idle
            elif time.monotonic() > deadline:
                stop("idle", f"no message for {a.idle} s")
        time.sleep(0.1)             # deliberate: let the last replies leave before closing (no ack to poll)
        del declared
        print(json.dumps({**counts, "status": state["status"], "peer": f"{peer:016x}"}), flush=True)
        if state["status"] != "ended":
            print(f"independent remote: {state['reason']}", file=sys.stderr, flush=True)
        code = {"ended": 0, "gone": 3, "refused": 4, "idle": 5}[state["status"]]
        if a.fault == "hang" or state["status"] == "gone":
            # a hung callback thread, or a hung peer, would hold closing the session for 10 s
            os._exit(code)
    finally:
        s.close()
    return code


if __name__ == "__main__":
    sys.exit(main())
