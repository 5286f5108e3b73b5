/*
 * A skeleton described by plain arrays (a "rig"), for the subjects that need more than the
 * parents and offsets of forward kinematics: joint names (to find feet, knees and elbows), End
 * Sites (toe tips of rigs without toe joints), the joints with per-frame translations, and
 * the body's size and up axis.
 *
 * An mlr_rig only points at the caller's arrays: it is borrowed for the duration of a call and
 * never kept. Joints are in depth-first order (parents[0] == -1, 0 <= parents[j] < j);
 * mlr_rig_depth_first_order gives that order for a tree listed in any other.
 *
 * Contact and end points are named "Joint" or "Joint/End" (the first End Site below Joint).
 */
#ifndef MLR_RIG_H
#define MLR_RIG_H

#include <stdint.h>

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A skeleton by reference. A frozen value type: fields are never reordered or removed. */
typedef struct mlr_rig {
    size_t n_joints;                 /* J >= 1 */
    const int32_t *parents;          /* J parent indices */
    const double *offsets;           /* J x 3 OFFSETs (local translations) */
    const char *const *names;        /* J NUL-terminated UTF-8 names, or NULL (no names) */
    size_t n_trans;                  /* P: joints with per-frame translations (0 for none) */
    const int32_t *trans_joints;     /* P indices, strictly increasing, each in [1, J) */
    size_t n_end_sites;              /* E */
    const int32_t *end_site_parents; /* E joint indices, or NULL when E is 0 */
    const double *end_site_offsets;  /* E x 3, or NULL when E is 0 */
} mlr_rig;

/** Frames of a motion over a rig, as the guards and the cleanup take them (their jobs): N
 *  root translations (N x 3), local rotations (N x J x 4 unit quaternions) and the rig's trans
 *  joints' translations (N x P x 3; NULL when P is 0). Borrowed, never copied by a job. A
 *  reference that is not given is all NULL with n_frames 0. A frozen value type. Since 0.3 */
typedef struct mlr_frames {
    size_t n_frames;
    const double *root_pos;
    const double *rot;
    const double *trans;
} mlr_frames;

/** Axes, for the up axis of a clip. Values pinned. */
typedef enum mlr_axis { MLR_AXIS_X = 0, MLR_AXIS_Y = 1, MLR_AXIS_Z = 2 } mlr_axis;

/** The suffix that names a joint's End Site as a point: "LeftFoot/End". */
#define MLR_RIG_END_SUFFIX "/End"

/**
 * Check a rig: J >= 1, parents in depth-first order, finite offsets, trans_joints strictly
 * increasing in [1, J), End Site parents in [0, J), arrays present where counts are nonzero.
 * @return MLR_OK; MLR_E_INVALID_ARG (reason in diag)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_rig_check(const mlr_rig *rig, mlr_diag *diag);

/**
 * Find a point by name: "Joint" gives (joint, -1), "Joint/End" (joint, its first End Site).
 * @param joint     [out] joint index
 * @param end_site  [out] End Site index, or -1 for the joint itself
 * @return MLR_OK; MLR_E_INVALID_ARG (no names, no such joint, the joint has no End Site;
 *         reason in diag)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_rig_find_point(const mlr_rig *rig, const char *name, int32_t *joint,
                                      int32_t *end_site, mlr_diag *diag);

/**
 * World positions of points (joints or End Sites) from forward kinematics:
 * out[f][c] = world_pos[f][joint] + rotate(world_rot[f][joint], end_site_offsets[e]).
 * @param world_pos  [in] N x J x 3
 * @param world_rot  [in] N x J x 4; may be NULL when no point is an End Site
 * @param joints     [in] C joint indices
 * @param end_sites  [in] C End Site indices (-1: the joint itself), or NULL for all joints
 * @param out        [out] N x C x 3
 * @return MLR_OK; MLR_E_INVALID_ARG (index out of range, End Site not below its joint)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_rig_point_positions(const mlr_rig *rig, size_t n_frames,
                                           const double *world_pos, const double *world_rot,
                                           size_t n_points, const int32_t *joints,
                                           const int32_t *end_sites, double *out, mlr_diag *diag);

/**
 * Body size used to make thresholds unit-free: the median over frames of the joints' extent
 * along the up axis (End Sites excluded). A standing CMU subject is about 24 units.
 * @param world_pos  [in] N x J x 3, N >= 1
 * @param up         [in] an mlr_axis
 * @param height     [out] the height (0 for a flat skeleton)
 * @param alloc      [in] for 2 N doubles of scratch; NULL for malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (N == 0, J == 0, bad axis, non-finite positions);
 *         MLR_E_NO_MEMORY
 * Allocates: 2 N doubles, released before return. Threads: any.
 */
MLR_API mlr_status mlr_rig_body_height(size_t n_frames, size_t n_joints, const double *world_pos,
                                       int up, double *height, const mlr_allocator *alloc,
                                       mlr_diag *diag);

/** Relative size of "rounding" for mlr_rig_body_translation_joint: a translation varies when
 *  one of its coordinates spans more than this times the rest pose's size over the frames. */
#define MLR_RIG_TRANSLATION_ROUNDING 1e-5

/**
 * The joint that carries the body translation. Most rigs move the root; some keep a static
 * root above a moving pelvis (Bandai: `joint_Root` stays at the origin, the walk is in the
 * position channels of `Hips`). The answer is:
 *  - the root, when one coordinate of root_pos spans more than rounding over the frames;
 *  - else the topmost (fewest ancestors; the first in joint order among equals) of the trans
 *    joints whose translation spans more than rounding;
 *  - else the root.
 * "Rounding" is MLR_RIG_TRANSLATION_ROUNDING times the size of the rest pose (the largest
 * extent along an axis of the joints and End Sites placed by their OFFSETs, the root at the
 * origin; a unit-free body size), or times the largest |translation| in the data when the rest
 * pose has no extent. Channel values that only repeat an OFFSET with float noise (Bandai's
 * non-root joints: a few 1e-12) are rounding; a capture moving its pelvis is far beyond it.
 * @param rig       [in] a valid rig (mlr_rig_check)
 * @param n_frames  [in] N, may be 0 (the answer is then the root)
 * @param root_pos  [in] N x 3 root translations, or NULL for a static root
 * @param trans     [in] N x P x 3 translations of rig->trans_joints (P = rig->n_trans), in
 *                  that order (the layout of mlr_motion_trans); NULL allowed when P or N is 0
 * @param joint     [out] the joint index (0 for the root)
 * @return MLR_OK; MLR_E_INVALID_ARG (joint NULL, an invalid rig, trans NULL with P, N > 0,
 *         a translation not finite; reason in diag)
 * Allocates: never. Cost O(N (1 + P) + J depth). Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_rig_body_translation_joint(const mlr_rig *rig, size_t n_frames,
                                                  const double *root_pos, const double *trans,
                                                  int32_t *joint, mlr_diag *diag);

/** How mlr_rig_up_axis decided (pinned values). */
typedef enum mlr_up_method {
    MLR_UP_NONE = 0,  /**< nothing to go by (no frames, a flat skeleton): Y, confidence 0 */
    MLR_UP_FEET = 1,  /**< the feet (joints named foot, ankle, toe, paw or hoof) hang below
                           their hips: up is opposite their mean offset from them */
    MLR_UP_FLOOR = 2  /**< no foot names: the side along which the lowest joint stays at one
                           height (the floor) while the other sides move */
} mlr_up_method;

/** The answer of mlr_rig_up_axis. */
typedef struct mlr_up_guess {
    int axis;          /**< an mlr_axis */
    int sign;          /**< +1: up is +axis; -1: up is -axis (the file stands upside down) */
    double confidence; /**< 0..1; MLR_RIG_UP_SURE or more: trust it */
    int method;        /**< an mlr_up_method */
} mlr_up_guess;

/** Confidence from which mlr_rig_up_axis's guess is taken rather than reported as unsure. */
#define MLR_RIG_UP_SURE 0.8

/**
 * The up axis of a motion, from its world positions (Y-up, Z-up and X-up files alike).
 *  - With feet by name: d, the sum over frames and feet of the foot's offset from the joint
 *    its leg hangs from (its grandparent: ankle, knee, hip; a leg of a biped or a quadruped,
 *    whatever the torso does), points down; the axis is d's largest component, up its
 *    opposite sign; confidence is that component over |d| (1: straight down the axis; 0.58:
 *    along a diagonal). Where that stands the clip upside down, yet on 15% of the frames or
 *    more the legs hang straight down another axis (within about 25 degrees, feet below their
 *    hips) and on none down this one, that other axis is up, with a confidence of at least
 *    MLR_RIG_UP_SURE: a body that stood and then lay down for longer (a game's death clip)
 *    summed to an upside-down lie. Depth cameras' and video estimates' upside-down clips keep
 *    their verdict.
 *  - Without: for each axis and side, the spread over frames (5% to 95% quantile) of the
 *    lowest (or highest) joint along it, over the body's median extent along it; the floor is
 *    the side with the smallest spread; confidence 1 - smallest / smallest of the other axes.
 * @param rig        [in] a valid rig (names used when present)
 * @param n_frames   [in] N
 * @param world_pos  [in] N x J x 3 (mlr_fk_arrays)
 * @param out        [out] the guess; Y with confidence 0 and MLR_UP_NONE when N is 0 or the
 *                   positions have no extent
 * @param alloc      [in] for scratch (3 N doubles, without feet names); NULL: malloc/free
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arguments, an invalid rig, non-finite positions:
 *         reason in diag); MLR_E_NO_MEMORY
 * Allocates: scratch only, released before return. Cost O(N J). Threads: any.
 */
MLR_API mlr_status mlr_rig_up_axis(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                                   mlr_up_guess *out, const mlr_allocator *alloc, mlr_diag *diag);

/**
 * The depth-first order of a joint tree given in any order (SMPL's joint list, a glTF node
 * list, parents after their children), for building a rig or a motion, which take joints in
 * depth-first order: joint k of that order is input joint order[k]. The root comes first and
 * each joint's subtree right after it; siblings keep their input order, so a tree already in
 * depth-first order gives the identity. Reorder the per-joint arrays by it and map each parent
 * p to the k with order[k] == p.
 * @param n_joints  J >= 1
 * @param parents   [in] J parent indices, -1 for the one root, any order
 * @param names     [in] J joint names for the messages, or NULL
 * @param order     [out] J joint indices (undefined on failure)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL arrays, J = 0, a parent outside -1..J-1, no root or
 *         two roots, a joint its own parent, a cycle: diag names the joint); MLR_E_OVERFLOW
 *         (J above INT32_MAX); MLR_E_NO_MEMORY
 * Allocates: scratch only (J + 1 sizes, 2 J indices), released before return. Cost O(J).
 * Threads: any.
 */
MLR_API mlr_status mlr_rig_depth_first_order(size_t n_joints, const int32_t *parents,
                                             const char *const *names, int32_t *order,
                                             const mlr_allocator *alloc, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_RIG_H */
