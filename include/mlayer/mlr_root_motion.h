/*
 * Root motion: a clip split into a root track on the ground plane (position and heading, the
 * form game engines drive characters with) and an in-place motion relative to that track.
 *
 * The track. Let b be the body joint (the joint that carries the body translation,
 * mlr_rig_body_translation_joint: the root for most rigs, Bandai's Hips under a static
 * joint_Root), x_b and W_b its world position and rotation (forward kinematics along its
 * chain), u = e_up the up axis and (g1, g2) = (e_{up+1}, e_{up+2}) the ground axes, cyclic
 * (Y-up: Z, X; Z-up: X, Y; X-up: Y, Z).
 *  - position c = x_b with its up component removed (mode GROUND and POSITION);
 *  - heading theta (mode GROUND; 0 in mode POSITION), radians about +u: the direction of the
 *    forward vector f = (W_b l) x u on the ground, theta = atan2(f . g2, f . g1), unwrapped
 *    to a continuous track (steps of at most pi). l is the body's left direction in the body
 *    joint's own frame, measured from the motion: the sum over frames and over the left/right
 *    joint pairs whose sides the names tell (mlr_mirror_pairs) of W_b^-1 (x_left - x_right),
 *    normalized; without such pairs (or when it vanishes), l = g2 (heading 0 then faces the
 *    body joint's local g1). The heading is a function of the body joint's rotation alone, so
 *    it is as smooth as the pelvis; measuring l from the data rather than from the OFFSETs
 *    makes it independent of the rig's rest orientation (Bandai's and LaFAN1's rest poses are
 *    not T-poses facing an axis: their bones lie along local X). Why the left-right axis and
 *    not a forward axis of the root: the names say which way is left, while no convention
 *    says which local axis of a root is forward; and the left-right axis does not move when
 *    the body pitches (a crouch, a bow, a dog lying down turn the torso about it), so the
 *    heading stays defined where a projected forward axis would shrink to nothing. Frames
 *    where W_b l points along u (|f| below 1e-9) keep the heading of the nearest frame before
 *    (after, at the start) that has one; 0 when none has.
 *  - both smoothed (the two ground coordinates of c and the unwrapped theta) by the LGS of
 *    order 2 with identity observations, (I + s L^T L) x = y, whose gain
 *    1 / (1 + s (2 sin(pi f / fps))^4) is 1/2 at the period MLR_ROOT_MOTION_OPT_SMOOTH:
 *    s = (2 sin(pi / (smooth fps)))^-4 (smooth fps at most 2: s = 1/16). smooth 0: none;
 *    also none for fewer than 3 frames.
 *
 * The in-place motion: with H(theta) the rotation by theta about u, the root (joint 0) becomes
 *     root_pos' = H^-1 (root_pos - c),   root_rot' = H^-1 root_rot,
 * every other channel unchanged; so its world positions are H^-1 (x - c) of the input's, and
 * mlr_root_motion_apply (root_pos = c + H root_pos', root_rot = H root_rot') puts track and
 * in-place motion back together to rounding. The in-place body joint stays near the origin,
 * facing g1, up to what the smoothing left out (the sway of a gait).
 */
#ifndef MLR_ROOT_MOTION_H
#define MLR_ROOT_MOTION_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Modes of mlr_root_motion_extract. Values pinned. */
typedef enum mlr_root_motion_mode {
    MLR_ROOT_MOTION_GROUND = 0,  /**< ground position and heading */
    MLR_ROOT_MOTION_POSITION = 1 /**< ground position only: heading 0, rotations unchanged */
} mlr_root_motion_mode;

/** Option keys for mlr_root_motion_extract. Values pinned; new options get new values. */
typedef enum mlr_root_motion_key {
    MLR_ROOT_MOTION_OPT_SMOOTH = 1,    /**< the LGS's half-power period, seconds, >= 0 (0: no
                                            smoothing). Default 1.0: the sway of a walk (one
                                            stride, about 1 s) mostly left in the in-place
                                            motion, turns kept */
    MLR_ROOT_MOTION_OPT_BODY_JOINT = 2 /**< the joint whose path the track follows, an index
                                            in [0, J), or -1 (default): the body translation
                                            joint (mlr_rig_body_translation_joint) */
} mlr_root_motion_key;

/** One option: key (an mlr_root_motion_key) and its value. A frozen value type. */
typedef struct mlr_root_motion_option {
    int key;
    double value;
} mlr_root_motion_option;

/**
 * Split a motion into a root track and an in-place motion (the rules of the file comment).
 * @param rig           [in] a valid rig (names used for the left direction when present)
 * @param fps           [in] frame rate, finite and > 0
 * @param up            [in] the up axis, an mlr_axis
 * @param mode          [in] an mlr_root_motion_mode
 * @param n_frames      [in] N >= 1
 * @param root_pos      [in] N x 3 root translations
 * @param rot           [in] N x J x 4 local rotations (unit quaternions)
 * @param trans         [in] N x P x 3 translations of rig->trans_joints; NULL when P is 0
 * @param opts          [in] n_opts options; NULL when n_opts is 0. A key may appear once.
 * @param track_pos     [out] N x 3 track positions (the up component 0)
 * @param track_heading [out] N headings, radians, continuous
 * @param out_root_pos  [out] N x 3 in-place root translations; may be root_pos (in place)
 * @param out_root_rot  [out] N in-place root rotations, 4 doubles each, ld_out_rot doubles
 *                      apart (4 for an N x 4 array; 4 J for the root column of an N x J x 4
 *                      array, which may be rot itself: in place)
 * @param ld_out_rot    [in] >= 4
 * @param alloc         [in] for scratch; NULL for malloc/free
 * @return MLR_OK; MLR_W_ILL_CONDITIONED (a very strong smoothing; the result is usable);
 *         MLR_E_INVALID_ARG (NULL arguments, an invalid rig, fps, axis or mode, N == 0, a
 *         value not finite, unknown or repeated option, an option out of range: reason in
 *         diag); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: 7 (N + J) doubles + N bytes of scratch, 5 J bytes + twice the longest name for
 * the pairs, and an LGS handle, released before return. Cost O(N J + J log J).
 * Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_root_motion_extract(
    const mlr_rig *rig, double fps, int up, int mode, size_t n_frames, const double *root_pos,
    const double *rot, const double *trans, const mlr_root_motion_option *opts, size_t n_opts,
    double *track_pos, double *track_heading, double *out_root_pos, double *out_root_rot,
    size_t ld_out_rot, const mlr_allocator *alloc, mlr_diag *diag);

/**
 * Put a root track and an in-place motion back together: root_pos = c + H(theta) root_pos',
 * root_rot = H(theta) root_rot' (H the rotation by theta about the up axis), frame by frame.
 * @param up            [in] the up axis, an mlr_axis
 * @param n_frames      [in] N
 * @param track_pos     [in] N x 3 (its up component is used as given: 0 from extract)
 * @param track_heading [in] N radians
 * @param root_pos      [in] N x 3 in-place root translations
 * @param root_rot      [in] N root rotations, ld_root_rot doubles apart (>= 4)
 * @param out_root_pos  [out] N x 3; may be root_pos
 * @param out_root_rot  [out] N root rotations, ld_out_rot doubles apart (>= 4); may be
 *                      root_rot (same pointer and stride)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments with N > 0, bad axis, strides below 4,
 *         a track value not finite)
 * Allocates: never. Cost O(N). Threads: any.
 */
MLR_API mlr_status mlr_root_motion_apply(int up, size_t n_frames, const double *track_pos,
                                         const double *track_heading, const double *root_pos,
                                         const double *root_rot, size_t ld_root_rot,
                                         double *out_root_pos, double *out_root_rot,
                                         size_t ld_out_rot, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_ROOT_MOTION_H */
