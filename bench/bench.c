/*
 * mlayer benchmark harness. Runs every case (or those matching --filter) until its time
 * budget is spent and prints one tab-separated line per case:
 *     name  n  median_ns  min_ns  ns_per_elem  checksum
 * (guards.stylize adds "# guards.stylize / its own decomposition (median of N runs): R", the
 * ratio within each run, which the load of a shared machine moves less) and, when
 * guards.decompose and guards.stylize both ran (--filter guards), a last line
 * "# guards.stylize / guards.decompose (medians): R"; crowd.frame adds "# crowd: ..." lines
 * (its allocations in the timed frames, which must be 0, and the characters per 16.6 ms).
 * Options: --budget-ms MS (default 200), --filter SUBSTR, --cold (flush caches between runs),
 * --list.
 */
#define _POSIX_C_SOURCE 200809L
#include "bench.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

double mlr_bench_uniform(unsigned long long *s)
{
    unsigned long long z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

double mlr_bench_normal(unsigned long long *s)
{
    double u1 = mlr_bench_uniform(s), u2 = mlr_bench_uniform(s);
    return sqrt(-2.0 * log(u1 > 1e-300 ? u1 : 1e-300)) * cos(6.283185307179586 * u2);
}

const char *mlr_bench_mocap_dir(void)
{
    const char *dir = getenv("MLR_TEST_MOCAP_DIR");
    return dir && *dir ? dir : MLR_BENCH_MOCAP_DIR;
}

double mlr_bench_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

int mlr_bench_failed = 0;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Touch a buffer larger than the last-level cache so the next run starts cold. */
static void flush_caches(void)
{
    static const size_t bytes = 64u << 20;
    static volatile unsigned char *junk;
    if (!junk)
        junk = malloc(bytes);
    if (!junk)
        return;
    for (size_t i = 0; i < bytes; i += 64)
        junk[i] = (unsigned char)(junk[i] + 1);
}

typedef struct table {
    const mlr_bench_case *cases;
    const size_t *count;
} table;

int main(int argc, char **argv)
{
    double budget_ms = 200.0;
    const char *filter = NULL;
    int cold = 0, list = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--budget-ms") && i + 1 < argc)
            budget_ms = atof(argv[++i]);
        else if (!strcmp(argv[i], "--filter") && i + 1 < argc)
            filter = argv[++i];
        else if (!strcmp(argv[i], "--cold"))
            cold = 1;
        else if (!strcmp(argv[i], "--list"))
            list = 1;
        else {
            fprintf(stderr, "usage: %s [--budget-ms MS] [--filter SUBSTR] [--cold] [--list]\n",
                    argv[0]);
            return 2;
        }
    }
    const table tables[] = {{mlr_bench_lgs_cases, &mlr_bench_lgs_count},
                            {mlr_bench_bvh_cases, &mlr_bench_bvh_count},
                            {mlr_bench_resample_cases, &mlr_bench_resample_count},
                            {mlr_bench_stream_cases, &mlr_bench_stream_count},
                            {mlr_bench_layers_cases, &mlr_bench_layers_count},
                            {mlr_bench_cluster_cases, &mlr_bench_cluster_count},
                            {mlr_bench_grbf_cases, &mlr_bench_grbf_count},
                            {mlr_bench_guards_cases, &mlr_bench_guards_count},
                            {mlr_bench_crowd_cases, &mlr_bench_crowd_count}};
    printf("name\tn\tmedian_ns\tmin_ns\tns_per_elem\tchecksum\n");
    int failures = 0;
    double t_decompose = 0.0, t_stylize = 0.0; /* medians of guards.decompose, guards.stylize */
    for (size_t t = 0; t < sizeof tables / sizeof tables[0]; t++) {
        for (size_t c = 0; c < *tables[t].count; c++) {
            const mlr_bench_case *bc = &tables[t].cases[c];
            if (filter && !strstr(bc->name, filter))
                continue;
            if (list) {
                printf("%s\n", bc->name);
                continue;
            }
            void *state = bc->setup(bc->n);
            if (!state) {
                fprintf(stderr, "%s: setup failed\n", bc->name);
                failures++;
                continue;
            }
            size_t cap = 1024, runs = 0;
            double *times = malloc(cap * sizeof *times), checksum = 0.0;
            double start = mlr_bench_now_ns();
            do {
                if (cold)
                    flush_caches();
                double t0 = mlr_bench_now_ns();
                checksum += bc->run(state);
                times[runs++] = mlr_bench_now_ns() - t0;
                if (runs == cap) {
                    double *grown = realloc(times, 2 * cap * sizeof *times);
                    if (!grown)
                        break;
                    times = grown;
                    cap *= 2;
                }
            } while (mlr_bench_now_ns() - start < budget_ms * 1e6 || runs < 3);
            qsort(times, runs, sizeof *times, cmp_double);
            double median = times[runs / 2], min = times[0];
            printf("%s\t%zu\t%.0f\t%.0f\t%.3f\t%.17g\n", bc->name, bc->n, median, min,
                   median / (double)bc->n, checksum / (double)runs);
            fflush(stdout);
            if (!strncmp(bc->name, "guards.decompose/", 17))
                t_decompose = median;
            else if (!strncmp(bc->name, "guards.stylize/", 15))
                t_stylize = median;
            else if (!strncmp(bc->name, "crowd.frame/", 12)) /* issue 41's target: 1,000 */
                printf("# crowd: characters per 16.6 ms frame at the median: %.0f (min: %.0f)\n",
                       16.6e6 / (median / (double)bc->n), 16.6e6 / (min / (double)bc->n));
            free(times);
            bc->teardown(state);
        }
    }
    if (t_decompose > 0.0 && t_stylize > 0.0) /* issue 18's target: at most 2 */
        printf("# guards.stylize / guards.decompose (medians): %.2f\n", t_stylize / t_decompose);
    if (mlr_bench_failed)
        fprintf(stderr, "a case found its result wrong (see its lines above)\n");
    return failures || mlr_bench_failed ? 1 : 0;
}
