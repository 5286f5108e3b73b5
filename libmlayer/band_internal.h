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

/* Entry A(i, j), j <= i <= j + kd, of the matrix to factor. */
typedef double (*mlr_band_entry_fn)(const void *ctx, size_t i, size_t j);

mlr_status mlr_band_factor_fn(mlr_band *b, mlr_band_entry_fn entry, const void *ctx);
void mlr_band_forward_row(const mlr_band *b, size_t i, double *x, size_t ldx, size_t m);
/* The same with the right-hand side row taken from yi (not aliasing x): x_i = y_i - ... */
void mlr_band_forward_row_from(const mlr_band *b, size_t i, const double *yi, double *x,
                               size_t ldx, size_t m);
void mlr_band_backward(const mlr_band *b, double *x, size_t ldx, size_t m);

#endif
