/*
 * Resampling through the LGS and the SLERP baseline (paper 1, section 5.3). The time map puts
 * input frame i at position t[i] of the output grid; the LGS (order 2) turns the positions into
 * linear-interpolation rows of A, factors once and solves every channel. See mlr_resample.h
 * for the choice of the smoothness.
 */
#include "common/mlr_internal.h"

#include <math.h>

/* Local steps are compared with the factor limit with this relative slack, so that a uniform
 * map at exactly 100x, computed in floating point, passes. */
#define FACTOR_SLACK 1e-9

/* A last position within this relative distance below an integer counts as that integer in
 * the exact count of a frame rate change (rounding of i fps_out / fps_in). */
#define RATE_SNAP 1e-9

static int extreme_ok(unsigned flags) { return (flags & MLR_RESAMPLE_ALLOW_EXTREME) != 0; }

/* Position of the last input frame on the exact grid of fps_out (as mlr_resample_rate_map). */
static double exact_last(size_t n_frames, double fps_in, double fps_out)
{
    return (double)(n_frames - 1) * fps_out / fps_in;
}

static mlr_status check_factor(double r, unsigned flags, mlr_diag *diag)
{
    const double lim = MLR_RESAMPLE_MAX_FACTOR;
    if (extreme_ok(flags))
        return MLR_OK;
    if (r > lim * (1.0 + FACTOR_SLACK) || r < (1.0 - FACTOR_SLACK) / lim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "resampling factor %g is beyond %gx (set the flag allow_extreme "
                                "if this is intended)",
                                r >= 1.0 ? r : 1.0 / r, lim);
    return MLR_OK;
}

static mlr_status check_flags(unsigned flags, mlr_diag *diag)
{
    if (flags & ~(unsigned)(MLR_RESAMPLE_ALLOW_EXTREME | MLR_RESAMPLE_NEAREST_SIGN |
                            MLR_RESAMPLE_OPEN_END))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown flags 0x%x", flags);
    return MLR_OK;
}

mlr_status mlr_resample_n_out(size_t n_frames, double fps_in, double fps_out, unsigned flags,
                              size_t *n_out, mlr_diag *diag)
{
    if (!n_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "n_out is NULL");
    *n_out = 0;
    if (check_flags(flags, diag))
        return MLR_E_INVALID_ARG;
    if (n_frames < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "resampling needs at least 2 frames, got %zu", n_frames);
    if (!isfinite(fps_in) || !(fps_in > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "input fps must be finite and > 0, got %g", fps_in);
    if (!isfinite(fps_out) || !(fps_out > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "output fps must be finite and > 0, got %g", fps_out);
    const double r = fps_out / fps_in;
    mlr_status st = check_factor(r, flags, diag);
    if (st != MLR_OK)
        return st;
    if (flags & MLR_RESAMPLE_OPEN_END) {
        const double x = exact_last(n_frames, fps_in, fps_out);
        const double n = floor(x + RATE_SNAP * (x > 1.0 ? x : 1.0)) + 1.0;
        if (!(n < (double)SIZE_MAX / 2))
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "output frame count overflows");
        if (n < 2.0)
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "%zu frames at %g fps last %g s, less than one frame at %g fps", n_frames, fps_in,
                (double)(n_frames - 1) / fps_in, fps_out);
        *n_out = (size_t)n;
        return MLR_OK;
    }
    const double n = round((double)(n_frames - 1) * r) + 1.0;
    if (!(n < (double)SIZE_MAX / 2))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "output frame count overflows");
    *n_out = n < 2.0 ? 2 : (size_t)n;
    return MLR_OK;
}

mlr_status mlr_resample_rate_map(size_t n_frames, double fps_in, double fps_out, unsigned flags,
                                 double *t, size_t *n_out, mlr_diag *diag)
{
    if (!t || !n_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "t or n_out is NULL");
    mlr_status st =
        mlr_resample_n_out(n_frames, fps_in, fps_out, flags | MLR_RESAMPLE_OPEN_END, n_out, diag);
    if (st != MLR_OK)
        return st;
    for (size_t i = 0; i < n_frames; i++)
        t[i] = (double)i * fps_out / fps_in;
    const double last = (double)(*n_out - 1);
    if (t[n_frames - 1] < last)
        t[n_frames - 1] = last; /* within RATE_SNAP below: the count took it as that integer */
    return MLR_OK;
}

mlr_status mlr_timemap_validate(const double *t, size_t n_frames, size_t n_out, unsigned flags,
                                mlr_diag *diag)
{
    if (check_flags(flags, diag))
        return MLR_E_INVALID_ARG;
    if (n_frames < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "a time map needs at least 2 frames, got %zu", n_frames);
    if (n_out < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "the output needs at least 2 frames, got %zu", n_out);
    if (!t)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "time map is NULL");
    const double last = (double)(n_out - 1);
    for (size_t i = 0; i < n_frames; i++)
        if (!isfinite(t[i]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "time map: t[%zu] is not finite", i);
    if (t[0] != 0.0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "time map: t[0] must be 0 (the first frame stays put), got %g",
                                t[0]);
    if (flags & MLR_RESAMPLE_OPEN_END) {
        if (!(t[n_frames - 1] >= last && t[n_frames - 1] < last + 1.0))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "time map: t[%zu] must lie in [n_out - 1, n_out) = [%zu, %zu) "
                                    "(open end), got %g",
                                    n_frames - 1, n_out - 1, n_out, t[n_frames - 1]);
    } else if (t[n_frames - 1] != last) {
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "time map: t[%zu] must be n_out - 1 = %zu (the last frame stays put), got %g",
            n_frames - 1, n_out - 1, t[n_frames - 1]);
    }
    mlr_status st = check_factor(t[n_frames - 1] / (double)(n_frames - 1), flags, diag);
    if (st != MLR_OK)
        return st;
    const double lo = (1.0 - FACTOR_SLACK) / MLR_RESAMPLE_MAX_FACTOR;
    const double hi = MLR_RESAMPLE_MAX_FACTOR * (1.0 + FACTOR_SLACK);
    for (size_t i = 1; i < n_frames; i++) {
        const double d = t[i] - t[i - 1];
        if (!(d > 0.0))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "time map is not strictly increasing: t[%zu] = %g, t[%zu] = %g", i - 1, t[i - 1],
                i, t[i]);
        if (!extreme_ok(flags) && (d < lo || d > hi))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "time map step t[%zu] - t[%zu] = %g is beyond the %gx factor limit "
                "(set the flag allow_extreme if this is intended)",
                i, i - 1, d, MLR_RESAMPLE_MAX_FACTOR);
    }
    return MLR_OK;
}

/* The automatic s for r output frames per input frame. */
static double auto_smoothness(double r)
{
    const double up = MLR_RESAMPLE_KAPPA_UP * r * r * r, down = MLR_RESAMPLE_KAPPA_DOWN / r;
    return up > down ? up : down;
}

double mlr_resample_auto_smoothness(size_t n_frames, size_t n_out)
{
    if (n_frames < 2 || n_out < 2)
        return 0.0;
    return auto_smoothness((double)(n_out - 1) / (double)(n_frames - 1));
}

/* Shared argument checks of the resampling entry points (everything but the time map). */
static mlr_status check_motion(size_t n_frames, size_t n_joints, size_t n_trans,
                               const double *root_pos, const double *rot, const double *trans,
                               size_t n_out, unsigned flags, const double *root_out,
                               const double *rot_out, const double *trans_out, mlr_diag *diag)
{
    if (check_flags(flags, diag))
        return MLR_E_INVALID_ARG;
    if (n_frames < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "resampling needs at least 2 frames, got %zu", n_frames);
    if (n_out < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "the output needs at least 2 frames, got %zu", n_out);
    if (!root_pos || !root_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "root_pos or root_out is NULL");
    if (n_joints > 0 && (!rot || !rot_out))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "rot or rot_out is NULL");
    if (n_trans > 0 && (!trans || !trans_out))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "trans or trans_out is NULL");
    size_t tmp;
    if (common__mul_size(n_frames, 3 * sizeof(double), &tmp) ||
        common__mul_size(n_out, 3 * sizeof(double), &tmp) ||
        common__mul_size(n_frames, n_joints, &tmp) ||
        common__mul_size(tmp, 4 * sizeof(double), &tmp) ||
        common__mul_size(n_out, n_joints, &tmp) ||
        common__mul_size(tmp, 4 * sizeof(double), &tmp) ||
        common__mul_size(n_frames, n_trans, &tmp) ||
        common__mul_size(tmp, 3 * sizeof(double), &tmp) ||
        common__mul_size(n_out, n_trans, &tmp) || common__mul_size(tmp, 3 * sizeof(double), &tmp))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "array sizes overflow");
    return MLR_OK;
}

/* 1 when every value is finite, else 0 with the index of the first bad one in *bad. */
static int all_finite(const double *v, size_t count, size_t *bad)
{
    for (size_t i = 0; i < count; i++)
        if (!isfinite(v[i])) {
            *bad = i;
            return 0;
        }
    return 1;
}

static mlr_status check_translations(size_t n_frames, size_t n_trans, const double *root_pos,
                                     const double *trans, mlr_diag *diag)
{
    size_t bad;
    if (!all_finite(root_pos, n_frames * 3, &bad))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "root_pos of frame %zu is not finite", bad / 3);
    if (n_trans > 0 && !all_finite(trans, n_frames * n_trans * 3, &bad))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "trans of frame %zu, joint %zu is not finite", bad / (3 * n_trans),
                                (bad / 3) % n_trans);
    return MLR_OK;
}

/* A quaternion row of J joints: finite and nonzero. */
static int rot_row_ok(const double *q, size_t n_joints, size_t *bad_joint)
{
    for (size_t j = 0; j < n_joints; j++) {
        const double *p = q + 4 * j;
        const double n2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3];
        if (!(n2 > 0.0) || !isfinite(n2)) {
            *bad_joint = j;
            return 0;
        }
    }
    return 1;
}

static mlr_status bad_rot(mlr_diag *diag, size_t f, size_t j)
{
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "rot of frame %zu, joint %zu is zero or not finite", f, j);
}

/* The arguments of mlr_resample_arrays after check_motion: sigma, lam, the time map (or the
 * uniform factor) and the translations. */
static mlr_status check_smoothing(size_t n_frames, size_t n_trans, const double *root_pos,
                                  const double *trans, const double *t, size_t n_out, double lam,
                                  double sigma, unsigned flags, mlr_diag *diag)
{
    if (!isfinite(sigma) || !(sigma > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "sigma must be finite and > 0, got %g", sigma);
    if (isnan(lam) || (lam >= 0.0 && !isfinite(lam)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lam must be finite and >= 0, or MLR_RESAMPLE_AUTO; got %g", lam);
    mlr_status st;
    if (t) {
        st = mlr_timemap_validate(t, n_frames, n_out, flags, diag);
    } else {
        st = check_factor((double)(n_out - 1) / (double)(n_frames - 1), flags, diag);
    }
    if (st != MLR_OK)
        return st;
    return check_translations(n_frames, n_trans, root_pos, trans, diag);
}

/* The scratch of one resampling: the longer grid of an open end, the uniform time map, the
 * sign-continuous rotations (each NULL when not needed). */
typedef struct resample_work {
    mlr_allocator a;
    double *grid, *tu, *q;
    size_t grid_bytes, tu_bytes, q_bytes;
} resample_work;

static void work_free(resample_work *w)
{
    common__free(&w->a, w->q, w->q_bytes);
    common__free(&w->a, w->tu, w->tu_bytes);
    common__free(&w->a, w->grid, w->grid_bytes);
}

/* The solution grid of n_grid rows: a grid of the work (root, rotations, translations,
 * variance) when n_grid > n_out, else the outputs themselves. */
typedef struct grid_rows {
    double *root, *rot, *trans, *var;
} grid_rows;

static mlr_status output_grid(resample_work *w, size_t n_grid, size_t n_out, size_t n_joints,
                              size_t n_trans, grid_rows *g, mlr_diag *diag)
{
    if (n_grid == n_out)
        return MLR_OK;
    /* sizes checked in check_motion for n_out rows; one more row stays far from SIZE_MAX */
    const size_t n_rot = n_joints * 4, row = 3 + n_rot + 3 * n_trans + 1;
    if (common__mul_size(n_grid, row * sizeof(double), &w->grid_bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "array sizes overflow");
    w->grid = common__alloc(&w->a, w->grid_bytes);
    if (!w->grid)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "resample: out of memory (%zu bytes for the output grid)",
                                w->grid_bytes);
    const int var = g->var != NULL;
    g->root = w->grid;
    g->rot = g->root + 3 * n_grid;
    g->trans = g->rot + n_rot * n_grid;
    g->var = var ? g->trans + 3 * n_trans * n_grid : NULL;
    return MLR_OK;
}

/* The uniform time map of n_frames onto n_out frames into the work (when it is not the
 * identity); *t points to it. */
static mlr_status uniform_map(resample_work *w, size_t n_frames, size_t n_out, const double **t,
                              mlr_diag *diag)
{
    if (*t || n_out == n_frames)
        return MLR_OK;
    w->tu_bytes = n_frames * sizeof(double);
    w->tu = common__alloc(&w->a, w->tu_bytes);
    if (!w->tu)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "resample: out of memory (%zu bytes for the time map)",
                                w->tu_bytes);
    const double step = (double)(n_out - 1) / (double)(n_frames - 1);
    for (size_t i = 0; i + 1 < n_frames; i++)
        w->tu[i] = (double)i * step;
    w->tu[n_frames - 1] = (double)(n_out - 1);
    *t = w->tu;
    return MLR_OK;
}

/* A sign-continuous copy of the rotations into the work (each checked finite and nonzero). */
static mlr_status continuous_rotations(resample_work *w, size_t n_frames, size_t n_joints,
                                       const double *rot, unsigned flags, mlr_diag *diag)
{
    if (n_joints == 0)
        return MLR_OK;
    const size_t n_rot = n_joints * 4;
    w->q_bytes = n_frames * n_rot * sizeof(double);
    w->q = common__alloc(&w->a, w->q_bytes);
    if (!w->q)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "resample: out of memory (%zu bytes for the rotations)",
                                w->q_bytes);
    double *q = w->q;
    const int nearest = (flags & MLR_RESAMPLE_NEAREST_SIGN) != 0;
    for (size_t f = 0; f < n_frames; f++) {
        size_t bad;
        const double *src = rot + f * n_rot;
        if (!rot_row_ok(src, n_joints, &bad))
            return bad_rot(diag, f, bad);
        memcpy(q + f * n_rot, src, n_rot * sizeof(double));
        if (f == 0)
            continue;
        if (nearest)
            mlr_quat_make_continuous((mlr_quat *)(q + (f - 1) * n_rot), 2, n_joints);
        else
            common__quat_continue_frame((mlr_quat *)q, f, n_joints);
    }
    return MLR_OK;
}

/* The LGS solves of root, rotations and translations onto the grid, and the variance;
 * *created is the status of the LGS's creation (MLR_OK or a warning such as
 * MLR_W_ILL_CONDITIONED). */
static mlr_status solve_grid(resample_work *w, size_t n_frames, size_t n_joints, size_t n_trans,
                             const double *root_pos, const double *trans, const double *t,
                             size_t n_grid, double lam, double sigma, const grid_rows *g,
                             mlr_status *created, mlr_diag *diag)
{
    const size_t n_rot = n_joints * 4;
    mlr_lgs *lgs = NULL;
    mlr_status st = mlr_lgs_create(n_grid, n_grid >= 3 ? 2 : 1, lam, sigma, t, n_frames,
                                   MLR_LGS_BANDED, &w->a, &lgs, diag);
    if (st < 0)
        return common__diag_prefix(diag, st, "resample");
    *created = st;
    st = mlr_lgs_solve(lgs, root_pos, 3, 3, g->root, 3, diag);
    if (st == MLR_OK && n_joints > 0)
        st = mlr_lgs_solve(lgs, w->q, n_rot, n_rot, g->rot, n_rot, diag);
    if (st == MLR_OK && n_trans > 0)
        st = mlr_lgs_solve(lgs, trans, 3 * n_trans, 3 * n_trans, g->trans, 3 * n_trans, diag);
    if (st == MLR_OK && g->var)
        st = mlr_lgs_variance(lgs, g->var, n_grid, diag);
    mlr_lgs_destroy(lgs);
    return st == MLR_OK ? st : common__diag_prefix(diag, st, "resample");
}

mlr_status mlr_resample_arrays(size_t n_frames, size_t n_joints, size_t n_trans,
                               const double *root_pos, const double *rot, const double *trans,
                               const double *t, size_t n_out, double lam, double sigma,
                               unsigned flags, double *root_out, double *rot_out,
                               double *trans_out, double *var_out, const mlr_allocator *alloc,
                               mlr_diag *diag)
{
    mlr_status st = check_motion(n_frames, n_joints, n_trans, root_pos, rot, trans, n_out, flags,
                                 root_out, rot_out, trans_out, diag);
    if (st == MLR_OK)
        st =
            check_smoothing(n_frames, n_trans, root_pos, trans, t, n_out, lam, sigma, flags, diag);
    if (st != MLR_OK)
        return st;
    /* an open end past the last output frame: the LGS solves one hidden frame more */
    const size_t n_grid =
        t && (flags & MLR_RESAMPLE_OPEN_END) && t[n_frames - 1] > (double)(n_out - 1) ? n_out + 1
                                                                                      : n_out;
    if (lam < 0.0)
        lam = sqrt(auto_smoothness((t ? t[n_frames - 1] : (double)(n_out - 1)) /
                                   (double)(n_frames - 1))) /
              sigma;

    resample_work w;
    memset(&w, 0, sizeof w);
    common__allocator_resolve(alloc, &w.a);
    grid_rows g = {root_out, rot_out, trans_out, var_out};
    st = output_grid(&w, n_grid, n_out, n_joints, n_trans, &g, diag);
    if (st == MLR_OK)
        st = uniform_map(&w, n_frames, n_out, &t, diag);
    if (st == MLR_OK)
        st = continuous_rotations(&w, n_frames, n_joints, rot, flags, diag);
    mlr_status created = MLR_OK;
    if (st == MLR_OK)
        st = solve_grid(&w, n_frames, n_joints, n_trans, root_pos, trans, t, n_grid, lam, sigma,
                        &g, &created, diag);
    if (st != MLR_OK) {
        work_free(&w);
        return st;
    }
    if (w.grid) { /* the first n_out frames of the grid */
        const size_t n_rot = n_joints * 4;
        memcpy(root_out, g.root, 3 * n_out * sizeof(double));
        if (n_joints > 0)
            memcpy(rot_out, g.rot, n_rot * n_out * sizeof(double));
        if (n_trans > 0)
            memcpy(trans_out, g.trans, 3 * n_trans * n_out * sizeof(double));
        if (var_out)
            memcpy(var_out, g.var, n_out * sizeof(double));
    }
    work_free(&w);
    if (n_joints > 0 && mlr_quat_normalize_array((const mlr_quat *)rot_out, n_out * n_joints,
                                                 (mlr_quat *)rot_out, NULL) != MLR_OK)
        return common__diag_set(
            diag, MLR_E_SINGULAR, 0, 0,
            "an interpolated quaternion vanished (a key step near 360 degrees?)");
    return created;
}

mlr_status mlr_slerp_resample_arrays(size_t n_frames, size_t n_joints, size_t n_trans,
                                     const double *root_pos, const double *rot,
                                     const double *trans, const double *t, size_t n_out,
                                     unsigned flags, double *root_out, double *rot_out,
                                     double *trans_out, mlr_diag *diag)
{
    mlr_status st = check_motion(n_frames, n_joints, n_trans, root_pos, rot, trans, n_out, flags,
                                 root_out, rot_out, trans_out, diag);
    if (st != MLR_OK)
        return st;
    if (t)
        st = mlr_timemap_validate(t, n_frames, n_out, flags, diag);
    else
        st = check_factor((double)(n_out - 1) / (double)(n_frames - 1), flags, diag);
    if (st != MLR_OK)
        return st;
    st = check_translations(n_frames, n_trans, root_pos, trans, diag);
    if (st != MLR_OK)
        return st;
    for (size_t f = 0; f < n_frames; f++) {
        size_t bad;
        if (!rot_row_ok(rot + f * n_joints * 4, n_joints, &bad))
            return bad_rot(diag, f, bad);
    }

    const double step = (double)(n_out - 1) / (double)(n_frames - 1);
    size_t k = 0; /* interval [k, k+1] of the input */
    enum { CHUNK = 64 };
    double u_rep[CHUNK];
    for (size_t j = 0; j < n_out; j++) {
        const double x = (double)j;
#define POS(i) (t ? t[i] : ((i) + 1 == n_frames ? (double)(n_out - 1) : (double)(i) * step))
        while (k + 2 < n_frames && POS(k + 1) <= x)
            k++;
        const double t0 = POS(k), t1 = POS(k + 1);
#undef POS
        double u = (x - t0) / (t1 - t0);
        u = u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u);
        const double *p0 = root_pos + 3 * k, *p1 = p0 + 3;
        for (size_t c = 0; c < 3; c++)
            root_out[3 * j + c] = p0[c] + u * (p1[c] - p0[c]);
        for (size_t c = 0; c < 3 * n_trans; c++) {
            const double a0 = trans[3 * n_trans * k + c], a1 = trans[3 * n_trans * (k + 1) + c];
            trans_out[3 * n_trans * j + c] = a0 + u * (a1 - a0);
        }
        for (size_t c = 0; c < CHUNK && c < n_joints; c++)
            u_rep[c] = u;
        for (size_t j0 = 0; j0 < n_joints; j0 += CHUNK) {
            const size_t cnt = n_joints - j0 < CHUNK ? n_joints - j0 : CHUNK;
            const mlr_quat *qa = (const mlr_quat *)(rot + 4 * (n_joints * k + j0));
            const mlr_quat *qb = qa + n_joints;
            mlr_quat_slerp_array(qa, qb, u_rep, cnt,
                                 (mlr_quat *)(rot_out + 4 * (n_joints * j + j0)), NULL);
        }
    }
    return MLR_OK;
}
