/*
 * The contact cleanup's spread of the IK's rotations: a displacement map of rotation
 * vectors through the constrained frames, blended and smoothed.
 */
#include "cleanup_internal.h"
#include "ik_internal.h"

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
    memset(y, 0, N * m * sizeof *y);
    for (size_t f = 0; f <= N; f++) {
        if (f < N && !mask[f])
            continue;
        if (f < N)
            memcpy(y + f * m, val + f * m, m * sizeof *y);
        if (prev == (size_t)-1 && f < N) { /* before the first constrained frame */
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

static void qlog(const double q_in[4], double v[3])
{
    double q[4] = {q_in[0], q_in[1], q_in[2], q_in[3]};
    if (q[0] < 0.0)
        q[0] = -q[0], q[1] = -q[1], q[2] = -q[2], q[3] = -q[3];
    const double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const double angle = 2.0 * atan2(s, q[0]);
    const double k = s > 1e-300 ? angle / s : 2.0;
    v[0] = k * q[1], v[1] = k * q[2], v[2] = k * q[3];
}

static void qexp(const double v[3], double q[4])
{
    const double a = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double h = 0.5 * a;
    const double k = a > 1e-300 ? sin(h) / a : 0.5;
    q[0] = cos(h), q[1] = k * v[0], q[2] = k * v[1], q[3] = k * v[2];
}

/* The map's smoothing with the constrained frames held: x = argmin sum over the free frames of
   (x - y)^2 + s |D2 x|^2 with x = y on the frames of mask (a weight of PIN_HOLD there), s the
   LGS's lam^2 for the time scale PIN_SMOOTH. The blend's corners are rounded on the free side
   only, so the constrained frames keep the IK's values to ~1e-10 relative and one pass
   reaches the targets. */
#define PIN_HOLD 1e10
static mlr_status smooth_held(cleanup_work *w, const uint8_t *mask, double *y, size_t m)
{
    const size_t N = w->N;
    const double lam = (w->cfg->pin_smooth * w->fps) * (w->cfg->pin_smooth * w->fps);
    const double sc = lam * lam;
    double *ab = w->ab;
    for (size_t f = 0; f < N; f++)
        ab[3 * f] = mask[f] ? PIN_HOLD : 1.0, ab[3 * f + 1] = ab[3 * f + 2] = 0.0;
    static const double c[3] = {1.0, -2.0, 1.0};
    for (size_t r = 0; r + 2 < N; r++) /* D2^T D2, row by row of D2 */
        for (size_t a = 0; a < 3; a++)
            for (size_t b = a; b < 3; b++)
                ab[3 * (r + a) + (b - a)] += sc * c[a] * c[b];
    mlr_status st = mlr_band_factor(w->pin, ab, 3, NULL);
    if (st < 0)
        return st;
    for (size_t f = 0; f < N; f++)
        if (mask[f])
            for (size_t k = 0; k < m; k++)
                y[f * m + k] *= PIN_HOLD;
    return mlr_band_solve(w->pin, y, m, m, NULL);
}

mlr_status cleanup__spread_rotations(cleanup_work *w, double *rot, const double *newr,
                                     const int32_t *js, size_t nj, const uint8_t *mask)
{
    const size_t N = w->N, J = w->J, m = 3 * nj;
    for (size_t f = 0; f < N; f++) {
        if (!mask[f])
            continue;
        for (size_t i = 0; i < nj; i++) {
            const double *a = newr + 4 * (f * J + (size_t)js[i]),
                         *b = rot + 4 * (f * J + (size_t)js[i]);
            const double cb[4] = {b[0], -b[1], -b[2], -b[3]};
            double d[4];
            mlr_ik_qmul(a, cb, d);
            qlog(d, w->map_val + f * m + 3 * i);
        }
    }
    design_map(N, m, mask, w->map_val, w->cfg->blend * w->fps, w->map_y);
    mlr_status st = smooth_held(w, mask, w->map_y, m);
    if (st != MLR_OK)
        return st;
    memcpy(w->map_out, w->map_y, N * m * sizeof(double));
    for (size_t f = 0; f < N; f++)
        for (size_t i = 0; i < nj; i++) {
            double *r = rot + 4 * (f * J + (size_t)js[i]), e[4], o[4];
            const double *v = w->map_out + f * m + 3 * i;
            if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0)
                continue; /* outside the blend: the frame is left as it is */
            w->dirty[f] = 1;
            qexp(v, e);
            mlr_ik_qmul(e, r, o);
            const double n = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3]);
            for (int k = 0; k < 4; k++)
                r[k] = o[k] / n;
        }
    return MLR_OK;
}
