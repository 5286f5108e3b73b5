/* Rigs by reference: checks, points by name, End Site positions, body height, the joint that
 * carries the body translation (synthetic rigs and the real clips). */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* root -> thigh -> shin -> foot (with an End Site 2 units ahead) */
static const int32_t parents[4] = {-1, 0, 1, 2};
static const double offsets[12] = {0, 10, 0, 1, -0.5, 0, 0, -4, 0, 0, -4, 0};
static const char *const names[4] = {"Hips", "LeftUpLeg", "LeftLeg", "LeftFoot"};
static const int32_t end_parents[1] = {3};
static const double end_offsets[3] = {0, 0, 2};

static mlr_rig leg_rig(void)
{
    mlr_rig r = {4, parents, offsets, names, 0, NULL, 1, end_parents, end_offsets};
    return r;
}

START_TEST(a_valid_rig_checks_and_bad_ones_say_why)
{
    mlr_rig r = leg_rig();
    mlr_diag d;
    ck_assert_int_eq(mlr_rig_check(&r, &d), MLR_OK);
    int32_t bad_parents[4] = {-1, 0, 3, 2};
    r.parents = bad_parents;
    ck_assert_int_eq(mlr_rig_check(&r, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "parents[2]"));
    r = leg_rig();
    int32_t bad_end[1] = {7};
    r.end_site_parents = bad_end;
    ck_assert_int_eq(mlr_rig_check(&r, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "End Site 0"));
    ck_assert_int_eq(mlr_rig_check(NULL, &d), MLR_E_INVALID_ARG);
}
END_TEST

START_TEST(points_are_found_by_name_and_end_suffix)
{
    mlr_rig r = leg_rig();
    mlr_diag d;
    int32_t j, e;
    ck_assert_int_eq(mlr_rig_find_point(&r, "LeftLeg", &j, &e, &d), MLR_OK);
    ck_assert_int_eq(j, 2);
    ck_assert_int_eq(e, -1);
    ck_assert_int_eq(mlr_rig_find_point(&r, "LeftFoot/End", &j, &e, &d), MLR_OK);
    ck_assert_int_eq(j, 3);
    ck_assert_int_eq(e, 0);
    ck_assert_int_eq(mlr_rig_find_point(&r, "LeftLeg/End", &j, &e, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "no End Site"));
    ck_assert_int_eq(mlr_rig_find_point(&r, "Head", &j, &e, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "Head"));
    r.names = NULL;
    ck_assert_int_eq(mlr_rig_find_point(&r, "Hips", &j, &e, &d), MLR_E_INVALID_ARG);
}
END_TEST

START_TEST(end_site_positions_follow_the_joint_rotation)
{
    mlr_rig r = leg_rig();
    /* one frame; the foot turned 90 degrees about +Y: the End Site's +Z goes to +X */
    double pos[12] = {0, 10, 0, 1, 9.5, 0, 1, 5.5, 0, 1, 1.5, 0};
    double rot[16] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0};
    rot[12] = sqrt(0.5);
    rot[14] = sqrt(0.5);
    int32_t joints[2] = {3, 3}, ends[2] = {-1, 0};
    double out[6];
    mlr_diag d;
    ck_assert_int_eq(mlr_rig_point_positions(&r, 1, pos, rot, 2, joints, ends, out, &d), MLR_OK);
    ck_assert_close(out[0], 1.0, 1e-15);
    ck_assert_close(out[1], 1.5, 1e-15);
    ck_assert_close(out[3], 3.0, 1e-12);
    ck_assert_close(out[4], 1.5, 1e-12);
    ck_assert_close(out[5], 0.0, 1e-12);
    int32_t wrong[2] = {2, 2};
    ck_assert_int_eq(mlr_rig_point_positions(&r, 1, pos, rot, 2, wrong, ends, out, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_rig_point_positions(&r, 1, pos, NULL, 2, joints, ends, out, &d),
                     MLR_E_INVALID_ARG);
}
END_TEST

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

START_TEST(body_height_is_the_median_extent_on_the_up_axis)
{
    /* 4 frames of 2 joints: extents along Z of 1, 3, 2, 10 -> median 2.5; along Y always 0 */
    double pos[4 * 2 * 3] = {0};
    const double ext[4] = {1, 3, 2, 10};
    for (int f = 0; f < 4; f++)
        pos[6 * f + 5] = ext[f];
    double h;
    mlr_diag d;
    ck_assert_int_eq(mlr_rig_body_height(4, 2, pos, MLR_AXIS_Z, &h, NULL, &d), MLR_OK);
    ck_assert_close(h, 2.5, 0.0);
    ck_assert_int_eq(mlr_rig_body_height(3, 2, pos, MLR_AXIS_Z, &h, NULL, &d), MLR_OK);
    ck_assert_close(h, 2.0, 0.0);
    ck_assert_int_eq(mlr_rig_body_height(4, 2, pos, MLR_AXIS_Y, &h, NULL, &d), MLR_OK);
    ck_assert_close(h, 0.0, 0.0);
    ck_assert_int_eq(mlr_rig_body_height(4, 2, pos, 3, &h, NULL, &d), MLR_E_INVALID_ARG);
    pos[7] = NAN;
    ck_assert_int_eq(mlr_rig_body_height(4, 2, pos, MLR_AXIS_Y, &h, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "frame 1"));
    pos[7] = 0;
    /* 201 frames of 7 joints (blocks of 64 frames and a remainder): the median of each frame's
       extent, against a plain scan; an infinity named by its joint and frame */
    enum { NF = 201, NJ = 7 };
    double *big = malloc(sizeof(double) * 3 * NF * NJ), ref_ext[NF];
    ck_assert_ptr_nonnull(big);
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 86);
    for (size_t i = 0; i < 3 * NF * NJ; i++)
        big[i] = mlr_test_rng_normal(&r);
    for (size_t f = 0; f < NF; f++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t j = 0; j < NJ; j++)
            lo = fmin(lo, big[3 * (f * NJ + j) + 1]), hi = fmax(hi, big[3 * (f * NJ + j) + 1]);
        ref_ext[f] = hi - lo;
    }
    qsort(ref_ext, NF, sizeof ref_ext[0], cmp_double);
    ck_assert_int_eq(mlr_rig_body_height(NF, NJ, big, MLR_AXIS_Y, &h, NULL, &d), MLR_OK);
    ck_assert_double_eq(h, ref_ext[NF / 2]);
    big[3 * (130 * NJ + 5) + 1] = INFINITY;
    ck_assert_int_eq(mlr_rig_body_height(NF, NJ, big, MLR_AXIS_Y, &h, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "joint 5 at frame 130"));
    free(big);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    ck_assert_int_eq(mlr_rig_body_height(4, 2, pos, MLR_AXIS_Y, &h, &ta.base, &d),
                     MLR_E_NO_MEMORY);
    ck_assert_uint_eq(ta.live_blocks, 0);
}
END_TEST

/* root 0 -> A 1 -> B 2, root -> C 3 (depth-first order); B and C have position channels.
 * B is deeper than C but comes first in joint order. */
static const int32_t tparents[4] = {-1, 0, 1, 0};
static const double toffsets[12] = {0, 0, 0, 0, 10, 0, 0, 5, 0, 3, 8, 0};
static const int32_t ttrans[2] = {2, 3};

static mlr_rig trans_rig(void)
{
    mlr_rig r = {4, tparents, toffsets, NULL, 2, ttrans, 0, NULL, NULL};
    return r;
}

/* N frames: root static at (1, 2, 3); B and C at their OFFSETs, plus moves given per joint
 * (amplitude along x, as a sine). The rest pose's size is 15 (B at y = 15). */
static void trans_frames(size_t n, double root_move, double b_move, double c_move, double *root,
                         double *trans)
{
    for (size_t f = 0; f < n; f++) {
        const double w = sin(0.3 * (double)f);
        root[3 * f] = 1.0 + root_move * w, root[3 * f + 1] = 2.0, root[3 * f + 2] = 3.0;
        for (int c = 0; c < 3; c++) {
            trans[6 * f + (size_t)c] = toffsets[6 + c];
            trans[6 * f + 3 + (size_t)c] = toffsets[9 + c];
        }
        trans[6 * f] += b_move * w;
        trans[6 * f + 3 + 2] += c_move * w;
    }
}

START_TEST(body_translation_joint_synthetic)
{
    enum { N = 40 };
    double root[3 * N], trans[6 * N];
    mlr_rig r = trans_rig();
    mlr_diag d;
    int32_t j = -7;
    /* nothing moves: the root */
    trans_frames(N, 0, 0, 0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 0);
    /* the root moves: the root, whatever else moves */
    trans_frames(N, 0.5, 2.0, 2.0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 0);
    /* static root, both move: the topmost (C, depth 1) over the first in order (B, depth 2) */
    trans_frames(N, 0, 2.0, 2.0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 3);
    /* only B moves */
    trans_frames(N, 0, 2.0, 0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 2);
    /* rounding: spans of 1e-6 of the body size (15) are not motion, 1e-4 is */
    trans_frames(N, 0, 2.0, 15e-6, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 2);
    trans_frames(N, 15e-6, 0, 15e-4, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 3);
    trans_frames(N, 15e-4, 0, 15e-4, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 0);
    /* the threshold scales with the body: the same motion on a rig 1000 times larger (its
     * OFFSETs in the channels) is rounding */
    double big[12];
    for (int k = 0; k < 12; k++)
        big[k] = 1000.0 * toffsets[k];
    mlr_rig rb = r;
    rb.offsets = big;
    trans_frames(N, 0, 0, 15e-4, root, trans);
    for (size_t f = 0; f < N; f++)
        for (int c = 0; c < 6; c++)
            trans[6 * f + (size_t)c] += big[6 + c] - toffsets[6 + c];
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 3); /* a span of 2e-4 of the small rig's size */
    ck_assert_int_eq(mlr_rig_body_translation_joint(&rb, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 0);
    trans_frames(N, 0, 0, 15e-4 * 1000.0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&rb, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 3);
    /* a rig without extent: rounding relative to the data */
    const double zero[12] = {0};
    mlr_rig rz = r;
    rz.offsets = zero;
    trans_frames(N, 0, 2.0, 0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&rz, N, root, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 2);
    /* no frames, no trans joints, a NULL root (static) */
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, 0, NULL, NULL, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 0);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, NULL, trans, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 2);
    mlr_rig rn = r;
    rn.n_trans = 0;
    rn.trans_joints = NULL;
    trans_frames(N, 0, 0, 0, root, trans);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&rn, N, root, NULL, &j, &d), MLR_OK);
    ck_assert_int_eq(j, 0);
}
END_TEST

START_TEST(body_translation_joint_bad_input)
{
    enum { N = 10 };
    double root[3 * N], trans[6 * N];
    trans_frames(N, 0, 2.0, 0, root, trans);
    mlr_rig r = trans_rig();
    mlr_diag d;
    int32_t j = 5;
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "joint is NULL"));
    ck_assert_int_eq(mlr_rig_body_translation_joint(NULL, N, root, trans, &j, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(j, 0);
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, NULL, &j, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "trans is NULL"));
    int32_t bad_trans[2] = {3, 2};
    mlr_rig rb = r;
    rb.trans_joints = bad_trans;
    ck_assert_int_eq(mlr_rig_body_translation_joint(&rb, N, root, trans, &j, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "trans_joints"));
    trans[6 * 4 + 4] = NAN;
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "frame 4"));
    trans[6 * 4 + 4] = 8.0;
    root[3 * 7 + 1] = INFINITY;
    ck_assert_int_eq(mlr_rig_body_translation_joint(&r, N, root, trans, &j, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "root translation at frame 7"));
}
END_TEST

/* The real clips: Bandai's walk is in Hips (joint 1) under a static joint_Root; every other
 * clip moves its root. */
START_TEST(body_translation_joint_real_clips)
{
    const struct {
        const char *file;
        const char *joint;
    } cases[] = {
        {"bandai1_walk_happy_001.bvh", "Hips"},    {"cmu_131_01_mj_style_walk.bvh", "Hips"},
        {"cmu_10_01_soccer_kick.bvh", "hip"},      {"lafan1_clip_a.bvh", "Hips"},
        {"ai4a_dog_D1_008_KAN01_002.bvh", "Hips"},
    };
    for (size_t i = 0; i < MLR_COUNTOF(cases); i++) {
        char path[4096];
        if (!MLR_TEST_HAVE_CLIP(cases[i].file))
            continue;
        mlr_test_clip_path(cases[i].file, path, sizeof path);
        mlr_motion *m = NULL;
        mlr_diag d;
        ck_assert_msg(mlr_bvh_read_file(path, NULL, &m, &d) == MLR_OK, "%s: %s", path, d.message);
        const size_t J = mlr_motion_n_joints(m);
        const char **nm = malloc(J * sizeof *nm);
        for (size_t k = 0; k < J; k++)
            nm[k] = mlr_motion_joint_name(m, k);
        mlr_rig r = {J,
                     mlr_motion_parents(m),
                     mlr_motion_offsets(m),
                     nm,
                     mlr_motion_n_trans(m),
                     mlr_motion_trans_joints(m),
                     mlr_motion_n_end_sites(m),
                     mlr_motion_end_site_parents(m),
                     mlr_motion_end_site_offsets(m)};
        int32_t j = -1;
        ck_assert_msg(mlr_rig_body_translation_joint(&r, mlr_motion_n_frames(m),
                                                     mlr_motion_root_pos(m), mlr_motion_trans(m),
                                                     &j, &d) == MLR_OK,
                      "%s: %s", cases[i].file, d.message);
        ck_assert_msg(strcmp(nm[j], cases[i].joint) == 0, "%s: body joint %s, expected %s",
                      cases[i].file, nm[j], cases[i].joint);
        if (strstr(cases[i].file, "bandai")) {
            ck_assert_int_eq(j, 1); /* not the root */
            ck_assert_uint_eq(mlr_motion_n_trans(m), J - 1);
        } else {
            ck_assert_int_eq(j, 0);
        }
        free(nm);
        mlr_motion_destroy(m);
    }
}
END_TEST

/* ---- depth-first order of a tree listed in any order ------------------------------------- */

/* Reference: recursive preorder, children in input order. */
static void dfo_reference(size_t J, const int32_t *parents, int32_t j, int32_t *out, size_t *n)
{
    out[(*n)++] = j;
    for (size_t c = 0; c < J; c++)
        if (parents[c] == j)
            dfo_reference(J, parents, (int32_t)c, out, n);
}

START_TEST(depth_first_order_of_shuffled_trees_matches_a_recursive_walk)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 2024);
    for (int trial = 0; trial < 200; trial++) {
        const size_t J = 1 + (size_t)(mlr_test_rng_uniform(&r) * 60);
        int32_t pre[64], perm[64], inv[64], parents[64], order[64], ref[64];
        /* a random tree in depth-first order: each joint's parent is the previous joint or one
           of its ancestors */
        pre[0] = -1;
        for (size_t j = 1; j < J; j++) {
            int32_t p = (int32_t)j - 1;
            while (p > 0 && mlr_test_rng_uniform(&r) < 0.4)
                p = pre[p];
            pre[j] = p;
        }
        /* listed in a random order: input joint i is tree joint perm[i] */
        for (size_t i = 0; i < J; i++)
            perm[i] = (int32_t)i;
        for (size_t i = J; i > 1; i--) {
            const size_t k = (size_t)(mlr_test_rng_uniform(&r) * (double)i);
            const int32_t t = perm[i - 1];
            perm[i - 1] = perm[k], perm[k] = t;
        }
        for (size_t i = 0; i < J; i++)
            inv[perm[i]] = (int32_t)i;
        for (size_t i = 0; i < J; i++)
            parents[i] = pre[perm[i]] < 0 ? -1 : inv[pre[perm[i]]];
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, SIZE_MAX);
        mlr_diag d = {0};
        ck_assert_int_eq(mlr_rig_depth_first_order(J, parents, NULL, order, &ta.base, &d), MLR_OK);
        ck_assert_uint_eq(ta.live_blocks, 0);
        size_t n = 0;
        dfo_reference(J, parents, inv[0], ref, &n);
        ck_assert_uint_eq(n, J);
        for (size_t k = 0; k < J; k++)
            ck_assert_int_eq(order[k], ref[k]);
        /* the reordered tree is in depth-first order: mlr_rig_check accepts it */
        int32_t where[64], reordered[64];
        double offsets[3 * 64] = {0};
        for (size_t k = 0; k < J; k++)
            where[order[k]] = (int32_t)k;
        for (size_t k = 0; k < J; k++)
            reordered[k] = parents[order[k]] < 0 ? -1 : where[parents[order[k]]];
        const mlr_rig rig = {J, reordered, offsets, NULL, 0, NULL, 0, NULL, NULL};
        ck_assert_int_eq(mlr_rig_check(&rig, &d), MLR_OK);
        /* a tree already in depth-first order gives the identity */
        ck_assert_int_eq(mlr_rig_depth_first_order(J, pre, NULL, order, NULL, &d), MLR_OK);
        for (size_t k = 0; k < J; k++)
            ck_assert_int_eq(order[k], (int32_t)k);
    }
}
END_TEST

START_TEST(depth_first_order_refuses_what_is_not_one_tree)
{
    static const char *const names[4] = {"Hips", "Spine", "Head", "Arm"};
    int32_t order[4];
    mlr_diag d = {0};
    static const int32_t two_roots[4] = {-1, 0, -1, 2};
    ck_assert_int_eq(mlr_rig_depth_first_order(4, two_roots, names, order, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "2 roots"));
    ck_assert_ptr_nonnull(strstr(d.message, "'Head'"));
    static const int32_t no_root[4] = {1, 0, 1, 2};
    ck_assert_int_eq(mlr_rig_depth_first_order(4, no_root, names, order, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "no root"));
    static const int32_t cycle[4] = {-1, 0, 3, 2}; /* Head and Arm are each other's parent */
    ck_assert_int_eq(mlr_rig_depth_first_order(4, cycle, names, order, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "'Head' (index 2) is not below the root"));
    static const int32_t self[4] = {-1, 0, 2, 0};
    ck_assert_int_eq(mlr_rig_depth_first_order(4, self, NULL, order, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "joint 2 is its own parent"));
    static const int32_t outside[4] = {-1, 0, 7, 0};
    ck_assert_int_eq(mlr_rig_depth_first_order(4, outside, names, order, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "outside -1..3"));
    ck_assert_int_eq(mlr_rig_depth_first_order(0, outside, NULL, order, NULL, &d),
                     MLR_E_INVALID_ARG);
    static const int32_t ok[4] = {-1, 0, 1, 0};
    for (size_t k = 0; k < 3; k++) { /* every allocation failure */
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        ck_assert_int_eq(mlr_rig_depth_first_order(4, ok, NULL, order, &ta.base, &d),
                         MLR_E_NO_MEMORY);
        ck_assert_uint_eq(ta.live_blocks, 0);
    }
}
END_TEST

static Suite *rig_suite(void)
{
    Suite *s = suite_create("rig");
    TCase *tc = tcase_create("rig");
    tcase_add_test(tc, a_valid_rig_checks_and_bad_ones_say_why);
    tcase_add_test(tc, points_are_found_by_name_and_end_suffix);
    tcase_add_test(tc, end_site_positions_follow_the_joint_rotation);
    tcase_add_test(tc, body_height_is_the_median_extent_on_the_up_axis);
    tcase_add_test(tc, body_translation_joint_synthetic);
    tcase_add_test(tc, body_translation_joint_bad_input);
    tcase_add_test(tc, body_translation_joint_real_clips);
    tcase_add_test(tc, depth_first_order_of_shuffled_trees_matches_a_recursive_walk);
    tcase_add_test(tc, depth_first_order_refuses_what_is_not_one_tree);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(rig_suite()); }
