/* GRBF basis matrices: kernel values of many points against a set of centres, and their
 * evaluation psi(x) B. See mlr_grbf.h. The fit on a symmetric lattice is in grbf_lattice.c. */
#include "manifold/grbf_internal.h"

#include <float.h>
#include <math.h>

/* Coordinates beyond this are refused: squared distances then stay far from overflow. */
#define GRBF_MAX_COORD 1e150

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
MLR_CLONES("avx512f", "avx2")
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
MLR_CLONES("avx512f", "avx2")
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
MLR_CLONES("avx512f", "avx2")
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

/* 1 when the AVX-512 product kernel may run (resolved once per call, common/cpu.h). */
int grbf__cpu_wide(void) { return cpu__isa(MLR_ISA_BEST) >= MLR_ISA_AVX512; }

void grbf__basis_task(void *ctx, size_t task)
{
    const basis_ctx *c = ctx;
    size_t i0 = task * GRBF_TASK_ROWS,
           i1 = i0 + GRBF_TASK_ROWS < c->n ? i0 + GRBF_TASK_ROWS : c->n;
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
size_t grbf__first_bad_row(const double *p, size_t n, size_t dim, size_t ld)
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
int grbf__rows_overflow(size_t n, size_t ld)
{
    size_t span;
    return n > 0 && (common__mul_size(n - 1, ld, &span) || span > SIZE_MAX / sizeof(double) - ld);
}

/* The kernel id and, for the Gaussian, its width. */
mlr_status grbf__check_kernel(int kernel, double width, mlr_diag *diag)
{
    if (kernel != MLR_GRBF_THIN_PLATE && kernel != MLR_GRBF_GAUSSIAN)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown GRBF kernel %d", kernel);
    if (kernel == MLR_GRBF_GAUSSIAN &&
        !(width > 0 && width < INFINITY && 1.0 / (width * width) < INFINITY))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "Gaussian width must be finite and >= 1e-150, got %g", width);
    return MLR_OK;
}

/* Argument checks shared by mlr_grbf_basis and mlr_grbf_eval (the data are scanned later, by
 * check_data, once the sizes are known to be sane); fills *ct_bytes (the transposed centres). */
static mlr_status check_common(int kernel, double width, const double *centers, size_t n_centers,
                               size_t ldc, const double *x, size_t n, size_t ldx, size_t dim,
                               size_t n_threads, size_t *ct_bytes, mlr_diag *diag)
{
    mlr_status st = grbf__check_kernel(kernel, width, diag);
    if (st != MLR_OK)
        return st;
    if (n_centers == 0 || dim == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%zu centres of dimension %zu: both must be >= 1", n_centers, dim);
    if (!centers || (n > 0 && !x))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "centers or x is NULL");
    if (ldc < dim || ldx < dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: strides ldc %zu, ldx %zu < dim %zu", ldc, ldx,
                                dim);
    if (n_threads < 1 || n_threads > MLR_MAX_THREADS)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "n_threads %zu not in 1 .. %d",
                                n_threads, MLR_MAX_THREADS);
    size_t nct;
    if (common__mul_size(n_centers, dim, &nct) ||
        common__mul_size(nct, sizeof(double), ct_bytes) || dim > SIZE_MAX - 1 - n_centers ||
        grbf__rows_overflow(n_centers, ldc) || grbf__rows_overflow(n, ldx))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "input or workspace size overflows");
    return MLR_OK;
}

static mlr_status check_data(const double *centers, size_t n_centers, size_t ldc, const double *x,
                             size_t n, size_t ldx, size_t dim, mlr_diag *diag)
{
    size_t bad = grbf__first_bad_row(centers, n_centers, dim, ldc);
    if (bad < n_centers)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "centre %zu holds a NaN, an infinity or a coordinate beyond 1e150",
                                bad);
    bad = grbf__first_bad_row(x, n, dim, ldx);
    if (bad < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
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
    size_t bytes = 0;
    mlr_status st = check_common(kernel, width, centers, n_centers, ldc, x, n, ldx, dim, n_threads,
                                 &bytes, diag);
    if (st)
        return st;
    size_t cols = n_centers + (poly ? 1 + dim : 0);
    if (n > 0 && !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    if (ldo < cols)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "output stride ldo %zu < %zu basis columns", ldo, cols);
    if (grbf__rows_overflow(n, ldo))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "output size overflows");
    if ((st = check_data(centers, n_centers, ldc, x, n, ldx, dim, diag)))
        return st;
    if (n == 0)
        return MLR_OK;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *ct = common__alloc(&a, bytes);
    if (!ct)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "grbf basis: out of memory for %zu centres", n_centers);
    transpose_centres(centers, n_centers, ldc, dim, ct);
    basis_ctx c = {kernel, poly != 0, kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0,
                   ct,     x,         n_centers,
                   ldx,    n,         dim,
                   ldo,    out};
    parallel__run(n_threads, (n + GRBF_TASK_ROWS - 1) / GRBF_TASK_ROWS, grbf__basis_task, &c);
    common__free(&a, ct, bytes);
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
    size_t ct_bytes = 0;
    mlr_status st = check_common(kernel, width, centers, n_centers, ldc, x, n, ldx, dim, n_threads,
                                 &ct_bytes, diag);
    if (st)
        return st;
    const size_t K = n_centers + 1 + dim;
    if (n_out == 0 || !coef || (n > 0 && !out))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "no outputs (n_out %zu) or coef or out NULL", n_out);
    if (ldcoef < n_out || ldo < n_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: strides ldcoef %zu, ldo %zu < n_out %zu",
                                ldcoef, ldo, n_out);
    size_t npanel = n_out / EVAL_PANEL + (n_out % EVAL_PANEL != 0), pan_n, pan_bytes;
    if (grbf__rows_overflow(n, ldo) || grbf__rows_overflow(K, ldcoef) ||
        common__mul_size(npanel * EVAL_PANEL, K, &pan_n) ||
        common__mul_size(pan_n, sizeof(double), &pan_bytes) || ct_bytes > SIZE_MAX - pan_bytes)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "evaluation workspace overflows");
    if ((st = check_data(centers, n_centers, ldc, x, n, ldx, dim, diag)))
        return st;
    size_t bad = cluster__first_nonfinite_row(coef, K, n_out, ldcoef);
    if (bad < K)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "coefficient row %zu holds a NaN or an infinity", bad);
    if (n == 0)
        return MLR_OK;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double *ws = common__alloc(&a, ct_bytes + pan_bytes);
    if (!ws)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "grbf eval: out of memory for the workspace (%zu bytes)",
                                ct_bytes + pan_bytes);
    grbf_eval_plan plan;
    grbf__eval_plan_init(&plan, kernel, width, centers, n_centers, ldc, coef, ldcoef, n_out, dim,
                         ws);
    eval_ctx c = {plan.kernel, plan.wide, plan.s, plan.ct, x,     plan.pan, n_centers, dim,
                  ldx,         n,         K,      npanel,  n_out, ldo,      out};
    parallel__run(n_threads, (n + EVAL_ROWS - 1) / EVAL_ROWS, eval_task, &c);
    common__free(&a, ws, ct_bytes + pan_bytes);
    return MLR_OK;
}

size_t grbf__eval_plan_bytes(size_t n_centers, size_t dim, size_t n_out)
{
    const size_t npanel = n_out / EVAL_PANEL + (n_out % EVAL_PANEL != 0);
    size_t ct, pan, K;
    if (dim > SIZE_MAX - 1 - n_centers)
        return 0;
    K = n_centers + 1 + dim;
    if (common__mul_size(n_centers, dim, &ct) || common__mul_size(npanel * EVAL_PANEL, K, &pan) ||
        ct > SIZE_MAX / sizeof(double) - pan)
        return 0;
    return (ct + pan) * sizeof(double);
}

void grbf__eval_plan_init(grbf_eval_plan *p, int kernel, double width, const double *centers,
                          size_t n_centers, size_t ldc, const double *coef, size_t ldcoef,
                          size_t n_out, size_t dim, double *ws)
{
    const size_t K = n_centers + 1 + dim;
    const size_t npanel = n_out / EVAL_PANEL + (n_out % EVAL_PANEL != 0);
    double *ct = ws, *pan = ws + n_centers * dim;
    transpose_centres(centers, n_centers, ldc, dim, ct);
    for (size_t q = 0; q < npanel; q++) /* pan[(q K + k) 24 + l] = B[k][24 q + l], 0 padded */
        for (size_t k = 0; k < K; k++)
            for (size_t l = 0; l < EVAL_PANEL; l++) {
                size_t o = q * EVAL_PANEL + l;
                pan[(q * K + k) * EVAL_PANEL + l] = o < n_out ? coef[k * ldcoef + o] : 0.0;
            }
    p->kernel = kernel;
    p->wide = grbf__cpu_wide();
    p->s = kernel == MLR_GRBF_GAUSSIAN ? 1.0 / (width * width) : 0.0;
    p->ct = ct;
    p->pan = pan;
    p->nc = n_centers;
    p->dim = dim;
    p->K = K;
    p->npanel = npanel;
    p->n_out = n_out;
}

void grbf__eval_plan_rows(const grbf_eval_plan *p, const double *x, size_t n, size_t ldx,
                          double *out, size_t ldo)
{
    eval_ctx c = {p->kernel, p->wide, p->s, p->ct,     x,        p->pan, p->nc, p->dim,
                  ldx,       n,       p->K, p->npanel, p->n_out, ldo,    out};
    for (size_t t = 0; t < (n + EVAL_ROWS - 1) / EVAL_ROWS; t++)
        eval_task(&c, t);
}
