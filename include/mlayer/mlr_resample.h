/*
 * Resampling and time warping through the LGS (paper 1, section 5.3), and the SLERP baseline.
 *
 * A motion is given as arrays (DESIGN.md): root_pos N x 3, rot N x J x 4 (scalar-first
 * quaternions, local to the parent) and optionally trans N x P x 3 (per-frame translations of
 * P non-root joints, as mlr_motion_trans). Input frame i is placed at the fractional position
 * t[i] of an output grid of n_out frames; t is a time map:
 * - strictly increasing, finite, t[0] == 0 and t[N-1] == n_out - 1 exactly (boundary frames stay
 *   put);
 * - uniform (t == NULL: t[i] = i (n_out-1)/(N-1)) for a change of frame count that keeps the
 *   duration; any such monotone map for a time warp;
 * - with MLR_RESAMPLE_OPEN_END, the last position may lie up to one output frame after the last
 *   output frame, n_out - 1 <= t[N-1] < n_out: the exact grid of a change of frame rate
 *   (mlr_resample_rate_map), where output frame k is at time k / fps_out after the input's first
 *   frame and the output ends at the last such time within the input (the LGS then solves one
 *   hidden frame more, at n_out, which is not returned).
 * The ratio of the frame counts, (n_out-1)/(N-1), and every local step t[i+1]-t[i] must lie in
 * [1/100, 100] unless MLR_RESAMPLE_ALLOW_EXTREME is given (an absurd factor is usually a unit
 * mistake, e.g. a frame time passed as a frame rate).
 *
 * The LGS (mlr_lgs.h, order 2) is solved on the root translation, the extra translations and
 * the four components of every joint's quaternion (chordal approximation, eq. 11), once for
 * all channels; quaternions are made sign-continuous first (mlr_quat_continue_sign, so a key
 * step of 180 to 300 degrees is followed the long way when the steps before announce it) and
 * renormalized after.
 *
 * Automatic smoothness (lam < 0): only s = lam^2 sigma^2 changes the mean. With r =
 * t[N-1]/(N-1) output frames per input frame ((n_out-1)/(N-1) for the uniform map), the order-2 LGS behaves as a low-pass filter of
 * gain about 1 / (1 + (w / w_c)^4) with w_c^4 = 1 / (s r) (w in radians per output frame).
 * mlayer takes
 *     s = max(MLR_RESAMPLE_KAPPA_UP * r^3, MLR_RESAMPLE_KAPPA_DOWN / r):
 * - downsampling (r < 1): the cutoff sits at a fixed fraction of the output Nyquist frequency,
 *   w_c = KAPPA_DOWN^(-1/4) = 1.19 rad per output frame (0.38 of Nyquist, 5.7 Hz at 30 fps),
 *   so the gain at the output Nyquist is about 0.02. With the linear-interpolation rows of A (a
 *   triangle prefilter two output frames wide) a sinusoid above the new Nyquist comes back as an
 *   alias of at most 5 % of its amplitude (measured at 120 -> 30 fps from 16 to 55 Hz, see
 *   tests/layers/test_resample.c), where plain decimation returns it whole. Below w_c / 2 (2.8 Hz at
 *   30 fps) the gain stays above 0.94; 120 -> 30 -> 120 fps round trips of real clips move the
 *   joints by 0.1 to 0.4 % of the body height (MPJPE). A weaker prior (smaller KAPPA_DOWN) would
 *   keep more of the 3 to 10 Hz band at the price of more aliasing (0.2 gives 10 % at 16 Hz).
 * - upsampling (r >= about 2.7): the cutoff is fixed relative to the input Nyquist frequency,
 *   KAPPA_UP^(-1/4) = 3.2 rad per input frame, just above it: the keys are nearly interpolated
 *   (a smoothing spline through them) while the prior fills the frames in between.
 * Between the two rules the larger s wins, so s is continuous in r.
 */
#ifndef MLR_RESAMPLE_H
#define MLR_RESAMPLE_H

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Pass as lam for the automatic smoothness described above. */
#define MLR_RESAMPLE_AUTO (-1.0)
/** Constants of the automatic smoothness rule. */
#define MLR_RESAMPLE_KAPPA_DOWN 0.5
#define MLR_RESAMPLE_KAPPA_UP 0.01
/** The largest resampling factor (either way) accepted without MLR_RESAMPLE_ALLOW_EXTREME. */
#define MLR_RESAMPLE_MAX_FACTOR 100.0

/** Flags of the resampling functions (bitwise or). Values pinned. */
enum {
    MLR_RESAMPLE_ALLOW_EXTREME = 1u, /* accept factors beyond MLR_RESAMPLE_MAX_FACTOR */
    MLR_RESAMPLE_NEAREST_SIGN = 2u,  /* nearest-sign continuity only (no prediction) */
    MLR_RESAMPLE_OPEN_END = 4u       /* t[N-1] may lie in [n_out - 1, n_out) (see the top) */
};

/**
 * Number of output frames for a change of frame rate: round((N-1) fps_out / fps_in) + 1, at
 * least 2. With the uniform map the first and last frames are kept, so the duration changes by
 * less than half an output frame (the exact rate fps_out is kept in the file header) and the
 * output frames are not exactly 1 / fps_out apart. With MLR_RESAMPLE_OPEN_END, the count of the
 * exact grid instead: floor((N-1) fps_out / fps_in) + 1 (a value within 1e-9 below an integer
 * counts as that integer), as mlr_resample_rate_map gives it; MLR_E_INVALID_ARG when that is
 * below 2 (the input lasts less than one output frame).
 * @param n_frames [in] N >= 2
 * @param fps_in   [in] frames per second of the input, finite, > 0
 * @param fps_out  [in] wanted frames per second, finite, > 0
 * @param flags    [in] MLR_RESAMPLE_ALLOW_EXTREME, MLR_RESAMPLE_OPEN_END or 0
 * @param n_out    [out] output frame count
 * @param diag     [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (N < 2, fps not finite or <= 0, factor beyond 100 without
 *         the flag, NULL n_out); MLR_E_OVERFLOW (the count does not fit)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_resample_n_out(size_t n_frames, double fps_in, double fps_out,
                                      unsigned flags, size_t *n_out, mlr_diag *diag);

/**
 * The exact time map of a change of frame rate: t[i] = i fps_out / fps_in, input frame i at its
 * own time on the output grid, so output frame k lies at time k / fps_out after the input's
 * first frame; n_out as mlr_resample_n_out with MLR_RESAMPLE_OPEN_END (the last output frame
 * is the last grid time within the input; when t[N-1] lies within 1e-9 below n_out - 1 it is
 * set to n_out - 1). Pass t, n_out and MLR_RESAMPLE_OPEN_END to mlr_resample_arrays or
 * mlr_slerp_resample_arrays. Two cuts of one clip that start on the same frame get the same
 * output frames at the same times, whatever their lengths.
 * @param n_frames [in] N >= 2
 * @param fps_in   [in] frames per second of the input, finite, > 0
 * @param fps_out  [in] wanted frames per second, finite, > 0
 * @param flags    [in] MLR_RESAMPLE_ALLOW_EXTREME, MLR_RESAMPLE_OPEN_END (implied) or 0
 * @param t        [out] N positions
 * @param n_out    [out] output frame count
 * @param diag     [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (as mlr_resample_n_out, NULL t or n_out; an input shorter
 *         than one output frame); MLR_E_OVERFLOW
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_resample_rate_map(size_t n_frames, double fps_in, double fps_out,
                                         unsigned flags, double *t, size_t *n_out, mlr_diag *diag);

/**
 * Check a time map as described at the top of this header.
 * @param t        [in] N positions
 * @param n_frames [in] N >= 2
 * @param n_out    [in] output frames >= 2
 * @param flags    [in] MLR_RESAMPLE_ALLOW_EXTREME, MLR_RESAMPLE_OPEN_END or 0
 * @return MLR_OK; MLR_E_INVALID_ARG with the first offending index in diag
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_timemap_validate(const double *t, size_t n_frames, size_t n_out,
                                        unsigned flags, mlr_diag *diag);

/** The automatic s = lam^2 sigma^2 for N input and n_out output frames (both >= 2); 0 when a
 *  count is below 2. Cannot fail. */
MLR_API double mlr_resample_auto_smoothness(size_t n_frames, size_t n_out);

/**
 * Resample (or time-warp) a motion through the LGS.
 * @param n_frames  [in] N >= 2
 * @param n_joints  [in] J (0 allowed: root translation only)
 * @param n_trans   [in] P (0 for none)
 * @param root_pos  [in] N x 3
 * @param rot       [in] N x J x 4 quaternions (NULL when J == 0); expected unit, zero rows
 *                  are rejected; sign and norm do not matter
 * @param trans     [in] N x P x 3 (NULL when P == 0)
 * @param t         [in] N positions on the output grid (a time map), or NULL for uniform
 * @param n_out     [in] output frames >= 2
 * @param lam       [in] smoothness lam >= 0, or MLR_RESAMPLE_AUTO (any negative value) for
 *                  the automatic rule (lam = sqrt(s) / sigma)
 * @param sigma     [in] observation noise, finite, > 0: scales var_out only (the mean depends
 *                  on lam^2 sigma^2); 1 gives the variance relative to one observation's
 * @param flags     [in] MLR_RESAMPLE_ALLOW_EXTREME, MLR_RESAMPLE_NEAREST_SIGN,
 *                  MLR_RESAMPLE_OPEN_END (with a time map t)
 * @param root_out  [out] n_out x 3
 * @param rot_out   [out] n_out x J x 4 unit quaternions (NULL when J == 0)
 * @param trans_out [out] n_out x P x 3 (NULL when P == 0)
 * @param var_out   [out] optional n_out posterior variances (the same for every channel), or
 *                  NULL; grows where the observations are sparse
 * @param alloc     [in] allocator for the LGS and a sign-continuous copy of rot (N x J x 4
 *                  doubles), with an open end also (n_out + 1) x (4 J + 3 P + 4) doubles for
 *                  the solve on the grid with the hidden frame; NULL for malloc/free
 * @param diag      [out] optional: the reason of an error
 * @return MLR_OK; MLR_W_ILL_CONDITIONED (result usable); MLR_E_INVALID_ARG (bad counts, NULL
 *         arrays, bad time map or factor, bad lam/sigma, non-finite input, zero quaternion;
 *         outputs unspecified); MLR_E_SINGULAR (lam == 0 with unobserved output frames);
 *         MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: yes, as said. Threads: any; outputs must not alias inputs.
 */
MLR_API mlr_status mlr_resample_arrays(size_t n_frames, size_t n_joints, size_t n_trans,
                                       const double *root_pos, const double *rot,
                                       const double *trans, const double *t, size_t n_out,
                                       double lam, double sigma, unsigned flags, double *root_out,
                                       double *rot_out, double *trans_out, double *var_out,
                                       const mlr_allocator *alloc, mlr_diag *diag);

/**
 * The classic baseline: each output frame j lies between the input frames k, k+1 with
 * t[k] <= j <= t[k+1]; its rotations are the slerp between rot[k] and rot[k+1] along the shorter
 * arc (nearest sign), the translations the linear interpolation.
 * Parameters as mlr_resample_arrays (same time map rules and flags; no smoothing).
 * @return MLR_OK; MLR_E_INVALID_ARG (as mlr_resample_arrays)
 * Allocates: never. Threads: any; outputs must not alias inputs.
 */
MLR_API mlr_status mlr_slerp_resample_arrays(size_t n_frames, size_t n_joints, size_t n_trans,
                                             const double *root_pos, const double *rot,
                                             const double *trans, const double *t, size_t n_out,
                                             unsigned flags, double *root_out, double *rot_out,
                                             double *trans_out, mlr_diag *diag);

/**
 * Per-frame motion magnitude for automatic time warping: at frame i, from the central
 * difference over frames i-1 and i+1 (one-sided at the ends),
 *     speed[i] = sum_j w_j angle(q_j) / sum_j w_j + root_weight |d root_pos|,
 * with angle the rotation angle (radians per frame) of joint j's local rotation change and
 * |d root_pos| the root's displacement per frame.
 * @param joint_weights [in] J weights >= 0 (not all 0), or NULL for equal weights
 * @param root_weight   [in] >= 0, radians per unit of length (e.g. 1 / body height; 0 ignores
 *                      the root)
 * @param speed         [out] N values
 * @return MLR_OK; MLR_E_INVALID_ARG (N < 2, NULL, bad weights, non-finite input)
 * Allocates: never. Threads: any.
 */
MLR_API mlr_status mlr_timewarp_speed(size_t n_frames, size_t n_joints, const double *root_pos,
                                      const double *rot, const double *joint_weights,
                                      double root_weight, double *speed, mlr_diag *diag);

/**
 * Automatic time map (paper 1, Figure 9): intervals of large motion are slowed down, with
 * easing in and out. The speed of mlr_timewarp_speed is divided by its clip mean, its log
 * (floored at log 0.05) is smoothed by an order-2 LGS whose half-gain period is smooth_frames,
 * and the output frames spent per input frame are proportional to exp(strength * that); the
 * cumulative map is scaled so that frame 0 lands on 0 and frame N-1 on n_out - 1. strength 0
 * gives the uniform map; 1 makes the dwell time follow the motion magnitude; larger values
 * exaggerate. The local rate ratio (slowest to fastest) is clamped to 100.
 * @param strength      [in] finite, in [0, 10]
 * @param smooth_frames [in] easing length in input frames, finite, >= 1 (e.g. a quarter of a
 *                      second's worth)
 * @param n_out         [in] output frames (the target length), >= 2
 * @param flags         [in] MLR_RESAMPLE_ALLOW_EXTREME or 0 (checks as for time maps)
 * @param t             [out] N positions: a valid time map for mlr_resample_arrays
 * @param alloc         [in] for O(N) workspace and the LGS; NULL for malloc/free
 * Other parameters as mlr_timewarp_speed.
 * @return MLR_OK; MLR_E_INVALID_ARG; MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: O(N), released before return. Threads: any.
 */
MLR_API mlr_status mlr_timewarp_map(size_t n_frames, size_t n_joints, const double *root_pos,
                                    const double *rot, const double *joint_weights,
                                    double root_weight, double strength, double smooth_frames,
                                    size_t n_out, unsigned flags, double *t,
                                    const mlr_allocator *alloc, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_RESAMPLE_H */
