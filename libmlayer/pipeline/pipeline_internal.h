/* What the files of the pipeline share (pipeline.c, pipeline_memory.c, glob.c). Not
 * installed. */
#ifndef MLR_PIPELINE_INTERNAL_H
#define MLR_PIPELINE_INTERNAL_H

#include "common/mlr_internal.h"

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

#endif
