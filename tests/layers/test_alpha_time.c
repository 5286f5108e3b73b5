/* Alpha over time (issue 43, item 2): the keyed curves (mlr_alpha_keys_eval) against their
 * formula, C2 at the keys and within their keys; mlr_layers_synthesize_frames frame by frame
 * equal to mlr_layers_synthesize at that frame's alphas and, for one row, to the constant
 * synthesis bit for bit; the pipeline's curves (mlr_pipeline_set_alpha_keys): constant keys
 * give the constant alpha's motion bit for bit with the guards, a changing curve gives at each
 * frame the synthesis at that frame's alpha (guards off), the guards run with the peak alpha;
 * bad keys refused naming the key. */
#include "mlr_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static double smooth(double u) { return u * u * u * (10.0 + u * (6.0 * u - 15.0)); }

START_TEST(keys_follow_the_smoothstep)
{
    const double t[] = {0.0, 2.5, 4.0}, a[] = {1.0, 3.0, 1.0};
    double q[] = {-1.0, 0.0, 1.0, 2.5, 3.0, 4.0, 7.0, 1.25};
    double out[8];
    ck_assert_int_eq(mlr_alpha_keys_eval(t, a, 3, q, 8, out, NULL), MLR_OK);
    ck_assert(out[0] == 1.0 && out[1] == 1.0 && out[3] == 3.0 && out[5] == 1.0 && out[6] == 1.0);
    ck_assert_double_eq_tol(out[2], 1.0 + 2.0 * smooth(0.4), 1e-15);
    ck_assert_double_eq_tol(out[4], 3.0 - 2.0 * smooth(1.0 / 3.0), 1e-15);
    ck_assert_double_eq_tol(out[7], 2.0, 1e-15); /* the middle of a segment */
    /* within the keys, C2 at a key: the one-sided first and second differences vanish */
    const size_t n = 4001;
    double *ts = malloc(n * sizeof(double)), *v = malloc(n * sizeof(double));
    ck_assert(ts && v);
    for (size_t i = 0; i < n; i++)
        ts[i] = -0.5 + 5.0 * (double)i / (double)(n - 1);
    ck_assert_int_eq(mlr_alpha_keys_eval(t, a, 3, ts, n, v, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert(v[i] >= 1.0 && v[i] <= 3.0);
    const double h = 1e-3;
    double k3[] = {2.5 - 2 * h, 2.5 - h, 2.5, 2.5 + h, 2.5 + 2 * h}, w[5];
    ck_assert_int_eq(mlr_alpha_keys_eval(t, a, 3, k3, 5, w, NULL), MLR_OK);
    for (int s = -1; s <= 1; s += 2) {
        const double d1 = (w[2 + s] - w[2]) / h,
                     d2 = (w[2 + 2 * s] - 2 * w[2 + s] + w[2]) / (h * h);
        ck_assert_double_le(fabs(d1), 1e-4);
        ck_assert_double_le(fabs(d2), 0.2); /* the second derivative is O(h) near the key */
    }
    /* one key: a constant; equal keys: their value, bit for bit */
    const double t1[] = {1.0}, a1[] = {0.7}, t2[] = {0.0, 1.0, 2.0}, a2[] = {0.3, 0.3, 0.3};
    ck_assert_int_eq(mlr_alpha_keys_eval(t1, a1, 1, ts, n, v, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert(v[i] == 0.7);
    ck_assert_int_eq(mlr_alpha_keys_eval(t2, a2, 3, ts, n, v, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert(v[i] == 0.3);
    /* in place */
    ck_assert_int_eq(mlr_alpha_keys_eval(t, a, 3, q, 8, q, NULL), MLR_OK);
    ck_assert_mem_eq(q, out, sizeof out);
    free(ts);
    free(v);
}
END_TEST

START_TEST(bad_keys_are_refused)
{
    const double t[] = {0.0, 1.0, 1.0}, a[] = {1.0, 2.0, 1.0};
    double q = 0.5, o = -7.0;
    mlr_diag d = {0};
    ck_assert_int_eq(mlr_alpha_keys_eval(t, a, 3, &q, 1, &o, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "times must increase: key 2"));
    ck_assert(o == -7.0);
    const double tb[] = {0.0, NAN}, ab[] = {1.0, INFINITY}, tc[] = {0.0, 1.0};
    ck_assert_int_eq(mlr_alpha_keys_check(tb, a, 2, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "time of key 1"));
    ck_assert_int_eq(mlr_alpha_keys_check(tc, ab, 2, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "alpha of key 1"));
    ck_assert_int_eq(mlr_alpha_keys_check(tc, a, 0, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_alpha_keys_check(NULL, a, 2, &d), MLR_E_INVALID_ARG);
    double bad = NAN;
    ck_assert_int_eq(mlr_alpha_keys_eval(tc, a, 2, &bad, 1, &o, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_alpha_keys_eval(tc, a, 2, NULL, 1, &o, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_alpha_keys_eval(tc, a, 2, NULL, 0, NULL, &d), MLR_OK);
}
END_TEST

/* A wobbling chain: a control layer that is not zero. */
static mlr_motion *chain(size_t n_frames, size_t J)
{
    const char *names[8] = {"Hips",       "LeftUpLeg", "LeftLeg",   "LeftFoot",
                            "RightUpLeg", "RightLeg",  "RightFoot", "Spine"};
    int32_t parents[8] = {-1, 0, 1, 2, 0, 4, 5, 0};
    double offsets[24] = {0};
    for (size_t j = 1; j < J; j++)
        offsets[3 * j + 1] = -0.3;
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_motion_create(J, names, parents, offsets, NULL, 0, NULL, NULL, n_frames,
                                       1.0 / 30, NULL, &m, NULL),
                     MLR_OK);
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 43);
    double *root = mlr_motion_root_pos_mut(m), *rot = mlr_motion_rot_mut(m);
    for (size_t i = 0; i < n_frames; i++) {
        root[3 * i] = 0.05 * (double)i + 0.1 * sin(0.4 * (double)i);
        root[3 * i + 1] = 1.0 + 0.02 * sin(0.8 * (double)i);
        root[3 * i + 2] = 0.01 * mlr_test_rng_normal(&r);
        for (size_t j = 0; j < J; j++) {
            double *q = rot + 4 * (J * i + j);
            const double a =
                0.4 * sin(0.3 * (double)i + (double)j) + 0.02 * mlr_test_rng_normal(&r);
            const double b = 0.2 * cos(0.2 * (double)i + 2.0 * (double)j);
            q[0] = cos(a) * cos(b), q[1] = sin(a) * cos(b), q[2] = cos(a) * sin(b),
            q[3] = sin(a) * sin(b);
        }
    }
    return m;
}

START_TEST(frames_synthesis_is_the_synthesis_per_frame)
{
    const size_t N = 90, J = 8, G = 1 + J;
    mlr_motion *m = chain(N, J);
    mlr_layers *L = NULL;
    ck_assert_int_eq(mlr_layers_decompose(N, J, mlr_motion_root_pos(m), mlr_motion_rot(m), NULL, 0,
                                          NULL, &L, NULL),
                     MLR_OK);
    double *alpha = malloc(N * G * sizeof(double));
    double *r1 = malloc(3 * N * sizeof(double)), *q1 = malloc(4 * N * J * sizeof(double));
    double *r2 = malloc(3 * N * sizeof(double)), *q2 = malloc(4 * N * J * sizeof(double));
    ck_assert(alpha && r1 && q1 && r2 && q2);
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 7);
    for (size_t k = 0; k < N * G; k++)
        alpha[k] = -1.0 + 4.0 * mlr_test_rng_uniform(&rng);
    /* frames 10..69, a row per frame: each frame is the synthesis at its own alphas */
    const size_t b = 10, c = 60;
    ck_assert_int_eq(
        mlr_layers_synthesize_frames(L, b, c, alpha, c * G, r1, 3 * c, q1, 4 * J * c, NULL),
        MLR_OK);
    for (size_t f = 0; f < c; f++) {
        ck_assert_int_eq(
            mlr_layers_synthesize(L, b + f, 1, alpha + f * G, G, r2, 3, q2, 4 * J, NULL), MLR_OK);
        ck_assert_mem_eq(r1 + 3 * f, r2, 3 * sizeof(double));
        ck_assert_mem_eq(q1 + 4 * J * f, q2, 4 * J * sizeof(double));
    }
    /* one alpha per frame for every group */
    ck_assert_int_eq(
        mlr_layers_synthesize_frames(L, b, c, alpha, c, r1, 3 * c, q1, 4 * J * c, NULL), MLR_OK);
    for (size_t f = 0; f < c; f++) {
        ck_assert_int_eq(mlr_layers_synthesize(L, b + f, 1, alpha + f, 1, r2, 3, q2, 4 * J, NULL),
                         MLR_OK);
        ck_assert_mem_eq(r1 + 3 * f, r2, 3 * sizeof(double));
        ck_assert_mem_eq(q1 + 4 * J * f, q2, 4 * J * sizeof(double));
    }
    /* the same row at every frame: the constant synthesis, bit for bit */
    for (size_t f = 1; f < N; f++)
        memcpy(alpha + f * G, alpha, G * sizeof(double));
    ck_assert_int_eq(
        mlr_layers_synthesize_frames(L, 0, N, alpha, N * G, r1, 3 * N, q1, 4 * J * N, NULL),
        MLR_OK);
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, N, alpha, G, r2, 3 * N, q2, 4 * J * N, NULL),
                     MLR_OK);
    ck_assert_mem_eq(r1, r2, 3 * N * sizeof(double));
    ck_assert_mem_eq(q1, q2, 4 * J * N * sizeof(double));
    /* refused: wrong count, NaN (naming frame and group), range; nothing written */
    mlr_diag d = {0};
    memset(r1, 0, 3 * N * sizeof(double));
    ck_assert_int_eq(
        mlr_layers_synthesize_frames(L, 0, N, alpha, N * G - 1, r1, 3 * N, q1, 4 * J * N, &d),
        MLR_E_INVALID_ARG);
    alpha[5 * G + 3] = NAN;
    ck_assert_int_eq(mlr_layers_synthesize_frames(L, 2, N - 2, alpha, (N - 2) * G, r1, 3 * (N - 2),
                                                  NULL, 0, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "frame 7, group 3"));
    ck_assert_int_eq(mlr_layers_synthesize_frames(L, 1, N, alpha, N, r1, 3 * N, NULL, 0, &d),
                     MLR_E_INVALID_ARG);
    for (size_t k = 0; k < 3 * N; k++)
        ck_assert(r1[k] == 0.0);
    ck_assert_int_eq(mlr_layers_synthesize_frames(L, 0, 0, NULL, 0, NULL, 0, NULL, 0, NULL),
                     MLR_OK);
    free(alpha), free(r1), free(q1), free(r2), free(q2);
    mlr_layers_destroy(L);
    mlr_motion_destroy(m);
}
END_TEST

/* A real clip (or the chain) for the pipeline tests. */
static mlr_motion *pipeline_clip(mlr_test_clip *c, int *loaded)
{
    *loaded = mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, c);
    return *loaded ? c->m : chain(120, 8);
}

static void unload(mlr_test_clip *c, mlr_motion *m, int loaded)
{
    if (loaded)
        mlr_test_clip_unload(c);
    else
        mlr_motion_destroy(m);
}

START_TEST(pipeline_constant_keys_are_the_constant_alpha)
{
    mlr_test_clip c;
    int loaded;
    mlr_motion *m = pipeline_clip(&c, &loaded);
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(NULL, &p, NULL), MLR_OK);
    mlr_motion *a = NULL, *b = NULL;
    /* every group at 2.5, the Left* joints at 0.5: constants, then keys of the same values */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 2.5, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Left*", 0.5, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, m, &a, NULL), MLR_OK);
    mlr_guards_report ra, rb;
    size_t *la = calloc(J, sizeof(size_t)), *lb = calloc(J, sizeof(size_t));
    ck_assert_int_eq(mlr_pipeline_report(p, &ra, la, J), MLR_OK);
    mlr_pipeline_clear_joint_alphas(p);
    const double t[] = {0.0, 1.0, 3.0}, v[] = {2.5, 2.5, 2.5}, w[] = {0.5, 0.5, 0.5};
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v, 3, NULL), MLR_OK);
    double got;
    ck_assert_int_eq(mlr_pipeline_get(p, MLR_PIPELINE_ALPHA, &got), MLR_OK);
    ck_assert(isnan(got));
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, "Left*", t, w, 3, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &b, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_report(p, &rb, lb, J), MLR_OK);
    ck_assert_mem_eq(mlr_motion_root_pos(a), mlr_motion_root_pos(b), 3 * N * sizeof(double));
    ck_assert_mem_eq(mlr_motion_rot(a), mlr_motion_rot(b), 4 * N * J * sizeof(double));
    if (mlr_motion_n_trans(a))
        ck_assert_mem_eq(mlr_motion_trans(a), mlr_motion_trans(b),
                         3 * N * mlr_motion_n_trans(a) * sizeof(double));
    ck_assert_int_eq(ra.limits_applied, rb.limits_applied);
    ck_assert_int_eq(ra.contact_frames, rb.contact_frames);
    ck_assert_mem_eq(la, lb, J * sizeof(size_t));
    /* keys all 1: the denoised motion of ALPHA 1, bit for bit */
    const double ones[] = {1.0, 1.0};
    mlr_pipeline_clear_joint_alphas(p);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 1.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &a, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, ones, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &b, NULL), MLR_OK);
    ck_assert_mem_eq(mlr_motion_rot(a), mlr_motion_rot(b), 4 * N * J * sizeof(double));
    ck_assert_mem_eq(mlr_motion_root_pos(a), mlr_motion_root_pos(b), 3 * N * sizeof(double));
    /* ALPHA set again replaces the curve */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 2.5, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_get(p, MLR_PIPELINE_ALPHA, &got), MLR_OK);
    ck_assert(got == 2.5);
    free(la), free(lb);
    mlr_motion_destroy(a);
    mlr_motion_destroy(b);
    mlr_pipeline_destroy(p);
    unload(&c, m, loaded);
}
END_TEST

START_TEST(pipeline_curve_is_the_synthesis_at_each_frame)
{
    mlr_test_clip c;
    int loaded;
    mlr_motion *m = pipeline_clip(&c, &loaded);
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
    const double dt = mlr_motion_frame_time(m), T = (double)(N - 1) * dt;
    /* 1 until T/4, 3 from T/2 to 3T/4 (flat), 1 again at the end; the Right* joints at 0 */
    const double t[] = {0.0, 0.25 * T, 0.5 * T, 0.75 * T, T}, v[] = {1.0, 1.0, 3.0, 3.0, 1.0};
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(NULL, &p, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_GUARDS, 0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v, 5, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Right*", 0.0, NULL), MLR_OK);
    mlr_motion *out = NULL, *one = NULL, *three = NULL;
    ck_assert_int_eq(mlr_pipeline_run(p, m, &out, NULL), MLR_OK);
    /* the references: the constant alphas 1 and 3 (Right* at 0), synthesized independently */
    mlr_pipeline_clear_joint_alphas(p);
    ck_assert_int_eq(mlr_pipeline_set_joint_alpha(p, "Right*", 0.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 1.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &one, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_ALPHA, 3.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &three, NULL), MLR_OK);
    /* every frame against the layers synthesized at its own alpha */
    const mlr_layers *L = mlr_pipeline_layers(p);
    size_t flat1 = 0, flat3 = 0, between = 0;
    double *row = malloc((1 + J) * sizeof(double)), *q = malloc(4 * J * sizeof(double));
    ck_assert(row && q);
    for (size_t i = 0; i < N; i++) {
        const double ti = (double)i * dt;
        double ai;
        ck_assert_int_eq(mlr_alpha_keys_eval(t, v, 5, &ti, 1, &ai, NULL), MLR_OK);
        for (size_t g = 0; g <= J; g++)
            row[g] = g && !strncmp(mlr_motion_joint_name(m, g - 1), "Right", 5) ? 0.0 : ai;
        ck_assert_int_eq(mlr_layers_synthesize(L, i, 1, row, 1 + J, NULL, 0, q, 4 * J, NULL),
                         MLR_OK);
        ck_assert_mem_eq(mlr_motion_rot(out) + 4 * J * i, q, 4 * J * sizeof(double));
        const mlr_motion *ref = ai == 1.0 ? one : ai == 3.0 ? three : NULL;
        if (ref) /* where the curve is flat: the constant synthesis' frame */
            ck_assert_mem_eq(mlr_motion_rot(out) + 4 * J * i, mlr_motion_rot(ref) + 4 * J * i,
                             4 * J * sizeof(double));
        flat1 += ai == 1.0, flat3 += ai == 3.0;
        between += ai > 1.0 && ai < 3.0;
    }
    ck_assert_uint_gt(flat1, N / 4);
    ck_assert_uint_gt(flat3, N / 5);
    ck_assert_uint_gt(between, N / 3);
    /* with the guards: the limits run (the peak is 3), frames where alpha is 1 stay near the
       denoised motion, and the result is finite */
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_GUARDS, 1, NULL), MLR_OK);
    mlr_pipeline_clear_joint_alphas(p);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v, 5, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, m, &out, NULL), MLR_OK);
    mlr_guards_report r;
    ck_assert_int_eq(mlr_pipeline_report(p, &r, NULL, 0), MLR_OK);
    ck_assert_int_eq(r.limits_applied, 1);
    for (size_t k = 0; k < 4 * N * J; k++)
        ck_assert(isfinite(mlr_motion_rot(out)[k]));
    /* a curve within [-1, 1]: no limits (as for a constant alpha within it) */
    const double v2[] = {1.0, 0.5, -1.0, 0.5, 1.0};
    mlr_pipeline_clear_joint_alphas(p);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v2, 5, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &out, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_report(p, &r, NULL, 0), MLR_OK);
    ck_assert_int_eq(r.limits_applied, 0);
    free(row), free(q);
    mlr_motion_destroy(out);
    mlr_motion_destroy(one);
    mlr_motion_destroy(three);
    mlr_pipeline_destroy(p);
    unload(&c, m, loaded);
}
END_TEST

START_TEST(pipeline_bad_keys_change_nothing)
{
    mlr_pipeline *p = NULL;
    ck_assert_int_eq(mlr_pipeline_create(NULL, &p, NULL), MLR_OK);
    const double t[] = {0.0, 2.0, 1.0}, v[] = {1.0, 2.0, 1.0};
    mlr_diag d = {0};
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, "Left*", t, v, 3, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "'Left*'"));
    ck_assert_ptr_nonnull(strstr(d.message, "key 2"));
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v, 3, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "every joint"));
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, "", t, v, 2, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v, 0, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(NULL, NULL, t, v, 2, &d), MLR_E_INVALID_ARG);
    double got;
    ck_assert_int_eq(mlr_pipeline_get(p, MLR_PIPELINE_ALPHA, &got), MLR_OK);
    ck_assert(got == 1.0);
    /* many curves: the key list grows and keeps the earlier ones */
    mlr_motion *m = chain(60, 8), *a = NULL, *b = NULL;
    ck_assert_int_eq(mlr_pipeline_set(p, MLR_PIPELINE_GUARDS, 0, NULL), MLR_OK);
    const double tt[] = {0.0, 1.0}, v1[] = {0.0, 2.0}, v3[] = {1.0, 1.0};
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, "Left*", tt, v1, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, m, &a, NULL), MLR_OK);
    for (int k = 0; k < 200; k++)
        ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, "Spine", tt, v3, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &b, NULL), MLR_OK);
    ck_assert_mem_eq(mlr_motion_rot(a), mlr_motion_rot(b), 4 * 60 * 8 * sizeof(double));
    /* a curve on a pattern that matches nothing fails the synthesis, naming it */
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, "Tail*", tt, v1, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &b, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "'Tail*'"));
    mlr_motion_destroy(a);
    mlr_motion_destroy(b);
    mlr_motion_destroy(m);
    mlr_pipeline_destroy(p);
}
END_TEST

/* A keyed run: every group's curve and a pattern's, run, then a synthesis with other keys. */
static mlr_status keyed_run(mlr_test_allocator *ta, const mlr_motion *clip, mlr_diag *d)
{
    const double t[] = {0.0, 0.3, 0.6}, v[] = {1.0, 2.5, 0.5}, w[] = {0.0, 1.0, 3.0};
    mlr_pipeline *p = NULL;
    mlr_motion *out = NULL;
    mlr_status s = mlr_pipeline_create(&ta->base, &p, d);
    if (s == MLR_OK)
        s = mlr_pipeline_set_alpha_keys(p, NULL, t, v, 3, d);
    if (s == MLR_OK)
        s = mlr_pipeline_set_alpha_keys(p, "Left*", t, w, 3, d);
    if (s == MLR_OK)
        s = mlr_pipeline_run(p, clip, &out, d);
    if (s == MLR_OK)
        s = mlr_pipeline_set_alpha_keys(p, "Right*", t, v, 3, d);
    if (s == MLR_OK)
        s = mlr_pipeline_synthesize(p, &out, d);
    if (s != MLR_OK)
        ck_assert_ptr_null(out);
    mlr_motion_destroy(out);
    mlr_pipeline_destroy(p);
    return s;
}

START_TEST(keyed_allocation_failures_are_clean)
{
    mlr_test_clip c;
    int loaded;
    mlr_motion *m = pipeline_clip(&c, &loaded), *small = NULL;
    ck_assert_int_eq(mlr_motion_copy_frames(m, 0, 90, &small, NULL), MLR_OK);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    ck_assert_int_eq(keyed_run(&ta, small, NULL), MLR_OK);
    const size_t n_calls = ta.n_calls;
    size_t n_failed = 0;
    for (size_t fail_at = 0; fail_at < n_calls; fail_at++) {
        mlr_test_allocator_init(&ta, fail_at);
        mlr_diag d = {0};
        const mlr_status s = keyed_run(&ta, small, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s != MLR_OK) { /* (a failed arena reservation is no error) */
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
            ck_assert_msg(strstr(d.message, "mlr_pipeline_") && strstr(d.message, "memory"),
                          "allocation %zu: '%s'", fail_at, d.message);
            n_failed++;
        }
    }
    ck_assert_uint_gt(n_failed, n_calls / 2);
    /* a second keyed synthesis of the same clip takes nothing new from the allocator */
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_pipeline *p = NULL;
    mlr_motion *out = NULL;
    const double t[] = {0.0, 1.0}, v[] = {1.0, 3.0};
    ck_assert_int_eq(mlr_pipeline_create(&ta.base, &p, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_set_alpha_keys(p, NULL, t, v, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_run(p, small, &out, NULL), MLR_OK);
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &out, NULL), MLR_OK);
    const size_t before = ta.n_calls;
    ck_assert_int_eq(mlr_pipeline_synthesize(p, &out, NULL), MLR_OK);
    ck_assert_uint_eq(ta.n_calls, before);
    mlr_motion_destroy(out);
    mlr_pipeline_destroy(p);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_motion_destroy(small);
    unload(&c, m, loaded);
}
END_TEST

static Suite *alpha_time_suite(void)
{
    Suite *s = suite_create("alpha_time");
    TCase *keys = tcase_create("keys");
    tcase_add_test(keys, keys_follow_the_smoothstep);
    tcase_add_test(keys, bad_keys_are_refused);
    suite_add_tcase(s, keys);
    TCase *synth = tcase_create("synthesis");
    tcase_add_test(synth, frames_synthesis_is_the_synthesis_per_frame);
    tcase_add_test(synth, pipeline_constant_keys_are_the_constant_alpha);
    tcase_add_test(synth, pipeline_curve_is_the_synthesis_at_each_frame);
    tcase_add_test(synth, pipeline_bad_keys_change_nothing);
    tcase_add_test(synth, keyed_allocation_failures_are_clean);
    suite_add_tcase(s, synth);
    return s;
}

int main(void) { return mlr_test_run(alpha_time_suite()); }
