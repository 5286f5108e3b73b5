/*
 * Controllable layer (paper 1, eq. 15): the displacement channels smoothed per group of 3
 * (the root translation, each joint's rotation vector). The smoothing s of each group is the
 * minimizer of generalized cross-validation,
 *
 *     GCV(s) = (RSS(s) / 3N) / (1 - tr(H(s)) / N)^2,   H(s) = (I + s L^T L)^-1,
 *
 * over u = ln s: a grid shared by every group (one point per two decades), then Brent's
 * method around each group's best grid point, all groups in lockstep so that every step is
 * one batched factor + solve + selected inversion over the groups still searching.
 */
#include "layers/layers_internal.h"

#include <math.h>
#define GCV_GRID_STEP 4.605170185988091 /* ln 100: one grid point per two decades */
#define GCV_TOL 0.012197083360807     /* ln(1.05) / 4: Brent stops with a bracket < 5% in s */
#define GCV_MAX_STEPS 100
#define CGOLD 0.3819660112501051

/* Brent's minimizer (reverse communication) on u = ln s. */
typedef struct brent {
    double a, b, x, w, v, fx, fw, fv, d, e, u;
} brent;

/* Next point to evaluate into br->u; 0 when converged. */
static int brent_next(brent *br)
{
    const double xm = 0.5 * (br->a + br->b), tol1 = GCV_TOL, tol2 = 2.0 * tol1;
    if (fabs(br->x - xm) <= tol2 - 0.5 * (br->b - br->a))
        return 0;
    double d = br->d, e = br->e;
    int golden = 1;
    if (fabs(e) > tol1) {
        double r = (br->x - br->w) * (br->fx - br->fv);
        double q = (br->x - br->v) * (br->fx - br->fw);
        double p = (br->x - br->v) * q - (br->x - br->w) * r;
        q = 2.0 * (q - r);
        if (q > 0.0)
            p = -p;
        q = fabs(q);
        const double etemp = e;
        e = d;
        if (!(fabs(p) >= fabs(0.5 * q * etemp) || p <= q * (br->a - br->x) ||
              p >= q * (br->b - br->x))) {
            d = p / q;
            const double u = br->x + d;
            if (u - br->a < tol2 || br->b - u < tol2)
                d = xm >= br->x ? tol1 : -tol1;
            golden = 0;
        }
    }
    if (golden) {
        e = br->x >= xm ? br->a - br->x : br->b - br->x;
        d = CGOLD * e;
    }
    br->d = d;
    br->e = e;
    br->u = fabs(d) >= tol1 ? br->x + d : br->x + (d >= 0.0 ? tol1 : -tol1);
    return 1;
}

static void brent_update(brent *br, double fu)
{
    const double u = br->u;
    if (fu <= br->fx) {
        if (u >= br->x)
            br->a = br->x;
        else
            br->b = br->x;
        br->v = br->w, br->fv = br->fw;
        br->w = br->x, br->fw = br->fx;
        br->x = u, br->fx = fu;
    } else {
        if (u < br->x)
            br->a = u;
        else
            br->b = u;
        if (fu <= br->fw || br->w == br->x) {
            br->v = br->w, br->fv = br->fw;
            br->w = u, br->fw = fu;
        } else if (fu <= br->fv || br->v == br->x || br->v == br->w) {
            br->v = u, br->fv = fu;
        }
    }
}

/* Work of one GCV evaluation. */
typedef struct gcv_work {
    double *trace, *tw, *acc, *ebuf; /* ng, 3 ng, 3 ng, 18 ng doubles */
} gcv_work;

/*
 * Batched evaluation of ng groups of 3 channels, the rows of y (stride 3 ng, groups packed)
 * smoothed into x (same stride): b->ns systems at s[k], each owning 3 ng / ns channels (one
 * system for all groups on the shared grid, or one per group). GCV and tr(H) per group; col
 * names the groups for messages. keep: x is the smoothed layer on return; otherwise x is only
 * scratch (the search needs the residual sums, not the solution).
 */
static mlr_status eval_gcv(const mlr_layers *L, mlr_lay_batch *b, const double *s, size_t ng,
                           const size_t *col, const double *y, double *x, int keep, double *gcv,
                           double *dof, const gcv_work *w, mlr_diag *diag)
{
    const size_t n = L->n, ns = b->ns, mm = 3 * ng, m = mm / ns;
    size_t bad = layers__batch_factor(b, s);
    if (bad)
        return common__diag_set(diag, MLR_E_SINGULAR, 0, 0,
                                "control smoothing of group %zu failed at s = %g: s is too large "
                                "for %zu frames",
                                col[(bad - 1) * m / 3] / 3, s[bad - 1], n);
    if (keep) {
        layers__batch_solve(b, m, y, mm, x, mm, w->ebuf);
        layers__sum_sq_diff(n, mm, y, x, w->acc);
    } else {
        layers__batch_rss(b, m, y, mm, x, mm, w->ebuf, w->acc);
    }
    layers__batch_trace(b, w->trace, w->tw);
    const double *acc = w->acc;
    const double nd = (double)n;
    for (size_t g = 0; g < ng; g++) {
        const double tr = w->trace[3 * g / m], den = 1.0 - tr / nd;
        const double rss = acc[3 * g] + acc[3 * g + 1] + acc[3 * g + 2];
        dof[g] = tr;
        gcv[g] = den > 0.0 ? rss / (3.0 * nd) / (den * den) : INFINITY;
    }
    return MLR_OK;
}

/*
 * eval_gcv with observation weights: one system per group (the weights differ by group), the
 * groups col[k] / 3 of delta (stride 3 ng_all) weighted into comp, the solution packed into x
 * (stride 3 na). GCV(s) = (RSS_w / 3 n_w) / (1 - tr(H W) / n_w)^2 with RSS_w the weighted
 * residual sum and n_w the sum of the weights (an outlier frame counts for its weight).
 */
static mlr_status eval_gcv_weighted(const mlr_layers *L, mlr_lay_batch *b, const double *s,
                                    size_t na, const size_t *col, const double *delta,
                                    const mlr_lay_robust *rb, double *comp, double *x, double *gcv,
                                    double *dof, const gcv_work *w, mlr_diag *diag)
{
    const size_t n = L->n, ng = 1 + L->j, ld = 3 * ng, mm = 3 * na;
    b->ns = na;
    layers__pack_weighted(n, ng, rb, 0, 3, col, na, 3, delta, ld, comp);
    b->w = rb->wpk;
    size_t bad = layers__batch_factor(b, s);
    if (bad)
        return common__diag_set(diag, MLR_E_SINGULAR, 0, 0,
                                "control smoothing of group %zu failed at s = %g: s is too large "
                                "for %zu frames",
                                col[bad - 1] / 3, s[bad - 1], n);
    layers__batch_solve(b, 3, comp, mm, x, mm, w->ebuf);
    double *rss = w->acc, *nw = w->acc + na; /* acc holds 3 ng doubles */
    for (size_t k = 0; k < na; k++)
        rss[k] = nw[k] = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double *di = delta + i * ld, *xi = x + i * mm, *wi = rb->wpk + i * na;
        for (size_t k = 0; k < na; k++) {
            const double *y = di + col[k], *f = xi + 3 * k;
            const double a = y[0] - f[0], c = y[1] - f[1], e = y[2] - f[2];
            rss[k] += wi[k] * (a * a + c * c + e * e);
            nw[k] += wi[k];
        }
    }
    layers__batch_trace(b, w->trace, w->tw);
    for (size_t k = 0; k < na; k++) {
        const double tr = w->trace[k], den = 1.0 - tr / nw[k];
        dof[k] = tr;
        gcv[k] = den > 0.0 ? rss[k] / (3.0 * nw[k]) / (den * den) : INFINITY;
    }
    return MLR_OK;
}

/* The groups col[0..na) of delta (row stride 3 ng_all) packed into comp (row stride 3 na). */
static void gather(size_t n, size_t ng_all, const double *delta, const size_t *col, size_t na,
                   double *comp)
{
    for (size_t i = 0; i < n; i++) {
        const double *di = delta + i * 3 * ng_all;
        double *ci = comp + i * 3 * na;
        for (size_t k = 0; k < na; k++)
            memcpy(ci + 3 * k, di + col[k], 3 * sizeof(double));
    }
}

/* The GCV search of the control s per group: a shared grid in u = log s, then Brent per
 * group from the grid's best. */
typedef struct gcv_search {
    mlr_layers *L;
    const double *delta;       /* N x ng x 3 */
    const mlr_lay_robust *rb;
    mlr_lay_batch *b;
    size_t *col;               /* the groups evaluated (3 g each) */
    double *comp, *x;          /* packed input, packed solutions */
    double *s, *gcv, *dof;     /* per system */
    double *searched;          /* per group: 1 when its s is searched */
    brent *br;
    const gcv_work *w;
    double *f_lo, *f_hi, *f_prev; /* per group: the grid's values around its best */
} gcv_search;

/* The groups with a nonzero displacement into col (their count returned; searched set);
 * the others have nothing to choose: s = 1. */
static size_t select_groups(const gcv_search *gs, double *s_best)
{
    const size_t n = gs->L->n, ng = 1 + gs->L->j, ld = 3 * ng;
    size_t na = 0;
    for (size_t g = 0; g < ng; g++) {
        int zero = 1;
        for (size_t i = 0; i < n && zero; i++) {
            const double *y = gs->delta + i * ld + 3 * g;
            zero = y[0] == 0.0 && y[1] == 0.0 && y[2] == 0.0;
        }
        s_best[g] = 1.0;
        if (!zero) {
            gs->col[na++] = 3 * g;
            gs->searched[g] = 1.0;
        }
    }
    return na;
}

/* GCV of the na groups in col at s (y: those groups packed, unless weighted). */
static mlr_status eval_groups(const gcv_search *gs, size_t na, const double *y, mlr_diag *diag)
{
    if (gs->rb)
        return eval_gcv_weighted(gs->L, gs->b, gs->s, na, gs->col, gs->delta, gs->rb, gs->comp,
                                 gs->x, gs->gcv, gs->dof, gs->w, diag);
    return eval_gcv(gs->L, gs->b, gs->s, na, gs->col, y, gs->x, 0, gs->gcv, gs->dof, gs->w, diag);
}

/* The shared grid from control_s_min to control_s_max (one system for every group): each
 * group's best grid point, its bracket and the values next to it. */
static mlr_status grid_search(const gcv_search *gs, const mlr_layers_cfg *cfg, size_t na,
                              const double *y, mlr_diag *diag)
{
    double *s = gs->s, *gcv = gs->gcv;
    double *f_lo = gs->f_lo, *f_hi = gs->f_hi, *f_prev = gs->f_prev;
    mlr_status rc;
    const double u0 = log(cfg->control_s_min), u1 = log(cfg->control_s_max);
    size_t n_grid = (size_t)ceil((u1 - u0) / GCV_GRID_STEP - 1e-9) + 1;
    if (n_grid < 2)
        n_grid = 2;
    const double step = (u1 - u0) / (double)(n_grid - 1);
    gs->b->ns = 1;
    for (size_t p = 0; p < n_grid && na > 0; p++) {
        const double u = p + 1 == n_grid ? u1 : u0 + step * (double)p;
        s[0] = exp(u);
        if (gs->rb) /* one system per group, every one at s */
            for (size_t k = 1; k < na; k++)
                s[k] = s[0];
        if ((rc = eval_groups(gs, na, y, diag)) < 0)
            return rc;
        for (size_t k = 0; k < na; k++) {
            const size_t g = gs->col[k] / 3;
            brent *r = &gs->br[g];
            if (p == 0 || gcv[k] < r->fx) {
                r->x = u, r->fx = gcv[k];
                r->a = p == 0 ? u0 : u - step;
                r->b = p + 1 == n_grid ? u1 : u + step;
                f_lo[g] = p == 0 ? NAN : f_prev[g];
                f_hi[g] = NAN;
            } else if (isnan(f_hi[g])) { /* the point right after the best so far */
                f_hi[g] = gcv[k];
            }
            f_prev[g] = gcv[k];
        }
    }
    for (size_t k = 0; k < na; k++) {
        const size_t g = gs->col[k] / 3;
        brent *r = &gs->br[g];
        if (r->b > u1)
            r->b = u1;
        r->w = r->v = r->x;
        r->fw = r->fv = r->fx;
        r->d = r->e = 0.0;
        /* an interior best: its two neighbours on the grid seed the parabola, so that the
         * first step is already a parabolic one (Brent starts with golden steps
         * otherwise); the step history is set to the grid step so that it is accepted
         * when it falls inside the bracket */
        if (isfinite(f_lo[g]) && isfinite(f_hi[g]) && r->a < r->x && r->x < r->b) {
            r->w = r->a, r->fw = f_lo[g];
            r->v = r->b, r->fv = f_hi[g];
            r->d = r->e = r->b - r->a;
        }
    }
    return MLR_OK;
}

/* Brent in lockstep, one system per group, from the grid's brackets (packed: the groups
 * packed in y when it is comp). */
static mlr_status brent_search(const gcv_search *gs, size_t na, size_t packed, const double *y,
                               mlr_diag *diag)
{
    const size_t n = gs->L->n, ng = 1 + gs->L->j;
    size_t *col = gs->col;
    mlr_status rc;
    for (int it = 0; na > 0 && it < GCV_MAX_STEPS; it++) {
        size_t nb = 0;
        for (size_t k = 0; k < na; k++) {
            brent *r = &gs->br[col[k] / 3];
            if (brent_next(r)) {
                gs->s[nb] = exp(r->u);
                col[nb++] = col[k];
            }
        }
        na = gs->b->ns = nb;
        if (na == 0)
            break;
        if (!gs->rb && na != packed) {
            gather(n, ng, gs->delta, col, na, gs->comp);
            y = gs->comp;
            packed = na;
        }
        if ((rc = eval_groups(gs, na, y, diag)) < 0)
            return rc;
        for (size_t k = 0; k < na; k++)
            brent_update(&gs->br[col[k] / 3], gs->gcv[k]);
    }
    return MLR_OK;
}

mlr_status layers__control(mlr_layers *L, const mlr_layers_cfg *cfg, const double *delta,
                           const mlr_lay_robust *rb, double *fac, double *comp, double *work,
                           size_t *col, mlr_diag *diag)
{
    const size_t n = L->n, ng = 1 + L->j;
    mlr_lay_batch b = {n, ng, n, fac, fac + n * ng, fac + 2 * n * ng, NULL};
    double *s = work, *gcv = work + ng, *dof = work + 2 * ng;
    double *s_best = work + 3 * ng, *searched = work + 4 * ng;
    brent *br = (brent *)(void *)(work + 5 * ng); /* 11 ng doubles */
    const gcv_work w = {work + 16 * ng, work + 17 * ng, work + 20 * ng, work + 23 * ng};
    double *x = L->control; /* packed solutions during the search; the layer at the end */
    const gcv_search gs = {L,
                           delta,
                           rb,
                           &b,
                           col,
                           comp,
                           x,
                           s,
                           gcv,
                           dof,
                           searched,
                           br,
                           &w,
                           work + 41 * ng,
                           work + 42 * ng,
                           work + 43 * ng};
    mlr_status rc;

    for (size_t g = 0; g < ng; g++)
        searched[g] = 0.0;
    if (cfg->control_s > 0.0) {
        for (size_t g = 0; g < ng; g++)
            s_best[g] = cfg->control_s;
    } else {
        const size_t na = select_groups(&gs, s_best);
        /* the groups searched, packed (delta itself when every group is) */
        const double *y = delta;
        if (na > 0 && na < ng && !rb) {
            gather(n, ng, delta, col, na, comp);
            y = comp;
        }
        if ((rc = grid_search(&gs, cfg, na, y, diag)) < 0 ||
            (rc = brent_search(&gs, na, na, y, diag)) < 0)
            return rc;
        for (size_t g = 0; g < ng; g++) {
            if (searched[g] != 0.0)
                s_best[g] = exp(br[g].x);
        }
    }
    /* the layer at the chosen s of every group */
    b.ns = ng;
    for (size_t g = 0; g < ng; g++)
        col[g] = 3 * g;
    rc = rb ? eval_gcv_weighted(L, &b, s_best, ng, col, delta, rb, comp, x, gcv, dof, &w, diag)
            : eval_gcv(L, &b, s_best, ng, col, delta, x, 1, gcv, dof, &w, diag);
    if (rc < 0)
        return rc;
    for (size_t g = 0; g < ng; g++) {
        const double sg = s_best[g], k = sqrt(sqrt(sg));
        *layers__param_slot(L, MLR_LAYERS_PARAM_CONTROL_S, g) = sg;
        *layers__param_slot(L, MLR_LAYERS_PARAM_CONTROL_LAM, g) = k;
        *layers__param_slot(L, MLR_LAYERS_PARAM_CONTROL_SIGMA, g) = k;
        *layers__param_slot(L, MLR_LAYERS_PARAM_CONTROL_GCV, g) =
            cfg->control_s > 0.0 ? NAN : gcv[g];
        *layers__param_slot(L, MLR_LAYERS_PARAM_CONTROL_DOF, g) = dof[g];
    }
    return MLR_OK;
}
