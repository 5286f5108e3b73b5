/* Lead-in trimming: the CMU clips' T-pose and blend frames found and the clean clips left
 * alone; a synthetic figure with a T-pose, a held T-pose and a blend put before its walk, moved,
 * turned, scaled and stood on Z; clips without a lead-in; bad input; allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* ---- the shared clips -------------------------------------------------------------------- */

static mlr_status clip_lead(const mlr_test_clip *c, size_t begin, mlr_trim_lead *out)
{
    const double *root = mlr_motion_root_pos(c->m), *rot = mlr_motion_rot(c->m);
    const double *trans = mlr_motion_trans(c->m);
    const size_t P = c->rig.n_trans;
    mlr_diag d;
    mlr_status st =
        mlr_trim_lead_in(&c->rig, c->n - begin, root + 3 * begin, rot + 4 * c->j * begin,
                         P ? trans + 3 * P * begin : NULL, MLR_AXIS_Y, out, NULL, &d);
    ck_assert_msg(st == MLR_OK, "%s", d.message);
    return st;
}

START_TEST(the_cmu_t_poses_are_trimmed_and_the_clean_clips_are_not)
{
    static const struct {
        const char *file;
        size_t lo, hi; /* the lead-in's frames */
    } clips[] = {
        {"cmu_01_01_playground_jumps.bvh", 1, 1}, /* a T-pose, then the capture */
        {"cmu_10_01_soccer_kick.bvh", 3, 10},     /* a T-pose and a blend of 4-7 frames */
        {"cmu_60_10_salsa_dance.bvh", 3, 10},
        {"cmu_02_03_run_jog_25fps.bvh", 3, 10},
        {"cmu_131_01_mj_style_walk.bvh", 0, 0},   /* 3dsMax-friendly: no T-pose */
        {"lafan1_clip_a.bvh", 0, 0},
        {"bandai1_walk_happy_001.bvh", 0, 0},
        {"ai4a_dog_D1_008_KAN01_002.bvh", 0, 0},
    };
    size_t loaded = 0;
    for (size_t k = 0; k < MLR_COUNTOF(clips); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(clips[k].file))
            continue;
        ck_assert(mlr_test_clip_load(clips[k].file, &c));
        loaded++;
        mlr_trim_lead lead;
        clip_lead(&c, 0, &lead);
        fprintf(stderr,
                "test_trim: %s: lead-in %zu frames (held %zu), frame 0 at %.3g median "
                "steps from the motion\n",
                clips[k].file, lead.n_frames, lead.n_held, lead.distance);
        ck_assert_msg(lead.n_frames >= clips[k].lo && lead.n_frames <= clips[k].hi,
                      "%s: %zu frames", clips[k].file, lead.n_frames);
        if (clips[k].hi == 0) {
            ck_assert_uint_eq(lead.n_held, 0);
            ck_assert_double_le(lead.distance, MLR_TRIM_JUMP);
        } else {
            /* one T-pose frame (the Python suite checks its arms are out) */
            ck_assert_uint_eq(lead.n_held, 1);
            ck_assert_double_gt(lead.distance, MLR_TRIM_JUMP);
            /* the trimmed clip starts with its motion: nothing more to trim */
            mlr_trim_lead again;
            clip_lead(&c, lead.n_frames, &again);
            ck_assert_uint_eq(again.n_frames, 0);
            ck_assert_double_le(again.distance, MLR_TRIM_JUMP);
        }
        mlr_test_clip_unload(&c);
    }
    ck_assert_uint_ge(loaded, 1); /* the bundled walk at least */
}
END_TEST

/* ---- a synthetic figure ------------------------------------------------------------------ */

/* hips, spine, head, two arms, two legs, two hands out to the sides (a T-pose at zero
 * rotations), two feet */
enum { SJ = 11 };
static const int32_t s_parents[SJ] = {-1, 0, 1, 1, 1, 0, 0, 3, 4, 5, 6};
static const double s_offsets[3 * SJ] = {
    0, 0,    0,    0, 0.3,  0, 0, 0.3,   0, 0.2, 0.2, 0,     -0.2, 0.2, 0,     0.1, -0.1,
    0, -0.1, -0.1, 0, 0.55, 0, 0, -0.55, 0, 0,   0,   -0.85, 0,    0,   -0.85, 0};

static void axis_angle(double *q, double x, double y, double z, double angle)
{
    const double s = sin(angle / 2);
    q[0] = cos(angle / 2), q[1] = x * s, q[2] = y * s, q[3] = z * s;
}

static void mul(const double *a, const double *b, double *o)
{
    const double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    const double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    const double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    const double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    o[0] = w, o[1] = x, o[2] = y, o[3] = z;
}

typedef struct figure {
    size_t n;
    double root[3 * 400], rot[4 * SJ * 400];
} figure;

/* A walk of n frames at 120 fps: arms hanging (70 degrees down) and swinging, legs swinging,
 * the body walking along Z while turning slowly. */
static void walk(figure *w, size_t n, size_t first_frame)
{
    w->n = n;
    for (size_t i = 0; i < n; i++) {
        const double t = (double)(i + first_frame) / 120.0, ph = 2 * PI * 1.1 * t;
        double *q = w->rot + 4 * SJ * i;
        axis_angle(q, 0, 1, 0, 0.3 * t);                      /* the hips turn */
        axis_angle(q + 4, 1, 0, 0, 0.05 * sin(ph));
        axis_angle(q + 8, 1, 0, 0, 0.1 * sin(2 * ph));
        double down[4], swing[4];
        axis_angle(down, 0, 0, 1, -70 * PI / 180);
        axis_angle(swing, 1, 0, 0, 0.4 * sin(ph));
        mul(swing, down, q + 12);
        axis_angle(down, 0, 0, 1, 70 * PI / 180);
        axis_angle(swing, 1, 0, 0, -0.4 * sin(ph));
        mul(swing, down, q + 16);
        axis_angle(q + 20, 1, 0, 0, 0.5 * sin(ph));
        axis_angle(q + 24, 1, 0, 0, -0.5 * sin(ph));
        for (size_t j = 7; j < SJ; j++)
            axis_angle(q + 4 * j, 1, 0, 0, 0.0);
        w->root[3 * i] = 0.02 * sin(ph);
        w->root[3 * i + 1] = 1.0 + 0.02 * cos(2 * ph);
        w->root[3 * i + 2] = 1.3 * t;
    }
}

/* Put `held` T-pose frames and `blend` frames blending (nlerp) into frame 0 before the walk. */
static void prepend_lead_in(figure *w, size_t held, size_t blend)
{
    const size_t L = held + blend, n = w->n;
    memmove(w->rot + 4 * SJ * L, w->rot, 4 * SJ * n * sizeof(double));
    memmove(w->root + 3 * L, w->root, 3 * n * sizeof(double));
    for (size_t i = 0; i < L; i++) {
        const double a = i < held ? 0.0 : (double)(i - held + 1) / (double)(blend + 1);
        for (size_t j = 0; j < SJ; j++) {
            const double *to = w->rot + 4 * SJ * L + 4 * j;
            double *q = w->rot + 4 * SJ * i + 4 * j, nq = 0;
            for (int k = 0; k < 4; k++)
                q[k] = (1 - a) * (k == 0) + a * to[k];
            for (int k = 0; k < 4; k++)
                nq += q[k] * q[k];
            for (int k = 0; k < 4; k++)
                q[k] /= sqrt(nq);
        }
        /* the converter keeps the root where the capture starts (as CMU 01_01 does) */
        memcpy(w->root + 3 * i, w->root + 3 * L, 3 * sizeof(double));
    }
    w->n = n + L;
}

static mlr_trim_lead figure_lead(const figure *w, const double *offsets, int up)
{
    mlr_rig r = {SJ, s_parents, offsets, NULL, 0, NULL, 0, NULL, NULL};
    mlr_trim_lead lead;
    mlr_diag d;
    ck_assert_msg(mlr_trim_lead_in(&r, w->n, w->root, w->rot, NULL, up, &lead, NULL, &d) == MLR_OK,
                  "%s", d.message);
    return lead;
}

static figure fig, fig2;

START_TEST(a_t_pose_and_its_blend_are_found_in_any_unit_place_heading_and_up_axis)
{
    static const size_t cases[][2] = {{1, 0}, {1, 3}, {1, 5}, {3, 0}, {2, 4}};
    for (size_t k = 0; k < MLR_COUNTOF(cases); k++) {
        const size_t held = cases[k][0], blend = cases[k][1];
        walk(&fig, 240, 0);
        ck_assert_uint_eq(figure_lead(&fig, s_offsets, MLR_AXIS_Y).n_frames, 0);
        prepend_lead_in(&fig, held, blend);
        mlr_trim_lead lead = figure_lead(&fig, s_offsets, MLR_AXIS_Y);
        ck_assert_msg(lead.n_frames == held + blend && lead.n_held == held,
                      "held %zu, blend %zu: found %zu (held %zu)", held, blend, lead.n_frames,
                      lead.n_held);
        ck_assert_double_gt(lead.distance, MLR_TRIM_JUMP);

        /* in centimetres, moved, turned by 2 radians about up: the same frames, the same
         * distance */
        fig2 = fig;
        double offsets[3 * SJ], turn[4];
        for (size_t i = 0; i < 3 * SJ; i++)
            offsets[i] = 100.0 * s_offsets[i];
        axis_angle(turn, 0, 1, 0, 2.0);
        for (size_t i = 0; i < fig2.n; i++) {
            double *p = fig2.root + 3 * i, *q = fig2.rot + 4 * SJ * i;
            const double x = p[0], z = p[2];
            p[0] = 100.0 * (cos(2.0) * x + sin(2.0) * z) + 500.0;
            p[1] = 100.0 * p[1];
            p[2] = 100.0 * (-sin(2.0) * x + cos(2.0) * z) - 300.0;
            double o[4];
            mul(turn, q, o);
            memcpy(q, o, sizeof o);
        }
        mlr_trim_lead moved = figure_lead(&fig2, offsets, MLR_AXIS_Y);
        ck_assert_uint_eq(moved.n_frames, lead.n_frames);
        ck_assert_uint_eq(moved.n_held, lead.n_held);
        ck_assert_close(moved.distance, lead.distance, 1e-9 * lead.distance);

        /* stood on Z (a proper rotation by +90 degrees about X: Y -> Z), read with up = Z */
        fig2 = fig;
        double zoff[3 * SJ], tilt[4];
        for (size_t j = 0; j < SJ; j++) {
            zoff[3 * j] = s_offsets[3 * j];
            zoff[3 * j + 1] = -s_offsets[3 * j + 2];
            zoff[3 * j + 2] = s_offsets[3 * j + 1];
        }
        axis_angle(tilt, 1, 0, 0, PI / 2);
        for (size_t i = 0; i < fig2.n; i++) {
            double *p = fig2.root + 3 * i, *q = fig2.rot + 4 * SJ * i, o[4], tc[4];
            const double y = p[1], z = p[2];
            p[1] = -z, p[2] = y;
            /* every local rotation R -> T R T^-1: world rotations T W T^-1, positions T p */
            memcpy(tc, tilt, sizeof tc);
            tc[1] = -tc[1];
            for (size_t j = 0; j < SJ; j++) {
                mul(tilt, q + 4 * j, o);
                mul(o, tc, q + 4 * j);
            }
        }
        mlr_trim_lead zup = figure_lead(&fig2, zoff, MLR_AXIS_Z);
        ck_assert_uint_eq(zup.n_frames, lead.n_frames);
        ck_assert_close(zup.distance, lead.distance, 1e-9 * lead.distance);
    }
}
END_TEST

START_TEST(clips_without_a_lead_in_give_zero)
{
    /* a walk that starts in its motion, at any frame of it */
    for (size_t first = 0; first < 120; first += 17) {
        walk(&fig, 200, first);
        mlr_trim_lead lead = figure_lead(&fig, s_offsets, MLR_AXIS_Y);
        ck_assert_uint_eq(lead.n_frames, 0);
        ck_assert_double_le(lead.distance, MLR_TRIM_JUMP);
    }
    /* a T-pose the capture comes back to (a calibration pose in the middle): not a lead-in */
    walk(&fig, 200, 0);
    prepend_lead_in(&fig, 1, 0);
    for (size_t i = 100; i < 110; i++)
        memcpy(fig.rot + 4 * SJ * i, fig.rot, 4 * SJ * sizeof(double));
    ck_assert_uint_eq(figure_lead(&fig, s_offsets, MLR_AXIS_Y).n_frames, 0);
    /* a T-pose before a clip too short to tell (fewer than MLR_TRIM_MIN_FRAMES frames), or
     * before a lead-in longer than a quarter of the clip */
    walk(&fig, MLR_TRIM_MIN_FRAMES - 2, 0);
    prepend_lead_in(&fig, 1, 0);
    ck_assert_uint_eq(fig.n, MLR_TRIM_MIN_FRAMES - 1);
    ck_assert_uint_eq(figure_lead(&fig, s_offsets, MLR_AXIS_Y).n_frames, 0);
    walk(&fig, 12, 0);
    prepend_lead_in(&fig, 5, 0);
    ck_assert_uint_eq(figure_lead(&fig, s_offsets, MLR_AXIS_Y).n_frames, 0);
    walk(&fig, 40, 0);
    prepend_lead_in(&fig, 5, 0);
    ck_assert_uint_eq(figure_lead(&fig, s_offsets, MLR_AXIS_Y).n_frames, 5);
    /* a static clip, and a one-joint rig (no pose) */
    walk(&fig, 50, 0);
    for (size_t i = 1; i < fig.n; i++) {
        memcpy(fig.rot + 4 * SJ * i, fig.rot, 4 * SJ * sizeof(double));
        memcpy(fig.root + 3 * i, fig.root, 3 * sizeof(double));
    }
    mlr_trim_lead still = figure_lead(&fig, s_offsets, MLR_AXIS_Y);
    ck_assert_uint_eq(still.n_frames, 0);
    ck_assert_double_eq(still.distance, 0.0);
    mlr_rig one = {1, s_parents, s_offsets, NULL, 0, NULL, 0, NULL, NULL};
    double rot1[4 * 20], root1[3 * 20];
    for (size_t i = 0; i < 20; i++) {
        axis_angle(rot1 + 4 * i, 0, 1, 0, (double)i);
        root1[3 * i] = root1[3 * i + 1] = root1[3 * i + 2] = (double)i;
    }
    mlr_trim_lead lead;
    ck_assert_int_eq(mlr_trim_lead_in(&one, 20, root1, rot1, NULL, MLR_AXIS_Y, &lead, NULL, NULL),
                     MLR_OK);
    ck_assert_uint_eq(lead.n_frames, 0);
}
END_TEST

START_TEST(bad_input_says_why)
{
    walk(&fig, 30, 0);
    mlr_rig r = {SJ, s_parents, s_offsets, NULL, 0, NULL, 0, NULL, NULL};
    mlr_trim_lead lead;
    mlr_diag d;
    ck_assert_int_eq(
        mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, NULL, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "out is NULL"));
    ck_assert_int_eq(
        mlr_trim_lead_in(&r, fig.n, fig.root, NULL, NULL, MLR_AXIS_Y, &lead, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "rot is NULL"));
    ck_assert_int_eq(mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, 3, &lead, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "up axis 3"));
    ck_assert_int_eq(mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, -1, &lead, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(
        mlr_trim_lead_in(NULL, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &lead, NULL, &d),
        MLR_E_INVALID_ARG);
    static const int32_t bad_parents[SJ] = {-1, 0, 5, 1, 1, 0, 0, 3, 4, 5, 6};
    mlr_rig bad = r;
    bad.parents = bad_parents;
    ck_assert_int_eq(
        mlr_trim_lead_in(&bad, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &lead, NULL, &d),
        MLR_E_INVALID_ARG);
    static const int32_t trans_joints[1] = {1};
    mlr_rig tr = r;
    tr.n_trans = 1;
    tr.trans_joints = trans_joints;
    ck_assert_int_eq(
        mlr_trim_lead_in(&tr, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &lead, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "trans is NULL"));
    fig.rot[4 * SJ * 7 + 4 * 3 + 1] = NAN;
    ck_assert_int_eq(
        mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &lead, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "frame 7 has non-finite"));
    walk(&fig, 30, 0);
    fig.root[3 * 4 + 2] = INFINITY;
    ck_assert_int_eq(
        mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &lead, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_uint_eq(lead.n_frames, 0);
    /* no frames: nothing to trim, rot may be NULL */
    ck_assert_int_eq(mlr_trim_lead_in(&r, 0, NULL, NULL, NULL, MLR_AXIS_Y, &lead, NULL, &d),
                     MLR_OK);
    ck_assert_uint_eq(lead.n_frames, 0);
}
END_TEST

START_TEST(every_allocation_failure_is_no_memory_without_leaks)
{
    walk(&fig, 120, 0);
    prepend_lead_in(&fig, 1, 3);
    mlr_rig r = {SJ, s_parents, s_offsets, NULL, 0, NULL, 0, NULL, NULL};
    mlr_trim_lead ref;
    ck_assert_int_eq(
        mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &ref, NULL, NULL),
        MLR_OK);
    size_t fails = 0;
    for (size_t at = 0;; at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, at);
        mlr_trim_lead lead;
        mlr_diag d;
        const mlr_status st =
            mlr_trim_lead_in(&r, fig.n, fig.root, fig.rot, NULL, MLR_AXIS_Y, &lead, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        ck_assert_uint_eq(ta.live_bytes, 0);
        if (st == MLR_OK) {
            ck_assert_uint_eq(lead.n_frames, ref.n_frames);
            ck_assert_double_eq(lead.distance, ref.distance);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_ptr_nonnull(strstr(d.message, "out of memory"));
        ck_assert_uint_eq(lead.n_frames, 0);
        fails++;
    }
    ck_assert_uint_eq(fails, 2u); /* the joint mask and the poses */
}
END_TEST

static Suite *trim_suite(void)
{
    Suite *s = suite_create("trim");
    TCase *tc = tcase_create("core");
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, the_cmu_t_poses_are_trimmed_and_the_clean_clips_are_not);
    tcase_add_test(tc, a_t_pose_and_its_blend_are_found_in_any_unit_place_heading_and_up_axis);
    tcase_add_test(tc, clips_without_a_lead_in_give_zero);
    tcase_add_test(tc, bad_input_says_why);
    tcase_add_test(tc, every_allocation_failure_is_no_memory_without_leaks);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(trim_suite()); }
