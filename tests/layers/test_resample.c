/* Resampling and time warping through the LGS, the SLERP baseline and predictive quaternion
 * sign continuity: against a dense reference built from explicit matrices, on sparse spinning
 * keys (paper 1, Table 1 / Figure 8), on the real clips (120 -> 30 -> 120 fps round trips),
 * against aliasing, on bad input and on every allocation failure. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* ---------------------------------------------------------------------------------------- */
/* Independent reference: explicit dense A (N x n), L ((n-2) x n), M = s L^T L + A^T A, solved by
 * a dense Cholesky factorization; the variance as sigma^2 diag(M^-1) column by column.         */

static void chol_solve(const double *C, size_t n, double *b) /* C: lower Cholesky factor */
{
    mlr_test_cholesky_solve(n, C, b, 1);
}

static void dense_reference(size_t N, const double *t, size_t n, unsigned order, double s,
                            double sigma, const double *y, size_t m, double *x, double *var)
{
    double *A = calloc(N * n, sizeof *A), *L = calloc(n * n, sizeof *L);
    double *M = calloc(n * n, sizeof *M), *C = calloc(n * n, sizeof *C),
           *b = malloc(n * sizeof *b);
    for (size_t i = 0; i < N; i++) {
        size_t lo = (size_t)floor(t[i]);
        if (lo >= n - 1)
            lo = n - 2;
        const double f = t[i] - (double)lo;
        A[i * n + lo] = 1.0 - f;
        A[i * n + lo + 1] = f;
    }
    for (size_t r = 0; r + order < n; r++) {
        if (order == 2) {
            L[r * n + r] = 1.0;
            L[r * n + r + 1] = -2.0;
            L[r * n + r + 2] = 1.0;
        } else {
            L[r * n + r] = -1.0;
            L[r * n + r + 1] = 1.0;
        }
    }
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < n; j++) {
            double v = 0.0;
            for (size_t r = 0; r + order < n; r++)
                v += s * L[r * n + i] * L[r * n + j];
            for (size_t r = 0; r < N; r++)
                v += A[r * n + i] * A[r * n + j];
            M[i * n + j] = v;
        }
    memcpy(C, M, n * n * sizeof *C); /* Cholesky M = C C^T */
    mlr_test_cholesky(n, C);
    for (size_t c = 0; c < m; c++) {
        for (size_t i = 0; i < n; i++) {
            double v = 0.0;
            for (size_t r = 0; r < N; r++)
                v += A[r * n + i] * y[r * m + c];
            b[i] = v;
        }
        chol_solve(C, n, b);
        for (size_t i = 0; i < n; i++)
            x[i * m + c] = b[i];
    }
    for (size_t i = 0; i < n; i++) {
        memset(b, 0, n * sizeof *b);
        b[i] = 1.0;
        chol_solve(C, n, b);
        var[i] = sigma * sigma * b[i];
    }
    free(A), free(L), free(M), free(C), free(b);
}

static void axis_angle(double ax, double ay, double az, double ang, double *q)
{
    const double n = sqrt(ax * ax + ay * ay + az * az);
    q[0] = cos(ang / 2);
    q[1] = sin(ang / 2) * ax / n;
    q[2] = sin(ang / 2) * ay / n;
    q[3] = sin(ang / 2) * az / n;
}

/* A smooth random motion: root random walk, J joints turning smoothly, P translations. */
static void smooth_motion(size_t N, size_t J, size_t P, uint64_t seed, double *root, double *rot,
                          double *trans)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, seed);
    for (size_t c = 0; c < 3; c++) {
        double a = mlr_test_rng_normal(&rng), w = 0.2 + mlr_test_rng_uniform(&rng);
        for (size_t i = 0; i < N; i++)
            root[3 * i + c] = 10 * a + 3 * sin(w * (double)i + a);
    }
    for (size_t j = 0; j < J; j++) {
        double ax = mlr_test_rng_normal(&rng), ay = mlr_test_rng_normal(&rng),
               az = mlr_test_rng_normal(&rng), w = 0.1 + 0.3 * mlr_test_rng_uniform(&rng);
        for (size_t i = 0; i < N; i++) {
            double *q = rot + 4 * (J * i + j);
            axis_angle(ax, ay + 0.3 * sin(0.2 * (double)i), az, 1.0 + sin(w * (double)i), q);
            if ((i * 7 + j) % 5 == 0) /* arbitrary signs on input */
                for (int k = 0; k < 4; k++)
                    q[k] = -q[k];
        }
    }
    for (size_t i = 0; i < N * P * 3; i++)
        trans[i] = 5.0 + sin(0.3 * (double)i);
}

/* Cases of the dense comparison: counts and the time map kind. */
static const struct {
    size_t N, n_out;
    int warped;     /* 0 uniform (t = NULL), 1 a non-uniform monotone map, 2 the exact map of
                       a frame rate change by the factor rate (open end) */
    double lam;     /* < 0: automatic */
    double rate;
} dense_cases[] = {
    {30, 9, 2, -1.0, 0.3},  /* exact rate, downsampling: t[N-1] = 8.7, one hidden frame */
    {9, 30, 2, -1.0, 3.7},  /* exact rate, upsampling: t[N-1] = 29.6 */
    {13, 4, 2, 0.4, 0.25},  /* exact rate landing on the grid: t[N-1] = 3, no hidden frame */
    {9, 33, 0, -1.0, 0.0},   /* upsampling */
    {30, 8, 0, -1.0, 0.0},   /* downsampling */
    {12, 12, 1, -1.0, 0.0},  /* warp, same length */
    {15, 21, 1, 0.7, 0.0},   /* warp, explicit lam */
    {10, 2, 0, -1.0, 0.0},   /* two output frames (order 1) */
};

START_TEST(matches_dense_reference)
{
    const size_t N = dense_cases[_i].N, n = dense_cases[_i].n_out, J = 3, P = 1;
    const double sigma = 0.5;
    double *root = malloc(N * 3 * sizeof(double)), *rot = malloc(N * J * 4 * sizeof(double));
    double *trans = malloc(N * P * 3 * sizeof(double)), *t = malloc(N * sizeof(double));
    smooth_motion(N, J, P, 11 + _i, root, rot, trans);
    const int open_end = dense_cases[_i].warped == 2;
    if (open_end) {
        size_t n_rate = 0;
        mlr_diag d0;
        ck_assert_int_eq(mlr_resample_rate_map(N, 1.0, dense_cases[_i].rate, 0, t, &n_rate, &d0),
                         MLR_OK);
        ck_assert_uint_eq(n_rate, n);
        for (size_t i = 0; i < N; i++)
            ck_assert_double_eq_tol(t[i], (double)i * dense_cases[_i].rate, 1e-12);
    } else if (dense_cases[_i].warped) {
        double acc = 0.0;
        for (size_t i = 0; i < N; i++) {
            t[i] = acc;
            acc += 1.0 + 0.8 * sin(0.7 * (double)i);
        }
        for (size_t i = 0; i < N; i++)
            t[i] *= (double)(n - 1) / t[N - 1];
        t[N - 1] = (double)(n - 1);
    } else {
        for (size_t i = 0; i < N; i++)
            t[i] = (double)i * (double)(n - 1) / (double)(N - 1);
        t[N - 1] = (double)(n - 1);
    }
    double *ro = malloc(n * 3 * sizeof(double)), *qo = malloc(n * J * 4 * sizeof(double));
    double *to = malloc(n * P * 3 * sizeof(double)), *var = malloc(n * sizeof(double));
    mlr_diag d;
    mlr_status st = mlr_resample_arrays(
        N, J, P, root, rot, trans, dense_cases[_i].warped ? t : NULL, n, dense_cases[_i].lam,
        sigma, open_end ? MLR_RESAMPLE_OPEN_END : 0, ro, qo, to, var, NULL, &d);
    ck_assert_msg(st == MLR_OK, "%s: %s", mlr_status_name(st), d.message);

    /* reference: all channels in one matrix, quaternions made continuous by the nearest sign
     * (the steps of this motion are small, where the predictive rule agrees); an open end is
     * solved on a grid of one frame more whose last frame is dropped */
    const double r = open_end ? dense_cases[_i].rate : (double)(n - 1) / (double)(N - 1);
    const double s_auto = fmax(MLR_RESAMPLE_KAPPA_UP * r * r * r, MLR_RESAMPLE_KAPPA_DOWN / r);
    if (!open_end)
        ck_assert_double_eq_tol(s_auto, mlr_resample_auto_smoothness(N, n), 1e-12 * s_auto);
    const double lam = dense_cases[_i].lam >= 0 ? dense_cases[_i].lam : sqrt(s_auto) / sigma;
    const double s = lam * lam * sigma * sigma;
    const size_t m = 3 + 4 * J + 3 * P;
    const size_t n_grid = open_end && t[N - 1] > (double)(n - 1) ? n + 1 : n;
    double *y = malloc(N * m * sizeof(double)), *x = malloc(n_grid * m * sizeof(double));
    double *vr = malloc(n_grid * sizeof(double));
    for (size_t i = 0; i < N; i++) {
        memcpy(y + i * m, root + 3 * i, 3 * sizeof(double));
        for (size_t j = 0; j < J; j++) {
            const double *q = rot + 4 * (J * i + j);
            const double *qp = i ? y + (i - 1) * m + 3 + 4 * j : q;
            const double sg =
                q[0] * qp[0] + q[1] * qp[1] + q[2] * qp[2] + q[3] * qp[3] < 0 ? -1 : 1;
            for (int k = 0; k < 4; k++)
                y[i * m + 3 + 4 * j + k] = sg * q[k];
        }
        memcpy(y + i * m + 3 + 4 * J, trans + 3 * P * i, 3 * P * sizeof(double));
    }
    dense_reference(N, t, n_grid, n_grid >= 3 ? 2 : 1, s, sigma, y, m, x, vr); /* order 1 for 2 */
    for (size_t i = 0; i < n; i++) {
        for (size_t c = 0; c < 3; c++)
            ck_assert_close(ro[3 * i + c], x[i * m + c], 1e-9 * (1 + fabs(x[i * m + c])));
        for (size_t j = 0; j < J; j++) {
            const double *xr = x + i * m + 3 + 4 * j;
            const double nr = sqrt(xr[0] * xr[0] + xr[1] * xr[1] + xr[2] * xr[2] + xr[3] * xr[3]);
            for (int k = 0; k < 4; k++)
                ck_assert_close(qo[4 * (J * i + j) + k], xr[k] / nr, 1e-9);
        }
        for (size_t c = 0; c < 3 * P; c++)
            ck_assert_close(to[3 * P * i + c], x[i * m + 3 + 4 * J + c],
                            1e-9 * (1 + fabs(to[3 * P * i + c])));
        ck_assert_close(var[i], vr[i], 1e-9 * vr[i]);
    }
    free(root), free(rot), free(trans), free(t), free(ro), free(qo), free(to), free(var);
    free(y), free(x), free(vr);
}
END_TEST

/* The exact map of a frame rate change puts output frame k at time k / fps_out: a root moving
 * linearly in time comes out on the line at those times (the order-2 prior does not bend a
 * line), with the last output frame the last grid time within the input. */
START_TEST(exact_rate_frames_lie_at_their_times)
{
    enum { N = 994 };
    static double root[N * 3], rot[N * 4], t[N];
    const double fps_in = 120.0, rates[] = {30.0, 29.97, 24.0, 240.0};
    for (size_t i = 0; i < N; i++) {
        const double time = (double)i / fps_in;
        root[3 * i] = 1.0 + 3.0 * time;
        root[3 * i + 1] = -2.0 * time;
        root[3 * i + 2] = 0.5;
        axis_angle(0.0, 1.0, 0.0, 0.2, rot + 4 * i);
    }
    for (size_t r = 0; r < MLR_COUNTOF(rates); r++) {
        size_t n = 0, n2 = 0;
        mlr_diag d;
        ck_assert_int_eq(mlr_resample_rate_map(N, fps_in, rates[r], 0, t, &n, &d), MLR_OK);
        ck_assert_int_eq(mlr_resample_n_out(N, fps_in, rates[r], MLR_RESAMPLE_OPEN_END, &n2, &d),
                         MLR_OK);
        ck_assert_uint_eq(n, n2);
        /* the last output time is within the input and the next one is past it */
        const double dur = (double)(N - 1) / fps_in;
        ck_assert((double)(n - 1) / rates[r] <= dur * (1 + 1e-12));
        ck_assert((double)n / rates[r] > dur);
        double *ro = malloc(n * 3 * sizeof(double)), *qo = malloc(n * 4 * sizeof(double));
        for (int method = 0; method < 2; method++) {
            mlr_status st =
                method == 0
                    ? mlr_resample_arrays(N, 1, 0, root, rot, NULL, t, n, MLR_RESAMPLE_AUTO, 1.0,
                                          MLR_RESAMPLE_OPEN_END, ro, qo, NULL, NULL, NULL, &d)
                    : mlr_slerp_resample_arrays(N, 1, 0, root, rot, NULL, t, n,
                                                MLR_RESAMPLE_OPEN_END, ro, qo, NULL, &d);
            ck_assert_msg(st == MLR_OK, "%s", d.message);
            for (size_t k = 0; k < n; k++) {
                const double time = (double)k / rates[r];
                ck_assert_double_eq_tol(ro[3 * k], 1.0 + 3.0 * time, 1e-9);
                ck_assert_double_eq_tol(ro[3 * k + 1], -2.0 * time, 1e-9);
                ck_assert_double_eq_tol(ro[3 * k + 2], 0.5, 1e-9);
                ck_assert_double_eq_tol(qo[4 * k], cos(0.1), 1e-9);
            }
        }
        free(ro), free(qo);
    }
}
END_TEST

/* Two cuts of one clip, of different lengths (and one starting a whole output frame later),
 * resampled separately: frames at the same time agree, exactly for SLERP and for the LGS away
 * from the shorter cut's ends, where the two solves see different data. */
START_TEST(cuts_of_one_clip_agree_at_the_same_times)
{
    enum { N = 480, J = 3, P = 1, NB = 301, SC = 8 }; /* cut C starts at input frame 8 */
    static double root[N * 3], rot[N * J * 4], trans[N * P * 3], t[N];
    smooth_motion(N, J, P, 21, root, rot, trans);
    for (size_t i = 0; i < N * 3; i++) /* slower than smooth_motion's per-frame waves */
        root[i] = 0.0;
    for (size_t i = 0; i < N; i++)
        root[3 * i] = 10 * sin(0.02 * (double)i), root[3 * i + 1] = 0.01 * (double)i;
    const double fps_in = 120.0, fps_out = 30.0;
    static double ro[3][N * 3], qo[3][N * J * 4], to[3][N * P * 3];
    size_t n[3];
    const size_t start[3] = {0, 0, SC}, len[3] = {N, NB, N - SC};
    for (int method = 0; method < 2; method++) {
        for (int c = 0; c < 3; c++) {
            mlr_diag d;
            const size_t b = start[c];
            ck_assert_int_eq(mlr_resample_rate_map(len[c], fps_in, fps_out, 0, t, &n[c], &d),
                             MLR_OK);
            mlr_status st =
                method == 0
                    ? mlr_resample_arrays(len[c], J, P, root + 3 * b, rot + 4 * J * b,
                                          trans + 3 * P * b, t, n[c], MLR_RESAMPLE_AUTO, 1.0,
                                          MLR_RESAMPLE_OPEN_END, ro[c], qo[c], to[c], NULL, NULL,
                                          &d)
                    : mlr_slerp_resample_arrays(len[c], J, P, root + 3 * b, rot + 4 * J * b,
                                                trans + 3 * P * b, t, n[c], MLR_RESAMPLE_OPEN_END,
                                                ro[c], qo[c], to[c], &d);
            ck_assert_msg(st == MLR_OK, "%s", d.message);
        }
        ck_assert_uint_eq(n[0], (N - 1) / 4 + 1);
        ck_assert_uint_eq(n[1], (NB - 1) / 4 + 1);
        /* the LGS's end effects decay by about 10x every 3 output frames (measured on the
         * root: 1e-2 at the ends, 2e-7 at 12 frames, 2e-11 at 24): compare from 24 frames in */
        const size_t margin = method == 0 ? 24 : 0;
        const double tol = method == 0 ? 1e-8 : 0.0;
        double worst = 0.0;
        for (int c = 1; c < 3; c++) {
            const size_t shift = start[c] / 4; /* output frames */
            for (size_t k = margin; k + margin < n[c]; k++) {
                const size_t ka = k + shift;
                for (size_t x = 0; x < 3; x++)
                    worst = fmax(worst, fabs(ro[c][3 * k + x] - ro[0][3 * ka + x]));
                for (size_t j = 0; j < J; j++) { /* up to the sign each cut started with */
                    const double *qa = qo[0] + 4 * (J * ka + j), *qc = qo[c] + 4 * (J * k + j);
                    double dm = 0.0, dp = 0.0;
                    for (int x = 0; x < 4; x++)
                        dm = fmax(dm, fabs(qc[x] - qa[x])), dp = fmax(dp, fabs(qc[x] + qa[x]));
                    worst = fmax(worst, fmin(dm, dp));
                }
                for (size_t x = 0; x < 3 * P; x++)
                    worst = fmax(worst, fabs(to[c][3 * P * k + x] - to[0][3 * P * ka + x]));
            }
        }
        fprintf(stderr, "cuts: %s, largest difference at the same times %.3g\n",
                method == 0 ? "LGS" : "SLERP", worst);
        ck_assert_msg(worst <= tol, "%s: %g", method == 0 ? "LGS" : "SLERP", worst);
    }
}
END_TEST

/* n_out == N with t_i = i and weak smoothing gives the input back. */
START_TEST(identity_with_weak_smoothing)
{
    const size_t N = 50, J = 4, P = 2;
    double root[50 * 3], rot[50 * 4 * 4], trans[50 * 2 * 3], t[50];
    double ro[50 * 3], qo[50 * 4 * 4], to[50 * 2 * 3];
    smooth_motion(N, J, P, 5, root, rot, trans);
    for (size_t i = 0; i < N; i++)
        t[i] = (double)i;
    for (int use_t = 0; use_t < 2; use_t++) {
        ck_assert_int_eq(mlr_resample_arrays(N, J, P, root, rot, trans, use_t ? t : NULL, N, 1e-4,
                                             1.0, 0, ro, qo, to, NULL, NULL, NULL),
                         MLR_OK);
        for (size_t i = 0; i < N * 3; i++)
            ck_assert_close(ro[i], root[i], 1e-6);
        for (size_t i = 0; i < N * P * 3; i++)
            ck_assert_close(to[i], trans[i], 1e-6);
        for (size_t i = 0; i < N * J; i++) {
            const double *a = rot + 4 * i, *b = qo + 4 * i;
            ck_assert_close(fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]), 1.0,
                            1e-9);
        }
    }
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Sign continuity by prediction                                                             */

/* Keys of a spin about y with the given steps (degrees); returns the count. */
static size_t spin_keys(const double *steps, size_t n_steps, double *q)
{
    double ang = 0.0;
    axis_angle(0, 1, 0, 0.0, q);
    for (size_t k = 0; k < n_steps; k++) {
        ang += steps[k] * PI / 180.0;
        axis_angle(0, 1, 0, ang, q + 4 * (k + 1));
        if (k % 2 == 0) /* the sign of a key carries no information */
            for (int c = 0; c < 4; c++)
                q[4 * (k + 1) + c] = -q[4 * (k + 1) + c];
    }
    return n_steps + 1;
}

/* Unwrapped angle (radians, of the rotation) of a spin about y, along a sequence. */
static void unwrap_spin(const double *q, size_t n, size_t stride, double *ang)
{
    double prev = 0.0;
    for (size_t i = 0; i < n; i++) {
        double a = 2.0 * atan2(q[i * stride + 2], q[i * stride + 0]);
        if (i > 0) {
            while (a - prev > PI)
                a -= 2 * PI;
            while (a - prev < -PI)
                a += 2 * PI;
        }
        ang[i] = prev = a;
    }
}

START_TEST(predictive_sign_follows_a_growing_spin)
{
    /* steps start below 180 degrees and grow smoothly past it */
    const double steps[] = {120, 140, 160, 180, 200, 220, 240, 260, 280};
    double q[10 * 4], qn[10 * 4];
    const size_t n = spin_keys(steps, MLR_COUNTOF(steps), q);
    memcpy(qn, q, sizeof q);
    mlr_quat_make_continuous_predictive((mlr_quat *)q, n, 1);
    mlr_quat_make_continuous((mlr_quat *)qn, n, 1);
    /* the chosen representatives advance by half the true step each time: the 4-D angle
     * atan2(y, w) grows by steps[k]/2 */
    for (size_t k = 0; k + 1 < n; k++) {
        const double *a = q + 4 * k, *b = q + 4 * (k + 1);
        const double dot = a[0] * b[0] + a[2] * b[2];
        ck_assert_close(dot, cos(steps[k] * PI / 360.0), 1e-12);
        const double *an = qn + 4 * k, *bn = qn + 4 * (k + 1);
        ck_assert(an[0] * bn[0] + an[2] * bn[2] >= 0.0); /* nearest sign: never beyond 180 */
    }
    /* the per-sample form agrees with the batch form */
    double r[10 * 4];
    spin_keys(steps, MLR_COUNTOF(steps), r);
    for (size_t k = 0; k < n; k++) {
        const size_t np = k < 3 ? k : 3;
        mlr_quat_continue_sign((const mlr_quat *)(r + 4 * (k - np)), np,
                               (const mlr_quat *)(r + 4 * k), (mlr_quat *)(r + 4 * k));
    }
    ck_assert_int_eq(memcmp(r, q, sizeof q), 0);
}
END_TEST

/* A steady spin above 180 degrees from the first key is read as the spin below 180 degrees the
 * other way (documented: indistinguishable); an isolated flip of ~180 degrees does not flip the
 * rest of the track; dense data keeps the nearest sign. */
START_TEST(predictive_sign_limits)
{
    const double steady[] = {200, 200, 200, 200, 200};
    double q[6 * 4], qn[6 * 4];
    const size_t n = spin_keys(steady, 5, q);
    memcpy(qn, q, sizeof q);
    mlr_quat_make_continuous_predictive((mlr_quat *)q, n, 1);
    mlr_quat_make_continuous((mlr_quat *)qn, n, 1);
    ck_assert_int_eq(memcmp(q, qn, sizeof q), 0);

    /* glitch: constant pose, one sample turned by 179 degrees, then back */
    double g[12 * 4];
    for (size_t i = 0; i < 12; i++)
        axis_angle(1, 2, 3, 0.4, g + 4 * i);
    axis_angle(0, 1, 0, 179.0 * PI / 180, g + 4 * 5);
    {
        double base[4];
        axis_angle(1, 2, 3, 0.4, base);
        mlr_quat_mul((const mlr_quat *)base, (const mlr_quat *)(g + 20), (mlr_quat *)(g + 20));
    }
    mlr_quat_make_continuous_predictive((mlr_quat *)g, 12, 1);
    for (size_t i = 6; i < 12; i++)
        ck_assert_close(g[4 * i] * g[0] + g[4 * i + 1] * g[1] + g[4 * i + 2] * g[2] +
                            g[4 * i + 3] * g[3],
                        1.0, 1e-12);

    /* dense random rotations: identical to the nearest-sign rule */
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 3);
    double d1[400 * 4], d2[400 * 4];
    double ang = 0.0;
    for (size_t i = 0; i < 400; i++) {
        ang += 0.3 * mlr_test_rng_normal(&rng);
        axis_angle(1 + 0.1 * sin(0.05 * (double)i), 0.5, -0.3, ang, d1 + 4 * i);
        if (mlr_test_rng_uniform(&rng) < 0.5)
            for (int c = 0; c < 4; c++)
                d1[4 * i + c] = -d1[4 * i + c];
    }
    memcpy(d2, d1, sizeof d1);
    mlr_quat_make_continuous_predictive((mlr_quat *)d1, 400, 1);
    mlr_quat_make_continuous((mlr_quat *)d2, 400, 1);
    ck_assert_int_eq(memcmp(d1, d2, sizeof d1), 0);

    /* degenerate input does not crash and returns +-q */
    const mlr_quat z = {0, 0, 0, 0}, one = {1, 0, 0, 0};
    mlr_quat hist[3] = {z, z, one}, out;
    mlr_quat_continue_sign(hist, 3, &one, &out);
    ck_assert(out.w == 1.0);
    mlr_quat_continue_sign(NULL, 0, &one, &out);
    ck_assert(out.w == 1.0);
    mlr_quat_continue_sign(hist, 3, &one, NULL); /* no-op */
}
END_TEST

/* Paper Table 1 (airplane): 8 key poses upsampled to 40 frames. The spin's steps grow from 120
 * to 270 degrees: SLERP takes the short way round from the 180+ steps on (the rotation goes
 * backwards), the LGS with predictive continuity keeps turning forward through every key. */
START_TEST(sparse_spin_keys_lgs_versus_slerp)
{
    const double steps[] = {120, 145, 170, 195, 220, 245, 270};
    const size_t N = 8, n = 40;
    double keys[8 * 4], root[8 * 3] = {0}, ro[40 * 3];
    double lgs[40 * 4], slerp[40 * 4], nearest[40 * 4], var[40];
    spin_keys(steps, 7, keys);
    ck_assert_int_eq(mlr_resample_arrays(N, 1, 0, root, keys, NULL, NULL, n, MLR_RESAMPLE_AUTO,
                                         1.0, 0, ro, lgs, NULL, var, NULL, NULL),
                     MLR_OK);
    ck_assert_int_eq(
        mlr_slerp_resample_arrays(N, 1, 0, root, keys, NULL, NULL, n, 0, ro, slerp, NULL, NULL),
        MLR_OK);
    ck_assert_int_eq(mlr_resample_arrays(N, 1, 0, root, keys, NULL, NULL, n, MLR_RESAMPLE_AUTO,
                                         1.0, MLR_RESAMPLE_NEAREST_SIGN, ro, nearest, NULL, NULL,
                                         NULL, NULL),
                     MLR_OK);
    double a_l[40], a_s[40], a_n[40];
    unwrap_spin(lgs, n, 4, a_l);
    unwrap_spin(slerp, n, 4, a_s);
    unwrap_spin(nearest, n, 4, a_n);
    double total = 0.0;
    for (size_t k = 0; k < 7; k++)
        total += steps[k] * PI / 180.0;
    int slerp_backwards = 0, nearest_backwards = 0;
    for (size_t i = 0; i + 1 < n; i++) {
        ck_assert_msg(a_l[i + 1] > a_l[i], "LGS turns backwards at frame %zu", i);
        slerp_backwards |= a_s[i + 1] < a_s[i];
        nearest_backwards |= a_n[i + 1] < a_n[i];
    }
    ck_assert(slerp_backwards);
    ck_assert(nearest_backwards); /* the prediction is what makes the difference */
    /* the whole 1365 degrees are turned (the ends are near-interpolated keys) */
    ck_assert_msg(fabs(a_l[n - 1] - a_l[0] - total) < 12.0 * PI / 180.0, "turned %g of %g deg",
                  (a_l[n - 1] - a_l[0]) * 180 / PI, total * 180 / PI);
    ck_assert(a_s[n - 1] - a_s[0] < total - PI);
    /* near-interpolation: the output passes close to every key (at frames 0, 39/7, ...) */
    for (size_t k = 0; k < N; k++) {
        double tk = (double)k * 39.0 / 7.0, want = 0.0;
        for (size_t c = 0; c < k; c++)
            want += steps[c] * PI / 180.0;
        size_t lo = (size_t)floor(tk);
        if (lo >= n - 1)
            lo = n - 2;
        const double f = tk - (double)lo, got = (1 - f) * a_l[lo] + f * a_l[lo + 1];
        ck_assert_msg(fabs(got - (want + a_l[0])) < 12.0 * PI / 180.0, "key %zu off by %g deg", k,
                      (got - want - a_l[0]) * 180 / PI);
    }
    /* posterior variance: larger between keys than at them */
    ck_assert(var[2] > var[0] && var[3] > var[6]);
}
END_TEST

/* Variance grows where observations are sparse: a warp that is dense, then sparse, then dense. */
START_TEST(variance_grows_where_sparse)
{
    const size_t N = 30;
    double t[30], root[30 * 3], ro[200 * 3], var[200];
    double acc = 0.0;
    for (size_t i = 0; i < N; i++) {
        t[i] = acc;
        acc += (i >= 10 && i < 20) ? 6.0 : 1.0;
    }
    const size_t n = (size_t)t[N - 1] + 1;
    for (size_t i = 0; i < N * 3; i++)
        root[i] = sin(0.1 * (double)i);
    ck_assert_int_eq(mlr_resample_arrays(N, 0, 0, root, NULL, NULL, t, n, 1.0, 0.1, 0, ro, NULL,
                                         NULL, var, NULL, NULL),
                     MLR_OK);
    double dense_max = 0.0, sparse_max = 0.0;
    for (size_t j = 0; j < n; j++) {
        if (j >= 3 && j <= 7)
            dense_max = fmax(dense_max, var[j]);
        if (j > (size_t)t[10] && j < (size_t)t[19])
            sparse_max = fmax(sparse_max, var[j]);
    }
    ck_assert_msg(sparse_max > 2.0 * dense_max, "sparse %g dense %g", sparse_max, dense_max);
    ck_assert(var[0] > 0.0);
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Anti-aliasing                                                                              */

/* RMS of x[c], c = 0, over frames [b, e) after removing the mean. */
static double rms(const double *x, size_t stride, size_t b, size_t e)
{
    double m = 0.0, v = 0.0;
    for (size_t i = b; i < e; i++)
        m += x[i * stride];
    m /= (double)(e - b);
    for (size_t i = b; i < e; i++)
        v += (x[i * stride] - m) * (x[i * stride] - m);
    return sqrt(v / (double)(e - b));
}

/* 120 -> 30 fps: a sinusoid above the new Nyquist (15 Hz) leaves little of itself, where naive
 * decimation returns it whole as an alias; slow motion passes. */
START_TEST(downsampling_does_not_alias)
{
    const size_t N = 961, n = 241; /* 8 s at 120 fps, 30 fps */
    static double root[961 * 3], ro[241 * 3];
    const double freqs[] = {16.0, 17.0, 18.0, 20.0, 25.0, 33.0, 45.0, 55.0};
    for (size_t k = 0; k < MLR_COUNTOF(freqs); k++) {
        for (size_t i = 0; i < N; i++) {
            root[3 * i] = sin(2 * PI * freqs[k] * (double)i / 120.0 + 0.3);
            root[3 * i + 1] = root[3 * i + 2] = 0.0;
        }
        const double in = rms(root, 3, 0, N);
        ck_assert_int_eq(mlr_resample_arrays(N, 0, 0, root, NULL, NULL, NULL, n, MLR_RESAMPLE_AUTO,
                                             1.0, 0, ro, NULL, NULL, NULL, NULL, NULL),
                         MLR_OK);
        const double out = rms(ro, 3, 8, n - 8), naive = rms(root, 12, 2, n - 2);
        fprintf(stderr, "alias %g Hz: LGS %.4f, decimation %.4f\n", freqs[k], out / in,
                naive / in);
        ck_assert_msg(out < 0.06 * in, "%g Hz: %.3f of the amplitude aliased", freqs[k], out / in);
        if (fmod(freqs[k], 30.0) != 0.0 && freqs[k] != 45.0)
            ck_assert_msg(naive > 0.5 * in, "%g Hz: decimation kept %.3f", freqs[k], naive / in);
    }
    /* passband: 2 Hz keeps > 97 % of its amplitude */
    for (size_t i = 0; i < N; i++)
        root[3 * i] = sin(2 * PI * 2.0 * (double)i / 120.0);
    ck_assert_int_eq(mlr_resample_arrays(N, 0, 0, root, NULL, NULL, NULL, n, MLR_RESAMPLE_AUTO,
                                         1.0, 0, ro, NULL, NULL, NULL, NULL, NULL),
                     MLR_OK);
    ck_assert(rms(ro, 3, 8, n - 8) > 0.97 * rms(root, 3, 32, N - 32));
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Real clips: 120 -> 30 -> 120 fps round trips, MPJPE                                        */

static const char *const clips_120[] = {
    "cmu_01_01_playground_jumps.bvh",
    "cmu_131_01_mj_style_walk.bvh",
    "cmu_10_01_soccer_kick.bvh",
    "cmu_60_10_salsa_dance.bvh",
};

static double mpjpe(size_t N, size_t J, const double *a, const double *b)
{
    double acc = 0.0;
    for (size_t i = 0; i < N * J; i++) {
        const double dx = a[3 * i] - b[3 * i], dy = a[3 * i + 1] - b[3 * i + 1],
                     dz = a[3 * i + 2] - b[3 * i + 2];
        acc += sqrt(dx * dx + dy * dy + dz * dz);
    }
    return acc / (double)(N * J);
}

/* The round trip through 30 fps keeps every joint within a small fraction of the body size:
 * MPJPE below 1 % of the skeleton's height (its vertical extent in the first kept frame; about
 * 1.7 cm for a 1.7 m person). Mocap carries little energy above the 30 fps passband (the gain is
 * > 0.9 below 4 Hz), so what is lost is the fast part of feet and hands in jumps and spins;
 * the SLERP round trip (decimation, then slerp) is reported alongside. */
START_TEST(real_clip_round_trip_120_30_120)
{
    char path[4096];
    MLR_TEST_NEED_CLIP(clips_120[_i]);
    mlr_test_clip_path(clips_120[_i], path, sizeof path);
    mlr_motion *full = NULL, *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &full, &d), MLR_OK);
    /* skip the converter's T-pose and blend frames */
    ck_assert_int_eq(mlr_motion_copy_frames(full, 6, mlr_motion_n_frames(full) - 6, &m, NULL),
                     MLR_OK);
    mlr_motion_destroy(full);
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m);
    const double fps = 1.0 / mlr_motion_frame_time(m);
    size_t n30;
    ck_assert_int_eq(mlr_resample_n_out(N, fps, 30.0, 0, &n30, &d), MLR_OK);
    ck_assert(fabs((double)(n30 - 1) - (double)(N - 1) / 4.0) <= 0.5 + 1e-3);

    double *r30 = malloc(n30 * 3 * sizeof(double)), *q30 = malloc(n30 * J * 4 * sizeof(double));
    double *p30 = malloc((n30 * P * 3 + 1) * sizeof(double));
    double *rb = malloc(N * 3 * sizeof(double)), *qb = malloc(N * J * 4 * sizeof(double));
    double *pb = malloc((N * P * 3 + 1) * sizeof(double));
    double *w0 = malloc(N * J * 3 * sizeof(double)), *w1 = malloc(N * J * 3 * sizeof(double));
    const double *root = mlr_motion_root_pos(m), *rot = mlr_motion_rot(m),
                 *tr = mlr_motion_trans(m);
    ck_assert_int_eq(mlr_fk_motion(m, 0, N, w0, NULL, NULL), MLR_OK);
    double ymin = INFINITY, ymax = -INFINITY;
    for (size_t j = 0; j < J; j++) {
        ymin = fmin(ymin, w0[3 * j + 1]);
        ymax = fmax(ymax, w0[3 * j + 1]);
    }
    const double height = ymax - ymin;

    double err[2];
    for (int method = 0; method < 2; method++) {
        mlr_status st;
        if (method == 0) {
            st = mlr_resample_arrays(N, J, P, root, rot, tr, NULL, n30, MLR_RESAMPLE_AUTO, 1.0, 0,
                                     r30, q30, p30, NULL, NULL, &d);
            ck_assert_int_eq(st, MLR_OK);
            st = mlr_resample_arrays(n30, J, P, r30, q30, p30, NULL, N, MLR_RESAMPLE_AUTO, 1.0, 0,
                                     rb, qb, pb, NULL, NULL, &d);
        } else {
            st =
                mlr_slerp_resample_arrays(N, J, P, root, rot, tr, NULL, n30, 0, r30, q30, p30, &d);
            ck_assert_int_eq(st, MLR_OK);
            st = mlr_slerp_resample_arrays(n30, J, P, r30, q30, p30, NULL, N, 0, rb, qb, pb, &d);
        }
        ck_assert_msg(st == MLR_OK, "%s", d.message);
        ck_assert_int_eq(mlr_fk_arrays(N, J, mlr_motion_parents(m), mlr_motion_offsets(m), rb, qb,
                                       P, mlr_motion_trans_joints(m), pb, w1, NULL, NULL, NULL),
                         MLR_OK);
        err[method] = mpjpe(N, J, w0, w1);
    }
    fprintf(stderr,
            "%s: %zu -> %zu -> %zu frames, height %.3f: MPJPE LGS %.4f (%.3f %%), "
            "SLERP %.4f (%.3f %%)\n",
            clips_120[_i], N, n30, N, height, err[0], 100 * err[0] / height, err[1],
            100 * err[1] / height);
    ck_assert_msg(err[0] < 0.01 * height, "MPJPE %g of height %g", err[0], height);
    free(r30), free(q30), free(p30), free(rb), free(qb), free(pb), free(w0), free(w1);
    mlr_motion_destroy(m);
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Time warping                                                                               */

/* One joint that turns slowly, then fast around frames 40..60, then slowly again. */
static void burst_motion(size_t N, double *root, double *rot)
{
    double ang = 0.0;
    for (size_t i = 0; i < N; i++) {
        const double x = ((double)i - 50.0) / 8.0;
        ang += 0.01 + 0.2 * exp(-x * x);
        axis_angle(0, 0, 1, ang, rot + 4 * i);
    }
    for (size_t i = 0; i < N * 3; i++)
        root[i] = 0.0;
}

START_TEST(timewarp_slows_large_motion_with_easing)
{
    const size_t N = 100, n = 130;
    double root[100 * 3], rot[100 * 4], t[100], speed[100];
    burst_motion(N, root, rot);
    ck_assert_int_eq(mlr_timewarp_speed(N, 1, root, rot, NULL, 0.0, speed, NULL), MLR_OK);
    ck_assert(speed[50] > 10 * speed[5]);
    ck_assert_close(speed[5], 0.01, 1e-3);
    mlr_diag d;
    ck_assert_int_eq(mlr_timewarp_map(N, 1, root, rot, NULL, 0.0, 1.0, 8.0, n, 0, t, NULL, &d),
                     MLR_OK);
    ck_assert(t[0] == 0.0 && t[N - 1] == (double)(n - 1));
    ck_assert_int_eq(mlr_timemap_validate(t, N, n, 0, NULL), MLR_OK);
    double smax = 0.0, dmax = 0.0;
    for (size_t i = 1; i < N; i++) {
        const double s = t[i] - t[i - 1];
        smax = fmax(smax, s);
        if (i > 1)
            dmax = fmax(dmax, fabs(s - (t[i - 1] - t[i - 2])));
    }
    const double s_burst = t[51] - t[50], s_calm = t[6] - t[5];
    ck_assert_msg(s_burst > 3 * s_calm, "burst %g calm %g", s_burst, s_calm);
    ck_assert(s_burst > 0.9 * smax);
    ck_assert_msg(dmax < 0.15 * smax, "the rate jumps by %g (max %g): no easing", dmax, smax);
    /* strength 0: uniform */
    ck_assert_int_eq(mlr_timewarp_map(N, 1, root, rot, NULL, 0.0, 0.0, 8.0, n, 0, t, NULL, NULL),
                     MLR_OK);
    for (size_t i = 0; i < N; i++)
        ck_assert_close(t[i], (double)i * (double)(n - 1) / (double)(N - 1), 1e-9);
    /* and the warp drives the resampler */
    ck_assert_int_eq(mlr_timewarp_map(N, 1, root, rot, NULL, 0.0, 1.5, 8.0, n, 0, t, NULL, NULL),
                     MLR_OK);
    double ro[130 * 3], qo[130 * 4];
    ck_assert_int_eq(mlr_resample_arrays(N, 1, 0, root, rot, NULL, t, n, MLR_RESAMPLE_AUTO, 1.0, 0,
                                         ro, qo, NULL, NULL, NULL, NULL),
                     MLR_OK);
}
END_TEST

/* On a real kick: a valid map, slowest around the fastest part of the clip. */
START_TEST(timewarp_real_clip)
{
    char path[4096];
    MLR_TEST_NEED_CLIP("cmu_10_01_soccer_kick.bvh");
    mlr_test_clip_path("cmu_10_01_soccer_kick.bvh", path, sizeof path);
    mlr_motion *full = NULL, *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &full, NULL), MLR_OK);
    ck_assert_int_eq(mlr_motion_copy_frames(full, 6, mlr_motion_n_frames(full) - 6, &m, NULL),
                     MLR_OK);
    mlr_motion_destroy(full);
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m), n = N * 5 / 4;
    double *t = malloc(N * sizeof(double)), *speed = malloc(N * sizeof(double));
    ck_assert_int_eq(mlr_timewarp_speed(N, J, mlr_motion_root_pos(m), mlr_motion_rot(m), NULL,
                                        0.05, speed, NULL),
                     MLR_OK);
    mlr_diag d;
    ck_assert_msg(mlr_timewarp_map(N, J, mlr_motion_root_pos(m), mlr_motion_rot(m), NULL, 0.05,
                                   1.0, 30.0, n, 0, t, NULL, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_int_eq(mlr_timemap_validate(t, N, n, 0, NULL), MLR_OK);
    size_t fast = 1, slow = 1;
    for (size_t i = 1; i < N; i++) {
        if (t[i] - t[i - 1] > t[slow] - t[slow - 1])
            slow = i;
        if (speed[i] > speed[fast])
            fast = i;
    }
    ck_assert_msg(labs((long)slow - (long)fast) < 60, "slowest at %zu, fastest motion at %zu",
                  slow, fast);
    free(t), free(speed);
    mlr_motion_destroy(m);
}
END_TEST

/* ---------------------------------------------------------------------------------------- */
/* Bad input and allocation failures                                                          */

START_TEST(bad_input_is_rejected_with_a_reason)
{
    double root[6 * 3] = {0}, rot[6 * 4], t[6] = {0, 1, 2, 3, 4, 5}, ro[400 * 3], qo[400 * 4];
    for (size_t i = 0; i < 6; i++)
        axis_angle(0, 1, 0, 0.1 * (double)i, rot + 4 * i);
    size_t n;
    mlr_diag d;
#define BAD(call)                                                    \
    do {                                                             \
        d.message[0] = 0;                                            \
        ck_assert_int_eq((call), MLR_E_INVALID_ARG);                 \
        ck_assert_msg(d.message[0] != 0, "no reason for %s", #call); \
    } while (0)
    BAD(mlr_resample_n_out(6, 0.0, 30.0, 0, &n, &d));
    BAD(mlr_resample_n_out(6, 120.0, -30.0, 0, &n, &d));
    BAD(mlr_resample_n_out(6, NAN, 30.0, 0, &n, &d));
    BAD(mlr_resample_n_out(6, 120.0, INFINITY, 0, &n, &d));
    BAD(mlr_resample_n_out(1, 120.0, 30.0, 0, &n, &d));
    BAD(mlr_resample_n_out(6, 1.0, 101.0, 0, &n, &d));
    BAD(mlr_resample_n_out(6, 120.0, 30.0, 8u, &n, &d));
    ck_assert_int_eq(mlr_resample_n_out(6, 1.0, 101.0, MLR_RESAMPLE_ALLOW_EXTREME, &n, &d),
                     MLR_OK);
    ck_assert_uint_eq(n, 506);
    {
        /* the exact grid: an input shorter than one output frame, NULL outputs, open ends */
        double tm[6] = {0}, tt[6];
        BAD(mlr_resample_n_out(3, 120.0, 30.0, MLR_RESAMPLE_OPEN_END, &n, &d));
        ck_assert_ptr_nonnull(strstr(d.message, "less than one frame"));
        BAD(mlr_resample_rate_map(3, 120.0, 30.0, 0, tm, &n, &d));
        BAD(mlr_resample_rate_map(6, 120.0, 30.0, 0, NULL, &n, &d));
        BAD(mlr_resample_rate_map(6, 120.0, 30.0, 0, tm, NULL, &d));
        BAD(mlr_resample_rate_map(6, 120.0, 0.0, 0, tm, &n, &d));
        ck_assert_int_eq(mlr_resample_rate_map(6, 120.0, 30.0, 0, tm, &n, &d), MLR_OK);
        ck_assert_uint_eq(n, 2); /* t[5] = 1.25 */
        ck_assert_int_eq(mlr_timemap_validate(tm, 6, 2, MLR_RESAMPLE_OPEN_END, &d), MLR_OK);
        BAD(mlr_timemap_validate(tm, 6, 2, 0, &d)); /* without the flag the end must be 1 */
        for (int i = 0; i < 6; i++)
            tt[i] = 0.5 * i; /* t[5] = 2.5: n_out 3 fits, 2 (beyond by 1.5) and 4 (short) not */
        ck_assert_int_eq(mlr_timemap_validate(tt, 6, 3, MLR_RESAMPLE_OPEN_END, &d), MLR_OK);
        BAD(mlr_timemap_validate(tt, 6, 2, MLR_RESAMPLE_OPEN_END, &d));
        ck_assert_ptr_nonnull(strstr(d.message, "open end"));
        BAD(mlr_timemap_validate(tt, 6, 4, MLR_RESAMPLE_OPEN_END, &d));
        /* a value a hair below an integer counts as that integer */
        ck_assert_int_eq(mlr_resample_n_out(301, 3.0, 1.0 - 1e-13, MLR_RESAMPLE_OPEN_END, &n, &d),
                         MLR_OK);
        ck_assert_uint_eq(n, 101);
    }
    ck_assert_int_eq(mlr_resample_n_out(6, 1.0, 100.0, 0, &n, &d), MLR_OK);
    /* fewer than 2 frames, factor, NULLs, lam, sigma */
    BAD(mlr_resample_arrays(1, 1, 0, root, rot, NULL, NULL, 5, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 1, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 502, -1, 1, 0, ro, qo, NULL, NULL,
                            NULL, &d));
    BAD(mlr_slerp_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 502, 0, ro, qo, NULL, &d));
    BAD(mlr_resample_arrays(6, 1, 0, NULL, rot, NULL, NULL, 10, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, NULL, NULL, NULL, 10, -1, 1, 0, ro, qo, NULL, NULL,
                            NULL, &d));
    BAD(mlr_resample_arrays(6, 1, 2, root, rot, NULL, NULL, 10, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, NAN, 1, 0, ro, qo, NULL, NULL,
                            NULL, &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, -1, 0, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, -1, 1, 8u, ro, qo, NULL, NULL,
                            NULL, &d));
    /* time maps: non-monotone, not finite, ends not in place, local factor */
    double tm[6];
    memcpy(tm, t, sizeof t);
    tm[3] = 1.5;
    BAD(mlr_timemap_validate(tm, 6, 6, 0, &d));
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, tm, 6, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_slerp_resample_arrays(6, 1, 0, root, rot, NULL, tm, 6, 0, ro, qo, NULL, &d));
    tm[3] = 2.0; /* a tie */
    BAD(mlr_timemap_validate(tm, 6, 6, 0, &d));
    tm[3] = NAN;
    BAD(mlr_timemap_validate(tm, 6, 6, 0, &d));
    memcpy(tm, t, sizeof t);
    tm[0] = 0.5;
    BAD(mlr_timemap_validate(tm, 6, 6, 0, &d));
    memcpy(tm, t, sizeof t);
    BAD(mlr_timemap_validate(tm, 6, 7, 0, &d));
    BAD(mlr_timemap_validate(NULL, 6, 6, 0, &d));
    double big[3] = {0, 0.001, 150};
    BAD(mlr_timemap_validate(big, 3, 151, 0, &d));
    ck_assert_int_eq(mlr_timemap_validate(big, 3, 151, MLR_RESAMPLE_ALLOW_EXTREME, &d), MLR_OK);
    /* NaN and zero quaternions in the data */
    root[7] = NAN;
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_slerp_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, 0, ro, qo, NULL, &d));
    BAD(mlr_timewarp_speed(6, 1, root, rot, NULL, 1.0, ro, &d));
    root[7] = 0.0;
    rot[9] = INFINITY;
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    rot[8] = rot[9] = rot[10] = rot[11] = 0.0;
    BAD(mlr_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, -1, 1, 0, ro, qo, NULL, NULL, NULL,
                            &d));
    BAD(mlr_slerp_resample_arrays(6, 1, 0, root, rot, NULL, NULL, 10, 0, ro, qo, NULL, &d));
    axis_angle(0, 1, 0, 0.2, rot + 8);
    /* time warp parameters */
    double tw[6], w[1] = {-1.0};
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, -0.5, 3.0, 8, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, 11.0, 3.0, 8, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, NAN, 3.0, 8, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, 1.0, 0.5, 8, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, -1.0, 1.0, 3.0, 8, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, w, 0.0, 1.0, 3.0, 8, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, 1.0, 3.0, 1, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, 1.0, 3.0, 700, 0, tw, NULL, &d));
    BAD(mlr_timewarp_map(1, 1, root, rot, NULL, 0.0, 1.0, 3.0, 8, 0, tw, NULL, &d));
    ck_assert_int_eq(mlr_timewarp_map(6, 1, root, rot, NULL, 0.0, 1.0, 3.0, 8, 0, tw, NULL, &d),
                     MLR_OK);
#undef BAD
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    const size_t N = 40, J = 3, P = 1;
    double root[40 * 3], rot[40 * 3 * 4], trans[40 * 3], t[40];
    double ro[90 * 3], qo[90 * 3 * 4], to[90 * 3], var[90];
    smooth_motion(N, J, P, 9, root, rot, trans);
    double tr[40];
    size_t n_rate = 0;
    ck_assert_int_eq(mlr_resample_rate_map(N, 1.0, 1.9, 0, tr, &n_rate, NULL), MLR_OK);
    ck_assert(tr[N - 1] > (double)(n_rate - 1)); /* a hidden frame */
    for (int which = 0; which < 4; which++) {
        size_t fail_at;
        for (fail_at = 0;; fail_at++) {
            mlr_test_allocator ta;
            mlr_test_allocator_init(&ta, fail_at);
            mlr_status s;
            if (which == 0)
                s = mlr_resample_arrays(N, J, P, root, rot, trans, NULL, 90, MLR_RESAMPLE_AUTO,
                                        1.0, 0, ro, qo, to, var, &ta.base, NULL);
            else if (which == 1)
                s = mlr_resample_arrays(N, J, P, root, rot, trans, NULL, N, MLR_RESAMPLE_AUTO, 1.0,
                                        0, ro, qo, to, var, &ta.base, NULL);
            else if (which == 2)
                s = mlr_timewarp_map(N, J, root, rot, NULL, 0.1, 1.0, 5.0, 60, 0, t, &ta.base,
                                     NULL);
            else
                s = mlr_resample_arrays(N, J, P, root, rot, trans, tr, n_rate, MLR_RESAMPLE_AUTO,
                                        1.0, MLR_RESAMPLE_OPEN_END, ro, qo, to, var, &ta.base,
                                        NULL);
            ck_assert_uint_eq(ta.live_blocks, 0);
            if (s == MLR_OK)
                break;
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        }
        ck_assert_uint_gt(fail_at, 0);
    }
}
END_TEST

static Suite *resample_suite(void)
{
    Suite *s = suite_create("resample");
    TCase *num = tcase_create("numerics");
    tcase_add_loop_test(num, matches_dense_reference, 0, (int)MLR_COUNTOF(dense_cases));
    tcase_add_test(num, identity_with_weak_smoothing);
    tcase_add_test(num, predictive_sign_follows_a_growing_spin);
    tcase_add_test(num, predictive_sign_limits);
    tcase_add_test(num, sparse_spin_keys_lgs_versus_slerp);
    tcase_add_test(num, variance_grows_where_sparse);
    tcase_add_test(num, downsampling_does_not_alias);
    tcase_add_test(num, timewarp_slows_large_motion_with_easing);
    tcase_add_test(num, exact_rate_frames_lie_at_their_times);
    tcase_add_test(num, cuts_of_one_clip_agree_at_the_same_times);
    suite_add_tcase(s, num);
    TCase *clips = tcase_create("clips");
    tcase_set_timeout(clips, 120);
    tcase_add_loop_test(clips, real_clip_round_trip_120_30_120, 0, (int)MLR_COUNTOF(clips_120));
    tcase_add_test(clips, timewarp_real_clip);
    suite_add_tcase(s, clips);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, bad_input_is_rejected_with_a_reason);
    tcase_add_test(args, every_allocation_failure_is_clean);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(resample_suite()); }
