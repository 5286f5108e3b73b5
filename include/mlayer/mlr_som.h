/*
 * Self-organizing map (Kohonen; paper 2 section 3): a rows x cols rectangular lattice of
 * units, each with a codebook vector of dim values, trained on the rows of a data matrix.
 *
 * Neighbourhood: Gaussian on the lattice, h(u, b) = exp(-|r_u - r_b|^2 / (2 sigma^2))
 * * exp(-|c_u - c_b|^2 / (2 sigma^2)) (rows and columns one unit apart; no wrap-around).
 *
 * Schedules (both decay exponentially from the *0 to the *1 option value):
 *  - batch (MLR_SOM_BATCH), epochs E: epoch e = 0 .. E-1 uses
 *        sigma_e = sigma0 * (sigma1 / sigma0)^(e / (E - 1))      (sigma0 when E == 1);
 *    each epoch finds every row's best-matching unit (BMU) with the codebook of the previous
 *    epoch, then sets w_u = sum_i h(u, bmu_i) x_i / sum_i h(u, bmu_i) (a unit whose
 *    denominator underflows to 0 keeps its vector). The Gaussian is separable, so the sums are
 *    two 1-D passes over the per-unit sums: O(n dim + rows cols (rows + cols) dim) per epoch
 *    after the BMU search.
 *  - online (MLR_SOM_ONLINE), T = E * n steps: step s presents one row (a seeded shuffle of
 *    the rows each epoch) and moves every unit toward it,
 *        w_u += alpha_s h_s(u, bmu) (x - w_u),
 *        sigma_s = sigma0 (sigma1 / sigma0)^(s / (T - 1)),  alpha_s = alpha0 (alpha1 / alpha0)^(s / (T - 1)),
 *    skipping units whose Gaussian factor h_s(u, bmu) is below MLR_SOM_CUTOFF (default 1e-3:
 *    lattice distance > 3.72 sigma; only that window is visited). With the default the
 *    quantization error stays within 1% of the full update (0: every unit moves, as MiniSom
 *    does); measured 2.413 against 2.415 for one epoch of a 65 x 65 map on 10,000 x 93 pose
 *    features. One pass over the codebook per step moves the units and finds the next row's BMU.
 * Defaults: sigma0 = max(rows, cols) / 2, sigma1 = 1, alpha0 = 0.5, alpha1 = 0.01. A train call
 * runs its whole schedule; calling it again starts a new schedule from the current codebook.
 * An untrained map is first initialized by mlr_som_init_random.
 *
 * BMU: nearest codebook vector, lowest unit index on exact ties; unit u is at row u / cols,
 * column u % cols. Quantization error: mean Euclidean distance of the rows to their BMU's
 * vector. Topographic error: fraction of rows whose BMU and second BMU are not neighbours
 * (8-neighbourhood: row and column differ by at most 1, the rule of MiniSom's 1.42 threshold).
 *
 * Determinism: every result is a function of the data, the options and the seed only; it is
 * bit-identical across runs and for every MLR_SOM_N_THREADS (rows are split into fixed blocks,
 * sums are taken in row order, lattice passes write disjoint outputs). Online training is
 * sequential by nature: its steps run one after the other, but each step (the update and the
 * next row's BMU search) is split over up to MLR_SOM_N_THREADS threads by fixed groups of 64
 * units when every thread gets at least 16,384 codebook values (a 65 x 65 map with dim 93:
 * up to 24 threads); each unit is computed the same way whatever the split, and the BMU is the
 * lowest (distance, index) over the parts. Those threads synchronize at every step (a short
 * spin, then they yield the core); a part whose thread has not started it by the time the
 * calling thread is done with its own is done by the calling thread (same values), so a core
 * busy with another process mostly costs the speed-up only (a thread descheduled in the middle
 * of its part still holds that step up).
 *
 * Export: the codebook travels as a relocatable blob (tag, version, size, FNV-1a hash; the
 * writer's byte order) that mlr_som_import checks before trusting it.
 */
#ifndef MLR_SOM_H
#define MLR_SOM_H

#include "mlr_common.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** A self-organizing map. Opaque. */
typedef struct mlr_som mlr_som;

/** Option keys of mlr_som_set. */
enum {
    MLR_SOM_SEED = 1,      /* integer in [0, 2^53], default 0 */
    MLR_SOM_N_THREADS = 2, /* 1 .. 64, default 1 */
    MLR_SOM_SIGMA0 = 3,    /* > 0, default max(rows, cols) / 2 */
    MLR_SOM_SIGMA1 = 4,    /* > 0, default 1 */
    MLR_SOM_ALPHA0 = 5,    /* in (0, 1], default 0.5 (online only) */
    MLR_SOM_ALPHA1 = 6,    /* in (0, 1], default 0.01 (online only) */
    MLR_SOM_CUTOFF = 7     /* in [0, 0.5], default 1e-3 (online only): see the online schedule */
};
/** Training modes. */
enum { MLR_SOM_BATCH = 0, MLR_SOM_ONLINE = 1 };

/**
 * Create an untrained map (codebook all zero).
 * @param out [out] new map or NULL; diag [out] optional reason
 * @return MLR_OK, MLR_E_INVALID_ARG (rows, cols or dim 0, rows * cols > INT32_MAX, out NULL),
 *         MLR_E_OVERFLOW, MLR_E_NO_MEMORY. Allocates: O(rows cols dim) through alloc (copied).
 */
MLR_API mlr_status mlr_som_create(size_t rows, size_t cols, size_t dim, const mlr_allocator *alloc,
                                  mlr_som **out, mlr_diag *diag);

/** Set an option (MLR_SOM_* keys). @return MLR_OK, MLR_E_INVALID_ARG (unknown key, bad value).
 *  Allocates: never. Threads: not while the map is in use. */
MLR_API mlr_status mlr_som_set(mlr_som *som, int option, double value, mlr_diag *diag);

/**
 * Initialize the codebook with rows of x drawn uniformly (with replacement) by the seed.
 * @return MLR_OK, MLR_E_INVALID_ARG (NULL x, n == 0, ldx < dim, NaN or infinity in x).
 * Allocates: never.
 */
MLR_API mlr_status mlr_som_init_random(mlr_som *som, const double *x, size_t n, size_t ldx,
                                       mlr_diag *diag);

/**
 * Train on n rows x (row i at x + i * ldx) for epochs epochs (schedules above).
 * @param mode MLR_SOM_BATCH or MLR_SOM_ONLINE
 * @return MLR_OK, MLR_E_INVALID_ARG (NULL x, n == 0, epochs == 0, ldx < dim, unknown mode,
 *         sigma1 > sigma0 or alpha1 > alpha0 is allowed; NaN or infinity in x),
 *         MLR_E_OVERFLOW, MLR_E_NO_MEMORY (the codebook is then unchanged).
 * Allocates: O(n + rows cols dim) workspace, released before returning.
 * Threads: both modes use up to MLR_SOM_N_THREADS threads (online: see above); results do not
 * depend on it.
 */
MLR_API mlr_status mlr_som_train(mlr_som *som, const double *x, size_t n, size_t ldx,
                                 size_t epochs, int mode, mlr_diag *diag);

/**
 * Best-matching unit of each row.
 * @param bmu    [out] n unit indices (row-major: u = r * cols + c)
 * @param dist   [out] optional n Euclidean distances to the BMU vector (direct differences)
 * @param second [out] optional n second-best units (== bmu when the map has one unit)
 * @return MLR_OK, MLR_E_INVALID_ARG (NULL x or bmu with n > 0, ldx < dim, non-finite x).
 * Allocates: never. Threads: MLR_SOM_N_THREADS; som is only read.
 */
MLR_API mlr_status mlr_som_bmu(const mlr_som *som, const double *x, size_t n, size_t ldx,
                               int32_t *bmu, double *dist, int32_t *second, mlr_diag *diag);

/**
 * Quantization error and topographic error of n rows (definitions above).
 * @param qe [out] optional; te [out] optional
 * @return MLR_OK, MLR_E_INVALID_ARG (NULL x, n == 0, ldx < dim, non-finite x).
 * Allocates: never. Threads: MLR_SOM_N_THREADS, result independent of it.
 */
MLR_API mlr_status mlr_som_errors(const mlr_som *som, const double *x, size_t n, size_t ldx,
                                  double *qe, double *te, mlr_diag *diag);

/** Codebook, (rows * cols) x dim row-major, owned by the map. */
MLR_API const double *mlr_som_codebook(const mlr_som *som);
/** Replace the codebook (rows * cols vectors, vector u at w + u * ldw).
 *  @return MLR_OK, MLR_E_INVALID_ARG (NULL, ldw < dim, non-finite). Allocates: never. */
MLR_API mlr_status mlr_som_set_codebook(mlr_som *som, const double *w, size_t ldw, mlr_diag *diag);
MLR_API size_t mlr_som_rows(const mlr_som *som);
MLR_API size_t mlr_som_cols(const mlr_som *som);
MLR_API size_t mlr_som_dim(const mlr_som *som);

/** Bytes of the blob mlr_som_export writes. */
MLR_API size_t mlr_som_export_size(const mlr_som *som);
/** Write the codebook blob into buf (size >= mlr_som_export_size).
 *  @return MLR_OK, MLR_E_INVALID_ARG (NULL, buffer too small). Allocates: never. */
MLR_API mlr_status mlr_som_export(const mlr_som *som, void *buf, size_t size, mlr_diag *diag);
/** A new map from a blob (options at their defaults).
 *  @return MLR_OK, MLR_E_PARSE (wrong tag, version, size, byte order or hash; non-finite or
 *  inconsistent dimensions), MLR_E_INVALID_ARG, MLR_E_NO_MEMORY. buf is only read. */
MLR_API mlr_status mlr_som_import(const void *buf, size_t size, const mlr_allocator *alloc,
                                  mlr_som **out, mlr_diag *diag);
/** Free the map. NULL is a no-op. */
MLR_API void mlr_som_destroy(mlr_som *som);

#ifdef __cplusplus
}
#endif

#endif /* MLR_SOM_H */
