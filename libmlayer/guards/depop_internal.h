/* Pops smoothed out of the guards' corrections (depop.c). Not installed. */
#ifndef MLR_DEPOP_INTERNAL_H
#define MLR_DEPOP_INTERNAL_H

#include "mlayer/mlr_limits.h"
#include "mlayer/mlr_rig.h"

/* The largest acceleration (second difference, per frame squared) of the C points pts
 * (N x C x 3) over points, per frame into a (N values, 0 at the first and last; or NULL), and
 * over the frames as the return value (0 for N < 3). */
double depop__points_accel(const double *pts, size_t N, size_t C, double *a);

/* Where a point (C points: joints, End Sites as mlr_rig_point_positions takes them) of the
 * result (root, rot: N frames, replaced) accelerates faster than 1.25 times its base, the
 * largest acceleration of the input's (in_root, in_rot, in_trans; in_root NULL: none) and of
 * the synthesis's (syn_root, syn_rot, trans, which the result shares) over the points of its
 * kind (the joints, the End Sites), the corrections of every joint and of the root from the
 * synthesis are replaced near it by their Gaussian average in time, over 50 ms and then up to
 * 5 rounds of 50 ms more while a pop is left; of the rounds' results the one with the smallest
 * pop is kept. contacts (N x C, or NULL): in the first round, on a point's contact frames,
 * its joint and their ancestors, and the root translation, are left as they are; the later
 * rounds smooth the joints of the limb of a point that still pops (up to the joint below the
 * first that branches) near its pops. limits (or NULL): the hinges of the smoothed frames are
 * clamped to their ranges at alpha (1 or 1 + J values) after each round. *smoothed: the most
 * frames a round of the kept result changed (0: none). Arguments checked by the caller
 * (finite, in range); MLR_E_NO_MEMORY or MLR_E_OVERFLOW leave some frames smoothed. */
mlr_status depop__apply(const mlr_rig *rig, size_t N, double fps, const double *in_root,
                        const double *in_rot, const double *in_trans, const double *syn_root,
                        const double *syn_rot, const double *trans, size_t C,
                        const int32_t *joints, const int32_t *end_sites, const uint8_t *contacts,
                        const mlr_limits *limits, const double *alpha, size_t n_alpha,
                        double *root, double *rot, size_t *smoothed, const mlr_allocator *alloc);

#endif /* MLR_DEPOP_INTERNAL_H */
