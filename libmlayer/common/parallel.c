/* The fixed-task parallel loop of the threaded parts (k-means, SOM, GRBF, BVH frames). See
 * parallel_internal.h. */
#define _DEFAULT_SOURCE 1 /* sysconf */
#include "common/parallel_internal.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

typedef struct par_ctx {
    atomic_size_t next;
    size_t n_tasks;
    mlr_task_worker_fn fn;
    void *ctx;
} par_ctx;

typedef struct par_worker_arg {
    par_ctx *pc;
    size_t worker;
} par_worker_arg;

static void *par_worker(void *arg)
{
    const par_worker_arg *wa = arg;
    par_ctx *pc = wa->pc;
    for (;;) {
        size_t t = atomic_fetch_add(&pc->next, 1);
        if (t >= pc->n_tasks)
            break;
        pc->fn(pc->ctx, t, wa->worker);
    }
    return NULL;
}

void parallel__run_workers(size_t n_threads, size_t n_tasks, mlr_task_worker_fn fn, void *ctx)
{
    if (n_threads > MLR_MAX_THREADS)
        n_threads = MLR_MAX_THREADS;
    if (n_threads > n_tasks)
        n_threads = n_tasks;
    if (n_threads <= 1) {
        for (size_t t = 0; t < n_tasks; t++)
            fn(ctx, t, 0);
        return;
    }
    par_ctx pc;
    atomic_init(&pc.next, 0);
    pc.n_tasks = n_tasks;
    pc.fn = fn;
    pc.ctx = ctx;
    pthread_t th[MLR_MAX_THREADS];
    par_worker_arg args[MLR_MAX_THREADS];
    size_t started = 0;
    for (size_t i = 0; i + 1 < n_threads; i++) {
        args[started].pc = &pc;
        args[started].worker = started + 1;
        if (pthread_create(&th[started], NULL, par_worker, &args[started]) != 0)
            break; /* the others take its share */
        started++;
    }
    par_worker_arg self = {&pc, 0};
    par_worker(&self);
    for (size_t i = 0; i < started; i++)
        pthread_join(th[i], NULL);
}

typedef struct par_plain {
    mlr_task_fn fn;
    void *ctx;
} par_plain;

static void par_plain_task(void *ctx, size_t task, size_t worker)
{
    (void)worker;
    const par_plain *pp = ctx;
    pp->fn(pp->ctx, task);
}

void parallel__run(size_t n_threads, size_t n_tasks, mlr_task_fn fn, void *ctx)
{
    par_plain pp = {fn, ctx};
    parallel__run_workers(n_threads, n_tasks, par_plain_task, &pp);
}

size_t parallel__wait_nonzero(atomic_size_t *a)
{
    size_t v;
    for (unsigned i = 0; (v = atomic_load_explicit(a, memory_order_acquire)) == 0; i++)
        if (i >= 256)
            sched_yield();
    return v;
}

size_t parallel__online_cpus(void)
{
#ifdef _SC_NPROCESSORS_ONLN
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n > 1)
        return (size_t)n;
#endif
    return 1;
}
