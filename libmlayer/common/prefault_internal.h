/* Mapping a large output's pages on a second thread while the caller fills it. Not installed.
 *
 * Writing into memory that was never touched costs a page fault per page, in which the kernel
 * zeroes the page: for a new 100 MB numpy array that is about as long as copying the data once.
 * A helper thread that asks the kernel to map the pages writable (Linux madvise
 * MADV_POPULATE_WRITE, which does not change their contents) runs ahead of the caller on the
 * other core, so the caller's writes find their pages mapped. Pages already mapped cost only a
 * walk of the page table. Where the call is not available (other systems, Linux before 5.14)
 * the helper does nothing and the caller faults its pages as before: results never change. */
#ifndef MLR_PREFAULT_INTERNAL_H
#define MLR_PREFAULT_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>

/* Outputs smaller than this are not worth a thread (its start costs tens of microseconds). */
#define MLR_PREFAULT_MIN_BYTES ((size_t)8 << 20)

typedef struct mlr_prefault {
    pthread_t thread;
    int started;
    atomic_int stop; /* set by prefault__finish: the helper stops at its next piece */
    unsigned char *begin, *end; /* page-aligned range */
} mlr_prefault;

/* Start the helper on the pages of [p, p + bytes) when bytes >= MLR_PREFAULT_MIN_BYTES and the
 * system can populate pages; otherwise (or if the thread cannot start) only records that there
 * is none. The memory must stay valid and writable until prefault__finish. */
void prefault__start(mlr_prefault *pf, void *p, size_t bytes);

/* Stop the helper (if any) and wait for it. */
void prefault__finish(mlr_prefault *pf);

#endif
