/*
 * Live filtering: a fixed-lag LGS smoother for motion that arrives one frame at a time.
 *
 * What it computes. The offline LGS of paper 1 (mlr_lgs, order 2, identity observations)
 * solves, for a clip of N frames and every channel at once,
 *
 *     (s D^T D + I) x = y,      s = lam^2 sigma^2,      D the (N-2) x N second difference.
 *
 * The prior is a second-order Gaussian random walk, so the terms of frames after n integrate
 * out: the posterior mean given the first n frames only is the same system written for the
 * n-frame prefix (with its end rows). After pushing frame n-1 the stream outputs frame
 * j = n-1-lag of that prefix solution: E[x_j | y_0 .. y_{n-1}], the fixed-lag smoother.
 *
 * How (exact, O(lag) per frame and channel). The prefix matrix A_n = L D L^T (banded LDL^T, as
 * mlr_lgs factors it) shares every row but its last two with any longer clip, so:
 *  - push runs the forward sweep z_i = y_i - L(i,i-1) z_{i-1} - L(i,i-2) z_{i-2} online for
 *    the "continuing" rows (one factor row per frame: O(1) scalars, O(m) channel work);
 *  - the two end rows of A_n are factored per frame (O(1) scalars) and the backward sweep for
 *    the single output row is written as a weighted sum: x_j = sum_k w_k zhat_k with
 *    w = D^{-1} (column j of L^{-1}), a stable O(lag) scalar recurrence; the end rows are
 *    folded into the weights, so the output costs lag + 1 multiply-adds per channel, over the
 *    last lag + 1 forward-swept rows (a ring buffer sized at create);
 *  - flush runs the true backward sweep over the last lag frames: the flushed frames are the
 *    offline solution of the whole clip (up to rounding) when lag >= N, and the last lag
 *    frames of it in any case.
 * The stream's output for frame j differs from the offline solution of a longer clip only
 * through the observations after frame j + lag. Their weight decays as rho^lag, where rho < 1
 * is the modulus of the roots of z + 1/z = 2 - i/sqrt(s) inside the unit circle (rho = 0 for
 * s = 0; rho -> 1 as s grows, 1 - rho ~ 0.7 s^(-1/4)): mlr_stream_decay_rate gives it, and
 * the lag needed for a relative gap tol is about log(tol) / log(rho). bench/stream_lag.c
 * measures it on the real clips (gap relative to the largest translation range; quaternion
 * components absolute). Measured on the CMU 131_01 walk (the other clips need a few frames
 * less), lag for 1e-3 / 1e-6:
 *     lam 1,  sigma 0.1 (rho 0.10):   2 /   5      lam 10, sigma 1  (rho 0.80):  30 /  60
 *     lam 1,  sigma 1   (rho 0.48):   9 /  18      lam 10, sigma 10 (rho 0.93):  91 / 183
 *     lam 4,  sigma 1   (rho 0.70):  19 /  37
 *
 * Frame layout (n_values = 3 * root + 3 * n_trans + 4 * n_joints doubles): the root
 * translation (3, when root is set), n_trans extra translations (3 each, e.g. the non-root
 * position channels of mlr_motion_trans), then n_joints quaternions (w, x, y, z): the order
 * of mlr_motion_root_pos, mlr_motion_trans and mlr_motion_rot for one frame.
 *
 * Quaternions: each pushed quaternion first gets its sign from the second-order predictive
 * rule (mlr_quat_continue_sign on the up to 3 earlier aligned samples of its joint; the nearest
 * sign for steps below 60 degrees), applied online exactly as the batch
 * mlr_quat_make_continuous_predictive applies it, so the aligned input equals that of the
 * offline clip bit for bit; its 4 components are smoothed as channels (the chordal
 * approximation, paper 1 eq. 11) and the output is renormalized.
 *
 * Layers (paper 1 section 4, optional): mlr_stream_create_layered adds a second, stronger
 * smoother (lam_base, sigma_base) over the same input, the base layer Mb; the output is
 * Mb (+) alpha * (M (-) Mb), M the main smoothed frame: pb + alpha_t (p - pb) for
 * translations and qb * exp(alpha_j log(conj(qb) q)) for joint j. alpha = 1 gives the main
 * smoothed motion; alpha > 1 exaggerates, 0 <= alpha < 1 flattens toward the base. The alphas
 * may change between any two pushes (live style modulation).
 *
 * Joint limits (optional): mlr_stream_set_limits attaches an mlr_limits; every output frame's
 * quaternions then go through mlr_limits_apply's map (with the stream's alphas for the
 * widening of input-derived ranges; alpha 1 without layers). The map is per frame, so the
 * output stays C1 and streamed frames equal mlr_limits_apply of the unlimited stream's output.
 *
 * Memory: everything is allocated by create (O((lag + 4) n_values) doubles per smoother);
 * push, flush, reset and set_alpha never allocate. A stream serves one thread at a time;
 * separate streams are independent.
 */
#ifndef MLR_STREAM_H
#define MLR_STREAM_H

#include "mlr_common.h"
#include "mlr_limits.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A streaming fixed-lag smoother for one skeleton. Opaque. */
typedef struct mlr_stream mlr_stream;

/**
 * Create a stream.
 * @param n_joints [in] J, quaternions per frame (0 allowed when there are translations)
 * @param root     [in] nonzero: each frame starts with a root translation (3 values)
 * @param n_trans  [in] extra translations per frame (3 values each), after the root's
 * @param lam      [in] smoothness weight, finite, >= 0 (as mlr_lgs_create, order 2)
 * @param sigma    [in] observation noise, finite, > 0
 * @param lag      [in] output delay in frames, >= 0 (0: pure filtering, the posterior mean
 *                 of the newest frame given the frames so far)
 * @param alloc    [in] allocator, copied; NULL for malloc/free
 * @param out      [out] new stream, NULL on failure
 * @param diag     [out] optional: the reason of an MLR_E_INVALID_ARG
 * @return MLR_OK; MLR_E_INVALID_ARG (no channel at all, lam or sigma out of range,
 *         lam^2 sigma^2 not finite, out NULL); MLR_E_OVERFLOW; MLR_E_NO_MEMORY
 * Allocates: yes, everything the stream will ever use. Threads: any.
 */
MLR_API mlr_status mlr_stream_create(size_t n_joints, int root, size_t n_trans, double lam,
                                     double sigma, size_t lag, const mlr_allocator *alloc,
                                     mlr_stream **out, mlr_diag *diag);

/**
 * Create a stream with a base layer for live style modulation (see the top of this file).
 * The alphas start at 1 (output = the main smoothed motion).
 * @param lam_base, sigma_base [in] the base layer's LGS parameters (same ranges as lam, sigma;
 *                 normally a stronger smoothing than lam, sigma)
 * Other parameters and statuses as mlr_stream_create. Allocates: yes (about twice as much).
 */
MLR_API mlr_status mlr_stream_create_layered(size_t n_joints, int root, size_t n_trans, double lam,
                                             double sigma, double lam_base, double sigma_base,
                                             size_t lag, const mlr_allocator *alloc,
                                             mlr_stream **out, mlr_diag *diag);

/**
 * Push the next frame; when the stream holds more than lag frames, write the smoothed frame
 * from lag frames ago into out.
 * @param st       [in,out] stream
 * @param frame    [in] n_values doubles in the layout above, all finite; not kept
 * @param n_values [in] must equal mlr_stream_frame_size(st)
 * @param out      [out] room for one frame (out_len >= n_values); may not overlap frame
 * @param out_len  [in] doubles available at out
 * @param n_ready  [out] 1 when out holds a frame (frame number mlr_stream_n_pushed - 1 - lag),
 *                 0 while fewer than lag + 1 frames have been pushed
 * @param diag     [out] optional: the reason of an error (the first non-finite value)
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL pointer, wrong n_values, out_len too small, or a
 *         NaN/inf value in frame: the frame is rejected and the stream's state is unchanged);
 *         MLR_E_BAD_STATE (the stream was flushed: reset it first)
 * Allocates: never. Threads: one caller at a time per stream.
 */
MLR_API mlr_status mlr_stream_push(mlr_stream *st, const double *frame, size_t n_values,
                                   double *out, size_t out_len, size_t *n_ready, mlr_diag *diag);

/**
 * End of the clip: write the mlr_stream_pending(st) frames not yet output (min(lag, frames
 * pushed)), oldest first, as the offline solution of the clip pushed so far gives them. The
 * stream is then finished: push returns MLR_E_BAD_STATE until mlr_stream_reset.
 * @param out       [out] room for the pending frames, out_len >= pending * n_values
 * @param n_written [out] frames written
 * @param diag      [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL; out may be NULL when nothing is pending);
 *         MLR_E_OVERFLOW (out_len too small: nothing written, state unchanged);
 *         MLR_E_BAD_STATE (already flushed)
 * Allocates: never. Threads: one caller at a time per stream.
 */
MLR_API mlr_status mlr_stream_flush(mlr_stream *st, double *out, size_t out_len, size_t *n_written,
                                    mlr_diag *diag);

/** Forget every pushed frame: the stream behaves as just created (the alphas are kept).
 *  NULL is a no-op. Allocates: never. */
MLR_API void mlr_stream_reset(mlr_stream *st);

/**
 * Set the layer scales of a layered stream, used from the next output on.
 * @param alpha_trans [in] scale of every translation channel (root and extra), finite
 * @param alpha       [in] n_joints scales, one per joint quaternion, finite (NULL when
 *                    n_joints is 0)
 * @param diag        [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, count mismatch, non-finite: nothing changed);
 *         MLR_E_BAD_STATE (the stream has no base layer)
 * Allocates: never.
 */
MLR_API mlr_status mlr_stream_set_alpha(mlr_stream *st, double alpha_trans, const double *alpha,
                                        size_t n_joints, mlr_diag *diag);

/**
 * Attach joint limits to the stream's output from the next output frame on (push and flush),
 * or detach them with NULL. The limits are borrowed: they must outlive the stream or be
 * detached first, and not be changed (mlr_limits_set_range) while a push or flush runs.
 * @param limits [in] limits for the stream's n_joints joints, or NULL
 * @param diag   [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL stream, mlr_limits_n_joints(limits) != n_joints)
 * Allocates: never. Threads: one caller at a time per stream.
 */
MLR_API mlr_status mlr_stream_set_limits(mlr_stream *st, const mlr_limits *limits, mlr_diag *diag);

/** Values per frame (3 root + 3 n_trans + 4 n_joints); 0 for NULL. */
MLR_API size_t mlr_stream_frame_size(const mlr_stream *st);
/** The lag of the stream in frames; 0 for NULL. */
MLR_API size_t mlr_stream_lag(const mlr_stream *st);
/** Frames pushed since create or reset; 0 for NULL. */
MLR_API size_t mlr_stream_n_pushed(const mlr_stream *st);
/** Frames pushed but not yet output (what flush would write); 0 for NULL or once flushed. */
MLR_API size_t mlr_stream_pending(const mlr_stream *st);

/**
 * Geometric rate rho at which the stream's gap to the offline solution shrinks per frame of
 * lag, for the given lam and sigma (see the top of this file). Returns a value in [0, 1), or
 * -1 when lam or sigma is out of range. Cannot fail otherwise; never allocates.
 */
MLR_API double mlr_stream_decay_rate(double lam, double sigma);

/** Release the stream. NULL is a no-op. */
MLR_API void mlr_stream_destroy(mlr_stream *st);

#ifdef __cplusplus
}
#endif

#endif /* MLR_STREAM_H */
