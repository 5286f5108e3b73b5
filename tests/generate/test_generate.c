/* Generation at run time (mlr_markov.h, mlr_generate.h): the sampler's frequencies and ranked
 * steps against the probabilities; a model file written here by hand from
 * docs/model-format.md, loaded, generating unit quaternions reproducibly; bad files
 * (truncated at every length, another magic, version, byte order, counts too large, another
 * skeleton) refused with a status and a diag, nothing left allocated; allocation failures. */
#include "gen_model_file.h"
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the sampler -------------------------------------------------------------------------- */

START_TEST(sampled_frequencies_follow_the_row)
{
    /* state 0 jumps to 1, 2, 3 with 0.2, 0.5, 0.3 */
    double J[16] = {0,   0.2, 0.5, 0.3, 1.0 / 3, 0,    1.0 / 3, 1.0 / 3,
                    0.5, 0.5, 0,   0,   0.25,    0.25, 0.5,     0};
    double rl[4] = {1, 2, 3, 4};
    mlr_markov *mk = NULL;
    ck_assert_int_eq(mlr_markov_create(4, J, rl, 1, 1, 0, NULL, NULL, NULL, NULL, &mk, NULL),
                     MLR_OK);
    mlr_rng rng;
    mlr_rng_seed(&rng, 42);
    size_t count[4] = {0, 0, 0, 0}, n = 200000;
    int64_t h = 0, next;
    for (size_t i = 0; i < n; i++) {
        ck_assert_int_eq(mlr_markov_next(mk, &h, 1, 0, &rng, &next, NULL), MLR_OK);
        count[next]++;
    }
    ck_assert_uint_eq(count[0], 0); /* a jump leaves its state */
    for (int k = 1; k < 4; k++) /* 4.5 binomial standard deviations at most */
        ck_assert_double_eq_tol((double)count[k] / (double)n, J[k],
                                4.5 * sqrt(J[k] * (1 - J[k]) / (double)n));
    /* ranked: equation 5 and the second most likely, lowest index on ties */
    ck_assert_int_eq(mlr_markov_next(mk, &h, 1, 1, NULL, &next, NULL), MLR_OK);
    ck_assert_int_eq(next, 2);
    ck_assert_int_eq(mlr_markov_next(mk, &h, 1, 2, NULL, &next, NULL), MLR_OK);
    ck_assert_int_eq(next, 3);
    h = 2;
    ck_assert_int_eq(mlr_markov_next(mk, &h, 1, 2, NULL, &next, NULL), MLR_OK);
    ck_assert_int_eq(next, 1);
    ck_assert_int_eq(mlr_markov_next(mk, &h, 1, 3, NULL, &next, NULL), MLR_OK);
    ck_assert_int_eq(next, 1); /* fewer than 3 possible: the least likely of those */
    /* a path fills the frames: steps of (max(rl, 1) + max(rl, 1)) / 2 */
    int64_t path[32];
    size_t len;
    mlr_rng_seed(&rng, 1);
    ck_assert_int_eq(mlr_markov_path(mk, NULL, 0, 0, 20, 0, &rng, path, 21, &len, NULL), MLR_OK);
    double total = 0;
    for (size_t i = 1; i < len; i++) {
        ck_assert_int_ne(path[i], path[i - 1]);
        total += (rl[path[i - 1]] + rl[path[i]]) / 2;
        if (i + 1 < len)
            ck_assert(total < 20);
    }
    ck_assert(total >= 20);
    /* the perturbed chain: rows still distributions over the same support, the diagonal 0;
     * with allow_unseen every other state reachable */
    mlr_markov *pk = NULL;
    mlr_rng_seed(&rng, 3);
    ck_assert_int_eq(mlr_markov_perturb(mk, 0.5, 0, &rng, NULL, &pk, NULL), MLR_OK);
    mlr_rng_seed(&rng, 3);
    h = 2;
    size_t seen3 = 0;
    for (int i = 0; i < 2000; i++) {
        ck_assert_int_eq(mlr_markov_next(pk, &h, 1, 0, &rng, &next, NULL), MLR_OK);
        ck_assert(next == 0 || next == 1); /* row 2: 0.5, 0.5, 0, 0 */
    }
    mlr_markov_destroy(pk);
    ck_assert_int_eq(mlr_markov_perturb(mk, 0.0, 1, &rng, NULL, &pk, NULL), MLR_OK);
    for (int i = 0; i < 20000; i++) {
        ck_assert_int_eq(mlr_markov_next(pk, &h, 1, 0, &rng, &next, NULL), MLR_OK);
        ck_assert_int_ne(next, 2);
        seen3 += next == 3;
    }
    /* 0.02 / 1 of the mass opened to state 3: about 400 of 20000 */
    ck_assert(seen3 > 250 && seen3 < 550);
    mlr_markov_destroy(pk);
    mlr_diag dd;
    ck_assert_int_eq(mlr_markov_perturb(mk, -1.0, 0, &rng, NULL, &pk, &dd), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(pk);
    ck_assert_ptr_nonnull(strstr(dd.message, "noise"));
    mlr_markov_destroy(mk);
}
END_TEST

START_TEST(contexts_back_off)
{
    /* order 2: after (1, 0) always 3; the context (2, 0) seen once, below min_count 2 */
    double J[16] = {0, 1.0 / 3, 1.0 / 3, 1.0 / 3, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    double rl[4] = {1, 1, 1, 1};
    int64_t keys[4] = {1, 0, 2, 0};
    double seen[2] = {5, 1}, probs[8] = {0, 0, 0, 1, 0, 1, 0, 0};
    mlr_markov *mk = NULL;
    ck_assert_int_eq(mlr_markov_create(4, J, rl, 2, 2, 2, keys, seen, probs, NULL, &mk, NULL),
                     MLR_OK);
    int64_t h[2] = {1, 0}, next;
    ck_assert_int_eq(mlr_markov_next(mk, h, 2, 1, NULL, &next, NULL), MLR_OK);
    ck_assert_int_eq(next, 3);
    h[0] = 2; /* backs off to the jump row of 0: 1, 2, 3 tie, the lowest index */
    ck_assert_int_eq(mlr_markov_next(mk, h, 2, 1, NULL, &next, NULL), MLR_OK);
    ck_assert_int_eq(next, 1);
    mlr_markov_destroy(mk);
    /* bad keys and rows */
    mlr_diag d;
    int64_t bad_keys[4] = {1, 0, 4, 0};
    ck_assert_int_eq(mlr_markov_create(4, J, rl, 2, 1, 2, bad_keys, seen, probs, NULL, &mk, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_null(mk);
    ck_assert_ptr_nonnull(strstr(d.message, "context key 1 holds state 4"));
    ck_assert_int_eq(mlr_markov_create(4, J, rl, 4, 1, 0, NULL, NULL, NULL, NULL, &mk, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "order 4"));
}
END_TEST

/* ---- a model file by hand (gen_model_file.h) ---------------------------------------------- */

static mlr_status load(const buf *f, size_t n, mlr_gen_model **m, mlr_diag *d)
{
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_status st = mlr_gen_model_load(&ta.base, f->b, n, NULL, m, d);
    if (st) {
        ck_assert_ptr_null(*m);
        ck_assert_uint_eq(ta.live_blocks, 0);
    } else {
        mlr_gen_model_destroy(*m);
        ck_assert_uint_eq(ta.live_blocks, 0);
        st = mlr_gen_model_load(NULL, f->b, n, NULL, m, d);
    }
    return st;
}

START_TEST(hand_written_model_generates)
{
    buf f = model_file(1, 0x01020304u, 0, 6);
    mlr_gen_model *m = NULL;
    mlr_diag d;
    ck_assert_msg(load(&f, f.n, &m, &d) == MLR_OK, "%s", d.message);
    ck_assert_uint_eq(mlr_gen_model_n_joints(m), 2);
    ck_assert_str_eq(mlr_gen_model_joint_name(m, 1), "Spine");
    ck_assert_uint_eq(mlr_gen_model_n_points(m), 6);
    ck_assert_uint_eq(mlr_gen_model_n_primitives(m), 3);
    ck_assert_uint_eq(mlr_gen_model_frame_size(m), 11);
    ck_assert_double_eq(mlr_gen_model_frame_time(m), 1.0 / 30);
    double a[11], b[11];
    mlr_generator *g1 = NULL, *g2 = NULL;
    mlr_generate_option o40[] = {{MLR_GEN_OPT_FRAMES, 40}};
    ck_assert_int_eq(mlr_generator_create(NULL, m, 9, o40, 1, &g1, &d), MLR_OK);
    ck_assert_int_eq(mlr_generator_create(NULL, m, 9, o40, 1, &g2, &d), MLR_OK);
    for (int f_ = 0; f_ < 130; f_++) { /* through three segment starts */
        ck_assert_int_eq(mlr_generator_next(g1, a, &d), MLR_OK);
        ck_assert_int_eq(mlr_generator_next(g2, b, &d), MLR_OK);
        ck_assert_mem_eq(a, b, sizeof a);
        for (int j = 0; j < 2; j++) {
            const double *q = a + 3 + 4 * j;
            ck_assert_double_eq_tol(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0,
                                    1e-14);
        }
        double pt[2];
        mlr_generator_point(g1, pt);
        ck_assert(pt[0] >= 0 && pt[0] <= 2 && pt[1] >= 0 && pt[1] <= 3);
        int64_t prim = mlr_generator_primitive(g1);
        ck_assert(prim >= 0 && prim < 3);
    }
    ck_assert_uint_eq(mlr_generator_frame(g1), 130);
    int64_t sf = mlr_generator_start_frame(g1);
    mlr_rng r;
    mlr_rng_seed(&r, 9);
    ck_assert_int_eq(sf, (int64_t)mlr_rng_below(&r, 6)); /* the first draw */
    mlr_generator_destroy(g1);
    mlr_generator_destroy(g2);
    mlr_gen_model_destroy(m);
    free(f.b);
}
END_TEST

START_TEST(load_from_a_file)
{
    buf f = model_file(1, 0x01020304u, 0, 6);
    mlr_test_temp t;
    mlr_test_temp_write(&t, "walk.mlrgen", f.b, f.n);
    mlr_gen_model *m = NULL;
    mlr_diag d;
    ck_assert_msg(mlr_gen_model_load_file(NULL, t.path, NULL, &m, &d) == MLR_OK, "%s", d.message);
    ck_assert_uint_eq(mlr_gen_model_n_points(m), 6);
    mlr_gen_model_destroy(m);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    ck_assert_int_eq(mlr_gen_model_load_file(&ta.base, t.path, NULL, &m, &d), MLR_OK);
    mlr_gen_model_destroy(m);
    ck_assert_uint_eq(ta.live_blocks, 0);
    mlr_test_temp_remove(&t);
    ck_assert_int_eq(mlr_gen_model_load_file(NULL, t.path, NULL, &m, &d), MLR_E_IO);
    ck_assert_ptr_null(m);
    free(f.b);
}
END_TEST

START_TEST(bad_files_are_refused)
{
    buf f = model_file(1, 0x01020304u, 0, 6);
    mlr_gen_model *m = NULL;
    mlr_diag d;
    for (size_t n = 0; n < f.n; n++) /* every truncation */
        ck_assert_int_eq(load(&f, n, &m, &d), MLR_E_PARSE);
    struct {
        buf file;
        const char *says;
    } cases[] = {
        {model_file(2, 0x01020304u, 0, 6), "model format version 2 (written by mlayer 0.4.0)"},
        {model_file(1, 0x04030201u, 0, 6), "byte-order mark"},
        {model_file(1, 0x01020304u, 17, 6), "bytes after the last field"},
        {model_file(1, 0x01020304u, 40, 6), "40 fields"},
        {model_file(1, 0x01020304u, 0, 5), "field 'points' is 5 x 2"},
        {model_file(1, 0x01020304u, 0, (uint64_t)1 << 61), "run past the end"},
    };
    for (size_t i = 0; i < MLR_COUNTOF(cases); i++) {
        buf *c = &cases[i].file;
        ck_assert_int_eq(load(c, c->n, &m, &d), MLR_E_PARSE);
        ck_assert_msg(strstr(d.message, cases[i].says) != NULL, "case %zu: %s", i, d.message);
        free(c->b);
    }
    /* another magic, a flipped payload byte */
    f.b[3] = 'X';
    ck_assert_int_eq(load(&f, f.n, &m, &d), MLR_E_PARSE);
    ck_assert_ptr_nonnull(strstr(d.message, "magic"));
    f.b[3] = 'G';
    f.b[f.n - 9] ^= 0x40;
    ck_assert_int_eq(load(&f, f.n, &m, &d), MLR_E_PARSE);
    ck_assert_ptr_nonnull(strstr(d.message, "CRC-32"));
    free(f.b);
}
END_TEST

START_TEST(another_skeleton_is_refused)
{
    buf f = model_file(1, 0x01020304u, 0, 6);
    const char *names[2] = {"Hips", "Chest"};
    int32_t parents[2] = {-1, 0};
    double offsets[6] = {0, 0, 0, 0, 1, 0};
    const char *channels[2] = {"Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                               "Zrotation Xrotation Yrotation"};
    mlr_motion *sk = NULL;
    ck_assert_int_eq(mlr_motion_create(2, names, parents, offsets, channels, 0, NULL, NULL, 0,
                                       1.0 / 30, NULL, &sk, NULL),
                     MLR_OK);
    mlr_gen_model *m = NULL;
    mlr_diag d;
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    ck_assert_int_eq(mlr_gen_model_load(&ta.base, f.b, f.n, sk, &m, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(m);
    ck_assert_uint_eq(ta.live_blocks, 0);
    ck_assert_ptr_nonnull(strstr(d.message, "joint 1 is 'Spine' in the model, 'Chest'"));
    mlr_motion_destroy(sk);
    names[1] = "Spine";
    ck_assert_int_eq(mlr_motion_create(2, names, parents, offsets, channels, 0, NULL, NULL, 0,
                                       1.0 / 30, NULL, &sk, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_gen_model_load(NULL, f.b, f.n, sk, &m, &d), MLR_OK);
    mlr_gen_model_destroy(m);
    mlr_motion_destroy(sk);
    free(f.b);
}
END_TEST

START_TEST(bad_options_and_allocation_failures)
{
    buf f = model_file(1, 0x01020304u, 0, 6);
    mlr_gen_model *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_gen_model_load(NULL, f.b, f.n, NULL, &m, &d), MLR_OK);
    mlr_generator *g = NULL;
    struct {
        mlr_generate_option o[2];
        size_t n;
        const char *says;
    } bad[] = {
        {{{77, 1}}, 1, "generate: unknown option key 77"},
        {{{MLR_GEN_OPT_FRAMES, 1}}, 1, "option frames = 1 is not"},
        {{{MLR_GEN_OPT_FRAMES, 2.5}}, 1, "option frames = 2.5 is not"},
        {{{MLR_GEN_OPT_START_FRAME, 6}}, 1, "option start_frame = 6 is not in -1 .. 5"},
        {{{MLR_GEN_OPT_START, 3}}, 1, "option start = 3 is not in -1 .. 2"},
        {{{MLR_GEN_OPT_SMOOTH, -1}}, 1, "option smooth = -1 is not"},
        {{{MLR_GEN_OPT_NOISE, INFINITY}}, 1, "option noise = inf is not finite"},
        {{{MLR_GEN_OPT_ALLOW_UNSEEN, 0.5}}, 1, "option allow_unseen = 0.5 is not"},
        {{{MLR_GEN_OPT_RANK, 1}, {MLR_GEN_OPT_RANK, 2}}, 2, "option rank given twice"},
    };
    for (size_t i = 0; i < MLR_COUNTOF(bad); i++) {
        ck_assert_int_eq(mlr_generator_create(NULL, m, 0, bad[i].o, bad[i].n, &g, &d),
                         MLR_E_INVALID_ARG);
        ck_assert_ptr_null(g);
        ck_assert_msg(strstr(d.message, bad[i].says) != NULL, "%zu: %s", i, d.message);
    }
    ck_assert_int_eq(mlr_generator_create(NULL, m, 0, NULL, 0, &g, &d), MLR_OK);
    ck_assert_int_eq(mlr_generator_next(g, NULL, &d), MLR_E_INVALID_ARG);
    mlr_generator_destroy(g);
    /* every allocation of loading and of a generator's first two segments fails cleanly */
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_gen_model *mm = NULL;
        mlr_status st = mlr_gen_model_load(&ta.base, f.b, f.n, NULL, &mm, &d);
        mlr_generator *gg = NULL;
        /* the perturbed chain's allocations too */
        mlr_generate_option o[] = {{MLR_GEN_OPT_FRAMES, 20}, {MLR_GEN_OPT_NOISE, 0.5}};
        if (!st)
            st = mlr_generator_create(&ta.base, mm, 3, o, 2, &gg, &d);
        double pose[11];
        for (int k = 0; !st && k < 30; k++)
            st = mlr_generator_next(gg, pose, &d);
        mlr_generator_destroy(gg);
        mlr_gen_model_destroy(mm);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (st == MLR_OK)
            break;
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_uint_lt(fail_at, 100);
    }
    mlr_gen_model_destroy(m);
    free(f.b);
}
END_TEST

static Suite *generate_suite(void)
{
    Suite *s = suite_create("generate");
    TCase *t = tcase_create("generate");
    tcase_set_timeout(t, 120);
    tcase_add_test(t, sampled_frequencies_follow_the_row);
    tcase_add_test(t, contexts_back_off);
    tcase_add_test(t, hand_written_model_generates);
    tcase_add_test(t, load_from_a_file);
    tcase_add_test(t, bad_files_are_refused);
    tcase_add_test(t, another_skeleton_is_refused);
    tcase_add_test(t, bad_options_and_allocation_failures);
    suite_add_tcase(s, t);
    return s;
}

int main(void) { return mlr_test_run(generate_suite()); }
