/* probeplace.h: reads probeplace's svo.bin and lightfield.bin, answers
 * probes_at and gives the diffuse blend's probes and weights, in C99.
 *
 * A single-header library (stb style). In exactly one C file:
 *
 *     #define PROBEPLACE_IMPLEMENTATION
 *     #include "probeplace.h"
 *
 * and include it plainly everywhere else. It needs only the C99 standard
 * library (stdio for the *_load_file functions, stdlib for malloc and
 * qsort, math for floorf, roundf, sqrtf, fabsf), and on POSIX systems
 * open, fstat and read (fcntl.h, sys/stat.h, unistd.h) for the
 * *_load_file functions (CONTRACT).
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
 * And `lightfield.bin`, version 1 (`probeplace bake`; docs/formats.md,
 * "lightfield.bin"): pp_lightfield_load points at each section of the
 * probes' maps, and pp_blend_weights gives, for a point and its unit
 * normal, the probes and the normalized weights of the validation
 * renders' irradiance gather (McGuire et al. 2017 section 5.2), exactly
 * as `probeplace::blend_weights` gives them (WEIGHTS, below):
 *
 *     pp_lightfield field;
 *     e = pp_lightfield_load_file("out/cornell/lightfield.bin", &field);
 *     // ... and svo loaded as above; then, per shading point:
 *     uint32_t *ids = malloc(pp_blend_terms(&field, NULL) * sizeof *ids);
 *     float *w = malloc(pp_blend_terms(&field, NULL) * sizeof *w);
 *     float normal[3] = { 0.0f, 1.0f, 0.0f };
 *     size_t count;
 *     e = pp_blend_weights(&field, &svo, NULL, p, normal, ids, w,
 *                          pp_blend_terms(&field, NULL), &count);
 *     // irradiance = sum over k < count of w[k] * E_ids[k](normal)
 *     pp_lightfield_free(&field);
 *
 * For a grid run's bi-level render, pass the lattice instead of the tree:
 * pp_lattice_from_positions(&field, &lattice), then
 * pp_blend_weights(&field, NULL, &lattice, ...) with 8 terms.
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
 *  - pp_lightfield_load / pp_lightfield_load_file accept exactly the files
 *    `LightField::read` (src/lightfield/format.rs) accepts, with its
 *    checks in its order: length at least the header's, magic, version,
 *    map sides powers of two up to 16384, pyramid levels log2(n) + 1, the
 *    exact length the header implies (computed without overflow), CRC-32.
 *    The map values are not checked (nor are they by Rust): a NaN in them
 *    makes the blend's weights NaN, hence its count 0, never a bad read.
 *  - A pp_svo filled by a successful load answers pp_svo_probes_at in
 *    O(depth) reads, without allocating; the walk is bounded by the depth
 *    (at most 24 steps) whatever the node words hold, and it re-checks
 *    every index it follows, so even a pp_svo whose bytes changed after the
 *    load reads nothing out of bounds. Every index it returns is below
 *    `probe_count`; it returns at most `max_probes` of them.
 *  - pp_blend_weights reads only the positions and moments of probes below
 *    `probe_count` and texels inside their maps, without allocating, in
 *    O(terms); pp_lattice_from_positions allocates its index (freed by
 *    pp_lattice_free) and, while it works, 12 bytes a probe.
 *  - The loaders keep pointers into `bytes` (no copy): the buffer must
 *    outlive the result and stay unchanged. The *_load_file functions own
 *    their buffer; pp_svo_free and pp_lightfield_free release it (and are
 *    harmless on a result of the in-memory loaders, or of a failed load).
 *  - pp_svo_load_file / pp_lightfield_load_file open the path without
 *    blocking (POSIX: O_NONBLOCK, then fstat on the open descriptor, so a
 *    FIFO without a writer neither blocks nor slips in between a check and
 *    the open) and refuse anything but a regular file before reading a
 *    byte (PP_ERR_NOT_REGULAR_FILE: a FIFO, a directory, /dev/zero or a
 *    link to it), and a file over PP_MAX_FILE_BYTES (PP_ERR_FILE_TOO_BIG).
 *    They read at most the size fstat gave, in one allocation of that
 *    size, as probeplace's own reader does (src/input.rs). Without POSIX
 *    (no __unix__) they read with stdio, up to PP_MAX_FILE_BYTES, and
 *    cannot tell a FIFO from a file.
 *  - Thread safety: loading touches only its arguments; any number of
 *    threads may query one pp_svo, pp_lightfield and pp_lattice at once.
 *
 * ARITHMETIC. pp_svo_probes_at answers exactly what `Svo::probes_at`
 * answers, bit for bit: g = floorf((p - origin) / leaf_size) in IEEE single
 * precision, one subtraction, one division and one floor per axis, each
 * rounded to float, then the walk in integers.
 *
 * WEIGHTS. pp_blend_weights gives `probeplace::blend_weights`'s bits.
 * Each term's weight is spatial x max(n . w, PP_MIN_NORMAL_WEIGHT) x
 * visibility, w the unit direction from the point toward the probe ("a
 * clamped dot product of the shading point's surface normal and the
 * direction towards each probe center", a smooth backface test), and the
 * visibility Chebyshev's bound s2 / (s2 + (r - E[r])^2) where r > E[r]
 * (else 1), s2 = |E[r^2] - E[r]^2| floored at 1e-6, from the probe's
 * moments read bilinearly (across the octahedral fold) in direction -w at
 * the distance r to the probe; at the probe itself (r = 0) facing counts
 * n . 0, so the floor, and visibility 1. Each weight is then divided by
 * their sum ("We normalize the result by the sum of all eight weights").
 * The spatial weight and the order of the terms follow the selection:
 *  - the SVO selection (`svo`, the Hi-Z render's, and the bi-level
 *    render's for probes off a grid): every probe, in index order,
 *    1 / (|q - p|^2 + leaf_size^2). Not the tree's lists: they change at
 *    node faces and weights from them jump there, which showed as
 *    rectangles on walls (src/trace/gather.rs);
 *  - the grid selection (`lattice`): the 8 corners of the cell holding p
 *    (clamped to the lattice), corner k at offset (k & 1, k >> 1 & 1,
 *    k >> 2 & 1), trilinear; a probe twice where the lattice has one layer
 *    along an axis, and weight 0 on a cell face.
 * The weights are in [0, 1] and sum to 1 up to a rounding per term; the
 * count is 0 when they sum to no positive number (a non-finite point).
 *
 * Both answers hold bit for bit wherever float operations are IEEE single
 * precision (FLT_EVAL_METHOD 0: x86-64 SSE, AArch64) and the compiler does
 * not contract a multiply and an add into a fused multiply-add: the blend
 * has many, and Rust never fuses them. BUILD WITH -ffp-contract=off (GCC
 * and Clang; elsewhere the switch that forbids contraction) for
 * bit-identical weights: GCC contracts by default in its GNU dialects
 * (-std=gnu*, its default) where the target has FMA (-march=haswell and
 * later, AArch64), and the weights then differ in their last bits (with
 * -std=gnu99 -march=haswell, at each of 4000 points of a Cornell grid's
 * SVO blend). With FLT_EVAL_METHOD 2 (x87),
 * C99 rounds every assignment to float (GCC with -std=c99 does,
 * -fexcess-precision=standard), and each intermediate here is assigned,
 * so it should hold too (untested). Do not build this file with
 * -ffast-math or -Ofast (they change the floor/compare semantics and NaN
 * handling, on which the answers for non-finite points rest).
 *
 * COORDINATES. Points are world space, as probes.json's `position`. The
 * origin is stored as f32 (`origin`) and exactly (`origin_exact`, f64).
 * At a distance D from the world origin f32 rounds a coordinate by about
 * D * 6e-8; where that nears the leaf size, compute p - origin_exact in
 * double in your own frame and query with `origin` set to zero: the
 * answers are then those of your rounding, not Rust's (docs/formats.md,
 * "Precision"). The blend takes world points as lightfield.bin's f32
 * positions hold them.
 *
 * Tested against the Rust writer by tests/it/readers.rs (tests/c/readers.c,
 * built with gcc -std=c99 -Wall -Wextra -Werror -pedantic
 * -fsanitize=address,undefined -ffp-contract=off): probes_at on Cornell,
 * Holodeck and Sponza, the blend on Cornell's placed probes and on a
 * Cornell grid with both selections (Holodeck and Sponza in the full
 * tier), and damaged and hostile files of both kinds.
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
/* The most bytes pp_svo_load_file and pp_lightfield_load_file read from one
 * file: 64 GiB unless defined lower (or higher) before the header is
 * included. A file is read up to the size fstat gives when it is opened,
 * never past it; a larger one is PP_ERR_FILE_TOO_BIG before a byte is
 * read. (An svo.bin of PP_SVO_MAX_LEAVES leaves takes under 3 GiB.) */
#ifndef PP_MAX_FILE_BYTES
#define PP_MAX_FILE_BYTES ((uint64_t)1 << 36)
#endif

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
    PP_ERR_SHARED_CHILD,     /* a node that is the child of two nodes */
    /* lightfield.bin (pp_lightfield_load), in the order of
     * src/lightfield/format.rs after PP_ERR_TRUNCATED (shorter than the
     * 64-byte header and the checksum), before PP_ERR_VERSION and
     * PP_ERR_CHECKSUM, which it shares with svo.bin: */
    PP_ERR_NOT_LIGHTFIELD,   /* the first 8 bytes are not PROBELFB */
    PP_ERR_MAP_SIDE,         /* a map side that is not a power of two up to 16384 */
    PP_ERR_LEVELS,           /* pyramid levels other than log2(n) + 1 */
    PP_ERR_LENGTH,           /* a length other than the header implies */
    /* The blend (pp_lattice_from_positions, pp_blend_weights): */
    PP_ERR_NOT_A_GRID,       /* the probes are not a regular lattice */
    PP_ERR_MISMATCH,         /* an svo.bin or lattice of another probe count than the light field */
    PP_ERR_CAPACITY,         /* output arrays shorter than the blend's terms */
    /* The *_load_file functions' own, before a byte is read (appended, so
     * the codes above keep their values): */
    PP_ERR_NOT_REGULAR_FILE, /* a FIFO, a directory, a device or a socket */
    PP_ERR_FILE_TOO_BIG      /* larger than PP_MAX_FILE_BYTES */
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

/* The svo.bin and lightfield.bin versions this header reads. */
#define PP_LIGHTFIELD_VERSION 1u
/* Bytes before the probe positions of lightfield.bin. */
#define PP_LIGHTFIELD_HEADER_BYTES 64u
/* Terms of the blend on a grid: the eight corners of a cell. */
#define PP_GRID_TERMS 8u
/* trace::gather::MIN_NORMAL_WEIGHT: the floor of the normal weight. */
#define PP_MIN_NORMAL_WEIGHT 0.05f

/* A loaded lightfield.bin (docs/formats.md, "lightfield.bin"). The section
 * pointers point into the loaded bytes: little-endian f32 positions, then
 * f16 maps (IEEE half), each probe after probe and row by row. */
typedef struct pp_lightfield {
    uint32_t probe_count;            /* P, in the order of probes.json */
    uint32_t resolution;             /* n: side of the radiance, normal and distance maps */
    uint32_t levels;                 /* pyramid levels, log2(n) + 1 */
    uint32_t irradiance_resolution;  /* m: side of the irradiance and moment maps */
    float max_distance;              /* the moments' stand-in for escaping rays (not checked) */
    uint64_t provenance[4];          /* as pp_svo's: equal for files of one run */
    const unsigned char *positions;  /* P x 3 f32, world space */
    const unsigned char *radiance;   /* P n^2 x 3 f16, RGB */
    const unsigned char *normal;     /* P n^2 x 2 f16, octahedral */
    const unsigned char *distance;   /* P n^2 f16 */
    const unsigned char *pyramid;    /* level k: P (n >> k)^2 x 2 f16, levels in order */
    const unsigned char *irradiance; /* P m^2 x 3 f16, RGB */
    const unsigned char *moments;    /* P m^2 x 2 f16, (E[r], E[r^2]) */
    void *owned;                     /* the buffer of pp_lightfield_load_file, or NULL */
} pp_lightfield;

/* The probes of a light field as a regular grid (trace::Lattice): the grid
 * selection of the blend. */
typedef struct pp_lattice {
    float origin[3];                 /* lattice point (0, 0, 0) */
    float spacing[3];                /* per axis; 1 where an axis has one layer */
    int32_t dims[3];                 /* points per axis */
    uint32_t *index;                 /* dims[0]*dims[1]*dims[2] probes, x fastest, then y, z */
} pp_lattice;

/* Checks and loads the lightfield.bin image `bytes` of `size` bytes into
 * `*field` (zero-filled on failure), with the checks of `LightField::read`
 * in its order: PP_ERR_TRUNCATED (under 68 bytes), PP_ERR_NOT_LIGHTFIELD,
 * PP_ERR_VERSION, PP_ERR_MAP_SIDE, PP_ERR_LEVELS, PP_ERR_LENGTH,
 * PP_ERR_CHECKSUM. `bytes` must outlive `*field`; no copy. */
pp_error pp_lightfield_load(const void *bytes, size_t size, pp_lightfield *field);

/* Reads the file at `path` whole and loads it; free with pp_lightfield_free. */
pp_error pp_lightfield_load_file(const char *path, pp_lightfield *field);

/* Releases what pp_lightfield_load_file allocated and zeroes `*field`. */
void pp_lightfield_free(pp_lightfield *field);

/* Recognizes the probes of `field` as a regular grid, as
 * `Lattice::from_positions` does: PP_ERR_NOT_A_GRID unless the positions
 * are finite, at least one, and exactly the points of an nx x ny x nz
 * lattice with constant spacing per axis (to 1e-4 of the largest
 * coordinate). Allocates the index (P words) and, while it works, 3 P
 * floats; free with pp_lattice_free. O(P x distinct values per axis). */
pp_error pp_lattice_from_positions(const pp_lightfield *field, pp_lattice *lattice);

/* Releases the index of `*lattice` and zeroes it. */
void pp_lattice_free(pp_lattice *lattice);

/* How many terms the blend has: PP_GRID_TERMS with a lattice, else (the
 * SVO selection) the probe count of `field`; 0 for a NULL field. */
size_t pp_blend_terms(const pp_lightfield *field, const pp_lattice *lattice);

/* The probes and normalized weights of the validation renders' diffuse
 * blend at the world-space `point` with unit `normal` (McGuire et al. 2017
 * section 5.2; probeplace::blend_weights, bit for bit; WEIGHTS, in
 * the opening comment).
 * Give exactly one selection: `svo` (the run's tree: the SVO selection,
 * which reads only its leaf size) or `lattice` (from
 * pp_lattice_from_positions on `field`: the grid selection). Writes
 * `*count` terms, in blend order, to `probes` and `weights`, which hold
 * `capacity` entries, at least pp_blend_terms(field, lattice); `*count` is
 * 0 when the weights sum to no positive number (a non-finite point).
 * Errors: PP_ERR_ARGUMENT (a NULL pointer, or not exactly one selection),
 * PP_ERR_MISMATCH (a selection of another probe count than `field`),
 * PP_ERR_CAPACITY. No allocation; O(terms); thread-safe. */
pp_error pp_blend_weights(const pp_lightfield *field, const pp_svo *svo,
                          const pp_lattice *lattice, const float point[3],
                          const float normal[3], uint32_t *probes, float *weights,
                          size_t capacity, size_t *count);

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

#if defined(__unix__) || defined(__unix) || (defined(__APPLE__) && defined(__MACH__))
#define PP__POSIX 1
#include <errno.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>
#ifdef O_CLOEXEC
#define PP__O_CLOEXEC O_CLOEXEC
#else
#define PP__O_CLOEXEC 0
#endif
#endif

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

/* The whole file at `path` in a buffer the caller frees (NULL for an
 * empty file, which then has `*len` 0). */
/* The bytes of the regular file at `path` (CONTRACT): opened without
 * blocking and checked with fstat before a byte is read; at most the size
 * fstat gave is read (a file that shrank since reads shorter, and the
 * loader's length checks refuse it). */
static pp_error pp__read_file(const char *path, unsigned char **out, size_t *out_len)
{
#ifdef PP__POSIX
    int fd;
    struct stat st;
    unsigned char *buf;
    size_t len = 0, size;

    *out = NULL;
    *out_len = 0;
    fd = open(path, O_RDONLY | O_NONBLOCK | PP__O_CLOEXEC);
    if (fd < 0)
        return PP_ERR_IO;
    if (fstat(fd, &st) != 0) {
        close(fd);
        return PP_ERR_IO;
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return PP_ERR_NOT_REGULAR_FILE;
    }
    if (st.st_size < 0 || (uint64_t)st.st_size > (uint64_t)PP_MAX_FILE_BYTES ||
        (uint64_t)st.st_size > (uint64_t)(size_t)-1) {
        close(fd);
        return PP_ERR_FILE_TOO_BIG;
    }
    size = (size_t)st.st_size;
    buf = (unsigned char *)PROBEPLACE_MALLOC(size ? size : 1u);
    if (buf == NULL) {
        close(fd);
        return PP_ERR_NO_MEMORY;
    }
    while (len < size) {
        size_t want = size - len;
        ssize_t got;
        if (want > ((size_t)1 << 30))
            want = (size_t)1 << 30;
        got = read(fd, buf + len, want);
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0) {
            PROBEPLACE_FREE(buf);
            close(fd);
            return PP_ERR_IO;
        }
        if (got == 0)
            break;
        len += (size_t)got;
    }
    close(fd);
    *out = buf;
    *out_len = len;
    return PP_OK;
#else
    FILE *f;
    unsigned char *buf = NULL;
    size_t len = 0, cap = 0;

    *out = NULL;
    *out_len = 0;
    f = fopen(path, "rb");
    if (f == NULL)
        return PP_ERR_IO;
    for (;;) {
        size_t got;
        if (len == cap) {
            size_t grown = cap ? 2 * cap : 65536u;
            unsigned char *next;
            if ((uint64_t)len >= (uint64_t)PP_MAX_FILE_BYTES) {
                PROBEPLACE_FREE(buf);
                fclose(f);
                return PP_ERR_FILE_TOO_BIG;
            }
            if ((uint64_t)grown > (uint64_t)PP_MAX_FILE_BYTES + 1u)
                grown = (size_t)((uint64_t)PP_MAX_FILE_BYTES + 1u);
            if (grown <= cap) {
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
    if ((uint64_t)len > (uint64_t)PP_MAX_FILE_BYTES) {
        PROBEPLACE_FREE(buf);
        return PP_ERR_FILE_TOO_BIG;
    }
    *out = buf;
    *out_len = len;
    return PP_OK;
#endif
}

pp_error pp_svo_load_file(const char *path, pp_svo *svo)
{
    unsigned char *buf;
    size_t len;
    pp_error e;

    if (svo == NULL)
        return PP_ERR_ARGUMENT;
    memset(svo, 0, sizeof *svo);
    if (path == NULL)
        return PP_ERR_ARGUMENT;
    e = pp__read_file(path, &buf, &len);
    if (e != PP_OK)
        return e;
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

/* ---- lightfield.bin ---------------------------------------------------- */

pp_error pp_lightfield_load(const void *bytes, size_t size, pp_lightfield *field)
{
    const unsigned char *b = (const unsigned char *)bytes;
    uint64_t per_probe, want, pyramid = 0;
    uint32_t p, n, levels, m, k;
    pp_lightfield f;

    if (field == NULL)
        return PP_ERR_ARGUMENT;
    memset(field, 0, sizeof *field);
    if (b == NULL && size != 0)
        return PP_ERR_ARGUMENT;
    if (size < PP_LIGHTFIELD_HEADER_BYTES + 4u)
        return PP_ERR_TRUNCATED;
    if (memcmp(b, "PROBELFB", 8) != 0)
        return PP_ERR_NOT_LIGHTFIELD;
    if (pp__u32(b + 8) != PP_LIGHTFIELD_VERSION)
        return PP_ERR_VERSION;
    p = pp__u32(b + 12);
    n = pp__u32(b + 16);
    levels = pp__u32(b + 20);
    m = pp__u32(b + 24);
    if (n == 0 || (n & (n - 1u)) != 0 || m == 0 || (m & (m - 1u)) != 0 ||
        n > (1u << 14) || m > (1u << 14))
        return PP_ERR_MAP_SIDE;
    for (k = 0; (n >> k) > 1u; k++)
        ;
    if (levels != k + 1u)
        return PP_ERR_LEVELS;
    for (k = 0; k < levels; k++)
        pyramid += (uint64_t)(n >> k) * (n >> k);
    /* At most 2^34 bytes a probe (sides up to 2^14): the product with P
     * can pass 2^64, so compare by division first. */
    per_probe = 12u + 12u * (uint64_t)n * n + 4u * pyramid + 10u * (uint64_t)m * m;
    if (p != 0 && per_probe > (UINT64_MAX - PP_LIGHTFIELD_HEADER_BYTES - 4u) / p)
        return PP_ERR_LENGTH;
    want = (uint64_t)p * per_probe + PP_LIGHTFIELD_HEADER_BYTES + 4u;
    if (want != (uint64_t)size)
        return PP_ERR_LENGTH;
    if (pp_crc32(b, size - 4u) != pp__u32(b + size - 4u))
        return PP_ERR_CHECKSUM;

    memset(&f, 0, sizeof f);
    f.probe_count = p;
    f.resolution = n;
    f.levels = levels;
    f.irradiance_resolution = m;
    f.max_distance = pp__f32(b + 28);
    for (k = 0; k < 4; k++)
        f.provenance[k] = pp__u64(b + 32 + 8 * k);
    f.positions = b + PP_LIGHTFIELD_HEADER_BYTES;
    f.radiance = f.positions + 12u * (size_t)p;
    f.normal = f.radiance + 6u * (size_t)p * n * n;
    f.distance = f.normal + 4u * (size_t)p * n * n;
    f.pyramid = f.distance + 2u * (size_t)p * n * n;
    f.irradiance = f.pyramid + 4u * (size_t)p * (size_t)pyramid;
    f.moments = f.irradiance + 6u * (size_t)p * m * m;
    *field = f;
    return PP_OK;
}

pp_error pp_lightfield_load_file(const char *path, pp_lightfield *field)
{
    unsigned char *buf;
    size_t len;
    pp_error e;

    if (field == NULL)
        return PP_ERR_ARGUMENT;
    memset(field, 0, sizeof *field);
    if (path == NULL)
        return PP_ERR_ARGUMENT;
    e = pp__read_file(path, &buf, &len);
    if (e != PP_OK)
        return e;
    e = pp_lightfield_load(buf, len, field);
    if (e != PP_OK) {
        PROBEPLACE_FREE(buf);
        return e;
    }
    field->owned = buf;
    return PP_OK;
}

void pp_lightfield_free(pp_lightfield *field)
{
    if (field == NULL)
        return;
    PROBEPLACE_FREE(field->owned);
    memset(field, 0, sizeof *field);
}

/* ---- The blend ----------------------------------------------------------
 * Each function mirrors the Rust one named beside it, operation for
 * operation, each intermediate assigned to a float (WEIGHTS, in the
 * header's opening comment). `a > b ? a : b` is both glam's Vec3::max and,
 * against a constant that is not NaN, f32::max: NaN gives the constant. */

static float pp__max(float a, float b) { return a > b ? a : b; }
static float pp__min(float a, float b) { return a < b ? a : b; }

/* IEEE half to float, exactly (half::f16::to_f32). */
static float pp__half(const unsigned char *b)
{
    uint32_t h = (uint32_t)b[0] | ((uint32_t)b[1] << 8);
    uint32_t sign = (h & 0x8000u) << 16, exp = (h >> 10) & 0x1Fu, man = h & 0x3FFu, w;
    float f;
    if (exp == 0x1Fu) {
        w = sign | 0x7F800000u | (man << 13);
    } else if (exp != 0) {
        w = sign | ((exp + 112u) << 23) | (man << 13);
    } else if (man == 0) {
        w = sign;
    } else {
        /* Subnormal: man x 2^-24, normalized. */
        exp = 113u;
        while ((man & 0x400u) == 0) {
            man <<= 1;
            exp--;
        }
        w = sign | (exp << 23) | ((man & 0x3FFu) << 13);
    }
    memcpy(&f, &w, sizeof f);
    return f;
}

/* Rust's `x as i32` for an integral float: NaN is 0, beyond the range the
 * nearest end (where a C cast would be undefined). */
static int32_t pp__sat_i32(float x)
{
    if (!(x == x))
        return 0;
    if (x >= 2147483648.0f)
        return INT32_MAX;
    if (x < -2147483648.0f)
        return INT32_MIN;
    return (int32_t)x;
}

/* lightfield::octahedral::encode */
static void pp__oct_encode(float dx, float dy, float dz, float *ex, float *ey)
{
    float s = fabsf(dx) + fabsf(dy);
    float px, py;
    s = s + fabsf(dz);
    px = dx / s;
    py = dy / s;
    if (dz < 0.0f) {
        float sx = px >= 0.0f ? 1.0f : -1.0f;
        float sy = py >= 0.0f ? 1.0f : -1.0f;
        float fx = 1.0f - fabsf(py), fy = 1.0f - fabsf(px);
        *ex = fx * sx;
        *ey = fy * sy;
    } else {
        *ex = px;
        *ey = py;
    }
}

static int64_t pp__clamp64(int64_t v, int64_t lo, int64_t hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* lightfield::octahedral::wrap_texel */
static void pp__wrap_texel(int64_t x, int64_t y, int64_t n, uint32_t *ox, uint32_t *oy)
{
    int64_t wx = x, wy = y;
    if (x < 0 || x >= n) {
        wx = pp__clamp64(x, 0, n - 1);
        wy = n - 1 - y;
    }
    if (y < 0 || y >= n) {
        wy = pp__clamp64(wy, 0, n - 1);
        wx = n - 1 - wx;
    }
    *ox = (uint32_t)pp__clamp64(wx, 0, n - 1);
    *oy = (uint32_t)pp__clamp64(wy, 0, n - 1);
}

/* trace::gather::bilinear of `probe`'s moment map in direction d. */
static void pp__bilinear_moments(const pp_lightfield *f, uint32_t probe, float dx,
                                 float dy, float dz, float out[2])
{
    const uint32_t m = f->irradiance_resolution;
    const float mf = (float)m;
    float ex, ey, ux, uy, x0, y0, fx, fy, gx, gy, w[4];
    int64_t xi, yi;
    int k;
    pp__oct_encode(dx, dy, dz, &ex, &ey);
    ux = (ex + 1.0f) * 0.5f;
    ux = ux * mf;
    ux = ux - 0.5f;
    uy = (ey + 1.0f) * 0.5f;
    uy = uy * mf;
    uy = uy - 0.5f;
    x0 = floorf(ux);
    y0 = floorf(uy);
    fx = ux - x0;
    fy = uy - y0;
    gx = 1.0f - fx;
    gy = 1.0f - fy;
    w[0] = gx * gy;
    w[1] = fx * gy;
    w[2] = gx * fy;
    w[3] = fx * fy;
    /* `x0 as i64`: |e| <= 1, so x0 lies in -1..=m, or is NaN (0). */
    xi = pp__sat_i32(x0);
    yi = pp__sat_i32(y0);
    out[0] = 0.0f;
    out[1] = 0.0f;
    for (k = 0; k < 4; k++) {
        uint32_t x, y;
        const unsigned char *t;
        float a, b;
        pp__wrap_texel(xi + (k & 1), yi + (k >> 1), m, &x, &y);
        t = f->moments + 4u * ((size_t)probe * m * m + (size_t)y * m + x);
        a = w[k] * pp__half(t);
        b = w[k] * pp__half(t + 2);
        out[0] = out[0] + a;
        out[1] = out[1] + b;
    }
}

/* lightfield::irradiance::chebyshev_visibility */
static float pp__chebyshev(const float moments[2], float r)
{
    float mean = moments[0], variance, d, dd;
    if (r <= mean)
        return 1.0f;
    variance = mean * mean;
    variance = fabsf(moments[1] - variance);
    variance = pp__max(variance, 1e-6f);
    d = r - mean;
    dd = d * d;
    dd = variance + dd;
    return variance / dd;
}

/* The weight of one term (trace::gather::for_each_term): spatial x facing
 * x visibility of `probe` at `p` with normal `n`. */
static float pp__term(const pp_lightfield *f, uint32_t probe, float spatial,
                      const float p[3], const float n[3])
{
    const unsigned char *q = f->positions + 12u * (size_t)probe;
    float tx = pp__f32(q) - p[0], ty = pp__f32(q + 4) - p[1], tz = pp__f32(q + 8) - p[2];
    float r, ox = 0.0f, oy = 0.0f, oz = 0.0f, facing, visibility = 1.0f, xx, yy, zz, w;
    xx = tx * tx;
    yy = ty * ty;
    zz = tz * tz;
    r = xx + yy;
    r = r + zz;
    r = sqrtf(r);
    if (r > 0.0f) {
        ox = tx / r;
        oy = ty / r;
        oz = tz / r;
    }
    xx = n[0] * ox;
    yy = n[1] * oy;
    zz = n[2] * oz;
    facing = xx + yy;
    facing = facing + zz;
    facing = pp__max(facing, PP_MIN_NORMAL_WEIGHT);
    if (r > 0.0f) {
        float moments[2];
        pp__bilinear_moments(f, probe, -ox, -oy, -oz, moments);
        visibility = pp__chebyshev(moments, r);
    }
    w = spatial * facing;
    return w * visibility;
}

size_t pp_blend_terms(const pp_lightfield *field, const pp_lattice *lattice)
{
    if (field == NULL)
        return 0;
    return lattice != NULL ? PP_GRID_TERMS : field->probe_count;
}

pp_error pp_blend_weights(const pp_lightfield *field, const pp_svo *svo,
                          const pp_lattice *lattice, const float point[3],
                          const float normal[3], uint32_t *probes, float *weights,
                          size_t capacity, size_t *count)
{
    size_t terms, k;
    float p[3], n[3], total = 0.0f;

    if (count != NULL)
        *count = 0;
    if (field == NULL || point == NULL || normal == NULL || probes == NULL ||
        weights == NULL || count == NULL || (svo == NULL) == (lattice == NULL))
        return PP_ERR_ARGUMENT;
    if ((field->positions == NULL && field->probe_count != 0) ||
        (lattice != NULL && lattice->index == NULL))
        return PP_ERR_ARGUMENT;
    if (svo != NULL && svo->probe_count != field->probe_count)
        return PP_ERR_MISMATCH;
    if (lattice != NULL &&
        (lattice->dims[0] < 1 || lattice->dims[1] < 1 || lattice->dims[2] < 1 ||
         (uint64_t)lattice->dims[0] * (uint64_t)lattice->dims[1] * (uint64_t)lattice->dims[2] !=
             field->probe_count))
        return PP_ERR_MISMATCH;
    terms = pp_blend_terms(field, lattice);
    if (capacity < terms)
        return PP_ERR_CAPACITY;
    for (k = 0; k < 3; k++) {
        p[k] = point[k];
        n[k] = normal[k];
    }
    if (lattice != NULL) {
        /* trace::Lattice::cell, then the trilinear weights of
         * for_each_term's grid branch (glam's clamp: max, then min). */
        int32_t cell[3];
        float f[3];
        for (k = 0; k < 3; k++) {
            float g = p[k] - lattice->origin[k];
            int32_t hi = lattice->dims[k] - 2 > 0 ? lattice->dims[k] - 2 : 0;
            int32_t c;
            g = g / lattice->spacing[k];
            c = pp__sat_i32(floorf(g));
            cell[k] = c < 0 ? 0 : (c > hi ? hi : c);
            f[k] = g - (float)cell[k];
            f[k] = pp__min(pp__max(f[k], 0.0f), 1.0f);
        }
        for (k = 0; k < PP_GRID_TERMS; k++) {
            size_t c[3], a;
            float w[3], spatial;
            for (a = 0; a < 3; a++) {
                int32_t o = (int32_t)((k >> a) & 1u);
                int32_t top = lattice->dims[a] - 1;
                c[a] = (size_t)(cell[a] + o < top ? cell[a] + o : top);
                w[a] = o ? f[a] : 1.0f - f[a];
            }
            probes[k] = lattice->index[c[0] + (size_t)lattice->dims[0] *
                                                  (c[1] + (size_t)lattice->dims[1] * c[2])];
            spatial = w[0] * w[1];
            spatial = spatial * w[2];
            weights[k] = pp__term(field, probes[k], spatial, p, n);
            total = total + weights[k];
        }
    } else {
        float soft = svo->leaf_size * svo->leaf_size;
        for (k = 0; k < terms; k++) {
            const unsigned char *q = field->positions + 12u * k;
            float vx = pp__f32(q) - p[0], vy = pp__f32(q + 4) - p[1], vz = pp__f32(q + 8) - p[2];
            float d = vx * vx, yy = vy * vy, zz = vz * vz;
            d = d + yy;
            d = d + zz;
            d = d + soft;
            probes[k] = (uint32_t)k;
            weights[k] = pp__term(field, (uint32_t)k, 1.0f / d, p, n);
            total = total + weights[k];
        }
    }
    if (!(total > 0.0f))
        return PP_OK;
    for (k = 0; k < terms; k++)
        weights[k] = weights[k] / total;
    *count = terms;
    return PP_OK;
}

/* ---- The lattice (trace::Lattice::from_positions) ---------------------- */

static int pp__cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

pp_error pp_lattice_from_positions(const pp_lightfield *field, pp_lattice *lattice)
{
    uint32_t count, i, len[3] = {0, 0, 0};
    float scale = 0.0f, tol, *axes;
    pp_lattice l;
    size_t a;

    if (lattice == NULL)
        return PP_ERR_ARGUMENT;
    memset(lattice, 0, sizeof *lattice);
    if (field == NULL || (field->positions == NULL && field->probe_count != 0))
        return PP_ERR_ARGUMENT;
    count = field->probe_count;
    if (count == 0)
        return PP_ERR_NOT_A_GRID;
    for (i = 0; i < count; i++)
        for (a = 0; a < 3; a++) {
            float v = pp__f32(field->positions + 12u * (size_t)i + 4u * a);
            if (!pp__finite(v))
                return PP_ERR_NOT_A_GRID;
            scale = pp__max(scale, fabsf(v));
        }
    scale = pp__max(scale, 1e-6f);
    tol = 1e-4f * scale;
    axes = (float *)PROBEPLACE_MALLOC(3u * (size_t)count * sizeof(float));
    if (axes == NULL)
        return PP_ERR_NO_MEMORY;
    /* Each axis's distinct values (within tol), first seen first, as
     * Rust's. The axes only grow: once they span more lattice points than
     * there are probes, the count check below must fail. */
    for (i = 0; i < count; i++) {
        for (a = 0; a < 3; a++) {
            float v = pp__f32(field->positions + 12u * (size_t)i + 4u * a);
            float *axis = axes + a * (size_t)count;
            uint32_t j;
            for (j = 0; j < len[a]; j++) {
                float d = axis[j] - v;
                if (fabsf(d) <= tol)
                    break;
            }
            if (j == len[a])
                axis[len[a]++] = v;
        }
        if ((uint64_t)len[0] * len[1] * len[2] > count) {
            PROBEPLACE_FREE(axes);
            return PP_ERR_NOT_A_GRID;
        }
    }
    memset(&l, 0, sizeof l);
    for (a = 0; a < 3; a++) {
        float *axis = axes + a * (size_t)count;
        uint32_t j;
        /* Distinct by more than tol: no -0 beside +0, so any sort orders
         * them as Rust's total_cmp does. */
        qsort(axis, len[a], sizeof(float), pp__cmp_float);
        l.origin[a] = axis[0];
        l.dims[a] = (int32_t)len[a];
        l.spacing[a] = 1.0f;
        if (len[a] > 1) {
            float span = axis[len[a] - 1] - axis[0];
            l.spacing[a] = span / (float)(len[a] - 1);
            for (j = 1; j < len[a]; j++) {
                float step = axis[j] - axis[j - 1];
                step = step - l.spacing[a];
                if (fabsf(step) > tol) {
                    PROBEPLACE_FREE(axes);
                    return PP_ERR_NOT_A_GRID;
                }
            }
        }
    }
    PROBEPLACE_FREE(axes);
    if ((uint64_t)len[0] * len[1] * len[2] != count)
        return PP_ERR_NOT_A_GRID;
    l.index = (uint32_t *)PROBEPLACE_MALLOC((size_t)count * sizeof(uint32_t));
    if (l.index == NULL)
        return PP_ERR_NO_MEMORY;
    for (i = 0; i < count; i++)
        l.index[i] = UINT32_MAX;
    for (i = 0; i < count; i++) {
        size_t flat = 0, stride = 1;
        for (a = 0; a < 3; a++) {
            float v = pp__f32(field->positions + 12u * (size_t)i + 4u * a);
            float c = v - l.origin[a];
            c = c / l.spacing[a];
            c = roundf(c);
            /* Rust rounds (halves away from zero, as roundf), casts and
             * compares with the dims; NaN fails here. */
            if (!(c >= 0.0f && c < (float)l.dims[a])) {
                PROBEPLACE_FREE(l.index);
                return PP_ERR_NOT_A_GRID;
            }
            flat += (size_t)c * stride;
            stride *= (size_t)l.dims[a];
        }
        if (l.index[flat] != UINT32_MAX) {
            PROBEPLACE_FREE(l.index);
            return PP_ERR_NOT_A_GRID;
        }
        l.index[flat] = i;
    }
    *lattice = l;
    return PP_OK;
}

void pp_lattice_free(pp_lattice *lattice)
{
    if (lattice == NULL)
        return;
    PROBEPLACE_FREE(lattice->index);
    memset(lattice, 0, sizeof *lattice);
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
    case PP_ERR_VERSION: return "unsupported version: this reader reads svo.bin version 2, lightfield.bin version 1";
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
    case PP_ERR_NOT_LIGHTFIELD: return "not a probeplace light-field file (bad magic)";
    case PP_ERR_MAP_SIDE: return "map sides must be powers of two up to 16384";
    case PP_ERR_LEVELS: return "pyramid levels other than log2 of the map side + 1";
    case PP_ERR_LENGTH: return "a length other than its header implies";
    case PP_ERR_NOT_A_GRID: return "the probes are not a regular grid";
    case PP_ERR_MISMATCH: return "the files come from different runs: their probe counts differ";
    case PP_ERR_CAPACITY: return "the output arrays are shorter than the blend's terms";
    case PP_ERR_NOT_REGULAR_FILE: return "not a regular file (a FIFO, a directory, a device or a socket): not read";
    case PP_ERR_FILE_TOO_BIG: return "larger than PP_MAX_FILE_BYTES: not read";
    }
    return "unknown error";
}

#endif /* PROBEPLACE_IMPLEMENTED */
#endif /* PROBEPLACE_IMPLEMENTATION */
