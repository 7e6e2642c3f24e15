"""Hermetic Zenoh sessions for hardware-in-the-loop runs (stdlib and Zenoh only).

:func:`open_session` opens a Zenoh session in peer mode with multicast and gossip
scouting off, listening only where told (default: loopback, port 0 chosen by the OS,
the real port read back into :attr:`Session.endpoints`) and connecting only where told.
So two runs on one machine never see each other, and nothing leaves the machine unless
an endpoint says so.  For several machines, connect every side to a Zenoh router
(``zenohd``) by address: ``connect=["tcp/192.168.1.10:7447"]``, ``listen=()``.

Authentication and encryption come from Zenoh's own configuration file
(``open_session(config=PATH)``): user/password (``transport/auth/usrpwd``), TLS
(``transport/link/tls``, endpoints ``tls/...``) and the rest are kept, and the hermetic
keys above are set on top (``docs/hil_security.md``).

Keys of one run live under ``netcosim/<run>/`` (:func:`key`).  Every session must be
closed (a session left open with a Python callback hangs interpreter exit): use it as a
context manager or call :meth:`Session.close` in ``finally``.
"""

from __future__ import annotations

import errno
import json
import os
import re
import uuid
from typing import Any, Callable, Sequence

__all__ = ["LOOPBACK", "DEFAULT_LEASE", "zenoh_available", "key", "new_run_id", "open_session", "Session"]

#: listen endpoint of a hermetic session: loopback, port chosen by the OS
LOOPBACK = "tcp/127.0.0.1:0"
#: default lease (s): a peer silent for this long is declared gone (its liveliness token dropped)
DEFAULT_LEASE = 1.0
_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")
#: the copy of the whole configuration Zenoh appends to "Invalid configuration" (passwords in clear)
_CONFIG_DUMP = re.compile(r"Invalid configuration: \{.*\}", re.S)


def zenoh_available() -> bool:
    """True if the ``eclipse-zenoh`` package (the ``zenoh`` extra) can be imported."""
    try:
        import zenoh  # noqa: F401
    except ImportError:
        return False
    return True


def _zenoh():
    try:
        import zenoh
    except ImportError:
        raise ImportError("hardware-in-the-loop needs Eclipse Zenoh: pip install 'netcosim[zenoh]' "
                          "(the eclipse-zenoh package)") from None
    return zenoh


def key(run: str, node: str, leaf: str) -> str:
    """The key ``netcosim/<run>/<node>/<leaf>`` (each part letters, digits, ``_``, ``.`` or ``-``)."""
    for what, part in (("run id", run), ("node name", node), ("key leaf", leaf)):
        if not isinstance(part, str) or not _NAME.match(part):
            raise ValueError(f"{what} must be letters, digits, '_', '.' or '-', got {part!r}")
    return f"netcosim/{run}/{node}/{leaf}"


def new_run_id() -> str:
    """A fresh run id (``r`` and 11 hex digits: a valid ROS 2 name token too): the
    namespace of one run's keys."""
    return "r" + uuid.uuid4().hex[:11]


def _socket_inodes() -> set[str]:
    inodes: set[str] = set()
    try:
        fds = os.listdir("/proc/self/fd")
    except OSError:
        return inodes
    for fd in fds:
        try:
            link = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            inodes.add(link[8:-1])
    return inodes


def _listening_ports(inodes: set[str]) -> list[int]:
    """TCP ports this process listens on through the sockets *inodes* (Linux ``/proc``)."""
    ports = []
    for table in ("/proc/self/net/tcp", "/proc/self/net/tcp6"):
        try:
            with open(table) as f:
                lines = f.read().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 9 and fields[3] == "0A" and fields[9] in inodes:   # 0A: LISTEN
                ports.append(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


class Session:
    """An open hermetic Zenoh session (see :func:`open_session`).

    ``zenoh``: the ``zenoh.Session``; ``endpoints``: the endpoints it really listens on
    (port 0 replaced by the port the OS chose; what a peer passes as ``connect``);
    ``lease``: the lease (s) set on its links.  ``z``: the ``zenoh.Session``, kept as ``zenoh``.
    """

    def __init__(self, z: Any, endpoints: list[str], lease: float):
        self.zenoh = z
        self.endpoints = endpoints
        self.lease = lease

    def publisher(self, key_expr: str, encoding: str | None = None):
        """A Zenoh publisher on *key_expr* (reliable, blocking on congestion, express:
        no batching, as every message is latency-critical), putting every message with
        the Zenoh *encoding* (a string such as ``"application/octet-stream;schema"``)."""
        zenoh = _zenoh()
        kw = {} if encoding is None else {"encoding": zenoh.Encoding(encoding)}
        return self.zenoh.declare_publisher(key_expr, congestion_control=zenoh.CongestionControl.BLOCK,
                                            express=True, **kw)

    def subscribe(self, key_expr: str, callback: Callable[[bytes], None]):
        """Call ``callback(payload bytes)`` on a Zenoh thread for every sample on *key_expr*."""
        return self.zenoh.declare_subscriber(key_expr, lambda s: callback(s.payload.to_bytes()))

    def token(self, key_expr: str):
        """Declare a liveliness token on *key_expr* (dropped when this session dies or closes)."""
        return self.zenoh.liveliness().declare_token(key_expr)

    def watch(self, key_expr: str, callback: Callable[[bool], None]):
        """Call ``callback(alive)`` on a Zenoh thread when a liveliness token on *key_expr*
        appears (True; also one already there) or disappears (False)."""
        zenoh = _zenoh()
        return self.zenoh.liveliness().declare_subscriber(
            key_expr, lambda s: callback(s.kind == zenoh.SampleKind.PUT), history=True)

    def watch_keys(self, key_expr: str, callback: Callable[[str, bool], None]):
        """Like :meth:`watch` for *key_expr*, a key expression with wildcards: ``callback(key, alive)``
        with the key of the token that appeared or disappeared."""
        zenoh = _zenoh()
        return self.zenoh.liveliness().declare_subscriber(
            key_expr, lambda s: callback(str(s.key_expr), s.kind == zenoh.SampleKind.PUT), history=True)

    def close(self) -> None:
        """Close the session (idempotent): undeclares everything declared on it."""
        if not self.zenoh.is_closed():
            self.zenoh.close()

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _zenoh_message(exc: BaseException) -> str:
    """Zenoh's error message, without the copy of the whole configuration it appends to
    "Invalid configuration" (that copy holds passwords in clear)."""
    return _CONFIG_DUMP.sub("Invalid configuration (Zenoh's copy of it left out: it may hold passwords)", str(exc))


def _load_config(zenoh: Any, path: str):
    """``zenoh.Config.from_file(path)``, with errors that name *path*."""
    if not os.path.isfile(path):
        if os.path.exists(path):
            raise ValueError(f"Zenoh configuration file {path!r} is not a regular file")
        raise FileNotFoundError(errno.ENOENT, "Zenoh configuration file not found", path)
    try:
        return zenoh.Config.from_file(path)
    except zenoh.ZError as e:    # `from None`: the chained ZError could print a password
        raise ValueError(f"Zenoh rejected the configuration file {path!r}: {_zenoh_message(e)}") from None


def open_session(*, listen: Sequence[str] = (LOOPBACK,), connect: Sequence[str] = (),
                 lease: float = DEFAULT_LEASE, config: str | os.PathLike[str] | None = None) -> Session:
    """Open a hermetic Zenoh session: peer mode, multicast and gossip scouting off.

    ``listen``: endpoints to accept peers on (default loopback, port 0: the OS picks the
    port, read back into ``Session.endpoints``; also for ``tls/...:0``); ``connect``:
    endpoints of peers or of a router to connect to; ``lease``: seconds after which a
    silent peer is declared gone (keep-alives are sent four times per lease).

    ``config``: path of a Zenoh configuration file (Zenoh's own format; the name ends in
    ``.json5``, ``.json`` or ``.yaml``), loaded with ``zenoh.Config.from_file``.  Its
    settings are kept (user/password in ``transport/auth/usrpwd``, TLS certificates in
    ``transport/link/tls``, ``access_control``, ...), then the keys above are set on top
    of them: ``mode``, ``scouting/multicast/enabled``, ``scouting/gossip/enabled``,
    ``listen/endpoints``, ``connect/endpoints``, ``transport/link/tx/lease`` and
    ``transport/link/tx/keep_alive`` in the file are replaced.  A missing file raises
    ``FileNotFoundError``; a file Zenoh rejects raises ``ValueError`` and a session Zenoh
    cannot open with it ``RuntimeError``, both naming the path and giving Zenoh's message.
    Note that a peer refused by the other side (wrong password, certificate not trusted)
    does not make this call fail: Zenoh logs the refusal, retries, and no message passes.
    """
    if isinstance(listen, str) or isinstance(connect, str):
        raise TypeError("listen and connect are lists of endpoints, e.g. ['tcp/127.0.0.1:0']")
    if not (isinstance(lease, (int, float)) and 0.01 <= lease <= 3600):
        raise ValueError(f"lease must be a number of seconds in [0.01, 3600], got {lease!r}")
    path = None if config is None else os.fsdecode(config)
    zenoh = _zenoh()
    zconfig = zenoh.Config() if path is None else _load_config(zenoh, path)
    for k, v in (("mode", "peer"), ("scouting/multicast/enabled", False), ("scouting/gossip/enabled", False),
                 ("listen/endpoints", list(listen)), ("connect/endpoints", list(connect)),
                 ("transport/link/tx/lease", int(round(lease * 1000))), ("transport/link/tx/keep_alive", 4)):
        zconfig.insert_json5(k, json.dumps(v))
    before = _socket_inodes()
    if path is None:
        z = zenoh.open(zconfig)
    else:
        try:
            z = zenoh.open(zconfig)
        except zenoh.ZError as exc:
            raise RuntimeError(f"cannot open a Zenoh session with the configuration file {path!r}: "
                               f"{_zenoh_message(exc)}") from None
    ports = iter(sorted(_listening_ports(_socket_inodes() - before)))
    endpoints = []
    for e in listen:
        if e.endswith(":0"):
            port = next(ports, None)
            if port is None:
                z.close()
                raise RuntimeError(f"cannot read back the port the OS chose for {e!r}")
            e = f"{e[:-2]}:{port}"
        endpoints.append(e)
    return Session(z, endpoints, float(lease))
