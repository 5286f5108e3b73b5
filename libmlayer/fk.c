/* Forward kinematics, batched over frames. Allocates only for scratch world rotations of big
 * skeletons when the caller does not want them. Nothing here prints or keeps state. */
#include "bvh_internal.h"

#define FK_STACK_JOINTS 256

static mlr_status check_skeleton(size_t n_joints, const int32_t *parents, size_t n_trans,
                                 const int32_t *trans_joints)
{
    if (n_joints == 0 || n_joints > BVH_MAX_JOINTS || parents[0] != -1)
        return MLR_E_INVALID_ARG;
    for (size_t j = 1; j < n_joints; j++)
        if (parents[j] < 0 || (size_t)parents[j] >= j)
            return MLR_E_INVALID_ARG;
    for (size_t k = 0; k < n_trans; k++)
        if (trans_joints[k] < 1 || (size_t)trans_joints[k] >= n_joints ||
            (k && trans_joints[k] <= trans_joints[k - 1]))
            return MLR_E_INVALID_ARG;
    return MLR_OK;
}

/* One frame. wr: J world rotations (output or scratch). */
static void fk_frame(size_t J, const int32_t *parents, const double *offsets,
                     const double *root_pos, const double *rot, size_t P,
                     const int32_t *trans_joints, const double *trans, double *wp, mlr_quat *wr)
{
    wr[0].w = rot[0];
    wr[0].x = rot[1];
    wr[0].y = rot[2];
    wr[0].z = rot[3];
    const double *t0 = root_pos ? root_pos : offsets;
    wp[0] = t0[0];
    wp[1] = t0[1];
    wp[2] = t0[2];
    size_t k = 0;
    for (size_t j = 1; j < J; j++) {
        const size_t p = (size_t)parents[j];
        const double *t = offsets + 3 * j;
        if (k < P && (size_t)trans_joints[k] == j)
            t = trans + 3 * k++;
        const mlr_quat q = {rot[4 * j], rot[4 * j + 1], rot[4 * j + 2], rot[4 * j + 3]};
        mlr_quat_mul_inline(&wr[p], &q, &wr[j]);
        double r[3];
        mlr_quat_rotate_inline(&wr[p], t, r);
        wp[3 * j] = wp[3 * p] + r[0];
        wp[3 * j + 1] = wp[3 * p + 1] + r[1];
        wp[3 * j + 2] = wp[3 * p + 2] + r[2];
    }
}

static mlr_status fk_run(size_t N, size_t J, const int32_t *parents, const double *offsets,
                         const double *root_pos, const double *rot, size_t P,
                         const int32_t *trans_joints, const double *trans, double *world_pos,
                         double *world_rot, const mlr_allocator *alloc)
{
    mlr_quat stack_scratch[FK_STACK_JOINTS];
    mlr_quat *scratch = stack_scratch;
    mlr_allocator a;
    size_t scratch_bytes = 0;
    if (!world_rot && J > FK_STACK_JOINTS && N > 0) {
        mlr_allocator_resolve(alloc, &a);
        if (mlr_mul_size(J, sizeof(mlr_quat), &scratch_bytes) != MLR_OK)
            return MLR_E_OVERFLOW;
        scratch = mlr_alloc(&a, scratch_bytes);
        if (!scratch)
            return MLR_E_NO_MEMORY;
    }
    for (size_t f = 0; f < N; f++) {
        mlr_quat *wr = world_rot ? (mlr_quat *)(void *)(world_rot + 4 * J * f) : scratch;
        fk_frame(J, parents, offsets, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f, P,
                 trans_joints, P ? trans + 3 * P * f : NULL, world_pos + 3 * J * f, wr);
    }
    if (scratch != stack_scratch)
        mlr_free(&a, scratch, scratch_bytes);
    return MLR_OK;
}

mlr_status mlr_fk_arrays(size_t n_frames, size_t n_joints, const int32_t *parents,
                         const double *offsets, const double *root_pos, const double *rot,
                         size_t n_trans, const int32_t *trans_joints, const double *trans,
                         double *world_pos, double *world_rot, const mlr_allocator *alloc)
{
    if (!parents || !offsets || (n_trans && (!trans_joints || !trans)) ||
        (n_frames && (!rot || !world_pos)))
        return MLR_E_INVALID_ARG;
    mlr_status s = check_skeleton(n_joints, parents, n_trans, trans_joints);
    if (s != MLR_OK)
        return s;
    size_t nj;
    if (mlr_mul_size(n_frames, n_joints, &nj) || mlr_mul_size(nj, 4, &nj))
        return MLR_E_OVERFLOW;
    return fk_run(n_frames, n_joints, parents, offsets, root_pos, rot, n_trans, trans_joints,
                  trans, world_pos, world_rot, alloc);
}

mlr_status mlr_fk_motion(const mlr_motion *m, size_t begin, size_t count, double *world_pos,
                         double *world_rot)
{
    if (!m || begin > m->n_frames || count > m->n_frames - begin || (count && !world_pos))
        return MLR_E_INVALID_ARG;
    const size_t J = m->n_joints, P = m->n_trans;
    return fk_run(count, J, m->parents, m->offsets, count ? m->root_pos + 3 * begin : NULL,
                  count ? m->rot + 4 * J * begin : NULL, P, m->trans_joints,
                  (count && P) ? m->trans + 3 * P * begin : NULL, world_pos, world_rot,
                  &m->alloc);
}
