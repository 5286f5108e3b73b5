/* Banded LDL^T: against a dense Cholesky solve inside the test, inverse diagonal against the
 * dense inverse, bad input, allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdlib.h>

/* Random SPD band matrix in LAPACK lower band storage (diagonally dominant). */
static void random_band(mlr_test_rng *r, size_t n, size_t kd, double *ab, size_t ldab,
                        double *dense)
{
    for (size_t j = 0; j < n; j++)
        for (size_t d = 0; d <= kd; d++)
            ab[j * ldab + d] = 0.0;
    for (size_t i = 0; i < n * n; i++)
        dense[i] = 0.0;
    for (size_t j = 0; j < n; j++) {
        for (size_t d = 1; d <= kd && j + d < n; d++) {
            double v = mlr_test_rng_uniform(r) - 0.5;
            ab[j * ldab + d] = v;
            dense[(j + d) * n + j] = dense[j * n + j + d] = v;
        }
    }
    for (size_t j = 0; j < n; j++) {
        double v = 2.0 * (double)kd + 0.5 + mlr_test_rng_uniform(r);
        ab[j * ldab] = v;
        dense[j * n + j] = v;
    }
}

/* Dense Cholesky solve of A X = B (B n x m row-major), in place; reference only. */
static void dense_solve(size_t n, double *a, double *b, size_t m)
{
    mlr_test_cholesky(n, a);
    mlr_test_cholesky_solve(n, a, b, m);
}

static const struct {
    size_t n, kd, m;
} shapes[] = {
    {1, 0, 1}, {2, 1, 3}, {5, 2, 1}, {17, 1, 4}, {40, 2, 7}, {33, 3, 2}, {25, 5, 3},
};

START_TEST(solve_matches_dense)
{
    const size_t n = shapes[_i].n, kd = shapes[_i].kd, m = shapes[_i].m, ldab = kd + 2;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 1000 + (uint64_t)_i);
    double *ab = malloc(n * ldab * sizeof *ab), *dense = malloc(n * n * sizeof *dense);
    double *b = malloc(n * m * sizeof *b), *x = malloc(n * (m + 1) * sizeof *x);
    random_band(&r, n, kd, ab, ldab, dense);
    for (size_t i = 0; i < n * m; i++)
        b[i] = mlr_test_rng_normal(&r);
    for (size_t i = 0; i < n; i++)       /* x uses a row stride of m + 1 */
        for (size_t c = 0; c < m; c++)
            x[i * (m + 1) + c] = b[i * m + c];
    mlr_band *band = NULL;
    ck_assert_int_eq(mlr_band_create(n, kd, NULL, &band, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_factor(band, ab, ldab, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_solve(band, x, m + 1, m, NULL), MLR_OK);
    dense_solve(n, dense, b, m);
    for (size_t i = 0; i < n; i++)
        for (size_t c = 0; c < m; c++)
            ck_assert_close(x[i * (m + 1) + c], b[i * m + c], 1e-12 * (1.0 + fabs(b[i * m + c])));
    mlr_band_destroy(band);
    free(ab), free(dense), free(b), free(x);
}
END_TEST

/* Long smoothing systems s L^T L + diag(w) with Toeplitz stretches (where the factor reaches
 * a fixed point and is copied) broken by changes of w: a stretch change, a single odd row and
 * the ends. The residual A x - b, from the band itself, is the reference. */
static const struct {
    size_t n, m;
    double s;
} long_systems[] = {
    {3000, 3, 16.0},
    {3000, 1, 1e4},
    {800, 2, 0.5},
    {70000, 1, 16.0},
};

START_TEST(long_toeplitz_stretches_solve_exactly)
{
    const size_t n = long_systems[_i].n, m = long_systems[_i].m, ldab = 3;
    const double s = long_systems[_i].s;
    static const double dc[3] = {1.0, -2.0, 1.0}; /* second difference */
    double *ab = calloc(n * ldab, sizeof *ab), *b = malloc(n * m * sizeof *b);
    double *x = malloc(n * m * sizeof *x);
    for (size_t i = 0; i < n; i++) /* w: 1 in the first half, 4 after, 2 on one row */
        ab[i * ldab] = i == n * 3 / 4 ? 2.0 : (i < n / 2 ? 1.0 : 4.0);
    for (size_t r = 0; r + 2 < n; r++) /* add s d_r d_r^T, d_r = dc at rows r..r+2 */
        for (size_t p = 0; p < 3; p++)
            for (size_t q = p; q < 3; q++)
                ab[(r + p) * ldab + (q - p)] += s * dc[p] * dc[q];
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 77 + (uint64_t)_i);
    for (size_t i = 0; i < n * m; i++)
        x[i] = b[i] = mlr_test_rng_normal(&rng);
    mlr_band *band = NULL;
    ck_assert_int_eq(mlr_band_create(n, 2, NULL, &band, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_factor(band, ab, ldab, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_solve(band, x, m, m, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        for (size_t c = 0; c < m; c++) {
            double ax = ab[i * ldab] * x[i * m + c];
            for (size_t k = 1; k <= 2; k++) {
                if (i + k < n)
                    ax += ab[i * ldab + k] * x[(i + k) * m + c];
                if (i >= k)
                    ax += ab[(i - k) * ldab + k] * x[(i - k) * m + c];
            }
            ck_assert_close(ax, b[i * m + c], 1e-9 * (1.0 + s));
        }
    mlr_band_destroy(band);
    free(ab), free(b), free(x);
}
END_TEST

START_TEST(inverse_diagonal_matches_dense_inverse)
{
    const size_t n = shapes[_i].n, kd = shapes[_i].kd, ldab = kd + 1;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 2000 + (uint64_t)_i);
    double *ab = malloc(n * ldab * sizeof *ab), *dense = malloc(n * n * sizeof *dense);
    double *eye = calloc(n * n, sizeof *eye), *var = malloc(n * sizeof *var);
    random_band(&r, n, kd, ab, ldab, dense);
    for (size_t i = 0; i < n; i++)
        eye[i * n + i] = 1.0;
    mlr_band *band = NULL;
    ck_assert_int_eq(mlr_band_create(n, kd, NULL, &band, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_factor(band, ab, ldab, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_inverse_diagonal(band, var, n, NULL), MLR_OK);
    dense_solve(n, dense, eye, n); /* eye becomes A^{-1} */
    for (size_t i = 0; i < n; i++)
        ck_assert_close(var[i], eye[i * n + i], 1e-13);
    mlr_band_destroy(band);
    free(ab), free(dense), free(eye), free(var);
}
END_TEST

static const struct {
    size_t n, kd;
} bad_shape[] = {{0, 0}, {4, 4}, {4, 9}};

START_TEST(create_rejects_bad_shape)
{
    static char sentinel;
    mlr_band *b = (mlr_band *)&sentinel;
    ck_assert_int_eq(mlr_band_create(bad_shape[_i].n, bad_shape[_i].kd, NULL, &b, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_null(b);
}
END_TEST

START_TEST(not_positive_definite_is_singular)
{
    /* [[1, 2], [2, 1]] has a negative eigenvalue */
    double ab[4] = {1, 2, 1, 0};
    mlr_band *b = NULL;
    double x[2] = {1, 1};
    ck_assert_int_eq(mlr_band_create(2, 1, NULL, &b, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_solve(b, x, 1, 1, NULL), MLR_E_BAD_STATE);
    ck_assert_int_eq(mlr_band_factor(b, ab, 2, NULL), MLR_E_SINGULAR);
    ck_assert_int_eq(mlr_band_solve(b, x, 1, 1, NULL), MLR_E_BAD_STATE);
    ck_assert_int_eq(mlr_band_factor(b, ab, 1, NULL), MLR_E_INVALID_ARG); /* ldab < kd + 1 */
    double nan_ab[4] = {NAN, 0, 1, 0};
    ck_assert_int_eq(mlr_band_factor(b, nan_ab, 2, NULL), MLR_E_SINGULAR);
    mlr_band_destroy(b);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_band *b = NULL;
        mlr_status s = mlr_band_create(64, 2, &ta.base, &b, NULL);
        mlr_band_destroy(b);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        ck_assert_ptr_null(b);
    }
}
END_TEST

START_TEST(size_overflow_is_reported)
{
    mlr_band *b = NULL;
    ck_assert_int_eq(mlr_band_create(SIZE_MAX / 2, 3, NULL, &b, NULL), MLR_E_OVERFLOW);
    ck_assert_ptr_null(b);
}
END_TEST

static Suite *band_suite(void)
{
    Suite *s = suite_create("band");
    TCase *num = tcase_create("numerics");
    tcase_add_loop_test(num, solve_matches_dense, 0, (int)MLR_COUNTOF(shapes));
    tcase_add_loop_test(num, inverse_diagonal_matches_dense_inverse, 0, (int)MLR_COUNTOF(shapes));
    tcase_add_loop_test(num, long_toeplitz_stretches_solve_exactly, 0,
                        (int)MLR_COUNTOF(long_systems));
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_loop_test(args, create_rejects_bad_shape, 0, (int)MLR_COUNTOF(bad_shape));
    tcase_add_test(args, not_positive_definite_is_singular);
    tcase_add_test(args, every_allocation_failure_is_clean);
    tcase_add_test(args, size_overflow_is_reported);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(band_suite()); }
