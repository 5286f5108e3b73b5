/* A model file of generation at run time written by hand from docs/model-format.md, for
 * test_generate.c and the loader's fuzz target (its seed). Static functions only. */
#ifndef MLR_TEST_GEN_MODEL_FILE_H
#define MLR_TEST_GEN_MODEL_FILE_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct buf {
    unsigned char *b;
    size_t n, cap;
} buf;

static void put(buf *o, const void *p, size_t n)
{
    if (o->n + n > o->cap) {
        o->cap = (o->n + n) * 2;
        o->b = realloc(o->b, o->cap);
    }
    memcpy(o->b + o->n, p, n);
    o->n += n;
}

static void put_u32(buf *o, uint32_t v)
{
    unsigned char b[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16),
                          (unsigned char)(v >> 24)};
    put(o, b, 4);
}

static void put_u64(buf *o, uint64_t v)
{
    put_u32(o, (uint32_t)v);
    put_u32(o, (uint32_t)(v >> 32));
}

static void field(buf *o, const char *name, uint32_t type, uint32_t ndim, uint64_t d0, uint64_t d1,
                  const void *data)
{
    char nm[24] = {0};
    strncpy(nm, name, 23);
    put(o, nm, 24);
    put_u32(o, type);
    put_u32(o, ndim);
    put_u64(o, d0);
    put_u64(o, d1);
    size_t n = (size_t)((d0 > 64 ? 6 : d0) * d1); /* a count too large: 6 rows follow */
    for (size_t i = 0; i < n; i++) {
        if (type == 3) {
            put(o, (const unsigned char *)data + i, 1);
        } else {
            uint64_t u;
            memcpy(&u, (const char *)data + 8 * i, 8);
            put_u64(o, u);
        }
    }
    static const unsigned char zero[8] = {0};
    size_t nb = type == 3 ? n : 8 * n;
    put(o, zero, (8 - nb % 8) % 8);
}

static uint32_t crc32_ref(const unsigned char *b, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        c ^= b[i];
        for (int k = 0; k < 8; k++)
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1)));
    }
    return ~c;
}

static uint64_t fnv_ref(uint64_t h, const unsigned char *b, size_t n)
{
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

/* A model of 2 joints (root, child), 6 training frames, 3 primitives, a 2x2 GRBF lattice.
 * version, mark and the field count as given (1, 0x01020304, 0 for the real count). */
static buf model_file(uint32_t version, uint32_t mark, uint32_t n_fields, uint64_t points_rows)
{
    buf p = {0};
    const char names[] = "Hips\0Spine";
    int64_t parents[2] = {-1, 0}, body = 0, labels[6] = {0, 0, 1, 1, 2, 2};
    double ft = 1.0 / 30, points[12] = {0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3};
    double centers[6] = {0, 0.5, 1, 1.5, 2, 2.5}, bounds[4] = {0, 2, 0, 3};
    double jumps[9] = {0, 0.7, 0.3, 0.5, 0, 0.5, 0.9, 0.1, 0};
    double run[3] = {4, 3, 5};
    int64_t markov[2] = {1, 1}, kernel = 0;
    double width = 0, gc[8] = {0, 0, 0, 3, 2, 0, 2, 3};
    size_t nout = 4 + 7 * 2;
    double coef[7 * 18];
    for (size_t r = 0; r < 7; r++)
        for (size_t c = 0; c < nout; c++)
            coef[r * nout + c] = r < 4 ? 0.01 * (double)((r * 7 + c * 3) % 11) - 0.05
                                       : (r == 4 ? (c == 4 || c == 8 ? 1.0 : 0.1) : 0.02);
    field(&p, "frame_time", 1, 1, 1, 1, &ft);
    field(&p, "joint_names", 3, 1, sizeof names, 1, names);
    field(&p, "parents", 2, 1, 2, 1, parents);
    field(&p, "body_joint", 2, 1, 1, 1, &body);
    field(&p, "points", 1, 2, points_rows, 2, points);
    field(&p, "labels", 2, 1, 6, 1, labels);
    field(&p, "centers", 1, 2, 3, 2, centers);
    field(&p, "bounds", 1, 2, 2, 2, bounds);
    field(&p, "jumps", 1, 2, 3, 3, jumps);
    field(&p, "run_length", 1, 1, 3, 1, run);
    field(&p, "markov", 2, 1, 2, 1, markov);
    field(&p, "context_keys", 2, 2, 0, 1, NULL);
    field(&p, "context_seen", 1, 1, 0, 1, NULL);
    field(&p, "context_probs", 1, 2, 0, 3, NULL);
    field(&p, "grbf_kernel", 2, 1, 1, 1, &kernel);
    field(&p, "grbf_width", 1, 1, 1, 1, &width);
    field(&p, "grbf_centers", 1, 2, 4, 2, gc);
    field(&p, "grbf_coef", 1, 2, 7, nout, coef);
    buf o = {0};
    put(&o, "MLRGEN\0\0", 8);
    put_u32(&o, version);
    put_u32(&o, mark);
    put_u32(&o, 400);
    put_u32(&o, n_fields ? n_fields : 18);
    put_u64(&o, 64 + p.n);
    /* the skeleton hash: the names field's bytes, then the parents' (as in the file) */
    unsigned char pb[16];
    for (int i = 0; i < 16; i++)
        pb[i] = (unsigned char)((uint64_t)parents[i / 8] >> (8 * (i % 8)));
    put_u64(&o, fnv_ref(fnv_ref(0xcbf29ce484222325ull, (const unsigned char *)names, sizeof names),
                        pb, 16));
    put_u64(&o, crc32_ref(p.b, p.n));
    static const unsigned char zero[16] = {0};
    put(&o, zero, 16);
    put(&o, p.b, p.n);
    free(p.b);
    return o;
}

#endif
