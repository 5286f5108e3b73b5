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

mlr_status mlr_band_factor_fn(mlr_band *b, mlr_band_entry_fn entry, const void *ctx)
{
    const size_t n = b->n, kd = b->kd;
    double *l = b->l, *dinv = b->dinv;
    mlr_status status = MLR_OK;
    b->factored = 0;
    for (size_t i = 0; i < n; i++) {
        size_t kmax = i < kd ? i : kd;
        /* L(i, j) for j = i-kmax .. i-1, left to right */
        for (size_t k = kmax; k >= 1; k--) {
            size_t j = i - k;
            double s = entry(ctx, i, j);
            /* subtract sum_p L(i,p) D(p) L(j,p) over p < j with p >= i - kd */
            for (size_t q = k + 1; q <= kmax; q++) {
                size_t p = i - q;           /* L(i,p) = l[i*kd + q-1] */
                size_t kj = j - p;          /* L(j,p) = l[j*kd + kj-1] */
                s -= l[i * kd + q - 1] * l[j * kd + kj - 1] / dinv[p];
            }
            l[i * kd + k - 1] = s * dinv[j];
        }
        for (size_t k = kmax + 1; k <= kd; k++)
            l[i * kd + k - 1] = 0.0;
        double aii = entry(ctx, i, i);
        double d = aii;
        for (size_t k = 1; k <= kmax; k++) {
            double lik = l[i * kd + k - 1];
            d -= lik * lik / dinv[i - k];
        }
        if (!(d > 0.0) || !isfinite(d))
            return MLR_E_SINGULAR;
        if (d < MLR_BAND_ILL_PIVOT * fabs(aii))
            status = MLR_W_ILL_CONDITIONED;
        dinv[i] = 1.0 / d;
    }
    b->factored = 1;
    return status;
}

typedef struct lapack_band { const double *ab; size_t ldab; } lapack_band;

static double lapack_entry(const void *ctx, size_t i, size_t j)
{
    const lapack_band *lb = ctx;
    return lb->ab[j * lb->ldab + (i - j)];
}

mlr_status mlr_band_factor(mlr_band *b, const double *ab, size_t ldab)
{
    if (!b || !ab || ldab < b->kd + 1)
        return MLR_E_INVALID_ARG;
    lapack_band lb = {ab, ldab};
    return mlr_band_factor_fn(b, lapack_entry, &lb);
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

/* Backward sweep after the forward one: x_i = x_i / D_i - sum_k L(i+k,i) x_{i+k}. */
void mlr_band_backward(const mlr_band *b, double *x, size_t ldx, size_t m)
{
    const size_t n = b->n, kd = b->kd;
    const double *l = b->l, *dinv = b->dinv;
    for (size_t i = n; i-- > 0;) {
        double *xi = x + i * ldx;
        const double di = dinv[i];
        size_t kmax = n - 1 - i < kd ? n - 1 - i : kd;
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
    for (size_t i = 1; i < b->n; i++)
        mlr_band_forward_row(b, i, x, ldx, m);
    mlr_band_backward(b, x, ldx, m);
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
