"""Analog I/O channels of a node (TrueTime's A/D and D/A ports).

A channel is connected to a plant port; ``ctx.read(node.analog_in(0))`` samples the
plant output at that instant, ``ctx.write(node.analog_out(0), u)`` sets the plant input,
which is held (zero-order hold) until the next write.  Using a channel that is not
connected raises :class:`~netcosim.errors.NotConnectedError`.
"""

from __future__ import annotations

from .. import validate
from ..errors import ConfigurationError, NotConnectedError


class _Channel:
    kind = "channel"

    def __init__(self, node, channel: int):
        channel = validate.integer(channel, f"node {node.name!r}: {self.kind} channel", lo=0,
                                   kind="a non-negative integer", type_error=ConfigurationError)
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
    kind = "analog input"

    def read(self):
        return self._port().read()


class AnalogOut(_Channel):
    kind = "analog output"

    def write(self, value) -> None:
        self._port().write(value)
