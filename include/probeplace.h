/* probeplace.h: reads probeplace's svo.bin and answers probes_at, in C99.
 *
 * A single-header library (stb style). In exactly one C file:
 *
 *     #define PROBEPLACE_IMPLEMENTATION
 *     #include "probeplace.h"
 *
 * and include it plainly everywhere else. It needs only the C99 standard
 * library (stdio for pp_svo_load_file, stdlib for malloc, math for floorf).
 *
 * WHAT IT READS. `svo.bin`, version 2: the sparse voxel octree of probe
 * indices that `probeplace place` writes (Wang et al. 2019 §4.1; byte
 * layout in docs/formats.md, "svo.bin"). For any world-space point it lists
 * up to 8 probe indices (into probes.json's `probes`, and lightfield.bin's
 * probe order), best first.
 *
 *     pp_svo svo;
 *     pp_error e = pp_svo_load_file("out/cornell/svo.bin", &svo);
 *     if (e != PP_OK) { fprintf(stderr, "svo.bin: %s\n", pp_error_string(e)); return 1; }
 *     uint32_t list[PP_MAX_PROBES_PER_LEAF];
 *     float p[3] = { 0.25f, 0.3f, 0.2f };
 *     unsigned n = pp_svo_probes_at(&svo, p, list);   // list[0..n), best first
 *     pp_svo_free(&svo);
 *
 * CONTRACT.
 *  - pp_svo_load / pp_svo_load_file accept exactly the files probeplace's
 *    own reader (`Svo::read`, src/svo/format.rs) accepts, with the same
 *    checks in the same order: magic, header length, version, exact length,
 *    CRC-32, then every structural invariant (finite origin, positive leaf
 *    size, depth <= 23, leaf counts within the root and at most 64 000 000,
 *    1..8 probes per leaf, a root, every payload index below the probe
 *    count, every leaf list inside the payload, every node reached exactly
 *    once from a parent stored before it, no children below the leaf
 *    level). Anything else, however hostile, is an error code and never a
 *    read outside the `size` bytes given: the loader reads each byte of the
 *    file at most a bounded number of times, and its only allocation is one
 *    byte per node (freed before it returns).
 *  - A pp_svo filled by a successful load answers pp_svo_probes_at in
 *    O(depth) reads, without allocating; the walk is bounded by the depth
 *    (at most 24 steps) whatever the node words hold, and it re-checks
 *    every index it follows, so even a pp_svo whose bytes changed after the
 *    load reads nothing out of bounds. Every index it returns is below
 *    `probe_count`; it returns at most `max_probes` of them.
 *  - pp_svo_load keeps pointers into `bytes` (no copy): the buffer must
 *    outlive the pp_svo and stay unchanged. pp_svo_load_file owns its
 *    buffer; pp_svo_free releases it (and is harmless on a pp_svo from
 *    pp_svo_load, or on a failed load).
 *  - Thread safety: loading touches only its arguments; any number of
 *    threads may query one pp_svo at once.
 *
 * ARITHMETIC. pp_svo_probes_at answers exactly what `Svo::probes_at`
 * answers, bit for bit: g = floorf((p - origin) / leaf_size) in IEEE single
 * precision, one subtraction, one division and one floor per axis, each
 * rounded to float, then the walk in integers. That holds wherever float
 * operations are IEEE single precision (FLT_EVAL_METHOD 0: x86-64 SSE,
 * AArch64). With FLT_EVAL_METHOD 2 (x87), C99 rounds every assignment to
 * float (GCC with -std=c99 does, -fexcess-precision=standard), and each
 * intermediate here is assigned, so it holds too. Do not build this file
 * with -ffast-math or -Ofast (they change the floor/compare semantics and
 * NaN handling). There is no multiply-add in the query for a compiler to
 * contract, but the tests build with -ffp-contract=off all the same.
 *
 * COORDINATES. Points are world space, as probes.json's `position`. The
 * origin is stored as f32 (`origin`) and exactly (`origin_exact`, f64).
 * At a distance D from the world origin f32 rounds a coordinate by about
 * D * 6e-8; where that nears the leaf size, compute p - origin_exact in
 * double in your own frame and query with `origin` set to zero: the
 * answers are then those of your rounding, not Rust's (docs/formats.md,
 * "Precision").
 *
 * Tested against the Rust writer by tests/it/readers.rs (tests/c/readers.c,
 * built with gcc -std=c99 -Wall -Wextra -Werror -pedantic
 * -fsanitize=address,undefined -ffp-contract=off), on Cornell, Holodeck and
 * Sponza and on damaged and hostile files.
 *
 * Overrides, before including with PROBEPLACE_IMPLEMENTATION:
 * PROBEPLACE_MALLOC(n), PROBEPLACE_REALLOC(p, n), PROBEPLACE_FREE(p).
 */
#ifndef PROBEPLACE_H
#define PROBEPLACE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The svo.bin version this header reads. */
#define PP_SVO_VERSION 2u
/* Bytes before the node array. */
#define PP_SVO_HEADER_BYTES 120u
/* The most indices one point lists (a leaf's 3-bit length field). */
#define PP_MAX_PROBES_PER_LEAF 8
/* The most leaves a tree may have (probeplace's sdf::MAX_VOXELS). */
#define PP_SVO_MAX_LEAVES 64000000u

/* Why a load failed. PP_OK is 0; every other value names one check, in
 * the order the loader makes them (the order of src/svo/format.rs). */
typedef enum pp_error {
    PP_OK = 0,
    PP_ERR_ARGUMENT,         /* a NULL pointer where one is needed */
    PP_ERR_IO,               /* the file cannot be opened or read */
    PP_ERR_NO_MEMORY,        /* an allocation failed */
    PP_ERR_NOT_SVO,          /* the first 8 bytes are not PROBESVO */
    PP_ERR_TRUNCATED,        /* shorter than the header, or than the header announces */
    PP_ERR_TOO_LONG,         /* longer than the header announces */
    PP_ERR_VERSION,          /* a version other than PP_SVO_VERSION */
    PP_ERR_CHECKSUM,         /* the CRC-32 does not match the contents */
    PP_ERR_ORIGIN,           /* the f32 origin is not finite */
    PP_ERR_LEAF_SIZE,        /* the leaf size is not finite and positive */
    PP_ERR_DEPTH,            /* depth above 23 */
    PP_ERR_DIMS,             /* a leaf count is 0 or above 2^depth */
    PP_ERR_TOO_MANY_LEAVES,  /* more than PP_SVO_MAX_LEAVES leaves */
    PP_ERR_MAX_PROBES,       /* probes per leaf outside 1..8 */
    PP_ERR_NO_ROOT,          /* node count 0 */
    PP_ERR_PROBE_INDEX,      /* a payload index not below the probe count */
    PP_ERR_LEAF_LIST,        /* a leaf lists beyond the payload, or more than max_probes */
    PP_ERR_ORPHAN_NODE,      /* a node no earlier node has as a child */
    PP_ERR_EMPTY_INNER,      /* an inner node other than the root without a child */
    PP_ERR_BELOW_LEAF_LEVEL, /* a node with children at the leaf level */
    PP_ERR_CHILD_INDEX,      /* children at or before their parent, or past the array */
    PP_ERR_SHARED_CHILD      /* a node that is the child of two nodes */
} pp_error;

/* A loaded svo.bin. Fields are the header's (docs/formats.md); `nodes`
 * and `payload` point at little-endian u32 words inside the loaded bytes. */
typedef struct pp_svo {
    float origin[3];                 /* world lower corner of leaf (0,0,0), f32 */
    float leaf_size;                 /* edge of a leaf */
    uint32_t depth;                  /* the root cube is 2^depth leaves along an edge */
    uint32_t dims[3];                /* leaves along x, y, z; points beyond list nothing */
    uint32_t probe_count;            /* every index is below it */
    uint32_t max_probes;             /* most indices a leaf lists, 1..8 */
    uint32_t leaves_without_visible_probe;
    uint32_t node_count;
    uint32_t payload_count;
    double origin_exact[3];          /* the origin in f64 (bytes 64..87) */
    uint64_t provenance[4];          /* config hash, scene hash, seed, FNV-1a of the tool */
    const unsigned char *nodes;      /* node_count words; node 0 is the root */
    const unsigned char *payload;    /* payload_count words: probe indices */
    void *owned;                     /* the buffer of pp_svo_load_file, or NULL */
} pp_svo;

/* Checks and loads the svo.bin image `bytes` of `size` bytes into `*svo`
 * (zero-filled on failure). `bytes` must outlive `*svo`. */
pp_error pp_svo_load(const void *bytes, size_t size, pp_svo *svo);

/* Reads the file at `path` whole and loads it; free with pp_svo_free. */
pp_error pp_svo_load_file(const char *path, pp_svo *svo);

/* Releases what pp_svo_load_file allocated and zeroes `*svo`. */
void pp_svo_free(pp_svo *svo);

/* Writes the probes listed for the world-space `point` into `out`, best
 * first, and returns how many (0 to 8): 0 outside the tree's leaves, in
 * solid or outside-the-scene space, or for a non-finite point. */
unsigned pp_svo_probes_at(const pp_svo *svo, const float point[3],
                          uint32_t out[PP_MAX_PROBES_PER_LEAF]);

/* A one-line description of `e` (static storage). */
const char *pp_error_string(pp_error e);

/* CRC-32 (IEEE 802.3, as zlib's crc32) of `size` bytes: svo.bin's and
 * lightfield.bin's checksum. */
uint32_t pp_crc32(const void *bytes, size_t size);

#ifdef __cplusplus
}
#endif

#endif /* PROBEPLACE_H */

#ifdef PROBEPLACE_IMPLEMENTATION
#ifndef PROBEPLACE_IMPLEMENTED
#define PROBEPLACE_IMPLEMENTED

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef PROBEPLACE_MALLOC
#define PROBEPLACE_MALLOC(n) malloc(n)
#define PROBEPLACE_REALLOC(p, n) realloc((p), (n))
#define PROBEPLACE_FREE(p) free(p)
#endif

#define PP__LEAF_BIT 0x80000000u
#define PP__PAYLOAD_OFFSET_BITS 28u
#define PP__CHILD_MASK_BITS 8u
#define PP__NO_LEVEL 0xFFu

static uint32_t pp__u32(const unsigned char *b)
{
    return (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) |
           ((uint32_t)b[3] << 24);
}

static uint64_t pp__u64(const unsigned char *b)
{
    return (uint64_t)pp__u32(b) | ((uint64_t)pp__u32(b + 4) << 32);
}

static float pp__f32(const unsigned char *b)
{
    uint32_t w = pp__u32(b);
    float f;
    memcpy(&f, &w, sizeof f);
    return f;
}

static double pp__f64(const unsigned char *b)
{
    uint64_t w = pp__u64(b);
    double d;
    memcpy(&d, &w, sizeof d);
    return d;
}

/* Finite by the bits: an exponent field short of all ones. */
static int pp__finite(float f)
{
    uint32_t w;
    memcpy(&w, &f, sizeof w);
    return (w & 0x7F800000u) != 0x7F800000u;
}

static unsigned pp__popcount8(uint32_t m)
{
    static const unsigned char nibble[16] = {0, 1, 1, 2, 1, 2, 2, 3,
                                             1, 2, 2, 3, 2, 3, 3, 4};
    return (unsigned)nibble[m & 15u] + nibble[(m >> 4) & 15u];
}

uint32_t pp_crc32(const void *bytes, size_t size)
{
    /* Reflected polynomial 0xEDB88320, four bits at a time. */
    static const uint32_t table[16] = {
        0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu,
        0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
        0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
        0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    const unsigned char *b = (const unsigned char *)bytes;
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    for (i = 0; i < size; i++) {
        crc ^= b[i];
        crc = (crc >> 4) ^ table[crc & 15u];
        crc = (crc >> 4) ^ table[crc & 15u];
    }
    return crc ^ 0xFFFFFFFFu;
}

/* The node walk of format::validate: each node is reached exactly once,
 * from a parent stored before it, so one pass in index order visits every
 * node with its level known. `level` has one byte per node. */
static pp_error pp__check_nodes(const pp_svo *s, unsigned char *level)
{
    uint32_t n = s->node_count, i;
    for (i = 0; i < n; i++)
        level[i] = (unsigned char)PP__NO_LEVEL;
    level[0] = (unsigned char)s->depth;
    for (i = 0; i < n; i++) {
        uint32_t w = pp__u32(s->nodes + 4u * (size_t)i);
        uint32_t mask, first, count, j;
        unsigned l = level[i];
        if (l == PP__NO_LEVEL)
            return PP_ERR_ORPHAN_NODE;
        if (w & PP__LEAF_BIT) {
            uint64_t len = ((w >> PP__PAYLOAD_OFFSET_BITS) & 7u) + 1u;
            uint64_t offset = w & ((1u << PP__PAYLOAD_OFFSET_BITS) - 1u);
            if (len > s->max_probes || offset + len > s->payload_count)
                return PP_ERR_LEAF_LIST;
            continue;
        }
        mask = w & 0xFFu;
        if (mask == 0) {
            if (i != 0)
                return PP_ERR_EMPTY_INNER;
            continue;
        }
        if (l == 0)
            return PP_ERR_BELOW_LEAF_LEVEL;
        first = w >> PP__CHILD_MASK_BITS;
        count = pp__popcount8(mask);
        if (first <= i || (uint64_t)first + count > n)
            return PP_ERR_CHILD_INDEX;
        for (j = first; j < first + count; j++) {
            if (level[j] != PP__NO_LEVEL)
                return PP_ERR_SHARED_CHILD;
            level[j] = (unsigned char)(l - 1u);
        }
    }
    return PP_OK;
}

pp_error pp_svo_load(const void *bytes, size_t size, pp_svo *svo)
{
    const unsigned char *b = (const unsigned char *)bytes;
    const size_t minimum = PP_SVO_HEADER_BYTES + 4u;
    uint64_t expected, side, leaves;
    uint32_t i, version;
    unsigned char *level;
    pp_error e;
    pp_svo s;

    if (svo == NULL)
        return PP_ERR_ARGUMENT;
    memset(svo, 0, sizeof *svo);
    if (b == NULL && size != 0)
        return PP_ERR_ARGUMENT;
    if (size < 8 || memcmp(b, "PROBESVO", 8) != 0)
        return PP_ERR_NOT_SVO;
    if (size < minimum)
        return PP_ERR_TRUNCATED;
    version = pp__u32(b + 8);
    if (version != PP_SVO_VERSION)
        return PP_ERR_VERSION;
    memset(&s, 0, sizeof s);
    s.node_count = pp__u32(b + 56);
    s.payload_count = pp__u32(b + 60);
    expected = (uint64_t)minimum + 4u * ((uint64_t)s.node_count + s.payload_count);
    if ((uint64_t)size < expected)
        return PP_ERR_TRUNCATED;
    if ((uint64_t)size > expected)
        return PP_ERR_TOO_LONG;
    if (pp_crc32(b, size - 4u) != pp__u32(b + size - 4u))
        return PP_ERR_CHECKSUM;

    for (i = 0; i < 3; i++) {
        s.origin[i] = pp__f32(b + 12 + 4 * i);
        s.dims[i] = pp__u32(b + 32 + 4 * i);
        s.origin_exact[i] = pp__f64(b + 64 + 8 * i);
    }
    s.leaf_size = pp__f32(b + 24);
    s.depth = pp__u32(b + 28);
    s.probe_count = pp__u32(b + 44);
    s.max_probes = pp__u32(b + 48);
    s.leaves_without_visible_probe = pp__u32(b + 52);
    for (i = 0; i < 4; i++)
        s.provenance[i] = pp__u64(b + 88 + 8 * i);
    s.nodes = b + PP_SVO_HEADER_BYTES;
    s.payload = s.nodes + 4u * (size_t)s.node_count;

    if (!(pp__finite(s.origin[0]) && pp__finite(s.origin[1]) && pp__finite(s.origin[2])))
        return PP_ERR_ORIGIN;
    if (!(pp__finite(s.leaf_size) && s.leaf_size > 0.0f))
        return PP_ERR_LEAF_SIZE;
    if (s.depth > 23)
        return PP_ERR_DEPTH;
    side = (uint64_t)1 << s.depth;
    for (i = 0; i < 3; i++)
        if (s.dims[i] == 0 || s.dims[i] > side)
            return PP_ERR_DIMS;
    /* Each leaf count is at most 2^23 here, so the product fits in 69 bits:
     * compare in two steps rather than overflow. */
    leaves = (uint64_t)s.dims[0] * s.dims[1];
    if (leaves > PP_SVO_MAX_LEAVES || leaves * s.dims[2] > PP_SVO_MAX_LEAVES)
        return PP_ERR_TOO_MANY_LEAVES;
    if (s.max_probes < 1 || s.max_probes > PP_MAX_PROBES_PER_LEAF)
        return PP_ERR_MAX_PROBES;
    if (s.node_count == 0)
        return PP_ERR_NO_ROOT;
    for (i = 0; i < s.payload_count; i++)
        if (pp__u32(s.payload + 4u * (size_t)i) >= s.probe_count)
            return PP_ERR_PROBE_INDEX;

    level = (unsigned char *)PROBEPLACE_MALLOC(s.node_count);
    if (level == NULL)
        return PP_ERR_NO_MEMORY;
    e = pp__check_nodes(&s, level);
    PROBEPLACE_FREE(level);
    if (e != PP_OK)
        return e;
    *svo = s;
    return PP_OK;
}

pp_error pp_svo_load_file(const char *path, pp_svo *svo)
{
    FILE *f;
    unsigned char *buf = NULL;
    size_t len = 0, cap = 0;
    pp_error e;

    if (svo == NULL)
        return PP_ERR_ARGUMENT;
    memset(svo, 0, sizeof *svo);
    if (path == NULL)
        return PP_ERR_ARGUMENT;
    f = fopen(path, "rb");
    if (f == NULL)
        return PP_ERR_IO;
    for (;;) {
        size_t got;
        if (len == cap) {
            size_t grown = cap ? 2 * cap : 65536u;
            unsigned char *next;
            if (grown < cap) {
                PROBEPLACE_FREE(buf);
                fclose(f);
                return PP_ERR_NO_MEMORY;
            }
            next = (unsigned char *)PROBEPLACE_REALLOC(buf, grown);
            if (next == NULL) {
                PROBEPLACE_FREE(buf);
                fclose(f);
                return PP_ERR_NO_MEMORY;
            }
            buf = next;
            cap = grown;
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            int failed = ferror(f);
            fclose(f);
            if (failed) {
                PROBEPLACE_FREE(buf);
                return PP_ERR_IO;
            }
            break;
        }
    }
    e = pp_svo_load(buf, len, svo);
    if (e != PP_OK) {
        PROBEPLACE_FREE(buf);
        return e;
    }
    svo->owned = buf;
    return PP_OK;
}

void pp_svo_free(pp_svo *svo)
{
    if (svo == NULL)
        return;
    PROBEPLACE_FREE(svo->owned);
    memset(svo, 0, sizeof *svo);
}

unsigned pp_svo_probes_at(const pp_svo *svo, const float point[3],
                          uint32_t out[PP_MAX_PROBES_PER_LEAF])
{
    uint32_t c[3], level, word, i;
    unsigned steps;
    if (svo == NULL || point == NULL || out == NULL || svo->nodes == NULL ||
        svo->node_count == 0 || svo->depth > 23)
        return 0;
    for (i = 0; i < 3; i++) {
        /* Svo::probes_at: ((point - origin) / leaf_size).floor(), each
         * operation rounded to f32. NaN fails both comparisons, -inf the
         * first and +inf the second: Rust's is_finite test is implied. */
        float d = point[i] - svo->origin[i];
        float q = d / svo->leaf_size;
        float g = floorf(q);
        if (!(g >= 0.0f && g < (float)svo->dims[i]))
            return 0;
        c[i] = (uint32_t)g;
    }
    level = svo->depth;
    word = pp__u32(svo->nodes);
    for (steps = 0; steps <= 24u; steps++) {
        uint32_t mask, child, index;
        if (word & PP__LEAF_BIT) {
            uint32_t count = ((word >> PP__PAYLOAD_OFFSET_BITS) & 7u) + 1u;
            uint32_t offset = word & ((1u << PP__PAYLOAD_OFFSET_BITS) - 1u);
            if ((uint64_t)offset + count > svo->payload_count)
                return 0;
            for (i = 0; i < count; i++)
                out[i] = pp__u32(svo->payload + 4u * ((size_t)offset + i));
            return count;
        }
        mask = word & 0xFFu;
        if (mask == 0 || level == 0)
            return 0;
        level--;
        child = ((c[0] >> level) & 1u) | (((c[1] >> level) & 1u) << 1) |
                (((c[2] >> level) & 1u) << 2);
        if ((mask & (1u << child)) == 0)
            return 0;
        index = (word >> PP__CHILD_MASK_BITS) + pp__popcount8(mask & ((1u << child) - 1u));
        if (index >= svo->node_count)
            return 0;
        word = pp__u32(svo->nodes + 4u * (size_t)index);
    }
    return 0;
}

const char *pp_error_string(pp_error e)
{
    switch (e) {
    case PP_OK: return "no error";
    case PP_ERR_ARGUMENT: return "a required pointer is NULL";
    case PP_ERR_IO: return "cannot open or read the file";
    case PP_ERR_NO_MEMORY: return "out of memory";
    case PP_ERR_NOT_SVO: return "not a probeplace SVO file (its first bytes are not PROBESVO)";
    case PP_ERR_TRUNCATED: return "truncated: shorter than its header, or than its header announces";
    case PP_ERR_TOO_LONG: return "corrupted: longer than its header announces";
    case PP_ERR_VERSION: return "unsupported version: this reader reads version 2";
    case PP_ERR_CHECKSUM: return "corrupted: the checksum does not match the contents";
    case PP_ERR_ORIGIN: return "corrupted: the origin is not finite";
    case PP_ERR_LEAF_SIZE: return "corrupted: the leaf size is not positive";
    case PP_ERR_DEPTH: return "corrupted: depth exceeds 23";
    case PP_ERR_DIMS: return "corrupted: the leaf counts do not fit the root";
    case PP_ERR_TOO_MANY_LEAVES: return "corrupted: more than 64000000 leaves";
    case PP_ERR_MAX_PROBES: return "corrupted: probes per leaf outside 1..=8";
    case PP_ERR_NO_ROOT: return "corrupted: there is no root node";
    case PP_ERR_PROBE_INDEX: return "corrupted: a probe index is not below the probe count";
    case PP_ERR_LEAF_LIST: return "corrupted: a leaf lists beyond the payload";
    case PP_ERR_ORPHAN_NODE: return "corrupted: a node has no parent";
    case PP_ERR_EMPTY_INNER: return "corrupted: an inner node has no child";
    case PP_ERR_BELOW_LEAF_LEVEL: return "corrupted: a node has children below the leaf level";
    case PP_ERR_CHILD_INDEX: return "corrupted: a node points outside the node array";
    case PP_ERR_SHARED_CHILD: return "corrupted: a node shares a child with another node";
    }
    return "unknown error";
}

#endif /* PROBEPLACE_IMPLEMENTED */
#endif /* PROBEPLACE_IMPLEMENTATION */
