/*
 * Trimming: the frames a converter put before the captured motion of a clip.
 *
 * The CMU BVH conversions (cgspeed's and others made from them) start with a T-pose frame,
 * the skeleton's rest pose, that was never captured; some follow it with a few frames that
 * blend from the T-pose into the first captured pose. Time warping dwells on those frames, a
 * SOM learns them as a pose class, smoothing spreads the jump. mlr_trim_lead_in finds them.
 *
 * The rule works on poses, not on channels. Pose f is x_f, as mlayer.pose_features makes it:
 * in the clip turned Y-up, the positions of the joints below the body joint
 * (mlr_rig_body_translation_joint: the root, or Bandai's Hips) relative to that joint, turned
 * about the vertical by minus its heading, so moving or turning the body on the floor leaves
 * the pose alone. The distance of two poses d(f, g) is the mean over those joints of
 * |x_f[j] - x_g[j]|; size is the median over frames of the joints' mean distance from the body
 * joint, still = MLR_TRIM_STILL * size. Then:
 *  1. held: h is the first frame farther than `still` from frame 0 (frames 0 .. h-1 hold the
 *     first pose: one frame in the CMU files). None (a static clip): no lead-in.
 *  2. blend: m is the median step d(f, f + 1) over f >= h (at least `still`). From h on,
 *     steps above MLR_TRIM_JOIN * m move from the first pose into the motion; the blend ends
 *     at c, the first frame in [h, h + MLR_TRIM_MAX_BLEND] from which MLR_TRIM_SETTLE steps
 *     in a row (or those left before the clip ends) are at most that (c = h: no blend), or
 *     c = h when there is none. (The CMU converters' blends slow down and speed up again
 *     before the capture starts: cmu_10_01's steps are 47 42 29 11 1.5 6.5 3.9 m, then
 *     0.2 m.)
 *  3. jump: it is a lead-in when frame 0 is farther than MLR_TRIM_JUMP * m from every frame
 *     from c on and c is at most a quarter of the clip. A captured first pose has frames about
 *     one median step away (at most 1.61 m on the 13 clips without a lead-in measured: 4
 *     shared, 9 from other exporters); the CMU T-poses are 25 to 70 m from their motion (54 on
 *     a CMU file converted by others). A clip that comes back to its first pose has no
 *     lead-in.
 *  The lead-in is c frames: drop frames 0 .. c-1. Every threshold is a ratio of distances, so
 *  the rule holds in any unit and at any frame rate. Clips of fewer than MLR_TRIM_MIN_FRAMES
 *  frames give 0 (too short to tell what their motion is).
 * On the shared clips: cmu_01_01 1 frame (the T-pose), cmu_10_01 8, cmu_60_10 7, cmu_02_03 5;
 * cmu_131_01, LaFAN1, Bandai and the dog 0.
 */
#ifndef MLR_TRIM_H
#define MLR_TRIM_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A first pose farther than this many median steps from the motion is a converter's. */
#define MLR_TRIM_JUMP 5.0
/** A blend frame's step to the next is above this many median steps. */
#define MLR_TRIM_JOIN 2.0
/** The blend ends where this many steps in a row are ordinary. */
#define MLR_TRIM_SETTLE 3
/** At most this many blend frames after the held first pose. */
#define MLR_TRIM_MAX_BLEND 30
/** Steps below this fraction of the body size count as holding still (floor of m). */
#define MLR_TRIM_STILL 1e-3
/** Clips of fewer frames have no lead-in (no median step to go by). */
#define MLR_TRIM_MIN_FRAMES 8

/** What mlr_trim_lead_in found. A frozen value type: fields are never reordered or removed. */
typedef struct mlr_trim_lead {
    size_t n_frames; /**< frames to drop at the start (0: the clip starts with its motion) */
    size_t n_held; /**< of those, the frames holding the first pose (the T-pose); 0 with none */
    double distance; /**< frame 0's distance to the frames from c on, in median steps (the
                          jump, step 3); 0 when not measured (a short or static clip) */
} mlr_trim_lead;

/**
 * The converter's lead-in at the start of a clip: a T-pose (held for one or more frames) that
 * is far from every pose of the motion, and the blend frames after it until the pose joins
 * the motion (the rule in the comment at the top of this header).
 * @param rig       [in] a valid rig (mlr_rig_check)
 * @param n_frames  [in] N (any; fewer than MLR_TRIM_MIN_FRAMES give 0)
 * @param root_pos  [in] N x 3 root translations, or NULL for the root at its OFFSET
 * @param rot       [in] N x J x 4 local rotations, unit quaternions (w, x, y, z)
 * @param trans     [in] N x P x 3 translations of rig->trans_joints (P = rig->n_trans); NULL
 *                  allowed when P is 0
 * @param up        [in] the up axis, an mlr_axis (mlr_rig_up_axis finds it)
 * @param out       [out] the lead-in; all zero when there is none
 * @param alloc     [in] for scratch; NULL for malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (out, rot NULL with N > 0, an invalid rig, a bad up axis,
 *         non-finite values; reason in diag); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: scratch of about 3 N J + 2 N doubles, released before return. Cost O(N J) plus a
 *            median of N values. Threads: any; the inputs are only read.
 */
MLR_API mlr_status mlr_trim_lead_in(const mlr_rig *rig, size_t n_frames, const double *root_pos,
                                    const double *rot, const double *trans, int up,
                                    mlr_trim_lead *out, const mlr_allocator *alloc,
                                    mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_TRIM_H */
