/* Clustering cases, the C side of bench/python/bench_cluster.py without the peers:
 *  - kmeans.iter: one fit of ITERS Lloyd iterations (tol 0, fixed initial centres: rows
 *    j * n / k), k = 64, n = 200,000 (and 20,000 for callgrind), on
 *      random: standard normal, d = 96 (no structure: the distance products dominate);
 *      mocap: joint positions minus the root position of the CMU clips in ../shared/data/mocap
 *      (31 joints, 93 columns; no heading removal, unlike mlayer.pose_features), tiled in order
 *      to n rows plus a jitter of 1% of each column's standard deviation;
 *    elements = n * ITERS, so ns_per_elem is per row and iteration;
 *  - som.batch_epoch / som.online_epoch: a 65 x 65 map on 10,000 x 93 mocap rows (as above),
 *    one epoch from the same random codebook each run; elements = 10,000 rows.
 * Threads: $MLR_BENCH_THREADS (default 2), as the Python bench. For repeatable counts on a
 * loaded machine: valgrind --tool=callgrind build/bench/mlayer-bench --filter n=20000 */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ITERS 5
#define K 64

static size_t bench_threads(void)
{
    const char *s = getenv("MLR_BENCH_THREADS");
    long v = s ? strtol(s, NULL, 10) : 2;
    return v >= 1 && v <= 64 ? (size_t)v : 2;
}

/* Joint positions minus the root of every 31-joint cmu_* clip, stacked: *rows x 93. */
static double *mocap_rows(size_t *rows)
{
    static const char *clips[] = {"cmu_01_01_playground_jumps.bvh", "cmu_02_03_run_jog_25fps.bvh",
                                  "cmu_10_01_soccer_kick.bvh", "cmu_131_01_mj_style_walk.bvh",
                                  "cmu_60_10_salsa_dance.bvh"};
    double *all = NULL;
    size_t total = 0;
    for (size_t c = 0; c < sizeof clips / sizeof clips[0]; c++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", mlr_bench_mocap_dir(), clips[c]);
        mlr_motion *m = NULL;
        if (mlr_bvh_read_file(path, NULL, &m, NULL) != MLR_OK)
            continue;
        size_t nf = mlr_motion_n_frames(m);
        if (mlr_motion_n_joints(m) != 31 || nf == 0) {
            mlr_motion_destroy(m);
            continue;
        }
        double *grown = realloc(all, (total + nf) * 93 * sizeof *all);
        if (!grown || mlr_fk_motion(m, 0, nf, grown + total * 93, NULL, NULL) != MLR_OK) {
            mlr_motion_destroy(m);
            free(grown ? grown : all);
            return NULL;
        }
        all = grown;
        for (size_t i = total; i < total + nf; i++)
            for (size_t j = 30; j < 31; j--) /* root last: it is the reference */
                for (size_t a = 0; a < 3; a++)
                    all[i * 93 + 3 * j + a] -= all[i * 93 + a];
        total += nf;
        mlr_motion_destroy(m);
    }
    *rows = total;
    return all;
}

/* n x 93 rows: the mocap rows repeated in order plus 1% jitter; NULL without clips. */
static double *mocap_tiled(size_t n)
{
    size_t nf = 0;
    double *f = mocap_rows(&nf);
    if (!f || nf == 0) {
        free(f);
        return NULL;
    }
    double sd[93];
    for (size_t t = 0; t < 93; t++) {
        double m = 0, v = 0;
        for (size_t i = 0; i < nf; i++)
            m += f[i * 93 + t];
        m /= (double)nf;
        for (size_t i = 0; i < nf; i++)
            v += (f[i * 93 + t] - m) * (f[i * 93 + t] - m);
        sd[t] = sqrt(v / (double)nf);
    }
    double *x = malloc(n * 93 * sizeof *x);
    unsigned long long seed = 7;
    for (size_t i = 0; x && i < n; i++)
        for (size_t t = 0; t < 93; t++)
            x[i * 93 + t] = f[(i % nf) * 93 + t] + 0.01 * sd[t] * mlr_bench_normal(&seed);
    free(f);
    return x;
}

/* ---- k-means ---------------------------------------------------------------------------- */

typedef struct km_state {
    size_t n, d;
    double *x, *init;
    int32_t *lab;
    mlr_kmeans *km;
} km_state;

static void km_teardown(void *p)
{
    km_state *s = p;
    mlr_kmeans_destroy(s->km);
    free(s->x), free(s->init), free(s->lab), free(s);
}

static void *km_setup(size_t n, double *x, size_t d)
{
    km_state *s = calloc(1, sizeof *s);
    if (!s || !x) {
        free(s), free(x);
        return NULL;
    }
    s->n = n, s->d = d, s->x = x;
    s->init = malloc(K * d * sizeof(double));
    s->lab = malloc(n * sizeof(int32_t));
    if (!s->init || !s->lab || mlr_kmeans_create(K, d, NULL, &s->km, NULL) != MLR_OK) {
        km_teardown(s);
        return NULL;
    }
    for (size_t j = 0; j < K; j++)
        memcpy(s->init + j * d, x + (j * (n / K)) * d, d * sizeof(double));
    mlr_kmeans_set(s->km, MLR_KMEANS_MAX_ITER, ITERS, NULL);
    mlr_kmeans_set(s->km, MLR_KMEANS_TOL, 0.0, NULL);
    mlr_kmeans_set(s->km, MLR_KMEANS_N_THREADS, (double)bench_threads(), NULL);
    return s;
}

static void *km_setup_random(size_t elems)
{
    size_t n = elems / ITERS, d = 96;
    double *x = malloc(n * d * sizeof *x);
    unsigned long long seed = 3;
    for (size_t q = 0; x && q < n * d; q++)
        x[q] = mlr_bench_normal(&seed);
    return km_setup(n, x, d);
}

static void *km_setup_mocap(size_t elems)
{
    size_t n = elems / ITERS;
    return km_setup(n, mocap_tiled(n), 93);
}

static double km_run(void *p)
{
    km_state *s = p;
    if (mlr_kmeans_fit(s->km, s->x, s->n, s->d, s->init, s->d, s->lab, NULL) != MLR_OK)
        return -1.0;
    return mlr_kmeans_inertia(s->km) / (double)s->n;
}

/* ---- SOM ----------------------------------------------------------------------------------- */

typedef struct som_state {
    size_t n;
    double *x;
    mlr_som *som;
    int mode;
} som_state;

static void som_teardown(void *p)
{
    som_state *s = p;
    mlr_som_destroy(s->som);
    free(s->x), free(s);
}

static void *som_setup(size_t n, int mode)
{
    som_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->n = n, s->mode = mode;
    s->x = mocap_tiled(n);
    if (!s->x || mlr_som_create(65, 65, 93, NULL, &s->som, NULL) != MLR_OK) {
        som_teardown(s);
        return NULL;
    }
    mlr_som_set(s->som, MLR_SOM_N_THREADS, (double)bench_threads(), NULL);
    return s;
}

static void *som_setup_batch(size_t n) { return som_setup(n, MLR_SOM_BATCH); }
static void *som_setup_online(size_t n) { return som_setup(n, MLR_SOM_ONLINE); }

static double som_run(void *p)
{
    som_state *s = p;
    double qe = -1.0;
    if (mlr_som_init_random(s->som, s->x, s->n, 93, NULL) != MLR_OK ||
        mlr_som_train(s->som, s->x, s->n, 93, 1, s->mode, NULL) != MLR_OK)
        return -1.0;
    mlr_som_errors(s->som, s->x, s->n < 1000 ? s->n : 1000, 93, &qe, NULL, NULL);
    return qe;
}

const mlr_bench_case mlr_bench_cluster_cases[] = {
    {"kmeans.iter/random,n=200000,d=96,k=64", 200000 * ITERS, km_setup_random, km_run,
     km_teardown},
    {"kmeans.iter/mocap,n=200000,d=93,k=64", 200000 * ITERS, km_setup_mocap, km_run, km_teardown},
    {"kmeans.iter/random,n=20000,d=96,k=64", 20000 * ITERS, km_setup_random, km_run, km_teardown},
    {"kmeans.iter/mocap,n=20000,d=93,k=64", 20000 * ITERS, km_setup_mocap, km_run, km_teardown},
    {"som.batch_epoch/65x65,n=10000,d=93", 10000, som_setup_batch, som_run, som_teardown},
    {"som.online_epoch/65x65,n=10000,d=93", 10000, som_setup_online, som_run, som_teardown},
    {"som.online_epoch/65x65,n=1000,d=93", 1000, som_setup_online, som_run, som_teardown},
};
const size_t mlr_bench_cluster_count =
    sizeof mlr_bench_cluster_cases / sizeof mlr_bench_cluster_cases[0];
