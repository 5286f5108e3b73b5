/*
 * The converter's lead-in at the start of a clip (T-pose and blend frames): see the rule in
 * include/mlayer/mlr_trim.h.
 */
#include "common/mlr_internal.h"

#include <math.h>

#include "mlayer/mlr_fk.h"
#include "mlayer/mlr_trim.h"

/* Mean over K joints of |a[j] - b[j]| (K x 3 each). */
static double pose_distance(const double *a, const double *b, size_t K)
{
    double s = 0.0;
    for (size_t k = 0; k < 3 * K; k += 3) {
        const double dx = a[k] - b[k], dy = a[k + 1] - b[k + 1], dz = a[k + 2] - b[k + 2];
        s += sqrt(dx * dx + dy * dy + dz * dz);
    }
    return s / (double)K;
}

/* v in the frame of a Y-up clip, for a clip whose up axis is u: the proper rotations of
 * mlayer.up_axis.to_y_up (X-up: +90 degrees about Z; Z-up: -90 degrees about X). */
static void to_y_up(int u, const double *v, double *o)
{
    const double x = v[0], y = v[1], z = v[2];
    if (u == MLR_AXIS_X)
        o[0] = -y, o[1] = x, o[2] = z;
    else if (u == MLR_AXIS_Z)
        o[0] = x, o[1] = z, o[2] = -y;
    else
        o[0] = x, o[1] = y, o[2] = z;
}

/* The pose of one frame, as mlayer.pose_features makes it: in the Y-up frame, the joints
 * flagged in inside (K of them) relative to the body joint b, turned about +Y by minus b's
 * heading yaw = atan2(f_x, f_z), f its +Z axis (the axis that the turn to Y-up takes to +Z:
 * -Y on a Z-up clip). wp J x 3, wr J x 4 (world); x K x 3. */
static void pose_of(const double *wp, const double *wr, size_t J, size_t b, const uint8_t *inside,
                    int u, double *x)
{
    static const double forward[3][3] = {{0, 0, 1}, {0, 0, 1}, {0, -1, 0}};
    double f[3], fy[3];
    common__quat_rotate_inline((const mlr_quat *)(wr + 4 * b), forward[u], f);
    to_y_up(u, f, fy);
    const double yaw = atan2(fy[0], fy[2]), c = cos(yaw), s = sin(yaw);
    const double *pb = wp + 3 * b;
    for (size_t j = 0; j < J; j++) {
        if (!inside[j])
            continue;
        const double r[3] = {wp[3 * j] - pb[0], wp[3 * j + 1] - pb[1], wp[3 * j + 2] - pb[2]};
        double ry[3];
        to_y_up(u, r, ry);
        x[0] = c * ry[0] - s * ry[2];
        x[1] = ry[1];
        x[2] = s * ry[0] + c * ry[2];
        x += 3;
    }
}

/* The arguments of mlr_trim_lead_in: the rig, the up axis, the arrays; every frame finite. */
static mlr_status check_clip(const mlr_rig *rig, size_t N, const double *root_pos,
                             const double *rot, const double *trans, int up, mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (up < MLR_AXIS_X || up > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lead_in: up axis %d is not 0 (X), "
                                "1 (Y) or 2 (Z)",
                                up);
    const size_t J = rig->n_joints, P = rig->n_trans;
    if (N > 0 && !rot)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lead_in: rot is NULL");
    if (N > 0 && P > 0 && !trans)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lead_in: trans is NULL with %zu "
                                "translated joints",
                                P);
    if (N < MLR_TRIM_MIN_FRAMES)
        return MLR_OK;
    for (size_t f = 0; f < N; f++) {
        int finite = !root_pos || (isfinite(root_pos[3 * f]) && isfinite(root_pos[3 * f + 1]) &&
                                   isfinite(root_pos[3 * f + 2]));
        for (size_t i = 4 * J * f; i < 4 * J * (f + 1) && finite; i++)
            finite = isfinite(rot[i]);
        if (!finite)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "lead_in: frame %zu has "
                                    "non-finite rotations or translations",
                                    f);
    }
    return MLR_OK;
}

/* The pose of every frame (pose_of) into x (N x K x 3); wp, wr one frame's FK (J x 3, J x 4). */
static mlr_status clip_poses(const mlr_rig *rig, size_t N, const double *root_pos,
                             const double *rot, const double *trans, size_t b,
                             const uint8_t *inside, size_t K, int up, double *x, double *wp,
                             double *wr, const mlr_allocator *A, mlr_diag *diag)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    for (size_t f = 0; f < N; f++) {
        mlr_status st = mlr_fk_arrays(
            1, J, rig->parents, rig->offsets, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f,
            P, rig->trans_joints, P ? trans + 3 * P * f : NULL, wp, wr, A, NULL);
        if (st != MLR_OK)
            return common__diag_set(diag, st, 0, 0, "lead_in: forward kinematics of frame %zu: %s",
                                    f, mlr_status_string(st));
        pose_of(wp, wr, J, b, inside, up, x + 3 * K * f);
    }
    return MLR_OK;
}

/* The rule of mlr_trim.h on the poses x (N x K x 3): held frames, the blend, the jump. step
 * and tmp N doubles of scratch each. */
static void lead_rule(const double *x, size_t N, size_t K, double *step, double *tmp,
                      mlr_trim_lead *out)
{
    /* the body size: the median over frames of the joints' mean distance from the body */
    for (size_t f = 0; f < N; f++) {
        const double *xf = x + 3 * K * f;
        double s = 0.0;
        for (size_t k = 0; k < 3 * K; k += 3)
            s += sqrt(xf[k] * xf[k] + xf[k + 1] * xf[k + 1] + xf[k + 2] * xf[k + 2]);
        tmp[f] = s / (double)K;
    }
    const double still = MLR_TRIM_STILL * common__median(tmp, N);
    /* 1. held: the frames that hold the first pose */
    size_t h = 1;
    while (h < N && !(pose_distance(x, x + 3 * K * h, K) > still))
        h++;
    if (!(h + 1 < N && still > 0))
        return;
    /* the median step of the rest, floored at `still` */
    for (size_t f = h; f + 1 < N; f++)
        tmp[f - h] = step[f] = pose_distance(x + 3 * K * f, x + 3 * K * (f + 1), K);
    const double m = fmax(common__median(tmp, N - 1 - h), still);
    /* 2. blend: until the steps are ordinary again, MLR_TRIM_SETTLE of them in a row */
    size_t c = h;
    for (size_t f = h, run = 0; f + 1 < N && f < h + MLR_TRIM_MAX_BLEND + MLR_TRIM_SETTLE; f++) {
        run = step[f] <= MLR_TRIM_JOIN * m ? run + 1 : 0;
        if (run == MLR_TRIM_SETTLE || (run > 0 && f + 2 == N)) {
            c = f + 1 - run;
            break;
        }
    }
    /* 3. jump: the first pose's distance to the motion, every frame from c on */
    double nearest = INFINITY;
    for (size_t g = c; g < N; g++)
        nearest = fmin(nearest, pose_distance(x, x + 3 * K * g, K));
    out->distance = nearest / m;
    if (out->distance > MLR_TRIM_JUMP && c <= N / 4) {
        out->n_frames = c;
        out->n_held = h;
    }
}

mlr_status mlr_trim_lead_in(const mlr_rig *rig, size_t n_frames, const double *root_pos,
                            const double *rot, const double *trans, int up, mlr_trim_lead *out,
                            const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lead_in: out is NULL");
    *out = (mlr_trim_lead){0, 0, 0.0};
    const size_t N = n_frames;
    mlr_status st = check_clip(rig, N, root_pos, rot, trans, up, diag);
    if (st != MLR_OK || N < MLR_TRIM_MIN_FRAMES)
        return st;
    int32_t body;
    st = mlr_rig_body_translation_joint(rig, N, root_pos, trans, &body, diag);
    if (st != MLR_OK)
        return st;
    const size_t b = (size_t)body, J = rig->n_joints;

    mlr_allocator A;
    common__allocator_resolve(alloc, &A);
    uint8_t *inside = common__alloc(&A, J);
    if (!inside)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "lead_in: out of memory");
    /* the joints below the body joint (parents come before children): their pose */
    size_t K = 0;
    for (size_t j = 0; j < J; j++) {
        inside[j] = j == b || (j > b && inside[rig->parents[j]]);
        K += j > b && inside[j];
    }
    inside[b] = 0;
    if (K == 0) {
        common__free(&A, inside, J);
        return MLR_OK;
    }
    /* scratch: poses N x K x 3, steps N, a copy for medians N, one frame's FK J x 7 */
    size_t n_pose, bytes;
    if (common__mul_size(N, 3 * K, &n_pose) != MLR_OK || n_pose > SIZE_MAX / 2 - 2 * N - 7 * J ||
        common__mul_size(n_pose + 2 * N + 7 * J, sizeof(double), &bytes) != MLR_OK) {
        common__free(&A, inside, J);
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "lead_in: %zu frames x %zu joints "
                                "overflow a size",
                                N, J);
    }
    double *x = common__alloc(&A, bytes);
    if (!x) {
        common__free(&A, inside, J);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "lead_in: out of memory");
    }
    double *step = x + n_pose, *tmp = step + N, *wp = tmp + N, *wr = wp + 3 * J;
    st = clip_poses(rig, N, root_pos, rot, trans, b, inside, K, up, x, wp, wr, &A, diag);
    if (st == MLR_OK)
        lead_rule(x, N, K, step, tmp, out);
    common__free(&A, x, bytes);
    common__free(&A, inside, J);
    return st;
}
