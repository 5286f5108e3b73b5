/*
 * How much lag the streaming smoother needs: for a few real clips and LGS settings, the
 * smallest lag whose streamed output stays within 1e-3 and 1e-6 of the clip's size from the
 * offline mlr_lgs solution (translations relative to the largest range of a translation
 * channel, quaternion components absolute: they are unit vectors), next to the prediction
 * log(tol) / log(rho) from mlr_stream_decay_rate. Prints one tab-separated line per clip and
 * setting. Usage: mlayer-stream-lag [MOCAP_DIR]
 */
#include <mlayer/mlayer.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef MLR_BENCH_MOCAP_DIR
#define MLR_BENCH_MOCAP_DIR "."
#endif

typedef struct clip {
    size_t N, J, P, m;
    double *y, *ya, extent;
} clip;

static int clip_load(const char *path, clip *c)
{
    mlr_motion *mo = NULL;
    if (mlr_bvh_read_file(path, NULL, &mo, NULL) != MLR_OK)
        return 0;
    c->N = mlr_motion_n_frames(mo), c->J = mlr_motion_n_joints(mo), c->P = mlr_motion_n_trans(mo);
    c->m = 3 + 3 * c->P + 4 * c->J;
    const size_t nt = 3 + 3 * c->P;
    c->y = malloc(c->N * c->m * sizeof(double));
    c->ya = malloc(c->N * c->m * sizeof(double));
    mlr_quat *q = malloc(c->N * c->J * sizeof(mlr_quat));
    memcpy(q, mlr_motion_rot(mo), c->N * c->J * sizeof(mlr_quat));
    mlr_quat_make_continuous_predictive(q, c->N, c->J);
    for (size_t f = 0; f < c->N; f++) {
        double *row = c->y + f * c->m, *ra = c->ya + f * c->m;
        memcpy(row, mlr_motion_root_pos(mo) + 3 * f, 3 * sizeof(double));
        if (c->P)
            memcpy(row + 3, mlr_motion_trans(mo) + 3 * c->P * f, 3 * c->P * sizeof(double));
        memcpy(row + nt, mlr_motion_rot(mo) + 4 * c->J * f, 4 * c->J * sizeof(double));
        memcpy(ra, row, nt * sizeof(double));
        memcpy(ra + nt, q + c->J * f, c->J * sizeof(mlr_quat));
    }
    free(q);
    c->extent = 0.0;
    for (size_t k = 0; k < nt; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t f = 0; f < c->N; f++)
            lo = fmin(lo, c->y[f * c->m + k]), hi = fmax(hi, c->y[f * c->m + k]);
        c->extent = fmax(c->extent, hi - lo);
    }
    mlr_motion_destroy(mo);
    return 1;
}

static void normalize(const clip *c, double *x)
{
    for (size_t f = 0; f < c->N; f++) {
        mlr_quat *q = (mlr_quat *)(x + f * c->m + 3 + 3 * c->P);
        mlr_quat_normalize_array(q, c->J, q, NULL);
    }
}

/* Gap of the stream with this lag to the offline solution ref. */
static double gap(const clip *c, double lam, double sigma, size_t lag, const double *ref,
                  double *x)
{
    mlr_stream *st = NULL;
    if (mlr_stream_create(c->J, 1, c->P, lam, sigma, lag, NULL, &st, NULL) != MLR_OK)
        return INFINITY;
    size_t done = 0, ready = 0, w = 0;
    for (size_t f = 0; f < c->N; f++) {
        mlr_stream_push(st, c->y + f * c->m, c->m, x + done * c->m, c->m, &ready, NULL);
        done += ready;
    }
    mlr_stream_flush(st, x + done * c->m, (c->N - done) * c->m, &w, NULL);
    mlr_stream_destroy(st);
    const size_t nt = 3 + 3 * c->P;
    double e = 0.0;
    for (size_t f = 0; f < c->N; f++)
        for (size_t k = 0; k < c->m; k++) {
            double d = fabs(x[f * c->m + k] - ref[f * c->m + k]);
            e = fmax(e, k < nt ? d / c->extent : d);
        }
    return e;
}

/* Smallest lag with gap <= tol, by doubling then bisection (the gap shrinks with the lag up to
 * small oscillations, so this is the first lag of the final descent). */
static size_t lag_for(const clip *c, double lam, double sigma, double tol, const double *ref,
                      double *x)
{
    size_t lo = 0, hi = 1;
    if (gap(c, lam, sigma, 0, ref, x) <= tol)
        return 0;
    while (gap(c, lam, sigma, hi, ref, x) > tol) {
        lo = hi;
        hi *= 2;
        if (hi > c->N)
            return c->N;
    }
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (gap(c, lam, sigma, mid, ref, x) <= tol)
            hi = mid;
        else
            lo = mid;
    }
    return hi;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : MLR_BENCH_MOCAP_DIR;
    const char *files[] = {"cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh",
                           "ai4a_dog_D1_008_KAN01_002.bvh"};
    const double settings[][2] = {{1, 0.1}, {1, 1}, {4, 1}, {10, 1}, {10, 10}};
    printf("clip\tlam\tsigma\trho\tpred_1e-3\tlag_1e-3\tpred_1e-6\tlag_1e-6\n");
    for (size_t fi = 0; fi < sizeof files / sizeof files[0]; fi++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, files[fi]);
        clip c;
        if (!clip_load(path, &c)) {
            fprintf(stderr, "cannot read %s\n", path);
            return 1;
        }
        double *ref = malloc(c.N * c.m * sizeof(double)), *x = malloc(c.N * c.m * sizeof(double));
        for (size_t s = 0; s < sizeof settings / sizeof settings[0]; s++) {
            const double lam = settings[s][0], sigma = settings[s][1];
            mlr_lgs *g = NULL;
            if (mlr_lgs_create(c.N, 2, lam, sigma, NULL, c.N, MLR_LGS_BANDED, NULL, &g, NULL) < 0)
                return 1;
            mlr_lgs_solve(g, c.ya, c.m, c.m, ref, c.m, NULL);
            mlr_lgs_destroy(g);
            normalize(&c, ref);
            const double rho = mlr_stream_decay_rate(lam, sigma);
            printf("%s\t%g\t%g\t%.4f\t%.1f\t%zu\t%.1f\t%zu\n", files[fi], lam, sigma, rho,
                   log(1e-3) / log(rho), lag_for(&c, lam, sigma, 1e-3, ref, x),
                   log(1e-6) / log(rho), lag_for(&c, lam, sigma, 1e-6, ref, x));
            fflush(stdout);
        }
        free(ref), free(x), free(c.y), free(c.ya);
    }
    return 0;
}
