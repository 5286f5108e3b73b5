/* Reading a whole file into memory, on several threads for a large regular file. Not
 * installed. */
#ifndef MLR_FILE_READ_INTERNAL_H
#define MLR_FILE_READ_INTERNAL_H

#include "common/mlr_internal.h"

/* Files from this size on are read by several threads (n_threads permitting), in chunks with
 * pread; smaller ones, pipes and devices by one sequential read. */
#define MLR_FILE_PARALLEL_MIN_BYTES ((size_t)1 << 20)

/* Read the file at path into *buf (through a; *cap bytes allocated, *len used, *len < *cap so
 * that one byte past the data is always there). n_threads: 1 reads sequentially, 0 picks one
 * thread per MiB up to the online processors and 8, more allows that many. A file that changes
 * size while it is read in parallel is read again sequentially. Returns MLR_OK, MLR_E_IO (the
 * reason in diag), MLR_E_NO_MEMORY or MLR_E_OVERFLOW; on failure *buf is NULL. */
mlr_status file_read__read(const char *path, size_t n_threads, const mlr_allocator *a, char **buf,
                           size_t *len, size_t *cap, mlr_diag *diag);

/* Most threads a read uses. */
#define MLR_FILE_MAX_THREADS 8

#endif
