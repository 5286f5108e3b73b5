/*
 * Base layer (paper 1, section 4.1, eq. 11 and 14): hemisphere-aligned quaternions smoothed as
 * 4 channels, renormalized; the smoothing s chosen per joint as the strongest one whose largest
 * displacement angle stays within gamma.
 *
 * The angle of conj(qb/|qb|) q for a unit q is 2 acos(|<qb, q>| / |qb|), so the largest angle
 * over the frames is the one with the smallest <qb, q>^2 / |qb|^2: no log per frame.
 *
 * The search runs every joint in lockstep (one batched solve per step over the joints still
 * searching) on u = ln s with h(u) = ln(angle(u) / gamma): the angle grows roughly like a
 * power of s, so h is nearly linear in u and a bracketed secant (Illinois) closes quickly.
 */
#include "layers/layers_internal.h"

#include <math.h>

/* The search stops when the bracket [s_ok, s_bad] is narrower than this ratio. */
#define BASE_BRACKET_RATIO 1.04
#define BASE_MAX_STEPS 60

mlr_status layers__prepare_rot(size_t n, size_t j, const double *rot_in, double *q, mlr_diag *diag)
{
    if (mlr_quat_normalize_array((const mlr_quat *)rot_in, n * j, (mlr_quat *)q, NULL) != MLR_OK) {
        for (size_t i = 0; i < n * j; i++) {
            const double *r = rot_in + 4 * i;
            const double nn = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
            if (!isfinite(r[0] + r[1] + r[2] + r[3]) || nn == 0.0)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "rotation of frame %zu, joint %zu is %s", i / j, i % j,
                                        nn == 0.0 ? "zero" : "not finite");
        }
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "a rotation cannot be normalized");
    }
    mlr_quat_make_continuous((mlr_quat *)q, n, j);
    return MLR_OK;
}

/* Smallest <qb, q>^2 / |qb|^2 over the frames for each of the ns joints whose 4 channels
 * are at 4 k of the rows of q (stride ldq) and qb (stride ldb). */
static void min_cos2(size_t n, size_t ns, const double *q, size_t ldq, const double *qb,
                     size_t ldb, double *out)
{
    for (size_t k = 0; k < ns; k++)
        out[k] = 1.0;
    for (size_t i = 0; i < n; i++) {
        const double *qi = q + i * ldq, *bi = qb + i * ldb;
        for (size_t k = 0; k < ns; k++) {
            const double *a = qi + 4 * k, *b = bi + 4 * k;
            const double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
            const double nn = b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3];
            /* nn == 0 only with d == 0: r = 0 then (no branch, so the loop vectorizes) */
            const double r = d * d / (nn > 1e-300 ? nn : 1e-300);
            out[k] = r < out[k] ? r : out[k];
        }
    }
}

/* min_cos2 of a weighted evaluation: the ns joints col[k] / 4 of q in the full layout (stride
 * 4 j), the base packed (stride 4 ns), frames that are outliers of their joint skipped. */
static void min_cos2_inliers(size_t n, size_t j, size_t ns, const size_t *col, const double *q,
                             const double *qb, const unsigned char *flag, double *out)
{
    for (size_t k = 0; k < ns; k++)
        out[k] = 1.0;
    for (size_t i = 0; i < n; i++) {
        const double *qi = q + i * 4 * j, *bi = qb + i * 4 * ns;
        const unsigned char *fi = flag + i * (1 + j) + 1;
        for (size_t k = 0; k < ns; k++) {
            if (fi[col[k] / 4])
                continue;
            const double *a = qi + col[k], *b = bi + 4 * k;
            const double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
            const double nn = b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3];
            const double r = d * d / (nn > 1e-300 ? nn : 1e-300);
            out[k] = r < out[k] ? r : out[k];
        }
    }
}

/* The weights of group g0 + col[k] / cw of rb->w packed into rb->wpk (n x ns), and the
 * observations y (channel col[k] + c of the rows, stride ldy) times them into comp (stride
 * m ns). */
void layers__pack_weighted(size_t n, size_t ng, const mlr_lay_robust *rb, size_t g0, size_t cw,
                           const size_t *col, size_t ns, size_t m, const double *y, size_t ldy,
                           double *comp)
{
    for (size_t i = 0; i < n; i++) {
        const double *wi = rb->w + i * ng + g0, *yi = y + i * ldy;
        double *wp = rb->wpk + i * ns, *ci = comp + i * m * ns;
        for (size_t k = 0; k < ns; k++) {
            const double w = wi[col[k] / cw];
            wp[k] = w;
            for (size_t c = 0; c < m; c++)
                ci[m * k + c] = w * yi[col[k] + c];
        }
    }
}

static double angle_of_cos2(double c2) { return 2.0 * acos(sqrt(c2 < 1.0 ? c2 : 1.0)); }

/* One batched evaluation: systems k = 0..ns-1 (joint col[k] / 4) at s[k]; base quaternions
 * (unnormalized) into L->base_rot, the ns joints packed (row stride 4 ns: the full layout
 * when every joint is evaluated); largest angles into angle. comp: 4 n ns doubles when some
 * joint is left out; ebuf: 12 ns doubles. */
static mlr_status eval_angles(mlr_layers *L, const double *q, const mlr_lay_robust *rb,
                              mlr_lay_batch *b, const size_t *col, const double *s, double *angle,
                              double *comp, double *ebuf, mlr_diag *diag)
{
    const size_t n = L->n, j = L->j, ns = b->ns;
    if (rb) { /* weighted: W q packed into comp; the bound over the frames that are inliers */
        layers__pack_weighted(n, 1 + j, rb, 1, 4, col, ns, 4, q, 4 * j, comp);
        b->w = rb->wpk;
    }
    size_t bad = layers__batch_factor(b, s);
    if (bad)
        return common__diag_set(diag, MLR_E_SINGULAR, 0, 0,
                                "base smoothing of joint %zu failed at s = %g: s is too large for "
                                "%zu frames",
                                col[bad - 1] / 4, s[bad - 1], n);
    if (rb) {
        layers__batch_solve(b, 4, comp, 4 * ns, L->base_rot, 4 * ns, ebuf);
        min_cos2_inliers(n, j, ns, col, q, L->base_rot, L->outliers, angle);
        for (size_t k = 0; k < ns; k++)
            angle[k] = angle_of_cos2(angle[k]);
        return MLR_OK;
    }
    const double *y = q;
    if (ns < j) {
        for (size_t i = 0; i < n; i++) {
            const double *qi = q + i * 4 * j;
            double *ci = comp + i * 4 * ns;
            for (size_t k = 0; k < ns; k++)
                memcpy(ci + 4 * k, qi + col[k], 4 * sizeof(double));
        }
        y = comp;
    }
    layers__batch_solve(b, 4, y, 4 * ns, L->base_rot, 4 * ns, ebuf);
    min_cos2(n, ns, y, 4 * ns, L->base_rot, 4 * ns, angle);
    for (size_t k = 0; k < ns; k++)
        angle[k] = angle_of_cos2(angle[k]);
    return MLR_OK;
}

static double h_of(double angle, double gamma) { return log(fmax(angle, 1e-300) / gamma); }

/* The search of the base s per joint: the largest s whose base keeps every joint within
 * gamma of the input, by bracketing in u = log s. */
typedef struct base_search {
    mlr_layers *L;
    const mlr_layers_cfg *cfg;
    const double *q;
    const mlr_lay_robust *rb;
    mlr_lay_batch *b;
    size_t *col;
    /* per system k (packed): s, angle; per joint: the rest */
    double *s, *angle, *s_best;
    double *u_lo, *u_hi, *h_lo, *h_hi;
    double *side; /* -1 the ok end moved last, +1 the broken end, 0 none */
    double *comp, *ebuf;
} base_search;

/* The ends of the brackets: the strongest setting first (joints within the bound there are
 * done; *fresh: L->base_rot holds every joint's solution there), then the weakest (joints
 * beyond the bound even there keep s_min). The *nb joints with a bracket are left in col. */
static mlr_status bracket_ends(const base_search *bs, int *fresh, size_t *nb_out, mlr_diag *diag)
{
    mlr_layers *L = bs->L;
    const mlr_layers_cfg *cfg = bs->cfg;
    const size_t j = L->j;
    const double gamma = cfg->gamma;
    size_t *col = bs->col;
    double *s = bs->s, *angle = bs->angle, *s_best = bs->s_best;
    double *u_lo = bs->u_lo, *u_hi = bs->u_hi, *h_lo = bs->h_lo, *h_hi = bs->h_hi;
    mlr_status rc;
    for (size_t k = 0; k < j; k++)
        s[k] = cfg->base_s_max;
    if (eval_angles(L, bs->q, bs->rb, bs->b, col, s, angle, bs->comp, bs->ebuf, NULL) < 0) {
        /* s_max too large */
        for (size_t k = 0; k < j; k++)
            angle[k] = INFINITY;
    } else {
        *fresh = 1;
    }
    size_t na = 0;
    for (size_t k = 0; k < j; k++) {
        s_best[k] = cfg->base_s_max;
        if (angle[k] > gamma) {
            u_hi[k] = log(cfg->base_s_max);
            h_hi[k] = isfinite(angle[k]) ? h_of(angle[k], gamma) : INFINITY;
            col[na++] = 4 * k;
        }
    }
    bs->b->ns = na;
    for (size_t k = 0; k < na; k++)
        s[k] = cfg->base_s_min;
    if (na > 0) {
        *fresh = 0;
        if ((rc = eval_angles(L, bs->q, bs->rb, bs->b, col, s, angle, bs->comp, bs->ebuf, diag)) <
            0)
            return rc;
    }
    size_t nb = 0;
    for (size_t k = 0; k < na; k++) {
        const size_t jj = col[k] / 4;
        s_best[jj] = cfg->base_s_min;
        if (angle[k] <= gamma) {
            u_lo[jj] = log(cfg->base_s_min);
            h_lo[jj] = h_of(angle[k], gamma);
            bs->side[jj] = 0.0;
            col[nb++] = col[k];
        }
    }
    *nb_out = nb;
    return MLR_OK;
}

/* Illinois on the nb joints with a bracket (in col), until each bracket is narrower than
 * tol or BASE_MAX_STEPS steps; s_best the last s within the bound. */
static mlr_status illinois(const base_search *bs, size_t nb, double tol, mlr_diag *diag)
{
    const double gamma = bs->cfg->gamma;
    size_t *col = bs->col;
    double *s = bs->s, *angle = bs->angle, *s_best = bs->s_best, *side = bs->side;
    double *u_lo = bs->u_lo, *u_hi = bs->u_hi, *h_lo = bs->h_lo, *h_hi = bs->h_hi;
    mlr_status rc;
    for (int step = 0; nb > 0 && step < BASE_MAX_STEPS; step++) {
        bs->b->ns = nb;
        for (size_t k = 0; k < nb; k++) {
            const size_t jj = col[k] / 4;
            const double a = u_lo[jj], c = u_hi[jj], ha = h_lo[jj], hc = h_hi[jj];
            double u = isfinite(hc) && hc > ha ? a - ha * (c - a) / (hc - ha) : 0.5 * (a + c);
            /* stay clear of the ends so that the bracket shrinks on both sides */
            const double margin = fmin(0.25 * tol, 0.25 * (c - a));
            if (!(u > a + margin))
                u = a + margin;
            if (!(u < c - margin))
                u = c - margin;
            s[k] = exp(u);
        }
        if ((rc = eval_angles(bs->L, bs->q, bs->rb, bs->b, col, s, angle, bs->comp, bs->ebuf,
                              diag)) < 0)
            return rc;
        size_t nn = 0;
        for (size_t k = 0; k < nb; k++) {
            const size_t jj = col[k] / 4;
            const double u = log(s[k]), h = h_of(angle[k], gamma);
            if (angle[k] <= gamma) {
                u_lo[jj] = u;
                h_lo[jj] = h;
                s_best[jj] = s[k];
                if (side[jj] < 0.0)
                    h_hi[jj] *= 0.5;
                side[jj] = -1.0;
            } else {
                u_hi[jj] = u;
                h_hi[jj] = h;
                if (side[jj] > 0.0)
                    h_lo[jj] *= 0.5;
                side[jj] = 1.0;
            }
            if (u_hi[jj] - u_lo[jj] > tol)
                col[nn++] = col[k];
        }
        nb = nn;
    }
    return MLR_OK;
}

/* The base rotations renormalized; a vanishing mean (only possible when even s_min breaks
 * the bound) falls back to the input rotation q. */
static void renormalize_base(mlr_layers *L, const double *q)
{
    const size_t n = L->n, j = L->j;
    double *qb = L->base_rot;
    int vanished = 0;
    for (size_t i = 0; i < n * j; i++) { /* branch-free, so that it vectorizes */
        double *r = qb + 4 * i;
        const double nn = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
        const double inv = 1.0 / sqrt(nn > 1e-200 ? nn : 1.0);
        r[0] *= inv, r[1] *= inv, r[2] *= inv, r[3] *= inv;
        vanished |= !(nn > 1e-200);
    }
    for (size_t i = 0; vanished && i < n * j; i++) {
        double *r = qb + 4 * i; /* unscaled where the mean vanished: below 1e-100 */
        if (!(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3] > 1e-200))
            memcpy(r, q + 4 * i, 4 * sizeof(double));
    }
}

/* The root translation's base with the body joint's s (joint 0 unless told); zeros without
 * a root_pos. */
static mlr_status smooth_root(mlr_layers *L, const mlr_layers_cfg *cfg, const double *root_pos,
                              const mlr_lay_robust *rb, mlr_lay_batch *b, size_t *col,
                              double *comp, double *ebuf, const double *s_best, mlr_diag *diag)
{
    const size_t n = L->n, j = L->j;
    const double s0 = s_best[cfg->body_joint], k0 = sqrt(sqrt(100.0 * s0));
    *layers__param_slot(L, MLR_LAYERS_PARAM_BASE_S, 0) = s0;
    *layers__param_slot(L, MLR_LAYERS_PARAM_BASE_LAM, 0) = k0;
    *layers__param_slot(L, MLR_LAYERS_PARAM_BASE_SIGMA, 0) = 0.1 * k0;
    if (!root_pos) {
        memset(L->base_pos, 0, 3 * n * sizeof(double));
        return MLR_OK;
    }
    b->ns = 1;
    col[0] = 0;
    const double *y = root_pos;
    if (rb) {
        layers__pack_weighted(n, 1 + j, rb, 0, 1, col, 1, 3, root_pos, 3, comp);
        b->w = rb->wpk;
        y = comp;
    }
    if (layers__batch_factor(b, &s0))
        return common__diag_set(diag, MLR_E_SINGULAR, 0, 0,
                                "base smoothing of the root translation failed at s = %g", s0);
    layers__batch_solve(b, 3, y, 3, L->base_pos, 3, ebuf);
    return MLR_OK;
}

mlr_status layers__base(mlr_layers *L, const mlr_layers_cfg *cfg, const double *q,
                        const double *root_pos, const mlr_lay_robust *rb, double *fac,
                        double *comp, double *work, size_t *col, mlr_diag *diag)
{
    const size_t n = L->n, j = L->j;
    mlr_lay_batch b = {n, j, n, fac, fac + n * j, fac + 2 * n * j, NULL};
    base_search bs = {L,
                      cfg,
                      q,
                      rb,
                      &b,
                      col,
                      work,
                      work + j,
                      work + 2 * j,
                      work + 3 * j,
                      work + 4 * j,
                      work + 5 * j,
                      work + 6 * j,
                      work + 7 * j,
                      comp,
                      work + 8 * j /* 12 j doubles for the solves */};
    double *s_best = bs.s_best;
    int fresh = 0; /* L->base_rot holds every joint's solution at s_best (full layout) */
    mlr_status rc;

    for (size_t k = 0; k < j; k++)
        col[k] = 4 * k;

    if (cfg->base_s > 0.0) {
        for (size_t k = 0; k < j; k++)
            s_best[k] = cfg->base_s;
    } else {
        size_t nb;
        if ((rc = bracket_ends(&bs, &fresh, &nb, diag)) < 0 ||
            (rc = illinois(&bs, nb, log(BASE_BRACKET_RATIO), diag)) < 0)
            return rc;
    }

    /* final pass at the chosen s of every joint */
    b.ns = j;
    for (size_t k = 0; k < j; k++)
        col[k] = 4 * k;
    if (!fresh && (rc = eval_angles(L, q, rb, &b, col, s_best, bs.angle, comp, bs.ebuf, diag)) < 0)
        return rc;
    for (size_t k = 0; k < j; k++) {
        const double sk = s_best[k], kk = sqrt(sqrt(100.0 * sk));
        *layers__param_slot(L, MLR_LAYERS_PARAM_BASE_S, 1 + k) = sk;
        *layers__param_slot(L, MLR_LAYERS_PARAM_BASE_LAM, 1 + k) = kk;
        *layers__param_slot(L, MLR_LAYERS_PARAM_BASE_SIGMA, 1 + k) = 0.1 * kk;
    }
    renormalize_base(L, q);
    return smooth_root(L, cfg, root_pos, rb, &b, col, comp, bs.ebuf, s_best, diag);
}
