/* Layer decomposition cases: the full decomposition (outlier search, base heuristic,
 * displacements, GCV control layer, residual) of real capture data, cmu_01_01 (31 joints, 120 fps): the first
 * 2,526 frames after its T-pose frame (the paper's clip length), and a 100,000-frame tiling of
 * the clip (mirrored back and forth so it stays continuous); "capped" cases pass the base s
 * range the Python wrapper passes by default. n is frames x joints. */
#include "bench.h"

#include <math.h>
#include <mlayer/mlayer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct layers_state {
    size_t n, j;
    double *pos, *rot;
    mlr_layers_option opt[2];
    size_t n_opt;
} layers_state;

static void teardown(void *p)
{
    layers_state *s = p;
    free(s->pos), free(s->rot), free(s);
}

/* Frames 1.. of the clip, tiled by reflection up to n frames. */
static void *setup_frames(size_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/cmu_01_01_playground_jumps.bvh", mlr_bench_mocap_dir());
    mlr_motion *m = NULL;
    if (mlr_bvh_read_file(path, NULL, &m, NULL) != MLR_OK)
        return NULL;
    const size_t nc = mlr_motion_n_frames(m) - 1, j = mlr_motion_n_joints(m);
    layers_state *s = calloc(1, sizeof *s);
    if (!s) {
        mlr_motion_destroy(m);
        return NULL;
    }
    s->n = n, s->j = j;
    s->pos = malloc(n * 3 * sizeof(double));
    s->rot = malloc(n * j * 4 * sizeof(double));
    if (!s->pos || !s->rot) {
        mlr_motion_destroy(m);
        teardown(s);
        return NULL;
    }
    const double *pos = mlr_motion_root_pos(m) + 3, *rot = mlr_motion_rot(m) + 4 * j;
    for (size_t i = 0; i < n; i++) {
        size_t period = 2 * (nc - 1), r = i % period, src = r < nc ? r : period - r;
        memcpy(s->pos + 3 * i, pos + 3 * src, 3 * sizeof(double));
        memcpy(s->rot + 4 * j * i, rot + 4 * j * src, 4 * j * sizeof(double));
    }
    mlr_motion_destroy(m);
    return s;
}

static void *setup_clip(size_t n) { return setup_frames(n / 31); }

/* The clip with a 5-frame glitch in the middle (the root 2,400 units off, alternating, every
 * joint turned by 180 degrees about a fixed axis): the robust decomposition's weighted path. */
static void *setup_clip_glitch(size_t n)
{
    layers_state *s = setup_frames(n / 31);
    if (!s)
        return NULL;
    const size_t at = s->n / 2, j = s->j;
    for (size_t f = 0; f < 5; f++) {
        s->pos[3 * (at + f)] += f % 2 ? -2400.0 : 2400.0;
        for (size_t k = 0; k < j; k++) { /* q * (0, 0.6, 0, 0.8) */
            double *q = s->rot + 4 * ((at + f) * j + k), w = q[0], x = q[1], y = q[2], z = q[3];
            q[0] = -0.6 * x - 0.8 * z;
            q[1] = 0.6 * w + 0.8 * y;
            q[2] = -0.8 * x + 0.6 * z;
            q[3] = 0.8 * w - 0.6 * y;
        }
    }
    return s;
}

static void *setup_clip_fixed(size_t n)
{
    layers_state *s = setup_frames(n / 31);
    if (s) {
        s->opt[0] = (mlr_layers_option){MLR_LAYERS_OPT_LAM_C, 1.0};
        s->opt[1] = (mlr_layers_option){MLR_LAYERS_OPT_SIGMA_C, 1.0};
        s->n_opt = 2;
    }
    return s;
}

/* Both smoothings given: no search at all, the floor of one factor + solve per layer plus the
 * quaternion log / exp of the displacements and residuals. */
static void *setup_clip_fixed_both(size_t n)
{
    layers_state *s = setup_clip_fixed(n);
    if (s) {
        s->opt[0] = (mlr_layers_option){MLR_LAYERS_OPT_LAM_B, 1000.0};
        s->opt[1] = (mlr_layers_option){MLR_LAYERS_OPT_LAM_C, 1.0};
    }
    return s;
}

/* What the Python wrapper passes by default: the base s capped at the 0.25 Hz floor of the
 * clip's frame rate (120 fps), (2 sin(pi 0.25 / fps))^-4 (about 8.3e7). */
static void *setup_clip_capped(size_t n)
{
    layers_state *s = setup_frames(n / 31);
    if (s) {
        const double w = 2.0 * sin(3.14159265358979323846 * 0.25 / 120.0);
        s->opt[0] = (mlr_layers_option){MLR_LAYERS_OPT_BASE_S_MAX, 1.0 / (w * w * w * w)};
        s->n_opt = 1;
    }
    return s;
}

static double run_decompose(void *p)
{
    layers_state *s = p;
    mlr_layers *L = NULL;
    if (mlr_layers_decompose(s->n, s->j, s->pos, s->rot, s->opt, s->n_opt, NULL, &L, NULL) < 0)
        return -1.0;
    double v[32];
    mlr_layers_get_param(L, MLR_LAYERS_PARAM_CONTROL_S, v, 32);
    double sum = 0.0;
    for (size_t g = 0; g < 32; g++)
        sum += v[g];
    mlr_layers_destroy(L);
    return sum;
}

const mlr_bench_case mlr_bench_layers_cases[] = {
    {"layers.decompose/n=2526,j=31", 2526 * 31, setup_clip, run_decompose, teardown},
    {"layers.decompose_glitch/n=2526,j=31", 2526 * 31, setup_clip_glitch, run_decompose, teardown},
    {"layers.decompose_fixed_c/n=2526,j=31", 2526 * 31, setup_clip_fixed, run_decompose, teardown},
    {"layers.decompose_fixed_bc/n=2526,j=31", 2526 * 31, setup_clip_fixed_both, run_decompose,
     teardown},
    {"layers.decompose/n=100000,j=31", 100000 * 31, setup_clip, run_decompose, teardown},
    {"layers.decompose_capped/n=2526,j=31", 2526 * 31, setup_clip_capped, run_decompose, teardown},
    {"layers.decompose_capped/n=20000,j=31", 20000 * 31, setup_clip_capped, run_decompose,
     teardown},
    {"layers.decompose_capped/n=100000,j=31", 100000 * 31, setup_clip_capped, run_decompose,
     teardown},
};
const size_t mlr_bench_layers_count =
    sizeof mlr_bench_layers_cases / sizeof mlr_bench_layers_cases[0];
