/*
 * Contact cleanup and floor guard of a synthesized motion (mlr_cleanup.h): the cleanup run.
 */
#include "cleanup_internal.h"
#include "ik_internal.h"

#include <math.h>

/* Horizontal path length of a foot's contact points (P: N x C x 3) over consecutive contact
   frames of the run [s, e). */
static double run_sliding(const double *P, const uint8_t *contacts, size_t C,
                          const cleanup_foot *ft, size_t s, size_t e, int up)
{
    double len = 0.0;
    for (size_t f = s; f + 1 < e; f++)
        for (size_t i = 0; i < ft->n_cols; i++) {
            const size_t c = ft->cols[i];
            if (!contacts[f * C + c] || !contacts[(f + 1) * C + c])
                continue;
            double d2 = 0.0;
            for (int d = 0; d < 3; d++)
                if (d != up) {
                    const double x =
                        P[3 * ((f + 1) * C + c) + (size_t)d] - P[3 * (f * C + c) + (size_t)d];
                    d2 += x * x;
                }
            len += sqrt(d2);
        }
    return len;
}

static double dist3(const double *a, const double *b)
{
    const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return sqrt(x * x + y * y + z * z);
}

/* The arguments of a cleanup run, checked (the rig, points and motion unless trusted). */
static mlr_status cleanup_check(const mlr_rig *rig, size_t N, double fps, int up,
                                const double *root_pos, const double *rot, const double *trans,
                                const double *ref_root_pos, const double *ref_rot,
                                const double *ref_trans, const mlr_cleanup_ref *pre, int trusted,
                                size_t C, const int32_t *joints, const int32_t *end_sites,
                                const uint8_t *contacts, const mlr_cleanup_option *opts,
                                size_t n_opts, const double *out_root_pos, const double *out_rot,
                                cleanup_config *cfg, mlr_diag *diag)
{
    mlr_status st = trusted ? MLR_OK : mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if ((st = cleanup__parse_options(opts, n_opts, cfg, diag)) != MLR_OK)
        return st;
    if (N == 0 || !out_root_pos || !out_rot || (C && !contacts))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "cleanup: no frames, or NULL outputs or contacts");
    if (!(isfinite(fps) && fps > 0.0))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "cleanup: fps %g is not finite "
                            "and > 0",
                            fps);
    if (up < 0 || up > 2)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "cleanup: up axis %d is not 0 (X), "
                            "1 (Y) or 2 (Z)",
                            up);
    const int have_arrays = ref_root_pos || ref_rot || ref_trans;
    if (!trusted &&
        ((st = cleanup__check_points(rig, C, joints, end_sites, diag)) != MLR_OK ||
         (st = cleanup__check_motion(rig, N, root_pos, rot, trans, "motion", diag)) != MLR_OK ||
         (have_arrays && (st = cleanup__check_motion(rig, N, ref_root_pos, ref_rot, ref_trans,
                                                     "reference", diag)) != MLR_OK)))
        return st;
    if (pre && (pre->n_frames != N || pre->n_points != C || pre->up != up ||
                pre->smooth != cfg->ref_smooth))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "cleanup: the reference was made for other frames or options");
    if (C > 64)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "cleanup: at most 64 contact "
                            "points, got %zu",
                            C);
    return MLR_OK;
}

/* The state of one cleanup run, shared by its steps. */
typedef struct cleanup {
    const mlr_rig *rig;
    size_t N, J, C;
    double fps;
    int up;
    const cleanup_config *cfg;
    const int32_t *joints, *end_sites;
    const uint8_t *contacts;
    const double *trans;
    double *out_root_pos, *out_rot;
    cleanup_foot *feet;
    size_t nf;
    int have_ref;
    const double *Pr, *pos_ref;     /* the reference's points and anchors, or NULL */
    double *pos, *wrot, *P;         /* forward kinematics of (out_root_pos, out_rot), points */
    double *lim, *newr, *shift;
    double floor_h;
    int floor_active;
    uint8_t *anyU, *anyF;
    uint8_t *need;                  /* joints whose forward kinematics the cleanup reads */
    int32_t *tidx;
    uint8_t *fk_frames;
    double *pos2, *wrot2;           /* one frame's forward kinematics */
    int32_t *chains;                /* nf x J: the toes' chains, top-down */
    size_t *chain_len;
    int chained;
    uint8_t *mask;
    cleanup_work *w;
} cleanup;

/* The floor height (given, or the quantile of the contact heights) and each point's limit
   (from the unsmoothed reference); MLR_E_NO_MEMORY in ar->st. */
static mlr_status set_floor(cleanup *cu, const mlr_cleanup_ref *pre, cleanup_arena *ar)
{
    const size_t N = cu->N, C = cu->C;
    const int up = cu->up;
    const cleanup_config *cfg = cu->cfg;
    const uint8_t *contacts = cu->contacts;
    const double *P = cu->P;
    double *lim = cu->lim;
    double floor_h = NAN;
    if (cfg->floor_on) {
        if (cfg->floor_given) {
            floor_h = cfg->floor_height;
        } else {
            double *v = cleanup__take(ar, N * C, sizeof(double));
            if (ar->st != MLR_OK)
                return ar->st;
            size_t k = 0;
            for (size_t i = 0; i < N * C; i++)
                if (contacts[i])
                    v[k++] = pre ? pre->h[i] : P[3 * i + (size_t)up];
            if (k)
                floor_h = cleanup__quantile_of(v, k, cfg->floor_q);
        }
        for (size_t i = 0; i < N * C; i++)
            lim[i] = pre ? fmin(floor_h, pre->h[i]) : floor_h;
    }
    cu->floor_h = floor_h;
    cu->floor_active = cfg->floor_on && isfinite(floor_h);
    return MLR_OK;
}

/* A contact run [s, e) of foot k pinned to the reference's trajectories, shifted horizontally
   by the run's mean offset of the foot's contact points from the reference's. */
static void pin_run_to_reference(const cleanup *cu, cleanup_foot *ft, size_t k, size_t s, size_t e)
{
    const size_t C = cu->C, nf = cu->nf;
    const int up = cu->up;
    const uint8_t *contacts = cu->contacts;
    const double *P = cu->P, *Pr = cu->Pr, *pos_ref = cu->pos_ref;
    const int has_toe = ft->n_cols > ft->n_own;
    const size_t toe = has_toe ? ft->cols[ft->n_own] : 0;
    double o[3] = {0, 0, 0};
    size_t cnt = 0;
    for (size_t f = s; f < e; f++)
        for (size_t i = 0; i < ft->n_cols; i++) {
            const size_t c = ft->cols[i];
            if (!contacts[f * C + c])
                continue;
            for (int d = 0; d < 3; d++)
                o[d] += P[3 * (f * C + c) + (size_t)d] - Pr[3 * (f * C + c) + (size_t)d];
            cnt++;
        }
    for (int d = 0; d < 3; d++)
        o[d] = d == up ? 0.0 : o[d] / (double)cnt;
    for (size_t f = s; f < e; f++)
        for (int d = 0; d < 3; d++) {
            ft->at[3 * f + (size_t)d] = pos_ref[3 * (f * nf + k) + (size_t)d] + o[d];
            if (has_toe)
                ft->tt[3 * f + (size_t)d] = Pr[3 * (f * C + toe) + (size_t)d] + o[d];
        }
}

/* A contact run [s, e) without a reference: each point pinned to its mean over each of its
   contact runs within [s, e), raised above the floor. */
static void pin_run_to_means(const cleanup *cu, cleanup_foot *ft, size_t s, size_t e)
{
    const size_t C = cu->C;
    const int up = cu->up;
    const uint8_t *contacts = cu->contacts;
    const double *P = cu->P;
    const double floor_h = cu->floor_h;
    const int has_toe = ft->n_cols > ft->n_own;
    for (size_t f = s; f < e; f++) {
        double md[3] = {0, 0, 0}, own_d[3] = {0, 0, 0}, toe_d[3] = {0, 0, 0};
        size_t cnt = 0;
        int own_in = 0, toe_in = 0;
        for (size_t i = 0; i < ft->n_cols; i++) {
            const size_t c = ft->cols[i];
            if (!contacts[f * C + c])
                continue;
            size_t r0 = f, r1 = f; /* the point's contact run around f */
            while (r0 > s && contacts[(r0 - 1) * C + c])
                r0--;
            while (r1 < e && contacts[r1 * C + c])
                r1++;
            double d[3];
            for (int q = 0; q < 3; q++) {
                double mean = 0.0;
                for (size_t g = r0; g < r1; g++)
                    mean += P[3 * (g * C + c) + (size_t)q];
                d[q] = mean / (double)(r1 - r0) - P[3 * (f * C + c) + (size_t)q];
                md[q] += d[q];
            }
            cnt++;
            if (i == 0 && ft->n_own)
                own_in = 1, memcpy(own_d, d, sizeof d);
            if (has_toe && i == ft->n_own)
                toe_in = 1, memcpy(toe_d, d, sizeof d);
        }
        for (int q = 0; q < 3; q++) {
            md[q] /= (double)(cnt ? cnt : 1);
            ft->at[3 * f + (size_t)q] += own_in ? own_d[q] : md[q];
            if (has_toe)
                ft->tt[3 * f + (size_t)q] += toe_in ? toe_d[q] : md[q];
        }
        if (cu->floor_active) { /* the pinned points stay above the floor */
            double lift = 0.0;
            if (ft->n_own)
                lift = fmax(lift, floor_h - ft->at[3 * f + (size_t)up]);
            if (has_toe)
                lift = fmax(lift, floor_h - ft->tt[3 * f + (size_t)up]);
            ft->at[3 * f + (size_t)up] += lift;
            if (has_toe)
                ft->tt[3 * f + (size_t)up] += lift;
        }
    }
}

/* Foot k's contact frames, leg chain and targets (the anchor's and the placed point's
   trajectories, pinned on each contact run unless the run is kept). */
static mlr_status set_foot_targets(cleanup *cu, size_t k, mlr_diag *diag)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    const int up = cu->up;
    const cleanup_config *cfg = cu->cfg;
    const uint8_t *contacts = cu->contacts;
    const double *pos = cu->pos, *P = cu->P;
    cleanup_foot *ft = &cu->feet[k];
    mlr_status st;
    size_t nu = 0;
    for (size_t f = 0; f < N; f++) {
        for (size_t i = 0; i < ft->n_cols; i++)
            ft->U[f] |= contacts[f * C + ft->cols[i]] != 0;
        nu += ft->U[f];
    }
    ft->active = nu > 0 || cu->floor_active;
    if (!ft->active)
        return MLR_OK;
    if ((st = mlr_ik_leg_chain(cu->rig, ft->anchor, &ft->hip, &ft->knee, diag)) != MLR_OK)
        return st;
    const size_t a = (size_t)ft->anchor;
    const int has_toe = ft->n_cols > ft->n_own;
    const size_t toe = has_toe ? ft->cols[ft->n_own] : 0;
    for (size_t f = 0; f < N; f++) {
        memcpy(ft->at + 3 * f, pos + 3 * (f * J + a), 3 * sizeof(double));
        if (has_toe)
            memcpy(ft->tt + 3 * f, P + 3 * (f * C + toe), 3 * sizeof(double));
    }
    for (size_t s = 0; s < N;) { /* runs of U */
        if (!ft->U[s]) {
            s++;
            continue;
        }
        size_t e = s;
        while (e < N && ft->U[e])
            e++;
        if (cu->have_ref && cfg->keep_stiller > 0.0 &&
            run_sliding(P, contacts, C, ft, s, e, up) <=
                cfg->keep_stiller * run_sliding(cu->Pr, contacts, C, ft, s, e, up)) {
            /* the foot's own trajectory slides no more than the reference's: kept (its
               frames stay held, with no correction, so IK is not needed there) */
            memset(ft->K + s, 1, e - s);
            s = e;
            continue;
        }
        if (cu->have_ref)
            pin_run_to_reference(cu, ft, k, s, e);
        else
            pin_run_to_means(cu, ft, s, e);
        s = e;
    }
    for (size_t f = 0; f < N; f++)
        cu->anyU[f] |= ft->U[f];
    return MLR_OK;
}

/* The root shift each frame needs (with the shift so far): where a leg cannot reach its
   contact target, or would fold its knee past MAX_FOLD to reach it or the floor. 1 when some
   frame needs one. */
static int root_needs(const cleanup *cu, double cos_fold, double *need)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    const int up = cu->up;
    const cleanup_config *cfg = cu->cfg;
    const double *pos = cu->pos, *P = cu->P, *lim = cu->lim, *shift = cu->shift;
    memset(need, 0, N * 3 * sizeof(double));
    int any = 0;
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        const size_t h = (size_t)ft->hip, kn = (size_t)ft->knee, e = (size_t)ft->anchor;
        for (size_t f = 0; f < N; f++) {
            const double *ph = pos + 3 * (f * J + h), *pk = pos + 3 * (f * J + kn),
                         *pe = pos + 3 * (f * J + e);
            double target[3];
            if (ft->U[f]) {
                memcpy(target, ft->at + 3 * f, sizeof target);
            } else if (cu->floor_active && cfg->max_fold < 3.14159265358979323846) {
                /* a floor frame: the ankle raised by the largest shortfall */
                double lift = 0.0;
                for (size_t i = 0; i < ft->n_cols; i++) {
                    const size_t c = ft->cols[i];
                    lift = fmax(lift, lim[f * C + c] - P[3 * (f * C + c) + (size_t)up]);
                }
                if (!(lift > 0.0))
                    continue;
                memcpy(target, pe, sizeof target);
                target[up] += lift;
            } else {
                continue;
            }
            const double l1 = dist3(pk, ph), l2 = dist3(pe, pk);
            const double length = l1 + l2;
            const double now = dist3(pe, ph);
            const double reach = fmax(cfg->reach * length, now);
            /* the hip-ankle distance of a knee folded to max_fold: a target nearer
               than that would fold the knee past its limit */
            const double fold =
                fmin(sqrt(fmax(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * cos_fold, 0.0)), now);
            double v[3];
            for (int d = 0; d < 3; d++)
                v[d] = target[d] - (ph[d] + shift[3 * f + (size_t)d]);
            const double dist = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            /* > 0: the hip moves toward a target out of reach; < 0: away from one
               too near */
            double excess = 0.0;
            if (dist - reach > 0.0)
                excess = dist - reach;
            else if (fold - dist > 0.0)
                excess = dist - fold;
            if (excess == 0.0)
                continue;
            const double cur = sqrt(need[3 * f] * need[3 * f] + need[3 * f + 1] * need[3 * f + 1] +
                                    need[3 * f + 2] * need[3 * f + 2]);
            if (fabs(excess) > cur) {
                for (int d = 0; d < 3; d++)
                    need[3 * f + (size_t)d] = v[d] * excess / fmax(dist, 1e-12);
                any = 1;
            }
        }
    }
    return any;
}

/* Each need widened to +-half frames (the largest need there; nmask where it is nonzero). */
static void widen_needs(size_t N, size_t half, const double *need, double *n2s, size_t *dq,
                        double *wide, uint8_t *nmask)
{
    /* (a sliding-window maximum: a queue of frames whose squared needs decrease, ties
       kept in frame order, so the front is the first largest, as a scan would find) */
    for (size_t g = 0; g < N; g++)
        n2s[g] = need[3 * g] * need[3 * g] + need[3 * g + 1] * need[3 * g + 1] +
                 need[3 * g + 2] * need[3 * g + 2];
    size_t qh = 0, qt = 0, next = 0;
    for (size_t f = 0; f < N; f++) {
        const size_t lo = f > half ? f - half : 0, hi = f + half < N ? f + half : N - 1;
        for (; next <= hi; next++) {
            while (qt > qh && n2s[dq[qt - 1]] < n2s[next])
                qt--;
            dq[qt++] = next;
        }
        while (dq[qh] < lo)
            qh++;
        const size_t best = dq[qh];
        memcpy(wide + 3 * f, need + 3 * best, 3 * sizeof(double));
        nmask[f] = n2s[best] > 0.0;
    }
}

/* The widened needs averaged over the same +-half frames with the raised-cosine window wtab:
   a smooth shift (no steps where the widest need changes) that still covers each need at its
   own frame, since the window sees only values at least as large; zero farther than 2 half
   frames from every need. */
static void smooth_needs(size_t N, size_t half, const double *wtab, const double *wide,
                         const uint8_t *nmask, double *ysh)
{
    size_t in_window = 0, next_in = 0, next_out = 0; /* needs within the window */
    for (size_t f = 0; f < N; f++) {
        const size_t lo = f > half ? f - half : 0, hi = f + half < N ? f + half : N - 1;
        for (; next_in <= hi; next_in++)
            in_window += nmask[next_in];
        for (; next_out < lo; next_out++)
            in_window -= nmask[next_out];
        if (!in_window) { /* what the sum gives: 0 / wsum */
            ysh[3 * f] = ysh[3 * f + 1] = ysh[3 * f + 2] = 0.0;
            continue;
        }
        double acc[3] = {0, 0, 0}, wsum = 0.0;
        for (size_t g = lo; g <= hi; g++) {
            const double wt = wtab[g + half - f];
            wsum += wt;
            if (nmask[g])
                for (int d = 0; d < 3; d++)
                    acc[d] += wt * wide[3 * g + (size_t)d];
        }
        for (int d = 0; d < 3; d++)
            ysh[3 * f + (size_t)d] = acc[d] / wsum;
    }
}

/* The root shift (up to 5 rounds of needs, widened and smoothed), added to out_root_pos;
   MLR_E_NO_MEMORY in ar->st. */
static mlr_status shift_root(cleanup *cu, cleanup_arena *ar, mlr_cleanup_report *report)
{
    const size_t N = cu->N;
    const double fps = cu->fps;
    double *shift = cu->shift, *out_root_pos = cu->out_root_pos;
    double *need = cleanup__take(ar, N * 3, sizeof(double));
    double *wide = cleanup__take(ar, N * 3, sizeof(double));
    uint8_t *nmask = cleanup__take(ar, N, 1);
    double *ysh = cleanup__take(ar, N * 3, sizeof(double));
    if (ar->st != MLR_OK)
        return ar->st;
    const size_t half = (size_t)fmax(1.0, round(0.1 * fps));
    /* the raised-cosine window's weights, by offset g - f + half */
    double *wtab = cleanup__take(ar, 2 * half + 1, sizeof(double));
    double *n2s = cleanup__take(ar, N, sizeof(double));
    size_t *dq = cleanup__take(ar, N, sizeof(size_t));
    if (ar->st != MLR_OK)
        return ar->st;
    for (size_t i = 0; i <= 2 * half; i++) {
        const double x = ((double)i - (double)half) / (double)(half + 1);
        wtab[i] = 0.5 * (1.0 + cos(3.14159265358979323846 * x));
    }
    const double cos_fold = cos(cu->cfg->max_fold);
    for (int it = 0; it < 5; it++) {
        if (!root_needs(cu, cos_fold, need))
            break;
        /* widen each need to +-0.1 s (the largest need there), then blend and smooth */
        widen_needs(N, half, need, n2s, dq, wide, nmask);
        smooth_needs(N, half, wtab, wide, nmask, ysh);
        for (size_t i = 0; i < 3 * N; i++)
            shift[i] += ysh[i];
    }
    for (size_t f = 0; f < N; f++) {
        for (int d = 0; d < 3; d++)
            out_root_pos[3 * f + (size_t)d] += shift[3 * f + (size_t)d];
        if (report) {
            const double n =
                sqrt(shift[3 * f] * shift[3 * f] + shift[3 * f + 1] * shift[3 * f + 1] +
                     shift[3 * f + 2] * shift[3 * f + 2]);
            report->root_shift_max = fmax(report->root_shift_max, n);
        }
    }
    return MLR_OK;
}

/* The toes' chains (the hip down to the placed point's joint), top-down; cu->chained is 1 when
   every active foot has one and no other foot's leg joint lies on it or above it: the turn of
   the ankle then needs the forward kinematics of the chain only, and newr is read at the
   legs' joints only. */
static void find_chains(cleanup *cu)
{
    const size_t J = cu->J, nf = cu->nf;
    const mlr_rig *rig = cu->rig;
    const cleanup_foot *feet = cu->feet;
    int32_t *chains = cu->chains;
    int chained = 1;
    for (size_t k = 0; k < nf; k++) {
        const cleanup_foot *ft = &feet[k];
        if (!ft->active)
            continue;
        /* the chain bottom-up: the placed point's joint (or the anchor) to the hip */
        const int32_t bottom =
            ft->n_cols > ft->n_own ? cu->joints[ft->cols[ft->n_own]] : ft->anchor;
        size_t n = 0;
        int32_t j = bottom;
        for (; j >= 0 && n < J; j = rig->parents[j]) {
            chains[k * J + n++] = j;
            if (j == ft->hip)
                break;
        }
        if (j != ft->hip) {
            chained = 0;
            break;
        }
        for (size_t i = 0; i < n / 2; i++) { /* top-down */
            const int32_t t = chains[k * J + i];
            chains[k * J + i] = chains[k * J + n - 1 - i], chains[k * J + n - 1 - i] = t;
        }
        cu->chain_len[k] = n;
        /* ... and above the hip, up to the root: no other foot's hip, knee or anchor */
        for (size_t q = 0; chained && q < nf; q++) {
            if (q == k || !feet[q].active)
                continue;
            for (int32_t u = bottom; u >= 0; u = rig->parents[u])
                if (u == feet[q].hip || u == feet[q].knee || u == feet[q].anchor)
                    chained = 0;
        }
    }
    cu->chained = chained;
}

/* Floor frames of a pass: a point below its limit, the foot not in contact (each foot's lift
   and F, anyF). */
static void find_floor_frames(cleanup *cu)
{
    const size_t N = cu->N, C = cu->C;
    const int up = cu->up;
    const double *lim = cu->lim, *P2 = cu->P;
    memset(cu->anyF, 0, N);
    for (size_t k = 0; k < cu->nf; k++) {
        cleanup_foot *ft = &cu->feet[k];
        if (!ft->active || !cu->floor_active)
            continue;
        for (size_t f = 0; f < N; f++) {
            double lift = 0.0;
            for (size_t i = 0; i < ft->n_cols; i++) {
                const size_t c = ft->cols[i];
                lift = fmax(lift, lim[f * C + c] - P2[3 * (f * C + c) + (size_t)up]);
            }
            ft->lift[f] = lift;
            if (!ft->U[f] && lift > 0.0)
                ft->F[f] = 1;
            cu->anyF[f] |= ft->F[f] && lift > 0.0;
        }
    }
}

/* newr = out_rot where the pass reads it: everywhere, or the chains' joints (the legs' hips,
   knees, anchors) frame by frame (each frame's rotations are read once). */
static void copy_leg_rotations(const cleanup *cu)
{
    const size_t N = cu->N, J = cu->J;
    double *newr = cu->newr;
    const double *out_rot = cu->out_rot;
    if (!cu->chained) {
        memcpy(newr, out_rot, N * J * 4 * sizeof(double));
    } else {
        for (size_t f = 0; f < N; f++)
            for (size_t k = 0; k < cu->nf; k++)
                for (size_t i = 0; cu->feet[k].active && i < cu->chain_len[k]; i++) {
                    const size_t j = (size_t)cu->chains[k * J + i];
                    memcpy(newr + 4 * (f * J + j), out_rot + 4 * (f * J + j), 4 * sizeof(double));
                }
    }
}

/* Within REACHED times the leg's length of its targets, a leg is left as it is: IK would move
   it by rounding (the pass before put it there, to ~1e-10 of the leg's length). */
#define REACHED 1e-8

/* Do a - o and b - o point the same way, to within REACHED radians? (place_toes turns the
   anchor so that its placed point points at the target from it.) */
static int aligned(const double *a, const double *b, const double *o)
{
    const double u[3] = {a[0] - o[0], a[1] - o[1], a[2] - o[2]};
    const double v[3] = {b[0] - o[0], b[1] - o[1], b[2] - o[2]};
    const double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    const double uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    const double c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    const double n2 =
        (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return uv > 0.0 && c2 <= REACHED * REACHED * n2;
}

/* Two-bone IK of each leg on its constrained frames (contact targets, or the ankle raised
   above the floor), into newr; where the anchor (and on contact frames the placed point) is
   already within REACHED of its target, the leg is left as it is (ft->S). */
static void solve_legs(const cleanup *cu)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    const int up = cu->up;
    const double *pos = cu->pos, *wrot = cu->wrot, *P = cu->P;
    double *newr = cu->newr;
    for (size_t k = 0; k < cu->nf; k++) {
        cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        memset(ft->S, 0, N);
        const int has_toe = ft->n_cols > ft->n_own;
        const size_t toe = has_toe ? ft->cols[ft->n_own] : 0;
        const size_t h = (size_t)ft->hip, kn = (size_t)ft->knee, a = (size_t)ft->anchor;
        const int32_t pk = cu->rig->parents[kn], ph = cu->rig->parents[h];
        double local[3] = {0, 0, 0};
        mlr_ik_bend_axis_local(N, J, pos, wrot, ft->hip, ft->knee, ft->anchor, local, NULL);
        const int have_local = local[0] != 0.0 || local[1] != 0.0 || local[2] != 0.0;
        for (size_t f = 0; f < N; f++) {
            if ((!ft->U[f] && !ft->F[f]) || ft->K[f])
                continue;
            const double *Pf = pos + 3 * f * J, *G = wrot + 4 * f * J;
            double target[3], ax[3], rh[4], rk[4];
            if (ft->U[f]) {
                memcpy(target, ft->at + 3 * f, sizeof target);
            } else {
                memcpy(target, Pf + 3 * a, sizeof target);
                target[up] += fmax(ft->lift[f], 0.0);
            }
            const double eps =
                REACHED * (dist3(Pf + 3 * h, Pf + 3 * kn) + dist3(Pf + 3 * kn, Pf + 3 * a));
            if (dist3(Pf + 3 * a, target) <= eps &&
                (!ft->U[f] || !has_toe ||
                 aligned(P + 3 * (f * C + toe), ft->tt + 3 * f, Pf + 3 * a))) {
                ft->S[f] = 1; /* newr holds the leg's rotations as they are */
                continue;
            }
            if (have_local)
                mlr_ik_qrot(G + 4 * h, local, ax);
            mlr_ik_two_bone_1(Pf + 3 * h, Pf + 3 * kn, Pf + 3 * a, target, have_local ? ax : NULL,
                              MLR_IK_MAX_EXTENSION, rh, rk);
            mlr_ik_rotate_to_1(newr + 4 * (f * J + kn), pk >= 0 ? G + 4 * (size_t)pk : NULL,
                               G + 4 * kn, rk);
            mlr_ik_rotate_to_1(newr + 4 * (f * J + h), ph >= 0 ? G + 4 * (size_t)ph : NULL,
                               G + 4 * h, rh);
        }
    }
}

/* Placed points (toes) by turning the ankle, into newr; on floor frames the ankle keeps its
   world rotation, so the whole foot rises with it (only on the frames where some foot with a
   placed point is constrained). */
static void place_toes(const cleanup *cu)
{
    const size_t N = cu->N, J = cu->J, nf = cu->nf;
    const mlr_rig *rig = cu->rig;
    const cleanup_foot *feet = cu->feet;
    const int32_t *joints = cu->joints, *end_sites = cu->end_sites;
    const double *tr = cu->trans, *wrot = cu->wrot;
    double *newr = cu->newr, *pos2 = cu->pos2, *wrot2 = cu->wrot2;
    uint8_t *fk_frames = cu->fk_frames;
    memset(fk_frames, 0, N);
    for (size_t k = 0; k < nf; k++)
        if (feet[k].active && feet[k].n_cols > feet[k].n_own)
            for (size_t f = 0; f < N; f++)
                fk_frames[f] |= (feet[k].U[f] | feet[k].F[f]) & !feet[k].K[f] & !feet[k].S[f];
    for (size_t f = 0; f < N; f++) {
        if (!fk_frames[f])
            continue;
        if (!cu->chained)
            cleanup__fk_masked_frame(rig, f, cu->need, cu->tidx, cu->out_root_pos, newr, tr, pos2,
                                     wrot2);
        for (size_t k = 0; k < nf; k++) {
            const cleanup_foot *ft = &feet[k];
            if (!ft->active || ft->n_cols == ft->n_own || (!ft->U[f] && !ft->F[f]) || ft->K[f] ||
                ft->S[f])
                continue;
            if (cu->chained) /* the same values as the whole frame's at the chain's joints */
                cleanup__fk_chain_frame(rig, f, cu->chains + k * J, cu->chain_len[k], cu->tidx,
                                        newr, tr, cu->pos + 3 * J * f, cu->wrot + 4 * J * f, pos2,
                                        wrot2);
            const size_t a = (size_t)ft->anchor;
            const int32_t pa = rig->parents[a];
            const size_t c = ft->cols[ft->n_own];
            const int32_t e = end_sites ? end_sites[c] : -1;
            const size_t j = (size_t)joints[c];
            const double *ga = wrot2 + 4 * a;
            const double *gp = pa >= 0 ? wrot2 + 4 * (size_t)pa : NULL;
            double r[4];
            if (ft->U[f]) {
                double now[3], u[3], v[3];
                if (e >= 0)
                    mlr_ik_qrot(wrot2 + 4 * j, rig->end_site_offsets + 3 * (size_t)e, now);
                else
                    now[0] = now[1] = now[2] = 0.0;
                for (int d = 0; d < 3; d++) {
                    now[d] += pos2[3 * j + (size_t)d];
                    u[d] = now[d] - pos2[3 * a + (size_t)d];
                    v[d] = ft->tt[3 * f + (size_t)d] - pos2[3 * a + (size_t)d];
                }
                mlr_ik_from_to_1(u, v, r);
            } else { /* r * ga = the old world rotation */
                const double *gold = wrot + 4 * (f * J + a);
                const double cg[4] = {ga[0], -ga[1], -ga[2], -ga[3]};
                mlr_ik_qmul(gold, cg, r);
            }
            mlr_ik_rotate_to_1(newr + 4 * (f * J + a), gp, ga, r);
        }
    }
}

/* One pass: forward kinematics again on the frames that changed since the last (the root
   shift before the first pass, the spread of the pass before), the floor frames, IK on the
   constrained frames, then the spread per leg. */
static mlr_status cleanup_pass(cleanup *cu)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    uint8_t *dirty = cu->w->dirty, *mask = cu->mask;
    mlr_status st;
    for (size_t f = 0; f < N; f++) {
        if (!dirty[f])
            continue;
        cleanup__fk_masked_frame(cu->rig, f, cu->need, cu->tidx, cu->out_root_pos, cu->out_rot,
                                 cu->trans, cu->pos + 3 * J * f, cu->wrot + 4 * J * f);
        if ((st = mlr_rig_point_positions(cu->rig, 1, cu->pos + 3 * J * f, cu->wrot + 4 * J * f, C,
                                          cu->joints, cu->end_sites, cu->P + 3 * C * f, NULL)) !=
            MLR_OK)
            return st;
    }
    memset(dirty, 0, N);
    find_floor_frames(cu);
    copy_leg_rotations(cu);
    solve_legs(cu);
    place_toes(cu);
    /* spread per leg */
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        size_t cnt = 0;
        for (size_t f = 0; f < N; f++)
            cnt += (mask[f] = ft->U[f] | ft->F[f]) != 0;
        if (!cnt)
            continue;
        int32_t js[3] = {ft->hip, ft->knee, ft->anchor};
        if ((st = cleanup__spread_rotations(cu->w, cu->out_rot, cu->newr, js,
                                            ft->n_cols > ft->n_own ? 3 : 2, mask)) != MLR_OK)
            return st;
    }
    return MLR_OK;
}

/* The run's failures: the arena's (out of memory), or a status of a step (out of memory, or a
   solve that failed). */
static mlr_status fail_memory(const cleanup_arena *ar, mlr_diag *diag)
{
    return mlr_diag_set(diag, ar->st, 0, 0, "cleanup: out of memory");
}

static mlr_status fail_status(mlr_status st, mlr_diag *diag)
{
    if (st == MLR_E_NO_MEMORY)
        mlr_diag_set(diag, st, 0, 0, "cleanup: out of memory");
    else
        mlr_diag_set(diag, st, 0, 0, "cleanup: internal solve failed (status %d)", (int)st);
    return st;
}

/* The outputs start as the inputs, the report empty; 0 when there is nothing to clean (fewer
   than 3 frames, no points, or no contact and no floor height given). */
static int cleanup_start(const mlr_rig *rig, size_t N, const double *root_pos, const double *rot,
                         size_t C, const uint8_t *contacts, const cleanup_config *cfg,
                         double *out_root_pos, double *out_rot, mlr_cleanup_report *report)
{
    const size_t J = rig->n_joints;
    if (report) {
        report->floor_height = NAN;
        report->contact_frames = report->floor_frames = 0;
        report->root_shift_max = 0.0;
    }
    if (out_root_pos != root_pos)
        memmove(out_root_pos, root_pos, 3 * N * sizeof(double));
    if (out_rot != rot)
        memmove(out_rot, rot, 4 * N * J * sizeof(double));
    size_t any_contact = 0;
    for (size_t i = 0; i < N * C; i++)
        any_contact += contacts[i] != 0;
    return !(N < 3 || C == 0 || (!any_contact && !(cfg->floor_on && cfg->floor_given)));
}

/* The feet of the contact points (cu->feet, cu->nf). */
static mlr_status cleanup_feet(cleanup *cu, cleanup_arena *ar, mlr_diag *diag)
{
    uint8_t *listed = cleanup__take(ar, cu->J, 1);
    uint8_t *assigned = cleanup__take(ar, cu->C, 1);
    if (ar->st != MLR_OK)
        return fail_memory(ar, diag);
    return cleanup__assign_feet(cu->rig, cu->C, cu->joints, cu->end_sites, cu->feet, &cu->nf,
                                listed, assigned, diag);
}

/* The run's arrays, and the forward kinematics and points of the motion (root_pos, rot). */
static mlr_status cleanup_fk(cleanup *cu, const double *root_pos, const double *rot,
                             cleanup_arena *ar, const mlr_allocator *A, mlr_diag *diag)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    cleanup_work *w = cu->w;
    /* (not zeroed: the forward kinematics write every joint that is read, the other arrays
       are written whole, or on the frames that are read, before they are read) */
    cu->pos = cleanup__take_raw(ar, N * J * 3, sizeof(double));
    cu->wrot = cleanup__take_raw(ar, N * J * 4, sizeof(double));
    cu->P = cleanup__take_raw(ar, N * C * 3, sizeof(double));
    cu->lim = cleanup__take(ar, N * C, sizeof(double));
    cu->newr = cleanup__take_raw(ar, N * J * 4, sizeof(double));
    cu->shift = cleanup__take(ar, N * 3, sizeof(double));
    w->map_val = cleanup__take_raw(ar, N * 9, sizeof(double));
    w->map_y = cleanup__take_raw(ar, N * 9, sizeof(double));
    w->map_out = cleanup__take_raw(ar, N * 9, sizeof(double));
    /* forward kinematics of the joints the cleanup reads only: the contact points, the
       feet's anchors and their ancestors (hips, knees and the joints above them) */
    cu->need = cleanup__take(ar, J, 1);
    cu->tidx = cleanup__take(ar, J, sizeof(int32_t));
    cu->fk_frames = cleanup__take(ar, N, 1);
    cu->pos2 = cleanup__take(ar, J * 3, sizeof(double));
    cu->wrot2 = cleanup__take(ar, J * 4, sizeof(double));
    if (ar->st != MLR_OK)
        return fail_memory(ar, diag);
    cleanup__fk_need(cu->rig, C, cu->joints, cu->feet, cu->nf, cu->need, cu->tidx);
    mlr_status st =
        cleanup__fk_points(cu->rig, N, root_pos, rot, cu->trans, C, cu->joints, cu->end_sites,
                           cu->pos, cu->wrot, cu->P, A, cu->need, cu->tidx);
    return st == MLR_OK ? MLR_OK : fail_status(st, diag);
}

/* The floor (set_floor, into the report) and the spread's band solver. */
static mlr_status cleanup_floor(cleanup *cu, const mlr_cleanup_ref *pre, cleanup_arena *ar,
                                const mlr_allocator *A, mlr_cleanup_report *report, mlr_diag *diag)
{
    if (set_floor(cu, pre, ar) != MLR_OK)
        return fail_memory(ar, diag);
    if (report)
        report->floor_height = cu->floor_active ? cu->floor_h : NAN;
    cleanup_work *w = cu->w;
    w->ab = cleanup__take(ar, cu->N * 3, sizeof(double));
    if (ar->st != MLR_OK)
        return fail_memory(ar, diag);
    mlr_status st = mlr_band_create(cu->N, 2, A, &w->pin, NULL);
    if (st == MLR_E_NO_MEMORY) {
        ar->st = st;
        return fail_memory(ar, diag);
    }
    return st == MLR_OK ? MLR_OK : fail_status(st, diag);
}

/* Each foot's contact frames, leg and targets (set_foot_targets). */
static mlr_status cleanup_targets(cleanup *cu, cleanup_arena *ar, mlr_diag *diag)
{
    const size_t N = cu->N, nf = cu->nf;
    cu->anyU = cleanup__take(ar, N, 1);
    cu->anyF = cleanup__take(ar, N, 1);
    if (ar->st != MLR_OK)
        return fail_memory(ar, diag);
    /* the feet's arrays, one block each for all feet (the arena holds CLEANUP_MAX_BLOCKS
       blocks) */
    uint8_t *all_uf = cleanup__take(ar, N * nf, 4);
    double *all_at = cleanup__take(ar, N * nf, 7 * sizeof(double));
    if (ar->st != MLR_OK)
        return fail_memory(ar, diag);
    for (size_t k = 0; k < nf; k++) {
        cleanup_foot *ft = &cu->feet[k];
        ft->U = all_uf + 4 * N * k, ft->F = ft->U + N, ft->K = ft->F + N, ft->S = ft->K + N;
        ft->at = all_at + 7 * N * k, ft->tt = ft->at + 3 * N, ft->lift = ft->tt + 3 * N;
        mlr_status st = set_foot_targets(cu, k, diag);
        if (st != MLR_OK)
            return st;
    }
    return MLR_OK;
}

/* 1 where the root shift moved frame f. */
static int shifted(const double *shift, size_t f)
{
    return shift[3 * f] != 0.0 || shift[3 * f + 1] != 0.0 || shift[3 * f + 2] != 0.0;
}

/* The passes: IK on the constrained frames, then the spread. */
static mlr_status cleanup_passes(cleanup *cu, cleanup_arena *ar, mlr_diag *diag)
{
    const size_t N = cu->N, J = cu->J, nf = cu->nf;
    const double *shift = cu->shift;
    /* a kept contact needs IK only where the root moved (the leg is held otherwise: the
       ankle is where its target is) */
    for (size_t k = 0; k < nf; k++)
        for (size_t f = 0; cu->feet[k].active && f < N; f++)
            if (shifted(shift, f))
                cu->feet[k].K[f] = 0;
    /* pos, wrot and the points P hold the forward kinematics of (root_pos, rot): a pass
       computes it again only on the frames that changed since (the root shift before the
       first pass, the spread of the pass before), the others are the same values */
    cu->mask = cleanup__take(ar, N, 1);
    uint8_t *dirty = cleanup__take(ar, N, 1);
    cu->chains = cleanup__take(ar, nf * J, sizeof(int32_t));
    cu->chain_len = cleanup__take(ar, nf, sizeof(size_t));
    if (ar->st != MLR_OK)
        return fail_memory(ar, diag);
    find_chains(cu);
    for (size_t f = 0; f < N; f++)
        dirty[f] = shifted(shift, f);
    cu->w->dirty = dirty;
    for (int pass = 0; pass < cu->cfg->passes; pass++) {
        mlr_status st = cleanup_pass(cu);
        if (st != MLR_OK)
            return fail_status(st, diag);
    }
    return MLR_OK;
}

static mlr_status cleanup_run(const mlr_rig *rig, size_t N, double fps, int up,
                              const double *root_pos, const double *rot, const double *trans,
                              const double *ref_root_pos, const double *ref_rot,
                              const double *ref_trans, const mlr_cleanup_ref *pre, int trusted,
                              size_t C, const int32_t *joints, const int32_t *end_sites,
                              const uint8_t *contacts, const mlr_cleanup_option *opts,
                              size_t n_opts, double *out_root_pos, double *out_rot,
                              mlr_cleanup_report *report, const mlr_allocator *alloc,
                              mlr_diag *diag)
{
    cleanup_config cfg;
    mlr_status st = cleanup_check(rig, N, fps, up, root_pos, rot, trans, ref_root_pos, ref_rot,
                                  ref_trans, pre, trusted, C, joints, end_sites, contacts, opts,
                                  n_opts, out_root_pos, out_rot, &cfg, diag);
    if (st != MLR_OK)
        return st;
    if (!cleanup_start(rig, N, root_pos, rot, C, contacts, &cfg, out_root_pos, out_rot, report))
        return MLR_OK;
    const int have_arrays = ref_root_pos || ref_rot || ref_trans, have_ref = have_arrays || pre;
    const size_t J = rig->n_joints;
    cleanup_foot feet[64];
    mlr_cleanup_ref *owned = NULL; /* the reference's trajectories when made here */
    cleanup_work w = {rig, N, J, C, fps, up, &cfg, NULL, NULL, NULL, NULL, NULL, NULL};
    cleanup c = {.rig = rig,
                 .N = N,
                 .J = J,
                 .C = C,
                 .fps = fps,
                 .up = up,
                 .cfg = &cfg,
                 .joints = joints,
                 .end_sites = end_sites,
                 .contacts = contacts,
                 .trans = trans,
                 .out_root_pos = out_root_pos,
                 .out_rot = out_rot,
                 .feet = feet,
                 .have_ref = have_ref,
                 .w = &w};
    mlr_allocator A;
    mlr_allocator_resolve(alloc, &A);
    cleanup_arena ar = {.a = &A, .st = MLR_OK};
    if ((st = cleanup_feet(&c, &ar, diag)) != MLR_OK ||
        (st = cleanup_fk(&c, root_pos, rot, &ar, &A, diag)) != MLR_OK)
        goto done;
    /* the reference's trajectories: given made, or made here from its frames */
    if (have_arrays && !pre) {
        if ((st = mlr_cleanup_ref_create(rig, N, fps, up, ref_root_pos, ref_rot, ref_trans, NULL,
                                         NULL, C, joints, end_sites, opts, n_opts, &A, &owned,
                                         diag)) != MLR_OK)
            goto done;
        pre = owned;
    }
    c.Pr = pre ? pre->pts : NULL, c.pos_ref = pre ? pre->anchors : NULL;
    if ((st = cleanup_floor(&c, pre, &ar, &A, report, diag)) != MLR_OK ||
        (st = cleanup_targets(&c, &ar, diag)) != MLR_OK)
        goto done;
    /* the root shift: legs that cannot reach their contact targets, or would have to fold
       their knee past MAX_FOLD to reach them or the floor */
    if (cfg.root_on && shift_root(&c, &ar, report) != MLR_OK) {
        st = fail_memory(&ar, diag);
        goto done;
    }
    if ((st = cleanup_passes(&c, &ar, diag)) != MLR_OK)
        goto done;
    if (report) {
        for (size_t f = 0; f < N; f++) {
            report->contact_frames += c.anyU[f];
            report->floor_frames += c.anyF[f];
        }
    }
done:
    mlr_band_destroy(w.pin);
    mlr_cleanup_ref_destroy(owned);
    cleanup__release(&ar);
    return st;
}

mlr_status mlr_cleanup_contacts(const mlr_rig *rig, size_t N, double fps, int up,
                                const double *root_pos, const double *rot, const double *trans,
                                const double *ref_root_pos, const double *ref_rot,
                                const double *ref_trans, size_t C, const int32_t *joints,
                                const int32_t *end_sites, const uint8_t *contacts,
                                const mlr_cleanup_option *opts, size_t n_opts,
                                double *out_root_pos, double *out_rot, mlr_cleanup_report *report,
                                const mlr_allocator *alloc, mlr_diag *diag)
{
    return cleanup_run(rig, N, fps, up, root_pos, rot, trans, ref_root_pos, ref_rot, ref_trans,
                       NULL, 0, C, joints, end_sites, contacts, opts, n_opts, out_root_pos,
                       out_rot, report, alloc, diag);
}

mlr_status mlr_cleanup_contacts_ref(const mlr_rig *rig, size_t N, double fps, int up,
                                    const double *root_pos, const double *rot, const double *trans,
                                    const mlr_cleanup_ref *ref, int trusted, size_t C,
                                    const int32_t *joints, const int32_t *end_sites,
                                    const uint8_t *contacts, const mlr_cleanup_option *opts,
                                    size_t n_opts, double *out_root_pos, double *out_rot,
                                    mlr_cleanup_report *report, const mlr_allocator *alloc,
                                    mlr_diag *diag)
{
    return cleanup_run(rig, N, fps, up, root_pos, rot, trans, NULL, NULL, NULL, ref, trusted, C,
                       joints, end_sites, contacts, opts, n_opts, out_root_pos, out_rot, report,
                       alloc, diag);
}
