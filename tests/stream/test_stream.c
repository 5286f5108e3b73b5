/* Streaming fixed-lag smoother: against a dense solve of each prefix built inside the test,
 * against the offline mlr_lgs on the real clips (flushed tail exact, the gap shrinking
 * geometrically with the lag at the rate mlr_stream_decay_rate gives), layers, reset, no
 * allocation after create, bad input. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* a v with its angle saturated below a half turn, as the layers' synthesis scales a
   displacement (mlr_layers.h, "Exaggeration"): past 90 degrees the angle x goes to
   90 + 72 tanh((x - 90) / 72) degrees, never below v's own. */
static mlr_vec3 scale_turn(mlr_vec3 v, double a)
{
    const double pi = 3.14159265358979323846, knee = 0.5 * pi, span = 0.9 * pi - knee;
    mlr_vec3 w = {a * v.x, a * v.y, a * v.z};
    const double x2 = w.x * w.x + w.y * w.y + w.z * w.z;
    if (!(fabs(a) > 1.0) || !(x2 > knee * knee) || !isfinite(x2))
        return w;
    const double x = sqrt(x2), own = x / fabs(a);
    const double s = fmax(own, knee + span * tanh((x - knee) / span)) / x;
    w.x *= s, w.y *= s, w.z *= s;
    return w;
}

/* ---------------------------------------------------------------------------------------- */
/* References                                                                               */

/* Dense (s D^T D + I) x = y for n frames, m channels, by Gauss elimination (D: second
 * differences, no rows when n < 3). */
static void dense_smooth(size_t n, double s, const double *y, size_t m, double *x)
{
    double *M = calloc(n * n, sizeof *M);
    memcpy(x, y, n * m * sizeof *x);
    const double c[3] = {1, -2, 1};
    for (size_t r = 0; r + 2 < n; r++)
        for (size_t a = 0; a < 3; a++)
            for (size_t b = 0; b < 3; b++)
                M[(r + a) * n + r + b] += s * c[a] * c[b];
    for (size_t i = 0; i < n; i++)
        M[i * n + i] += 1.0;
    for (size_t p = 0; p < n; p++)
        for (size_t r = p + 1; r < n; r++) {
            double f = M[r * n + p] / M[p * n + p];
            for (size_t k = p; k < n; k++)
                M[r * n + k] -= f * M[p * n + k];
            for (size_t k = 0; k < m; k++)
                x[r * m + k] -= f * x[p * m + k];
        }
    for (size_t p = n; p-- > 0;) {
        for (size_t k = p + 1; k < n; k++)
            for (size_t c2 = 0; c2 < m; c2++)
                x[p * m + c2] -= M[p * n + k] * x[k * m + c2];
        for (size_t c2 = 0; c2 < m; c2++)
            x[p * m + c2] /= M[p * n + p];
    }
    free(M);
}

static const char *const clip_files[] = {
    "cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",  "cmu_10_01_soccer_kick.bvh",
    "cmu_60_10_salsa_dance.bvh",      "cmu_02_03_run_jog_25fps.bvh",   "lafan1_clip_a.bvh",
    "bandai1_walk_happy_001.bvh",     "ai4a_dog_D1_008_KAN01_002.bvh",
};

/* A clip as stream frames (the shared clip `which`, or a bundled one in its place): [root 3][trans 3P][rot 4J], N x m. */
typedef struct clip {
    size_t N, J, P, m;
    double *y;     /* as read */
    double *ya;    /* quaternions made continuous (the offline input) */
    double extent; /* largest range of a translation channel (root or extra) */
} clip;

static void clip_load(clip *c, size_t which)
{
    /* any real clip whose body moves (the gaps are relative to the translations' extent):
       without the shared ones, the bundled walk and the first four wild clips */
    char path[4096];
    ck_assert_ptr_nonnull(mlr_test_any_clip_path(clip_files[which], which % 5, path, sizeof path));
    mlr_motion *mo = NULL;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &mo, NULL), MLR_OK);
    c->N = mlr_motion_n_frames(mo), c->J = mlr_motion_n_joints(mo), c->P = mlr_motion_n_trans(mo);
    c->m = 3 + 3 * c->P + 4 * c->J;
    c->y = malloc(c->N * c->m * sizeof(double));
    c->ya = malloc(c->N * c->m * sizeof(double));
    const double *rp = mlr_motion_root_pos(mo), *tr = mlr_motion_trans(mo),
                 *rot = mlr_motion_rot(mo);
    for (size_t f = 0; f < c->N; f++) {
        double *row = c->y + f * c->m;
        memcpy(row, rp + 3 * f, 3 * sizeof(double));
        if (c->P)
            memcpy(row + 3, tr + 3 * c->P * f, 3 * c->P * sizeof(double));
        memcpy(row + 3 + 3 * c->P, rot + 4 * c->J * f, 4 * c->J * sizeof(double));
    }
    memcpy(c->ya, c->y, c->N * c->m * sizeof(double));
    mlr_quat *q = malloc(c->N * c->J * sizeof(mlr_quat));
    for (size_t f = 0; f < c->N; f++)
        memcpy(q + f * c->J, c->ya + f * c->m + 3 + 3 * c->P, c->J * sizeof(mlr_quat));
    mlr_quat_make_continuous_predictive(q, c->N, c->J);
    for (size_t f = 0; f < c->N; f++)
        memcpy(c->ya + f * c->m + 3 + 3 * c->P, q + f * c->J, c->J * sizeof(mlr_quat));
    free(q);
    c->extent = 0.0;
    for (size_t k = 0; k < 3 + 3 * c->P; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t f = 0; f < c->N; f++)
            lo = fmin(lo, c->y[f * c->m + k]), hi = fmax(hi, c->y[f * c->m + k]);
        c->extent = fmax(c->extent, hi - lo);
    }
    ck_assert_double_gt(c->extent, 0.0);
    mlr_motion_destroy(mo);
}

static void clip_free(clip *c)
{
    free(c->y);
    free(c->ya);
}

static void normalize_rows(const clip *c, double *x)
{
    for (size_t f = 0; f < c->N; f++) {
        mlr_quat *q = (mlr_quat *)(x + f * c->m + 3 + 3 * c->P);
        ck_assert_int_eq(mlr_quat_normalize_array(q, c->J, q, NULL), MLR_OK);
    }
}

/* Offline: mlr_lgs on the aligned clip, quaternions renormalized. */
static void offline(const clip *c, double lam, double sigma, double *x)
{
    mlr_lgs *g = NULL;
    ck_assert_int_ge(
        mlr_lgs_create(c->N, 2, lam, sigma, NULL, c->N, MLR_LGS_BANDED, NULL, &g, NULL), 0);
    ck_assert_int_eq(mlr_lgs_solve(g, c->ya, c->m, c->m, x, c->m, NULL), MLR_OK);
    mlr_lgs_destroy(g);
    normalize_rows(c, x);
}

/* Push every frame of y (n frames, raw input), then flush; outputs in x, in frame order. */
static void stream_all(mlr_stream *st, const double *y, size_t n, size_t m, double *x)
{
    size_t done = 0, ready = 0;
    for (size_t f = 0; f < n; f++) {
        ck_assert_int_eq(mlr_stream_push(st, y + f * m, m, x + done * m, m, &ready, NULL), MLR_OK);
        done += ready;
    }
    ck_assert_uint_eq(done, n > mlr_stream_lag(st) ? n - mlr_stream_lag(st) : 0);
    size_t w = 0;
    ck_assert_int_eq(mlr_stream_flush(st, x + done * m, (n - done) * m, &w, NULL), MLR_OK);
    ck_assert_uint_eq(done + w, n);
}

/* Largest gap: translations relative to the clip's extent, quaternion components absolute. */
static double rel_gap(const clip *c, const double *a, const double *b, size_t f0, size_t f1)
{
    double e = 0.0;
    const size_t nt = 3 + 3 * c->P;
    for (size_t f = f0; f < f1; f++)
        for (size_t k = 0; k < c->m; k++) {
            double d = fabs(a[f * c->m + k] - b[f * c->m + k]);
            e = fmax(e, k < nt ? d / c->extent : d);
        }
    return e;
}

/* ---------------------------------------------------------------------------------------- */
/* Numerics                                                                                 */

static const size_t lags[] = {0, 1, 2, 3, 4, 7};

/* Every output equals the dense solve of the prefix pushed so far, at frame n-1-lag; the flush
 * equals the dense solve of the whole. Translations only (no quaternion normalization). */
START_TEST(outputs_equal_dense_prefix)
{
    const size_t lag = lags[_i], n = 23, m = 6;
    const double lams[] = {0.0, 0.7, 3.0, 40.0};
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 7 + _i);
    double *y = malloc(n * m * sizeof *y), *ref = malloc(n * m * sizeof *ref);
    double *out = malloc(n * m * sizeof *out);
    for (size_t k = 0; k < n * m; k++)
        y[k] = mlr_test_rng_normal(&rng) + 0.1 * (double)(k / m);
    for (size_t t = 0; t < MLR_COUNTOF(lams); t++) {
        const double sigma = 0.9, s = lams[t] * lams[t] * sigma * sigma;
        mlr_stream *st = NULL;
        ck_assert_int_eq(mlr_stream_create(0, 1, 1, lams[t], sigma, lag, NULL, &st, NULL), MLR_OK);
        ck_assert_uint_eq(mlr_stream_frame_size(st), m);
        for (size_t p = 1; p <= n; p++) {
            size_t ready = 9;
            ck_assert_int_eq(mlr_stream_push(st, y + (p - 1) * m, m, out, m, &ready, NULL),
                             MLR_OK);
            ck_assert_uint_eq(ready, p > lag);
            ck_assert_uint_eq(mlr_stream_pending(st), p > lag ? lag : p);
            if (!ready)
                continue;
            dense_smooth(p, s, y, m, ref);
            for (size_t k = 0; k < m; k++)
                ck_assert_close(out[k], ref[(p - 1 - lag) * m + k], 1e-10 * (1 + fabs(ref[k])));
        }
        size_t w = 0;
        ck_assert_int_eq(mlr_stream_flush(st, out, n * m, &w, NULL), MLR_OK);
        ck_assert_uint_eq(w, lag < n ? lag : n);
        dense_smooth(n, s, y, m, ref);
        for (size_t r = 0; r < w; r++)
            for (size_t k = 0; k < m; k++)
                ck_assert_close(out[r * m + k], ref[(n - w + r) * m + k], 1e-10);
        /* short clips: fewer frames than the lag, flushed whole */
        for (size_t p = 1; p <= 4; p++) {
            mlr_stream_reset(st);
            for (size_t f = 0; f < p; f++) {
                size_t ready;
                ck_assert_int_eq(mlr_stream_push(st, y + f * m, m, out + f * m, m, &ready, NULL),
                                 MLR_OK);
            }
            if (p > lag)
                continue;
            ck_assert_int_eq(mlr_stream_flush(st, out, p * m, &w, NULL), MLR_OK);
            ck_assert_uint_eq(w, p);
            dense_smooth(p, s, y, m, ref);
            for (size_t k = 0; k < p * m; k++)
                ck_assert_close(out[k], ref[k], 1e-10);
        }
        mlr_stream_destroy(st);
    }
    free(y), free(ref), free(out);
}
END_TEST

/* With lag >= N the whole clip comes out of the flush: the offline solution to 1e-9. With a
 * shorter lag the flushed tail is exact too. Every real clip. */
START_TEST(flush_equals_offline_on_clips)
{
    clip c;
    clip_load(&c, (size_t)_i);
    double *ref = malloc(c.N * c.m * sizeof(double)), *x = malloc(c.N * c.m * sizeof(double));
    const double lam = 3.0, sigma = 0.5;
    offline(&c, lam, sigma, ref);
    const size_t lag_list[] = {c.N, c.N + 5, 40};
    for (size_t t = 0; t < MLR_COUNTOF(lag_list); t++) {
        mlr_stream *st = NULL;
        ck_assert_int_eq(mlr_stream_create(c.J, 1, c.P, lam, sigma, lag_list[t], NULL, &st, NULL),
                         MLR_OK);
        stream_all(st, c.y, c.N, c.m, x);
        size_t first = lag_list[t] >= c.N ? 0 : c.N - lag_list[t];
        ck_assert_double_le(rel_gap(&c, x, ref, first, c.N), 1e-9);
        mlr_stream_destroy(st);
    }
    free(ref), free(x);
    clip_free(&c);
}
END_TEST

/* The gap to the offline solution against the lag: below 1e-9 once rho^lag is tiny, and
 * shrinking at the rate mlr_stream_decay_rate predicts (a least-squares slope of log gap
 * against lag within 20 % of log rho). */
START_TEST(gap_decays_geometrically)
{
    clip c;
    clip_load(&c, 1); /* cmu_131_01: 994 frames, 31 joints */
    double *ref = malloc(c.N * c.m * sizeof(double)), *x = malloc(c.N * c.m * sizeof(double));
    const double lam_sig[][2] = {{1.0, 1.0}, {10.0, 1.0}, {10.0, 10.0}};
    for (size_t t = 0; t < MLR_COUNTOF(lam_sig); t++) {
        const double lam = lam_sig[t][0], sigma = lam_sig[t][1];
        const double rho = mlr_stream_decay_rate(lam, sigma);
        ck_assert(rho > 0.0 && rho < 1.0);
        offline(&c, lam, sigma, ref);
        /* lags from gap ~ 1e-2 down to ~ 1e-11 of the clip */
        const size_t l0 = (size_t)(log(1e-2) / log(rho)), l1 = (size_t)(log(1e-11) / log(rho));
        double sx = 0, sy = 0, sxx = 0, sxy = 0, cnt = 0, last = 0;
        const size_t step = (l1 - l0) / 12 + 1;
        for (size_t lag = l0; lag <= l1; lag += step) {
            mlr_stream *st = NULL;
            ck_assert_int_eq(mlr_stream_create(c.J, 1, c.P, lam, sigma, lag, NULL, &st, NULL),
                             MLR_OK);
            stream_all(st, c.y, c.N, c.m, x);
            mlr_stream_destroy(st);
            const double gap = rel_gap(&c, x, ref, 0, c.N);
            ck_assert_double_gt(gap, 0.0);
            sx += (double)lag, sy += log(gap), sxx += (double)lag * lag;
            sxy += (double)lag * log(gap), cnt += 1;
            last = gap;
        }
        const double slope = (cnt * sxy - sx * sy) / (cnt * sxx - sx * sx);
        ck_assert_msg(fabs(slope / log(rho) - 1.0) < 0.2, "lam %g sigma %g: slope %g, log rho %g",
                      lam, sigma, slope, log(rho));
        ck_assert_double_le(last, 1e-9);
    }
    free(ref), free(x);
    clip_free(&c);
}
END_TEST

/* mlr_stream_decay_rate is the modulus of a root of 1 + s (2 - z - 1/z)^2 inside the circle. */
START_TEST(decay_rate_is_a_root)
{
    const double lam[] = {0.1, 1.0, 5.0, 100.0};
    for (size_t t = 0; t < MLR_COUNTOF(lam); t++) {
        const double rho = mlr_stream_decay_rate(lam[t], 0.5), s = lam[t] * lam[t] * 0.25;
        ck_assert(rho > 0.0 && rho < 1.0);
        /* some angle th with |1 + s (2 - z - 1/z)^2| ~ 0 for z = rho e^{i th} */
        double best = INFINITY;
        for (int k = 0; k <= 200000; k++) {
            const double th = 3.14159265358979323846 * k / 200000.0;
            const double zr = rho * cos(th), zi = rho * sin(th), ir = cos(th) / rho,
                         ii = -sin(th) / rho;
            const double wr = 2 - zr - ir, wi = -zi - ii;
            const double pr = 1 + s * (wr * wr - wi * wi), pi = s * 2 * wr * wi;
            best = fmin(best, hypot(pr, pi) / (1 + s));
        }
        ck_assert_double_le(best, 1e-4);
    }
    ck_assert_double_eq(mlr_stream_decay_rate(0.0, 1.0), 0.0);
    ck_assert_double_eq(mlr_stream_decay_rate(-1.0, 1.0), -1.0);
    ck_assert_double_eq(mlr_stream_decay_rate(1.0, 0.0), -1.0);
}
END_TEST

/* Outputs are unit quaternions; a clip streamed twice with a reset between gives the same
 * bytes; a clip streamed a second time into a fresh stream too. */
START_TEST(reset_repeats_bitwise)
{
    clip c;
    clip_load(&c, 6); /* bandai: 22 joints with 21 extra translations */
    double *x1 = malloc(c.N * c.m * sizeof(double)), *x2 = malloc(c.N * c.m * sizeof(double));
    mlr_stream *st = NULL;
    ck_assert_int_eq(mlr_stream_create(c.J, 1, c.P, 2.0, 0.3, 12, NULL, &st, NULL), MLR_OK);
    stream_all(st, c.y, c.N / 2, c.m, x1); /* a half run first: reset must forget it */
    mlr_stream_reset(st);
    stream_all(st, c.y, c.N, c.m, x1);
    mlr_stream_reset(st);
    stream_all(st, c.y, c.N, c.m, x2);
    ck_assert_int_eq(memcmp(x1, x2, c.N * c.m * sizeof(double)), 0);
    for (size_t f = 0; f < c.N; f++)
        for (size_t j = 0; j < c.J; j++) {
            const double *q = x1 + f * c.m + 3 + 3 * c.P + 4 * j;
            ck_assert_close(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-14);
        }
    mlr_stream_destroy(st);
    free(x1), free(x2);
    clip_free(&c);
}
END_TEST

/* Quaternion signs: the stream applies the predictive rule online exactly as the batch
 * mlr_quat_make_continuous_predictive does. Spins that speed up to 190 .. 280 degrees per frame
 * (where the nearest sign would turn them back) with random input signs: lam 0 returns the
 * aligned input itself (the same representative as the batch rule, every sample); lam > 0
 * with lag >= N flushes the offline solve of the batch-aligned clip. */
START_TEST(signs_follow_predictive_rule)
{
    const size_t N = 240, J = 6, m = 3 + 4 * J;
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 1234);
    clip c = {.N = N, .J = J, .P = 0, .m = m};
    c.y = malloc(N * m * sizeof(double));
    c.ya = malloc(N * m * sizeof(double));
    double *x = malloc(N * m * sizeof(double)), *ref = malloc(N * m * sizeof(double));
    mlr_quat *qp = malloc(N * J * sizeof(mlr_quat)), *qn = malloc(N * J * sizeof(mlr_quat));
    const double deg = 3.14159265358979323846 / 180.0;
    for (size_t j = 0; j < J; j++) {
        double ax[3] = {mlr_test_rng_normal(&rng), mlr_test_rng_normal(&rng),
                        mlr_test_rng_normal(&rng)};
        const double na = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
        const double top = (190.0 + 18.0 * (double)j) * deg; /* top speed of track j */
        double th = 0.0, w = 20.0 * deg;
        for (size_t f = 0; f < N; f++) {
            /* speed up by 6 degrees per frame, hold, slow down after frame 160 */
            w = f < 160 ? fmin(w + 6.0 * deg, top) : fmax(w - 6.0 * deg, 10.0 * deg);
            th += w;
            const double sg = mlr_test_rng_uniform(&rng) < 0.5 ? -1.0 : 1.0;
            mlr_quat q = {sg * cos(th / 2), sg * sin(th / 2) * ax[0] / na,
                          sg * sin(th / 2) * ax[1] / na, sg * sin(th / 2) * ax[2] / na};
            qp[f * J + j] = qn[f * J + j] = q;
        }
    }
    for (size_t f = 0; f < N; f++) {
        double *row = c.y + f * m;
        row[0] = sin(0.05 * (double)f), row[1] = 0.01 * (double)f, row[2] = 1.0;
        memcpy(row + 3, qp + f * J, J * sizeof(mlr_quat));
    }
    c.extent = 1.0;
    mlr_quat_make_continuous_predictive(qp, N, J);
    mlr_quat_make_continuous(qn, N, J);
    size_t differ = 0;
    for (size_t k = 0; k < N * J; k++)
        differ +=
            qp[k].w * qn[k].w + qp[k].x * qn[k].x + qp[k].y * qn[k].y + qp[k].z * qn[k].z < 0.0;
    ck_assert_uint_gt(differ, N / 4); /* the rules disagree here: the test tells them apart */
    memcpy(c.ya, c.y, N * m * sizeof(double));
    for (size_t f = 0; f < N; f++)
        memcpy(c.ya + f * m + 3, qp + f * J, J * sizeof(mlr_quat));

    mlr_stream *st = NULL;
    ck_assert_int_eq(mlr_stream_create(J, 1, 0, 0.0, 1.0, 0, NULL, &st, NULL), MLR_OK);
    stream_all(st, c.y, N, m, x);
    mlr_stream_destroy(st);
    for (size_t k = 0; k < N * m; k++)
        ck_assert_close(x[k], c.ya[k], 1e-15);

    offline(&c, 2.0, 0.5, ref);
    ck_assert_int_eq(mlr_stream_create(J, 1, 0, 2.0, 0.5, N, NULL, &st, NULL), MLR_OK);
    stream_all(st, c.y, N, m, x);
    mlr_stream_destroy(st);
    ck_assert_double_le(rel_gap(&c, x, ref, 0, N), 1e-9);
    free(x), free(ref), free(qp), free(qn);
    clip_free(&c);
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Layers                                                                                   */

/* alpha = 1: the plain stream's bytes; alpha = 0: the offline base; alpha = 1.7 / 0.4: the
 * offline base (+) alpha (main (-) base), composed here from the offline layers. */
START_TEST(layers_match_offline_composition)
{
    clip c;
    clip_load(&c, 2); /* cmu_10_01: 43 joints */
    const size_t N = c.N, m = c.m, J = c.J, nt = 3 + 3 * c.P;
    double *xm = malloc(N * m * sizeof(double)), *xb = malloc(N * m * sizeof(double));
    double *x = malloc(N * m * sizeof(double)), *xp = malloc(N * m * sizeof(double));
    const double lam = 2.0, sigma = 0.5, lam_b = 20.0, sigma_b = 2.0;
    offline(&c, lam, sigma, xm);
    offline(&c, lam_b, sigma_b, xb);
    mlr_stream *plain = NULL, *st = NULL;
    ck_assert_int_eq(mlr_stream_create(J, 1, c.P, lam, sigma, 25, NULL, &plain, NULL), MLR_OK);
    ck_assert_int_eq(
        mlr_stream_create_layered(J, 1, c.P, lam, sigma, lam_b, sigma_b, 25, NULL, &st, NULL),
        MLR_OK);
    stream_all(plain, c.y, N, m, xp);
    stream_all(st, c.y, N, m, x);
    ck_assert_int_eq(memcmp(x, xp, N * m * sizeof(double)), 0);
    mlr_stream_destroy(plain);
    mlr_stream_destroy(st);

    double *alpha = malloc(J * sizeof(double));
    const double a_list[] = {0.0, 1.7, 0.4};
    for (size_t t = 0; t < MLR_COUNTOF(a_list); t++) {
        ck_assert_int_eq(
            mlr_stream_create_layered(J, 1, c.P, lam, sigma, lam_b, sigma_b, N, NULL, &st, NULL),
            MLR_OK);
        for (size_t j = 0; j < J; j++)
            alpha[j] = j % 2 ? a_list[t] : 1.0; /* every other joint modulated */
        ck_assert_int_eq(mlr_stream_set_alpha(st, a_list[t], alpha, J, NULL), MLR_OK);
        stream_all(st, c.y, N, m, x);
        mlr_stream_destroy(st);
        for (size_t f = 0; f < N; f++) {
            const double *rm = xm + f * m, *rb = xb + f * m, *r = x + f * m;
            for (size_t k = 0; k < nt; k++)
                ck_assert_close(r[k], rb[k] + a_list[t] * (rm[k] - rb[k]), 1e-9 * c.extent);
            for (size_t j = 0; j < J; j++) {
                const mlr_quat *qm = (const mlr_quat *)(rm + nt) + j;
                const mlr_quat *qb = (const mlr_quat *)(rb + nt) + j;
                const mlr_quat *q = (const mlr_quat *)(r + nt) + j;
                mlr_quat bc = {qb->w, -qb->x, -qb->y, -qb->z}, d, e, want;
                mlr_vec3 v;
                mlr_quat_mul(&bc, qm, &d);
                mlr_quat_log_array(&d, 1, &v, NULL);
                v = scale_turn(v, alpha[j]);
                mlr_quat_exp_array(&v, 1, &e, NULL);
                mlr_quat_mul(qb, &e, &want);
                if (alpha[j] == 1.0)
                    want = *qm;
                /* same rotation: |dot| = 1 */
                double dot = want.w * q->w + want.x * q->x + want.y * q->y + want.z * q->z;
                ck_assert_close(fabs(dot), 1.0, 1e-12);
                if (a_list[t] == 0.0 && j % 2)
                    ck_assert_close(
                        fabs(qb->w * q->w + qb->x * q->x + qb->y * q->y + qb->z * q->z), 1.0,
                        1e-12);
            }
        }
    }
    free(alpha);
    free(xm), free(xb), free(x), free(xp);
    clip_free(&c);
}
END_TEST

/* The layered stream's output, bit for bit, against the two plain streams (main and base)
 * composed here joint by joint with the public calls: translations xb + a (x - xb), joint j
 * qb exp(a_j log(conj(qb) q)) where a_j != 1 (the stream batches these over the joints, and
 * takes joints whose scaled vectors leave the exp's fast range, a_j = 1e6 here, one by one).
 * Every alpha 1 (the base layer then not read) equals the main stream. */
START_TEST(layers_bitwise_per_joint_composition)
{
    clip c;
    clip_load(&c, 0);
    const size_t N = c.N < 300 ? c.N : 300, m = c.m, J = c.J, nt = 3 + 3 * c.P, lag = 12;
    const double lam = 1.0, sigma = 1.0, lam_b = 20.0, sigma_b = 1.0;
    double *xm = malloc(N * m * sizeof(double)), *xb = malloc(N * m * sizeof(double));
    double *x = malloc(N * m * sizeof(double)), *alpha = malloc(J * sizeof(double));
    mlr_stream *st = NULL;
    ck_assert_int_eq(mlr_stream_create(J, 1, c.P, lam, sigma, lag, NULL, &st, NULL), MLR_OK);
    stream_all(st, c.y, N, m, xm);
    mlr_stream_destroy(st);
    ck_assert_int_eq(mlr_stream_create(J, 1, c.P, lam_b, sigma_b, lag, NULL, &st, NULL), MLR_OK);
    stream_all(st, c.y, N, m, xb);
    mlr_stream_destroy(st);
    const double a_trans[] = {1.0, 1.0, 0.6, 2.5};
    for (int t = 0; t < 4; t++) {
        for (size_t j = 0; j < J; j++) {
            const double mixed[] = {1.0, 2.5, -0.5, 0.0, 1.0, 0.75, 1e6};
            alpha[j] = t == 0 ? 1.0 : t == 1 ? 1.8 : mixed[j % MLR_COUNTOF(mixed)];
        }
        ck_assert_int_eq(
            mlr_stream_create_layered(J, 1, c.P, lam, sigma, lam_b, sigma_b, lag, NULL, &st, NULL),
            MLR_OK);
        ck_assert_int_eq(mlr_stream_set_alpha(st, a_trans[t], alpha, J, NULL), MLR_OK);
        stream_all(st, c.y, N, m, x);
        mlr_stream_destroy(st);
        for (size_t f = 0; f < N; f++) {
            double want[512];
            ck_assert_uint_le(m, MLR_COUNTOF(want));
            const double *rm = xm + f * m, *rb = xb + f * m;
            for (size_t k = 0; k < nt; k++)
                want[k] = a_trans[t] == 1.0 ? rm[k] : rb[k] + a_trans[t] * (rm[k] - rb[k]);
            for (size_t j = 0; j < J; j++) {
                const mlr_quat *qm = (const mlr_quat *)(rm + nt) + j;
                const mlr_quat *qb = (const mlr_quat *)(rb + nt) + j;
                mlr_quat *w = (mlr_quat *)(want + nt) + j;
                *w = *qm;
                if (alpha[j] == 1.0)
                    continue;
                mlr_quat bc = {qb->w, -qb->x, -qb->y, -qb->z}, d, e;
                mlr_vec3 v;
                mlr_quat_mul(&bc, qm, &d);
                mlr_quat_log_array(&d, 1, &v, NULL);
                v = scale_turn(v, alpha[j]);
                mlr_quat_exp_array(&v, 1, &e, NULL);
                mlr_quat_mul(qb, &e, w);
            }
            ck_assert_msg(memcmp(x + f * m, want, m * sizeof(double)) == 0,
                          "alphas %d, frame %zu differs", t, f);
        }
    }
    free(xm), free(xb), free(x), free(alpha);
    clip_free(&c);
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Memory and bad input                                                                     */

START_TEST(no_allocation_after_create)
{
    clip c;
    clip_load(&c, 1);
    double *x = malloc(c.N * c.m * sizeof(double));
    for (int layered = 0; layered < 2; layered++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, SIZE_MAX);
        mlr_stream *st = NULL;
        if (layered)
            ck_assert_int_eq(mlr_stream_create_layered(c.J, 1, c.P, 3.0, 1.0, 30.0, 1.0, 30,
                                                       &ta.base, &st, NULL),
                             MLR_OK);
        else
            ck_assert_int_eq(mlr_stream_create(c.J, 1, c.P, 3.0, 1.0, 30, &ta.base, &st, NULL),
                             MLR_OK);
        const size_t calls = ta.n_calls;
        ta.fail_at = calls; /* the next allocation, if any, fails */
        double *alpha = calloc(c.J, sizeof(double));
        if (layered)
            ck_assert_int_eq(mlr_stream_set_alpha(st, 0.5, alpha, c.J, NULL), MLR_OK);
        stream_all(st, c.y, c.N, c.m, x);
        mlr_stream_reset(st);
        stream_all(st, c.y, c.N, c.m, x);
        ck_assert_uint_eq(ta.n_calls, calls);
        mlr_stream_destroy(st);
        ck_assert_uint_eq(ta.live_blocks, 0);
        free(alpha);
    }
    free(x);
    clip_free(&c);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    for (int layered = 0; layered < 2; layered++)
        for (size_t fail_at = 0;; fail_at++) {
            mlr_test_allocator ta;
            mlr_test_allocator_init(&ta, fail_at);
            mlr_stream *st = NULL;
            mlr_status s =
                layered ? mlr_stream_create_layered(31, 1, 0, 1, 1, 5, 1, 10, &ta.base, &st, NULL)
                        : mlr_stream_create(31, 1, 0, 1, 1, 10, &ta.base, &st, NULL);
            mlr_stream_destroy(st);
            ck_assert_uint_eq(ta.live_blocks, 0);
            if (s == MLR_OK)
                break;
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
            ck_assert_ptr_null(st);
        }
}
END_TEST

/* A NaN or inf frame is rejected and changes nothing: the outputs equal those of a run that
 * never saw it. */
START_TEST(non_finite_frame_rejected)
{
    clip c;
    clip_load(&c, 7); /* dog */
    const size_t m = c.m;
    double *x1 = malloc(c.N * m * sizeof(double)), *x2 = malloc(c.N * m * sizeof(double));
    double *bad = malloc(m * sizeof(double));
    mlr_stream *st = NULL;
    ck_assert_int_eq(mlr_stream_create(c.J, 1, c.P, 4.0, 0.5, 9, NULL, &st, NULL), MLR_OK);
    stream_all(st, c.y, c.N, m, x1);
    mlr_stream_reset(st);
    size_t done = 0, ready;
    const double poison[] = {NAN, INFINITY, -INFINITY};
    for (size_t f = 0; f < c.N; f++) {
        if (f % 97 == 50) {
            memcpy(bad, c.y + f * m, m * sizeof(double));
            bad[(f * 7) % m] = poison[f % 3];
            const size_t before = mlr_stream_n_pushed(st), pend = mlr_stream_pending(st);
            ready = 5;
            ck_assert_int_eq(mlr_stream_push(st, bad, m, x2 + done * m, m, &ready, NULL),
                             MLR_E_INVALID_ARG);
            ck_assert_uint_eq(ready, 0);
            ck_assert_uint_eq(mlr_stream_n_pushed(st), before);
            ck_assert_uint_eq(mlr_stream_pending(st), pend);
        }
        ck_assert_int_eq(mlr_stream_push(st, c.y + f * m, m, x2 + done * m, m, &ready, NULL),
                         MLR_OK);
        done += ready;
    }
    size_t w;
    ck_assert_int_eq(mlr_stream_flush(st, x2 + done * m, (c.N - done) * m, &w, NULL), MLR_OK);
    ck_assert_int_eq(memcmp(x1, x2, c.N * m * sizeof(double)), 0);
    mlr_stream_destroy(st);
    free(x1), free(x2), free(bad);
    clip_free(&c);
}
END_TEST

START_TEST(bad_arguments)
{
    mlr_stream *st = (mlr_stream *)&st;
    mlr_diag d;
    ck_assert_int_eq(mlr_stream_create(0, 0, 0, 1, 1, 3, NULL, &st, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(st);
    ck_assert_int_eq(mlr_stream_create(2, 1, 0, -1, 1, 3, NULL, &st, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_create(2, 1, 0, NAN, 1, 3, NULL, &st, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_create(2, 1, 0, 1, 0, 3, NULL, &st, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_create(2, 1, 0, 1e200, 1e200, 3, NULL, &st, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_create_layered(2, 1, 0, 1, 1, 1, INFINITY, 3, NULL, &st, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_create(2, 1, 0, 1, 1, 3, NULL, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_create(SIZE_MAX / 2, 1, 0, 1, 1, 3, NULL, &st, &d),
                     MLR_E_OVERFLOW);
    ck_assert_int_eq(mlr_stream_create(2, 1, 0, 1, 1, SIZE_MAX, NULL, &st, &d), MLR_E_OVERFLOW);

    ck_assert_int_eq(mlr_stream_create(2, 1, 0, 1, 1, 2, NULL, &st, &d), MLR_OK);
    const size_t m = mlr_stream_frame_size(st);
    ck_assert_uint_eq(m, 11);
    double f[11] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}, out[3 * 11];
    size_t ready;
    ck_assert_int_eq(mlr_stream_push(st, f, m - 1, out, m, &ready, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_push(st, f, m + 1, out, m, &ready, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_push(st, f, m, out, m - 1, &ready, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_push(st, NULL, m, out, m, &ready, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_push(st, f, m, NULL, m, &ready, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_push(st, f, m, out, m, NULL, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_push(NULL, f, m, out, m, &ready, NULL), MLR_E_INVALID_ARG);
    ck_assert_uint_eq(mlr_stream_n_pushed(st), 0);
    ck_assert_int_eq(mlr_stream_set_alpha(st, 1.0, f, 2, NULL), MLR_E_BAD_STATE);
    for (int k = 0; k < 3; k++)
        ck_assert_int_eq(mlr_stream_push(st, f, m, out, m, &ready, NULL), MLR_OK);
    ck_assert_uint_eq(ready, 1);
    ck_assert_uint_eq(mlr_stream_pending(st), 2);
    size_t w = 7;
    ck_assert_int_eq(mlr_stream_flush(st, out, 2 * m - 1, &w, NULL), MLR_E_OVERFLOW);
    ck_assert_uint_eq(w, 0);
    ck_assert_uint_eq(mlr_stream_pending(st), 2);
    ck_assert_int_eq(mlr_stream_flush(st, NULL, 0, &w, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_flush(st, out, 2 * m, NULL, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_flush(st, out, 2 * m, &w, NULL), MLR_OK);
    ck_assert_uint_eq(w, 2);
    for (size_t k = 0; k < 2 * m; k++) /* constant input: the output is that input */
        ck_assert_close(out[k], f[k % m], 1e-15);
    ck_assert_int_eq(mlr_stream_flush(st, out, 2 * m, &w, NULL), MLR_E_BAD_STATE);
    ck_assert_int_eq(mlr_stream_push(st, f, m, out, m, &ready, NULL), MLR_E_BAD_STATE);
    mlr_stream_reset(st);
    ck_assert_int_eq(mlr_stream_push(st, f, m, out, m, &ready, NULL), MLR_OK);
    mlr_stream_destroy(st);

    ck_assert_int_eq(mlr_stream_create_layered(2, 0, 0, 1, 1, 9, 1, 0, NULL, &st, &d), MLR_OK);
    double al[2] = {1, 2};
    ck_assert_int_eq(mlr_stream_set_alpha(st, 1.0, al, 3, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_set_alpha(st, 1.0, NULL, 2, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_set_alpha(st, NAN, al, 2, NULL), MLR_E_INVALID_ARG);
    al[1] = INFINITY;
    ck_assert_int_eq(mlr_stream_set_alpha(st, 1.0, al, 2, NULL), MLR_E_INVALID_ARG);
    mlr_stream_destroy(st);
    mlr_stream_destroy(NULL);
    mlr_stream_reset(NULL);
    ck_assert_uint_eq(mlr_stream_frame_size(NULL), 0);
}
END_TEST

static Suite *stream_suite(void)
{
    Suite *s = suite_create("stream");
    TCase *num = tcase_create("numerics");
    tcase_set_timeout(num, 60);
    tcase_add_loop_test(num, outputs_equal_dense_prefix, 0, (int)MLR_COUNTOF(lags));
    tcase_add_loop_test(num, flush_equals_offline_on_clips, 0, (int)MLR_COUNTOF(clip_files));
    tcase_add_test(num, gap_decays_geometrically);
    tcase_add_test(num, decay_rate_is_a_root);
    tcase_add_test(num, reset_repeats_bitwise);
    tcase_add_test(num, layers_bitwise_per_joint_composition);
    tcase_add_test(num, signs_follow_predictive_rule);
    tcase_add_test(num, layers_match_offline_composition);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("memory_and_arguments");
    tcase_add_test(args, no_allocation_after_create);
    tcase_add_test(args, every_allocation_failure_is_clean);
    tcase_add_test(args, non_finite_frame_rejected);
    tcase_add_test(args, bad_arguments);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(stream_suite()); }
