/* GRBF basis matrices: every kernel value against libm's log and exp computed here (random
 * points in 1 to 5 dimensions, strides, coincident points; squared distances from 1e-310 to
 * 1e300 for the thin plate and arguments around the -708 cut of the Gaussian), the polynomial
 * columns, the same bits for every thread count and for a point alone or in a batch.
 * Evaluation psi(x) B against the basis and a product summed here (output counts around the
 * blocks of 24 and past 192, strides), the same bits for every thread count and for a point
 * alone. Interpolation on a lattice (split by its symmetry) against the whole bordered system
 * solved here by Gaussian elimination, for odd and even sizes and both kernels; it
 * interpolates; the same bits for every thread count. Bad arguments (an asymmetric or
 * degenerate lattice among them), allocation failures. */
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
            x[i * ldx + t] =
                i % 10 == 0 ? c[(i % nc) * ldc + t] : 5.0 * mlr_test_rng_uniform(&r) - 1.5;
    for (size_t q = 0; q < n * ldo; q++)
        out[q] = -12345.0; /* the padding past the columns must stay */
    ck_assert_int_eq(
        mlr_grbf_basis(kernel, width, c, nc, ldc, x, n, ldx, dim, 1, 2, out, ldo, NULL, NULL),
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
    ck_assert_int_eq(
        mlr_grbf_basis(kernel, width, c, nc, ldc, x, n, ldx, dim, 0, 1, bare, nc, NULL, NULL),
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
    ck_assert_int_eq(
        mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1, zero, 1, 2, x, n, 2, 2, 0, 3, out, 1, NULL, NULL),
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
    ck_assert_int_eq(
        mlr_grbf_basis(MLR_GRBF_GAUSSIAN, width, zero, 1, 2, x, n, 2, 2, 0, 1, out, 1, NULL, NULL),
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
    ck_assert_int_eq(
        mlr_grbf_basis(kernel, 2.5, c, nc, dim, x, n, dim, dim, 1, 1, a, ldo, NULL, NULL), MLR_OK);
    const size_t threads[] = {2, 3, 7, 64};
    for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
        ck_assert_int_eq(mlr_grbf_basis(kernel, 2.5, c, nc, dim, x, n, dim, dim, 1, threads[q], b,
                                        ldo, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a, b, n * ldo * sizeof *a) == 0);
    }
    for (size_t i = 0; i < n; i += 97) { /* a point alone */
        ck_assert_int_eq(mlr_grbf_basis(kernel, 2.5, c, nc, dim, x + i * dim, 1, dim, dim, 1, 1, b,
                                        ldo, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a + i * ldo, b, ldo * sizeof *a) == 0);
    }
    free(c), free(x), free(a), free(b);
}
END_TEST

/* psi(x) B by mlr_grbf_eval against the basis of mlr_grbf_basis times B summed here in long
 * double: within 1e-14 of the sum of the magnitudes of the terms. */
START_TEST(eval_matches_basis_times_coefficients)
{
    const size_t outs[] = {1, 23, 24, 25, 93, 200};
    const size_t n_out = outs[_i % 6], dim = _i < 6 ? 2 : 1 + (size_t)_i % 3;
    const int kernel = _i % 2 ? MLR_GRBF_GAUSSIAN : MLR_GRBF_THIN_PLATE;
    const size_t nc = 45, n = 67, K = nc + 1 + dim, ldcoef = n_out + 3, ldo = n_out + 2;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 300 + (uint64_t)_i);
    double *c = malloc(nc * dim * sizeof *c), *x = malloc(n * dim * sizeof *x);
    double *B = malloc(K * ldcoef * sizeof *B), *psi = malloc(n * K * sizeof *psi);
    double *out = malloc(n * ldo * sizeof *out);
    for (size_t q = 0; q < nc * dim; q++)
        c[q] = 6.0 * mlr_test_rng_uniform(&r);
    for (size_t q = 0; q < n * dim; q++)
        x[q] = 7.0 * mlr_test_rng_uniform(&r) - 0.5;
    for (size_t q = 0; q < K * ldcoef; q++)
        B[q] = q % ldcoef < n_out ? mlr_test_rng_normal(&r) : NAN; /* padding never read */
    for (size_t q = 0; q < n * ldo; q++)
        out[q] = -7.0;
    ck_assert_int_eq(
        mlr_grbf_basis(kernel, 1.9, c, nc, dim, x, n, dim, dim, 1, 1, psi, K, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_grbf_eval(kernel, 1.9, c, nc, dim, B, ldcoef, n_out, x, n, dim, dim, 2,
                                   out, ldo, NULL, NULL),
                     MLR_OK);
    for (size_t i = 0; i < n; i++) {
        for (size_t o = 0; o < n_out; o++) {
            long double sum = 0, mag = 0;
            for (size_t k = 0; k < K; k++) {
                long double term = (long double)psi[i * K + k] * B[k * ldcoef + o];
                sum += term;
                mag += fabsl(term);
            }
            ck_assert_close(out[i * ldo + o], (double)sum, 1e-14 * (double)mag);
        }
        for (size_t o = n_out; o < ldo; o++)
            ck_assert(out[i * ldo + o] == -7.0);
    }
    free(c), free(x), free(B), free(psi), free(out);
}
END_TEST

START_TEST(eval_same_bits_for_every_thread_count)
{
    const size_t nc = 300, n = 333, dim = 2, n_out = 50, K = nc + 3;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 8);
    double *c = malloc(nc * dim * sizeof *c), *x = malloc(n * dim * sizeof *x);
    double *B = malloc(K * n_out * sizeof *B);
    double *a = malloc(n * n_out * sizeof *a), *b = malloc(n * n_out * sizeof *b);
    for (size_t q = 0; q < nc * dim; q++)
        c[q] = 10.0 * mlr_test_rng_uniform(&r);
    for (size_t q = 0; q < n * dim; q++)
        x[q] = 12.0 * mlr_test_rng_uniform(&r) - 1.0;
    for (size_t q = 0; q < K * n_out; q++)
        B[q] = mlr_test_rng_normal(&r);
    ck_assert_int_eq(mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 0, c, nc, dim, B, n_out, n_out, x, n, dim,
                                   dim, 1, a, n_out, NULL, NULL),
                     MLR_OK);
    const size_t threads[] = {2, 3, 7};
    for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
        ck_assert_int_eq(mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 0, c, nc, dim, B, n_out, n_out, x, n,
                                       dim, dim, threads[q], b, n_out, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a, b, n * n_out * sizeof *a) == 0);
    }
    for (size_t i = 0; i < n; i += 37) { /* alone, and in a short batch at another offset */
        ck_assert_int_eq(mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 0, c, nc, dim, B, n_out, n_out,
                                       x + i * dim, 1, dim, dim, 1, b, n_out, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a + i * n_out, b, n_out * sizeof *a) == 0);
        size_t m = n - i < 11 ? n - i : 11;
        ck_assert_int_eq(mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 0, c, nc, dim, B, n_out, n_out,
                                       x + i * dim, m, dim, dim, 1, b, n_out, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a + i * n_out, b, m * n_out * sizeof *a) == 0);
    }
    free(c), free(x), free(B), free(a), free(b);
}
END_TEST

/* Solve the n x n row-major system a x = b (m right-hand sides, row-major) by Gaussian
 * elimination with partial pivoting; a and b are overwritten. */
static void dense_solve(double *a, double *b, size_t n, size_t m)
{
    for (size_t j = 0; j < n; j++) {
        size_t piv = j;
        for (size_t i = j + 1; i < n; i++)
            if (fabs(a[i * n + j]) > fabs(a[piv * n + j]))
                piv = i;
        for (size_t t = 0; t < n; t++) {
            double v = a[j * n + t];
            a[j * n + t] = a[piv * n + t];
            a[piv * n + t] = v;
        }
        for (size_t t = 0; t < m; t++) {
            double v = b[j * m + t];
            b[j * m + t] = b[piv * m + t];
            b[piv * m + t] = v;
        }
        for (size_t i = j + 1; i < n; i++) {
            double f = a[i * n + j] / a[j * n + j];
            for (size_t t = j; t < n; t++)
                a[i * n + t] -= f * a[j * n + t];
            for (size_t t = 0; t < m; t++)
                b[i * m + t] -= f * b[j * m + t];
        }
    }
    for (size_t i = n; i-- > 0;) {
        for (size_t t = 0; t < m; t++) {
            double s = b[i * m + t];
            for (size_t k = i + 1; k < n; k++)
                s -= a[i * n + k] * b[k * m + t];
            b[i * m + t] = s / a[i * n + i];
        }
    }
}

static void lattice_axes(size_t rows, size_t cols, double *xs, double *ys)
{
    for (size_t r = 0; r < rows; r++) /* as numpy.linspace(-1, 3, rows) */
        xs[r] = r + 1 == rows ? 3.0 : -1.0 + 4.0 * (double)r / (double)(rows - 1);
    for (size_t c = 0; c < cols; c++)
        ys[c] = c + 1 == cols ? 2.0 : 0.5 + 1.5 * (double)c / (double)(cols - 1);
}

/* The lattice fit against the bordered system [[K, P], [P^T, 0]] [w; a] = [y; 0] (libm kernel
 * values) solved here; the fit interpolates y (checked through mlr_grbf_eval). */
START_TEST(lattice_fit_matches_whole_system)
{
    const size_t sizes[][2] = {{2, 2}, {2, 3}, {3, 2}, {3, 3}, {4, 5}, {5, 4}, {6, 7}, {8, 6}};
    const size_t rows = sizes[_i / 2][0], cols = sizes[_i / 2][1], N = rows * cols, m = 3;
    const int kernel = _i % 2 ? MLR_GRBF_GAUSSIAN : MLR_GRBF_THIN_PLATE;
    double xs[8], ys[8];
    lattice_axes(rows, cols, xs, ys);
    /* the Gaussian as wide as the smaller spacing: wider ones make the system so ill-conditioned
     * that any two solvers differ in the coefficients' leading digits */
    const double width = fmin(xs[1] - xs[0], ys[1] - ys[0]);
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 500 + (uint64_t)_i);
    double *y = malloc(N * m * sizeof *y), *coef = malloc((N + 3) * m * sizeof *coef);
    double *A = calloc((N + 3) * (N + 3), sizeof *A), *b = calloc((N + 3) * m, sizeof *b);
    double *c = malloc(N * 2 * sizeof *c), *back = malloc(N * m * sizeof *back);
    for (size_t q = 0; q < N * m; q++)
        y[q] = b[q] = mlr_test_rng_normal(&r);
    for (size_t u = 0; u < N; u++) {
        c[2 * u] = xs[u / cols];
        c[2 * u + 1] = ys[u % cols];
    }
    for (size_t u = 0; u < N; u++) {
        for (size_t v = 0; v < N; v++)
            A[u * (N + 3) + v] = ref_phi(kernel, width, ref_d2(c + 2 * u, c + 2 * v, 2));
        const double p[3] = {1.0, c[2 * u], c[2 * u + 1]};
        for (size_t t = 0; t < 3; t++)
            A[u * (N + 3) + N + t] = A[(N + t) * (N + 3) + u] = p[t];
    }
    dense_solve(A, b, N + 3, m);
    ck_assert_int_eq(
        mlr_grbf_fit_lattice(kernel, width, xs, rows, ys, cols, y, m, m, 2, coef, m, NULL, NULL),
        MLR_OK);
    double scale = 0;
    for (size_t q = 0; q < (N + 3) * m; q++)
        scale = fmax(scale, fabs(b[q]));
    for (size_t q = 0; q < (N + 3) * m; q++)
        ck_assert_close(coef[q], b[q], 1e-9 * scale);
    ck_assert_int_eq(
        mlr_grbf_eval(kernel, width, c, N, 2, coef, m, m, c, N, 2, 2, 1, back, m, NULL, NULL),
        MLR_OK);
    for (size_t q = 0; q < N * m; q++)
        ck_assert_close(back[q], y[q], 1e-9 * scale);
    free(y), free(coef), free(A), free(b), free(c), free(back);
}
END_TEST

START_TEST(lattice_fit_same_bits_for_every_thread_count)
{
    const size_t rows = 13, cols = 10, N = rows * cols, m = 30;
    double xs[13], ys[10];
    for (size_t q = 0; q < rows; q++)
        xs[q] = 0.5 * (double)q;
    for (size_t q = 0; q < cols; q++)
        ys[q] = -2.0 + 0.75 * (double)q;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 77);
    double *y = malloc(N * m * sizeof *y), *a = malloc((N + 3) * m * sizeof *a);
    double *b = malloc((N + 3) * m * sizeof *b);
    for (size_t q = 0; q < N * m; q++)
        y[q] = mlr_test_rng_normal(&r);
    ck_assert_int_eq(mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 0, xs, rows, ys, cols, y, m, m, 1,
                                          a, m, NULL, NULL),
                     MLR_OK);
    const size_t threads[] = {2, 3, 4, 9};
    for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
        ck_assert_int_eq(mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 0, xs, rows, ys, cols, y, m, m,
                                              threads[q], b, m, NULL, NULL),
                         MLR_OK);
        ck_assert(memcmp(a, b, (N + 3) * m * sizeof *a) == 0);
    }
    free(y), free(a), free(b);
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
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 0, 1, out, 3, NULL, &dg), MLR_OK);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 0, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_basis(tp, 1, c, 3, 2, x, 2, 2, 2, 1, 65, out, 6, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(
        mlr_grbf_basis(tp, 1, c, 3, 2, x, SIZE_MAX / 4, 2, 2, 1, 1, out, 6, NULL, &dg),
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
    c[4] = 4;
    /* evaluation: coefficients (3 centres + 1 + 2 rows) of 2 outputs */
    double B[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_OK);
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 0, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, NULL, 2, 2, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, NULL, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 1, 2, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "dimension mismatch"));
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 1, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_eval(ga, -1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(
        mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 2, x, SIZE_MAX / 4, 2, 2, 1, out, 2, NULL, &dg),
        MLR_E_OVERFLOW);
    B[11] = NAN;
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "coefficient row 5"));
    B[11] = 12;
    x[0] = NAN;
    ck_assert_int_eq(mlr_grbf_eval(tp, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "point 0"));
    /* lattice fit: 3 x 2 lattice, 2 outputs */
    double xs[3] = {0, 1, 2}, ys[2] = {5, 6}, y[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    double co[18];
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_OK);
    ck_assert_int_eq(mlr_grbf_fit_lattice(9, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_fit_lattice(ga, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 1, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "2 x 2"));
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, NULL, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 0, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 1, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "dimension mismatch"));
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 2, 0, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    xs[1] = 1.5; /* not symmetric about 1 */
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "symmetric"));
    xs[1] = NAN;
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    xs[1] = 1;
    y[7] = INFINITY;
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "y row 3"));
    y[7] = 8;
    xs[0] = xs[1] = xs[2] = 1; /* every centre on the line x = 1: the x term is undetermined */
    ck_assert_int_eq(mlr_grbf_fit_lattice(tp, 0, xs, 3, ys, 2, y, 2, 2, 1, co, 2, NULL, &dg),
                     MLR_E_SINGULAR);
    ck_assert_ptr_nonnull(strstr(dg.message, "positive definite"));
}
END_TEST

START_TEST(allocation_failure_is_clean)
{
    double c[6] = {0, 1, 2, 3, 4, 5}, x[4] = {0.5, 0.5, 1, 2}, out[12];
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    mlr_diag dg;
    ck_assert_int_eq(
        mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, &ta.base, &dg),
        MLR_E_NO_MEMORY);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_test_allocator_init(&ta, 1);
    ck_assert_int_eq(
        mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1, c, 3, 2, x, 2, 2, 2, 1, 1, out, 6, &ta.base, &dg),
        MLR_OK);
    ck_assert_uint_eq(ta.live_blocks, 0);
    ck_assert_uint_eq(ta.n_calls, 1);
    double B[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    mlr_test_allocator_init(&ta, 0);
    ck_assert_int_eq(mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 2,
                                   &ta.base, &dg),
                     MLR_E_NO_MEMORY);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_test_allocator_init(&ta, 1);
    ck_assert_int_eq(mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 1, c, 3, 2, B, 2, 2, x, 2, 2, 2, 1, out, 2,
                                   &ta.base, &dg),
                     MLR_OK);
    ck_assert_uint_eq(ta.live_blocks, 0);
    double xs[2] = {0, 1}, ys[3] = {0, 1, 2}, y[6] = {1, 2, 3, 4, 5, 6}, co[9];
    mlr_test_allocator_init(&ta, 0);
    ck_assert_int_eq(mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 0, xs, 2, ys, 3, y, 1, 1, 1, co, 1,
                                          &ta.base, &dg),
                     MLR_E_NO_MEMORY);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_test_allocator_init(&ta, 1);
    ck_assert_int_eq(mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 0, xs, 2, ys, 3, y, 1, 1, 1, co, 1,
                                          &ta.base, &dg),
                     MLR_OK);
    ck_assert_uint_eq(ta.live_blocks, 0);
}
END_TEST

static Suite *grbf_suite(void)
{
    Suite *s = suite_create("grbf");
    TCase *num = tcase_create("numerics");
    tcase_add_loop_test(num, basis_matches_libm, 0, 8);
    tcase_add_test(num, kernel_over_the_whole_range);
    tcase_add_loop_test(num, same_bits_for_every_thread_count_and_batch, 0, 2);
    tcase_add_loop_test(num, eval_matches_basis_times_coefficients, 0, 9);
    tcase_add_test(num, eval_same_bits_for_every_thread_count);
    tcase_add_loop_test(num, lattice_fit_matches_whole_system, 0, 16);
    tcase_add_test(num, lattice_fit_same_bits_for_every_thread_count);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, bad_input_is_refused_with_a_reason);
    tcase_add_test(args, allocation_failure_is_clean);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(grbf_suite()); }
