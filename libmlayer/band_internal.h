/* Internals of the banded solver, shared with the LGS (which fuses its right-hand side with
 * the forward sweep). Not installed. */
#ifndef MLR_BAND_INTERNAL_H
#define MLR_BAND_INTERNAL_H

#include "mlr_internal.h"

struct mlr_band {
    mlr_allocator alloc;
    size_t n, kd;
    int factored;
    size_t storage_bytes;
    double *dinv; /* n values, 1 / D(i); start of the single allocation */
    double *l;    /* n * kd values, L(i, i-k) at l[i*kd + k-1] */
};

/* Entry A(i, j), j <= i <= j + kd, of a matrix (used to assemble the CHOLMOD path). */
typedef double (*mlr_band_entry_fn)(const void *ctx, size_t i, size_t j);

/* Factor in place: on entry dinv[i] holds A(i,i) and l[i*kd + k-1] holds A(i,i-k) (zero
 * where i < k); on return the factor. Same statuses as mlr_band_factor. */
mlr_status mlr_band_factor_in_place(mlr_band *b);
void mlr_band_forward_row(const mlr_band *b, size_t i, double *x, size_t ldx, size_t m);
/* The same with the right-hand side row taken from yi (not aliasing x): x_i = y_i - ... */
void mlr_band_forward_row_from(const mlr_band *b, size_t i, const double *yi, double *x,
                               size_t ldx, size_t m);
/* Row r of the right-hand side into x, then its forward-sweep update (forward_row or
 * forward_row_from); called for r = 0, 1, ..., n-1 in order. */
typedef void (*mlr_band_row_fn)(const void *ctx, size_t r, double *x, size_t ldx, size_t m);

/* The whole solve: forward through forward_row, backward sweep; by cache-sized chunks in a
 * single pass over x when the factor allows it (see band.c). Never allocates. */
void mlr_band_solve_rows(const mlr_band *b, mlr_band_row_fn forward_row, const void *ctx,
                         double *x, size_t ldx, size_t m);
void mlr_band_backward(const mlr_band *b, double *x, size_t ldx, size_t m);

#endif
