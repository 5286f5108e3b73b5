/* Contacts: private entry points of feet.c and contacts_detect.c for the guards (guards.c,
 * which measure the body height once for both; upright.c). */
#ifndef MLR_CONTACTS_INTERNAL_H
#define MLR_CONTACTS_INTERNAL_H

#include "mlayer/mlr_contacts.h"

/* mlr_contacts_find_feet and mlr_contacts_detect with the body height of world_pos
 * (mlr_rig_body_height) given in *height (*body_height), or measured when it is NULL: the same results. */
mlr_status contacts__find_feet(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                               int up, size_t capacity, int32_t *joints, int32_t *end_sites,
                               size_t *n_feet, const mlr_allocator *alloc, const double *height,
                               mlr_diag *diag);
mlr_status contacts__detect(const mlr_rig *rig, double fps, int up, size_t n_frames,
                            const double *world_pos, const double *world_rot, size_t n_points,
                            const int32_t *joints, const int32_t *end_sites,
                            const mlr_contacts_option *opts, size_t n_opts, uint8_t *contacts,
                            const mlr_allocator *alloc, const double *body_height, mlr_diag *diag);
/* Whether a joint's name says foot (foot, ankle, paw or hoof, case-insensitive): the names
 * contacts__find_feet takes a foot by; 0 for NULL. */
int contacts__is_foot_name(const char *name);

#endif
