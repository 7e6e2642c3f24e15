"""The wire format of netcosim's hardware-in-the-loop messages: one fixed ``struct`` header
and a payload of IEEE-754 float64 values, little endian.  Never pickle.

Layout, version 2 (little endian, 40-byte header, then ``count`` float64 values).  Every
field lies at an offset that is a multiple of its size, so the C struct of the same
fields in the same order has no padding on any common ABI (``sizeof == 40``; the header
C programs include is ``netcosim/transport/ncsm_wire.h``)::

    offset size type     field    meaning
    0      4    char[4]  magic    b"NCSM"
    4      1    uint8    version  :data:`VERSION` (a decoder rejects every other version)
    5      1    uint8    kind     :data:`DATA`, :data:`END` (the run is over), :data:`REFUSED`
    6      2    uint16   node     network index of the destination (to the simulation) or of
                                  the source (from it); :data:`LOCAL`: the node's own plant
                                  I/O; :data:`BROADCAST`: every other node of the network
    8      8    uint64   session  the simulation run's session id (random, never 0)
    16     8    uint64   peer     the remote process's id (random, never 0; chosen by it)
    24     8    int64    ticks    simulated time (ticks of 1 ps); a reply echoes its request's
    32     4    uint32   seq      the request's number (wraps at 2**32); a reply echoes it
    36     4    uint32   count    number of float64 values that follow (at most :data:`MAX_VALUES`)
    40     8n   double   values

Versioning: :data:`VERSION` changes with any change of layout or meaning (a field, a
kind, a rule of matching); a decoder accepts its own version only, so two sides of
different versions refuse each other's messages (counted, reason ``"version"``) rather
than misread them.

Fixed layouts instead of msgpack or Protocol Buffers: a message is a handful of numbers,
the format is read by ``struct`` on both sides (also from a microcontroller in C), and a
fixed header makes every check a length comparison.  Stdlib only: the real process
needs neither NumPy nor SimPy to speak it.  A ROS 2-friendly alternative with the same
fields (CDR): :mod:`netcosim.transport.cdr`.
"""

from __future__ import annotations

import math
import struct
from typing import NamedTuple, Sequence

__all__ = ["MAGIC", "VERSION", "DATA", "END", "REFUSED", "KINDS", "LOCAL", "BROADCAST", "HEADER", "MAX_VALUES",
           "ENCODING", "Message", "WireError", "encode", "decode", "finite"]

MAGIC = b"NCSM"
#: version of the layout above; bumped on any change of layout or meaning
VERSION = 2
#: kind of a request (simulation -> process) or of a reply (process -> simulation)
DATA = 1
#: kind of the message that ends a run: the simulation's (no values), then the process's
#: answer after its last reply
END = 2
#: kind of the message the simulation sends a second process claiming a node already
#: served by another (``peer`` names the refused process); the refused process stops
REFUSED = 3
KINDS = (DATA, END, REFUSED)
#: ``node`` of a request sampled from / a reply written to the node's own plant I/O
LOCAL = 0xFFFF
#: ``node`` of a reply the simulation broadcasts on the node's network
BROADCAST = 0xFFFE
HEADER = struct.Struct("<4sBBHQQqII")
#: largest payload a decoder accepts (float64 values: 8 KiB)
MAX_VALUES = 1024
#: the Zenoh encoding set on every message of this format
ENCODING = "application/octet-stream;netcosim.ncsm.v2"
_U16, _U32, _U64 = 0xFFFF, 0xFFFFFFFF, 0xFFFFFFFFFFFFFFFF
_I64 = 1 << 63


class WireError(ValueError):
    """A message that is not a valid netcosim message; ``reason`` is one of
    ``"short"``, ``"magic"``, ``"version"``, ``"kind"``, ``"oversized"``, ``"length"``; ``detail``
    says what was wrong, in the message."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"rejected message ({reason}): {detail}")
        self.reason = reason


class Message(NamedTuple):
    """One decoded message: ``kind``, ``node`` (network index, :data:`LOCAL` or
    :data:`BROADCAST`), ``session`` and ``peer`` (ids), ``ticks`` (simulated time,
    integer ticks of 1 ps), ``seq`` and ``values`` (tuple of floats)."""

    kind: int
    node: int
    session: int
    peer: int
    ticks: int
    seq: int
    values: tuple[float, ...]


def check_fields(kind: int, node: int, session: int, peer: int, ticks: int, n: int) -> None:
    """Raise :class:`ValueError` naming the first field out of its range (``seq`` is
    always taken modulo 2**32): ``kind`` one of :data:`KINDS`, ``node`` in [0, 65535],
    ``session`` and ``peer`` in [0, 2**64 - 1], ``ticks`` a signed 64-bit integer, ``n``
    (the number of values) at most :data:`MAX_VALUES`."""
    if kind not in KINDS:
        raise ValueError(f"message kind must be one of {KINDS}, got {kind!r}")
    if not 0 <= node <= _U16:
        raise ValueError(f"message node index must be in [0, {_U16}], got {node!r}")
    for what, v in (("session", session), ("peer", peer)):
        if not 0 <= v <= _U64:
            raise ValueError(f"message {what} id must be in [0, 2**64 - 1], got {v!r}")
    if not -_I64 <= ticks < _I64:
        raise ValueError(f"message ticks must fit a signed 64-bit integer, got {ticks!r}")
    if n > MAX_VALUES:
        raise ValueError(f"a message carries at most {MAX_VALUES} values, got {n}")


def encode(kind: int, node: int, session: int, peer: int, ticks: int, seq: int,
           values: Sequence[float] = ()) -> bytes:
    """The bytes of one message (see the module docstring for the layout).

    ``kind``: :data:`DATA`, :data:`END` or :data:`REFUSED`; ``node``: the network index of
    the destination (to the simulation) or source (from it), or :data:`LOCAL` /
    :data:`BROADCAST`; ``session``: the run's session id; ``peer``: the remote process's
    id; ``ticks``: simulated time (ticks of 1 ps); ``values``: the float64 payload.
    ``seq`` is taken modulo 2**32; every other field out of its range raises
    :class:`ValueError` naming it (:func:`check_fields`).
    """
    n = len(values)
    check_fields(kind, node, session, peer, ticks, n)
    return HEADER.pack(MAGIC, VERSION, kind, node, session, peer, ticks, seq & _U32, n) + \
        struct.pack(f"<{n}d", *values)


def decode(data: bytes | bytearray | memoryview) -> Message:
    """The :class:`Message` in *data*; raises :class:`WireError` (with a ``reason``) for
    anything that is not exactly one valid message of this version."""
    size = len(data)
    if size < HEADER.size:
        raise WireError("short", f"{size} bytes, the header alone is {HEADER.size}")
    magic, version, kind, node, session, peer, ticks, seq, n = HEADER.unpack_from(data)
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
    return Message(kind, node, session, peer, ticks, seq, struct.unpack_from(f"<{n}d", data, HEADER.size))


def finite(values: Sequence[float]) -> bool:
    """True if every value of *values* is finite (no NaN, no infinity)."""
    isfinite = math.isfinite
    return all(isfinite(v) for v in values)
