/*
 * Quaternions, batched. Stored scalar-first (w, x, y, z), Hamilton product. Rotation vectors
 * are axis times the full rotation angle (as scipy's Rotation.as_rotvec).
 * Every array function takes count elements; out may alias an input of the same shape.
 * None of them allocates; all are thread-safe on separate data.
 * Status-returning functions accept NULL pointers when count is 0 (MLR_OK) and return
 * MLR_E_INVALID_ARG for a NULL pointer otherwise. A bad element does not stop the batch: its
 * output is set as documented (identity quaternion, zero vector or zero angles), the other
 * elements are still computed, and the call returns MLR_E_INVALID_ARG.
 * The void functions do nothing when given a NULL pointer.
 */
#ifndef MLR_QUAT_H
#define MLR_QUAT_H

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A quaternion, scalar first: w + x i + y j + z k. Rotations are unit quaternions; arrays of
 *  them are N x 4 row-major doubles in this order (scipy's Rotation is scalar-last). */
typedef struct mlr_quat {
    double w, x, y, z;
} mlr_quat;
/** A 3-vector (a position, an offset, a rotation vector: axis times the full angle). */
typedef struct mlr_vec3 {
    double x, y, z;
} mlr_vec3;

/** Intrinsic Euler orders as BVH channel lines name them: "Zrotation Xrotation Yrotation" is
 *  MLR_EULER_ZXY and means R = Rz(a0) Rx(a1) Ry(a2). Values pinned. */
typedef enum mlr_euler_order {
    MLR_EULER_XYZ = 0,
    MLR_EULER_XZY = 1,
    MLR_EULER_YXZ = 2,
    MLR_EULER_YZX = 3,
    MLR_EULER_ZXY = 4,
    MLR_EULER_ZYX = 5
} mlr_euler_order;

/** Single-quaternion helpers (cannot fail). out may alias a or b. */
MLR_API void mlr_quat_mul(const mlr_quat *a, const mlr_quat *b, mlr_quat *out);
/** Rotate vector v by unit quaternion q. out may alias v. */
MLR_API void mlr_quat_rotate(const mlr_quat *q, const mlr_vec3 *v, mlr_vec3 *out);

/** out[i] = a[i] * b[i]. */
MLR_API void mlr_quat_mul_array(const mlr_quat *a, const mlr_quat *b, size_t count, mlr_quat *out);
/** out[i] = conj(q[i]). */
MLR_API void mlr_quat_conj_array(const mlr_quat *q, size_t count, mlr_quat *out);
/*
 * The array functions below take an optional diag last: on MLR_E_INVALID_ARG it names the
 * argument, how many elements were bad and the first of them ("quat log: q: 1 of 40
 * quaternions zero, NaN or infinite, the first at index 7"). Allocates: never. Threads: any, on separate data.
 */
/**
 * out[i] = q[i] / |q[i]|.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arrays with count > 0; a zero or non-finite
 *         quaternion: out[i] for that i is set to the identity and the others are still
 *         normalized)
 */
MLR_API mlr_status mlr_quat_normalize_array(const mlr_quat *q, size_t count, mlr_quat *out,
                                            mlr_diag *diag);
/** out[i] = exp(v[i]): the rotation by |v| about v/|v|, accurate near 0.
 *  @return MLR_OK; MLR_E_INVALID_ARG (non-finite input: that out[i] is the identity) */
MLR_API mlr_status mlr_quat_exp_array(const mlr_vec3 *v, size_t count, mlr_quat *out,
                                      mlr_diag *diag);
/** out[i] = log(q[i]) as a full-angle rotation vector of the unit quaternion q[i] (its angle
 *  taken in [0, pi], so q and -q give the same vector). Accurate near 0 and near pi. The result
 *  does not depend on |q[i]|: an unnormalized q gives the log of its rotation.
 *  @return MLR_OK; MLR_E_INVALID_ARG (non-finite or zero input: that out[i] is zero) */
MLR_API mlr_status mlr_quat_log_array(const mlr_quat *q, size_t count, mlr_vec3 *out,
                                      mlr_diag *diag);
/** out[i] = slerp(a[i], b[i], t[i]) along the shorter arc, unit-norm output. a and b are
 *  normalized first; t outside [0, 1] extrapolates. Exact limit as a -> b (no 0/0), and a ~ -b
 *  is the same rotation as b, so it is handled like a ~ b.
 *  @return MLR_OK; MLR_E_INVALID_ARG (non-finite input, or a zero a or b: that out[i] is the
 *          identity) */
MLR_API mlr_status mlr_quat_slerp_array(const mlr_quat *a, const mlr_quat *b, const double *t,
                                        size_t count, mlr_quat *out, mlr_diag *diag);
/**
 * From intrinsic Euler angles in radians, angles[3*i + k] about the k-th axis of order.
 * Any finite angles are accepted (no range restriction).
 * @return MLR_OK; MLR_E_INVALID_ARG (bad order: nothing written; non-finite angle: that out[i]
 *         is the identity)
 */
MLR_API mlr_status mlr_quat_from_euler_array(const double *angles, size_t count,
                                             mlr_euler_order order, mlr_quat *out, mlr_diag *diag);
/** To intrinsic Euler angles in radians; the middle angle in [-pi/2, pi/2], the others in
 *  (-pi, pi]. At gimbal lock (middle angle within 1e-13 of +-pi/2) the third angle is 0 and the
 *  first carries the whole rotation about the locked axis. q need not be normalized; q and -q
 *  give the same angles (up to the +-pi ends of the ranges).
 *  @return MLR_OK; MLR_E_INVALID_ARG (bad order: nothing written; zero or non-finite q: those
 *          three angles are 0) */
MLR_API mlr_status mlr_quat_to_euler_array(const mlr_quat *q, size_t count, mlr_euler_order order,
                                           double *angles, mlr_diag *diag);
/**
 * Sign continuity in place along a sequence: q is n_frames x n_tracks (row-major), and each
 * track is flipped (q -> -q) where needed so that consecutive samples have a non-negative dot
 * product. The rotations are unchanged.
 */
MLR_API void mlr_quat_make_continuous(mlr_quat *q, size_t n_frames, size_t n_tracks);

/**
 * Predictive sign continuity for one sample (for streaming filters and sparse keys): returns in
 * out the representative, q or -q, that continues the track whose previously chosen samples
 * are prev[0 .. n_prev-1] (oldest first; only the last three are used).
 *
 * The nearest-sign rule (out . prev[n_prev-1] >= 0) limits a step between samples to 180
 * degrees of rotation. Here the angular velocity of the previous step is extrapolated
 * (second-order prediction p = p1 conj(p2) p1, p1 and p2 the last two samples) and the sign
 * closer to p is taken, so a spin whose steps grow smoothly past 180 degrees keeps its true
 * direction. The longer representative (a step of 180 to 300 degrees) is taken only when all
 * of these hold, otherwise the nearest sign is the fallback:
 * - n_prev >= 2, and the previous step is at most 300 degrees;
 * - the prediction misses the longer representative by less than 90 degrees of rotation;
 * - the new step is at most 300 degrees (beyond that the chordal LGS cannot follow it);
 * - with n_prev >= 3: the step changed by less than 90 degrees since the step before (a bounded
 *   angular acceleration), so an isolated glitch of about 180 degrees (one sample flipped, then
 *   back) is not taken for a spin and does not flip the rest of the track.
 * Steps below 60 degrees always take the nearest sign (dense data never pays for prediction).
 * What cannot be told apart: a spin that is already above 180 degrees per step at the very
 * first samples is indistinguishable from a spin below 180 degrees the other way (both give
 * the same rotations), and is read as the latter; a step of exactly 360 degrees looks like no
 * motion. With n_prev == 2 the acceleration check is skipped (pass three samples if possible).
 * The chordal LGS interpolates the chosen representatives along the long arc correctly only
 * while a step stays below 360 degrees.
 * @param prev    [in] n_prev chosen samples, oldest first (unit or not; only directions
 *                matter); may be NULL when n_prev == 0
 * @param n_prev  [in] number of previous samples (0 or 1: nearest sign, or q itself for 0)
 * @param q       [in] the new sample
 * @param out     [out] q or -q (exactly, no renormalization); may alias q
 * Cannot fail: non-finite or zero inputs fall back to the nearest sign (or q as is). Does nothing
 * when q or out is NULL. Allocates: never. Threads: any.
 */
MLR_API void mlr_quat_continue_sign(const mlr_quat *prev, size_t n_prev, const mlr_quat *q,
                                    mlr_quat *out);

/**
 * Predictive sign continuity in place along a sequence: q is n_frames x n_tracks (row-major);
 * every sample of each track is replaced by the representative mlr_quat_continue_sign picks
 * given the (up to three) samples before it. The rotations are unchanged. On dense data this
 * equals mlr_quat_make_continuous; it differs only where steps exceed 60 degrees.
 * Allocates: never. Threads: any, on separate data.
 */
MLR_API void mlr_quat_make_continuous_predictive(mlr_quat *q, size_t n_frames, size_t n_tracks);

/** Parse "XYZ".."ZYX" (case-insensitive) into an order.
 *  @return MLR_OK; MLR_E_INVALID_ARG (NULL, not three letters of X, Y and Z, a repeated axis;
 *          diag, optional, says which) */
MLR_API mlr_status mlr_euler_order_parse(const char *name, mlr_euler_order *out, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_QUAT_H */
