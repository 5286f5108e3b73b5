/* libFuzzer target for the BVH reader (built only with clang; see run.sh).
 * Oracles beyond "no crash, no leak, no UB": the status is OK or PARSE (or NO_MEMORY from the
 * capped allocator), a PARSE error carries a line and a message, the portable, AVX2 and
 * AVX-512 kernels on one to three threads give the same status, error and bits, and whatever
 * parses is written and read back to the same skeleton and exact positions. */
#include <mlayer/mlayer.h>

#include "io/bvh_frames.h"   /* BVH_KERNELS_*: which kernels */
#include "motion/bvh_internal.h" /* bvh_read_memory_ex: a kernel set on request */

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Refuse single blocks above 64 MiB and more than 256 MiB live, as an embedding game would:
 * the parser must then fail cleanly with MLR_E_NO_MEMORY. */
typedef struct capped {
    size_t live;
} capped;

static void *cap_alloc(void *user, size_t size, size_t align)
{
    capped *c = user;
    (void)align;
    if (size > ((size_t)64 << 20) || c->live + size > ((size_t)256 << 20))
        return NULL;
    void *p = malloc(size);
    if (p)
        c->live += size;
    return p;
}

static void cap_release(void *user, void *ptr, size_t size)
{
    capped *c = user;
    c->live -= size;
    free(ptr);
}

static void check(int ok)
{
    if (!ok)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    capped c = {0};
    mlr_allocator a = {cap_alloc, cap_release, &c};
    mlr_motion *m = NULL;
    mlr_diag d;
    mlr_status s = mlr_bvh_read_memory((const char *)data, size, &a, &m, &d);
    check(s == MLR_OK || s == MLR_E_PARSE || s == MLR_E_NO_MEMORY || s == MLR_E_OVERFLOW);
    if (s == MLR_E_PARSE)
        check(d.line >= 1 && d.message[0] != '\0' && memchr(d.message, 0, sizeof d.message));
    /* the same input through the portable kernels on one thread, the AVX2 ones (where the CPU
     * has them) on two and the best on three */
    for (int v = 0; v < 3; v++) {
        mlr_motion *o = NULL;
        mlr_diag od;
        static const int sets[3] = {BVH_KERNELS_PORTABLE, BVH_KERNELS_AVX2, BVH_KERNELS_BEST};
        mlr_status os =
            bvh_read_memory_ex((const char *)data, size, (size_t)v + 1, sets[v], &a, &o, &od);
        check(os == s || os == MLR_E_NO_MEMORY || s == MLR_E_NO_MEMORY);
        if (os == s && s == MLR_E_PARSE)
            check(od.line == d.line && od.column == d.column &&
                  strcmp(od.message, d.message) == 0);
        if (os == s && s == MLR_OK) {
            size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
            size_t P = mlr_motion_n_trans(m), d8 = sizeof(double);
            check(mlr_motion_n_frames(o) == N && mlr_motion_n_joints(o) == J);
            check(N == 0 || memcmp(mlr_motion_rot(m), mlr_motion_rot(o), 4 * N * J * d8) == 0);
            check(N == 0 ||
                  memcmp(mlr_motion_root_pos(m), mlr_motion_root_pos(o), 3 * N * d8) == 0);
            check(N == 0 || P == 0 ||
                  memcmp(mlr_motion_trans(m), mlr_motion_trans(o), 3 * N * P * d8) == 0);
        }
        mlr_motion_destroy(o);
    }
    if (s != MLR_OK) {
        check(m == NULL);
        check(c.live == 0);
        return 0;
    }
    size_t len = 0;
    if (mlr_bvh_write_memory(m, NULL, 0, &len, NULL) == MLR_OK && len < ((size_t)32 << 20)) {
        char *text = malloc(len ? len : 1);
        size_t len2;
        check(mlr_bvh_write_memory(m, text, len, &len2, NULL) == MLR_OK && len2 == len);
        mlr_motion *b = NULL;
        s = mlr_bvh_read_memory(text, len, &a, &b, &d);
        check(s == MLR_OK || s == MLR_E_NO_MEMORY);
        if (s == MLR_OK) {
            size_t J = mlr_motion_n_joints(m), N = mlr_motion_n_frames(m);
            check(mlr_motion_n_joints(b) == J && N == mlr_motion_n_frames(b));
            check(mlr_motion_n_channels(b) == mlr_motion_n_channels(m));
            check(mlr_motion_n_end_sites(b) == mlr_motion_n_end_sites(m));
            for (size_t j = 0; j < J; j++) {
                check(strcmp(mlr_motion_joint_name(m, j), mlr_motion_joint_name(b, j)) == 0);
                check(strcmp(mlr_motion_joint_channels(m, j), mlr_motion_joint_channels(b, j)) ==
                      0);
                check(mlr_motion_parents(m)[j] == mlr_motion_parents(b)[j]);
            }
            check(N == 0 || memcmp(mlr_motion_root_pos(m), mlr_motion_root_pos(b),
                                   3 * N * sizeof(double)) == 0);
            check(mlr_motion_frame_time(m) == mlr_motion_frame_time(b));
        }
        mlr_motion_destroy(b);
        free(text);
    }
    /* forward kinematics over the parsed motion */
    size_t J = mlr_motion_n_joints(m), N = mlr_motion_n_frames(m);
    if (N * J <= 100000) {
        double *wp = malloc(3 * (N * J + 1) * sizeof(double));
        check(mlr_fk_motion(m, 0, N, wp, NULL, NULL) == MLR_OK || J > 256);
        free(wp);
    }
    mlr_motion_destroy(m);
    check(c.live == 0);
    return 0;
}
