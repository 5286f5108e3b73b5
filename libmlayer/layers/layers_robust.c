/*
 * Robust decomposition: the outlier frames of every group (the body translation, each joint)
 * found by iteratively reweighted smoothing, so that the layers' LGS can down-weight them.
 *
 * Per group, a light LGS (s = cfg->robust_s, about a 2 Hz half-power point) is fitted to the
 * observations; the residual r_i of frame i is the rotation angle between the input and the
 * renormalized fit for a joint, the distance for the translation, divided by 1 - h_i (h_i the
 * leverage of the frame, the diagonal of the smoother A^-1 W: the deleted residual of a linear
 * smoother, what the fit would leave without the frame; it matters at the clip's ends, where
 * the prior lets a fit follow a few frames). A frame whose residual is
 * within the gate G keeps the weight 1; past it the weight falls as exp(-8 ((r/G)^2 - 1)) (a
 * redescending, Welsch-type M-estimator weight: a glitch of twice the gate weighs e^-24, a gross
 * one 0, so that it drops out of the fits and of GCV's residual sums; the prior bridges it).
 * A system stays positive definite while two frames keep a weight: a group with fewer than
 * three frames of weight 1/2 or more keeps the weights 1. The fit is redone with the
 * new weights until the set of outlier frames (weight below 1/2) stops changing. Where nothing
 * passes the gate on the first fit, the weights stay 1 and the decomposition is the plain one.
 *
 * Before the first fit, find_flips marks each joint's flips (runs of 1-10 frames entered and
 * left by a jump, judged from the steps between frames, not from a fit) as outliers from the
 * start: at 30 fps a 5-frame flip is 0.17 s, and the light LGS (2 Hz) follows a burst that
 * long so far that its residual stays within the gate (and a 90-degree flip never passes a
 * gate of pi/2). The flips stay outliers whatever the fits say. At the end every outlier
 * frame (weight below 1/2) weighs 0: a redescending weight of e^-10 times the square of a
 * flip still outweighs the residual sums of the control layer's GCV at weak smoothing, and
 * moved the control s of a flipped joint for the whole clip.
 *
 * A flip run of 2-10 frames whose corruption is a constant turn (q R or R q, R the same on
 * every frame of the run: a joint flipped by a converter or a solver) is undone rather than
 * bridged (undo_flip): R is estimated at both edges of the run, and where the two estimates
 * agree the run is rewritten without it in the working quaternions. Its frames then count in
 * every fit with their repaired rotation (weight 1: flag 2 in L->outliers until the layers
 * are done), so that at 30 fps the layers follow a knee through a 10-frame flip, where the
 * prior's bridge over a third of a second missed it by up to 20% of body height. They are
 * still outliers for mlr_layers_get_outliers and mlr_layers_repair, and the residual layer
 * keeps the input there (layers.c, restore_undone). A run of one frame, or one whose two
 * estimates disagree (not a constant turn, or a joint that changes speed at both edges), is
 * bridged as before.
 *
 * A glitch of 180 degrees leaves the hemisphere alignment of the frames after it to chance (the
 * flipped quaternion is orthogonal to its neighbours), so whenever new outliers are found the
 * quaternions are realigned: each frame with the most similar of its last frames (a quarter
 * of a second, at least 8 frames) that are not outliers.
 */
#include "layers/layers_internal.h"

#include <math.h>

#define MLR_PI_R 3.14159265358979323846
#define ROBUST_MAX_IT 12
/* without a length gate: the translation's gate is this many times the median residual */
#define ROBUST_REL_GATE 100.0
/* flips (find_flips): the longest run, the steps either side for the scale, the factor by which
 * the jumps pass the scale, the slack of the bridge over the run */
#define ROBUST_FLIP_MAX 10
#define ROBUST_FLIP_SIDE 3
#define ROBUST_FLIP_KAPPA 2.5
#define ROBUST_FLIP_BRIDGE 1.5
/* undo_flip: the largest angle between the two estimates of a flip's constant turn, radians */
#define ROBUST_FLIP_AGREE 0.25
/* undo_flip: the square of the smallest uncertainty of an estimate (0.01 rad) */
#define ROBUST_FLIP_U2 1e-4
/* rb->w of a flip frame undone by undo_flip until the end of the search (then 1) */
#define ROBUST_UNDONE (-1.0)
/* a body translation's run at a clip's end: its step past this many times the others */
#define ROBUST_END_KAPPA 10.0
/* a pose's run at a clip's end with no step of the translation (layers__pose_end_runs): this
   many joints step out of it past ROBUST_END_KAPPA times their others, by more than this angle
   (radians, 20 degrees) */
#define ROBUST_END_JOINTS 3
#define ROBUST_END_ANGLE 0.35
/* outlier frames a realignment steps over beyond its window */
#define ROBUST_REALIGN_SKIP 64

static double robust_weight(double r, double gate)
{
    if (!(r > gate))
        return 1.0;
    const double t = r / gate, e = 8.0 * (t * t - 1.0);
    return e < 700.0 ? exp(-e) : 0.0;
}

/* Median of x[0..n) (x reordered). */
static double median_of(double *x, size_t n)
{
    size_t lo = 0, hi = n - 1, kth = n / 2;
    while (lo < hi) { /* Hoare selection */
        const double pv = x[lo + (hi - lo) / 2];
        size_t i = lo, k = hi;
        while (i <= k) {
            while (x[i] < pv)
                i++;
            while (x[k] > pv)
                k--;
            if (i <= k) {
                const double t = x[i];
                x[i] = x[k], x[k] = t;
                i++;
                if (k == 0)
                    break;
                k--;
            }
        }
        if (kth <= k)
            hi = k;
        else if (kth >= i)
            lo = i;
        else
            break;
    }
    return x[kth];
}

/* Each joint's quaternions in the hemisphere of the most similar (largest |<q_i, q_f>|) of
 * its last `window` frames that are not outliers (outlier frames are stepped over and not
 * counted, up to ROBUST_REALIGN_SKIP of them: a flip of ten frames at 30 fps is longer than
 * the window) (frames with none such: of their
 * predecessor). Where the steps are small that is the predecessor, as in the plain alignment;
 * across a glitch it is a frame before the glitch, whatever the glitch frames were. */
static void realign(size_t n, size_t j, double *q, const unsigned char *flag, size_t ldf,
                    size_t window)
{
    for (size_t k = 0; k < j; k++) {
        for (size_t i = 1; i < n; i++) {
            double *c = q + 4 * (i * j + k);
            const double *ref = c - 4 * j;
            double best = -1.0;
            size_t seen = 0; /* frames that are not outliers looked at */
            for (size_t f = i;
                 f-- > 0 && seen < window && f + window + ROBUST_REALIGN_SKIP >= i;) {
                if (flag[f * ldf + 1 + k])
                    continue;
                seen++;
                const double *p = q + 4 * (f * j + k);
                const double d = fabs(c[0] * p[0] + c[1] * p[1] + c[2] * p[2] + c[3] * p[3]);
                if (d > best)
                    best = d, ref = p;
                if (d > 0.866) /* within 60 degrees: no older frame is looked at */
                    break;
            }
            if (c[0] * ref[0] + c[1] * ref[1] + c[2] * ref[2] + c[3] * ref[3] < 0.0)
                c[0] = -c[0], c[1] = -c[1], c[2] = -c[2], c[3] = -c[3];
        }
    }
}

/* Angle between two unit quaternions, blind to their signs. */
static double angle_between(const double *a, const double *b)
{
    const double d = fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]);
    return 2.0 * acos(d < 1.0 ? d : 1.0);
}

/* The jump detector's scale: the largest of the steps d[lo..hi) (clipped to [1, n)). */
static double steps_max(const double *d, size_t n, size_t lo, size_t hi)
{
    double m = 0.0;
    for (size_t i = lo < 1 ? 1 : lo; i < hi && i < n; i++)
        m = fmax(m, d[i]);
    return m;
}

/*
 * A joint's part in the runs at the clip's ends that a flip's test cannot see (it needs a frame
 * on either side): where the body translation leaves a run of its first ends[0] frames by a
 * jump (or enters its last ends[1] frames by one; layers__end_runs: a converter's rest-pose
 * frame before the capture), the joint's frames of the run weigh 0 in w (stride ldw) when its
 * step out of the run passes ROBUST_FLIP_KAPPA S, S the largest step inside the run and in the
 * ROBUST_FLIP_SIDE steps beyond it. Returns the frames flagged.
 */
static size_t find_end_runs(size_t n, const double *steps, const size_t ends[2], double *w,
                            size_t ldw)
{
    size_t found = 0;
    if (ends[0]) {
        const size_t b = ends[0];
        const double sc =
            fmax(steps_max(steps, n, 1, b), steps_max(steps, n, b + 1, b + 1 + ROBUST_FLIP_SIDE));
        if (steps[b] > ROBUST_FLIP_KAPPA * sc) {
            for (size_t i = 0; i < b; i++) /* an undone flip stays undone */
                w[i * ldw] = w[i * ldw] < 0.0 ? w[i * ldw] : 0.0;
            found += b;
        }
    }
    if (ends[1]) {
        const size_t a = n - ends[1]; /* the last frames [a, n), entered by the step d_a */
        const double sc =
            fmax(steps_max(steps, n, a + 1, n),
                 steps_max(steps, n, a >= ROBUST_FLIP_SIDE ? a - ROBUST_FLIP_SIDE : 1, a));
        if (steps[a] > ROBUST_FLIP_KAPPA * sc) {
            for (size_t i = a; i < n; i++)
                w[i * ldw] = w[i * ldw] < 0.0 ? w[i * ldw] : 0.0;
            found += ends[1];
        }
    }
    return found;
}

/* |p_i - p_{i-1}| of n x 3 points; 0 at i = 0 */
static double step_at(const double *p, size_t i)
{
    if (i == 0)
        return 0.0;
    const double dx = p[3 * i] - p[3 * i - 3], dy = p[3 * i + 1] - p[3 * i - 2],
                 dz = p[3 * i + 2] - p[3 * i - 1];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* The largest of the steps [lo, hi) of p (clipped to [1, n)). */
static double point_steps_max(const double *p, size_t n, size_t lo, size_t hi)
{
    double m = 0.0;
    for (size_t i = lo < 1 ? 1 : lo; i < hi && i < n; i++)
        m = fmax(m, step_at(p, i));
    return m;
}

void layers__end_runs(size_t n, const double *p, size_t ends[2])
{
    ends[0] = ends[1] = 0;
    for (size_t b = 1; b <= ROBUST_FLIP_MAX && b + 2 * ROBUST_FLIP_SIDE + 2 <= n; b++) {
        const double sc = fmax(point_steps_max(p, n, 1, b),
                               point_steps_max(p, n, b + 1, b + 1 + ROBUST_FLIP_SIDE));
        const double d = step_at(p, b);
        if (d > ROBUST_END_KAPPA * sc && d > 0.0) {
            ends[0] = b;
            break;
        }
    }
    for (size_t r = 1; r <= ROBUST_FLIP_MAX && ends[0] + r + 2 * ROBUST_FLIP_SIDE + 2 <= n; r++) {
        const size_t a = n - r;
        const double sc =
            fmax(point_steps_max(p, n, a + 1, n),
                 point_steps_max(p, n, a >= ROBUST_FLIP_SIDE ? a - ROBUST_FLIP_SIDE : 1, a));
        const double d = step_at(p, a);
        if (d > ROBUST_END_KAPPA * sc && d > 0.0) {
            ends[1] = r;
            break;
        }
    }
}

/* The joints' steps into frame i of joint k (working quaternions q, n x j x 4); 0 at i = 0. */
static double rot_step(const double *q, size_t j, size_t k, size_t i)
{
    return i ? angle_between(q + 4 * (i * j + k), q + 4 * ((i - 1) * j + k)) : 0.0;
}

/* The largest of joint k's steps [lo, hi) (clipped to [1, n)). */
static double rot_steps_max(const double *q, size_t n, size_t j, size_t k, size_t lo, size_t hi)
{
    double m = 0.0;
    for (size_t i = lo < 1 ? 1 : lo; i < hi && i < n; i++)
        m = fmax(m, rot_step(q, j, k, i));
    return m;
}

/* Does the pose jump at step b, the edge of a run at a clip's end: do at least
   ROBUST_END_JOINTS joints step there by more than ROBUST_END_ANGLE and by more than
   ROBUST_END_KAPPA times each of their steps [in_lo, in_hi) (inside the run) and
   [out_lo, out_hi) (the ROBUST_FLIP_SIDE steps beyond it)? */
static int pose_jumps(const double *q, size_t n, size_t j, size_t b, size_t in_lo, size_t in_hi,
                      size_t out_lo, size_t out_hi)
{
    size_t count = 0;
    for (size_t k = 0; k < j; k++) {
        const double d = rot_step(q, j, k, b);
        if (!(d > ROBUST_END_ANGLE))
            continue;
        const double sc = fmax(rot_steps_max(q, n, j, k, in_lo, in_hi),
                               rot_steps_max(q, n, j, k, out_lo, out_hi));
        count += d > ROBUST_END_KAPPA * sc;
    }
    return count >= ROBUST_END_JOINTS;
}

void layers__pose_end_runs(size_t n, size_t j, const double *q, size_t ends[2])
{
    if (!ends[0])
        for (size_t b = 1; b <= ROBUST_FLIP_MAX && b + 2 * ROBUST_FLIP_SIDE + 2 <= n; b++)
            if (pose_jumps(q, n, j, b, 1, b, b + 1, b + 1 + ROBUST_FLIP_SIDE)) {
                ends[0] = b;
                break;
            }
    if (!ends[1])
        for (size_t r = 1; r <= ROBUST_FLIP_MAX && ends[0] + r + 2 * ROBUST_FLIP_SIDE + 2 <= n;
             r++) {
            const size_t a = n - r;
            if (pose_jumps(q, n, j, a, a + 1, n, a >= ROBUST_FLIP_SIDE ? a - ROBUST_FLIP_SIDE : 1,
                           a)) {
                ends[1] = r;
                break;
            }
        }
}

/* o = conj(a) b (rc 0) or a conj(b) (rc 1), quaternions as (w, x, y, z) arrays. */
static void qmul_conj(const double *a, const double *b, int rc, double *o)
{
    const mlr_quat r = rc ? common__qmul_wxyz(a[0], a[1], a[2], a[3], b[0], -b[1], -b[2], -b[3])
                          : common__qmul_wxyz(a[0], -a[1], -a[2], -a[3], b[0], b[1], b[2], b[3]);
    o[0] = r.w, o[1] = r.x, o[2] = r.y, o[3] = r.z;
}

/* The slerp from a to b (taken in a's hemisphere) at t, unit. */
static void slerp_unit(const double *a, const double *b, double t, double *o)
{
    const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    const double sg = dot < 0.0 ? -1.0 : 1.0, d = fabs(dot) < 1.0 ? fabs(dot) : 1.0;
    const double half = acos(d);
    double c0 = 1.0 - t, c1 = t;
    if (half > 1e-9) {
        const double sh = sin(half);
        c0 = sin((1.0 - t) * half) / sh, c1 = sin(t * half) / sh;
    }
    for (int c = 0; c < 4; c++)
        o[c] = c0 * a[c] + sg * c1 * b[c];
    const double nr = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3]);
    for (int c = 0; c < 4; c++)
        o[c] /= nr;
}

/* The step between two frames x -> y, near the identity (w >= 0): y conj(x) in the world
 * frame (wf 1), conj(x) y in the joint's own (wf 0). */
static void step_of(const double *x, const double *y, int wf, double *o)
{
    if (wf)
        qmul_conj(y, x, 1, o);
    else
        qmul_conj(x, y, 0, o);
    if (o[0] < 0.0)
        o[0] = -o[0], o[1] = -o[1], o[2] = -o[2], o[3] = -o[3];
}

/* The step across a run's edge: the mean (slerp at 1/2) of the step beside it outside the
 * run (NULL at the clip's end) and the one beside it inside. Returns its uncertainty: the
 * angle between the two (pi without the outside one). */
static double edge_step(const double *out, const double *in, double *o)
{
    if (!out) {
        memcpy(o, in, 4 * sizeof(double));
        return MLR_PI_R;
    }
    slerp_unit(out, in, 0.5, o);
    return angle_between(out, in);
}

/*
 * Undo a flip run [a, b) (at least 2 frames) of joint k whose corruption is a constant turn:
 * q_bad = q R (right form) or R q (left form). A constant turn leaves the steps inside the run
 * as they were, in the world frame (q(i+1) conj(q(i))) for the right form, in the joint's frame
 * (conj(q(i)) q(i+1)) for the left one. So the step across each edge of the run is estimated
 * as the mean of the steps beside it (outside the run and inside it), and R from it: at the
 * start against q(a-1) carried on by that step, at the end against q(b) carried back by it.
 * Where the two estimates of one form agree (their angle below jump / 4 and ROBUST_FLIP_AGREE;
 * the form with the closer pair), the run is rewritten as q_bad R^-1 (or R^-1 q_bad) with one
 * R for the run: the slerp between the two estimates that weighs each by the inverse square
 * of its uncertainty (the angle between the two steps its edge step is the mean of, at least
 * 0.01 rad: a joint that changes speed at one edge, a knee at 30 fps, makes that estimate the
 * weaker), and returns 1. Otherwise q is left as it is and 0 returned (the run is bridged by
 * the prior, as a run of one frame is, whose turn cannot be told from the motion).
 */
static int undo_flip(size_t n, size_t j, size_t k, double *q, size_t a, size_t b, double jump)
{
    if (b - a < 2)
        return 0;
    const size_t s4 = 4 * j;
    double *qk = q + 4 * k;
    const double *qa1 = qk + (a - 1) * s4, *qb0 = qk + b * s4;
    const double *xa = qk + a * s4, *xb = qk + (b - 1) * s4;
    double ra[2][4], rb[2][4], dis[2], ua[2], ub[2];
    for (int f = 0; f < 2; f++) { /* f 0: q_bad = q R (world-frame steps); 1: R q (own) */
        double so[4], si[4], se[4], p[4];
        /* start: q(a) = se q(a-1) (world) or q(a-1) se (own); R = conj(q) q_bad, q_bad conj(q) */
        if (a >= 2)
            step_of(qk + (a - 2) * s4, qa1, !f, so);
        step_of(xa, xa + s4, !f, si);
        ua[f] = edge_step(a >= 2 ? so : NULL, si, se);
        if (f == 0) {
            ik__qmul4(se, qa1, p);
            qmul_conj(p, xa, 0, ra[f]);
        } else {
            ik__qmul4(qa1, se, p);
            qmul_conj(xa, p, 1, ra[f]);
        }
        /* end: q(b-1) = conj(se) q(b) (world) or q(b) conj(se) (own) */
        if (b + 1 < n)
            step_of(qb0, qb0 + s4, !f, so);
        step_of(xb - s4, xb, !f, si);
        ub[f] = edge_step(b + 1 < n ? so : NULL, si, se);
        if (f == 0) {
            qmul_conj(se, qb0, 0, p);
            qmul_conj(p, xb, 0, rb[f]);
        } else {
            qmul_conj(qb0, se, 1, p);
            qmul_conj(xb, p, 1, rb[f]);
        }
        dis[f] = angle_between(ra[f], rb[f]);
    }
    const int f = dis[1] < dis[0];
    if (!(dis[f] < 0.25 * jump) || !(dis[f] < ROBUST_FLIP_AGREE))
        return 0;
    /* one turn: the two estimates weighed by the inverse squares of their uncertainties */
    const double va = ua[f] * ua[f] + ROBUST_FLIP_U2, vb = ub[f] * ub[f] + ROBUST_FLIP_U2;
    double r[4];
    slerp_unit(ra[f], rb[f], va / (va + vb), r);
    for (size_t i = a; i < b; i++) {
        double o[4];
        double *x = qk + i * s4;
        if (f == 0)
            qmul_conj(x, r, 1, o); /* q_bad conj(R) */
        else
            qmul_conj(r, x, 0, o); /* conj(R) q_bad */
        const double nr = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + o[3] * o[3]);
        const double sg =
            o[0] * qa1[0] + o[1] * qa1[1] + o[2] * qa1[2] + o[3] * qa1[3] < 0.0 ? -1.0 : 1.0;
        for (int c = 0; c < 4; c++)
            x[c] = sg * o[c] / nr;
    }
    return 1;
}

/*
 * Flips of a joint, found from its rotations alone: a run of frames [a, b) (1 <= b - a <=
 * ROBUST_FLIP_MAX frames, inside the clip) that the joint enters by a jump and leaves by a
 * jump back. With d_i the rotation angle from frame i - 1 to frame i (blind to the sign of the
 * quaternions, so q -> -q is no step), and the scale S the largest step around the run (the
 * ROBUST_FLIP_SIDE steps before it, those inside it, the ROBUST_FLIP_SIDE after it):
 * d_a and d_b both pass max(theta, ROBUST_FLIP_KAPPA S) (theta = half the gate), the frames
 * a - 1 and b are within (b - a + 1) S ROBUST_FLIP_BRIDGE + theta / 4 of each other (the joint
 * comes back where its speed would have taken it) and closer than half the smaller jump, and
 * every frame of the run is more than half the smaller jump off the slerp between them. The
 * shortest such run from each a is taken. The test looks at steps only, so it reads the same
 * at any frame rate: a burst of ten frames cannot drag a fit that is not there; real fast
 * motion has large steps all along, which raise S. Found runs get weight 0 in flag (1 byte
 * per frame, stride ldf); steps: n doubles of scratch. Returns the frames flagged.
 */
static size_t find_flips(size_t n, size_t j, size_t k, double *q, double theta,
                         const size_t ends[2], double *steps, double *w, size_t ldw)
{
    const double *qk = q + 4 * k;
    const size_t s4 = 4 * j;
    steps[0] = 0.0;
    for (size_t i = 1; i < n; i++)
        steps[i] = angle_between(qk + i * s4, qk + (i - 1) * s4);
    size_t found = 0;
    for (size_t a = 1; a + 1 < n; a++) {
        if (!(steps[a] > theta))
            continue;
        const double before =
            steps_max(steps, n, a >= ROBUST_FLIP_SIDE ? a - ROBUST_FLIP_SIDE : 1, a);
        for (size_t b = a + 1; b < n && b - a <= ROBUST_FLIP_MAX; b++) {
            if (!(steps[b] > theta))
                continue;
            const double jump = fmin(steps[a], steps[b]);
            const double sc = fmax(fmax(before, steps_max(steps, n, a + 1, b)),
                                   steps_max(steps, n, b + 1, b + 1 + ROBUST_FLIP_SIDE));
            if (!(jump > ROBUST_FLIP_KAPPA * sc))
                continue;
            const double *p0 = qk + (a - 1) * s4, *p1 = qk + b * s4;
            const double gap = angle_between(p0, p1);
            if (!(gap < 0.5 * jump) ||
                !(gap <= (double)(b - a + 1) * sc * ROBUST_FLIP_BRIDGE + 0.25 * theta))
                continue;
            /* every frame of the run off the slerp from p0 to p1 */
            const double dot = p0[0] * p1[0] + p0[1] * p1[1] + p0[2] * p1[2] + p0[3] * p1[3];
            const double sg = dot < 0.0 ? -1.0 : 1.0, half = 0.5 * gap;
            int off = 1;
            for (size_t i = a; i < b && off; i++) {
                const double t = (double)(i - a + 1) / (double)(b - a + 1);
                double c0 = 1.0 - t, c1 = t;
                if (half > 1e-9) {
                    const double sh = sin(half);
                    c0 = sin((1.0 - t) * half) / sh, c1 = sin(t * half) / sh;
                }
                double r[4];
                for (int c = 0; c < 4; c++)
                    r[c] = c0 * p0[c] + sg * c1 * p1[c];
                const double nr = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
                for (int c = 0; c < 4; c++)
                    r[c] /= nr;
                off = angle_between(qk + i * s4, r) > 0.5 * jump;
            }
            if (!off)
                continue;
            const double mark = undo_flip(n, j, k, q, a, b, jump) ? ROBUST_UNDONE : 0.0;
            for (size_t i = a; i < b; i++)
                w[i * ldw] = mark;
            found += b - a;
            a = b; /* the loop's a++ then looks past the run's last jump */
            break;
        }
    }
    found += find_end_runs(n, steps, ends, w, ldw);
    return found;
}

/* One group kind: ns systems of m channels, observations y (stride m ns), weights of system k
 * at frame i in rb->w[i ng + g0 + k] (g0: 1 for the joints, 0 for the translation). */
typedef struct rgroups {
    size_t ns, m, g0;
} rgroups;

/* cos^2 of half the rotation angle between a unit quaternion y and the direction of f. */
static inline double cos2_of(const double *y, const double *f)
{
    const double d = y[0] * f[0] + y[1] * f[1] + y[2] * f[2] + y[3] * f[3];
    const double nn = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] + f[3] * f[3];
    return d * d / (nn > 1e-300 ? nn : 1e-300);
}

/* Residual of frame i, system k: angle (m == 4) or distance (m == 3) to the fit. */
static double residual_of(const double *y, const double *f, size_t m)
{
    if (m == 4) {
        const double c2 = cos2_of(y, f);
        return 2.0 * acos(sqrt(c2 < 1.0 ? c2 : 1.0));
    }
    const double a = y[0] - f[0], b = y[1] - f[1], c = y[2] - f[2];
    return sqrt(a * a + b * b + c * c);
}

/* The reweighting loop of one kind; gate: per system (ns values); q: y itself when y holds
 * quaternions (realigned here), else NULL; buf: 3 m ns doubles; lev: n ns doubles. *any:
 * some weight < 1. */
static mlr_status reweight(mlr_layers *L, const mlr_layers_cfg *cfg, const rgroups *gk,
                           const double *y, double *q, const mlr_lay_robust *rb, double *fac,
                           double *fit, double *rhs, double *lev, double *s, double *gate,
                           double *buf, int *any, mlr_diag *diag)
{
    const size_t n = L->n, j = L->j, ng = 1 + j, ns = gk->ns, m = gk->m, mm = m * ns;
    mlr_lay_batch b = {n, ns, n, fac, fac + n * ns, fac + 2 * n * ns, NULL};
    double *wk = rb->wpk; /* n x ns: this kind's weights, packed */
    for (size_t k = 0; k < ns; k++)
        s[k] = cfg->robust_s;
    *any = 0;
    /* the flips found beforehand (weight 0 in rb->w; ROBUST_UNDONE where undone: weight 1,
     * flag 2) are outliers from the first fit on */
    int seeded = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned char *fl = L->outliers + i * ng + gk->g0;
        for (size_t k = 0; k < ns; k++) {
            const double w0 = rb->w[i * ng + gk->g0 + k];
            wk[i * ns + k] = w0 == 0.0 ? 0.0 : 1.0;
            fl[k] = (unsigned char)(w0 == 0.0 ? 1 : w0 < 0.0 ? 2 : 0);
            seeded |= w0 <= 0.0;
        }
    }
    if (seeded && q)
        realign(n, j, q, L->outliers, ng, cfg->robust_window);
    for (int it = 0; it < ROBUST_MAX_IT; it++) {
        b.w = it == 0 && !seeded ? NULL : wk;
        if (layers__batch_factor(&b, s))
            return common__diag_set(diag, MLR_E_SINGULAR, 0, 0,
                                    "outlier search: the smoothing of %zu frames failed", n);
        const double *obs = y;
        if (b.w) {
            for (size_t i = 0; i < n; i++)
                for (size_t k = 0; k < ns; k++)
                    for (size_t c = 0; c < m; c++)
                        rhs[i * mm + k * m + c] = wk[i * ns + k] * y[i * mm + k * m + c];
            obs = rhs;
        }
        layers__batch_solve(&b, m, obs, mm, fit, mm, buf);
        layers__batch_leverage(&b, buf, lev, buf + ns);
        if (it == 0 && gk->g0 == 0 && cfg->robust_length <= 0.0) {
            /* the translation's gate relative to its median residual */
            double *r = rhs;
            for (size_t i = 0; i < n; i++)
                r[i] = residual_of(y + i * mm, fit + i * mm, 3) / (1.0 - lev[i]);
            const double med = median_of(r, n);
            double scale = 0.0;
            for (size_t i = 0; i < n; i++)
                scale = fmax(scale, fabs(y[i * mm]) + fabs(y[i * mm + 1]) + fabs(y[i * mm + 2]));
            gate[0] = fmax(ROBUST_REL_GATE * med, 1e-9 * scale + 1e-300);
        }
        /* a cheap test first: a joint's deleted residual passes its gate only where the
         * residual angle passes gate (1 - largest leverage), a bound on the cosine, no acos */
        double *c2min = buf + 4 * ns; /* buf holds 12 ns doubles; [ns, 4 ns) the leverage's */
        if (m == 4) {
            for (size_t k = 0; k < ns; k++)
                c2min[k] = 0.0;
            for (size_t i = 0; i < n; i++)
                for (size_t k = 0; k < ns; k++)
                    c2min[k] = fmax(c2min[k], lev[i * ns + k]);
            for (size_t k = 0; k < ns; k++) {
                const double c = cos(0.5 * fmin(gate[k] * (1.0 - c2min[k]), MLR_PI_R));
                c2min[k] = c * c;
            }
        }
        int changed = 0, fresh = 0, some = 0;
        for (size_t i = 0; i < n; i++) {
            unsigned char *fl = L->outliers + i * ng + gk->g0;
            for (size_t k = 0; k < ns; k++) {
                const double *yk = y + i * mm + k * m, *fk = fit + i * mm + k * m;
                const double w0 = rb->w[i * ng + gk->g0 + k];
                double w = 1.0;
                if (w0 == 0.0)
                    w = 0.0; /* a flip */
                else if (w0 < 0.0)
                    w = 1.0; /* a flip undone: its frames count as they are now */
                else if (m != 4 || cos2_of(yk, fk) < c2min[k])
                    w = robust_weight(residual_of(yk, fk, m) / (1.0 - lev[i * ns + k]), gate[k]);
                const unsigned char f = w < 0.5 || w0 < 0.0;
                changed |= f != (fl[k] != 0);
                fresh |= f && !fl[k];
                some |= w < 1.0;
                fl[k] = (unsigned char)(w0 < 0.0 ? 2 : f);
                wk[i * ns + k] = w;
            }
        }
        for (size_t k = 0; k < ns; k++) { /* nearly every frame an outlier: not a glitch */
            size_t kept = 0;
            for (size_t i = 0; i < n && kept < 3; i++)
                kept += wk[i * ns + k] >= 0.5;
            if (kept < 3) {
                for (size_t i = 0; i < n; i++) { /* an undone flip stays undone */
                    const int u = rb->w[i * ng + gk->g0 + k] < 0.0;
                    wk[i * ns + k] = 1.0;
                    rb->w[i * ng + gk->g0 + k] = u ? ROBUST_UNDONE : 1.0;
                    L->outliers[i * ng + gk->g0 + k] = (unsigned char)(u ? 2 : 0);
                }
            }
        }
        some = 0;
        for (size_t i = 0; i < n * ns && !some; i++)
            some = wk[i] < 1.0;
        *any = some;
        if (!some || (it > 0 && !changed))
            break;
        if (fresh && q)
            realign(n, j, q, L->outliers, ng, cfg->robust_window);
    }
    /* an outlier frame weighs nothing in the layers: a weight of e^-10 times the square of a
     * flip would still outweigh the residual sums of GCV at weak smoothing; an undone flip
     * (flag 2) weighs 1 */
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < ns; k++) {
            const unsigned char o = L->outliers[i * ng + gk->g0 + k];
            rb->w[i * ng + gk->g0 + k] = o == 2 ? 1.0 : o ? 0.0 : wk[i * ns + k];
        }
    return MLR_OK;
}

mlr_status layers__robust_weights(mlr_layers *L, const mlr_layers_cfg *cfg, double *q,
                                  const double *root_pos, const mlr_lay_robust *rb, double *fac,
                                  double *fit, double *rhs, double *work, int *any, mlr_diag *diag)
{
    const size_t n = L->n, j = L->j, ng = 1 + j;
    memset(L->outliers, 0, n * ng);
    for (size_t i = 0; i < n * ng; i++)
        rb->w[i] = 1.0;
    double *s = work, *gate = work + j, *buf = work + 2 * j;
    size_t ends[2] = {0, 0};
    L->end_runs[0] = L->end_runs[1] = 0;
    if (root_pos) /* the translation's end runs */
        layers__end_runs(n, root_pos, ends);
    /* and the pose's, where the translation stays (CMU's rest frame before a capture, with the
       root where the capture starts) */
    layers__pose_end_runs(n, j, q, ends);
    if (root_pos) { /* outliers of the translation from the first fit on */
        for (size_t i = 0; i < ends[0]; i++)
            rb->w[i * ng] = 0.0;
        for (size_t i = n - ends[1]; i < n; i++)
            rb->w[i * ng] = 0.0;
    }
    for (size_t k = 0; k < j; k++) {
        gate[k] = cfg->robust_angle;
        find_flips(n, j, k, q, 0.5 * cfg->robust_angle, ends, rhs, rb->w + 1 + k, ng);
    }
    const rgroups joints = {j, 4, 1};
    int any_j = 0, any_r = 0;
    double *lev = rhs + 4 * n * j; /* rhs holds 5 n j doubles */
    mlr_status rc =
        reweight(L, cfg, &joints, q, q, rb, fac, fit, rhs, lev, s, gate, buf, &any_j, diag);
    if (rc != MLR_OK)
        return rc;
    if (root_pos) {
        const rgroups root = {1, 3, 0};
        gate[0] = cfg->robust_length;
        rc = reweight(L, cfg, &root, root_pos, NULL, rb, fac, fit, rhs, lev, s, gate, buf, &any_r,
                      diag);
        if (rc != MLR_OK)
            return rc;
    }
    for (int e = 0; e < 2; e++) { /* kept where the translation's fits kept them outliers */
        const size_t lo = e ? n - ends[1] : 0, hi = e ? n : ends[0];
        int all = hi > lo;
        for (size_t i = lo; i < hi && all && root_pos; i++)
            all = L->outliers[i * ng] != 0;
        L->end_runs[e] = all ? hi - lo : 0;
    }
    *any = any_j || any_r;
    return MLR_OK;
}
