/* GRBF basis matrices: kernel values of many points against a set of centres. See mlr_grbf.h. */
#include "cluster_internal.h" /* mlr_first_nonfinite_row, mlr_parallel_run */

#include <float.h>
#include <math.h>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#  define MLR_GRBF_X86 1
#  include <immintrin.h>
#endif

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
 * t of centre j at ct[t * ldt + j]), summed over the coordinates in order. */
GRBF_CLONES
static void dist2_row(const double *xi, const double *ct, size_t ldt, size_t n, size_t dim,
                      double *o)
{
    const double x0 = xi[0];
    for (size_t j = 0; j < n; j++) {
        double d = x0 - ct[j];
        o[j] = d * d;
    }
    for (size_t t = 1; t < dim; t++) {
        const double xt = xi[t], *c = ct + t * ldt;
        for (size_t j = 0; j < n; j++) {
            double d = xt - c[j];
            o[j] += d * d;
        }
    }
}

/* 1 when the AVX-512 product kernel may run. */
static int cpu_wide(void)
{
#ifdef MLR_GRBF_X86
    return __builtin_cpu_supports("avx512f");
#else
    return 0;
#endif
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
        dist2_row(xi, c->ct, c->nc, c->nc, c->dim, o);
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

/* n rows at stride ld (in doubles) must fit a size_t of bytes. */
static int rows_overflow(size_t n, size_t ld)
{
    size_t span;
    return n > 0 && (mlr_mul_size(n - 1, ld, &span) || span > SIZE_MAX / sizeof(double) - ld);
}

/* Argument checks shared by mlr_grbf_basis and mlr_grbf_eval (the data are scanned later, by
 * check_data, once the sizes are known to be sane); fills *ct_bytes (the transposed centres). */
/* The kernel id and, for the Gaussian, its width. */
static mlr_status check_kernel(int kernel, double width, mlr_diag *diag)
{
    if (kernel != MLR_GRBF_THIN_PLATE && kernel != MLR_GRBF_GAUSSIAN)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown GRBF kernel %d", kernel);
    if (kernel == MLR_GRBF_GAUSSIAN &&
        !(width > 0 && width < INFINITY && 1.0 / (width * width) < INFINITY))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "Gaussian width must be finite and >= 1e-150, got %g", width);
    return MLR_OK;
}

static mlr_status check_common(int kernel, double width, const double *centers, size_t n_centers,
                               size_t ldc, const double *x, size_t n, size_t ldx, size_t dim,
                               size_t n_threads, size_t *ct_bytes, mlr_diag *diag)
{
    mlr_status st = check_kernel(kernel, width, diag);
    if (st != MLR_OK)
        return st;
    if (n_centers == 0 || dim == 0)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "%zu centres of dimension %zu: both must be >= 1", n_centers, dim);
    if (!centers || (n > 0 && !x))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "centers or x is NULL");
    if (ldc < dim || ldx < dim)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "dimension mismatch: strides ldc %zu, ldx %zu < dim %zu", ldc, ldx,
                            dim);
    if (n_threads < 1 || n_threads > MLR_MAX_THREADS)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "n_threads %zu not in 1 .. %d",
                            n_threads, MLR_MAX_THREADS);
    size_t nct;
    if (mlr_mul_size(n_centers, dim, &nct) || mlr_mul_size(nct, sizeof(double), ct_bytes) ||
        dim > SIZE_MAX - 1 - n_centers || rows_overflow(n_centers, ldc) ||
        rows_overflow(n, ldx))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "input or workspace size overflows");
    return MLR_OK;
}

static mlr_status check_data(const double *centers, size_t n_centers, size_t ldc,
                             const double *x, size_t n, size_t ldx, size_t dim, mlr_diag *diag)
{
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
    return MLR_OK;
}

static void transpose_centres(const double *centers, size_t n_centers, size_t ldc, size_t dim,
                              double *ct)
{
    for (size_t j = 0; j < n_centers; j++)
        for (size_t t = 0; t < dim; t++)
            ct[t * n_centers + j] = centers[j * ldc + t];
}

mlr_status mlr_grbf_basis(int kernel, double width, const double *centers, size_t n_centers,
                          size_t ldc, const double *x, size_t n, size_t ldx, size_t dim, int poly,
                          size_t n_threads, double *out, size_t ldo, const mlr_allocator *alloc,
                          mlr_diag *diag)
{
    size_t bytes;
    mlr_status st = check_common(kernel, width, centers, n_centers, ldc, x, n, ldx, dim,
                                 n_threads, &bytes, diag);
    if (st)
        return st;
    size_t cols = n_centers + (poly ? 1 + dim : 0);
    if (n > 0 && !out)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    if (ldo < cols)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "output stride ldo %zu < %zu basis columns", ldo, cols);
    if (rows_overflow(n, ldo))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "output size overflows");
    if ((st = check_data(centers, n_centers, ldc, x, n, ldx, dim, diag)))
        return st;
    if (n == 0)
        return MLR_OK;
    mlr_allocator a;
    mlr_allocator_resolve(alloc, &a);
    double *ct = mlr_alloc(&a, bytes);
    if (!ct)
        return mlr_diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "no memory for %zu centres", n_centers);
    transpose_centres(centers, n_centers, ldc, dim, ct);
    basis_ctx c = {kernel, poly != 0, kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0,
                   ct, x, n_centers, ldx, n, dim, ldo, out};
    mlr_parallel_run(n_threads, (n + GRBF_TASK_ROWS - 1) / GRBF_TASK_ROWS, basis_task, &c);
    mlr_free(&a, ct, bytes);
    return MLR_OK;
}

/* ---- evaluation: psi(x) B without storing psi ------------------------------------------------ *
 * A task takes EVAL_ROWS points. For each block of EVAL_KC basis columns it computes their basis
 * values (kernel columns, then 1 and x) into a small buffer, then multiplies them into the
 * accumulators of the outputs, EVAL_PANEL outputs at a time from B packed by panels (the B panel
 * block stays in L1, B itself in L2). Every output is summed over the basis columns in order,
 * whatever the task, the thread and the row's place in its task. */
#define EVAL_ROWS 16
#define EVAL_KC 128
#define EVAL_PANEL 24 /* = PANEL */
#define EVAL_GROUP 8 /* panels per pass: up to 192 outputs share one basis evaluation */

typedef struct eval_ctx {
    int kernel, wide;
    double s;
    const double *ct, *x, *pan;
    size_t nc, dim, ldx, n, K, npanel, n_out, ldo;
    double *out;
} eval_ctx;

/* Basis columns [k0, k0 + kc) of the point xi into b. */
static void basis_segment(const eval_ctx *c, const double *xi, size_t k0, size_t kc, double *b)
{
    size_t kn = k0 >= c->nc ? 0 : (c->nc - k0 < kc ? c->nc - k0 : kc);
    if (kn) {
        dist2_row(xi, c->ct + k0, c->nc, kn, c->dim, b);
        if (c->kernel == MLR_GRBF_THIN_PLATE)
            thin_plate_row(b, kn);
        else
            gaussian_row(b, kn, c->s);
    }
    for (size_t k = k0 + kn; k < k0 + kc; k++)
        b[k - k0] = k == c->nc ? 1.0 : xi[k - c->nc - 1];
}

/* The product kernel of the evaluation and of the lattice solves: acc[p * lda + l] += sum_k
 * a[p * sp + k * sk] b[k * ldb + l] for p < rows, l < 24 (PANEL), k = 0 .. kc-1 in order. */
#define PANEL 24
static void panel_generic(const double *a, size_t sp, size_t sk, size_t rows, size_t kc,
                          const double *b, size_t ldb, double *acc, size_t lda)
{
    for (size_t p = 0; p < rows; p++) {
        double s[PANEL];
        memcpy(s, acc + p * lda, sizeof s);
        for (size_t k = 0; k < kc; k++) {
            double v = a[p * sp + k * sk];
            const double *q = b + k * ldb;
            for (size_t l = 0; l < PANEL; l++)
                s[l] += v * q[l];
        }
        memcpy(acc + p * lda, s, sizeof s);
    }
}

#ifdef MLR_GRBF_X86
/* The same with fused multiply-adds: 8 rows x 24 columns in 24 registers, then single rows
 * (the same fma sequence per output). */
__attribute__((target("avx512f"))) static void panel_avx512(const double *a, size_t sp,
                                                             size_t sk, size_t rows, size_t kc,
                                                             const double *b, size_t ldb,
                                                             double *acc, size_t lda)
{
    size_t p0 = 0;
    for (; p0 + 8 <= rows; p0 += 8) {
        const double *ap = a + p0 * sp;
        double *o = acc + p0 * lda;
#define LOAD3(r)                                                                       \
    __m512d a##r##0 = _mm512_loadu_pd(o + r * lda), a##r##1 = _mm512_loadu_pd(o + r * lda + 8), \
            a##r##2 = _mm512_loadu_pd(o + r * lda + 16)
        LOAD3(0);
        LOAD3(1);
        LOAD3(2);
        LOAD3(3);
        LOAD3(4);
        LOAD3(5);
        LOAD3(6);
        LOAD3(7);
#undef LOAD3
        for (size_t k = 0; k < kc; k++) {
            const double *q = b + k * ldb, *ak = ap + k * sk;
            __m512d q0 = _mm512_loadu_pd(q), q1 = _mm512_loadu_pd(q + 8),
                    q2 = _mm512_loadu_pd(q + 16), v;
#define FMA3(r)                                \
    v = _mm512_set1_pd(ak[r * sp]);            \
    a##r##0 = _mm512_fmadd_pd(v, q0, a##r##0); \
    a##r##1 = _mm512_fmadd_pd(v, q1, a##r##1); \
    a##r##2 = _mm512_fmadd_pd(v, q2, a##r##2)
            FMA3(0);
            FMA3(1);
            FMA3(2);
            FMA3(3);
            FMA3(4);
            FMA3(5);
            FMA3(6);
            FMA3(7);
#undef FMA3
        }
#define STORE3(r)                               \
    _mm512_storeu_pd(o + r * lda, a##r##0);     \
    _mm512_storeu_pd(o + r * lda + 8, a##r##1); \
    _mm512_storeu_pd(o + r * lda + 16, a##r##2)
        STORE3(0);
        STORE3(1);
        STORE3(2);
        STORE3(3);
        STORE3(4);
        STORE3(5);
        STORE3(6);
        STORE3(7);
#undef STORE3
    }
    for (; p0 < rows; p0++) {
        const double *ap = a + p0 * sp;
        double *o = acc + p0 * lda;
        __m512d a0 = _mm512_loadu_pd(o), a1 = _mm512_loadu_pd(o + 8),
                a2 = _mm512_loadu_pd(o + 16);
        for (size_t k = 0; k < kc; k++) {
            const double *q = b + k * ldb;
            __m512d v = _mm512_set1_pd(ap[k * sk]);
            a0 = _mm512_fmadd_pd(v, _mm512_loadu_pd(q), a0);
            a1 = _mm512_fmadd_pd(v, _mm512_loadu_pd(q + 8), a1);
            a2 = _mm512_fmadd_pd(v, _mm512_loadu_pd(q + 16), a2);
        }
        _mm512_storeu_pd(o, a0);
        _mm512_storeu_pd(o + 8, a1);
        _mm512_storeu_pd(o + 16, a2);
    }
}
#endif

static void panel(int wide, const double *a, size_t sp, size_t sk, size_t rows, size_t kc,
                  const double *b, size_t ldb, double *acc, size_t lda)
{
#ifdef MLR_GRBF_X86
    if (wide) {
        panel_avx512(a, sp, sk, rows, kc, b, ldb, acc, lda);
        return;
    }
#endif
    (void)wide;
    panel_generic(a, sp, sk, rows, kc, b, ldb, acc, lda);
}

static void eval_task(void *ctx, size_t task)
{
    const eval_ctx *c = ctx;
    const size_t i0 = task * EVAL_ROWS;
    const size_t rows = c->n - i0 < EVAL_ROWS ? c->n - i0 : EVAL_ROWS;
    double bas[EVAL_ROWS * EVAL_KC], acc[EVAL_ROWS * EVAL_GROUP * EVAL_PANEL];
    for (size_t g0 = 0; g0 < c->npanel; g0 += EVAL_GROUP) {
        const size_t gp = c->npanel - g0 < EVAL_GROUP ? c->npanel - g0 : EVAL_GROUP;
        const size_t lda = gp * EVAL_PANEL;
        memset(acc, 0, rows * lda * sizeof(double));
        for (size_t k0 = 0; k0 < c->K; k0 += EVAL_KC) {
            const size_t kc = c->K - k0 < EVAL_KC ? c->K - k0 : EVAL_KC;
            for (size_t p = 0; p < rows; p++)
                basis_segment(c, c->x + (i0 + p) * c->ldx, k0, kc, bas + p * EVAL_KC);
            for (size_t q = 0; q < gp; q++)
                panel(c->wide, bas, EVAL_KC, 1, rows, kc,
                      c->pan + ((g0 + q) * c->K + k0) * EVAL_PANEL, EVAL_PANEL,
                      acc + q * EVAL_PANEL, lda);
        }
        const size_t o0 = g0 * EVAL_PANEL;
        const size_t no = c->n_out - o0 < lda ? c->n_out - o0 : lda;
        for (size_t p = 0; p < rows; p++)
            memcpy(c->out + (i0 + p) * c->ldo + o0, acc + p * lda, no * sizeof(double));
    }
}

mlr_status mlr_grbf_eval(int kernel, double width, const double *centers, size_t n_centers,
                         size_t ldc, const double *coef, size_t ldcoef, size_t n_out,
                         const double *x, size_t n, size_t ldx, size_t dim, size_t n_threads,
                         double *out, size_t ldo, const mlr_allocator *alloc, mlr_diag *diag)
{
    size_t ct_bytes;
    mlr_status st = check_common(kernel, width, centers, n_centers, ldc, x, n, ldx, dim,
                                 n_threads, &ct_bytes, diag);
    if (st)
        return st;
    const size_t K = n_centers + 1 + dim;
    if (n_out == 0 || !coef || (n > 0 && !out))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "no outputs (n_out %zu) or coef or out NULL", n_out);
    if (ldcoef < n_out || ldo < n_out)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "dimension mismatch: strides ldcoef %zu, ldo %zu < n_out %zu",
                            ldcoef, ldo, n_out);
    size_t npanel = n_out / EVAL_PANEL + (n_out % EVAL_PANEL != 0), pan_n, pan_bytes;
    if (rows_overflow(n, ldo) || rows_overflow(K, ldcoef) ||
        mlr_mul_size(npanel * EVAL_PANEL, K, &pan_n) ||
        mlr_mul_size(pan_n, sizeof(double), &pan_bytes) || ct_bytes > SIZE_MAX - pan_bytes)
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "evaluation workspace overflows");
    if ((st = check_data(centers, n_centers, ldc, x, n, ldx, dim, diag)))
        return st;
    size_t bad = mlr_first_nonfinite_row(coef, K, n_out, ldcoef);
    if (bad < K)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "coefficient row %zu holds a NaN or an infinity", bad);
    if (n == 0)
        return MLR_OK;
    mlr_allocator a;
    mlr_allocator_resolve(alloc, &a);
    double *ws = mlr_alloc(&a, ct_bytes + pan_bytes);
    if (!ws)
        return mlr_diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                            "no memory for the evaluation workspace (%zu bytes)",
                            ct_bytes + pan_bytes);
    double *ct = ws, *pan = ws + ct_bytes / sizeof(double);
    transpose_centres(centers, n_centers, ldc, dim, ct);
    for (size_t q = 0; q < npanel; q++) /* pan[(q K + k) 24 + l] = B[k][24 q + l], 0 padded */
        for (size_t k = 0; k < K; k++)
            for (size_t l = 0; l < EVAL_PANEL; l++) {
                size_t o = q * EVAL_PANEL + l;
                pan[(q * K + k) * EVAL_PANEL + l] = o < n_out ? coef[k * ldcoef + o] : 0.0;
            }
    eval_ctx c = {kernel, 0, kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0,
                  ct, x, pan, n_centers, dim, ldx, n, K, npanel, n_out, ldo, out};
    c.wide = cpu_wide();
    mlr_parallel_run(n_threads, (n + EVAL_ROWS - 1) / EVAL_ROWS, eval_task, &c);
    mlr_free(&a, ws, ct_bytes + pan_bytes);
    return MLR_OK;
}

/* ---- interpolation on a symmetric lattice ------------------------------------------------------
 * Notation of mlr_grbf.h: representatives i = (r, c) with r < Rh = ceil(R/2), c < Ch = ceil(C/2)
 * (index r * Ch + c), the four reflections g, class (sx, sy) with characters chi(g) = 1, sx, sy,
 * sx sy. Each class is solved by one thread, so the result does not depend on the count. */

/* sum_t a[t] b[t] in 32 interleaved sums (four vectors of independent chains), reduced in a
 * fixed order. Inlined into the cloned callers, which vectorize it. */
static inline double dot32(const double *a, const double *b, size_t n)
{
    double s[32] = {0};
    size_t t = 0;
    for (; t + 32 <= n; t += 32)
        for (size_t l = 0; l < 32; l++)
            s[l] += a[t + l] * b[t + l];
    for (size_t l = 0; t + l < n; l++)
        s[l] += a[t + l] * b[t + l];
    for (size_t w = 16; w >= 1; w /= 2)
        for (size_t l = 0; l < w; l++)
            s[l] += s[l + w];
    return s[0];
}

/* y[t] -= f x[t] */
static inline void axpy_sub(double *restrict y, double f, const double *restrict x, size_t n)
{
    for (size_t t = 0; t < n; t++)
        y[t] -= f * x[t];
}

/* In-place Cholesky A = L L^T of the n x n matrix at a (row stride lda; the lower triangle is
 * read and overwritten by L), left-looking by blocks of PANEL columns: the block's columns of
 * every row below get the products with the columns before the block from the product kernel
 * (the block's rows packed transposed into pk, n x PANEL), then the block is finished column by
 * column. Returns 0, or -1 at a pivot that is not positive and finite. */
static int cholesky_lower(double *a, size_t n, size_t lda, double *pk, int wide)
{
    double acc[8 * PANEL];
    for (size_t j0 = 0; j0 < n; j0 += PANEL) {
        const size_t jb = n - j0 < PANEL ? n - j0 : PANEL;
        for (size_t q = 0; q < j0; q++) /* pk[q][c] = L[j0 + c][q] */
            for (size_t c = 0; c < PANEL; c++)
                pk[q * PANEL + c] = c < jb ? a[(j0 + c) * lda + q] : 0.0;
        for (size_t i0 = j0; i0 < n && j0 > 0; i0 += 8) {
            const size_t rb = n - i0 < 8 ? n - i0 : 8;
            memset(acc, 0, sizeof acc);
            panel(wide, a + i0 * lda, lda, 1, rb, j0, pk, PANEL, acc, PANEL);
            for (size_t p = 0; p < rb; p++) {
                double *ai = a + (i0 + p) * lda + j0;
                const size_t cmax = i0 + p - j0 + 1 < jb ? i0 + p - j0 + 1 : jb;
                for (size_t c = 0; c < cmax; c++)
                    ai[c] -= acc[p * PANEL + c];
            }
        }
        for (size_t c = 0; c < jb; c++) { /* the block itself, then its column below */
            double *aj = a + (j0 + c) * lda + j0;
            double d = aj[c];
            for (size_t t = 0; t < c; t++)
                d -= aj[t] * aj[t];
            if (!(d > 0.0) || !(d < INFINITY))
                return -1;
            d = sqrt(d);
            aj[c] = d;
            const double inv = 1.0 / d;
            for (size_t i = j0 + c + 1; i < n; i++) {
                double *ai = a + i * lda + j0, v = ai[c];
                for (size_t t = 0; t < c; t++)
                    v -= ai[t] * aj[t];
                ai[c] = v * inv;
            }
        }
    }
    return 0;
}

/* X = (L L^T)^-1 X for the factor of cholesky_lower; X n x (np PANEL) (padded), row stride ldx.
 * By blocks of 8 rows: the product kernel takes the rows already solved, the 8 x 8 diagonal
 * block is solved by substitution. */
static void cholesky_solve(const double *l, size_t n, size_t ldl, double *x, size_t ldx,
                           size_t np, int wide, double *acc)
{
    const size_t w = np * PANEL;
    for (size_t i0 = 0; i0 < n; i0 += 8) { /* L y = x */
        const size_t rb = n - i0 < 8 ? n - i0 : 8;
        memset(acc, 0, rb * w * sizeof(double));
        for (size_t q = 0; q < np && i0 > 0; q++)
            panel(wide, l + i0 * ldl, ldl, 1, rb, i0, x + q * PANEL, ldx, acc + q * PANEL, w);
        for (size_t p = 0; p < rb; p++) {
            double *xi = x + (i0 + p) * ldx;
            const double *li = l + (i0 + p) * ldl;
            for (size_t t = 0; t < w; t++)
                xi[t] -= acc[p * w + t];
            for (size_t p2 = 0; p2 < p; p2++)
                axpy_sub(xi, li[i0 + p2], x + (i0 + p2) * ldx, w);
            const double inv = 1.0 / li[i0 + p];
            for (size_t t = 0; t < w; t++)
                xi[t] *= inv;
        }
    }
    for (size_t e = n; e > 0;) { /* L^T x = y, blocks from the bottom */
        const size_t rb = e % 8 ? e % 8 : 8, i0 = e - rb, done = n - e;
        memset(acc, 0, rb * w * sizeof(double));
        for (size_t q = 0; q < np && done > 0; q++) /* sum_{k >= e} L[k][i] x_k */
            panel(wide, l + e * ldl + i0, 1, ldl, rb, done, x + e * ldx + q * PANEL, ldx,
                  acc + q * PANEL, w);
        for (size_t p = rb; p-- > 0;) {
            double *xi = x + (i0 + p) * ldx;
            for (size_t t = 0; t < w; t++)
                xi[t] -= acc[p * w + t];
            for (size_t p2 = p + 1; p2 < rb; p2++)
                axpy_sub(xi, l[(i0 + p2) * ldl + i0 + p], x + (i0 + p2) * ldx, w);
            const double inv = 1.0 / l[(i0 + p) * ldl + i0 + p];
            for (size_t t = 0; t < w; t++)
                xi[t] *= inv;
        }
        e = i0;
    }
}

/* X = (I - beta v v^T) X for X k x m (row-major), t: m values of scratch. */
GRBF_CLONES
static void householder_rows(double *x, size_t k, size_t m, const double *v, double beta,
                             double *t)
{
    for (size_t o = 0; o < m; o++)
        t[o] = 0.0;
    for (size_t i = 0; i < k; i++)
        axpy_sub(t, -v[i], x + i * m, m);
    for (size_t i = 0; i < k; i++)
        axpy_sub(x + i * m, beta * v[i], t, m);
}

typedef struct lattice_ctx {
    size_t R, C, Rh, Ch, n_out, mp, ldy; /* mp: n_out rounded up to PANEL */
    const double *xs, *ys, *y, *krow;   /* krow: Rh Ch rows of the R C kernel values */
    double xm, ym;
    int wide;
    /* per class: matrix (k x k), right-hand sides then solution (k x mp, zero padded), work
     * (LATTICE_WORK); the polynomial coefficient of classes 0, 1, 2 (n_out each) */
    double *a[4], *x[4], *v[4], *poly_a[3];
    int failed[4];
} lattice_ctx;

/* Work doubles of a class of at most nr unknowns: v and z (2 nr), t (mp), the packed block of
 * the Cholesky (nr PANEL) and the accumulators of the solves (8 mp). */
#define LATTICE_WORK(nr, mp) ((2 + PANEL) * (nr) + 9 * (mp))

static double lattice_scale(const lattice_ctx *c, size_t r, size_t col)
{
    double s = 1.0; /* sqrt of the stabilizer size */
    if (c->R % 2 && r == c->Rh - 1)
        s *= 1.4142135623730950488;
    if (c->C % 2 && col == c->Ch - 1)
        s *= 1.4142135623730950488;
    return s;
}

static void lattice_class_task(void *ctx, size_t cls)
{
    lattice_ctx *c = ctx;
    const double sx = cls & 1 ? -1.0 : 1.0, sy = cls & 2 ? -1.0 : 1.0;
    const size_t R = c->R, C = c->C, Ch = c->Ch, m = c->n_out, mp = c->mp, np = mp / PANEL;
    const size_t rv = sx > 0 ? c->Rh : R / 2, cv = sy > 0 ? Ch : C / 2, k = rv * cv;
    double *A = c->a[cls], *X = c->x[cls], *v = c->v[cls], *z = v + k, *t = z + k;
    double *pk = t + mp, *acc = pk + k * PANEL;
    /* lower triangle of sum_g chi(g) K[i, g j] / sqrt(s_i s_j), mirrored */
    for (size_t i = 0; i < k; i++) {
        const size_t ri = i / cv, ci = i % cv;
        const double *kr = c->krow + (ri * Ch + ci) * (R * C), si = lattice_scale(c, ri, ci);
        for (size_t j = 0; j <= i; j++) {
            const size_t rj = j / cv, cj = j % cv, rr = R - 1 - rj, cr = C - 1 - cj;
            double sum = kr[rj * C + cj] + sx * kr[rr * C + cj] + sy * kr[rj * C + cr] +
                         sx * sy * kr[rr * C + cr];
            A[i * k + j] = A[j * k + i] = sum / (si * lattice_scale(c, rj, cj));
        }
        const double *y0 = c->y + (ri * C + ci) * c->ldy, *y1 = c->y + ((R - 1 - ri) * C + ci) * c->ldy;
        const double *y2 = c->y + (ri * C + C - 1 - ci) * c->ldy;
        const double *y3 = c->y + ((R - 1 - ri) * C + C - 1 - ci) * c->ldy;
        for (size_t o = 0; o < m; o++)
            X[i * mp + o] = (y0[o] + sx * y1[o] + sy * y2[o] + sx * sy * y3[o]) / (2.0 * si);
        for (size_t o = m; o < mp; o++)
            X[i * mp + o] = 0.0;
        /* the class's polynomial, 2 p(i) / sqrt(s_i): 1, x - xm, y - ym */
        v[i] = cls == 0 ? 2.0 / si
             : cls == 1 ? 2.0 * (c->xs[ri] - c->xm) / si
             : cls == 2 ? 2.0 * (c->ys[ci] - c->ym) / si : 0.0;
    }
    if (cls == 3) { /* no polynomial term: K is positive definite on the whole class */
        if (cholesky_lower(A, k, k, pk, c->wide)) {
            c->failed[cls] = 1;
            return;
        }
        cholesky_solve(A, k, k, X, mp, np, c->wide, acc);
        return;
    }
    /* Householder H = I - beta v v^T with H p = alpha e_0; w = H [0; w'] satisfies p^T w = 0,
     * and (H A H)[1:, 1:] w' = (H y)[1:] is positive definite */
    double pn = sqrt(dot32(v, v, k));
    if (!(pn > 0.0)) {
        c->failed[cls] = 1;
        return;
    }
    const double alpha = v[0] >= 0 ? -pn : pn;
    v[0] -= alpha;
    const double beta = 2.0 / dot32(v, v, k);
    for (size_t i = 0; i < k; i++)
        z[i] = beta * dot32(A + i * k, v, k); /* beta A v */
    const double g = 0.5 * beta * dot32(v, z, k);
    for (size_t i = 0; i < k; i++)
        z[i] -= g * v[i]; /* z = beta A v - (beta^2 v^T A v / 2) v: H A H = A - v z^T - z v^T */
    for (size_t i = 0; i < k; i++)
        for (size_t j = 0; j < k; j++)
            A[i * k + j] -= v[i] * z[j] + z[i] * v[j];
    householder_rows(X, k, mp, v, beta, t); /* X = H X */
    if (cholesky_lower(A + k + 1, k - 1, k, pk, c->wide)) {
        c->failed[cls] = 1;
        return;
    }
    cholesky_solve(A + k + 1, k - 1, k, X + mp, mp, np, c->wide, acc);
    double *pa = c->poly_a[cls];
    for (size_t o = 0; o < m; o++) /* alpha a = (H y)_0 - (H A H)[0, 1:] w' */
        pa[o] = X[o];
    for (size_t j = 1; j < k; j++)
        axpy_sub(pa, A[j], X + j * mp, m);
    for (size_t o = 0; o < mp; o++)
        X[o] = 0.0;
    for (size_t o = 0; o < m; o++)
        pa[o] /= alpha;
    householder_rows(X, k, mp, v, beta, t); /* w = H [0; w'] */
}

mlr_status mlr_grbf_fit_lattice(int kernel, double width, const double *xs, size_t rows,
                                const double *ys, size_t cols, const double *y, size_t ldy,
                                size_t n_out, size_t n_threads, double *coef, size_t ldcoef,
                                const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_status st = check_kernel(kernel, width, diag);
    if (st != MLR_OK)
        return st;
    if (rows < 2 || cols < 2)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "lattice %zu x %zu: needs at least 2 x 2 (the linear terms)", rows,
                            cols);
    if (!xs || !ys || !y || !coef || n_out == 0)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "xs, ys, y or coef NULL, or no outputs (n_out %zu)", n_out);
    if (ldy < n_out || ldcoef < n_out)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "dimension mismatch: strides ldy %zu, ldcoef %zu < n_out %zu", ldy,
                            ldcoef, n_out);
    if (n_threads < 1 || n_threads > MLR_MAX_THREADS)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "n_threads %zu not in 1 .. %d",
                            n_threads, MLR_MAX_THREADS);
    const size_t Rh = (rows + 1) / 2, Ch = (cols + 1) / 2;
    size_t N, nr, nkrow, kk, total = 0;
    if (mlr_mul_size(rows, cols, &N) || N > SIZE_MAX / 4 - 3 || mlr_mul_size(Rh, Ch, &nr) ||
        mlr_mul_size(nr, N, &nkrow) || mlr_mul_size(nr, nr, &kk) || rows_overflow(N, ldy) ||
        rows_overflow(N + 3, ldcoef))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
    /* workspace: transposed centres (2 N), representatives (2 nr), kernel rows (nr N), and per
     * class a matrix (<= nr^2), the right-hand sides (<= nr n_out), work (2 nr + n_out); the
     * three polynomial coefficients (n_out each) */
    if (n_out > SIZE_MAX / 16 - PANEL || nr > SIZE_MAX / (4 * (PANEL + 2)))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
    const size_t mp = (n_out + PANEL - 1) / PANEL * PANEL;
    size_t parts[] = {2 * N, 2 * nr, nkrow, kk, kk, kk, kk, 0, 0, 0, 0, 0, 0, 0, 0, 3 * n_out};
    for (size_t q = 7; q < 11; q++)
        if (mlr_mul_size(nr, mp, &parts[q]))
            return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
    for (size_t q = 11; q < 15; q++)
        parts[q] = LATTICE_WORK(nr, mp);
    for (size_t q = 0; q < MLR_COUNTOF(parts); q++) {
        if (parts[q] > SIZE_MAX / sizeof(double) - total)
            return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "lattice workspace overflows");
        total += parts[q];
    }
    size_t bad = first_bad_row(xs, 1, rows, rows);
    if (bad == 0 || first_bad_row(ys, 1, cols, cols) == 0)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "lattice coordinates hold a NaN, an infinity or a value beyond 1e150");
    /* the reflections must map the lattice onto itself */
    double xm = 0.5 * (xs[0] + xs[rows - 1]), ym = 0.5 * (ys[0] + ys[cols - 1]);
    double xe = fabs(xs[rows - 1] - xs[0]), ye = fabs(ys[cols - 1] - ys[0]);
    for (size_t r = 0; r < rows; r++)
        if (!(fabs(xs[r] + xs[rows - 1 - r] - 2.0 * xm) <= 1e-12 * xe))
            return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "xs is not symmetric about its middle (xs[%zu] + xs[%zu])", r,
                                rows - 1 - r);
    for (size_t c = 0; c < cols; c++)
        if (!(fabs(ys[c] + ys[cols - 1 - c] - 2.0 * ym) <= 1e-12 * ye))
            return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "ys is not symmetric about its middle (ys[%zu] + ys[%zu])", c,
                                cols - 1 - c);
    bad = mlr_first_nonfinite_row(y, N, n_out, ldy);
    if (bad < N)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "y row %zu holds a NaN or an infinity",
                            bad);
    mlr_allocator a;
    mlr_allocator_resolve(alloc, &a);
    double *ws = mlr_alloc(&a, total * sizeof(double));
    if (!ws)
        return mlr_diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                            "no memory for the lattice workspace (%zu doubles)", total);
    double *ptr[MLR_COUNTOF(parts)];
    for (size_t q = 0, off = 0; q < MLR_COUNTOF(parts); off += parts[q], q++)
        ptr[q] = ws + off;
    double *ct = ptr[0], *rep = ptr[1], *krow = ptr[2];
    for (size_t u = 0; u < N; u++) {
        ct[u] = xs[u / cols];
        ct[N + u] = ys[u % cols];
    }
    for (size_t i = 0; i < nr; i++) {
        rep[2 * i] = xs[i / Ch];
        rep[2 * i + 1] = ys[i % Ch];
    }
    basis_ctx bc = {kernel, 0, kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0,
                    ct, rep, N, 2, nr, 2, N, krow};
    mlr_parallel_run(n_threads, (nr + GRBF_TASK_ROWS - 1) / GRBF_TASK_ROWS, basis_task, &bc);
    lattice_ctx lc = {rows, cols, Rh, Ch, n_out, mp, ldy, xs, ys, y, krow, xm, ym, cpu_wide(),
                      {ptr[3], ptr[4], ptr[5], ptr[6]}, {ptr[7], ptr[8], ptr[9], ptr[10]},
                      {ptr[11], ptr[12], ptr[13], ptr[14]},
                      {ptr[15], ptr[15] + n_out, ptr[15] + 2 * n_out}, {0, 0, 0, 0}};
    mlr_parallel_run(n_threads, 4, lattice_class_task, &lc);
    st = MLR_OK;
    for (size_t cls = 0; cls < 4; cls++)
        if (lc.failed[cls] && !st)
            st = mlr_diag_set(diag, MLR_E_SINGULAR, 0, 0,
                              "symmetry class %zu of the kernel matrix is not numerically "
                              "positive definite (coincident centres or a too wide Gaussian)",
                              cls);
    if (!st) {
        for (size_t u = 0; u < N + 3; u++)
            memset(coef + u * ldcoef, 0, n_out * sizeof(double));
        for (size_t cls = 0; cls < 4; cls++) {
            const double sx = cls & 1 ? -1.0 : 1.0, sy = cls & 2 ? -1.0 : 1.0;
            const size_t rv = sx > 0 ? Rh : rows / 2, cv = sy > 0 ? Ch : cols / 2;
            for (size_t i = 0; i < rv * cv; i++) {
                const size_t ri = i / cv, ci = i % cv, rr = rows - 1 - ri, cr = cols - 1 - ci;
                const double f = 1.0 / (2.0 * lattice_scale(&lc, ri, ci));
                const double *w = lc.x[cls] + i * mp;
                /* w[g i] += chi(g) w_i / (2 sqrt(s_i)); a fixed centre gets its share twice */
                axpy_sub(coef + (ri * cols + ci) * ldcoef, -f, w, n_out);
                axpy_sub(coef + (rr * cols + ci) * ldcoef, -sx * f, w, n_out);
                axpy_sub(coef + (ri * cols + cr) * ldcoef, -sy * f, w, n_out);
                axpy_sub(coef + (rr * cols + cr) * ldcoef, -sx * sy * f, w, n_out);
            }
        }
        double *c0 = coef + N * ldcoef, *c1 = c0 + ldcoef, *c2 = c1 + ldcoef;
        for (size_t o = 0; o < n_out; o++) { /* a0 + ax (x - xm) + ay (y - ym) */
            c1[o] = lc.poly_a[1][o];
            c2[o] = lc.poly_a[2][o];
            c0[o] = lc.poly_a[0][o] - (c1[o] * xm + c2[o] * ym);
        }
    }
    mlr_free(&a, ws, total * sizeof(double));
    return st;
}
