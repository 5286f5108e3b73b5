/*
 * A crowd on one core: CHARS characters, each with its own stream and guards, playing one clip
 * from different phases and at different alphas, stepped FRAMES times at 60 Hz. Every
 * allocation of the library and of the characters goes through a counting allocator (the
 * public mlr_allocator hook); after the first frames (warm-up: lag + 1 steps) the steady-state
 * frames must allocate nothing. Prints the time per character-frame and how many characters
 * fit in one 16.6 ms frame at that rate.
 *
 *     crowd CLIP.bvh [CHARS] [FRAMES]      (exit 1 if a steady-state frame allocated)
 *
 * The timed figures of docs/performance.md come from the same characters in the C bench
 * harness (bench/bench_crowd.c, `mlayer-bench --filter crowd`).
 */
#define _POSIX_C_SOURCE 200809L
#include "character.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

typedef struct counter {
    size_t allocations, releases, live_bytes;
} counter;

static void *count_allocate(void *user, size_t size, size_t align)
{
    counter *k = user;
    void *p = NULL;
    if (posix_memalign(&p, align < sizeof(void *) ? sizeof(void *) : align, size))
        return NULL;
    k->allocations++;
    k->live_bytes += size;
    return p;
}

static void count_release(void *user, void *ptr, size_t size)
{
    counter *k = user;
    k->releases++;
    k->live_bytes -= size;
    free(ptr);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 4) {
        fprintf(stderr, "usage: %s CLIP.bvh [CHARS] [FRAMES]\n", argv[0]);
        return 2;
    }
    const size_t n_chars = argc > 2 ? strtoul(argv[2], NULL, 10) : 1000;
    const size_t frames = argc > 3 ? strtoul(argv[3], NULL, 10) : 120;
    const size_t lag = 10;
    counter k = {0, 0, 0};
    const mlr_allocator counting = {count_allocate, count_release, &k};
    mlr_diag diag = {0};
    char_clip clip;
    character *crowd = calloc(n_chars ? n_chars : 1, sizeof *crowd);
    int rc = 1;
    size_t made = 0;
    if (!crowd || n_chars == 0 || frames == 0) {
        fprintf(stderr, "crowd: CHARS and FRAMES must be positive\n");
        free(crowd);
        return 2;
    }
    mlr_status s = char_clip_load(argv[1], &counting, &clip, &diag);
    if (s < 0) {
        fprintf(stderr, "crowd: %s: %s\n", argv[1], diag.message);
        free(crowd);
        return 1;
    }
    for (; made < n_chars && s >= 0; made++) {
        s = char_init(&crowd[made], &clip, made * 37, lag, &counting, &diag);
        if (s >= 0) /* alphas from 0.5 to 2.5: some above 1, so the limits run */
            s = char_set_alpha(&crowd[made], 0.5 + 2.0 * (double)(made % 9) / 8.0, &diag);
    }
    if (s < 0) {
        fprintf(stderr, "crowd: character %zu: %s\n", made - 1, diag.message);
        goto done;
    }
    size_t steady_allocs = 0, steady_frames = 0;
    double steady_s = 0.0, checksum = 0.0;
    for (size_t f = 0; f < frames && s >= 0; f++) {
        const size_t before = k.allocations;
        const double t0 = now_s();
        for (size_t c = 0; c < n_chars && s >= 0; c++)
            s = char_step(&crowd[c], &diag);
        const double t1 = now_s();
        if (f > lag) { /* every stream outputs from step lag + 1 on */
            steady_allocs += k.allocations - before;
            steady_frames++;
            steady_s += t1 - t0;
        }
        checksum += crowd[f % n_chars].world_pos[3];
    }
    if (s < 0) {
        fprintf(stderr, "crowd: step: %s\n", diag.message);
        goto done;
    }
    const double us = steady_frames ? 1e6 * steady_s / (double)(steady_frames * n_chars) : 0.0;
    printf("crowd: %zu characters (%zu joints, %zu feet), %zu steady frames: %.2f us per "
           "character-frame (mean), %.0f characters per 16.6 ms frame; allocations in the "
           "steady frames: %zu (load and create: %zu); checksum %.6g\n",
           n_chars, clip.n_joints, clip.n_feet, steady_frames, us, us > 0.0 ? 16666.7 / us : 0.0,
           steady_allocs, k.allocations - steady_allocs, checksum);
    rc = steady_allocs == 0 && steady_frames > 0 && clip.n_feet > 0 ? 0 : 1;
    if (clip.n_feet == 0)
        fprintf(stderr, "crowd: no foot found on %s: the feet guard did not run\n", argv[1]);
done:
    for (size_t c = 0; c < made; c++)
        char_free(&crowd[c]);
    free(crowd);
    char_clip_free(&clip);
    if (k.live_bytes != 0) {
        fprintf(stderr, "crowd: %zu bytes not released\n", k.live_bytes);
        rc = 1;
    }
    return rc;
}
