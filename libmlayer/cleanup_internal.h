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

/* A reference's trajectories, as mlr_cleanup_contacts derives them from the reference frames:
 * what depends on the reference alone, made once and then read by any number of cleanups of
 * motions on the same frames (the guards' rounds, and every apply when the reference is the
 * input). Read only once made: threads may share it. */
typedef struct mlr_cleanup_ref {
    mlr_allocator alloc;
    size_t n_frames, n_points, n_feet;
    int up;
    double smooth;   /* the MLR_CLEANUP_OPT_REF_SMOOTH it was made with */
    double *h;       /* N x C: the points' up coordinates (unsmoothed) */
    double *pts;     /* N x C x 3: the points, smoothed over `smooth` seconds */
    double *anchors; /* N x F x 3: the feet's anchors (ankles), smoothed */
} mlr_cleanup_ref;

/* Make the trajectories of reference frames (root_pos, rot, trans) for the contact points
 * and the frames (both checked by the caller: finite); world_pos / world_rot: the reference's full
 * forward kinematics (N x J x 3 and N x J x 4) when at hand, else NULL (computed here). opts:
 * the cleanup's options (only REF_SMOOTH is read; the others are checked). *out NULL on
 * failure. Allocates about N (4 C + 3 F) doubles. */
mlr_status mlr_cleanup_ref_create(const mlr_rig *rig, size_t N, double fps, int up,
                                  const double *root_pos, const double *rot, const double *trans,
                                  const double *world_pos, const double *world_rot, size_t C,
                                  const int32_t *joints, const int32_t *end_sites,
                                  const mlr_cleanup_option *opts, size_t n_opts,
                                  const mlr_allocator *alloc, mlr_cleanup_ref **out,
                                  mlr_diag *diag);
void mlr_cleanup_ref_destroy(mlr_cleanup_ref *ref);

/* mlr_cleanup_contacts with the reference's trajectories made (ref, or NULL for no reference:
 * then ref_root_pos and the others of the public call are NULL). trusted: the rig, the points
 * and the motion were checked by the caller (the guards' later rounds), so they are not
 * checked again. */
mlr_status mlr_cleanup_contacts_ref(const mlr_rig *rig, size_t N, double fps, int up,
                                    const double *root_pos, const double *rot, const double *trans,
                                    const mlr_cleanup_ref *ref, int trusted, size_t C,
                                    const int32_t *joints, const int32_t *end_sites,
                                    const uint8_t *contacts, const mlr_cleanup_option *opts,
                                    size_t n_opts, double *out_root_pos, double *out_rot,
                                    mlr_cleanup_report *report, const mlr_allocator *alloc,
                                    mlr_diag *diag);

#endif
