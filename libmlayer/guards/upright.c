/*
 * A body that stands on its head along the up axis, found so that the guards can say so.
 *
 * Video pose estimators write image coordinates, whose y points down: MediaPipe's and Azure
 * Kinect's BVH exports stand on their heads along +Y (MediaPipe's cxk dance: the feet's median
 * height +67, the head's -49, the hips at 0). mlr_rig_up_axis finds the axis but not its sign,
 * and the guards measure heights along +up: they take the head and the hands for the body's
 * lowest points, and the floor from the feet's contacts lies above them (with the contact and
 * floor guards on, cxk's hands turned by up to 86 degrees a frame in denoise; by none with
 * them off). The guards note it at create
 * (mlr_guards_create's diag, Python's MlayerWarning). Turning such a body upright inside the
 * guards (a half turn of its root, and back) was tried: right for the body, but a measure that
 * takes +Y as up then sees its head 5-18% of body height under its floor; the clip is better
 * turned upright by its owner, once.
 */
#include "guards/upright_internal.h"

#include "common/mlr_internal.h"
#include "guards/contacts_internal.h"

mlr_status upright__upside_down(const mlr_rig *rig, size_t N, const double *wpos, int up,
                                const mlr_allocator *alloc, int *upside_down)
{
    const size_t J = rig->n_joints;
    *upside_down = 0;
    if (N == 0 || !rig->names)
        return MLR_OK;
    size_t bytes = 0, ibytes = 0, n_feet = 0;
    if (common__mul_size(2 * N, sizeof(double), &bytes) != MLR_OK ||
        common__mul_size(J, sizeof(size_t), &ibytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *feet = common__alloc(alloc, bytes);
    size_t *idx = common__alloc(alloc, ibytes); /* the foot joints, found once */
    if (!feet || !idx) {
        common__free(alloc, feet, bytes);
        common__free(alloc, idx, ibytes);
        return MLR_E_NO_MEMORY;
    }
    double *body = feet + N;
    for (size_t j = 1; j < J; j++)
        if (contacts__is_foot_name(rig->names[j]))
            idx[n_feet++] = j;
    for (size_t f = 0; n_feet && f < N; f++) {
        const double *p = wpos + 3 * f * J;
        double s = 0.0, all = 0.0;
        for (size_t j = 0; j < J; j++)
            all += p[3 * j + (size_t)up];
        for (size_t i = 0; i < n_feet; i++)
            s += p[3 * idx[i] + (size_t)up];
        feet[f] = s / (double)n_feet;
        body[f] = all / (double)J;
    }
    if (n_feet)
        *upside_down = common__median(feet, N) > common__median(body, N);
    common__free(alloc, feet, bytes);
    common__free(alloc, idx, ibytes);
    return MLR_OK;
}
