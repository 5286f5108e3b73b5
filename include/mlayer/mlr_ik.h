/*
 * Analytic two-bone inverse kinematics, vectorized over frames.
 *
 * A leg is a chain hip -> knee -> end (end: the ankle, or any joint that should reach a
 * target). mlr_ik_two_bone returns two world-space rotations per frame: r_knee turns the
 * knee-to-end segment about the knee (a hinge: only the knee angle changes), then r_hip turns
 * the whole leg about the hip so that the end lands on the target. Both are deltas applied on
 * the left of the joints' current world rotations; mlr_ik_rotate_to / mlr_ik_apply_leg turn
 * them into new local rotations (L' = inv(G_parent) * r * G), so bone lengths never change.
 *
 * Positions are N x 3 (or N x J x 3 for whole skeletons), quaternions scalar-first
 * (w, x, y, z), float64, row-major.
 */
#ifndef MLR_IK_H
#define MLR_IK_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The default max_extension of mlr_ik_two_bone: a leg is not stretched beyond 99.99%. */
#define MLR_IK_MAX_EXTENSION 0.9999

/**
 * World-space rotation deltas (r_hip, r_knee) of a two-bone chain, per frame.
 * The knee turns about the hinge axis (made perpendicular to the shin) by the angle that puts
 * the end at the target's distance from the hip; of the two such angles the one with the knee
 * bent forward (a positive turn about the axis) is taken, so a target at the current distance
 * leaves a forward-bent knee unchanged. Then r_hip turns the leg about the hip by the shortest
 * arc onto the target. The end reaches the target exactly when its distance from the hip is
 * reachable with that hinge (for a hinge perpendicular to the thigh: between |l1 - l2| and
 * max_extension (l1 + l2); a leg already straighter than that is not bent); otherwise the end
 * stops at the nearest reachable distance on the hip-target line.
 * @param n          [in] frames N
 * @param hip, knee, end, target [in] N x 3 world positions each, finite
 * @param bend_axis  [in] N x 3 knee hinge axes, oriented like cross(end - knee, hip - knee) of
 *                   a normally bent leg; NULL for that cross product itself frame by frame
 *                   (undefined for a straight leg: give an axis for legs that straighten)
 * @param max_extension [in] in (0, 1], e.g. MLR_IK_MAX_EXTENSION
 * @param r_hip, r_knee [out] N x 4 unit quaternions each
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL array, non-finite input, max_extension outside
 *         (0, 1]; reason in diag)
 * Allocates: never. Threads: any; outputs must not alias inputs.
 */
MLR_API mlr_status mlr_ik_two_bone(size_t n, const double *hip, const double *knee,
                                   const double *end, const double *target,
                                   const double *bend_axis, double max_extension, double *r_hip,
                                   double *r_knee, mlr_diag *diag);

/**
 * Shortest-arc unit quaternions turning direction u[i] into direction v[i]. Identity where
 * either vector is zero; for opposite vectors a half turn about an axis perpendicular to u.
 * @param u, v [in] N x 3 each; @param out [out] N x 4
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL with n > 0)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_ik_from_to(size_t n, const double *u, const double *v, double *out);

/**
 * The two-bone chain ending at joint `end`: the knee is the nearest ancestor of end at a
 * non-zero distance from it (bone lengths from the OFFSETs; zero-length bones such as CMU's
 * LHipJoint are skipped), the hip the nearest ancestor at a non-zero distance from the knee.
 * @param hip, knee [out] joint indices
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, end out of range, no such chain: a joint too
 *         close to the root; reason in diag, naming the joint when the rig has names)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_ik_leg_chain(const mlr_rig *rig, int32_t end, int32_t *hip, int32_t *knee,
                                    mlr_diag *diag);

/**
 * The knee's bend axis in the hip joint's frame: the normalized sum over frames of
 * inv(G_hip) cross(end - knee, hip - knee) (so weighted by how bent the leg is); zeros when
 * the leg never bends.
 * @param world_pos [in] N x J x 3; @param world_rot [in] N x J x 4
 * @param axis [out] 3 values
 * @param diag [out] optional: the reason of a failure (the NULL array, the joint out of range)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, joint out of range)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_ik_bend_axis_local(size_t n, size_t n_joints, const double *world_pos,
                                          const double *world_rot, int32_t hip, int32_t knee,
                                          int32_t end, double axis[3], mlr_diag *diag);

/**
 * Apply a world-space delta r_world (N x 4) to `joint` in the local rotations rot (N x J x 4,
 * changed in place), given the world rotations world_rot of the motion rot belongs to:
 * L' = normalize(inv(G_parent) * r * G).
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, joint out of range, bad parent)
 * Allocates: never. Threads: any; rot must not alias world_rot.
 */
MLR_API mlr_status mlr_ik_rotate_to(size_t n, size_t n_joints, const int32_t *parents, double *rot,
                                    const double *world_rot, int32_t joint, const double *r_world,
                                    mlr_diag *diag);

/**
 * Solve the chain (hip, knee, end) toward target (N x 3) with mlr_ik_two_bone
 * (MLR_IK_MAX_EXTENSION) and write the new local rotations of hip and knee into rot
 * (N x J x 4, in place). world_pos, world_rot: N x J x 3 and N x J x 4, the current forward
 * kinematics of rot. The knee's parent is the hip or a joint between them.
 * @param bend_axis [in] N x 3 world hinge axes, or NULL for the clip's own mean bend axis in
 *                  the hip's frame (mlr_ik_bend_axis_local), turned by the hip's world
 *                  rotation of each frame (the per-frame cross product when that is zero)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, joints out of range or not a chain, non-finite)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_ik_apply_leg(size_t n, size_t n_joints, const int32_t *parents, double *rot,
                                    const double *world_pos, const double *world_rot, int32_t hip,
                                    int32_t knee, int32_t end, const double *target,
                                    const double *bend_axis, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_IK_H */
