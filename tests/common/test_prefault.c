/* The page-mapping helper (libmlayer/common/prefault.c, compiled in here): it maps every page
 * of the range it is given without changing a byte, stays off small ranges, and can be stopped.
 * The solves that use it are checked in test_lgs.c (same bits for every thread count). */
#include "common/prefault.c"

#include "mlr_test.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

/* Pages of [p, p + bytes) (page-aligned) that are resident. */
static size_t resident_pages(void *p, size_t bytes, size_t page)
{
    const size_t n = (bytes + page - 1) / page;
    unsigned char *vec = malloc(n);
    ck_assert_ptr_nonnull(vec);
    ck_assert_int_eq(mincore(p, bytes, vec), 0);
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        k += vec[i] & 1u;
    free(vec);
    return k;
}

/* Run the helper to its end (joining its thread directly, as finish would after a stop). */
static void run_to_end(mlr_prefault *pf)
{
    if (pf->started)
        pthread_join(pf->thread, NULL);
    pf->started = 0;
}

START_TEST(maps_every_page_and_keeps_the_bytes)
{
    const size_t page = (size_t)sysconf(_SC_PAGESIZE), bytes = (size_t)24 << 20;
    unsigned char *p =
        mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ck_assert_ptr_ne(p, MAP_FAILED);
    /* the first 3 MiB hold data; the rest was never touched */
    const size_t data = (size_t)3 << 20;
    for (size_t i = 0; i < data; i++)
        p[i] = (unsigned char)(i * 2654435761u >> 13);
    ck_assert_uint_lt(resident_pages(p, bytes, page), bytes / page / 2);
    mlr_prefault pf;
    prefault__start(&pf, p + 100, bytes - 200); /* not page-aligned: whole pages are used */
#ifdef MADV_POPULATE_WRITE
    ck_assert_int_eq(pf.started, 1);
#endif
    run_to_end(&pf);
    for (size_t i = 0; i < data; i++)
        ck_assert_uint_eq(p[i], (unsigned char)(i * 2654435761u >> 13));
    for (size_t i = data; i < bytes; i += 997)
        ck_assert_uint_eq(p[i], 0);
#ifdef MADV_POPULATE_WRITE
    /* kernels before 5.14 refuse the call (EINVAL): then nothing is mapped ahead, which is
     * allowed; where the call works every page must be mapped */
    errno = 0;
    const int supported = madvise(p, page, MADV_POPULATE_WRITE) == 0;
    if (supported)
        ck_assert_uint_eq(resident_pages(p, bytes, page), bytes / page);
#endif
    prefault__finish(&pf); /* after the end: nothing to do */
    munmap(p, bytes);
}
END_TEST

START_TEST(small_ranges_get_no_thread)
{
    static unsigned char buf[4096];
    mlr_prefault pf;
    prefault__start(&pf, buf, sizeof buf);
    ck_assert_int_eq(pf.started, 0);
    prefault__finish(&pf);
    prefault__start(&pf, buf, MLR_PREFAULT_MIN_BYTES - 1);
    ck_assert_int_eq(pf.started, 0);
    prefault__finish(&pf);
}
END_TEST

/* A stop right after the start returns promptly and leaves the range intact. */
START_TEST(stops_when_asked)
{
    const size_t bytes = (size_t)64 << 20;
    unsigned char *p =
        mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ck_assert_ptr_ne(p, MAP_FAILED);
    for (int k = 0; k < 20; k++) {
        mlr_prefault pf;
        prefault__start(&pf, p, bytes);
        p[(size_t)k << 20] = (unsigned char)(k + 1); /* the caller writes meanwhile */
        prefault__finish(&pf);
        ck_assert_int_eq(pf.started, 0);
        ck_assert_uint_eq(p[(size_t)k << 20], (unsigned)(k + 1));
    }
    munmap(p, bytes);
}
END_TEST

static Suite *prefault_suite(void)
{
    Suite *s = suite_create("prefault");
    TCase *tc = tcase_create("helper");
    tcase_add_test(tc, maps_every_page_and_keeps_the_bytes);
    tcase_add_test(tc, small_ranges_get_no_thread);
    tcase_add_test(tc, stops_when_asked);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(prefault_suite()); }
