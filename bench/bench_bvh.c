/* BVH reader cases: parse the two long shared clips (LaFAN1 clip A, 5.05 MB, 7184 frames; CMU
 * 01_01, 2.07 MB, 2752 frames) from memory (file already read) and from the file (read
 * included), on one thread and on two (mlr_bvh_read_*_mt). n is the file's size in bytes, so
 * ns_per_elem is ns per byte and MB/s is 1000 / ns_per_elem; frames/s is frames / median. The
 * clips come from $MLR_TEST_MOCAP_DIR or ../shared/data/mocap beside the source tree; a missing
 * or changed clip fails its setup. */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct bvh_state {
    char path[1024];
    char *text;
    size_t len;
} bvh_state;

static void *setup_clip(const char *file, size_t n)
{
    const char *dir = mlr_bench_mocap_dir();
    bvh_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    snprintf(s->path, sizeof s->path, "%s/%s", dir, file);
    FILE *fp = fopen(s->path, "rb");
    s->text = malloc(n + 1);
    if (!fp || !s->text || fread(s->text, 1, n + 1, fp) != n) { /* exactly n bytes */
        if (fp)
            fclose(fp);
        free(s->text), free(s);
        return NULL;
    }
    fclose(fp);
    s->len = n;
    return s;
}

static void teardown(void *p)
{
    bvh_state *s = p;
    free(s->text), free(s);
}

static double checksum(mlr_motion *m)
{
    if (!m)
        return -1.0;
    size_t n = mlr_motion_n_frames(m), j = mlr_motion_n_joints(m);
    double v = mlr_motion_rot(m)[4 * j * (n / 2) + 1] + mlr_motion_root_pos(m)[3 * (n - 1)];
    mlr_motion_destroy(m);
    return v;
}

static double run_memory(void *p)
{
    bvh_state *s = p;
    mlr_motion *m = NULL;
    mlr_bvh_read_memory(s->text, s->len, NULL, &m, NULL);
    return checksum(m);
}

static double run_file(void *p)
{
    bvh_state *s = p;
    mlr_motion *m = NULL;
    mlr_bvh_read_file(s->path, NULL, &m, NULL);
    return checksum(m);
}

static double run_memory_2(void *p)
{
    bvh_state *s = p;
    mlr_motion *m = NULL;
    mlr_bvh_read_memory_mt(s->text, s->len, 2, NULL, &m, NULL);
    return checksum(m);
}

static double run_file_2(void *p)
{
    bvh_state *s = p;
    mlr_motion *m = NULL;
    mlr_bvh_read_file_mt(s->path, 2, NULL, &m, NULL);
    return checksum(m);
}

/* Writing, for reference: the same clip formatted back into memory. */
static double run_write(void *p)
{
    bvh_state *s = p;
    mlr_motion *m = NULL;
    if (mlr_bvh_read_memory(s->text, s->len, NULL, &m, NULL) != MLR_OK)
        return -1.0;
    size_t len = 0;
    mlr_bvh_write_memory(m, NULL, 0, &len, NULL);
    mlr_motion_destroy(m);
    return (double)len;
}

#define LAFAN "lafan1_clip_a.bvh"
#define LAFAN_BYTES 5048314
#define CMU "cmu_01_01_playground_jumps.bvh"
#define CMU_BYTES 2070355

static void *setup_lafan(size_t n) { return setup_clip(LAFAN, n); }
static void *setup_cmu(size_t n) { return setup_clip(CMU, n); }

const mlr_bench_case mlr_bench_bvh_cases[] = {
    {"bvh.read_memory/lafan1_clip_a,7184_frames", LAFAN_BYTES, setup_lafan, run_memory, teardown},
    {"bvh.read_file/lafan1_clip_a,7184_frames", LAFAN_BYTES, setup_lafan, run_file, teardown},
    {"bvh.read_memory_mt2/lafan1_clip_a,7184_frames", LAFAN_BYTES, setup_lafan, run_memory_2,
     teardown},
    {"bvh.read_file_mt2/lafan1_clip_a,7184_frames", LAFAN_BYTES, setup_lafan, run_file_2,
     teardown},
    {"bvh.read_memory/cmu_01_01,2752_frames", CMU_BYTES, setup_cmu, run_memory, teardown},
    {"bvh.read_file/cmu_01_01,2752_frames", CMU_BYTES, setup_cmu, run_file, teardown},
    {"bvh.read_memory_mt2/cmu_01_01,2752_frames", CMU_BYTES, setup_cmu, run_memory_2, teardown},
    {"bvh.read_file_mt2/cmu_01_01,2752_frames", CMU_BYTES, setup_cmu, run_file_2, teardown},
    {"bvh.read+write_memory/cmu_01_01,2752_frames", CMU_BYTES, setup_cmu, run_write, teardown},
};
const size_t mlr_bench_bvh_count = sizeof mlr_bench_bvh_cases / sizeof mlr_bench_bvh_cases[0];
