/*
 * The contact cleanup's forward kinematics: of the joints it reads only, frame by frame or
 * along a chain, bit for bit what mlr_fk_arrays gives.
 */
#include "guards/cleanup_internal.h"

/* One joint's world rotation and position at frame f from its parent's (already in wr / wp),
   its local rotation r[4 j ..] (r: the frame's J x 4) and its offset or translation, with the
   arithmetic of mlr_fk_arrays. */
static inline void fk_joint(const mlr_rig *rig, size_t f, size_t j, const int32_t *tidx,
                            const double *r, const double *trans, double *wp, mlr_quat *wr)
{
    const size_t p = (size_t)rig->parents[j];
    const double *t =
        tidx[j] >= 0 ? trans + 3 * (rig->n_trans * f + (size_t)tidx[j]) : rig->offsets + 3 * j;
    const mlr_quat q = {r[4 * j], r[4 * j + 1], r[4 * j + 2], r[4 * j + 3]};
    common__fk_joint_inline(&wr[p], wp + 3 * p, &q, t, &wr[j], wp + 3 * j);
}

void cleanup__fk_list_frame(const mlr_rig *rig, size_t f, const int32_t *list, size_t n,
                            const int32_t *tidx, const double *rot, const double *trans,
                            double *wp, double *wrot_f)
{
    const double *r = rot + 4 * rig->n_joints * f;
    mlr_quat *wr = (mlr_quat *)(void *)wrot_f;
    for (size_t i = 0; i < n; i++)
        fk_joint(rig, f, (size_t)list[i], tidx, r, trans, wp, wr);
}

mlr_fk_list cleanup__fk_list_of(const mlr_rig *rig, const int32_t *list, size_t n,
                                const int32_t *tidx)
{
    const mlr_fk_list fl = {.n_joints = rig->n_joints,
                            .n_trans = rig->n_trans,
                            .parents = rig->parents,
                            .offsets = rig->offsets,
                            .tidx = tidx,
                            .list = list,
                            .n = n};
    return fl;
}

void cleanup__fk_masked_frame(const mlr_rig *rig, size_t f, const int32_t *list, size_t n,
                              const int32_t *tidx, const double *root_pos, const double *rot,
                              const double *trans, double *wp, double *wrot_f)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    const mlr_fk_list fl = cleanup__fk_list_of(rig, list, n, tidx);
    fk__list_frame(&fl, root_pos ? root_pos + 3 * f : NULL, rot + 4 * J * f,
                   P ? trans + 3 * P * f : NULL, wp, wrot_f);
}

void cleanup__fk_chain_frame(const mlr_rig *rig, size_t f, const int32_t *chain, size_t n,
                             const int32_t *tidx, const double *rot, const double *trans,
                             const double *pos_f, const double *wrot_f, double *wp,
                             double *wrot_out)
{
    const size_t J = rig->n_joints;
    const double *r = rot + 4 * J * f;
    mlr_quat *wr = (mlr_quat *)(void *)wrot_out;
    const int32_t top = rig->parents[chain[0]];
    if (top >= 0) {
        memcpy(wp + 3 * (size_t)top, pos_f + 3 * (size_t)top, 3 * sizeof(double));
        memcpy(wrot_out + 4 * (size_t)top, wrot_f + 4 * (size_t)top, 4 * sizeof(double));
    }
    for (size_t i = 0; i < n; i++) {
        const size_t j = (size_t)chain[i];
        if (j == 0) { /* the root: as fk_masked_frame */
            wr[0].w = r[0], wr[0].x = r[1], wr[0].y = r[2], wr[0].z = r[3];
            memcpy(wp, pos_f, 3 * sizeof(double));
            continue;
        }
        fk_joint(rig, f, j, tidx, r, trans, wp, wr);
    }
}

mlr_status cleanup__fk_list_points(const mlr_rig *rig, const mlr_fk_list *fl, size_t N,
                                   const double *root_pos, const double *rot, const double *trans,
                                   size_t C, const int32_t *joints, const int32_t *end_sites,
                                   double *pos, double *wrot, double *pts, double *s)
{
    fk__list_arrays(fl, N, root_pos, rot, trans, pos, wrot, s);
    if (!pts)
        return MLR_OK;
    return mlr_rig_point_positions(rig, N, pos, wrot, C, joints, end_sites, pts, NULL);
}

mlr_status cleanup__fk_points(const mlr_rig *rig, size_t N, const double *root_pos,
                              const double *rot, const double *trans, size_t C,
                              const int32_t *joints, const int32_t *end_sites, double *pos,
                              double *wrot, double *pts, const mlr_allocator *alloc,
                              const int32_t *list, size_t n, const int32_t *tidx)
{
    if (list) { /* with the blocks' scratch */
        mlr_allocator a;
        common__allocator_resolve(alloc, &a);
        size_t bytes = 0;
        double *s = NULL;
        if (N >= MLR_FK_BLOCK) {
            if (common__mul_size(rig->n_joints, MLR_FK_BLOCK_SCRATCH(1) * sizeof(double), &bytes))
                return MLR_E_OVERFLOW;
            if (!(s = common__alloc(&a, bytes)))
                return MLR_E_NO_MEMORY;
        }
        const mlr_fk_list fl = cleanup__fk_list_of(rig, list, n, tidx);
        const mlr_status st = cleanup__fk_list_points(rig, &fl, N, root_pos, rot, trans, C, joints,
                                                      end_sites, pos, wrot, pts, s);
        common__free(&a, s, bytes);
        return st;
    }
    mlr_status st = mlr_fk_arrays(N, rig->n_joints, rig->parents, rig->offsets, root_pos, rot,
                                  rig->n_trans, rig->trans_joints, trans, pos, wrot, alloc, NULL);
    if (st != MLR_OK || !pts)
        return st;
    return mlr_rig_point_positions(rig, N, pos, wrot, C, joints, end_sites, pts, NULL);
}

size_t cleanup__fk_need(const mlr_rig *rig, size_t C, const int32_t *joints,
                        const cleanup_foot *feet, size_t nf, uint8_t *need, int32_t *list,
                        int32_t *tidx)
{
    for (size_t j = 0; j < rig->n_joints; j++)
        tidx[j] = -1;
    for (size_t k = 0; k < rig->n_trans; k++)
        tidx[rig->trans_joints[k]] = (int32_t)k;
    for (size_t i = 0; i < C + nf; i++)
        for (int32_t j = i < C ? joints[i] : feet[i - C].anchor; j >= 0 && !need[j];
             j = rig->parents[j])
            need[j] = 1;
    size_t n = 0;
    for (size_t j = 1; j < rig->n_joints; j++)
        if (need[j])
            list[n++] = (int32_t)j;
    return n;
}

mlr_status cleanup__point_heights(const mlr_rig *rig, size_t N, const double *root_pos,
                                  const double *rot, const double *trans, size_t C,
                                  const int32_t *joints, const int32_t *end_sites, int up,
                                  double *h, const mlr_allocator *a)
{
    /* CLEANUP_HEIGHT_FRAMES frames at a time (or all, when fewer): their forward kinematics
       (F x J x 7, written at the points' joints only), the blocks' scratch
       (MLR_FK_BLOCK_SCRATCH(J)), the points (F x C x 3), tidx, list, the points' joints and
       need, in one allocation */
    enum { CLEANUP_HEIGHT_FRAMES = 4 * MLR_FK_BLOCK };
    const size_t J = rig->n_joints, P = rig->n_trans;
    const size_t F = N < CLEANUP_HEIGHT_FRAMES ? (N ? N : 1) : CLEANUP_HEIGHT_FRAMES;
    const size_t per_joint = (7 * F + 7 * MLR_FK_BLOCK) * sizeof(double) + 3 * sizeof(int32_t) + 1;
    size_t bytes;
    if (common__mul_size(J, per_joint, &bytes) != MLR_OK ||
        C > (SIZE_MAX - bytes) / (3 * F * sizeof(double)))
        return MLR_E_OVERFLOW;
    bytes += 3 * F * C * sizeof(double);
    double *wp = common__alloc(a, bytes);
    if (!wp)
        return MLR_E_NO_MEMORY;
    double *wr = wp + 3 * F * J, *s = wr + 4 * F * J, *pts = s + MLR_FK_BLOCK_SCRATCH(J);
    int32_t *tidx = (int32_t *)(void *)(pts + 3 * F * C), *list = tidx + J, *keep = list + J;
    uint8_t *need = (uint8_t *)(keep + J);
    memset(need, 0, J);
    const size_t n = cleanup__fk_need(rig, C, joints, NULL, 0, need, list, tidx);
    mlr_fk_list fl = cleanup__fk_list_of(rig, list, n, tidx);
    fl.keep = keep;
    for (size_t c = 0; c < C; c++) { /* the points' joints, each once */
        size_t i = 0;
        while (i < fl.n_keep && keep[i] != joints[c])
            i++;
        if (i == fl.n_keep)
            keep[fl.n_keep++] = joints[c];
    }
    mlr_status st = MLR_OK;
    for (size_t f = 0; st == MLR_OK && f < N; f += F) {
        const size_t m = N - f < F ? N - f : F;
        st = cleanup__fk_list_points(rig, &fl, m, root_pos ? root_pos + 3 * f : NULL,
                                     rot + 4 * J * f, P ? trans + 3 * P * f : NULL, C, joints,
                                     end_sites, wp, wr, pts, s);
        for (size_t i = 0; st == MLR_OK && i < m * C; i++)
            h[f * C + i] = pts[3 * i + (size_t)up];
    }
    common__free(a, wp, bytes);
    return st;
}
