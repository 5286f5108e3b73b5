/* Forward kinematics of some joints only, a block of frames at once, for the contact cleanup
 * (cleanup_fk.c); fk.c does the arithmetic, the one of mlr_fk_arrays, so the values are bit
 * for bit the full FK's. Not installed; none of it is exported. */
#ifndef MLR_FK_INTERNAL_H
#define MLR_FK_INTERNAL_H

#include "common/mlr_internal.h"

#include "mlayer/mlr_rig.h"

/* The frames of a block, and the doubles of its scratch for J joints (7 per joint and frame:
 * the world rotation and position in structure-of-arrays order). */
#define MLR_FK_BLOCK 8
#define MLR_FK_BLOCK_SCRATCH(J) (7 * MLR_FK_BLOCK * (size_t)(J))

/* A skeleton and the joints to compute: the root and the n joints of list (top-down: each one's
 * parent is the root or listed before it). */
typedef struct mlr_fk_list {
    size_t n_joints, n_trans;   /* J, P */
    const int32_t *parents;     /* J */
    const double *offsets;      /* J x 3 */
    const int32_t *tidx;        /* J: each joint's index among the P trans joints, or -1 */
    const int32_t *list;        /* n joints, not the root (not NULL) */
    size_t n;
    const int32_t *keep;        /* n_keep of those (the root among them or not): the ones the
                                   blocks write; NULL: the root and every listed joint */
    size_t n_keep;
} mlr_fk_list;

/* Forward kinematics of fl's joints on MLR_FK_BLOCK frames: rot (frames x J x 4), root_pos
 * (frames x 3, or NULL: the root's offset) and trans (frames x P x 3) start at the block's first
 * frame, and so do wp and wr (frames x J x 3 and frames x J x 4), written at fl's kept joints
 * only. s: MLR_FK_BLOCK_SCRATCH(J) doubles. */
void fk__list_block(const mlr_fk_list *fl, const double *root_pos, const double *rot,
                    const double *trans, double *wp, double *wr, double *s);

/* The same on one frame (rot: J x 4, root_pos: 3 or NULL, trans: P x 3, wp: J x 3, wr: J x 4),
 * without scratch, written at the root and every listed joint. */
void fk__list_frame(const mlr_fk_list *fl, const double *root_pos, const double *rot,
                    const double *trans, double *wp, double *wr);

/* The same on MLR_FK_BLOCK frames for fl's listed joints only, from joint seed's world pose as
 * wp and wr hold it already (every listed joint's parent is seed or listed before it; root_pos
 * is not read): written at the listed joints. */
void fk__list_block_from(const mlr_fk_list *fl, size_t seed, const double *rot,
                         const double *trans, double *wp, double *wr, double *s);

/* The same on N frames: blocks of MLR_FK_BLOCK frames with scratch s (NULL: none, every frame
 * alone, the same values), then the frames left one by one (those written at the root and every
 * listed joint). */
void fk__list_arrays(const mlr_fk_list *fl, size_t N, const double *root_pos, const double *rot,
                     const double *trans, double *wp, double *wr, double *s);

/* mlr_fk_arrays (arguments checked by the caller) with the world rotations written at the
 * n_rot_joints joints rot_joints only (the positions at every joint): the same values, without
 * the stores of the others (the guards read the rotations of the End Sites' parents only). */
mlr_status fk__arrays_rot_at(size_t n_frames, size_t n_joints, const int32_t *parents,
                             const double *offsets, const double *root_pos, const double *rot,
                             size_t n_trans, const int32_t *trans_joints, const double *trans,
                             double *world_pos, double *world_rot, const int32_t *rot_joints,
                             size_t n_rot_joints, const mlr_allocator *alloc);

#endif
