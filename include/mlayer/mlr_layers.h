/*
 * Motion layers (paper 1, section 4): a motion M = (root translation p, joint rotations q_j)
 * is decomposed into
 *
 *     M = (Mb (+) delta_c) (+) delta_r
 *
 * Mb        base layer: LGS (order 2) on the root translation and on each joint's
 *           hemisphere-aligned quaternion as 4 channels, renormalized (eq. 11);
 * delta     displacement M (-) Mb: u0 = p - pb for the root, v_j = log(conj(qb_j) q_j) for
 *           the joints (full-angle rotation vectors, eq. 13);
 * delta_c   controllable layer: LGS of the displacement channels (eq. 15);
 * delta_r   residual exp(delta) (-) exp(delta_c): u0 - uc for the root,
 *           r_j = log(conj(exp(vc_j)) exp(v_j)) for the joints.
 *
 * (+) is vector addition for translations and q * exp(v) for rotations. Synthesis (eq. 16, 17)
 * is M' = Mb (+) W delta_c with one alpha for the root translation and one per joint; alpha = 1
 * everywhere is the denoised motion.
 *
 * Smoothing strength. Every LGS here has identity observations, so its mean depends only on
 * s = lam^2 sigma^2 (the system is (I + s L^T L) x = y with L the second difference).
 *
 * Base layer, per joint (eq. 14): the strongest s in [BASE_S_MIN, BASE_S_MAX] whose largest
 * displacement angle max_t |v_j(t)| stays within gamma (default pi/2, valid [pi/2, pi)). The
 * paper uses one setting for the whole body; a setting per joint keeps a one-joint glitch
 * from weakening every other joint. The search runs all joints in lockstep: BASE_S_MAX first
 * (a joint within the bound there keeps it), then BASE_S_MIN (a joint beyond the bound even
 * there keeps it, see MLR_LAYERS_PARAM_BASE_MAX_ANGLE), then a bracketed secant (Illinois)
 * search on log s of log(max angle / gamma), nearly linear in log s, until the bracket
 * [s_ok, s_broken] is narrower than 4% in s. The reported s is s_ok: it satisfies the bound
 * and 1.04 s breaks it. The paper strengthens lam and sigma together from
 * lam = 1, sigma = 0.1; the reported pair is that path: lam = k, sigma = 0.1 k, k = (100 s)^(1/4).
 * The root translation has no angle to bound: it takes the s of joint 0, the root segment
 * whose orientation the same markers measure, so the pelvis translation and orientation are
 * smoothed alike. On rigs whose body translation rides on a non-root joint (a static root
 * above a moving pelvis, see mlr_rig_body_translation_joint), pass that joint's translation
 * as root_pos and its index as MLR_LAYERS_OPT_BODY_JOINT: the translation then takes that
 * joint's s.
 *
 * The base floor (fps-dependent default). Human joints rarely move gamma = 90 degrees from
 * their mean, so without a floor the heuristic picks BASE_S_MAX for nearly every joint and the
 * base layer becomes a straight line or parabola through the whole clip; exaggerating then
 * pushes the root far off its path. With MLR_LAYERS_OPT_FPS given, the upper end of the search
 * defaults to the s whose LGS halves the amplitude at the cutoff frequency fc
 * (MLR_LAYERS_OPT_BASE_CUTOFF, default 0.25 Hz: trends slower than about 4 s stay in the base):
 *
 *     BASE_S_MAX = (2 sin(pi fc / fps))^-4     (the gain 1 / (1 + s (2 sin(pi f/fps))^4)
 *                                               is 1/2 at f = fc)
 *
 * which is at least 1/16, above the default BASE_S_MIN. Precedence: LAM_B / SIGMA_B fix the base s and the search range is not used (FPS,
 * BASE_CUTOFF, BASE_S_MIN and BASE_S_MAX are validated, then ignored); an explicit BASE_S_MAX
 * replaces the floor of FPS (BASE_S_MAX together with BASE_CUTOFF is a conflict:
 * MLR_E_INVALID_ARG); an explicit BASE_S_MIN is kept and must stay below the floor's
 * BASE_S_MAX. To lift the floor, leave out FPS (the range is then [1e-2, 1e10]) or give FPS
 * with an explicit BASE_S_MAX.
 *
 * Controllable layer, per group (the root translation, then each joint; 3 channels each): s is
 * chosen by generalized cross-validation, GCV(s) = (RSS / 3N) / (1 - tr(H)/N)^2 with
 * H = (I + s L^T L)^-1 (tr(H) by selected inversion of the banded factor), minimized over
 * log s in [CONTROL_S_MIN, CONTROL_S_MAX]: a grid of one point per two decades, then Brent's
 * method around the best point to 5% in s. A group whose displacement is identically zero
 * gets s = 1. Explicit lam_c / sigma_c options replace GCV for every group (the paper uses
 * lam_c = sigma_c = 1). The reported pair is lam_c = sigma_c = s^(1/4).
 *
 * Outliers (MLR_LAYERS_OPT_ROBUST, on by default). Decoder glitches, marker swaps and one-frame
 * flips would pull every LGS towards them and, through the base heuristic's angle bound, weaken
 * the smoothing of their joint for the whole clip. Before the layers, each group (the body
 * translation, each joint) is fitted by a light LGS (half power at 2 Hz given FPS, else as at
 * 30 fps); a frame whose residual (the rotation angle to the renormalized fit for a joint, the
 * distance for the translation, over 1 - the frame's leverage: the deleted residual) passes
 * the gate (ROBUST_ANGLE, default pi/2; for the
 * translation 0.2 BODY_HEIGHT, or 100 times the median residual without BODY_HEIGHT) gets the
 * weight exp(-8 ((r/gate)^2 - 1)) (1 within the gate, 0 for a gross outlier; a group with
 * fewer than 3 frames of weight 1/2 or more keeps the weights 1), and the fit is redone with
 * the weights until the outlier frames (weight below 1/2) stop changing (at most 12 fits).
 * Before that fit, each joint's flips are found from its rotations alone, at any frame rate:
 * a run of 1 to 10 frames inside the clip that the joint enters by a jump and leaves by a
 * jump back (with d_i the rotation angle from frame i - 1 to i, blind to the sign of the
 * quaternions, and S the largest step in the 3 frames either side of the run and inside it:
 * both jumps pass max(ROBUST_ANGLE / 2, 2.5 S), the frames either side are within
 * 1.5 S (run + 1) + ROBUST_ANGLE / 8 of each other and closer than half the smaller jump, and
 * every frame of the run is more than half the smaller jump off the slerp between them).
 * Those frames are outliers from the first fit on, so a burst of 10 frames at 30 fps cannot
 * drag the fit it is measured against, and a flip of 90 degrees, below the gate, is found
 * too; q -> -q is no step and never an outlier. A flip of 2 to 10 frames whose corruption is
 * a constant turn R (q R or R q, R the same on each frame of the run) is undone: R is
 * estimated at each end of the run (the step across the end as the mean of the steps beside
 * it; a constant turn leaves the steps inside the run as they were, in the world frame for
 * q R, in the joint's own for R q), and where the two estimates of one form agree (within a
 * quarter of the smaller jump and 0.25 rad) the run is rewritten as q_bad R^-1 (R^-1 q_bad),
 * R the two estimates weighed by the inverse squares of their uncertainties (the angle
 * between the two steps each end's step is the mean of). Those frames count in the layers
 * with their repaired rotations, so that synthesis and mlr_layers_repair follow the motion
 * through the flip rather than the prior's bridge; they are still reported as outliers, and
 * the residual layer keeps the input there. Any other outlier frame weighs 0 in the layers.
 * When a weight is below 1, every LGS of the decomposition weights its observations,
 * (W + s L^T L) x = W y, the base heuristic's bound and MLR_LAYERS_PARAM_BASE_MAX_ANGLE skip the
 * outlier frames, GCV counts a frame by its weight, and a joint's quaternion takes the
 * hemisphere of the most similar of its last frames (a quarter second, at least 8, at most 256
 * frames) that are not outliers (outlier frames stepped over, up to 64 of them) (a 180-degree flip leaves the plain alignment of the frames
 * after it to chance). The glitch then stays in the residual
 * layer (the identity still holds) and synthesis and denoising pass over it. When no residual
 * passes its gate the decomposition is the plain one, bit for bit; the search costs one light
 * LGS solve of every channel. mlr_layers_get_outliers reports the outlier frames.
 *
 * Arrays are row-major float64; quaternions scalar-first (w, x, y, z). Joint 0 is the root
 * segment; root_pos is the body translation (its translation, unless BODY_JOINT names another
 * joint). Rotations are normalized on input, and the layers
 * reproduce the normalized input; an output quaternion of synthesis and reconstruction is taken
 * in the hemisphere of the base quaternion of its frame (the base is sign-continuous in time),
 * so a rotation may come back as -q for an input q.
 */
#ifndef MLR_LAYERS_H
#define MLR_LAYERS_H

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A decomposed motion. Opaque; read-only after mlr_layers_decompose. */
typedef struct mlr_layers mlr_layers;

/** Option keys for mlr_layers_decompose. Values pinned; new options get new values. */
typedef enum mlr_layers_key {
    MLR_LAYERS_OPT_GAMMA = 1,          /* angle bound of eq. 14 in radians, [pi/2, pi); pi/2 */
    MLR_LAYERS_OPT_LAM_B = 2,          /* base lam: setting LAM_B or SIGMA_B fixes the base s */
    MLR_LAYERS_OPT_SIGMA_B = 3,        /*   for every joint and the root (the other of the pair
                                          then defaults to lam = 1 / sigma = 0.1) */
    MLR_LAYERS_OPT_LAM_C = 4,          /* control lam: setting LAM_C or SIGMA_C replaces GCV */
    MLR_LAYERS_OPT_SIGMA_C = 5,        /*   (the other of the pair then defaults to 1) */
    MLR_LAYERS_OPT_BASE_S_MIN = 6,     /* search range of the base s; default 1e-2 */
    MLR_LAYERS_OPT_BASE_S_MAX = 7,     /*   default 1e10 */
    MLR_LAYERS_OPT_CONTROL_S_MIN = 8,  /* GCV search range of the control s; default 1e-2 */
    MLR_LAYERS_OPT_CONTROL_S_MAX = 9,  /*   default 1e8 */
    MLR_LAYERS_OPT_FPS = 10,           /* frame rate in Hz, finite > 0: turns on the base floor
                                          (BASE_CUTOFF, default 0.25 Hz) */
    MLR_LAYERS_OPT_BASE_CUTOFF = 11,   /* base floor in Hz, in (0, fps/2); needs FPS */
    MLR_LAYERS_OPT_BODY_JOINT = 12,    /* joint whose base s the translation group takes, an
                                          integer in [0, J); default 0 (the root) */
    MLR_LAYERS_OPT_ROBUST = 13,        /* 1 (default): find outlier frames and down-weight them
                                          (see "Outliers" above); 0: off */
    MLR_LAYERS_OPT_BODY_HEIGHT = 14,   /* body height in root_pos units, > 0: the translation's
                                          outlier gate is 0.2 of it (default: 100 times its
                                          median residual) */
    MLR_LAYERS_OPT_ROBUST_ANGLE = 15   /* the joints' outlier gate in radians, (0, pi]; pi/2 */
} mlr_layers_key;

/** One option: key (an mlr_layers_key) and its value. A frozen value type. */
typedef struct mlr_layers_option {
    int key;
    double value;
} mlr_layers_option;

/** What mlr_layers_get_param reports, 1 + n_joints values each: the root translation first,
 *  then the joints. Values pinned. */
typedef enum mlr_layers_param {
    MLR_LAYERS_PARAM_BASE_S = 0,          /* s = lam^2 sigma^2 of the base LGS */
    MLR_LAYERS_PARAM_BASE_LAM = 1,
    MLR_LAYERS_PARAM_BASE_SIGMA = 2,
    MLR_LAYERS_PARAM_BASE_MAX_ANGLE = 3,  /* max_t |v_j(t)| in radians; for the root,
                                             max_t |u0(t)| in its length unit */
    MLR_LAYERS_PARAM_CONTROL_S = 4,       /* s of the controllable layer's LGS */
    MLR_LAYERS_PARAM_CONTROL_LAM = 5,
    MLR_LAYERS_PARAM_CONTROL_SIGMA = 6,
    MLR_LAYERS_PARAM_CONTROL_GCV = 7,     /* GCV score at the chosen s; NaN when s was given */
    MLR_LAYERS_PARAM_CONTROL_DOF = 8      /* tr(H): effective degrees of freedom per channel */
} mlr_layers_param;

/**
 * Decompose a motion.
 * @param n_frames  [in] N >= 3 (the second-difference prior needs three frames)
 * @param n_joints  [in] J >= 1
 * @param root_pos  [in] N x 3 body translations, finite (the root's, or those of the joint
 *                  given as MLR_LAYERS_OPT_BODY_JOINT); NULL for zeros. Not kept.
 * @param rot       [in] N x J x 4 joint rotations, finite and nonzero (normalized here). Not
 *                  kept.
 * @param opts      [in] n_opts options; NULL when n_opts is 0. A key may appear once.
 * @param alloc     [in] allocator, copied; NULL for malloc/free
 * @param out       [out] new handle, NULL on failure
 * @param diag      [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (N < 3, J == 0, NULL arrays, non-finite or zero input,
 *         unknown or repeated key, gamma outside [pi/2, pi), a lam/sigma not finite and > 0,
 *         an s range not finite, positive and ordered, fps not finite and > 0, BASE_CUTOFF
 *         outside (0, fps/2) or without FPS or together with BASE_S_MAX, BODY_JOINT not an
 *         integer in [0, J), ROBUST not 0 or 1, BODY_HEIGHT not > 0, ROBUST_ANGLE outside
 *         (0, pi]); MLR_E_SINGULAR (a factorization
 *         failed: s far too large for the clip); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: the handle, one block of about (10 J + 9) N doubles and (J + 1) N bytes, and
 * while running one block of about (11 J + 6) N doubles of scratch (robust: (18 J + 8) N).
 * Cost O(N J) per search step (a few dozen steps; robust with outliers: a few more, and the
 * weighted solves cost about twice as much).
 * Threads: any; inputs only read.
 */
MLR_API mlr_status mlr_layers_decompose(size_t n_frames, size_t n_joints, const double *root_pos,
                                        const double *rot, const mlr_layers_option *opts,
                                        size_t n_opts, const mlr_allocator *alloc,
                                        mlr_layers **out, mlr_diag *diag);

/** Frames N of the decomposition (0 for NULL). */
MLR_API size_t mlr_layers_n_frames(const mlr_layers *layers);
/** Joints J of the decomposition (0 for NULL). */
MLR_API size_t mlr_layers_n_joints(const mlr_layers *layers);

/**
 * Copy the base layer.
 * @param root_pos    [out] N x 3, or NULL to skip (then n_root_pos is ignored)
 * @param n_root_pos  [in] doubles at root_pos; must be 3 N
 * @param rot         [out] N x J x 4 unit quaternions, or NULL to skip
 * @param n_rot       [in] doubles at rot; must be 4 N J
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, wrong count)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_layers_get_base(const mlr_layers *layers, double *root_pos,
                                       size_t n_root_pos, double *rot, size_t n_rot);

/** Copy the controllable layer delta_c: N x (1 + J) x 3, the root translation first in every
 *  frame, then the joints' rotation vectors. count must be 3 N (1 + J).
 *  @return MLR_OK; MLR_E_INVALID_ARG. Allocates: never. Threads: handle only read. */
MLR_API mlr_status mlr_layers_get_control(const mlr_layers *layers, double *out, size_t count);

/** Copy the residual layer delta_r, laid out like the controllable layer.
 *  @return MLR_OK; MLR_E_INVALID_ARG. Allocates: never. Threads: handle only read. */
MLR_API mlr_status mlr_layers_get_residual(const mlr_layers *layers, double *out, size_t count);

/** Parameters chosen per group (see mlr_layers_param): count must be 1 + J, the root first.
 *  @return MLR_OK; MLR_E_INVALID_ARG (NULL, wrong count, unknown which). Allocates: never. */
MLR_API mlr_status mlr_layers_get_param(const mlr_layers *layers, mlr_layers_param which,
                                        double *out, size_t count);

/**
 * The outlier frames found (see "Outliers"): out[i (1 + J) + g] is 1 where frame i of group g
 * (0 the body translation, 1 + k joint k) was down-weighted (weight below 1/2) or belongs to a
 * flip that was undone (its repaired rotation counted), else 0. All 0 when robust is off or
 * nothing passed a gate.
 * @param out    [out] N (1 + J) bytes
 * @param count  [in] must be N (1 + J)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, wrong count). Allocates: never. Threads: handle
 *         only read.
 */
MLR_API mlr_status mlr_layers_get_outliers(const mlr_layers *layers, unsigned char *out,
                                           size_t count);

/**
 * The runs at the clip's ends that the robust decomposition left out whole: the first *head
 * and the last *tail frames (0: none), each 1-10 frames that the body translation leaves (or
 * enters) by a step more than 10 times every step inside the run and the 3 beyond it, or, where
 * the translation does not, that at least 3 joints leave (enter) by a turn of more than 20
 * degrees and 10 times each of theirs inside the run and the 3 beyond it, with at least 8
 * frames outside the runs (a converter's rest-pose frame before the capture). They are outliers
 * of the translation and of every joint that jumps there too; since the layers know no pose of
 * the motion there, mlr_pipeline passes them through unchanged in a denoise (every alpha 1) and
 * otherwise holds the result's pose next to each run over it (raised where it would sink
 * deeper under the floor than the rest pose). 0 and 0 when robust is off.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL). Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_layers_get_end_runs(const mlr_layers *layers, size_t *head, size_t *tail);

/**
 * Repair the input at its outlier frames: frames [begin, begin + count) of the input, in the
 * layout given to mlr_layers_decompose (root_pos the body translation, rot the rotations),
 * are rewritten in place where the frame is an outlier of some group (mlr_layers_get_outliers)
 * by the denoised frame, the synthesis at alpha 1 (the same values mlr_layers_synthesize
 * gives); the other frames are left as they are. What the guards (mlr_guards_create) should
 * learn from, so that a glitch does not break a contact, move the floor or widen a joint's
 * range; mlayer's Python pipeline does this before making the guards. On a rig whose body
 * translation rides on a non-root joint, root_pos holds that joint's translations (as given
 * to decompose with MLR_LAYERS_OPT_BODY_JOINT): copy them back to its position channels.
 * @param layers      [in] the layers of the input
 * @param root_pos    [in/out] count x 3 of the input's body translations, or NULL to skip
 * @param n_root_pos  [in] must be 3 count when root_pos is not NULL
 * @param rot         [in/out] count x J x 4 of the input's rotations, or NULL to skip
 * @param n_rot       [in] must be 4 J count when rot is not NULL
 * @param n_repaired  [out] optional: how many frames were outliers (and so rewritten)
 * @param diag        [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL layers, range outside the frames, wrong sizes;
 *         nothing written)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_layers_repair(const mlr_layers *layers, size_t begin, size_t count,
                                     double *root_pos, size_t n_root_pos, double *rot,
                                     size_t n_rot, size_t *n_repaired, mlr_diag *diag);

/**
 * Synthesize frames [begin, begin + count) of M' = Mb (+) W delta_c (eq. 16, 17): the root
 * translation pb + alpha_0 uc, joint j's rotation qb_j * exp(alpha_{1+j} vc_j).
 * @param alpha       [in] n_alpha finite scales: 1 + J values (root translation first), or a
 *                    single value for every group. Any finite value is accepted (0 gives the
 *                    base layer, 1 the denoised motion, > 1 exaggerates, < 0 inverts).
 * @param root_pos    [out] count x 3, or NULL to skip
 * @param n_root_pos  [in] must be 3 count when root_pos is not NULL
 * @param rot         [out] count x J x 4, or NULL to skip
 * @param n_rot       [in] must be 4 J count when rot is not NULL
 * @param diag        [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, frame range outside [0, N), wrong counts,
 *         alpha NaN or infinite: nothing is written)
 * Allocates: never. Threads: handle only read, so threads may synthesize concurrently.
 */
MLR_API mlr_status mlr_layers_synthesize(const mlr_layers *layers, size_t begin, size_t count,
                                         const double *alpha, size_t n_alpha, double *root_pos,
                                         size_t n_root_pos, double *rot, size_t n_rot,
                                         mlr_diag *diag);

/**
 * Alpha over time (paper 1, section 6.2: the final motion composited by changing the local
 * weights over time). mlr_layers_synthesize_frames is mlr_layers_synthesize with a row of
 * alphas per frame: frame begin + f takes the row at alpha + f n, n = 1 (every group) or 1 + J
 * (the root translation first). The arithmetic per frame is that of mlr_layers_synthesize, so
 * a frame comes out bit for bit as mlr_layers_synthesize(layers, begin + f, 1, row, n) gives it,
 * and the same row for every frame gives the constant synthesis bit for bit.
 * @param alpha       [in] n_alpha finite values, count x 1 or count x (1 + J), row-major
 * @param n_alpha     [in] count or count (1 + J)
 * Other parameters as mlr_layers_synthesize.
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL handle, frame range outside [0, N), wrong counts,
 *         an alpha NaN or infinite: the diag names its frame and group; nothing is written)
 * Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_layers_synthesize_frames(const mlr_layers *layers, size_t begin,
                                                size_t count, const double *alpha, size_t n_alpha,
                                                double *root_pos, size_t n_root_pos, double *rot,
                                                size_t n_rot, mlr_diag *diag);

/**
 * Keyframed alpha curves: keys (times[k], values[k]), times in seconds strictly increasing,
 * evaluated at any time t as
 *
 *     a(t) = values[0]                         t <= times[0]
 *            values[n - 1]                     t >= times[n - 1]
 *            a_k + (a_{k+1} - a_k) s(u)        times[k] <= t < times[k+1],
 *                                              u = (t - t_k) / (t_{k+1} - t_k),
 *                                              s(u) = u^3 (10 - 15 u + 6 u^2)
 *
 * (one key: a constant). Why this smoothstep and not a spline through the keys: the result's
 * acceleration has the term a''(t) delta_c, so a curve with a jump in a'' (a C1 curve such as
 * the monotone cubic of Fritsch-Carlson, or a piecewise linear one with its jumps in a') puts
 * a step or a kick into every joint's acceleration at each key; s has s' = s'' = 0 at both
 * ends, so the curve is C2 everywhere. A C2 interpolating spline (natural or clamped cubic)
 * overshoots: keys 1, 3, 1 give alphas above 3 and the exaggeration goes past what was keyed;
 * the smoothstep stays within its two keys (max |a| over the clip is the largest |key|), a key
 * changes only the two segments beside it, and two equal keys give exactly their value between
 * them (bit for bit: a constant curve is the constant alpha). The price: the slope is zero at
 * every key, so a curve eases in and out of each key (it holds there for an instant) rather
 * than passing through with speed; add keys to shape a ramp.
 */

/**
 * Check keys: n_keys >= 1, times and values finite, times strictly increasing.
 * @return MLR_OK; MLR_E_INVALID_ARG (the diag names the first bad key)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_alpha_keys_check(const double *times, const double *values, size_t n_keys,
                                        mlr_diag *diag);

/**
 * Evaluate keyed alphas (see above) at count times.
 * @param t      [in] count finite times in seconds (any order)
 * @param out    [out] count values; may be t
 * @return MLR_OK; MLR_E_INVALID_ARG (bad keys as mlr_alpha_keys_check, NULL t or out with
 *         count > 0, a t not finite: nothing written)
 * Allocates: never. Threads: any. Cost O(count log n_keys).
 */
MLR_API mlr_status mlr_alpha_keys_eval(const double *times, const double *values, size_t n_keys,
                                       const double *t, size_t count, double *out, mlr_diag *diag);

/**
 * Rebuild frames [begin, begin + count) of the input as (Mb (+) delta_c) (+) delta_r. It equals
 * the (normalized) input to rounding, a rotation possibly as -q. Arguments as for synthesize.
 * @return MLR_OK; MLR_E_INVALID_ARG. Allocates: never. Threads: handle only read.
 */
MLR_API mlr_status mlr_layers_reconstruct(const mlr_layers *layers, size_t begin, size_t count,
                                          double *root_pos, size_t n_root_pos, double *rot,
                                          size_t n_rot, mlr_diag *diag);

/** Release the handle. NULL is a no-op. */
MLR_API void mlr_layers_destroy(mlr_layers *layers);

#ifdef __cplusplus
}
#endif

#endif /* MLR_LAYERS_H */
