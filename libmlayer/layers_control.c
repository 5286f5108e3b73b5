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
#include "layers_internal.h"

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

/* Batched evaluation for systems k (group col[k] / 3) at s[k]: the solution into L->control,
 * GCV and tr(H) per system. */
static mlr_status eval_gcv(mlr_layers *L, const double *delta, mlr_lay_batch *b,
                           const size_t *col, const double *s, double *gcv, double *dof,
                           double *work, double *zero, mlr_diag *diag)
{
    const size_t n = L->n, ld = 3 * (1 + L->j), ns = b->ns;
    size_t bad = mlr_lay_batch_factor(b, s);
    if (bad)
        return mlr_diag_set(diag, MLR_E_SINGULAR, 0, 0,
                            "control smoothing of group %zu failed at s = %g: s is too large "
                            "for %zu frames", col[bad - 1] / 3, s[bad - 1], n);
    mlr_lay_batch_solve(b, col, 3, delta, ld, L->control, ld, zero);
    mlr_lay_batch_trace(b, dof, work);
    for (size_t k = 0; k < ns; k++)
        gcv[k] = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double *y = delta + i * ld, *x = L->control + i * ld;
        for (size_t k = 0; k < ns; k++) {
            const size_t c = col[k];
            const double r0 = y[c] - x[c], r1 = y[c + 1] - x[c + 1], r2 = y[c + 2] - x[c + 2];
            gcv[k] += r0 * r0 + r1 * r1 + r2 * r2;
        }
    }
    const double nd = (double)n;
    for (size_t k = 0; k < ns; k++) {
        const double den = 1.0 - dof[k] / nd;
        gcv[k] = den > 0.0 ? gcv[k] / (3.0 * nd) / (den * den) : INFINITY;
    }
    return MLR_OK;
}

mlr_status mlr_layers_control(mlr_layers *L, const mlr_layers_cfg *cfg, const double *delta,
                              double *fac, double *work, size_t *col, mlr_diag *diag)
{
    const size_t n = L->n, ng = 1 + L->j, ld = 3 * ng;
    mlr_lay_batch b = {n, ng, fac, fac + n * ng, fac + 2 * n * ng};
    double *s = work, *gcv = work + ng, *dof = work + 2 * ng, *tw = work + 3 * ng;
    double *s_best = work + 6 * ng, *searched = work + 7 * ng;
    brent *br = (brent *)(void *)(work + 8 * ng); /* 11 ng doubles */
    double *zero = work + 19 * ng;                 /* 4 ng doubles for the solves */
    mlr_status rc;

    for (size_t g = 0; g < ng; g++)
        searched[g] = 0.0;
    if (cfg->control_s > 0.0) {
        for (size_t g = 0; g < ng; g++)
            s_best[g] = cfg->control_s;
    } else {
        /* groups with an identically zero displacement have nothing to choose: s = 1 */
        size_t na = 0;
        for (size_t g = 0; g < ng; g++) {
            int zero = 1;
            for (size_t i = 0; i < n && zero; i++) {
                const double *y = delta + i * ld + 3 * g;
                zero = y[0] == 0.0 && y[1] == 0.0 && y[2] == 0.0;
            }
            s_best[g] = 1.0;
            if (!zero) {
                col[na++] = 3 * g;
                searched[g] = 1.0;
            }
        }
        /* the shared grid */
        const double u0 = log(cfg->control_s_min), u1 = log(cfg->control_s_max);
        size_t n_grid = (size_t)ceil((u1 - u0) / GCV_GRID_STEP - 1e-9) + 1;
        if (n_grid < 2)
            n_grid = 2;
        const double step = (u1 - u0) / (double)(n_grid - 1);
        b.ns = na;
        for (size_t p = 0; p < n_grid && na > 0; p++) {
            const double u = p + 1 == n_grid ? u1 : u0 + step * (double)p;
            for (size_t k = 0; k < na; k++)
                s[k] = exp(u);
            if ((rc = eval_gcv(L, delta, &b, col, s, gcv, dof, tw, zero, diag)) < 0)
                return rc;
            for (size_t k = 0; k < na; k++) {
                brent *r = &br[col[k] / 3];
                if (p == 0 || gcv[k] < r->fx) {
                    r->x = u, r->fx = gcv[k];
                    r->a = p == 0 ? u0 : u - step;
                    r->b = p + 1 == n_grid ? u1 : u + step;
                }
            }
        }
        for (size_t k = 0; k < na; k++) {
            brent *r = &br[col[k] / 3];
            if (r->b > u1)
                r->b = u1;
            r->w = r->v = r->x;
            r->fw = r->fv = r->fx;
            r->d = r->e = 0.0;
        }
        /* Brent in lockstep */
        for (int it = 0; na > 0 && it < GCV_MAX_STEPS; it++) {
            size_t nb = 0;
            for (size_t k = 0; k < na; k++) {
                brent *r = &br[col[k] / 3];
                if (brent_next(r)) {
                    s[nb] = exp(r->u);
                    col[nb++] = col[k];
                }
            }
            na = b.ns = nb;
            if (na == 0)
                break;
            if ((rc = eval_gcv(L, delta, &b, col, s, gcv, dof, tw, zero, diag)) < 0)
                return rc;
            for (size_t k = 0; k < na; k++)
                brent_update(&br[col[k] / 3], gcv[k]);
        }
        for (size_t g = 0; g < ng; g++) {
            if (searched[g] != 0.0)
                s_best[g] = exp(br[g].x);
        }
    }
    /* the layer at the chosen s of every group */
    b.ns = ng;
    for (size_t g = 0; g < ng; g++)
        col[g] = 3 * g;
    if ((rc = eval_gcv(L, delta, &b, col, s_best, gcv, dof, tw, zero, diag)) < 0)
        return rc;
    for (size_t g = 0; g < ng; g++) {
        const double sg = s_best[g], k = sqrt(sqrt(sg));
        *mlr_layers_param_slot(L, MLR_LAYERS_PARAM_CONTROL_S, g) = sg;
        *mlr_layers_param_slot(L, MLR_LAYERS_PARAM_CONTROL_LAM, g) = k;
        *mlr_layers_param_slot(L, MLR_LAYERS_PARAM_CONTROL_SIGMA, g) = k;
        *mlr_layers_param_slot(L, MLR_LAYERS_PARAM_CONTROL_GCV, g) =
            cfg->control_s > 0.0 ? NAN : gcv[g];
        *mlr_layers_param_slot(L, MLR_LAYERS_PARAM_CONTROL_DOF, g) = dof[g];
    }
    return MLR_OK;
}
