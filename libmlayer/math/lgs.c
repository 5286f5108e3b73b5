/*
 * The LGS posterior mean, solved as the equivalent scaled system
 *     (s L^T L + A^T A) x = A^T y,   s = lam^2 sigma^2,
 * whose matrix has bandwidth `order`. The right-hand side A^T y is formed row by row inside
 * the forward sweep, so a solve reads y once and makes one more pass over x.
 */
#include "math/lgs_internal.h"
#include "common/parallel_internal.h"
#include "common/prefault_internal.h"

#include <math.h>

struct mlr_lgs {
    mlr_allocator alloc;
    size_t n_out, n_obs;
    unsigned order;
    double s, sigma2;
    mlr_lgs_solver solver;
    mlr_band *band;            /* MLR_LGS_BANDED */
    mlr_sparse_spd *sparse;    /* MLR_LGS_CHOLMOD */
    /* interpolation rows (NULL for the identity): observations i with lo_i == r are
     * first[r] .. first[r+1]-1; f[i] is the weight on frame lo_i + 1 */
    size_t *first;
    double *f;
    size_t first_bytes, f_bytes;
};

int mlr_lgs_have_cholmod(void)
{
#ifdef MLR_HAVE_CHOLMOD
    return 1;
#else
    return 0;
#endif
}

/* Coefficients of the difference operator of the given order (alternating binomials). */
static const double diff_coef[3][3] = {{1, 0, 0}, {-1, 1, 0}, {1, -2, 1}};

typedef struct system_ctx {
    size_t n;
    unsigned order;
    double s;
    const double *ata_d; /* diagonal of A^T A (NULL: identity) */
    const double *ata_o; /* A^T A (i, i-1) (NULL: zero) */
} system_ctx;

double lgs__ltl_entry(size_t n, unsigned p, size_t i, size_t j)
{
    if (i - j > p || n <= p)
        return 0.0;
    const double *c = diff_coef[p];
    size_t r0 = i >= p ? i - p : 0;
    size_t r1 = j < n - p - 1 ? j : n - p - 1; /* rows r = 0 .. n-p-1 */
    double v = 0.0;
    for (size_t r = r0; r <= r1 && r <= j; r++)
        v += c[i - r] * c[j - r];
    return v;
}

static double system_entry(const void *vctx, size_t i, size_t j)
{
    const system_ctx *ctx = vctx;
    double v = ctx->s == 0.0 ? 0.0 : ctx->s * lgs__ltl_entry(ctx->n, ctx->order, i, j);
    if (i == j)
        v += ctx->ata_d ? ctx->ata_d[i] : 1.0;
    else if (i == j + 1 && ctx->ata_o)
        v += ctx->ata_o[i];
    return v;
}

static mlr_status check_params(size_t n_out, unsigned order, double lam, double sigma,
                               const double *t, size_t n_obs, mlr_diag *diag)
{
    if (order != 1 && order != 2)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "order must be 1 or 2, got %u",
                                order);
    if (!isfinite(lam) || lam < 0.0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lam must be finite and >= 0, got %g", lam);
    if (!isfinite(sigma) || !(sigma > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "sigma must be finite and > 0, got %g", sigma);
    if (n_out <= order)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "an order-%u prior needs at least %u frames, got %zu", order,
                                order + 1, n_out);
    if (!t) {
        if (n_obs != n_out)
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "without positions t the observations (%zu) must equal the output frames (%zu)",
                n_obs, n_out);
        return MLR_OK;
    }
    if (n_obs == 0)
        return common__diag_set(diag, MLR_E_SINGULAR, 0, 0, "no observations");
    const double tmax = (double)(n_out - 1);
    size_t distinct = 0;
    for (size_t i = 0; i < n_obs; i++) {
        if (!isfinite(t[i]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "t[%zu] is not finite", i);
        if (t[i] < 0.0 || t[i] > tmax)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "t[%zu] = %g is outside [0, n_out-1 = %zu]", i, t[i],
                                    n_out - 1);
        if (i > 0 && t[i] < t[i - 1])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "t is not sorted: t[%zu] = %g < t[%zu] = %g", i, t[i], i - 1,
                                    t[i - 1]);
        if (i == 0 || t[i] != t[i - 1])
            distinct++;
    }
    if (lam > 0.0 && distinct < order)
        return common__diag_set(
            diag, MLR_E_SINGULAR, 0, 0,
            "an order-%u prior needs observations at %u distinct positions, got %zu", order, order,
            distinct);
    return MLR_OK;
}

static void lgs_free(mlr_lgs *g)
{
    mlr_allocator a = g->alloc;
    mlr_band_destroy(g->band);
#ifdef MLR_HAVE_CHOLMOD
    lgs__sparse_spd_destroy(g->sparse);
#endif
    common__free(&a, g->first, g->first_bytes);
    common__free(&a, g->f, g->f_bytes);
    common__free(&a, g, sizeof *g);
}

/* Observation i sits between frames lo and lo+1 with weight f on lo+1; lo <= n_out - 2. */
static size_t obs_lo(double t, size_t n_out, double *f)
{
    double fl = floor(t);
    size_t lo = (size_t)fl;
    if (lo > n_out - 2)
        lo = n_out - 2;
    *f = t - (double)lo;
    return lo;
}

/* The observation map of t into g (first, f) and A^T A into *ata (2 n_out doubles: the
 * diagonal, then the subdiagonal at [n_out + i] for (i, i-1)); the caller frees *ata. */
static mlr_status observation_map(mlr_lgs *g, const double *t, double **ata, size_t *ata_bytes,
                                  mlr_diag *diag)
{
    const size_t n_out = g->n_out, n_obs = g->n_obs;
    if (common__mul_size(n_out + 1, sizeof(size_t), &g->first_bytes) ||
        common__mul_size(n_obs, sizeof(double), &g->f_bytes) ||
        common__mul_size(n_out, 2 * sizeof(double), ata_bytes))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0,
                                "lgs: %zu output frames, %zu observations overflow a size", n_out,
                                n_obs);
    g->first = common__alloc(&g->alloc, g->first_bytes);
    g->f = common__alloc(&g->alloc, g->f_bytes);
    *ata = common__alloc(&g->alloc, *ata_bytes);
    if (!g->first || !g->f || !*ata)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "lgs: out of memory for the observation map (%zu observations)",
                                n_obs);
    double *ata_d = *ata, *ata_o = *ata + n_out;
    memset(*ata, 0, *ata_bytes);
    size_t r = 0;
    for (size_t i = 0; i < n_obs; i++) {
        size_t lo = obs_lo(t[i], n_out, &g->f[i]);
        while (r <= lo)
            g->first[r++] = i;
        double f = g->f[i];
        ata_d[lo] += (1.0 - f) * (1.0 - f);
        ata_d[lo + 1] += f * f;
        ata_o[lo + 1] += (1.0 - f) * f;
    }
    while (r <= n_out)
        g->first[r++] = n_obs;
    return MLR_OK;
}

/* The system of ctx into a new band of g, factored. */
static mlr_status factor_banded(mlr_lgs *g, const system_ctx *ctx)
{
    const size_t n_out = g->n_out;
    const unsigned order = g->order;
    mlr_status st = mlr_band_create(n_out, order, &g->alloc, &g->band, NULL);
    if (st != MLR_OK)
        return st;
    mlr_band *b = g->band;
    /* interior rows of L^T L are constant: (6, -4, 1) for order 2, (2, -1) for 1 */
    const double sd = g->s * (order == 2 ? 6.0 : 2.0), s1 = g->s * (order == 2 ? -4.0 : -1.0);
    const double s2 = g->s;
    for (size_t i = 0; i < n_out; i++) {
        double *li = b->l + i * order;
        if (i >= order && i + order < n_out) {
            b->dinv[i] = sd + (ctx->ata_d ? ctx->ata_d[i] : 1.0);
            li[0] = s1 + (ctx->ata_o ? ctx->ata_o[i] : 0.0);
            if (order == 2)
                li[1] = s2;
            continue;
        }
        b->dinv[i] = system_entry(ctx, i, i);
        for (size_t k = 1; k <= order; k++)
            li[k - 1] = k <= i ? system_entry(ctx, i, i - k) : 0.0;
    }
    return band__factor_in_place(b);
}

mlr_status mlr_lgs_create(size_t n_out, unsigned order, double lam, double sigma, const double *t,
                          size_t n_obs, mlr_lgs_solver solver, const mlr_allocator *alloc,
                          mlr_lgs **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "out is NULL");
    *out = NULL;
    if (t == NULL && n_obs > 0 && n_obs != n_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "t is NULL but n_obs != n_out");
    mlr_status st = check_params(n_out, order, lam, sigma, t, n_obs, diag);
    if (st != MLR_OK)
        return st;
    if (solver != MLR_LGS_BANDED && solver != MLR_LGS_CHOLMOD)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "unknown solver %d", (int)solver);
    if (solver == MLR_LGS_CHOLMOD && !mlr_lgs_have_cholmod())
        return common__diag_set(diag, MLR_E_UNSUPPORTED, 0, 0,
                                "this build of mlayer has no CHOLMOD "
                                "(build it with SuiteSparse and -Dcholmod=enabled)");

    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_lgs *g = common__alloc(&a, sizeof *g);
    if (!g)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "lgs: out of memory for the handle");
    memset(g, 0, sizeof *g);
    g->alloc = a;
    g->n_out = n_out;
    g->n_obs = n_obs;
    g->order = order;
    g->s = lam * lam * sigma * sigma;
    g->sigma2 = sigma * sigma;
    g->solver = solver;
    if (!isfinite(g->s)) {
        lgs_free(g);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lam^2 sigma^2 overflows");
    }

    double *ata = NULL;
    size_t ata_bytes = 0;
    system_ctx ctx = {n_out, order, g->s, NULL, NULL};
    if (t) {
        st = observation_map(g, t, &ata, &ata_bytes, diag);
        if (st != MLR_OK) {
            common__free(&a, ata, ata_bytes);
            lgs_free(g);
            return st;
        }
        ctx.ata_d = ata;
        ctx.ata_o = ata + n_out;
    }
    if (solver == MLR_LGS_BANDED) {
        st = factor_banded(g, &ctx);
    } else {
#ifdef MLR_HAVE_CHOLMOD
        st = lgs__sparse_spd_create(n_out, order, system_entry, &ctx, &g->sparse);
#else
        st = MLR_E_UNSUPPORTED;
#endif
    }
    common__free(&a, ata, ata_bytes);
    if (st < 0) {
        lgs_free(g);
        if (st == MLR_E_SINGULAR)
            return common__diag_set(
                diag, st, 0, 0,
                "the system is singular: some output frames are not determined "
                "by the observations and the prior (lam = 0 with unobserved frames?)");
        return common__diag_set(diag, st, 0, 0, "lgs: the %s factorization of %zu frames: %s",
                                solver == MLR_LGS_BANDED ? "banded" : "CHOLMOD", n_out,
                                mlr_status_string(st));
    }
    *out = g;
    return st;
}

void mlr_lgs_destroy(mlr_lgs *g)
{
    if (g)
        lgs_free(g);
}

size_t mlr_lgs_n_out(const mlr_lgs *g) { return g ? g->n_out : 0; }
size_t mlr_lgs_n_obs(const mlr_lgs *g) { return g ? g->n_obs : 0; }

/* Row r of A^T y into x. */
static void rhs_row(const mlr_lgs *g, size_t r, const double *y, size_t ldy, size_t m, double *xr)
{
    for (size_t c = 0; c < m; c++)
        xr[c] = 0.0;
    if (r > 0) { /* observations between r-1 and r contribute f */
        for (size_t i = g->first[r - 1]; i < g->first[r]; i++) {
            const double w = g->f[i];
            const double *yi = y + i * ldy;
            for (size_t c = 0; c < m; c++)
                xr[c] += w * yi[c];
        }
    }
    if (r < g->n_out - 1) { /* observations between r and r+1 contribute 1-f */
        for (size_t i = g->first[r]; i < g->first[r + 1]; i++) {
            const double w = 1.0 - g->f[i];
            const double *yi = y + i * ldy;
            for (size_t c = 0; c < m; c++)
                xr[c] += w * yi[c];
        }
    }
}

typedef struct solve_ctx {
    const mlr_lgs *g;
    const double *y;
    size_t ldy;
} solve_ctx;

static void row_interp(const void *vctx, size_t r, double *xr, size_t ld, size_t m)
{
    const solve_ctx *c = vctx;
    rhs_row(c->g, r, c->y, c->ldy, m, xr);
    band__forward_row(c->g->band, r, xr, ld, m);
}

static void row_copy(const void *vctx, size_t r, double *xr, size_t ld, size_t m)
{
    const solve_ctx *c = vctx;
    band__forward_row_any(c->g->band, r, c->y + r * c->ldy, xr, ld, m);
}

static int row_finite(const double *x, size_t m)
{
    double acc = 0.0;
    for (size_t c = 0; c < m; c++)
        acc += x[c] * 0.0; /* NaN for any NaN or inf */
    return acc == 0.0;
}

mlr_status mlr_lgs_solve(const mlr_lgs *g, const double *y, size_t ldy, size_t m, double *x,
                         size_t ldx, mlr_diag *diag)
{
    return mlr_lgs_solve_mt(g, y, ldy, m, x, ldx, 1, diag);
}

/* The first non-finite value of y (n rows of m, stride ldy): the message of a failed solve. */
static mlr_status bad_y(const double *y, size_t n, size_t m, size_t ldy, mlr_diag *diag)
{
    for (size_t i = 0; i < n; i++)
        for (size_t c = 0; c < m; c++)
            if (!isfinite(y[i * ldy + c]))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "lgs solve: y[%zu][%zu] is NaN or infinite", i, c);
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "lgs solve: the solution is not finite (y too large)");
}

mlr_status mlr_lgs_solve_mt(const mlr_lgs *g, const double *y, size_t ldy, size_t m, double *x,
                            size_t ldx, size_t n_threads, mlr_diag *diag)
{
    if (!g)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lgs solve: the handle is NULL");
    if (m == 0)
        return MLR_OK;
    if (!y || !x)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "lgs solve: y or x is NULL");
    if (ldy < m || ldx < m)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lgs solve: ldy %zu or ldx %zu is below m = %zu columns", ldy, ldx,
                                m);
    if (g->first && x == y)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lgs solve: x is y, but an in-place solve needs t == NULL");
    const size_t n = g->n_out;
    if (g->solver == MLR_LGS_BANDED) {
        solve_ctx ctx = {g, y, ldy};
        mlr_band_row_fn fn = g->first ? row_interp : row_copy;
        mlr_prefault pf = {0};
        size_t rows, span; /* bytes from x's first to its last value; the size test comes
                            * first, so small solves never ask for the processor count */
        if (n_threads != 1 && common__mul_size(n - 1, ldx, &rows) == MLR_OK &&
            rows <= SIZE_MAX - m && common__mul_size(rows + m, sizeof(double), &span) == MLR_OK &&
            span >= MLR_PREFAULT_MIN_BYTES && (n_threads > 1 || parallel__online_cpus() > 1))
            prefault__start(&pf, x, span);
        band__solve_rows(g->band, fn, &ctx, x, ldx, m);
        prefault__finish(&pf);
    } else {
#ifdef MLR_HAVE_CHOLMOD
        /* a sparse factor need not connect every row with every other: check y itself */
        for (size_t i = 0; i < g->n_obs; i++)
            if (!row_finite(y + i * ldy, m))
                return bad_y(y, g->n_obs, m, ldy, diag);
        for (size_t r = 0; r < n; r++) {
            double *xr = x + r * ldx;
            if (g->first)
                rhs_row(g, r, y, ldy, m, xr);
            else if (xr != y + r * ldy)
                memcpy(xr, y + r * ldy, m * sizeof(double));
        }
        mlr_status st = lgs__sparse_spd_solve(g->sparse, x, ldx, m);
        if (st != MLR_OK)
            return common__diag_set(diag, st, 0, 0, "lgs solve: CHOLMOD: %s",
                                    mlr_status_string(st));
#else
        return common__diag_set(diag, MLR_E_UNSUPPORTED, 0, 0,
                                "lgs solve: no CHOLMOD in this build");
#endif
    }
    /* Any NaN or inf in y reaches every output row through the two sweeps (0 * inf and
     * 0 * NaN are NaN), so the first and last rows tell whether y was finite. */
    if (!row_finite(x, m) || !row_finite(x + (n - 1) * ldx, m))
        return bad_y(y, g->n_obs, m, ldy, diag);
    return MLR_OK;
}

mlr_status mlr_lgs_variance(const mlr_lgs *g, double *var, size_t n_out, mlr_diag *diag)
{
    if (!g || !var)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lgs variance: the handle or var is NULL");
    if (n_out != g->n_out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "lgs variance: n_out is %zu, the handle has %zu output frames",
                                n_out, g->n_out);
    if (g->solver != MLR_LGS_BANDED)
        return common__diag_set(diag, MLR_E_UNSUPPORTED, 0, 0,
                                "lgs variance: needs the banded solver, the handle is CHOLMOD's");
    mlr_status st = mlr_band_inverse_diagonal(g->band, var, n_out, NULL);
    if (st != MLR_OK)
        return common__diag_set(diag, st, 0, 0, "lgs variance: %s", mlr_status_string(st));
    for (size_t i = 0; i < n_out; i++)
        var[i] *= g->sigma2;
    return MLR_OK;
}
