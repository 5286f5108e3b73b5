/*
 * The contact cleanup's root shift: where a leg cannot reach its target, or would fold its
 * knee past MAX_FOLD, the root moves by the need, widened and smoothed.
 *
 * The vertical part of the first round's needs, up to ROOT_BOB_CAP leg lengths, is widened and
 * smoothed over +-MLR_CLEANUP_OPT_ROOT_BOB seconds (the guards' 0.5: a gait cycle) instead of +-0.1 s: at alpha 0.5 a walk's
 * pelvis, its bob halved, stands higher than the input's in double support, where the planted
 * legs cannot reach, and a shift that local put the bob back (Xia's walk: 1.89 alpha, where
 * the synthesis has 1.00); at alpha 3 it took the bob out at its peaks (CMU 02_03's run: 0.69
 * alpha). Over a gait cycle the body stands lower or higher as a whole and keeps its bob. A
 * lowering that long must not take the body through the floor (it put jumps' hands and
 * dogs' tails under it): the long part's lowering at a frame is at most the least height above
 * the floor of every joint and End Site off the feet, over twice that. The rest of a
 * need, and every later round's, takes the short way.
 */
#include "guards/cleanup_internal.h"

#include <math.h>

#include "mlayer/mlr_fk.h"

#define ROOT_BOB_CAP 0.1    /* leg lengths */

/* The root shift each frame needs (with the shift so far): where a leg cannot reach its
   contact target, or would fold its knee past MAX_FOLD to reach it or the floor. 1 when some
   frame needs one. moved: the last round's smoothed shift (NULL in the first round), with need
   the last round's needs: a frame that needed nothing and whose shift did not change needs
   nothing again (its inputs are the same), so only the others are computed (redo: N scratch). */
static int root_needs(const cleanup_state *cu, double cos_fold, double *need, const double *moved,
                      uint8_t *redo)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    const int up = cu->up;
    const cleanup_config *cfg = cu->cfg;
    const double *pos = cu->pos, *P = cu->P, *lim = cu->lim, *shift = cu->shift;
    for (size_t f = 0; f < N; f++) {
        const double *n = need + 3 * f;
        redo[f] = !moved || moved[3 * f] != 0.0 || moved[3 * f + 1] != 0.0 ||
                  moved[3 * f + 2] != 0.0 || n[0] != 0.0 || n[1] != 0.0 || n[2] != 0.0;
        if (redo[f])
            need[3 * f] = need[3 * f + 1] = need[3 * f + 2] = 0.0;
    }
    int any = 0;
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        const size_t h = (size_t)ft->hip, kn = (size_t)ft->knee, e = (size_t)ft->anchor;
        for (size_t f = 0; f < N; f++) {
            if (!redo[f])
                continue;
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
                    lift = common__fmax(lift, lim[f * C + c] - P[3 * (f * C + c) + (size_t)up]);
                }
                if (!(lift > 0.0))
                    continue;
                memcpy(target, pe, sizeof target);
                target[up] += lift;
            } else {
                continue;
            }
            const double l1 = cleanup__dist3(pk, ph), l2 = cleanup__dist3(pe, pk);
            const double length = l1 + l2;
            const double now = cleanup__dist3(pe, ph);
            const double reach = common__fmax(cfg->reach * length, now);
            /* the hip-ankle distance of a knee folded to max_fold: a target nearer
               than that would fold the knee past its limit */
            const double fold = common__fmin(
                sqrt(common__fmax(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * cos_fold, 0.0)), now);
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
                    need[3 * f + (size_t)d] = v[d] * excess / common__fmax(dist, 1e-12);
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

mlr_status cleanup__shift_root(cleanup_state *cu, cleanup_arena *ar, mlr_cleanup_report *report)
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
    const size_t half = (size_t)common__fmax(1.0, round(0.1 * fps));
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
    uint8_t *redo = cleanup__take(ar, N, 1);
    /* the vertical part of the needs, over a gait cycle */
    const size_t vhalf = (size_t)common__fmax((double)half, round(cu->cfg->root_bob * fps));
    double *vtab = cleanup__take(ar, 2 * vhalf + 1, sizeof(double));
    double *vneed = cleanup__take(ar, N * 3, sizeof(double));
    double *vsh = cleanup__take(ar, N * 3, sizeof(double));
    if (ar->st != MLR_OK)
        return ar->st;
    for (size_t i = 0; i <= 2 * vhalf; i++) {
        const double x = ((double)i - (double)vhalf) / (double)(vhalf + 1);
        vtab[i] = 0.5 * (1.0 + cos(3.14159265358979323846 * x));
    }
    const double cos_fold = cos(cu->cfg->max_fold);
    double leg = 0.0;
    for (size_t k = 0; k < cu->nf; k++)
        if (cu->feet[k].active)
            leg = common__fmax(leg, cu->feet[k].leg);
    const double vcap = cu->cfg->root_bob > 0.0 ? ROOT_BOB_CAP * leg : 0.0;
    /* how far the body may go down over a gait cycle: the least height above the floor of
       the joints and End Sites that are not on a foot (at or below an active foot's anchor),
       its minimum over +-2 vhalf frames (the shift at a frame averages needs from that far) */
    double *room = NULL;
    if (vcap > 0.0) {
        const size_t J = cu->J;
        room = cleanup__take(ar, N, sizeof(double));
        double *wp = cleanup__take(ar, N * J * 3, sizeof(double));
        double *wr = cleanup__take(ar, N * J * 4, sizeof(double));
        uint8_t *onfoot = cleanup__take(ar, J, 1);
        if (ar->st != MLR_OK)
            return ar->st;
        for (size_t k = 0; k < cu->nf; k++)
            if (cu->feet[k].active)
                onfoot[cu->feet[k].anchor] = 1;
        for (size_t j = 1; j < J; j++)
            if (onfoot[cu->rig->parents[j]])
                onfoot[j] = 1;
        const mlr_rig *rig = cu->rig;
        if (!cu->floor_active || mlr_fk_arrays(N, J, rig->parents, rig->offsets, out_root_pos,
                                               cu->out_rot, rig->n_trans, rig->trans_joints,
                                               cu->trans, wp, wr, ar->a, NULL) != MLR_OK) {
            for (size_t f = 0; f < N; f++)
                room[f] = cu->floor_active ? 0.0 : INFINITY;
        } else {
            for (size_t f = 0; f < N; f++) {
                double c = INFINITY;
                for (size_t j = 0; j < J; j++)
                    if (!onfoot[j])
                        c = common__fmin(c, wp[3 * (f * J + j) + (size_t)cu->up] - cu->floor_h);
                for (size_t e = 0; e < rig->n_end_sites; e++) { /* and their End Sites */
                    const size_t j = (size_t)rig->end_site_parents[e];
                    if (onfoot[j])
                        continue;
                    double v[3];
                    common__quat_rotate_inline((const mlr_quat *)(wr + 4 * (f * J + j)),
                                               rig->end_site_offsets + 3 * e, v);
                    c = common__fmin(c, wp[3 * (f * J + j) + (size_t)cu->up] + v[cu->up] -
                                            cu->floor_h);
                }
                wp[f] = common__fmax(c, 0.0); /* (wp's first N doubles: no longer read) */
            }
            const size_t w2 = 2 * vhalf;
            for (size_t f = 0; f < N; f++) {
                const size_t lo = f > w2 ? f - w2 : 0, hi = f + w2 < N ? f + w2 : N - 1;
                double c = INFINITY;
                for (size_t g = lo; g <= hi; g++)
                    c = common__fmin(c, wp[g]);
                room[f] = c;
            }
        }
    }
    for (int it = 0; it < 5; it++) {
        if (!root_needs(cu, cos_fold, need, it ? ysh : NULL, redo))
            break;
        /* the first round's vertical part over a gait cycle (ROOT_BOB), up to vcap and
           room; what is left, and every later round, the short way */
        const int up = cu->up, bob = it == 0 && vcap > 0.0;
        for (size_t f = 0; f < N && bob; f++) {
            for (int d = 0; d < 3; d++)
                vneed[3 * f + (size_t)d] = 0.0;
            const double v = need[3 * f + (size_t)up];
            const double small = common__fmax(-common__fmin(vcap, room[f]), common__fmin(vcap, v));
            vneed[3 * f + (size_t)up] = small;
            need[3 * f + (size_t)up] = v - small;
        }
        /* widen each need to +-0.1 s (the largest need there), then blend and smooth */
        widen_needs(N, half, need, n2s, dq, wide, nmask);
        smooth_needs(N, half, wtab, wide, nmask, ysh);
        if (bob) {
            widen_needs(N, vhalf, vneed, n2s, dq, wide, nmask);
            smooth_needs(N, vhalf, vtab, wide, nmask, vsh);
            for (size_t f = 0; f < N; f++) {
                ysh[3 * f + (size_t)up] += vsh[3 * f + (size_t)up];
                need[3 * f + (size_t)up] += vneed[3 * f + (size_t)up];
            }
        }
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
            report->root_shift_max = common__fmax(report->root_shift_max, n);
        }
    }
    return MLR_OK;
}
