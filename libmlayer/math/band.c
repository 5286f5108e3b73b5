/*
 * Banded SPD solver: A = L D L^T with unit lower-triangular L of bandwidth kd.
 * Storage: l[i*kd + (k-1)] = L(i, i-k) for k = 1..kd, dinv[i] = 1 / D(i).
 * Right-hand sides are rows of a row-major n x m matrix, so every update of the forward and
 * backward sweeps is a contiguous axpy over the m channels: the whole solve streams memory.
 */
#include "math/band_internal.h"

#include <math.h>
#include <stdint.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <stdlib.h>

mlr_status mlr_band_create(size_t n, size_t kd, const mlr_allocator *alloc, mlr_band **out,
                           mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "band create: out is NULL");
    *out = NULL;
    if (n == 0 || kd >= n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "band create: n %zu, kd %zu: needs n >= 1 and kd < n", n, kd);
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    size_t nl, bytes;
    if (common__mul_size(n, kd, &nl) || common__mul_size(nl + n, sizeof(double), &bytes))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "band create: n %zu x (kd %zu + 1) doubles overflow a size_t", n,
                                kd);
    mlr_band *b = common__alloc(&a, sizeof *b);
    if (!b)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "band create: out of memory for the handle");
    b->alloc = a;
    b->n = n;
    b->kd = kd;
    b->factored = 0;
    b->bad_row = 0;
    b->storage_bytes = bytes;
    b->dinv = common__alloc(&a, bytes);
    if (!b->dinv) {
        common__free(&a, b, sizeof *b);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "band create: out of memory for the factor (%zu bytes)", bytes);
    }
    b->l = b->dinv + n;
    *out = b;
    return MLR_OK;
}

void mlr_band_destroy(mlr_band *b)
{
    if (!b)
        return;
    mlr_allocator a = b->alloc;
    common__free(&a, b->dinv, b->storage_bytes);
    common__free(&a, b, sizeof *b);
}

/* Pivot below this fraction of its diagonal entry: the factor is usable but inaccurate. */
#define MLR_BAND_ILL_PIVOT 1e-13

/* Pivot checks shared by the factor loops. */
static inline int pivot_ok(double d, double aii, mlr_status *status)
{
    if (!(d > 0.0) || !isfinite(d))
        return 0;
    if (d < MLR_BAND_ILL_PIVOT * fabs(aii))
        *status = MLR_W_ILL_CONDITIONED;
    return 1;
}

mlr_status band__factor_in_place(mlr_band *b)
{
    const size_t n = b->n, kd = b->kd;
    double *l = b->l, *dinv = b->dinv;
    mlr_status status = MLR_OK;
    b->factored = 0;
    if (kd == 2) { /* pentadiagonal, the LGS default: one division per row */
        double pa[3] = {0.0, 0.0, 0.0}; /* A's row i-1 */
        for (size_t i = 0; i < n; i++) {
            double *li = l + 2 * i, aii = dinv[i];
            const double a1 = li[0], a2 = li[1];
            double d = band__ldl2_row(i, aii, a1, a2, i >= 2 ? l[2 * (i - 1)] : 0.0,
                                      i >= 1 ? dinv[i - 1] : 0.0, i >= 2 ? dinv[i - 2] : 0.0,
                                      &li[0], &li[1]);
            if (!pivot_ok(d, aii, &status)) {
                b->bad_row = i;
                return MLR_E_SINGULAR;
            }
            dinv[i] = 1.0 / d;
            /* A Toeplitz stretch (the interior of every smoothing prior) drives the recurrence
             * to a fixed point within a few hundred rows: once a row repeats the previous one
             * bit for bit on the same input, every following row with that input is the same. */
            if (i >= 3 && aii == pa[0] && a1 == pa[1] && a2 == pa[2] && li[0] == li[-2] &&
                li[1] == li[-1] && dinv[i] == dinv[i - 1] && dinv[i - 1] == dinv[i - 2]) {
                while (i + 1 < n && dinv[i + 1] == aii && l[2 * (i + 1)] == a1 &&
                       l[2 * (i + 1) + 1] == a2) {
                    i++;
                    l[2 * i] = li[0];
                    l[2 * i + 1] = li[1];
                    dinv[i] = dinv[i - 1];
                }
            }
            pa[0] = aii, pa[1] = a1, pa[2] = a2;
        }
    } else {
        for (size_t i = 0; i < n; i++) {
            size_t kmax = i < kd ? i : kd;
            /* L(i, j) for j = i-kmax .. i-1, left to right, over A(i, j) in the same slots */
            for (size_t k = kmax; k >= 1; k--) {
                size_t j = i - k;
                double v = l[i * kd + k - 1];
                /* subtract sum_p L(i,p) D(p) L(j,p) over p < j with p >= i - kd */
                for (size_t q = k + 1; q <= kmax; q++) {
                    size_t p = i - q;   /* L(i,p) = l[i*kd + q-1] */
                    size_t kj = j - p;  /* L(j,p) = l[j*kd + kj-1] */
                    v -= l[i * kd + q - 1] * l[j * kd + kj - 1] / dinv[p];
                }
                l[i * kd + k - 1] = v * dinv[j];
            }
            for (size_t k = kmax + 1; k <= kd; k++)
                l[i * kd + k - 1] = 0.0;
            double aii = dinv[i], d = aii;
            for (size_t k = 1; k <= kmax; k++) {
                double lik = l[i * kd + k - 1];
                d -= lik * lik / dinv[i - k];
            }
            if (!pivot_ok(d, aii, &status)) {
                b->bad_row = i;
                return MLR_E_SINGULAR;
            }
            dinv[i] = 1.0 / d;
        }
    }
    b->factored = 1;
    return status;
}

mlr_status mlr_band_factor(mlr_band *b, const double *ab, size_t ldab, mlr_diag *diag)
{
    if (!b || !ab)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "band factor: %s is NULL",
                                !b ? "band" : "ab");
    if (ldab < b->kd + 1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "band factor: ldab %zu < kd + 1 = %zu", ldab, b->kd + 1);
    const size_t n = b->n, kd = b->kd;
    for (size_t i = 0; i < n; i++) {
        b->dinv[i] = ab[i * ldab];
        for (size_t k = 1; k <= kd; k++)
            b->l[i * kd + k - 1] = k <= i ? ab[(i - k) * ldab + k] : 0.0;
    }
    const mlr_status st = band__factor_in_place(b);
    if (st == MLR_E_SINGULAR)
        return common__diag_set(
            diag, st, 0, 0,
            "band factor: ab is not positive definite (the pivot of row %zu is "
            "<= 0 or not finite)",
            b->bad_row);
    return st;
}

/* Row kernels: the rows are distinct, so restrict lets the compiler vectorize over channels. */
static inline void row_sub1(double *restrict xi, const double *restrict x1, double l1, size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] -= l1 * x1[c];
}

static inline void row_sub2(double *restrict xi, const double *restrict x1,
                            const double *restrict x2, double l1, double l2, size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] -= l1 * x1[c] + l2 * x2[c];
}

static inline void row_scale_sub1(double *restrict xi, const double *restrict x1, double di,
                                  double l1, size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] = xi[c] * di - l1 * x1[c];
}

static inline void row_scale_sub2(double *restrict xi, const double *restrict x1,
                                  const double *restrict x2, double di, double l1, double l2,
                                  size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] = xi[c] * di - (l1 * x1[c] + l2 * x2[c]);
}

/* x_i = y_i - l1 x_{i-1} - l2 x_{i-2}: the forward sweep fused with the copy of the input. */
static inline void row_from2(double *restrict xi, const double *restrict yi,
                             const double *restrict x1, const double *restrict x2, double l1,
                             double l2, size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] = yi[c] - (l1 * x1[c] + l2 * x2[c]);
}

static inline void row_from1(double *restrict xi, const double *restrict yi,
                             const double *restrict x1, double l1, size_t m)
{
    for (size_t c = 0; c < m; c++)
        xi[c] = yi[c] - l1 * x1[c];
}

MLR_CLONES("avx512f", "avx2")
void band__forward_row_from(const mlr_band *b, size_t i, const double *yi, double *xi, size_t ld,
                            size_t m)
{
    const size_t kd = b->kd;
    const double *li = b->l + i * kd;
    size_t kmax = i < kd ? i : kd;
    if (kmax == 2) {
        row_from2(xi, yi, xi - ld, xi - 2 * ld, li[0], li[1], m);
    } else if (kmax == 1) {
        row_from1(xi, yi, xi - ld, li[0], m);
    } else {
        memcpy(xi, yi, m * sizeof(double));
        for (size_t k = 1; k <= kmax; k++)
            row_sub1(xi, xi - k * ld, li[k - 1], m);
    }
}

/* Forward sweep for one row: x_i -= sum_k L(i,i-k) x_{i-k} (the 1/D scaling comes in the
 * backward sweep). */
MLR_CLONES("avx512f", "avx2")
void band__forward_row(const mlr_band *b, size_t i, double *xi, size_t ld, size_t m)
{
    const size_t kd = b->kd;
    const double *li = b->l + i * kd;
    size_t kmax = i < kd ? i : kd;
    if (kmax == 2) {
        row_sub2(xi, xi - ld, xi - 2 * ld, li[0], li[1], m);
    } else if (kmax == 1) {
        row_sub1(xi, xi - ld, li[0], m);
    } else {
        for (size_t k = 1; k <= kmax; k++)
            row_sub1(xi, xi - k * ld, li[k - 1], m);
    }
}

void band__forward_row_any(const mlr_band *b, size_t i, const double *yi, double *xi, size_t ld,
                           size_t m)
{
    if (yi == xi)
        band__forward_row(b, i, xi, ld, m);
    else
        band__forward_row_from(b, i, yi, xi, ld, m);
}

/* Backward sweep over rows e..a (e >= a) after the forward one, row a at xa, stride ld:
 * x_i = x_i / D_i - sum_k L(i+k,i) x_{i+k}, rows past e taken as zero. */
MLR_CLONES("avx512f", "avx2")
static void backward_range(const mlr_band *b, size_t a, size_t e, double *xa, size_t ld, size_t m)
{
    const size_t kd = b->kd;
    const double *l = b->l, *dinv = b->dinv;
    for (size_t i = e + 1; i-- > a;) {
        double *xi = xa + (i - a) * ld;
        const double di = dinv[i];
        size_t kmax = e - i < kd ? e - i : kd;
        if (kmax == 2) {
            row_scale_sub2(xi, xi + ld, xi + 2 * ld, di, l[(i + 1) * kd], l[(i + 2) * kd + 1], m);
        } else if (kmax == 1) {
            row_scale_sub1(xi, xi + ld, di, l[(i + 1) * kd], m);
        } else {
            for (size_t c = 0; c < m; c++)
                xi[c] *= di;
            for (size_t k = 1; k <= kmax; k++)
                row_sub1(xi, xi + k * ld, l[(i + k) * kd + k - 1], m);
        }
    }
}

void band__backward(const mlr_band *b, double *x, size_t ldx, size_t m)
{
    backward_range(b, 0, b->n - 1, x, ldx, m);
}

/*
 * Single-pass solve by chunks. A chunk [a, e] swept backward with zero rows past e gives p;
 * the true x is p + sum_j h_j x_{e+j}, where h_j solves the homogeneous backward recurrence
 * h_i = -sum_k L(i+k,i) h_{i+k} with h_{e+k} = delta_jk. The recurrence is stable backward,
 * so h_j decays away from e: past MLR_BAND_TAIL_TOL it changes no digit of x. When the decay
 * fits inside every chunk, a chunk's first rows are final as soon as it is swept, and the
 * previous chunk only needs its tail corrected. Each chunk is swept forward into a ring of
 * three cache-sized buffers, then (one chunk later) backward, and its predecessor's tail
 * fixed; that chunk is then final and streams out to x. y is read once and x written once,
 * with non-temporal stores: no read of x's old contents, no write-back of intermediate values.
 */
#define MLR_BAND_TAIL_TOL 1e-20
#define MLR_BAND_TAIL_MAX 1024            /* rows of h kept on the stack (16 KiB for kd = 2) */
#define MLR_BAND_CHUNK_BYTES (512u << 10) /* a chunk of the ring, about 1/8 of a core's L2 */

/* h for the chunk ending at e (e + kd <= n - 1): h[(e - i) * kd + j - 1] for rows i down to
 * e + 1 - *len; returns 0 when it does not decay within max_len rows. */
static int tail_homogeneous(const mlr_band *b, size_t e, size_t max_len, double *h, size_t *len)
{
    const size_t kd = b->kd;
    const double *l = b->l;
    size_t quiet = 0;
    for (size_t r = 0; r < max_len && r <= e; r++) {
        size_t i = e - r;
        double mag = 0.0;
        for (size_t j = 1; j <= kd; j++) {
            double v = 0.0;
            for (size_t k = 1; k <= kd; k++) {
                double hk; /* h_j at row i + k */
                size_t rk = i + k;
                if (rk > e)
                    hk = (rk - e == j) ? 1.0 : 0.0;
                else
                    hk = h[(e - rk) * kd + j - 1];
                v -= l[(i + k) * kd + k - 1] * hk;
            }
            h[r * kd + j - 1] = v;
            mag = fabs(v) > mag ? fabs(v) : mag;
        }
        quiet = mag < MLR_BAND_TAIL_TOL ? quiet + 1 : 0;
        if (quiet >= kd + 1) {
            *len = r + 1;
            return 1;
        }
    }
    return 0;
}

/* Add the true boundary (rows e+1, e+2 at next, stride ld_next) to the tail of the chunk
 * ending at row e (at xe, stride ld). */
MLR_CLONES("avx512f", "avx2")
static void correct_tail(const mlr_band *b, size_t e, double *xe, size_t ld, const double *next,
                         size_t ld_next, size_t m, double *h)
{
    size_t len = 0;
    const size_t kd = b->kd;
    tail_homogeneous(b, e, MLR_BAND_TAIL_MAX, h, &len); /* checked to decay before the solve */
    for (size_t r = 0; r < len; r++) {
        double *xi = xe - r * ld;
        if (kd == 2)
            row_sub2(xi, next, next + ld_next, -h[r * 2], -h[r * 2 + 1], m);
        else
            row_sub1(xi, next, -h[r], m);
    }
}

/* rows x rows of m values from src (stride m) to dst (stride ld), bypassing the cache where
 * the ISA has non-temporal stores (the caller fences once at the end). */
static void stream_out(double *dst, size_t ld, const double *src, size_t m, size_t rows)
{
    if (ld == m) {
        m *= rows;
        rows = 1;
    }
    for (size_t r = 0; r < rows; r++, dst += ld, src += m) {
#if defined(__SSE2__)
        size_t c = 0;
        if ((uintptr_t)dst % 16 != 0 && m > 0)
            dst[c] = src[c], c++;
        for (; c + 2 <= m; c += 2)
            _mm_stream_pd(dst + c, _mm_loadu_pd(src + c));
        for (; c < m; c++)
            dst[c] = src[c];
#else
        memcpy(dst, src, m * sizeof(double));
#endif
    }
}

void band__solve_rows(const mlr_band *b, mlr_band_row_fn forward_row, const void *ctx, double *x,
                      size_t ldx, size_t m)
{
    const size_t n = b->n, kd = b->kd;
    size_t chunk = MLR_BAND_CHUNK_BYTES / (m * sizeof(double) + 1);
    if (chunk < 64)
        chunk = 64;
    double h[MLR_BAND_TAIL_MAX * 2];
    int chunked = (kd == 1 || kd == 2) && n >= 4 * chunk;
    /* every interior chunk's tail must decay within the chunk (and within the buffer) */
    for (size_t e = chunk - 1; chunked && e + chunk < n; e += chunk) {
        size_t len = 0, lim = chunk - kd < MLR_BAND_TAIL_MAX ? chunk - kd : MLR_BAND_TAIL_MAX;
        chunked = tail_homogeneous(b, e, lim, h, &len);
    }
    /* the ring: three slots of kd halo rows (the previous chunk's last forward rows) + chunk */
    const size_t slot = (kd + chunk) * m, ring_bytes = 3 * slot * sizeof(double);
    double *ring = chunked ? common__alloc(&b->alloc, ring_bytes) : NULL;
    if (!ring) { /* small, not chunkable, or no memory: two sweeps over x */
        for (size_t r = 0; r < n; r++)
            forward_row(ctx, r, x + r * ldx, ldx, m);
        band__backward(b, x, ldx, m);
        return;
    }
    /* chunks [k*chunk, min(n, (k+1)*chunk) - 1]; only the last one can be shorter */
    const size_t n_chunks = (n + chunk - 1) / chunk;
#define CHUNK_A(k) ((k) * chunk)
#define CHUNK_E(k) ((k) + 1 == n_chunks ? n - 1 : ((k) + 1) * chunk - 1)
#define SLOT_ROW(k, r) (ring + ((k) % 3) * slot + (kd + (r) - CHUNK_A(k)) * m)
    for (size_t k = 0; k <= n_chunks; k++) {
        if (k < n_chunks) {
            if (k >= 1) /* halo: the forward rows just before this chunk */
                memcpy(SLOT_ROW(k, CHUNK_A(k) - kd), SLOT_ROW(k - 1, CHUNK_A(k) - kd),
                       kd * m * sizeof(double));
            for (size_t r = CHUNK_A(k); r <= CHUNK_E(k); r++)
                forward_row(ctx, r, SLOT_ROW(k, r), m, m);
        }
        if (k >= 1) /* the last chunk ends at row n - 1: its sweep is exact */
            backward_range(b, CHUNK_A(k - 1), CHUNK_E(k - 1), SLOT_ROW(k - 1, CHUNK_A(k - 1)), m,
                           m);
        if (k >= 2) {
            size_t e = CHUNK_E(k - 2);
            correct_tail(b, e, SLOT_ROW(k - 2, e), m, SLOT_ROW(k - 1, e + 1), m, m, h);
            stream_out(x + CHUNK_A(k - 2) * ldx, ldx, SLOT_ROW(k - 2, CHUNK_A(k - 2)), m, chunk);
        }
    }
    size_t a = CHUNK_A(n_chunks - 1);
    stream_out(x + a * ldx, ldx, SLOT_ROW(n_chunks - 1, a), m, n - a);
#if defined(__SSE2__)
    _mm_sfence();
#endif
    common__free(&b->alloc, ring, ring_bytes);
#undef CHUNK_A
#undef CHUNK_E
#undef SLOT_ROW
}

typedef struct inplace_ctx {
    const mlr_band *b;
    const double *y; /* the right-hand side, overwritten by the solution */
    size_t ldy;
} inplace_ctx;

static void forward_in_place(const void *vctx, size_t r, double *xr, size_t ld, size_t m)
{
    const inplace_ctx *ctx = vctx;
    band__forward_row_any(ctx->b, r, ctx->y + r * ctx->ldy, xr, ld, m);
}

/* MLR_E_BAD_STATE for a handle without a factor (fn names the function). */
static mlr_status not_factored(mlr_diag *diag, const char *fn)
{
    return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                            "band %s: band is not factored (mlr_band_factor failed or was not "
                            "called)",
                            fn);
}

mlr_status mlr_band_solve(const mlr_band *b, double *x, size_t ldx, size_t m, mlr_diag *diag)
{
    if (!b)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "band solve: band is NULL");
    if (!b->factored)
        return not_factored(diag, "solve");
    if (m == 0)
        return MLR_OK;
    if (!x)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "band solve: x is NULL with m %zu",
                                m);
    if (ldx < m)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "band solve: ldx %zu < m %zu", ldx,
                                m);
    inplace_ctx ctx = {b, x, ldx};
    band__solve_rows(b, forward_in_place, &ctx, x, ldx, m);
    return MLR_OK;
}

/*
 * Selected inversion (Takahashi): with Z = A^{-1} = L^{-T} D^{-1} L^{-1},
 *   Z(i,j) = -sum_{k=1..kd} L(i+k, i) Z(i+k, j)        for j > i,
 *   Z(i,i) = 1/D(i) - sum_{k=1..kd} L(i+k, i) Z(i+k, i),
 * and only entries inside the band are needed. z[i*(kd+1) + d] holds Z(i, i+d), d = 0..kd.
 */
mlr_status mlr_band_inverse_diagonal(const mlr_band *b, double *var, size_t n, mlr_diag *diag)
{
    if (!b || !var)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "band inverse_diagonal: %s is NULL",
                                !b ? "band" : "var");
    if (n != b->n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "band inverse_diagonal: n %zu is not the order %zu of band", n,
                                b->n);
    if (!b->factored)
        return not_factored(diag, "inverse_diagonal");
    const size_t kd = b->kd, w = kd + 1;
    size_t nz, bytes;
    if (common__mul_size(n, w, &nz) || common__mul_size(nz, sizeof(double), &bytes))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "band inverse_diagonal: workspace of n %zu x (kd %zu + 1) doubles "
                                "overflows",
                                n, kd);
    double *z = common__alloc(&b->alloc, bytes);
    if (!z)
        return common__diag_set(
            diag, MLR_E_NO_MEMORY, 0, 0,
            "band inverse_diagonal: out of memory for the workspace (%zu bytes)", bytes);
    const double *l = b->l;
    for (size_t i = n; i-- > 0;) {
        size_t kmax = n - 1 - i < kd ? n - 1 - i : kd;
        /* off-diagonal Z(i, i+d), d = kmax..1, uses Z(i+k, i+d) for k = 1..kmax */
        for (size_t d = kmax; d >= 1; d--) {
            double s = 0.0;
            for (size_t k = 1; k <= kmax; k++) {
                double lk = l[(i + k) * kd + k - 1];
                size_t r = i + k, c = i + d; /* Z(r, c) by symmetry */
                double zrc = r <= c ? z[r * w + (c - r)] : z[c * w + (r - c)];
                s -= lk * zrc;
            }
            z[i * w + d] = s;
        }
        for (size_t d = kmax + 1; d <= kd; d++)
            z[i * w + d] = 0.0;
        double s = b->dinv[i];
        for (size_t k = 1; k <= kmax; k++)
            s -= l[(i + k) * kd + k - 1] * z[i * w + k];
        z[i * w] = s;
        var[i] = s;
    }
    common__free(&b->alloc, z, bytes);
    return MLR_OK;
}
