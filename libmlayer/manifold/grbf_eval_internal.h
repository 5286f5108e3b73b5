/* The GRBF evaluation in parts (grbf.c), for the generator (generate/generator.c). Not
 * installed. */
#ifndef MLR_GRBF_EVAL_INTERNAL_H
#define MLR_GRBF_EVAL_INTERNAL_H

#include <stddef.h>

/* mlr_grbf_eval in parts, for a caller that evaluates the same centres and coefficients
 * many times (the generator, libmlayer/generate/generator.c): the transposed centres and the
 * packed coefficients made once in a workspace the caller owns, then rows evaluated with the
 * very sums of mlr_grbf_eval (every output summed over the basis columns in order, whatever
 * the rows evaluated together), on the calling thread, allocating nothing. The arguments are
 * those mlr_grbf_eval checks; these functions check nothing. */
typedef struct grbf_eval_plan {
    int kernel, wide;
    double s;                /* Gaussian: 1 / width^2 */
    const double *ct, *pan;  /* into the workspace */
    size_t nc, dim, K, npanel, n_out;
} grbf_eval_plan;
/* Bytes of the workspace of a plan; 0 when they overflow. */
size_t grbf__eval_plan_bytes(size_t n_centers, size_t dim, size_t n_out);
/* Fill ws (grbf__eval_plan_bytes, 8-byte aligned) and p; p points into ws. */
void grbf__eval_plan_init(grbf_eval_plan *p, int kernel, double width, const double *centers,
                          size_t n_centers, size_t ldc, const double *coef, size_t ldcoef,
                          size_t n_out, size_t dim, double *ws);
/* out (n rows, stride ldo) = the mapping of the n points x (stride ldx). */
void grbf__eval_plan_rows(const grbf_eval_plan *p, const double *x, size_t n, size_t ldx,
                          double *out, size_t ldo);

#endif
