"""The networked servo's PID controller as a real process (the remote side of ``hil_servo``).

It connects to a running ``python -m experiments.hil_servo`` (or ``netcosim hil``), which
prints this command with its endpoint and run id, and answers every measurement
``(t_sample, y)`` the simulated network delivers with ``(t_sample, u)``: TrueTime's PID
(K = 0.96, Ti = 0.12, Td = 0.049, beta = 0.5, N = 10, h = 10 ms) on the reference of
the networked servo (square wave, amplitude 1, period 1 s).  It stops at the
simulation's END message, or after ``--idle`` seconds without a message.  Its last line
on stdout is a JSON object of its counters (received, published, rejected).

Imports: the client library (stdlib and Zenoh) and the PID; no SimPy, no CasADi.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from controllers.pid import PID
from netcosim.transport.client import RemoteProcess

PERIOD = 0.010      # the sensor's sampling period (s): the PID's h


def reference(t: float) -> float:
    """The networked servo's set point at sampling instant *t* (s): +1 on the first half
    of each second, -1 on the second (``experiments.servo.square_wave(1.0, 1.0)``)."""
    return 1.0 if int(math.floor(t / 0.5 + 1e-12)) % 2 == 0 else -1.0


def serve(run: str, connect: list[str], *, node: str = "controller", idle: float = 10.0,
          lease: float = 1.0) -> dict:
    """Answer measurements until the run ends; returns the counters."""
    pid = PID(h=PERIOD)
    with RemoteProcess(node, run=run, connect=connect, lease=lease) as rp:
        print("ready", flush=True)
        for msg in rp.messages(timeout=idle):
            t_sample, y = msg.values
            rp.reply(msg, (t_sample, pid.compute(reference(t_sample), y)))
        return {"received": rp.received, "published": rp.published, "rejected": rp.rejected, "ended": rp.ended}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m experiments.hil_servo_controller", description=__doc__.splitlines()[0],
                                epilog="\n".join(__doc__.splitlines()[1:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", required=True, help="run id printed by the simulation side")
    p.add_argument("--connect", action="append", required=True, help="simulation endpoint, e.g. tcp/127.0.0.1:7447")
    p.add_argument("--node", default="controller", help="name of the remote node (default: controller)")
    p.add_argument("--idle", type=float, default=10.0, help="give up after this many seconds without a message")
    p.add_argument("--lease", type=float, default=1.0, help="liveliness lease of the session (s)")
    a = p.parse_args(argv)
    counters = serve(a.run, a.connect, node=a.node, idle=a.idle, lease=a.lease)
    print(json.dumps(counters), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
