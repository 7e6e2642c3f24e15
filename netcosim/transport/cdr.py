"""A ROS 2-friendly encoding of the version-2 HIL message: CDR payloads and rmw_zenoh key
expressions.  Stdlib only (the remote process imports it without NumPy or SimPy).

The same seven fields as the native ``ncsm`` layout of :mod:`netcosim.transport.wire`
(``kind, node, session, peer, ticks, seq, values``), serialized as OMG CDR (XCDR1, the
plain CDR of ROS 2 / Fast-DDS / Cyclone DDS and of ``rmw_zenoh_cpp`` payloads), little
endian, of this IDL struct::

    module netcosim_msgs { module msg {
      struct Frame {
        uint8 version;            // 2 (VERSION)
        uint8 kind;               // 1 DATA, 2 END, 3 REFUSED
        uint16 node;              // 0xFFFF LOCAL, 0xFFFE BROADCAST
        uint64 session;
        uint64 peer;
        int64 ticks;              // simulated time, 1 ps ticks
        uint32 seq;
        sequence<double> values;  // at most 1024 (MAX_VALUES)
      };
    }; };

or, as the ``netcosim_msgs/msg/Frame.msg`` file of a ROS 2 package (same type)::

    uint8 version
    uint8 kind
    uint16 node
    uint64 session
    uint64 peer
    int64 ticks
    uint32 seq
    float64[] values

Layout (``payload`` = offset in the bytes, ``cdr`` = offset used for CDR alignment, which
counts from the byte after the 4-byte encapsulation header)::

    payload cdr  size field      meaning
    0       -    2    encap id   00 01 = CDR_LE (a decoder rejects every other id)
    2       -    2    options    00 00 when encoding; ignored when decoding
    4       0    1    version    VERSION (2)
    5       1    1    kind       DATA, END, REFUSED
    6       2    2    node       network index (0xFFFF LOCAL, 0xFFFE BROADCAST)
    8       4    4    padding    zeros (alignment of the uint64 that follows); ignored
    12      8    8    session    uint64
    20      16   8    peer       uint64
    28      24   8    ticks      int64
    36      32   4    seq        uint32 (wraps at 2**32)
    40      36   4    count      sequence length, at most MAX_VALUES
    44      40   8n   values     float64 (already 8-aligned: no padding before them)

so a message is exactly ``44 + 8 * count`` bytes.  The layout is checked byte for byte
against an independent CDR implementation (``pycdr2``, Cyclone DDS's IDL package) in
``tests/test_hil_cdr.py``.

Reading these from ROS 2 (Jazzy or later, ``RMW_IMPLEMENTATION=rmw_zenoh_cpp``): put the
``Frame.msg`` (or ``Frame.idl``) above in a package named ``netcosim_msgs`` and build it
with ``rosidl_generate_interfaces``; the generated type then has the DDS name
:data:`TYPE_NAME` and the type hash :data:`TYPE_HASH` (computed here as rosidl does, see
:func:`rihs01`), so its topic ``/netcosim/<run>/<node>/<leaf>`` maps to the Zenoh key
expression that :func:`ros_key` returns.  A subscriber that is not ``rmw_zenoh_cpp`` (a
plain Zenoh subscriber on that key) can decode the payload with :func:`decode`, or with
any CDR library.

What is *not* done here, honestly:

* no rmw_zenoh liveliness tokens (``@ros2_lv/...``): a netcosim publisher is not in the
  ROS graph, so ``ros2 topic list`` / ``ros2 topic info`` do not show it;
* no rmw_zenoh attachment (int64 sequence number, int64 source timestamp, 16-byte
  publisher GID, written with Zenoh's ``ext`` serializer): ``rmw_zenoh_cpp`` 1.x
  subscriptions drop samples that carry no attachment ("Unable to obtain attachment",
  ``rmw_zenoh_cpp/src/detail/rmw_subscription_data.cpp``), so a ROS 2 node subscribed
  through ``rmw_zenoh_cpp`` does not receive what netcosim puts on these keys until a
  transport adds that attachment.  The other direction needs none of it: a payload
  published by a ROS 2 node is decoded by :func:`decode` (the attachment is ignored).
"""

from __future__ import annotations

import hashlib
import json
import re
import struct
from typing import Any, Sequence

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError, NetcosimError
from .wire import DATA, END, KINDS, MAX_VALUES, REFUSED, VERSION, check_fields

__all__ = ["VERSION", "DATA", "END", "REFUSED", "KINDS", "MAX_VALUES", "ENCAPSULATION", "HEADER",
           "CdrError", "encode", "decode", "ROS_TYPE", "TYPE_NAME", "FIELDS", "rihs01", "TYPE_HASH",
           "ros_key"]

# the version, kinds and largest payload are the native layout's: one message, two encodings
#: encapsulation identifier CDR_LE (XCDR1 plain CDR, little endian)
ENCAPSULATION = b"\x00\x01"
#: encapsulation id, options, version, kind, node, pad to 8, session, peer, ticks, seq, count
HEADER = struct.Struct("<2sHBBH4xQQqII")
_U32 = 0xFFFFFFFF


class CdrError(NetcosimError, ValueError):
    """A payload that is not a valid CDR ``Frame``; ``reason`` is one of ``"short"``,
    ``"encapsulation"``, ``"version"``, ``"kind"``, ``"oversized"``, ``"length"``; ``detail``
    says what was wrong, in the message."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"rejected CDR message ({reason}): {detail}")
        self.reason = reason


def encode(kind: int, node: int, session: int, peer: int, ticks: int, seq: int,
           values: Sequence[float] = ()) -> bytes:
    """The CDR bytes of one message (see the module docstring for the layout).

    The fields are those of :func:`netcosim.transport.wire.encode`: ``kind`` (``DATA``,
    ``END`` or ``REFUSED``), ``node`` (network index, or ``LOCAL`` / ``BROADCAST``),
    ``session`` and ``peer`` (64-bit ids), ``ticks`` (simulated time, ticks of 1 ps),
    ``seq`` and ``values`` (a sequence of real numbers, sent as float64).

    ``seq`` is taken modulo 2**32; every other field out of its range (``ticks`` is the
    IDL's signed ``int64``: a negative value is stored as such and decodes unchanged, as
    in the native layout) raises :class:`~netcosim.errors.ConfigurationError` (a
    ``ValueError``) naming it; a field that is not an integer, or a value that is not a
    real number, :class:`~netcosim.errors.ConfigurationTypeError` naming it.
    """
    for what, v in (("kind", kind), ("node", node), ("session", session), ("peer", peer), ("ticks", ticks),
                    ("seq", seq)):
        validate.integer(v, f"CDR message {what}")
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
        raise ConfigurationTypeError(f"CDR message values must be a sequence of numbers, got {_short(values)}")
    n = len(values)
    try:
        check_fields(kind, node, session, peer, ticks, n)
    except ValueError as exc:
        raise ConfigurationError(f"CDR {exc}") from None
    try:
        payload = struct.pack(f"<{n}d", *values)
    except struct.error:
        bad = next(((i, x) for i, x in enumerate(values) if not validate.is_real(x)), (None, values))
        raise ConfigurationTypeError(f"CDR message values[{bad[0]}] must be a real number, got {bad[1]!r}") \
            from None
    return HEADER.pack(ENCAPSULATION, 0, VERSION, kind, node, session, peer, ticks, seq & _U32, n) + payload


def decode(data: bytes | bytearray | memoryview) -> tuple[int, int, int, int, int, int, tuple[float, ...]]:
    """``(kind, node, session, peer, ticks, seq, values)`` of the CDR message in *data* (the
    field order of ``wire.Message``); raises :class:`CdrError` (with a ``reason``) for
    anything that is not exactly one valid message of this version, and
    :class:`~netcosim.errors.ConfigurationTypeError` for *data* that is not bytes."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise ConfigurationTypeError(f"CDR data must be bytes, a bytearray or a memoryview, got "
                                     f"{type(data).__name__} {_short(data)}")
    size = len(data)
    if size < HEADER.size:
        raise CdrError("short", f"{size} bytes, the header alone is {HEADER.size}")
    encap, _options, version, kind, node, session, peer, ticks, seq, n = HEADER.unpack_from(data)
    if encap != ENCAPSULATION:
        raise CdrError("encapsulation",
                       f"encapsulation {bytes(encap).hex(' ')}, only {ENCAPSULATION.hex(' ')} (CDR_LE) is read")
    if version != VERSION:
        raise CdrError("version", f"version {version}, this side speaks {VERSION}")
    if kind not in KINDS:
        raise CdrError("kind", f"kind {kind}, known kinds are {KINDS}")
    if n > MAX_VALUES:
        raise CdrError("oversized", f"{n} values announced, at most {MAX_VALUES} accepted")
    if size != HEADER.size + 8 * n:
        raise CdrError("length", f"{size} bytes for {n} values (expected {HEADER.size + 8 * n})")
    return kind, node, session, peer, ticks, seq, struct.unpack_from(f"<{n}d", data, HEADER.size)


# --- ROS 2 type name, type hash and key expression -------------------------------------

#: the ROS 2 interface name of the type (what rosidl hashes)
ROS_TYPE = "netcosim_msgs/msg/Frame"
#: the DDS type name that rmw_zenoh_cpp puts in key expressions (``<pkg>::msg::dds_::<Name>_``,
#: rmw_zenoh_cpp/src/detail/type_support_common.cpp, _create_type_name)
TYPE_NAME = "netcosim_msgs::msg::dds_::Frame_"
#: the fields of the type with their ``type_description_interfaces/msg/FieldType`` ids
#: (3 UINT8, 5 UINT16, 7 UINT32, 8 INT64, 9 UINT64, 155 DOUBLE_UNBOUNDED_SEQUENCE)
FIELDS = (("version", 3), ("kind", 3), ("node", 5), ("session", 9), ("peer", 9), ("ticks", 8),
          ("seq", 7), ("values", 155))


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


#: a ROS 2 interface name: tokens separated by "/" (``std_msgs/msg/String``)
_INTERFACE = re.compile(r"[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)+")


def rihs01(ros_type: str, fields: Sequence[tuple[str, int]]) -> str:
    """The ROS 2 type hash (``"RIHS01_"`` + 64 hex digits, REP-2016) of a type whose fields
    are all unbounded and none of a nested type, given as ``(name, FieldType id)`` pairs.

    As ``rosidl_generator_type_description`` computes it (``calculate_type_hash`` in
    ros2/rosidl ``rosidl_generator_type_description/__init__.py``): SHA-256 of the JSON of
    the type description without default values, written with ``", "`` and ``": "``
    separators and keys in this order.  Checked in the tests against published hashes
    (std_msgs/msg/String, std_msgs/msg/Float64, builtin_interfaces/msg/Time,
    sensor_msgs/msg/ChannelFloat32); :data:`TYPE_HASH` is also the value rosidl's own
    generator gives for the IDL and the ``.msg`` of the module docstring.  Nested types
    (which add ``referenced_type_descriptions``) and bounded sizes are not supported here.
    An empty or malformed *ros_type* (not ``package/msg/Name``), or a field that is not
    a ``(name, id)`` pair of a non-empty string and an integer, raises naming it.
    """
    if not isinstance(ros_type, str):
        raise ConfigurationTypeError(f"ros_type must be a ROS 2 interface name such as 'std_msgs/msg/String', "
                                     f"got {ros_type!r}")
    if not _INTERFACE.fullmatch(ros_type):
        raise ConfigurationError(f"ros_type must be a ROS 2 interface name such as 'std_msgs/msg/String', "
                                 f"got {ros_type!r}")
    if isinstance(fields, (str, bytes)) or not isinstance(fields, Sequence):
        raise ConfigurationTypeError(f"fields must be a sequence of (name, FieldType id) pairs, got {fields!r}")
    for i, f in enumerate(fields):
        if not (isinstance(f, (tuple, list)) and len(f) == 2 and isinstance(f[0], str) and f[0]
                and validate.is_real(f[1]) and float(f[1]).is_integer()):
            raise ConfigurationTypeError(f"fields[{i}] must be a (name, FieldType id) pair, got {f!r}")
    description = {
        "type_description": {
            "type_name": ros_type,
            "fields": [{"name": name, "type": {"type_id": type_id, "capacity": 0, "string_capacity": 0,
                                                "nested_type_name": ""}}
                       for name, type_id in fields],
        },
        "referenced_type_descriptions": [],
    }
    text = json.dumps(description, ensure_ascii=True, allow_nan=False, separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


#: the type hash of :data:`ROS_TYPE` (what rmw_zenoh_cpp puts in key expressions)
TYPE_HASH = rihs01(ROS_TYPE, FIELDS)

# one token of a ROS 2 name: letters, digits and "_", not starting with a digit
# (rmw/validate_full_topic_name.h: RMW_TOPIC_INVALID_NAME_TOKEN_STARTS_WITH_NUMBER)
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def ros_key(run: str, node: str, leaf: str, *, domain: int = 0) -> str:
    """The Zenoh key expression of the ROS 2 topic ``/netcosim/<run>/<node>/<leaf>`` of
    type :data:`TYPE_NAME` as rmw_zenoh_cpp (ROS 2 Jazzy) maps topics:
    ``<domain_id>/<topic name without its leading "/">/<type name>/<type hash>``.

    The slashes inside the topic name stay slashes in the data key; only the liveliness
    tokens replace them by ``%`` ("mangle").  Source: ``TopicInfo::TopicInfo`` (which
    builds ``topic_keyexpr_`` with ``strip_slashes``) in ros2/rmw_zenoh
    ``rmw_zenoh_cpp/src/detail/liveliness_utils.cpp``, and docs/design.md, "Topic and
    Service name mapping to Zenoh key expressions"
    (``0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df66...``).

    *run*, *node* and *leaf* are single ROS name tokens (letters, digits, ``_``, not
    starting with a digit: ROS names allow neither ``.`` nor ``-``); *domain* is the
    ``ROS_DOMAIN_ID``.  Anything else raises :class:`ValueError` naming the bad part.
    """
    for part, value in (("run", run), ("node", node), ("leaf", leaf)):
        if not isinstance(value, str) or not _TOKEN.fullmatch(value):
            raise ValueError(f"ros_key {part} must be a ROS name token (letters, digits and '_', "
                             f"not starting with a digit), got {value!r}")
    if type(domain) is not int or domain < 0:      # a bool is no domain id; stdlib only, no validate
        raise ValueError(f"ros_key domain must be a non-negative integer (ROS_DOMAIN_ID), got {domain!r}")
    return f"{domain}/netcosim/{run}/{node}/{leaf}/{TYPE_NAME}/{TYPE_HASH}"
