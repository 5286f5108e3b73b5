/* Self-organizing map: batch and online training, BMUs, errors, blobs. See mlr_som.h. */
#include "manifold/cluster_internal.h"

#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>

struct mlr_som {
    mlr_allocator a;
    size_t rows, cols, dim, units;
    double *w;          /* units * dim codebook */
    mlr_packed pk;      /* packed copy of w for the search */
    size_t n_threads;
    uint64_t seed;
    double sigma0, sigma1, alpha0, alpha1;
    double cutoff;      /* online: Gaussian factors below it count as 0 */
    int initialized;
    size_t bytes;       /* of the single allocation after the struct */
};

#define SUB 64
#define MLR_SOM_DEFAULT_CUTOFF 1e-3
#define N_BLOCKS 16
static const char som_tag[8] = {'M', 'L', 'R', 'S', 'O', 'M', 0, 0};
#define SOM_BLOB_VERSION 1u

mlr_status mlr_som_create(size_t rows, size_t cols, size_t dim, const mlr_allocator *alloc,
                          mlr_som **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (rows == 0 || cols == 0 || dim == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lattice %zu x %zu with dim %zu: every size must be >= 1", rows,
                                cols, dim);
    size_t units, nw, np, bytes;
    if (common__mul_size(rows, cols, &units) || units > INT32_MAX)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lattice %zu x %zu is too large",
                                rows, cols);
    size_t kpad = cluster__packed_kpad(units);
    if (common__mul_size(units, dim, &nw) || common__mul_size(kpad, dim + 1, &np) ||
        common__mul_size(nw + np + 16, sizeof(double), &bytes))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "codebook size overflows");
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_som *s = common__alloc(&a, sizeof *s);
    if (!s)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "som create: out of memory for the map");
    memset(s, 0, sizeof *s);
    s->a = a;
    s->w = common__alloc(&a, bytes);
    if (!s->w) {
        common__free(&a, s, sizeof *s);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "som create: out of memory for a %zu x %zu codebook", units, dim);
    }
    s->bytes = bytes;
    s->rows = rows;
    s->cols = cols;
    s->dim = dim;
    s->units = units;
    memset(s->w, 0, nw * sizeof(double));
    /* the packed blocks start on a 64-byte boundary (and so does every block of 16 units):
     * the vector loads of the search then never straddle two cache lines */
    uintptr_t at = (uintptr_t)(s->w + nw);
    s->pk.pc = s->w + nw + ((64 - at % 64) % 64) / sizeof(double);
    s->pk.cn = s->pk.pc + kpad * dim;
    s->pk.k = units;
    s->pk.kpad = kpad;
    s->pk.dim = dim;
    s->pk.isa = cpu__isa(MLR_ISA_BEST);
    cluster__packed_fill(&s->pk, s->w, dim);
    s->n_threads = 1;
    s->sigma0 = (double)(rows > cols ? rows : cols) / 2.0;
    s->sigma1 = 1.0;
    s->alpha0 = 0.5;
    s->alpha1 = 0.01;
    s->cutoff = MLR_SOM_DEFAULT_CUTOFF;
    *out = s;
    return MLR_OK;
}

void mlr_som_destroy(mlr_som *som)
{
    if (!som)
        return;
    mlr_allocator a = som->a;
    common__free(&a, som->w, som->bytes);
    common__free(&a, som, sizeof *som);
}

mlr_status mlr_som_set(mlr_som *som, int option, double v, mlr_diag *diag)
{
    if (!som)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "som is NULL");
    int ok = 0;
    switch (option) {
    case MLR_SOM_SEED:
        if ((ok = v >= 0 && v <= 9007199254740992.0 && floor(v) == v))
            som->seed = (uint64_t)v;
        break;
    case MLR_SOM_N_THREADS:
        if ((ok = v >= 1 && v <= MLR_MAX_THREADS && floor(v) == v))
            som->n_threads = (size_t)v;
        break;
    case MLR_SOM_SIGMA0:
    case MLR_SOM_SIGMA1:
        if ((ok = v > 0 && v < INFINITY))
            *(option == MLR_SOM_SIGMA0 ? &som->sigma0 : &som->sigma1) = v;
        break;
    case MLR_SOM_ALPHA0:
    case MLR_SOM_ALPHA1:
        if ((ok = v > 0 && v <= 1))
            *(option == MLR_SOM_ALPHA0 ? &som->alpha0 : &som->alpha1) = v;
        break;
    case MLR_SOM_CUTOFF:
        if ((ok = v >= 0 && v <= 0.5))
            som->cutoff = v;
        break;
    default:
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown SOM option %d", option);
    }
    return ok ? MLR_OK
              : common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                 "SOM option %d: value %g out of range", option, v);
}

static mlr_status check_data(const mlr_som *som, const double *x, size_t n, size_t ldx,
                             mlr_diag *diag)
{
    if (!som)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "som is NULL");
    if (!x || n == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "empty data: no rows");
    if (ldx < som->dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: row stride %zu < dim %zu", ldx, som->dim);
    size_t bad = cluster__first_nonfinite_row(x, n, som->dim, ldx);
    if (bad < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "row %zu holds a NaN or an infinity", bad);
    return MLR_OK;
}

mlr_status mlr_som_init_random(mlr_som *som, const double *x, size_t n, size_t ldx, mlr_diag *diag)
{
    mlr_status st = check_data(som, x, n, ldx, diag);
    if (st)
        return st;
    mlr_rng rng;
    mlr_rng_seed(&rng, som->seed);
    for (size_t u = 0; u < som->units; u++)
        memcpy(som->w + u * som->dim, x + mlr_rng_below(&rng, n) * ldx, som->dim * sizeof(double));
    cluster__packed_fill(&som->pk, som->w, som->dim);
    som->initialized = 1;
    return MLR_OK;
}

/* ---- BMU search over fixed row blocks --------------------------------------------------- */

typedef struct bmu_ctx {
    const mlr_som *som;
    const double *x;
    size_t n, ldx;
    int32_t *bmu, *second;
    double *dist;
    double part_qe[N_BLOCKS];
    size_t part_te[N_BLOCKS];
    int errors; /* accumulate qe/te instead of writing per-row outputs */
} bmu_ctx;

static void bmu_task(void *ctx, size_t b)
{
    bmu_ctx *c = ctx;
    const mlr_som *s = c->som;
    size_t lo = c->n / N_BLOCKS * b + (b < c->n % N_BLOCKS ? b : c->n % N_BLOCKS);
    size_t hi = lo + c->n / N_BLOCKS + (b < c->n % N_BLOCKS ? 1 : 0);
    int32_t lb[SUB], l2[SUB];
    double db[SUB];
    double qe = 0;
    size_t te = 0;
    for (size_t i0 = lo; i0 < hi; i0 += SUB) {
        size_t m = hi - i0 < SUB ? hi - i0 : SUB;
        const double *xr = c->x + i0 * c->ldx;
        int32_t *best = c->bmu ? c->bmu + i0 : lb;
        int32_t *sec = c->second ? c->second + i0 : (c->errors ? l2 : NULL);
        cluster__nearest2(&s->pk, xr, c->ldx, NULL, m, NULL, best, db, NULL, sec);
        if (c->dist || c->errors) {
            for (size_t r = 0; r < m; r++) {
                double d = sqrt(cluster__dist2(xr + r * c->ldx, s->w + (size_t)best[r] * s->dim,
                                               s->dim, s->pk.isa));
                if (c->dist)
                    c->dist[i0 + r] = d;
                qe += d;
            }
        }
        if (c->errors) {
            for (size_t r = 0; r < m; r++) {
                size_t u1 = (size_t)best[r], u2 = (size_t)sec[r];
                size_t r1 = u1 / s->cols, c1 = u1 % s->cols, r2 = u2 / s->cols, c2 = u2 % s->cols;
                size_t dr = r1 > r2 ? r1 - r2 : r2 - r1, dc = c1 > c2 ? c1 - c2 : c2 - c1;
                if (dr > 1 || dc > 1)
                    te++;
            }
        }
    }
    c->part_qe[b] = qe;
    c->part_te[b] = te;
}

mlr_status mlr_som_bmu(const mlr_som *som, const double *x, size_t n, size_t ldx, int32_t *bmu,
                       double *dist, int32_t *second, mlr_diag *diag)
{
    if (som && n == 0)
        return MLR_OK;
    mlr_status st = check_data(som, x, n, ldx, diag);
    if (st)
        return st;
    if (!bmu)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "bmu is NULL");
    bmu_ctx c;
    memset(&c, 0, sizeof c);
    c.som = som;
    c.x = x;
    c.n = n;
    c.ldx = ldx;
    c.bmu = bmu;
    c.dist = dist;
    c.second = second;
    parallel__run(som->n_threads, N_BLOCKS, bmu_task, &c);
    return MLR_OK;
}

mlr_status mlr_som_errors(const mlr_som *som, const double *x, size_t n, size_t ldx, double *qe,
                          double *te, mlr_diag *diag)
{
    mlr_status st = check_data(som, x, n, ldx, diag);
    if (st)
        return st;
    bmu_ctx c;
    memset(&c, 0, sizeof c);
    c.som = som;
    c.x = x;
    c.n = n;
    c.ldx = ldx;
    c.errors = 1;
    parallel__run(som->n_threads, N_BLOCKS, bmu_task, &c);
    double q = 0;
    size_t t = 0;
    for (size_t b = 0; b < N_BLOCKS; b++) {
        q += c.part_qe[b];
        t += c.part_te[b];
    }
    if (qe)
        *qe = q / (double)n;
    if (te)
        *te = (double)t / (double)n;
    return MLR_OK;
}

/* ---- batch training ------------------------------------------------------------------------ */

typedef struct batch_ctx {
    mlr_som *som;
    const double *gr, *gc; /* Gaussian of lattice row / column offsets, indexed by |offset| */
    double *sum;           /* units * (dim + 1): per-unit sums then numerators */
    double *tmp;           /* units * (dim + 1) */
} batch_ctx;

/* tmp[r][cu] = sum_cb gc[|cu - cb|] sum[r][cb], for lattice row r */
static void conv_cols_task(void *ctx, size_t r)
{
    batch_ctx *c = ctx;
    const size_t cols = c->som->cols, w = c->som->dim + 1;
    const double *src = c->sum + r * cols * w;
    double *dst = c->tmp + r * cols * w;
    memset(dst, 0, cols * w * sizeof(double));
    for (size_t cu = 0; cu < cols; cu++) {
        double *o = dst + cu * w;
        for (size_t cb = 0; cb < cols; cb++) {
            double g = c->gc[cu > cb ? cu - cb : cb - cu];
            if (g == 0.0)
                continue;
            const double *in = src + cb * w;
            for (size_t t = 0; t < w; t++)
                o[t] += g * in[t];
        }
    }
}

/* sum[ru][c] = sum_rb gr[|ru - rb|] tmp[rb][c]; then the new vectors of lattice row ru */
static void conv_rows_task(void *ctx, size_t ru)
{
    batch_ctx *c = ctx;
    mlr_som *s = c->som;
    const size_t rows = s->rows, cols = s->cols, dim = s->dim, w = dim + 1;
    double *dst = c->sum + ru * cols * w;
    memset(dst, 0, cols * w * sizeof(double));
    for (size_t rb = 0; rb < rows; rb++) {
        double g = c->gr[ru > rb ? ru - rb : rb - ru];
        if (g == 0.0)
            continue;
        const double *in = c->tmp + rb * cols * w;
        for (size_t q = 0; q < cols * w; q++)
            dst[q] += g * in[q];
    }
    for (size_t cu = 0; cu < cols; cu++) {
        const double *o = dst + cu * w;
        if (!(o[dim] > 0))
            continue;
        double inv = 1.0 / o[dim];
        double *wv = s->w + (ru * cols + cu) * dim;
        for (size_t t = 0; t < dim; t++)
            wv[t] = o[t] * inv;
    }
}

static void gauss_table(double *g, size_t len, double sigma)
{
    double k = -0.5 / (sigma * sigma);
    for (size_t d = 0; d < len; d++)
        g[d] = exp(k * (double)d * (double)d);
}

static double decay(double v0, double v1, size_t step, size_t steps)
{
    if (steps <= 1)
        return v0;
    return v0 * pow(v1 / v0, (double)step / (double)(steps - 1));
}

/* ---- online training ------------------------------------------------------------------------ */

/* Neighbourhood of one online step around unit b into h (kpad values, zero outside) and the
 * block marks: h_u = alpha exp(-dr^2 / 2 sigma^2) exp(-dc^2 / 2 sigma^2), set to 0 where the
 * Gaussian factor is below cut (the square window of half-width sigma sqrt(2 ln(1 / cut)) is all
 * that is visited). Returns the window as rows [*r0, *r1) and columns [*c0, *c1). */
static void online_window(const mlr_som *s, size_t b, double sigma, double alpha, double cut,
                          double *gr, double *gc, double *h, unsigned char *active, size_t win[4])
{
    const size_t rows = s->rows, cols = s->cols;
    size_t br = b / cols, bc = b % cols;
    double reach = cut > 0 ? sigma * sqrt(-2.0 * log(cut)) : INFINITY;
    size_t rad = reach >= (double)(rows + cols) ? rows + cols : (size_t)reach;
    size_t r0 = br > rad ? br - rad : 0, r1 = br + rad + 1 < rows ? br + rad + 1 : rows;
    size_t c0 = bc > rad ? bc - rad : 0, c1 = bc + rad + 1 < cols ? bc + rad + 1 : cols;
    double k = -0.5 / (sigma * sigma), hmin = cut * alpha;
    for (size_t r = r0; r < r1; r++)
        gr[r] = alpha * exp(k * (double)((r - br) * (r - br)));
    for (size_t c = c0; c < c1; c++)
        gc[c] = exp(k * (double)((c - bc) * (c - bc)));
    for (size_t r = r0; r < r1; r++) {
        size_t u0 = r * cols;
        for (size_t c = c0; c < c1; c++) {
            double v = gr[r] * gc[c];
            h[u0 + c] = v < hmin ? 0.0 : v;
        }
        for (size_t jb = (u0 + c0) / MLR_PACK; jb * MLR_PACK < u0 + c1; jb++)
            active[jb] = 1;
    }
    win[0] = r0, win[1] = r1, win[2] = c0, win[3] = c1;
}

static void online_clear(const mlr_som *s, double *h, unsigned char *active, const size_t win[4])
{
    for (size_t r = win[0]; r < win[1]; r++) {
        size_t u0 = r * s->cols;
        memset(h + u0 + win[2], 0, (win[3] - win[2]) * sizeof(double));
        for (size_t jb = (u0 + win[2]) / MLR_PACK; jb * MLR_PACK < u0 + win[3]; jb++)
            active[jb] = 0;
    }
}

/* Online steps shared by a team: the caller sweeps part 0 of every step and n_parts - 1
 * workers the other parts (cluster__packed_sweep parts, disjoint units). Per step the caller
 * publishes the step number in go (release) after writing x, xnext, h and active. Part q is
 * done by whoever claims it first for the step (a compare-and-swap of the step number into its
 * claim word): its worker as soon as it sees go, or the caller once its own part is done. So a
 * worker that the system has not run in time (a core busy with another process) costs nothing
 * but its share of the speed-up: the caller does the part itself. A worker that claimed its
 * part stores its result and the step number in done (release), and the caller waits for it.
 * Then the caller takes the lowest (value, index). The parts compute the same values whoever
 * runs them. Waits spin briefly, then yield the core. */
#define TEAM_SLOT 64
typedef struct team_slot {
    _Alignas(TEAM_SLOT) atomic_size_t claim; /* last step number + 1 claimed */
    atomic_size_t done;                      /* last step number + 1 done by the worker */
    double value;
    int32_t unit;
} team_slot;

typedef struct team {
    mlr_packed *pk;
    const double *h;
    const unsigned char *active;
    const double *x, *xnext;
    size_t n_parts;
    _Alignas(TEAM_SLOT) atomic_size_t go; /* step number + 1; SIZE_MAX: quit */
    team_slot slot[MLR_MAX_THREADS];
} team;

typedef struct team_arg {
    team *t;
    size_t part;
} team_arg;

static inline void cpu_relax(void)
{
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
    __builtin_ia32_pause();
#endif
}

/* Wait until *a != old (acquire); returns the new value. */
static size_t wait_change(atomic_size_t *a, size_t old)
{
    size_t v;
    for (unsigned spin = 0; (v = atomic_load_explicit(a, memory_order_acquire)) == old; spin++) {
        if (spin < 1024)
            cpu_relax();
        else
            sched_yield();
    }
    return v;
}

static void *team_worker(void *arg)
{
    team_arg *ta = arg;
    team *t = ta->t;
    team_slot *sl = &t->slot[ta->part];
    size_t seen = 0;
    for (;;) {
        seen = wait_change(&t->go, seen);
        if (seen == SIZE_MAX)
            return NULL;
        /* claim words only grow: a worker that wakes up late (seen is an old step, the caller
         * has claimed later ones) must not take anything */
        size_t cur = atomic_load_explicit(&sl->claim, memory_order_acquire);
        if (cur >= seen || !atomic_compare_exchange_strong_explicit(
                               &sl->claim, &cur, seen, memory_order_acq_rel, memory_order_acquire))
            continue; /* the caller took this step's part */
        sl->unit = cluster__packed_sweep(t->pk, t->x, t->h, t->active, t->xnext, ta->part,
                                         t->n_parts, &sl->value);
        atomic_store_explicit(&sl->done, seen, memory_order_release);
    }
}

/* One step on the team (n_parts >= 1): returns the unit nearest to xnext (0 without it). */
static int32_t team_step(team *t, size_t step, const double *x, const double *xnext)
{
    t->x = x;
    t->xnext = xnext;
    if (t->n_parts > 1)
        atomic_store_explicit(&t->go, step + 1, memory_order_release);
    double bv;
    int32_t bi = cluster__packed_sweep(t->pk, x, t->h, t->active, xnext, 0, t->n_parts, &bv);
    for (size_t q = 1; q < t->n_parts; q++) {
        team_slot *sl = &t->slot[q];
        double v;
        int32_t u;
        size_t cur = atomic_load_explicit(&sl->claim, memory_order_acquire);
        if (cur < step + 1 &&
            atomic_compare_exchange_strong_explicit(&sl->claim, &cur, step + 1,
                                                    memory_order_acq_rel, memory_order_acquire)) {
            u = cluster__packed_sweep(t->pk, x, t->h, t->active, xnext, q, t->n_parts, &v);
        } else { /* the worker has it */
            size_t d = atomic_load_explicit(&sl->done, memory_order_acquire);
            while (d != step + 1)
                d = wait_change(&sl->done, d);
            v = sl->value;
            u = sl->unit;
        }
        if (v < bv || (v == bv && u < bi)) {
            bv = v;
            bi = u;
        }
    }
    return bi;
}

/* Values of the codebook per online part below which splitting a step does not pay. */
#define TEAM_MIN_VALUES 16384

/* The scratch of one training: g the Gaussian tables (rows + cols); idx the BMUs (batch,
 * int32) or the visiting order (online, size_t); sum the per-unit sums (batch) or h and the
 * block marks (online); tmp the convolution's intermediate (batch only). */
typedef struct train_work {
    double *g, *sum, *tmp;
    void *idx;
    size_t gbytes, ibytes, sbytes, nb, steps;
} train_work;

static void train_work_free(const mlr_som *som, train_work *tw, int mode)
{
    common__free(&som->a, tw->g, tw->gbytes);
    common__free(&som->a, tw->idx, tw->ibytes);
    common__free(&som->a, tw->sum, tw->sbytes);
    if (mode == MLR_SOM_BATCH)
        common__free(&som->a, tw->tmp, tw->sbytes);
}

/* Sizes and allocation of the training scratch of n rows, epochs epochs. */
static mlr_status train_work_alloc(const mlr_som *som, size_t n, size_t epochs, int mode,
                                   train_work *tw, mlr_diag *diag)
{
    memset(tw, 0, sizeof *tw);
    const size_t w = som->dim + 1;
    if (common__mul_size(som->units, w * sizeof(double), &tw->nb) ||
        common__mul_size(epochs, n, &tw->steps))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "training workspace overflows");
    const size_t kpad = som->pk.kpad;
    tw->gbytes = (som->rows + som->cols) * sizeof(double);
    tw->ibytes = n * (mode == MLR_SOM_BATCH ? sizeof(int32_t) : sizeof(size_t));
    /* batch: per-unit sums; online: h (kpad doubles) then the block marks (kpad / 16 bytes) */
    tw->sbytes = mode == MLR_SOM_BATCH ? tw->nb : kpad * sizeof(double) + kpad / MLR_PACK;
    tw->g = common__alloc(&som->a, tw->gbytes);
    tw->idx = common__alloc(&som->a, tw->ibytes);
    tw->sum = tw->sbytes ? common__alloc(&som->a, tw->sbytes) : NULL;
    tw->tmp = mode == MLR_SOM_BATCH ? common__alloc(&som->a, tw->sbytes) : NULL;
    if (!tw->g || !tw->idx || !tw->sum || (mode == MLR_SOM_BATCH && !tw->tmp)) {
        train_work_free(som, tw, mode);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "som train: out of memory for the workspace");
    }
    return MLR_OK;
}

/* Batch epochs: per epoch the BMUs, the per-unit sums, the separable Gaussian smoothing. */
static void train_batch(mlr_som *som, const double *x, size_t n, size_t ldx, size_t epochs,
                        const train_work *tw)
{
    const size_t dim = som->dim, w = dim + 1;
    int32_t *bmu = tw->idx;
    double *g = tw->g, *sum = tw->sum;
    batch_ctx c = {som, g, g + som->rows, sum, tw->tmp};
    for (size_t e = 0; e < epochs; e++) {
        double sigma = decay(som->sigma0, som->sigma1, e, epochs);
        mlr_som_bmu(som, x, n, ldx, bmu, NULL, NULL, NULL);
        memset(sum, 0, tw->nb);
        for (size_t i = 0; i < n; i++) { /* per-unit sums in row order */
            double *o = sum + (size_t)bmu[i] * w;
            const double *xi = x + i * ldx;
            for (size_t t = 0; t < dim; t++)
                o[t] += xi[t];
            o[dim] += 1.0;
        }
        gauss_table(g, som->rows, sigma);
        gauss_table(g + som->rows, som->cols, sigma);
        parallel__run(som->n_threads, som->rows, conv_cols_task, &c);
        parallel__run(som->n_threads, som->rows, conv_rows_task, &c);
        cluster__packed_fill(&som->pk, som->w, dim);
    }
}

/* Online epochs: rows in a shuffled order, each step moving the units near the BMU and
 * finding the next row's BMU in the same pass, on a team of threads. */
static void train_online(mlr_som *som, const double *x, size_t n, size_t ldx, size_t epochs,
                         const train_work *tw)
{
    const size_t dim = som->dim, units = som->units, kpad = som->pk.kpad;
    double *g = tw->g, *sum = tw->sum;
    size_t *order = tw->idx;
    mlr_rng rng;
    mlr_rng_seed(&rng, som->seed ^ 0x5eed5eed5eedull);
    for (size_t i = 0; i < n; i++)
        order[i] = i;
    double *h = sum;
    unsigned char *active = (unsigned char *)(sum + kpad);
    memset(sum, 0, tw->sbytes);
    /* the team: parts of at least TEAM_MIN_VALUES codebook values and one group each */
    size_t groups = (kpad / MLR_PACK + MLR_SWEEP_GROUP - 1) / MLR_SWEEP_GROUP;
    size_t parts = som->n_threads < groups ? som->n_threads : groups;
    size_t cap = kpad * dim / TEAM_MIN_VALUES;
    if (parts > cap)
        parts = cap ? cap : 1;
    team tm;
    memset(&tm, 0, sizeof tm);
    tm.pk = &som->pk;
    tm.h = h;
    tm.active = active;
    atomic_init(&tm.go, 0);
    for (size_t q = 0; q < MLR_MAX_THREADS; q++) {
        atomic_init(&tm.slot[q].claim, 0);
        atomic_init(&tm.slot[q].done, 0);
    }
    pthread_t th[MLR_MAX_THREADS];
    team_arg ta[MLR_MAX_THREADS];
    size_t started = 0;
    for (size_t q = 1; q < parts; q++) {
        ta[q].t = &tm;
        ta[q].part = q;
        if (pthread_create(&th[q], NULL, team_worker, &ta[q]) != 0)
            break; /* fewer parts: the same result */
        started = q;
    }
    tm.n_parts = started + 1;
    size_t step = 0;
    for (size_t e = 0; e < epochs; e++) {
        for (size_t i = n - 1; i > 0; i--) { /* Fisher-Yates */
            size_t j = mlr_rng_below(&rng, i + 1), t = order[i];
            order[i] = order[j];
            order[j] = t;
        }
        /* BMU of the first row; each step then moves the units and finds the BMU of the
         * next row in the same pass over the codebook */
        int32_t b;
        double d2;
        cluster__nearest2(&som->pk, x + order[0] * ldx, ldx, NULL, 1, NULL, &b, &d2, NULL, NULL);
        for (size_t i = 0; i < n; i++, step++) {
            double sigma = decay(som->sigma0, som->sigma1, step, tw->steps);
            double alpha = decay(som->alpha0, som->alpha1, step, tw->steps);
            size_t win[4];
            online_window(som, (size_t)b, sigma, alpha, som->cutoff, g, g + som->rows, h, active,
                          win);
            b = team_step(&tm, step, x + order[i] * ldx,
                          i + 1 < n ? x + order[i + 1] * ldx : NULL);
            online_clear(som, h, active, win);
        }
    }
    if (started) {
        atomic_store_explicit(&tm.go, SIZE_MAX, memory_order_release);
        for (size_t q = 1; q <= started; q++)
            pthread_join(th[q], NULL);
    }
    for (size_t u = 0; u < units; u++)
        cluster__packed_get(&som->pk, u, som->w + u * dim);
    cluster__packed_fill(&som->pk, som->w, dim); /* norms by the same rule as everywhere */
}

mlr_status mlr_som_train(mlr_som *som, const double *x, size_t n, size_t ldx, size_t epochs,
                         int mode, mlr_diag *diag)
{
    mlr_status st = check_data(som, x, n, ldx, diag);
    if (st)
        return st;
    if (epochs == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "epochs must be >= 1");
    if (mode != MLR_SOM_BATCH && mode != MLR_SOM_ONLINE)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown training mode %d", mode);
    train_work tw;
    st = train_work_alloc(som, n, epochs, mode, &tw, diag);
    if (st != MLR_OK)
        return st;
    if (!som->initialized)
        mlr_som_init_random(som, x, n, ldx, NULL);
    if (mode == MLR_SOM_BATCH)
        train_batch(som, x, n, ldx, epochs, &tw);
    else
        train_online(som, x, n, ldx, epochs, &tw);
    train_work_free(som, &tw, mode);
    return MLR_OK;
}

/* ---- codebook access and blobs ---------------------------------------------------------------- */

const double *mlr_som_codebook(const mlr_som *som) { return som ? som->w : NULL; }
size_t mlr_som_rows(const mlr_som *som) { return som ? som->rows : 0; }
size_t mlr_som_cols(const mlr_som *som) { return som ? som->cols : 0; }
size_t mlr_som_dim(const mlr_som *som) { return som ? som->dim : 0; }

mlr_status mlr_som_set_codebook(mlr_som *som, const double *w, size_t ldw, mlr_diag *diag)
{
    if (!som || !w)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "som or codebook NULL");
    if (ldw < som->dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: codebook stride %zu < dim %zu", ldw,
                                som->dim);
    size_t bad = cluster__first_nonfinite_row(w, som->units, som->dim, ldw);
    if (bad < som->units)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "unit %zu holds a NaN or an infinity", bad);
    for (size_t u = 0; u < som->units; u++)
        memcpy(som->w + u * som->dim, w + u * ldw, som->dim * sizeof(double));
    cluster__packed_fill(&som->pk, som->w, som->dim);
    som->initialized = 1;
    return MLR_OK;
}

size_t mlr_som_export_size(const mlr_som *som)
{
    return som ? MLR_BLOB_HEADER + som->units * som->dim * sizeof(double) : 0;
}

mlr_status mlr_som_export(const mlr_som *som, void *buf, size_t size, mlr_diag *diag)
{
    if (!som || !buf)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "som or buffer NULL");
    if (size < mlr_som_export_size(som))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "buffer of %zu bytes, need %zu",
                                size, mlr_som_export_size(som));
    uint64_t dims[3] = {som->rows, som->cols, som->dim};
    cluster__blob_write(buf, som_tag, SOM_BLOB_VERSION, dims, som->w, som->units * som->dim);
    return MLR_OK;
}

mlr_status mlr_som_import(const void *buf, size_t size, const mlr_allocator *alloc, mlr_som **out,
                          mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    uint64_t dims[3];
    const unsigned char *payload;
    size_t np;
    mlr_status st =
        cluster__blob_check(buf, size, som_tag, SOM_BLOB_VERSION, dims, &payload, &np, diag);
    if (st)
        return st;
    if (dims[0] == 0 || dims[1] == 0 || dims[2] == 0 || dims[0] > INT32_MAX ||
        dims[1] > INT32_MAX / dims[0] || dims[2] > SIZE_MAX / (dims[0] * dims[1]) ||
        dims[0] * dims[1] * dims[2] != np)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "blob dimensions do not match its payload");
    mlr_som *s;
    st = mlr_som_create((size_t)dims[0], (size_t)dims[1], (size_t)dims[2], alloc, &s, diag);
    if (st)
        return common__diag_prefix(diag, st, "som import");
    memcpy(s->w, payload, np * sizeof(double));
    if (cluster__first_nonfinite_row(s->w, s->units, s->dim, s->dim) < s->units) {
        mlr_som_destroy(s);
        return common__diag_set(diag, MLR_E_PARSE, 0, 0, "blob holds a NaN or an infinity");
    }
    cluster__packed_fill(&s->pk, s->w, s->dim);
    s->initialized = 1;
    *out = s;
    return MLR_OK;
}
