/* k-means: against a naive Lloyd written here (direct differences, scikit-learn's rules), on
 * seeded clustered data and on the joint positions of real clips; bit-identical results for
 * every thread count; inertia never increasing with the iterations; k-means++ properties;
 * predict against a brute-force search; bad input and allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* n rows in d dims around c well-separated centres plus noise. */
static double *clustered(size_t n, size_t d, size_t c, uint64_t seed)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, seed);
    double *mu = malloc(c * d * sizeof *mu), *x = malloc(n * d * sizeof *x);
    for (size_t q = 0; q < c * d; q++)
        mu[q] = 10.0 * mlr_test_rng_normal(&r);
    for (size_t i = 0; i < n; i++) {
        size_t j = (size_t)(mlr_test_rng_u64(&r) % c);
        for (size_t t = 0; t < d; t++)
            x[i * d + t] = mu[j * d + t] + 2.0 * mlr_test_rng_normal(&r);
    }
    free(mu);
    return x;
}

/* squared Euclidean distance: the reference, summed in plain order */
static double d2(const double *a, const double *b, size_t d) { return mlr_test_dist2(a, b, d); }

/* Naive Lloyd with scikit-learn's stopping rules (no empty clusters in these tests). */
static void ref_lloyd(const double *x, size_t n, size_t d, size_t k, const double *init,
                      size_t max_iter, double tol, int32_t *lab, double *c, double *inertia,
                      size_t *n_iter)
{
    double mvar = 0;
    for (size_t t = 0; t < d; t++) {
        double m = 0, v = 0;
        for (size_t i = 0; i < n; i++)
            m += x[i * d + t];
        m /= (double)n;
        for (size_t i = 0; i < n; i++)
            v += (x[i * d + t] - m) * (x[i * d + t] - m);
        mvar += v / (double)n;
    }
    double tol_abs = tol * mvar / (double)d;
    memcpy(c, init, k * d * sizeof *c);
    double *cn = calloc(k * d, sizeof *cn);
    size_t *cnt = calloc(k, sizeof *cnt);
    for (size_t i = 0; i < n; i++)
        lab[i] = -1;
    int strict = 0;
    size_t it;
    for (it = 0; it < max_iter; it++) {
        size_t changed = 0;
        for (size_t i = 0; i < n; i++) {
            int32_t b = 0;
            double bd = INFINITY;
            for (size_t j = 0; j < k; j++) {
                double v = d2(x + i * d, c + j * d, d);
                if (v < bd) {
                    bd = v;
                    b = (int32_t)j;
                }
            }
            changed += b != lab[i];
            lab[i] = b;
        }
        memset(cn, 0, k * d * sizeof *cn);
        memset(cnt, 0, k * sizeof *cnt);
        for (size_t i = 0; i < n; i++) {
            for (size_t t = 0; t < d; t++)
                cn[(size_t)lab[i] * d + t] += x[i * d + t];
            cnt[lab[i]]++;
        }
        double shift = 0;
        for (size_t j = 0; j < k; j++) {
            ck_assert_uint_gt(cnt[j], 0);
            for (size_t t = 0; t < d; t++)
                cn[j * d + t] /= (double)cnt[j];
            shift += d2(cn + j * d, c + j * d, d);
        }
        memcpy(c, cn, k * d * sizeof *c);
        if (changed == 0) {
            strict = 1;
            it++;
            break;
        }
        if (shift <= tol_abs) {
            it++;
            break;
        }
    }
    if (!strict)
        for (size_t i = 0; i < n; i++) {
            double bd = INFINITY;
            for (size_t j = 0; j < k; j++) {
                double v = d2(x + i * d, c + j * d, d);
                if (v < bd) {
                    bd = v;
                    lab[i] = (int32_t)j;
                }
            }
        }
    *inertia = 0;
    for (size_t i = 0; i < n; i++)
        *inertia += d2(x + i * d, c + (size_t)lab[i] * d, d);
    *n_iter = it;
    free(cn);
    free(cnt);
}

static const struct {
    size_t n, d, k, c;
    int alg;
} lloyd_cases[] = {
    {500, 2, 3, 3, MLR_KMEANS_LLOYD},    {500, 2, 3, 3, MLR_KMEANS_HAMERLY},
    {2000, 7, 12, 8, MLR_KMEANS_LLOYD},  {2000, 7, 12, 8, MLR_KMEANS_HAMERLY},
    {1500, 33, 20, 25, MLR_KMEANS_AUTO}, {3000, 96, 17, 30, MLR_KMEANS_HAMERLY},
    {64, 5, 64, 4, MLR_KMEANS_AUTO},
};

START_TEST(matches_naive_lloyd)
{
    size_t n = lloyd_cases[_i].n, d = lloyd_cases[_i].d, k = lloyd_cases[_i].k;
    double *x = clustered(n, d, lloyd_cases[_i].c, 11 + (uint64_t)_i);
    double *init = malloc(k * d * sizeof *init), *c = malloc(k * d * sizeof *c);
    for (size_t j = 0; j < k; j++) /* distinct rows as initial centres */
        memcpy(init + j * d, x + (j * (n / k)) * d, d * sizeof *init);
    int32_t *lab = malloc(n * sizeof *lab), *ref = malloc(n * sizeof *ref);
    double rin;
    size_t rit;
    ref_lloyd(x, n, d, k, init, 300, 1e-4, ref, c, &rin, &rit);
    mlr_kmeans *km = NULL;
    ck_assert_int_eq(mlr_kmeans_create(k, d, NULL, &km, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_ALGORITHM, lloyd_cases[_i].alg, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_fit(km, x, n, d, init, d, lab, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert_int_eq(lab[i], ref[i]);
    ck_assert_uint_eq(mlr_kmeans_n_iter(km), rit);
    ck_assert_close(mlr_kmeans_inertia(km), rin, 1e-9 * rin);
    const double *kc = mlr_kmeans_centers(km);
    for (size_t q = 0; q < k * d; q++)
        ck_assert_close(kc[q], c[q], 1e-9 * (1 + fabs(c[q])));
    if (lloyd_cases[_i].alg == MLR_KMEANS_HAMERLY && rit > 2)
        ck_assert_uint_gt(mlr_kmeans_n_skipped(km), 0);
    mlr_kmeans_destroy(km);
    free(x);
    free(init);
    free(c);
    free(lab);
    free(ref);
}
END_TEST

START_TEST(real_clip_positions_match_naive_lloyd)
{
    const char *files[] = {"cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh",
                           "ai4a_dog_D1_008_KAN01_002.bvh"};
    /* any real clip: without the shared ones, the bundled walk and the wild clips */
    char path[4096];
    ck_assert_ptr_nonnull(mlr_test_any_clip_path(files[_i], (size_t)_i, path, sizeof path));
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &m, NULL), MLR_OK);
    size_t n = mlr_motion_n_frames(m), d = 3 * mlr_motion_n_joints(m), k = 24;
    if (n > 1500)
        n = 1500;
    double *x = malloc(n * d * sizeof *x);
    ck_assert_int_eq(mlr_fk_motion(m, 0, n, x, NULL, NULL), MLR_OK);
    double *init = malloc(k * d * sizeof *init), *c = malloc(k * d * sizeof *c);
    for (size_t j = 0; j < k; j++)
        memcpy(init + j * d, x + (j * (n / k)) * d, d * sizeof *init);
    int32_t *lab = malloc(n * sizeof *lab), *ref = malloc(n * sizeof *ref);
    double rin;
    size_t rit;
    ref_lloyd(x, n, d, k, init, 300, 1e-4, ref, c, &rin, &rit);
    mlr_kmeans *km = NULL;
    ck_assert_int_eq(mlr_kmeans_create(k, d, NULL, &km, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_fit(km, x, n, d, init, d, lab, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++)
        ck_assert_int_eq(lab[i], ref[i]);
    ck_assert_close(mlr_kmeans_inertia(km), rin, 1e-9 * rin);
    mlr_kmeans_destroy(km);
    mlr_motion_destroy(m);
    free(x);
    free(init);
    free(c);
    free(lab);
    free(ref);
}
END_TEST

/* Full fit (k-means++, 3 restarts) with 1, 2, 3 and 7 threads: bit-identical. */
START_TEST(bit_identical_across_thread_counts)
{
    size_t n = 5003, d = 13, k = 21;
    double *x = clustered(n, d, 15, 99);
    int32_t *lab0 = malloc(n * sizeof *lab0), *lab = malloc(n * sizeof *lab);
    double *c0 = malloc(k * d * sizeof *c0), in0 = 0;
    const size_t threads[] = {1, 2, 3, 7};
    for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
        mlr_kmeans *km = NULL;
        ck_assert_int_eq(mlr_kmeans_create(k, d, NULL, &km, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_N_THREADS, (double)threads[q], NULL), 0);
        ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_N_INIT, 3, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_SEED, 1234, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_fit(km, x, n, d, NULL, 0, q ? lab : lab0, NULL), MLR_OK);
        if (q == 0) {
            memcpy(c0, mlr_kmeans_centers(km), k * d * sizeof *c0);
            in0 = mlr_kmeans_inertia(km);
        } else {
            ck_assert(memcmp(c0, mlr_kmeans_centers(km), k * d * sizeof *c0) == 0);
            ck_assert(memcmp(lab0, lab, n * sizeof *lab) == 0);
            ck_assert(memcmp(&in0, &(double){mlr_kmeans_inertia(km)}, sizeof in0) == 0);
        }
        mlr_kmeans_destroy(km);
    }
    free(x);
    free(lab0);
    free(lab);
    free(c0);
}
END_TEST

START_TEST(inertia_never_increases)
{
    size_t n = 3000, d = 4, k = 9;
    double *x = clustered(n, d, 6, 5);
    double prev = INFINITY;
    for (size_t it = 1; it <= 12; it++) {
        mlr_kmeans *km = NULL;
        ck_assert_int_eq(mlr_kmeans_create(k, d, NULL, &km, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_MAX_ITER, (double)it, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_TOL, 0, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_SEED, 3, NULL), MLR_OK);
        ck_assert_int_eq(mlr_kmeans_fit(km, x, n, d, NULL, 0, NULL, NULL), MLR_OK);
        ck_assert_uint_le(mlr_kmeans_n_iter(km), it);
        ck_assert(mlr_kmeans_inertia(km) <= prev * (1 + 1e-12));
        prev = mlr_kmeans_inertia(km);
        mlr_kmeans_destroy(km);
    }
    free(x);
}
END_TEST

/* k-means++ picks data rows; k == n gives every row its own centre and inertia 0. */
START_TEST(kmeanspp_picks_rows)
{
    size_t n = 40, d = 3;
    double *x = clustered(n, d, 40, 8);
    mlr_kmeans *km = NULL;
    ck_assert_int_eq(mlr_kmeans_create(n, d, NULL, &km, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_MAX_ITER, 1, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_fit(km, x, n, d, NULL, 0, NULL, NULL), MLR_OK);
    ck_assert_close(mlr_kmeans_inertia(km), 0.0, 0.0);
    const double *c = mlr_kmeans_centers(km);
    for (size_t j = 0; j < n; j++) {
        int found = 0;
        for (size_t i = 0; i < n && !found; i++)
            found = memcmp(c + j * d, x + i * d, d * sizeof *c) == 0;
        ck_assert(found);
    }
    mlr_kmeans_destroy(km);
    free(x);
}
END_TEST

START_TEST(predict_is_nearest)
{
    size_t n = 777, d = 9, k = 31;
    double *x = clustered(n, d, 5, 21), *c = clustered(k, d, 31, 22), *dist = malloc(n * 8);
    int32_t *lab = malloc(n * sizeof *lab);
    mlr_kmeans *km = NULL;
    ck_assert_int_eq(mlr_kmeans_create(k, d, NULL, &km, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_set_centers(km, c, d, NULL), MLR_OK);
    ck_assert_int_eq(mlr_kmeans_predict(km, x, n, d, lab, dist, NULL), MLR_OK);
    for (size_t i = 0; i < n; i++) {
        double bd = INFINITY;
        int32_t b = -1;
        for (size_t j = 0; j < k; j++)
            if (d2(x + i * d, c + j * d, d) < bd) {
                bd = d2(x + i * d, c + j * d, d);
                b = (int32_t)j;
            }
        ck_assert_int_eq(lab[i], b);
        ck_assert_close(dist[i], bd, 1e-12 * bd);
    }
    mlr_kmeans_destroy(km);
    free(x);
    free(c);
    free(dist);
    free(lab);
}
END_TEST

START_TEST(bad_input_is_refused_with_a_reason)
{
    double x[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    mlr_diag dg;
    mlr_kmeans *km = (mlr_kmeans *)x;
    ck_assert_int_eq(mlr_kmeans_create(0, 2, NULL, &km, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(km);
    ck_assert_int_eq(mlr_kmeans_create(2, 0, NULL, &km, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_create(2, 2, NULL, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_create(5, 2, NULL, &km, NULL), MLR_OK);
    dg.message[0] = 0;
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 4, 2, NULL, 0, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "exceeds")); /* k > n */
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 0, 2, NULL, 0, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "empty"));
    ck_assert_int_eq(mlr_kmeans_fit(km, NULL, 6, 2, NULL, 0, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 6, 1, NULL, 0, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "dimension mismatch"));
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 6, 2, x, 1, NULL, &dg), MLR_E_INVALID_ARG);
    x[7] = NAN;
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 6, 2, NULL, 0, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "row 3"));
    x[7] = INFINITY;
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 6, 2, NULL, 0, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_set_centers(km, x, 2, &dg), MLR_E_INVALID_ARG);
    x[7] = 7;
    int32_t lab[6];
    ck_assert_int_eq(mlr_kmeans_predict(km, x, 6, 1, lab, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_MAX_ITER, 0, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_TOL, -1, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_N_THREADS, 0.5, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_ALGORITHM, 9, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_kmeans_set(km, 999, 1, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "unknown"));
    ck_assert(isnan(mlr_kmeans_inertia(km)));
    ck_assert_int_eq(mlr_kmeans_fit(km, x, 6, 2, NULL, 0, NULL, &dg), MLR_OK);
    mlr_kmeans_destroy(km);
    mlr_kmeans_destroy(NULL);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    size_t n = 300, d = 3, k = 5;
    double *x = clustered(n, d, 4, 2);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_kmeans *km = NULL;
        mlr_status s = mlr_kmeans_create(k, d, &ta.base, &km, NULL);
        if (s == MLR_OK) {
            ck_assert_int_eq(mlr_kmeans_set(km, MLR_KMEANS_N_INIT, 2, NULL), MLR_OK);
            s = mlr_kmeans_fit(km, x, n, d, NULL, 0, NULL, NULL);
        }
        mlr_kmeans_destroy(km);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
    }
    free(x);
}
END_TEST

static Suite *kmeans_suite(void)
{
    Suite *s = suite_create("kmeans");
    TCase *num = tcase_create("numerics");
    tcase_set_timeout(num, 120);
    tcase_add_loop_test(num, matches_naive_lloyd, 0, (int)MLR_COUNTOF(lloyd_cases));
    tcase_add_loop_test(num, real_clip_positions_match_naive_lloyd, 0, 3);
    tcase_add_test(num, bit_identical_across_thread_counts);
    tcase_add_test(num, inertia_never_increases);
    tcase_add_test(num, kmeanspp_picks_rows);
    tcase_add_test(num, predict_is_nearest);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, bad_input_is_refused_with_a_reason);
    tcase_add_test(args, every_allocation_failure_is_clean);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(kmeans_suite()); }
