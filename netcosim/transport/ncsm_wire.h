/*
 * ncsm_wire.h - netcosim's hardware-in-the-loop wire format, version 2, for C programs.
 *
 * Self-contained C99 (also C11 and C++): needs only <stdint.h>, <string.h>, <stddef.h>
 * and <math.h>; every function is static inline, so there is nothing to link.  The
 * reference is the Python module netcosim/transport/wire.py; the layout below is its
 * docstring's.  Tested by tests/test_hil_c_header.py against wire.encode / wire.decode.
 *
 * One message: a 40-byte header, then `count` IEEE-754 float64 values, all little endian.
 *
 *   offset size type      field    meaning
 *   0      4    char[4]   magic    "NCSM" (no terminating NUL)
 *   4      1    uint8_t   version  NCSM_VERSION (2); a decoder rejects every other version
 *   5      1    uint8_t   kind     NCSM_DATA, NCSM_END (the run is over), NCSM_REFUSED
 *   6      2    uint16_t  node     network index of the destination (process -> simulation)
 *                                  or of the source (simulation -> process); NCSM_LOCAL:
 *                                  the node's own plant I/O; NCSM_BROADCAST: every other
 *                                  node of the network
 *   8      8    uint64_t  session  the simulation run's session id (random, never 0)
 *   16     8    uint64_t  peer     the remote process's id (random, never 0, chosen by it)
 *   24     8    int64_t   ticks    SIGNED simulated time in ticks of 1 ps (1 s = 10^12)
 *   32     4    uint32_t  seq      UNSIGNED request number, wraps at 2^32 (compare with ==)
 *   36     4    uint32_t  count    number of float64 values that follow (<= NCSM_MAX_VALUES)
 *   40     8n   double    values
 *
 * A REPLY MUST ECHO THE REQUEST'S ticks AND seq (the simulation matches replies to
 * outstanding requests by seq, and drops anything else), carry the session id and the
 * process's own peer id, with node = the destination (see ncsm_reply()).
 *
 * Portability.  ncsm_encode() / ncsm_decode() read and write the fields one byte at a
 * time with shifts, so they are correct on big-endian CPUs and on any alignment of the
 * buffer; that is the portable way.  Every field lies at an offset that is a multiple of
 * its size, so struct ncsm_header has no padding (sizeof == 40, checked below) and on a
 * LITTLE-ENDIAN CPU a program may also memcpy() the first 40 bytes of a message into an
 * ncsm_header (never cast the buffer pointer: it may be misaligned) - but then it must
 * check magic, version, kind, count and the length itself.  Doubles are assumed to be
 * IEEE-754 binary64 with the same byte order as uint64_t (every current CPU); they travel
 * bit for bit (-0.0, infinities, NaN payloads).
 */
#ifndef NCSM_WIRE_H
#define NCSM_WIRE_H

#if !defined(__cplusplus) && (!defined(__STDC_VERSION__) || __STDC_VERSION__ < 199901L)
#error "ncsm_wire.h needs C99 or later (static inline, <stdint.h>): compile with -std=c99 or newer"
#endif

#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <math.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- constants (the same names as in wire.py, prefixed NCSM_) ---------------------- */

#define NCSM_MAGIC "NCSM"                /* the 4 bytes of magic (the literal has a NUL: 5) */
#define NCSM_VERSION 2u                  /* version of the layout above */
#define NCSM_DATA 1u                     /* a request (simulation -> process) or a reply */
#define NCSM_END 2u                      /* the run is over: the simulation's, then the process's answer */
#define NCSM_REFUSED 3u                  /* sent to a process whose claim of a node was refused (peer = it) */
#define NCSM_LOCAL 0xFFFFu               /* node: the node's own plant I/O */
#define NCSM_BROADCAST 0xFFFEu           /* node: every other node of the network */
#define NCSM_HEADER_SIZE 40u             /* bytes of the header */
#define NCSM_MAX_VALUES 1024u            /* largest count a decoder accepts (8 KiB of values) */
#define NCSM_MAX_MESSAGE (NCSM_HEADER_SIZE + 8u * NCSM_MAX_VALUES)  /* 8232 bytes */
#define NCSM_TICKS_PER_SECOND 1000000000000LL                        /* ticks are 1 ps */
/* the Zenoh encoding every publisher of this format sets on its messages */
#define NCSM_ENCODING "application/octet-stream;netcosim.ncsm.v2"

/* Negative return values of ncsm_decode() / ncsm_encode().  The first six are the
 * `reason`s of Python's wire.WireError, checked in the same order. */
typedef enum ncsm_error {
    NCSM_OK = 0,
    NCSM_ERR_SHORT = -1,      /* "short": fewer than 40 bytes */
    NCSM_ERR_MAGIC = -2,      /* "magic": does not start with "NCSM" */
    NCSM_ERR_VERSION = -3,    /* "version": another version of the format */
    NCSM_ERR_KIND = -4,       /* "kind": not DATA, END or REFUSED */
    NCSM_ERR_OVERSIZED = -5,  /* "oversized": count > NCSM_MAX_VALUES */
    NCSM_ERR_LENGTH = -6,     /* "length": len != 40 + 8 * count */
    NCSM_ERR_CAPACITY = -7,   /* not a wire.py reason: the caller's buffer or values array is too small */
    NCSM_ERR_ARGUMENT = -8    /* not a wire.py reason: NULL pointer, or a field ncsm_encode() refuses */
} ncsm_error;

/* ---- the header ------------------------------------------------------------------- */

typedef struct ncsm_header {
    char magic[4];      /* "NCSM" (ncsm_encode() writes it, whatever is here) */
    uint8_t version;    /* NCSM_VERSION (ncsm_encode() writes it, whatever is here) */
    uint8_t kind;       /* NCSM_DATA, NCSM_END or NCSM_REFUSED */
    uint16_t node;      /* network index, NCSM_LOCAL or NCSM_BROADCAST */
    uint64_t session;   /* session id of the simulation run (never 0) */
    uint64_t peer;      /* id of the remote process (never 0) */
    int64_t ticks;      /* signed, simulated time in ticks of 1 ps; a reply echoes it */
    uint32_t seq;       /* unsigned, wraps at 2^32; a reply echoes it */
    uint32_t count;     /* number of float64 values after the header */
} ncsm_header;

/* The layout is the wire's: no padding, every offset as documented. */
#if defined(__cplusplus) && __cplusplus >= 201103L
#define NCSM_STATIC_ASSERT(cond, name) static_assert(cond, #name)
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define NCSM_STATIC_ASSERT(cond, name) _Static_assert(cond, #name)
#else
/* C99: an array of negative size does not compile */
#define NCSM_STATIC_ASSERT(cond, name) typedef char ncsm_static_assert_##name[(cond) ? 1 : -1]
#endif
NCSM_STATIC_ASSERT(sizeof(ncsm_header) == 40, ncsm_header_is_40_bytes);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, magic) == 0, magic_at_0);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, version) == 4, version_at_4);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, kind) == 5, kind_at_5);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, node) == 6, node_at_6);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, session) == 8, session_at_8);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, peer) == 16, peer_at_16);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, ticks) == 24, ticks_at_24);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, seq) == 32, seq_at_32);
NCSM_STATIC_ASSERT(offsetof(ncsm_header, count) == 36, count_at_36);
NCSM_STATIC_ASSERT(sizeof(double) == 8 && sizeof(uint64_t) == 8, double_is_64_bits);

/* ---- little-endian byte access (any alignment, any host byte order) --------------- */

static inline void ncsm_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static inline void ncsm_put_u32(uint8_t *p, uint32_t v)
{
    int i;
    for (i = 0; i < 4; i++)
        p[i] = (uint8_t)((v >> (8 * i)) & 0xFFu);
}

static inline void ncsm_put_u64(uint8_t *p, uint64_t v)
{
    int i;
    for (i = 0; i < 8; i++)
        p[i] = (uint8_t)((v >> (8 * i)) & 0xFFu);
}

static inline uint16_t ncsm_get_u16(const uint8_t *p)
{
    return (uint16_t)((unsigned)p[0] | ((unsigned)p[1] << 8));
}

static inline uint32_t ncsm_get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static inline uint64_t ncsm_get_u64(const uint8_t *p)
{
    uint64_t v = 0;
    int i;
    for (i = 7; i >= 0; i--)
        v = (v << 8) | (uint64_t)p[i];
    return v;
}

/* int64_t is two's complement without padding (C99 7.18.1.1): the same 8 bytes as the
 * uint64_t of the same bits; memcpy avoids the implementation-defined unsigned -> signed
 * conversion */
static inline void ncsm_put_i64(uint8_t *p, int64_t v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    ncsm_put_u64(p, u);
}

static inline int64_t ncsm_get_i64(const uint8_t *p)
{
    uint64_t u = ncsm_get_u64(p);
    int64_t v;
    memcpy(&v, &u, sizeof v);
    return v;
}

/* a double travels as the little-endian bytes of its 64 bits (memcpy: no aliasing issue) */
static inline void ncsm_put_f64(uint8_t *p, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    ncsm_put_u64(p, u);
}

static inline double ncsm_get_f64(const uint8_t *p)
{
    uint64_t u = ncsm_get_u64(p);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

/* ---- encode / decode --------------------------------------------------------------- */

/* The length of a message carrying `count` values. */
static inline size_t ncsm_message_size(uint32_t count)
{
    return (size_t)NCSM_HEADER_SIZE + 8u * (size_t)count;
}

/* Write the message (h->kind, node, session, peer, ticks, seq, count, then h->count
 * values) into buf of cap bytes.  magic and version are always NCSM_MAGIC and
 * NCSM_VERSION (h->magic and h->version are not read).  Returns the message length
 * (40 + 8 * count), or NCSM_ERR_ARGUMENT (NULL buf or h, NULL values with count > 0,
 * kind not DATA/END/REFUSED, count > NCSM_MAX_VALUES), or NCSM_ERR_CAPACITY (cap too
 * small); nothing is written on error. */
static inline int ncsm_encode(uint8_t *buf, size_t cap, const ncsm_header *h, const double *values)
{
    size_t size, i;
    if (buf == NULL || h == NULL || (values == NULL && h->count > 0))
        return NCSM_ERR_ARGUMENT;
    if (h->kind != NCSM_DATA && h->kind != NCSM_END && h->kind != NCSM_REFUSED)
        return NCSM_ERR_ARGUMENT;
    if (h->count > NCSM_MAX_VALUES)
        return NCSM_ERR_ARGUMENT;
    size = ncsm_message_size(h->count);
    if (cap < size)
        return NCSM_ERR_CAPACITY;
    memcpy(buf, NCSM_MAGIC, 4);
    buf[4] = (uint8_t)NCSM_VERSION;
    buf[5] = h->kind;
    ncsm_put_u16(buf + 6, h->node);
    ncsm_put_u64(buf + 8, h->session);
    ncsm_put_u64(buf + 16, h->peer);
    ncsm_put_i64(buf + 24, h->ticks);
    ncsm_put_u32(buf + 32, h->seq);
    ncsm_put_u32(buf + 36, h->count);
    for (i = 0; i < h->count; i++)
        ncsm_put_f64(buf + NCSM_HEADER_SIZE + 8u * i, values[i]);
    return (int)size;
}

/* Read the message in buf (len bytes: exactly one message) into *h and values[0..count).
 * Returns count (>= 0), or a negative ncsm_error, checked in wire.decode()'s order:
 * SHORT, MAGIC, VERSION, KIND, OVERSIZED, LENGTH; then CAPACITY if count > max_values
 * (no value is written then).  NCSM_ERR_ARGUMENT for a NULL buf or h, or NULL values
 * with max_values > 0.  Unless the result is SHORT or ARGUMENT, *h holds the 40 header
 * bytes as read (useful to log what was rejected).  The program must still check
 * session and peer (which session it serves, peer == its own id or 0). */
static inline int ncsm_decode(const uint8_t *buf, size_t len, ncsm_header *h, double *values, size_t max_values)
{
    size_t i;
    if (buf == NULL || h == NULL || (values == NULL && max_values > 0))
        return NCSM_ERR_ARGUMENT;
    if (len < NCSM_HEADER_SIZE)
        return NCSM_ERR_SHORT;
    memcpy(h->magic, buf, 4);
    h->version = buf[4];
    h->kind = buf[5];
    h->node = ncsm_get_u16(buf + 6);
    h->session = ncsm_get_u64(buf + 8);
    h->peer = ncsm_get_u64(buf + 16);
    h->ticks = ncsm_get_i64(buf + 24);
    h->seq = ncsm_get_u32(buf + 32);
    h->count = ncsm_get_u32(buf + 36);
    if (memcmp(h->magic, NCSM_MAGIC, 4) != 0)
        return NCSM_ERR_MAGIC;
    if (h->version != NCSM_VERSION)
        return NCSM_ERR_VERSION;
    if (h->kind != NCSM_DATA && h->kind != NCSM_END && h->kind != NCSM_REFUSED)
        return NCSM_ERR_KIND;
    if (h->count > NCSM_MAX_VALUES)
        return NCSM_ERR_OVERSIZED;
    if (len != ncsm_message_size(h->count))
        return NCSM_ERR_LENGTH;
    if (h->count > max_values)
        return NCSM_ERR_CAPACITY;
    for (i = 0; i < h->count; i++)
        values[i] = ncsm_get_f64(buf + NCSM_HEADER_SIZE + 8u * i);
    return (int)h->count;
}

/* The header of the reply to `request`: kind DATA, node `to` (the destination: usually
 * request->node, the sender of the request or NCSM_LOCAL for a plant sample; or another
 * network index, or NCSM_BROADCAST), the session id `session` (the one this process
 * serves: request->session once it is accepted), the process's own id `own_peer`, and
 * the request's ticks and seq ECHOED unchanged; `count` values will follow.  Then:
 *     n = ncsm_encode(buf, sizeof buf, &reply, values);
 * For the process's END answer, set reply.kind = NCSM_END, reply.node = 0, count 0. */
static inline ncsm_header ncsm_reply(const ncsm_header *request, uint64_t session, uint64_t own_peer,
                                     uint16_t to, uint32_t count)
{
    ncsm_header r;
    memcpy(r.magic, NCSM_MAGIC, 4);
    r.version = (uint8_t)NCSM_VERSION;
    r.kind = (uint8_t)NCSM_DATA;
    r.node = to;
    r.session = session;
    r.peer = own_peer;
    r.ticks = request->ticks;   /* echoed */
    r.seq = request->seq;       /* echoed */
    r.count = count;
    return r;
}

/* The reason string of an ncsm_error, as Python's WireError.reason for the first six
 * ("short", "magic", "version", "kind", "oversized", "length"); "ok" for >= 0. */
static inline const char *ncsm_strerror(int code)
{
    switch (code) {
    case NCSM_ERR_SHORT: return "short";
    case NCSM_ERR_MAGIC: return "magic";
    case NCSM_ERR_VERSION: return "version";
    case NCSM_ERR_KIND: return "kind";
    case NCSM_ERR_OVERSIZED: return "oversized";
    case NCSM_ERR_LENGTH: return "length";
    case NCSM_ERR_CAPACITY: return "capacity";
    case NCSM_ERR_ARGUMENT: return "argument";
    default: return code >= 0 ? "ok" : "unknown";
    }
}

/* 1 if every one of the n values is finite (no NaN, no infinity), as wire.finite(). */
static inline int ncsm_finite(const double *values, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(values[i]))
            return 0;
    return 1;
}

#ifdef __cplusplus
}
#endif

#endif /* NCSM_WIRE_H */
