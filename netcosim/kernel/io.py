"""Analog I/O channels of a node (TrueTime's A/D and D/A ports).

A channel is connected to a plant port; ``ctx.read(node.analog_in(0))`` samples the
plant output at that instant, ``ctx.write(node.analog_out(0), u)`` sets the plant input,
which is held (zero-order hold) until the next write.  Using a channel that is not
connected raises :class:`~netcosim.errors.NotConnectedError`.
"""

from __future__ import annotations

from .. import validate
from ..errors import ConfigurationError, NotConnectedError

#: The largest analog channel number a node accepts (channels 0..MAX_CHANNEL; a bigger
#: number, 2**70, is a bug rather than a channel).
MAX_CHANNEL = 65535


class _Channel:
    kind = "channel"

    def __init__(self, node, channel: int):
        channel = validate.integer(channel, f"node {node.name!r}: {self.kind} channel", lo=0, hi=MAX_CHANNEL,
                                   kind=f"an integer in 0..{MAX_CHANNEL} (netcosim.kernel.io.MAX_CHANNEL)",
                                   type_error=ConfigurationError)
        self.node, self.channel = node, channel
        self.port = None

    def connect(self, port) -> "_Channel":
        self.port = port
        return self

    def _port(self):
        if self.port is None:
            raise NotConnectedError(f"{self.kind} {self.channel} of node {self.node.name!r} is not connected")
        return self.port

    def __repr__(self):
        return f"<{type(self).__name__} {self.node.name}[{self.channel}] -> {self.port!r}>"


class AnalogIn(_Channel):
    """An analog input channel of a node, connected to a plant output port (see :meth:`Node.analog_in
    <netcosim.kernel.node.Node.analog_in>`).

    Examples
    --------
    A tank integrating its inflow, ``dx/dt = u``: the node samples the level through analog
    input 0 every 10 ms and sets the inflow to 2 through analog output 0 at the end of the
    first job's 1 ms of CPU (times in seconds), so it reads ``2 x (t - 0.001)``.

    >>> from netcosim import ContinuousSystem, Simulation
    >>> sim = Simulation()
    >>> tank = sim.plant(ContinuousSystem(f=lambda t, x, u, p: u, states=["x"], inputs=["u"], outputs=["y"]),
    ...                  x0=[0.0], name="tank")
    >>> cpu = sim.node("cpu")
    >>> adc = cpu.analog_in(0).connect(tank.output("y"))
    >>> dac = cpu.analog_out(0).connect(tank.input("u"))
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def ctrl(ctx):
    ...     ctx.log("y", ctx.read(adc))      # or adc.read()
    ...     yield ctx.execute(0.001)
    ...     ctx.write(dac, 2.0)
    >>> sim.run(until=0.030)
    >>> sim.trace.signal("cpu.ctrl", "y").round(6).tolist()
    [0.0, 0.018, 0.038]

    A channel not connected to a port refuses to be read:

    >>> cpu.analog_in(1).read()
    Traceback (most recent call last):
    ...
    netcosim.errors.NotConnectedError: analog input 1 of node 'cpu' is not connected
    """

    kind = "analog input"

    def read(self):
        """The connected plant output at the current time (units of the plant's output); raises
        :class:`~netcosim.errors.NotConnectedError` when unconnected."""
        return self._port().read()


class AnalogOut(_Channel):
    """An analog output channel of a node, connected to a plant input port (see :meth:`Node.analog_out
    <netcosim.kernel.node.Node.analog_out>`).

    Examples
    --------
    A step of 2 on a tank integrating its inflow (``dx/dt = u``), written through analog
    output 0 at the end of 1 ms of CPU: 30 ms later the level is ``2 x (0.030 - 0.001)``
    (times in seconds).

    >>> from netcosim import ContinuousSystem, Simulation
    >>> sim = Simulation()
    >>> tank = sim.plant(ContinuousSystem(f=lambda t, x, u, p: u, states=["x"], inputs=["u"], outputs=["y"]),
    ...                  x0=[0.0], name="tank")
    >>> cpu = sim.node("cpu")
    >>> dac = cpu.analog_out(0).connect(tank.input("u"))
    >>> @cpu.aperiodic(priority=1)
    ... def step(ctx):
    ...     yield ctx.execute(0.001)
    ...     ctx.write(dac, 2.0)              # or dac.write(2.0): held until the next write
    >>> _ = step.release()
    >>> sim.run(until=0.030)
    >>> round(float(tank.x[0]), 6)
    0.058
    """

    kind = "analog output"

    def write(self, value) -> None:
        """Set the connected plant input to *value* from now on (zero-order hold; units of the plant's
        input); raises :class:`~netcosim.errors.NotConnectedError` when unconnected."""
        self._port().write(value)
