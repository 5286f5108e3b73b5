/* The BVH writer's number formatting (libmlayer/io/bvh_write.c, compiled in here): the fast
 * "%.9g" gives printf's text, but for a last digit off by one where the scaled value lies
 * within an ulp of a half, and declines what it does not cover. The temporaries of
 * mlr_bvh_write_file follow the naming rule of mlr_bvh.h and the files honour the umask. The
 * writer as a whole (round trips of every clip, locales, atomic files) is checked in
 * test_bvh.c. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp */
#include "io/bvh_write.c"
#include "common/common.c"   /* the allocator and diag helpers */
#include "io/numparse.c" /* mlr_parse_decimal */

#include "mlr_test.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

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
    ck_assert_msg(fabs(x - y) <= 1.000001e-8 * fabs(y) + 1e-300, "%.17g: fast '%s', printf '%s'",
                  v, fast, ref);
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
    static const double edges[] = {0.0,        1e-4,    9.99999999e-5, 1e8,      99999999.95,
                                   99999999.4, 0.5,     1.0,           10.0,     123456789e-9,
                                   1.5e-4,     -0.0001, -12.5,         180.0,    -179.999999999,
                                   1e-300,     1e300,   NAN,           INFINITY, -0.0};
    for (size_t i = 0; i < MLR_COUNTOF(edges); i++) {
        int s;
        if (check_one(edges[i], &s))
            ck_assert_msg(s, "edge %.17g differs from printf", edges[i]);
    }
}
END_TEST

/* ---- the temporary's name and the file's mode ---------------------------------------------- */

/* Whether name (a file name, no folder) is a temporary of target by the rule of mlr_bvh.h:
 * "." target ".tmp-" and 16 lowercase hexadecimal digits, nothing after (the C writer appends
 * no extension). */
static int is_temporary_of(const char *name, const char *target)
{
    const size_t t = strlen(target);
    if (strlen(name) != 1 + t + 5 + 16 || name[0] != '.' || memcmp(name + 1, target, t) != 0 ||
        memcmp(name + 1 + t, ".tmp-", 5) != 0)
        return 0;
    for (const char *h = name + 1 + t + 5; *h; h++)
        if (!((*h >= '0' && *h <= '9') || (*h >= 'a' && *h <= 'f')))
            return 0;
    return 1;
}

START_TEST(temporary_names_follow_the_rule)
{
    static const struct {
        const char *path, *want;
    } cases[] = {
        {"out.bvh", ".out.bvh.tmp-0000000000abcdef"},
        {"dir/sub/out.bvh", "dir/sub/.out.bvh.tmp-0000000000abcdef"},
        {"/abs/x", "/abs/.x.tmp-0000000000abcdef"},
        {"./.hidden.bvh", "./..hidden.bvh.tmp-0000000000abcdef"},
        {"a//b", "a//.b.tmp-0000000000abcdef"},
    };
    for (size_t i = 0; i < MLR_COUNTOF(cases); i++) {
        char out[64];
        const char *path = cases[i].path, *base = base_name(path);
        ck_assert_uint_le(strlen(path) + 23, sizeof out);
        memset(out, 'x', sizeof out);
        temp_name(out, strlen(path) + 23, path, base, 0xabcdefu);
        ck_assert_str_eq(out, cases[i].want);
        ck_assert(is_temporary_of(out + (base - path), base));
    }
    char out[64];
    temp_name(out, 3 + 23, "a/b", base_name("a/b"), UINT64_MAX >> 1);
    ck_assert_str_eq(out, "a/.b.tmp-7fffffffffffffff"); /* the longest: 23 bytes added */
    ck_assert_str_eq(base_name("dir/"), "");
}
END_TEST

/* An allocator that remembers the last released block that held a temporary's name (a string
 * starting with prefix): mlr_bvh_write_file allocates the name from the motion's allocator. */
typedef struct {
    mlr_allocator base;
    const char *prefix;
    char name[512];
} name_spy;

static void *spy_allocate(void *user, size_t size, size_t align)
{
    (void)user;
    (void)align;
    return malloc(size);
}

static void spy_release(void *user, void *ptr, size_t size)
{
    name_spy *spy = user;
    const size_t n = strlen(spy->prefix);
    if (ptr && size > n && memcmp(ptr, spy->prefix, n) == 0 && memchr(ptr, '\0', size) &&
        strlen(ptr) < sizeof spy->name)
        strcpy(spy->name, ptr);
    free(ptr);
}

static const char tiny_bvh[] =
    "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  JOINT Leg\n  {\n    OFFSET 0 -10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    End Site\n    {\n      OFFSET 0 -5 0\n    }\n  }\n}\n"
    "MOTION\nFrames: 2\nFrame Time: 0.0333333\n"
    "0 90 0 0 0 0 10 20 30\n1 91 2 5 6 7 11 21 31\n";

static char dir[64];

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

START_TEST(write_file_temporary_is_named_by_the_rule)
{
    snprintf(dir, sizeof dir, "/tmp/mlr_test_bvh_write_XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char path[128], prefix[128];
    snprintf(path, sizeof path, "%s/out.bvh", dir);
    snprintf(prefix, sizeof prefix, "%s/.out.bvh.tmp-", dir);
    name_spy spy = {{spy_allocate, spy_release, NULL}, prefix, ""};
    spy.base.user = &spy;
    mlr_motion *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_memory(tiny_bvh, strlen(tiny_bvh), &spy.base, &m, &d), MLR_OK);

    ck_assert_int_eq(mlr_bvh_write_file(m, path, &d), MLR_OK);
    ck_assert_msg(spy.name[0], "no temporary name was released");
    ck_assert_msg(is_temporary_of(spy.name + strlen(dir) + 1, "out.bvh"), "%s", spy.name);
    ck_assert(!exists(spy.name) && exists(path)); /* renamed into place */
    ck_assert_uint_eq(mlr_test_dir_entries(dir), 1);

    /* a failing write: its temporary (named by the rule) is removed, the file is kept */
    spy.name[0] = '\0';
    mlr_motion_rot_mut(m)[1] = NAN;
    ck_assert_int_eq(mlr_bvh_write_file(m, path, &d), MLR_E_INVALID_ARG);
    ck_assert(is_temporary_of(spy.name + strlen(dir) + 1, "out.bvh"));
    ck_assert(!exists(spy.name) && exists(path));
    ck_assert_uint_eq(mlr_test_dir_entries(dir), 1);
    mlr_motion_rot_mut(m)[1] = 0.0;

    /* a path that names a folder is refused before anything is created */
    snprintf(path, sizeof path, "%s/", dir);
    ck_assert_int_eq(mlr_bvh_write_file(m, path, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "folder"));
    ck_assert_uint_eq(mlr_test_dir_entries(dir), 1);

    mlr_motion_destroy(m);
    snprintf(path, sizeof path, "%s/out.bvh", dir);
    ck_assert_int_eq(remove(path), 0);
    ck_assert_int_eq(rmdir(dir), 0);
}
END_TEST

START_TEST(write_file_honours_the_umask)
{
    snprintf(dir, sizeof dir, "/tmp/mlr_test_bvh_write_XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(dir));
    mlr_motion *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_memory(tiny_bvh, strlen(tiny_bvh), NULL, &m, &d), MLR_OK);
    char path[128];
    snprintf(path, sizeof path, "%s/out.bvh", dir);
    /* a new file takes 0666 less the umask; a rewrite keeps the existing file's mode whatever
       the umask (a 0600 output became 0644 when rewritten, issue 39) */
    static const struct {
        mode_t mask, mode;
        int fresh;    /* remove the file first */
        mode_t chmod; /* set this mode before writing (0: none) */
    } cases[] = {{022, 0644, 1, 0}, {077, 0600, 1, 0},    {022, 0600, 0, 0}, {027, 0640, 1, 0},
                 {077, 0640, 0, 0}, {022, 0604, 0, 0604}, {022, 0644, 1, 0}};
    const mode_t old = umask(022);
    for (size_t i = 0; i < MLR_COUNTOF(cases); i++) {
        if (cases[i].fresh)
            (void)remove(path);
        if (cases[i].chmod)
            ck_assert_int_eq(chmod(path, cases[i].chmod), 0);
        umask(cases[i].mask);
        ck_assert_int_eq(mlr_bvh_write_file(m, path, &d), MLR_OK);
        struct stat st;
        ck_assert_int_eq(stat(path, &st), 0);
        ck_assert_msg((st.st_mode & 07777) == cases[i].mode, "case %zu, umask %03o: mode %03o", i,
                      (unsigned)cases[i].mask, (unsigned)(st.st_mode & 07777));
    }
    umask(old);
    mlr_motion_destroy(m);
    ck_assert_int_eq(remove(path), 0);
    ck_assert_int_eq(rmdir(dir), 0);
}
END_TEST

static Suite *bvh_write_suite(void)
{
    Suite *s = suite_create("bvh_write");
    TCase *tc = tcase_create("format");
    tcase_add_test(tc, g9_matches_printf);
    suite_add_tcase(s, tc);
    tc = tcase_create("file");
    tcase_add_test(tc, temporary_names_follow_the_rule);
    tcase_add_test(tc, write_file_temporary_is_named_by_the_rule);
    tcase_add_test(tc, write_file_honours_the_umask);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(bvh_write_suite()); }
