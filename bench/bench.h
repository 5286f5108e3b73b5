/* The benchmark harness: a case is a row in a table; the harness times it. */
#ifndef MLR_BENCH_H
#define MLR_BENCH_H

#include <stddef.h>

typedef struct mlr_bench_case {
    const char *name;               /* "lgs.solve/n=100000,m=127" */
    size_t n;                       /* elements per iteration, for ns/element */
    void *(*setup)(size_t n);       /* seeded input; NULL on failure */
    double (*run)(void *state);     /* one iteration; result folded into a checksum */
    void (*teardown)(void *state);
} mlr_bench_case;

/* Seeded uniform [0, 1) and normal values for inputs (splitmix64). */
double mlr_bench_uniform(unsigned long long *state);
double mlr_bench_normal(unsigned long long *state);

/* A monotonic clock, in nanoseconds. */
double mlr_bench_now_ns(void);

/* Folder of the shared real clips: $MLR_TEST_MOCAP_DIR, else the one next to the checkout. */
const char *mlr_bench_mocap_dir(void);

/* Case tables of each subject, defined in bench_<subject>.c. */
extern const mlr_bench_case mlr_bench_lgs_cases[];
extern const size_t mlr_bench_lgs_count;
extern const mlr_bench_case mlr_bench_bvh_cases[];
extern const size_t mlr_bench_bvh_count;
extern const mlr_bench_case mlr_bench_resample_cases[];
extern const size_t mlr_bench_resample_count;
extern const mlr_bench_case mlr_bench_stream_cases[];
extern const size_t mlr_bench_stream_count;
extern const mlr_bench_case mlr_bench_layers_cases[];
extern const size_t mlr_bench_layers_count;
extern const mlr_bench_case mlr_bench_cluster_cases[];
extern const size_t mlr_bench_cluster_count;
extern const mlr_bench_case mlr_bench_grbf_cases[];
extern const size_t mlr_bench_grbf_count;
extern const mlr_bench_case mlr_bench_guards_cases[];
extern const size_t mlr_bench_guards_count;
extern const mlr_bench_case mlr_bench_crowd_cases[];
extern const size_t mlr_bench_crowd_count;

/* Set by a case that found its result wrong (the crowd's frames allocated): main returns 1. */
extern int mlr_bench_failed;

#endif
