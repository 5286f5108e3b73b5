/* GRBF cases, the C side of bench/python/bench_grbf.py without scipy: a 40 x 50 lattice of
 * centres on [0, 64]^2, 93 outputs (smooth waves), thin plate with linear terms:
 *  - grbf.fit_lattice: the interpolating fit at the lattice points (mlr_grbf_fit_lattice);
 *    elements = 2,000 centres;
 *  - grbf.eval: psi(x) B at 10,000 random points (mlr_grbf_eval); elements = points.
 * Threads: $MLR_BENCH_THREADS (default 2), as the Python bench. */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <math.h>
#include <stdlib.h>

#define ROWS 40
#define COLS 50
#define NC (ROWS * COLS)
#define NOUT 93

static size_t grbf_threads(void)
{
    const char *s = getenv("MLR_BENCH_THREADS");
    long v = s ? strtol(s, NULL, 10) : 2;
    return v >= 1 && v <= 64 ? (size_t)v : 2;
}

typedef struct grbf_state {
    size_t n;
    double xs[ROWS], ys[COLS], *c, *y, *coef, *x, *out;
} grbf_state;

static void grbf_teardown(void *p)
{
    grbf_state *s = p;
    free(s->c), free(s->y), free(s->coef), free(s->x), free(s->out), free(s);
}

static void *grbf_setup(size_t n)
{
    grbf_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->n = n;
    s->c = malloc(NC * 2 * sizeof *s->c);
    s->y = malloc(NC * NOUT * sizeof *s->y);
    s->coef = malloc((NC + 3) * NOUT * sizeof *s->coef);
    s->x = malloc(n * 2 * sizeof *s->x);
    s->out = malloc(n * NOUT * sizeof *s->out);
    if (!s->c || !s->y || !s->coef || !s->x || !s->out) {
        grbf_teardown(s);
        return NULL;
    }
    for (size_t r = 0; r < ROWS; r++)
        s->xs[r] = 64.0 * (double)r / (ROWS - 1);
    for (size_t q = 0; q < COLS; q++)
        s->ys[q] = 64.0 * (double)q / (COLS - 1);
    unsigned long long st = 7;
    double f[2][NOUT], ph[NOUT], amp[NOUT];
    for (size_t o = 0; o < NOUT; o++) {
        f[0][o] = 0.08 * mlr_bench_normal(&st);
        f[1][o] = 0.08 * mlr_bench_normal(&st);
        ph[o] = 6.283185307179586 * mlr_bench_uniform(&st);
        amp[o] = 1.0 + 19.0 * mlr_bench_uniform(&st);
    }
    for (size_t u = 0; u < NC; u++) {
        double px = s->xs[u / COLS], py = s->ys[u % COLS];
        s->c[2 * u] = px;
        s->c[2 * u + 1] = py;
        for (size_t o = 0; o < NOUT; o++)
            s->y[u * NOUT + o] = amp[o] * sin(px * f[0][o] + py * f[1][o] + ph[o]);
    }
    for (size_t i = 0; i < 2 * n; i++)
        s->x[i] = 64.0 * mlr_bench_uniform(&st);
    if (mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 0, s->xs, ROWS, s->ys, COLS, s->y, NOUT, NOUT,
                             grbf_threads(), s->coef, NOUT, NULL, NULL) != MLR_OK) {
        grbf_teardown(s);
        return NULL;
    }
    return s;
}

static double grbf_fit_run(void *p)
{
    grbf_state *s = p;
    if (mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 0, s->xs, ROWS, s->ys, COLS, s->y, NOUT, NOUT,
                             grbf_threads(), s->coef, NOUT, NULL, NULL) != MLR_OK)
        return -1.0;
    return s->coef[NC * NOUT];
}

static double grbf_eval_run(void *p)
{
    grbf_state *s = p;
    if (mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 0, s->c, NC, 2, s->coef, NOUT, NOUT, s->x, s->n, 2, 2,
                      grbf_threads(), s->out, NOUT, NULL, NULL) != MLR_OK)
        return -1.0;
    return s->out[0] + s->out[s->n * NOUT - 1];
}

const mlr_bench_case mlr_bench_grbf_cases[] = {
    {"grbf.fit_lattice/40x50,outputs=93", NC, grbf_setup, grbf_fit_run, grbf_teardown},
    {"grbf.eval/centres=2000,outputs=93,n=10000", 10000, grbf_setup, grbf_eval_run, grbf_teardown},
};
const size_t mlr_bench_grbf_count = sizeof mlr_bench_grbf_cases / sizeof mlr_bench_grbf_cases[0];
