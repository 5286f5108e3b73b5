/* The pipeline's arena (pipeline_internal.h). Blocks are handed out as from a stack: each one
 * starts where the one before it ended (its "virtual offset"), and the top of the stack comes
 * down when the blocks on it are released (a block released below the top waits until the
 * ones above it go). A block whose virtual range lies within the arena's capacity is placed in
 * the arena at that offset; one beyond it is taken from the caller's allocator. The highest
 * top reached is recorded, and pipeline__arena_reserve makes an arena of that size, switched
 * in as soon as nothing lives in the old one. The same calls on a clip of the same size, or a
 * smaller one, reach the same or lower offsets, so they then take nothing from the caller. */
#include "pipeline/pipeline_internal.h"

/* Before each block; its size keeps the payload 16-byte aligned. */
struct pipeline__block {
    pipeline__block *below; /* the block under this one on the stack */
    size_t start;           /* virtual offset of this header */
    size_t end;             /* virtual offset one past the payload */
    unsigned char outside;  /* 1: taken from the caller's allocator */
    unsigned char released; /* 1: released, waiting for the blocks above it */
};

#define HEADER ((sizeof(pipeline__block) + 15) & ~(size_t)15)

static size_t round16(size_t n) { return (n + 15) & ~(size_t)15; }

static void *arena_allocate(void *user, size_t size, size_t align)
{
    pipeline__arena *a = user;
    if (a->next && a->n_inside == 0) { /* switch to the larger arena */
        if (a->base)
            a->user.release(a->user.user, a->base, a->capacity);
        a->base = a->next;
        a->capacity = a->next_capacity;
        a->next = NULL;
        a->next_capacity = 0;
    }
    if (align > 16 || size > SIZE_MAX / 2)
        return NULL;
    const size_t start = a->top ? a->top->end : 0;
    const size_t end = start + HEADER + round16(size);
    pipeline__block *b;
    if (end <= a->capacity) {
        b = (pipeline__block *)(void *)(a->base + start);
        b->outside = 0;
        a->n_inside++;
    } else {
        b = a->user.allocate(a->user.user, HEADER + round16(size), 16);
        if (!b)
            return NULL;
        b->outside = 1;
    }
    b->below = a->top;
    b->start = start;
    b->end = end;
    b->released = 0;
    a->top = b;
    if (end > a->peak)
        a->peak = end;
    return (unsigned char *)b + HEADER;
}

static void arena_release(void *user, void *ptr, size_t size)
{
    (void)size;
    pipeline__arena *a = user;
    pipeline__block *b = (pipeline__block *)(void *)((unsigned char *)ptr - HEADER);
    b->released = 1;
    while (a->top && a->top->released) { /* bring the top down */
        pipeline__block *t = a->top;
        a->top = t->below;
        if (t->outside)
            a->user.release(a->user.user, t, t->end - t->start);
        else
            a->n_inside--;
    }
}

void pipeline__arena_init(pipeline__arena *a, const mlr_allocator *user, mlr_allocator *as)
{
    memset(a, 0, sizeof *a);
    a->user = *user;
    as->allocate = arena_allocate;
    as->release = arena_release;
    as->user = a;
}

void pipeline__arena_reserve(pipeline__arena *a)
{
    const size_t have = a->next ? a->next_capacity : a->capacity;
    if (a->peak <= have)
        return;
    unsigned char *n = a->user.allocate(a->user.user, a->peak, 16);
    if (!n)
        return; /* not an error: the blocks beyond the arena keep coming from the caller */
    if (a->next)
        a->user.release(a->user.user, a->next, a->next_capacity);
    a->next = n;
    a->next_capacity = a->peak;
}

void pipeline__arena_free(pipeline__arena *a)
{
    while (a->top) { /* nothing should be left; give back what is */
        pipeline__block *t = a->top;
        a->top = t->below;
        if (t->outside)
            a->user.release(a->user.user, t, t->end - t->start);
    }
    if (a->base)
        a->user.release(a->user.user, a->base, a->capacity);
    if (a->next)
        a->user.release(a->user.user, a->next, a->next_capacity);
    a->base = a->next = NULL;
    a->capacity = a->next_capacity = 0;
}
