/* Forward kinematics, batched over frames. Allocates only for scratch world rotations of big
 * skeletons when the caller does not want them. Nothing here prints or keeps state. */
#include "bvh_internal.h"

#define FK_STACK_JOINTS 256

static mlr_status check_skeleton(size_t n_joints, const int32_t *parents, size_t n_trans,
                                 const int32_t *trans_joints, mlr_diag *diag)
{
    if (n_joints == 0 || n_joints > BVH_MAX_JOINTS)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "fk: %zu joints, not in [1, %zu]",
                            n_joints, BVH_MAX_JOINTS);
    if (parents[0] != -1)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "fk: parents[0] is %d, not -1",
                            (int)parents[0]);
    for (size_t j = 1; j < n_joints; j++)
        if (parents[j] < 0 || (size_t)parents[j] >= j)
            return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "fk: parents[%zu] is %d, not in [0, %zu)", j, (int)parents[j], j);
    for (size_t k = 0; k < n_trans; k++)
        if (trans_joints[k] < 1 || (size_t)trans_joints[k] >= n_joints ||
            (k && trans_joints[k] <= trans_joints[k - 1]))
            return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "fk: trans_joints[%zu] is %d: not in [1, %zu) or not increasing",
                                k, (int)trans_joints[k], n_joints);
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
        mlr_fk_joint_inline(&wr[p], wp + 3 * p, &q, t, &wr[j], wp + 3 * j);
    }
}

/* FK_BLOCK frames at once, joint by joint, in structure-of-arrays scratch (s: 7 * FK_BLOCK
 * doubles per joint: w x y z of the world rotation, then the world position, lane fastest) so
 * that the lane loops vectorize. Every lane does the operations of mlr_fk_joint_inline in its
 * order (the library builds with -ffp-contract=off): the bits are those of fk_frame. rot, wp and
 * wr (NULL: not wanted) start at the block's first frame; root_pos and trans too, or NULL. */
#define FK_BLOCK 8
#define FK_BLOCK_STACK_JOINTS 64 /* 28 KiB */

MLR_CLONES_AVX2
static void fk_block(size_t J, const int32_t *parents, const double *offsets,
                     const double *root_pos, const double *rot, size_t P,
                     const int32_t *trans_joints, const double *trans, double *wp, double *wr,
                     double *s)
{
    enum { B = FK_BLOCK };
    const size_t sr = 4 * J, sp = 3 * J, st = 3 * P;
    for (size_t l = 0; l < B; l++) {
        for (size_t c = 0; c < 4; c++)
            s[c * B + l] = rot[sr * l + c];
        for (size_t c = 0; c < 3; c++)
            s[(4 + c) * B + l] = root_pos ? root_pos[3 * l + c] : offsets[c];
    }
    size_t k = 0;
    for (size_t j = 1; j < J; j++) {
        const double *sq = s + 7 * B * (size_t)parents[j];
        double *so = s + 7 * B * j;
        double q[4][B], t[3][B];
        for (size_t l = 0; l < B; l++)
            for (size_t c = 0; c < 4; c++)
                q[c][l] = rot[sr * l + 4 * j + c];
        if (k < P && (size_t)trans_joints[k] == j) {
            for (size_t l = 0; l < B; l++)
                for (size_t c = 0; c < 3; c++)
                    t[c][l] = trans[st * l + 3 * k + c];
            k++;
        } else {
            for (size_t l = 0; l < B; l++)
                for (size_t c = 0; c < 3; c++)
                    t[c][l] = offsets[3 * j + c];
        }
        for (size_t l = 0; l < B; l++) {
            /* mlr_quat_mul_inline(wr_p, q) */
            const double aw = sq[l], ax = sq[B + l], ay = sq[2 * B + l], az = sq[3 * B + l];
            const double bw = q[0][l], bx = q[1][l], by = q[2][l], bz = q[3][l];
            so[l] = aw * bw - ax * bx - ay * by - az * bz;
            so[B + l] = aw * bx + ax * bw + ay * bz - az * by;
            so[2 * B + l] = aw * by - ax * bz + ay * bw + az * bx;
            so[3 * B + l] = aw * bz + ax * by - ay * bx + az * bw;
            /* mlr_quat_rotate_inline(wr_p, t), added to wp_p */
            const double vx = t[0][l], vy = t[1][l], vz = t[2][l];
            const double tx = 2.0 * (ay * vz - az * vy);
            const double ty = 2.0 * (az * vx - ax * vz);
            const double tz = 2.0 * (ax * vy - ay * vx);
            const double ox = vx + aw * tx + (ay * tz - az * ty);
            const double oy = vy + aw * ty + (az * tx - ax * tz);
            const double oz = vz + aw * tz + (ax * ty - ay * tx);
            so[4 * B + l] = sq[4 * B + l] + ox;
            so[5 * B + l] = sq[5 * B + l] + oy;
            so[6 * B + l] = sq[6 * B + l] + oz;
        }
    }
    for (size_t j = 0; j < J; j++) {
        const double *so = s + 7 * B * j;
        for (size_t l = 0; l < B; l++)
            for (size_t c = 0; c < 3; c++)
                wp[sp * l + 3 * j + c] = so[(4 + c) * B + l];
        if (wr)
            for (size_t l = 0; l < B; l++)
                for (size_t c = 0; c < 4; c++)
                    wr[sr * l + 4 * j + c] = so[c * B + l];
    }
}

static mlr_status fk_run(size_t N, size_t J, const int32_t *parents, const double *offsets,
                         const double *root_pos, const double *rot, size_t P,
                         const int32_t *trans_joints, const double *trans, double *world_pos,
                         double *world_rot, const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_quat stack_scratch[FK_STACK_JOINTS];
    mlr_quat *scratch = stack_scratch;
    mlr_allocator a;
    size_t scratch_bytes = 0;
    if (!world_rot && J > FK_STACK_JOINTS && N > 0) {
        mlr_allocator_resolve(alloc, &a);
        if (mlr_mul_size(J, sizeof(mlr_quat), &scratch_bytes) != MLR_OK)
            return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "fk: %zu joints overflow a size", J);
        scratch = mlr_alloc(&a, scratch_bytes);
        if (!scratch)
            return mlr_diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "fk: out of memory for %zu world rotations of scratch", J);
    }
    /* The blocks' scratch: on the stack for up to FK_BLOCK_STACK_JOINTS joints, else allocated;
     * without it (no memory) every frame goes the one-frame way, which gives the same bits. */
    double block_stack[7 * FK_BLOCK * FK_BLOCK_STACK_JOINTS];
    double *s = block_stack;
    size_t f = 0, block_bytes = 0;
    mlr_allocator ab;
    if (N >= FK_BLOCK && J > FK_BLOCK_STACK_JOINTS) {
        mlr_allocator_resolve(alloc, &ab);
        s = NULL;
        if (mlr_mul_size(J, 7 * FK_BLOCK * sizeof(double), &block_bytes) == MLR_OK)
            s = mlr_alloc(&ab, block_bytes);
    }
    if (s)
        for (; f + FK_BLOCK <= N; f += FK_BLOCK)
            fk_block(J, parents, offsets, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f, P,
                     trans_joints, P ? trans + 3 * P * f : NULL, world_pos + 3 * J * f,
                     world_rot ? world_rot + 4 * J * f : NULL, s);
    if (s && s != block_stack)
        mlr_free(&ab, s, block_bytes);
    for (; f < N; f++) {
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
                         double *world_pos, double *world_rot, const mlr_allocator *alloc,
                         mlr_diag *diag)
{
    if (!parents || !offsets || (n_trans && (!trans_joints || !trans)) ||
        (n_frames && (!rot || !world_pos)))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "fk: parents, offsets, rot, world_pos%s is NULL",
                            n_trans ? ", trans_joints or trans" : "");
    mlr_status s = check_skeleton(n_joints, parents, n_trans, trans_joints, diag);
    if (s != MLR_OK)
        return s;
    size_t nj;
    if (mlr_mul_size(n_frames, n_joints, &nj) || mlr_mul_size(nj, 4, &nj))
        return mlr_diag_set(diag, MLR_E_OVERFLOW, 0, 0, "fk: %zu frames x %zu joints overflow",
                            n_frames, n_joints);
    return fk_run(n_frames, n_joints, parents, offsets, root_pos, rot, n_trans, trans_joints,
                  trans, world_pos, world_rot, alloc, diag);
}

mlr_status mlr_fk_motion(const mlr_motion *m, size_t begin, size_t count, double *world_pos,
                         double *world_rot, mlr_diag *diag)
{
    if (!m || (count && !world_pos))
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "fk: motion or world_pos is NULL");
    if (begin > m->n_frames || count > m->n_frames - begin)
        return mlr_diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "fk: frames [%zu, %zu + %zu) are not within the motion's %zu", begin,
                            begin, count, m->n_frames);
    const size_t J = m->n_joints, P = m->n_trans;
    return fk_run(count, J, m->parents, m->offsets, count ? m->root_pos + 3 * begin : NULL,
                  count ? m->rot + 4 * J * begin : NULL, P, m->trans_joints,
                  (count && P) ? m->trans + 3 * P * begin : NULL, world_pos, world_rot, &m->alloc,
                  diag);
}
