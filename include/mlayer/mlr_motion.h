/*
 * The motion object: a skeleton and N frames (the data model is at the top of mlr_bvh.h,
 * whose readers create most motions), built from arrays, copied, and read through accessors.
 *
 * Every function is thread-safe on separate handles; a handle may be read from several
 * threads at once while nobody modifies it.
 */
#ifndef MLR_MOTION_H
#define MLR_MOTION_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_quat.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A skeleton and its frames. Opaque; created by the readers or mlr_motion_create. */
typedef struct mlr_motion mlr_motion;

/** Channel kinds, as named on a CHANNELS line. Values pinned. */
typedef enum mlr_bvh_channel {
    MLR_BVH_XPOSITION = 0,
    MLR_BVH_YPOSITION = 1,
    MLR_BVH_ZPOSITION = 2,
    MLR_BVH_XROTATION = 3,
    MLR_BVH_YROTATION = 4,
    MLR_BVH_ZROTATION = 5
} mlr_bvh_channel;

/* ---------------------------------------------------------------------------------------- */
/* Building a motion from arrays                                                            */

/**
 * Create a motion from a skeleton; its frames start as the rest pose (identity rotations,
 * root_pos and trans equal to the OFFSETs). Fill them through mlr_motion_root_pos_mut,
 * mlr_motion_rot_mut and mlr_motion_trans_mut.
 * @param n_joints    [in] J >= 1
 * @param names       [in] J NUL-terminated names: not empty, no control characters except
 *                    tabs, no braces, no leading or trailing blanks; copied
 * @param parents     [in] J parent indices: parents[0] == -1, and the joints in depth-first
 *                    order (each parents[j] is j-1 or one of j-1's ancestors)
 * @param offsets     [in] J x 3 OFFSETs, finite
 * @param channels    [in] J channel lists as on a CHANNELS line without the count, e.g.
 *                    "Xposition Yposition Zposition Zrotation Xrotation Yrotation" (any case,
 *                    any order, each kind at most once; "" for none); or NULL for the common
 *                    layout: the root "Xposition Yposition Zposition Zrotation Yrotation
 *                    Xrotation", the others "Zrotation Yrotation Xrotation"
 * @param n_end_sites [in] number of End Sites E
 * @param end_parents [in] E joint indices, non-decreasing (an End Site is written right
 *                    after its joint's CHANNELS line)
 * @param end_offsets [in] E x 3 End Site OFFSETs, finite
 * @param n_frames    [in] N (0 allowed)
 * @param frame_time  [in] seconds per frame, finite and > 0
 * @param alloc       [in] allocator, copied; NULL for malloc/free
 * @param out         [out] new motion, or NULL on failure
 * @param diag        [out] optional: which argument is wrong, on MLR_E_INVALID_ARG (line 0)
 * @return MLR_OK; MLR_E_INVALID_ARG; MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: yes. Threads: any.
 */
MLR_API mlr_status mlr_motion_create(size_t n_joints, const char *const *names,
                                     const int32_t *parents, const double *offsets,
                                     const char *const *channels, size_t n_end_sites,
                                     const int32_t *end_parents, const double *end_offsets,
                                     size_t n_frames, double frame_time,
                                     const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag);

/**
 * Deep copy of frames [begin, begin + count) of a motion (the skeleton is copied whole).
 * @param diag [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (out of range, NULL); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: yes, with the allocator of src. Threads: src is only read.
 */
MLR_API mlr_status mlr_motion_copy_frames(const mlr_motion *src, size_t begin, size_t count,
                                          mlr_motion **out, mlr_diag *diag);

/** Release a motion. NULL is a no-op. */
MLR_API void mlr_motion_destroy(mlr_motion *motion);

/* ---------------------------------------------------------------------------------------- */
/* Accessors. None allocates or fails; out-of-range indices give 0, NULL or -1 as stated.    */
/* Returned pointers live as long as the motion.                                            */

MLR_API size_t mlr_motion_n_joints(const mlr_motion *motion);
MLR_API size_t mlr_motion_n_frames(const mlr_motion *motion);
/** Total number of channels (values per frame line). */
MLR_API size_t mlr_motion_n_channels(const mlr_motion *motion);
/** Seconds per frame ("Frame Time:"). */
MLR_API double mlr_motion_frame_time(const mlr_motion *motion);
/** Set the frame time. @return MLR_OK; MLR_E_INVALID_ARG (not finite or <= 0) */
MLR_API mlr_status mlr_motion_set_frame_time(mlr_motion *motion, double frame_time);

/** Name of joint j, NUL-terminated; NULL when j >= J. */
MLR_API const char *mlr_motion_joint_name(const mlr_motion *motion, size_t j);
/** J parent indices, -1 for the root. */
MLR_API const int32_t *mlr_motion_parents(const mlr_motion *motion);
/** J x 3 OFFSETs. */
MLR_API const double *mlr_motion_offsets(const mlr_motion *motion);

/** Number of channels of joint j (0..6; 0 when j >= J). */
MLR_API size_t mlr_motion_joint_n_channels(const mlr_motion *motion, size_t j);
/** Channel j's kinds in file order into codes (room for 6); returns their number. */
MLR_API size_t mlr_motion_joint_channel_codes(const mlr_motion *motion, size_t j,
                                              unsigned char *codes);
/** Channel list of joint j as on a CHANNELS line without the count, "" for none, NULL when
 *  j >= J. */
MLR_API const char *mlr_motion_joint_channels(const mlr_motion *motion, size_t j);
/** 1 when joint j has at least one position channel, else 0. */
MLR_API int mlr_motion_joint_has_position(const mlr_motion *motion, size_t j);
/** Euler order of joint j's rotation channels (completed as described at the top). */
MLR_API mlr_euler_order mlr_motion_joint_euler_order(const mlr_motion *motion, size_t j);

/** All J joint names at once: each followed by a NUL, in joint order, into buf when cap is at
 *  least the size returned (nothing is written otherwise; buf may then be NULL).
 *  @return the bytes the names take with their NULs (0 for NULL) */
MLR_API size_t mlr_motion_joint_names_packed(const mlr_motion *motion, char *buf, size_t cap);
/** All J channel lists at once (as mlr_motion_joint_channels), as mlr_motion_joint_names_packed
 *  does for the names. */
MLR_API size_t mlr_motion_joint_channels_packed(const mlr_motion *motion, char *buf, size_t cap);
/** The J Euler orders (as mlr_motion_joint_euler_order) into out (room for J).
 *  @return J (0 for NULL) */
MLR_API size_t mlr_motion_joint_euler_orders(const mlr_motion *motion, int32_t *out);

/** End Sites: E, their parent joints (sorted) and E x 3 OFFSETs. */
MLR_API size_t mlr_motion_n_end_sites(const mlr_motion *motion);
MLR_API const int32_t *mlr_motion_end_site_parents(const mlr_motion *motion);
MLR_API const double *mlr_motion_end_site_offsets(const mlr_motion *motion);

/** Root translation, N x 3 (NULL when N == 0). The _mut form allows changing the values. */
MLR_API const double *mlr_motion_root_pos(const mlr_motion *motion);
MLR_API double *mlr_motion_root_pos_mut(mlr_motion *motion);
/** Local rotations, N x J x 4 scalar-first quaternions (NULL when N == 0). */
MLR_API const double *mlr_motion_rot(const mlr_motion *motion);
MLR_API double *mlr_motion_rot_mut(mlr_motion *motion);
/** P, the number of non-root joints with position channels, and those joints (increasing). */
MLR_API size_t mlr_motion_n_trans(const mlr_motion *motion);
MLR_API const int32_t *mlr_motion_trans_joints(const mlr_motion *motion);
/** Their local translations, N x P x 3 (NULL when N == 0 or P == 0). */
MLR_API const double *mlr_motion_trans(const mlr_motion *motion);
MLR_API double *mlr_motion_trans_mut(mlr_motion *motion);

#ifdef __cplusplus
}
#endif

#endif /* MLR_MOTION_H */
