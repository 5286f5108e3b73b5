/* Two-bone IK on one frame, for the cleanup (contacts_fix.c). Not installed. */
#ifndef MLR_IK_INTERNAL_H
#define MLR_IK_INTERNAL_H

#include "mlr_internal.h"

/* r_hip, r_knee (w, x, y, z) of one frame, as mlr_ik_two_bone; axis may be NULL. */
void mlr_ik_two_bone_1(const double a[3], const double b[3], const double c[3], const double t[3],
                       const double *axis, double max_ext, double r_hip[4], double r_knee[4]);
/* Shortest arc from u to v (as mlr_ik_from_to). */
void mlr_ik_from_to_1(const double u[3], const double v[3], double q[4]);
/* rot_j' = normalize(conj(G_parent) * r * G_j) for one frame; gp NULL for the root. */
void mlr_ik_rotate_to_1(double rot_j[4], const double *gp, const double g[4], const double r[4]);
/* out = a * b, out = rotate(q, v) (no aliasing restrictions: computed into temporaries). */
void mlr_ik_qmul(const double a[4], const double b[4], double out[4]);
void mlr_ik_qrot(const double q[4], const double v[3], double out[3]);

#endif
