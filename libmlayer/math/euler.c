/* Intrinsic Euler angles: the six orders (mlr_euler_order, mlr_euler_order_parse) and the
 * conversions between angle triples and quaternions. Nothing here allocates, prints or keeps
 * state. */
#include "math/quat_internal.h"

#include <math.h>

#define MLR_PI 3.14159265358979323846
#define MLR_TWO_PI 6.28318530717958647693

/* Inside this band of the middle angle around +-pi/2 (in radians), to_euler reports gimbal
 * lock (third angle 0). from_euler at exactly +-pi/2 lands within ~5e-16 of the pole; forcing
 * the third angle to 0 costs at most about this much in the reproduced rotation. */
#define GIMBAL_EPS 1e-13

const unsigned char mlr_euler_axes[6][3] = {
    {0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0},
};
const double mlr_euler_parity[6] = {1.0, -1.0, -1.0, 1.0, 1.0, -1.0};

/* Wrap an angle in (-2pi, 2pi] (in fact any angle within one turn of the range) to (-pi, pi]. */
static double wrap_pi(double a)
{
    if (a > MLR_PI)
        a -= MLR_TWO_PI;
    else if (a <= -MLR_PI)
        a += MLR_TWO_PI;
    return a;
}

static int order_is_valid(mlr_euler_order order) { return (int)order >= 0 && (int)order < 6; }

static mlr_status bad_order(mlr_diag *diag, const char *fn, mlr_euler_order order)
{
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "%s: order %d is not an mlr_euler_order", fn, (int)order);
}

mlr_status mlr_quat_from_euler_array(const double *angles, size_t count, mlr_euler_order order,
                                     mlr_quat *out, mlr_diag *diag)
{
    if (!order_is_valid(order))
        return bad_order(diag, "quat from_euler", order);
    if (count == 0)
        return MLR_OK;
    if (!angles || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "quat from_euler: angles or out is NULL");
    const unsigned char *axes = mlr_euler_axes[order];
    const double s = mlr_euler_parity[order];
    size_t n_bad = 0, first = 0;
    for (size_t n = 0; n < count; n++) {
        const double a0 = angles[3 * n], a1 = angles[3 * n + 1], a2 = angles[3 * n + 2];
        if (!(isfinite(a0) && isfinite(a1) && isfinite(a2))) {
            out[n] = mlr__quat_identity;
            first = n_bad++ ? first : n;
            continue;
        }
        common__quat_from_euler_half(cos(0.5 * a0), sin(0.5 * a0), cos(0.5 * a1), sin(0.5 * a1),
                                     cos(0.5 * a2), sin(0.5 * a2), axes, s, &out[n]);
    }
    if (n_bad)
        return quat__bad_elements(diag, "quat from_euler", "angles", "angle triples", first, n_bad,
                                  count);
    return MLR_OK;
}

mlr_status mlr_quat_to_euler_array(const mlr_quat *q, size_t count, mlr_euler_order order,
                                   double *angles, mlr_diag *diag)
{
    if (!order_is_valid(order))
        return bad_order(diag, "quat to_euler", order);
    if (count == 0)
        return MLR_OK;
    if (!q || !angles)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "quat to_euler: q or angles is NULL");
    const unsigned ia = mlr_euler_axes[order][0], ja = mlr_euler_axes[order][1],
                   ka = mlr_euler_axes[order][2];
    const double s = mlr_euler_parity[order];
    size_t n_bad = 0, first = 0;
    for (size_t n = 0; n < count; n++) {
        double *out = &angles[3 * n];
        mlr_quat p;
        if (!quat__unit(&q[n], &p)) {
            out[0] = out[1] = out[2] = 0.0;
            first = n_bad++ ? first : n;
            continue;
        }
        /* Direct from the quaternion (the method of Bernardes & Viollet 2022, as in SciPy),
         * which avoids the cancellation of the matrix entries near gimbal lock. With
         * qk' = s qk, the expansion in from_euler gives, for beta = a1/2 + pi/4,
         *   A = w + qj = sqrt2 sin(beta) cos((a0+a2')/2),  B = qi + qk' = sqrt2 sin(beta) sin(..)
         *   C = w - qj = sqrt2 cos(beta) cos((a0-a2')/2),  D = qi - qk' = sqrt2 cos(beta) sin(..)
         * where a2' = s a2. */
        const double v[3] = {p.x, p.y, p.z};
        const double qi = v[ia], qj = v[ja], qk = s * v[ka];
        const double A = p.w + qj, B = qi + qk, C = p.w - qj, D = qi - qk;
        const double P = sqrt(A * A + B * B), M = sqrt(C * C + D * D);
        /* sin(a1) = 2 (w qj + qi qk'), cos(a1) = P M (|q| = 1): a1 is accurate at the poles. */
        const double a1 = atan2(2.0 * (p.w * qj + qi * qk), P * M);
        const double half_sum = atan2(B, A), half_diff = atan2(D, C);
        double a0, a2;
        if (M <= 0.5 * GIMBAL_EPS * P) { /* a1 = +pi/2: only a0 + a2' is defined */
            a0 = 2.0 * half_sum;
            a2 = 0.0;
        } else if (P <= 0.5 * GIMBAL_EPS * M) { /* a1 = -pi/2: only a0 - a2' is defined */
            a0 = 2.0 * half_diff;
            a2 = 0.0;
        } else {
            a0 = half_sum + half_diff;
            a2 = s * (half_sum - half_diff);
        }
        out[0] = wrap_pi(a0);
        out[1] = a1;
        out[2] = wrap_pi(a2);
    }
    if (n_bad)
        return quat__bad_elements(diag, "quat to_euler", "q", "quaternions", first, n_bad, count);
    return MLR_OK;
}

mlr_status mlr_euler_order_parse(const char *name, mlr_euler_order *out, mlr_diag *diag)
{
    if (!name || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "euler order: name or out is NULL");
    int axis[3];
    for (int k = 0; k < 3; k++) {
        switch (name[k]) {
        case 'X':
        case 'x':
            axis[k] = 0;
            break;
        case 'Y':
        case 'y':
            axis[k] = 1;
            break;
        case 'Z':
        case 'z':
            axis[k] = 2;
            break;
        default: /* also stops at a NUL before the third letter */
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "euler order \"%.8s\" is not three of the letters X, Y, Z",
                                    name);
        }
    }
    if (name[3] != '\0')
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "euler order \"%.8s\" is longer than three letters", name);
    for (int o = 0; o < 6; o++) {
        if (mlr_euler_axes[o][0] == axis[0] && mlr_euler_axes[o][1] == axis[1] &&
            mlr_euler_axes[o][2] == axis[2]) {
            *out = (mlr_euler_order)o;
            return MLR_OK;
        }
    }
    /* a repeated axis ("XYX"): proper Euler orders are not used */
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "euler order \"%s\" repeats an axis (XYZ, XZY, YXZ, YZX, ZXY or ZYX)",
                            name);
}
