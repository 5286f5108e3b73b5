/*
 * Batched smoothing systems of the layers: A_k = I + s_k L^T L for many k at once (one per
 * joint or per displacement group, each with its own s). The LDL^T recurrences follow band.c
 * (mlr_band_factor_in_place, the selected inversion of mlr_band_inverse_diagonal); here they
 * run over the systems in the innermost loop, which the compiler vectorizes, instead of one
 * latency-bound chain per system.
 */
#include "layers_internal.h"

#include <math.h>

/* Entries of row i of L^T L (order 2): diagonal, (i, i-1), (i, i-2). */
static void ltl_row(size_t n, size_t i, double *d0, double *d1, double *d2)
{
    if (i >= 2 && i + 2 < n) {
        *d0 = 6.0, *d1 = -4.0, *d2 = 1.0;
        return;
    }
    *d0 = mlr_lgs_ltl_entry(n, 2, i, i);
    *d1 = i >= 1 ? mlr_lgs_ltl_entry(n, 2, i, i - 1) : 0.0;
    *d2 = i >= 2 ? mlr_lgs_ltl_entry(n, 2, i, i - 2) : 0.0;
}

size_t mlr_lay_batch_factor(mlr_lay_batch *b, const double *s)
{
    const size_t n = b->n, ns = b->ns;
    for (size_t i = 0; i < n; i++) {
        double c0, c1, c2;
        ltl_row(n, i, &c0, &c1, &c2);
        double *restrict di = b->dinv + i * ns, *restrict l1 = b->l1 + i * ns;
        double *restrict l2 = b->l2 + i * ns;
        if (i == 0) {
            for (size_t k = 0; k < ns; k++) {
                l1[k] = l2[k] = 0.0;
                di[k] = 1.0 / (1.0 + s[k] * c0);
            }
        } else if (i == 1) {
            const double *restrict dp = b->dinv;
            for (size_t k = 0; k < ns; k++) {
                const double a1 = s[k] * c1;
                l2[k] = 0.0;
                l1[k] = a1 * dp[k];
                di[k] = 1.0 / (1.0 + s[k] * c0 - l1[k] * a1);
            }
        } else {
            const double *restrict dp = b->dinv + (i - 1) * ns, *restrict dpp = b->dinv + (i - 2) * ns;
            const double *restrict l1p = b->l1 + (i - 1) * ns;
            for (size_t k = 0; k < ns; k++) {
                const double a2 = s[k] * c2, a1 = s[k] * c1 - a2 * l1p[k];
                l2[k] = a2 * dpp[k];
                l1[k] = a1 * dp[k];
                di[k] = 1.0 / (1.0 + s[k] * c0 - l2[k] * a2 - l1[k] * a1);
            }
        }
    }
    /* I + s L^T L is SPD: a pivot that is not positive and finite is rounding at a huge s */
    for (size_t i = 0; i < n; i++) {
        const double *di = b->dinv + i * ns;
        int bad = 0;
        for (size_t k = 0; k < ns; k++)
            bad |= !(di[k] > 0.0 && di[k] < INFINITY);
        if (bad)
            for (size_t k = 0; k < ns; k++)
                if (!(di[k] > 0.0 && di[k] < INFINITY))
                    return k + 1;
    }
    return 0;
}

/* The sweeps with the channel count fixed at compile time (3 or 4) so the inner loops unroll;
 * the first and last two rows (fewer neighbours) use zero coefficients on a guard row. */
static inline void forward_row(size_t ns, const size_t *restrict col, const size_t m,
                               const double *restrict l1, const double *restrict l2,
                               const double *restrict yi, double *restrict xi,
                               const double *restrict x1, const double *restrict x2)
{
    for (size_t k = 0; k < ns; k++) {
        const size_t c0 = col[k];
        const double a1 = l1[k], a2 = l2[k];
        for (size_t c = 0; c < m; c++)
            xi[c0 + c] = yi[c0 + c] - a1 * x1[c0 + c] - a2 * x2[c0 + c];
    }
}

static inline void backward_row(size_t ns, const size_t *restrict col, const size_t m,
                                const double *restrict di, const double *restrict l1,
                                const double *restrict l2, double *restrict xi,
                                const double *restrict x1, const double *restrict x2)
{
    for (size_t k = 0; k < ns; k++) {
        const size_t c0 = col[k];
        const double d = di[k], a1 = l1[k], a2 = l2[k];
        for (size_t c = 0; c < m; c++)
            xi[c0 + c] = xi[c0 + c] * d - a1 * x1[c0 + c] - a2 * x2[c0 + c];
    }
}

static inline void solve_m(const mlr_lay_batch *b, const size_t *col, const size_t m,
                           const double *y, size_t ldy, double *x, size_t ldx, double *zero)
{
    const size_t n = b->n, ns = b->ns;
    /* zero: ns coefficients and one row of ldx values, all zero */
    const double *zrow = zero + ns;
    for (size_t i = 0; i < n; i++) {
        const double *l1 = i >= 1 ? b->l1 + i * ns : zero, *l2 = i >= 2 ? b->l2 + i * ns : zero;
        const double *x1 = i >= 1 ? x + (i - 1) * ldx : zrow, *x2 = i >= 2 ? x + (i - 2) * ldx : zrow;
        forward_row(ns, col, m, l1, l2, y + i * ldy, x + i * ldx, x1, x2);
    }
    for (size_t i = n; i-- > 0;) {
        const double *l1 = i + 1 < n ? b->l1 + (i + 1) * ns : zero;
        const double *l2 = i + 2 < n ? b->l2 + (i + 2) * ns : zero;
        const double *x1 = i + 1 < n ? x + (i + 1) * ldx : zrow;
        const double *x2 = i + 2 < n ? x + (i + 2) * ldx : zrow;
        backward_row(ns, col, m, b->dinv + i * ns, l1, l2, x + i * ldx, x1, x2);
    }
}

void mlr_lay_batch_solve(const mlr_lay_batch *b, const size_t *col, size_t m, const double *y,
                         size_t ldy, double *x, size_t ldx, double *zero)
{
    memset(zero, 0, (b->ns + ldx) * sizeof(double));
    if (m == 4)
        solve_m(b, col, 4, y, ldy, x, ldx, zero);
    else
        solve_m(b, col, 3, y, ldy, x, ldx, zero);
}

/*
 * Z = A^-1 backward from the last row, keeping only Z(i+1, i+1), Z(i+1, i+2), Z(i+2, i+2):
 *   Z(i, i+1) = -L(i+1,i) Z(i+1,i+1) - L(i+2,i) Z(i+2,i+1)
 *   Z(i, i+2) = -L(i+1,i) Z(i+1,i+2) - L(i+2,i) Z(i+2,i+2)
 *   Z(i, i)   = 1/D(i) - L(i+1,i) Z(i,i+1) - L(i+2,i) Z(i,i+2)
 */
void mlr_lay_batch_trace(const mlr_lay_batch *b, double *trace, double *work)
{
    const size_t n = b->n, ns = b->ns;
    double *restrict za = work, *restrict zb = work + ns, *restrict zc = work + 2 * ns;
    const double *dl = b->dinv + (n - 1) * ns;
    for (size_t k = 0; k < ns; k++) {
        za[k] = dl[k]; /* Z(i+1, i+1) */
        zb[k] = 0.0;   /* Z(i+1, i+2) */
        zc[k] = 0.0;   /* Z(i+2, i+2) */
        trace[k] = dl[k];
    }
    for (size_t i = n - 1; i-- > 0;) {
        const double *restrict di = b->dinv + i * ns, *restrict l1 = b->l1 + (i + 1) * ns;
        const double *restrict l2 = i + 2 < n ? b->l2 + (i + 2) * ns : NULL;
        for (size_t k = 0; k < ns; k++) {
            const double a1 = l1[k], a2 = l2 ? l2[k] : 0.0;
            const double z01 = -a1 * za[k] - a2 * zb[k];
            const double z02 = -a1 * zb[k] - a2 * zc[k];
            const double z00 = di[k] - a1 * z01 - a2 * z02;
            zc[k] = za[k];
            zb[k] = z01;
            za[k] = z00;
            trace[k] += z00;
        }
    }
}
