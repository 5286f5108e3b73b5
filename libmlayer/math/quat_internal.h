/* Private helpers shared by the quaternion files: quat.c (algebra, exp/log/slerp arrays),
 * euler.c (Euler orders) and quat_continuity.c (sign continuity). Not installed. The scalar
 * helpers are inline so that every file's loops get the same code as before the split. */
#ifndef MLR_QUAT_INTERNAL_H
#define MLR_QUAT_INTERNAL_H

#include "common/mlr_internal.h"

#include <math.h>

/* Components whose largest magnitude lies in this range are squared without over/underflow. */
#define SAFE_LO 0x1p-500
#define SAFE_HI 0x1p+500

static const mlr_quat mlr__quat_identity = {1.0, 0.0, 0.0, 0.0};

static inline int quat__is_finite(const mlr_quat *q)
{
    return isfinite(q->w) && isfinite(q->x) && isfinite(q->y) && isfinite(q->z);
}

static inline double quat__max4_abs(double a, double b, double c, double d)
{
    double m = fabs(a);
    if (fabs(b) > m)
        m = fabs(b);
    if (fabs(c) > m)
        m = fabs(c);
    if (fabs(d) > m)
        m = fabs(d);
    return m;
}

/* Scale a finite quaternion so that its squares neither overflow nor underflow (direction is
 * unchanged). Returns 0 for the zero quaternion. */
static inline int quat__prescale(mlr_quat *q)
{
    double m = quat__max4_abs(q->w, q->x, q->y, q->z);
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

/* |q| for a quaternion that went through quat__prescale. */
static inline double quat__norm(const mlr_quat *q)
{
    return sqrt(q->w * q->w + q->x * q->x + q->y * q->y + q->z * q->z);
}

/* Unit quaternion in the direction of q; 0 when q is zero or not finite. */
static inline int quat__unit(const mlr_quat *q, mlr_quat *out)
{
    mlr_quat p = *q;
    if (!quat__is_finite(&p) || !quat__prescale(&p))
        return 0;
    double n = quat__norm(&p);
    out->w = p.w / n;
    out->x = p.x / n;
    out->y = p.y / n;
    out->z = p.z / n;
    return 1;
}

/* The rotation vector (axis times angle, angle in [0, pi]) of unit quaternion q. */
static inline void quat__rotvec(const double *q, double *v)
{
    const double sg = q[0] < 0 ? -1.0 : 1.0;
    const double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const double k = s > 1e-300 ? 2.0 * atan2(s, sg * q[0]) / s : 2.0;
    v[0] = sg * k * q[1], v[1] = sg * k * q[2], v[2] = sg * k * q[3];
}

/* The exaggerated displacement a v (v a rotation vector of angle at most pi, |a| > 1 the
 * exaggeration) with its angle saturated below a half turn: past pi, exp(a v) turns back the
 * other way (a thigh's 89 degree kick at alpha 3 is a rotation of 267 degrees, which is one of
 * -93), so the limits found the exaggerated joint on the far side of its range and snapped it
 * from one bound to the other (CMU 60_10's thigh turned 180 degrees in a frame). The angle
 * x = |a v| is kept up to TURN_KNEE, above it TURN_KNEE + (TURN_MAX - TURN_KNEE)
 * tanh((x - TURN_KNEE) / (TURN_MAX - TURN_KNEE)) (smooth, increasing, below TURN_MAX), and
 * never below v's own angle (alpha 1's). |a| <= 1 and angles up to the knee: a v as it is,
 * to the bit. */
#define QUAT_TURN_KNEE (0.5 * 3.14159265358979323846)
#define QUAT_TURN_MAX (0.9 * 3.14159265358979323846)
static inline mlr_vec3 quat__scale_turn(mlr_vec3 v, double a)
{
    mlr_vec3 w = {a * v.x, a * v.y, a * v.z};
    const double x2 = w.x * w.x + w.y * w.y + w.z * w.z;
    if (!(fabs(a) > 1.0) || !(x2 > QUAT_TURN_KNEE * QUAT_TURN_KNEE) || !isfinite(x2))
        return w;
    const double x = sqrt(x2), own = x / fabs(a), span = QUAT_TURN_MAX - QUAT_TURN_KNEE;
    const double s = fmax(own, QUAT_TURN_KNEE + span * tanh((x - QUAT_TURN_KNEE) / span)) / x;
    w.x *= s, w.y *= s, w.z *= s;
    return w;
}

/* The unit quaternion of rotation vector v. */
static inline void quat__rotvec_quat(const double *v, double *q)
{
    const double a = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double k = a > 1e-300 ? sin(0.5 * a) / a : 0.5;
    q[0] = cos(0.5 * a), q[1] = k * v[0], q[2] = k * v[1], q[3] = k * v[2];
}

/* o = q v q* for unit quaternion q (w, x, y, z) and vector v (o may not alias v). */
static inline void quat__rotate3(const double *q, const double *v, double *o)
{
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    const double tx = 2.0 * (y * v[2] - z * v[1]), ty = 2.0 * (z * v[0] - x * v[2]),
                 tz = 2.0 * (x * v[1] - y * v[0]);
    o[0] = v[0] + w * tx + (y * tz - z * ty);
    o[1] = v[1] + w * ty + (z * tx - x * tz);
    o[2] = v[2] + w * tz + (x * ty - y * tx);
}

/* The unit quaternions of q into out (which may be q): those already unit to rounding (|q|^2
 * within 4 DBL_EPSILON of 1) copied bit for bit, the others divided by their norm (as
 * mlr_quat_normalize_array); the identity for a zero or non-finite one, and then
 * MLR_E_INVALID_ARG. Cheaper than normalizing: most rotations a motion holds are unit to
 * rounding already. */
mlr_status quat__unit_array(const mlr_quat *q, size_t count, mlr_quat *out);
/* The same with the hand-written kernel limited to the ISA level most (MLR_ISA_*, common/cpu.h):
 * the same bits at every level (tests/test_twins.c). */
mlr_status quat__unit_array_isa(const mlr_quat *q, size_t count, mlr_quat *out, int most);

/* The diag of an array function that met n_bad bad elements of arg, the first at index first:
 * "quat log: q: 1 of 40 quaternions zero, NaN or infinite, the first at index 7" (quat.c). */
mlr_status quat__bad_elements(mlr_diag *diag, const char *fn, const char *arg, const char *what,
                              size_t first, size_t n_bad, size_t count);

#endif
