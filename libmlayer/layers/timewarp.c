/*
 * Automatic time warping (paper 1, section 5.3 and Figure 9): a per-frame motion magnitude
 * turned into a monotone time map that spends more output frames where the motion is large,
 * eased in and out by an LGS smoothing of the log rate.
 */
#include "common/mlr_internal.h"

#include <math.h>

#define TW_PI 3.14159265358979323846
/* Speeds below this fraction of the clip mean count as this fraction (log floor). */
#define TW_SPEED_FLOOR 0.05
#define TW_MAX_STRENGTH 10.0
#define TW_MAX_RATE_RATIO 100.0

/* Rotation angle between two quaternions of any norm and sign, in [0, pi]. */
static double rot_angle(const double *a, const double *b)
{
    /* conj(a) * b: w = a.b, v = a.w b.v - b.w a.v - a.v x b.v */
    const double w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    const double vx = a[0] * b[1] - b[0] * a[1] - (a[2] * b[3] - a[3] * b[2]);
    const double vy = a[0] * b[2] - b[0] * a[2] - (a[3] * b[1] - a[1] * b[3]);
    const double vz = a[0] * b[3] - b[0] * a[3] - (a[1] * b[2] - a[2] * b[1]);
    return 2.0 * atan2(sqrt(vx * vx + vy * vy + vz * vz), fabs(w));
}

mlr_status mlr_timewarp_speed(size_t n_frames, size_t n_joints, const double *root_pos,
                              const double *rot, const double *joint_weights, double root_weight,
                              double *speed, mlr_diag *diag)
{
    if (n_frames < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "time warping needs at least 2 frames, got %zu", n_frames);
    if (!root_pos || !speed || (n_joints > 0 && !rot))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "NULL array");
    if (!isfinite(root_weight) || root_weight < 0.0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "root_weight must be finite and >= 0, got %g", root_weight);
    double wsum = 0.0;
    if (joint_weights) {
        for (size_t j = 0; j < n_joints; j++) {
            if (!isfinite(joint_weights[j]) || joint_weights[j] < 0.0)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "joint_weights[%zu] must be finite and >= 0, got %g", j,
                                        joint_weights[j]);
            wsum += joint_weights[j];
        }
        if (n_joints > 0 && !(wsum > 0.0))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "joint_weights are all zero");
    } else {
        wsum = (double)n_joints;
    }
    size_t tmp;
    if (common__mul_size(n_frames, n_joints, &tmp) || common__mul_size(tmp, 4, &tmp))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "array sizes overflow");
    for (size_t i = 0; i < n_frames; i++) {
        const size_t a = i > 0 ? i - 1 : 0, b = i + 1 < n_frames ? i + 1 : n_frames - 1;
        const double span = (double)(b - a);
        double ang = 0.0;
        for (size_t j = 0; j < n_joints; j++) {
            const double w = joint_weights ? joint_weights[j] : 1.0;
            if (w != 0.0)
                ang += w * rot_angle(rot + 4 * (a * n_joints + j), rot + 4 * (b * n_joints + j));
        }
        const double *pa = root_pos + 3 * a, *pb = root_pos + 3 * b;
        const double dx = pb[0] - pa[0], dy = pb[1] - pa[1], dz = pb[2] - pa[2];
        double v = root_weight * sqrt(dx * dx + dy * dy + dz * dz);
        if (n_joints > 0)
            v += ang / wsum;
        speed[i] = v / span;
        if (!isfinite(speed[i]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "frames %zu..%zu hold non-finite values", a, b);
    }
    return MLR_OK;
}

mlr_status mlr_timewarp_map(size_t n_frames, size_t n_joints, const double *root_pos,
                            const double *rot, const double *joint_weights, double root_weight,
                            double strength, double smooth_frames, size_t n_out, unsigned flags,
                            double *t, const mlr_allocator *alloc, mlr_diag *diag)
{
    if (!isfinite(strength) || strength < 0.0 || strength > TW_MAX_STRENGTH)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "strength must be finite and in [0, %g], got %g", TW_MAX_STRENGTH,
                                strength);
    if (!isfinite(smooth_frames) || !(smooth_frames >= 1.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "smooth_frames must be finite and >= 1, got %g", smooth_frames);
    if (n_out < 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "the output needs at least 2 frames, got %zu", n_out);
    if (flags & ~(unsigned)MLR_RESAMPLE_ALLOW_EXTREME)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown flags 0x%x", flags);
    if (!t)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "t is NULL");
    mlr_status st =
        mlr_timewarp_speed(n_frames, n_joints, root_pos, rot, joint_weights, root_weight, t, diag);
    if (st != MLR_OK)
        return st;

    /* t holds the speed; turn it into the log of the relative speed */
    double mean = 0.0;
    for (size_t i = 0; i < n_frames; i++)
        mean += t[i];
    mean /= (double)n_frames;
    const double floor_log = log(TW_SPEED_FLOOR);
    for (size_t i = 0; i < n_frames; i++) {
        const double rel = mean > 0.0 ? t[i] / mean : 1.0;
        t[i] = rel > TW_SPEED_FLOOR ? log(rel) : floor_log;
    }
    /* ease: order-2 LGS whose gain is 1/2 at the period smooth_frames */
    if (n_frames >= 3 && strength > 0.0) {
        const double lam = pow(smooth_frames / (2.0 * TW_PI), 2.0);
        mlr_lgs *lgs = NULL;
        st = mlr_lgs_create(n_frames, 2, lam, 1.0, NULL, n_frames, MLR_LGS_BANDED, alloc, &lgs,
                            diag);
        if (st < 0)
            return common__diag_prefix(diag, st, "timewarp");
        st = mlr_lgs_solve(lgs, t, 1, 1, t, 1, diag);
        mlr_lgs_destroy(lgs);
        if (st != MLR_OK)
            return st;
    }
    /* rates exp(strength * g), the slowest at most TW_MAX_RATE_RATIO below the fastest */
    double gmax = -INFINITY;
    for (size_t i = 0; i < n_frames; i++) {
        t[i] *= strength;
        if (t[i] > gmax)
            gmax = t[i];
    }
    const double gmin = gmax - log(TW_MAX_RATE_RATIO);
    double prev = exp((t[0] < gmin ? gmin : t[0]) - gmax), acc = 0.0;
    t[0] = 0.0;
    for (size_t i = 1; i < n_frames; i++) {
        const double rate = exp((t[i] < gmin ? gmin : t[i]) - gmax);
        acc += 0.5 * (prev + rate);
        prev = rate;
        t[i] = acc;
    }
    const double scale = (double)(n_out - 1) / acc;
    for (size_t i = 1; i + 1 < n_frames; i++)
        t[i] *= scale;
    t[n_frames - 1] = (double)(n_out - 1);
    return mlr_timemap_validate(t, n_frames, n_out, flags, diag);
}
