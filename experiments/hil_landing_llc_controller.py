"""The ch. 2 low-level controller as a real process (the remote side of ``hil_landing_llc``).

It connects to a running ``python -m netcosim.experiments.hil_landing_llc`` (which prints this
command with its endpoint and run id) and answers every sample of the simulated
tethered UAV with the thrust and torque to apply: the feedback linearization
(2.14)-(2.16) with PID and feed-forward of thesis §2.5
(``netcosim.controllers.landing.feedback_linearization.FeedbackLinearization``), one call per
sample, sampling period ``--period`` (0.002 s: 500 Hz in simulated time).

A sample (the simulation's ``RemotePlantIO`` with ``extra``) carries 10 float64 values:
the measured ``φ, φ̇, ϑ, ϑ̇`` (rad, rad/s), then the reference of the C² interpolator
(Fig. 2.6) at the sampling instant: ``φ_d, ϑ_d`` (rad), ``φ̇_d, ϑ̇_d`` (rad/s),
``φ̈_d, ϑ̈_d`` (rad/s², the feed-forward, evaluated ``ff_lead`` s after the instant).
The reply is ``(f_R, τ_R)`` (N, N·m), written to the plant (zero-order hold) when it
arrives.  It stops at the simulation's END message (exit status 0), when the simulation
is gone without one (3), when another process already serves the plant (4), or after
``--idle`` seconds without a message (5).  Its last line on stdout is a JSON object of its
counters (received, published, dropped, status, saturated, singular).

Imports: the client library (stdlib and Zenoh), NumPy and the low-level controller;
no SimPy, no CasADi.
"""

from __future__ import annotations

import argparse
import sys

from netcosim.controllers.landing.feedback_linearization import DEFAULT_FL_GAINS, FeedbackLinearization, PIDGains
from netcosim.plants.tethered_uav_params import TetheredUAVParams
from netcosim.transport.client import add_arguments, connect, finish

#: values in a sample: the measured state (4), the reference positions, velocities, accelerations (2 each)
SAMPLE_VALUES = 10


def controller(period: float = 0.002, gains: PIDGains = DEFAULT_FL_GAINS) -> FeedbackLinearization:
    """The low-level controller of the landing: default parameters (``SIM_PARAMS``),
    sampling period *period* (s), the same PID *gains* on both loops."""
    return FeedbackLinearization(TetheredUAVParams(), period, gains_phi=gains, gains_theta=gains)


def command(fl: FeedbackLinearization, values) -> tuple[float, float]:
    """``(f_R, τ_R)`` (N, N·m) for one sample's *values* (see the module doc)."""
    if len(values) != SAMPLE_VALUES:
        raise ValueError(f"a sample carries {SAMPLE_VALUES} values (state, reference), got {len(values)}")
    u = fl(values[0:4], values[4:6], values[6:8], values[8:10])
    return float(u[0]), float(u[1])


def serve(args: argparse.Namespace) -> int:
    """Answer samples until the run is over; returns the exit status."""
    fl = controller(args.period, PIDGains(*args.gains))
    with connect(args) as rp:
        print("ready", flush=True)
        rp.serve(lambda msg: command(fl, msg.values), timeout=args.idle)
        return finish(rp, {"saturated": fl.n_saturated, "singular": fl.n_singular})


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m netcosim.experiments.hil_landing_llc_controller",
                                description=__doc__.splitlines()[0], epilog="\n".join(__doc__.splitlines()[1:]),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    p.add_argument("--period", type=float, default=0.002, help="sampling period (s) of the controller (default 0.002)")
    p.add_argument("--gains", type=float, nargs=3, metavar=("KP", "KD", "KI"),
                   default=(DEFAULT_FL_GAINS.kp, DEFAULT_FL_GAINS.kd, DEFAULT_FL_GAINS.ki),
                   help="PID gains of both loops (1/s², 1/s, 1/s³; default: triple pole at -60 rad/s)")
    return serve(p.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
