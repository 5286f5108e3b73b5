/* mlr_pipeline: the same motion as the steps composed by hand (what mlayer's Python pipeline
 * did before it called the pipeline: decompose with Python's options, repair, guards, synthesis,
 * guards applied with the translations) on real clips, Bandai and Z-up clips included; no new
 * allocation clip after clip unless a clip is larger; bad input refused with a diag and
 * nothing changed; every allocation failure clean; the joint patterns as fnmatch. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The clips of the equality test: the shared ones (Bandai's static root, the dog, 120 and 25
 * fps, 165 joints, LaFAN1's 7184 frames) and the Z-up wild clips of the repository. */
static const char *const clips[] = {
    "cmu_131_01_mj_style_walk.bvh",   "bandai1_walk_happy_001.bvh",
    "cmu_01_01_playground_jumps.bvh", "cmu_10_01_soccer_kick.bvh",
    "cmu_60_10_salsa_dance.bvh",      "cmu_02_03_run_jog_25fps.bvh",
    "ai4a_dog_D1_008_KAN01_002.bvh",  "lafan1_clip_a.bvh",
    "wild/makehuman_walk1_zup.bvh",   "wild/fair1_jumping_zup_first400.bvh",
};

/* ---- the reference: the steps by hand --------------------------------------------------- */

typedef struct frames {
    size_t n, j, p;
    double *root, *rot, *trans;
} frames;

static void frames_free(frames *f)
{
    free(f->root);
    free(f->rot);
    free(f->trans);
}

static size_t slot_of(const mlr_motion *m, int32_t joint)
{
    const int32_t *tj = mlr_motion_trans_joints(m);
    size_t s = 0;
    while (s < mlr_motion_n_trans(m) && tj[s] != joint)
        s++;
    ck_assert_uint_lt(s, mlr_motion_n_trans(m));
    return s;
}

/* The heights along up of every joint and End Site of frame i of (root, rot, trans). */
static void point_heights(const mlr_rig *rig, const double *root, const double *rot,
                          const double *trans, size_t i, int up, double *h)
{
    const size_t J = rig->n_joints, P = rig->n_trans;
    double *pos = malloc(3 * J * sizeof(double)), *wrot = malloc(4 * J * sizeof(double));
    ck_assert(pos && wrot);
    ck_assert_int_eq(mlr_fk_arrays(1, J, rig->parents, rig->offsets, root + 3 * i, rot + 4 * J * i,
                                   P, rig->trans_joints, P ? trans + 3 * P * i : NULL, pos, wrot,
                                   NULL, NULL),
                     MLR_OK);
    for (size_t j = 0; j < J; j++)
        h[j] = pos[3 * j + (size_t)up];
    for (size_t e = 0; e < rig->n_end_sites; e++) {
        const size_t j = (size_t)rig->end_site_parents[e];
        const double *q = wrot + 4 * j, *v = rig->end_site_offsets + 3 * e;
        /* v rotated by q, its up component: v + 2 w (u x v) + 2 u x (u x v) */
        const double u[3] = {q[1], q[2], q[3]};
        const double t[3] = {2 * (u[1] * v[2] - u[2] * v[1]), 2 * (u[2] * v[0] - u[0] * v[2]),
                             2 * (u[0] * v[1] - u[1] * v[0])};
        const double r[3] = {v[0] + q[0] * t[0] + u[1] * t[2] - u[2] * t[1],
                             v[1] + q[0] * t[1] + u[2] * t[0] - u[0] * t[2],
                             v[2] + q[0] * t[2] + u[0] * t[1] - u[1] * t[0]};
        h[J + e] = pos[3 * j + (size_t)up] + r[up];
    }
    free(pos), free(wrot);
}

/* How far the result's pose of frame k, held at frame i, goes deeper under the floor than the
   input's same point on frame i (its largest over the points, at least 0). */
static double held_need(const mlr_rig *rig, const mlr_motion *m, const frames *f, size_t i,
                        size_t k, double floor, int up)
{
    const size_t K = rig->n_joints + rig->n_end_sites;
    double *ho = malloc(K * sizeof(double)), *hi = malloc(K * sizeof(double));
    ck_assert(ho && hi);
    point_heights(rig, f->root, f->rot, f->trans, k, up, ho);
    point_heights(rig, mlr_motion_root_pos(m), mlr_motion_rot(m), mlr_motion_trans(m), i, up, hi);
    double need = 0.0;
    for (size_t p = 0; p < K; p++)
        need = fmax(need, fmax(0.0, floor - ho[p]) - fmax(0.0, floor - hi[p]));
    free(ho), free(hi);
    return need;
}

/* Stylize c.m with alpha everywhere, joints matching `pattern` (a prefix and '*') at pattern_alpha,
 * the way mlayer.stylize composed it; up axis and body height as mlayer.Motion finds them. */
static frames reference(const mlr_test_clip *c, double alpha, const char *prefix,
                        double prefix_alpha, double *height_out)
{
    const mlr_motion *m = c->m;
    const size_t N = c->n, J = c->j, P = mlr_motion_n_trans(m);
    double *pos = malloc(3 * N * J * sizeof(double));
    ck_assert_ptr_nonnull(pos);
    ck_assert_int_eq(mlr_fk_arrays(N, J, mlr_motion_parents(m), mlr_motion_offsets(m),
                                   mlr_motion_root_pos(m), mlr_motion_rot(m), P,
                                   mlr_motion_trans_joints(m), mlr_motion_trans(m), pos, NULL,
                                   NULL, NULL),
                     MLR_OK);
    mlr_up_guess g;
    ck_assert_int_eq(mlr_rig_up_axis(&c->rig, N, pos, &g, NULL, NULL), MLR_OK);
    const int up = g.method != MLR_UP_NONE && g.confidence >= MLR_RIG_UP_SURE ? g.axis : 1;
    double h;
    ck_assert_int_eq(mlr_rig_body_height(N, J, pos, up, &h, NULL, NULL), MLR_OK);
    free(pos);
    *height_out = h;
    int32_t body;
    ck_assert_int_eq(mlr_rig_body_translation_joint(&c->rig, N, mlr_motion_root_pos(m),
                                                    mlr_motion_trans(m), &body, NULL),
                     MLR_OK);
    frames f = {N,
                J,
                P,
                malloc(3 * N * sizeof(double)),
                malloc(4 * N * J * sizeof(double)),
                P ? malloc(3 * N * P * sizeof(double)) : NULL};
    double *t = malloc(3 * N * sizeof(double));
    ck_assert(f.root && f.rot && t);
    const size_t slot = body ? slot_of(m, body) : 0;
    for (size_t i = 0; i < N; i++)
        memcpy(t + 3 * i,
               body ? mlr_motion_trans(m) + 3 * (i * P + slot) : mlr_motion_root_pos(m) + 3 * i,
               3 * sizeof(double));
    const double fps = 1.0 / mlr_motion_frame_time(m);
    mlr_layers_option lo[] = {{MLR_LAYERS_OPT_GAMMA, 3.14159265358979323846 / 2},
                              {MLR_LAYERS_OPT_FPS, fps},
                              {MLR_LAYERS_OPT_BASE_CUTOFF, 0.25},
                              {MLR_LAYERS_OPT_ROBUST, 1},
                              {MLR_LAYERS_OPT_BODY_HEIGHT, h},
                              {MLR_LAYERS_OPT_BODY_JOINT, (double)body}};
    mlr_layers *L = NULL;
    mlr_diag d = {0};
    ck_assert_msg(
        mlr_layers_decompose(N, J, t, mlr_motion_rot(m), lo, body ? 6 : 5, NULL, &L, &d) == MLR_OK,
        "%s", d.message);
    /* the guards learn from the input with its outliers repaired */
    memcpy(f.root, mlr_motion_root_pos(m), 3 * N * sizeof(double));
    memcpy(f.rot, mlr_motion_rot(m), 4 * N * J * sizeof(double));
    if (P)
        memcpy(f.trans, mlr_motion_trans(m), 3 * N * P * sizeof(double));
    ck_assert_int_eq(mlr_layers_repair(L, 0, N, t, 3 * N, f.rot, 4 * N * J, NULL, NULL), MLR_OK);
    for (size_t i = 0; i < N; i++)
        memcpy(body ? f.trans + 3 * (i * P + slot) : f.root + 3 * i, t + 3 * i,
               3 * sizeof(double));
    const mlr_guards_option go[] = {{MLR_GUARDS_OPT_UP, up},
                                    {MLR_GUARDS_OPT_LIMITS, MLR_GUARDS_LIMITS_AUTO},
                                    {MLR_GUARDS_OPT_KEEP_CONTACTS, 1},
                                    {MLR_GUARDS_OPT_FLOOR, 1}};
    mlr_guards *G = NULL;
    ck_assert_msg(
        mlr_guards_create(&c->rig, fps, N, f.root, f.rot, f.trans, go, 4, NULL, &G, &d) == MLR_OK,
        "%s", d.message);
    /* the alphas, the synthesis, the body translation where it rides, the guards */
    double *a = malloc((1 + J) * sizeof(double));
    ck_assert_ptr_nonnull(a);
    for (size_t k = 0; k <= J; k++)
        a[k] = alpha;
    for (size_t k = 0; prefix && k < J; k++)
        if (strncmp(c->names[k], prefix, strlen(prefix)) == 0)
            a[1 + k] = prefix_alpha;
    memcpy(f.root, mlr_motion_root_pos(m), 3 * N * sizeof(double));
    if (P)
        memcpy(f.trans, mlr_motion_trans(m), 3 * N * P * sizeof(double));
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, N, a, 1 + J, t, 3 * N, f.rot, 4 * N * J, NULL),
                     MLR_OK);
    for (size_t i = 0; i < N; i++)
        memcpy(body ? f.trans + 3 * (i * P + slot) : f.root + 3 * i, t + 3 * i,
               3 * sizeof(double));
    mlr_guards_report rep;
    ck_assert_msg(mlr_guards_apply_trans(G, a, 1 + J, NULL, NULL, NULL, f.root, f.rot, f.trans,
                                         NULL, 0, &rep, &d) == MLR_OK,
                  "%s", d.message);
    /* the runs at the ends that the layers left out: as they are in a denoise, else the
       result's pose next to the run held over it */
    size_t ends[2];
    ck_assert_int_eq(mlr_layers_get_end_runs(L, &ends[0], &ends[1]), MLR_OK);
    int denoise = 1;
    for (size_t k = 0; k <= J; k++)
        denoise &= a[k] == 1.0;
    for (size_t i = 0; i < N; i++) {
        if (i >= ends[0] && i < N - ends[1])
            continue;
        const size_t k = denoise ? i : i < ends[0] ? ends[0] : N - ends[1] - 1;
        const double *r = denoise ? mlr_motion_root_pos(m) : f.root;
        const double *q = denoise ? mlr_motion_rot(m) : f.rot;
        const double *tr = denoise ? mlr_motion_trans(m) : f.trans;
        memmove(f.root + 3 * i, r + 3 * k, 3 * sizeof(double));
        memmove(f.rot + 4 * i * J, q + 4 * k * J, 4 * J * sizeof(double));
        if (P)
            memmove(f.trans + 3 * i * P, tr + 3 * k * P, 3 * P * sizeof(double));
    }
    for (int e = 0; e < 2 && !denoise && isfinite(rep.floor_height); e++) {
        /* the held frames raised, by one height over each run, where deeper than the input */
        const size_t lo = e ? N - ends[1] : 0, hi = e ? N : ends[0], k = e ? lo - 1 : hi;
        double need = 0.0;
        for (size_t i = lo; i < hi; i++)
            need = fmax(need, held_need(&c->rig, m, &f, i, k, rep.floor_height, up));
        for (size_t i = lo; i < hi; i++)
            f.root[3 * i + (size_t)up] += need;
    }
    free(a);
    free(t);
    mlr_guards_destroy(G);
    mlr_layers_destroy(L);
    return f;
}

static double max_abs_diff(const double *a, const double *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++)
        m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

START_TEST(same_as_the_steps_by_hand)
{
    char path[1024];
    if (!mlr_test_clip_path(clips[_i], path, sizeof path)) {
        mlr_test_skip_note(__FILE__, __func__, _i, 0, "clip absent", clips[_i]);
        return;
    }
    mlr_test_clip c;
    mlr_test_clip_load_path(path, &c);
    mlr_pipeline *p = NULL;
    mlr_diag d = {0};
    ck_assert_int_eq(mlr_pipeline_create(NULL, &p, &d), MLR_OK);
    mlr_motion *out = NULL;
    const struct {
        double alpha;
        const char *prefix;
        double prefix_alpha;
    } cases[] = {{1.0, NULL, 0}, {2.5, NULL, 0}, {2.0, "Left", 3.0}};
    for (size_t k = 0; k < MLR_COUNTOF(cases); k++) {
        double h;
        frames ref = reference(&c, cases[k].alpha, cases[k].prefix, cases[k].prefix_alpha, &h);
        mlr_pipeline_clear_joint_alphas(p);
        ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, cases[k].alpha, &d), MLR_OK);
        if (cases[k].prefix) {
            char pattern[64];
            snprintf(pattern, sizeof pattern, "%s*", cases[k].prefix);
            ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, pattern, cases[k].prefix_alpha, &d),
                             MLR_OK);
        }
        mlr_status s = mlr_pipeline_run(p, c.m, &out, &d);
        if (s == MLR_E_INVALID_ARG && cases[k].prefix && strstr(d.message, "matches no joint")) {
            frames_free(&ref); /* a rig without "Left*" joints: the pattern is refused */
            continue;
        }
        ck_assert_msg(s == MLR_OK, "%s: %s", clips[_i], d.message);
        ck_assert_uint_eq(mlr_motion_n_frames(out), c.n);
        ck_assert_uint_eq(mlr_motion_n_joints(out), c.j);
        ck_assert_str_eq(mlr_motion_joint_name(out, c.j - 1), c.names[c.j - 1]);
        const double dp = max_abs_diff(mlr_motion_root_pos(out), ref.root, 3 * c.n) / h;
        const double dq = max_abs_diff(mlr_motion_rot(out), ref.rot, 4 * c.n * c.j);
        const double dt =
            ref.p ? max_abs_diff(mlr_motion_trans(out), ref.trans, 3 * c.n * ref.p) / h : 0;
        fprintf(stderr,
                "pipeline %s alpha %g%s: max |diff| root %.3g, trans %.3g body heights, "
                "rot %.3g\n",
                clips[_i], cases[k].alpha, cases[k].prefix ? " (+Left*)" : "", dp, dt, dq);
        ck_assert_msg(dp <= 1e-9 && dt <= 1e-9 && dq <= 1e-9, "%s alpha %g: %g %g %g", clips[_i],
                      cases[k].alpha, dp, dt, dq);
        double up, body_h;
        ck_assert_int_eq(mlr_pipeline_get(p, MLR_PIPELINE_INFO_BODY_HEIGHT, &body_h), MLR_OK);
        ck_assert_int_eq(mlr_pipeline_get(p, MLR_PIPELINE_INFO_UP, &up), MLR_OK);
        ck_assert_double_eq(body_h, h);
        if (strstr(clips[_i], "zup"))
            ck_assert_double_eq(up, MLR_AXIS_Z);
        frames_free(&ref);
    }
    mlr_motion_destroy(out);
    mlr_pipeline_destroy(p);
    mlr_test_clip_unload(&c);
}
END_TEST

/* A second alpha on the prepared clip is the run with that alpha; the static root of Bandai
 * stays where the input has it (the shifts ride on Hips). */
START_TEST(prepare_once_synthesize_twice)
{
    mlr_test_clip c;
    if (!mlr_test_clip_load("bandai1_walk_happy_001.bvh", &c) &&
        !mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, &c))
        MLR_TEST_SKIP("no clip");
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(NULL, &p, NULL), MLR_OK);
    mlr_motion *a = NULL, *b = NULL;
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 3.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, c.m, &a, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 1.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &b, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 3.0, NULL), MLR_OK);
    mlr_motion *a2 = NULL;
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &a2, NULL), MLR_OK);
    ck_assert_mem_eq(mlr_motion_rot(a), mlr_motion_rot(a2), 4 * c.n * c.j * sizeof(double));
    ck_assert(memcmp(mlr_motion_rot(a), mlr_motion_rot(b), 4 * c.n * c.j * sizeof(double)) != 0);
    double body;
    ck_assert_int_eq(mlr_pipeline_get(p, MLR_PIPELINE_INFO_BODY_JOINT, &body), MLR_OK);
    if (body != 0) /* Bandai: the root keeps the input's values */
        ck_assert_mem_eq(mlr_motion_root_pos(a), mlr_motion_root_pos(c.m),
                         3 * c.n * sizeof(double));
    mlr_guards_report r;
    size_t *limited = calloc(c.j, sizeof(size_t));
    ck_assert_int_eq(mlr_pipeline_report(p, &r, limited, c.j), MLR_OK);
    ck_assert_int_eq(r.limits_applied, 1);
    ck_assert_int_eq(mlr_pipeline_report(p, &r, limited, c.j + 1), MLR_E_INVALID_ARG);
    free(limited);
    /* a parameter prepare uses, changed: a new prepare is needed */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_GAMMA, 2.0, NULL), MLR_OK);
    mlr_diag d = {0};
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &a2, &d), MLR_E_BAD_STATE);
    ck_assert_ptr_nonnull(strstr(d.message, "gamma"));
    mlr_motion_destroy(a);
    mlr_motion_destroy(a2);
    mlr_motion_destroy(b);
    mlr_pipeline_destroy(p);
    mlr_test_clip_unload(&c);
}
END_TEST

/* ---- memory: clip after clip ------------------------------------------------------------- */

START_TEST(reuse_allocates_only_for_a_larger_clip)
{
    /* the largest first, then smaller ones, the same again, then one with more joints; twice */
    const char *order[] = {"cmu_131_01_mj_style_walk.bvh", "wild/fair1_jumping_zup_first400.bvh",
                           "bandai1_walk_happy_001.bvh", "cmu_131_01_mj_style_walk.bvh",
                           "wild/makehuman_walk1_zup.bvh"};
    mlr_test_clip c[MLR_COUNTOF(order)];
    size_t n_clips = 0;
    for (size_t k = 0; k < MLR_COUNTOF(order); k++) {
        char path[1024];
        if (mlr_test_clip_path(order[k], path, sizeof path))
            mlr_test_clip_load_path(path, &c[n_clips++]);
        else
            mlr_test_skip_note(__FILE__, __func__, _i, 1, "clip absent", order[k]);
    }
    ck_assert_uint_ge(n_clips, 2);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(&ta.base, &p, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 2.0, NULL), MLR_OK);
    mlr_motion *out = NULL;
    size_t max_n = 0, max_j = 0, max_p = 0; /* the most frames, joints, trans joints so far */
    for (int round = 0; round < 2; round++)
        for (size_t k = 0; k < n_clips; k++) {
            const size_t before = ta.n_calls, P = mlr_motion_n_trans(c[k].m);
            mlr_diag d = {0};
            ck_assert_msg(mlr_pipeline_run(p, c[k].m, &out, &d) == MLR_OK, "%s", d.message);
            fprintf(stderr,
                    "pipeline reuse: round %d, %zu frames x %zu joints (%zu with position "
                    "channels): %zu allocations, %.1f MB kept\n",
                    round, c[k].n, c[k].j, P, ta.n_calls - before, (double)ta.live_bytes / 1e6);
            if (round == 0 && k == 0)
                ck_assert_uint_gt(ta.n_calls, before);
            if (c[k].n <= max_n && c[k].j <= max_j && P <= max_p) /* not larger than before */
                ck_assert_msg(ta.n_calls == before, "clip %zu (%zu x %zu): %zu allocations", k,
                              c[k].n, c[k].j, ta.n_calls - before);
            max_n = c[k].n > max_n ? c[k].n : max_n;
            max_j = c[k].j > max_j ? c[k].j : max_j;
            max_p = P > max_p ? P : max_p;
        }
    /* KEEP_MEMORY 0: the scratch goes back after each call, and comes again */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_KEEP_MEMORY, 0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, c[0].m, &out, NULL), MLR_OK);
    const size_t before = ta.n_calls, live = ta.live_blocks;
    ck_assert_int_eq(mlr_pipeline_run(p, c[0].m, &out, NULL), MLR_OK);
    ck_assert_uint_gt(ta.n_calls, before);
    ck_assert_uint_eq(ta.live_blocks, live);
    mlr_motion_destroy(out);
    mlr_pipeline_destroy(p);
    ck_assert_uint_eq(ta.live_blocks, 0);
    for (size_t k = 0; k < n_clips; k++)
        mlr_test_clip_unload(&c[k]);
}
END_TEST

/* One run of the pipeline on clip with allocator ta (alpha 2, then a second synthesis at 1). */
static mlr_status run_once(mlr_test_allocator *ta, const mlr_motion *clip, mlr_diag *d)
{
    mlr_pipeline *p = NULL;
    mlr_motion *out = NULL;
    mlr_status s = mlr_pipeline_create(&ta->base, &p, d);
    if (s == MLR_OK)
        s = mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 2.0, d);
    if (s == MLR_OK)
        s = mlr_pipeline_run(p, clip, &out, d);
    if (s == MLR_OK)
        s = mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 1.0, d);
    if (s == MLR_OK)
        s = mlr_pipeline_synthesize(p, &out, d);
    if (s != MLR_OK)
        ck_assert_ptr_null(out);
    mlr_motion_destroy(out);
    mlr_pipeline_destroy(p);
    return s;
}

START_TEST(every_allocation_failure_is_clean)
{
    mlr_test_clip c;
    if (!mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, &c))
        MLR_TEST_SKIP("no clip");
    mlr_motion *small = NULL;
    ck_assert_int_eq(mlr_motion_copy_frames(c.m, 100, 90, &small, NULL), MLR_OK);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    ck_assert_int_eq(run_once(&ta, small, NULL), MLR_OK);
    const size_t n_calls = ta.n_calls;
    size_t n_failed = 0;
    for (size_t fail_at = 0; fail_at < n_calls; fail_at++) {
        mlr_test_allocator_init(&ta, fail_at);
        mlr_diag d = {0};
        const mlr_status s = run_once(&ta, small, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s != MLR_OK) { /* (a failed arena reservation is no error) */
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
            ck_assert_msg(strstr(d.message, "mlr_pipeline_") && strstr(d.message, "memory"),
                          "allocation %zu: '%s'", fail_at, d.message);
            n_failed++;
        }
    }
    ck_assert_uint_gt(n_failed, n_calls / 2);
    mlr_motion_destroy(small);
    mlr_test_clip_unload(&c);
}
END_TEST

/* ---- bad input --------------------------------------------------------------------------- */

static const struct {
    int param;
    double value;
    const char *named;
} bad_values[] = {
    {MLR_PIPELINE_ALPHA, NAN, "alpha"},
    {MLR_PIPELINE_ALPHA, INFINITY, "alpha"},
    {MLR_PIPELINE_ROOT_ALPHA, NAN, "root_alpha"},
    {MLR_PIPELINE_UP, 3, "up"},
    {MLR_PIPELINE_UP, -2, "up"},
    {MLR_PIPELINE_UP, 0.5, "up"},
    {MLR_PIPELINE_TRIM, -2, "trim"},
    {MLR_PIPELINE_TRIM, 1.5, "trim"},
    {MLR_PIPELINE_UNITS, -1, "units"},
    {MLR_PIPELINE_GUARDS, 2, "guards"},
    {MLR_PIPELINE_LIMITS, 3, "limits"},
    {MLR_PIPELINE_FLOOR, -1, "floor"},
    {MLR_PIPELINE_FLOOR_HEIGHT, NAN, "floor_height"},
    {MLR_PIPELINE_KEEP_CONTACTS, 0.5, "keep_contacts"},
    {MLR_PIPELINE_ROBUST, NAN, "robust"},
    {MLR_PIPELINE_GAMMA, 1.0, "gamma"},
    {MLR_PIPELINE_GAMMA, 3.2, "gamma"},
    {MLR_PIPELINE_LAM_C, -1, "lam_c"},
    {MLR_PIPELINE_SIGMA_B, INFINITY, "sigma_b"},
    {MLR_PIPELINE_BASE_CUTOFF, -0.25, "base_cutoff"},
    {MLR_PIPELINE_BODY_HEIGHT, NAN, "body_height"},
    {MLR_PIPELINE_KEEP_MEMORY, 2, "keep_memory"},
    {0, 1, "unknown parameter 0"},
    {99, 1, "unknown parameter 99"},
    {MLR_PIPELINE_INFO_UP, 1, "read-only"},
};

START_TEST(bad_values_are_refused)
{
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(&ta.base, &p, NULL), MLR_OK);
    const size_t calls = ta.n_calls;
    double before = 0, after = 0;
    const int known = mlr_pipeline_get(p, bad_values[_i].param, &before) == MLR_OK;
    mlr_diag d = {0};
    ck_assert_int_eq(mlr_pipeline_set(p, bad_values[_i].param, bad_values[_i].value, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_msg(strstr(d.message, bad_values[_i].named), "'%s'", d.message);
    if (known) { /* nothing changed */
        ck_assert_int_eq(mlr_pipeline_get(p, bad_values[_i].param, &after), MLR_OK);
        ck_assert(memcmp(&before, &after, sizeof before) == 0);
    }
    ck_assert_uint_eq(ta.n_calls, calls);
    mlr_pipeline_destroy(p);
}
END_TEST

START_TEST(bad_calls_are_refused)
{
    mlr_test_clip c;
    if (!mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, &c))
        MLR_TEST_SKIP("no clip");
    mlr_diag d = {0};
    ck_assert_int_eq(mlr_pipeline_create(NULL, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "out"));
    ck_assert_int_eq(mlr_pipeline_set(NULL, MLR_PIPELINE_ALPHA, 1, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "p is NULL"));
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(&ta.base, &p, NULL), MLR_OK);
    const size_t calls = ta.n_calls;
    static char sentinel;
    mlr_motion *out = (mlr_motion *)(void *)&sentinel; /* must come back as it went in */
    ck_assert_int_eq(mlr_pipeline_run(p, NULL, &out, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "in is NULL"));
    ck_assert_int_eq(mlr_pipeline_run(p, c.m, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "out is NULL"));
    mlr_motion *self = c.m;
    ck_assert_int_eq(mlr_pipeline_run(p, c.m, &self, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &out, &d), MLR_E_BAD_STATE);
    ck_assert_ptr_nonnull(strstr(d.message, "not prepared"));
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, NULL, 1, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "pattern is NULL"));
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "", 1, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Left*", NAN, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "Left*"));
    ck_assert_ptr_eq(out, (mlr_motion *)(void *)&sentinel);
    ck_assert_uint_eq(ta.n_calls, calls);
    /* a trim that leaves too little, a short clip */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_TRIM, (double)c.n - 2, &d), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, c.m, &out, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "trim"));
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_TRIM, 0, &d), MLR_OK);
    /* a base floor the frame rate rules out: the layers' message, named */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_BASE_CUTOFF, 1000, &d), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, c.m, &out, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "mlr_pipeline_prepare"));
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_BASE_CUTOFF, 0.25, &d), MLR_OK);
    /* a pattern that matches no joint: named, the result untouched */
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Nope*", 2, &d), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, c.m, &out, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "'Nope*' matches no joint"));
    ck_assert_ptr_eq(out, (mlr_motion *)(void *)&sentinel);
    /* a pattern per joint of a large rig (the viewer's body parts): the list grows, once */
    mlr_pipeline_clear_joint_alphas(p);
    for (int k = 0; k < 300; k++)
        ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Hips", 1, &d), MLR_OK);
    const size_t grown = ta.n_calls;
    mlr_pipeline_clear_joint_alphas(p);
    for (int k = 0; k < 300; k++)
        ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Hips", 1, &d), MLR_OK);
    ck_assert_uint_eq(ta.n_calls, grown);
    mlr_pipeline_destroy(p);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_test_clip_unload(&c);
}
END_TEST

/* ---- the joint patterns, as Python's fnmatch.fnmatchcase --------------------------------- */

START_TEST(joint_patterns_as_fnmatch)
{
    /* a 6-joint chain named for the patterns; alpha 2 on what a pattern matches */
    static const char *const names[] = {"Hips",      "LeftUpLeg", "LeftFoot",
                                        "RightFoot", "a[b",       "Kn\xc3\xa9"};
    static const int32_t parents[] = {-1, 0, 1, 0, 3, 4};
    double offsets[18] = {0};
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_motion_create(6, names, parents, offsets, NULL, 0, NULL, NULL, 12,
                                       1.0 / 30, NULL, &m, NULL),
                     MLR_OK);
    double *root = mlr_motion_root_pos_mut(m);
    double *rot = mlr_motion_rot_mut(m);
    for (size_t i = 0; i < 12; i++) { /* a wobble, so that the control layer is not zero */
        root[3 * i] = 0.1 * sin(0.9 * (double)i);
        for (size_t j = 0; j < 6; j++) {
            double *q = rot + 4 * (6 * i + j);
            const double a = 0.2 * sin(0.7 * (double)i + (double)j);
            q[0] = cos(a), q[1] = sin(a), q[2] = q[3] = 0;
        }
    }
    static const struct {
        const char *pattern;
        unsigned hits; /* bit j: joint j matched */
    } cases[] = {
        {"Left*", 0x06}, {"*Foot", 0x0C},  {"?ips", 0x01},    {"[LR]*Foot", 0x0C},
        {"[!L]*", 0x39}, {"Hips", 0x01},   {"a[b", 0x10},     {"Kn?", 0x20},
        {"*", 0x3F},     {"[A-Z]*", 0x2F}, {"[!A-Z]*", 0x10}, {"Kn[\xc3\xa9]", 0x20},
        {"*e*t", 0x04},  {"Hip", 0},       {"", 0},
    };
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(NULL, &p, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_GUARDS, 0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ROBUST, 0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 1.0, NULL), MLR_OK);
    mlr_motion *base = NULL, *out = NULL;
    ck_assert_int_eq(mlr_pipeline_run(p, m, &base, NULL), MLR_OK);
    for (size_t k = 0; k < MLR_COUNTOF(cases); k++) {
        mlr_pipeline_clear_joint_alphas(p);
        mlr_status s = mlr_pipeline_set_joint_alpha(p, cases[k].pattern, 2.0, NULL);
        if (!cases[k].pattern[0]) {
            ck_assert_int_eq(s, MLR_E_INVALID_ARG);
            continue;
        }
        ck_assert_int_eq(s, MLR_OK);
        s = mlr_pipeline_synthesize(p, &out, NULL);
        if (!cases[k].hits) {
            ck_assert_int_eq(s, MLR_E_INVALID_ARG);
            continue;
        }
        ck_assert_int_eq(s, MLR_OK);
        for (size_t j = 0; j < 6; j++) {
            int changed = 0;
            for (size_t i = 0; i < 12; i++)
                changed |= memcmp(mlr_motion_rot(out) + 4 * (6 * i + j),
                                  mlr_motion_rot(base) + 4 * (6 * i + j), 4 * sizeof(double)) != 0;
            ck_assert_msg(changed == (int)((cases[k].hits >> j) & 1), "'%s' on %s: %d",
                          cases[k].pattern, names[j], changed);
        }
    }
    mlr_motion_destroy(out);
    mlr_motion_destroy(base);
    mlr_pipeline_destroy(p);
    mlr_motion_destroy(m);
}
END_TEST

static Suite *pipeline_suite(void)
{
    Suite *s = suite_create("pipeline");
    TCase *same = tcase_create("same");
    tcase_add_loop_test(same, same_as_the_steps_by_hand, 0, (int)MLR_COUNTOF(clips));
    tcase_add_test(same, prepare_once_synthesize_twice);
    suite_add_tcase(s, same);
    TCase *mem = tcase_create("memory");
    tcase_add_test(mem, reuse_allocates_only_for_a_larger_clip);
    tcase_add_test(mem, every_allocation_failure_is_clean);
    suite_add_tcase(s, mem);
    TCase *args = tcase_create("arguments");
    tcase_add_loop_test(args, bad_values_are_refused, 0, (int)MLR_COUNTOF(bad_values));
    tcase_add_test(args, bad_calls_are_refused);
    tcase_add_test(args, joint_patterns_as_fnmatch);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(pipeline_suite()); }
