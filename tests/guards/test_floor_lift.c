/* The floor's last lift (libmlayer/guards/floor_lift.c, compiled in here): it covers the need
 * at every frame, never lifts more than a stretch's largest need, is zero far from it, keeps
 * its second difference within half the clip's own where the ramps may be long enough (the
 * 0.1 s ramps of before popped a standing elephant's feet 2.8x), makes stretches whose ramps
 * would meet one lift, and leaves the root as it was when scratch cannot be had. */
#include "guards/floor_lift.c"
#include "common/common.c" /* the allocator helpers */

#include "mlr_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { N = 600 };
static const double FPS = 60.0;

/* the lift alone: root heights (along y) of 0 plus the lift */
static void lift_of(const double *need, double a_ref, double *lift)
{
    static double root[3 * N];
    memset(root, 0, sizeof root);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    ck_assert_int_eq(floor_lift__smooth(N, FPS, need, a_ref, 1, root, &ta.base), MLR_OK);
    ck_assert_uint_eq(ta.live_blocks, 0);
    for (size_t f = 0; f < N; f++) {
        ck_assert(root[3 * f] == 0.0 && root[3 * f + 2] == 0.0); /* along up only */
        lift[f] = root[3 * f + 1];
    }
}

static double max_second_difference(const double *x)
{
    double m = 0.0;
    for (size_t f = 1; f + 1 < N; f++)
        m = fmax(m, fabs(x[f + 1] - 2.0 * x[f] + x[f - 1]));
    return m;
}

START_TEST(the_half_width_grows_with_the_need_between_its_bounds)
{
    /* a small lift against a lively clip: the short ramp, 0.1 s */
    ck_assert_uint_eq(floor_lift__half_width(1e-6, 1.0, FPS), 6);
    /* no motion to measure against: the long one, 1 s */
    ck_assert_uint_eq(floor_lift__half_width(0.1, 0.0, FPS), 60);
    ck_assert_uint_eq(floor_lift__half_width(1e3, 1e-9, FPS), 60);
    /* in between: the least h with peak * pi / (2 (h + 1)^2) <= a_ref / 2 */
    const double peak = 0.1, a_ref = 1e-3;
    const size_t h = floor_lift__half_width(peak, a_ref, FPS);
    ck_assert(h > 6 && h < 60);
    ck_assert(peak * LIFT_PI / (2.0 * (double)((h + 1) * (h + 1))) <= a_ref / 2.0);
    ck_assert(peak * LIFT_PI / (2.0 * (double)(h * h)) > a_ref / 2.0);
}
END_TEST

START_TEST(the_lift_covers_the_need_and_no_more_than_its_peak)
{
    mlr_test_rng s;
    mlr_test_rng_seed(&s, 12345);
    static double need[N], lift[N];
    for (int trial = 0; trial < 20; trial++) {
        memset(need, 0, sizeof need);
        double peak = 0.0;
        for (int k = 0; k < 4; k++) { /* four stretches of random needs */
            const size_t a = (size_t)(mlr_test_rng_uniform(&s) * (N - 40)),
                         len = 1 + (size_t)(mlr_test_rng_uniform(&s) * 30);
            for (size_t f = a; f < a + len; f++) {
                need[f] = fmax(need[f], 0.2 * mlr_test_rng_uniform(&s));
                peak = fmax(peak, need[f]);
            }
        }
        const double a_ref = trial % 2 ? 1e-4 : 1e-2;
        lift_of(need, a_ref, lift);
        for (size_t f = 0; f < N; f++) {
            ck_assert_msg(lift[f] >= need[f] - 1e-12, "frame %zu: lift %g under need %g", f,
                          lift[f], need[f]);
            ck_assert(lift[f] <= peak + 1e-12);
            /* zero farther than 2 s (twice the longest half width) from any need */
            size_t d = N;
            for (size_t k = 0; k < N; k++)
                if (need[k] > 0.0)
                    d = (k > f ? k - f : f - k) < d ? (k > f ? k - f : f - k) : d;
            if (d > 120)
                ck_assert(lift[f] == 0.0);
        }
    }
}
END_TEST

START_TEST(a_large_lift_ramps_no_faster_than_half_the_clips_own)
{
    /* 10% of body height for 0.5 s, against a clip whose feet accelerate by 1e-3 per frame^2:
       with 0.1 s ramps the lift's second difference was 4x that */
    static double need[N], lift[N];
    memset(need, 0, sizeof need);
    for (size_t f = 270; f < 300; f++)
        need[f] = 0.1;
    const double a_ref = 1e-3;
    lift_of(need, a_ref, lift);
    const double a = max_second_difference(lift);
    ck_assert_msg(a <= 0.5 * a_ref, "second difference %g over %g", a, 0.5 * a_ref);
    /* the fixed 0.1 s ramp's own figure: peak * pi / (2 (6 + 1)^2) */
    ck_assert(0.1 * LIFT_PI / (2.0 * 49.0) > 2.0 * a_ref);
}
END_TEST

START_TEST(stretches_whose_ramps_meet_are_one_lift)
{
    /* two needs of 0.05, 5 frames apart: one plateau, no dip between them, no sum above */
    static double need[N], lift[N];
    memset(need, 0, sizeof need);
    for (size_t f = 200; f < 210; f++)
        need[f] = need[f + 15] = 0.05;
    lift_of(need, 1e-3, lift);
    for (size_t f = 200; f < 225; f++)
        ck_assert(fabs(lift[f] - 0.05) < 1e-12);
    for (size_t f = 0; f < N; f++)
        ck_assert(lift[f] <= 0.05 + 1e-12);
}
END_TEST

START_TEST(no_memory_leaves_the_root_as_it_was)
{
    static double need[N], root[3 * N];
    memset(need, 0, sizeof need);
    need[300] = 0.1;
    memset(root, 0, sizeof root);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    ck_assert_int_eq(floor_lift__smooth(N, FPS, need, 1e-3, 1, root, &ta.base), MLR_E_NO_MEMORY);
    for (size_t i = 0; i < 3 * N; i++)
        ck_assert(root[i] == 0.0);
    ck_assert_uint_eq(ta.live_blocks, 0);
    /* and none needed for no frame */
    ck_assert_int_eq(floor_lift__smooth(0, FPS, need, 1e-3, 1, root, &ta.base), MLR_OK);
}
END_TEST

static Suite *floor_lift_suite(void)
{
    Suite *s = suite_create("floor_lift");
    TCase *tc = tcase_create("core");
    tcase_add_test(tc, the_half_width_grows_with_the_need_between_its_bounds);
    tcase_add_test(tc, the_lift_covers_the_need_and_no_more_than_its_peak);
    tcase_add_test(tc, a_large_lift_ramps_no_faster_than_half_the_clips_own);
    tcase_add_test(tc, stretches_whose_ramps_meet_are_one_lift);
    tcase_add_test(tc, no_memory_leaves_the_root_as_it_was);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(floor_lift_suite()); }
