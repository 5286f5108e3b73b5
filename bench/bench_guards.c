/* The whole stylize of a runtime on the C ABI against the decomposition alone, on real capture
 * data: cmu_01_01 (31 joints, 120 fps), the first 2,526 frames after its T-pose frame.
 *   guards.decompose      mlr_layers_decompose with the frame rate (the C defaults)
 *   guards.stylize        that, then repair the input's outlier frames (mlr_layers_repair on
 *                         a copy, where mlr_layers_get_outliers finds some: the bench clip has
 *                         none, so the input is taken as it is, as mlayer's pipeline does),
 *                         create the guards on it (contacts, floor, limits of the input),
 *                         synthesize at alpha 2 and apply the guards with the input as the
 *                         reference (NULL): every guard on, what mlayer.stylize(m, 2) computes
 *   guards.apply          synthesize at alpha 2 and mlr_guards_apply (a slider move with the
 *                         guards made once), the input as the reference, as mlayer.stylize
 *   guards.apply_ref      the same with a given reference (the synthesis at alpha 1)
 *   guards.synthesize     mlr_layers_synthesize at alpha 2 alone
 *   guards.create         the outlier frames looked up (none: no copy, no repair) and
 *                         mlr_guards_create (contacts, floor and limits of the input)
 * n is frames x joints. guards.stylize also times its own decomposition and prints the median
 * over its runs of each run's ratio of the whole to that (both timed at the same moment of a
 * shared machine's load, which moves the two cases' medians apart by up to 20%). */
#include "bench.h"

#include <mlayer/mlayer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One run of guards.stylize: its decomposition and the rest (ns). */
typedef struct stylize_run {
    double dec, rest;
} stylize_run;

typedef struct guards_state {
    mlr_motion *m;
    mlr_rig rig;
    const char **names;
    size_t n, j;
    double fps;
    const double *root, *rot; /* frames 1 .. n of the clip */
    double *out_root, *out_rot, *ref_root, *ref_rot, *in_root, *in_rot;
    unsigned char *outliers; /* N x (1 + J): mlr_layers_get_outliers */
    mlr_layers *layers;
    mlr_guards *guards;
    stylize_run *runs; /* guards.stylize: each run's timings */
    size_t n_runs, cap_runs;
} guards_state;

static void teardown(void *p)
{
    guards_state *s = p;
    mlr_guards_destroy(s->guards);
    mlr_layers_destroy(s->layers);
    free(s->out_root), free(s->out_rot), free(s->ref_root), free(s->ref_rot);
    free(s->in_root), free(s->in_rot), free(s->outliers);
    free(s->names);
    free(s->runs);
    mlr_motion_destroy(s->m);
    free(s);
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The median of the n values x (sorted in place). */
static double median_of(double *x, size_t n)
{
    qsort(x, n, sizeof *x, cmp_double);
    return x[n / 2];
}

/* teardown of guards.stylize: the medians of the runs' ratios, whole over its decomposition,
   and of their two parts first */
static void teardown_stylize(void *p)
{
    guards_state *s = p;
    const size_t n = s->n_runs;
    double *x = n ? malloc(n * sizeof *x) : NULL;
    if (x) {
        for (size_t i = 0; i < n; i++)
            x[i] = (s->runs[i].dec + s->runs[i].rest) / s->runs[i].dec;
        printf("# guards.stylize / its own decomposition (median of %zu runs): %.3f\n", n,
               median_of(x, n));
        for (size_t i = 0; i < n; i++)
            x[i] = s->runs[i].dec;
        const double dec = median_of(x, n);
        for (size_t i = 0; i < n; i++)
            x[i] = s->runs[i].rest;
        printf("# guards.stylize: its own decomposition %.3f ms, the guards and the synthesis "
               "%.3f ms (medians)\n",
               1e-6 * dec, 1e-6 * median_of(x, n));
    }
    free(x);
    teardown(s);
}

static void *setup(size_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/cmu_01_01_playground_jumps.bvh", mlr_bench_mocap_dir());
    guards_state *s = calloc(1, sizeof *s);
    if (!s || mlr_bvh_read_file(path, NULL, &s->m, NULL) != MLR_OK) {
        free(s);
        return NULL;
    }
    s->j = mlr_motion_n_joints(s->m);
    s->n = n / s->j;
    if (s->n + 1 > mlr_motion_n_frames(s->m)) {
        teardown(s);
        return NULL;
    }
    s->fps = 1.0 / mlr_motion_frame_time(s->m);
    s->names = malloc(s->j * sizeof *s->names);
    for (size_t k = 0; s->names && k < s->j; k++)
        s->names[k] = mlr_motion_joint_name(s->m, k);
    mlr_rig r = {s->j,
                 mlr_motion_parents(s->m),
                 mlr_motion_offsets(s->m),
                 s->names,
                 0,
                 NULL,
                 mlr_motion_n_end_sites(s->m),
                 mlr_motion_end_site_parents(s->m),
                 mlr_motion_end_site_offsets(s->m)};
    s->rig = r;
    s->root = mlr_motion_root_pos(s->m) + 3;
    s->rot = mlr_motion_rot(s->m) + 4 * s->j;
    s->out_root = malloc(3 * s->n * sizeof(double));
    s->ref_root = malloc(3 * s->n * sizeof(double));
    s->out_rot = malloc(4 * s->n * s->j * sizeof(double));
    s->ref_rot = malloc(4 * s->n * s->j * sizeof(double));
    s->in_root = malloc(3 * s->n * sizeof(double));
    s->in_rot = malloc(4 * s->n * s->j * sizeof(double));
    s->outliers = malloc(s->n * (1 + s->j));
    if (!s->names || !s->out_root || !s->ref_root || !s->out_rot || !s->ref_rot || !s->in_root ||
        !s->in_rot || !s->outliers) {
        teardown(s);
        return NULL;
    }
    return s;
}

static int decompose(guards_state *s)
{
    const mlr_layers_option o = {MLR_LAYERS_OPT_FPS, s->fps};
    mlr_layers_destroy(s->layers);
    s->layers = NULL;
    return mlr_layers_decompose(s->n, s->j, s->root, s->rot, &o, 1, NULL, &s->layers, NULL);
}

static int synthesize(guards_state *s, double alpha, double *root, double *rot)
{
    return mlr_layers_synthesize(s->layers, 0, s->n, &alpha, 1, root, 3 * s->n, rot,
                                 4 * s->n * s->j, NULL);
}

/* The guards of the input with its outlier frames repaired, as mlayer's pipeline makes them
   (Layers.repaired): a copy repaired when the decomposition found outlier frames, the input
   itself when it found none (the bench clip has none). */
static int create_guards(guards_state *s)
{
    mlr_guards_destroy(s->guards);
    s->guards = NULL;
    const double *root = s->root, *rot = s->rot;
    if (mlr_layers_get_outliers(s->layers, s->outliers, s->n * (1 + s->j)) != MLR_OK)
        return -1;
    if (memchr(s->outliers, 1, s->n * (1 + s->j))) {
        memcpy(s->in_root, s->root, 3 * s->n * sizeof(double));
        memcpy(s->in_rot, s->rot, 4 * s->n * s->j * sizeof(double));
        if (mlr_layers_repair(s->layers, 0, s->n, s->in_root, 3 * s->n, s->in_rot, 4 * s->n * s->j,
                              NULL, NULL) < 0)
            return -1;
        root = s->in_root, rot = s->in_rot;
    }
    return mlr_guards_create(&s->rig, s->fps, s->n, root, rot, NULL, NULL, 0, NULL, &s->guards,
                             NULL);
}

static double apply_with(guards_state *s, int given_ref)
{
    const double alpha = 2.0;
    mlr_guards_report rep;
    if (synthesize(s, alpha, s->out_root, s->out_rot) < 0 ||
        mlr_guards_apply(s->guards, &alpha, 1, given_ref ? s->ref_root : NULL,
                         given_ref ? s->ref_rot : NULL, NULL, s->out_root, s->out_rot, NULL, NULL,
                         0, &rep, NULL) < 0)
        return -1.0;
    return s->out_root[3 * (s->n / 2) + 1] + (double)rep.contact_frames;
}

static double apply(guards_state *s) { return apply_with(s, 0); }

static double run_decompose(void *p)
{
    guards_state *s = p;
    return decompose(s) < 0 ? -1.0 : (double)mlr_layers_n_frames(s->layers);
}

static double run_stylize(void *p)
{
    guards_state *s = p;
    const double t0 = mlr_bench_now_ns();
    if (decompose(s) < 0)
        return -1.0;
    const double t1 = mlr_bench_now_ns();
    if (create_guards(s) < 0)
        return -1.0;
    const double r = apply(s), t2 = mlr_bench_now_ns();
    if (s->n_runs == s->cap_runs) {
        const size_t cap = s->cap_runs ? 2 * s->cap_runs : 256;
        stylize_run *grown = realloc(s->runs, cap * sizeof *grown);
        if (!grown)
            return r;
        s->runs = grown, s->cap_runs = cap;
    }
    s->runs[s->n_runs++] = (stylize_run){t1 - t0, t2 - t1};
    return r;
}

static void *setup_ready(size_t n)
{
    guards_state *s = setup(n);
    if (s && (decompose(s) < 0 || synthesize(s, 1.0, s->ref_root, s->ref_rot) < 0 ||
              create_guards(s) < 0)) {
        teardown(s);
        return NULL;
    }
    return s;
}

static double run_apply(void *p) { return apply(p); }

static double run_apply_ref(void *p) { return apply_with(p, 1); }

static double run_synthesize(void *p)
{
    guards_state *s = p;
    return synthesize(s, 2.0, s->out_root, s->out_rot) < 0 ? -1.0
                                                           : s->out_rot[4 * s->j * (s->n / 2)];
}

static double run_create(void *p)
{
    guards_state *s = p;
    return create_guards(s) < 0 ? -1.0 : 1.0;
}

const mlr_bench_case mlr_bench_guards_cases[] = {
    {"guards.decompose/n=2526,j=31", 2526 * 31, setup, run_decompose, teardown},
    {"guards.stylize/n=2526,j=31", 2526 * 31, setup, run_stylize, teardown_stylize},
    {"guards.apply/n=2526,j=31", 2526 * 31, setup_ready, run_apply, teardown},
    {"guards.apply_ref/n=2526,j=31", 2526 * 31, setup_ready, run_apply_ref, teardown},
    {"guards.synthesize/n=2526,j=31", 2526 * 31, setup_ready, run_synthesize, teardown},
    {"guards.create/n=2526,j=31", 2526 * 31, setup_ready, run_create, teardown},
};
const size_t mlr_bench_guards_count =
    sizeof mlr_bench_guards_cases / sizeof mlr_bench_guards_cases[0];
