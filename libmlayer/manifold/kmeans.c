/* k-means: k-means++ seeding, Lloyd with optional Hamerly bounds. See mlr_kmeans.h. */
#include "manifold/cluster_internal.h"

#include <float.h>
#include <math.h>

struct mlr_kmeans {
    mlr_allocator a;
    size_t k, dim;
    size_t max_iter, n_init, n_threads;
    double tol;
    uint64_t seed;
    int algorithm;
    double *centers;  /* k * dim */
    mlr_packed packed; /* of centers, for predict */
    double inertia;
    size_t n_iter, n_skipped;
};

#define SUB 64            /* rows per sub-batch of the assignment */
#define MAX_BLOCKS 16     /* fixed row blocks of the assignment (thread-count independent) */
#define PP_BLOCK 4096     /* rows per task of k-means++ */

/* ---- workspace of one fit -------------------------------------------------------------- */

typedef struct fit_ws {
    const mlr_kmeans *km;
    const double *x;
    size_t n, ldx, dim, k;
    double *xn;          /* n: ||x_i||^2 */
    int32_t *lab;        /* n: current labels */
    double *u, *l;       /* n: Hamerly bounds (k-means++ scratch before the run) */
    double *c;           /* k * dim: current centres */
    double *cnew;        /* k * dim: sums then new centres */
    mlr_packed pk;       /* packed c */
    double *s;           /* k: half distance to the nearest other centre */
    double *p;           /* k: last shift of each centre */
    size_t nblk;         /* assignment blocks */
    double *psum;        /* nblk * k * dim partial sums */
    size_t *pcnt;        /* nblk * k partial counts */
    size_t *pchg, *pskip; /* nblk: changed labels, skipped rows */
    double *pinert;      /* nblk partial inertia; also k-means++ pots (n_ppblk * trials) */
    size_t n_pot;        /* doubles in pinert */
    size_t *cnt;         /* k */
    /* per-iteration state read by the tasks */
    int hamerly, first, update;
    double pmax, pmax2;  /* largest and second largest shift */
    size_t jmax;
    double margin;       /* rounding margin of the expanded distances */
    /* k-means++ task state */
    const double *cand[32];
    size_t n_cand;
    /* k-means++ bounds: lab[i] is the chosen centre whose squared distance u[i] is; ppd[t * k
     * + a] the squared distance from candidate t to chosen centre a (pp_bound: in use) */
    double *ppd;
    const double *ppd_best; /* ppd's row of the candidate taken */
    int pp_bound;
    int32_t pp_new;         /* index of the centre taken */
    double pp_lo, pp_hi;    /* rounding factors of the skip test */
} fit_ws;

static void blk_range(size_t n, size_t nblk, size_t b, size_t *lo, size_t *hi)
{
    *lo = n / nblk * b + (b < n % nblk ? b : n % nblk);
    *hi = *lo + n / nblk + (b < n % nblk ? 1 : 0);
}

/* One assignment block: bounds test, search of the rows that fail it, partial sums. */
static void assign_task(void *ctx, size_t b)
{
    fit_ws *w = ctx;
    const size_t dim = w->dim, k = w->k;
    const double rel = 1.0 + 4.0 * (double)(dim + 2) * DBL_EPSILON;
    size_t lo, hi;
    blk_range(w->n, w->nblk, b, &lo, &hi);
    /* partial sums of the block: rebuilt on the first iteration, then kept up to date by
     * moving the rows whose label changed (incremental, in row order: still independent of
     * the thread count) */
    double *ps = w->update ? w->psum + b * k * dim : NULL;
    size_t *pc = w->update ? w->pcnt + b * k : NULL;
    const int rebuild = ps && w->first;
    if (rebuild) {
        memset(ps, 0, k * dim * sizeof *ps);
        memset(pc, 0, k * sizeof *pc);
    }
    size_t changed = 0, skipped = 0;
    size_t rows[SUB];
    double xnb[SUB], db[SUB], ds[SUB];
    int32_t lb[SUB];
    for (size_t i0 = lo; i0 < hi; i0 += SUB) {
        size_t i1 = i0 + SUB < hi ? i0 + SUB : hi, m = 0;
        for (size_t i = i0; i < i1; i++) {
            if (w->hamerly && !w->first) {
                int32_t a = w->lab[i];
                w->u[i] += w->p[a];
                w->l[i] -= ((size_t)a == w->jmax) ? w->pmax2 : w->pmax;
                double bound = w->s[a] > w->l[i] ? w->s[a] : w->l[i];
                if (w->u[i] <= bound) {
                    skipped++;
                    continue;
                }
                w->u[i] = sqrt(cluster__dist2(w->x + i * w->ldx, w->c + (size_t)a * dim, dim,
                                              w->pk.isa)) *
                          rel;
                if (w->u[i] <= bound) {
                    skipped++;
                    continue;
                }
            }
            rows[m] = i;
            xnb[m++] = w->xn[i];
        }
        if (m) {
            cluster__nearest2(&w->pk, w->x, w->ldx, rows, m, xnb, lb, db, w->hamerly ? ds : NULL,
                              NULL);
            for (size_t r = 0; r < m; r++) {
                size_t i = rows[r];
                if (lb[r] != w->lab[i]) {
                    changed++;
                    if (ps && !rebuild) {
                        double *from = ps + (size_t)w->lab[i] * dim,
                               *to = ps + (size_t)lb[r] * dim;
                        const double *xi = w->x + i * w->ldx;
                        for (size_t t = 0; t < dim; t++) {
                            from[t] -= xi[t];
                            to[t] += xi[t];
                        }
                        pc[w->lab[i]]--;
                        pc[lb[r]]++;
                    }
                }
                w->lab[i] = lb[r];
                if (w->hamerly) {
                    w->u[i] = sqrt(db[r]) + w->margin;
                    w->l[i] = sqrt(ds[r]) - w->margin;
                }
            }
        }
        if (rebuild) {
            for (size_t i = i0; i < i1; i++) {
                size_t a = (size_t)w->lab[i];
                double *dst = ps + a * dim;
                const double *xi = w->x + i * w->ldx;
                for (size_t t = 0; t < dim; t++)
                    dst[t] += xi[t];
                pc[a]++;
            }
        }
    }
    w->pchg[b] = changed;
    w->pskip[b] = skipped;
}

static void inertia_task(void *ctx, size_t b)
{
    fit_ws *w = ctx;
    size_t lo, hi;
    blk_range(w->n, w->nblk, b, &lo, &hi);
    double s = 0;
    for (size_t i = lo; i < hi; i++)
        s += cluster__dist2(w->x + i * w->ldx, w->c + (size_t)w->lab[i] * w->dim, w->dim,
                            w->pk.isa);
    w->pinert[b] = s;
}

/* k-means++ bounds (the triangle inequality, as Elkan's k-means uses it): a row x whose
 * closest chosen centre a is at squared distance u, and a candidate c at squared distance D
 * from a, has |x - c| >= |c - a| - |x - a|; when D lo >= 4 u hi (lo, hi: the relative rounding
 * of the computed distances, taken three times), the computed ||x - c||^2 is >= u, so
 * min(||x - c||^2, u) = u without computing it: the sums and updates are those of the plain
 * search, bit for bit. */
static int pp_far(const fit_ws *w, const double *drow, size_t i)
{
    return w->pp_bound && drow[w->lab[i]] * w->pp_lo >= 4.0 * w->u[i] * w->pp_hi;
}

/* k-means++: potential of each candidate over one block (closest in w->u). One pass over the
 * rows for all the candidates (each row read once while the candidates stay in cache); each
 * candidate's sum still runs over the rows in order, so the sums are those of one pass per
 * candidate, bit for bit. */
static void pp_pot_task(void *ctx, size_t b)
{
    fit_ws *w = ctx;
    size_t lo = b * PP_BLOCK, hi = lo + PP_BLOCK < w->n ? lo + PP_BLOCK : w->n;
    const size_t nc = w->n_cand;
    double s[32] = {0};
    for (size_t i = lo; i < hi; i++) {
        const double *xi = w->x + i * w->ldx, ui = w->u[i];
        for (size_t c = 0; c < nc; c++) {
            if (pp_far(w, w->ppd + c * w->k, i)) {
                s[c] += ui;
                continue;
            }
            double d = cluster__dist2(xi, w->cand[c], w->dim, w->pk.isa);
            s[c] += d < ui ? d : ui;
        }
    }
    for (size_t c = 0; c < nc; c++)
        w->pinert[b * nc + c] = s[c];
}

/* k-means++: closest = min(closest, d(x, cand[0])) over one block, lab the centre pp_new where
 * it is closer. */
static void pp_update_task(void *ctx, size_t b)
{
    fit_ws *w = ctx;
    size_t lo = b * PP_BLOCK, hi = lo + PP_BLOCK < w->n ? lo + PP_BLOCK : w->n;
    for (size_t i = lo; i < hi; i++) {
        if (pp_far(w, w->ppd_best, i))
            continue;
        double d = cluster__dist2(w->x + i * w->ldx, w->cand[0], w->dim, w->pk.isa);
        if (d < w->u[i]) {
            w->u[i] = d;
            w->lab[i] = w->pp_new;
        }
    }
}

static void kmeans_pp(fit_ws *w, mlr_rng *rng)
{
    const size_t n = w->n, dim = w->dim, k = w->k, nth = w->km->n_threads;
    const size_t nb = (n + PP_BLOCK - 1) / PP_BLOCK;
    size_t trials = 2 + (size_t)floor(log((double)k));
    if (trials > 32)
        trials = 32;
    size_t first = mlr_rng_below(rng, n);
    memcpy(w->c, w->x + first * w->ldx, dim * sizeof(double));
    w->cand[0] = w->x + first * w->ldx;
    for (size_t i = 0; i < n; i++) {
        w->u[i] = INFINITY;
        w->lab[i] = 0;
    }
    const double e = 4.0 * (double)(dim + 2) * DBL_EPSILON;
    w->pp_lo = (1.0 - e) * (1.0 - e) * (1.0 - e);
    w->pp_hi = (1.0 + e) * (1.0 + e) * (1.0 + e);
    w->pp_bound = 0;
    w->pp_new = 0;
    parallel__run(nth, nb, pp_update_task, w);
    /* the bounds cost trials * k distances per centre: worth it while k is small beside n */
    const int bound = w->ppd != NULL;
    double pot = 0;
    for (size_t i = 0; i < n; i++)
        pot += w->u[i];
    for (size_t c = 1; c < k; c++) {
        double cum = 0; /* w->l = running sums of the closest distances */
        for (size_t i = 0; i < n; i++)
            w->l[i] = (cum += w->u[i]);
        size_t ids[32] = {0};
        for (size_t t = 0; t < trials; t++) {
            double v = mlr_rng_uniform(rng) * pot;
            size_t lo = 0, hi = n; /* first i with cum[i] >= v */
            while (lo < hi) {
                size_t mid = lo + (hi - lo) / 2;
                if (w->l[mid] < v)
                    lo = mid + 1;
                else
                    hi = mid;
            }
            ids[t] = lo < n ? lo : n - 1;
            w->cand[t] = w->x + ids[t] * w->ldx;
        }
        w->n_cand = trials;
        if (bound) { /* candidate to chosen-centre distances */
            for (size_t t = 0; t < trials; t++)
                for (size_t a = 0; a < c; a++)
                    w->ppd[t * k + a] = cluster__dist2(w->cand[t], w->c + a * dim, dim, w->pk.isa);
            w->pp_bound = 1;
        }
        parallel__run(nth, nb, pp_pot_task, w);
        size_t bt = 0;
        double bpot = INFINITY;
        for (size_t t = 0; t < trials; t++) {
            double s = 0;
            for (size_t b = 0; b < nb; b++)
                s += w->pinert[b * trials + t];
            if (s < bpot) {
                bpot = s;
                bt = t;
            }
        }
        pot = bpot;
        w->cand[0] = w->x + ids[bt] * w->ldx;
        w->ppd_best = bound ? w->ppd + bt * k : NULL;
        w->pp_new = (int32_t)c;
        memcpy(w->c + c * dim, w->cand[0], dim * sizeof(double));
        parallel__run(nth, nb, pp_update_task, w);
    }
}

/* Before an assignment pass: pack the centres w->c and their norms, the rounding margin of the
 * distance comparisons, and (Hamerly) half the distance from each centre to its nearest other
 * centre, shrunk by that margin. */
static void prepare_centres(fit_ws *w, double xmax2, double eps_d)
{
    const size_t k = w->k, dim = w->dim;
    cluster__packed_fill(&w->pk, w->c, dim);
    double cmax2 = 0;
    for (size_t j = 0; j < k; j++)
        cmax2 = w->pk.cn[j] > cmax2 ? w->pk.cn[j] : cmax2;
    w->margin = sqrt(eps_d * (xmax2 + cmax2));
    if (!w->hamerly)
        return;
    for (size_t j = 0; j < k; j++) {
        double best = INFINITY;
        for (size_t q = 0; q < k; q++) {
            if (q == j)
                continue;
            double d = cluster__dist2(w->c + j * dim, w->c + q * dim, dim, w->pk.isa);
            best = d < best ? d : best;
        }
        w->s[j] = 0.5 * sqrt(best) * (1.0 - eps_d) - w->margin;
    }
}

/* The assignment's partial sums and counts reduced in block order, into cnew and cnt. */
static void reduce_sums(fit_ws *w)
{
    const size_t k = w->k, dim = w->dim;
    memcpy(w->cnew, w->psum, k * dim * sizeof(double));
    for (size_t j = 0; j < k; j++)
        w->cnt[j] = w->pcnt[j];
    for (size_t b = 1; b < w->nblk; b++) {
        const double *ps = w->psum + b * k * dim;
        for (size_t q = 0; q < k * dim; q++)
            w->cnew[q] += ps[q];
        for (size_t j = 0; j < k; j++)
            w->cnt[j] += w->pcnt[b * k + j];
    }
}

/* Empty clusters take the rows farthest from their centres (scikit-learn's rule); a relocated
 * row is marked (l = -inf) so that it is not taken twice. */
static void relocate_empty(fit_ws *w)
{
    const size_t n = w->n, k = w->k, dim = w->dim;
    size_t n_reloc = 0;
    for (size_t j = 0; j < k; j++) {
        if (w->cnt[j] != 0)
            continue;
        size_t far = SIZE_MAX;
        double fd = -1;
        for (size_t i = 0; i < n; i++) {
            if (w->l[i] == -INFINITY)
                continue;
            double d =
                cluster__dist2(w->x + i * w->ldx, w->c + (size_t)w->lab[i] * dim, dim, w->pk.isa);
            if (d > fd) {
                fd = d;
                far = i;
            }
        }
        if (far == SIZE_MAX)
            continue;
        size_t old = (size_t)w->lab[far];
        const double *xf = w->x + far * w->ldx;
        for (size_t t = 0; t < dim; t++) {
            w->cnew[old * dim + t] -= xf[t];
            w->cnew[j * dim + t] = xf[t];
        }
        w->cnt[old]--;
        w->cnt[j] = 1;
        w->l[far] = -INFINITY;
        n_reloc++;
    }
    if (n_reloc) /* unmark; the relocated rows are searched again next iteration */
        for (size_t i = 0; i < n; i++)
            if (w->l[i] == -INFINITY) {
                w->l[i] = 0;
                w->u[i] = INFINITY;
            }
}

/* The new centres (cnew: sums to means) and each centre's shift (p, the largest two and
 * jmax); returns the sum of the squared shifts. */
static double new_centres(fit_ws *w, double eps_d)
{
    const size_t k = w->k, dim = w->dim;
    double tot = 0;
    w->pmax = w->pmax2 = 0;
    w->jmax = 0;
    for (size_t j = 0; j < k; j++) {
        double *cn = w->cnew + j * dim;
        if (w->cnt[j] > 0) {
            double inv = 1.0 / (double)w->cnt[j];
            for (size_t t = 0; t < dim; t++)
                cn[t] *= inv;
        }
        double d2 = cluster__dist2(cn, w->c + j * dim, dim, w->pk.isa);
        tot += d2;
        double d = sqrt(d2) * (1.0 + eps_d);
        w->p[j] = d;
        if (d > w->pmax) {
            w->pmax2 = w->pmax;
            w->pmax = d;
            w->jmax = j;
        } else if (d > w->pmax2) {
            w->pmax2 = d;
        }
    }
    return tot;
}

/* One Lloyd run from the centres in w->c. */
static void run_lloyd(fit_ws *w, double tol_abs, double xmax2, double *inertia, size_t *n_iter,
                      size_t *n_skipped)
{
    const mlr_kmeans *km = w->km;
    const size_t n = w->n, k = w->k, dim = w->dim, nth = km->n_threads;
    const double eps_d = 4.0 * (double)(dim + 2) * DBL_EPSILON;
    w->hamerly =
        km->algorithm == MLR_KMEANS_HAMERLY || (km->algorithm == MLR_KMEANS_AUTO && k >= 4);
    for (size_t i = 0; i < n; i++) {
        w->lab[i] = -1;
        w->u[i] = INFINITY;
        w->l[i] = 0;
    }
    w->first = 1;
    int strict = 0;
    size_t it = 0, skipped = 0;
    for (it = 0; it < km->max_iter; it++) {
        prepare_centres(w, xmax2, eps_d);
        w->update = 1;
        parallel__run(nth, w->nblk, assign_task, w);
        w->first = 0;
        size_t changed = 0, skip_it = 0;
        for (size_t b = 0; b < w->nblk; b++) {
            changed += w->pchg[b];
            skip_it += w->pskip[b];
        }
        skipped += skip_it;
        /* AUTO: from the fifth iteration on (the bounds need a few small centre moves to
         * bite: on random normal data they skip ~0%, 0.2%, 8%, 12% of the rows in iterations
         * 2 to 5, then 15-35%), drop them if they skip under 1/32 of the rows, where their
         * upkeep costs more than they save; labels are the same either way */
        if (w->hamerly && km->algorithm == MLR_KMEANS_AUTO && it >= 4 && skip_it * 32 < n)
            w->hamerly = 0;
        reduce_sums(w);
        relocate_empty(w);
        const double tot = new_centres(w, eps_d);
        memcpy(w->c, w->cnew, k * dim * sizeof(double));
        if (changed == 0) {
            strict = 1;
            it++;
            break;
        }
        if (tot <= tol_abs) {
            it++;
            break;
        }
    }
    if (!strict) { /* labels of the final centres */
        prepare_centres(w, xmax2, eps_d);
        w->update = 0;
        parallel__run(nth, w->nblk, assign_task, w);
    }
    parallel__run(nth, w->nblk, inertia_task, w);
    double in = 0;
    for (size_t b = 0; b < w->nblk; b++)
        in += w->pinert[b];
    *inertia = in;
    *n_iter = it;
    *n_skipped = skipped;
}

/* ---- public API --------------------------------------------------------------------------- */

mlr_status mlr_kmeans_create(size_t k, size_t dim, const mlr_allocator *alloc, mlr_kmeans **out,
                             mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (k == 0 || dim == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "k = %zu and dim = %zu must be >= 1", k, dim);
    if (k > INT32_MAX)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "k = %zu exceeds INT32_MAX", k);
    size_t kpad = cluster__packed_kpad(k), nc, np;
    if (common__mul_size(k, dim, &nc) || common__mul_size(kpad, dim + 1, &np) ||
        common__mul_size(nc + np, sizeof(double), &nc))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "k * dim overflows");
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_kmeans *km = common__alloc(&a, sizeof *km);
    if (!km)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "kmeans create: out of memory for the model");
    memset(km, 0, sizeof *km);
    km->a = a;
    km->k = k;
    km->dim = dim;
    km->centers = common__alloc(&a, nc);
    if (!km->centers) {
        common__free(&a, km, sizeof *km);
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "kmeans create: out of memory for %zu centres", k);
    }
    memset(km->centers, 0, k * dim * sizeof(double));
    km->packed.pc = km->centers + k * dim;
    km->packed.cn = km->packed.pc + kpad * dim;
    km->packed.k = k;
    km->packed.kpad = kpad;
    km->packed.dim = dim;
    km->packed.isa = cpu__isa(MLR_ISA_BEST);
    cluster__packed_fill(&km->packed, km->centers, dim);
    km->max_iter = 300;
    km->n_init = 1;
    km->n_threads = 1;
    km->tol = 1e-4;
    km->algorithm = MLR_KMEANS_AUTO;
    km->inertia = NAN;
    *out = km;
    return MLR_OK;
}

static size_t total_bytes(const mlr_kmeans *km)
{
    size_t kpad = cluster__packed_kpad(km->k);
    return (km->k * km->dim + kpad * (km->dim + 1)) * sizeof(double);
}

void mlr_kmeans_destroy(mlr_kmeans *km)
{
    if (!km)
        return;
    mlr_allocator a = km->a;
    common__free(&a, km->centers, total_bytes(km));
    common__free(&a, km, sizeof *km);
}

static int is_int(double v, double lo, double hi)
{
    return v == v && v >= lo && v <= hi && floor(v) == v;
}

mlr_status mlr_kmeans_set(mlr_kmeans *km, int option, double v, mlr_diag *diag)
{
    if (!km)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "km is NULL");
    switch (option) {
    case MLR_KMEANS_MAX_ITER:
        if (!is_int(v, 1, 1e15))
            break;
        km->max_iter = (size_t)v;
        return MLR_OK;
    case MLR_KMEANS_TOL:
        if (!(v >= 0 && v < INFINITY))
            break;
        km->tol = v;
        return MLR_OK;
    case MLR_KMEANS_N_INIT:
        if (!is_int(v, 1, 1e9))
            break;
        km->n_init = (size_t)v;
        return MLR_OK;
    case MLR_KMEANS_SEED:
        if (!is_int(v, 0, 9007199254740992.0))
            break;
        km->seed = (uint64_t)v;
        return MLR_OK;
    case MLR_KMEANS_N_THREADS:
        if (!is_int(v, 1, MLR_MAX_THREADS))
            break;
        km->n_threads = (size_t)v;
        return MLR_OK;
    case MLR_KMEANS_ALGORITHM:
        if (!(v == MLR_KMEANS_AUTO || v == MLR_KMEANS_LLOYD || v == MLR_KMEANS_HAMERLY))
            break;
        km->algorithm = (int)v;
        return MLR_OK;
    default:
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown k-means option %d",
                                option);
    }
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "k-means option %d: value %g out of range", option, v);
}

mlr_status mlr_kmeans_set_centers(mlr_kmeans *km, const double *c, size_t ldc, mlr_diag *diag)
{
    if (!km || !c)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "km or centres NULL");
    if (ldc < km->dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: centre stride %zu < dim %zu", ldc, km->dim);
    size_t bad = cluster__first_nonfinite_row(c, km->k, km->dim, ldc);
    if (bad < km->k)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "centre %zu holds a NaN or an infinity", bad);
    for (size_t j = 0; j < km->k; j++)
        memcpy(km->centers + j * km->dim, c + j * ldc, km->dim * sizeof(double));
    cluster__packed_fill(&km->packed, km->centers, km->dim);
    return MLR_OK;
}

const double *mlr_kmeans_centers(const mlr_kmeans *km) { return km ? km->centers : NULL; }
double mlr_kmeans_inertia(const mlr_kmeans *km) { return km ? km->inertia : NAN; }
size_t mlr_kmeans_n_iter(const mlr_kmeans *km) { return km ? km->n_iter : 0; }
size_t mlr_kmeans_n_skipped(const mlr_kmeans *km) { return km ? km->n_skipped : 0; }
size_t mlr_kmeans_k(const mlr_kmeans *km) { return km ? km->k : 0; }
size_t mlr_kmeans_dim(const mlr_kmeans *km) { return km ? km->dim : 0; }

mlr_status mlr_kmeans_predict(const mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                              int32_t *labels, double *dist2, mlr_diag *diag)
{
    if (!km)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "km is NULL");
    if (n == 0)
        return MLR_OK;
    if (!x || !labels)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "x or labels NULL");
    if (ldx < km->dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: row stride %zu < dim %zu", ldx, km->dim);
    size_t bad = cluster__first_nonfinite_row(x, n, km->dim, ldx);
    if (bad < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "row %zu holds a NaN or an infinity", bad);
    double db[SUB];
    for (size_t i0 = 0; i0 < n; i0 += SUB) {
        size_t m = n - i0 < SUB ? n - i0 : SUB;
        cluster__nearest2(&km->packed, x + i0 * ldx, ldx, NULL, m, NULL, labels + i0, db, NULL,
                          NULL);
        if (dist2)
            for (size_t r = 0; r < m; r++)
                dist2[i0 + r] = cluster__dist2(x + (i0 + r) * ldx,
                                               km->centers + (size_t)labels[i0 + r] * km->dim,
                                               km->dim, km->packed.isa);
    }
    return MLR_OK;
}

/* The arguments of mlr_kmeans_fit, checked. */
static mlr_status fit_check(const mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                            const double *init, size_t ldinit, mlr_diag *diag)
{
    if (!km)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "km is NULL");
    const size_t k = km->k, dim = km->dim;
    if (!x || n == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "empty data: no rows");
    if (k > n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "k = %zu exceeds the %zu rows", k,
                                n);
    if (ldx < dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: row stride %zu < dim %zu", ldx, dim);
    if (init && ldinit < dim)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "dimension mismatch: initial centre stride %zu < dim %zu", ldinit,
                                dim);
    size_t bad = cluster__first_nonfinite_row(x, n, dim, ldx);
    if (bad < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "row %zu holds a NaN or an infinity", bad);
    if (init && (bad = cluster__first_nonfinite_row(init, k, dim, ldinit)) < k)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "initial centre %zu holds a NaN or an infinity", bad);
    size_t tmp;
    if (common__mul_size(n, ldx, &tmp) || common__mul_size(n, 4 * sizeof(double), &tmp))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "n = %zu rows overflow", n);
    return MLR_OK;
}

/* The squared row norms (w->xn), their largest (*xmax2), and the absolute tolerance
 * (scikit-learn: tol * mean of the column variances); w->c and w->cnew are scratch. */
static double data_stats(fit_ws *w, double *xmax_out)
{
    const size_t n = w->n, ldx = w->ldx, dim = w->dim;
    const double *x = w->x;
    double xmax2 = 0, mvar = 0, *mean = w->c, *var = w->cnew; /* dim each, before the runs */
    memset(mean, 0, dim * sizeof(double));
    memset(var, 0, dim * sizeof(double));
    for (size_t i = 0; i < n; i++) { /* row by row: the column sums still run over i in order */
        const double *xi = x + i * ldx;
        w->xn[i] = cluster__norm2(xi, dim);
        xmax2 = w->xn[i] > xmax2 ? w->xn[i] : xmax2;
        for (size_t t = 0; t < dim; t++)
            mean[t] += xi[t];
    }
    for (size_t t = 0; t < dim; t++)
        mean[t] /= (double)n;
    for (size_t i = 0; i < n; i++) {
        const double *xi = x + i * ldx;
        for (size_t t = 0; t < dim; t++) {
            double e = xi[t] - mean[t];
            var[t] += e * e;
        }
    }
    for (size_t t = 0; t < dim; t++)
        mvar += var[t] / (double)n;
    *xmax_out = xmax2;
    return w->km->tol * mvar / (double)dim;
}

/* The runs of a fit (one from init, else n_init from k-means++, seeded in turn): w->c and
 * w->lab those of the lowest inertia (best_lab, best_c: the kept run's copies when several
 * runs are made, else NULL). */
static void fit_runs(fit_ws *w, const double *init, size_t ldinit, double tol_abs, double xmax2,
                     int32_t *best_lab, double *best_c, double *best_in_out, size_t *best_it_out,
                     size_t *best_skip_out)
{
    const mlr_kmeans *km = w->km;
    const size_t n = w->n, k = w->k, dim = w->dim;
    const int multi = !init && km->n_init > 1;
    mlr_rng rng;
    mlr_rng_seed(&rng, km->seed);
    size_t runs = init ? 1 : km->n_init;
    double best_in = INFINITY;
    size_t best_it = 0, best_skip = 0;
    for (size_t r = 0; r < runs; r++) {
        if (init) {
            for (size_t j = 0; j < k; j++)
                memcpy(w->c + j * dim, init + j * ldinit, dim * sizeof(double));
        } else {
            kmeans_pp(w, &rng);
        }
        double in;
        size_t it, skip;
        run_lloyd(w, tol_abs, xmax2, &in, &it, &skip);
        if (r == 0 || in < best_in) {
            best_in = in;
            best_it = it;
            best_skip = skip;
            if (multi && r + 1 < runs) {
                memcpy(best_lab, w->lab, n * sizeof(int32_t));
                memcpy(best_c, w->c, k * dim * sizeof(double));
            }
        } else if (multi && r + 1 == runs) { /* the kept run is an earlier one */
            memcpy(w->lab, best_lab, n * sizeof(int32_t));
            memcpy(w->c, best_c, k * dim * sizeof(double));
        }
    }
    *best_in_out = best_in;
    *best_it_out = best_it;
    *best_skip_out = best_skip;
}

typedef struct ws_block {
    void **slot;
    size_t bytes;
} ws_block;

mlr_status mlr_kmeans_fit(mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                          const double *init, size_t ldinit, int32_t *labels, mlr_diag *diag)
{
    mlr_status st = fit_check(km, x, n, ldx, init, ldinit, diag);
    if (st != MLR_OK)
        return st;
    const size_t k = km->k, dim = km->dim;

    fit_ws w;
    memset(&w, 0, sizeof w);
    w.km = km;
    w.x = x;
    w.n = n;
    w.ldx = ldx;
    w.dim = dim;
    w.k = k;
    size_t nblk = (n + 511) / 512, cap = (size_t)1 << 22;
    if (nblk > MAX_BLOCKS)
        nblk = MAX_BLOCKS;
    if (k * dim > cap / nblk)
        nblk = cap / (k * dim) > 0 ? cap / (k * dim) : 1;
    w.nblk = nblk;
    size_t n_ppblk = (n + PP_BLOCK - 1) / PP_BLOCK;
    w.n_pot = n_ppblk * 32 > nblk ? n_ppblk * 32 : nblk;
    size_t kpad = cluster__packed_kpad(k);
    int multi = !init && km->n_init > 1;
    /* k-means++ bounds (kmeans_pp): trials * k distances, for k up to n / 8 (then their cost
     * stays within 1/16 of the seeding's row distances); 256 k <= 32 n bytes, within the
     * overflow check of fit_check */
    size_t pp_trials = k > 1 ? 2 + (size_t)floor(log((double)k)) : 0;
    if (pp_trials > 32)
        pp_trials = 32;
    const size_t pp_bytes = !init && k >= 2 && k <= n / 8 ? pp_trials * k * sizeof(double) : 0;
    int32_t *best_lab = NULL;
    double *best_c = NULL;
    ws_block blocks[] = {
        {(void **)&w.xn, n * sizeof(double)},
        {(void **)&w.lab, n * sizeof(int32_t)},
        {(void **)&w.u, n * sizeof(double)},
        {(void **)&w.l, n * sizeof(double)},
        {(void **)&w.c, k * dim * sizeof(double)},
        {(void **)&w.cnew, k * dim * sizeof(double)},
        {(void **)&w.pk.pc, kpad * dim * sizeof(double)},
        {(void **)&w.pk.cn, kpad * sizeof(double)},
        {(void **)&w.s, k * sizeof(double)},
        {(void **)&w.p, k * sizeof(double)},
        {(void **)&w.psum, nblk * k * dim * sizeof(double)},
        {(void **)&w.pcnt, nblk * k * sizeof(size_t)},
        {(void **)&w.pchg, nblk * sizeof(size_t)},
        {(void **)&w.pskip, nblk * sizeof(size_t)},
        {(void **)&w.pinert, w.n_pot * sizeof(double)},
        {(void **)&w.cnt, k * sizeof(size_t)},
        {(void **)&w.ppd, pp_bytes},
        {(void **)&best_lab, multi ? n * sizeof(int32_t) : 0},
        {(void **)&best_c, multi ? k * dim * sizeof(double) : 0},
    };
    for (size_t q = 0; q < MLR_COUNTOF(blocks); q++) {
        if (blocks[q].bytes == 0)
            continue;
        *blocks[q].slot = common__alloc(&km->a, blocks[q].bytes);
        if (!*blocks[q].slot) {
            st = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                  "kmeans fit: out of memory for the workspace");
            goto done;
        }
    }
    w.pk.k = k;
    w.pk.kpad = kpad;
    w.pk.dim = dim;
    w.pk.isa = cpu__isa(MLR_ISA_BEST);

    /* norms, tolerance */
    double xmax2;
    const double tol_abs = data_stats(&w, &xmax2);

    double best_in;
    size_t best_it, best_skip;
    fit_runs(&w, init, ldinit, tol_abs, xmax2, best_lab, best_c, &best_in, &best_it, &best_skip);
    memcpy(km->centers, w.c, k * dim * sizeof(double));
    cluster__packed_fill(&km->packed, km->centers, dim);
    km->inertia = best_in;
    km->n_iter = best_it;
    km->n_skipped = best_skip;
    if (labels)
        memcpy(labels, w.lab, n * sizeof(int32_t));
done:
    for (size_t q = 0; q < MLR_COUNTOF(blocks); q++)
        if (blocks[q].bytes)
            common__free(&km->a, *blocks[q].slot, blocks[q].bytes);
    return st;
}
