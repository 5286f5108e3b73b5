/* Streaming smoother cases: per-frame cost of push (forward sweep, end rows, weighted output
 * row, quaternion alignment and renormalization) for a 31-joint (CMU) and a 65-joint skeleton
 * at lag 10 and 30, plus the layered stream (two smoothers and the composition). One
 * iteration streams 1000 frames of a seeded random walk through a stream created in setup;
 * ns_per_elem is the cost per frame. */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <stdlib.h>
#include <string.h>

#define STREAM_FRAMES 1000

typedef struct stream_state {
    mlr_stream *st;
    size_t m;
    double *y, *out;
} stream_state;

static void *setup(size_t joints, size_t lag, int layered)
{
    stream_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    mlr_status rc = layered ? mlr_stream_create_layered(joints, 1, 0, 2.0, 0.5, 20.0, 1.0, lag,
                                                        NULL, &s->st, NULL)
                            : mlr_stream_create(joints, 1, 0, 2.0, 0.5, lag, NULL, &s->st, NULL);
    if (rc != MLR_OK) {
        free(s);
        return NULL;
    }
    s->m = mlr_stream_frame_size(s->st);
    s->y = malloc(STREAM_FRAMES * s->m * sizeof(double));
    s->out = malloc(s->m * sizeof(double));
    if (!s->y || !s->out) {
        mlr_stream_destroy(s->st);
        free(s->y), free(s->out), free(s);
        return NULL;
    }
    unsigned long long seed = 7;
    double *acc = calloc(s->m, sizeof(double));
    for (size_t f = 0; f < STREAM_FRAMES; f++) {
        double *row = s->y + f * s->m;
        for (size_t c = 0; c < s->m; c++)
            row[c] = acc[c] += 0.01 * mlr_bench_normal(&seed);
        for (size_t j = 0; j < joints; j++)
            row[3 + 4 * j] += 1.0; /* near-identity quaternions, unnormalized on purpose */
    }
    free(acc);
    if (layered) {
        double *alpha = malloc(joints * sizeof(double));
        for (size_t j = 0; j < joints; j++)
            alpha[j] = j % 3 ? 1.0 : 1.5;
        mlr_stream_set_alpha(s->st, 1.2, alpha, joints, NULL);
        free(alpha);
    }
    return s;
}

static void teardown(void *p)
{
    stream_state *s = p;
    mlr_stream_destroy(s->st);
    free(s->y), free(s->out), free(s);
}

static double run(void *p)
{
    stream_state *s = p;
    double sum = 0.0;
    size_t ready = 0;
    mlr_stream_reset(s->st);
    for (size_t f = 0; f < STREAM_FRAMES; f++) {
        mlr_stream_push(s->st, s->y + f * s->m, s->m, s->out, s->m, &ready, NULL);
        sum += ready ? s->out[3] : 0.0;
    }
    return sum;
}

static void *j31_l10(size_t n)
{
    (void)n;
    return setup(31, 10, 0);
}
static void *j31_l30(size_t n)
{
    (void)n;
    return setup(31, 30, 0);
}
static void *j65_l10(size_t n)
{
    (void)n;
    return setup(65, 10, 0);
}
static void *j65_l30(size_t n)
{
    (void)n;
    return setup(65, 30, 0);
}
static void *j31_l0(size_t n)
{
    (void)n;
    return setup(31, 0, 0);
}
static void *j31_l10_layered(size_t n)
{
    (void)n;
    return setup(31, 10, 1);
}

const mlr_bench_case mlr_bench_stream_cases[] = {
    {"stream.push/J=31,lag=0", STREAM_FRAMES, j31_l0, run, teardown},
    {"stream.push/J=31,lag=10", STREAM_FRAMES, j31_l10, run, teardown},
    {"stream.push/J=31,lag=30", STREAM_FRAMES, j31_l30, run, teardown},
    {"stream.push/J=65,lag=10", STREAM_FRAMES, j65_l10, run, teardown},
    {"stream.push/J=65,lag=30", STREAM_FRAMES, j65_l30, run, teardown},
    {"stream.push_layered/J=31,lag=10", STREAM_FRAMES, j31_l10_layered, run, teardown},
};
const size_t mlr_bench_stream_count =
    sizeof mlr_bench_stream_cases / sizeof mlr_bench_stream_cases[0];
