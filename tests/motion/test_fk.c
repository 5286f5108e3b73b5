/* Forward kinematics: a hand-computed chain, translations that replace OFFSETs, the motion and
 * array entry points agreeing, invariants on the real clips, arguments and allocations. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define S2 0.70710678118654752440

/* Root at (1,2,3) turned 90 deg about Z; joint 1 at OFFSET (1,0,0) turned 90 deg about X;
 * joint 2 at OFFSET (0,1,0). By hand:
 *   p1 = (1,2,3) + Rz90 (1,0,0) = (1,3,3)
 *   p2 = p1 + Rz90 Rx90 (0,1,0) = (1,3,3) + Rz90 (0,0,1) = (1,3,4)
 *   world rot of 1 and 2 = Rz90 * Rx90 = (1/2, 1/2, 1/2, 1/2). */
static const int32_t chain_parents[3] = {-1, 0, 1};
static const double chain_offsets[9] = {9, 9, 9, 1, 0, 0, 0, 1, 0};
static const double chain_root[3] = {1, 2, 3};
static const double chain_rot[12] = {S2, 0, 0, S2, S2, S2, 0, 0, 1, 0, 0, 0};

START_TEST(hand_computed_chain)
{
    double wp[9], wr[12];
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, chain_root, chain_rot, 0,
                                   NULL, NULL, wp, wr, NULL, NULL),
                     MLR_OK);
    const double expect_p[9] = {1, 2, 3, 1, 3, 3, 1, 3, 4};
    for (int i = 0; i < 9; i++)
        ck_assert_close(wp[i], expect_p[i], 1e-15);
    const double expect_r[12] = {S2, 0, 0, S2, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5};
    for (int i = 0; i < 12; i++)
        ck_assert_close(wr[i], expect_r[i], 1e-15);

    /* no root_pos: the root sits at its OFFSET; no world_rot wanted: same positions */
    double wp2[9];
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, NULL, chain_rot, 0, NULL,
                                   NULL, wp2, NULL, NULL, NULL),
                     MLR_OK);
    for (int i = 0; i < 9; i++)
        ck_assert_close(wp2[i], expect_p[i] + 9 - chain_root[i % 3], 1e-14);
}
END_TEST

START_TEST(translations_replace_offsets)
{
    /* joint 1 gets a per-frame translation (5,0,0) instead of its OFFSET (1,0,0) */
    const int32_t tj[1] = {1};
    const double tr[6] = {5, 0, 0, 0, 0, 2};
    double rot2[24], root2[6] = {1, 2, 3, 0, 0, 0};
    memcpy(rot2, chain_rot, sizeof chain_rot);
    memcpy(rot2 + 12, chain_rot, sizeof chain_rot);
    double wp[18];
    ck_assert_int_eq(mlr_fk_arrays(2, 3, chain_parents, chain_offsets, root2, rot2, 1, tj, tr, wp,
                                   NULL, NULL, NULL),
                     MLR_OK);
    /* frame 0: p1 = (1,2,3) + Rz90 (5,0,0) = (1,7,3); p2 = p1 + (0,0,1) */
    const double e0[9] = {1, 2, 3, 1, 7, 3, 1, 7, 4};
    /* frame 1: root at 0, p1 = Rz90 (0,0,2) = (0,0,2); p2 = (0,0,3) */
    const double e1[9] = {0, 0, 0, 0, 0, 2, 0, 0, 3};
    for (int i = 0; i < 9; i++) {
        ck_assert_close(wp[i], e0[i], 1e-14);
        ck_assert_close(wp[9 + i], e1[i], 1e-14);
    }
}
END_TEST

START_TEST(bad_arguments)
{
    double wp[9];
    const int32_t p_bad0[3] = {0, 0, 1}, p_fwd[3] = {-1, 2, 0}, p_neg[3] = {-1, 0, -1};
    const int32_t tj_root[1] = {0}, tj_far[1] = {3}, tj_dup[2] = {2, 2};
    const double tr[6] = {0};
    ck_assert_int_eq(mlr_fk_arrays(1, 0, chain_parents, chain_offsets, NULL, chain_rot, 0, NULL,
                                   NULL, wp, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, p_bad0, chain_offsets, NULL, chain_rot, 0, NULL, NULL, wp,
                                   NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, p_fwd, chain_offsets, NULL, chain_rot, 0, NULL, NULL, wp,
                                   NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, p_neg, chain_offsets, NULL, chain_rot, 0, NULL, NULL, wp,
                                   NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, NULL, chain_rot, 1, tj_root,
                                   tr, wp, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, NULL, chain_rot, 1, tj_far,
                                   tr, wp, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, NULL, chain_rot, 2, tj_dup,
                                   tr, wp, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, NULL, NULL, 0, NULL, NULL,
                                   wp, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_fk_arrays(1, 3, chain_parents, chain_offsets, NULL, chain_rot, 1, NULL,
                                   NULL, wp, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    /* zero frames is fine */
    ck_assert_int_eq(mlr_fk_arrays(0, 3, chain_parents, chain_offsets, NULL, NULL, 0, NULL, NULL,
                                   NULL, NULL, NULL, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_fk_motion(NULL, 0, 0, wp, NULL, NULL), MLR_E_INVALID_ARG);
}
END_TEST

/* a long chain of 300 joints, each turned a little: positions with and without world_rot
 * agree; the scratch allocation for J > 256 fails cleanly */
START_TEST(big_skeleton_scratch)
{
    enum { J = 300, N = 3 };
    int32_t par[J];
    double off[3 * J], rot[4 * J * N], wp[3 * J * N], wp2[3 * J * N], wr[4 * J * N];
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 11);
    for (int j = 0; j < J; j++) {
        par[j] = j - 1;
        for (int k = 0; k < 3; k++)
            off[3 * j + k] = mlr_test_rng_normal(&rng);
    }
    for (int i = 0; i < J * N; i++) {
        double q[4], n = 0;
        for (int k = 0; k < 4; k++) {
            q[k] = mlr_test_rng_normal(&rng);
            n += q[k] * q[k];
        }
        for (int k = 0; k < 4; k++)
            rot[4 * i + k] = q[k] / sqrt(n);
    }
    ck_assert_int_eq(mlr_fk_arrays(N, J, par, off, NULL, rot, 0, NULL, NULL, wp, wr, NULL, NULL),
                     MLR_OK);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_status s =
            mlr_fk_arrays(N, J, par, off, NULL, rot, 0, NULL, NULL, wp2, NULL, &ta.base, NULL);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
    }
    for (int i = 0; i < 3 * J * N; i++)
        ck_assert_double_eq(wp[i], wp2[i]);
    /* every bone keeps its length */
    for (int f = 0; f < N; f++)
        for (int j = 1; j < J; j++) {
            double d = 0, o = 0;
            for (int k = 0; k < 3; k++) {
                double t = wp[3 * (J * f + j) + k] - wp[3 * (J * f + j - 1) + k];
                d += t * t;
                o += off[3 * j + k] * off[3 * j + k];
            }
            ck_assert_close(sqrt(d), sqrt(o), 1e-12);
        }
}
END_TEST

static const char *const clip_files[] = {
    "cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",  "cmu_10_01_soccer_kick.bvh",
    "cmu_60_10_salsa_dance.bvh",      "cmu_02_03_run_jog_25fps.bvh",   "lafan1_clip_a.bvh",
    "bandai1_walk_happy_001.bvh",     "ai4a_dog_D1_008_KAN01_002.bvh",
};

/* On every clip (the shared ones, or the repository's when they are absent): the motion and array entry points agree, a frame range equals the same rows
 * of the whole, and each bone keeps the length of its local translation. */
START_TEST(clips_motion_and_arrays_agree)
{
    /* any real clip: without the shared ones, the bundled walk and the wild clips */
    char path[4096];
    ck_assert_ptr_nonnull(mlr_test_any_clip_path(clip_files[_i], (size_t)_i, path, sizeof path));
    mlr_motion *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &m, &d), MLR_OK);
    size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m);
    double *wp = malloc(3 * N * J * sizeof(double)), *wr = malloc(4 * N * J * sizeof(double));
    double *wp2 = malloc(3 * N * J * sizeof(double));
    ck_assert_int_eq(mlr_fk_motion(m, 0, N, wp, wr, NULL), MLR_OK);
    ck_assert_int_eq(mlr_fk_arrays(N, J, mlr_motion_parents(m), mlr_motion_offsets(m),
                                   mlr_motion_root_pos(m), mlr_motion_rot(m), P,
                                   mlr_motion_trans_joints(m), mlr_motion_trans(m), wp2, NULL,
                                   NULL, NULL),
                     MLR_OK);
    ck_assert_int_eq(memcmp(wp, wp2, 3 * N * J * sizeof(double)), 0);
    size_t b = N / 3, c = N / 4;
    ck_assert_int_eq(mlr_fk_motion(m, b, c, wp2, NULL, NULL), MLR_OK);
    ck_assert_int_eq(memcmp(wp + 3 * J * b, wp2, 3 * c * J * sizeof(double)), 0);
    ck_assert_int_eq(mlr_fk_motion(m, N - 1, 2, wp2, NULL, NULL), MLR_E_INVALID_ARG);
    const int32_t *par = mlr_motion_parents(m), *tj = mlr_motion_trans_joints(m);
    const double *off = mlr_motion_offsets(m), *tr = mlr_motion_trans(m);
    for (size_t f = 0; f < N; f += 7) {
        size_t slot = 0;
        for (size_t j = 1; j < J; j++) {
            const double *t = off + 3 * j;
            if (slot < P && (size_t)tj[slot] == j)
                t = tr + 3 * (P * f + slot++);
            double dd = 0, oo = 0;
            for (int k = 0; k < 3; k++) {
                double x = wp[3 * (J * f + j) + k] - wp[3 * (J * f + (size_t)par[j]) + k];
                dd += x * x;
                oo += t[k] * t[k];
            }
            ck_assert_close(sqrt(dd), sqrt(oo), 1e-9 * (1 + sqrt(oo)));
            const double *q = wr + 4 * (J * f + j);
            ck_assert_close(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
        }
    }
    free(wp);
    free(wr);
    free(wp2);
    mlr_motion_destroy(m);
}
END_TEST

static Suite *fk_suite(void)
{
    Suite *s = suite_create("fk");
    TCase *tc = tcase_create("fk");
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, hand_computed_chain);
    tcase_add_test(tc, translations_replace_offsets);
    tcase_add_test(tc, bad_arguments);
    tcase_add_test(tc, big_skeleton_scratch);
    tcase_add_loop_test(tc, clips_motion_and_arrays_agree, 0, (int)MLR_COUNTOF(clip_files));
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(fk_suite()); }
