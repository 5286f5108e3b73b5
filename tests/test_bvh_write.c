/* The BVH writer's number formatting (libmlayer/bvh_write.c, compiled in here): the fast
 * "%.9g" gives printf's text, but for a last digit off by one where the scaled value lies
 * within an ulp of a half, and declines what it does not cover. The writer as a whole (round
 * trips of every clip, locales, atomic files) is checked in test_bvh.c. */
#include "bvh_write.c"
#include "common.c"   /* the allocator and diag helpers */
#include "numparse.c" /* mlr_parse_decimal */

#include "mlr_test.h"

#include <stdio.h>
#include <stdlib.h>

/* format_g9_fast on v against snprintf("%.9g"): *same = 1 for the same text; 0 when it
 * declined; otherwise the two must read back within one unit of the ninth digit. */
static int check_one(double v, int *same)
{
    char fast[48], ref[48];
    const size_t n = format_g9_fast(v, fast);
    const int rn = snprintf(ref, sizeof ref, "%.9g", v);
    ck_assert(rn > 0 && (size_t)rn < sizeof ref);
    *same = 0;
    if (n == 0) { /* only outside the range, at its edges, or where printf rounds to 10^k */
        const double a = fabs(v), l = log10(fabs(strtod(ref, NULL)));
        ck_assert_msg(!(a >= 2e-4 && a <= 9e7) || (signbit(v) && a == 0.0) ||
                          fabs(l - nearbyint(l)) < 1e-12,
                      "declined %.17g ('%s')", v, ref);
        return 0;
    }
    fast[n] = '\0';
    if (strcmp(fast, ref) == 0) {
        *same = 1;
        return 1;
    }
    const double x = strtod(fast, NULL), y = strtod(ref, NULL);
    ck_assert_msg(fabs(x - y) <= 1.000001e-8 * fabs(y) + 1e-300,
                  "%.17g: fast '%s', printf '%s'", v, fast, ref);
    return 1;
}

START_TEST(g9_matches_printf)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 909);
    size_t taken = 0, same = 0, ties = 0;
    for (int i = 0; i < 400000; i++) {
        double v;
        const uint64_t kind = mlr_test_rng_u64(&r) % 4;
        if (kind == 0) /* any magnitude from 1e-6 to 1e10 */
            v = pow(10.0, -6.0 + 16.0 * (double)(mlr_test_rng_u64(&r) >> 11) * 0x1p-53);
        else if (kind == 1) /* angles in degrees, as the writer gets them */
            v = 360.0 * ((double)(mlr_test_rng_u64(&r) >> 11) * 0x1p-53 - 0.5);
        else if (kind == 2) /* values with few decimals, as files hold them */
            v = (double)(int64_t)(mlr_test_rng_u64(&r) % 20000001) / 10000.0 - 1000.0;
        else /* ties and near-ties of the ninth digit */
            v = ((double)(mlr_test_rng_u64(&r) % 900000000 + 100000000) + 0.5) *
                pow(10.0, (double)(int)(mlr_test_rng_u64(&r) % 12) - 12.0);
        if (mlr_test_rng_u64(&r) & 1)
            v = -v;
        int s;
        const int took = check_one(v, &s);
        if (kind == 3) { /* within a unit of the ninth digit (checked), either way */
            ties += (size_t)took;
            continue;
        }
        taken += (size_t)took;
        same += (size_t)s;
    }
    /* nearly all values are taken, and those not made to be near a tie give printf's text */
    ck_assert_uint_gt(taken, 260000);
    ck_assert_uint_gt(ties, 90000);
    ck_assert_uint_eq(same, taken);
    /* the edges */
    static const double edges[] = {0.0,     1e-4,   9.99999999e-5, 1e8, 99999999.95, 99999999.4,
                                   0.5,     1.0,    10.0,          123456789e-9, 1.5e-4,
                                   -0.0001, -12.5,  180.0,         -179.999999999, 1e-300,
                                   1e300,   NAN,    INFINITY,      -0.0};
    for (size_t i = 0; i < MLR_COUNTOF(edges); i++) {
        int s;
        if (check_one(edges[i], &s))
            ck_assert_msg(s, "edge %.17g differs from printf", edges[i]);
    }
}
END_TEST

static Suite *bvh_write_suite(void)
{
    Suite *s = suite_create("bvh_write");
    TCase *tc = tcase_create("format");
    tcase_add_test(tc, g9_matches_printf);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(bvh_write_suite()); }
