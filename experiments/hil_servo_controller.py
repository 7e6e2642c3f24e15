"""The networked servo's PID controller as a real process (the remote side of ``hil_servo``).

It connects to a running ``python -m netcosim.experiments.hil_servo`` (or ``netcosim hil``), which
prints this command with its endpoint and run id, and answers every measurement
``(t_sample, y)`` the simulated network delivers with ``(t_sample, u)``: TrueTime's PID
(K = 0.96, Ti = 0.12, Td = 0.049, beta = 0.5, N = 10, h = 10 ms) on the reference of
the networked servo (square wave, amplitude 1, period 1 s).  It stops at the
simulation's END message (exit status 0), when the simulation is gone without one (3),
when another process already serves the node (4), or after ``--idle`` seconds without a
message (5); the reason goes to stderr.  Its last line on stdout is a JSON object of its
counters (received, published, dropped by reason, status).

Payload schema: a request carries ``(t_sample, y)`` (s, rad) from the sensor (network
index 0); the reply ``(t_sample, u)`` (s, V) goes back to it.

Imports: the client library (stdlib and Zenoh) and the PID; no SimPy, no CasADi.
"""

from __future__ import annotations

import argparse
import math
import sys

from netcosim.controllers.pid import PID
from netcosim.transport.client import add_arguments, connect, finish

PERIOD = 0.010      # the sensor's sampling period (s): the PID's h


def reference(t: float) -> float:
    """The networked servo's set point at sampling instant *t* (s): +1 on the first half
    of each second, -1 on the second (``netcosim.experiments.servo.square_wave(1.0, 1.0)``)."""
    return 1.0 if int(math.floor(t / 0.5 + 1e-12)) % 2 == 0 else -1.0


def serve(args: argparse.Namespace) -> int:
    """Answer measurements until the run is over; returns the exit status."""
    pid = PID(h=PERIOD)
    with connect(args) as rp:
        print("ready", flush=True)
        for msg in rp.messages(timeout=args.idle):
            t_sample, y = msg.values
            rp.reply(msg, (t_sample, pid.compute(reference(t_sample), y)))
        return finish(rp)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m netcosim.experiments.hil_servo_controller",
                                description=__doc__.splitlines()[0],
                                epilog="\n".join(__doc__.splitlines()[1:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    return serve(p.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
