/* Elbows kept on their own side of straight (hinge_side.c). Not installed. */
#ifndef MLR_HINGE_SIDE_INTERNAL_H
#define MLR_HINGE_SIDE_INTERNAL_H

#include "mlayer/mlr_rig.h"

#include <stddef.h>

#define HINGE_SIDE_MAX 8 /* arms per rig (a many-armed creature's first eight) */

/* One arm: the chain (upper, middle, end) mlr_ik_leg_chain gives for a hand or wrist, the
 * elbow's hinge axis in the frame of the middle joint's parent (unit), the smallest signed
 * flexion the input has (radians, at most 0) and the largest (at least 150 degrees). */
typedef struct hinge_side {
    int32_t upper, middle, end;
    double axis[3];
    double lo, hi;
} hinge_side;

/* The arms of rig (its topmost joints named hand or wrist, each with a two-bone chain), at
 * most cap, into out (upper, middle and end set); returns how many. */
size_t hinge_side__chains(const mlr_rig *rig, hinge_side *out, size_t cap);

/* h's axis and lo learned from the input's world positions and rotations (N x J x 3, N x J x
 * 4; the rotation read only at the middle joint's parent): the axis is the mean of the unit
 * normals cross(upper bone, lower bone) over the frames bent by more than 20 degrees, carried
 * into the parent's frame; the input's signed flexion per frame into ref (N; NAN where a bone
 * has no length). Returns 0 (h unusable) when no frame bends that far, or when the
 * input bends it more than 60 degrees the other way (no side to keep). */
int hinge_side__learn(const mlr_rig *rig, size_t N, const double *wpos, const double *wrot,
                      hinge_side *h, double *ref);

/* Wherever the motion (root, rot, trans: N frames; rot rewritten) bends an arm of h[0..n)
 * further the other way than lo (its signed flexion atan2((u x w) . axis, u . w) below lo), or
 * folds it past hi (the angle taken on the turn nearest the input's, ref: N x n), the elbow is turned about the axis by the shortfall or the excess, eased in time (a running maximum, then
 * a 40 ms Gaussian: limits__ease_lookahead), measured and turned twice. mask (N x J, or NULL):
 * set at the elbow of every frame turned (left as it is elsewhere). *turned: how many arms
 * needed it. Arguments checked by the caller; MLR_E_NO_MEMORY, MLR_E_OVERFLOW (the motion
 * unchanged then, or turned once). */
mlr_status hinge_side__apply(const mlr_rig *rig, size_t N, double fps, const hinge_side *h,
                             size_t n, const double *ref, const double *root, double *rot,
                             const double *trans, uint8_t *mask, size_t *turned,
                             const mlr_allocator *alloc);

#endif /* MLR_HINGE_SIDE_INTERNAL_H */
