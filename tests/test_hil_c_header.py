"""The C header of the HIL wire format (``netcosim/transport/ncsm_wire.h``), compiled and
run against the Python reference ``netcosim.transport.wire``.

A small C program (below) is built several ways (C11 and C99 with ``-Wall -Wextra
-Werror -pedantic``, C11 with conversion warnings at -O2, and C++11 when a C++ compiler
exists); each build must print the layout and constants of ``wire.py``, decode what
``wire.encode`` wrote field for field and bit for bit, encode exactly the bytes
``wire.encode`` writes, reject crafted messages for the same reason as ``wire.decode``,
and build replies that echo ``ticks`` and ``seq``.  The example of ``docs/hil_c.md`` is
compiled and run too.  Skipped without a C compiler.
"""

from __future__ import annotations

import re
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from netcosim.transport import wire

CC = shutil.which("cc") or shutil.which("gcc")
CXX = shutil.which("c++") or shutil.which("g++")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler on PATH (neither cc nor gcc)")

HEADER = Path(wire.__file__).parent / "ncsm_wire.h"
DOC = Path(__file__).resolve().parents[1] / "docs" / "hil_c.md"
WARN = ["-Wall", "-Wextra", "-Werror", "-pedantic"]
STRICT = ["-O2", "-Wconversion", "-Wsign-conversion", "-Wshadow", "-Wcast-qual", "-Wcast-align",
          "-Wstrict-prototypes", "-Wmissing-prototypes", "-Wundef"]
BUILDS = {
    "c11": ["-std=c11", *WARN],
    "c99": ["-std=c99", *WARN],
    "c11-strict": ["-std=c11", *WARN, *STRICT],
    "c++11": ["-x", "c++", "-std=c++11", *WARN],
}
COMPILE_TIMEOUT = 120
RUN_TIMEOUT = 20
U64 = 2**64 - 1

# The checking program.  Messages come as hex on stdin; fields as arguments (ids in hex,
# values as the 16 hex digits of their IEEE-754 bits so -0.0 and NaN payloads are exact).
CHECK_C = r"""
#include "ncsm_wire.h"
#include <stdio.h>
#include <stdlib.h>

static uint8_t buf[2 * NCSM_MAX_MESSAGE];
static uint8_t out[NCSM_MAX_MESSAGE];
static double vals[NCSM_MAX_VALUES];

static size_t read_hex(void)
{
    size_t n = 0;
    int hi = -1, c;
    while ((c = getchar()) != EOF) {
        int d;
        if (c >= '0' && c <= '9') d = c - '0';
        else if (c >= 'a' && c <= 'f') d = c - 'a' + 10;
        else if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
        else continue;
        if (hi < 0) {
            hi = d;
        } else {
            if (n >= sizeof buf) {
                fprintf(stderr, "message too long for the test buffer\n");
                exit(2);
            }
            buf[n++] = (uint8_t)((hi << 4) | d);
            hi = -1;
        }
    }
    return n;
}

static uint64_t bits(double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    return u;
}

static double from_bits(const char *s)
{
    uint64_t u = (uint64_t)strtoull(s, NULL, 16);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static void print_hex(const uint8_t *p, size_t n)
{
    size_t i;
    printf("hex ");
    for (i = 0; i < n; i++)
        printf("%02x", (unsigned)p[i]);
    printf("\n");
}

static void print_header(const ncsm_header *h)
{
    printf("magic %02x%02x%02x%02x\n", (unsigned)(unsigned char)h->magic[0], (unsigned)(unsigned char)h->magic[1],
           (unsigned)(unsigned char)h->magic[2], (unsigned)(unsigned char)h->magic[3]);
    printf("version %u\n", (unsigned)h->version);
    printf("kind %u\n", (unsigned)h->kind);
    printf("node %u\n", (unsigned)h->node);
    printf("session %016llx\n", (unsigned long long)h->session);
    printf("peer %016llx\n", (unsigned long long)h->peer);
    printf("ticks %lld\n", (long long)h->ticks);
    printf("seq %lu\n", (unsigned long)h->seq);
    printf("count %lu\n", (unsigned long)h->count);
}

static void print_values(const double *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        printf("value %.17g %016llx\n", v[i], (unsigned long long)bits(v[i]));
}

static int layout(void)
{
    printf("sizeof %lu\n", (unsigned long)sizeof(ncsm_header));
    printf("offsetof.magic %lu\n", (unsigned long)offsetof(ncsm_header, magic));
    printf("offsetof.version %lu\n", (unsigned long)offsetof(ncsm_header, version));
    printf("offsetof.kind %lu\n", (unsigned long)offsetof(ncsm_header, kind));
    printf("offsetof.node %lu\n", (unsigned long)offsetof(ncsm_header, node));
    printf("offsetof.session %lu\n", (unsigned long)offsetof(ncsm_header, session));
    printf("offsetof.peer %lu\n", (unsigned long)offsetof(ncsm_header, peer));
    printf("offsetof.ticks %lu\n", (unsigned long)offsetof(ncsm_header, ticks));
    printf("offsetof.seq %lu\n", (unsigned long)offsetof(ncsm_header, seq));
    printf("offsetof.count %lu\n", (unsigned long)offsetof(ncsm_header, count));
    printf("MAGIC %s\n", NCSM_MAGIC);
    printf("VERSION %u\n", (unsigned)NCSM_VERSION);
    printf("DATA %u\n", (unsigned)NCSM_DATA);
    printf("END %u\n", (unsigned)NCSM_END);
    printf("REFUSED %u\n", (unsigned)NCSM_REFUSED);
    printf("LOCAL %u\n", (unsigned)NCSM_LOCAL);
    printf("BROADCAST %u\n", (unsigned)NCSM_BROADCAST);
    printf("HEADER_SIZE %u\n", (unsigned)NCSM_HEADER_SIZE);
    printf("MAX_VALUES %u\n", (unsigned)NCSM_MAX_VALUES);
    printf("MAX_MESSAGE %u\n", (unsigned)NCSM_MAX_MESSAGE);
    printf("TICKS_PER_SECOND %lld\n", (long long)NCSM_TICKS_PER_SECOND);
    printf("ENCODING %s\n", NCSM_ENCODING);
    return 0;
}

/* decode [max_values]: the field-wise decoder */
static int decode(int argc, char **argv)
{
    size_t n = read_hex();
    size_t max = argc > 2 ? (size_t)strtoul(argv[2], NULL, 10) : (size_t)NCSM_MAX_VALUES;
    ncsm_header h;
    int rc;
    memset(&h, 0, sizeof h);
    rc = ncsm_decode(buf, n, &h, vals, max);
    printf("rc %d %s\n", rc, ncsm_strerror(rc));
    if (rc != NCSM_ERR_SHORT && rc != NCSM_ERR_ARGUMENT)
        print_header(&h);
    if (rc >= 0)
        print_values(vals, (size_t)rc);
    return 0;
}

/* naive: memcpy of the header into the struct (little-endian hosts), values likewise */
static int naive(void)
{
    size_t n = read_hex(), i;
    ncsm_header h;
    if (n < sizeof h)
        return 3;
    memcpy(&h, buf, sizeof h);
    printf("rc %lu ok\n", (unsigned long)h.count);
    print_header(&h);
    for (i = 0; i < h.count && sizeof h + 8 * (i + 1) <= n; i++)
        memcpy(&vals[i], buf + sizeof h + 8 * i, 8);
    print_values(vals, i);
    return 0;
}

/* encode KIND NODE SESSION PEER TICKS SEQ [VALUE_BITS...] */
static int encode(int argc, char **argv)
{
    ncsm_header h;
    int i, rc;
    if (argc < 8)
        return 3;
    memset(&h, 0, sizeof h);
    h.kind = (uint8_t)strtoul(argv[2], NULL, 10);
    h.node = (uint16_t)strtoul(argv[3], NULL, 10);
    h.session = (uint64_t)strtoull(argv[4], NULL, 16);
    h.peer = (uint64_t)strtoull(argv[5], NULL, 16);
    h.ticks = (int64_t)strtoll(argv[6], NULL, 10);
    h.seq = (uint32_t)strtoul(argv[7], NULL, 10);
    h.count = (uint32_t)(argc - 8);
    for (i = 8; i < argc; i++)
        vals[i - 8] = from_bits(argv[i]);
    rc = ncsm_encode(out, ncsm_message_size(h.count), &h, vals);
    printf("rc %d %s\n", rc, ncsm_strerror(rc));
    if (rc > 0)
        print_hex(out, (size_t)rc);
    return 0;
}

/* reply SESSION OWN_PEER TO [VALUE_BITS...]: decode the request on stdin, answer it */
static int reply(int argc, char **argv)
{
    size_t n = read_hex();
    ncsm_header req, rep;
    int i, rc;
    if (argc < 5)
        return 3;
    rc = ncsm_decode(buf, n, &req, vals, NCSM_MAX_VALUES);
    if (rc < 0) {
        printf("rc %d %s\n", rc, ncsm_strerror(rc));
        return 0;
    }
    rep = ncsm_reply(&req, (uint64_t)strtoull(argv[2], NULL, 16), (uint64_t)strtoull(argv[3], NULL, 16),
                     (uint16_t)strtoul(argv[4], NULL, 10), (uint32_t)(argc - 5));
    for (i = 5; i < argc; i++)
        vals[i - 5] = from_bits(argv[i]);
    rc = ncsm_encode(out, sizeof out, &rep, vals);
    printf("rc %d %s\n", rc, ncsm_strerror(rc));
    if (rc > 0)
        print_hex(out, (size_t)rc);
    return 0;
}

/* errors: the encoder's refusals, and that a refused encode writes nothing */
static int errors(void)
{
    ncsm_header h;
    double v[2] = {1.0, 2.0};
    uint8_t small[64];
    size_t i;
    int untouched = 1;
    memset(&h, 0, sizeof h);
    h.kind = (uint8_t)NCSM_DATA;
    h.count = 2;
    memset(small, 0xAB, sizeof small);
    printf("cap_39 %d\n", ncsm_encode(small, 39, &h, v));
    printf("cap_55 %d\n", ncsm_encode(small, 55, &h, v));
    for (i = 0; i < sizeof small; i++)
        untouched = untouched && small[i] == 0xAB;
    printf("untouched %d\n", untouched);
    printf("cap_56 %d\n", ncsm_encode(small, 56, &h, v));
    printf("null_values %d\n", ncsm_encode(small, sizeof small, &h, NULL));
    printf("null_buf %d\n", ncsm_encode(NULL, sizeof small, &h, v));
    printf("null_header %d\n", ncsm_encode(small, sizeof small, NULL, v));
    h.kind = 0;
    printf("kind_0 %d\n", ncsm_encode(small, sizeof small, &h, v));
    h.kind = 4;
    printf("kind_4 %d\n", ncsm_encode(small, sizeof small, &h, v));
    h.kind = (uint8_t)NCSM_END;
    h.count = NCSM_MAX_VALUES + 1;
    printf("count_1025 %d\n", ncsm_encode(buf, sizeof buf, &h, vals));
    h.count = 0;
    printf("end_no_values %d\n", ncsm_encode(small, 40, &h, NULL));
    printf("decode_null_values %d\n", ncsm_decode(small, 40, &h, NULL, 1));
    printf("decode_null_values_max0 %d\n", ncsm_decode(small, 40, &h, NULL, 0));
    printf("strerror_ok %s\n", ncsm_strerror(3));
    printf("strerror_unknown %s\n", ncsm_strerror(-99));
    printf("finite_yes %d\n", ncsm_finite(v, 2));
    v[1] = from_bits("7ff0000000000000");
    printf("finite_inf %d\n", ncsm_finite(v, 2));
    v[1] = from_bits("7ff8000000000001");
    printf("finite_nan %d\n", ncsm_finite(v, 2));
    printf("finite_empty %d\n", ncsm_finite(NULL, 0));
    return 0;
}

int main(int argc, char **argv)
{
    const char *mode = argc > 1 ? argv[1] : "";
    if (strcmp(mode, "layout") == 0) return layout();
    if (strcmp(mode, "decode") == 0) return decode(argc, argv);
    if (strcmp(mode, "naive") == 0) return naive();
    if (strcmp(mode, "encode") == 0) return encode(argc, argv);
    if (strcmp(mode, "reply") == 0) return reply(argc, argv);
    if (strcmp(mode, "errors") == 0) return errors();
    fprintf(stderr, "usage: check layout|decode [max]|naive|encode ...|reply ...|errors\n");
    return 2;
}
"""

# main() around the example of docs/hil_c.md: request on stdin, OWN_PEER SESSION as args
DOC_MAIN_C = r"""
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    static uint8_t msg[NCSM_MAX_MESSAGE + 16], reply[NCSM_MAX_MESSAGE];
    size_t n = 0;
    int hi = -1, c, stop = 0, rc, i;
    uint64_t own_peer, session;
    if (argc < 3)
        return 2;
    own_peer = (uint64_t)strtoull(argv[1], NULL, 16);
    session = (uint64_t)strtoull(argv[2], NULL, 16);
    while ((c = getchar()) != EOF && n < sizeof msg) {
        int d = (c >= '0' && c <= '9') ? c - '0' : (c >= 'a' && c <= 'f') ? c - 'a' + 10 : -1;
        if (d < 0)
            continue;
        if (hi < 0) {
            hi = d;
        } else {
            msg[n++] = (uint8_t)((hi << 4) | d);
            hi = -1;
        }
    }
    rc = answer(msg, n, own_peer, &session, reply, sizeof reply, &stop);
    printf("rc %d\nstop %d\nsession %016llx\nhex ", rc, stop, (unsigned long long)session);
    for (i = 0; i < rc; i++)
        printf("%02x", (unsigned)reply[i]);
    printf("\n");
    return 0;
}
"""


def _compile(cmd: list[str], cwd: Path) -> None:
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=COMPILE_TIMEOUT)
    assert proc.returncode == 0, f"{' '.join(cmd)} failed:\n{proc.stdout}{proc.stderr}"
    assert proc.stderr == "", f"{' '.join(cmd)} warned:\n{proc.stderr}"


@pytest.fixture(scope="module", params=list(BUILDS))
def program(request, tmp_path_factory) -> Path:
    """The checking program, built one way per parameter (the header used in place)."""
    name = request.param
    compiler = CXX if name.startswith("c++") else CC
    if compiler is None:
        pytest.skip(f"no compiler for the {name} build (c++ or g++)")
    d = tmp_path_factory.mktemp(f"ncsm_{name.replace('+', 'x')}")
    (d / "check.c").write_text(CHECK_C)
    exe = d / "check"
    _compile([compiler, *BUILDS[name], "-I", str(HEADER.parent), "check.c", "-o", str(exe)], d)
    return exe


def run(exe: Path, *args: object, stdin: bytes | str = "") -> dict[str, list[str]]:
    """Run the program; its output lines ``key rest`` as {key: [rest, ...]}."""
    text = stdin.hex() if isinstance(stdin, (bytes, bytearray)) else stdin
    proc = subprocess.run([str(exe), *map(str, args)], input=text, capture_output=True, text=True,
                          timeout=RUN_TIMEOUT)
    assert proc.returncode == 0, f"{exe.name} {args} exited {proc.returncode}: {proc.stderr}"
    out: dict[str, list[str]] = {}
    for line in proc.stdout.splitlines():
        k, _, rest = line.partition(" ")
        out.setdefault(k, []).append(rest)
    return out


def one(out: dict[str, list[str]], k: str) -> str:
    (v,) = out[k]
    return v


def bits(x: float) -> str:
    return struct.pack(">d", x).hex()


def from_bits(h: str) -> float:
    return struct.unpack(">d", bytes.fromhex(h))[0]


def fields(out: dict[str, list[str]]) -> tuple:
    """(kind, node, session, peer, ticks, seq, value bits) as printed by the program."""
    return (int(one(out, "kind")), int(one(out, "node")), int(one(out, "session"), 16),
            int(one(out, "peer"), 16), int(one(out, "ticks")), int(one(out, "seq")),
            tuple(v.split()[1] for v in out.get("value", [])))


def py_fields(data: bytes) -> tuple:
    """The same tuple from the message bytes, through wire.decode (value bits from the
    bytes themselves, so NaN payloads are compared exactly)."""
    m = wire.decode(data)
    raw = tuple(data[40 + 8 * i:48 + 8 * i][::-1].hex() for i in range(len(m.values)))
    assert raw == tuple(bits(v) for v in m.values)
    return (m.kind, m.node, m.session, m.peer, m.ticks, m.seq, raw)


NAN_PAYLOAD = from_bits("7ff8000000000123")
EDGE_VALUES = (0.1, -0.0, 0.0, float("inf"), float("-inf"), NAN_PAYLOAD, 5e-324, -1.7976931348623157e308,
               2.0 ** -1022, 1.0 / 3.0)
MESSAGES = {
    "data": (wire.DATA, 3, 0x0123456789ABCDEF, 0xFEDCBA9876543210, 10_000_000_000, 7, (1.5, -2.0)),
    "edges": (wire.DATA, wire.LOCAL, U64, 1, -(2**63), 2**32 - 1, EDGE_VALUES),
    "max_ticks": (wire.DATA, wire.BROADCAST, 1, U64, 2**63 - 1, 0, (float("nan"),)),
    "negative_ticks": (wire.DATA, 0, 2**63, 2**63 + 1, -1, 2**31, (-0.0,)),
    "end": (wire.END, 0, 0xDEADBEEF, 0, 123_456_789_012_345, 99, ()),
    "refused": (wire.REFUSED, 0, 42, 43, 0, 0, ()),
    "max_values": (wire.DATA, 65535, 5, 6, 2**40, 2**32 - 2,
                   tuple((-1) ** i * (i + 0.5) * 10.0 ** (i % 40 - 20) for i in range(wire.MAX_VALUES))),
}


def test_header_includes_only_the_documented_system_headers():
    text = HEADER.read_text()
    assert set(re.findall(r"#include\s*<([^>]+)>", text)) == {"stdint.h", "string.h", "stddef.h", "math.h"}
    assert '#include "' not in text
    assert "#pragma" not in text and "__attribute__" not in text     # plain C: no packing, no extensions


def test_layout_and_constants_are_wire_py(program):
    out = run(program, "layout")
    assert int(one(out, "sizeof")) == wire.HEADER.size == 40
    fmt = wire.HEADER.format.lstrip("<")
    names = ["magic", "version", "kind", "node", "session", "peer", "ticks", "seq", "count"]
    codes = re.findall(r"\d*[a-zA-Z]", fmt)
    assert len(codes) == len(names)
    for i, name in enumerate(names):
        expected = struct.calcsize("<" + "".join(codes[:i]))
        assert int(one(out, f"offsetof.{name}")) == expected, name
    assert one(out, "MAGIC") == wire.MAGIC.decode()
    for name in ("VERSION", "DATA", "END", "REFUSED", "LOCAL", "BROADCAST", "MAX_VALUES"):
        assert int(one(out, name)) == getattr(wire, name), name
    assert int(one(out, "HEADER_SIZE")) == wire.HEADER.size
    assert int(one(out, "MAX_MESSAGE")) == wire.HEADER.size + 8 * wire.MAX_VALUES
    assert int(one(out, "TICKS_PER_SECOND")) == 10**12
    assert one(out, "ENCODING") == wire.ENCODING


@pytest.mark.parametrize("name", list(MESSAGES))
def test_c_decodes_what_python_encodes(program, name):
    data = wire.encode(*MESSAGES[name])
    out = run(program, "decode", stdin=data)
    assert one(out, "rc") == f"{len(MESSAGES[name][6])} ok"
    assert one(out, "magic") == wire.MAGIC.hex() and int(one(out, "version")) == wire.VERSION
    assert int(one(out, "count")) == len(MESSAGES[name][6])
    assert fields(out) == py_fields(data)
    # %.17g round-trips every finite double
    for text, v in zip((s.split()[0] for s in out.get("value", [])), wire.decode(data).values):
        if v == v and abs(v) != float("inf"):
            assert float(text) == v and bits(float(text)) == bits(v)


@pytest.mark.parametrize("name", list(MESSAGES))
def test_c_encodes_the_bytes_python_encodes(program, name):
    kind, node, session, peer, ticks, seq, values = MESSAGES[name]
    if len(values) > 100:
        values = values[:100]       # keep the command line short
    out = run(program, "encode", kind, node, f"{session:x}", f"{peer:x}", ticks, seq, *map(bits, values))
    data = bytes.fromhex(one(out, "hex"))
    assert one(out, "rc") == f"{len(data)} ok"
    assert data == wire.encode(kind, node, session, peer, ticks, seq, values)
    m = wire.decode(data)
    assert (m.kind, m.node, m.session, m.peer, m.ticks, m.seq) == (kind, node, session, peer, ticks, seq)
    assert [bits(v) for v in m.values] == [bits(v) for v in values]


@pytest.mark.parametrize("to", [None, wire.LOCAL, wire.BROADCAST, 0])
def test_c_reply_echoes_ticks_and_seq(program, to):
    session, own_peer = U64, 0x8000000000000001
    request = wire.encode(wire.DATA, 12, session, own_peer, -(2**62) - 3, 2**32 - 1, (1.0, 2.0))
    dest = 12 if to is None else to
    values = (-0.0, float("inf"), NAN_PAYLOAD, 5e-324)
    out = run(program, "reply", f"{session:x}", f"{own_peer:x}", dest, *map(bits, values), stdin=request)
    data = bytes.fromhex(one(out, "hex"))
    assert one(out, "rc") == f"{len(data)} ok"
    m = wire.decode(data)
    assert (m.kind, m.node, m.session, m.peer, m.ticks, m.seq) == \
        (wire.DATA, dest, session, own_peer, -(2**62) - 3, 2**32 - 1)
    assert data[40:].hex() == struct.pack("<4d", *values).hex()
    assert [bits(v) for v in m.values] == [bits(v) for v in values]     # -0.0, inf, the NaN's payload
    # and the very bytes wire.encode writes for the same reply (what RemoteProcess.reply sends)
    assert data == wire.encode(wire.DATA, dest, session, own_peer, -(2**62) - 3, 2**32 - 1, values)


def _with(data: bytes, offset: int, fmt: str, value) -> bytes:
    b = bytearray(data)
    struct.pack_into(fmt, b, offset, value)
    return bytes(b)


GOOD = wire.encode(wire.DATA, 1, 2, 3, 4, 5, (6.0, 7.0))
BAD = {
    "empty": b"",
    "header_minus_one": GOOD[:39],
    "magic": b"NCSX" + GOOD[4:],
    "magic_lowercase": b"ncsm" + GOOD[4:],
    "magic_and_version": b"XCSM" + bytes([9]) + GOOD[5:],
    "version_1": _with(GOOD, 4, "B", 1),
    "version_3": _with(GOOD, 4, "B", 3),
    "version_0_and_kind_0": _with(_with(GOOD, 4, "B", 0), 5, "B", 0),
    "kind_0": _with(GOOD, 5, "B", 0),
    "kind_4": _with(GOOD, 5, "B", 4),
    "kind_255_and_oversized": _with(_with(GOOD, 5, "B", 255), 36, "<I", 5000),
    "oversized_1025": _with(GOOD, 36, "<I", wire.MAX_VALUES + 1),
    "oversized_u32_max": _with(GOOD, 36, "<I", 2**32 - 1),
    "length_one_more": GOOD + b"\0",
    "length_one_less": GOOD[:-1],
    "length_count_3": _with(GOOD, 36, "<I", 3),
    "length_count_0": _with(GOOD, 36, "<I", 0),
    "length_header_only": GOOD[:40],
}


@pytest.mark.parametrize("name", list(BAD))
def test_c_rejects_for_the_reason_python_does(program, name):
    data = BAD[name]
    with pytest.raises(wire.WireError) as err:
        wire.decode(data)
    out = run(program, "decode", stdin=data)
    code, reason = one(out, "rc").split()
    assert reason == err.value.reason and int(code) < 0
    assert "value" not in out
    if reason != "short":       # the header as read, for the log
        assert one(out, "magic") == data[:4].hex()
        assert int(one(out, "count")) == struct.unpack_from("<I", data, 36)[0]


def test_c_error_codes_are_distinct_and_named(program):
    codes = {}
    for name in ("empty", "magic", "version_1", "kind_0", "oversized_1025", "length_one_more"):
        code, reason = one(run(program, "decode", stdin=BAD[name]), "rc").split()
        codes[reason] = int(code)
    assert codes == {"short": -1, "magic": -2, "version": -3, "kind": -4, "oversized": -5, "length": -6}


def test_c_decode_refuses_more_values_than_the_caller_holds(program):
    data = wire.encode(wire.DATA, 1, 2, 3, 4, 5, (6.0, 7.0, 8.0))
    out = run(program, "decode", 2, stdin=data)
    assert one(out, "rc") == "-7 capacity" and "value" not in out
    assert int(one(out, "count")) == 3 and int(one(out, "seq")) == 5
    assert one(run(program, "decode", 3, stdin=data), "rc") == "3 ok"
    assert one(run(program, "decode", 0, stdin=wire.encode(wire.END, 0, 2, 0, 4, 5)), "rc") == "0 ok"


def test_c_encode_refusals(program):
    out = {k: one(run(program, "errors"), k) for k in run(program, "errors")}
    assert out == {
        "cap_39": "-7", "cap_55": "-7", "untouched": "1", "cap_56": "56",
        "null_values": "-8", "null_buf": "-8", "null_header": "-8",
        "kind_0": "-8", "kind_4": "-8", "count_1025": "-8", "end_no_values": "40",
        "decode_null_values": "-8", "decode_null_values_max0": "0",    # small holds the END just encoded
        "strerror_ok": "ok", "strerror_unknown": "unknown",
        "finite_yes": "1", "finite_inf": "0", "finite_nan": "0", "finite_empty": "1",
    }


@pytest.mark.skipif(sys.byteorder != "little", reason="memcpy into the struct is the wire's layout on "
                                                      "little-endian hosts only")
@pytest.mark.parametrize("name", list(MESSAGES))
def test_naive_memcpy_gives_the_same_fields_on_little_endian(program, name):
    data = wire.encode(*MESSAGES[name])
    naive = run(program, "naive", stdin=data)
    portable = run(program, "decode", stdin=data)
    assert fields(naive) == fields(portable) == py_fields(data)
    assert one(naive, "magic") == one(portable, "magic")
    assert one(naive, "version") == one(portable, "version")
    assert one(naive, "count") == one(portable, "count")


def _doc_example() -> str:
    blocks = re.findall(r"```c\n(.*?)```", DOC.read_text(), re.S)
    assert len(blocks) == 1, "docs/hil_c.md should hold exactly one ```c block (the example)"
    return blocks[0]


@pytest.fixture(scope="module")
def doc_program(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("ncsm_doc")
    (d / "example.c").write_text(_doc_example() + DOC_MAIN_C)
    exe = d / "example"
    _compile([CC, "-std=c99", *WARN, "-I", str(HEADER.parent), "example.c", "-o", str(exe)], d)
    return exe


def test_doc_example_answers_a_request(doc_program):
    own, session = 0x00000000000000AB, 0xFFFFFFFFFFFFFFFE
    request = wire.encode(wire.DATA, 4, session, own, -(10**12), 2**32 - 1, (1.0, 2.0))
    out = run(doc_program, f"{own:x}", "0", stdin=request)
    data = bytes.fromhex(one(out, "hex"))
    assert int(one(out, "rc")) == len(data) == 48 and one(out, "stop") == "0"
    assert int(one(out, "session"), 16) == session          # learned from the request addressed to it
    assert wire.decode(data) == wire.Message(wire.DATA, 4, session, own, -(10**12), 2**32 - 1, (-3.0,))
    # the session's END: answered with the process's END (echoing ticks and seq), then stop
    out = run(doc_program, f"{own:x}", f"{session:x}", stdin=wire.encode(wire.END, 0, session, 0, 77, 9))
    assert one(out, "stop") == "1"
    assert wire.decode(bytes.fromhex(one(out, "hex"))) == wire.Message(wire.END, 0, session, own, 77, 9, ())


@pytest.mark.parametrize("case", ["other_peer", "other_session", "invalid", "refused", "too_many_values"])
def test_doc_example_drops_what_is_not_its_own(doc_program, case):
    own, session = 0xAB, 0x1234
    msg = {
        "other_peer": wire.encode(wire.DATA, 4, session, own + 1, 0, 1, (1.0, 2.0)),
        "other_session": wire.encode(wire.DATA, 4, session + 1, 0, 0, 1, (1.0, 2.0)),
        "invalid": BAD["version_1"],
        "refused": wire.encode(wire.REFUSED, 0, session, own, 0, 0),
        "too_many_values": wire.encode(wire.DATA, 4, session, own, 0, 1, (0.0,) * 9),
    }[case]
    out = run(doc_program, f"{own:x}", f"{session:x}", stdin=msg)
    assert one(out, "rc") == "0" and one(out, "hex") == ""
    assert one(out, "stop") == ("1" if case == "refused" else "0")
