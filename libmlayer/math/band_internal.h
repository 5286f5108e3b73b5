/* Internals of the banded solver, shared with the LGS (which fuses its right-hand side with
 * the forward sweep). Not installed. */
#ifndef MLR_BAND_INTERNAL_H
#define MLR_BAND_INTERNAL_H

#include "common/mlr_internal.h"

struct mlr_band {
    mlr_allocator alloc;
    size_t n, kd;
    int factored;
    size_t bad_row; /* after MLR_E_SINGULAR: the row whose pivot failed */
    size_t storage_bytes;
    double *dinv; /* n values, 1 / D(i); start of the single allocation */
    double *l;    /* n * kd values, L(i, i-k) at l[i*kd + k-1] */
};

/* Entry A(i, j), j <= i <= j + kd, of a matrix (used to assemble the CHOLMOD path). */
typedef double (*mlr_band_entry_fn)(const void *ctx, size_t i, size_t j);

/* One row of the pentadiagonal (kd = 2) LDL^T, the recurrence of band__factor_in_place:
 * from A(i,i), A(i,i-1), A(i,i-2) and the previous rows' L(i-1,i-2), 1/D(i-1), 1/D(i-2), set
 * L(i,i-1), L(i,i-2) and return D(i) (rows 0 and 1 ignore what they do not have). Shared with
 * the streaming smoother, which factors one row per pushed frame. */
static inline double band__ldl2_row(size_t i, double aii, double a1, double a2, double l1_prev,
                                    double dinv_prev1, double dinv_prev2, double *l1, double *l2)
{
    double d = aii;
    if (i >= 2) {
        const double b1 = a1 - a2 * l1_prev;
        *l2 = a2 * dinv_prev2;
        *l1 = b1 * dinv_prev1;
        d -= *l2 * a2 + *l1 * b1;
    } else if (i == 1) {
        *l1 = a1 * dinv_prev1;
        *l2 = 0.0;
        d -= *l1 * a1;
    } else {
        *l1 = *l2 = 0.0;
    }
    return d;
}

/* Factor in place: on entry dinv[i] holds A(i,i) and l[i*kd + k-1] holds A(i,i-k) (zero
 * where i < k); on return the factor. Same statuses as mlr_band_factor. */
mlr_status band__factor_in_place(mlr_band *b);
/* Forward-sweep update of row i, at xi, its predecessors at xi - ld and xi - 2 ld. */
void band__forward_row(const mlr_band *b, size_t i, double *xi, size_t ld, size_t m);
/* The same with the right-hand side row taken from yi (not aliasing xi): x_i = y_i - ... */
void band__forward_row_from(const mlr_band *b, size_t i, const double *yi, double *xi, size_t ld,
                            size_t m);
/* Either of the two, by whether yi is xi. */
void band__forward_row_any(const mlr_band *b, size_t i, const double *yi, double *xi, size_t ld,
                           size_t m);
/* Row r of the right-hand side into xr, then its forward-sweep update (one of the above, with
 * rows r-1 and r-2 at xr - ld and xr - 2 ld); called for r = 0, 1, ..., n-1 in order. xr is a
 * row of the solver's own buffer or of x: read the right-hand side from the caller's data. */
typedef void (*mlr_band_row_fn)(const void *ctx, size_t r, double *xr, size_t ld, size_t m);

/* The whole solve into x: forward through forward_row, backward sweep; by cache-sized chunks
 * in a single pass through a ring buffer when the factor allows it (see band.c; the ring is
 * allocated per call, and without memory the solve takes two plain sweeps over x). */
void band__solve_rows(const mlr_band *b, mlr_band_row_fn forward_row, const void *ctx, double *x,
                      size_t ldx, size_t m);
void band__backward(const mlr_band *b, double *x, size_t ldx, size_t m);

#endif
