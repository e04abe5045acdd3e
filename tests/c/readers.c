/* The C reader (include/probeplace.h) against Rust's answers; built and run
 * by tests/it/readers.rs with -fsanitize=address,undefined, so a read out
 * of bounds anywhere below fails the run.
 *
 *   readers answers SVO POINTS ANSWERS
 *       loads SVO (from the file, and from an exact-size copy in memory)
 *       and checks pp_svo_probes_at on every point against Rust's answers.
 *   readers check LIST POINTS
 *       for each line `PATH` or `PATH<TAB>ANSWERS` of LIST, loads PATH
 *       (both ways), prints `PATH<TAB>CODE`, and where it loads queries
 *       every point (against ANSWERS when given).
 *
 * POINTS: little-endian f32 x, y, z per point. ANSWERS: per point nine
 * little-endian u32: the count, then 8 slots (unused ones 0xFFFFFFFF).
 */
#define PROBEPLACE_IMPLEMENTATION
#include "probeplace.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *code_name(pp_error e)
{
    switch (e) {
    case PP_OK: return "PP_OK";
    case PP_ERR_ARGUMENT: return "PP_ERR_ARGUMENT";
    case PP_ERR_IO: return "PP_ERR_IO";
    case PP_ERR_NO_MEMORY: return "PP_ERR_NO_MEMORY";
    case PP_ERR_NOT_SVO: return "PP_ERR_NOT_SVO";
    case PP_ERR_TRUNCATED: return "PP_ERR_TRUNCATED";
    case PP_ERR_TOO_LONG: return "PP_ERR_TOO_LONG";
    case PP_ERR_VERSION: return "PP_ERR_VERSION";
    case PP_ERR_CHECKSUM: return "PP_ERR_CHECKSUM";
    case PP_ERR_ORIGIN: return "PP_ERR_ORIGIN";
    case PP_ERR_LEAF_SIZE: return "PP_ERR_LEAF_SIZE";
    case PP_ERR_DEPTH: return "PP_ERR_DEPTH";
    case PP_ERR_DIMS: return "PP_ERR_DIMS";
    case PP_ERR_TOO_MANY_LEAVES: return "PP_ERR_TOO_MANY_LEAVES";
    case PP_ERR_MAX_PROBES: return "PP_ERR_MAX_PROBES";
    case PP_ERR_NO_ROOT: return "PP_ERR_NO_ROOT";
    case PP_ERR_PROBE_INDEX: return "PP_ERR_PROBE_INDEX";
    case PP_ERR_LEAF_LIST: return "PP_ERR_LEAF_LIST";
    case PP_ERR_ORPHAN_NODE: return "PP_ERR_ORPHAN_NODE";
    case PP_ERR_EMPTY_INNER: return "PP_ERR_EMPTY_INNER";
    case PP_ERR_BELOW_LEAF_LEVEL: return "PP_ERR_BELOW_LEAF_LEVEL";
    case PP_ERR_CHILD_INDEX: return "PP_ERR_CHILD_INDEX";
    case PP_ERR_SHARED_CHILD: return "PP_ERR_SHARED_CHILD";
    }
    return "?";
}

/* The file at `path`, in a buffer of exactly its size (one byte when it
 * is empty, never read), so that the sanitizer sees any overread. */
static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    unsigned char *buf;
    long len;
    if (f == NULL || fseek(f, 0, SEEK_END) != 0 || (len = ftell(f)) < 0 ||
        fseek(f, 0, SEEK_SET) != 0) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(2);
    }
    buf = (unsigned char *)malloc(len > 0 ? (size_t)len : 1u);
    if (buf == NULL || fread(buf, 1, (size_t)len, f) != (size_t)len) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(2);
    }
    fclose(f);
    *size = (size_t)len;
    return buf;
}

static uint32_t le32(const unsigned char *b)
{
    return (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) |
           ((uint32_t)b[3] << 24);
}

static float lef32(const unsigned char *b)
{
    uint32_t w = le32(b);
    float f;
    memcpy(&f, &w, sizeof f);
    return f;
}

struct points {
    size_t count;
    float *xyz;
};

static struct points read_points(const char *path)
{
    struct points p;
    size_t size, i;
    unsigned char *b = slurp(path, &size);
    if (size % 12 != 0) {
        fprintf(stderr, "%s: not a whole number of points\n", path);
        exit(2);
    }
    p.count = size / 12;
    p.xyz = (float *)malloc(3 * p.count * sizeof(float) + 1);
    if (p.xyz == NULL)
        exit(2);
    for (i = 0; i < 3 * p.count; i++)
        p.xyz[i] = lef32(b + 4 * i);
    free(b);
    return p;
}

/* Both loads of `path` must agree; returns the code, `*svo` from memory
 * (its buffer in `*bytes`, to free after). */
static pp_error load_both(const char *path, pp_svo *svo, unsigned char **bytes)
{
    size_t size;
    pp_svo from_file;
    pp_error e, f;
    *bytes = slurp(path, &size);
    e = pp_svo_load(*bytes, size, svo);
    f = pp_svo_load_file(path, &from_file);
    if (e != f) {
        printf("%s: pp_svo_load says %s but pp_svo_load_file %s\n", path,
               code_name(e), code_name(f));
        exit(1);
    }
    if (e == PP_OK &&
        (from_file.node_count != svo->node_count ||
         from_file.payload_count != svo->payload_count ||
         memcmp(from_file.nodes, svo->nodes, 4u * (size_t)svo->node_count) != 0)) {
        printf("%s: the two loads differ\n", path);
        exit(1);
    }
    pp_svo_free(&from_file);
    return e;
}

/* Checks every point against `answers` (NULL: only queries them); returns
 * the number of mismatches and counts the non-empty answers. */
static size_t compare(const char *name, const pp_svo *svo, struct points pts,
                      const char *answers, size_t *non_empty)
{
    unsigned char *a = NULL;
    size_t size = 0, i, bad = 0;
    if (answers != NULL) {
        a = slurp(answers, &size);
        if (size != pts.count * 36) {
            printf("%s: %lu answer bytes for %lu points\n", answers,
                   (unsigned long)size, (unsigned long)pts.count);
            exit(1);
        }
    }
    *non_empty = 0;
    for (i = 0; i < pts.count; i++) {
        uint32_t out[PP_MAX_PROBES_PER_LEAF];
        unsigned n = pp_svo_probes_at(svo, pts.xyz + 3 * i, out), k;
        int same = 1;
        if (n > svo->max_probes) {
            printf("%s: point %lu lists %u probes, more than %u\n", name,
                   (unsigned long)i, n, (unsigned)svo->max_probes);
            exit(1);
        }
        for (k = 0; k < n; k++)
            if (out[k] >= svo->probe_count) {
                printf("%s: point %lu lists probe %u of %u\n", name,
                       (unsigned long)i, (unsigned)out[k], (unsigned)svo->probe_count);
                exit(1);
            }
        *non_empty += n > 0;
        if (a == NULL)
            continue;
        same = le32(a + 36 * i) == n;
        for (k = 0; same && k < n; k++)
            same = le32(a + 36 * i + 4 + 4 * k) == out[k];
        if (!same) {
            if (bad < 10) {
                const float *p = pts.xyz + 3 * i;
                printf("%s: point %lu (%.9g, %.9g, %.9g): C lists %u probes, Rust %u\n",
                       name, (unsigned long)i, p[0], p[1], p[2], n,
                       (unsigned)le32(a + 36 * i));
            }
            bad++;
        }
    }
    free(a);
    return bad;
}

static int run_answers(const char *svo_path, const char *points, const char *answers)
{
    pp_svo svo;
    unsigned char *bytes;
    struct points pts = read_points(points);
    size_t bad, non_empty;
    pp_error e = load_both(svo_path, &svo, &bytes);
    if (e != PP_OK) {
        printf("%s: %s (%s)\n", svo_path, pp_error_string(e), code_name(e));
        return 1;
    }
    bad = compare(svo_path, &svo, pts, answers, &non_empty);
    printf("%s: %lu points, %lu non-empty, %lu differ from Rust\n", svo_path,
           (unsigned long)pts.count, (unsigned long)non_empty, (unsigned long)bad);
    free(bytes);
    free(pts.xyz);
    return bad == 0 ? 0 : 1;
}

static int run_check(const char *list, const char *points)
{
    struct points pts = read_points(points);
    size_t size, at = 0, failed = 0;
    unsigned char *text = slurp(list, &size);
    while (at < size) {
        char *line = (char *)text + at, *tab, *answers = NULL;
        size_t end = at;
        pp_svo svo;
        unsigned char *bytes;
        pp_error e;
        while (end < size && text[end] != '\n')
            end++;
        if (end == size) {
            fprintf(stderr, "%s: the last line has no newline\n", list);
            return 2;
        }
        text[end] = '\0';
        at = end + 1;
        tab = strchr(line, '\t');
        if (tab != NULL) {
            *tab = '\0';
            answers = tab + 1;
        }
        e = load_both(line, &svo, &bytes);
        printf("%s\t%s\n", line, code_name(e));
        if (e == PP_OK) {
            size_t non_empty;
            failed += compare(line, &svo, pts, answers, &non_empty) != 0;
        }
        free(bytes);
    }
    free(text);
    free(pts.xyz);
    return failed == 0 ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 5 && strcmp(argv[1], "answers") == 0)
        return run_answers(argv[2], argv[3], argv[4]);
    if (argc == 4 && strcmp(argv[1], "check") == 0)
        return run_check(argv[2], argv[3]);
    fprintf(stderr, "usage: readers answers SVO POINTS ANSWERS | readers check LIST POINTS\n");
    return 2;
}
