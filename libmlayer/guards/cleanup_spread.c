/*
 * The contact cleanup's spread of the IK's rotations: a displacement map of rotation
 * vectors through the constrained frames, blended and smoothed.
 */
#include "guards/cleanup_internal.h"
#include "math/band_internal.h"

#include <math.h>

static double smoothstep(double x)
{
    x = x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
    return x * x * (3.0 - 2.0 * x);
}

/* y (N x m): the blended map through val at the frames with mask set (see the header). */
static void design_map(size_t N, size_t m, const uint8_t *mask, const double *val, double B,
                       double *y)
{
    size_t prev = (size_t)-1;
    /* every row is written once there is a frame of mask (before the first, at each, between
       two, after the last): only a map without one is 0 */
    for (size_t f = 0; f <= N; f++) {
        if (f < N && !mask[f])
            continue;
        if (f < N)
            memcpy(y + f * m, val + f * m, m * sizeof *y);
        if (prev == (size_t)-1 && f == N) /* no constrained frame */
            memset(y, 0, N * m * sizeof *y);
        else if (prev == (size_t)-1) { /* before the first constrained frame */
            for (size_t i = 0; i < f; i++) {
                const double w = 1.0 - smoothstep((double)(f - i) / B);
                for (size_t k = 0; k < m; k++)
                    y[i * m + k] = w * val[f * m + k];
            }
        } else if (prev != (size_t)-1 && f == N) { /* after the last */
            for (size_t i = prev + 1; i < N; i++) {
                const double w = 1.0 - smoothstep((double)(i - prev) / B);
                for (size_t k = 0; k < m; k++)
                    y[i * m + k] = w * val[prev * m + k];
            }
        } else if (prev != (size_t)-1 && f > prev + 1) {
            const double L = (double)(f - prev);
            const double s = L <= B ? L : B;
            for (size_t i = prev + 1; i < f; i++) {
                const double wa = 1.0 - smoothstep((double)(i - prev) / s);
                const double wb = 1.0 - smoothstep((double)(f - i) / s);
                for (size_t k = 0; k < m; k++)
                    y[i * m + k] = wa * val[prev * m + k] + wb * val[f * m + k];
            }
        }
        prev = f;
    }
}

/* The map's smoothing with the constrained frames held: x = argmin sum over the free frames of
   (x - y)^2 + s |D2 x|^2 with x = y on the frames of mask (a weight of PIN_HOLD there), s the
   LGS's lam^2 for the time scale PIN_SMOOTH. The blend's corners are rounded on the free side
   only, so the constrained frames keep the IK's values to ~1e-10 relative and one pass
   reaches the targets. */
#define PIN_HOLD 1e10

/* The system is solved on windows only. Through a run of held frames whose value is 0 the
   solution decays geometrically: a held frame's row gives |x_i| <= 10 (s / PIN_HOLD) times its
   neighbours' (the +-2 coupling of D2 makes that a factor of about sqrt(s / PIN_HOLD) per
   frame; sqrt(10 s / PIN_HOLD) is the bound used, q). After R consecutive such frames, with
   q^R <= 1e-30, what lies beyond is 0 to far below rounding, both in the full solve and for
   the frames inside. So a window is the frames around the held frames with a nonzero value,
   extended on each side through R consecutive held frames with value 0 (or to the clip's
   end); its principal submatrix of the full system gives the full solve's values there
   (to rounding), and outside every window the map is 0: those frames are left as they are.
   The right-hand side (the blended map) is 0 outside the windows exactly: a free frame there
   lies between held frames of value 0, or before the first (after the last) of value 0. When
   q is not small (a long PIN_SMOOTH), the window is the whole clip. Window frames: */
enum { SPREAD_FREE = 0, SPREAD_QUIET = 1, SPREAD_SOURCE = 2 };
#define SPREAD_TAIL 1e-30

/* How many held frames of value 0 end a window (0: the whole clip is one). */
static size_t quiet_run(double sc)
{
    const double q = sqrt(10.0 * sc / PIN_HOLD);
    if (!(q < 1e-2))
        return 0;
    const double r = ceil(log(SPREAD_TAIL) / log(q));
    return r < 2.0 ? 2 : (size_t)r;
}

/* The first source frame at or after f (N when none). */
static size_t next_source(const uint8_t *cls, size_t N, size_t f)
{
    while (f < N && cls[f] != SPREAD_SOURCE)
        f++;
    return f;
}

/* The last frame of a window going right from frame s: R consecutive quiet frames, or the
   clip's last frame. */
static size_t extend_right(const uint8_t *cls, size_t N, size_t s, size_t R)
{
    size_t e = s, run = 0;
    while (run < R && e + 1 < N) {
        e++;
        run = cls[e] == SPREAD_QUIET ? run + 1 : 0;
    }
    return e;
}

/* The first frame of a window going left from frame s, down to lo at most; *cut: it ends on R
   consecutive quiet frames (else it reached lo). */
static size_t extend_left(const uint8_t *cls, size_t s, size_t lo, size_t R, int *cut)
{
    size_t a = s, run = 0;
    while (run < R && a > lo) {
        a--;
        run = cls[a] == SPREAD_QUIET ? run + 1 : 0;
    }
    *cut = run >= R;
    return a;
}

/* x = the solve of the principal submatrix of the full system (the smoothing above) on frames
   [a, b), y (the window's rows, m columns) in place: the full system's entries (assembled in
   the same order) in w->ab, then the banded solver's own factor and sweeps (band_internal.h)
   on a pentadiagonal view of the window in w->fac. */
static mlr_status solve_window(const cleanup_work *w, const uint8_t *mask, size_t a, size_t b,
                               double sc, double *y, size_t m)
{
    const size_t N = w->N, n = b - a;
    double *ab = w->ab;
    for (size_t i = 0; i < n; i++)
        ab[3 * i] = mask[a + i] ? PIN_HOLD : 1.0, ab[3 * i + 1] = ab[3 * i + 2] = 0.0;
    static const double c[3] = {1.0, -2.0, 1.0};
    for (size_t r = a >= 2 ? a - 2 : 0; r < b && r + 2 < N; r++) /* D2^T D2, row by row */
        for (size_t p = 0; p < 3; p++)
            for (size_t q = p; q < 3; q++)
                if (r + p >= a && r + q < b)
                    ab[3 * (r + p - a) + (q - p)] += sc * c[p] * c[q];
    /* the band's layout: dinv[i] = A(i,i), l[2 i + k - 1] = A(i,i-k) before the factor */
    mlr_band band = {.n = n, .kd = 2, .dinv = w->fac, .l = w->fac + N};
    for (size_t i = 0; i < n; i++) {
        band.dinv[i] = ab[3 * i];
        band.l[2 * i] = i >= 1 ? ab[3 * (i - 1) + 1] : 0.0;
        band.l[2 * i + 1] = i >= 2 ? ab[3 * (i - 2) + 2] : 0.0;
    }
    const mlr_status st = band__factor_in_place(&band);
    if (st < 0) /* a positive status is a warning (ill-conditioned), not a failure */
        return st;
    double *x = y + a * m;
    for (size_t i = 1; i < n; i++)
        band__forward_row(&band, i, x + i * m, m, m);
    band__backward(&band, x, m, m);
    return MLR_OK;
}

/* The apply's blocks of frames, the log's of (frame, joint) pairs. */
#define SPREAD_BLK 32

/* The listed joints (nj <= 3) of rot on the n <= SPREAD_BLK frames from f0 turned by their
   map's exp(v), normalized: r' = exp(v) r / |exp(v) r|, v the row of y (m = 3 nj values a
   frame). A joint whose v = 0 lies outside the blend: it is left as it is (and its frame not
   marked dirty for it). The product and the norm go through structure-of-arrays copies that
   the compiler vectorizes. */
MLR_CLONES("avx2")
static void rotate_block(cleanup_work *w, double *rot, const int32_t *js, size_t nj,
                         const double *y, size_t f0, size_t n)
{
    const size_t J = w->J, m = 3 * nj;
    mlr_quat e[3 * SPREAD_BLK];
    double ew[SPREAD_BLK], ex[SPREAD_BLK], ey[SPREAD_BLK], ez[SPREAD_BLK];
    double qw[SPREAD_BLK], qx[SPREAD_BLK], qy[SPREAD_BLK], qz[SPREAD_BLK];
    /* the rows are n nj rotation vectors in a row; finite (a solve of finite values) */
    (void)mlr_quat_exp_array((const mlr_vec3 *)(const void *)(y + f0 * m), n * nj, e, NULL);
    for (size_t i = 0; i < nj; i++) {
        const size_t j = (size_t)js[i];
        for (size_t k = 0; k < n; k++) {
            const double *r = rot + 4 * ((f0 + k) * J + j);
            const mlr_quat *ek = &e[k * nj + i];
            ew[k] = ek->w, ex[k] = ek->x, ey[k] = ek->y, ez[k] = ek->z;
            qw[k] = r[0], qx[k] = r[1], qy[k] = r[2], qz[k] = r[3];
        }
        for (size_t k = 0; k < n; k++) {
            const mlr_quat o =
                common__qmul_wxyz(ew[k], ex[k], ey[k], ez[k], qw[k], qx[k], qy[k], qz[k]);
            const double ow = o.w, ox = o.x, oy = o.y, oz = o.z;
            const double nn = sqrt(ow * ow + ox * ox + oy * oy + oz * oz);
            qw[k] = ow / nn, qx[k] = ox / nn, qy[k] = oy / nn, qz[k] = oz / nn;
        }
        for (size_t k = 0; k < n; k++) {
            const double *v = y + (f0 + k) * m + 3 * i;
            if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0)
                continue; /* outside the blend: the frame is left as it is */
            double *r = rot + 4 * ((f0 + k) * J + j);
            r[0] = qw[k], r[1] = qx[k], r[2] = qy[k], r[3] = qz[k];
            w->dirty[f0 + k] |= w->dirty_bit;
        }
    }
}

/* The map on the window [a, b): blended (design_map on the window alone gives the same values:
   its ends are held frames, or the clip's), smoothed, and applied to the rotations. */
static mlr_status spread_window(cleanup_work *w, double *rot, const int32_t *js, size_t nj,
                                const uint8_t *mask, size_t a, size_t b, double sc)
{
    const size_t m = 3 * nj;
    double *y = w->map_y;
    design_map(b - a, m, mask + a, w->map_val + a * m, w->cfg->blend * w->fps, y + a * m);
    for (size_t f = a; f < b; f++)
        if (mask[f])
            for (size_t k = 0; k < m; k++)
                y[f * m + k] *= PIN_HOLD;
    mlr_status st = solve_window(w, mask, a, b, sc, y, m);
    if (st != MLR_OK)
        return st;
    for (size_t f = a; f < b; f += SPREAD_BLK)
        rotate_block(w, rot, js, nj, y, f, b - f < SPREAD_BLK ? b - f : SPREAD_BLK);
    return MLR_OK;
}

/* The (frame, joint) pairs whose log is pending: a = newr, b = rot, v the map's values. */
typedef struct log_block {
    mlr_quat a[SPREAD_BLK], b[SPREAD_BLK];
    mlr_vec3 lg[SPREAD_BLK];
    double *v[SPREAD_BLK];
    size_t f[SPREAD_BLK], n;
} log_block;

/* v = log(a conj(b)) of the pending pairs, their frames with a nonzero value a source. */
static void log_flush(log_block *blk, uint8_t *cls)
{
    common__quat_conj_mul_log(blk->a, blk->b, blk->n, 1, blk->b, blk->lg);
    for (size_t k = 0; k < blk->n; k++) {
        double *v = blk->v[k];
        v[0] = blk->lg[k].x, v[1] = blk->lg[k].y, v[2] = blk->lg[k].z;
        if (v[0] != 0.0 || v[1] != 0.0 || v[2] != 0.0)
            cls[blk->f[k]] = SPREAD_SOURCE;
    }
    blk->n = 0;
}

mlr_status cleanup__spread_rotations(cleanup_work *w, double *rot, const double *newr,
                                     const int32_t *js, size_t nj, const uint8_t *mask)
{
    const size_t N = w->N, J = w->J, m = 3 * nj;
    uint8_t *cls = w->cls;
    /* the log of newr * conj(rot) of each moved joint, by blocks; where the IK left the joint
       as it was (reached, kept), the log of a * inv(a) is 0: exactly 0 here, where the
       product's sums leave residues of ~1e-17 (which the whole-clip solve spread everywhere) */
    log_block blk;
    blk.n = 0;
    for (size_t f = 0; f < N; f++) {
        cls[f] = mask[f] ? SPREAD_QUIET : SPREAD_FREE;
        if (!mask[f])
            continue;
        if (mask[f] == CLEANUP_HELD_SAME) { /* reached or kept: newr is rot there */
            memset(w->map_val + f * m, 0, m * sizeof(double));
            continue;
        }
        for (size_t i = 0; i < nj; i++) {
            const size_t q = 4 * (f * J + (size_t)js[i]);
            double *v = w->map_val + f * m + 3 * i;
            if (memcmp(newr + q, rot + q, 4 * sizeof(double)) == 0) {
                v[0] = v[1] = v[2] = 0.0;
                continue;
            }
            memcpy(&blk.a[blk.n], newr + q, sizeof blk.a[0]);
            memcpy(&blk.b[blk.n], rot + q, sizeof blk.b[0]);
            blk.f[blk.n] = f, blk.v[blk.n] = v;
            if (++blk.n == SPREAD_BLK)
                log_flush(&blk, cls);
        }
    }
    log_flush(&blk, cls);
    const double lam = (w->cfg->pin_smooth * w->fps) * (w->cfg->pin_smooth * w->fps);
    const double sc = lam * lam;
    const size_t R = quiet_run(sc);
    size_t s = next_source(cls, N, 0);
    if (!R) /* one window: the whole clip (when some value is nonzero: else the map is 0) */
        return s < N ? spread_window(w, rot, js, nj, mask, 0, N, sc) : MLR_OK;
    int cut;
    size_t a = s < N ? extend_left(cls, s, 0, R, &cut) : 0;
    while (s < N) {
        /* the window of source s, and of each next source whose window would reach it */
        size_t e = extend_right(cls, N, s, R), s2, a2 = 0;
        for (;;) {
            if ((s2 = next_source(cls, N, e + 1)) >= N)
                break;
            a2 = extend_left(cls, s2, e + 1, R, &cut);
            if (cut)
                break;
            e = extend_right(cls, N, s2, R);
        }
        mlr_status st = spread_window(w, rot, js, nj, mask, a, e + 1, sc);
        if (st != MLR_OK)
            return st;
        s = s2, a = a2;
    }
    return MLR_OK;
}
