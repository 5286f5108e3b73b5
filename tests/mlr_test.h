/* Shared helpers of the Check suites: seeded data, a counting/failing allocator, a runner. */
#ifndef MLR_TEST_H
#define MLR_TEST_H

#include <check.h>
#include <mlayer/mlayer.h>
#include <stddef.h>
#include <stdint.h>

#define MLR_COUNTOF(a) (sizeof(a) / sizeof((a)[0]))

/* Deterministic generator (splitmix64); never rand(). */
typedef struct mlr_test_rng {
    uint64_t state;
} mlr_test_rng;
void mlr_test_rng_seed(mlr_test_rng *r, uint64_t seed);
uint64_t mlr_test_rng_u64(mlr_test_rng *r);
double mlr_test_rng_uniform(mlr_test_rng *r);            /* [0, 1) */
double mlr_test_rng_normal(mlr_test_rng *r);             /* N(0, 1) */

/* Allocator that counts live blocks and fails the fail_at-th allocation (0-based);
 * fail_at = SIZE_MAX never fails. */
typedef struct mlr_test_allocator {
    mlr_allocator base;                                  /* pass &ta.base */
    size_t fail_at, n_calls, live_blocks, live_bytes;
} mlr_test_allocator;
void mlr_test_allocator_init(mlr_test_allocator *ta, size_t fail_at);

/* Directory of the shared real mocap clips, or NULL when not configured. */
const char *mlr_test_mocap_dir(void);

/* Dense references for the banded solvers (small n only). mlr_test_cholesky overwrites the
 * lower triangle of the SPD n x n row-major matrix a with its Cholesky factor C (a = C C^T);
 * mlr_test_cholesky_solve solves C C^T X = B in place for B n x m row-major. */
void mlr_test_cholesky(size_t n, double *a);
/* Squared Euclidean distance of two d-vectors, summed in index order (a plain reference). */
double mlr_test_dist2(const double *a, const double *b, size_t d);
void mlr_test_cholesky_solve(size_t n, const double *c, double *b, size_t m);

/* A new temporary directory holding one file of the given bytes; remove both with
 * mlr_test_temp_remove. */
typedef struct mlr_test_temp {
    char dir[64], path[192];
} mlr_test_temp;
void mlr_test_temp_write(mlr_test_temp *t, const char *name, const void *data, size_t n);
void mlr_test_temp_remove(const mlr_test_temp *t);
/* Entries of a folder, hidden ones included ("." and ".." not counted). */
size_t mlr_test_dir_entries(const char *dir);

/* The real clip the repository bundles (the Python package's sample, byte for byte the shared
 * folder's file of that name), and the redistributable clips of tests/data/wild. */
#define MLR_TEST_BUNDLED_CLIP "cmu_131_01_mj_style_walk.bvh"
extern const char *const mlr_test_wild_clips[];
extern const size_t mlr_test_n_wild_clips;

/* Path (in buf, cap bytes) of the real clip `file`: the shared folder's file when it is there,
 * else the repository's copy (MLR_TEST_BUNDLED_CLIP, or "wild/NAME.bvh" from tests/data/wild);
 * NULL when neither. */
const char *mlr_test_clip_path(const char *file, char *buf, size_t cap);
/* For a test that needs some real clip, not this one: the path of `file` as above, or, when it
 * is absent, of the k-th (modulo their count) of the bundled clip and the wild clips. */
const char *mlr_test_any_clip_path(const char *file, size_t k, char *buf, size_t cap);

/* A real clip with its rig view (names borrowed from the motion). */
typedef struct mlr_test_clip {
    mlr_motion *m;
    mlr_rig rig;
    const char **names;
    size_t n, j;   /* frames, joints */
    double fps;
} mlr_test_clip;
/* Read the clip mlr_test_clip_path(file) names; 0 (nothing to release) when it is absent. */
int mlr_test_clip_load(const char *file, mlr_test_clip *c);
/* Read the clip at path (which must be there). */
void mlr_test_clip_load_path(const char *path, mlr_test_clip *c);
void mlr_test_clip_unload(mlr_test_clip *c);

/* 1 when the shared real clips are there (mlr_test_mocap_dir() holds the README's clips); 0
 * otherwise. */
int mlr_test_have_clips(void);

/* Check has no skip status: a test that cannot run returns (and so passes) after printing one
 * line on stderr, "SKIP file: test[i]: why", that names it (meson's test log keeps it); a test
 * that leaves out a part (one clip of several) prints "SKIP-PART file: test[i]: why" and goes
 * on. */
void mlr_test_skip_note(const char *file, const char *func, int i, int part, const char *why,
                        const char *clip);
#define MLR_TEST_SKIP(why)                                          \
    do {                                                            \
        mlr_test_skip_note(__FILE__, __func__, _i, 0, (why), NULL); \
        return;                                                     \
    } while (0)
/* 1 when mlr_test_clip_path(clip) is there; otherwise 0, after the note. */
int mlr_test_clip_there(const char *file, const char *func, int i, int part, const char *clip);
/* Skip the whole test (with the note) when the real clip `clip` is absent. */
#define MLR_TEST_NEED_CLIP(clip)                                     \
    do {                                                             \
        if (!mlr_test_clip_there(__FILE__, __func__, _i, 0, (clip))) \
            return;                                                  \
    } while (0)
/* In a test over several clips: 1 when `clip` is there, else 0 after a SKIP-PART note. */
#define MLR_TEST_HAVE_CLIP(clip) mlr_test_clip_there(__FILE__, __func__, _i, 1, (clip))
/* At the start of a test that reads the shared clips: skip (with the note) when they are
 * absent. */
#define MLR_TEST_NEED_CLIPS()                                                                     \
    do {                                                                                          \
        if (!mlr_test_have_clips())                                                               \
            MLR_TEST_SKIP("the shared clips are absent (MLR_TEST_MOCAP_DIR names their folder)"); \
    } while (0)

/* Run a suite, print Check's summary line, return the process exit code. */
int mlr_test_run(Suite *s);

#define ck_assert_close(a, b, tol)                                                               \
    do {                                                                                         \
        double a_ = (a), b_ = (b), t_ = (tol);                                                   \
        ck_assert_msg(fabs(a_ - b_) <= t_, "%s = %.17g, %s = %.17g, |diff| %.3g > %.3g", #a, a_, \
                      #b, b_, fabs(a_ - b_), t_);                                                \
    } while (0)

#endif
