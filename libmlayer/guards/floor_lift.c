/* The whole body raised smoothly by a need in time: the floor guard's last word (guards.c,
 * raise_to_floor), what is still below the floor after every other guard.
 *
 * A lift that covers the need at every frame and enters and leaves over ramps that grow with
 * its size. The ramps were 0.1 s whatever the size: a lift of 10% of body height on an
 * elephant standing still (Truebones' idle, alpha 3) then popped its feet 2.8x the synthesis's
 * own largest acceleration (tools/plausibility_check.py's pop ratio). Now each stretch of need
 * takes the half width that keeps the lift's second difference within half the clip's own.
 */
#include "guards/floor_lift_internal.h"

#include "common/mlr_internal.h"

#include <math.h>
#include <string.h>

#define LIFT_PI 3.14159265358979323846
#define LIFT_MIN_SECONDS 0.1 /* the shortest half width */
#define LIFT_MAX_SECONDS 1.0 /* the longest */

size_t floor_lift__half_width(double peak, double a_ref, double fps)
{
    const double lo = fmax(1.0, round(LIFT_MIN_SECONDS * fps));
    const double hi = fmax(lo, round(LIFT_MAX_SECONDS * fps));
    if (!(a_ref > 0.0))
        return (size_t)hi;
    /* the smoothed step's slope is the window over its sum, about h + 1; the window's slope
       is at most pi / (2 (h + 1)): so peak * pi / (2 (h + 1)^2) <= a_ref / 2 */
    const double h = ceil(sqrt(LIFT_PI * fmax(peak, 0.0) / a_ref)) - 1.0;
    return (size_t)(h < lo ? lo : h > hi ? hi : h);
}

mlr_status floor_lift__smooth(size_t N, double fps, const double *need, double a_ref, int up,
                              double *root, const mlr_allocator *alloc)
{
    return floor_lift__envelope(N, fps, need, a_ref, root + up, 3, alloc);
}

mlr_status floor_lift__envelope(size_t N, double fps, const double *need, double a_ref,
                                double *out, size_t stride, const mlr_allocator *alloc)
{
    if (N == 0)
        return MLR_OK;
    const size_t hmax = floor_lift__half_width(0.0, 0.0, fps);
    /* scratch: the stretches (first frame, last frame, half width), the running maximum, the
       window's weights */
    size_t nseg, nd, bytes;
    if (common__mul_size(N, 3 * sizeof(size_t), &nseg) != MLR_OK ||
        common__mul_size(N + 2 * hmax + 1, sizeof(double), &nd) != MLR_OK || nseg > SIZE_MAX - nd)
        return MLR_E_OVERFLOW;
    bytes = nseg + nd;
    void *buf = common__alloc(alloc, bytes);
    if (!buf)
        return MLR_E_NO_MEMORY;
    double *wide = buf, *wtab = wide + N;
    size_t *seg = (size_t *)(void *)(wtab + 2 * hmax + 1);
    size_t n = 0;
    for (size_t f = 0; f < N; f++) {
        if (!(need[f] > 0.0))
            continue;
        size_t e = f;
        double peak = need[f];
        while (e + 1 < N && need[e + 1] > 0.0)
            peak = common__fmax(peak, need[++e]);
        size_t a = f, h = floor_lift__half_width(peak, a_ref, fps);
        /* one with the stretches before while the reaches (2h each side) meet */
        while (n > 0 && seg[3 * (n - 1) + 1] + 2 * seg[3 * (n - 1) + 2] + 2 * h + 1 >= a) {
            n--;
            a = seg[3 * n];
            peak = 0.0;
            for (size_t k = a; k <= e; k++)
                peak = common__fmax(peak, need[k]);
            const size_t h2 = floor_lift__half_width(peak, a_ref, fps);
            h = h2 > h ? h2 : h;
            h = seg[3 * n + 2] > h ? seg[3 * n + 2] : h;
        }
        seg[3 * n] = a, seg[3 * n + 1] = e, seg[3 * n + 2] = h;
        n++;
        f = e;
    }
    for (size_t s = 0; s < n; s++) {
        const size_t a = seg[3 * s], e = seg[3 * s + 1], h = seg[3 * s + 2];
        for (size_t i = 0; i <= 2 * h; i++) {
            const double x = ((double)i - (double)h) / (double)(h + 1);
            wtab[i] = 0.5 * (1.0 + cos(LIFT_PI * x));
        }
        /* the running maximum over +-h, on [a - h, e + h] */
        const size_t wa = a > h ? a - h : 0, we = e + h < N ? e + h : N - 1;
        for (size_t f = wa; f <= we; f++) {
            const size_t lo = f > h ? f - h : 0, hi = f + h < N ? f + h : N - 1;
            double m = 0.0;
            for (size_t k = lo > a ? lo : a; k <= hi && k <= e; k++)
                m = common__fmax(m, need[k]);
            wide[f] = m;
        }
        /* its raised-cosine average over +-h, on [a - 2h, e + 2h] */
        const size_t la = a > 2 * h ? a - 2 * h : 0, le = e + 2 * h < N ? e + 2 * h : N - 1;
        for (size_t f = la; f <= le; f++) {
            const size_t lo = f > h ? f - h : 0, hi = f + h < N ? f + h : N - 1;
            double acc = 0.0, wsum = 0.0;
            for (size_t k = lo; k <= hi; k++) {
                const double w = wtab[k + h - f];
                acc += k >= wa && k <= we ? w * wide[k] : 0.0;
                wsum += w;
            }
            out[stride * f] += acc / wsum;
        }
    }
    common__free(alloc, buf, bytes);
    return MLR_OK;
}
