/* GRBF basis matrices: kernel values of many points against a set of centres. See mlr_grbf.h. */
#include "cluster_internal.h"

#include <float.h>
#include <math.h>

/* The kernel loops get AVX-512 and AVX2 clones chosen at load time with GCC on x86-64 (the
 * build itself assumes only the baseline ISA); the loops are written branch-free, with the bit
 * manipulations of the log and exp reductions in integer lanes, so every clone vectorizes. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(__SANITIZE_ADDRESS__)
#define GRBF_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define GRBF_CLONES
#endif

/* Coordinates beyond this are refused: squared distances then stay far from overflow. */
#define GRBF_MAX_COORD 1e150
/* Rows per task of the parallel loop. */
#define GRBF_TASK_ROWS 32

static inline uint64_t as_u64(double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    return u;
}

static inline double as_f64(uint64_t u)
{
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

/* o[j] = d2 log(d2) / 2 for d2 = o[j] >= DBL_MIN, else 0. log by fdlibm's method: d2 = 2^k m
 * with m in [sqrt(2)/2, sqrt(2)), f = m - 1, s = f / (2 + f), log(1 + f) = f - f^2/2 + s (f^2/2 +
 * R(s^2)) with fdlibm's minimax R (error below 1 ulp). k comes from the exponent bits through
 * the 2^52 trick (no integer to double conversion, so AVX2 and AVX-512F both vectorize it). */
GRBF_CLONES
static void thin_plate_row(double *o, size_t n)
{
    const double Lg1 = 6.666666666666735130e-01, Lg2 = 3.999999999940941908e-01,
                 Lg3 = 2.857142874366239149e-01, Lg4 = 2.222219843214978396e-01,
                 Lg5 = 1.818357216161805012e-01, Lg6 = 1.531383769920937332e-01,
                 Lg7 = 1.479819860511658591e-01;
    const double ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
    for (size_t j = 0; j < n; j++) {
        double d2 = o[j];
        uint64_t b = as_u64(d2), t = b - 0x3fe6a09e667f3bcdull; /* bits of sqrt(2)/2 */
        double m = as_f64(b - (t & 0xfff0000000000000ull));
        uint64_t kb = ((t >> 52) + 2048) & 0xfff; /* k + 2048 */
        double k = as_f64(0x4330000000000000ull | kb) - (0x1p52 + 2048.0);
        double f = m - 1.0, s = f / (2.0 + f), z = s * s, w = z * z;
        double t1 = w * (Lg2 + w * (Lg4 + w * Lg6));
        double t2 = z * (Lg1 + w * (Lg3 + w * (Lg5 + w * Lg7)));
        double r = t2 + t1, hfsq = 0.5 * f * f;
        double lg = k * ln2_hi - ((hfsq - (s * (hfsq + r) + k * ln2_lo)) - f);
        uint64_t keep = (uint64_t)0 - (uint64_t)(d2 >= DBL_MIN);
        o[j] = as_f64(as_u64(0.5 * d2 * lg) & keep);
    }
}

/* o[j] = exp(-o[j] * s) (s > 0), 0 once the argument is below -708. exp(x) = 2^k exp(r), k the
 * nearest integer to x / ln 2 (the 1.5 * 2^52 shifter), r = x - k ln 2 in two parts (|r| <=
 * ln(2)/2), exp(r) by its Taylor polynomial of degree 13 (truncation below 5e-18). */
GRBF_CLONES
static void gaussian_row(double *o, size_t n, double s)
{
    const double log2e = 1.44269504088896338700e+00;
    const double ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
    const double shifter = 0x1.8p52;
    for (size_t j = 0; j < n; j++) {
        double x = -o[j] * s;
        uint64_t keep = (uint64_t)0 - (uint64_t)(x >= -708.0);
        x = x >= -708.0 ? x : -708.0;
        double kd = x * log2e + shifter;
        uint64_t kb = as_u64(kd); /* low bits: k in two's complement */
        kd -= shifter;
        double r = (x - kd * ln2_hi) - kd * ln2_lo;
        double p = 1.0 / 6227020800.0;
        p = p * r + 1.0 / 479001600.0;
        p = p * r + 1.0 / 39916800.0;
        p = p * r + 1.0 / 3628800.0;
        p = p * r + 1.0 / 362880.0;
        p = p * r + 1.0 / 40320.0;
        p = p * r + 1.0 / 5040.0;
        p = p * r + 1.0 / 720.0;
        p = p * r + 1.0 / 120.0;
        p = p * r + 1.0 / 24.0;
        p = p * r + 1.0 / 6.0;
        p = p * r + 0.5;
        p = p * r + 1.0;
        p = p * r + 1.0;
        double scale = as_f64((kb + 1023) << 52); /* 2^k, k in [-1022, 0] */
        o[j] = as_f64(as_u64(p * scale) & keep);
    }
}

/* Squared distances of the point xi (dim values) to the n centres of ct (transposed: coordinate
 * t of centre j at ct[t * n + j]), summed over the coordinates in order. */
GRBF_CLONES
static void dist2_row(const double *xi, const double *ct, size_t n, size_t dim, double *o)
{
    const double x0 = xi[0];
    for (size_t j = 0; j < n; j++) {
        double d = x0 - ct[j];
        o[j] = d * d;
    }
    for (size_t t = 1; t < dim; t++) {
        const double xt = xi[t], *c = ct + t * n;
        for (size_t j = 0; j < n; j++) {
            double d = xt - c[j];
            o[j] += d * d;
        }
    }
}

typedef struct basis_ctx {
    int kernel, poly;
    double s; /* Gaussian: 1 / width^2 */
    const double *ct, *x;
    size_t nc, ldx, n, dim, ldo;
    double *out;
} basis_ctx;

static void basis_task(void *ctx, size_t task)
{
    const basis_ctx *c = ctx;
    size_t i0 = task * GRBF_TASK_ROWS, i1 = i0 + GRBF_TASK_ROWS < c->n ? i0 + GRBF_TASK_ROWS : c->n;
    for (size_t i = i0; i < i1; i++) {
        const double *xi = c->x + i * c->ldx;
        double *o = c->out + i * c->ldo;
        dist2_row(xi, c->ct, c->nc, c->dim, o);
        if (c->kernel == MLR_GRBF_THIN_PLATE)
            thin_plate_row(o, c->nc);
        else
            gaussian_row(o, c->nc, c->s);
        if (c->poly) {
            o[c->nc] = 1.0;
            memcpy(o + c->nc + 1, xi, c->dim * sizeof(double));
        }
    }
}

/* First row of p (n rows of dim values, stride ld) holding a NaN, an infinity or a coordinate
 * beyond GRBF_MAX_COORD, or n. */
static size_t first_bad_row(const double *p, size_t n, size_t dim, size_t ld)
{
    for (size_t i = 0; i < n; i++) {
        int bad = 0;
        for (size_t t = 0; t < dim; t++)
            bad |= !(fabs(p[i * ld + t]) <= GRBF_MAX_COORD);
        if (bad)
            return i;
    }
    return n;
}

mlr_status mlr_grbf_basis(int kernel, double width, const double *centers, size_t n_centers,
                          size_t ldc, const double *x, size_t n, size_t ldx, size_t dim, int poly,
                          size_t n_threads, double *out, size_t ldo, const mlr_allocator *alloc,
                          mlr_diag *diag)
{
    if (kernel != MLR_GRBF_THIN_PLATE && kernel != MLR_GRBF_GAUSSIAN)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown GRBF kernel %d", kernel);
    if (kernel == MLR_GRBF_GAUSSIAN &&
        !(width > 0 && width < INFINITY && 1.0 / (width * width) < INFINITY))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "Gaussian width must be finite and >= 1e-150, got %g", width);
    if (n_centers == 0 || dim == 0)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "%zu centres of dimension %zu: both must be >= 1", n_centers, dim);
    if (!centers || (n > 0 && (!x || !out)))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "centers, x or out is NULL");
    if (ldc < dim || ldx < dim)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "dimension mismatch: strides ldc %zu, ldx %zu < dim %zu", ldc, ldx,
                            dim);
    size_t cols = n_centers, nct, bytes;
    if (poly && (dim > SIZE_MAX - 1 - n_centers))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "basis width overflows");
    if (poly)
        cols += 1 + dim;
    if (ldo < cols)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "output stride ldo %zu < %zu basis columns", ldo, cols);
    if (n_threads < 1 || n_threads > MLR_MAX_THREADS)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "n_threads %zu not in 1 .. %d",
                            n_threads, MLR_MAX_THREADS);
    size_t span;
    if (n > 0 && (mlr_mul_size(n - 1, ldo, &span) || span > SIZE_MAX / sizeof(double) - ldo))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "output size overflows");
    if (mlr_mul_size(n_centers, dim, &nct) || mlr_mul_size(nct, sizeof(double), &bytes))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "centre workspace overflows");
    size_t bad = first_bad_row(centers, n_centers, dim, ldc);
    if (bad < n_centers)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "centre %zu holds a NaN, an infinity or a coordinate beyond 1e150",
                            bad);
    bad = first_bad_row(x, n, dim, ldx);
    if (bad < n)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "point %zu holds a NaN, an infinity or a coordinate beyond 1e150",
                            bad);
    if (n == 0)
        return MLR_OK;
    mlr_allocator a;
    mlr_allocator_resolve(alloc, &a);
    double *ct = mlr_alloc(&a, bytes);
    if (!ct)
        return mlr_diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "no memory for %zu centres", n_centers);
    for (size_t j = 0; j < n_centers; j++)
        for (size_t t = 0; t < dim; t++)
            ct[t * n_centers + j] = centers[j * ldc + t];
    basis_ctx c = {kernel, poly != 0, kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0,
                   ct, x, n_centers, ldx, n, dim, ldo, out};
    mlr_parallel_run(n_threads, (n + GRBF_TASK_ROWS - 1) / GRBF_TASK_ROWS, basis_task, &c);
    mlr_free(&a, ct, bytes);
    return MLR_OK;
}
