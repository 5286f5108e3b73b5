/* LGS posterior mean and variance against a dense solve of the normal equations built inside
 * the test; the CHOLMOD path against the banded one; bad input. */
#include "mlr_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Dense (lam^2 L^T L + A^T A / sigma^2) and A^T y / sigma^2, then Gauss elimination. */
static void dense_lgs(size_t n_out, unsigned order, double lam, double sigma, const double *t,
                      size_t n_obs, const double *y, size_t m, double *x, double *var)
{
    double *M = calloc(n_out * n_out, sizeof *M), *B = calloc(n_out * m, sizeof *B);
    double *Inv = calloc(n_out * n_out, sizeof *Inv);
    const double c[3][3] = {{1, 0, 0}, {-1, 1, 0}, {1, -2, 1}};
    for (size_t r = 0; r + order < n_out; r++)        /* rows of L */
        for (size_t a = 0; a <= order; a++)
            for (size_t b = 0; b <= order; b++)
                M[(r + a) * n_out + r + b] += lam * lam * c[order][a] * c[order][b];
    for (size_t i = 0; i < n_obs; i++) {              /* rows of A */
        double w[2];
        size_t lo;
        if (t) {
            lo = (size_t)floor(t[i]);
            if (lo > n_out - 2)
                lo = n_out - 2;
            w[1] = t[i] - (double)lo;
            w[0] = 1.0 - w[1];
        } else {
            lo = i;
            w[0] = 1.0, w[1] = 0.0;
        }
        for (size_t a = 0; a < 2; a++) {
            if (lo + a >= n_out)
                continue;
            for (size_t b = 0; b < 2; b++)
                if (lo + b < n_out)
                    M[(lo + a) * n_out + lo + b] += w[a] * w[b] / (sigma * sigma);
            for (size_t k = 0; k < m; k++)
                B[(lo + a) * m + k] += w[a] * y[i * m + k] / (sigma * sigma);
        }
    }
    for (size_t i = 0; i < n_out; i++)
        Inv[i * n_out + i] = 1.0;
    /* Gauss-Jordan without pivoting (M is SPD) on [M | B | I] */
    for (size_t p = 0; p < n_out; p++) {
        double d = M[p * n_out + p];
        for (size_t r = 0; r < n_out; r++) {
            if (r == p)
                continue;
            double f = M[r * n_out + p] / d;
            if (f == 0.0)
                continue;
            for (size_t k = 0; k < n_out; k++) {
                M[r * n_out + k] -= f * M[p * n_out + k];
                Inv[r * n_out + k] -= f * Inv[p * n_out + k];
            }
            for (size_t k = 0; k < m; k++)
                B[r * m + k] -= f * B[p * m + k];
        }
    }
    for (size_t i = 0; i < n_out; i++) {
        double d = M[i * n_out + i];
        for (size_t k = 0; k < m; k++)
            x[i * m + k] = B[i * m + k] / d;
        if (var)
            var[i] = Inv[i * n_out + i] / d;
    }
    free(M), free(B), free(Inv);
}

enum { T_IDENTITY, T_UNIFORM, T_RANDOM, T_SPARSE_KEYS };
static const struct {
    size_t n_out, n_obs, m;
    unsigned order;
    double lam, sigma;
    int tkind;
} cases[] = {
    {50, 50, 1, 2, 1.0, 1.0, T_IDENTITY},  {50, 50, 3, 1, 2.0, 0.5, T_IDENTITY},
    {64, 64, 5, 2, 10.0, 0.1, T_IDENTITY}, {3, 3, 2, 2, 1.0, 1.0, T_IDENTITY},
    {40, 10, 2, 2, 1.0, 1.0, T_UNIFORM},   {40, 10, 1, 1, 0.3, 1.0, T_UNIFORM},
    {30, 90, 4, 2, 5.0, 0.2, T_UNIFORM},   {45, 30, 3, 2, 1.0, 2.0, T_RANDOM},
    {45, 30, 3, 1, 1.0, 2.0, T_RANDOM},    {40, 8, 2, 2, 0.5, 0.01, T_SPARSE_KEYS},
    {20, 20, 2, 2, 0.0, 1.0, T_IDENTITY},
};

static double *make_t(mlr_test_rng *r, int kind, size_t n_out, size_t n_obs)
{
    if (kind == T_IDENTITY)
        return NULL;
    double *t = malloc(n_obs * sizeof *t);
    double span = (double)(n_out - 1);
    for (size_t i = 0; i < n_obs; i++) {
        if (kind == T_RANDOM)
            t[i] = span * mlr_test_rng_uniform(r);
        else
            t[i] = span * (double)i / (double)(n_obs - 1);
    }
    if (kind == T_RANDOM) { /* sort, and pin both ends */
        for (size_t i = 1; i < n_obs; i++)
            for (size_t j = i; j > 0 && t[j] < t[j - 1]; j--) {
                double tmp = t[j];
                t[j] = t[j - 1], t[j - 1] = tmp;
            }
        t[0] = 0.0, t[n_obs - 1] = span;
    }
    return t;
}

START_TEST(mean_and_variance_match_dense)
{
    const size_t n_out = cases[_i].n_out, n_obs = cases[_i].n_obs, m = cases[_i].m;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 77 + (uint64_t)_i);
    double *t = make_t(&r, cases[_i].tkind, n_out, n_obs);
    double *y = malloc(n_obs * m * sizeof *y), *x = malloc(n_out * m * sizeof *x);
    double *xr = malloc(n_out * m * sizeof *xr), *var = malloc(n_out * sizeof *var);
    double *varr = malloc(n_out * sizeof *varr);
    for (size_t i = 0; i < n_obs * m; i++)
        y[i] = sin(0.1 * (double)i) + mlr_test_rng_normal(&r);
    mlr_lgs *g = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_lgs_create(n_out, cases[_i].order, cases[_i].lam, cases[_i].sigma, t,
                                    n_obs, MLR_LGS_BANDED, NULL, &g, &d),
                     MLR_OK);
    ck_assert_uint_eq(mlr_lgs_n_out(g), n_out);
    ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, x, m, NULL), MLR_OK);
    ck_assert_int_eq(mlr_lgs_variance(g, var, n_out, NULL), MLR_OK);
    dense_lgs(n_out, cases[_i].order, cases[_i].lam, cases[_i].sigma, t, n_obs, y, m, xr, varr);
    for (size_t i = 0; i < n_out * m; i++)
        ck_assert_close(x[i], xr[i], 1e-9 * (1.0 + fabs(xr[i])));
    for (size_t i = 0; i < n_out; i++)
        ck_assert_close(var[i], varr[i], 1e-9 * varr[i]);
    mlr_lgs_destroy(g);
    free(t), free(y), free(x), free(xr), free(var), free(varr);
}
END_TEST

START_TEST(in_place_identity_solve)
{
    const size_t n = 30, m = 2;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 5);
    double y[60], x[60];
    for (size_t i = 0; i < n * m; i++)
        y[i] = mlr_test_rng_normal(&r);
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(n, 2, 3.0, 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, x, m, NULL), MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, y, m, NULL), MLR_OK);
    for (size_t i = 0; i < n * m; i++)
        ck_assert_close(x[i], y[i], 0.0);
    mlr_lgs_destroy(g);
}
END_TEST

START_TEST(smoothing_keeps_lines_for_order_2)
{
    /* the second-difference prior does not penalise a straight line: it passes unchanged */
    const size_t n = 100;
    double y[100], x[100];
    for (size_t i = 0; i < n; i++)
        y[i] = 3.0 - 0.25 * (double)i;
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(n, 2, 1e3, 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(g, y, 1, 1, x, 1, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert_close(x[i], y[i], 1e-8);
    mlr_lgs_destroy(g);
}
END_TEST

/* A build without CHOLMOD (the Python wheels) refuses the solver with a message saying how to
 * get it; a build with it accepts the same call. */
START_TEST(cholmod_solver_matches_the_build)
{
    mlr_lgs *g = (mlr_lgs *)&g; /* not NULL: create must reset it */
    mlr_diag d = {0};
    mlr_status st = mlr_lgs_create(20, 2, 1.0, 1.0, NULL, 20, MLR_LGS_CHOLMOD, NULL, &g, &d);
    if (mlr_lgs_have_cholmod()) {
        ck_assert_int_eq(st, MLR_OK);
        ck_assert_ptr_nonnull(g);
        mlr_lgs_destroy(g);
    } else {
        ck_assert_int_eq(st, MLR_E_UNSUPPORTED);
        ck_assert_ptr_null(g);
        ck_assert_msg(strstr(d.message, "-Dcholmod=enabled"), "message: %s", d.message);
    }
}
END_TEST

START_TEST(cholmod_agrees_with_banded)
{
    if (!mlr_lgs_have_cholmod())
        return;
    const size_t n_out = cases[_i].n_out, n_obs = cases[_i].n_obs, m = cases[_i].m;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 99 + (uint64_t)_i);
    double *t = make_t(&r, cases[_i].tkind, n_out, n_obs);
    double *y = malloc(n_obs * m * sizeof *y), *xb = malloc(n_out * m * sizeof *xb);
    double *xs = malloc(n_out * m * sizeof *xs), scale = 0.0;
    for (size_t i = 0; i < n_obs * m; i++)
        y[i] = mlr_test_rng_normal(&r);
    mlr_lgs *gb = NULL, *gs = NULL;
    ck_assert_int_eq(mlr_lgs_create(n_out, cases[_i].order, cases[_i].lam, cases[_i].sigma, t,
                                    n_obs, MLR_LGS_BANDED, NULL, &gb, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_create(n_out, cases[_i].order, cases[_i].lam, cases[_i].sigma, t,
                                    n_obs, MLR_LGS_CHOLMOD, NULL, &gs, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(gb, y, m, m, xb, m, NULL), MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(gs, y, m, m, xs, m, NULL), MLR_OK);
    for (size_t i = 0; i < n_out * m; i++)
        scale = fmax(scale, fabs(xb[i]));
    for (size_t i = 0; i < n_out * m; i++)
        ck_assert_close(xs[i], xb[i], 1e-10 * scale);
    double *v = malloc(n_out * sizeof *v);
    ck_assert_int_eq(mlr_lgs_variance(gs, v, n_out, NULL), MLR_E_UNSUPPORTED);
    free(v);
    mlr_lgs_destroy(gb);
    mlr_lgs_destroy(gs);
    free(t), free(y), free(xb), free(xs);
}
END_TEST

START_TEST(rejects_bad_parameters)
{
    static char sentinel;
    double t_unsorted[3] = {0, 2, 1}, t_out[3] = {0, 1, 9}, t_nan[3] = {0, NAN, 2};
    double t_same[3] = {1, 1, 1};
    struct {
        size_t n_out, n_obs;
        unsigned order;
        double lam, sigma;
        const double *t;
        mlr_status want;
    } bad[] = {
        {10, 10, 3, 1, 1, NULL, MLR_E_INVALID_ARG},     /* order */
        {10, 10, 0, 1, 1, NULL, MLR_E_INVALID_ARG},
        {10, 10, 2, -1, 1, NULL, MLR_E_INVALID_ARG},    /* lam < 0 */
        {10, 10, 2, NAN, 1, NULL, MLR_E_INVALID_ARG},
        {10, 10, 2, 1, 0, NULL, MLR_E_INVALID_ARG},     /* sigma <= 0 */
        {10, 10, 2, 1, INFINITY, NULL, MLR_E_INVALID_ARG},
        {2, 2, 2, 1, 1, NULL, MLR_E_INVALID_ARG},       /* too few frames */
        {10, 9, 2, 1, 1, NULL, MLR_E_INVALID_ARG},      /* identity needs n_obs == n_out */
        {10, 3, 2, 1, 1, t_unsorted, MLR_E_INVALID_ARG},
        {5, 3, 2, 1, 1, t_out, MLR_E_INVALID_ARG},
        {10, 3, 2, 1, 1, t_nan, MLR_E_INVALID_ARG},
        {10, 3, 2, 1, 1, t_same, MLR_E_SINGULAR},       /* one position cannot pin a line */
        {10, 3, 2, 0, 1, t_out, MLR_E_SINGULAR},        /* lam = 0 with unobserved frames */
    };
    for (size_t k = 0; k < MLR_COUNTOF(bad); k++) {
        mlr_lgs *g = (mlr_lgs *)&sentinel;
        mlr_diag d = {0, 0, ""};
        mlr_status s = mlr_lgs_create(bad[k].n_out, bad[k].order, bad[k].lam, bad[k].sigma,
                                      bad[k].t, bad[k].n_obs, MLR_LGS_BANDED, NULL, &g, &d);
        ck_assert_msg(s == bad[k].want, "case %zu: got %s (%s)", k, mlr_status_name(s), d.message);
        ck_assert_ptr_null(g);
        ck_assert_msg(d.message[0] != '\0', "case %zu has no diagnostic", k);
    }
}
END_TEST

START_TEST(non_finite_observations_are_rejected)
{
    const size_t n = 20;
    double y[40], x[40];
    for (size_t i = 0; i < 2 * n; i++)
        y[i] = 1.0;
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(n, 2, 1.0, 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     MLR_OK);
    y[2 * 7 + 1] = NAN;
    ck_assert_int_eq(mlr_lgs_solve(g, y, 2, 2, x, 2, NULL), MLR_E_INVALID_ARG);
    y[2 * 7 + 1] = INFINITY;
    ck_assert_int_eq(mlr_lgs_solve(g, y, 2, 2, x, 2, NULL), MLR_E_INVALID_ARG);
    y[2 * 7 + 1] = 1.0;
    ck_assert_int_eq(mlr_lgs_solve(g, y, 2, 2, x, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(g, y, 1, 2, x, 2, NULL), MLR_E_INVALID_ARG); /* ldy < m */
    ck_assert_int_eq(mlr_lgs_solve(g, NULL, 2, 2, x, 2, NULL), MLR_E_INVALID_ARG);
    mlr_lgs_destroy(g);
}
END_TEST

/* The same on a problem long enough for the chunked single-pass solve: a NaN or inf in the
 * first, a middle or the last row, in any channel, is reported. */
START_TEST(non_finite_observations_are_rejected_when_chunked)
{
    const size_t n = 20000, m = 16;
    double *y = malloc(n * m * sizeof *y), *x = malloc(n * m * sizeof *x);
    for (size_t i = 0; i < n * m; i++)
        y[i] = sin(0.001 * (double)i);
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(n, 2, 4.0, 1.0, NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, x, m, NULL), MLR_OK);
    const size_t rows[] = {0, n / 3, n / 2 + 7, n - 2, n - 1};
    const double bad[] = {NAN, INFINITY, -INFINITY};
    for (size_t r = 0; r < MLR_COUNTOF(rows); r++) {
        for (size_t b = 0; b < MLR_COUNTOF(bad); b++) {
            const size_t at = rows[r] * m + (r * 5 + b) % m;
            const double keep = y[at];
            y[at] = bad[b];
            ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, x, m, NULL), MLR_E_INVALID_ARG);
            y[at] = keep;
        }
    }
    mlr_lgs_destroy(g);
    free(y), free(x);
}
END_TEST

/* With the page-mapping helper (outputs over 8 MiB), every thread count gives the bits of the
 * plain solve: into new memory, at an odd offset and stride, in place, with interpolation rows,
 * and a NaN is still reported. */
START_TEST(helper_thread_changes_no_bits)
{
    const size_t n = 70000, m = 16, ld = 19; /* x spans 8.96 MB (10.1 MB strided) */
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 808);
    double *y = malloc(n * m * sizeof *y), *ref = malloc(n * m * sizeof *ref);
    double acc = 0.0;
    for (size_t i = 0; i < n * m; i++)
        y[i] = (acc += 0.01 * mlr_test_rng_normal(&r)) + mlr_test_rng_normal(&r);
    double *t = malloc(n * sizeof *t);
    for (size_t i = 0; i < n; i++)
        t[i] = (double)i * (double)(n - 1) / (double)n + 0.3 * mlr_test_rng_uniform(&r);
    for (int interp = 0; interp < 2; interp++) {
        mlr_lgs *g = NULL;
        ck_assert_int_eq(
            mlr_lgs_create(n, 2, 3.0, 1.0, interp ? t : NULL, n, MLR_LGS_BANDED, NULL, &g, NULL),
            MLR_OK);
        ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, ref, m, NULL), MLR_OK);
        for (size_t threads = 0; threads < 4; threads++) {
            double *x = malloc(n * m * sizeof *x); /* new pages each time */
            ck_assert_int_eq(mlr_lgs_solve_mt(g, y, m, m, x, m, threads, NULL), MLR_OK);
            ck_assert_msg(memcmp(x, ref, n * m * sizeof *x) == 0, "threads %zu", threads);
            free(x);
            double *xs = malloc((n * ld + 1) * sizeof *xs), *x1 = xs + 1; /* odd offset */
            ck_assert_int_eq(mlr_lgs_solve_mt(g, y, m, m, x1, ld, threads, NULL), MLR_OK);
            for (size_t i = 0; i < n; i++)
                ck_assert_msg(memcmp(x1 + i * ld, ref + i * m, m * sizeof *x1) == 0,
                              "threads %zu, row %zu", threads, i);
            if (!interp) {
                double *yy = malloc(n * m * sizeof *yy);
                memcpy(yy, y, n * m * sizeof *yy);
                ck_assert_int_eq(mlr_lgs_solve_mt(g, yy, m, m, yy, m, threads, NULL), MLR_OK);
                ck_assert(memcmp(yy, ref, n * m * sizeof *yy) == 0);
                free(yy);
            }
            const double keep = y[(n / 2) * m + 3];
            y[(n / 2) * m + 3] = NAN;
            ck_assert_int_eq(mlr_lgs_solve_mt(g, y, m, m, x1, ld, threads, NULL),
                             MLR_E_INVALID_ARG);
            y[(n / 2) * m + 3] = keep;
            free(xs);
        }
        mlr_lgs_destroy(g);
    }
    free(y), free(ref), free(t);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    double t[5] = {0, 2, 4.5, 7, 9};
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_lgs *g = NULL;
        mlr_status s = mlr_lgs_create(10, 2, 1.0, 1.0, t, 5, MLR_LGS_BANDED, &ta.base, &g, NULL);
        double var[10];
        if (s == MLR_OK) {
            mlr_status sv = mlr_lgs_variance(g, var, 10, NULL);
            ck_assert(sv == MLR_OK || sv == MLR_E_NO_MEMORY);
        }
        mlr_lgs_destroy(g);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK && fail_at > 8)
            break;
        if (s != MLR_OK) {
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
            ck_assert_ptr_null(g);
        }
    }
}
END_TEST

START_TEST(variance_grows_between_sparse_keys)
{
    const size_t n_out = 41;
    double t[5] = {0, 10, 20, 30, 40}, var[41];
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(n_out, 2, 1.0, 0.1, t, 5, MLR_LGS_BANDED, NULL, &g, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_variance(g, var, n_out, NULL), MLR_OK);
    ck_assert(var[15] > 10.0 * var[10]);   /* mid-gap far less certain than at a key */
    ck_assert(var[20] < var[19]);
    mlr_lgs_destroy(g);
}
END_TEST

/* Large problems take the chunked single-pass path (many channels, n >> chunk); the same
 * problem solved one channel at a time takes the plain two-sweep path: both must agree. */
static const struct {
    size_t n, m;
    unsigned order;
    double lam;
    int interp;
} big[] = {
    {6000, 64, 2, 4.0, 0},  {6000, 64, 1, 4.0, 0},    {7000, 48, 2, 1.0, 1},
    {7001, 96, 2, 30.0, 0}, {6000, 64, 2, 3000.0, 0}, /* the last decays too slowly: fallback */
};

START_TEST(chunked_solve_matches_column_by_column)
{
    const size_t n = big[_i].n, m = big[_i].m;
    const size_t n_obs = big[_i].interp ? n + n / 3 : n;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4242 + (uint64_t)_i);
    double *t = NULL;
    if (big[_i].interp) {
        t = malloc(n_obs * sizeof *t);
        for (size_t i = 0; i < n_obs; i++)
            t[i] = (double)(n - 1) * (double)i / (double)(n_obs - 1);
    }
    double *y = malloc(n_obs * m * sizeof *y), *x = malloc(n * m * sizeof *x);
    double *col = malloc(n_obs * sizeof *col), *xc = malloc(n * sizeof *xc);
    for (size_t c = 0; c < m; c++) {
        double acc = 0.0;
        for (size_t i = 0; i < n_obs; i++) {
            acc += mlr_test_rng_normal(&r);
            y[i * m + c] = acc;
        }
    }
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(n, big[_i].order, big[_i].lam, 1.0, t, n_obs, MLR_LGS_BANDED,
                                    NULL, &g, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, x, m, NULL), MLR_OK);
    for (size_t c = 0; c < m; c++) {
        double scale = 0.0;
        for (size_t i = 0; i < n_obs; i++)
            col[i] = y[i * m + c];
        ck_assert_int_eq(mlr_lgs_solve(g, col, 1, 1, xc, 1, NULL), MLR_OK);
        for (size_t i = 0; i < n; i++)
            scale = fmax(scale, fabs(xc[i]));
        for (size_t i = 0; i < n; i++)
            ck_assert_close(x[i * m + c], xc[i], 1e-12 * scale);
    }
    /* into a strided output: the same bits */
    const size_t ldw = m + 3;
    double *w = malloc(n * ldw * sizeof *w);
    ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, w, ldw, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        for (size_t c = 0; c < m; c++)
            ck_assert_close(w[i * ldw + c], x[i * m + c], 0.0);
    /* without memory for the solver's ring buffer: the two-sweep path, the same values */
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_lgs *gf = NULL;
    ck_assert_int_eq(mlr_lgs_create(n, big[_i].order, big[_i].lam, 1.0, t, n_obs, MLR_LGS_BANDED,
                                    &ta.base, &gf, NULL),
                     MLR_OK);
    const size_t calls = ta.n_calls, live = ta.live_blocks;
    ck_assert_int_eq(mlr_lgs_solve(gf, y, m, m, w, m, NULL), MLR_OK); /* ring freed again */
    ck_assert_uint_eq(ta.live_blocks, live);
    for (size_t i = 0; i < n * m; i++)
        ck_assert_close(w[i], x[i], 0.0);
    if (ta.n_calls > calls) { /* the chunked path asked for its ring: now refuse it */
        ta.fail_at = ta.n_calls;
        ck_assert_int_eq(mlr_lgs_solve(gf, y, m, m, w, m, NULL), MLR_OK);
        ck_assert_uint_eq(ta.live_blocks, live);
        double scale = 0.0;
        for (size_t i = 0; i < n * m; i++)
            scale = fmax(scale, fabs(x[i]));
        for (size_t i = 0; i < n * m; i++)
            ck_assert_close(w[i], x[i], 1e-12 * scale);
    }
    mlr_lgs_destroy(gf);
    free(w);
    if (!big[_i].interp) { /* in place gives the same bits as out of place */
        ck_assert_int_eq(mlr_lgs_solve(g, y, m, m, y, m, NULL), MLR_OK);
        for (size_t i = 0; i < n * m; i++)
            ck_assert_close(y[i], x[i], 0.0);
    }
    mlr_lgs_destroy(g);
    free(t), free(y), free(x), free(col), free(xc);
}
END_TEST

static Suite *lgs_suite(void)
{
    Suite *s = suite_create("lgs");
    TCase *num = tcase_create("numerics");
    tcase_add_loop_test(num, mean_and_variance_match_dense, 0, (int)MLR_COUNTOF(cases));
    tcase_add_test(num, in_place_identity_solve);
    tcase_add_test(num, smoothing_keeps_lines_for_order_2);
    tcase_add_loop_test(num, cholmod_agrees_with_banded, 0, (int)MLR_COUNTOF(cases));
    tcase_add_test(num, cholmod_solver_matches_the_build);
    tcase_add_test(num, variance_grows_between_sparse_keys);
    tcase_add_loop_test(num, chunked_solve_matches_column_by_column, 0, (int)MLR_COUNTOF(big));
    tcase_add_test(num, non_finite_observations_are_rejected_when_chunked);
    tcase_add_test(num, helper_thread_changes_no_bits);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, rejects_bad_parameters);
    tcase_add_test(args, non_finite_observations_are_rejected);
    tcase_add_test(args, every_allocation_failure_is_clean);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(lgs_suite()); }
