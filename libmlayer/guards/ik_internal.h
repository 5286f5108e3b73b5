/* Two-bone IK on one frame, for the cleanup (contacts_fix.c). Not installed. */
#ifndef MLR_IK_INTERNAL_H
#define MLR_IK_INTERNAL_H

#include "common/mlr_internal.h"

#include <math.h>

/* r_hip, r_knee (w, x, y, z) of one frame, as mlr_ik_two_bone; axis may be NULL. */
void ik__two_bone_1(const double a[3], const double b[3], const double c[3], const double t[3],
                    const double *axis, double max_ext, double r_hip[4], double r_knee[4]);
/* The frames of a batch of ik__two_bone_lanes. */
#define MLR_IK_LANES 16

/* A batch of m <= MLR_IK_LANES frames of two-bone IK, by components (structure of arrays):
   in: the hip a, knee b, end c, target t and, when have_axis, the bend axis of each frame;
   out: r_hip, r_knee (w, x, y, z) and slow: the frames left to ik__two_bone_1. */
typedef struct mlr_ik_lanes {
    double a[3][MLR_IK_LANES], b[3][MLR_IK_LANES], c[3][MLR_IK_LANES], t[3][MLR_IK_LANES];
    double axis[3][MLR_IK_LANES];
    double r_hip[4][MLR_IK_LANES], r_knee[4][MLR_IK_LANES];
    int slow[MLR_IK_LANES];
} mlr_ik_lanes;

/* ik__two_bone_1 of each of the m frames of L at once (vectorized), with its operations in
   its order, so the same bits; a frame that would take one of its rare branches (the hinge
   along the shin, the shortest arc's slow path) is flagged slow, its outputs undefined. */
void ik__two_bone_lanes(mlr_ik_lanes *L, size_t m, int have_axis, double max_ext);
/* Shortest arc from u to v (as mlr_ik_from_to). */
void ik__from_to_1(const double u[3], const double v[3], double q[4]);
/* out = rotate(q, v) (no aliasing restrictions: computed into temporaries); the product is
   ik__qmul4. Inline: the cleanup calls them per frame and joint (about 80,000 times per guards apply of
   2,526 frames), and the call cost a quarter of each. */
static inline void ik__qrot(const double q[4], const double v[3], double o[3])
{
    /* v + w t + u x t, t = 2 u x v (as ik._rotate) */
    const double u[3] = {q[1], q[2], q[3]};
    const double t[3] = {2.0 * (u[1] * v[2] - u[2] * v[1]), 2.0 * (u[2] * v[0] - u[0] * v[2]),
                         2.0 * (u[0] * v[1] - u[1] * v[0])};
    const double ut[3] = {u[1] * t[2] - u[2] * t[1], u[2] * t[0] - u[0] * t[2],
                          u[0] * t[1] - u[1] * t[0]};
    const double x = v[0] + q[0] * t[0] + ut[0], y = v[1] + q[0] * t[1] + ut[1],
                 z = v[2] + q[0] * t[2] + ut[2];
    o[0] = x, o[1] = y, o[2] = z;
}

/* rot_j' = normalize(conj(G_parent) * r * G_j) for one frame; gp NULL for the root. */
static inline void ik__rotate_to_1(double rot_j[4], const double *gp, const double g[4],
                                   const double r[4])
{
    double nw[4];
    ik__qmul4(r, g, nw);
    if (gp) {
        const double cgp[4] = {gp[0], -gp[1], -gp[2], -gp[3]};
        ik__qmul4(cgp, nw, rot_j);
    } else {
        rot_j[0] = nw[0], rot_j[1] = nw[1], rot_j[2] = nw[2], rot_j[3] = nw[3];
    }
    /* unit to rounding already (the product of unit quaternions nearly always is): left as
       it is */
    const double n2 = ik__quat_norm2_wxyz(rot_j[0], rot_j[1], rot_j[2], rot_j[3]);
    if (ik__near_unit2(n2))
        return;
    const double n = sqrt(n2);
    if (n > 0.0)
        rot_j[0] /= n, rot_j[1] /= n, rot_j[2] /= n, rot_j[3] /= n;
}

#endif
