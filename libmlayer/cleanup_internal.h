/* The cleanup's private parts shared with the guards. */
#ifndef MLR_CLEANUP_INTERNAL_H
#define MLR_CLEANUP_INTERNAL_H

#include "mlr_internal.h"

/* The floor of mlr_cleanup_floor_height from the contact points' world positions pts
 * (N x C x 3, as mlr_rig_point_positions gives them) instead of the frames: the quantile of
 * their up coordinates on their contact frames, NaN when nothing touches. Arguments checked
 * by the caller; N C doubles of scratch from a. */
mlr_status mlr_cleanup_floor_of_points(size_t n_frames, size_t n_points, const double *pts,
                                       const uint8_t *contacts, int up, double quantile,
                                       double *height, const mlr_allocator *a);

/* Heights along up of the contact points (N x C into h) of frames (root_pos, rot, trans), by
 * forward kinematics of the points' chains only, bit for bit what mlr_fk_arrays and
 * mlr_rig_point_positions give. Arguments checked by the caller; scratch of a few J from a. */
mlr_status mlr_cleanup_point_heights(const mlr_rig *rig, size_t N, const double *root_pos,
                                     const double *rot, const double *trans, size_t C,
                                     const int32_t *joints, const int32_t *end_sites, int up,
                                     double *h, const mlr_allocator *a);

#endif
