/* LGS cases: factor + solve of the smoothing system at clip sizes (the paper's longest clip,
 * 2,526 frames x 96 channels) and at corpus sizes (100,000 x 127), against a plain copy of the
 * same data (the memory floor). */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <stdlib.h>
#include <string.h>

typedef struct lgs_state {
    size_t n, m;
    double *y, *x;
} lgs_state;

static void *setup(size_t n, size_t m)
{
    lgs_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->n = n, s->m = m;
    s->y = malloc(n * m * sizeof(double));
    s->x = malloc(n * m * sizeof(double));
    if (!s->y || !s->x) {
        free(s->y), free(s->x), free(s);
        return NULL;
    }
    unsigned long long seed = 42;
    for (size_t j = 0; j < m; j++) {
        double acc = 0.0;
        for (size_t i = 0; i < n; i++) {
            acc += 0.01 * mlr_bench_normal(&seed);
            s->y[i * m + j] = acc;
        }
    }
    memset(s->x, 0, n * m * sizeof(double));
    return s;
}

static void *setup_clip(size_t n) { return setup(n / 96, 96); }
static void *setup_big(size_t n) { return setup(n / 127, 127); }

static void teardown(void *p)
{
    lgs_state *s = p;
    free(s->y), free(s->x), free(s);
}

static double solve_order(lgs_state *s, unsigned order)
{
    mlr_lgs *g = NULL;
    if (mlr_lgs_create(s->n, order, 4.0, 1.0, NULL, s->n, MLR_LGS_BANDED, NULL, &g, NULL) < 0)
        return -1.0;
    mlr_lgs_solve(g, s->y, s->m, s->m, s->x, s->m, NULL);
    mlr_lgs_destroy(g);
    return s->x[(s->n / 2) * s->m];
}

/* Into a newly allocated x (as a Python caller gets): the page faults of new memory count, and
 * n_threads 0 lets a second thread map x's pages while the solve runs. */
static double solve_new_x(lgs_state *s, size_t n_threads)
{
    mlr_lgs *g = NULL;
    double *x = malloc(s->n * s->m * sizeof(double));
    if (!x || mlr_lgs_create(s->n, 2, 4.0, 1.0, NULL, s->n, MLR_LGS_BANDED, NULL, &g, NULL) < 0) {
        free(x);
        return -1.0;
    }
    mlr_lgs_solve_mt(g, s->y, s->m, s->m, x, s->m, n_threads, NULL);
    mlr_lgs_destroy(g);
    const double v = x[(s->n / 2) * s->m];
    free(x);
    return v;
}

static double run_new_x_1(void *p) { return solve_new_x(p, 1); }
static double run_new_x_auto(void *p) { return solve_new_x(p, 0); }

static double run_copy_new_x(void *p)
{
    lgs_state *s = p;
    double *x = malloc(s->n * s->m * sizeof(double));
    if (!x)
        return -1.0;
    memcpy(x, s->y, s->n * s->m * sizeof(double));
    const double v = x[(s->n / 2) * s->m];
    free(x);
    return v;
}

static double run_order2(void *p) { return solve_order(p, 2); }
static double run_order1(void *p) { return solve_order(p, 1); }

static double run_copy(void *p)
{
    lgs_state *s = p;
    memcpy(s->x, s->y, s->n * s->m * sizeof(double));
    return s->x[(s->n / 2) * s->m];
}

static double run_variance(void *p)
{
    lgs_state *s = p;
    mlr_lgs *g = NULL;
    if (mlr_lgs_create(s->n, 2, 4.0, 1.0, NULL, s->n, MLR_LGS_BANDED, NULL, &g, NULL) < 0)
        return -1.0;
    mlr_lgs_variance(g, s->x, s->n, NULL);
    mlr_lgs_destroy(g);
    return s->x[s->n / 2];
}

const mlr_bench_case mlr_bench_lgs_cases[] = {
    {"lgs.order2/n=2526,m=96", 2526 * 96, setup_clip, run_order2, teardown},
    {"lgs.order1/n=2526,m=96", 2526 * 96, setup_clip, run_order1, teardown},
    {"copy/n=2526,m=96", 2526 * 96, setup_clip, run_copy, teardown},
    {"lgs.variance/n=100000", 100000 * 96, setup_clip, run_variance, teardown},
    {"lgs.order2/n=100000,m=127", 100000 * 127, setup_big, run_order2, teardown},
    {"copy/n=100000,m=127", 100000 * 127, setup_big, run_copy, teardown},
    {"lgs.order2.new_x,1_thread/n=100000,m=127", 100000 * 127, setup_big, run_new_x_1, teardown},
    {"lgs.order2.new_x,auto/n=100000,m=127", 100000 * 127, setup_big, run_new_x_auto, teardown},
    {"copy.new_x/n=100000,m=127", 100000 * 127, setup_big, run_copy_new_x, teardown},
};
const size_t mlr_bench_lgs_count = sizeof mlr_bench_lgs_cases / sizeof mlr_bench_lgs_cases[0];
