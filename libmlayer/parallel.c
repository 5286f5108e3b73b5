/* The fixed-task parallel loop of the threaded parts (k-means, SOM, GRBF, BVH frames). See
 * parallel_internal.h. */
#define _DEFAULT_SOURCE 1 /* sysconf */
#include "parallel_internal.h"

#include <pthread.h>
#include <stdatomic.h>
#if defined(__unix__) || defined(__APPLE__)
#  include <unistd.h>
#endif

typedef struct par_ctx {
    atomic_size_t next;
    size_t n_tasks;
    mlr_task_fn fn;
    void *ctx;
} par_ctx;

static void *par_worker(void *arg)
{
    par_ctx *pc = arg;
    for (;;) {
        size_t t = atomic_fetch_add(&pc->next, 1);
        if (t >= pc->n_tasks)
            break;
        pc->fn(pc->ctx, t);
    }
    return NULL;
}

void mlr_parallel_run(size_t n_threads, size_t n_tasks, mlr_task_fn fn, void *ctx)
{
    if (n_threads > MLR_MAX_THREADS)
        n_threads = MLR_MAX_THREADS;
    if (n_threads > n_tasks)
        n_threads = n_tasks;
    if (n_threads <= 1) {
        for (size_t t = 0; t < n_tasks; t++)
            fn(ctx, t);
        return;
    }
    par_ctx pc;
    atomic_init(&pc.next, 0);
    pc.n_tasks = n_tasks;
    pc.fn = fn;
    pc.ctx = ctx;
    pthread_t th[MLR_MAX_THREADS];
    size_t started = 0;
    for (size_t i = 0; i + 1 < n_threads; i++) {
        if (pthread_create(&th[started], NULL, par_worker, &pc) != 0)
            break; /* the others take its share */
        started++;
    }
    par_worker(&pc);
    for (size_t i = 0; i < started; i++)
        pthread_join(th[i], NULL);
}

size_t mlr_online_cpus(void)
{
#ifdef _SC_NPROCESSORS_ONLN
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n > 1)
        return (size_t)n;
#endif
    return 1;
}
