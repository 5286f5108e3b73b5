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
    /* (Check runs each test in a child process by default: the note may repeat per test) */
    fprintf(stderr,
            "the shared clips are absent (%s): a test that needs them is skipped; set "
            "MLR_TEST_MOCAP_DIR to their folder\n",
            dir ? dir : "no folder configured");
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
    const char *dir = mlr_test_mocap_dir();
    if (!dir)
        return 0;
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return 0;
    fclose(fp);
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
    return 1;
}

void mlr_test_clip_unload(mlr_test_clip *c)
{
    free(c->names);
    mlr_motion_destroy(c->m);
}
