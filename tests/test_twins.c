/* Twin tests: computations the library writes in two forms (a vectorized batch and the scalar
 * one frame at a time) compared bit for bit, the library's sources compiled in here so that the
 * internal forms are in reach. Each runs on random inputs mixed with degenerate ones.
 * - two-bone IK: mlr_ik_two_bone_lanes (the batch the cleanup and mlr_ik_two_bone use) against
 *   mlr_ik_two_bone_1 (the one mlr_ik_apply_leg uses), frame by frame, on every frame the batch
 *   does not flag slow; and mlr_ik_two_bone (batch plus the slow frames' fallback) against
 *   mlr_ik_two_bone_1 on every frame. */
#include "mlr_test.h"

#include "common/common.c" /* mlr_diag_set, which ik.c reports through */
#include "guards/ik.c"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A random leg (hip a, knee b, end c, bend axis n, target t) at scale s, or one of the
   degenerate cases by k % 10. */
static void twin_leg(mlr_test_rng *r, size_t k, double s, double *a, double *b, double *c,
                     double *n, double *t)
{
    for (int i = 0; i < 3; i++) {
        a[i] = s * (mlr_test_rng_uniform(r) - 0.5);
        b[i] = a[i] + s * (mlr_test_rng_uniform(r) - 0.5);
        c[i] = b[i] + s * (mlr_test_rng_uniform(r) - 0.5);
        n[i] = s * mlr_test_rng_normal(r); /* at the leg's scale, as a bend axis is */
        t[i] = a[i] + 1.5 * s * (mlr_test_rng_uniform(r) - 0.5);
    }
    switch (k % 10) {
    case 1: /* the target on the hip */
        memcpy(t, a, 3 * sizeof(double));
        break;
    case 2: /* the hinge along the shin */
        for (int i = 0; i < 3; i++)
            n[i] = c[i] - b[i];
        break;
    case 3: /* the end on the hip */
        memcpy(c, a, 3 * sizeof(double));
        break;
    case 4: /* the target straight behind the hip, away from the end */
        for (int i = 0; i < 3; i++)
            t[i] = a[i] - 3.0 * (c[i] - a[i]);
        break;
    case 5: /* a zero-length thigh */
        memcpy(b, a, 3 * sizeof(double));
        break;
    case 6: /* the target on the end (reached as it is) */
        memcpy(t, c, 3 * sizeof(double));
        break;
    case 7: /* a straight leg, the target far beyond it */
        for (int i = 0; i < 3; i++)
            c[i] = b[i] + (b[i] - a[i]), t[i] = a[i] + 10.0 * (b[i] - a[i]);
        break;
    case 8: /* a zero bend axis */
        n[0] = n[1] = n[2] = 0.0;
        break;
    default:
        break;
    }
}

START_TEST(ik_lanes_give_the_bits_of_two_bone_1)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4040);
    const double scales[] = {1.0, 1e-6, 1e6};
    enum { N = 16 * 40 + 7 };
    double *buf = malloc(sizeof(double) * N * (5 * 3 + 4 * 4));
    ck_assert_ptr_nonnull(buf);
    double *A = buf, *B = A + 3 * N, *C = B + 3 * N, *X = C + 3 * N, *T = X + 3 * N;
    double *rh = T + 3 * N, *rk = rh + 4 * N, *rh1 = rk + 4 * N, *rk1 = rh1 + 4 * N;
    for (size_t si = 0; si < MLR_COUNTOF(scales); si++) {
        for (size_t f = 0; f < N; f++)
            twin_leg(&r, f, scales[si], A + 3 * f, B + 3 * f, C + 3 * f, X + 3 * f, T + 3 * f);
        for (int with_axis = 0; with_axis < 2; with_axis++) {
            const double *axis = with_axis ? X : NULL;
            size_t n_fast = 0;
            for (size_t f0 = 0; f0 < N; f0 += MLR_IK_LANES) {
                const size_t m = N - f0 < MLR_IK_LANES ? N - f0 : MLR_IK_LANES;
                mlr_ik_lanes L;
                for (size_t i = 0; i < m; i++)
                    for (int k = 0; k < 3; k++) {
                        const size_t q = 3 * (f0 + i) + (size_t)k;
                        L.a[k][i] = A[q], L.b[k][i] = B[q], L.c[k][i] = C[q], L.t[k][i] = T[q];
                        L.axis[k][i] = axis ? axis[q] : 0.0;
                    }
                mlr_ik_two_bone_lanes(&L, m, axis != NULL, MLR_IK_MAX_EXTENSION);
                for (size_t i = 0; i < m; i++) {
                    const size_t f = f0 + i;
                    double h1[4], k1[4];
                    mlr_ik_two_bone_1(A + 3 * f, B + 3 * f, C + 3 * f, T + 3 * f,
                                      axis ? axis + 3 * f : NULL, MLR_IK_MAX_EXTENSION, h1, k1);
                    if (L.slow[i])
                        continue;
                    n_fast++;
                    for (int k = 0; k < 4; k++) {
                        ck_assert_msg(memcmp(&L.r_hip[k][i], &h1[k], sizeof(double)) == 0,
                                      "scale %g axis %d frame %zu r_hip[%d]: %.17g vs %.17g",
                                      scales[si], with_axis, f, k, L.r_hip[k][i], h1[k]);
                        ck_assert_msg(memcmp(&L.r_knee[k][i], &k1[k], sizeof(double)) == 0,
                                      "scale %g axis %d frame %zu r_knee[%d]: %.17g vs %.17g",
                                      scales[si], with_axis, f, k, L.r_knee[k][i], k1[k]);
                    }
                }
            }
            /* the random legs (7 in 10, and some degenerate ones) take the batch */
            ck_assert_uint_ge(n_fast, N / 2);
            /* the public entry point: batch plus fallback, every frame as two_bone_1 */
            ck_assert_int_eq(
                mlr_ik_two_bone(N, A, B, C, T, axis, MLR_IK_MAX_EXTENSION, rh, rk, NULL), MLR_OK);
            for (size_t f = 0; f < N; f++)
                mlr_ik_two_bone_1(A + 3 * f, B + 3 * f, C + 3 * f, T + 3 * f,
                                  axis ? axis + 3 * f : NULL, MLR_IK_MAX_EXTENSION, rh1 + 4 * f,
                                  rk1 + 4 * f);
            ck_assert_mem_eq(rh, rh1, sizeof(double) * 4 * N);
            ck_assert_mem_eq(rk, rk1, sizeof(double) * 4 * N);
        }
    }
    free(buf);
}
END_TEST

static Suite *twins_suite(void)
{
    Suite *s = suite_create("twins");
    TCase *tc = tcase_create("twins");
    tcase_add_test(tc, ik_lanes_give_the_bits_of_two_bone_1);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(twins_suite()); }
