/* Toe tips kept above the floor by tilting the bone that carries them (toe_tilt.c). Not
 * installed. */
#ifndef MLR_TOE_TILT_INTERNAL_H
#define MLR_TOE_TILT_INTERNAL_H

#include "guards/input_internal.h"
#include "mlayer/mlr_rig.h"

/* For every End Site among the C points (end_sites[c] >= 0) whose parent joint has no child
 * joint (a toe tip at the end of the foot), and for every joint point that carries a short
 * chain below it (up to 3 single children, none of them a point, and the End Sites of the
 * last: Mixamo's ToeBase carrying Toe_End and its tip), wherever the motion (root, rot, trans:
 * N frames; rot rewritten) puts such a tip more than slack below floor (along axis up) beyond
 * the input's own depth there (the input: in, with its forward kinematics), the joint that carries
 * it is turned about the horizontal axis across its bone until every tip is within slack / 2
 * of that limit, by at most TOE_TILT_MAX; the angles eased in time as the limits' corrections
 * are (a running maximum, then a Gaussian of 40 ms), so the tilt enters and leaves smoothly.
 * No point moves: only what lies below the last one. *tilted: how many joints needed it.
 * Arguments checked by the caller; the motion unchanged on failure (MLR_E_NO_MEMORY,
 * MLR_E_OVERFLOW). */
mlr_status toe_tilt__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                           double slack, const guards_input *in, const double *root, double *rot,
                           const double *trans, size_t C, const int32_t *joints,
                           const int32_t *end_sites, size_t *tilted, const mlr_allocator *alloc);

#endif /* MLR_TOE_TILT_INTERNAL_H */
