/* Whole-file reads: see file_read_internal.h. */
#if defined(__unix__) || defined(__APPLE__)
#define _POSIX_C_SOURCE 200809L /* fdopen, fstat, pread, strerror_r */
#define MLR_POSIX_FILES 1
#endif
#include "io/file_read_internal.h"

#include "common/parallel_internal.h"

#include <errno.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#ifdef MLR_POSIX_FILES
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>
#endif

#define READ_MAX_THREADS MLR_FILE_MAX_THREADS

/* Bytes of a parallel read's chunk: the threads take the next one as they come free, so a
 * thread that starts late or runs slow holds up little. */
#define READ_CHUNK ((size_t)1 << 18)

/* The reason of an errno value, thread-safe (strerror need not be). */
static mlr_status io_error(mlr_diag *diag, const char *what, int err)
{
    char reason[128] = "unknown error";
#ifdef MLR_POSIX_FILES
    /* the XSI strerror_r (this file asks for POSIX, not GNU) fills the buffer */
    if (strerror_r(err, reason, sizeof reason) != 0)
        snprintf(reason, sizeof reason, "error %d", err);
#else
    snprintf(reason, sizeof reason, "error %d", err);
#endif
    return common__diag_set(diag, MLR_E_IO, 0, 0, "%s: %s", what, reason);
}

/* The size of an open file from fseek/ftell, or 0 when unknown: only a first guess. */
static size_t size_hint(FILE *fp)
{
    long n = -1;
    if (fseek(fp, 0, SEEK_END) == 0)
        n = ftell(fp);
    if (fseek(fp, 0, SEEK_SET) != 0) {
        clearerr(fp);
        rewind(fp);
    }
    return n > 0 && (unsigned long)n < SIZE_MAX / 2 ? (size_t)n : 0;
}

/* Read fp from its start to its end, in a buffer first sized from the file's size (one byte
 * more, so that a file of the expected size needs no second buffer) and doubled when the file
 * turns out longer: the size is a guess, not relied on. */
static mlr_status read_stream(FILE *fp, const mlr_allocator *a, char **out, size_t *out_len,
                              size_t *out_cap, mlr_diag *diag)
{
    const size_t hint = size_hint(fp);
    size_t cap = 0, len = 0;
    char *buf = NULL;
    mlr_status s = MLR_OK;
    int err = 0;
    for (;;) {
        if (len == cap) {
            size_t ncap = cap ? cap * 2 : hint ? hint + 1 : (size_t)1 << 16;
            if (ncap < cap) {
                s = MLR_E_OVERFLOW;
                break;
            }
            char *nb = common__alloc(a, ncap);
            if (!nb) {
                s = MLR_E_NO_MEMORY;
                break;
            }
            if (len)
                memcpy(nb, buf, len);
            common__free(a, buf, cap);
            buf = nb;
            cap = ncap;
        }
        errno = 0;
        size_t got = fread(buf + len, 1, cap - len, fp);
        len += got;
        if (got == 0 || len < cap) {
            if (ferror(fp)) {
                s = MLR_E_IO;
                err = errno;
            }
            if (feof(fp) || s != MLR_OK)
                break;
        }
    }
    if (s != MLR_OK) {
        common__free(a, buf, cap);
        if (s == MLR_E_IO)
            return io_error(diag, "read error", err ? err : EIO);
        return common__diag_set(diag, s, 0, 0, "%s", mlr_status_string(s));
    }
    *out = buf;
    *out_len = len;
    *out_cap = cap;
    return MLR_OK;
}

#ifdef MLR_POSIX_FILES
/* A parallel read: chunks of READ_CHUNK bytes handed out as threads come free. */
typedef struct read_job {
    int fd;
    char *buf;
    size_t size;
    atomic_int err; /* 0; the errno of a failed pread; -1 when the file ended early */
} read_job;

static void read_chunk_run(void *ctx, size_t k)
{
    read_job *j = ctx;
    const size_t off = k * READ_CHUNK;
    const size_t len = j->size - off < READ_CHUNK ? j->size - off : READ_CHUNK;
    size_t done = 0;
    while (done < len) {
        ssize_t got = pread(j->fd, j->buf + off + done, len - done, (off_t)(off + done));
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0) {
            int none = 0;
            atomic_compare_exchange_strong(&j->err, &none, got < 0 ? errno : -1);
            return;
        }
        done += (size_t)got;
    }
}

/* A regular file of `size` bytes on T threads. Returns 1 when read, 0 when the file must be
 * read sequentially instead (it changed size), -1 on an error (diag set, *status). */
static int read_parallel(int fd, size_t size, size_t T, const mlr_allocator *a, char **out,
                         size_t *out_len, size_t *out_cap, mlr_status *status, mlr_diag *diag)
{
    const size_t cap = size + 1;
    char *buf = common__alloc(a, cap);
    if (!buf) {
        *status = common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "%s",
                                   mlr_status_string(MLR_E_NO_MEMORY));
        return -1;
    }
    read_job j = {fd, buf, size, 0};
    atomic_init(&j.err, 0);
    parallel__run(T, (size + READ_CHUNK - 1) / READ_CHUNK, read_chunk_run, &j);
    const int err = atomic_load(&j.err);
    if (err > 0) {
        common__free(a, buf, cap);
        *status = io_error(diag, "read error", err);
        return -1;
    }
    /* a byte past the size means the file grew meanwhile */
    ssize_t more;
    do
        more = pread(fd, buf + size, 1, (off_t)size);
    while (more < 0 && errno == EINTR);
    if (err < 0 || more != 0) {
        common__free(a, buf, cap);
        return 0;
    }
    *out = buf;
    *out_len = size;
    *out_cap = cap;
    return 1;
}
#endif

mlr_status file_read__read(const char *path, size_t n_threads, const mlr_allocator *a, char **buf,
                           size_t *len, size_t *cap, mlr_diag *diag)
{
    *buf = NULL;
    *len = *cap = 0;
#ifdef MLR_POSIX_FILES
    int fd;
    do
        fd = open(path, O_RDONLY | O_CLOEXEC);
    while (fd < 0 && errno == EINTR);
    if (fd < 0)
        return io_error(diag, "cannot open", errno);
    struct stat st;
    if (n_threads != 1 && fstat(fd, &st) == 0 && S_ISREG(st.st_mode) &&
        (unsigned long long)st.st_size >= MLR_FILE_PARALLEL_MIN_BYTES &&
        (unsigned long long)st.st_size < SIZE_MAX / 2) {
        const size_t size = (size_t)st.st_size;
        size_t T = n_threads ? n_threads : size >> 20;
        const size_t cpus = parallel__online_cpus();
        if (!n_threads && T > cpus)
            T = cpus;
        if (T > READ_MAX_THREADS)
            T = READ_MAX_THREADS;
        if (T > 1) {
            mlr_status s = MLR_OK;
            const int r = read_parallel(fd, size, T, a, buf, len, cap, &s, diag);
            if (r != 0) {
                close(fd);
                return s;
            }
        }
    }
    FILE *fp = fdopen(fd, "rb");
    if (!fp) {
        const int err = errno;
        close(fd);
        return io_error(diag, "cannot open", err);
    }
#else
    (void)n_threads;
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return io_error(diag, "cannot open", errno);
#endif
    mlr_status s = read_stream(fp, a, buf, len, cap, diag);
    fclose(fp);
    return s;
}
