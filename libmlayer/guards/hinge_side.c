/* Elbows kept on their own side of straight, and short of folding flat.
 *
 * The limits bound a joint named as a hinge (limits__hinge_name) as a hinge only where its
 * input turns about one axis (limits.c); an elbow whose capture also twists about the bone or
 * wobbles (Kinect's, Xsens's, MakeHuman's) gets a swing-twist cone around its mean rotation,
 * and at alpha 2-3 the exaggerated forearm swings through straight and bends the other way: on
 * a Kinect capture (MAE's ah_cut_01) 173 degrees at alpha 3, on an Xsens capture 110, against
 * an input that never bent it more than 9 degrees that way; or through a fold. Per arm, the
 * hinge axis is learned from the input (the mean of the unit normals of the plane of the upper
 * and lower bones over the frames bent by more than 20 degrees, in the frame of the elbow's
 * parent, so that it turns with the upper arm) and with it the input's smallest signed
 * flexion, lo (at most 0), and its largest, hi (at least 150 degrees, limits_human.c's fold).
 * The result's elbow angle is measured in the plane across that axis made perpendicular to the
 * upper bone, where a turn of the elbow about the axis moves the angle by exactly the turn,
 * continuous in time (a forearm that folds past 180 degrees is a fold, not a bend the other
 * way). Where it falls below lo or rises above hi, the elbow is turned about the axis by the
 * shortfall or the excess: its local rotation premultiplied by the turn, since the axis lives
 * in the parent's frame; the forearm and hand turn with it. Shortfalls and excesses are eased
 * in time as the limits' corrections are (a running maximum, then a 40 ms Gaussian), so the
 * turn enters and leaves smoothly, and a frame is never turned past the other bound. The
 * result is measured and turned a second time (the axis moves with the upper arm a little
 * between frames).
 *
 * Not for knees: the contact cleanup's IK sets them after this pass and keeps the plane of
 * each leg.
 */
#include "guards/hinge_side_internal.h"

#include "common/mlr_internal.h"
#include "guards/ik_internal.h"
#include "guards/limits_internal.h"
#include "mlayer/mlr_fk.h"
#include "mlayer/mlr_ik.h"

#include <math.h>
#include <string.h>

#define HINGE_SIDE_EASE_SIGMA 0.04 /* seconds */
#define HINGE_SIDE_EASE_TRUNC 2.5  /* limits__ease_kernel's cut, in sigmas */
#define HINGE_SIDE_BENT 20.0       /* degrees: the input's frames that show the axis */
#define HINGE_SIDE_PASSES 2
#define HINGE_SIDE_MAX_BACK 60.0  /* degrees: an input bent further the other way has no side */
#define HINGE_SIDE_FOLD 150.0 /* degrees: the turn takes no elbow past this (limits_human.c) */
#define HINGE_SIDE_MIN_ACROSS 0.3 /* the axis across the upper bone, at least (sin 17 degrees) */
#define HINGE_SIDE_PI 3.14159265358979323846

static const char *const hand_names[] = {"hand", "wrist", NULL};

size_t hinge_side__chains(const mlr_rig *rig, hinge_side *out, size_t cap)
{
    const size_t J = rig->n_joints;
    size_t n = 0;
    if (!rig->names)
        return 0;
    for (size_t j = 1; j < J && n < cap; j++) {
        if (!rig->names[j] || !common__name_matches(rig->names[j], hand_names))
            continue;
        int below = 0; /* a hand below a hand (a finger named hand...) is the same arm */
        for (int32_t a = rig->parents[j]; a >= 0 && !below; a = rig->parents[a])
            below = rig->names[a] && common__name_matches(rig->names[a], hand_names);
        int32_t upper = -1, middle = -1;
        if (below || mlr_ik_leg_chain(rig, (int32_t)j, &upper, &middle, NULL) != MLR_OK ||
            rig->parents[middle] < 0)
            continue;
        out[n++] = (hinge_side){upper, middle, (int32_t)j, {0, 0, 0}, 0.0, 0.0};
    }
    return n;
}

static void sub3(const double *a, const double *b, double *o)
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}

/* The unit bones u (upper to middle) and w (middle to end) of h at frame f; 0 when one has no
   length. */
static int bones(const hinge_side *h, size_t J, const double *wpos, size_t f, double *u, double *w)
{
    const double *p = wpos + 3 * f * J;
    sub3(p + 3 * (size_t)h->middle, p + 3 * (size_t)h->upper, u);
    sub3(p + 3 * (size_t)h->end, p + 3 * (size_t)h->middle, w);
    const double nu = sqrt(common__dot3(u, u)), nw = sqrt(common__dot3(w, w));
    if (!(nu > 0.0) || !(nw > 0.0))
        return 0;
    for (int i = 0; i < 3; i++)
        u[i] /= nu, w[i] /= nw;
    return 1;
}

/* The signed flexion of h at frame f (radians; NAN where a bone has no length). */
static double signed_flexion(const mlr_rig *rig, const hinge_side *h, const double *wpos,
                             const double *wrot, size_t f)
{
    const size_t J = rig->n_joints, p = (size_t)rig->parents[h->middle];
    double u[3], w[3], n[3], ax[3];
    if (!bones(h, J, wpos, f, u, w))
        return NAN;
    common__cross3(u, w, n);
    ik__qrot(wrot + 4 * (f * J + p), h->axis, ax);
    return atan2(common__dot3(n, ax), common__dot3(u, w));
}

int hinge_side__learn(const mlr_rig *rig, size_t N, const double *wpos, const double *wrot,
                      hinge_side *h, double *ref)
{
    const size_t J = rig->n_joints, p = (size_t)rig->parents[h->middle];
    const double bent = cos(HINGE_SIDE_BENT * HINGE_SIDE_PI / 180.0);
    double m[3] = {0, 0, 0};
    for (size_t f = 0; f < N; f++) {
        double u[3], w[3], n[3], l[3];
        if (!bones(h, J, wpos, f, u, w) || !(common__dot3(u, w) < bent))
            continue;
        common__cross3(u, w, n);
        const double nn = sqrt(common__dot3(n, n));
        if (!(nn > 0.0))
            continue;
        const double *q = wrot + 4 * (f * J + p);
        const double qc[4] = {q[0], -q[1], -q[2], -q[3]};
        ik__qrot(qc, n, l);
        for (int i = 0; i < 3; i++)
            m[i] += l[i] / nn;
    }
    const double nm = sqrt(common__dot3(m, m));
    if (!(nm > 1e-9) || !isfinite(nm))
        return 0;
    for (int i = 0; i < 3; i++)
        h->axis[i] = m[i] / nm;
    double lo = 0.0, hi = HINGE_SIDE_FOLD * HINGE_SIDE_PI / 180.0;
    for (size_t f = 0; f < N; f++) {
        const double s = ref[f] = signed_flexion(rig, h, wpos, wrot, f);
        lo = s < lo ? s : lo;
        hi = s > hi ? s : hi;
    }
    h->lo = lo, h->hi = hi;
    /* an input that bends it far both ways has no side to keep (a 7 fps dance whose elbow
       reads -177 degrees, video pose estimates): left as it is */
    return lo >= -HINGE_SIDE_MAX_BACK * HINGE_SIDE_PI / 180.0;
}

/* The elbow's angle phi in the plane across the axis made perpendicular to the upper bone, at
   frame f of the motion (pos, wrot): 0 straight, positive toward the input's bending side
   (rotating the forearm by t about that axis moves phi by exactly t); h's lo and hi in that
   plane into *phi_lo, *phi_hi; that axis in the parent's frame into a. Returns 0 where it is not defined (a
   bone of no length, the axis within 17 degrees of the upper bone). */
static int plane_angle(const mlr_rig *rig, const hinge_side *h, const double *pos,
                       const double *wrot, size_t f, double *phi, double *phi_lo, double *phi_hi,
                       double *a)
{
    const size_t J = rig->n_joints, p = (size_t)rig->parents[h->middle];
    double u[3], w[3], ax[3], e2[3];
    if (!bones(h, J, pos, f, u, w))
        return 0;
    const double *W = wrot + 4 * (f * J + p);
    ik__qrot(W, h->axis, ax);
    const double along = common__dot3(ax, u);
    for (int i = 0; i < 3; i++)
        ax[i] -= along * u[i];
    const double k = sqrt(common__dot3(ax, ax)); /* (the axis is unit) */
    if (!(k > HINGE_SIDE_MIN_ACROSS))
        return 0;
    for (int i = 0; i < 3; i++)
        ax[i] /= k;
    common__cross3(ax, u, e2);
    *phi = atan2(common__dot3(w, e2), common__dot3(w, u));
    *phi_lo = atan2(sin(h->lo) / k, cos(h->lo));
    *phi_hi = atan2(sin(h->hi) / k, cos(h->hi));
    const double Wc[4] = {W[0], -W[1], -W[2], -W[3]};
    ik__qrot(Wc, ax, a);
    return 1;
}

mlr_status hinge_side__apply(const mlr_rig *rig, size_t N, double fps, const hinge_side *h,
                             size_t n, const double *ref, const double *root, double *rot,
                             const double *trans, uint8_t *mask, size_t *turned,
                             const mlr_allocator *alloc)
{
    if (turned)
        *turned = 0;
    const size_t J = rig->n_joints;
    if (N < 3 || n == 0 || !(fps > 0))
        return MLR_OK;
    const double sigma = HINGE_SIDE_EASE_SIGMA * fps;
    const size_t r = (size_t)ceil(HINGE_SIDE_EASE_TRUNC * sigma); /* limits__ease_kernel's */
    /* scratch: the motion's positions and world rotations; per frame of an arm its angle,
       the bounds, the shortfall below lo and its eased copy, the excess above hi and its
       eased copy, the running maximum's, the axis; the kernel */
    size_t nd = 0, bytes = 0;
    if (common__mul_size(N, 7 * J + 11, &nd) != MLR_OK ||
        common__mul_size(nd + r + 1, sizeof(double), &bytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    if (!buf)
        return MLR_E_NO_MEMORY;
    double *pos = buf, *wrot = pos + 3 * N * J, *phi = wrot + 4 * N * J, *plo = phi + N,
           *phi_ = plo + N, *sh = phi_ + N, *esh = sh + N, *ex = esh + N, *eex = ex + N,
           *tmp = eex + N, *axes = tmp + N, *kern = axes + 3 * N;
    limits__ease_kernel(sigma, kern);
    int needed[HINGE_SIDE_MAX] = {0};
    mlr_status st = MLR_OK;
    for (int pass = 0; pass < HINGE_SIDE_PASSES; pass++) {
        st = mlr_fk_arrays(N, J, rig->parents, rig->offsets, root, rot, rig->n_trans,
                           rig->trans_joints, trans, pos, wrot, alloc, NULL);
        if (st != MLR_OK)
            break;
        int moved = 0;
        for (size_t k = 0; k < n && k < HINGE_SIDE_MAX; k++) {
            int any = 0;
            for (size_t f = 0; f < N; f++) {
                sh[f] = ex[f] = 0.0;
                if (!plane_angle(rig, &h[k], pos, wrot, f, &phi[f], &plo[f], &phi_[f],
                                 axes + 3 * f)) {
                    phi[f] = NAN;
                    continue;
                }
                /* the turn nearest the input's angle there: a forearm folded past 180 degrees
                   where the input's is folded is a fold, not a bend the other way (continuous
                   in time as the input is; unwrapping in time instead carried a glitch's jump
                   of the synthesis to the rest of a clip) */
                const double in = ref[k * N + f];
                if (!isnan(in))
                    phi[f] += 2.0 * HINGE_SIDE_PI * round((in - phi[f]) / (2.0 * HINGE_SIDE_PI));
                sh[f] = phi[f] < plo[f] ? plo[f] - phi[f] : 0.0;
                ex[f] = phi[f] > phi_[f] ? phi[f] - phi_[f] : 0.0;
                any |= sh[f] > 0.0 || ex[f] > 0.0;
            }
            if (!any)
                continue;
            needed[k] = moved = 1;
            limits__ease_lookahead(sh, N, kern, r, tmp, esh);
            limits__ease_lookahead(ex, N, kern, r, tmp, eex);
            for (size_t f = 0; f < N; f++) {
                if (isnan(phi[f]))
                    continue;
                /* the eased turn, but never past the other bound (the running maximum
                   carries a large shortfall to the frames around, which may need none) */
                double t = esh[f] - eex[f];
                t = t > phi_[f] - phi[f] ? phi_[f] - phi[f] : t;
                t = t < plo[f] - phi[f] ? plo[f] - phi[f] : t;
                if (t == 0.0)
                    continue;
                const double s = sin(0.5 * t), *ax = axes + 3 * f;
                const double R[4] = {cos(0.5 * t), s * ax[0], s * ax[1], s * ax[2]};
                double *q = rot + 4 * (f * J + (size_t)h[k].middle), o[4];
                ik__qmul4(R, q, o);
                const double no =
                    1.0 / sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3]);
                const double sg =
                    o[0] * q[0] + o[1] * q[1] + o[2] * q[2] + o[3] * q[3] < 0 ? -no : no;
                for (int i = 0; i < 4; i++)
                    q[i] = sg * o[i];
                if (mask)
                    mask[f * J + (size_t)h[k].middle] = 1;
            }
        }
        if (!moved)
            break;
    }
    if (turned)
        for (size_t k = 0; k < n && k < HINGE_SIDE_MAX; k++)
            *turned += (size_t)needed[k];
    common__free(alloc, buf, bytes);
    return st;
}
