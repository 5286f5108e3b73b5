/*
 * Root motion: a root track on the ground plane and the motion in place relative to it. The
 * rules are in include/mlayer/mlr_root_motion.h.
 */
#include "common/mlr_internal.h"

#include <math.h>

#include "motion/mirror_internal.h"
#include "mlayer/mlr_fk.h"
#include "mlayer/mlr_lgs.h"
#include "mlayer/mlr_root_motion.h"
#include "common/options_internal.h"

#define SUBJECT "root motion"
#define PI 3.14159265358979323846

static const mlr_opt_spec root_motion_spec[] = {
    {MLR_ROOT_MOTION_OPT_SMOOTH, "smooth", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 1.0, ">= 0"},
    {MLR_ROOT_MOTION_OPT_BODY_JOINT, "body_joint", MLR_OPT_INT, -1.0, 2147483647.0, 0, 0, -1.0,
     "-1 or a joint index"},
};

/* The quaternion of the rotation by theta about axis a. */
static mlr_quat heading_quat(int a, double theta)
{
    mlr_quat h = {cos(0.5 * theta), 0.0, 0.0, 0.0};
    const double s = sin(0.5 * theta);
    if (a == MLR_AXIS_X)
        h.x = s;
    else if (a == MLR_AXIS_Y)
        h.y = s;
    else
        h.z = s;
    return h;
}

/* The left/right pairs whose sides the names tell: partner and side (J each, in one block of
 * *bytes bytes that the caller releases), or NULL when the rig has no names. */
static mlr_status sided_pairs(const mlr_rig *rig, const mlr_allocator *a, int32_t **partner,
                              int8_t **side, size_t *bytes, mlr_diag *diag)
{
    const size_t J = rig->n_joints;
    *partner = NULL, *side = NULL, *bytes = 0;
    if (!rig->names)
        return MLR_OK;
    for (size_t j = 0; j < J; j++)
        if (!rig->names[j])
            return MLR_OK;
    if (common__mul_size(J, sizeof(int32_t) + 1, bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                SUBJECT ": %zu joints overflow the "
                                        "size",
                                J);
    *partner = common__alloc(a, *bytes);
    if (!*partner)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                SUBJECT ": out of memory for the "
                                        "left/right pairs of %zu joints",
                                J);
    *side = (int8_t *)(*partner + J);
    size_t n_pairs = 0;
    const mlr_status st = mirror__find_pairs(rig, NULL, 0, 0, *partner, *side, &n_pairs, a, diag);
    if (st != MLR_OK) {
        common__free(a, *partner, *bytes);
        *partner = NULL, *side = NULL;
    }
    return st;
}

/* Unwrapped headings: h[3 n + 2] holds atan2 per frame, valid[n] whether it was defined.
 * Steps of at most pi between defined frames; undefined frames take the nearest defined
 * frame before (after, at the start); all 0 when none is defined. */
static void unwrap_heading(double *h, const unsigned char *valid, size_t N)
{
    size_t first = N;
    for (size_t n = 0; n < N && first == N; n++)
        if (valid[n])
            first = n;
    if (first == N) {
        for (size_t n = 0; n < N; n++)
            h[3 * n + 2] = 0.0;
        return;
    }
    double prev_raw = h[3 * first + 2], prev = prev_raw;
    for (size_t n = first + 1; n < N; n++) {
        if (!valid[n]) {
            h[3 * n + 2] = prev;
            continue;
        }
        const double raw = h[3 * n + 2];
        double d = raw - prev_raw;
        d -= 2.0 * PI * floor((d + PI) / (2.0 * PI));
        prev += d, prev_raw = raw;
        h[3 * n + 2] = prev;
    }
    for (size_t n = 0; n < first; n++)
        h[3 * n + 2] = h[3 * first + 2];
}

static mlr_status check_args(const mlr_rig *rig, double fps, int up, int mode, size_t N,
                             const double *root_pos, const double *rot, const double *trans,
                             const double *track_pos, const double *track_heading,
                             const double *out_root_pos, const double *out_root_rot,
                             size_t ld_out_rot, mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (!(isfinite(fps) && fps > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": fps %g is not finite "
                                        "and > 0",
                                fps);
    if (up < MLR_AXIS_X || up > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": up axis %d is not 0 (x), "
                                        "1 (y) or 2 (z)",
                                up);
    if (mode != MLR_ROOT_MOTION_GROUND && mode != MLR_ROOT_MOTION_POSITION)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": mode %d is not 0 "
                                        "(ground) or 1 (position)",
                                mode);
    if (N == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, SUBJECT ": no frames");
    if (!root_pos || !rot || (rig->n_trans && !trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": root_pos, rot or trans "
                                        "is NULL");
    if (!track_pos || !track_heading || !out_root_pos || !out_root_rot)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, SUBJECT ": an output is NULL");
    if (ld_out_rot < 4)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": ld_out_rot %zu is below "
                                        "4",
                                ld_out_rot);
    return MLR_OK;
}

/* The frames, finite (forward kinematics reads them all). */
static mlr_status check_finite(const mlr_rig *rig, size_t N, const double *root_pos,
                               const double *rot, const double *trans, mlr_diag *diag)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    for (size_t k = 0; k < 3 * N; k++)
        if (!isfinite(root_pos[k]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    SUBJECT ": root_pos[%zu][%zu] "
                                            "is not finite",
                                    k / 3, k % 3);
    for (size_t k = 0; k < 4 * N * J; k++)
        if (!isfinite(rot[k]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    SUBJECT ": rot[%zu][%zu] is not "
                                            "finite",
                                    k / (4 * J), k / 4 % J);
    for (size_t k = 0; k < 3 * N * P; k++)
        if (!isfinite(trans[k]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    SUBJECT ": trans[%zu][%zu] is "
                                            "not finite",
                                    k / (3 * P), k / 3 % P);
    return MLR_OK;
}

/* Smooth the n_ch first columns of y (N x 3) by the LGS of the period smooth. */
static mlr_status smooth_track(double *y, size_t N, size_t n_ch, double smooth, double fps,
                               const mlr_allocator *alloc, mlr_diag *diag)
{
    if (smooth == 0.0 || N < 3)
        return MLR_OK;
    const double arg = PI / (smooth * fps);
    const double g = 2.0 * sin(arg < 0.5 * PI ? arg : 0.5 * PI);
    const double s = 1.0 / (g * g * g * g);
    mlr_lgs *lgs = NULL;
    mlr_status st = mlr_lgs_create(N, 2, sqrt(s), 1.0, NULL, N, MLR_LGS_BANDED, alloc, &lgs, diag);
    if (st < 0)
        return st;
    const mlr_status solved = mlr_lgs_solve(lgs, y, 3, n_ch, y, 3, diag);
    mlr_lgs_destroy(lgs);
    return solved != MLR_OK ? solved : st;
}

/* The options of an extract: the smoothing (seconds) and the body joint (-1: the rig's body
   translation joint), below J. */
static mlr_status read_options(const mlr_rig *rig, const mlr_root_motion_option *opts,
                               size_t n_opts, double *smooth, double *body_joint, mlr_diag *diag)
{
    mlr_opt_values ov;
    mlr_status st = MLR_OPTIONS_READ(SUBJECT, root_motion_spec, opts, n_opts, &ov, diag);
    if (st != MLR_OK)
        return st;
    *smooth = ov.v[MLR_ROOT_MOTION_OPT_SMOOTH];
    *body_joint = ov.v[MLR_ROOT_MOTION_OPT_BODY_JOINT];
    const size_t J = rig->n_joints;
    if (*body_joint >= (double)J)
        return options__reject(diag, SUBJECT, "body_joint", *body_joint, "-1 or below %zu joints",
                               J);
    return MLR_OK;
}

/* The scratch of an extract, one block: y: N x 3 (the track's ground coordinates, the
   heading), wb: N x 4 (the body joint's world rotation), one frame's forward kinematics
   (J x 3, J x 4), valid: N flags. */
typedef struct track_work {
    double *y, *wb, *wpos, *wrot;
    unsigned char *valid;
} track_work;

/* The body joint b's ground path (y's first two columns, on the ground axes g1, g2) and world
   rotations wb, frame by frame; with the sided pairs (partner, side), the left direction in
   the body joint's frame summed over frames and pairs into left, and the pairs' distances
   into total. */
static mlr_status body_path(const mlr_rig *rig, size_t N, const double *root_pos,
                            const double *rot, const double *trans, int32_t b, int g1, int g2,
                            const int32_t *partner, const int8_t *side, const track_work *tw,
                            double left[3], double *total, const mlr_allocator *a, mlr_diag *diag)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    double *y = tw->y, *wb = tw->wb, *wpos = tw->wpos, *wrot = tw->wrot;
    mlr_status st = MLR_OK;
    for (size_t n = 0; n < N && st == MLR_OK; n++) {
        st = mlr_fk_arrays(1, J, rig->parents, rig->offsets, root_pos + 3 * n, rot + 4 * J * n, P,
                           rig->trans_joints, P ? trans + 3 * P * n : NULL, wpos, wrot, a, diag);
        y[3 * n] = wpos[3 * (size_t)b + (size_t)g1];
        y[3 * n + 1] = wpos[3 * (size_t)b + (size_t)g2];
        y[3 * n + 2] = 0.0;
        memcpy(wb + 4 * n, wrot + 4 * (size_t)b, 4 * sizeof(double));
        if (!partner)
            continue;
        /* the left direction in the body joint's frame, summed over frames and pairs */
        const mlr_quat *w = (const mlr_quat *)(wb + 4 * n);
        const mlr_quat winv = {w->w, -w->x, -w->y, -w->z};
        for (size_t j = 0; j < J; j++) {
            if (side[j] != 1)
                continue;
            const double *p = wpos + 3 * j, *q = wpos + 3 * (size_t)partner[j];
            const double d[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
            double dl[3];
            common__quat_rotate_inline(&winv, d, dl);
            for (int c = 0; c < 3; c++)
                left[c] += dl[c];
            *total += sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        }
    }
    return st;
}

/* The headings (y's third column, continuous; with ground only): the body's forward
   direction, the summed left direction (normalised; the ground axis g2 when there is none)
   crossed with the up axis, on the ground. */
static void body_headings(size_t N, int ground, int g1, int g2, double left[3], double total,
                          const track_work *tw)
{
    double *y = tw->y;
    unsigned char *valid = tw->valid;
    const double norm = sqrt(left[0] * left[0] + left[1] * left[1] + left[2] * left[2]);
    if (norm > 1e-9 * total && norm > 0.0)
        for (int c = 0; c < 3; c++)
            left[c] /= norm;
    else
        left[0] = left[1] = left[2] = 0.0, left[g2] = 1.0;
    for (size_t n = 0; ground && n < N; n++) {
        double v[3];
        common__quat_rotate_inline((const mlr_quat *)(tw->wb + 4 * n), left, v);
        /* f = v x e_up: its ground components are f.g1 = v[g2], f.g2 = -v[g1] */
        const double f1 = v[g2], f2 = -v[g1];
        valid[n] = sqrt(f1 * f1 + f2 * f2) > 1e-9;
        if (valid[n])
            y[3 * n + 2] = atan2(f2, f1);
    }
    if (ground)
        unwrap_heading(y, valid, N);
}

/* The in-place root: the root's position and rotation relative to the track's, frame by
   frame. */
static void in_place_root(const mlr_rig *rig, int up, size_t N, const double *root_pos,
                          const double *rot, const double *track_pos, const double *track_heading,
                          double *out_root_pos, double *out_root_rot, size_t ld_out_rot)
{
    const size_t J = rig->n_joints;
    for (size_t n = 0; n < N; n++) {
        const double *c = track_pos + 3 * n, *p = root_pos + 3 * n;
        const mlr_quat hinv = heading_quat(up, -track_heading[n]);
        const double d[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
        const mlr_quat q = *(const mlr_quat *)(rot + 4 * J * n);
        common__quat_rotate_inline(&hinv, d, out_root_pos + 3 * n);
        common__quat_mul_inline(&hinv, &q, (mlr_quat *)(out_root_rot + ld_out_rot * n));
    }
}

mlr_status mlr_root_motion_extract(const mlr_rig *rig, double fps, int up, int mode,
                                   size_t n_frames, const double *root_pos, const double *rot,
                                   const double *trans, const mlr_root_motion_option *opts,
                                   size_t n_opts, double *track_pos, double *track_heading,
                                   double *out_root_pos, double *out_root_rot, size_t ld_out_rot,
                                   const mlr_allocator *alloc, mlr_diag *diag)
{
    const size_t N = n_frames;
    mlr_status st = check_args(rig, fps, up, mode, N, root_pos, rot, trans, track_pos,
                               track_heading, out_root_pos, out_root_rot, ld_out_rot, diag);
    if (st != MLR_OK)
        return st;
    double smooth, bj;
    if ((st = read_options(rig, opts, n_opts, &smooth, &bj, diag)) != MLR_OK)
        return st;
    const size_t J = rig->n_joints;
    st = check_finite(rig, N, root_pos, rot, trans, diag);
    if (st != MLR_OK)
        return st;
    int32_t b = (int32_t)bj;
    if (b < 0 && (st = mlr_rig_body_translation_joint(rig, N, root_pos, trans, &b, diag)) != 0)
        return st;
    const int ground = mode == MLR_ROOT_MOTION_GROUND;
    const int g1 = (up + 1) % 3, g2 = (up + 2) % 3;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    int32_t *partner = NULL;
    int8_t *side = NULL;
    size_t pair_bytes = 0, n_doubles, bytes;
    if (ground && (st = sided_pairs(rig, &a, &partner, &side, &pair_bytes, diag)) != MLR_OK)
        return st;
    /* the scratch: see track_work */
    if (common__mul_size(N + J, 7, &n_doubles) != MLR_OK ||
        common__mul_size(n_doubles, sizeof(double), &bytes) != MLR_OK || bytes > SIZE_MAX - N) {
        common__free(&a, partner, pair_bytes);
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                SUBJECT ": %zu frames of %zu joints "
                                        "overflow the size",
                                N, J);
    }
    bytes += N;
    double *y = common__alloc(&a, bytes);
    if (!y) {
        common__free(&a, partner, pair_bytes);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                SUBJECT ": out of memory for the "
                                        "track of %zu frames",
                                N);
    }
    track_work tw = {y, y + 3 * N, y + 7 * N, y + 7 * N + 3 * J, NULL};
    tw.valid = (unsigned char *)(tw.wrot + 4 * J);
    double left[3] = {0.0, 0.0, 0.0}, total = 0.0;
    st = body_path(rig, N, root_pos, rot, trans, b, g1, g2, partner, side, &tw, left, &total, &a,
                   diag);
    common__free(&a, partner, pair_bytes);
    if (st != MLR_OK) {
        common__free(&a, y, bytes);
        return st;
    }
    body_headings(N, ground, g1, g2, left, total, &tw);
    st = smooth_track(y, N, ground ? 3 : 2, smooth, fps, &a, diag);
    if (st < 0) {
        common__free(&a, y, bytes);
        return st;
    }
    for (size_t n = 0; n < N; n++) {
        double *c = track_pos + 3 * n;
        c[up] = 0.0, c[g1] = y[3 * n], c[g2] = y[3 * n + 1];
        track_heading[n] = y[3 * n + 2];
    }
    common__free(&a, y, bytes);
    in_place_root(rig, up, N, root_pos, rot, track_pos, track_heading, out_root_pos, out_root_rot,
                  ld_out_rot);
    return st;
}

mlr_status mlr_root_motion_apply(int up, size_t n_frames, const double *track_pos,
                                 const double *track_heading, const double *root_pos,
                                 const double *root_rot, size_t ld_root_rot, double *out_root_pos,
                                 double *out_root_rot, size_t ld_out_rot, mlr_diag *diag)
{
    const size_t N = n_frames;
    if (up < MLR_AXIS_X || up > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": up axis %d is not 0 (x), "
                                        "1 (y) or 2 (z)",
                                up);
    if (ld_root_rot < 4 || ld_out_rot < 4)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": rotation strides %zu and "
                                        "%zu must be >= 4",
                                ld_root_rot, ld_out_rot);
    if (N &&
        (!track_pos || !track_heading || !root_pos || !root_rot || !out_root_pos || !out_root_rot))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                SUBJECT ": NULL argument with %zu "
                                        "frames",
                                N);
    for (size_t n = 0; n < N; n++) {
        if (!isfinite(track_heading[n]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    SUBJECT ": track heading[%zu] "
                                            "is not finite",
                                    n);
        for (size_t c = 0; c < 3; c++)
            if (!isfinite(track_pos[3 * n + c]))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        SUBJECT ": track "
                                                "position[%zu][%zu] is not finite",
                                        n, c);
    }
    for (size_t n = 0; n < N; n++) {
        const mlr_quat h = heading_quat(up, track_heading[n]);
        const double *c = track_pos + 3 * n;
        const double p[3] = {root_pos[3 * n], root_pos[3 * n + 1], root_pos[3 * n + 2]};
        const mlr_quat q = *(const mlr_quat *)(root_rot + ld_root_rot * n);
        double r[3];
        common__quat_rotate_inline(&h, p, r);
        for (int k = 0; k < 3; k++)
            out_root_pos[3 * n + (size_t)k] = c[k] + r[k];
        common__quat_mul_inline(&h, &q, (mlr_quat *)(out_root_rot + ld_out_rot * n));
    }
    return MLR_OK;
}
