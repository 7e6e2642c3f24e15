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
    <netcosim.kernel.node.Node.analog_in>`)."""

    kind = "analog input"

    def read(self):
        """The connected plant output at the current time (units of the plant's output); raises
        :class:`~netcosim.errors.NotConnectedError` when unconnected."""
        return self._port().read()


class AnalogOut(_Channel):
    """An analog output channel of a node, connected to a plant input port (see :meth:`Node.analog_out
    <netcosim.kernel.node.Node.analog_out>`)."""

    kind = "analog output"

    def write(self, value) -> None:
        """Set the connected plant input to *value* from now on (zero-order hold; units of the plant's
        input); raises :class:`~netcosim.errors.NotConnectedError` when unconnected."""
        self._port().write(value)
