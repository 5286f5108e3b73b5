#define _POSIX_C_SOURCE 200809L /* mkdtemp */
#include "mlr_test.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void mlr_test_temp_write(mlr_test_temp *t, const char *name, const void *data, size_t n)
{
    snprintf(t->dir, sizeof t->dir, "/tmp/mlr_test_XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(t->dir));
    snprintf(t->path, sizeof t->path, "%s/%s", t->dir, name);
    FILE *fp = fopen(t->path, "wb");
    ck_assert_ptr_nonnull(fp);
    ck_assert_uint_eq(fwrite(data, 1, n, fp), n);
    ck_assert_int_eq(fclose(fp), 0);
}

void mlr_test_temp_remove(const mlr_test_temp *t)
{
    unlink(t->path);
    rmdir(t->dir);
}

size_t mlr_test_dir_entries(const char *dir)
{
    DIR *d = opendir(dir);
    ck_assert_ptr_nonnull(d);
    size_t n = 0;
    for (struct dirent *e; (e = readdir(d)) != NULL;)
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(d);
    return n;
}

void mlr_test_rng_seed(mlr_test_rng *r, uint64_t seed) { r->state = seed; }

uint64_t mlr_test_rng_u64(mlr_test_rng *r)
{
    uint64_t z = (r->state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double mlr_test_rng_uniform(mlr_test_rng *r)
{
    return (double)(mlr_test_rng_u64(r) >> 11) * (1.0 / 9007199254740992.0);
}

double mlr_test_rng_normal(mlr_test_rng *r)
{
    double u1 = mlr_test_rng_uniform(r), u2 = mlr_test_rng_uniform(r);
    if (u1 < 1e-300)
        u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

typedef struct block_header {
    size_t size;
    size_t pad;
} block_header;

static void *test_allocate(void *user, size_t size, size_t align)
{
    mlr_test_allocator *ta = user;
    (void)align;
    if (ta->n_calls++ == ta->fail_at)
        return NULL;
    block_header *h = malloc(sizeof *h + size);
    if (!h)
        return NULL;
    h->size = size;
    ta->live_blocks++;
    ta->live_bytes += size;
    return h + 1;
}

static void test_release(void *user, void *ptr, size_t size)
{
    mlr_test_allocator *ta = user;
    block_header *h = (block_header *)ptr - 1;
    ck_assert_uint_eq(h->size, size); /* release gets the size that was allocated */
    ta->live_blocks--;
    ta->live_bytes -= size;
    free(h);
}

void mlr_test_allocator_init(mlr_test_allocator *ta, size_t fail_at)
{
    ta->base.allocate = test_allocate;
    ta->base.release = test_release;
    ta->base.user = ta;
    ta->fail_at = fail_at;
    ta->n_calls = ta->live_blocks = ta->live_bytes = 0;
}

const char *mlr_test_mocap_dir(void)
{
    const char *env = getenv("MLR_TEST_MOCAP_DIR");
    if (env && *env)
        return env;
#ifdef MLR_TEST_MOCAP_DIR_DEFAULT
    return MLR_TEST_MOCAP_DIR_DEFAULT;
#else
    return NULL;
#endif
}

int mlr_test_have_clips(void)
{
    const char *dir = mlr_test_mocap_dir();
    char path[1024];
    snprintf(path, sizeof path, "%s/cmu_131_01_mj_style_walk.bvh", dir ? dir : "");
    FILE *fp = dir ? fopen(path, "rb") : NULL;
    if (fp) {
        fclose(fp);
        return 1;
    }
    return 0;
}

void mlr_test_skip_note(const char *file, const char *func, int i, int part, const char *why,
                        const char *clip)
{
    /* START_TEST(name) defines name_fn: print the test's own name */
    size_t len = strlen(func);
    int n = len > 3 && strcmp(func + len - 3, "_fn") == 0 ? (int)(len - 3) : (int)len;
    const char *base = strrchr(file, '/');
    fprintf(stderr, "%s %s: %.*s[%d]: %s%s%s\n", part ? "SKIP-PART" : "SKIP",
            base ? base + 1 : file, n, func, i, why, clip ? " " : "", clip ? clip : "");
}

/* The wild clips (tests/data/wild/README.md) that read without a warning (mlr_bvh_read_file is
 * strict): CMU, PyMO and Meta captures, a pybvh fixture with mixed Euler orders, a video
 * estimate, two MakeHuman cycles; Z-up and Y-up. The first four move their root. */
const char *const mlr_test_wild_clips[] = {
    "wild/assimp_cmu_01_03_first600.bvh",          "wild/pymo_av_8walk_meredith_first600.bvh",
    "wild/fair1_jumping_zup_first400.bvh",         "wild/pybvh_test1.bvh",
    "wild/video2bvh_cxk_videopose3d_first300.bvh", "wild/makehuman_walk1_zup.bvh",
    "wild/makehuman_zombie_walk1_zup.bvh",
};
const size_t mlr_test_n_wild_clips = MLR_COUNTOF(mlr_test_wild_clips);

static int readable(const char *path)
{
    FILE *fp = fopen(path, "rb");
    if (fp)
        fclose(fp);
    return fp != NULL;
}

const char *mlr_test_clip_path(const char *file, char *buf, size_t cap)
{
    const char *dir = mlr_test_mocap_dir();
    if (dir && (size_t)snprintf(buf, cap, "%s/%s", dir, file) < cap && readable(buf))
        return buf;
#ifdef MLR_TEST_SOURCE_ROOT
    const char *in_repo = NULL;
    if (strcmp(file, MLR_TEST_BUNDLED_CLIP) == 0)
        in_repo = "bindings/python/mlayer/data/";
    else if (strncmp(file, "wild/", 5) == 0)
        in_repo = "tests/data/";
    if (in_repo &&
        (size_t)snprintf(buf, cap, "%s/%s%s", MLR_TEST_SOURCE_ROOT, in_repo, file) < cap &&
        readable(buf))
        return buf;
#endif
    return NULL;
}

const char *mlr_test_any_clip_path(const char *file, size_t k, char *buf, size_t cap)
{
    const char *p = mlr_test_clip_path(file, buf, cap);
    if (p)
        return p;
    k %= mlr_test_n_wild_clips + 1;
    return mlr_test_clip_path(k == 0 ? MLR_TEST_BUNDLED_CLIP : mlr_test_wild_clips[k - 1], buf,
                              cap);
}

int mlr_test_clip_there(const char *file, const char *func, int i, int part, const char *clip)
{
    char buf[4096];
    if (mlr_test_clip_path(clip, buf, sizeof buf))
        return 1;
    mlr_test_skip_note(file, func, i, part,
                       "the shared clip is absent (MLR_TEST_MOCAP_DIR names their folder):", clip);
    return 0;
}

int mlr_test_run(Suite *s)
{
    SRunner *sr = srunner_create(s);
    srunner_run_all(sr, CK_NORMAL);
    int failed = srunner_ntests_failed(sr);
    srunner_free(sr);
    return failed == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}

void mlr_test_cholesky(size_t n, double *a)
{
    for (size_t j = 0; j < n; j++) {
        double d = a[j * n + j];
        for (size_t k = 0; k < j; k++)
            d -= a[j * n + k] * a[j * n + k];
        a[j * n + j] = sqrt(d);
        for (size_t i = j + 1; i < n; i++) {
            double v = a[i * n + j];
            for (size_t k = 0; k < j; k++)
                v -= a[i * n + k] * a[j * n + k];
            a[i * n + j] = v / a[j * n + j];
        }
    }
}

void mlr_test_cholesky_solve(size_t n, const double *c, double *b, size_t m)
{
    for (size_t col = 0; col < m; col++) {
        for (size_t i = 0; i < n; i++) {
            double v = b[i * m + col];
            for (size_t k = 0; k < i; k++)
                v -= c[i * n + k] * b[k * m + col];
            b[i * m + col] = v / c[i * n + i];
        }
        for (size_t i = n; i-- > 0;) {
            double v = b[i * m + col];
            for (size_t k = i + 1; k < n; k++)
                v -= c[k * n + i] * b[k * m + col];
            b[i * m + col] = v / c[i * n + i];
        }
    }
}

double mlr_test_dist2(const double *a, const double *b, size_t d)
{
    double s = 0;
    for (size_t t = 0; t < d; t++)
        s += (a[t] - b[t]) * (a[t] - b[t]);
    return s;
}

int mlr_test_clip_load(const char *file, mlr_test_clip *c)
{
    char path[4096];
    if (!mlr_test_clip_path(file, path, sizeof path))
        return 0;
    mlr_test_clip_load_path(path, c);
    return 1;
}

void mlr_test_clip_load_path(const char *path, mlr_test_clip *c)
{
    mlr_diag d;
    ck_assert_msg(mlr_bvh_read_file(path, NULL, &c->m, &d) == MLR_OK, "%s", d.message);
    c->n = mlr_motion_n_frames(c->m);
    c->j = mlr_motion_n_joints(c->m);
    c->fps = 1.0 / mlr_motion_frame_time(c->m);
    c->names = malloc(c->j * sizeof *c->names);
    ck_assert_ptr_nonnull(c->names);
    for (size_t j = 0; j < c->j; j++)
        c->names[j] = mlr_motion_joint_name(c->m, j);
    const mlr_rig g = {c->j,
                       mlr_motion_parents(c->m),
                       mlr_motion_offsets(c->m),
                       c->names,
                       mlr_motion_n_trans(c->m),
                       mlr_motion_trans_joints(c->m),
                       mlr_motion_n_end_sites(c->m),
                       mlr_motion_end_site_parents(c->m),
                       mlr_motion_end_site_offsets(c->m)};
    c->rig = g;
}

void mlr_test_clip_unload(mlr_test_clip *c)
{
    free(c->names);
    mlr_motion_destroy(c->m);
}
