/* The whole body above the floor: the path to a point through it has its exaggeration reduced
 * (floor_chains.c). Not installed. */
#ifndef MLR_FLOOR_CHAINS_INTERNAL_H
#define MLR_FLOOR_CHAINS_INTERNAL_H

#include "guards/input_internal.h"
#include "mlayer/mlr_rig.h"

/* For every joint and End Site of rig that is not on a foot (the C contact points' joints and
 * their descendants: the cleanup's), wherever the motion (root, rot, trans: N frames; root and
 * rot rewritten) puts it more than slack below floor (along axis up) beyond the input's own
 * depth there (the input: in, with its forward kinematics), the path from the root to it (the root's
 * translation, the rotations, and the translation of the body joint, trans joint body (-1: the
 * root carries the body), which enters as a root shift) is blended toward the input's by the least weight in steps
 * of 1/8 that lifts it, the weights eased in time over 0.2 s. *lifted: how many points needed
 * it. keep_feet: the root's translation and the rotations of the contact points' joints and
 * their ancestors are left as they are (after the cleanup, which pinned the feet). Arguments
 * checked by the caller; the motion unchanged on failure. */
mlr_status floor_chains__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                               double slack, const guards_input *in, double *root, double *rot,
                               const double *trans, int32_t body, size_t C, const int32_t *joints,
                               int keep_feet, size_t *lifted, const mlr_allocator *alloc);

#endif /* MLR_FLOOR_CHAINS_INTERNAL_H */
