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
 *   readers blend LIGHTFIELD SVO SELECTION POINTS NORMALS BLEND
 *       loads LIGHTFIELD (both ways) and SVO, prints whether the probes
 *       form a grid (`probes: grid` or `probes: not-grid`), and checks
 *       pp_blend_weights with SELECTION (`grid` or `svo`) at every point
 *       and normal against Rust's answers, bit for bit, and its errors.
 *   readers open svo|lightfield PATH...
 *       loads each PATH from its file alone (it may be a FIFO or a
 *       device) and prints `PATH<TAB>CODE`.
 *   readers check-lightfield LIST POINTS NORMALS
 *       for each line `PATH` or `PATH<TAB>SVO<TAB>BLEND` of LIST, loads
 *       the lightfield.bin PATH (both ways), prints `PATH<TAB>CODE`, and
 *       where it loads and BLEND is given checks the SVO selection's blend.
 *
 * POINTS, NORMALS: little-endian f32 x, y, z per point. ANSWERS: per point
 * nine little-endian u32: the count, then 8 slots (unused ones 0xFFFFFFFF).
 * BLEND: per point 1 + 2K little-endian u32 (K = pp_blend_terms): the
 * count of terms (K, or 0 where the weights sum to no positive number),
 * then K pairs (probe, bits of the weight).
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
    case PP_ERR_NOT_LIGHTFIELD: return "PP_ERR_NOT_LIGHTFIELD";
    case PP_ERR_MAP_SIDE: return "PP_ERR_MAP_SIDE";
    case PP_ERR_LEVELS: return "PP_ERR_LEVELS";
    case PP_ERR_LENGTH: return "PP_ERR_LENGTH";
    case PP_ERR_NOT_A_GRID: return "PP_ERR_NOT_A_GRID";
    case PP_ERR_MISMATCH: return "PP_ERR_MISMATCH";
    case PP_ERR_CAPACITY: return "PP_ERR_CAPACITY";
    case PP_ERR_NOT_REGULAR_FILE: return "PP_ERR_NOT_REGULAR_FILE";
    case PP_ERR_FILE_TOO_BIG: return "PP_ERR_FILE_TOO_BIG";
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

/* Both loads of the lightfield.bin `path` must agree; returns the code,
 * `*field` from memory (its buffer in `*bytes`, to free after). */
static pp_error load_field_both(const char *path, pp_lightfield *field, unsigned char **bytes)
{
    size_t size;
    pp_lightfield from_file;
    pp_error e, f;
    *bytes = slurp(path, &size);
    e = pp_lightfield_load(*bytes, size, field);
    f = pp_lightfield_load_file(path, &from_file);
    if (e != f) {
        printf("%s: pp_lightfield_load says %s but pp_lightfield_load_file %s\n", path,
               code_name(e), code_name(f));
        exit(1);
    }
    if (e == PP_OK &&
        (from_file.probe_count != field->probe_count ||
         from_file.irradiance_resolution != field->irradiance_resolution ||
         memcmp(from_file.positions, field->positions, 12u * (size_t)field->probe_count) != 0 ||
         memcmp(from_file.moments, field->moments,
                4u * (size_t)field->probe_count * field->irradiance_resolution *
                    field->irradiance_resolution) != 0)) {
        printf("%s: the two loads differ\n", path);
        exit(1);
    }
    pp_lightfield_free(&from_file);
    return e;
}

/* Checks pp_blend_weights at every point against `answers`; returns the
 * number of points that differ and counts those with terms. */
static size_t compare_blend(const char *name, const pp_lightfield *field, const pp_svo *svo,
                            const pp_lattice *lattice, struct points pts,
                            struct points normals, const char *answers, size_t *non_empty)
{
    size_t terms = pp_blend_terms(field, lattice), words = 1 + 2 * terms, size, i, bad = 0;
    unsigned char *a = slurp(answers, &size);
    /* Exactly `terms` entries, so that the sanitizer sees any overrun. */
    uint32_t *probes = (uint32_t *)malloc(terms * sizeof(uint32_t) + 1);
    float *weights = (float *)malloc(terms * sizeof(float) + 1);
    if (probes == NULL || weights == NULL)
        exit(2);
    if (pts.count != normals.count || size != 4 * words * pts.count) {
        printf("%s: %lu answer bytes for %lu points and %lu normals of %lu terms\n", answers,
               (unsigned long)size, (unsigned long)pts.count, (unsigned long)normals.count,
               (unsigned long)terms);
        exit(1);
    }
    *non_empty = 0;
    for (i = 0; i < pts.count; i++) {
        const unsigned char *want = a + 4 * words * i;
        size_t count = 99, k;
        int same;
        pp_error e = pp_blend_weights(field, svo, lattice, pts.xyz + 3 * i, normals.xyz + 3 * i,
                                      probes, weights, terms, &count);
        if (e != PP_OK) {
            printf("%s: point %lu: %s\n", name, (unsigned long)i, code_name(e));
            exit(1);
        }
        *non_empty += count > 0;
        same = le32(want) == count;
        for (k = 0; same && k < count; k++) {
            uint32_t bits;
            memcpy(&bits, &weights[k], sizeof bits);
            same = le32(want + 4 + 8 * k) == probes[k] && le32(want + 8 + 8 * k) == bits;
        }
        if (!same) {
            if (bad < 5) {
                const float *p = pts.xyz + 3 * i;
                printf("%s: point %lu (%.9g, %.9g, %.9g): C %lu terms, Rust %u", name,
                       (unsigned long)i, p[0], p[1], p[2], (unsigned long)count,
                       (unsigned)le32(want));
                for (k = 0; k < count && k < terms; k++)
                    if (le32(want + 4 + 8 * k) != probes[k] ||
                        lef32(want + 8 + 8 * k) != weights[k]) {
                        printf("; term %lu: C %u %.9g, Rust %u %.9g", (unsigned long)k,
                               (unsigned)probes[k], weights[k], (unsigned)le32(want + 4 + 8 * k),
                               lef32(want + 8 + 8 * k));
                        break;
                    }
                printf("\n");
            }
            bad++;
        }
    }
    /* The errors: one slot short, no selection or two, a tree of another run. */
    if (terms > 0) {
        size_t count = 7;
        pp_svo other;
        if (pp_blend_weights(field, svo, lattice, pts.xyz, normals.xyz, probes, weights,
                             terms - 1, &count) != PP_ERR_CAPACITY || count != 0) {
            printf("%s: a short output is not PP_ERR_CAPACITY\n", name);
            exit(1);
        }
        if (pp_blend_weights(field, NULL, NULL, pts.xyz, normals.xyz, probes, weights, terms,
                             &count) != PP_ERR_ARGUMENT) {
            printf("%s: no selection is not PP_ERR_ARGUMENT\n", name);
            exit(1);
        }
        if (svo != NULL) {
            other = *svo;
            other.probe_count++;
            if (pp_blend_weights(field, &other, NULL, pts.xyz, normals.xyz, probes, weights,
                                 terms, &count) != PP_ERR_MISMATCH) {
                printf("%s: another run's tree is not PP_ERR_MISMATCH\n", name);
                exit(1);
            }
        }
    }
    free(probes);
    free(weights);
    free(a);
    return bad;
}

static int run_blend(char **argv)
{
    const char *field_path = argv[0], *svo_path = argv[1], *selection = argv[2];
    struct points pts = read_points(argv[3]), normals = read_points(argv[4]);
    unsigned char *bytes;
    pp_lightfield field;
    pp_svo svo;
    pp_lattice lattice;
    size_t bad, non_empty;
    pp_error e = load_field_both(field_path, &field, &bytes), g;
    if (e != PP_OK) {
        printf("%s: %s (%s)\n", field_path, pp_error_string(e), code_name(e));
        return 1;
    }
    e = pp_svo_load_file(svo_path, &svo);
    if (e != PP_OK) {
        printf("%s: %s (%s)\n", svo_path, pp_error_string(e), code_name(e));
        return 1;
    }
    g = pp_lattice_from_positions(&field, &lattice);
    if (g != PP_OK && g != PP_ERR_NOT_A_GRID) {
        printf("%s: pp_lattice_from_positions: %s\n", field_path, code_name(g));
        return 1;
    }
    printf("%s: probes: %s\n", field_path, g == PP_OK ? "grid" : "not-grid");
    if (strcmp(selection, "grid") == 0 && g != PP_OK) {
        printf("%s: the grid selection without a grid\n", field_path);
        return 1;
    }
    bad = compare_blend(field_path, &field, strcmp(selection, "grid") == 0 ? NULL : &svo,
                        strcmp(selection, "grid") == 0 ? &lattice : NULL, pts, normals,
                        argv[5], &non_empty);
    printf("%s (%s): %lu points, %lu non-empty, %lu differ from Rust\n", field_path, selection,
           (unsigned long)pts.count, (unsigned long)non_empty, (unsigned long)bad);
    pp_lattice_free(&lattice);
    pp_svo_free(&svo);
    free(bytes);
    free(pts.xyz);
    free(normals.xyz);
    return bad == 0 ? 0 : 1;
}

static int run_check_lightfield(const char *list, const char *points, const char *normal_path)
{
    struct points pts = read_points(points), normals = read_points(normal_path);
    size_t size, at = 0, failed = 0;
    unsigned char *text = slurp(list, &size);
    while (at < size) {
        char *line = (char *)text + at, *tab, *svo_path = NULL, *answers = NULL;
        size_t end = at;
        pp_lightfield field;
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
            svo_path = tab + 1;
            tab = strchr(svo_path, '\t');
            if (tab == NULL) {
                fprintf(stderr, "%s: a line with a tree but no answers\n", list);
                return 2;
            }
            *tab = '\0';
            answers = tab + 1;
        }
        e = load_field_both(line, &field, &bytes);
        printf("%s\t%s\n", line, code_name(e));
        if (e == PP_OK && answers != NULL) {
            pp_svo svo;
            size_t non_empty;
            if (pp_svo_load_file(svo_path, &svo) != PP_OK) {
                printf("%s: cannot load\n", svo_path);
                return 1;
            }
            failed += compare_blend(line, &field, &svo, NULL, pts, normals, answers,
                                    &non_empty) != 0;
            pp_svo_free(&svo);
        }
        free(bytes);
    }
    free(text);
    free(pts.xyz);
    free(normals.xyz);
    return failed == 0 ? 0 : 1;
}

/* `readers open svo|lightfield PATH...`: each PATH loaded from its file
 * alone (never slurped: it may be a FIFO or /dev/zero), printing
 * `PATH<TAB>CODE`. */
static int run_open(const char *kind, int count, char **paths)
{
    int i;
    for (i = 0; i < count; i++) {
        pp_error e;
        if (strcmp(kind, "svo") == 0) {
            pp_svo svo;
            e = pp_svo_load_file(paths[i], &svo);
            pp_svo_free(&svo);
        } else {
            pp_lightfield field;
            e = pp_lightfield_load_file(paths[i], &field);
            pp_lightfield_free(&field);
        }
        printf("%s\t%s\n", paths[i], code_name(e));
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 3 && strcmp(argv[1], "open") == 0 &&
        (strcmp(argv[2], "svo") == 0 || strcmp(argv[2], "lightfield") == 0))
        return run_open(argv[2], argc - 3, argv + 3);
    if (argc == 5 && strcmp(argv[1], "answers") == 0)
        return run_answers(argv[2], argv[3], argv[4]);
    if (argc == 4 && strcmp(argv[1], "check") == 0)
        return run_check(argv[2], argv[3]);
    if (argc == 8 && strcmp(argv[1], "blend") == 0)
        return run_blend(argv + 2);
    if (argc == 5 && strcmp(argv[1], "check-lightfield") == 0)
        return run_check_lightfield(argv[2], argv[3], argv[4]);
    fprintf(stderr, "usage: readers answers SVO POINTS ANSWERS | readers check LIST POINTS"
                    " | readers blend LIGHTFIELD SVO grid|svo POINTS NORMALS BLEND"
                    " | readers check-lightfield LIST POINTS NORMALS\n");
    return 2;
}
