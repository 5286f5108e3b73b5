/*
 * The up axis of a motion: from its feet (by name) or, without foot names, from the side on
 * which the lowest joint keeps one height (see mlr_rig_up_axis in include/mlayer/mlr_rig.h).
 */
#include "common/mlr_internal.h"

#include <math.h>
#include <stdlib.h>

static const char *const foot_names[] = {"foot", "ankle", "toe", "paw", "hoof", NULL};

/* from_feet's upright stretch: its share of the frames, and how straight down the legs hang */
#define UPRIGHT_SHARE 0.15
#define UPRIGHT_COS 0.9

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The q-quantile (nearest rank) of v[0..n), sorted in place. */
static double quantile(double *v, size_t n, double q)
{
    qsort(v, n, sizeof *v, cmp_double);
    return v[(size_t)(q * (double)(n - 1) + 0.5)];
}

/* The joint a leg hangs from: the ankle's grandparent (the hip: ankle, knee, hip), or its
 * parent, or itself at the root. */
static size_t leg_top(const mlr_rig *rig, size_t j)
{
    for (int up = 0; up < 2 && rig->parents[j] >= 0; up++)
        j = (size_t)rig->parents[j];
    return j;
}

static void from_feet(const mlr_rig *rig, size_t N, const double *wp, const uint8_t *is_foot,
                      mlr_up_guess *out)
{
    const size_t J = rig->n_joints;
    double d[3] = {0, 0, 0};
    size_t votes[3] = {0, 0, 0}; /* frames whose legs hang straight down +k (UPRIGHT_COS) */
    for (size_t f = 0; f < N; f++) {
        const double *p = wp + 3 * J * f;
        double e[3] = {0, 0, 0};
        for (size_t j = 0; j < J; j++) {
            if (!is_foot[j])
                continue;
            const size_t h = leg_top(rig, j);
            for (int k = 0; k < 3; k++)
                e[k] += p[3 * j + (size_t)k] - p[3 * h + (size_t)k];
        }
        const double en = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        for (int k = 0; k < 3; k++) {
            d[k] += e[k];
            votes[k] += en > 0.0 && e[k] < -UPRIGHT_COS * en;
        }
    }
    const double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(n > 0))
        return;
    int best = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(d[k]) > fabs(d[best]))
            best = k;
    out->axis = best;
    out->sign = d[best] < 0 ? 1 : -1;
    out->confidence = fabs(d[best]) / n;
    out->method = MLR_UP_FEET;
    if (out->sign > 0)
        return;
    /* upside down on the whole: depth cameras and video estimates are (Y down), but a body
       that stands upright for a stretch and lies down for longer (a game's death: standing
       along Y, then lying along Z, legs toward +Z) sums to an upside-down lie. A stretch of
       UPRIGHT_SHARE of the frames whose legs hang down another axis (feet below their hips
       by UPRIGHT_COS of their offset) is taken as the up the body stood in. */
    int up = -1;
    for (int k = 0; k < 3; k++)
        if (k != best && (double)votes[k] >= UPRIGHT_SHARE * (double)N &&
            (up < 0 || votes[k] > votes[up]))
            up = k;
    if (up < 0 || votes[best] > 0)
        return;
    out->axis = up;
    out->sign = 1;
    out->confidence = fmax(MLR_RIG_UP_SURE, (double)votes[up] / (double)N);
}

static mlr_status from_floor(size_t N, size_t J, const double *wp, mlr_up_guess *out,
                             const mlr_allocator *a)
{
    size_t bytes;
    if (common__mul_size(N, 3 * sizeof(double), &bytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *lo = common__alloc(a, bytes);
    if (!lo)
        return MLR_E_NO_MEMORY;
    double *hi = lo + N, *ext = hi + N;
    double spread[3][2]; /* [axis][0: floor at the lowest joint (up +), 1: at the highest] */
    int any = 0;
    for (int k = 0; k < 3; k++) {
        for (size_t f = 0; f < N; f++) {
            const double *p = wp + 3 * J * f;
            double mn = p[k], mx = p[k];
            for (size_t j = 1; j < J; j++) {
                const double v = p[3 * j + (size_t)k];
                mn = v < mn ? v : mn;
                mx = v > mx ? v : mx;
            }
            lo[f] = mn, hi[f] = mx, ext[f] = mx - mn;
        }
        const double size = quantile(ext, N, 0.5);
        if (!(size > 0)) {
            spread[k][0] = spread[k][1] = INFINITY;
            continue;
        }
        any = 1;
        spread[k][0] = (quantile(lo, N, 0.95) - quantile(lo, N, 0.05)) / size;
        spread[k][1] = (quantile(hi, N, 0.95) - quantile(hi, N, 0.05)) / size;
    }
    common__free(a, lo, bytes);
    if (!any)
        return MLR_OK;
    int bk = 0, bs = 0;
    for (int k = 0; k < 3; k++)
        for (int s = 0; s < 2; s++)
            if (spread[k][s] < spread[bk][bs])
                bk = k, bs = s;
    double other = INFINITY;
    for (int k = 0; k < 3; k++)
        if (k != bk)
            for (int s = 0; s < 2; s++)
                other = spread[k][s] < other ? spread[k][s] : other;
    out->axis = bk;
    out->sign = bs == 0 ? 1 : -1;
    out->confidence = isfinite(other) && other > 0 ? fmax(0.0, 1.0 - spread[bk][bs] / other)
                                                   : (isfinite(other) ? 0.0 : 1.0);
    out->method = MLR_UP_FLOOR;
    return MLR_OK;
}

mlr_status mlr_rig_up_axis(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                           mlr_up_guess *out, const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "up axis: out is NULL");
    *out = (mlr_up_guess){MLR_AXIS_Y, 1, 0.0, MLR_UP_NONE};
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    const size_t N = n_frames, J = rig->n_joints;
    if (N == 0)
        return MLR_OK;
    if (!world_pos)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "up axis: world_pos is NULL");
    size_t count;
    if (common__mul_size(N, 3 * J, &count) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "up axis: %zu frames x %zu joints "
                                "overflow a size",
                                N, J);
    for (size_t i = 0; i < count; i++)
        if (!isfinite(world_pos[i]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "up axis: position %zu of frame "
                                    "%zu is not finite",
                                    (i / 3) % J, i / (3 * J));
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    uint8_t *is_foot = common__alloc(&a, J);
    if (!is_foot)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "up axis: out of memory");
    size_t n_feet = 0;
    for (size_t j = 0; j < J; j++)
        n_feet += is_foot[j] = rig->names && common__name_matches(rig->names[j], foot_names);
    if (n_feet > 0 && n_feet < J)
        from_feet(rig, N, world_pos, is_foot, out);
    common__free(&a, is_foot, J);
    if (out->method == MLR_UP_NONE && J > 1) {
        st = from_floor(N, J, world_pos, out, &a);
        if (st != MLR_OK)
            return common__diag_set(diag, st, 0, 0, "up axis: %s",
                                    st == MLR_E_NO_MEMORY ? "out of memory" : "frames too large");
    }
    return MLR_OK;
}
