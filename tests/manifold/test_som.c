/* Self-organizing map: BMUs, second BMUs, quantization and topographic errors against a brute
 * force written here; one batch epoch against a dense reference update; bit-identical results
 * across runs and thread counts; online training lowers the quantization error; online steps
 * against a dense update (also split over threads); online steps split over threads are
 * bit-identical to one thread; the neighbourhood cutoff keeps the quantization error within 1% on
 * real clips; codebook
 * export/import and corrupt blobs; bad input; allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double *normal_data(size_t n, size_t d, uint64_t seed)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, seed);
    double *x = malloc(n * d * sizeof *x);
    for (size_t q = 0; q < n * d; q++)
        x[q] = mlr_test_rng_normal(&r) + (q % d == 0 ? 3.0 * (double)((q / d) % 3) : 0.0);
    return x;
}

/* squared Euclidean distance: the reference, summed in plain order */
static double d2(const double *a, const double *b, size_t d) { return mlr_test_dist2(a, b, d); }

static mlr_som *som_with_codebook(size_t rows, size_t cols, size_t d, const double *w)
{
    mlr_som *s = NULL;
    ck_assert_int_eq(mlr_som_create(rows, cols, d, NULL, &s, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_set_codebook(s, w, d, NULL), MLR_OK);
    return s;
}

START_TEST(bmu_and_errors_match_brute_force)
{
    const size_t rows = 7, cols = 5, d = 6, n = 1003, U = rows * cols;
    double *x = normal_data(n, d, 1), *w = normal_data(U, d, 2), *dist = malloc(n * 8);
    int32_t *b = malloc(n * 4), *b2 = malloc(n * 4);
    mlr_som *s = som_with_codebook(rows, cols, d, w);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_N_THREADS, 3, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_bmu(s, x, n, d, b, dist, b2, NULL), MLR_OK);
    double qe_ref = 0, qe, te;
    size_t te_ref = 0;
    for (size_t i = 0; i < n; i++) {
        size_t best = 0, sec = 0;
        double bd = INFINITY, sd = INFINITY;
        for (size_t u = 0; u < U; u++) {
            double v = d2(x + i * d, w + u * d, d);
            if (v < bd) {
                sd = bd;
                sec = best;
                bd = v;
                best = u;
            } else if (v < sd) {
                sd = v;
                sec = u;
            }
        }
        ck_assert_int_eq(b[i], (int32_t)best);
        ck_assert_int_eq(b2[i], (int32_t)sec);
        ck_assert_close(dist[i], sqrt(bd), 1e-12 * (1 + sqrt(bd)));
        qe_ref += sqrt(bd);
        long dr = labs((long)(best / cols) - (long)(sec / cols));
        long dc = labs((long)(best % cols) - (long)(sec % cols));
        te_ref += (dr > 1 || dc > 1);
    }
    ck_assert_int_eq(mlr_som_errors(s, x, n, d, &qe, &te, NULL), MLR_OK);
    ck_assert_close(qe, qe_ref / (double)n, 1e-12 * qe);
    ck_assert_close(te, (double)te_ref / (double)n, 1e-15);
    mlr_som_destroy(s);
    free(x);
    free(w);
    free(dist);
    free(b);
    free(b2);
}
END_TEST

/* One batch epoch (sigma0 used when epochs == 1) against the dense formula. */
START_TEST(batch_epoch_matches_dense_update)
{
    const size_t rows = 6, cols = 9, d = 4, n = 500, U = rows * cols;
    const double sigma = 1.7;
    double *x = normal_data(n, d, 3), *w = normal_data(U, d, 4);
    mlr_som *s = som_with_codebook(rows, cols, d, w);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_SIGMA0, sigma, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_N_THREADS, 2, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_train(s, x, n, d, 1, MLR_SOM_BATCH, NULL), MLR_OK);
    const double *got = mlr_som_codebook(s);
    for (size_t u = 0; u < U; u++) {
        double num[4] = {0}, den = 0;
        for (size_t i = 0; i < n; i++) {
            size_t best = 0;
            double bd = INFINITY;
            for (size_t v = 0; v < U; v++)
                if (d2(x + i * d, w + v * d, d) < bd) {
                    bd = d2(x + i * d, w + v * d, d);
                    best = v;
                }
            double dr = (double)(u / cols) - (double)(best / cols);
            double dc = (double)(u % cols) - (double)(best % cols);
            double h = exp(-(dr * dr + dc * dc) / (2 * sigma * sigma));
            for (size_t t = 0; t < d; t++)
                num[t] += h * x[i * d + t];
            den += h;
        }
        for (size_t t = 0; t < d; t++)
            ck_assert_close(got[u * d + t], num[t] / den, 1e-10);
    }
    mlr_som_destroy(s);
    free(x);
    free(w);
}
END_TEST

static void train_copy(int mode, size_t threads, const double *x, size_t n, size_t d, double *out)
{
    mlr_som *s = NULL;
    ck_assert_int_eq(mlr_som_create(8, 11, d, NULL, &s, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_SEED, 77, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_N_THREADS, (double)threads, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_train(s, x, n, d, 4, mode, NULL), MLR_OK);
    memcpy(out, mlr_som_codebook(s), 8 * 11 * d * sizeof *out);
    double qe, te;
    ck_assert_int_eq(mlr_som_errors(s, x, n, d, &qe, &te, NULL), MLR_OK);
    out[8 * 11 * d] = qe;
    out[8 * 11 * d + 1] = te;
    mlr_som_destroy(s);
}

START_TEST(bit_identical_across_runs_and_threads)
{
    const size_t n = 2001, d = 5, len = 8 * 11 * d + 2;
    double *x = normal_data(n, d, 5), *a = malloc(len * 8), *b = malloc(len * 8);
    for (int mode = 0; mode < 2; mode++) {
        train_copy(mode, 1, x, n, d, a);
        const size_t threads[] = {1, 2, 5};
        for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
            train_copy(mode, threads[q], x, n, d, b);
            ck_assert(memcmp(a, b, len * sizeof *a) == 0);
        }
    }
    free(x);
    free(a);
    free(b);
}
END_TEST

START_TEST(training_lowers_quantization_error)
{
    const size_t n = 1500, d = 3;
    double *x = normal_data(n, d, 6);
    for (int mode = 0; mode < 2; mode++) {
        mlr_som *s = NULL;
        double q0, q1, te;
        ck_assert_int_eq(mlr_som_create(10, 10, d, NULL, &s, NULL), MLR_OK);
        double w[100 * 3]; /* a poor start: every unit near one corner */
        for (size_t q = 0; q < 300; q++)
            w[q] = 5.0 + 1e-3 * (double)q;
        ck_assert_int_eq(mlr_som_set_codebook(s, w, d, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_set(s, MLR_SOM_SIGMA1, 0.5, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_errors(s, x, n, d, &q0, &te, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_train(s, x, n, d, 10, mode, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_errors(s, x, n, d, &q1, &te, NULL), MLR_OK);
        ck_assert_msg(q1 < 0.2 * q0, "mode %d: qe %g -> %g", mode, q0, q1);
        ck_assert_msg(te < 0.3, "mode %d: te %g", mode, te); /* an ordered map */
        mlr_som_destroy(s);
    }
    free(x);
}
END_TEST

START_TEST(export_import_roundtrip_and_corruption)
{
    const size_t rows = 3, cols = 4, d = 5, U = rows * cols;
    double *w = normal_data(U, d, 7);
    mlr_som *s = som_with_codebook(rows, cols, d, w), *t = NULL;
    size_t size = mlr_som_export_size(s);
    unsigned char *buf = malloc(size);
    mlr_diag dg;
    ck_assert_int_eq(mlr_som_export(s, buf, size - 1, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_export(s, buf, size, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_import(buf, size, NULL, &t, NULL), MLR_OK);
    ck_assert_uint_eq(mlr_som_rows(t), rows);
    ck_assert_uint_eq(mlr_som_cols(t), cols);
    ck_assert_uint_eq(mlr_som_dim(t), d);
    ck_assert(memcmp(mlr_som_codebook(t), w, U * d * sizeof *w) == 0);
    mlr_som_destroy(t);
    t = (mlr_som *)buf;
    ck_assert_int_eq(mlr_som_import(buf, size - 8, NULL, &t, &dg), MLR_E_PARSE);
    ck_assert_ptr_null(t);
    ck_assert_int_eq(mlr_som_import(buf, 10, NULL, &t, &dg), MLR_E_PARSE);
    buf[size - 3] ^= 1; /* payload bit: hash mismatch */
    ck_assert_int_eq(mlr_som_import(buf, size, NULL, &t, &dg), MLR_E_PARSE);
    ck_assert_ptr_nonnull(strstr(dg.message, "hash"));
    buf[size - 3] ^= 1;
    buf[0] = 'X'; /* tag */
    ck_assert_int_eq(mlr_som_import(buf, size, NULL, &t, &dg), MLR_E_PARSE);
    buf[0] = 'M';
    buf[8] = 9; /* version */
    ck_assert_int_eq(mlr_som_import(buf, size, NULL, &t, &dg), MLR_E_PARSE);
    buf[8] = 1;
    buf[32] = 4; /* rows changed: dims do not match the payload */
    ck_assert_int_eq(mlr_som_import(buf, size, NULL, &t, &dg), MLR_E_PARSE);
    buf[32] = 3;
    ck_assert_int_eq(mlr_som_import(buf, size, NULL, &t, NULL), MLR_OK);
    mlr_som_destroy(t);
    ck_assert_int_eq(mlr_som_import(NULL, size, NULL, &t, &dg), MLR_E_INVALID_ARG);
    mlr_som_destroy(s);
    free(buf);
    free(w);
}
END_TEST

START_TEST(bad_input_is_refused_with_a_reason)
{
    double x[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    int32_t b[6];
    mlr_diag dg;
    mlr_som *s = (mlr_som *)x;
    ck_assert_int_eq(mlr_som_create(0, 3, 2, NULL, &s, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(s);
    ck_assert_ptr_nonnull(strstr(dg.message, "lattice"));
    ck_assert_int_eq(mlr_som_create(3, 0, 2, NULL, &s, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_create(3, 3, 0, NULL, &s, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_create((size_t)1 << 20, (size_t)1 << 20, 2, NULL, &s, &dg),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_create(2, 3, 2, NULL, &s, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_train(s, x, 0, 2, 1, MLR_SOM_BATCH, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "empty"));
    ck_assert_int_eq(mlr_som_train(s, x, 6, 1, 1, MLR_SOM_BATCH, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "dimension mismatch"));
    ck_assert_int_eq(mlr_som_train(s, x, 6, 2, 0, MLR_SOM_BATCH, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_train(s, x, 6, 2, 1, 7, &dg), MLR_E_INVALID_ARG);
    x[5] = NAN;
    ck_assert_int_eq(mlr_som_train(s, x, 6, 2, 1, MLR_SOM_ONLINE, &dg), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(dg.message, "row 2"));
    ck_assert_int_eq(mlr_som_bmu(s, x, 6, 2, b, NULL, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set_codebook(s, x, 2, &dg), MLR_E_INVALID_ARG);
    x[5] = 5;
    ck_assert_int_eq(mlr_som_bmu(s, x, 6, 2, NULL, NULL, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_errors(s, x, 0, 2, NULL, NULL, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_SIGMA0, 0, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_CUTOFF, -1e-3, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_CUTOFF, 0.6, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_CUTOFF, NAN, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_ALPHA0, 1.5, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_N_THREADS, 65, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_set(s, 42, 1, &dg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_som_train(s, x, 6, 2, 2, MLR_SOM_ONLINE, &dg), MLR_OK);
    mlr_som_destroy(s);
    mlr_som_destroy(NULL);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    const size_t n = 200, d = 3;
    double *x = normal_data(n, d, 9);
    for (int mode = 0; mode < 3; mode++) {
        for (size_t fail_at = 0;; fail_at++) {
            mlr_test_allocator ta;
            mlr_test_allocator_init(&ta, fail_at);
            mlr_som *s = NULL, *t = NULL;
            mlr_status st = mlr_som_create(4, 5, d, &ta.base, &s, NULL);
            if (st == MLR_OK && mode < 2)
                st = mlr_som_train(s, x, n, d, 2, mode, NULL);
            unsigned char buf[64 + 4 * 5 * 3 * 8];
            if (st == MLR_OK && mode == 2) {
                ck_assert_int_eq(mlr_som_export(s, buf, sizeof buf, NULL), MLR_OK);
                st = mlr_som_import(buf, sizeof buf, &ta.base, &t, NULL);
            }
            mlr_som_destroy(s);
            mlr_som_destroy(t);
            ck_assert_uint_eq(ta.live_blocks, 0);
            if (st == MLR_OK)
                break;
            ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        }
    }
    free(x);
}
END_TEST

/* Online steps with one row (the order is then known) against a dense update written here:
 * brute-force BMU, every unit moved by alpha_s h_s; cutoff 0 (no unit skipped). Steps after
 * the first take the BMU from the fused update-and-search pass. */
START_TEST(online_steps_match_dense_update)
{
    /* _i = 0: one thread; _i = 1: a map large enough for the step to be split over 3 threads */
    const size_t rows = _i ? 32 : 7, cols = _i ? 32 : 9, d = _i ? 48 : 5, units = rows * cols;
    const size_t epochs = 4;
    double *w = normal_data(units, d, 21), *x = normal_data(1, d, 22);
    double *ref = malloc(units * d * sizeof *ref);
    memcpy(ref, w, units * d * sizeof *ref);
    mlr_som *s = som_with_codebook(rows, cols, d, w);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_CUTOFF, 0.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_SIGMA0, 3.0, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_set(s, MLR_SOM_N_THREADS, _i ? 3 : 1, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_train(s, x, 1, d, epochs, MLR_SOM_ONLINE, NULL), MLR_OK);
    for (size_t step = 0; step < epochs; step++) {
        double f = (double)step / (double)(epochs - 1);
        double sigma = 3.0 * pow(1.0 / 3.0, f), alpha = 0.5 * pow(0.01 / 0.5, f);
        size_t b = 0;
        for (size_t u = 1; u < units; u++)
            if (d2(x, ref + u * d, d) < d2(x, ref + b * d, d))
                b = u;
        for (size_t u = 0; u < units; u++) {
            double dr = (double)(u / cols) - (double)(b / cols);
            double dc = (double)(u % cols) - (double)(b % cols);
            double h = alpha * exp(-(dr * dr + dc * dc) / (2 * sigma * sigma));
            for (size_t t = 0; t < d; t++)
                ref[u * d + t] += h * (x[t] - ref[u * d + t]);
        }
    }
    const double *got = mlr_som_codebook(s);
    for (size_t q = 0; q < units * d; q++)
        ck_assert_close(got[q], ref[q], 1e-12 * (1 + fabs(ref[q])));
    mlr_som_destroy(s);
    free(w), free(x), free(ref);
}
END_TEST

/* Online training splits each step over the threads when the map is large enough (at least
 * 16,384 codebook values per part): the codebook is bit-identical for every thread count, with
 * the default cutoff (windows that cover some parts only) and without it. */
START_TEST(online_split_is_bit_identical)
{
    const size_t rows = 32, cols = 31, d = 48, n = 700, len = rows * cols * d;
    double *x = normal_data(n, d, 31), *a = malloc(len * 8), *b = malloc(len * 8);
    const size_t threads[] = {1, 2, 3, 7};
    for (size_t q = 0; q < MLR_COUNTOF(threads); q++) {
        mlr_som *s = NULL;
        ck_assert_int_eq(mlr_som_create(rows, cols, d, NULL, &s, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_set(s, MLR_SOM_SEED, 5, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_set(s, MLR_SOM_CUTOFF, _i ? 0.0 : 1e-3, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_set(s, MLR_SOM_N_THREADS, (double)threads[q], NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_train(s, x, n, d, 2, MLR_SOM_ONLINE, NULL), MLR_OK);
        memcpy(q ? b : a, mlr_som_codebook(s), len * sizeof *a);
        mlr_som_destroy(s);
        if (q)
            ck_assert(memcmp(a, b, len * sizeof *a) == 0);
    }
    free(x);
    free(a);
    free(b);
}
END_TEST

/* The default cutoff (Gaussian factors below 1e-3 are not applied) changes the quantization
 * error of online training by less than 1% against the full update, on the joint positions of
 * real clips. */
START_TEST(online_cutoff_keeps_quantization_error)
{
    const char *files[] = {"cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh"};
    /* any real clip: without the shared ones, the bundled walk and the wild clips */
    char path[4096];
    ck_assert_ptr_nonnull(mlr_test_any_clip_path(files[_i], (size_t)_i, path, sizeof path));
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &m, NULL), MLR_OK);
    size_t n = mlr_motion_n_frames(m), d = 3 * mlr_motion_n_joints(m);
    if (n > 2000)
        n = 2000;
    double *x = malloc(n * d * sizeof *x);
    ck_assert_int_eq(mlr_fk_motion(m, 0, n, x, NULL, NULL), MLR_OK);
    double qe[2];
    for (int full = 0; full < 2; full++) {
        mlr_som *s = NULL;
        ck_assert_int_eq(mlr_som_create(24, 24, d, NULL, &s, NULL), MLR_OK);
        if (full)
            ck_assert_int_eq(mlr_som_set(s, MLR_SOM_CUTOFF, 0.0, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_train(s, x, n, d, 2, MLR_SOM_ONLINE, NULL), MLR_OK);
        ck_assert_int_eq(mlr_som_errors(s, x, n, d, &qe[full], NULL, NULL), MLR_OK);
        mlr_som_destroy(s);
    }
    ck_assert_msg(fabs(qe[0] - qe[1]) < 0.01 * qe[1], "%s: qe %g with the cutoff, %g without",
                  files[_i], qe[0], qe[1]);
    mlr_motion_destroy(m);
    free(x);
}
END_TEST

static Suite *som_suite(void)
{
    Suite *s = suite_create("som");
    TCase *num = tcase_create("numerics");
    tcase_set_timeout(num, 120);
    tcase_add_test(num, bmu_and_errors_match_brute_force);
    tcase_add_test(num, batch_epoch_matches_dense_update);
    tcase_add_test(num, bit_identical_across_runs_and_threads);
    tcase_add_test(num, training_lowers_quantization_error);
    tcase_add_loop_test(num, online_steps_match_dense_update, 0, 2);
    tcase_add_loop_test(num, online_split_is_bit_identical, 0, 2);
    tcase_add_loop_test(num, online_cutoff_keeps_quantization_error, 0, 2);
    tcase_add_test(num, export_import_roundtrip_and_corruption);
    suite_add_tcase(s, num);
    TCase *args = tcase_create("arguments");
    tcase_add_test(args, bad_input_is_refused_with_a_reason);
    tcase_add_test(args, every_allocation_failure_is_clean);
    suite_add_tcase(s, args);
    return s;
}

int main(void) { return mlr_test_run(som_suite()); }
