/* The whole body raised smoothly by a need in time (floor_lift.c). Not installed. */
#ifndef MLR_FLOOR_LIFT_INTERNAL_H
#define MLR_FLOOR_LIFT_INTERNAL_H

#include "mlayer/mlr_common.h"

#include <stddef.h>

/* The half width h, in frames, of the lift of a stretch whose largest need is `peak`: at least
 * 0.1 s, at most 1 s, and otherwise the least h for which the lift's largest second difference,
 * about peak * pi / (2 (h + 1)^2), is at most a_ref / 2 (a_ref: the clip's own largest second
 * difference, per frame^2, in the units of peak). a_ref <= 0: 1 s. */
size_t floor_lift__half_width(double peak, double a_ref, double fps);

/* Adds to root[3 f + up] (f < N) a smooth lift that covers need[f] (>= 0; 0 where none):
 * every stretch of frames with a need (stretches whose reaches, 2h each side, would meet are
 * one) gets the running maximum of its need over +-h frames, averaged with a raised-cosine
 * window of +-h (h = floor_lift__half_width of the stretch's largest need), so that the lift
 * is at least the need at every frame, at most the stretch's largest need, and zero farther
 * than 2h from the stretch. MLR_E_NO_MEMORY (root unchanged) when scratch cannot be had. */
mlr_status floor_lift__smooth(size_t N, double fps, const double *need, double a_ref, int up,
                              double *root, const mlr_allocator *alloc);

/* What floor_lift__smooth adds, added to out[stride f] (f < N) instead: the envelope of any
 * need in time (a_ref = INFINITY: 0.1 s ramps whatever the need, as the retarget's lift and
 * its toes' weights take it). */
mlr_status floor_lift__envelope(size_t N, double fps, const double *need, double a_ref,
                                double *out, size_t stride, const mlr_allocator *alloc);

#endif /* MLR_FLOOR_LIFT_INTERNAL_H */
