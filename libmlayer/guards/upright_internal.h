/* A body that stands on its head along the up axis, found (upright.c). Not installed. */
#ifndef MLR_UPRIGHT_INTERNAL_H
#define MLR_UPRIGHT_INTERNAL_H

#include "mlayer/mlr_rig.h"

#include <stddef.h>

/* *upside_down = 1 when the clip's named feet (contacts__is_foot_name: foot, ankle, paw, hoof) stand above the
 * mean of its joints along +up in the median over its frames (world positions wpos, N x J x
 * 3; the mean, not the root: Bandai's root joint lies on the ground under the hips): the
 * body is upside down, as a video pose estimator's image coordinates (y down) leave it; 0
 * otherwise and for a rig without such names. MLR_E_NO_MEMORY when scratch cannot be had. */
mlr_status upright__upside_down(const mlr_rig *rig, size_t N, const double *wpos, int up,
                                const mlr_allocator *alloc, int *upside_down);

#endif /* MLR_UPRIGHT_INTERNAL_H */
