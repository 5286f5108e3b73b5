/* Batched quaternions: Hamilton product, scalar-first (w, x, y, z). Rotation vectors are axis
 * times the full angle. Nothing here allocates, prints or keeps state. */
#include "mlr_internal.h"

#include <math.h>

#define MLR_PI 3.14159265358979323846
#define MLR_TWO_PI 6.28318530717958647693

/* Below this, sinc and atan(r)/r use their Taylor series (error of the first dropped term is
 * below 1e-24 relative). */
#define SMALL_ARG 1e-4
/* log uses a longer series for r = |xyz| / w below this (error below 1e-19 relative). */
#define LOG_SERIES_ARG 0.05

/* Inside this band of the middle angle around +-pi/2 (in radians), to_euler reports gimbal
 * lock (third angle 0). from_euler at exactly +-pi/2 lands within ~5e-16 of the pole; forcing
 * the third angle to 0 costs at most about this much in the reproduced rotation. */
#define GIMBAL_EPS 1e-13

/* Components whose largest magnitude lies in this range are squared without over/underflow. */
#define SAFE_LO 0x1p-500
#define SAFE_HI 0x1p+500

static const mlr_quat quat_identity = {1.0, 0.0, 0.0, 0.0};

/* Intrinsic orders: axes (0 = X, 1 = Y, 2 = Z) in the order of the enum, and the sign of the
 * permutation (+1 cyclic, -1 anticyclic). */
static const unsigned char euler_axes[6][3] = {
    {0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0},
};
static const double euler_parity[6] = {1.0, -1.0, -1.0, 1.0, 1.0, -1.0};

static int quat_is_finite(const mlr_quat *q)
{
    return isfinite(q->w) && isfinite(q->x) && isfinite(q->y) && isfinite(q->z);
}

static double max4(double a, double b, double c, double d)
{
    double m = fabs(a);
    if (fabs(b) > m) m = fabs(b);
    if (fabs(c) > m) m = fabs(c);
    if (fabs(d) > m) m = fabs(d);
    return m;
}

/* Scale a finite quaternion so that its squares neither overflow nor underflow (direction is
 * unchanged). Returns 0 for the zero quaternion. */
static int quat_prescale(mlr_quat *q)
{
    double m = max4(q->w, q->x, q->y, q->z);
    if (m == 0.0)
        return 0;
    if (m < SAFE_LO || m > SAFE_HI) {
        q->w /= m;
        q->x /= m;
        q->y /= m;
        q->z /= m;
    }
    return 1;
}

/* |q| for a quaternion that went through quat_prescale. */
static double quat_norm(const mlr_quat *q)
{
    return sqrt(q->w * q->w + q->x * q->x + q->y * q->y + q->z * q->z);
}

/* Unit quaternion in the direction of q; 0 when q is zero or not finite. */
static int quat_unit(const mlr_quat *q, mlr_quat *out)
{
    mlr_quat p = *q;
    if (!quat_is_finite(&p) || !quat_prescale(&p))
        return 0;
    double n = quat_norm(&p);
    out->w = p.w / n;
    out->x = p.x / n;
    out->y = p.y / n;
    out->z = p.z / n;
    return 1;
}

/* |(x, y, z)| without spurious overflow or underflow, for finite input. */
static double norm3(double x, double y, double z)
{
    double m = max4(x, y, z, 0.0);
    if (m == 0.0)
        return 0.0;
    if (m < SAFE_LO || m > SAFE_HI) {
        x /= m;
        y /= m;
        z /= m;
        return m * sqrt(x * x + y * y + z * z);
    }
    return sqrt(x * x + y * y + z * z);
}

/* sin(x) / x, 1 at 0. */
static double sinc(double x)
{
    if (fabs(x) < SMALL_ARG) {
        double x2 = x * x;
        return 1.0 - x2 * (1.0 / 6.0) * (1.0 - x2 * (1.0 / 20.0));
    }
    return sin(x) / x;
}

/* Wrap an angle in (-2pi, 2pi] (in fact any angle within one turn of the range) to (-pi, pi]. */
static double wrap_pi(double a)
{
    if (a > MLR_PI)
        a -= MLR_TWO_PI;
    else if (a <= -MLR_PI)
        a += MLR_TWO_PI;
    return a;
}

void mlr_quat_mul(const mlr_quat *a, const mlr_quat *b, mlr_quat *out)
{
    if (!a || !b || !out)
        return;
    const double aw = a->w, ax = a->x, ay = a->y, az = a->z;
    const double bw = b->w, bx = b->x, by = b->y, bz = b->z;
    out->w = aw * bw - ax * bx - ay * by - az * bz;
    out->x = aw * bx + ax * bw + ay * bz - az * by;
    out->y = aw * by - ax * bz + ay * bw + az * bx;
    out->z = aw * bz + ax * by - ay * bx + az * bw;
}

void mlr_quat_rotate(const mlr_quat *q, const mlr_vec3 *v, mlr_vec3 *out)
{
    if (!q || !v || !out)
        return;
    /* v' = v + 2w (u x v) + 2 u x (u x v), u = (x, y, z). */
    const double w = q->w, ux = q->x, uy = q->y, uz = q->z;
    const double vx = v->x, vy = v->y, vz = v->z;
    const double tx = 2.0 * (uy * vz - uz * vy);
    const double ty = 2.0 * (uz * vx - ux * vz);
    const double tz = 2.0 * (ux * vy - uy * vx);
    out->x = vx + w * tx + (uy * tz - uz * ty);
    out->y = vy + w * ty + (uz * tx - ux * tz);
    out->z = vz + w * tz + (ux * ty - uy * tx);
}

void mlr_quat_mul_array(const mlr_quat *a, const mlr_quat *b, size_t count, mlr_quat *out)
{
    if (!a || !b || !out)
        return;
    for (size_t i = 0; i < count; i++)
        mlr_quat_mul(&a[i], &b[i], &out[i]);
}

void mlr_quat_conj_array(const mlr_quat *q, size_t count, mlr_quat *out)
{
    if (!q || !out)
        return;
    for (size_t i = 0; i < count; i++) {
        out[i].w = q[i].w;
        out[i].x = -q[i].x;
        out[i].y = -q[i].y;
        out[i].z = -q[i].z;
    }
}

mlr_status mlr_quat_normalize_array(const mlr_quat *q, size_t count, mlr_quat *out)
{
    if (count == 0)
        return MLR_OK;
    if (!q || !out)
        return MLR_E_INVALID_ARG;
    mlr_status status = MLR_OK;
    for (size_t i = 0; i < count; i++) {
        if (!quat_unit(&q[i], &out[i])) {
            out[i] = quat_identity;
            status = MLR_E_INVALID_ARG;
        }
    }
    return status;
}

mlr_status mlr_quat_exp_array(const mlr_vec3 *v, size_t count, mlr_quat *out)
{
    if (count == 0)
        return MLR_OK;
    if (!v || !out)
        return MLR_E_INVALID_ARG;
    mlr_status status = MLR_OK;
    for (size_t i = 0; i < count; i++) {
        const double x = v[i].x, y = v[i].y, z = v[i].z;
        if (!(isfinite(x) && isfinite(y) && isfinite(z))) {
            out[i] = quat_identity;
            status = MLR_E_INVALID_ARG;
            continue;
        }
        const double angle = norm3(x, y, z);
        const double half = 0.5 * angle;
        const double k = 0.5 * sinc(half); /* sin(angle / 2) / angle */
        out[i].w = cos(half);
        out[i].x = k * x;
        out[i].y = k * y;
        out[i].z = k * z;
    }
    return status;
}

mlr_status mlr_quat_log_array(const mlr_quat *q, size_t count, mlr_vec3 *out)
{
    if (count == 0)
        return MLR_OK;
    if (!q || !out)
        return MLR_E_INVALID_ARG;
    mlr_status status = MLR_OK;
    for (size_t i = 0; i < count; i++) {
        mlr_quat p = q[i];
        if (!quat_is_finite(&p) || !quat_prescale(&p)) {
            out[i].x = out[i].y = out[i].z = 0.0;
            status = MLR_E_INVALID_ARG;
            continue;
        }
        if (p.w < 0.0) { /* q and -q are the same rotation; take the angle in [0, pi] */
            p.w = -p.w;
            p.x = -p.x;
            p.y = -p.y;
            p.z = -p.z;
        }
        /* angle = 2 atan2(s, w); the vector is angle * (x, y, z) / s. The scale is invariant
         * to |q|, so a slightly unnormalized q gives the log of its normalized rotation. */
        const double s = norm3(p.x, p.y, p.z);
        double k;
        if (s < LOG_SERIES_ARG * p.w) {
            /* 2 atan(r) / (r w), Taylor in r to r^12: the first dropped term is below 1e-19
             * relative, and it spares the atan2 for the small angles that dominate motion
             * displacements (below about 5.7 degrees) */
            const double r = s / p.w, r2 = r * r;
            const double t = 1.0 / 11.0 - r2 * (1.0 / 13.0);
            const double u = 1.0 / 7.0 - r2 * (1.0 / 9.0 - r2 * t);
            k = (2.0 / p.w) * (1.0 - r2 * (1.0 / 3.0 - r2 * (1.0 / 5.0 - r2 * u)));
        } else {
            k = 2.0 * atan2(s, p.w) / s;
        }
        out[i].x = k * p.x;
        out[i].y = k * p.y;
        out[i].z = k * p.z;
    }
    return status;
}

mlr_status mlr_quat_slerp_array(const mlr_quat *a, const mlr_quat *b, const double *t,
                                size_t count, mlr_quat *out)
{
    if (count == 0)
        return MLR_OK;
    if (!a || !b || !t || !out)
        return MLR_E_INVALID_ARG;
    mlr_status status = MLR_OK;
    for (size_t i = 0; i < count; i++) {
        mlr_quat p, r;
        const double ti = t[i];
        if (!isfinite(ti) || !quat_unit(&a[i], &p) || !quat_unit(&b[i], &r)) {
            out[i] = quat_identity;
            status = MLR_E_INVALID_ARG;
            continue;
        }
        if (p.w * r.w + p.x * r.x + p.y * r.y + p.z * r.z < 0.0) { /* shorter arc */
            r.w = -r.w;
            r.x = -r.x;
            r.y = -r.y;
            r.z = -r.z;
        }
        /* theta: the angle between p and r on the 4-sphere, in [0, pi/2], accurate even when
         * p ~ r. The weights sin((1-t) theta) / sin(theta) and sin(t theta) / sin(theta) are
         * written with sinc so that they tend to the lerp weights as theta -> 0 (no 0/0). */
        const double dw = p.w - r.w, dx = p.x - r.x, dy = p.y - r.y, dz = p.z - r.z;
        const double sw = p.w + r.w, sx = p.x + r.x, sy = p.y + r.y, sz = p.z + r.z;
        const double theta = 2.0 * atan2(sqrt(dw * dw + dx * dx + dy * dy + dz * dz),
                                          sqrt(sw * sw + sx * sx + sy * sy + sz * sz));
        const double u = 1.0 - ti;
        const double sinc_theta = sinc(theta);
        const double ka = u * sinc(u * theta) / sinc_theta;
        const double kb = ti * sinc(ti * theta) / sinc_theta;
        mlr_quat m = {ka * p.w + kb * r.w, ka * p.x + kb * r.x, ka * p.y + kb * r.y,
                      ka * p.z + kb * r.z};
        if (!quat_unit(&m, &out[i])) { /* only for a non-finite t far outside [0, 1] */
            out[i] = quat_identity;
            status = MLR_E_INVALID_ARG;
        }
    }
    return status;
}

static int order_is_valid(mlr_euler_order order)
{
    return (int)order >= 0 && (int)order < 6;
}

mlr_status mlr_quat_from_euler_array(const double *angles, size_t count, mlr_euler_order order,
                                     mlr_quat *out)
{
    if (!order_is_valid(order))
        return MLR_E_INVALID_ARG;
    if (count == 0)
        return MLR_OK;
    if (!angles || !out)
        return MLR_E_INVALID_ARG;
    const unsigned ia = euler_axes[order][0], ja = euler_axes[order][1],
                   ka = euler_axes[order][2];
    const double s = euler_parity[order];
    mlr_status status = MLR_OK;
    for (size_t n = 0; n < count; n++) {
        const double a0 = angles[3 * n], a1 = angles[3 * n + 1], a2 = angles[3 * n + 2];
        if (!(isfinite(a0) && isfinite(a1) && isfinite(a2))) {
            out[n] = quat_identity;
            status = MLR_E_INVALID_ARG;
            continue;
        }
        /* q = q_i(a0) q_j(a1) q_k(a2), expanded with e_i e_j = s e_k (s the order's parity). */
        const double ca = cos(0.5 * a0), sa = sin(0.5 * a0);
        const double cb = cos(0.5 * a1), sb = sin(0.5 * a1);
        const double cc = cos(0.5 * a2), sc = sin(0.5 * a2);
        double v[3];
        const double w = ca * cb * cc - s * sa * sb * sc;
        v[ia] = sa * cb * cc + s * ca * sb * sc;
        v[ja] = ca * sb * cc - s * sa * cb * sc;
        v[ka] = ca * cb * sc + s * sa * sb * cc;
        out[n].w = w;
        out[n].x = v[0];
        out[n].y = v[1];
        out[n].z = v[2];
    }
    return status;
}

mlr_status mlr_quat_to_euler_array(const mlr_quat *q, size_t count, mlr_euler_order order,
                                   double *angles)
{
    if (!order_is_valid(order))
        return MLR_E_INVALID_ARG;
    if (count == 0)
        return MLR_OK;
    if (!q || !angles)
        return MLR_E_INVALID_ARG;
    const unsigned ia = euler_axes[order][0], ja = euler_axes[order][1],
                   ka = euler_axes[order][2];
    const double s = euler_parity[order];
    mlr_status status = MLR_OK;
    for (size_t n = 0; n < count; n++) {
        double *out = &angles[3 * n];
        mlr_quat p;
        if (!quat_unit(&q[n], &p)) {
            out[0] = out[1] = out[2] = 0.0;
            status = MLR_E_INVALID_ARG;
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
    return status;
}

void mlr_quat_make_continuous(mlr_quat *q, size_t n_frames, size_t n_tracks)
{
    if (!q || n_frames < 2 || n_tracks == 0)
        return;
    for (size_t f = 1; f < n_frames; f++) {
        const mlr_quat *prev = &q[(f - 1) * n_tracks];
        mlr_quat *cur = &q[f * n_tracks];
        for (size_t j = 0; j < n_tracks; j++) {
            const double d = prev[j].w * cur[j].w + prev[j].x * cur[j].x +
                             prev[j].y * cur[j].y + prev[j].z * cur[j].z;
            if (d < 0.0) {
                cur[j].w = -cur[j].w;
                cur[j].x = -cur[j].x;
                cur[j].y = -cur[j].y;
                cur[j].z = -cur[j].z;
            }
        }
    }
}

/* Thresholds of the predictive sign rule, as cosines of angles between unit quaternions
 * (half the rotation angles): a step below 60 degrees of rotation is always short (30 deg);
 * a step of at most 300 degrees (150 deg) may be long; the prediction must be within 90
 * degrees of rotation (45 deg), and so must the change of step (acceleration check). */
#define CONT_COS_FAST 0.86602540378443865 /* cos 30 deg */
#define CONT_COS_MAX_STEP -0.86602540378443865 /* cos 150 deg */
#define CONT_COS_PRED 0.70710678118654752 /* cos 45 deg */

static double quat_dot(const mlr_quat *a, const mlr_quat *b)
{
    return a->w * b->w + a->x * b->x + a->y * b->y + a->z * b->z;
}

static void quat_neg(const mlr_quat *q, mlr_quat *out)
{
    out->w = -q->w;
    out->x = -q->x;
    out->y = -q->y;
    out->z = -q->z;
}

/* conj(a) * b */
static void quat_conj_mul(const mlr_quat *a, const mlr_quat *b, mlr_quat *out)
{
    const mlr_quat ca = {a->w, -a->x, -a->y, -a->z};
    mlr_quat_mul(&ca, b, out);
}

void mlr_quat_continue_sign(const mlr_quat *prev, size_t n_prev, const mlr_quat *q,
                            mlr_quat *out)
{
    if (!q || !out)
        return;
    if (n_prev == 0 || !prev) {
        *out = *q;
        return;
    }
    if (n_prev > 3) {
        prev += n_prev - 3;
        n_prev = 3;
    }
    const mlr_quat *p1 = &prev[n_prev - 1];
    const double d = quat_dot(q, p1);
    const double nn = quat_dot(q, q) * quat_dot(p1, p1);
    /* nearest sign: the fallback, and the answer for any step below 60 degrees */
    mlr_quat c = *q;
    if (d < 0.0)
        quat_neg(q, &c);
    if (n_prev < 2 || d * d >= CONT_COS_FAST * CONT_COS_FAST * nn) {
        *out = c;
        return;
    }
    mlr_quat u1, u2, uc, step, pred;
    if (!quat_unit(p1, &u1) || !quat_unit(&prev[n_prev - 2], &u2) || !quat_unit(&c, &uc)) {
        *out = c;
        return;
    }
    if (quat_dot(&u1, &u2) < CONT_COS_MAX_STEP) { /* previous step above 300 degrees */
        *out = c;
        return;
    }
    quat_conj_mul(&u2, &u1, &step); /* previous step, in the frame of u2 */
    mlr_quat_mul(&u1, &step, &pred);
    /* the longer representative is -uc: it must be near the prediction */
    if (-quat_dot(&uc, &pred) < CONT_COS_PRED) {
        *out = c;
        return;
    }
    if (n_prev >= 3) {
        mlr_quat u3, step_before;
        if (!quat_unit(&prev[0], &u3)) {
            *out = c;
            return;
        }
        quat_conj_mul(&u3, &u2, &step_before);
        if (quat_dot(&step, &step_before) < CONT_COS_PRED) {
            *out = c;
            return;
        }
    }
    quat_neg(&c, out);
}

void mlr_quat_continue_frame(mlr_quat *q, size_t f, size_t n_tracks)
{
    const size_t n_prev = f < 3 ? f : 3;
    mlr_quat *cur = &q[f * n_tracks];
    for (size_t j = 0; j < n_tracks; j++) {
        mlr_quat hist[3];
        for (size_t k = 0; k < n_prev; k++) /* oldest first */
            hist[k] = q[(f - n_prev + k) * n_tracks + j];
        mlr_quat_continue_sign(hist, n_prev, &cur[j], &cur[j]);
    }
}

void mlr_quat_make_continuous_predictive(mlr_quat *q, size_t n_frames, size_t n_tracks)
{
    if (!q || n_frames < 2 || n_tracks == 0)
        return;
    for (size_t f = 1; f < n_frames; f++)
        mlr_quat_continue_frame(q, f, n_tracks);
}

mlr_status mlr_euler_order_parse(const char *name, mlr_euler_order *out)
{
    if (!name || !out)
        return MLR_E_INVALID_ARG;
    int axis[3];
    for (int k = 0; k < 3; k++) {
        switch (name[k]) {
        case 'X': case 'x': axis[k] = 0; break;
        case 'Y': case 'y': axis[k] = 1; break;
        case 'Z': case 'z': axis[k] = 2; break;
        default: return MLR_E_INVALID_ARG; /* also stops at a NUL before the third letter */
        }
    }
    if (name[3] != '\0')
        return MLR_E_INVALID_ARG;
    for (int o = 0; o < 6; o++) {
        if (euler_axes[o][0] == axis[0] && euler_axes[o][1] == axis[1] &&
            euler_axes[o][2] == axis[2]) {
            *out = (mlr_euler_order)o;
            return MLR_OK;
        }
    }
    return MLR_E_INVALID_ARG; /* a repeated axis ("XYX"): proper Euler orders are not used */
}
