/*
 * Linear Gaussian system (paper 1, section 3): the posterior mean of a smooth signal x on a
 * grid of n_out frames, from observations y at fractional frame positions t,
 *
 *     (lam^2 L^T L + A^T A / sigma^2) x = A^T y / sigma^2,
 *
 * with L the first (order 1) or second (order 2) difference matrix and A the identity
 * (t == NULL) or linear-interpolation rows (observation i at position t[i] in [0, n_out-1]:
 * weights 1-f and f on frames floor(t[i]) and floor(t[i])+1). The system is banded
 * (bandwidth = order), factored once and applied to every channel in O(n m).
 */
#ifndef MLR_LGS_H
#define MLR_LGS_H

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A factored LGS for fixed n_out, order, lam, sigma and observation positions. Opaque. */
typedef struct mlr_lgs mlr_lgs;

/** Which linear solver a handle uses. */
typedef enum mlr_lgs_solver {
    MLR_LGS_BANDED = 0,  /* banded LDL^T of the library itself (always available) */
    MLR_LGS_CHOLMOD = 1  /* sparse Cholesky through SuiteSparse CHOLMOD (optional at build) */
} mlr_lgs_solver;

/**
 * 1 when the library was built with the CHOLMOD path, 0 otherwise. CHOLMOD is chosen when the
 * library is built (meson -Dcholmod=auto|enabled|disabled; auto: when SuiteSparse is found) and
 * linked, not loaded at run time: CHOLMOD's structures differ between SuiteSparse versions, and
 * the library keeps no global state in which a loaded copy could live. The Python wheels are
 * built with -Dcholmod=disabled, so that they need no SuiteSparse where they are installed.
 * @return 1 or 0, the same for every call.
 * Allocates: no. Threads: any.
 */
MLR_API int mlr_lgs_have_cholmod(void);

/**
 * Build and factor the system.
 * @param n_out   [in] frames of the output grid; must exceed order
 * @param order   [in] 1 (first difference, tridiagonal) or 2 (second difference, pentadiagonal)
 * @param lam     [in] smoothness weight, finite, >= 0
 * @param sigma   [in] observation noise, finite, > 0
 * @param t       [in] n_obs observation positions, sorted, finite, in [0, n_out-1]; NULL for
 *                the identity (then n_obs must equal n_out). Not kept.
 * @param n_obs   [in] number of observations
 * @param solver  [in] MLR_LGS_BANDED or MLR_LGS_CHOLMOD
 * @param alloc   [in] allocator, copied; NULL for malloc/free. (CHOLMOD allocates through its
 *                own configured allocator.)
 * @param out     [out] new handle, NULL on failure
 * @param diag    [out] optional: the reason of an MLR_E_INVALID_ARG / MLR_E_SINGULAR
 * @return MLR_OK; MLR_W_ILL_CONDITIONED (usable, very small pivot); MLR_E_INVALID_ARG (bad
 *         shape or parameter, t not sorted, not finite or out of range); MLR_E_SINGULAR (the
 *         observations do not pin the prior's null space: fewer than `order` distinct
 *         positions, or lam == 0 with unobserved frames); MLR_E_UNSUPPORTED (MLR_LGS_CHOLMOD
 *         in a build without CHOLMOD, see mlr_lgs_have_cholmod); MLR_E_NO_MEMORY; MLR_E_OVERFLOW
 * Allocates: yes, O(n_out + n_obs). Threads: any.
 */
MLR_API mlr_status mlr_lgs_create(size_t n_out, unsigned order, double lam, double sigma,
                                  const double *t, size_t n_obs, mlr_lgs_solver solver,
                                  const mlr_allocator *alloc, mlr_lgs **out, mlr_diag *diag);

/**
 * Posterior mean for m channels.
 * @param lgs  [in] handle
 * @param y    [in] n_obs x m observations, row stride ldy >= m; every value finite
 * @param x    [out] n_out x m result, row stride ldx >= m. With t == NULL, x may be y itself
 *             (same pointer and stride) for an in-place solve; other overlaps are not allowed.
 * @param diag [out] optional: the reason of an error (for a non-finite y, the first such value:
 *             "lgs solve: y[12][0] is NaN or infinite")
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, strides, non-finite y: x is then unspecified);
 *         MLR_E_NO_MEMORY (CHOLMOD path only)
 * Allocates: banded path never; CHOLMOD path O(n m). Threads: the banded handle is only read,
 * so threads may share it; a CHOLMOD handle serves one thread at a time.
 */
MLR_API mlr_status mlr_lgs_solve(const mlr_lgs *lgs, const double *y, size_t ldy, size_t m,
                                 double *x, size_t ldx, mlr_diag *diag);

/**
 * mlr_lgs_solve with help from a second thread for large outputs: while the calling thread
 * solves, the helper maps the pages of x (Linux madvise MADV_POPULATE_WRITE, which leaves their
 * contents alone), so that writing a newly allocated x does not stop at a page fault per page.
 * On a new 100,000 x 127 output this roughly halves the time on two cores; on memory already
 * written, or on other systems, it changes nothing. The results are those of mlr_lgs_solve,
 * bit for bit, for every n_threads.
 * @param n_threads [in] 1: the calling thread only (mlr_lgs_solve); 0: automatic, the helper
 *                  when x spans at least 8 MiB and more than one processor is online; >= 2:
 *                  the helper when x spans at least 8 MiB. More threads are not used.
 * @return as mlr_lgs_solve
 * Allocates: no memory through the allocator; the helper thread's stack comes from the system
 * (pthread_create); if it cannot start, the solve runs alone. Threads: as mlr_lgs_solve.
 */
MLR_API mlr_status mlr_lgs_solve_mt(const mlr_lgs *lgs, const double *y, size_t ldy, size_t m,
                                    double *x, size_t ldx, size_t n_threads, mlr_diag *diag);

/**
 * Posterior variance per output frame: the diagonal of the inverse system matrix, in O(n_out)
 * by selected inversion of the banded factor. It is the variance of a channel whose
 * observation noise is sigma; it grows where observations are sparse.
 * @param var  [out] n_out values
 * @param diag [out] optional: the reason of an error
 * @return MLR_OK; MLR_E_INVALID_ARG (NULL, n_out not the handle's); MLR_E_UNSUPPORTED (CHOLMOD
 *         handle); MLR_E_NO_MEMORY
 * Allocates: O(n_out) workspace, released before return. Threads: handle only read.
 */
MLR_API mlr_status mlr_lgs_variance(const mlr_lgs *lgs, double *var, size_t n_out, mlr_diag *diag);

/** Output frames of the handle. */
MLR_API size_t mlr_lgs_n_out(const mlr_lgs *lgs);
/** Observations of the handle. */
MLR_API size_t mlr_lgs_n_obs(const mlr_lgs *lgs);

/** Release the handle. NULL is a no-op. */
MLR_API void mlr_lgs_destroy(mlr_lgs *lgs);

#ifdef __cplusplus
}
#endif

#endif /* MLR_LGS_H */
