"""Bad input to the tethered UAV helpers, the networked loop and the PID controller."""

from __future__ import annotations

import math

from invalid_cases import Case
from netcosim.errors import ConfigurationError, ConfigurationTypeError

NAN = math.nan


def _uav():
    import netcosim.plants.tethered_uav as m
    return m


def _pid(**kw):
    from netcosim.controllers.pid import PID
    return PID(h=0.01, **kw)


def _loop(names=False, **kw):
    """The networked servo's loop (experiments/networked_servo.py) with one argument replaced."""
    from netcosim import Simulation
    from netcosim.controllers.networked_loop import networked_loop
    from netcosim.network import IdealLink
    from netcosim.plants.dc_servo import DCServo
    sim = Simulation()
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo")
    net = IdealLink(sim, "link", data_rate=1e6)
    sensor, controller = sim.node("sensor"), sim.node("controller")
    s_if, c_if = net.attach(sensor), net.attach(controller)
    args = dict(law=_pid().compute, reference=lambda t: 1.0, period=0.01, io_exec=1e-4, control_exec=1e-3,
                frame_bits=80)
    args.update(kw)
    nodes = ("sensor", "controller") if names else (sensor, controller)
    networked_loop(servo, *nodes, s_if, c_if, **args)
    sim.run(0.05)


CASES = [
    Case("uav-wind-text", lambda: _uav().wind("x"), ConfigurationTypeError, "got 'x'"),
    Case("uav-wind-nan", lambda: _uav().wind(NAN), ConfigurationError, "wind: t"),
    Case("uav-wind-params-not-params", lambda: _uav().wind(0.01, 5), ConfigurationTypeError, "got 5"),
    Case("uav-hover-thrust-params-none", lambda: _uav().hover_thrust(0.0, 0.0, None), ConfigurationTypeError,
         "got None"),
    Case("uav-hover-thrust-nan", lambda: _uav().hover_thrust(NAN, 0.0, _uav().TetheredUAVParams()),
         ConfigurationError, "phi must be a finite number of rad, got nan"),
    Case("uav-landers-text", lambda: _uav().TetheredUAV(landers="x"), ConfigurationTypeError, "landers"),
    Case("loop-law-not-callable", lambda: _loop(law=5), ConfigurationTypeError, "law"),
    Case("loop-reference-none", lambda: _loop(reference=None), ConfigurationTypeError, "reference"),
    Case("loop-u-max-nan", lambda: _loop(u_max=NAN), ConfigurationError, "u_max"),
    Case("loop-u-max-negative", lambda: _loop(u_max=-1), ConfigurationError, "u_max must be None or a positive"),
    Case("loop-node-names", lambda: _loop(names=True), ConfigurationTypeError, "got 'sensor'"),
    Case("pid-compute-text", lambda: _pid().compute("a", 0), ConfigurationTypeError, "r must be a finite number"),
    Case("pid-compute-nan", lambda: _pid().compute(NAN, 0), ConfigurationError, "PID.compute: r"),
    Case("pid-compute-y-none", lambda: _pid().compute(0.0, None), ConfigurationTypeError, "y must be"),
    Case("pid-beta-nan", lambda: _pid(beta=NAN), ConfigurationError, "PID beta"),
]
