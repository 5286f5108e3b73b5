/* The crowd budget (issue 41): one 60 Hz frame of 1,000 characters on one core, each a 31-joint
 * rig (the bundled CMU 131_01 walk) with its own layered stream (lag 10) and guards (limits in
 * the stream, feet pinned by IK, the floor), started at different phases and alphas 0.5-2.5:
 * the runtime character of examples/c/game_loop/character.c. One iteration steps every
 * character once; ns_per_elem is the time per character-frame (target: at most 16,600 ns, so
 * 1,000 characters fit in 16.6 ms). Every allocation goes through a counting allocator (the
 * public mlr_allocator hook): the timed frames must allocate nothing, or the harness fails. */
#define _POSIX_C_SOURCE 200809L
#include "bench.h"

#include "character.h"

#include <stdio.h>
#include <stdlib.h>

#define CROWD 1000
#define CROWD_LAG 10

typedef struct crowd_state {
    size_t allocations, live_bytes; /* the counting allocator's counts */
    mlr_allocator alloc;
    char_clip clip;
    character *chars;
    size_t n_chars, frames, frame_allocs;
} crowd_state;

static void *count_allocate(void *user, size_t size, size_t align)
{
    crowd_state *s = user;
    void *p = NULL;
    if (posix_memalign(&p, align < sizeof(void *) ? sizeof(void *) : align, size))
        return NULL;
    s->allocations++;
    s->live_bytes += size;
    return p;
}

static void count_release(void *user, void *ptr, size_t size)
{
    crowd_state *s = user;
    s->live_bytes -= size;
    free(ptr);
}

static void teardown(void *p)
{
    crowd_state *s = p;
    if (s->frames) {
        printf("# crowd: allocations in %zu timed frames of %zu characters: %zu\n", s->frames,
               s->n_chars, s->frame_allocs);
        if (s->frame_allocs)
            mlr_bench_failed = 1;
    }
    for (size_t c = 0; c < s->n_chars; c++)
        char_free(&s->chars[c]);
    free(s->chars);
    char_clip_free(&s->clip);
    free(s);
}

static void *setup(size_t n)
{
    crowd_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->alloc = (mlr_allocator){count_allocate, count_release, s};
    mlr_diag diag = {0};
    s->chars = calloc(n, sizeof *s->chars);
    mlr_status st = s->chars ? char_clip_load(MLR_BENCH_SAMPLE_CLIP, &s->alloc, &s->clip, &diag)
                             : MLR_E_NO_MEMORY;
    if (st < 0) {
        fprintf(stderr, "crowd: %s: %s\n", MLR_BENCH_SAMPLE_CLIP, diag.message);
        free(s->chars), free(s);
        return NULL;
    }
    for (; s->n_chars < n && st >= 0; s->n_chars++) {
        st = char_init(&s->chars[s->n_chars], &s->clip, s->n_chars * 37, CROWD_LAG, &s->alloc,
                       &diag);
        if (st >= 0)
            st = char_set_alpha(&s->chars[s->n_chars], 0.5 + 2.0 * (double)(s->n_chars % 9) / 8.0,
                                &diag);
    }
    for (size_t f = 0; f <= CROWD_LAG && st >= 0; f++) /* warm-up: every stream outputs */
        for (size_t c = 0; c < s->n_chars && st >= 0; c++)
            st = char_step(&s->chars[c], &diag);
    if (st < 0) {
        fprintf(stderr, "crowd: %s\n", diag.message);
        teardown(s);
        return NULL;
    }
    return s;
}

static double run(void *p)
{
    crowd_state *s = p;
    const size_t before = s->allocations;
    double sum = 0.0;
    for (size_t c = 0; c < s->n_chars; c++) {
        if (char_step(&s->chars[c], NULL) < 0)
            mlr_bench_failed = 1;
        sum += s->chars[c].world_pos[3];
    }
    s->frame_allocs += s->allocations - before;
    s->frames++;
    return sum;
}

const mlr_bench_case mlr_bench_crowd_cases[] = {
    {"crowd.frame/J=31,chars=1000,lag=10", CROWD, setup, run, teardown},
};
const size_t mlr_bench_crowd_count =
    sizeof mlr_bench_crowd_cases / sizeof mlr_bench_crowd_cases[0];
