/* Knees kept above the floor by turning each leg about its hip-ankle axis (legs_swivel.c). Not
 * installed. */
#ifndef MLR_LEGS_SWIVEL_INTERNAL_H
#define MLR_LEGS_SWIVEL_INTERNAL_H

#include "guards/input_internal.h"
#include "mlayer/mlr_rig.h"

/* For every leg (a contact point's joint with no contact point above it is the ankle, its
 * parent the knee, the knee's parent the hip), wherever the motion (root, rot, trans: N frames;
 * rot rewritten) puts the knee more than slack below floor (along axis up) beyond the input's
 * own depth there (the input: in, with its forward kinematics), the leg is turned about the line from
 * the hip to the ankle by the smallest angle that brings the knee up to the input's depth (as
 * high as it goes when none does). The angles are eased in time as the limits' corrections are
 * (a running maximum, then a Gaussian of 40 ms; positive and negative parts apart). The hip's
 * rotation takes the turn and the ankle's gives it back: the ankle and the foot stay where the
 * cleanup put them, the knee's bend is kept. *turned: how many legs needed it. Arguments checked
 * by the caller; the motion unchanged on failure. */
mlr_status legs_swivel__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                              double slack, const guards_input *in, const double *root,
                              double *rot, const double *trans, size_t C, const int32_t *joints,
                              size_t *turned, const mlr_allocator *alloc);

#endif /* MLR_LEGS_SWIVEL_INTERNAL_H */
