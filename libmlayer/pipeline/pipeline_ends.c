/*
 * The runs at a clip's ends that the robust decomposition left out (a converter's rest pose
 * before or after the capture, mlr_layers_get_end_runs): no pose of the motion is known there.
 * Extrapolated, the bridge put a walk's toes 1% of body height under the floor, and the rest
 * pose's standing legs under the bridged root 29%.
 *
 * A denoise passes them through as they are, so a clean clip comes back unchanged. Any other
 * alpha holds the result's pose next to the run over it: a rest pose is not motion to
 * exaggerate, and passed through it met the stylized and guarded first pose with a jump that no
 * guard sees (Daz CMU 10_03 at alpha 2: a foot's acceleration 1.9x the larger of the input's and
 * the synthesis's; a pybvh CMU 12_01, 2.2x). The held pose is raised, by one height over the
 * run, where a point of it would be deeper under the floor than the input's same point on a
 * frame of the run (the input's rest pose stands on its toes' tips where the capture's first
 * pose sinks them: Daz CMU 14_19 at alpha 2, 0.8% of body height).
 */
#include "pipeline/pipeline_internal.h"

#include <math.h>
#include <string.h>

#include "mlayer/mlr_fk.h"

/* The height along up of every joint and End Site of frame f (pos, wrot: one frame's forward
   kinematics, J joints) into h (J + E). */
static void heights(const mlr_rig *rig, const double *pos, const double *wrot, int up, double *h)
{
    const size_t J = rig->n_joints;
    for (size_t j = 0; j < J; j++)
        h[j] = pos[3 * j + (size_t)up];
    for (size_t e = 0; e < rig->n_end_sites; e++) {
        const size_t j = (size_t)rig->end_site_parents[e];
        double v[3];
        common__quat_rotate_inline((const mlr_quat *)(const void *)(wrot + 4 * j),
                                   rig->end_site_offsets + 3 * e, v);
        h[J + e] = pos[3 * j + (size_t)up] + v[up];
    }
}

/* One frame's forward kinematics of (root, rot, trans) at frame f into pos, wrot. */
static mlr_status fk_frame(const mlr_rig *rig, size_t f, const double *root, const double *rot,
                           const double *trans, double *pos, double *wrot,
                           const mlr_allocator *alloc)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    return mlr_fk_arrays(1, J, rig->parents, rig->offsets, root + 3 * f, rot + 4 * J * f, P,
                         rig->trans_joints, P ? trans + 3 * P * f : NULL, pos, wrot, alloc, NULL);
}

/* The held frames [lo, hi) raised along up, all by one height: the most that the held pose's
   points go deeper under floor than the input's same points on a frame of the run. */
static mlr_status raise_held(const mlr_rig *rig, const double *in_root, const double *in_rot,
                             const double *in_trans, size_t lo, size_t hi, double floor, int up,
                             double *root, const double *rot, const double *trans,
                             const mlr_allocator *alloc)
{
    const size_t J = rig->n_joints, K = J + rig->n_end_sites;
    size_t n = 0, bytes = 0;
    if (common__mul_size(J, 7, &n) != MLR_OK ||
        common__mul_size(n + 2 * K, sizeof(double), &bytes) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *buf = common__alloc(alloc, bytes);
    if (!buf)
        return MLR_E_NO_MEMORY;
    double *pos = buf, *wrot = pos + 3 * J, *h_held = wrot + 4 * J, *h_in = h_held + K;
    double need = 0.0;
    mlr_status s = fk_frame(rig, lo, root, rot, trans, pos, wrot, alloc);
    if (s == MLR_OK)
        heights(rig, pos, wrot, up, h_held);
    for (size_t i = lo; i < hi && s == MLR_OK; i++) {
        if ((s = fk_frame(rig, i, in_root, in_rot, in_trans, pos, wrot, alloc)) != MLR_OK)
            break;
        heights(rig, pos, wrot, up, h_in);
        for (size_t k = 0; k < K; k++)
            need = common__fmax(need, common__fmax(0.0, floor - h_held[k]) -
                                          common__fmax(0.0, floor - h_in[k]));
    }
    for (size_t i = lo; i < hi && s == MLR_OK; i++) /* one lift: a held pose does not move */
        root[3 * i + (size_t)up] += need;
    common__free(alloc, buf, bytes);
    return s;
}

mlr_status pipeline__fill_end_runs(const mlr_rig *rig, size_t N, const size_t ends[2], int denoise,
                                   double floor, int up, const double *in_root,
                                   const double *in_rot, const double *in_trans, double *root,
                                   double *rot, double *trans, const mlr_allocator *alloc)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    for (int e = 0; e < 2; e++) {
        const size_t lo = e ? N - ends[1] : 0, hi = e ? N : ends[0];
        if (lo >= hi || hi - lo >= N)
            continue;
        const size_t next = e ? lo - 1 : hi; /* the result's frame next to the run */
        for (size_t i = lo; i < hi; i++) {
            const size_t k = denoise ? i : next;
            memcpy(root + 3 * i, (denoise ? in_root : root) + 3 * k, 3 * sizeof(double));
            memcpy(rot + 4 * J * i, (denoise ? in_rot : rot) + 4 * J * k, 4 * J * sizeof(double));
            if (P)
                memcpy(trans + 3 * P * i, (denoise ? in_trans : trans) + 3 * P * k,
                       3 * P * sizeof(double));
        }
        if (!denoise && isfinite(floor) && up >= 0 && up < 3) {
            mlr_status s = raise_held(rig, in_root, in_rot, in_trans, lo, hi, floor, up, root, rot,
                                      trans, alloc);
            if (s != MLR_OK)
                return s;
        }
    }
    return MLR_OK;
}
