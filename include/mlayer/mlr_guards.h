/*
 * Plausibility guards of a synthesized motion: what makes the output of style modulation,
 * denoising and generation fit for a body, in one place, with the defaults mlayer's Python
 * package uses (so a runtime on the C ABI gets the same motion):
 *
 *   1. joint limits (mlr_limits.h): hinges that never bend the other way, swing/twist ranges,
 *      a soft saturation; by default only when some |alpha| > 1, the one case where synthesis
 *      leaves the range of the input;
 *   2. foot contacts (mlr_contacts.h, mlr_cleanup.h): the contacts of the input, found once at
 *      create, pinned by two-bone IK with the corrections blended in time;
 *   3. the floor (mlr_cleanup.h): a flat floor from the input's contacts (or given); no foot
 *      point goes below it where the reference's did not: IK on the legs first, and where the
 *      limited legs cannot keep a foot up (an exaggerated crouch would need a knee folded
 *      past its range), the whole body is raised, smoothly.
 *
 * Use, per input clip (the handle keeps copies of everything it needs):
 *
 *     mlr_layers_decompose(...)                    the layers of the input
 *     mlr_layers_repair(layers, copy of input)     its outlier frames replaced by the
 *                                                  denoised ones (what mlayer does)
 *     mlr_guards_create(rig, fps, repaired, ...)   contacts, floor and limits of the input
 *     mlr_layers_synthesize(layers, alpha, ...)    M' = Mb (+) alpha delta_c
 *     mlr_guards_apply(guards, alpha, NULL, M')    M' made plausible, in place
 *
 * The reference of apply is the motion whose foot trajectories the pinned feet follow during
 * contacts (shifted horizontally by one offset per contact, toward where the synthesized foot
 * is). NULL (what mlayer uses) is the input, smoothed over 0.02 s against its capture noise;
 * a given reference is followed as it is. Per foot and contact, the synthesized foot keeps its
 * own trajectory where that slides no more than the reference's (MLR_CLEANUP_OPT_KEEP_STILLER):
 * so the feet slide at most as much as the input's, and an input that does not slide comes out
 * of denoise as it went in.
 *
 * Rigs whose body translation rides on a non-root joint (position channels of "Hips" under a
 * static root): the frames here are whole motions (root_pos, rot and every trans joint), so
 * whichever joint carries the translation, forward kinematics and the cleanup see it. The
 * cleanup moves the body through root_pos in mlr_guards_apply, and through the body joint's
 * translation in mlr_guards_apply_trans (the static root then stays where it is).
 *
 * Arrays are row-major float64; quaternions scalar-first (w, x, y, z).
 */
#ifndef MLR_GUARDS_H
#define MLR_GUARDS_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_limits.h"
#include "mlr_rig.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The guards of one input clip. Opaque. */
typedef struct mlr_guards mlr_guards;

/** Modes of MLR_GUARDS_OPT_LIMITS. Values pinned. */
typedef enum mlr_guards_limits_mode {
    MLR_GUARDS_LIMITS_OFF = 0,
    MLR_GUARDS_LIMITS_AUTO = 1,   /* when some |alpha| > 1 (the default) */
    MLR_GUARDS_LIMITS_ALWAYS = 2
} mlr_guards_limits_mode;

/** Option keys of mlr_guards_create. Values pinned; new options get new values. */
typedef enum mlr_guards_key {
    MLR_GUARDS_OPT_UP = 1,            /* the up axis, an mlr_axis; default MLR_AXIS_Y */
    MLR_GUARDS_OPT_LIMITS = 2,        /* an mlr_guards_limits_mode; default AUTO */
    MLR_GUARDS_OPT_KEEP_CONTACTS = 3, /* 1: pin the feet during the input's contacts (default),
                                         0: do not */
    MLR_GUARDS_OPT_FLOOR = 4,         /* 1: keep the feet above the floor (default), 0: do not */
    MLR_GUARDS_OPT_FLOOR_HEIGHT = 5,  /* finite: the floor's height along the up axis; default:
                                         from the input's contacts (mlr_cleanup_floor_height,
                                         quantile 0.05) */
    MLR_GUARDS_OPT_FOLLOW = 6         /* 1: pinned feet follow the reference's trajectories
                                         (default); 0: each contact point is pinned at its mean
                                         position over the contact, and no reference is used
                                         (generated motion, whose own feet skate) */
} mlr_guards_key;

/** One option: key (an mlr_guards_key) and its value. A frozen value type. */
typedef struct mlr_guards_option {
    int key;
    double value;
} mlr_guards_option;

/** What one mlr_guards_apply did. A frozen value type: fields are never reordered or
 *  removed. */
typedef struct mlr_guards_report {
    int limits_applied;     /* 1 when the joint limits ran */
    size_t limited_joints;  /* joints changed by the limits in some frame */
    size_t limited_frames;  /* the most frames any one joint was limited in */
    size_t contact_frames;  /* frames where some foot was pinned */
    size_t floor_frames;    /* frames where some foot was raised to the floor */
    double floor_height;    /* the floor used; NaN when the floor guard was off or unknown */
    double root_shift_max;  /* the largest root correction of the cleanup (length units) */
    size_t floor_raised;    /* frames where a foot point, or any joint or End Site, was still
                               below the floor (beyond the input's own depth there) after the
                               other guards, so the whole body was raised */
} mlr_guards_report;

/**
 * Prepare the guards of an input clip (the long form of mlr_guards_create_from, kept for the
 * ABI of 0.2): copies the rig and the frames, finds the feet by joint
 * name (mlr_contacts_find_feet; a rig without recognisable feet gets no contact and no floor
 * guard, which is not an error), detects their contacts (mlr_contacts_detect, default
 * thresholds), estimates the floor from them, and learns the joint limits from the clip
 * (mlr_limits_create, default options).
 * @param rig       [in] the skeleton (mlr_rig_check; names needed to find feet and hinges);
 *                  copied
 * @param fps       [in] frame rate, finite, > 0
 * @param n_frames  [in] N >= 3
 * @param root_pos  [in] N x 3 root translations; copied
 * @param rot       [in] N x J x 4 local rotations, finite and nonzero; copied
 * @param trans     [in] N x P x 3 translations of the rig's trans joints (NULL when P is 0);
 *                  copied
 * @param opts      [in] n_opts options, a key at most once; NULL when n_opts is 0
 * @param alloc     [in] allocator, copied; NULL for malloc/free
 * @param out       [out] new handle, NULL on failure
 * @param diag      [out] optional: the reason of an error; on MLR_OK an empty message, or a
 *                  note naming a guard that cannot run and is skipped (no foot found: the
 *                  contacts and the floor), for the caller to show as a warning
 * @return MLR_OK; MLR_E_INVALID_ARG (bad rig, fps, N < 3, NULL or non-finite frames, unknown
 *         or repeated key, bad option value); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: the handle with copies of the rig and the frames (about N (4 J + 3 P + 3) doubles),
 * the contacts (N C bytes) and the input's contact point and ankle trajectories that apply
 * reads as its default reference (about N (4 C + 6) doubles); while running, forward
 * kinematics (7 N J doubles).
 * Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_guards_create(const mlr_rig *rig, double fps, size_t n_frames,
                                     const double *root_pos, const double *rot,
                                     const double *trans, const mlr_guards_option *opts,
                                     size_t n_opts, const mlr_allocator *alloc, mlr_guards **out,
                                     mlr_diag *diag);

/** Contact points C the handle pins (0 when the rig has no feet or contacts are off). */
MLR_API size_t mlr_guards_n_points(const mlr_guards *g);

/**
 * The contact points and the input's contacts (any pointer may be NULL to skip it).
 * @param joints     [out] C joint indices
 * @param end_sites  [out] C End Site indices or -1
 * @param contacts   [out] N x C, 1 in contact
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle). Allocates: never.
 */
MLR_API mlr_status mlr_guards_get_contacts(const mlr_guards *g, int32_t *joints,
                                           int32_t *end_sites, uint8_t *contacts);

/**
 * Replace the contact points and contacts (an override list, or contacts found another way).
 * n_points 0 removes them (no contact pinning; the floor then needs MLR_GUARDS_OPT_FLOOR_HEIGHT).
 * The floor height is estimated again from the new contacts unless it was given.
 * @param joints, end_sites [in] C points (end_sites NULL: all joints); checked against the rig
 * @param contacts  [in] N x C, nonzero in contact
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle or arrays, a point that names nothing, a point
 *         listed twice; nothing changed); MLR_E_NO_MEMORY (nothing changed)
 * Allocates: N C bytes, C indices and the new points' trajectories (about N (4 C + 6)
 * doubles). Threads: one writer, no concurrent apply.
 */
MLR_API mlr_status mlr_guards_set_contacts(mlr_guards *g, size_t n_points, const int32_t *joints,
                                           const int32_t *end_sites, const uint8_t *contacts,
                                           mlr_diag *diag);

/**
 * Use other joint limits than the ones learned at create (explicit ranges, or limits learned
 * from several clips). The handle is borrowed, not copied: it must outlive every later apply.
 * NULL goes back to the learned limits.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, limits for another number of joints)
 * Allocates: never. Threads: one writer, no concurrent apply.
 */
MLR_API mlr_status mlr_guards_set_limits(mlr_guards *g, const mlr_limits *limits, mlr_diag *diag);

/**
 * Make N synthesized frames (the input's frames, synthesized with alpha) plausible, in place:
 * joint limits (by mode and alpha), then the contacts and the floor in one cleanup. The long
 * form of mlr_guards_run, kept for the ABI of 0.2: new code fills an mlr_guards_job.
 * @param alpha     [in] the synthesis scales: 1 value or 1 + J (the root translation first, as
 *                  mlr_layers_synthesize), finite
 * @param ref_root_pos, ref_rot, ref_trans [in] the reference at the same frames (see the top
 *                  of this file), or all NULL for the input (ref_trans NULL when P is 0)
 * @param root_pos  [in/out] N x 3
 * @param rot       [in/out] N x J x 4 unit quaternions
 * @param trans     [in] N x P x 3 (NULL when P is 0): kept as they are
 * @param limited   [out] J counts of frames each joint was limited in, or NULL
 * @param n_limited [in] J when limited is not NULL
 * @param report    [out] optional
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle or arrays, wrong counts, non-finite alpha or
 *         frames: the frames are then unchanged); MLR_E_NO_MEMORY (frames unchanged);
 *         MLR_E_OVERFLOW
 * Allocates: scratch of about N (18 J + 12 C + 44) doubles and N J bytes, released before
 * return.
 * Threads: the handle is only read: threads may apply concurrently on separate frames.
 */
MLR_API mlr_status mlr_guards_apply(const mlr_guards *g, const double *alpha, size_t n_alpha,
                                    const double *ref_root_pos, const double *ref_rot,
                                    const double *ref_trans, double *root_pos, double *rot,
                                    const double *trans, size_t *limited, size_t n_limited,
                                    mlr_guards_report *report, mlr_diag *diag);

/**
 * mlr_guards_apply with the translations in and out: where the input's body translation rides
 * on a joint below a static root (mlr_rig_body_translation_joint; Bandai's Hips under
 * joint_Root), the body's shifts (the cleanup lowering the body toward planted feet, the floor
 * raising it) go into that joint's translation, in its parent's frame, and root_pos keeps the
 * synthesis's values: the static root stays where it is instead of moving under the floor with
 * the body. The body joint and everything below it end where mlr_guards_apply puts them. On
 * rigs whose root carries the body translation, trans is left as it is and the result is
 * mlr_guards_apply's. What mlayer's Python pipeline calls.
 * @param trans     [in/out] N x P x 3 (NULL when P is 0)
 * Other parameters, return values, allocation and threads: as mlr_guards_apply.
 */
MLR_API mlr_status mlr_guards_apply_trans(const mlr_guards *g, const double *alpha, size_t n_alpha,
                                          const double *ref_root_pos, const double *ref_rot,
                                          const double *ref_trans, double *root_pos, double *rot,
                                          double *trans, size_t *limited, size_t n_limited,
                                          mlr_guards_report *report, mlr_diag *diag);

/** The input clip of a guards handle (mlr_guards_create_from): the rig, the frame rate, the
 *  input's frames (N = frames.n_frames >= 3) and the options. Borrowed for the call (create
 *  copies what it keeps). A frozen value type. Since 0.3 */
typedef struct mlr_guards_input {
    const mlr_rig *rig;
    double fps;
    mlr_frames frames;
    const mlr_guards_option *opts; /* n_opts options, a key at most once; NULL when n_opts is 0 */
    size_t n_opts;
} mlr_guards_input;

/**
 * mlr_guards_create with its arguments in one struct.
 * @return as mlr_guards_create; MLR_E_INVALID_ARG for a NULL input
 * Allocates, threads: as mlr_guards_create.
 */
MLR_API mlr_status mlr_guards_create_from(const mlr_guards_input *input,
                                          const mlr_allocator *alloc, mlr_guards **out,
                                          mlr_diag *diag);

/** A guards job, in the manner of ozz-animation's jobs: what mlr_guards_apply and
 *  mlr_guards_apply_trans take, in one struct, for mlr_guards_run (zero what you do not use:
 *  `mlr_guards_job job = {0};`). Every pointer is borrowed for the call. A frozen value type.
 *  Since 0.3 */
typedef struct mlr_guards_job {
    const double *alpha; /* the synthesis scales: 1 value or 1 + J, finite */
    size_t n_alpha;
    mlr_frames reference; /* the reference at the handle's N frames, or all NULL with
                                    n_frames 0 for the input */
    double *root_pos; /* [in/out] N x 3 */
    double *rot; /* [in/out] N x J x 4 unit quaternions */
    double *trans; /* N x P x 3 (NULL when P is 0): read, or [in/out] with
                                    body_on_trans */
    int body_on_trans; /* nonzero: the body's shifts go into the translation of the
                                    joint that carries the body (mlr_guards_apply_trans); 0:
                                    into root_pos, trans kept (mlr_guards_apply) */
    size_t *limited; /* [out] J counts of frames each joint was limited in, or NULL */
    size_t n_limited; /* J when limited is not NULL */
    mlr_guards_report *report; /* [out] optional */
} mlr_guards_job;

/**
 * Check a guards job against its handle as mlr_guards_run would, without running it.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle or job, a reference for other frames, or what
 *         mlr_guards_apply refuses; reason in diag)
 * Allocates: never. Threads: as mlr_guards_apply.
 */
MLR_API mlr_status mlr_guards_job_validate(const mlr_guards *g, const mlr_guards_job *job,
                                           mlr_diag *diag);

/**
 * Run a guards job: mlr_guards_apply_trans (body_on_trans) or mlr_guards_apply with the job's
 * fields, the same bits.
 * @return as mlr_guards_apply; MLR_E_INVALID_ARG for a NULL job or a reference for other frames
 * Allocates, threads: as mlr_guards_apply.
 */
MLR_API mlr_status mlr_guards_run(const mlr_guards *g, const mlr_guards_job *job, mlr_diag *diag);

/** Release the handle. NULL is a no-op. */
MLR_API void mlr_guards_destroy(mlr_guards *g);

#ifdef __cplusplus
}
#endif

#endif /* MLR_GUARDS_H */
