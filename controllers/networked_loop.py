"""TrueTime's networked control loop as task factories: a time-driven sensor node, an
event-driven controller node and an event-driven actuator, talking over any netcosim
network (the "networked servo" of the TrueTime examples).

The sensor samples the plant output every ``period`` s and sends ``(t_sample, y)`` to
the controller; the controller runs on each arrival and sends ``(t_sample, u)`` back;
the actuator task on the sensor node writes ``u`` on each arrival (zero-order hold)
and logs the sampling-to-actuation delay.  Times in seconds, sizes in bits.
"""

from __future__ import annotations

from typing import Any, Callable

from netcosim import validate
from netcosim.errors import ConfigurationTypeError
from netcosim.network import BROADCAST

__all__ = ["networked_loop"]


def networked_loop(plant: Any, sensor: Any, controller: Any, sensor_iface: Any, controller_iface: Any, *,
                   law: Callable[[float, float], float], reference: Callable[[float], float], period: float,
                   io_exec: float, control_exec: float, frame_bits: int, u_max: float | None = None,
                   log_reference: bool = True, broadcast: bool = False) -> None:
    """Add the loop's three tasks to the nodes *sensor* and *controller*.

    ``plant``: a plant instance (output 0 is measured, input 0 actuated);
    ``sensor_iface``/``controller_iface``: the nodes' network interfaces;
    ``law(r, y) -> u`` the control law (e.g. ``PID.compute``), ``reference(t)`` the set
    point at the sampling instant ``t`` (s); ``period``: sampling period (s);
    ``io_exec``/``control_exec``: CPU time (s) of the sensor/actuator and controller
    jobs; ``frame_bits``: size of each message (bits); ``u_max``: saturate ``|u|`` to
    this value (None: no saturation); ``log_reference``: log ``r`` beside ``y``;
    ``broadcast``: address every message to ``BROADCAST`` instead of the peer node (on
    a wireless network: no ACK and no retry, so a lost frame is a lost message; meant
    for a network holding just the two nodes, as every other node receives them too).
    Signals logged: ``u`` and ``delay`` (s) by ``sensor.actuate``, ``r`` and ``y`` by
    ``controller.pid``.

    Checked before any task is added, each error naming the argument: *sensor* and
    *controller* must be nodes (``sim.node(...)``, not their names), the interfaces
    network interfaces, *law* and *reference* callables, ``u_max`` None or a positive
    finite bound (``|u| <= u_max``; 0 or less would hold u at -u_max).
    """
    for what, node in (("sensor", sensor), ("controller", controller)):
        if not (hasattr(node, "periodic") and hasattr(node, "aperiodic") and hasattr(node, "name")):
            raise ConfigurationTypeError(f"networked_loop: {what} must be a node (sim.node(...)), got {node!r}")
    for what, iface in (("sensor_iface", sensor_iface), ("controller_iface", controller_iface)):
        if not (hasattr(iface, "mailbox") and hasattr(iface, "on_receive")):
            raise ConfigurationTypeError(f"networked_loop: {what} must be a network interface "
                                         f"(network.attach(node)), got {iface!r}")
    validate.callable_(law, "networked_loop: law", kind="a function law(r, y) -> u")
    validate.callable_(reference, "networked_loop: reference", kind="a function reference(t) -> r")
    if u_max is not None:
        validate.positive(u_max, "networked_loop: u_max", kind="None or a positive finite bound on |u|")
    y_port, u_port = plant.output(0), plant.input(0)
    controller_name: Any = BROADCAST if broadcast else controller.name
    sensor_name: Any = BROADCAST if broadcast else sensor.name

    @sensor.periodic(period=period, priority=2, name="sample")
    def sample(ctx):
        y = ctx.read(y_port)
        t = ctx.now
        yield ctx.execute(io_exec)
        ctx.send(controller_name, (t, y), frame_bits)

    @sensor.aperiodic(priority=1, name="actuate")
    def actuate(ctx):
        msg = sensor_iface.mailbox.try_fetch()
        yield ctx.execute(io_exec)
        t_sample, u = msg.payload
        ctx.write(u_port, u)
        ctx.log("u", u)
        ctx.log("delay", ctx.now - t_sample)

    sensor_iface.on_receive(actuate)

    @controller.aperiodic(priority=1, name="pid")
    def control(ctx):
        msg = controller_iface.mailbox.try_fetch()
        t_sample, y = msg.payload
        r = reference(t_sample)
        u = law(r, y)
        if u_max is not None:
            u = min(u_max, max(-u_max, u))
        if log_reference:
            ctx.log("r", r)
        ctx.log("y", y)
        yield ctx.execute(control_exec)
        ctx.send(sensor_name, (t_sample, u), frame_bits)

    controller_iface.on_receive(control)
