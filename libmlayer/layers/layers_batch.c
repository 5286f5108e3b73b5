/*
 * Batched smoothing systems of the layers: A_k = I + s_k L^T L for many k at once (one per
 * joint or per displacement group, each with its own s). The LDL^T recurrences follow band.c
 * (band__ldl2_row, the selected inversion of mlr_band_inverse_diagonal); here they run over
 * the systems in the innermost loop, which the compiler vectorizes, instead of one
 * latency-bound chain per system.
 *
 * Away from the ends the factor of a Toeplitz-like SPD matrix converges geometrically to a
 * fixed point of its recurrence (within a number of rows that grows like s^(1/4)). Once a row
 * equals its predecessor to rounding (with the same inputs) every later interior row is that
 * same row, so the factor stores only the rows up to there plus the last two: the same factor
 * to rounding, and O(1) rows per system for a moderate s whatever n. The selected inversion
 * skips the constant stretch the same way once its state stops changing, and the sweeps use
 * one per-channel coefficient row for the whole interior.
 */
#include "layers/layers_internal.h"

#include <math.h>

/* Entries of row i of L^T L (order 2): diagonal, (i, i-1), (i, i-2). */
static void ltl_row(size_t n, size_t i, double *d0, double *d1, double *d2)
{
    if (i >= 2 && i + 2 < n) {
        *d0 = 6.0, *d1 = -4.0, *d2 = 1.0;
        return;
    }
    *d0 = lgs__ltl_entry(n, 2, i, i);
    *d1 = i >= 1 ? lgs__ltl_entry(n, 2, i, i - 1) : 0.0;
    *d2 = i >= 2 ? lgs__ltl_entry(n, 2, i, i - 2) : 0.0;
}

/* factor_row with observation weights: the diagonal is w_i + s c0 instead of 1 + s c0. */
static void factor_row_weighted(mlr_lay_batch *b, const double *restrict s, size_t i, size_t r,
                                size_t p1, size_t p2, double c0, double c1, double c2)
{
    const size_t ns = b->ns;
    const double *restrict w = b->w + i * ns;
    double *restrict di = b->dinv + r * ns, *restrict l1 = b->l1 + r * ns;
    double *restrict l2 = b->l2 + r * ns;
    const double *restrict dp = b->dinv + p1 * ns, *restrict dpp = b->dinv + p2 * ns;
    const double *restrict l1p = b->l1 + p1 * ns;
    for (size_t k = 0; k < ns; k++) {
        const double a2 = i >= 2 ? s[k] * c2 : 0.0;
        const double a1 = i >= 1 ? s[k] * c1 - (i >= 2 ? a2 * l1p[k] : 0.0) : 0.0;
        l2[k] = i >= 2 ? a2 * dpp[k] : 0.0;
        l1[k] = i >= 1 ? a1 * dp[k] : 0.0;
        di[k] = 1.0 / (w[k] + s[k] * c0 - l2[k] * a2 - l1[k] * a1);
    }
}

/* Factor row i of every system into storage row r from storage rows p1 (row i-1) and p2
 * (row i-2). */
static void factor_row(mlr_lay_batch *b, const double *restrict s, size_t i, size_t r, size_t p1,
                       size_t p2)
{
    const size_t ns = b->ns;
    double c0, c1, c2;
    ltl_row(b->n, i, &c0, &c1, &c2);
    if (b->w) {
        factor_row_weighted(b, s, i, r, p1, p2, c0, c1, c2);
        return;
    }
    double *restrict di = b->dinv + r * ns, *restrict l1 = b->l1 + r * ns;
    double *restrict l2 = b->l2 + r * ns;
    if (i == 0) {
        for (size_t k = 0; k < ns; k++) {
            l1[k] = l2[k] = 0.0;
            di[k] = 1.0 / (1.0 + s[k] * c0);
        }
    } else if (i == 1) {
        const double *restrict dp = b->dinv + p1 * ns;
        for (size_t k = 0; k < ns; k++) {
            const double a1 = s[k] * c1;
            l2[k] = 0.0;
            l1[k] = a1 * dp[k];
            di[k] = 1.0 / (1.0 + s[k] * c0 - l1[k] * a1);
        }
    } else {
        const double *restrict dp = b->dinv + p1 * ns, *restrict dpp = b->dinv + p2 * ns;
        const double *restrict l1p = b->l1 + p1 * ns;
        for (size_t k = 0; k < ns; k++) {
            const double a2 = s[k] * c2, a1 = s[k] * c1 - a2 * l1p[k];
            l2[k] = a2 * dpp[k];
            l1[k] = a1 * dp[k];
            di[k] = 1.0 / (1.0 + s[k] * c0 - l2[k] * a2 - l1[k] * a1);
        }
    }
}

/* Two values of a converging recurrence equal to rounding (a fixed point in exact arithmetic
 * may show as a cycle of an ulp or two in floating point). */
#define MLR_LAY_SAME 6e-16
static inline int differs(double a, double b) { return fabs(a - b) > MLR_LAY_SAME * fabs(b); }

/* Row i equals row i-1 and row i-1's inputs equal row i's: the recurrence is at its fixed
 * point. */
static int row_repeats(const mlr_lay_batch *b, size_t i)
{
    const size_t ns = b->ns;
    const double *d0 = b->dinv + i * ns, *d1 = d0 - ns, *d2 = d1 - ns;
    const double *a0 = b->l1 + i * ns, *a1 = a0 - ns;
    int diff = 0;
    for (size_t k = 0; k < ns; k++)
        diff |= differs(d0[k], d1[k]) | differs(d1[k], d2[k]) | differs(a0[k], a1[k]);
    return !diff;
}

size_t layers__batch_factor(mlr_lay_batch *b, const double *s)
{
    const size_t n = b->n, ns = b->ns;
    b->k = n;
    for (size_t i = 0; i < n; i++) {
        factor_row(b, s, i, i, i >= 1 ? i - 1 : 0, i >= 2 ? i - 2 : 0);
        /* rows i+1 .. n-3 are interior rows with the inputs of row i: all equal row i
         * (checked every fourth row: a fixed point found a few rows late stores those rows) */
        if (!b->w && i >= 4 && i + 4 <= n && (i & 3) == 0 && row_repeats(b, i)) {
            b->k = i + 1;
            break;
        }
    }
    size_t stored = n;
    if (b->k < n) { /* rows n-2, n-1 after the constant stretch, stored at k, k+1 */
        const size_t k = b->k;
        factor_row(b, s, n - 2, k, k - 1, k - 1);
        factor_row(b, s, n - 1, k + 1, k, k - 1);
        stored = k + 2;
    }
    /* W + s L^T L is SPD (weights > 0): a pivot that is not positive and finite is rounding at a huge s */
    for (size_t r = 0; r < stored; r++) {
        const double *di = b->dinv + r * ns;
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

/* Row kernels. Group form: system k scales its m channels [k m, (k+1) m) by its coefficient
 * (m fixed at compile time by the callers, so the inner loop unrolls); channel form: one
 * coefficient per channel (the constant interior, expanded once). */
static inline void fwd_groups(size_t ns, const size_t m, const double *restrict l1,
                              const double *restrict l2, const double *restrict yi,
                              double *restrict xi, const double *restrict x1,
                              const double *restrict x2)
{
    for (size_t k = 0; k < ns; k++) {
        const double a1 = l1[k], a2 = l2[k];
        for (size_t c = k * m; c < k * m + m; c++)
            xi[c] = yi[c] - (a1 * x1[c] + a2 * x2[c]);
    }
}

static inline void bwd_groups(size_t ns, const size_t m, const double *restrict di,
                              const double *restrict l1, const double *restrict l2,
                              double *restrict xi, const double *restrict x1,
                              const double *restrict x2)
{
    for (size_t k = 0; k < ns; k++) {
        const double d = di[k], a1 = l1[k], a2 = l2[k];
        for (size_t c = k * m; c < k * m + m; c++)
            xi[c] = xi[c] * d - (a1 * x1[c] + a2 * x2[c]);
    }
}

static inline void fwd_channels(size_t mm, const double *restrict e1, const double *restrict e2,
                                const double *restrict yi, double *restrict xi,
                                const double *restrict x1, const double *restrict x2)
{
    for (size_t c = 0; c < mm; c++)
        xi[c] = yi[c] - (e1[c] * x1[c] + e2[c] * x2[c]);
}

static inline void bwd_channels(size_t mm, const double *restrict ed, const double *restrict e1,
                                const double *restrict e2, double *restrict xi,
                                const double *restrict x1, const double *restrict x2)
{
    for (size_t c = 0; c < mm; c++)
        xi[c] = xi[c] * ed[c] - (e1[c] * x1[c] + e2[c] * x2[c]);
}

/* Backward row kernels of the residual form: x_i from the forward value z_i into a separate
 * output row, and acc[c] += (y_i[c] - x_i[c])^2. */
static inline void bwd_groups_rss(size_t ns, const size_t m, const double *restrict di,
                                  const double *restrict l1, const double *restrict l2,
                                  const double *restrict zi, double *restrict xi,
                                  const double *restrict x1, const double *restrict x2,
                                  const double *restrict yi, double *restrict acc)
{
    for (size_t k = 0; k < ns; k++) {
        const double d = di[k], a1 = l1[k], a2 = l2[k];
        for (size_t c = k * m; c < k * m + m; c++) {
            const double v = zi[c] * d - (a1 * x1[c] + a2 * x2[c]), r = yi[c] - v;
            xi[c] = v;
            acc[c] += r * r;
        }
    }
}

static inline void bwd_channels_rss(size_t mm, const double *restrict ed,
                                    const double *restrict e1, const double *restrict e2,
                                    const double *restrict zi, double *restrict xi,
                                    const double *restrict x1, const double *restrict x2,
                                    const double *restrict yi, double *restrict acc)
{
    for (size_t c = 0; c < mm; c++) {
        const double v = zi[c] * ed[c] - (e1[c] * x1[c] + e2[c] * x2[c]), r = yi[c] - v;
        xi[c] = v;
        acc[c] += r * r;
    }
}

/* The constant interior row, one coefficient per channel, into e1, e2, ed (3 m ns doubles);
 * 0 when the factor has no constant stretch. */
static inline int expand_interior(const mlr_lay_batch *b, const size_t m, double *e1, double *e2,
                                  double *ed)
{
    const size_t ns = b->ns, kc = b->k - 1;
    if (b->k >= b->n)
        return 0;
    for (size_t k = 0; k < ns; k++) {
        for (size_t c = k * m; c < k * m + m; c++) {
            e1[c] = b->l1[kc * ns + k];
            e2[c] = b->l2[kc * ns + k];
            ed[c] = b->dinv[kc * ns + k];
        }
    }
    return 1;
}

/* Forward sweep z = L^-1 y into x. */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void fwd_m(const mlr_lay_batch *b, const size_t m, const double *y, size_t ldy,
                         double *x, size_t ldx, const double *e1, const double *e2, int conv)
{
    const size_t n = b->n, ns = b->ns, mm = m * ns, kc = b->k - 1;
    const double *l1 = b->l1, *l2 = b->l2;
    memcpy(x, y, mm * sizeof(double));
    {
        const double *y1 = y + ldy, *x0 = x;
        double *x1 = x + ldx;
        const double *a = l1 + ns;
        for (size_t k = 0; k < ns; k++)
            for (size_t c = k * m; c < k * m + m; c++)
                x1[c] = y1[c] - a[k] * x0[c];
    }
    for (size_t i = 2; i < n; i++) {
        const size_t r = layers__row(b, i);
        double *xi = x + i * ldx;
        if (conv && r == kc)
            fwd_channels(mm, e1, e2, y + i * ldy, xi, xi - ldx, xi - 2 * ldx);
        else
            fwd_groups(ns, m, l1 + r * ns, l2 + r * ns, y + i * ldy, xi, xi - ldx, xi - 2 * ldx);
    }
}

#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void solve_m(const mlr_lay_batch *b, const size_t m, const double *y, size_t ldy,
                           double *x, size_t ldx, double *buf)
{
    const size_t n = b->n, ns = b->ns, mm = m * ns, kc = b->k - 1;
    const double *l1 = b->l1, *l2 = b->l2, *dv = b->dinv;
    double *e1 = buf, *e2 = buf + mm, *ed = buf + 2 * mm;
    const int conv = expand_interior(b, m, e1, e2, ed);
    fwd_m(b, m, y, ldy, x, ldx, e1, e2, conv);
    {
        double *xl = x + (n - 1) * ldx;
        const double *d = dv + layers__row(b, n - 1) * ns;
        for (size_t k = 0; k < ns; k++)
            for (size_t c = k * m; c < k * m + m; c++)
                xl[c] *= d[k];
        double *xp = x + (n - 2) * ldx;
        const double *d2 = dv + layers__row(b, n - 2) * ns, *a = l1 + layers__row(b, n - 1) * ns;
        for (size_t k = 0; k < ns; k++)
            for (size_t c = k * m; c < k * m + m; c++)
                xp[c] = xp[c] * d2[k] - a[k] * xl[c];
    }
    for (size_t i = n - 2; i-- > 0;) {
        const size_t r0 = layers__row(b, i), r1 = layers__row(b, i + 1),
                     r2 = layers__row(b, i + 2);
        double *xi = x + i * ldx;
        if (conv && r0 == kc && r1 == kc && r2 == kc)
            bwd_channels(mm, ed, e1, e2, xi, xi + ldx, xi + 2 * ldx);
        else
            bwd_groups(ns, m, dv + r0 * ns, l1 + r1 * ns, l2 + r2 * ns, xi, xi + ldx,
                       xi + 2 * ldx);
    }
}

/* acc[c] += (y_i[c] - x_i[c])^2 over rows of mm channels, y with stride ldy, x packed. */
static inline void mlr_lay_sum_sq_diff_rows(size_t rows, size_t mm, const double *y, size_t ldy,
                                            const double *x, double *acc)
{
    for (size_t i = 0; i < rows; i++) {
        const double *restrict yi = y + i * ldy, *restrict xi = x + i * mm;
        double *restrict a = acc;
        for (size_t c = 0; c < mm; c++) {
            const double r = yi[c] - xi[c];
            a[c] += r * r;
        }
    }
}

/*
 * The residual sums in a single pass over y by chunks, for long clips whose arrays do not stay
 * in cache (the method of band__solve_rows in band.c): each chunk is swept forward into a
 * ring of three chunk buffers, one chunk later backward with zero rows past its end, and one
 * chunk later again its tail gets the true boundary through the homogeneous solutions h (the
 * same for every chunk: the interior coefficients are constant), after which its rows are
 * final and add to acc. The ring, h and a zero row live in z. Returns 0 (nothing done) when
 * the clip is short, the factor has no constant interior, or h decays too slowly.
 */
#define MLR_LAY_TAIL_TOL 1e-20
#define MLR_LAY_CHUNK_BYTES (128u << 10)

/* The homogeneous solutions h_1, h_2 of the backward sweep with the interior coefficients
 * l1, l2, from the chunk end backward (h_j = 1 at boundary row j): with h NULL, the number of
 * rows until both stay below MLR_LAY_TAIL_TOL for three rows (0 when that takes more than
 * max_rows); otherwise the first max_rows of them into h[r * 2 * stride + j - 1]. */
static size_t interior_tail(double l1, double l2, size_t max_rows, double *h, size_t stride)
{
    double p1 = 1.0, q1 = 0.0, p2 = 0.0, q2 = 1.0; /* h_j at the two rows after this one */
    size_t quiet = 0;
    for (size_t r = 0; r < max_rows; r++) {
        const double v1 = -(l1 * p1 + l2 * q1), v2 = -(l1 * p2 + l2 * q2);
        q1 = p1, p1 = v1, q2 = p2, p2 = v2;
        if (h) {
            h[r * 2 * stride] = v1;
            h[r * 2 * stride + 1] = v2;
        } else {
            quiet = fabs(v1) < MLR_LAY_TAIL_TOL && fabs(v2) < MLR_LAY_TAIL_TOL ? quiet + 1 : 0;
            if (quiet == 3)
                return r + 1;
        }
    }
    return h ? max_rows : 0;
}

#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline int rss_chunked(const mlr_lay_batch *b, const size_t m, const double *y, size_t ldy,
                              double *z, size_t ldz, const double *e1, const double *e2,
                              const double *ed, double *acc)
{
    const size_t n = b->n, ns = b->ns, mm = m * ns, kc = b->k - 1;
    if (b->k >= b->n || n < 4096)
        return 0;
    const double *l1c = b->l1 + kc * ns, *l2c = b->l2 + kc * ns;
    /* tail length T: rows until |h| < tol for three rows in a row, every system */
    size_t tail = 0; /* rows until |h| < tol for three rows in a row, every system */
    for (size_t k = 0; k < ns; k++) {
        const size_t r = interior_tail(l1c[k], l2c[k], n / 16, NULL, 0);
        if (r == 0)
            return 0;
        tail = r > tail ? r : tail;
    }
    size_t chunk = MLR_LAY_CHUNK_BYTES / (mm * sizeof(double));
    if (chunk < 2 * tail + 8)
        chunk = 2 * tail + 8;
    if (chunk < kc + tail + 8)
        chunk = kc + tail + 8;
    const size_t n_chunks = n / chunk, cap = 2 * chunk + 2; /* rows per slot, halo included */
    if (n_chunks < 4 || (3 * cap + 1 + 2 * tail) * mm > (n - 1) * ldz) /* ring inside z */
        return 0;
    double *ring = z, *zero = z + 3 * cap * mm, *h = zero + mm;
    for (size_t c = 0; c < mm; c++)
        zero[c] = 0.0;
    for (size_t k = 0; k < ns; k++) /* h[(r ns + k) 2 + j]: row e - r, boundary row e+1+j */
        interior_tail(l1c[k], l2c[k], tail, h + 2 * k, ns);
    const double *l1 = b->l1, *l2 = b->l2, *dv = b->dinv;
#define CHUNK_A(k) ((k) * chunk)
#define CHUNK_E(k) ((k) + 1 == n_chunks ? n - 1 : ((k) + 1) * chunk - 1)
#define SLOT_ROW(k, i) (ring + ((k) % 3) * cap * mm + (2 + (i) - CHUNK_A(k)) * mm)
    for (size_t q = 0; q <= n_chunks; q++) {
        if (q < n_chunks) { /* forward sweep of chunk q */
            size_t i = CHUNK_A(q);
            if (q >= 1) {
                memcpy(SLOT_ROW(q, i - 2), SLOT_ROW(q - 1, i - 2), 2 * mm * sizeof(double));
            } else {
                double *x0 = SLOT_ROW(0, 0), *x1 = SLOT_ROW(0, 1);
                const double *y1 = y + ldy, *a = l1 + ns;
                memcpy(x0, y, mm * sizeof(double));
                for (size_t k = 0; k < ns; k++)
                    for (size_t c = k * m; c < k * m + m; c++)
                        x1[c] = y1[c] - a[k] * x0[c];
                i = 2;
            }
            for (; i <= CHUNK_E(q); i++) {
                const size_t r = layers__row(b, i);
                double *xi = SLOT_ROW(q, i);
                if (r == kc)
                    fwd_channels(mm, e1, e2, y + i * ldy, xi, xi - mm, xi - 2 * mm);
                else
                    fwd_groups(ns, m, l1 + r * ns, l2 + r * ns, y + i * ldy, xi, xi - mm,
                               xi - 2 * mm);
            }
        }
        if (q >= 1) { /* backward sweep of chunk q-1, zero rows past its end */
            const size_t a = CHUNK_A(q - 1), e = CHUNK_E(q - 1);
            for (size_t i = e + 1; i-- > a;) {
                const size_t r0 = layers__row(b, i);
                const size_t r1 = layers__row(b, i + 1 < n ? i + 1 : n - 1);
                const size_t r2 = layers__row(b, i + 2 < n ? i + 2 : n - 1);
                double *xi = SLOT_ROW(q - 1, i);
                const double *x1 = i + 1 <= e ? xi + mm : zero,
                             *x2 = i + 2 <= e ? xi + 2 * mm : zero;
                if (r0 == kc && r1 == kc && r2 == kc)
                    bwd_channels(mm, ed, e1, e2, xi, x1, x2);
                else
                    bwd_groups(ns, m, dv + r0 * ns, l1 + r1 * ns, l2 + r2 * ns, xi, x1, x2);
            }
        }
        if (q >= 2) { /* chunk q-2: true boundary into its tail, then its residuals */
            const size_t a = CHUNK_A(q - 2), e = CHUNK_E(q - 2);
            const double *b1 = SLOT_ROW(q - 1, e + 1), *b2 = b1 + mm;
            for (size_t r = 0; r < tail; r++) {
                double *xi = SLOT_ROW(q - 2, e - r);
                const double *hr = h + r * ns * 2;
                for (size_t k = 0; k < ns; k++) {
                    const double g1 = hr[2 * k], g2 = hr[2 * k + 1];
                    for (size_t c = k * m; c < k * m + m; c++)
                        xi[c] += g1 * b1[c] + g2 * b2[c];
                }
            }
            mlr_lay_sum_sq_diff_rows(e + 1 - a, mm, y + a * ldy, ldy, SLOT_ROW(q - 2, a), acc);
        }
    }
    {
        const size_t a = CHUNK_A(n_chunks - 1);
        mlr_lay_sum_sq_diff_rows(n - a, mm, y + a * ldy, ldy, SLOT_ROW(n_chunks - 1, a), acc);
    }
#undef CHUNK_A
#undef CHUNK_E
#undef SLOT_ROW
    return 1;
}

/* The residual sums of the solve without keeping the solution: the forward sweep into z (full
 * rows, stride ldz), the backward one through a ring of three rows, acc[c] = sum_i
 * (y_i[c] - x_i[c])^2 accumulated as it goes (one pass less over the arrays than a solve and
 * layers__sum_sq_diff). */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void rss_m(const mlr_lay_batch *b, const size_t m, const double *y, size_t ldy,
                         double *z, size_t ldz, double *buf, double *acc)
{
    const size_t n = b->n, ns = b->ns, mm = m * ns, kc = b->k - 1;
    const double *l1 = b->l1, *l2 = b->l2, *dv = b->dinv;
    double *e1 = buf, *e2 = buf + mm, *ed = buf + 2 * mm, *ring = buf + 3 * mm;
    const int conv = expand_interior(b, m, e1, e2, ed);
    for (size_t c = 0; c < mm; c++)
        acc[c] = 0.0;
    if (conv && rss_chunked(b, m, y, ldy, z, ldz, e1, e2, ed, acc))
        return;
    fwd_m(b, m, y, ldy, z, ldz, e1, e2, conv);
    /* rows n-1, n-2: ring rows (n-1) % 3 and (n-2) % 3 */
    {
        double *xl = ring + ((n - 1) % 3) * mm, *xp = ring + ((n - 2) % 3) * mm;
        const double *zl = z + (n - 1) * ldz, *zp = z + (n - 2) * ldz;
        const double *yl = y + (n - 1) * ldy, *yp = y + (n - 2) * ldy;
        const double *d = dv + layers__row(b, n - 1) * ns;
        const double *d2 = dv + layers__row(b, n - 2) * ns, *a = l1 + layers__row(b, n - 1) * ns;
        for (size_t k = 0; k < ns; k++) {
            for (size_t c = k * m; c < k * m + m; c++) {
                xl[c] = zl[c] * d[k];
                xp[c] = zp[c] * d2[k] - a[k] * xl[c];
                const double r1 = yl[c] - xl[c], r2 = yp[c] - xp[c];
                acc[c] += r1 * r1 + r2 * r2;
            }
        }
    }
    for (size_t i = n - 2; i-- > 0;) {
        const size_t r0 = layers__row(b, i), r1 = layers__row(b, i + 1),
                     r2 = layers__row(b, i + 2);
        double *xi = ring + (i % 3) * mm;
        const double *x1 = ring + ((i + 1) % 3) * mm, *x2 = ring + ((i + 2) % 3) * mm;
        if (conv && r0 == kc && r1 == kc && r2 == kc)
            bwd_channels_rss(mm, ed, e1, e2, z + i * ldz, xi, x1, x2, y + i * ldy, acc);
        else
            bwd_groups_rss(ns, m, dv + r0 * ns, l1 + r1 * ns, l2 + r2 * ns, z + i * ldz, xi, x1,
                           x2, y + i * ldy, acc);
    }
}

/* The sweeps are the bulk of a decomposition: they get an AVX2 clone (mlr_internal.h). */
MLR_CLONES("avx2")
void layers__batch_solve(const mlr_lay_batch *b, size_t m, const double *y, size_t ldy, double *x,
                         size_t ldx, double *buf)
{
    if (m == 3)
        solve_m(b, 3, y, ldy, x, ldx, buf);
    else if (m == 4)
        solve_m(b, 4, y, ldy, x, ldx, buf);
    else
        solve_m(b, m, y, ldy, x, ldx, buf);
}

MLR_CLONES("avx2")
void layers__batch_rss(const mlr_lay_batch *b, size_t m, const double *y, size_t ldy, double *z,
                       size_t ldz, double *buf, double *acc)
{
    if (m == 3)
        rss_m(b, 3, y, ldy, z, ldz, buf, acc);
    else
        rss_m(b, m, y, ldy, z, ldz, buf, acc);
}

MLR_CLONES("avx2")
void layers__sum_sq_diff(size_t n, size_t mm, const double *y, const double *x, double *acc)
{
    for (size_t c = 0; c < mm; c++)
        acc[c] = 0.0;
    mlr_lay_sum_sq_diff_rows(n, mm, y, mm, x, acc);
}

/*
 * Z = A^-1 backward from the last row, keeping only Z(i+1, i+1), Z(i+1, i+2), Z(i+2, i+2):
 *   Z(i, i+1) = -L(i+1,i) Z(i+1,i+1) - L(i+2,i) Z(i+2,i+1)
 *   Z(i, i+2) = -L(i+1,i) Z(i+1,i+2) - L(i+2,i) Z(i+2,i+2)
 *   Z(i, i)   = 1/D(i) - L(i+1,i) Z(i,i+1) - L(i+2,i) Z(i,i+2)
 * In the constant interior, once the state repeats bit for bit, the rows down to the start
 * of that stretch each add the same Z(i, i).
 */
void layers__batch_trace(const mlr_lay_batch *b, double *trace, double *work)
{
    layers__batch_leverage(b, trace, NULL, work);
}

void layers__batch_leverage(const mlr_lay_batch *b, double *trace, double *lev, double *work)
{
    const size_t n = b->n, ns = b->ns, kc = b->k - 1;
    double *restrict za = work, *restrict zb = work + ns, *restrict zc = work + 2 * ns;
    const double *dl = b->dinv + layers__row(b, n - 1) * ns;
    const double *wt = b->w;
    for (size_t k = 0; k < ns; k++) {
        za[k] = dl[k]; /* Z(i+1, i+1) */
        zb[k] = 0.0;   /* Z(i+1, i+2) */
        zc[k] = 0.0;   /* Z(i+2, i+2) */
        trace[k] = wt ? wt[(n - 1) * ns + k] * dl[k] : dl[k];
        if (lev)
            lev[(n - 1) * ns + k] = trace[k];
    }
    for (size_t i = n - 1; i-- > 0;) {
        const size_t r0 = layers__row(b, i), r1 = layers__row(b, i + 1);
        const double *restrict di = b->dinv + r0 * ns, *restrict l1 = b->l1 + r1 * ns;
        const double *restrict l2 = i + 2 < n ? b->l2 + layers__row(b, i + 2) * ns : NULL;
        int moved = 0;
        for (size_t k = 0; k < ns; k++) {
            const double a1 = l1[k], a2 = l2 ? l2[k] : 0.0;
            const double z01 = -a1 * za[k] - a2 * zb[k];
            const double z02 = -a1 * zb[k] - a2 * zc[k];
            const double z00 = di[k] - a1 * z01 - a2 * z02;
            moved |= differs(z00, za[k]) | differs(z01, zb[k]) | differs(za[k], zc[k]);
            zc[k] = za[k];
            zb[k] = z01;
            za[k] = z00;
            const double h = wt ? wt[i * ns + k] * z00 : z00;
            trace[k] += h;
            if (lev)
                lev[i * ns + k] = h;
        }
        /* rows i-1 .. kc have the factor rows of row i: the same update, the same Z(i, i) */
        if (!moved && !lev && b->k < n && i > kc && i + 2 <= n - 3) {
            const double rows = (double)(i - kc);
            for (size_t k = 0; k < ns; k++)
                trace[k] += rows * za[k];
            i = kc;
        }
    }
}
