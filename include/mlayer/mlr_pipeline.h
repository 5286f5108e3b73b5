/*
 * The pipeline: one reusable job object that does what mlayer.stylize and mlayer.denoise do,
 * with the same defaults, so that a runtime gets Python's motion from one call:
 *
 *     mlr_pipeline *p;
 *     mlr_pipeline_create(NULL, &p, &diag);
 *     mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 2.0, &diag);          (1, the default: denoise)
 *     mlr_pipeline_set_joint_alpha(p, "Left*", 3.0, &diag);          (optional, by name or glob)
 *     mlr_motion *out = NULL;
 *     for each clip: mlr_pipeline_run(p, clip, &out, &diag);        (out reused clip after clip)
 *     mlr_motion_destroy(out);
 *     mlr_pipeline_destroy(p);
 *
 * What a run does, in order (the steps of docs/ARCHITECTURE.md, "The path of a clip"):
 *  1. trim (MLR_PIPELINE_TRIM): none by default; "auto" drops the converter's lead-in
 *     (mlr_trim_lead_in, along the up axis of the whole clip);
 *  2. the up axis (MLR_PIPELINE_UP): given, or detected from the clip's world positions
 *     (mlr_rig_up_axis; Y when it is not sure), as mlayer.Motion.up_axis;
 *  3. the joint that carries the body translation (mlr_rig_body_translation_joint);
 *  4. the layers (mlr_layers_decompose) with Python's options: gamma, the base floor of
 *     MLR_PIPELINE_BASE_CUTOFF at the clip's frame rate, the robust outlier search with the
 *     body height (mlr_rig_body_height along the up axis) as the translation's gate, the body
 *     joint; or layers decomposed elsewhere (mlr_pipeline_prepare);
 *  5. the guards (mlr_guards_create) learned from the input with its outlier frames repaired
 *     (mlr_layers_repair), with the switches below;
 *  6. the synthesis (mlr_layers_synthesize) with the alphas: MLR_PIPELINE_ALPHA (or the curve
 *     of mlr_pipeline_set_alpha_keys with no pattern) everywhere, MLR_PIPELINE_ROOT_ALPHA for
 *     the body translation, then each joint pattern in the order given (later patterns win),
 *     a constant or a curve; with a curve anywhere, mlr_layers_synthesize_frames with the
 *     alphas of every frame (see "Alpha over time" below); the body translation written to the
 *     joint that carries it;
 *  7. the guards applied (mlr_guards_apply_trans, the input as the reference: under a static
 *     root, the body's shifts go to the joint that carries the body translation);
 *  8. the runs at the clip's ends the layers left out (mlr_layers_get_end_runs: a converter's
 *     rest pose): the input's frames in a denoise (every alpha 1), else the result's pose next
 *     to each run held over it, raised by what its points would go deeper under the floor
 *     than the rest pose's (pipeline_ends.c).
 * Steps 1 to 5 are mlr_pipeline_prepare, 6 to 8 mlr_pipeline_synthesize, so that a second
 * alpha costs only a synthesis and the guards; mlr_pipeline_run does both.
 *
 * Alpha over time (paper 1, section 6.2: the final motion composited by changing the local
 * weights over time). mlr_pipeline_set_alpha_keys gives every group (no pattern) or the joints
 * of a pattern keyed alphas instead of a constant: (time, alpha) keys evaluated as
 * mlr_alpha_keys_eval does (the quintic smoothstep between keys, C2, within its two keys; held
 * before the first key and after the last), frame i of the prepared clip at i frame_time
 * seconds (after the trim: time 0 is the result's first frame). The synthesis is then
 * mlr_layers_synthesize_frames with one row of 1 + J alphas per frame. The guards run on its
 * result as for a constant alpha per group: the group's alpha of largest magnitude over the
 * clip. That is what each use of alpha in the guards means: the limits run when some |alpha|
 * exceeds 1 anywhere (MLR_GUARDS_LIMITS_AUTO), and ranges learned from the input widen by the
 * joint's max |alpha| (human published ranges never widen), so at frames where a curve is
 * below its peak the range is that of the peak: the limits never cut a frame that the peak's
 * constant alpha would keep, and a frame whose alpha is lower moves less far anyway; the
 * contacts follow the input smoothed unless every alpha is 1 at every frame (a denoise: a
 * curve whose peak is 1 but that is not 1 everywhere goes to the guards as the double just
 * below 1, which the limits read as 1 and the guards do not take for a denoise).
 * Keys all equal give the constant alpha's motion bit for bit, guards included.
 *
 * What stays in Python (mlayer.pipeline): the GuardReport's joint names (from
 * mlr_pipeline_report), the contact points given by name (contact_joints=: set them on
 * mlr_pipeline_guards with mlr_guards_set_contacts), joint limits given as an object
 * (mlr_guards_set_limits on mlr_pipeline_guards), the viewer's "residual kept" synthesis, the
 * figures (jitter, foot sliding). Reading and writing files are the caller's (mlr_bvh.h).
 *
 * Memory. Every allocation of a run (the layers, the guards, their scratch, the pipeline's
 * copy of the clip and its buffers) goes through the pipeline's allocator and is kept for the
 * next run when released: a run allocates from the caller's allocator only when it needs more
 * than the runs before it (a clip with more frames or joints than any before). The result
 * goes into the caller's motion *out, overwritten in place when its block is large enough.
 *
 * Threads: a pipeline is used by one thread at a time; separate pipelines are independent.
 * The library keeps no global state; no function here prints, exits or aborts.
 */
#ifndef MLR_PIPELINE_H
#define MLR_PIPELINE_H

#include "mlr_common.h"
#include "mlr_guards.h"
#include "mlr_layers.h"
#include "mlr_motion.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A reusable job: parameters, and the clip it was last prepared on. Opaque. */
typedef struct mlr_pipeline mlr_pipeline;

/** Parameters of mlr_pipeline_set (their defaults are mlayer.stylize's), and what
 *  mlr_pipeline_get reports after a prepare (the MLR_PIPELINE_INFO_ keys, read-only). Values
 *  pinned; new keys get new values. */
typedef enum mlr_pipeline_param {
    MLR_PIPELINE_ALPHA = 1,         /* scale of the controllable layer, every joint and the body
                                       translation; finite (0: the base layer, 1: denoised, > 1
                                       exaggerated, < 0 inverted); default 1 */
    MLR_PIPELINE_ROOT_ALPHA = 2,    /* the body translation's alpha, finite; default: ALPHA
                                       (mlr_pipeline_clear_joint_alphas goes back to that) */
    MLR_PIPELINE_UP = 3,            /* the up axis, an mlr_axis, or -1 (default): detected */
    MLR_PIPELINE_TRIM = 4,          /* frames dropped at the start: an integer >= 0 (default
                                       0), or -1: the converter's lead-in (mlr_trim_lead_in) */
    MLR_PIPELINE_UNITS = 5,         /* the clip's length unit in metres, > 0, or 0 (default):
                                       unknown. Kept for the caller (mlr_pipeline_get); the
                                       result does not depend on it: every threshold is
                                       relative to the body height */
    MLR_PIPELINE_GUARDS = 6,        /* 1 (default): make and apply the guards; 0: the plain
                                       synthesis (the switches below are then not used) */
    MLR_PIPELINE_LIMITS = 7,        /* an mlr_guards_limits_mode; default AUTO */
    MLR_PIPELINE_FLOOR = 8,         /* 0: no floor guard; 1 (default): the floor from the
                                       input's contacts; 2: at MLR_PIPELINE_FLOOR_HEIGHT */
    MLR_PIPELINE_FLOOR_HEIGHT = 9,  /* finite: the floor's height along up when FLOOR is 2;
                                       default 0 */
    MLR_PIPELINE_KEEP_CONTACTS = 10, /* 1 (default): pin the feet during the input's contacts;
                                       0: do not */
    MLR_PIPELINE_ROBUST = 11,       /* 1 (default): outlier frames down-weighted
                                       (MLR_LAYERS_OPT_ROBUST); 0: off */
    MLR_PIPELINE_GAMMA = 12,        /* the base layer's angle bound, [pi/2, pi); default pi/2 */
    MLR_PIPELINE_LAM_C = 13,        /* fixed controllable-layer lam, > 0; 0 (default): GCV */
    MLR_PIPELINE_SIGMA_C = 14,      /* fixed controllable-layer sigma, > 0; 0 (default): GCV */
    MLR_PIPELINE_LAM_B = 15,        /* fixed base lam, > 0; 0 (default): the gamma heuristic */
    MLR_PIPELINE_SIGMA_B = 16,      /* fixed base sigma, > 0; 0 (default): the heuristic */
    MLR_PIPELINE_BASE_CUTOFF = 17,  /* the base floor in Hz, > 0 (below fps / 2); default
                                       0.25; 0: no floor (the layers' widest range) */
    MLR_PIPELINE_BODY_HEIGHT = 18,  /* the body height that scales the robust translation gate:
                                       > 0 given; 0 (default): measured; < 0: none (the
                                       layers' default gate) */
    MLR_PIPELINE_KEEP_MEMORY = 19,  /* 1 (default): keep the memory of the largest run for the
                                       next ones (see "Memory" above); 0: give the scratch back
                                       after each call (a pipeline used once, as mlayer's
                                       Python package uses them) */
    MLR_PIPELINE_INFO_UP = 100,     /* after a prepare: the up axis used (-1 when not needed) */
    MLR_PIPELINE_INFO_TRIMMED = 101, /* after a prepare: the frames dropped at the start */
    MLR_PIPELINE_INFO_FRAMES = 102, /* after a prepare: the frames of the result */
    MLR_PIPELINE_INFO_BODY_JOINT = 103, /* after a prepare: the joint of the body translation */
    MLR_PIPELINE_INFO_BODY_HEIGHT = 104 /* after a prepare: the body height given to the layers
                                           (NaN when none was) */
} mlr_pipeline_param;

/** Longest joint pattern, in bytes without its NUL. */
#define MLR_PIPELINE_MAX_PATTERN 127

/**
 * Create a pipeline with the default parameters.
 * @param alloc  [in] allocator, copied; it serves the pipeline's whole life, and the results
 *               it creates; NULL for malloc/free
 * @param out    [out] new handle, NULL on failure
 * @param diag   [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (out NULL); MLR_E_NO_MEMORY
 * Allocates: the handle. Threads: any.
 */
MLR_API mlr_status mlr_pipeline_create(const mlr_allocator *alloc, mlr_pipeline **out,
                                       mlr_diag *diag);

/**
 * Set a parameter (see mlr_pipeline_param for the values each takes).
 * Changing one that prepare uses (all but ALPHA, ROOT_ALPHA, UNITS and KEEP_MEMORY) after a
 * prepare leaves
 * the pipeline needing a new prepare: mlr_pipeline_synthesize then returns MLR_E_BAD_STATE.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, unknown or read-only key, value out of
 *         range: the diag names the parameter; nothing changed)
 * Allocates: never. Threads: one writer.
 */
MLR_API mlr_status mlr_pipeline_set(mlr_pipeline *p, mlr_pipeline_param param, double value,
                                    mlr_diag *diag);

/**
 * Read a parameter, or what the last prepare found (the MLR_PIPELINE_INFO_ keys; NaN before a
 * prepare).
 * @param value  [out] the value
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL argument, unknown key)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_pipeline_get(const mlr_pipeline *p, mlr_pipeline_param param,
                                    double *value);

/**
 * Give the joints whose name matches a pattern their own alpha. Patterns are Python's
 * fnmatch.fnmatchcase globs (`*`, `?`, `[abc]`, `[!abc]`, `[a-z]`; a name without them matches
 * itself only), applied after ALPHA in the order given, later ones winning. A pattern that
 * matches no joint of the clip makes mlr_pipeline_synthesize fail, naming it.
 * @param pattern  [in] NUL-terminated, at most MLR_PIPELINE_MAX_PATTERN bytes; copied
 * @param alpha    [in] finite
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, empty or too long pattern, alpha not finite:
 *         nothing changed); MLR_E_NO_MEMORY (nothing changed)
 * Allocates: the list of patterns, when it grows longer than it has been (kept until
 * mlr_pipeline_destroy; mlr_pipeline_clear_joint_alphas keeps it). Threads: one writer.
 */
MLR_API mlr_status mlr_pipeline_set_joint_alpha(mlr_pipeline *p, const char *pattern, double alpha,
                                                mlr_diag *diag);

/**
 * Give every group (pattern NULL: the body translation and every joint, in the place of
 * MLR_PIPELINE_ALPHA) or the joints whose name matches a pattern (in the list of
 * mlr_pipeline_set_joint_alpha, ordered with its constants, later ones winning) alphas that
 * change over time: keys (times[k] seconds from the clip's first frame after the trim,
 * values[k]), interpolated as mlr_alpha_keys_eval (see "Alpha over time" above and in
 * mlr_layers.h). MLR_PIPELINE_ROOT_ALPHA, when set, stays the body translation's constant; a
 * later mlr_pipeline_set of MLR_PIPELINE_ALPHA replaces the curve of every group with that
 * constant (mlr_pipeline_get of ALPHA is NaN while the curve is set). Changes no prepare.
 * @param pattern  [in] NULL, or as for mlr_pipeline_set_joint_alpha
 * @param times    [in] n_keys finite times in seconds, strictly increasing; copied
 * @param values   [in] n_keys finite alphas; copied
 * @param n_keys   [in] >= 1 (one key: a constant)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL p, bad pattern, no keys, a time or alpha not finite,
 *         times not increasing: the diag names the key; nothing changed); MLR_E_NO_MEMORY,
 *         MLR_E_OVERFLOW (nothing changed)
 * Allocates: the list of keys when it grows longer than it has been (kept until
 * mlr_pipeline_destroy; mlr_pipeline_clear_joint_alphas empties it). Threads: one writer.
 */
MLR_API mlr_status mlr_pipeline_set_alpha_keys(mlr_pipeline *p, const char *pattern,
                                               const double *times, const double *values,
                                               size_t n_keys, mlr_diag *diag);

/** Remove every joint pattern, every curve of alpha keys and the root alpha: ALPHA everywhere
 *  again. NULL is a no-op. Allocates: never. */
MLR_API void mlr_pipeline_clear_joint_alphas(mlr_pipeline *p);

/**
 * Steps 1 to 5 on a clip: trim, up axis, body joint, layers, guards. The pipeline keeps a copy
 * of the (trimmed) clip; `in` is not kept.
 * @param in      [in] the clip, at least 3 frames after the trim
 * @param layers  [in] NULL: decompose here with the pipeline's parameters; else the layers
 *                of the (trimmed) clip made elsewhere, borrowed (they must outlive the
 *                prepared state: the next prepare or destroy)
 * @param diag    [out] optional: the reason of an error; on MLR_OK an empty message, or the
 *                guards' note naming a guard that cannot run (no foot found)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle or clip, fewer than 3 frames, a trim that
 *         leaves fewer, layers of another size, a parameter the clip rules out such as a
 *         BASE_CUTOFF not below fps / 2, or what decompose and the guards refuse: the diag
 *         names it); MLR_E_SINGULAR; MLR_E_NO_MEMORY; MLR_E_OVERFLOW. On failure the pipeline
 *         is left unprepared.
 * Allocates: as said at the top. Threads: one caller per pipeline; `in` is only read.
 */
MLR_API mlr_status mlr_pipeline_prepare(mlr_pipeline *p, const mlr_motion *in,
                                        const mlr_layers *layers, mlr_diag *diag);

/**
 * Steps 6 and 7 on the prepared clip with the current alphas: the result, on the clip's
 * skeleton, its frames and frame time.
 * @param out   [in,out] NULL, or a motion from an earlier result (or any motion, owned by the
 *              caller): overwritten in place when its block is large enough, else replaced
 *              by a new motion (the old one destroyed) made with the pipeline's allocator.
 *              Unchanged on failure.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL argument, a joint pattern that matches no joint);
 *         MLR_E_BAD_STATE (not prepared, or a parameter changed since); MLR_E_NO_MEMORY;
 *         MLR_E_OVERFLOW
 * Allocates: the result when *out is NULL or too small; the guards' scratch through the
 *            pipeline's memory (as said at the top). Threads: one caller per pipeline.
 */
MLR_API mlr_status mlr_pipeline_synthesize(mlr_pipeline *p, mlr_motion **out, mlr_diag *diag);

/**
 * mlr_pipeline_prepare(p, in, NULL, diag) then mlr_pipeline_synthesize(p, out, diag): the
 * clip denoised or stylized, as mlayer.denoise / mlayer.stylize give it.
 * @param out  [in,out] as for mlr_pipeline_synthesize; must not be `in`
 * @return as the two; on failure *out is unchanged.
 */
MLR_API mlr_status mlr_pipeline_run(mlr_pipeline *p, const mlr_motion *in, mlr_motion **out,
                                    mlr_diag *diag);

/**
 * What the guards did in the last synthesis.
 * @param report     [out] optional; all zero (floor_height NaN) when the guards were off
 * @param limited    [out] optional: J counts of frames each joint was limited in
 * @param n_limited  [in] J when limited is not NULL
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, wrong count); MLR_E_BAD_STATE (no synthesis
 *         since the last prepare)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_pipeline_report(const mlr_pipeline *p, mlr_guards_report *report,
                                       size_t *limited, size_t n_limited);

/** The layers of the prepared clip (the pipeline's own, or those given to prepare), NULL when
 *  not prepared. Borrowed until the next prepare or destroy. Allocates: never. */
MLR_API const mlr_layers *mlr_pipeline_layers(const mlr_pipeline *p);

/** The guards of the prepared clip, NULL when not prepared or MLR_PIPELINE_GUARDS is 0.
 *  Borrowed until the next prepare or destroy; mlr_guards_set_contacts and
 *  mlr_guards_set_limits on it change what the next syntheses do. Allocates: never. */
MLR_API mlr_guards *mlr_pipeline_guards(mlr_pipeline *p);

/** Release the pipeline and everything it kept (not the results it gave). NULL is a no-op. */
MLR_API void mlr_pipeline_destroy(mlr_pipeline *p);

#ifdef __cplusplus
}
#endif

#endif /* MLR_PIPELINE_H */
