/* Up-axis detection: the shared clips (Y-up) and copies of them turned to Z-up, X-up and upside
 * down, with foot names and without; bad input; allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const clips[] = {
    "cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh", "cmu_10_01_soccer_kick.bvh",
    "cmu_60_10_salsa_dance.bvh",      "cmu_02_03_run_jog_25fps.bvh",  "lafan1_clip_a.bvh",
    "bandai1_walk_happy_001.bvh",     "ai4a_dog_D1_008_KAN01_002.bvh"};

/* World positions of a clip (at most 1200 frames), turned so that the file's +Y becomes
 * sign * axis: each point p -> R p for a proper rotation R (a right-handed frame). */
static double *turned_positions(const mlr_test_clip *c, size_t n, int axis, int sign)
{
    double *wp = malloc(3 * n * c->j * sizeof(double));
    ck_assert_int_eq(mlr_fk_motion(c->m, 0, n, wp, NULL, NULL), MLR_OK);
    for (size_t i = 0; i < n * c->j; i++) {
        double *p = wp + 3 * i;
        const double x = p[0], y = p[1], z = p[2];
        double o[3];
        if (axis == MLR_AXIS_Y)
            o[0] = x, o[1] = y, o[2] = z;
        else if (axis == MLR_AXIS_Z) /* +90 degrees about X: Y -> Z, Z -> -Y */
            o[0] = x, o[1] = -z, o[2] = y;
        else /* -90 degrees about Z: Y -> X, X -> -Y */
            o[0] = y, o[1] = -x, o[2] = z;
        if (sign < 0) /* 180 degrees about the axis after it: up becomes down */
            for (int k = 0; k < 3; k++)
                if (k != (axis + 1) % 3)
                    o[k] = -o[k];
        memcpy(p, o, sizeof o);
    }
    return wp;
}

START_TEST(the_shared_clips_and_turned_copies_stand_on_the_axis_found)
{
    size_t loaded = 0;
    for (size_t k = 0; k < MLR_COUNTOF(clips); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(clips[k]))
            continue;
        ck_assert(mlr_test_clip_load(clips[k], &c));
        loaded++;
        const size_t n = c.n < 1200 ? c.n : 1200;
        for (int axis = 0; axis < 3; axis++)
            for (int sign = -1; sign <= 1; sign += 2) {
                double *wp = turned_positions(&c, n, axis, sign);
                mlr_up_guess g;
                mlr_diag d;
                ck_assert_msg(mlr_rig_up_axis(&c.rig, n, wp, &g, NULL, &d) == MLR_OK, "%s",
                              d.message);
                ck_assert_msg(g.axis == axis && g.sign == sign, "%s turned to %c%c: found %c%c",
                              clips[k], sign > 0 ? '+' : '-', "XYZ"[axis], g.sign > 0 ? '+' : '-',
                              "XYZ"[g.axis]);
                ck_assert_int_eq(g.method, MLR_UP_FEET);
                ck_assert_msg(g.confidence >= MLR_RIG_UP_SURE, "%s: confidence %g", clips[k],
                              g.confidence);
                free(wp);
            }
        mlr_test_clip_unload(&c);
    }
    ck_assert_uint_ge(loaded, 1); /* the bundled walk at least */
}
END_TEST

/* Without names the floor decides: on the walks and runs (feet on one floor, the body moving
 * along it) it is found on every turned copy. */
START_TEST(without_names_the_floor_is_the_side_that_stays_at_one_height)
{
    static const char *const walks[] = {"cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh",
                                        "cmu_02_03_run_jog_25fps.bvh",
                                        "bandai1_walk_happy_001.bvh"};
    for (size_t k = 0; k < MLR_COUNTOF(walks); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(walks[k]))
            continue;
        ck_assert(mlr_test_clip_load(walks[k], &c));
        mlr_rig r = c.rig;
        r.names = NULL;
        const size_t n = c.n < 1200 ? c.n : 1200;
        for (int axis = 0; axis < 3; axis++)
            for (int sign = -1; sign <= 1; sign += 2) {
                double *wp = turned_positions(&c, n, axis, sign);
                mlr_up_guess g;
                ck_assert_int_eq(mlr_rig_up_axis(&r, n, wp, &g, NULL, NULL), MLR_OK);
                ck_assert_int_eq(g.method, MLR_UP_FLOOR);
                ck_assert_msg(g.axis == axis && g.sign == sign,
                              "%s turned to %c%c: found %c%c "
                              "(%g)",
                              walks[k], sign > 0 ? '+' : '-', "XYZ"[axis], g.sign > 0 ? '+' : '-',
                              "XYZ"[g.axis], g.confidence);
                ck_assert_double_gt(g.confidence, 0.0);
                free(wp);
            }
        mlr_test_clip_unload(&c);
    }
}
END_TEST

/* A synthetic figure: a feet-down stick figure leaning 30 degrees toward X stays Y (cos 30 =
 * 0.87 >= SURE); at 40 degrees (cos 0.77) it is still Y, below SURE. */
START_TEST(confidence_is_the_cosine_of_the_feet_direction)
{
    static const int32_t parents[3] = {-1, 0, 0};
    static const double offsets[9] = {0, 0, 0, 0, 1, 0, 0, -1, 0};
    static const char *const names[3] = {"Hips", "Head", "LeftFoot"};
    mlr_rig r = {3, parents, offsets, names, 0, NULL, 0, NULL, NULL};
    const double lean[2] = {30.0, 40.0};
    for (int i = 0; i < 2; i++) {
        const double a = lean[i] * 3.14159265358979323846 / 180.0;
        /* centroid of (0,0,0), head, foot = 0; the foot's offset from it along -(sin a, cos a) */
        double wp[9] = {0, 0, 0, sin(a), cos(a), 0, -sin(a), -cos(a), 0};
        mlr_up_guess g;
        ck_assert_int_eq(mlr_rig_up_axis(&r, 1, wp, &g, NULL, NULL), MLR_OK);
        ck_assert_int_eq(g.axis, MLR_AXIS_Y);
        ck_assert_int_eq(g.sign, 1);
        ck_assert_close(g.confidence, cos(a), 1e-12);
        ck_assert_int_eq(g.confidence >= MLR_RIG_UP_SURE, i == 0);
    }
}
END_TEST

/* A body that stands for a third of the clip (feet down Y) and lies for the rest (legs toward
 * +Z) sums to an upside-down lie along Z: the upright stretch decides (Y, at SURE; a game's
 * death clip was taken as Z-up, upside down). Lying throughout, with no upright stretch, it
 * stays what the sum says, as a depth camera's upside-down clip does. */
START_TEST(a_body_that_stood_and_lay_down_is_up_the_way_it_stood)
{
    static const int32_t parents[3] = {-1, 0, 0};
    static const double offsets[9] = {0, 0, 0, 0, 1, 0, 0, -1, 0};
    static const char *const names[3] = {"Hips", "Head", "LeftFoot"};
    mlr_rig r = {3, parents, offsets, names, 0, NULL, 0, NULL, NULL};
    enum { N = 30 };
    double wp[N * 9];
    for (int stood = 10; stood >= 0; stood -= 10) {
        for (int f = 0; f < N; f++) {
            double *p = wp + 9 * f;
            const double hz = 0.3 * f; /* the body moves along Z */
            p[0] = 0, p[1] = f < stood ? 1 : 0.2, p[2] = hz;
            if (f < stood) /* head up Y, foot down Y */
                p[3] = 0, p[4] = 2, p[5] = hz, p[6] = 0, p[7] = 0, p[8] = hz;
            else /* lying: head toward -Z, foot toward +Z, all at one height */
                p[3] = 0, p[4] = 0.2, p[5] = hz - 1, p[6] = 0, p[7] = 0.2, p[8] = hz + 1;
        }
        mlr_up_guess g;
        ck_assert_int_eq(mlr_rig_up_axis(&r, N, wp, &g, NULL, NULL), MLR_OK);
        ck_assert_int_eq(g.method, MLR_UP_FEET);
        if (stood) {
            ck_assert_int_eq(g.axis, MLR_AXIS_Y);
            ck_assert_int_eq(g.sign, 1);
            ck_assert(g.confidence >= MLR_RIG_UP_SURE);
        } else {
            ck_assert_int_eq(g.axis, MLR_AXIS_Z);
            ck_assert_int_eq(g.sign, -1);
        }
    }
}
END_TEST

START_TEST(bad_input_says_why_and_empty_input_is_y)
{
    static const int32_t parents[2] = {-1, 0};
    static const double offsets[6] = {0, 0, 0, 0, 1, 0};
    mlr_rig r = {2, parents, offsets, NULL, 0, NULL, 0, NULL, NULL};
    double wp[6] = {0, 0, 0, 0, 1, 0};
    mlr_up_guess g;
    mlr_diag d;
    ck_assert_int_eq(mlr_rig_up_axis(&r, 1, wp, NULL, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "out is NULL"));
    ck_assert_int_eq(mlr_rig_up_axis(&r, 1, NULL, &g, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "world_pos"));
    wp[4] = NAN;
    ck_assert_int_eq(mlr_rig_up_axis(&r, 1, wp, &g, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "position 1 of frame 0 is not finite"));
    ck_assert_int_eq(mlr_rig_up_axis(NULL, 1, wp, &g, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_rig_up_axis(&r, 0, NULL, &g, NULL, &d), MLR_OK);
    ck_assert_int_eq(g.axis, MLR_AXIS_Y);
    ck_assert_int_eq(g.method, MLR_UP_NONE);
    ck_assert_double_eq(g.confidence, 0.0);
    /* a point: no extent, nothing to go by */
    const double still[6] = {0, 0, 0, 0, 0, 0};
    ck_assert_int_eq(mlr_rig_up_axis(&r, 1, still, &g, NULL, &d), MLR_OK);
    ck_assert_int_eq(g.method, MLR_UP_NONE);
}
END_TEST

START_TEST(every_allocation_failure_is_no_memory_without_leaks)
{
    mlr_test_clip c;
    ck_assert(mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, &c));
    const size_t n = 300;
    double *wp = turned_positions(&c, n, MLR_AXIS_Z, 1);
    for (int named = 0; named < 2; named++) {
        mlr_rig r = c.rig;
        if (!named)
            r.names = NULL;
        mlr_up_guess ref, g;
        ck_assert_int_eq(mlr_rig_up_axis(&r, n, wp, &ref, NULL, NULL), MLR_OK);
        size_t fails = 0;
        for (size_t k = 0;; k++) {
            mlr_test_allocator ta;
            mlr_test_allocator_init(&ta, k);
            mlr_diag d;
            const mlr_status st = mlr_rig_up_axis(&r, n, wp, &g, &ta.base, &d);
            ck_assert_uint_eq(ta.live_blocks, 0);
            if (st == MLR_OK) {
                ck_assert_int_eq(g.axis, ref.axis);
                ck_assert_double_eq(g.confidence, ref.confidence);
                break;
            }
            ck_assert_int_eq(st, MLR_E_NO_MEMORY);
            ck_assert_ptr_nonnull(strstr(d.message, "out of memory"));
            fails++;
        }
        ck_assert_uint_eq(fails, named ? 1u : 2u); /* the foot flags; and the floor's scratch */
    }
    free(wp);
    mlr_test_clip_unload(&c);
}
END_TEST

static Suite *up_axis_suite(void)
{
    Suite *s = suite_create("up_axis");
    TCase *tc = tcase_create("core");
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, the_shared_clips_and_turned_copies_stand_on_the_axis_found);
    tcase_add_test(tc, without_names_the_floor_is_the_side_that_stays_at_one_height);
    tcase_add_test(tc, confidence_is_the_cosine_of_the_feet_direction);
    tcase_add_test(tc, a_body_that_stood_and_lay_down_is_up_the_way_it_stood);
    tcase_add_test(tc, bad_input_says_why_and_empty_input_is_y);
    tcase_add_test(tc, every_allocation_failure_is_no_memory_without_leaks);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(up_axis_suite()); }
