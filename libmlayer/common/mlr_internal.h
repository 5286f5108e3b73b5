/* Private helpers shared by the C core. Not installed. */
#ifndef MLR_INTERNAL_H
#define MLR_INTERNAL_H

#include <float.h>
#include <math.h>
#include <mlayer/mlayer.h>
#include <stdint.h>
#include <string.h>

#define MLR_COUNTOF(a) (sizeof(a) / sizeof((a)[0]))

/* CPU dispatch (MLR_CLONES, cpu__isa, MLR_X86_DISPATCH) and its promise: common/cpu.h. */
#include "common/cpu.h"

/* Allocation through a (possibly NULL) allocator. common__alloc returns NULL on failure or when
 * size is 0 is not requested; callers never ask for 0 bytes. */
void common__allocator_resolve(const mlr_allocator *in, mlr_allocator *out);
void *common__alloc(const mlr_allocator *a, size_t size);
void common__free(const mlr_allocator *a, void *ptr, size_t size);

/* *out = a * b, MLR_E_OVERFLOW when it does not fit a size_t. */
static inline mlr_status common__mul_size(size_t a, size_t b, size_t *out)
{
    if (b != 0 && a > SIZE_MAX / b)
        return MLR_E_OVERFLOW;
    *out = a * b;
    return MLR_OK;
}

/* Fill diag (if not NULL) with a formatted message; returns status for tail calls. */
mlr_status common__diag_set(mlr_diag *diag, mlr_status status, size_t line, size_t column,
                            const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

/* Put "who: " before the message a callee left in diag (if any, and unless it starts so
 * already); returns status. For a failure of a nested call to name the public function. */
mlr_status common__diag_prefix(mlr_diag *diag, mlr_status status, const char *who);

/* fmax / fmin inline (the libm calls are not: 5 instructions and a call each, ~100,000 calls
   per guards apply in the cleanup): the same values, the ordered comparison returning the
   second argument when equal (as x86-64's maxsd / minsd in glibc's fmax / fmin) and the other
   argument when one is NaN. */
/* Small helpers every caller must get inlined (the vectorized loops, and the inliner's size
 * estimates of their callers, which an extra call level would change). */
#if defined(__GNUC__)
#define MLR_ALWAYS_INLINE __attribute__((always_inline))
#else
#define MLR_ALWAYS_INLINE
#endif

/* A quaternion whose computed |q|^2 lies within this of 1 is as unit as dividing by its norm
 * makes it (|q| within 2 DBL_EPSILON of 1): the library's normalizations leave it as it is
 * (quat__unit_array, ik__rotate_to_1). */
#define MLR_NEAR_UNIT2 (4.0 * DBL_EPSILON)

/* |q|^2 of q = (w, x, y, z), summed in the one order every near-unit test takes. */
MLR_ALWAYS_INLINE static inline double ik__quat_norm2_wxyz(double w, double x, double y, double z)
{
    return w * w + x * x + y * y + z * z;
}

/* The near-unit test on a squared norm n2 (ik__quat_norm2_wxyz): |q|^2 within MLR_NEAR_UNIT2
 * of 1; NaN is not. */
MLR_ALWAYS_INLINE static inline int ik__near_unit2(double n2)
{
    return fabs(n2 - 1.0) <= MLR_NEAR_UNIT2;
}

static inline double common__fmax(double a, double b) { return a > b || b != b ? a : b; }
static inline double common__fmin(double a, double b) { return a < b || b != b ? a : b; }

/* The quaternion product (aw, ax, ay, az) (bw, bx, by, bz), the library's one spelling of it:
 * every other form (common__quat_mul_inline, ik__qmul4, the structure-of-arrays loops) calls this
 * one. The library builds with -ffp-contract=off, so every caller gets the same bits. Scalars in
 * and out, so that loops over structure-of-arrays copies vectorize. */
MLR_ALWAYS_INLINE static inline mlr_quat common__qmul_wxyz(double aw, double ax, double ay,
                                                           double az, double bw, double bx,
                                                           double by, double bz)
{
    mlr_quat o;
    o.w = aw * bw - ax * bx - ay * by - az * bz;
    o.x = aw * bx + ax * bw + ay * bz - az * by;
    o.y = aw * by - ax * bz + ay * bw + az * bx;
    o.z = aw * bz + ax * by - ay * bx + az * bw;
    return o;
}

/* The quaternion product and rotation, inlined into loops (mlr_quat_mul and mlr_quat_rotate
 * are these). out may alias a or b; o must not alias v. */
static inline void common__quat_mul_inline(const mlr_quat *a, const mlr_quat *b, mlr_quat *out)
{
    const mlr_quat r = common__qmul_wxyz(a->w, a->x, a->y, a->z, b->w, b->x, b->y, b->z);
    out->w = r.w, out->x = r.x, out->y = r.y, out->z = r.z;
}

/* o = a b, quaternions as (w, x, y, z) arrays; o may alias a or b. */
static inline void ik__qmul4(const double *a, const double *b, double *o)
{
    const mlr_quat r = common__qmul_wxyz(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]);
    o[0] = r.w, o[1] = r.x, o[2] = r.y, o[3] = r.z;
}

/* a . b for 3 doubles. */
static inline double common__dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* o = a x b for 3 doubles; o may alias a or b. */
static inline void common__cross3(const double *a, const double *b, double *o)
{
    const double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2],
                 z = a[0] * b[1] - a[1] * b[0];
    o[0] = x, o[1] = y, o[2] = z;
}

/* c ? a : b by bit masks, so that the compiler keeps both operands computed unconditionally
 * (GCC otherwise moves a division under a branch, which stops the vectorizer). */
static inline double common__select_bits(int c, double a, double b)
{
    const uint64_t mask = (uint64_t)0 - (uint64_t)(c != 0);
    uint64_t ab, bb;
    memcpy(&ab, &a, sizeof ab);
    memcpy(&bb, &b, sizeof bb);
    const uint64_t r = (ab & mask) | (bb & ~mask);
    double out;
    memcpy(&out, &r, sizeof out);
    return out;
}

/* v' = v + 2w (u x v) + 2 u x (u x v), u = (x, y, z); v and o are 3 doubles. */
static inline void common__quat_rotate_inline(const mlr_quat *q, const double *v, double *o)
{
    const double w = q->w, ux = q->x, uy = q->y, uz = q->z;
    const double vx = v[0], vy = v[1], vz = v[2];
    const double tx = 2.0 * (uy * vz - uz * vy);
    const double ty = 2.0 * (uz * vx - ux * vz);
    const double tz = 2.0 * (ux * vy - uy * vx);
    o[0] = vx + w * tx + (uy * tz - uz * ty);
    o[1] = vy + w * ty + (uz * tx - ux * tz);
    o[2] = vz + w * tz + (ux * ty - uy * tx);
}

/* One joint of forward kinematics: the world rotation wr_j = wr_p q and the world position
 * wp_j = wp_p + wr_p t of a joint with local rotation q and translation t (its OFFSET or its
 * position channels) below a parent at (wp_p, wr_p). Outputs must not alias the parent's. */
static inline void common__fk_joint_inline(const mlr_quat *wr_p, const double *wp_p,
                                           const mlr_quat *q, const double *t, mlr_quat *wr_j,
                                           double *wp_j)
{
    common__quat_mul_inline(wr_p, q, wr_j);
    double o[3];
    common__quat_rotate_inline(wr_p, t, o);
    wp_j[0] = wp_p[0] + o[0];
    wp_j[1] = wp_p[1] + o[1];
    wp_j[2] = wp_p[2] + o[2];
}

/* Predictive sign continuity of row f of q (n_frames x n_tracks) given rows f-3 .. f-1 (those
 * that exist) already made continuous: mlr_quat_continue_sign per track (quat_continuity.c). */
void common__quat_continue_frame(mlr_quat *q, size_t f, size_t n_tracks);

/* prod[k] = conj(a[k]) b[k] (conj_b 0) or a[k] conj(b[k]) (conj_b 1) and out[k] = log(prod[k])
 * as mlr_quat_log_array (zero for a zero or non-finite product) for k < count, in one
 * vectorized pass (quat.c). prod may alias a or b. */
void common__quat_conj_mul_log(const mlr_quat *a, const mlr_quat *b, size_t count, int conj_b,
                               mlr_quat *prod, mlr_vec3 *out);

/* Intrinsic Euler orders (euler.c): axes (0 = X, 1 = Y, 2 = Z) in the order of mlr_euler_order,
 * and the sign of each permutation (+1 cyclic, -1 anticyclic). */
extern const unsigned char mlr_euler_axes[6][3];
extern const double mlr_euler_parity[6];

/* q = q_i(a0) q_j(a1) q_k(a2) from the cosines and sines of the half-angles, for the order with
 * axes (i, j, k) and parity par, expanded with e_i e_j = par e_k. */
static inline void common__quat_from_euler_half(double ca, double sa, double cb, double sb,
                                                double cc, double sc, const unsigned char axes[3],
                                                double par, mlr_quat *out)
{
    double v[3];
    out->w = ca * cb * cc - par * sa * sb * sc;
    v[axes[0]] = sa * cb * cc + par * ca * sb * sc;
    v[axes[1]] = ca * sb * cc - par * sa * cb * sc;
    v[axes[2]] = ca * cb * sc + par * sa * sb * cc;
    out->x = v[0];
    out->y = v[1];
    out->z = v[2];
}

/* Whether name (NULL allowed) contains one of the patterns (lower-case ASCII, a NULL-terminated
 * list), ASCII case-insensitively and with the non-ASCII letters Python's re.IGNORECASE folds to
 * i, s and k (rig.c). */
int common__name_matches(const char *name, const char *const *patterns);

/* rig.c: the lowest and the highest coordinate along up of the n_joints positions of each
   frame into lo and hi (n_frames each; either may be NULL); the index f n_joints + j of the
   first value not finite (its frame's lo and hi are then undefined), or n_frames n_joints. */
size_t common__rig_up_range(size_t n_frames, size_t n_joints, const double *world_pos, int up,
                            double *lo, double *hi);

/* values.c: numpy's median of n >= 1 finite values, in O(n) on average (reorders v); the
   selection behind it: v[0..n) (n >= 1, finite) reordered so that v[k] is the value a sort
   would put there, those before it no larger, those after no smaller; the index of the first
   NaN or infinite value of x[0..n), or n. */
double common__median(double *v, size_t n);
void common__select_kth(double *v, size_t n, size_t k);
size_t common__first_nonfinite(const double *x, size_t n);

#endif
