/* Toe tips above the floor by a tilt of the bone that carries them, not a lift of the foot.
 *
 * The smoothing of the layers takes a toe tip (an End Site below the last joint of a foot) a
 * little under the floor where the input's tip touched it between jittering frames: CMU's salsa
 * tip went 0.87% of body height under its floor limit in denoise, a climbing take's 0.9%. The
 * contact cleanup then raised the whole foot to lift it, and moved the knee 0.7-0.9% of body
 * height on clips that did not slide. Turning the joint that carries the tip (the toe joint, or
 * the ankle where the foot has no toe joint) lifts the tip and moves no joint; the cleanup's
 * lift is left for what a tilt of TOE_TILT_MAX does not reach.
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

/* The height of End Site e (parent j) at frame f of a forward kinematics (pos, wrot). */
static double tip_height(const mlr_rig *rig, size_t J, const double *pos, const double *wrot,
                         size_t f, size_t j, size_t e, int up, double *d)
{
    quat__rotate3(wrot + 4 * (f * J + j), rig->end_site_offsets + 3 * e, d);
    return pos[3 * (f * J + j) + (size_t)up] + d[up];
}

mlr_status toe_tilt__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                           double slack, const double *in_root, const double *in_rot,
                           const double *in_trans, const double *root, double *rot,
                           const double *trans, size_t C, const int32_t *joints,
                           const int32_t *end_sites, size_t *tilted, const mlr_allocator *alloc)
{
    (void)joints;
    if (tilted)
        *tilted = 0;
    const size_t J = rig->n_joints;
    if (N < 3 || C == 0 || !end_sites || !isfinite(floor) || !(fps > 0))
        return MLR_OK;
    const double sigma = TOE_TILT_EASE_SIGMA * fps;
    const size_t r = (size_t)ceil(TOE_TILT_EASE_TRUNC * sigma); /* limits__ease_kernel's */
    /* scratch: two forward kinematics, a tip's raw and eased angles, the running maximum's,
       the kernel; a flag per joint */
    size_t nd = 0, bytes = 0;
    if (common__mul_size(N, 14 * J + 3, &nd) != MLR_OK ||
        common__mul_size(nd + r + 1, sizeof(double), &bytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    uint8_t *flag = common__alloc(alloc, J);
    if (!buf || !flag) {
        common__free(alloc, buf, bytes);
        common__free(alloc, flag, J);
        return MLR_E_NO_MEMORY;
    }
    double *pos_in = buf, *wrot_in = pos_in + 3 * N * J, *pos = wrot_in + 4 * N * J,
           *wrot = pos + 3 * N * J, *th = wrot + 4 * N * J, *the = th + N, *tmp = the + N,
           *kern = tmp + N;
    mlr_status st = fk__two_motions(rig, N, in_root, in_rot, in_trans, pos_in, wrot_in, root, rot,
                                    trans, pos, wrot, alloc);
    if (st != MLR_OK)
        goto done;
    /* flag: 1 for a joint with a child joint, 2 once a tip of it is done */
    memset(flag, 0, J);
    for (size_t j = 1; j < J; j++)
        flag[rig->parents[j]] = 1;
    limits__ease_kernel(sigma, kern);
    size_t n_tilted = 0;
    for (size_t c = 0; c < C; c++) {
        if (end_sites[c] < 0)
            continue;
        const size_t e = (size_t)end_sites[c], j = (size_t)rig->end_site_parents[e];
        if (flag[j] != 0)
            continue; /* a joint with children (its tilt would move them), or done */
        flag[j] = 2;
        const double len =
            sqrt(rig->end_site_offsets[3 * e] * rig->end_site_offsets[3 * e] +
                 rig->end_site_offsets[3 * e + 1] * rig->end_site_offsets[3 * e + 1] +
                 rig->end_site_offsets[3 * e + 2] * rig->end_site_offsets[3 * e + 2]);
        if (!(len > 0.0))
            continue;
        int any = 0;
        for (size_t f = 0; f < N; f++) {
            double d[3];
            const double lim =
                common__fmin(floor, tip_height(rig, J, pos_in, wrot_in, f, j, e, up, d));
            const double y = tip_height(rig, J, pos, wrot, f, j, e, up, d);
            th[f] = 0.0;
            if (!(y < lim - slack))
                continue;
            /* the bone's pitch now and the one that puts the tip at lim - slack / 2 */
            const double h = d[up], rise = lim - 0.5 * slack - y;
            const double s0 = common__fmax(-1.0, common__fmin(1.0, h / len));
            const double s1 = common__fmax(-1.0, common__fmin(1.0, (h + rise) / len));
            th[f] = common__fmin(TOE_TILT_MAX, asin(s1) - asin(s0));
            any = 1;
        }
        if (!any)
            continue;
        n_tilted++;
        limits__ease_lookahead(th, N, kern, r, tmp, the);
        for (size_t f = 0; f < N; f++) {
            if (!(the[f] > 0.0))
                continue;
            double d[3];
            (void)tip_height(rig, J, pos, wrot, f, j, e, up, d);
            /* the axis d x up: a positive turn about it raises the tip */
            double k[3] = {0.0, 0.0, 0.0};
            const int a = (up + 1) % 3, b = (up + 2) % 3;
            k[a] = d[b], k[b] = -d[a]; /* d x e_up */
            const double kn = sqrt(k[a] * k[a] + k[b] * k[b]);
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
    common__free(alloc, flag, J);
    return st;
}
