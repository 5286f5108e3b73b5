/* Forward kinematics, batched over frames. Allocates only for scratch world rotations of big
 * skeletons when the caller does not want them. Nothing here prints or keeps state. */
#include "motion/bvh_internal.h"
#include "motion/fk_internal.h"

#define FK_STACK_JOINTS 256

static mlr_status check_skeleton(size_t n_joints, const int32_t *parents, size_t n_trans,
                                 const int32_t *trans_joints, mlr_diag *diag)
{
    if (n_joints == 0 || n_joints > BVH_MAX_JOINTS)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "fk: %zu joints, not in [1, %zu]",
                                n_joints, BVH_MAX_JOINTS);
    if (parents[0] != -1)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "fk: parents[0] is %d, not -1",
                                (int)parents[0]);
    for (size_t j = 1; j < n_joints; j++)
        if (parents[j] < 0 || (size_t)parents[j] >= j)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "fk: parents[%zu] is %d, not in [0, %zu)", j, (int)parents[j],
                                    j);
    for (size_t k = 0; k < n_trans; k++)
        if (trans_joints[k] < 1 || (size_t)trans_joints[k] >= n_joints ||
            (k && trans_joints[k] <= trans_joints[k - 1]))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "fk: trans_joints[%zu] is %d: not in [1, %zu) or not increasing", k,
                (int)trans_joints[k], n_joints);
    return MLR_OK;
}

/* One frame, of every joint (every 1: the k-th trans joint's translation from trans + 3 k) or
 * (every 0, a constant in each caller) of the root and the n joints of list (top-down; tidx[j]:
 * j's index among the trans joints, or -1). wr: J world rotations (output or scratch). */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void fk_frame_run(int every, size_t J, const int32_t *parents, const double *offsets,
                                const double *root_pos, const double *rot, size_t P,
                                const int32_t *trans_joints, const int32_t *tidx,
                                const double *trans, const int32_t *list, size_t n, double *wp,
                                mlr_quat *wr)
{
    wr[0].w = rot[0];
    wr[0].x = rot[1];
    wr[0].y = rot[2];
    wr[0].z = rot[3];
    const double *t0 = root_pos ? root_pos : offsets;
    wp[0] = t0[0];
    wp[1] = t0[1];
    wp[2] = t0[2];
    const size_t m = every ? J - 1 : n;
    size_t k = 0;
    for (size_t i = 0; i < m; i++) {
        const size_t j = every ? i + 1 : (size_t)list[i];
        const size_t p = (size_t)parents[j];
        const double *t = offsets + 3 * j;
        if (every ? k < P && (size_t)trans_joints[k] == j : tidx[j] >= 0)
            t = trans + 3 * (every ? k++ : (size_t)tidx[j]);
        const mlr_quat q = {rot[4 * j], rot[4 * j + 1], rot[4 * j + 2], rot[4 * j + 3]};
        common__fk_joint_inline(&wr[p], wp + 3 * p, &q, t, &wr[j], wp + 3 * j);
    }
}

static void fk_frame(size_t J, const int32_t *parents, const double *offsets,
                     const double *root_pos, const double *rot, size_t P,
                     const int32_t *trans_joints, const double *trans, double *wp, mlr_quat *wr)
{
    fk_frame_run(1, J, parents, offsets, root_pos, rot, P, trans_joints, NULL, trans, NULL, 0, wp,
                 wr);
}

void fk__list_frame(const mlr_fk_list *fl, const double *root_pos, const double *rot,
                    const double *trans, double *wp, double *wr)
{
    fk_frame_run(0, fl->n_joints, fl->parents, fl->offsets, root_pos, rot, fl->n_trans, NULL,
                 fl->tidx, trans, fl->list, fl->n, wp, (mlr_quat *)(void *)wr);
}

/* FK_BLOCK frames at once, joint by joint, in structure-of-arrays scratch (s: 7 * FK_BLOCK
 * doubles per joint: w x y z of the world rotation, then the world position, lane fastest) so
 * that the lane loops vectorize. Every lane does the operations of common__fk_joint_inline in its
 * order (the library builds with -ffp-contract=off): the bits are those of fk_frame. rot, wp and
 * wr (NULL: not wanted) start at the block's first frame; root_pos and trans too, or NULL. */
#define FK_BLOCK MLR_FK_BLOCK
#define FK_BLOCK_STACK_JOINTS 64 /* 28 KiB */

/* One joint in every lane of the block, common__fk_joint_inline lane by lane (the compiler
 * vectorizes over the lanes): so (its 7 x FK_BLOCK scratch) from sq (its parent's), its local
 * rotations (lane l's at r + sr l) and translations (lane l's at tv + st l; st 0: its offset in
 * every lane). */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void fk_block_joint(const double *restrict sq, const double *restrict r, size_t sr,
                                  const double *restrict tv, size_t st, double *restrict so)
{
    enum { B = FK_BLOCK };
    for (size_t l = 0; l < B; l++) {
        const mlr_quat wr_p = {sq[l], sq[B + l], sq[2 * B + l], sq[3 * B + l]};
        const double wp_p[3] = {sq[4 * B + l], sq[5 * B + l], sq[6 * B + l]};
        const mlr_quat q = {r[sr * l], r[sr * l + 1], r[sr * l + 2], r[sr * l + 3]};
        const double t[3] = {tv[st * l], tv[st * l + 1], tv[st * l + 2]};
        mlr_quat wr_j;
        double wp_j[3];
        common__fk_joint_inline(&wr_p, wp_p, &q, t, &wr_j, wp_j);
        so[l] = wr_j.w, so[B + l] = wr_j.x, so[2 * B + l] = wr_j.y, so[3 * B + l] = wr_j.z;
        so[4 * B + l] = wp_j[0], so[5 * B + l] = wp_j[1], so[6 * B + l] = wp_j[2];
    }
}

/* Joint j's lanes from the scratch into wp and wr (NULL: not wanted). */
static inline void fk_block_store(size_t J, size_t j, const double *restrict s,
                                  double *restrict wp, double *restrict wr)
{
    enum { B = FK_BLOCK };
    const double *so = s + 7 * B * j;
    for (size_t l = 0; l < B; l++)
        for (size_t c = 0; c < 3; c++)
            wp[3 * J * l + 3 * j + c] = so[(4 + c) * B + l];
    if (wr)
        for (size_t l = 0; l < B; l++)
            for (size_t c = 0; c < 4; c++)
                wr[4 * J * l + 4 * j + c] = so[c * B + l];
}

/* The block of every joint (list NULL) or of the root and list's (with tidx), as fk_frame_run;
 * into wp / wr the joints of keep (n_keep) or, keep NULL, all those computed. */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void fk_block_run(size_t J, const int32_t *parents, const double *offsets,
                                const double *root_pos, const double *restrict rot, size_t P,
                                const int32_t *trans_joints, const int32_t *tidx,
                                const double *trans, const int32_t *list, size_t n,
                                const int32_t *keep, size_t n_keep, double *restrict wp,
                                double *restrict wr, double *restrict s)
{
    enum { B = FK_BLOCK };
    const size_t sr = 4 * J, st = 3 * P;
    for (size_t l = 0; l < B; l++) {
        for (size_t c = 0; c < 4; c++)
            s[c * B + l] = rot[sr * l + c];
        for (size_t c = 0; c < 3; c++)
            s[(4 + c) * B + l] = root_pos ? root_pos[3 * l + c] : offsets[c];
    }
    const size_t m = list ? n : J - 1;
    size_t k = 0;
    for (size_t i = 0; i < m; i++) {
        const size_t j = list ? (size_t)list[i] : i + 1;
        const double *sq = s + 7 * B * (size_t)parents[j];
        double *so = s + 7 * B * j;
        if (list ? tidx[j] >= 0 : k < P && (size_t)trans_joints[k] == j)
            fk_block_joint(sq, rot + 4 * j, sr, trans + 3 * (list ? (size_t)tidx[j] : k++), st,
                           so);
        else
            fk_block_joint(sq, rot + 4 * j, sr, offsets + 3 * j, 0, so);
    }
    if (keep) {
        for (size_t i = 0; i < n_keep; i++)
            fk_block_store(J, (size_t)keep[i], s, wp, wr);
        return;
    }
    fk_block_store(J, 0, s, wp, wr);
    for (size_t i = 0; i < m; i++)
        fk_block_store(J, list ? (size_t)list[i] : i + 1, s, wp, wr);
}

MLR_CLONES("avx2")
static void fk_block(size_t J, const int32_t *parents, const double *offsets,
                     const double *root_pos, const double *rot, size_t P,
                     const int32_t *trans_joints, const double *trans, double *wp, double *wr,
                     double *s)
{
    fk_block_run(J, parents, offsets, root_pos, rot, P, trans_joints, NULL, trans, NULL, 0, NULL,
                 0, wp, wr, s);
}

MLR_CLONES("avx2")
void fk__list_block(const mlr_fk_list *fl, const double *root_pos, const double *rot,
                    const double *trans, double *wp, double *wr, double *s)
{
    fk_block_run(fl->n_joints, fl->parents, fl->offsets, root_pos, rot, fl->n_trans, NULL,
                 fl->tidx, trans, fl->list, fl->n, fl->keep, fl->n_keep, wp, wr, s);
}

/* fl's listed joints on a block, from seed's world pose as wp and wr hold it (the listed
 * joints' parents are seed or listed before them): the same operations as fk__list_frame
 * per frame, so the same bits. */
MLR_CLONES("avx2")
void fk__list_block_from(const mlr_fk_list *fl, size_t seed, const double *rot,
                         const double *trans, double *wp, double *wr, double *s)
{
    enum { B = FK_BLOCK };
    const size_t J = fl->n_joints, sr = 4 * J, st = 3 * fl->n_trans;
    double *ss = s + 7 * B * seed;
    for (size_t l = 0; l < B; l++) {
        for (size_t c = 0; c < 4; c++)
            ss[c * B + l] = wr[sr * l + 4 * seed + c];
        for (size_t c = 0; c < 3; c++)
            ss[(4 + c) * B + l] = wp[3 * J * l + 3 * seed + c];
    }
    for (size_t i = 0; i < fl->n; i++) {
        const size_t j = (size_t)fl->list[i];
        const double *sq = s + 7 * B * (size_t)fl->parents[j];
        double *so = s + 7 * B * j;
        if (fl->tidx[j] >= 0)
            fk_block_joint(sq, rot + 4 * j, sr, trans + 3 * (size_t)fl->tidx[j], st, so);
        else
            fk_block_joint(sq, rot + 4 * j, sr, fl->offsets + 3 * j, 0, so);
    }
    for (size_t i = 0; i < fl->n; i++)
        fk_block_store(J, (size_t)fl->list[i], s, wp, wr);
}

void fk__list_arrays(const mlr_fk_list *fl, size_t N, const double *root_pos, const double *rot,
                     const double *trans, double *wp, double *wr, double *s)
{
    const size_t J = fl->n_joints, P = fl->n_trans;
    size_t f = 0;
    if (s)
        for (; f + FK_BLOCK <= N; f += FK_BLOCK)
            fk__list_block(fl, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f,
                           P ? trans + 3 * P * f : NULL, wp + 3 * J * f, wr + 4 * J * f, s);
    for (; f < N; f++)
        fk__list_frame(fl, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f,
                       P ? trans + 3 * P * f : NULL, wp + 3 * J * f, wr + 4 * J * f);
}

/* Joint j's world rotations of a block from the scratch into wr (frames x J x 4). */
static inline void fk_block_store_rot(size_t J, size_t j, const double *restrict s,
                                      double *restrict wr)
{
    enum { B = FK_BLOCK };
    const double *so = s + 7 * B * j;
    for (size_t l = 0; l < B; l++)
        for (size_t c = 0; c < 4; c++)
            wr[4 * J * l + 4 * j + c] = so[c * B + l];
}

/* rot_keep (n_keep joints, or NULL: all): the joints whose world rotations are written. */
static mlr_status fk_run(size_t N, size_t J, const int32_t *parents, const double *offsets,
                         const double *root_pos, const double *rot, size_t P,
                         const int32_t *trans_joints, const double *trans, double *world_pos,
                         double *world_rot, const int32_t *rot_keep, size_t n_keep,
                         const mlr_allocator *alloc, mlr_diag *diag)
{
    mlr_quat stack_scratch[FK_STACK_JOINTS];
    mlr_quat *scratch = stack_scratch;
    mlr_allocator a;
    size_t scratch_bytes = 0;
    double *all_rot = rot_keep ? NULL : world_rot; /* written at every joint */
    if (!all_rot && J > FK_STACK_JOINTS && N > 0) {
        common__allocator_resolve(alloc, &a);
        if (common__mul_size(J, sizeof(mlr_quat), &scratch_bytes) != MLR_OK)
            return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "fk: %zu joints overflow a size",
                                    J);
        scratch = common__alloc(&a, scratch_bytes);
        if (!scratch)
            return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                    "fk: out of memory for %zu world rotations of scratch", J);
    }
    /* The blocks' scratch: on the stack for up to FK_BLOCK_STACK_JOINTS joints, else allocated;
     * without it (no memory) every frame goes the one-frame way, which gives the same bits. */
    double block_stack[7 * FK_BLOCK * FK_BLOCK_STACK_JOINTS];
    double *s = block_stack;
    size_t f = 0, block_bytes = 0;
    mlr_allocator ab;
    if (N >= FK_BLOCK && J > FK_BLOCK_STACK_JOINTS) {
        common__allocator_resolve(alloc, &ab);
        s = NULL;
        if (common__mul_size(J, 7 * FK_BLOCK * sizeof(double), &block_bytes) == MLR_OK)
            s = common__alloc(&ab, block_bytes);
    }
    if (s)
        for (; f + FK_BLOCK <= N; f += FK_BLOCK) {
            fk_block(J, parents, offsets, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f, P,
                     trans_joints, P ? trans + 3 * P * f : NULL, world_pos + 3 * J * f,
                     all_rot ? all_rot + 4 * J * f : NULL, s);
            for (size_t i = 0; rot_keep && world_rot && i < n_keep; i++)
                fk_block_store_rot(J, (size_t)rot_keep[i], s, world_rot + 4 * J * f);
        }
    if (s && s != block_stack)
        common__free(&ab, s, block_bytes);
    for (; f < N; f++) {
        mlr_quat *wr = all_rot ? (mlr_quat *)(void *)(all_rot + 4 * J * f) : scratch;
        fk_frame(J, parents, offsets, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f, P,
                 trans_joints, P ? trans + 3 * P * f : NULL, world_pos + 3 * J * f, wr);
        for (size_t i = 0; rot_keep && world_rot && i < n_keep; i++)
            memcpy(world_rot + 4 * (J * f + (size_t)rot_keep[i]), &wr[rot_keep[i]],
                   4 * sizeof(double));
    }
    if (scratch != stack_scratch)
        common__free(&a, scratch, scratch_bytes);
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
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "fk: parents, offsets, rot, world_pos%s is NULL",
                                n_trans ? ", trans_joints or trans" : "");
    mlr_status s = check_skeleton(n_joints, parents, n_trans, trans_joints, diag);
    if (s != MLR_OK)
        return s;
    size_t nj;
    if (common__mul_size(n_frames, n_joints, &nj) || common__mul_size(nj, 4, &nj))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "fk: %zu frames x %zu joints overflow",
                                n_frames, n_joints);
    return fk_run(n_frames, n_joints, parents, offsets, root_pos, rot, n_trans, trans_joints,
                  trans, world_pos, world_rot, NULL, 0, alloc, diag);
}

mlr_status fk__arrays_rot_at(size_t n_frames, size_t n_joints, const int32_t *parents,
                             const double *offsets, const double *root_pos, const double *rot,
                             size_t n_trans, const int32_t *trans_joints, const double *trans,
                             double *world_pos, double *world_rot, const int32_t *rot_joints,
                             size_t n_rot_joints, const mlr_allocator *alloc)
{
    return fk_run(n_frames, n_joints, parents, offsets, root_pos, rot, n_trans, trans_joints,
                  trans, world_pos, world_rot, rot_joints, n_rot_joints, alloc, NULL);
}

mlr_status mlr_fk_motion(const mlr_motion *m, size_t begin, size_t count, double *world_pos,
                         double *world_rot, mlr_diag *diag)
{
    if (!m || (count && !world_pos))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "fk: motion or world_pos is NULL");
    if (begin > m->n_frames || count > m->n_frames - begin)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "fk: frames [%zu, %zu + %zu) are not within the motion's %zu",
                                begin, begin, count, m->n_frames);
    const size_t J = m->n_joints, P = m->n_trans;
    return fk_run(count, J, m->parents, m->offsets, count ? m->root_pos + 3 * begin : NULL,
                  count ? m->rot + 4 * J * begin : NULL, P, m->trans_joints,
                  (count && P) ? m->trans + 3 * P * begin : NULL, world_pos, world_rot, NULL, 0,
                  &m->alloc, diag);
}
