/* Private parts shared by the GRBF files: grbf.c (kernels, basis matrices, evaluation) and
 * grbf_lattice.c (the interpolation on a symmetric lattice). Not installed. */
#ifndef MLR_GRBF_INTERNAL_H
#define MLR_GRBF_INTERNAL_H

#include "manifold/cluster_internal.h" /* cluster__first_nonfinite_row, parallel__run */
#include "manifold/grbf_eval_internal.h" /* grbf_eval_plan */
#include "manifold/grbf_panel.h"       /* PANEL, panel() */

/* The kernel loops get AVX-512 and AVX2 clones (MLR_CLONES, common/cpu.h); the loops are
 * written branch-free, with the bit manipulations of the log and exp reductions in integer
 * lanes, so every clone vectorizes. */

/* Rows per task of the parallel loop. */
#define GRBF_TASK_ROWS 32

/* 1 when the AVX-512 product kernel may run. */
int grbf__cpu_wide(void);

/* The basis rows of points x against the transposed centres ct, GRBF_TASK_ROWS rows a task. */
typedef struct basis_ctx {
    int kernel, poly;
    double s; /* Gaussian: 1 / width^2 */
    const double *ct, *x;
    size_t nc, ldx, n, dim, ldo;
    double *out;
} basis_ctx;
void grbf__basis_task(void *ctx, size_t task);

/* The kernel id and, for the Gaussian, its width. */
mlr_status grbf__check_kernel(int kernel, double width, mlr_diag *diag);
/* First row of p (n rows of dim values, stride ld) holding a NaN, an infinity or a coordinate
 * beyond 1e150, or n. */
size_t grbf__first_bad_row(const double *p, size_t n, size_t dim, size_t ld);
/* n rows at stride ld (in doubles) must fit a size_t of bytes. */
int grbf__rows_overflow(size_t n, size_t ld);

#endif
