/*
 * k-means clustering (paper 2 section 4.1): k-means++ seeding, Lloyd iterations with an
 * optional Hamerly bound that skips most distance computations once the centres settle,
 * n_init restarts keeping the lowest inertia.
 *
 * What a fit computes (scikit-learn's KMeans(algorithm="lloyd") step for step, so the same
 * initial centres give the same labels and inertia up to rounding):
 *  - tolerance: tol_abs = tol * mean over columns of the column variances of x;
 *  - iteration i = 1 .. max_iter: assign every row to its nearest centre (lowest index on exact
 *    ties), recompute each centre as the mean of its rows; an empty cluster takes the row
 *    farthest from its assigned centre (as scikit-learn relocates it); stop when no label
 *    changed (strict convergence) or when the sum over centres of the squared centre shift
 *    is <= tol_abs; n_iter = i;
 *  - without strict convergence the rows are assigned once more to the final centres;
 *  - inertia = sum of squared distances of the rows to their centres (direct differences).
 * Distances in the assignment are ||x||^2 - 2 x.c + ||c||^2 over packed centres with a
 * vectorized kernel (AVX-512 or AVX2/FMA when the CPU has it, chosen at run time). The
 * Hamerly variant keeps, per row, an upper bound on the distance to its centre and a lower
 * bound on the distance to the second nearest, widened by a rounding margin: a row whose bounds prove its
 * centre cannot change is not searched, so labels equal those of plain Lloyd. With
 * MLR_KMEANS_AUTO the bounds are dropped for the rest of a run when, from the fifth iteration
 * on, they skip fewer than 1/32 of the rows. The per-cluster sums are rebuilt on the first
 * iteration of a run and then updated by the rows that changed cluster (in fixed row blocks,
 * so still bit-identical across thread counts).
 *
 * k-means++ (scikit-learn's greedy variant): the first centre is a uniformly drawn row; each
 * next one is the best, by resulting potential, of 2 + floor(ln k) rows drawn with probability
 * proportional to the squared distance to the nearest chosen centre. Draws come from a
 * seeded xoshiro256** generator (not NumPy's), so seeds do not match scikit-learn's.
 *
 * Threads: MLR_KMEANS_N_THREADS threads (default 1) share fixed row blocks whose partial sums
 * are reduced in block order: the result is bit-identical for every thread count.
 */
#ifndef MLR_KMEANS_H
#define MLR_KMEANS_H

#include "mlr_common.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** A k-means model: k centres in dim dimensions plus its options. Opaque. */
typedef struct mlr_kmeans mlr_kmeans;

/** Option keys of mlr_kmeans_set (values are doubles; integers must be exact). */
enum {
    MLR_KMEANS_MAX_ITER = 1,  /* >= 1, default 300 */
    MLR_KMEANS_TOL = 2,       /* >= 0, default 1e-4 (relative to the mean column variance) */
    MLR_KMEANS_N_INIT = 3,    /* >= 1, default 1; ignored when initial centres are given */
    MLR_KMEANS_SEED = 4,      /* integer in [0, 2^53], default 0 */
    MLR_KMEANS_N_THREADS = 5, /* 1 .. 64, default 1 */
    MLR_KMEANS_ALGORITHM = 6  /* MLR_KMEANS_AUTO (default), _LLOYD or _HAMERLY */
};
/** Values of MLR_KMEANS_ALGORITHM. AUTO uses the Hamerly bounds when k >= 4 (and drops them
 *  when they skip too few rows, see above). */
enum { MLR_KMEANS_AUTO = 0, MLR_KMEANS_LLOYD = 1, MLR_KMEANS_HAMERLY = 2 };

/**
 * Create a model with k centres of dimension dim (all zero until a fit or set_centers).
 * @param alloc  [in] copied; serves the model's whole life (NULL: malloc/free)
 * @param out    [out] new model, or NULL on failure
 * @param diag   [out] optional reason on failure
 * @return MLR_OK, MLR_E_INVALID_ARG (k == 0, dim == 0, k > INT32_MAX, out NULL),
 *         MLR_E_OVERFLOW, MLR_E_NO_MEMORY. Allocates: O(k dim). Threads: any.
 */
MLR_API mlr_status mlr_kmeans_create(size_t k, size_t dim, const mlr_allocator *alloc,
                                     mlr_kmeans **out, mlr_diag *diag);

/**
 * Set an option (see the MLR_KMEANS_* keys).
 * @return MLR_OK, MLR_E_INVALID_ARG (unknown key or value out of range; the option is kept).
 * Allocates: never. Threads: not while the model is in use.
 */
MLR_API mlr_status mlr_kmeans_set(mlr_kmeans *km, int option, double value, mlr_diag *diag);

/**
 * Fit the model to n rows x (row i at x + i * ldx, dim values each).
 * @param init    [in] optional k initial centres (row j at init + j * ldinit) for a single run;
 *                NULL: n_init runs seeded by k-means++, the lowest inertia kept
 * @param labels  [out] optional n cluster indices of the rows (int32)
 * @return MLR_OK (also when max_iter was reached: see mlr_kmeans_n_iter);
 *         MLR_E_INVALID_ARG (NULL x, n == 0, k > n, ldx < dim, ldinit < dim, a NaN or an
 *         infinity in x or init), MLR_E_OVERFLOW, MLR_E_NO_MEMORY; on error the model keeps its
 *         previous centres.
 * Allocates: O(n + k dim) workspace, released before returning.
 * Threads: uses MLR_KMEANS_N_THREADS threads; the model must not be used by others meanwhile.
 * labels may not alias x or init.
 */
MLR_API mlr_status mlr_kmeans_fit(mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                                  const double *init, size_t ldinit, int32_t *labels,
                                  mlr_diag *diag);

/**
 * Nearest centre of each of n rows (lowest index on exact ties).
 * @param labels [out] n indices; dist2 [out] optional n squared distances (direct differences)
 * @return MLR_OK, MLR_E_INVALID_ARG (NULL pointers with n > 0, ldx < dim, non-finite x).
 * Allocates: never. Threads: single-threaded; km is only read, so calls may run concurrently.
 */
MLR_API mlr_status mlr_kmeans_predict(const mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                                      int32_t *labels, double *dist2, mlr_diag *diag);

/** Replace the centres (k rows, row j at c + j * ldc): import of a trained model.
 *  @return MLR_OK, MLR_E_INVALID_ARG (NULL, ldc < dim, non-finite). Allocates: never. */
MLR_API mlr_status mlr_kmeans_set_centers(mlr_kmeans *km, const double *c, size_t ldc,
                                          mlr_diag *diag);

/** Centres, k x dim row-major, owned by the model (valid until the next fit/set/destroy). */
MLR_API const double *mlr_kmeans_centers(const mlr_kmeans *km);
/** Inertia of the last fit (sum of squared distances to the centres); NaN before any fit. */
MLR_API double mlr_kmeans_inertia(const mlr_kmeans *km);
/** Lloyd iterations run by the last fit (of the kept run); 0 before any fit. */
MLR_API size_t mlr_kmeans_n_iter(const mlr_kmeans *km);
/** Rows whose search the Hamerly bounds skipped over the kept run (0 for plain Lloyd). */
MLR_API size_t mlr_kmeans_n_skipped(const mlr_kmeans *km);
MLR_API size_t mlr_kmeans_k(const mlr_kmeans *km);
MLR_API size_t mlr_kmeans_dim(const mlr_kmeans *km);
/** Free the model. NULL is a no-op. */
MLR_API void mlr_kmeans_destroy(mlr_kmeans *km);

#ifdef __cplusplus
}
#endif

#endif /* MLR_KMEANS_H */
