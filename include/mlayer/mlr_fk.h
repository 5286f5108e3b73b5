/*
 * Forward kinematics, batched over frames: world positions (and rotations) of every joint.
 *
 * For joint j with parent p at one frame:
 *   world_rot[j] = world_rot[p] * rot[j]
 *   world_pos[j] = world_pos[p] + rotate(world_rot[p], t[j])
 * where t[j] is the joint's local translation: root_pos for the root, the row of trans for a
 * joint listed in trans_joints, its OFFSET otherwise. The root has world_rot = rot[0] and
 * world_pos = root_pos. End Sites are not part of the output.
 * Quaternions are scalar-first (w, x, y, z) and expected to be unit; they are not renormalized.
 */
#ifndef MLR_FK_H
#define MLR_FK_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_bvh.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Forward kinematics from plain arrays (no motion handle needed).
 * @param n_frames     [in] N
 * @param n_joints     [in] J >= 1
 * @param parents      [in] J indices: parents[0] == -1, 0 <= parents[j] < j for j >= 1
 * @param offsets      [in] J x 3 local translations used where nothing overrides them
 * @param root_pos     [in] N x 3 root translations, or NULL to use offsets[0] in every frame
 * @param rot          [in] N x J x 4 local rotations
 * @param n_trans      [in] P, number of joints with per-frame translations (0 for none)
 * @param trans_joints [in] P joint indices, strictly increasing, each in [1, J)
 * @param trans        [in] N x P x 3 their local translations (replace offsets)
 * @param world_pos    [out] N x J x 3 world positions
 * @param world_rot    [out] N x J x 4 world rotations, or NULL when not wanted
 * @param alloc        [in] used only when world_rot is NULL and J > 256, for J x 4 doubles of
 *                     scratch; NULL for malloc/free
 * @param diag         [out] optional: the reason of an error (which parent or trans joint)
 * @return MLR_OK; MLR_E_INVALID_ARG (bad parents or trans_joints, NULL arrays);
 *         MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: only as said for alloc. Threads: any; outputs must not alias inputs.
 */
MLR_API mlr_status mlr_fk_arrays(size_t n_frames, size_t n_joints, const int32_t *parents,
                                 const double *offsets, const double *root_pos, const double *rot,
                                 size_t n_trans, const int32_t *trans_joints, const double *trans,
                                 double *world_pos, double *world_rot, const mlr_allocator *alloc,
                                 mlr_diag *diag);

/**
 * Forward kinematics of frames [begin, begin + count) of a motion.
 * @param world_pos    [out] count x J x 3
 * @param world_rot    [out] count x J x 4, or NULL (then scratch is taken from the motion's
 *                     allocator when J > 256)
 * @param diag         [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (frame range out of bounds, NULL); MLR_E_NO_MEMORY
 * Allocates: only as said. Threads: motion is only read.
 */
MLR_API mlr_status mlr_fk_motion(const mlr_motion *motion, size_t begin, size_t count,
                                 double *world_pos, double *world_rot, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_FK_H */
