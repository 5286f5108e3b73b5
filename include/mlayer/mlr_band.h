/*
 * Banded symmetric positive definite systems: an LDL^T factorization of bandwidth kd,
 * computed once and applied to many right-hand sides (one column per channel).
 */
#ifndef MLR_BAND_H
#define MLR_BAND_H

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Banded SPD factorization (bandwidth kd) reused across right-hand sides. Opaque. */
typedef struct mlr_band mlr_band;

/**
 * Create an unfactored handle for an n x n matrix with kd sub-diagonals.
 * @param n      [in] order of the matrix, >= 1
 * @param kd     [in] number of sub-diagonals, kd < n
 * @param alloc  [in] allocator, copied; NULL for malloc/free
 * @param out    [out] new handle, or NULL on failure
 * @param diag   [out] optional: the reason of a failure (the argument it names)
 * @return MLR_OK, MLR_E_INVALID_ARG (n == 0, kd >= n, out NULL), MLR_E_NO_MEMORY, MLR_E_OVERFLOW
 * Allocates: yes (O(n kd)). Threads: any.
 */
MLR_API mlr_status mlr_band_create(size_t n, size_t kd, const mlr_allocator *alloc, mlr_band **out,
                                   mlr_diag *diag);

/**
 * Factor A = L D L^T from LAPACK lower band storage: A(i,j) at ab[j*ldab + (i - j)] for
 * j <= i <= min(n-1, j+kd). ab is read, not kept.
 * @param band  [in,out] handle from mlr_band_create
 * @param ab    [in] lower band of A, n columns of ldab >= kd+1 values
 * @param diag  [out] optional: the reason of a failure (the NULL argument, ldab, the row whose
 *              pivot failed); not written on MLR_OK and MLR_W_ILL_CONDITIONED
 * @return MLR_OK; MLR_W_ILL_CONDITIONED (factored, a pivot below 1e-13 of its diagonal entry);
 *         MLR_E_SINGULAR (a pivot <= 0 or not finite: A is not positive definite; the handle is
 *         left unfactored); MLR_E_INVALID_ARG (NULL or ldab too small)
 * Allocates: never. Threads: writes band only.
 */
MLR_API mlr_status mlr_band_factor(mlr_band *band, const double *ab, size_t ldab, mlr_diag *diag);

/**
 * Solve A X = B in place for m right-hand sides stored as columns of a row-major matrix.
 * @param band  [in] factored handle
 * @param x     [in,out] B on entry, X on return: n rows of m values, row stride ldx >= m
 * @param diag  [out] optional: the reason of a failure
 * @return MLR_OK; MLR_E_BAD_STATE (not factored); MLR_E_INVALID_ARG (band NULL, x NULL with
 *         m > 0, ldx < m)
 * Allocates: never. Threads: band is only read, so one factor may serve several threads.
 */
MLR_API mlr_status mlr_band_solve(const mlr_band *band, double *x, size_t ldx, size_t m,
                                  mlr_diag *diag);

/**
 * Diagonal of A^{-1} by selected inversion of the factor, O(n kd^2).
 * @param var  [out] n values
 * @param diag [out] optional: the reason of a failure
 * @return MLR_OK; MLR_E_BAD_STATE (not factored); MLR_E_INVALID_ARG (band or var NULL, n not
 *         the handle's order); MLR_E_OVERFLOW; MLR_E_NO_MEMORY
 * Allocates: yes, O(n kd) workspace, released before return. Threads: band is only read.
 */
MLR_API mlr_status mlr_band_inverse_diagonal(const mlr_band *band, double *var, size_t n,
                                             mlr_diag *diag);

/** Release the handle. NULL is a no-op. */
MLR_API void mlr_band_destroy(mlr_band *band);

#ifdef __cplusplus
}
#endif

#endif /* MLR_BAND_H */
