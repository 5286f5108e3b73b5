/* The page-mapping helper thread: see prefault_internal.h. */
#define _DEFAULT_SOURCE 1 /* madvise, MADV_POPULATE_WRITE, sysconf */
#include "common/prefault_internal.h"

#include <stdint.h>
#if defined(__unix__) || defined(__APPLE__)
#include <sys/mman.h>
#include <unistd.h>
#endif

/* Pieces of 2 MiB (a huge page): small enough that a stop request is seen quickly. */
#define PIECE ((size_t)2 << 20)

#ifdef MADV_POPULATE_WRITE
static void *prefault_run(void *arg)
{
    mlr_prefault *pf = arg;
    for (unsigned char *q = pf->begin; q < pf->end; q += PIECE) {
        if (atomic_load_explicit(&pf->stop, memory_order_relaxed))
            break;
        size_t len = (size_t)(pf->end - q) < PIECE ? (size_t)(pf->end - q) : PIECE;
        if (madvise(q, len, MADV_POPULATE_WRITE) != 0)
            break; /* not supported here (EINVAL), or no memory: the caller faults its pages */
    }
    return NULL;
}
#endif

void prefault__start(mlr_prefault *pf, void *p, size_t bytes)
{
    pf->started = 0;
    atomic_init(&pf->stop, 0);
#ifdef MADV_POPULATE_WRITE
    long page = sysconf(_SC_PAGESIZE);
    if (bytes < MLR_PREFAULT_MIN_BYTES || page <= 0 || (size_t)page > PIECE)
        return;
    /* whole pages: the first and last may hold other data of the process; populating a page
     * does not change what it holds */
    const uintptr_t mask = (uintptr_t)page - 1, a = (uintptr_t)p;
    pf->begin = (unsigned char *)(a & ~mask);
    pf->end = (unsigned char *)((a + bytes + mask) & ~mask);
    pf->started = pthread_create(&pf->thread, NULL, prefault_run, pf) == 0;
#else
    (void)p;
    (void)bytes;
#endif
}

void prefault__finish(mlr_prefault *pf)
{
    if (!pf->started)
        return;
    atomic_store_explicit(&pf->stop, 1, memory_order_relaxed);
    pthread_join(pf->thread, NULL);
    pf->started = 0;
}
