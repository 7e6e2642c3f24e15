"""A remote for the networked servo speaking the ROS 2-friendly encoding (CDR payloads on
rmw_zenoh-style keys), written without netcosim: ``zenoh`` for transport and ``pycdr2``
(Cyclone DDS's IDL/CDR package) for the messages.  It asks the simulation for the keys
and the session with the info query (``netcosim/<run>/<node>/info``), checks that every
request carries rmw_zenoh's attachment (int64 sequence number, int64 timestamp, 16-byte
GID, read with ``zenoh.ext``), answers ``(t_sample, y)`` with ``(t_sample, u)`` of
TrueTime's PID and the same attachment, and answers END with its own.  Its last stdout
line is a JSON object of its counters.
"""

# no `from __future__ import annotations`: pycdr2 reads the dataclass annotations as types
import argparse
import json
import queue
import secrets
import sys
import time
from dataclasses import dataclass

import pycdr2
import zenoh
from hil_independent_remote import PID, reference  # beside this file: the same PID, still no netcosim
from pycdr2.types import float64, int64, sequence, uint8, uint16, uint32, uint64
from zenoh.ext import Int64, z_deserialize, z_serialize

DATA, END = 1, 2


@dataclass
class Frame(pycdr2.IdlStruct, typename="netcosim_msgs::msg::dds_::Frame_"):
    version: uint8
    kind: uint8
    node: uint16
    session: uint64
    peer: uint64
    ticks: int64
    seq: uint32
    values: sequence[float64]


def main(argv=None):
    p = argparse.ArgumentParser()
    for opt in ("--run", "--node", "--session", "--encoding", "--zenoh-config"):
        p.add_argument(opt)
    p.add_argument("--connect", action="append", required=True)
    p.add_argument("--lease", type=float, default=1.0)
    p.add_argument("--idle", type=float, default=10.0)
    a = p.parse_args(argv)
    conf = zenoh.Config()
    for k, v in (("mode", "peer"), ("scouting/multicast/enabled", False), ("scouting/gossip/enabled", False),
                 ("listen/endpoints", []), ("connect/endpoints", a.connect)):
        conf.insert_json5(k, json.dumps(v))
    s = zenoh.open(conf)
    peer = secrets.randbits(64) or 1
    counts = {"received": 0, "published": 0, "attachments": 0, "status": "running"}
    done: queue.SimpleQueue = queue.SimpleQueue()
    try:
        info = None
        for _ in range(50):             # until the simulation answers the info query
            for reply in s.get(f"netcosim/{a.run}/{a.node}/info", timeout=1.0):
                if reply.ok is not None:
                    info = json.loads(reply.ok.payload.to_bytes())
            if info is not None:
                break
            time.sleep(0.1)             # the polling interval of the info query above
        session = int(info["session"], 16)
        pid, n = PID(), [0]
        pub = s.declare_publisher(info["keys"]["tx"], encoding=zenoh.Encoding("application/cdr"),
                                  congestion_control=zenoh.CongestionControl.BLOCK, express=True)

        def put(frame):
            n[0] += 1
            pub.put(frame.serialize(), attachment=z_serialize((Int64(n[0]), Int64(time.time_ns()),
                                                               peer.to_bytes(8, "little") * 2)))

        def on_rx(sample):
            m = Frame.deserialize(sample.payload.to_bytes())
            seqno, stamp, gid = z_deserialize(tuple[Int64, Int64, bytes], sample.attachment)
            if seqno > 0 and stamp > 0 and len(gid) == 16:
                counts["attachments"] += 1
            if m.session != session or m.peer not in (peer, 0):
                return
            if m.kind == END:
                put(Frame(2, END, 0, session, peer, m.ticks, m.seq, []))
                counts["status"] = "ended"
                done.put(True)
                return
            counts["received"] += 1
            t_sample, y = m.values
            put(Frame(2, DATA, m.node, session, peer, m.ticks, m.seq, [t_sample, pid.compute(reference(t_sample), y)]))
            counts["published"] += 1

        keep = [s.declare_subscriber(info["keys"]["rx"], on_rx),
                s.liveliness().declare_token(f"netcosim/{a.run}/{a.node}/alive/{peer:016x}")]
        print("ready", flush=True)
        try:
            done.get(timeout=30)
        except queue.Empty:
            counts["status"] = "idle"
        time.sleep(0.1)                 # deliberate: let the last replies leave before closing (no ack to poll)
        del keep
    finally:
        s.close()
    print(json.dumps({**counts, "info": info}), flush=True)
    return 0 if counts["status"] == "ended" else 5


if __name__ == "__main__":
    sys.exit(main())
