/*
 * Generalized radial basis functions (paper 2, equations 1-2): the basis matrix of a GRBF
 * mapping y = B psi(x), psi(x) = [phi(|x - c_1|), ..., phi(|x - c_N|), 1, x_1, ..., x_dim], for
 * many points at once. The fit itself (a dense symmetric or least-squares solve) is left to the
 * caller's LAPACK; this is the part no BLAS does: N kernel values per point.
 *
 * Kernels, with u = |x - c| and d2 = u^2 summed over the coordinates in order (exactly 0 for a
 * point equal to a centre):
 *  - MLR_GRBF_THIN_PLATE: phi = u^2 log u = d2 log(d2) / 2, 0 for d2 < DBL_MIN (u = 0 and
 *    distances below 1.5e-154, where the value is below 1e-305 anyway);
 *  - MLR_GRBF_GAUSSIAN: phi = exp(-d2 / width^2), 0 once d2 / width^2 > 708 (below 3.3e-308).
 * The logarithm and the exponential are evaluated by fixed polynomial approximations in vector
 * lanes (fdlibm's log reduction; exp by Cody-Waite reduction and a degree-13 polynomial):
 * within 2 units in the last place of the libm values, and the same bits whatever the thread
 * count or the row a point sits in.
 */
#ifndef MLR_GRBF_H
#define MLR_GRBF_H

#include "mlr_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Kernels of mlr_grbf_basis. */
enum { MLR_GRBF_THIN_PLATE = 0, MLR_GRBF_GAUSSIAN = 1 };

/**
 * Basis matrix: row i of out (at out + i * ldo) receives phi(|x_i - c_j|) for j = 0 .. n_centers-1
 * and then, with poly != 0, 1 and the dim coordinates of x_i (n_centers + 1 + dim columns).
 * @param kernel     MLR_GRBF_THIN_PLATE or MLR_GRBF_GAUSSIAN
 * @param width      Gaussian width (finite, >= 1e-150); ignored by the thin plate
 * @param centers    [in] n_centers points of dim coordinates, centre j at centers + j * ldc
 * @param x          [in] n points, point i at x + i * ldx (may be the centres themselves)
 * @param n_threads  1 .. 64 threads over blocks of rows (the values do not depend on it)
 * @param out        [out] n rows, stride ldo >= n_centers (+ 1 + dim with poly); must not
 *                   overlap centers or x
 * @param alloc      allocator of the workspace (NULL: malloc/free)
 * @return MLR_OK; MLR_E_INVALID_ARG (unknown kernel, bad width, n_centers or dim 0, NULL
 *         pointers with a nonzero count, ldc or ldx < dim, ldo too small, n_threads out of range,
 *         a NaN or an infinity or a coordinate beyond 1e150 in centers or x); MLR_E_OVERFLOW;
 *         MLR_E_NO_MEMORY (nothing written).
 * Allocates: n_centers * dim doubles (the centres transposed), released before returning.
 * Threads: safe on separate outputs; starts up to n_threads - 1 threads.
 */
MLR_API mlr_status mlr_grbf_basis(int kernel, double width, const double *centers,
                                  size_t n_centers, size_t ldc, const double *x, size_t n,
                                  size_t ldx, size_t dim, int poly, size_t n_threads, double *out,
                                  size_t ldo, const mlr_allocator *alloc, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_GRBF_H */
