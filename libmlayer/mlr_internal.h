/* Private helpers shared by the C core. Not installed. */
#ifndef MLR_INTERNAL_H
#define MLR_INTERNAL_H

#include <mlayer/mlayer.h>
#include <stdint.h>
#include <string.h>

#define MLR_COUNTOF(a) (sizeof(a) / sizeof((a)[0]))

/* Allocation through a (possibly NULL) allocator. mlr_alloc returns NULL on failure or when
 * size is 0 is not requested; callers never ask for 0 bytes. */
void mlr_allocator_resolve(const mlr_allocator *in, mlr_allocator *out);
void *mlr_alloc(const mlr_allocator *a, size_t size);
void mlr_free(const mlr_allocator *a, void *ptr, size_t size);

/* *out = a * b, MLR_E_OVERFLOW when it does not fit a size_t. */
static inline mlr_status mlr_mul_size(size_t a, size_t b, size_t *out)
{
    if (b != 0 && a > SIZE_MAX / b)
        return MLR_E_OVERFLOW;
    *out = a * b;
    return MLR_OK;
}

/* Fill diag (if not NULL) with a formatted message; returns status for tail calls. */
mlr_status mlr_diag_set(mlr_diag *diag, mlr_status status, size_t line, size_t column,
                        const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

/* Predictive sign continuity of row f of q (n_frames x n_tracks) given rows f-3 .. f-1 (those
 * that exist) already made continuous: mlr_quat_continue_sign per track (quat.c). */
void mlr_quat_continue_frame(mlr_quat *q, size_t f, size_t n_tracks);

#endif
