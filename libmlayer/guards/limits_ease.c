/* Joint limits eased in time: a look-ahead limiter on the limits' corrections.
 *
 * The limits (limits.c) saturate each frame's rotation on its own. Where a fast joint runs
 * into its bound (a knee flexing at 8 rad/s in the swing of an exaggerated walk), that brakes
 * it within a few frames: the foot's acceleration was up to 3.7x the unlimited synthesis's on
 * real walks at alpha 2-3. An audio limiter solves the same problem by looking ahead: the gain
 * reduction is the largest one needed within a window, smoothed. Here the reduction is the
 * limits' correction, the rotation c = limited * conj(raw) as a rotation vector in the parent's
 * frame. Each of its components is split into its positive and its negative part; each part
 * goes through a running maximum over +-EASE_TRUNC sigma and then a Gaussian of that radius
 * (sigma EASE_SIGMA seconds), so that it is smooth in time and, where the correction keeps its
 * sign, at least as large as at every frame of the window (the running maximum covers the
 * Gaussian's support). The eased rotation is exp(eased correction) * raw.
 *
 * Measured with plausibility_check.py's foot points and acceleration (limits on, contacts and
 * floor off): Xia's walks at alpha 2-3 from 2.6-3.7x the synthesis's to 0.7-0.9x, CMU/FAIR's
 * jumps from 3.1-3.3x to 0.7x. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "guards/limits_internal.h"
#include "common/mlr_internal.h"
#include "math/quat_internal.h"

#define EASE_SIGMA 0.04 /* seconds */
#define EASE_TRUNC 2.5  /* the Gaussian's support and the running maximum's radius, in sigmas */
#define EASE_DEQUE 1024 /* the running maximum's deque, in frames */

size_t limits__ease_kernel(double sigma, double *k)
{
    const size_t r = (size_t)ceil(EASE_TRUNC * sigma);
    double ks = 0.0;
    for (size_t d = 0; d <= r; d++) {
        k[d] = exp(-0.5 * ((double)d / sigma) * ((double)d / sigma));
        ks += d ? 2.0 * k[d] : k[d];
    }
    for (size_t d = 0; d <= r; d++)
        k[d] /= ks;
    return r;
}

/* tmp[f] = the largest of x over [f - r, f + r] (clamped to the clip), the first of equal
   ones (as a scan from f - r keeps it): a deque of the indices whose values no later one in
   the window exceeds, O(n) however wide the window; the scan where the window is wider than
   the deque (r > 511: sigma 40 ms at over 5 kHz). */
static void running_max(const double *x, size_t n, size_t r, double *tmp)
{
    const size_t w = 2 * r + 1;
    if (w > EASE_DEQUE) {
        for (size_t f = 0; f < n; f++) {
            const size_t a = f > r ? f - r : 0, b = f + r < n ? f + r : n - 1;
            double m = x[a];
            for (size_t i = a + 1; i <= b; i++)
                m = x[i] > m ? x[i] : m;
            tmp[f] = m;
        }
        return;
    }
    size_t q[EASE_DEQUE], head = 0, len = 0, pushed = 0; /* q: a ring of w */
    for (size_t f = 0; f < n; f++) {
        const size_t a = f > r ? f - r : 0, b = f + r < n ? f + r : n - 1;
        while (len && q[head] < a)
            head = head + 1 == w ? 0 : head + 1, len--;
        for (; pushed <= b; pushed++) {
            while (len && x[q[(head + len - 1) % w]] < x[pushed])
                len--;
            q[(head + len) % w] = pushed;
            len++;
        }
        tmp[f] = x[q[head]];
    }
}

void limits__ease_lookahead(const double *x, size_t n, const double *k, size_t r, double *tmp,
                            double *y)
{
    running_max(x, n, r, tmp);
    /* The Gaussian, the edge values repeated. A frame whose window [f - r, f + r] holds only
       zeros gets 0, as the sum would give it; the corrections are sparse (a joint near its
       bound, a chain under the floor), so only the frames within r of a value that is not
       zero are summed (NaN counts as not zero). */
    size_t next = 0, last = SIZE_MAX; /* the first nonzero at or after f; the last before */
    for (size_t f = 0; f < n; f++) {
        const size_t a = f > r ? f - r : 0, b = f + r < n ? f + r : n - 1;
        if (next < f)
            next = f;
        while (next < n && tmp[next] == 0.0)
            next++;
        const int quiet = next > b && (last == SIZE_MAX || last < a);
        if (tmp[f] != 0.0)
            last = f;
        if (quiet) {
            y[f] = 0.0;
            continue;
        }
        double s = k[0] * tmp[f];
        for (size_t d = 1; d <= r; d++)
            s += k[d] * (tmp[f >= d ? f - d : 0] + tmp[f + d < n ? f + d : n - 1]);
        y[f] = s;
    }
}

typedef struct ease_work {
    double *v, *eased;  /* N x 3: the correction's rotation vectors, the eased ones */
    double *tmp, *x;    /* N each: the running maximum's output, a part to ease */
    double *pos;        /* N: an eased part */
    double *kernel;     /* r + 1 */
    size_t r;
} ease_work;

/* out = x through the running maximum and the Gaussian. */
static void ease_signal(const ease_work *w, const double *x, size_t N, double *out)
{
    limits__ease_lookahead(x, N, w->kernel, w->r, w->tmp, out);
}

/* Component k of the eased correction into w->eased: its positive part eased minus its
   negative part eased. Where the two overlap (a knee swung from one bound to the other within
   0.2 s: CMU and Xia walks at alpha 2-3) their difference can fall short of a frame's own
   correction; the caller sees to that (limits__ease's comment in limits_internal.h).
   Keeping the frame's own correction there instead jumped by up to 30 degrees in a frame (the
   other bound's eased part is large there); shrinking the window there (so that the parts
   never overlap) braked Xia's knees within a few frames again (3.3x the synthesis's foot
   acceleration, 0.8x this way). */
static void ease_component(const ease_work *w, size_t N, int k)
{
    const double *c = w->v + k;
    double *e = w->eased + k;
    for (size_t f = 0; f < N; f++)
        e[3 * f] = 0.0;
    for (int sign = -1; sign <= 1; sign += 2) {
        int any = 0;
        for (size_t f = 0; f < N; f++) {
            const double x = sign * c[3 * f];
            w->x[f] = x > 0 ? x : 0.0;
            any |= x > 0;
        }
        if (!any)
            continue;
        ease_signal(w, w->x, N, w->pos);
        for (size_t f = 0; f < N; f++)
            e[3 * f] += sign * w->pos[f];
    }
}

/* The eased correction of joint j into w->eased; returns 0 when the joint has none. */
static int ease_joint(const double *raw, const double *lim, size_t N, size_t J, size_t j,
                      const ease_work *w)
{
    int any = 0;
    for (size_t f = 0; f < N; f++) {
        const double *a = raw + 4 * (f * J + j), *b = lim + 4 * (f * J + j);
        if (memcmp(a, b, 4 * sizeof(double)) == 0) { /* not limited: no correction (the
                                                        product below leaves 1e-17 there) */
            w->v[3 * f] = w->v[3 * f + 1] = w->v[3 * f + 2] = 0.0;
            continue;
        }
        const double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3]);
        const double ac[4] = {a[0] / n, -a[1] / n, -a[2] / n, -a[3] / n};
        double c[4];
        ik__qmul4(b, ac, c);
        quat__rotvec(c, w->v + 3 * f);
        any |= w->v[3 * f] != 0 || w->v[3 * f + 1] != 0 || w->v[3 * f + 2] != 0;
    }
    if (!any)
        return 0;
    for (int k = 0; k < 3; k++)
        ease_component(w, N, k);
    return 1;
}

mlr_status limits__ease(const double *raw, double *lim, size_t N, size_t J, double fps,
                        const size_t *counts, const mlr_allocator *alloc)
{
    if (N < 3)
        return MLR_OK;
    const double sigma = EASE_SIGMA * fps;
    const size_t r = (size_t)ceil(EASE_TRUNC * sigma);
    if (!(sigma > 0) || r == 0)
        return MLR_OK;
    size_t bytes = 0;
    if (common__mul_size(9 * N + r + 1, sizeof(double), &bytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    if (!buf)
        return MLR_E_NO_MEMORY;
    ease_work w = {buf, buf + 3 * N, buf + 6 * N, buf + 7 * N, buf + 8 * N, buf + 9 * N, r};
    limits__ease_kernel(sigma, w.kernel);
    for (size_t j = 0; j < J; j++) {
        if ((counts && counts[j] == 0) || !ease_joint(raw, lim, N, J, j, &w))
            continue;
        for (size_t f = 0; f < N; f++) {
            const double *e = w.eased + 3 * f;
            if (e[0] == 0 && e[1] == 0 && e[2] == 0)
                continue;
            const double *a = raw + 4 * (f * J + j);
            double *b = lim + 4 * (f * J + j);
            const double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3]);
            const double an[4] = {a[0] / n, a[1] / n, a[2] / n, a[3] / n};
            double c[4], q[4];
            quat__rotvec_quat(e, c);
            ik__qmul4(c, an, q);
            /* the hemisphere of the limited rotation it replaces */
            const double sg = q[0] * b[0] + q[1] * b[1] + q[2] * b[2] + q[3] * b[3] < 0 ? -1 : 1;
            for (int i = 0; i < 4; i++)
                b[i] = sg * q[i];
        }
    }
    common__free(alloc, buf, bytes);
    return MLR_OK;
}
