/*
 * Foot contacts of a motion: the contact points of a rig found by joint name, and the frames
 * where each point touches the ground (paper 1, section 4.3).
 *
 * Contact points are (joint, End Site or -1) pairs, as mlr_rig_find_point gives them for
 * "Joint" and "Joint/End". Every threshold is relative to the body height
 * (mlr_rig_body_height on the clip's up axis) and to seconds, so the defaults work in any
 * length unit and at any frame rate. Heights are measured along the up axis; speeds are the
 * full 3-D magnitude (the same on any up axis).
 */
#ifndef MLR_CONTACTS_H
#define MLR_CONTACTS_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * The feet of a rig found by joint name (ASCII case-insensitive substring search, with the
 * four non-ASCII letters that Python's re.IGNORECASE also folds: U+0130, U+0131, U+017F,
 * U+212A).
 *
 * Ankles: the topmost joint of each chain whose name contains foot, ankle, paw or hoof (no
 * ancestor also matches). A joint whose name contains hand or wrist (topmost of its chain,
 * not already an ankle) is a foot too when it stays low: the median over frames of its height
 * above the frame's lowest joint is within 0.2 body heights of the ankles' median height
 * above it (a quadruped's front feet); that needs world positions. The feet are listed in
 * joint order. The toe of an ankle: its child whose name contains toe or ball (the one with
 * the longest OFFSET when there are several; the first of equal ones); without one, such a
 * descendant reached only through zero-length joints (|OFFSET| <= 1e-9); without one, the
 * ankle's first End Site; without one, no toe.
 *
 * Output per foot f: point 2f is the ankle (joints[2f], end_sites[2f] = -1); point 2f + 1
 * the toe: (toe joint, -1), (ankle, its End Site) or (-1, -1) when the foot has no toe.
 *
 * @param rig        [in] the skeleton; names required
 * @param n_frames   [in] N, frames of world_pos (0: no positions, hands are never feet)
 * @param world_pos  [in] N x J x 3 world positions (mlr_fk_arrays), finite; NULL when N is 0
 * @param up         [in] the up axis, an mlr_axis
 * @param capacity   [in] feet that joints / end_sites hold (2 * capacity points each);
 *                   n_joints always suffices
 * @param joints     [out] 2 * capacity joint indices
 * @param end_sites  [out] 2 * capacity End Site indices or -1
 * @param n_feet     [out] feet found (F >= 1 on success)
 * @param alloc      [in] for scratch; NULL for malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, no names, bad axis, non-finite positions,
 *         capacity too small, or no joint name matches: the message names the patterns);
 *         MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: J bytes and, when the rig has hand joints and N > 0, about N (A + 2) doubles
 * (A ankles) of scratch, released before return. Cost O(N J) (medians by selection).
 * Threads: any.
 */
MLR_API mlr_status mlr_contacts_find_feet(const mlr_rig *rig, size_t n_frames,
                                          const double *world_pos, int up, size_t capacity,
                                          int32_t *joints, int32_t *end_sites, size_t *n_feet,
                                          const mlr_allocator *alloc, mlr_diag *diag);

/** Option keys for mlr_contacts_detect. Values pinned; new options get new values. */
typedef enum mlr_contacts_key {
    MLR_CONTACTS_OPT_SPEED = 1,        /* enter below this speed, body heights per second;
                                          leave above twice it. Default 0.25 */
    MLR_CONTACTS_OPT_HEIGHT = 2,       /* enter below this height above the local floor
                                          level, body heights; leave above 1.5 times it.
                                          Default 0.06 */
    MLR_CONTACTS_OPT_MIN_DURATION = 3  /* drop contacts shorter than this, seconds (at least
                                          2 frames). Default 0.08 */
} mlr_contacts_key;

/** One option: key (an mlr_contacts_key) and its value. A frozen value type. */
typedef struct mlr_contacts_option {
    int key;
    double value;
} mlr_contacts_option;

/**
 * Foot contacts: the frames where each point is slow and low.
 *
 * With H the body height (mlr_rig_body_height on up) and p the points' world positions:
 * speed v = |p(t + k) - p(t - k)| / (2 k / fps), k = max(1, round(fps / 60)) (about 1/30 s;
 * the first and last k frames take the nearest computed value; for N <= 2 k, the mean speed
 * over the clip); height h = p_up(t) - (the lowest p_up within t +- round(0.75 fps)), the
 * height above the point's own local floor level. A point enters contact where
 * v < speed H and h < height H, leaves where v > 2 speed H or h > 1.5 height H, and keeps
 * its state otherwise (hysteresis, starting out of contact). Then gaps of at most
 * round(0.05 fps) frames between contacts are closed, and contacts shorter than
 * max(2, round(min_duration fps)) frames dropped. round() is to nearest, ties to even.
 *
 * @param rig        [in] the skeleton (names not needed)
 * @param fps        [in] frame rate, finite and > 0
 * @param up         [in] the up axis, an mlr_axis
 * @param n_frames   [in] N >= 3
 * @param world_pos  [in] N x J x 3 world positions (mlr_fk_arrays), finite
 * @param world_rot  [in] N x J x 4 world rotations; may be NULL when no point is an End Site
 * @param n_points   [in] C >= 1
 * @param joints     [in] C joint indices
 * @param end_sites  [in] C End Site indices (-1: the joint itself), or NULL for all joints
 * @param opts       [in] n_opts options; NULL when n_opts is 0. A key may appear once.
 * @param contacts   [out] N x C, 1 in contact, 0 not
 * @param alloc      [in] for scratch; NULL for malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, fps, axis, N < 3, C == 0, NULL arrays, point
 *         out of range or listed twice, non-finite positions (of a point, or of a joint
 *         along up), unknown or repeated key, an option not finite and > 0, no extent along
 *         up: a flat skeleton); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: at most N (4 C + 17) doubles of scratch (4 N C + 5 N for a window of more than
 * N / 2 frames each side), released before return. Cost O(N (J + C)).
 * Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_contacts_detect(const mlr_rig *rig, double fps, int up, size_t n_frames,
                                       const double *world_pos, const double *world_rot,
                                       size_t n_points, const int32_t *joints,
                                       const int32_t *end_sites, const mlr_contacts_option *opts,
                                       size_t n_opts, uint8_t *contacts,
                                       const mlr_allocator *alloc, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_CONTACTS_H */
