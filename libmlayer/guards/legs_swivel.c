/* Knees above the floor: a leg turned about its hip-ankle axis.
 *
 * At alpha 3 the synthesis folds a landing or a crouch far deeper than the input did (SFU's
 * two-feet jump: the hips at 40% of their height, the feet above them); the cleanup then pins
 * the feet back on the floor, and the two-bone IK, which keeps the plane the synthesis gave the
 * leg, swings the knee down through the floor (13% of body height on that jump, 8.7% on PyMO's
 * walk, 3.8% on LaFAN1). A leg can be turned about the line from its hip to its ankle without
 * moving the ankle or changing the knee's bend: the knee moves on a circle around that line.
 * Per leg and frame, the smallest turn that lifts the knee to the input's depth there (within
 * the guards' slack) is found in closed form (the knee's height along the circle is
 * c + r A cos(phi - phi0)), the way toward the top of the circle (where the knee sits at the
 * bottom, toward the side the input's knee is on); the turns are eased in time like the limits' corrections
 * (limits__ease_lookahead: a running maximum, then a 40 ms Gaussian; positive and negative turns
 * apart), so a knee leaves the floor and returns over about 0.1 s. The hip's world rotation
 * takes the turn; the ankle's local rotation gives it back, so the foot keeps its world
 * orientation and stays where the cleanup planted it.
 *
 * What it cannot do: make an impossible pose natural. Where the synthesis has pitched the pelvis
 * and folded the leg so far that no knee position on the circle is both above the floor and on
 * the input's side (SFU's landing at alpha 3, the pelvis tipped forward), the knee ends above
 * the floor but turned away from where the input's pointed (110 degrees in the pelvis's frame
 * at the worst frame, against 70 through the floor before). Turning toward the input's side
 * there went through the bottom of the circle: the easing's partial turns then took the frames
 * around down (1.5% of body height under on SFU, 17% on an AI4Animation dog's hind knee).
 */
#include "guards/legs_swivel_internal.h"

#include "motion/fk_internal.h"
#include "guards/limits_internal.h"
#include "common/mlr_internal.h"
#include "math/quat_internal.h"

#include <math.h>
#include <string.h>

#define SWIVEL_EASE_SIGMA 0.04 /* seconds */
#define SWIVEL_EASE_TRUNC 2.5  /* limits__ease_kernel's cut, in sigmas */
#define SWIVEL_MAX_LEGS 16
#define SWIVEL_PI 3.14159265358979323846

/* The knee's circle about the hip-ankle axis at one frame: u the axis, c its centre, r its
 * radius, e1 the knee's direction from c, e2 = u x e1. 0 when the leg is straight or folded
 * flat (no circle to turn on). */
static int knee_circle(const double *h, const double *k, const double *a, double *u, double *c,
                       double *r, double *e1, double *e2)
{
    double L = 0.0, t = 0.0;
    for (int d = 0; d < 3; d++)
        u[d] = a[d] - h[d], L += u[d] * u[d];
    L = sqrt(L);
    if (!(L > 1e-12))
        return 0;
    for (int d = 0; d < 3; d++)
        u[d] /= L, t += (k[d] - h[d]) * u[d];
    double rr = 0.0;
    for (int d = 0; d < 3; d++) {
        c[d] = h[d] + t * u[d];
        e1[d] = k[d] - c[d];
        rr += e1[d] * e1[d];
    }
    *r = sqrt(rr);
    if (!(*r > 1e-9 * L))
        return 0;
    for (int d = 0; d < 3; d++)
        e1[d] /= *r;
    e2[0] = u[1] * e1[2] - u[2] * e1[1];
    e2[1] = u[2] * e1[0] - u[0] * e1[2];
    e2[2] = u[0] * e1[1] - u[1] * e1[0];
    return 1;
}

/* The smallest turns (radians, about u) in each direction, *pos >= 0 and *neg <= 0, that put
 * the knee at height target or above (the turns to its highest point when none does), and how
 * far below its height y the knee goes on the way (*dip_pos, *dip_neg); all 0 when it is
 * already there. */
static void turns_to(double c_up, double r, double e1_up, double e2_up, double y, double target,
                     double *pos, double *neg, double *dip_pos, double *dip_neg)
{
    *pos = *neg = *dip_pos = *dip_neg = 0.0;
    const double A = hypot(e1_up, e2_up);
    if (y >= target || !(A > 0.0))
        return;
    /* the way toward the top along the shorter arc only rises; the other way first goes down
       to the bottom of the circle, y - (c - r A) below where the knee is */
    const double top = atan2(e2_up, e1_up), dip = fmax(0.0, y - (c_up - r * A));
    *dip_pos = top >= 0.0 ? 0.0 : dip;
    *dip_neg = top <= 0.0 ? 0.0 : dip;
    const double two_pi = 2.0 * SWIVEL_PI, phi0 = atan2(e2_up, e1_up);
    const double x = (target - c_up) / (r * A);
    const double dl = x >= 1.0 ? 0.0 : acos(x < -1.0 ? -1.0 : x);
    /* the knee is high enough for turns within dl of phi0 (mod 2 pi); 0 is not among them */
    double p = fmod(phi0 - dl, two_pi), n = fmod(phi0 + dl, two_pi);
    p = p < 0.0 ? p + two_pi : p;
    n = n > 0.0 ? n - two_pi : n;
    *pos = p, *neg = n;
}

/* The angle on the knee's circle (e1, e2 at frame f of the motion) of the input's knee: its
 * offset from its own hip-ankle line, carried from the input's pelvis (the hip's parent) to the
 * motion's, projected on the circle's plane; 0 (no preference) when the input's leg is straight
 * or the offset is along the axis. */
static double input_angle(const mlr_rig *rig, const double *pos_in, const double *wrot_in,
                          const double *wrot, size_t J, size_t f, size_t h, size_t k, size_t a,
                          const double *e1, const double *e2)
{
    const size_t p = (size_t)rig->parents[h];
    const double *ph = pos_in + 3 * (f * J + h), *pk = pos_in + 3 * (f * J + k);
    const double *pa = pos_in + 3 * (f * J + a);
    double u[3], c[3], d1[3], d2[3], rad;
    if (!knee_circle(ph, pk, pa, u, c, &rad, d1, d2))
        return 0.0;
    const double *Wi = wrot_in + 4 * (f * J + p), *Wo = wrot + 4 * (f * J + p);
    const double Wic[4] = {Wi[0], -Wi[1], -Wi[2], -Wi[3]};
    double local[3], d[3];
    quat__rotate3(Wic, d1, local);
    quat__rotate3(Wo, local, d);
    const double x = d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2];
    const double y = d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2];
    return hypot(x, y) > 0.0 ? atan2(y, x) : 0.0;
}

/* The legs: (hip, knee, ankle) of each contact point's joint with no contact point's joint
   above it; returns how many (at most SWIVEL_MAX_LEGS). */
static size_t find_legs(const mlr_rig *rig, size_t C, const int32_t *joints, int32_t *legs)
{
    size_t n = 0;
    for (size_t c = 0; c < C && n < SWIVEL_MAX_LEGS; c++) {
        const int32_t a = joints[c];
        int below = 0;
        for (int32_t p = rig->parents[a]; p >= 0 && !below; p = rig->parents[p])
            for (size_t d = 0; d < C && !below; d++)
                below = joints[d] == p;
        const int32_t k = rig->parents[a], h = k >= 0 ? rig->parents[k] : -1;
        if (below || h < 0 || rig->parents[h] < 0)
            continue;
        int seen = 0;
        for (size_t i = 0; i < n && !seen; i++)
            seen = legs[3 * i + 2] == a;
        if (seen)
            continue;
        legs[3 * n] = h, legs[3 * n + 1] = k, legs[3 * n + 2] = a;
        n++;
    }
    return n;
}

mlr_status legs_swivel__apply(const mlr_rig *rig, size_t N, double fps, int up, double floor,
                              double slack, const guards_input *in, const double *root,
                              double *rot, const double *trans, size_t C, const int32_t *joints,
                              size_t *turned, const mlr_allocator *alloc)
{
    if (turned)
        *turned = 0;
    const size_t J = rig->n_joints;
    int32_t legs[3 * SWIVEL_MAX_LEGS];
    const size_t nl = find_legs(rig, C, joints, legs);
    if (N < 3 || nl == 0 || !isfinite(floor) || !(fps > 0))
        return MLR_OK;
    const double sigma = SWIVEL_EASE_SIGMA * fps;
    const size_t r = (size_t)ceil(SWIVEL_EASE_TRUNC * sigma); /* limits__ease_kernel's */
    /* scratch: the input's positions, the motion's positions and world rotations, the turns
       (positive and negative parts, eased copies, the running maximum's), the kernel */
    size_t nd = 0, bytes = 0;
    if (common__mul_size(N, 7 * J + 8, &nd) != MLR_OK ||
        common__mul_size(nd + r + 3, sizeof(double), &bytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    if (!buf)
        return MLR_E_NO_MEMORY;
    const double *pos_in = in->pos, *wrot_in = in->wrot;
    double *pos = buf, *wrot = pos + 3 * N * J, *tp = wrot + 4 * N * J, *tn = tp + N, *ep = tn + N,
           *en = ep + N, *pref = en + N, *dp = pref + N, *dn = dp + N, *tmp = dn + N,
           *kern = tmp + N;
    mlr_status st = mlr_fk_arrays(N, J, rig->parents, rig->offsets, root, rot, rig->n_trans,
                                  rig->trans_joints, trans, pos, wrot, alloc, NULL);
    if (st != MLR_OK)
        goto done;
    limits__ease_kernel(sigma, kern);
    size_t n_turned = 0;
    for (size_t l = 0; l < nl; l++) {
        const size_t h = (size_t)legs[3 * l], k = (size_t)legs[3 * l + 1];
        const size_t a = (size_t)legs[3 * l + 2];
        int any = 0;
        for (size_t f = 0; f < N; f++) {
            tp[f] = tn[f] = pref[f] = dp[f] = dn[f] = 0.0;
            const double *ph = pos + 3 * (f * J + h), *pk = pos + 3 * (f * J + k);
            const double *pa = pos + 3 * (f * J + a);
            const double din = fmax(0.0, floor - pos_in[3 * (f * J + k) + (size_t)up]);
            const double y = pk[up];
            if (!((floor - y) - din > slack))
                continue;
            double u[3], c[3], e1[3], e2[3], rad;
            if (!knee_circle(ph, pk, pa, u, c, &rad, e1, e2))
                continue;
            /* the smallest turn that lifts the knee, the way along which it does not first go
               down through the bottom of the circle (more than the slack: the easing turns the
               frames around by every smaller angle); where neither way does (the knee at the
               bottom), toward the side of the circle the input's knee is on */
            double gp, gn, xp, xn;
            turns_to(c[up], rad, e1[up], e2[up], y, floor - din, &gp, &gn, &xp, &xn);
            const double to = input_angle(rig, pos_in, wrot_in, wrot, J, f, h, k, a, e1, e2);
            const int pos_ok = xp <= slack, neg_ok = xn <= slack;
            const int want_pos = pos_ok && neg_ok   ? (to != 0.0 ? to > 0.0 : gp <= -gn)
                                 : pos_ok || neg_ok ? pos_ok
                                                    : xp <= xn;
            const double turn = want_pos ? gp : gn;
            pref[f] = turn, dp[f] = gp, dn[f] = gn;
            any = 1;
        }
        /* one direction per stretch of frames that need a turn (closer than the easing's
           reach): the sign of the larger turns; frames that wanted the other take the
           smallest turn this way. Turns of both signs on neighbouring frames would cancel in
           the easing. */
        for (size_t f = 0; any && f < N;) {
            if (pref[f] == 0.0 && dp[f] == 0.0 && dn[f] == 0.0) {
                f++;
                continue;
            }
            size_t end = f + 1, last = f;
            double sum = pref[f];
            for (; end < N && end <= last + 2 * r + 1; end++)
                if (pref[end] != 0.0 || dp[end] != 0.0 || dn[end] != 0.0) {
                    last = end;
                    sum += pref[end];
                }
            for (size_t t = f; t <= last; t++) {
                const double x = pref[t];
                if (x == 0.0 && dp[t] == 0.0 && dn[t] == 0.0)
                    continue;
                if (sum >= 0.0)
                    tp[t] = x > 0.0 ? x : dp[t];
                else
                    tn[t] = x < 0.0 ? -x : -dn[t];
            }
            f = last + 1;
        }
        if (!any)
            continue;
        n_turned++;
        limits__ease_lookahead(tp, N, kern, r, tmp, ep);
        limits__ease_lookahead(tn, N, kern, r, tmp, en);
        const size_t ph_ = (size_t)rig->parents[h];
        for (size_t f = 0; f < N; f++) {
            const double phi = ep[f] - en[f];
            if (phi == 0.0)
                continue;
            double u[3], c[3], e1[3], e2[3], rad;
            if (!knee_circle(pos + 3 * (f * J + h), pos + 3 * (f * J + k), pos + 3 * (f * J + a),
                             u, c, &rad, e1, e2))
                continue;
            const double s = sin(0.5 * phi);
            const double R[4] = {cos(0.5 * phi), s * u[0], s * u[1], s * u[2]};
            const double Rc[4] = {R[0], -R[1], -R[2], -R[3]};
            const double *Wp = wrot + 4 * (f * J + ph_), *Wk = wrot + 4 * (f * J + k);
            const double *Wa = wrot + 4 * (f * J + a);
            const double Wpc[4] = {Wp[0], -Wp[1], -Wp[2], -Wp[3]};
            const double Wkc[4] = {Wk[0], -Wk[1], -Wk[2], -Wk[3]};
            double t1[4], t2[4], qh[4], qa[4];
            /* hip: W_p^-1 R W_h, with W_h = W_p q_h */
            ik__qmul4(R, wrot + 4 * (f * J + h), t1);
            ik__qmul4(Wpc, t1, qh);
            /* ankle: (R W_k)^-1 W_a = W_k^-1 R^-1 W_a */
            ik__qmul4(Rc, Wa, t1);
            ik__qmul4(Wkc, t1, t2);
            memcpy(qa, t2, sizeof qa);
            double *q_h = rot + 4 * (f * J + h), *q_a = rot + 4 * (f * J + a);
            const double sh = qh[0] * q_h[0] + qh[1] * q_h[1] + qh[2] * q_h[2] + qh[3] * q_h[3];
            const double sa = qa[0] * q_a[0] + qa[1] * q_a[1] + qa[2] * q_a[2] + qa[3] * q_a[3];
            double nh = 0.0, na = 0.0;
            for (int i = 0; i < 4; i++)
                nh += qh[i] * qh[i], na += qa[i] * qa[i];
            nh = (sh < 0 ? -1.0 : 1.0) / sqrt(nh), na = (sa < 0 ? -1.0 : 1.0) / sqrt(na);
            for (int i = 0; i < 4; i++)
                q_h[i] = nh * qh[i], q_a[i] = na * qa[i];
        }
    }
    if (turned)
        *turned = n_turned;
done:
    common__free(alloc, buf, bytes);
    return st;
}
