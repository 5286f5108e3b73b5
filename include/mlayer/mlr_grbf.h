/*
 * Generalized radial basis functions (paper 2, equations 1-2): a mapping y = B psi(x),
 * psi(x) = [phi(|x - c_1|), ..., phi(|x - c_N|), 1, x_1, ..., x_dim], from points x to n_out
 * outputs. Here: the basis matrix of many points (mlr_grbf_basis, for fits done with the
 * caller's LAPACK), the evaluation psi(x) B without storing psi (mlr_grbf_eval), and the
 * interpolating fit on a symmetric lattice of centres (mlr_grbf_fit_lattice).
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

/**
 * Evaluate the mapping: out[i][o] = sum_k psi_k(x_i) coef[k][o] for the n points x_i, with
 * psi(x) = [phi(|x - c_1|), ..., phi(|x - c_N|), 1, x_1, ..., x_dim] as in mlr_grbf_basis,
 * without storing psi (blocks of it stay in the cache): the n x (N + 1 + dim) by
 * (N + 1 + dim) x n_out product in one pass.
 * Each output is summed over k = 0 .. N + dim in order (fused multiply-adds on CPUs with
 * AVX-512, else multiplies and adds): the same bits for every thread count and wherever a
 * point sits in x, on a given CPU.
 * @param coef   [in] N + 1 + dim rows of n_out values, row k at coef + k * ldcoef
 * @param out    [out] n rows of n_out values, row i at out + i * ldo; must not overlap the
 *               inputs
 * Other parameters as for mlr_grbf_basis.
 * @return MLR_OK; MLR_E_INVALID_ARG (as mlr_grbf_basis; n_out 0, coef or out NULL, ldcoef or
 *         ldo < n_out, a NaN or an infinity in coef); MLR_E_OVERFLOW; MLR_E_NO_MEMORY (nothing
 *         written).
 * Allocates: (N + 1 + dim) * n_out rounded up to 24 plus N * dim doubles (the coefficients
 * packed by blocks of 24 outputs, the centres transposed), released before returning. With more
 * than 192 outputs the kernel values are computed once per 192 outputs.
 * Threads: safe on separate outputs; starts up to n_threads - 1 threads.
 */
MLR_API mlr_status mlr_grbf_eval(int kernel, double width, const double *centers, size_t n_centers,
                                 size_t ldc, const double *coef, size_t ldcoef, size_t n_out,
                                 const double *x, size_t n, size_t ldx, size_t dim,
                                 size_t n_threads, double *out, size_t ldo,
                                 const mlr_allocator *alloc, mlr_diag *diag);

/**
 * Interpolation on a lattice: the coefficients B of the mapping (psi as in mlr_grbf_basis, the
 * centres the rows x cols lattice points, centre u = r * cols + c at (xs[r], ys[c])) whose
 * values at the lattice points are y: sum_j w_j phi(|c_u - c_j|) + a0 + a1 xs[r] + a2 ys[c] =
 * y_u, with the side conditions sum_j w_j = 0, sum_j w_j c_j = 0. coef receives w (rows 0 ..
 * N-1) and a0, a1, a2 (rows N .. N + 2), n_out columns each.
 *
 * The lattice must be symmetric (xs[r] + xs[rows-1-r] the same for all r within 1e-12 of the
 * span, ys likewise; a regular lattice is). The reflections x -> xs[0] + xs[rows-1] - x and
 * y -> ys[0] + ys[cols-1] - y map it onto itself and leave the kernel matrix K unchanged, so in
 * the basis of even and odd combinations of mirrored centres the bordered system splits into
 * four independent systems of about N/4 unknowns: the even-even one holds the constant term,
 * the odd-even one the x term, the even-odd one the y term, the odd-odd one none. In each, a
 * Householder reflection removes the side condition and leaves a positive definite matrix (the
 * thin plate is conditionally positive definite of order 2, the Gaussian positive definite),
 * factored by Cholesky. About 1/16 of the work of one LU of the whole system; the solution is
 * that of the whole system up to rounding (the reflected lattice is the lattice up to rounding
 * of the coordinates).
 * @param y      [in] N rows of n_out values, row u at y + u * ldy
 * @param coef   [out] N + 3 rows of n_out values, row k at coef + k * ldcoef
 * @return MLR_OK; MLR_E_INVALID_ARG (unknown kernel, bad width, rows or cols < 2, NULL pointers,
 *         n_out 0, ldy or ldcoef < n_out, n_threads not in 1 .. 64, non-finite or asymmetric
 *         coordinates, a NaN or an infinity in y); MLR_E_OVERFLOW; MLR_E_NO_MEMORY;
 *         MLR_E_SINGULAR (a class matrix is not numerically positive definite: two equal
 *         coordinates, or a Gaussian much wider than the spacing; coef is then not written).
 * Allocates: about (N / 4) (N + N / 4 + n_out) doubles of workspace (the kernel values of a
 * quarter of the centres, the four class matrices), released before returning.
 * Threads: up to 4 at once (one per class; the kernel values on n_threads); the result does not
 * depend on n_threads.
 */
MLR_API mlr_status mlr_grbf_fit_lattice(int kernel, double width, const double *xs, size_t rows,
                                        const double *ys, size_t cols, const double *y, size_t ldy,
                                        size_t n_out, size_t n_threads, double *coef,
                                        size_t ldcoef, const mlr_allocator *alloc, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_GRBF_H */
