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

/* The sweeps with the channel count fixed at compile time (3 or 4) so the inner loops unroll. */
static inline void solve_m(const mlr_lay_batch *b, const size_t *col, const size_t m,
                           const double *y, size_t ldy, double *x, size_t ldx)
{
    const size_t n = b->n, ns = b->ns;
    for (size_t i = 0; i < n; i++) {
        const double *l1 = b->l1 + i * ns, *l2 = b->l2 + i * ns;
        double *xi = x + i * ldx;
        const double *yi = y + i * ldy;
        for (size_t k = 0; k < ns; k++) {
            const size_t c0 = col[k];
            for (size_t c = 0; c < m; c++) {
                double v = yi[c0 + c];
                if (i >= 1)
                    v -= l1[k] * xi[c0 + c - ldx];
                if (i >= 2)
                    v -= l2[k] * xi[c0 + c - 2 * ldx];
                xi[c0 + c] = v;
            }
        }
    }
    for (size_t i = n; i-- > 0;) {
        const double *di = b->dinv + i * ns;
        const double *l1n = i + 1 < n ? b->l1 + (i + 1) * ns : NULL;
        const double *l2n = i + 2 < n ? b->l2 + (i + 2) * ns : NULL;
        double *xi = x + i * ldx;
        for (size_t k = 0; k < ns; k++) {
            const size_t c0 = col[k];
            for (size_t c = 0; c < m; c++) {
                double v = xi[c0 + c] * di[k];
                if (l1n)
                    v -= l1n[k] * xi[c0 + c + ldx];
                if (l2n)
                    v -= l2n[k] * xi[c0 + c + 2 * ldx];
                xi[c0 + c] = v;
            }
        }
    }
}

void mlr_lay_batch_solve(const mlr_lay_batch *b, const size_t *col, size_t m, const double *y,
                         size_t ldy, double *x, size_t ldx)
{
    if (m == 4)
        solve_m(b, col, 4, y, ldy, x, ldx);
    else
        solve_m(b, col, 3, y, ldy, x, ldx);
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
