/* What the files of the pipeline share (pipeline.c, pipeline_memory.c, pipeline_ends.c,
 * glob.c). Not installed. */
#ifndef MLR_PIPELINE_INTERNAL_H
#define MLR_PIPELINE_INTERNAL_H

#include "common/mlr_internal.h"
#include "mlayer/mlr_rig.h"

/* The arena every allocation of a pipeline's runs goes through (the layers, the guards, their
 * scratch): a stack of blocks over one kept allocation, grown after a run that needed more
 * (pipeline_memory.c), so that a run on a clip no larger than an earlier one takes nothing new
 * from the caller's allocator. Not thread-safe: a pipeline is used by one thread at a time. */
typedef struct pipeline__block pipeline__block;
typedef struct pipeline__arena {
    mlr_allocator user;      /* the caller's */
    unsigned char *base;     /* the arena, capacity bytes (NULL at first) */
    size_t capacity;
    unsigned char *next;     /* a larger arena, switched in when nothing lives in this one */
    size_t next_capacity;
    pipeline__block *top;    /* the top of the stack of live (and waiting) blocks */
    size_t n_inside;         /* blocks placed in base */
    size_t peak;             /* the highest top reached, in bytes */
} pipeline__arena;

/* Set up a over user (resolved) and fill *as with the allocator that serves from it (its user
 * points at a, which must not move while it is used). */
void pipeline__arena_init(pipeline__arena *a, const mlr_allocator *user, mlr_allocator *as);
/* After a run: make an arena as large as the highest top reached, when it is larger than the
 * one there is (a failed allocation is no error: the arena just does not grow). */
void pipeline__arena_reserve(pipeline__arena *a);
/* Give everything back to the caller's allocator. */
void pipeline__arena_free(pipeline__arena *a);

/* 1 when name matches pattern as Python's fnmatch.fnmatchcase: `*` any run of characters,
 * `?` one character, `[...]` a class (`!` first negates, `a-z` a range, `]` first is a member;
 * a `[` without a closing `]` is itself), anything else itself; characters are UTF-8 code
 * points. Both NUL-terminated. */
int pipeline__glob_match(const char *pattern, const char *name);

/* The runs at the clip's ends that the layers left out (ends[0] frames at the start, ends[1]
 * at the end; mlr_layers_get_end_runs) in the result (root N x 3, rot N x J x 4, trans N x P x
 * 3 or NULL when the rig has no translation channels): denoise (every alpha 1): the input's
 * frames (in_root, in_rot, in_trans) as they are; else the result's pose next to each run held
 * over it, raised along up (0-2) by the most that a point of it (a joint or an End Site) goes
 * deeper under floor than the input's same point on a frame of the run, one height over the
 * run (floor NaN: not raised). A run of
 * the whole clip is left as it is. MLR_E_NO_MEMORY (7 J doubles and two heights per point),
 * MLR_E_OVERFLOW; the result may be partly filled then. */
mlr_status pipeline__fill_end_runs(const mlr_rig *rig, size_t N, const size_t ends[2], int denoise,
                                   double floor, int up, const double *in_root,
                                   const double *in_rot, const double *in_trans, double *root,
                                   double *rot, double *trans, const mlr_allocator *alloc);

#endif
