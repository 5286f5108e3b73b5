/* Whole-file reads (libmlayer/io/file_read.c, compiled in here): every thread count gives the
 * file's bytes; errors and allocation failures are reported and leave nothing behind. The BVH
 * reader's use of it is checked in test_bvh.c. */
#include "io/file_read.c"
#include "common/common.c"   /* the allocator and diag helpers */
#include "common/parallel.c" /* the thread loop */

#include "mlr_test.h"

#include <stdlib.h>

static mlr_test_temp tf;  /* the file written last */
static const char *path;  /* its path */

static unsigned char *expect; /* its bytes */

static void write_file(size_t bytes)
{
    free(expect);
    expect = malloc(bytes + 1);
    ck_assert_ptr_nonnull(expect);
    for (size_t i = 0; i < bytes; i++)
        expect[i] = (unsigned char)((i * 2654435761u) >> 11 & 0xff);
    mlr_test_temp_write(&tf, "f.bin", expect, bytes);
    path = tf.path;
}

static void remove_file(void) { mlr_test_temp_remove(&tf); }

/* Every thread count gives the file's bytes. */
START_TEST(every_thread_count_reads_the_same_bytes)
{
    /* sizes around the parallel threshold and ones that do not divide evenly into chunks; the
     * last has more chunks than threads */
    const size_t sizes[] = {0, 1000, MLR_FILE_PARALLEL_MIN_BYTES - 1, MLR_FILE_PARALLEL_MIN_BYTES,
                            3 * MLR_FILE_PARALLEL_MIN_BYTES + 12345};
    for (size_t z = 0; z < MLR_COUNTOF(sizes); z++) {
        write_file(sizes[z]);
        for (size_t threads = 0; threads <= 9; threads++) {
            char *buf;
            size_t len, cap;
            mlr_diag d;
            mlr_allocator a;
            common__allocator_resolve(NULL, &a);
            ck_assert_int_eq(file_read__read(path, threads, &a, &buf, &len, &cap, &d), MLR_OK);
            ck_assert_uint_eq(len, sizes[z]);
            ck_assert_uint_gt(cap, len);
            ck_assert(len == 0 || memcmp(buf, expect, len) == 0);
            common__free(&a, buf, cap);
        }
        remove_file();
    }
}
END_TEST

START_TEST(errors_are_reported)
{
    char *buf = (char *)1;
    size_t len = 1, cap = 1;
    mlr_diag d;
    mlr_allocator a;
    common__allocator_resolve(NULL, &a);
    ck_assert_int_eq(file_read__read("/nonexistent/f.bin", 0, &a, &buf, &len, &cap, &d), MLR_E_IO);
    ck_assert_ptr_null(buf);
    ck_assert_msg(strstr(d.message, "cannot open") && strstr(d.message, "No such file"), "%s",
                  d.message);
    ck_assert_int_eq(file_read__read("/tmp", 2, &a, &buf, &len, &cap, &d), MLR_E_IO);
    ck_assert_ptr_null(buf);
    ck_assert_msg(strstr(d.message, "directory") != NULL, "%s", d.message);
    /* not a regular file: read sequentially to its end */
    ck_assert_int_eq(file_read__read("/dev/null", 2, &a, &buf, &len, &cap, &d), MLR_OK);
    ck_assert_uint_eq(len, 0);
    common__free(&a, buf, cap);
}
END_TEST

START_TEST(allocation_failures_leave_nothing)
{
    write_file(2 * MLR_FILE_PARALLEL_MIN_BYTES + 3);
    for (size_t threads = 1; threads <= 2; threads++) {
        for (size_t fail_at = 0;; fail_at++) {
            mlr_test_allocator ta;
            mlr_test_allocator_init(&ta, fail_at);
            mlr_allocator a;
            common__allocator_resolve(&ta.base, &a);
            char *buf;
            size_t len, cap;
            mlr_diag d;
            mlr_status s = file_read__read(path, threads, &a, &buf, &len, &cap, &d);
            if (s == MLR_OK) {
                ck_assert_uint_eq(len, 2 * MLR_FILE_PARALLEL_MIN_BYTES + 3);
                common__free(&a, buf, cap);
                ck_assert_uint_eq(ta.live_blocks, 0);
                break;
            }
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
            ck_assert_ptr_null(buf);
            ck_assert_uint_eq(ta.live_blocks, 0);
        }
    }
    remove_file();
}
END_TEST

static Suite *file_read_suite(void)
{
    Suite *s = suite_create("file_read");
    TCase *tc = tcase_create("read");
    tcase_add_test(tc, every_thread_count_reads_the_same_bytes);
    tcase_add_test(tc, errors_are_reported);
    tcase_add_test(tc, allocation_failures_leave_nothing);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(file_read_suite()); }
