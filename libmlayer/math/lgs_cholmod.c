/*
 * The sparse path of the LGS through SuiteSparse CHOLMOD (built only when CHOLMOD is found).
 * CHOLMOD types stay in this file; one cholmod_common lives in each handle. CHOLMOD allocates
 * through its own configured allocator (SuiteSparse_config), not through mlr_allocator.
 */
#include "math/lgs_internal.h"

#include <cholmod.h>
#include <stdlib.h>

struct mlr_sparse_spd {
    cholmod_common common;
    cholmod_factor *factor;
    size_t n;
};

static mlr_status status_of(const cholmod_common *c)
{
    switch (c->status) {
    case CHOLMOD_OK:
        return MLR_OK;
    case CHOLMOD_OUT_OF_MEMORY:
        return MLR_E_NO_MEMORY;
    case CHOLMOD_TOO_LARGE:
        return MLR_E_OVERFLOW;
    case CHOLMOD_NOT_POSDEF:
        return MLR_E_SINGULAR;
    default:
        return c->status < 0 ? MLR_E_INVALID_ARG : MLR_W_ILL_CONDITIONED;
    }
}

void lgs__sparse_spd_destroy(mlr_sparse_spd *s)
{
    if (!s)
        return;
    if (s->factor)
        cholmod_free_factor(&s->factor, &s->common);
    cholmod_finish(&s->common);
    free(s);
}

mlr_status lgs__sparse_spd_create(size_t n, size_t kd, mlr_band_entry_fn entry, const void *ctx,
                                  mlr_sparse_spd **out)
{
    *out = NULL;
    if (n > (size_t)1 << 30)
        return MLR_E_OVERFLOW;
    mlr_sparse_spd *s = calloc(1, sizeof *s);
    if (!s)
        return MLR_E_NO_MEMORY;
    s->n = n;
    cholmod_start(&s->common);
    s->common.print = 0;          /* never print */
    s->common.error_handler = NULL;
    s->common.supernodal = CHOLMOD_SIMPLICIAL; /* banded: no dense fronts to exploit */
    s->common.final_ll = 0;

    /* lower triangle, column by column: entries (j..j+kd, j) */
    size_t nnz = 0;
    for (size_t j = 0; j < n; j++)
        nnz += (n - j - 1 < kd ? n - j - 1 : kd) + 1;
    cholmod_sparse *A = cholmod_allocate_sparse(n, n, nnz, 1, 1, -1, CHOLMOD_REAL, &s->common);
    if (!A) {
        mlr_status st = status_of(&s->common);
        lgs__sparse_spd_destroy(s);
        return st < 0 ? st : MLR_E_NO_MEMORY;
    }
    int *Ap = A->p, *Ai = A->i;
    double *Ax = A->x;
    size_t k = 0;
    for (size_t j = 0; j < n; j++) {
        Ap[j] = (int)k;
        size_t last = j + kd < n - 1 ? j + kd : n - 1;
        for (size_t i = j; i <= last; i++) {
            Ai[k] = (int)i;
            Ax[k] = entry(ctx, i, j);
            k++;
        }
    }
    Ap[n] = (int)k;

    s->factor = cholmod_analyze(A, &s->common);
    mlr_status st = status_of(&s->common);
    if (s->factor && st >= 0) {
        cholmod_factorize(A, s->factor, &s->common);
        st = status_of(&s->common);
        if (st >= 0 && s->factor->minor < n)
            st = MLR_E_SINGULAR;
    }
    cholmod_free_sparse(&A, &s->common);
    if (!s->factor || st < 0) {
        lgs__sparse_spd_destroy(s);
        return st < 0 ? st : MLR_E_NO_MEMORY;
    }
    *out = s;
    return st;
}

mlr_status lgs__sparse_spd_solve(mlr_sparse_spd *s, double *x, size_t ldx, size_t m)
{
    const size_t n = s->n;
    if (m > (size_t)1 << 30)
        return MLR_E_OVERFLOW;
    /* CHOLMOD's dense matrices are column-major: transpose the row-major right-hand sides */
    cholmod_dense *B = cholmod_allocate_dense(n, m, n, CHOLMOD_REAL, &s->common);
    if (!B)
        return MLR_E_NO_MEMORY;
    double *bx = B->x;
    for (size_t r = 0; r < n; r++)
        for (size_t c = 0; c < m; c++)
            bx[c * n + r] = x[r * ldx + c];
    cholmod_dense *X = cholmod_solve(CHOLMOD_A, s->factor, B, &s->common);
    cholmod_free_dense(&B, &s->common);
    if (!X)
        return status_of(&s->common) < 0 ? status_of(&s->common) : MLR_E_NO_MEMORY;
    const double *xx = X->x;
    for (size_t r = 0; r < n; r++)
        for (size_t c = 0; c < m; c++)
            x[r * ldx + c] = xx[c * n + r];
    cholmod_free_dense(&X, &s->common);
    return MLR_OK;
}
