"""The wire format of netcosim's hardware-in-the-loop messages: one fixed ``struct`` header
and a payload of IEEE-754 float64 values, little endian.  Never pickle.

Layout (little endian, 24-byte header, then ``count`` float64 values)::

    offset size field    meaning
    0      4    magic    b"NCSM"
    4      1    version  :data:`VERSION` (a decoder rejects every other version)
    5      1    kind     :data:`DATA` (a frame's payload), :data:`END` (the run is over)
    6      2    node     network index of the destination (``tx``) or of the source (``rx``)
    8      4    seq      sender's message counter (wraps at 2**32)
    12     8    ticks    simulated time of the frame (integer ticks of 1 ps, signed)
    20     4    count    number of float64 values that follow (at most :data:`MAX_VALUES`)
    24     8n   values

Fixed layouts instead of msgpack or Protocol Buffers: a message is a handful of numbers,
the format is read by ``struct`` on both sides (also from a microcontroller in C), and a
fixed header makes every check a length comparison.  Stdlib only: the real process
needs neither NumPy nor SimPy to speak it.
"""

from __future__ import annotations

import struct
from typing import NamedTuple, Sequence

__all__ = ["MAGIC", "VERSION", "DATA", "END", "KINDS", "HEADER", "MAX_VALUES", "Message", "WireError",
           "encode", "decode"]

MAGIC = b"NCSM"
#: version of the layout above; bumped on any change
VERSION = 1
#: kind of a message carrying a frame's payload
DATA = 1
#: kind of the message the simulation publishes when the run is over (no values)
END = 2
KINDS = (DATA, END)
HEADER = struct.Struct("<4sBBHIqI")
#: largest payload a decoder accepts (float64 values: 8 KiB)
MAX_VALUES = 1024
_U16, _U32 = 0xFFFF, 0xFFFFFFFF


class WireError(ValueError):
    """A message that is not a valid netcosim message; ``reason`` is one of
    ``"short"``, ``"magic"``, ``"version"``, ``"kind"``, ``"oversized"``, ``"length"``."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"rejected message ({reason}): {detail}")
        self.reason = reason


class Message(NamedTuple):
    """One decoded message: ``kind``, ``node`` (network index), ``seq``, ``ticks``
    (simulated time, integer ticks of 1 ps) and ``values`` (tuple of floats)."""

    kind: int
    node: int
    seq: int
    ticks: int
    values: tuple[float, ...]


def encode(kind: int, node: int, seq: int, ticks: int, values: Sequence[float] = ()) -> bytes:
    """The bytes of one message (see the module docstring for the layout).

    ``seq`` is taken modulo 2**32; every other field out of its range raises
    :class:`ValueError` naming it.
    """
    if kind not in KINDS:
        raise ValueError(f"message kind must be one of {KINDS}, got {kind!r}")
    if not 0 <= node <= _U16:
        raise ValueError(f"message node index must be in [0, {_U16}], got {node!r}")
    n = len(values)
    if n > MAX_VALUES:
        raise ValueError(f"a message carries at most {MAX_VALUES} values, got {n}")
    return HEADER.pack(MAGIC, VERSION, kind, node, seq & _U32, ticks, n) + struct.pack(f"<{n}d", *values)


def decode(data: bytes | bytearray | memoryview) -> Message:
    """The :class:`Message` in *data*; raises :class:`WireError` (with a ``reason``) for
    anything that is not exactly one valid message of this version."""
    size = len(data)
    if size < HEADER.size:
        raise WireError("short", f"{size} bytes, the header alone is {HEADER.size}")
    magic, version, kind, node, seq, ticks, n = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise WireError("magic", f"starts with {bytes(magic)!r}, not {MAGIC!r}")
    if version != VERSION:
        raise WireError("version", f"version {version}, this side speaks {VERSION}")
    if kind not in KINDS:
        raise WireError("kind", f"kind {kind}, known kinds are {KINDS}")
    if n > MAX_VALUES:
        raise WireError("oversized", f"{n} values announced, at most {MAX_VALUES} accepted")
    if size != HEADER.size + 8 * n:
        raise WireError("length", f"{size} bytes for {n} values (expected {HEADER.size + 8 * n})")
    return Message(kind, node, seq, ticks, struct.unpack_from(f"<{n}d", data, HEADER.size))
