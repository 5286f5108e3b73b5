/* Toe tips above the floor by a tilt of the bone that carries them, not a lift of the foot.
 *
 * The smoothing of the layers takes a toe tip (an End Site below the last joint of a foot) a
 * little under the floor where the input's tip touched it between jittering frames: CMU's salsa
 * tip went 0.87% of body height under its floor limit in denoise, a climbing take's 0.9%. The
 * contact cleanup then raised the whole foot to lift it, and moved the knee 0.7-0.9% of body
 * height on clips that did not slide. Turning the joint that carries the tip (the toe joint, or
 * the ankle where the foot has no toe joint) lifts the tip and moves no joint; the cleanup's
 * lift is left for what a tilt of TOE_TILT_MAX does not reach.
 *
 * A foot whose last point is a joint with a toe chain below it (Mixamo: the points are Foot
 * and ToeBase; Toe_End and its End Site hang below ToeBase) is tilted at that joint: neither
 * the cleanup nor the first form of this pass saw those tips, and the last lift raised the
 * whole body for them on every step (Mixamo's walk at alpha 0.5 kept 2.16 alpha of its bob).
 */
#include "guards/toe_tilt_internal.h"

#include "motion/fk_internal.h"
#include "guards/ik_internal.h"
#include "guards/limits_internal.h"
#include "common/mlr_internal.h"
#include "math/quat_internal.h"

#include <math.h>
#include <string.h>

#ifndef TOE_TILT_MAX
#define TOE_TILT_MAX 0.35 /* radians (20 degrees) */
#endif
#define TOE_TILT_EASE_SIGMA 0.04  /* seconds */
#define TOE_TILT_EASE_TRUNC 2.5   /* limits__ease_kernel's cut, in sigmas */

/* A point below the tilted joint: a joint (e < 0) or an End Site (e >= 0, its parent j). */
typedef struct tip {
    size_t j;
    int32_t e;
} tip;

enum { TOE_TILT_MAX_TIPS = 8 }; /* a toe chain of up to 3 joints, their End Sites */

/* The world position of tip t at frame f of a forward kinematics (pos, wrot). */
static void tip_position(const mlr_rig *rig, size_t J, const double *pos, const double *wrot,
                         size_t f, tip t, double *p)
{
    const double *pj = pos + 3 * (f * J + t.j);
    if (t.e < 0) {
        p[0] = pj[0], p[1] = pj[1], p[2] = pj[2];
        return;
    }
    quat__rotate3(wrot + 4 * (f * J + t.j), rig->end_site_offsets + 3 * (size_t)t.e, p);
    for (int d = 0; d < 3; d++)
        p[d] += pj[d];
}

/* The tips a turn of joint j would lift: the chain of single children below j (at most 3
   joints) and the End Sites of its last (Mixamo's ToeBase carries Toe_End and its End Site;
   MakeHuman's toe2-1 carries toe2-2, toe2-3 and a tip). Only for a toe: a joint whose parent is
   a joint point (the ankle, or a toe point; the ankle itself is the cleanup's to turn). 0 when
   j carries more than a chain, or nothing. */
static size_t tips_below(const mlr_rig *rig, const uint8_t *n_child, const int32_t *child,
                         const uint8_t *is_point, size_t j, tip *out)
{
    size_t n = 0, last = j;
    if (rig->parents[j] < 0 || !is_point[rig->parents[j]])
        return 0;
    for (int depth = 0; n_child[last] == 1; depth++) {
        const size_t c = (size_t)child[last];
        if (depth == 3)
            return 0;
        out[n++] = (tip){c, -1};
        last = c;
    }
    if (n_child[last] > 1)
        return 0;
    for (size_t e = 0; e < rig->n_end_sites && n < TOE_TILT_MAX_TIPS; e++)
        if ((size_t)rig->end_site_parents[e] == last)
            out[n++] = (tip){last, (int32_t)e};
    return n;
}

mlr_status toe_tilt__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                           double slack, const guards_input *in, const double *root, double *rot,
                           const double *trans, size_t C, const int32_t *joints,
                           const int32_t *end_sites, size_t *tilted, const mlr_allocator *alloc)
{
    if (tilted)
        *tilted = 0;
    const size_t J = rig->n_joints;
    if (N < 3 || C == 0 || !joints || !isfinite(floor) || !(fps > 0))
        return MLR_OK;
    const double sigma = TOE_TILT_EASE_SIGMA * fps;
    const size_t r = (size_t)ceil(TOE_TILT_EASE_TRUNC * sigma); /* limits__ease_kernel's */
    /* scratch: two forward kinematics, a joint's raw and eased angles, the running maximum's,
       the kernel; per joint its children's count, its one child, whether it is a contact
       point's, whether it was done */
    size_t nd = 0, bytes = 0, jbytes = 0;
    if (common__mul_size(N, 7 * J + 3, &nd) != MLR_OK ||
        common__mul_size(nd + r + 1, sizeof(double), &bytes) != MLR_OK ||
        common__mul_size(J, 3 + sizeof(int32_t), &jbytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    uint8_t *jb = common__alloc(alloc, jbytes);
    if (!buf || !jb) {
        common__free(alloc, buf, bytes);
        common__free(alloc, jb, jbytes);
        return MLR_E_NO_MEMORY;
    }
    const double *pos_in = in->pos, *wrot_in = in->wrot;
    double *pos = buf, *wrot = pos + 3 * N * J, *th = wrot + 4 * N * J, *the = th + N,
           *tmp = the + N, *kern = tmp + N;
    int32_t *child = (int32_t *)(void *)jb; /* first: the allocation's alignment */
    uint8_t *n_child = jb + J * sizeof(int32_t), *is_point = n_child + J, *done = is_point + J;
    mlr_status st = mlr_fk_arrays(N, J, rig->parents, rig->offsets, root, rot, rig->n_trans,
                                  rig->trans_joints, trans, pos, wrot, alloc, NULL);
    if (st != MLR_OK)
        goto done;
    memset(n_child, 0, 3 * J);
    for (size_t j = 1; j < J; j++) {
        const size_t p = (size_t)rig->parents[j];
        n_child[p] = (uint8_t)(n_child[p] < 2 ? n_child[p] + 1 : 2);
        child[p] = (int32_t)j;
    }
    for (size_t c = 0; c < C; c++) /* the joint points (not an End Site's parent) */
        if (joints[c] >= 0 && (size_t)joints[c] < J && !(end_sites && end_sites[c] >= 0))
            is_point[joints[c]] = 1;
    limits__ease_kernel(sigma, kern);
    size_t n_tilted = 0;
    /* the toes below the joint points first (joints in depth-first order: a toe before what
       it carries), then the End Site points they did not carry */
    for (size_t cc = 1; cc < J + C; cc++) {
        tip tips[TOE_TILT_MAX_TIPS];
        size_t nt = 0, j = 0;
        if (cc < J) { /* a joint below a joint point: what it carries */
            j = cc;
            nt = tips_below(rig, n_child, child, is_point, j, tips);
        } else if (end_sites && end_sites[cc - J] >= 0) { /* an End Site point: its parent */
            const size_t e = (size_t)end_sites[cc - J];
            j = (size_t)rig->end_site_parents[e];
            if (n_child[j] == 0)
                tips[nt++] = (tip){j, (int32_t)e};
        }
        if (nt == 0 || done[j])
            continue;
        done[j] = 1;
        for (size_t i = 0; i < nt; i++) /* what it carries is tilted with it */
            done[tips[i].j] = 1;
        int any = 0;
        for (size_t f = 0; f < N; f++) {
            /* each tip's rise to within slack / 2 of its limit, as a turn of the bone from j
               to it; the largest */
            const double *pj = pos + 3 * (f * J + j);
            th[f] = 0.0;
            for (size_t i = 0; i < nt; i++) {
                double pi[3], qi[3];
                tip_position(rig, J, pos_in, wrot_in, f, tips[i], qi);
                tip_position(rig, J, pos, wrot, f, tips[i], pi);
                const double lim = common__fmin(floor, qi[up]), y = pi[up];
                if (!(y < lim - slack))
                    continue;
                const double d[3] = {pi[0] - pj[0], pi[1] - pj[1], pi[2] - pj[2]};
                const double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                if (!(len > 0.0))
                    continue;
                const double h = d[up], rise = lim - 0.5 * slack - y;
                const double s0 = common__fmax(-1.0, common__fmin(1.0, h / len));
                const double s1 = common__fmax(-1.0, common__fmin(1.0, (h + rise) / len));
                th[f] = common__fmax(th[f], common__fmin(TOE_TILT_MAX, asin(s1) - asin(s0)));
                any = 1;
            }
        }
        if (!any)
            continue;
        n_tilted++;
        limits__ease_lookahead(th, N, kern, r, tmp, the);
        for (size_t f = 0; f < N; f++) {
            if (!(the[f] > 0.0))
                continue;
            /* the axis d x up, d toward the farthest tip: a positive turn raises the tips */
            const double *pj = pos + 3 * (f * J + j);
            double d[3], pt[3];
            tip_position(rig, J, pos, wrot, f, tips[nt - 1], pt);
            for (int i = 0; i < 3; i++)
                d[i] = pt[i] - pj[i];
            double k[3] = {0.0, 0.0, 0.0};
            const int a = (up + 1) % 3, b = (up + 2) % 3;
            k[a] = d[b], k[b] = -d[a]; /* d x e_up */
            const double kn = sqrt(k[a] * k[a] + k[b] * k[b]);
            const double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (!(kn > 1e-9 * len))
                continue; /* the bone along the up axis: no tilt lifts it */
            const double sh = sin(0.5 * the[f]) / kn;
            const double q[4] = {cos(0.5 * the[f]), sh * k[0], sh * k[1], sh * k[2]};
            double *rj = rot + 4 * (f * J + j), nr[4];
            const int32_t p = rig->parents[j];
            ik__rotate_to_1(nr, p >= 0 ? wrot + 4 * (f * J + (size_t)p) : NULL,
                            wrot + 4 * (f * J + j), q);
            const double sg =
                nr[0] * rj[0] + nr[1] * rj[1] + nr[2] * rj[2] + nr[3] * rj[3] < 0 ? -1.0 : 1.0;
            for (int i = 0; i < 4; i++)
                rj[i] = sg * nr[i];
        }
    }
    if (tilted)
        *tilted = n_tilted;
done:
    common__free(alloc, buf, bytes);
    common__free(alloc, jb, jbytes);
    return st;
}
