/* GRBF basis matrices: every kernel value against libm's log and exp computed here (random
 * points in 1 to 5 dimensions, strides, coincident points; squared distances from 1e-310 to
 * 1e300 for the thin plate and arguments around the -708 cut of the Gaussian), the polynomial
 * columns, the same bits for every thread count and for a point alone or in a batch, bad
 * arguments, allocation failures. */
#include "mlr_test.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* libm references, from the squared distance summed in coordinate order */
static double ref_d2(const double *x, const double *c, size_t dim)
{
    double s = 0;
    for (size_t t = 0; t < dim; t++)
        s += (x[t] - c[t]) * (x[t] - c[t]);
    return s;
}

static double ref_phi(int kernel, double width, double d2)
{
    if (kernel == MLR_GRBF_THIN_PLATE)
        return d2 >= DBL_MIN ? 0.5 * d2 * log(d2) : 0.0;
    double a = d2 * (1.0 / (width * width)); /* the argument as mlr_grbf_basis forms it */
    return a > 708.0 ? 0.0 : exp(-a);
}

/* |got - ref| within 4 units in the last place of ref (and exact zeros where ref is 0) */
static void assert_ulps(double got, double ref)
{
    double tol = 4.0 * DBL_EPSILON * fabs(ref);
    ck_assert_msg(fabs(got - ref) <= tol, "got %.17g, libm %.17g (%.2f ulp)", got, ref,
                  ref != 0 ? fabs(got - ref) / (DBL_EPSILON * fabs(ref)) : INFINITY);
}

START_TEST(basis_matches_libm)
{
    const int kernel = _i % 2 ? MLR_GRBF_GAUSSIAN : MLR_GRBF_THIN_PLATE;
    const size_t dims[] = {1, 2, 3, 5};
    const size_t dim = dims[_i / 2], nc = 37, n = 301, ldc = dim + 2, ldx = dim + 1;
    const size_t cols = nc + 1 + dim, ldo = cols + 3;
    const double width = 1.7;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 100 + (uint64_t)_i);
    double *c = malloc(nc * ldc * sizeof *c), *x = malloc(n * ldx * sizeof *x);
    double *out = malloc(n * ldo * sizeof *out);
    for (size_t q = 0; q < nc * ldc; q++)
        c[q] = 4.0 * mlr_test_rng_uniform(&r) - 1.0;
    for (size_t i = 0; i < n; i++)
        for (size_t t = 0; t < dim; t++) /* every 10th point on a centre: phi(0) */
            x[i * ldx + t] = i % 10 == 0 ? c[(i % nc) * ldc + t]
                                         : 5.0 * mlr_test_rng_uniform(&r) - 1.5;
    for (size_t q = 0; q < n * ldo; q++)
        out[q] = -12345.0; /* the padding past the columns must stay */
    ck_assert_int_eq(mlr_grbf_basis(kernel, width, c, nc, ldc, x, n, ldx, dim, 1, 2, out, ldo,
                                    NULL, NULL),
                     MLR_OK);
    for (size_t i = 0; i < n; i++) {
        const double *o = out + i * ldo, *xi = x + i * ldx;
        for (size_t j = 0; j < nc; j++)
            assert_ulps(o[j], ref_phi(kernel, width, ref_d2(xi, c + j * ldc, dim)));
        if (i % 10 == 0)
            ck_assert(o[i % nc] == (kernel == MLR_GRBF_THIN_PLATE ? 0.0 : 1.0));
        ck_assert(o[nc] == 1.0);
        for (size_t t = 0; t < dim; t++)
            ck_assert(o[nc + 1 + t] == xi[t]);
        for (size_t q = cols; q < ldo; q++)
            ck_assert(o[q] == -12345.0);
    }
    /* without the polynomial columns: the same kernel values, nothing past them */
    double *bare = malloc(n * nc * sizeof *bare);
    ck_assert_int_eq(mlr_grbf_basis(kernel, width, c, nc, ldc, x, n, ldx, dim, 0, 1, bare, nc,
                                    NULL, NULL),
                     MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert(memcmp(bare + i * nc, out + i * ldo, nc * sizeof *bare) == 0);
    free(c), free(x), free(out), free(bare);
}
END_TEST

/* The thin plate over squared distances from 1e-310 (subnormal: 0) to 1e300, across every
 * binade and the sqrt(2)/2 split of the log reduction; the Gaussian around its -708 cut and for
 * arguments down to 1e-20. One centre at 0, points (u, 0). */
START_TEST(kernel_over_the_whole_range)
{
    const size_t n = 4000;
    const double zero[2] = {0, 0};
    double *x = calloc(2 * n, sizeof *x), *out = malloc(n * sizeof *out);
    for (size_t i = 0; i < n; i++) /* u from 1e-155 to 1e150, plus points near 2^k sqrt(2)/2 */
        x[2 * i] = i % 4 == 3 ? ldexp(0.70710678118654752440 * (1 + 1e-15 * (double)(i % 7)),
                                    (int)(i % 400) - 200)
                              : pow(10.0, -155.0 + 304.9 * (double)i / (double)n);
    ck_assert_int_eq(mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1, zero, 1, 2, x, n, 2, 2, 0, 3, out, 1,
                                    NULL, NULL),
                     MLR_OK);
    for (size_t i = 0; i < n; i++) {
        double d2 = x[2 * i] * x[2 * i];
        if (d2 < DBL_MIN)
            ck_assert(out[i] == 0.0);
        else
            assert_ulps(out[i], ref_phi(MLR_GRBF_THIN_PLATE, 1, d2));
    }
    const double width = 3.0;
    for (size_t i = 0; i < n; i++) /* d2 / width^2 from 1e-20 to 750, dense near 708 */
        x[2 * i] = width * sqrt(i % 2 ? 700.0 + 16.0 * (double)i / (double)n
                                      : pow(10.0, -20.0 + 22.9 * (double)i / (double)n));
    ck_assert_int_eq(mlr_grbf_basis(MLR_GRBF_GAUSSIAN, width, zero, 1, 2, x, n, 2, 2, 0, 1, out,
                                    1, NULL, NULL),
                     MLR_OK);
    for (size_t i = 0; i < n; i++) {
        double d2 = x[2 * i] * x[2 * i], ref = ref_phi(MLR_GRBF_GAUSSIAN, width, d2);
        double a = d2 * (1.0 / (width * width));
        if (a > 708.0 + 1e-9 || a < 708.0 - 1e-9)
            assert_ulps(out[i], ref);
        else /* at the cut itself: either side */
            ck_assert(out[i] == 0.0 || fabs(out[i] - ref) <= 4.0 * DBL_EPSILON * ref);
    }
    free(x), free(out);
}
END_TEST

START_TEST(same_bits_for_every_thread_count_and_batch)
{
    const size_t nc = 150, n = 777, dim = 2, ldo = nc + 3;
    const int kernel = _i ? MLR_GRBF_GAUSSIAN : MLR_GRBF_THIN_PLATE;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 7);
    double *c = malloc(nc * dim * sizeof *c), *x = malloc(n * dim * sizeof *x);
    for (size_t q = 0; q < nc * dim; q++)
        c[q] = 10.0 * mlr_test_rng_uniform(&r);
    for (size_t q = 0; q < n * dim; q++)
        x[q] = 12.0 * mlr_test_rng_uniform(&r) - 1.0;
    double *a = malloc(n * ldo * sizeof *a), *b = malloc(n * ldo * sizeof *b);
    ck_assert_int_eq(mlr_grbf_basis(kernel, 2.5, c, nc, dim, x, n, dim, dim, 1, 1, a, ldo, NULL,
                                    NULL),
                     MLR_OK);
    const size_t threads[] = {2, 3, 7, 64};
    for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
        ck_assert_int_eq(mlr_grbf_basis(kernel, 2.5, c, nc, dim, x, n, dim, dim, 1, threads[q], b,
                                        ldo, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a, b, n * ldo * sizeof *a) == 0);
    }
    for (size_t i = 0; i < n; i += 97) { /* a point alone */
        ck_assert_int_eq(mlr_grbf_basis(kernel, 2.5, c, nc, dim, x + i * dim, 1, dim, dim, 1, 1,
                                        b, ldo, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a + i * ldo, b, ldo * sizeof *a) == 0);
    }
    free(c), free(x), free(a), free(b);
}
END_TEST

START_TEST(bad_input_is_refused_with_a_reason)
{
    double c[6] = {0, 1, 2, 3, 4, 5}, x[4] = {0.5, 0.5, 1, 2}, out[16];
    mlr_diag dg;
    const int tp = MLR_GRBF_THIN_PLATE, ga = MLR_GRBF_GAUSSIAN;
    ck_assert_int_eq(mlr_grbf_basis(7, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "kernel"));
    ck_assert_int_eq(mlr_grbf_basis(ga, 0, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "width"));
    ck_assert_int_eq(mlr_grbf_basis(ga, NAN, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(ga, 1e-200, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 0, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_OK); /* the thin plate ignores the width */
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 0, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 0, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, NULL, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, NULL, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 1, NULL, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, NULL, 0, 2, 2, 1, 1, NULL, 6, NULL, &dg),
                     MLR_OK); /* no points: nothing to do */
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 1, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "dimension mismatch"));
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 1, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 5, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "ldo"));
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 0, 1, out, 3, NULL, &dg),
                     MLR_OK);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 0, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 65, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, SIZE_MAX / 4, 2, 2, 1, 1, out, 6, NULL,
                                    &dg),
                     MLR_E_OVERFLOW);
    x[3] = NAN;
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "point 1"));
    x[3] = 2;
    c[4] = -1e151;
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "centre 2"));
    c[4] = INFINITY;
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
}
END_TEST

START_TEST(allocation_failure_is_clean)
{
    double c[6] = {0, 1, 2, 3, 4, 5}, x[4] = {0.5, 0.5, 1, 2}, out[12];
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    mlr_diag dg;
    ck_assert_int_eq(mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6,
                                    &ta.base, &dg),
                     MLR_E_NO_MEMORY);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_test_allocator_init(&ta, 1);
    ck_assert_int_eq(mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6,
                                    &ta.base, &dg),
                     MLR_OK);
    ck_assert_uint_eq(ta.live_blocks, 0);
    ck_assert_uint_eq(ta.n_calls, 1);
}
END_TEST

static Suite *grbf_suite(void)
{
    Suite *s = suite_create("grbf");
    TCase *num = tcase_create("numerics");
    tcase_add_loop_test(num, basis_matches_libm, 0, 8);
    tcase_add_test(num, kernel_over_the_whole_range);
    tcase_add_loop_test(num, same_bits_for_every_thread_count_and_batch, 0, 2);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, bad_input_is_refused_with_a_reason);
    tcase_add_test(args, allocation_failure_is_clean);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(grbf_suite()); }
