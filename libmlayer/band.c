/*
 * Banded SPD solver: A = L D L^T with unit lower-triangular L of bandwidth kd.
 * Storage: l[i*kd + (k-1)] = L(i, i-k) for k = 1..kd, dinv[i] = 1 / D(i).
 * Right-hand sides are rows of a row-major n x m matrix, so every update of the forward and
 * backward sweeps is a contiguous axpy over the m channels: the whole solve streams memory.
 */
#include "band_internal.h"

#include <math.h>
#include <stdlib.h>

mlr_status mlr_band_create(size_t n, size_t kd, const mlr_allocator *alloc, mlr_band **out)
{
    if (!out)
        return MLR_E_INVALID_ARG;
    *out = NULL;
    if (n == 0 || kd >= n)
        return MLR_E_INVALID_ARG;
    mlr_allocator a;
    mlr_allocator_resolve(alloc, &a);
    size_t nl, bytes;
    if (mlr_mul_size(n, kd, &nl) || mlr_mul_size(nl + n, sizeof(double), &bytes))
        return MLR_E_OVERFLOW;
    mlr_band *b = mlr_alloc(&a, sizeof *b);
    if (!b)
        return MLR_E_NO_MEMORY;
    b->alloc = a;
    b->n = n;
    b->kd = kd;
    b->factored = 0;
    b->storage_bytes = bytes;
    b->dinv = mlr_alloc(&a, bytes);
    if (!b->dinv) {
        mlr_free(&a, b, sizeof *b);
        return MLR_E_NO_MEMORY;
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
    mlr_free(&a, b->dinv, b->storage_bytes);
    mlr_free(&a, b, sizeof *b);
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

mlr_status mlr_band_factor_in_place(mlr_band *b)
{
    const size_t n = b->n, kd = b->kd;
    double *l = b->l, *dinv = b->dinv;
    mlr_status status = MLR_OK;
    b->factored = 0;
    if (kd == 2) { /* pentadiagonal, the LGS default: one division per row */
        for (size_t i = 0; i < n; i++) {
            double *li = l + 2 * i, aii = dinv[i];
            double d = mlr_band_ldl2_row(i, aii, li[0], li[1], i >= 2 ? l[2 * (i - 1)] : 0.0,
                                         i >= 1 ? dinv[i - 1] : 0.0, i >= 2 ? dinv[i - 2] : 0.0,
                                         &li[0], &li[1]);
            if (!pivot_ok(d, aii, &status))
                return MLR_E_SINGULAR;
            dinv[i] = 1.0 / d;
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
            if (!pivot_ok(d, aii, &status))
                return MLR_E_SINGULAR;
            dinv[i] = 1.0 / d;
        }
    }
    b->factored = 1;
    return status;
}

mlr_status mlr_band_factor(mlr_band *b, const double *ab, size_t ldab)
{
    if (!b || !ab || ldab < b->kd + 1)
        return MLR_E_INVALID_ARG;
    const size_t n = b->n, kd = b->kd;
    for (size_t i = 0; i < n; i++) {
        b->dinv[i] = ab[i * ldab];
        for (size_t k = 1; k <= kd; k++)
            b->l[i * kd + k - 1] = k <= i ? ab[(i - k) * ldab + k] : 0.0;
    }
    return mlr_band_factor_in_place(b);
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

void mlr_band_forward_row_from(const mlr_band *b, size_t i, const double *yi, double *x,
                               size_t ldx, size_t m)
{
    const size_t kd = b->kd;
    const double *li = b->l + i * kd;
    double *xi = x + i * ldx;
    size_t kmax = i < kd ? i : kd;
    if (kmax == 2) {
        row_from2(xi, yi, xi - ldx, xi - 2 * ldx, li[0], li[1], m);
    } else if (kmax == 1) {
        row_from1(xi, yi, xi - ldx, li[0], m);
    } else {
        memcpy(xi, yi, m * sizeof(double));
        for (size_t k = 1; k <= kmax; k++)
            row_sub1(xi, xi - k * ldx, li[k - 1], m);
    }
}

/* Forward sweep for one row: x_i -= sum_k L(i,i-k) x_{i-k} (the 1/D scaling comes in the
 * backward sweep). */
void mlr_band_forward_row(const mlr_band *b, size_t i, double *x, size_t ldx, size_t m)
{
    const size_t kd = b->kd;
    const double *li = b->l + i * kd;
    double *xi = x + i * ldx;
    size_t kmax = i < kd ? i : kd;
    if (kmax == 2) {
        row_sub2(xi, xi - ldx, xi - 2 * ldx, li[0], li[1], m);
    } else if (kmax == 1) {
        row_sub1(xi, xi - ldx, li[0], m);
    } else {
        for (size_t k = 1; k <= kmax; k++)
            row_sub1(xi, xi - k * ldx, li[k - 1], m);
    }
}

/* Backward sweep over rows e..a (e >= a) after the forward one:
 * x_i = x_i / D_i - sum_k L(i+k,i) x_{i+k}, rows past e taken as zero. */
static void backward_range(const mlr_band *b, size_t a, size_t e, double *x, size_t ldx, size_t m)
{
    const size_t kd = b->kd;
    const double *l = b->l, *dinv = b->dinv;
    for (size_t i = e + 1; i-- > a;) {
        double *xi = x + i * ldx;
        const double di = dinv[i];
        size_t kmax = e - i < kd ? e - i : kd;
        if (kmax == 2) {
            row_scale_sub2(xi, xi + ldx, xi + 2 * ldx, di, l[(i + 1) * kd], l[(i + 2) * kd + 1], m);
        } else if (kmax == 1) {
            row_scale_sub1(xi, xi + ldx, di, l[(i + 1) * kd], m);
        } else {
            for (size_t c = 0; c < m; c++)
                xi[c] *= di;
            for (size_t k = 1; k <= kmax; k++)
                row_sub1(xi, xi + k * ldx, l[(i + k) * kd + k - 1], m);
        }
    }
}

void mlr_band_backward(const mlr_band *b, double *x, size_t ldx, size_t m)
{
    backward_range(b, 0, b->n - 1, x, ldx, m);
}

/*
 * Single-pass solve by chunks. A chunk [a, e] swept backward with zero rows past e gives p;
 * the true x is p + sum_j h_j x_{e+j}, where h_j solves the homogeneous backward recurrence
 * h_i = -sum_k L(i+k,i) h_{i+k} with h_{e+k} = delta_jk. The recurrence is stable backward,
 * so h_j decays away from e: past MLR_BAND_TAIL_TOL it changes no digit of x. When the decay
 * fits inside every chunk, a chunk's first rows are final as soon as it is swept, and the
 * previous chunk only needs its tail corrected. Each chunk is swept forward, then (one chunk
 * later) backward, and its predecessor's tail fixed, while all three are still in cache: the
 * solve streams y and x once instead of twice.
 */
#define MLR_BAND_TAIL_TOL 1e-20
#define MLR_BAND_TAIL_MAX 1024           /* rows of h kept on the stack (16 KiB for kd = 2) */
#define MLR_BAND_CHUNK_BYTES (256u << 10) /* about a quarter of a core's L2 per chunk */

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
            mag = fmax(mag, fabs(v));
        }
        quiet = mag < MLR_BAND_TAIL_TOL ? quiet + 1 : 0;
        if (quiet >= kd + 1) {
            *len = r + 1;
            return 1;
        }
    }
    return 0;
}

static void correct_tail(const mlr_band *b, size_t e, double *x, size_t ldx, size_t m,
                         double *h)
{
    size_t len = 0;
    const size_t kd = b->kd;
    tail_homogeneous(b, e, MLR_BAND_TAIL_MAX, h, &len); /* checked to decay before the solve */
    for (size_t r = 0; r < len; r++) {
        double *xi = x + (e - r) * ldx;
        if (kd == 2)
            row_sub2(xi, x + (e + 1) * ldx, x + (e + 2) * ldx, -h[r * 2], -h[r * 2 + 1], m);
        else
            row_sub1(xi, x + (e + 1) * ldx, -h[r], m);
    }
}

void mlr_band_solve_rows(const mlr_band *b, mlr_band_row_fn forward_row, const void *ctx,
                         double *x, size_t ldx, size_t m)
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
    if (!chunked) {
        for (size_t r = 0; r < n; r++)
            forward_row(ctx, r, x, ldx, m);
        mlr_band_backward(b, x, ldx, m);
        return;
    }
    /* chunks [k*chunk, (k+1)*chunk - 1]; the last one takes the remainder */
    size_t n_chunks = n / chunk;
#define CHUNK_A(k) ((k) * chunk)
#define CHUNK_E(k) ((k) + 1 == n_chunks ? n - 1 : ((k) + 1) * chunk - 1)
    for (size_t k = 0; k < n_chunks; k++) {
        for (size_t r = CHUNK_A(k); r <= CHUNK_E(k); r++)
            forward_row(ctx, r, x, ldx, m);
        if (k >= 1)
            backward_range(b, CHUNK_A(k - 1), CHUNK_E(k - 1), x, ldx, m);
        if (k >= 2)
            correct_tail(b, CHUNK_E(k - 2), x, ldx, m, h);
    }
    backward_range(b, CHUNK_A(n_chunks - 1), n - 1, x, ldx, m);
    correct_tail(b, CHUNK_E(n_chunks - 2), x, ldx, m, h);
#undef CHUNK_A
#undef CHUNK_E
}

typedef struct inplace_ctx { const mlr_band *b; } inplace_ctx;

static void forward_in_place(const void *vctx, size_t r, double *x, size_t ldx, size_t m)
{
    const inplace_ctx *ctx = vctx;
    mlr_band_forward_row(ctx->b, r, x, ldx, m);
}

mlr_status mlr_band_solve(const mlr_band *b, double *x, size_t ldx, size_t m)
{
    if (!b)
        return MLR_E_INVALID_ARG;
    if (!b->factored)
        return MLR_E_BAD_STATE;
    if (m == 0)
        return MLR_OK;
    if (!x || ldx < m)
        return MLR_E_INVALID_ARG;
    inplace_ctx ctx = {b};
    mlr_band_solve_rows(b, forward_in_place, &ctx, x, ldx, m);
    return MLR_OK;
}

/*
 * Selected inversion (Takahashi): with Z = A^{-1} = L^{-T} D^{-1} L^{-1},
 *   Z(i,j) = -sum_{k=1..kd} L(i+k, i) Z(i+k, j)        for j > i,
 *   Z(i,i) = 1/D(i) - sum_{k=1..kd} L(i+k, i) Z(i+k, i),
 * and only entries inside the band are needed. z[i*(kd+1) + d] holds Z(i, i+d), d = 0..kd.
 */
mlr_status mlr_band_inverse_diagonal(const mlr_band *b, double *var, size_t n)
{
    if (!b || !var || n != b->n)
        return MLR_E_INVALID_ARG;
    if (!b->factored)
        return MLR_E_BAD_STATE;
    const size_t kd = b->kd, w = kd + 1;
    size_t nz, bytes;
    if (mlr_mul_size(n, w, &nz) || mlr_mul_size(nz, sizeof(double), &bytes))
        return MLR_E_OVERFLOW;
    double *z = mlr_alloc(&b->alloc, bytes);
    if (!z)
        return MLR_E_NO_MEMORY;
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
    mlr_free(&b->alloc, z, bytes);
    return MLR_OK;
}
