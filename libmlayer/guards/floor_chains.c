/* The whole body above the floor: the path to a point that the synthesis takes through it (a
 * dog's tail, a boxer's hands, a crouching walker's hips) has its exaggeration reduced there.
 *
 * The contact cleanup keeps the feet above the floor; the rest of the body went through it at
 * alpha 2-3 (a dog's tail 44% of body height below at alpha 3, a boxer's wrists 63%). For every
 * joint and End Site that is not on a foot (a contact point's joint or below it: the
 * cleanup's), the depth below the floor beyond the input's own depth there is measured; where
 * it exceeds the slack, the path from the root to the point (the root's translation and the
 * rotations on it) is blended toward the input's, by the least weight of 1/FLOOR_STEPS, ..., 1
 * that lifts the point to within the slack (all the way when none does: at 1 the path is the
 * input's, and so is the point). Each point's weights are smoothed in time as the limits'
 * corrections are (limits__ease_lookahead: a running maximum, then a Gaussian), so the path returns to
 * the input's pose and back over 0.2 s, and each joint takes the largest weight of the paths it
 * is on. The guards run this before the cleanup, which then pins the feet of the result.
 *
 * Blending only the chain below the pelvis (its rotations, not the root's) was tried first: the
 * dog's tail went deeper (22% to 46% of body height at alpha 2), the pelvis's own exaggerated
 * orientation taking it down whatever the tail's joints did.
 */
#include "guards/floor_chains_internal.h"

#include "motion/fk_internal.h"
#include "guards/limits_internal.h"
#include "common/mlr_internal.h"
#include "math/quat_internal.h"

#include <math.h>
#include <string.h>

#define FLOOR_STEPS 8          /* the weights tried: 0, 1/8, ..., 1 */
#define FLOOR_EASE_SIGMA 0.04  /* seconds */
#define FLOOR_EASE_TRUNC 2.5   /* limits__ease_kernel's cut, in sigmas */
#define CHAIN_MAX 64           /* longer chains are left as they are */

/* slerp(a, b, t) of unit quaternions along the shorter arc, into o. */
static void slerp4(const double *a, const double *b, double t, double *o)
{
    double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    const double s = c < 0 ? -1.0 : 1.0;
    c = fabs(c);
    double wa = 1.0 - t, wb = t;
    if (c < 1.0 - 1e-12) {
        const double th = acos(c < 1.0 ? c : 1.0), st = sin(th);
        wa = sin((1.0 - t) * th) / st, wb = sin(t * th) / st;
    }
    double n = 0.0;
    for (int i = 0; i < 4; i++) {
        o[i] = wa * a[i] + s * wb * b[i];
        n += o[i] * o[i];
    }
    n = sqrt(n);
    for (int i = 0; i < 4; i++)
        o[i] /= n;
}

static void unit4(const double *a, double *o)
{
    const double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3]);
    for (int i = 0; i < 4; i++)
        o[i] = a[i] / n;
}

mlr_status floor_chains__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                               double slack, const guards_input *in, double *root, double *rot,
                               const double *trans, int32_t body, size_t C, const int32_t *joints,
                               int keep_feet, size_t *lifted, const mlr_allocator *alloc)
{
    if (lifted)
        *lifted = 0;
    const size_t J = rig->n_joints, E = rig->n_end_sites, P = J + E;
    if (N < 3 || !isfinite(floor) || !(fps > 0))
        return MLR_OK;
    const double sigma = FLOOR_EASE_SIGMA * fps;
    const size_t r = (size_t)ceil(FLOOR_EASE_TRUNC * sigma); /* limits__ease_kernel's */
    /* scratch: two FKs (positions, world rotations), the input's heights, a point's weights
       and their eased copy, the joints' weights, the running maximum's, a chain's rotations
       and local translations (CHAIN_MAX joints), the kernel; the flags */
    size_t nd = 0, bytes = 0, fb = 0;
    if (common__mul_size(N, 7 * J + P + J + 3, &nd) != MLR_OK ||
        common__mul_size(nd + 7 * CHAIN_MAX + r + 1, sizeof(double), &bytes) != MLR_OK ||
        common__mul_size(3 * J, sizeof(int32_t), &fb) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    int32_t *ib = common__alloc(alloc, fb);
    if (!buf || !ib) {
        common__free(alloc, buf, bytes);
        common__free(alloc, ib, fb);
        return MLR_E_NO_MEMORY;
    }
    const double *pos_in = in->pos, *wrot_in = in->wrot, *in_root = in->root, *in_rot = in->rot,
                 *in_trans = in->trans;
    double *pos = buf, *wrot = pos + 3 * N * J, *h_in = wrot + 4 * N * J, *wp = h_in + N * P,
           *wpe = wp + N, *wj = wpe + N, *tmp = wj + N * J, *qc = tmp + N,
           *lt = qc + 4 * CHAIN_MAX, *kern = lt + 3 * CHAIN_MAX;
    int32_t *foot = ib, *tidx = ib + J, *chain = ib + 2 * J;
    mlr_status st = mlr_fk_arrays(N, J, rig->parents, rig->offsets, root, rot, rig->n_trans,
                                  rig->trans_joints, trans, pos, wrot, alloc, NULL);
    if (st != MLR_OK)
        goto done;
    /* the feet's joints: the contact points' joints, their ancestors and descendants */
    memset(foot, 0, J * sizeof(int32_t));
    for (size_t c = 0; c < C; c++)
        for (int32_t j = joints[c]; j >= 0; j = rig->parents[j])
            foot[j] = 1;
    for (size_t j = 1; j < J; j++)
        if (foot[rig->parents[j]] && !foot[j]) {
            /* a descendant of a contact point's joint is on the foot; of an ancestor, not */
            int below = 0;
            for (size_t c = 0; c < C && !below; c++)
                for (int32_t a = (int32_t)j; a >= 0 && !below; a = rig->parents[a])
                    below = a == joints[c];
            foot[j] = below ? 2 : 0;
        }
    for (size_t c = 0; c < C; c++)
        foot[joints[c]] = 2; /* the feet themselves are the cleanup's */
    for (size_t j = 0; j < J; j++)
        tidx[j] = -1;
    for (size_t k = 0; k < rig->n_trans; k++)
        tidx[rig->trans_joints[k]] = (int32_t)k;
    /* the input's heights */
    for (size_t f = 0; f < N; f++)
        for (size_t p = 0; p < P; p++) {
            const size_t j = p < J ? p : (size_t)rig->end_site_parents[p - J];
            double y = pos_in[3 * (f * J + j) + (size_t)up];
            if (p >= J) {
                double v[3];
                quat__rotate3(wrot_in + 4 * (f * J + j), rig->end_site_offsets + 3 * (p - J), v);
                y += v[up];
            }
            h_in[f * P + p] = y;
        }
    limits__ease_kernel(sigma, kern);
    memset(wj, 0, N * J * sizeof(double));
    size_t n_lifted = 0;
    for (size_t p = 0; p < P; p++) {
        const size_t jp = p < J ? p : (size_t)rig->end_site_parents[p - J];
        const int32_t e = p < J ? -1 : (int32_t)(p - J);
        if (foot[jp] == 2)
            continue;
        /* the chain: jp and its ancestors up to the root */
        size_t n = 0;
        for (int32_t a = (int32_t)jp; a >= 0 && n <= CHAIN_MAX; a = rig->parents[a])
            chain[n++] = a;
        if (n > CHAIN_MAX)
            continue;
        for (size_t i = 0; i < n / 2; i++) { /* top down */
            const int32_t t = chain[i];
            chain[i] = chain[n - 1 - i], chain[n - 1 - i] = t;
        }
        int any = 0;
        for (size_t f = 0; f < N; f++) {
            wp[f] = 0.0;
            const double din = fmax(0.0, floor - h_in[f * P + p]);
            double y = pos[3 * (f * J + jp) + (size_t)up];
            if (e >= 0) {
                double v[3];
                quat__rotate3(wrot + 4 * (f * J + jp), rig->end_site_offsets + 3 * (size_t)e, v);
                y += v[up];
            }
            if (!((floor - y) - din > slack))
                continue;
            /* the local translations of the chain at f */
            const size_t m = n;
            size_t ib = m; /* the body joint's place on the chain, m when not on it */
            for (size_t i = 0; i < m; i++) {
                const size_t j = (size_t)chain[i];
                const double *t = tidx[j] >= 0 ? trans + 3 * (f * rig->n_trans + (size_t)tidx[j])
                                               : rig->offsets + 3 * j;
                memcpy(lt + 3 * i, t, 3 * sizeof(double));
                if (body >= 0 && tidx[j] == body)
                    ib = i;
            }
            double w = 1.0;
            /* keep_feet: the blend does not reach the input's pose (the feet's ancestors keep
               theirs), so where no weight lifts the point enough, the one that lifts it most,
               and none when no weight lifts it at all */
            double best_depth = (floor - y) - din, best_w = 0.0;
            for (int s = 1; s <= FLOOR_STEPS; s++) {
                const double t = (double)s / FLOOR_STEPS;
                if (ib < m && !keep_feet) { /* the body's translation, with the root's */
                    const double *a = trans + 3 * (f * rig->n_trans + (size_t)body),
                                 *b = in_trans + 3 * (f * rig->n_trans + (size_t)body);
                    for (int d = 0; d < 3; d++)
                        lt[3 * ib + (size_t)d] = a[d] + t * (b[d] - a[d]);
                }
                for (size_t i = 0; i < m; i++) {
                    const size_t j = (size_t)chain[i];
                    double a[4], b[4];
                    unit4(rot + 4 * (f * J + j), a);
                    unit4(in_rot + 4 * (f * J + j), b);
                    slerp4(a, b, keep_feet && foot[j] ? 0.0 : t, qc + 4 * i);
                }
                double pt[3];
                /* the point's position: forward kinematics down the chain from the root,
                   whose translation is blended too */
                double pp[3], rr[4];
                const double tr = keep_feet ? 0.0 : t; /* the root's translation */
                for (int d = 0; d < 3; d++)
                    pp[d] = root[3 * f + (size_t)d] +
                            tr * (in_root[3 * f + (size_t)d] - root[3 * f + (size_t)d]);
                memcpy(rr, qc, sizeof rr);
                for (size_t i = 1; i < m; i++) {
                    double v[3], r2[4];
                    quat__rotate3(rr, lt + 3 * i, v);
                    for (int d = 0; d < 3; d++)
                        pp[d] += v[d];
                    ik__qmul4(rr, qc + 4 * i, r2);
                    memcpy(rr, r2, sizeof rr);
                }
                if (e >= 0) {
                    double v[3];
                    quat__rotate3(rr, rig->end_site_offsets + 3 * (size_t)e, v);
                    for (int d = 0; d < 3; d++)
                        pp[d] += v[d];
                }
                memcpy(pt, pp, sizeof pt);
                if ((floor - pt[up]) - din <= slack) {
                    w = t;
                    break;
                }
                if ((floor - pt[up]) - din < best_depth)
                    best_depth = (floor - pt[up]) - din, best_w = t;
                if (keep_feet && s == FLOOR_STEPS)
                    w = best_w;
            }
            if (!(w > 0.0))
                continue;
            wp[f] = w;
            any = 1;
        }
        if (!any)
            continue;
        n_lifted++;
        limits__ease_lookahead(wp, N, kern, r, tmp, wpe);
        for (size_t f = 0; f < N; f++)
            for (size_t i = 0; i < n; i++) {
                double *x = wj + f * J + (size_t)chain[i];
                *x = wpe[f] > *x ? wpe[f] : *x;
            }
    }
    for (size_t f = 0; f < N; f++)
        for (size_t j = 0; j < J; j++) {
            const double t = keep_feet && foot[j] ? 0.0 : wj[f * J + j];
            if (!(t > 0.0))
                continue;
            double a[4], b[4], o[4];
            unit4(rot + 4 * (f * J + j), a);
            unit4(in_rot + 4 * (f * J + j), b);
            slerp4(a, b, t, o);
            double *q = rot + 4 * (f * J + j);
            const double sg = o[0] * q[0] + o[1] * q[1] + o[2] * q[2] + o[3] * q[3] < 0 ? -1 : 1;
            for (int i = 0; i < 4; i++)
                q[i] = sg * o[i];
        }
    for (size_t f = 0; f < N && !keep_feet; f++) {
        const double t = wj[f * J];
        for (int d = 0; d < 3 && t > 0.0; d++)
            root[3 * f + (size_t)d] += t * (in_root[3 * f + (size_t)d] - root[3 * f + (size_t)d]);
    }
    if (body >= 0 && !keep_feet) {
        /* the body joint's translation, blended by its weight, enters as a root shift (in the
           world, through its parent's rotation): the guards carry root shifts into the body's
           translation at the end (carry_body_shift in guards.c) */
        const int32_t bj = rig->trans_joints[body];
        for (size_t f = 0; f < N; f++) {
            const double t = wj[f * J + (size_t)bj];
            if (!(t > 0.0))
                continue;
            double w[4] = {1.0, 0.0, 0.0, 0.0};
            for (int32_t a = rig->parents[bj]; a >= 0; a = rig->parents[a]) {
                double r2[4];
                ik__qmul4(rot + 4 * (f * J + (size_t)a), w, r2);
                memcpy(w, r2, sizeof w);
            }
            const double *a = trans + 3 * (f * rig->n_trans + (size_t)body),
                         *b = in_trans + 3 * (f * rig->n_trans + (size_t)body);
            double dl[3], dw[3];
            for (int d = 0; d < 3; d++)
                dl[d] = t * (b[d] - a[d]);
            quat__rotate3(w, dl, dw);
            for (int d = 0; d < 3; d++)
                root[3 * f + (size_t)d] += dw[d];
        }
    }
    if (lifted)
        *lifted = n_lifted;
done:
    common__free(alloc, buf, bytes);
    common__free(alloc, ib, fb);
    return st;
}
