/* Resampling cases: a 10-minute 120 fps clip (72,000 frames, 31 joints), tiled from the real
 * CMU clip 01_01 (T-pose frame skipped), resampled to 30 fps through the LGS and by the SLERP
 * baseline. The clip is read from the shared data folder (mlr_bench_mocap_dir); a synthetic
 * smooth motion of the same shape stands in when it cannot be read. */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { N_IN = 72000, J = 31 };

typedef struct rs_state {
    size_t n_in, n_out;
    double *root, *rot, *root_out, *rot_out;
} rs_state;

static void teardown(void *p)
{
    rs_state *s = p;
    if (!s)
        return;
    free(s->root), free(s->rot), free(s->root_out), free(s->rot_out), free(s);
}

static int fill_from_clip(rs_state *s)
{
    const char *dir = mlr_bench_mocap_dir();
    char path[4096];
    snprintf(path, sizeof path, "%s/cmu_01_01_playground_jumps.bvh", dir);
    mlr_motion *m = NULL;
    if (mlr_bvh_read_file(path, NULL, &m, NULL) != MLR_OK)
        return 0;
    const size_t n = mlr_motion_n_frames(m);
    if (mlr_motion_n_joints(m) != J || n < 2) {
        mlr_motion_destroy(m);
        return 0;
    }
    const double *root = mlr_motion_root_pos(m), *rot = mlr_motion_rot(m);
    /* tile frames 1..n-1, shifting the root so that every tile continues the previous one */
    double shift[3] = {0, 0, 0};
    size_t src = 1;
    for (size_t i = 0; i < s->n_in; i++) {
        if (src == n) {
            for (int c = 0; c < 3; c++)
                shift[c] += root[3 * (n - 1) + c] - root[3 + c];
            src = 1;
        }
        for (int c = 0; c < 3; c++)
            s->root[3 * i + c] = root[3 * src + c] + shift[c];
        memcpy(s->rot + 4 * J * i, rot + 4 * J * src, 4 * J * sizeof(double));
        src++;
    }
    mlr_motion_destroy(m);
    return 1;
}

static void *setup(size_t unused)
{
    (void)unused;
    rs_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->n_in = N_IN;
    if (mlr_resample_n_out(N_IN, 120.0, 30.0, 0, &s->n_out, NULL) != MLR_OK) {
        free(s);
        return NULL;
    }
    s->root = malloc(3 * N_IN * sizeof(double));
    s->rot = malloc(4 * J * (size_t)N_IN * sizeof(double));
    s->root_out = malloc(3 * s->n_out * sizeof(double));
    s->rot_out = malloc(4 * J * s->n_out * sizeof(double));
    if (!s->root || !s->rot || !s->root_out || !s->rot_out) {
        teardown(s);
        return NULL;
    }
    if (!fill_from_clip(s)) {
        unsigned long long seed = 7;
        for (size_t i = 0; i < 3 * (size_t)N_IN; i++)
            s->root[i] = sin(0.01 * (double)i);
        for (size_t j = 0; j < J; j++) {
            double a = mlr_bench_uniform(&seed);
            for (size_t i = 0; i < N_IN; i++) {
                double *q = s->rot + 4 * (J * i + j), ang = a + sin(0.02 * (double)i + a);
                q[0] = cos(ang / 2), q[1] = sin(ang / 2), q[2] = 0.0, q[3] = 0.0;
            }
        }
    }
    return s;
}

static double run_lgs(void *p)
{
    rs_state *s = p;
    if (mlr_resample_arrays(s->n_in, J, 0, s->root, s->rot, NULL, NULL, s->n_out,
                            MLR_RESAMPLE_AUTO, 1.0, 0, s->root_out, s->rot_out, NULL, NULL, NULL,
                            NULL) < 0)
        return -1.0;
    return s->rot_out[4 * J * (s->n_out / 2)] + s->root_out[3 * (s->n_out / 2)];
}

static double run_slerp(void *p)
{
    rs_state *s = p;
    if (mlr_slerp_resample_arrays(s->n_in, J, 0, s->root, s->rot, NULL, NULL, s->n_out, 0,
                                  s->root_out, s->rot_out, NULL, NULL) < 0)
        return -1.0;
    return s->rot_out[4 * J * (s->n_out / 2)] + s->root_out[3 * (s->n_out / 2)];
}

const mlr_bench_case mlr_bench_resample_cases[] = {
    {"resample.lgs/120to30fps,n=72000,J=31", (size_t)N_IN * J, setup, run_lgs, teardown},
    {"resample.slerp/120to30fps,n=72000,J=31", (size_t)N_IN * J, setup, run_slerp, teardown},
};
const size_t mlr_bench_resample_count =
    sizeof mlr_bench_resample_cases / sizeof mlr_bench_resample_cases[0];
