/*
 * Joint limits (paper 1, section 6.1): a range per joint that style modulation may exaggerate
 * into and not past, applied with a soft saturation that keeps the motion C1.
 *
 * The model, per joint j (rotations local to the parent, as in a motion):
 *
 *   free         no limit: the root segment (joint 0, the global orientation), joints named
 *                hips/hip/pelvis/root, and joints the user frees.
 *   hinge        knees and elbows. The thigh vector a = the joint's own translation (in the
 *                parent's frame) and the shin vector s = q_j b, b the translation of its main
 *                child (the child farthest from it; an End Site when it has no child). The
 *                hinge axis n (parent frame) is learned from the input: the direction of the
 *                sum over frames of a x s, so the input bends mostly the positive way. The hinge
 *                angle phi is the signed angle about n from a to s, both projected on the plane
 *                normal to n (phi = 0: straight; for a perfect hinge |phi| is the angle between
 *                the thigh and shin vectors). Range [lo, hi]: lo = min(0, the input's smallest
 *                phi) (never bend the other way beyond the input's own largest reversal),
 *                hi = max(fold, the input's largest phi), fold = 150 degrees by default (what a
 *                human knee or elbow reaches). Limiting rotates q_j about n only:
 *                q' = R(n, phi' - phi) q_j, so the other components of the rotation are kept.
 *                Angles are read in [m - 2 pi, m), m the middle of the excluded arc
 *                (hi, lo + 2 pi), so a fold past 180 degrees is still a fold; over the frames
 *                of one call, an angle outside [lo, hi] is read in the branch nearest the
 *                frame before (unwrapped in time), so a trajectory that swings through the
 *                excluded arc stays on its side (streams read each frame on its own). Twists
 *                beyond their bound are unwrapped alike.
 *   swing-twist  every other joint with a bone: r = conj(c_j) q_j is the rotation from the
 *                joint's centre c_j (the input's mean rotation), split as r = swing * twist
 *                with the twist about the bone direction b (the main child's translation, in
 *                the joint's frame). The swing angle is limited to `swing`, |twist| to `twist`.
 *                A joint without a bone (no child, no End Site, or zero length) limits the
 *                whole angle of r to `swing`.
 *
 * Where the bounds come from (mlr_limits_range.source):
 *   human rigs (decided from the names and proportions, see MLR_LIMITS_OPT_HUMAN): hips,
 *       shoulders, clavicles, spine, neck, wrists, ankles and toes from published ranges of
 *       motion (limits_human.c: the table and its sources), half the total arc of the joint's
 *       largest plane about the centre (spine and neck shared among their joints); never below
 *       the input's own largest deviation / (1 - soft), so the input itself is not limited.
 *       These bounds do not widen with alpha: a body cannot go further.
 *   other joints and non-human rigs (a dog): the input's largest swing and twist about the
 *       centre, / (1 - soft), at least 5 degrees, and widened by max(1, |alpha_j|) at apply
 *       time (widen = 1): an exaggerated motion stays exaggerated.
 *   the user: mlr_limits_set_range.
 *
 * Soft saturation. A bound B with soft width w (w = soft * B for swing and twist,
 * soft * (hi - lo) at a hinge's fold side, MLR_LIMITS_OPT_REVERSAL_SOFT at its reversal side):
 * x is unchanged up to the knee point k = B - w, above it y = k + w tanh((x - k) / w). The map
 * is C-infinity except at k where it is C2 (tanh'(0) = 1, tanh''(0) = 0), increasing, and
 * y < B for every x (y rounds to B only far beyond it, x - k > 19 w): no clip. Each frame is mapped on its own (no state), so the same
 * function serves batch synthesis and streams (mlr_stream_set_limits).
 *
 * Arrays are row-major float64; quaternions scalar-first (w, x, y, z); angles in radians.
 */
#ifndef MLR_LIMITS_H
#define MLR_LIMITS_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Joint ranges for a rig. Opaque. Read-only except through mlr_limits_set_range. */
typedef struct mlr_limits mlr_limits;

/** Kinds of range. Values pinned. */
typedef enum mlr_limits_kind {
    MLR_LIMITS_FREE = 0,
    MLR_LIMITS_HINGE = 1,
    MLR_LIMITS_SWING_TWIST = 2
} mlr_limits_kind;

/** Where a joint's range came from. Values pinned. */
typedef enum mlr_limits_source {
    MLR_LIMITS_SOURCE_NONE = 0,   /* free joints */
    MLR_LIMITS_SOURCE_TABLE = 1,  /* published human ranges (hinges of a human rig too) */
    MLR_LIMITS_SOURCE_INPUT = 2,  /* the input clips */
    MLR_LIMITS_SOURCE_USER = 3    /* mlr_limits_set_range */
} mlr_limits_source;

/** One joint's range. A frozen value type: fields are never reordered or removed. */
typedef struct mlr_limits_range {
    int kind;      /* an mlr_limits_kind */
    double lo;     /* hinge: smallest hinge angle, radians, (-pi, hi) */
    double hi;     /* hinge: largest hinge angle, radians, (lo, pi] */
    double swing;  /* swing-twist: largest swing angle from the centre, (0, pi] */
    double twist;  /* swing-twist: largest |twist| about the bone from the centre, (0, pi] */
    int widen;     /* swing-twist: nonzero scales swing and twist by max(1, |alpha|) at apply
                      time (capped at pi); hinges ignore it */
    int source;    /* an mlr_limits_source; written by get, ignored by set */
} mlr_limits_range;

/** One input clip. rot: N x J x 4 local rotations, finite and nonzero. trans: N x P x 3 local
 *  translations of the rig's trans joints (they replace those joints' offsets when measuring
 *  bones: their mean over the frames is used), or NULL to use the offsets. A frozen value
 *  type. */
typedef struct mlr_limits_clip {
    size_t n_frames;
    const double *rot;
    const double *trans;
} mlr_limits_clip;

/** Option keys of mlr_limits_create. Values pinned; new options get new values. */
typedef enum mlr_limits_key {
    MLR_LIMITS_OPT_HUMAN = 1,          /* -1 decide (default), 0 not human, 1 human */
    MLR_LIMITS_OPT_FOLD = 2,           /* hinge fold bound, radians in (0, pi]; 150 degrees */
    MLR_LIMITS_OPT_SOFT = 3,           /* soft width as a fraction of a bound, (0, 1); 0.15 */
    MLR_LIMITS_OPT_REVERSAL_SOFT = 4   /* soft width at a hinge's reversal bound, radians,
                                          (0, pi/2]; 10 degrees */
} mlr_limits_key;

/** One option: key (an mlr_limits_key) and its value. A frozen value type. */
typedef struct mlr_limits_option {
    int key;
    double value;
} mlr_limits_option;

/**
 * Build the ranges of a rig from one or more clips of it (see the top of this file).
 * Human or not: MLR_LIMITS_OPT_HUMAN, else human when no joint name contains "tail", a knee
 * (or leg/shin/calf) and an elbow (or forearm/lowerarm) hinge are found and the arm (upper arm +
 * forearm) is shorter than 0.85 of the leg (thigh + shin); a dog's front legs are about as
 * long as its hind legs, a human arm about 0.65 of the leg. Hinges: joints named
 * knee/shin/calf/elbow/forearm/lowerarm/lowerleg or *leg* (not up/upper/thigh) whose centred
 * rotation vectors have at least 0.5 of their second moment about one axis within 35 degrees
 * of the learned hinge axis; a rig without names takes joints with a thigh and a shin, at least
 * 0.9 of the moment about one axis and 30 degrees of range.
 * @param rig      [in] the skeleton (mlr_rig_check); borrowed, not kept
 * @param clips    [in] n_clips >= 1 clips, each N >= 1 frames
 * @param opts     [in] n_opts options, a key at most once; NULL when n_opts is 0
 * @param alloc    [in] allocator, copied; NULL for malloc/free
 * @param out      [out] new handle, NULL on failure
 * @param diag     [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, no clips, N == 0, NULL rot, non-finite or zero
 *         quaternions, non-finite trans, unknown/repeated/out-of-range option, out NULL);
 *         MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: the handle (about 24 J doubles) and J doubles of scratch. Cost O(N J) per clip.
 * Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_limits_create(const mlr_rig *rig, const mlr_limits_clip *clips,
                                     size_t n_clips, const mlr_limits_option *opts, size_t n_opts,
                                     const mlr_allocator *alloc, mlr_limits **out, mlr_diag *diag);

/** Joints J of the limits (0 for NULL). */
MLR_API size_t mlr_limits_n_joints(const mlr_limits *lim);

/** 1 when the rig was taken as human (table ranges), 0 otherwise or for NULL. */
MLR_API int mlr_limits_is_human(const mlr_limits *lim);

/**
 * A joint's range.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, joint out of range)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_limits_get_range(const mlr_limits *lim, size_t joint,
                                        mlr_limits_range *out);

/**
 * Set a joint's range explicitly (source becomes MLR_LIMITS_SOURCE_USER). A hinge keeps the
 * learned axis and needs the joint to have a thigh and a shin vector.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, joint out of range, unknown kind, bounds not finite
 *         or outside the ranges of mlr_limits_range, a hinge on a joint without the two
 *         bones; nothing changed, reason in diag)
 * Allocates: never. Threads: one writer, no concurrent readers.
 */
MLR_API mlr_status mlr_limits_set_range(mlr_limits *lim, size_t joint,
                                        const mlr_limits_range *range, mlr_diag *diag);

/**
 * The learned geometry of a joint (any pointer may be NULL to skip it).
 * @param centre   [out] 4: the centre rotation c_j (unit quaternion)
 * @param axis     [out] 3: the hinge axis n in the parent's frame (unit; zero when the joint has
 *                 no thigh and shin vectors)
 * @param bone_in  [out] 3: the thigh vector a (the joint's translation, parent frame)
 * @param bone_out [out] 3: the shin vector b (main child's translation, joint frame; zero if
 *                 none)
 * @param stats    [out] 4: the input's smallest and largest hinge angle, the largest swing and
 *                 the largest |twist| about the centre (radians; 0 where not defined). The
 *                 hinge angles are measured on the hinge candidates only: the joints named as
 *                 hinges (knee, elbow; every joint but the root when the rig has no names) that
 *                 have an axis; they are 0 on every other joint.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, joint out of range)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_limits_get_geometry(const mlr_limits *lim, size_t joint, double *centre,
                                           double *axis, double *bone_in, double *bone_out,
                                           double *stats);

/**
 * Limit N frames of local rotations (soft saturation, see the top of this file).
 * @param rot_in   [in] N x J x 4 rotations, finite and nonzero (normalized here: one whose
 *                 |q|^2 is within 4 DBL_EPSILON of 1 is taken as it is)
 * @param rot_out  [out] N x J x 4; may be rot_in (in place). A joint within its knee points
 *                 is copied unchanged (normalized), others are limited.
 * @param alpha    [in] the synthesis scales: n_alpha = 1 (every joint) or 1 + J (the root
 *                 translation first, as mlr_layers_synthesize; it is ignored); NULL with
 *                 n_alpha 0 for alpha 1. Widen swing-twist ranges with widen set.
 * @param counts   [out] J counts: frames in which the joint was changed; NULL to skip
 * @param n_counts [in] J when counts is not NULL
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle or arrays, wrong counts, alpha non-finite,
 *         a non-finite or zero quaternion: nothing written, reason in
 *         diag)
 * Allocates: never. Threads: handle only read; outputs distinct per thread.
 */
MLR_API mlr_status mlr_limits_apply(const mlr_limits *lim, size_t n_frames, const double *rot_in,
                                    double *rot_out, const double *alpha, size_t n_alpha,
                                    size_t *counts, size_t n_counts, mlr_diag *diag);

/** Release the handle. NULL is a no-op. */
MLR_API void mlr_limits_destroy(mlr_limits *lim);

#ifdef __cplusplus
}
#endif

#endif /* MLR_LIMITS_H */
