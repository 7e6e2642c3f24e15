"""The two encodings of a HIL message, one interface: ``"ncsm"`` (the native fixed layout,
:mod:`netcosim.transport.wire`; the default) and ``"cdr"`` (ROS 2-friendly: CDR payloads on
rmw_zenoh-style key expressions, :mod:`netcosim.transport.cdr`).  Stdlib and Zenoh only.

A :class:`Codec` says how a message is written and read, on which key expressions the
requests (``rx``) and replies (``tx``) travel, and which Zenoh encoding marks them.  The
liveliness tokens and the info query stay under ``netcosim/<run>/<node>/`` in both.

With ``"cdr"``, every message also carries the attachment ``rmw_zenoh_cpp`` (ROS 2 Jazzy)
expects on a topic's samples -- sequence number (int64), source timestamp (int64, ns) and
a 16-byte source GID, serialized as Zenoh's own serializer writes ``(int64, int64,
bytes)`` (``zenoh.ext.z_serialize``: 8 + 8 bytes little endian, then the length 16 as a
varint and the 16 bytes), the layout of ``AttachmentData`` in ``rmw_zenoh_cpp``
(``detail/attachment_helpers.cpp``).  Checked here against ``zenoh.ext`` and an independent
CDR decoder (``pycdr2``), not against a ROS 2 installation.
"""

from __future__ import annotations

import struct
import time
from typing import Any, Callable, NamedTuple

from . import cdr, wire
from .session import key

__all__ = ["Codec", "CODECS", "codec"]


def _cdr_decode(data: bytes) -> wire.Message:
    try:
        return wire.Message(*cdr.decode(data))
    except cdr.CdrError as e:
        raise wire.WireError(e.reason, str(e)) from None


class _AttachedPublisher:
    """A publisher adding rmw_zenoh's attachment (sequence number, timestamp, GID) to every put."""

    def __init__(self, pub: Any, gid: bytes):
        self._pub, self._gid, self._n = pub, gid, 0

    def put(self, data: bytes) -> None:
        self._n += 1
        self._pub.put(data, attachment=struct.pack("<qq", self._n, time.time_ns()) + bytes([len(self._gid)])
                      + self._gid)

    def undeclare(self) -> None:
        self._pub.undeclare()

    @property
    def matching_status(self) -> Any:
        return self._pub.matching_status


class Codec(NamedTuple):
    """An encoding of HIL messages: ``name``; ``encoding`` (the Zenoh encoding of every
    message); ``encode(kind, node, session, peer, ticks, seq, values) -> bytes``;
    ``decode(bytes) -> Message`` raising :class:`~netcosim.transport.wire.WireError` with a
    reason; ``data_key(run, node, leaf)``: the key expression of ``rx``/``tx``; ``attach``:
    whether a put carries rmw_zenoh's attachment."""

    name: str
    encoding: str
    encode: Callable[..., bytes]
    decode: Callable[[bytes], wire.Message]
    data_key: Callable[[str, str, str], str]
    attach: bool = False

    def publisher(self, session: Any, key_expr: str, ident: int) -> Any:
        """A publisher on *key_expr* of *session* that puts with this encoding (and, for
        ``cdr``, the attachment, with a GID made of the 64-bit id *ident*)."""
        pub = session.publisher(key_expr, encoding=self.encoding)
        return _AttachedPublisher(pub, ident.to_bytes(8, "little") * 2) if self.attach else pub


CODECS = {
    "ncsm": Codec("ncsm", wire.ENCODING, wire.encode, wire.decode, key),
    "cdr": Codec("cdr", "application/cdr", cdr.encode, _cdr_decode, cdr.ros_key, attach=True),
}


def codec(name: str) -> Codec:
    """The :class:`Codec` called *name* (``"ncsm"`` or ``"cdr"``); :class:`ValueError` naming it otherwise."""
    try:
        return CODECS[name]
    except (KeyError, TypeError):
        raise ValueError(f"encoding must be one of {sorted(CODECS)}, got {name!r}") from None
