/* A fixed-task parallel loop for the library's threaded parts. Not installed. */
#ifndef MLR_PARALLEL_INTERNAL_H
#define MLR_PARALLEL_INTERNAL_H

#include <stdatomic.h>
#include <stddef.h>

/* Largest thread count honoured; more are clamped. */
#define MLR_MAX_THREADS 64

/* Run fn(ctx, t) for t = 0 .. n_tasks-1 on up to n_threads threads (the caller is one of
 * them). Tasks are taken in any order by any thread, so a result must depend only on the task
 * index (each task writes its own output). If a thread cannot be started the remaining tasks
 * run on the others: never fails, never allocates. */
typedef void (*mlr_task_fn)(void *ctx, size_t task);
void parallel__run(size_t n_threads, size_t n_tasks, mlr_task_fn fn, void *ctx);

/* The same, fn also told which thread runs the task: worker 0 is the caller, the others 1 ..
 * n_threads-1 (for per-thread scratch). Tasks are handed out in increasing order, so a task may
 * wait for something an earlier task publishes early in its run (its thread is running). */
typedef void (*mlr_task_worker_fn)(void *ctx, size_t task, size_t worker);
void parallel__run_workers(size_t n_threads, size_t n_tasks, mlr_task_worker_fn fn, void *ctx);

/* Wait until *a is not 0 and return it (an acquire load): spins a little, then yields the
 * processor at each look (the thread that is to publish may have lost its own). */
size_t parallel__wait_nonzero(atomic_size_t *a);

/* Online processors (at least 1). */
size_t parallel__online_cpus(void);

#endif
