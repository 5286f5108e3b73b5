/* Status names, version and allocator plumbing. */
#include "mlr_test.h"

#include <math.h>
#include <string.h>

static const mlr_status all_codes[] = {
    MLR_OK,         MLR_E_INVALID_ARG,     MLR_E_NO_MEMORY,   MLR_E_OVERFLOW,
    MLR_E_SINGULAR, MLR_E_BAD_STATE,       MLR_E_UNSUPPORTED, MLR_E_PARSE,
    MLR_E_IO,       MLR_W_ILL_CONDITIONED, MLR_W_MAX_ITER};

START_TEST(every_status_has_a_distinct_name)
{
    const char *name = mlr_status_name(all_codes[_i]);
    ck_assert_str_ne(name, "MLR_UNKNOWN");
    ck_assert_int_eq(strncmp(name, "MLR_", 4), 0);
    ck_assert_ptr_nonnull(mlr_status_string(all_codes[_i]));
    for (size_t j = 0; j < MLR_COUNTOF(all_codes); j++)
        if ((int)j != _i)
            ck_assert_str_ne(name, mlr_status_name(all_codes[j]));
}
END_TEST

START_TEST(unknown_status_is_named_unknown)
{
    ck_assert_str_eq(mlr_status_name(-12345), "MLR_UNKNOWN");
    ck_assert_str_eq(mlr_status_string(777), "unknown status code");
}
END_TEST

START_TEST(pinned_status_values)
{
    /* values are part of the ABI: they may never change */
    ck_assert_int_eq(MLR_E_INVALID_ARG, -10);
    ck_assert_int_eq(MLR_E_NO_MEMORY, -20);
    ck_assert_int_eq(MLR_E_SINGULAR, -30);
    ck_assert_int_eq(MLR_E_PARSE, -50);
    ck_assert_int_eq(MLR_W_ILL_CONDITIONED, 10);
}
END_TEST

START_TEST(version_matches_headers)
{
    ck_assert_str_eq(mlr_version_string(), MLR_VERSION_STRING);
    ck_assert_int_eq(mlr_version_number(), MLR_VERSION_NUMBER);
    ck_assert_int_eq(MLR_VERSION_NUMBER,
                     MLR_VERSION_MAJOR * 10000 + MLR_VERSION_MINOR * 100 + MLR_VERSION_PATCH);
}
END_TEST

static Suite *common_suite(void)
{
    Suite *s = suite_create("common");
    TCase *tc = tcase_create("status");
    tcase_add_loop_test(tc, every_status_has_a_distinct_name, 0, (int)MLR_COUNTOF(all_codes));
    tcase_add_test(tc, unknown_status_is_named_unknown);
    tcase_add_test(tc, pinned_status_values);
    tcase_add_test(tc, version_matches_headers);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(common_suite()); }
