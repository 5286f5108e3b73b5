/* Internals of the LGS shared by its banded and CHOLMOD paths. Not installed. */
#ifndef MLR_LGS_INTERNAL_H
#define MLR_LGS_INTERNAL_H

#include "math/band_internal.h"

/* (L^T L)(i, j) for j <= i < n, L the (n - p) x n difference matrix of order p (0 when n <= p:
 * L has no rows). Shared with the streaming smoother (stream.c) and
 * the layers (layers_batch.c). */
double lgs__ltl_entry(size_t n, unsigned p, size_t i, size_t j);

/* Sparse SPD solver behind MLR_LGS_CHOLMOD (lgs_cholmod.c, only built with CHOLMOD). */
typedef struct mlr_sparse_spd mlr_sparse_spd;

/* Assemble the n x n matrix of bandwidth kd from entry(), then analyze and factor it. */
mlr_status lgs__sparse_spd_create(size_t n, size_t kd, mlr_band_entry_fn entry, const void *ctx,
                                  mlr_sparse_spd **out);
/* Solve in place: x holds n rows of m right-hand-side values (row stride ldx). */
mlr_status lgs__sparse_spd_solve(mlr_sparse_spd *s, double *x, size_t ldx, size_t m);
void lgs__sparse_spd_destroy(mlr_sparse_spd *s);

#endif
