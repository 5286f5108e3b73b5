/* Rigs by reference: checks, points by name, End Site positions, body height. */
#include "mlr_test.h"

#include <math.h>
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
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    ck_assert_int_eq(mlr_rig_body_height(4, 2, pos, MLR_AXIS_Y, &h, &ta.base, &d),
                     MLR_E_NO_MEMORY);
    ck_assert_uint_eq(ta.live_blocks, 0);
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
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return mlr_test_run(rig_suite());
}
