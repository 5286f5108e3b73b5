/* Private parts of the BVH motion handle, shared by bvh_motion.c, bvh_read.c, bvh_write.c and
 * fk.c. Not installed. */
#ifndef MLR_BVH_INTERNAL_H
#define MLR_BVH_INTERNAL_H

#include "common/mlr_internal.h"

#include <mlayer/mlr_bvh.h>
#include <mlayer/mlr_fk.h>

#define BVH_MAX_CHANNELS 6
/* Room for "Xposition Yposition Zposition Xrotation Yrotation Zrotation" and its NUL. */
#define BVH_CHSTR 64
#define BVH_DEG2RAD 0.017453292519943295769
#define BVH_RAD2DEG 57.295779513082320877
/* Largest joint or End Site count (indices are int32_t). */
#define BVH_MAX_JOINTS ((size_t)INT32_MAX - 1)

/* One allocation holds the struct and every array; block_size is its size in bytes. */
struct mlr_motion {
    mlr_allocator alloc;
    size_t block_size;
    size_t n_joints, n_end, n_frames, n_trans, n_channels;
    double frame_time;
    /* skeleton */
    const char **names;        /* J pointers into name_buf */
    char *name_buf;            /* names, each NUL-terminated */
    int32_t *parents;          /* J */
    double *offsets;           /* J x 3 */
    unsigned char *n_ch;       /* J channel counts */
    unsigned char *ch;         /* J x 6 channel codes (mlr_bvh_channel) in file order */
    unsigned char *order;      /* J completed Euler orders (mlr_euler_order) */
    unsigned char *rot_idx;    /* J x 3: for axis X, Y, Z its index in the order's angles */
    char *ch_str;              /* J x BVH_CHSTR channel lists */
    int32_t *end_parents;      /* E, non-decreasing */
    double *end_offsets;       /* E x 3 */
    int32_t *trans_joints;     /* P, increasing */
    int32_t *trans_slot;       /* J: index into trans_joints, or -1 */
    /* frames */
    double *root_pos;          /* N x 3 */
    double *rot;               /* N x J x 4 */
    double *trans;             /* N x P x 3 */
};

/* Allocate a motion with every array in place (contents unset except the counts, alloc and
 * the pointers). name_bytes counts every name's NUL. */
mlr_status bvh_motion_alloc(const mlr_allocator *alloc, size_t n_joints, size_t n_end,
                            size_t name_bytes, size_t n_frames, size_t n_trans, mlr_motion **out);

/* *dst becomes a motion with src's skeleton, channel layout and frame time and n_frames frames
 * (their values unset): in place when *dst is not NULL and its block is large enough (it keeps
 * its allocator), else a new motion made with alloc, the old one destroyed once the new one
 * exists. On failure *dst is unchanged. dst must not hold src. */
mlr_status bvh_motion_fit(mlr_motion **dst, const mlr_motion *src, size_t n_frames,
                          const mlr_allocator *alloc);

/* Parse a channel name (case-insensitive, exact length); -1 when unknown. */
int bvh_channel_parse(const char *s, size_t len);
/* Canonical channel name ("Xposition", ...). */
const char *bvh_channel_name(int code);

/* From a joint's channel codes: set order[j], rot_idx[j], ch_str[j] and the count of position
 * channels (returned). Codes must be valid and distinct. */
size_t bvh_layout_finish(mlr_motion *m, size_t j);

/* mlr_bvh_read_memory_mt with the MOTION kernels limited to a set (BVH_KERNELS_* of
 * bvh_frames.h; BVH_KERNELS_BEST in the library, the others to compare them in the fuzz
 * target). */
mlr_status bvh_read_memory_ex(const char *text, size_t len, size_t n_threads, int kernels,
                              const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag);

/* Set frame f to the rest pose: identity rotations, root_pos and trans from the OFFSETs. */
void bvh_motion_rest_frame(mlr_motion *m, size_t f);

#endif
