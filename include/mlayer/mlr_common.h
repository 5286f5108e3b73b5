/*
 * mlayer common definitions: export macro, status codes, allocator, parser diagnostics.
 *
 * Conventions of the whole API:
 * - Functions that can fail return mlr_status: 0 is success, < 0 an error (no result; out
 *   handles are set to NULL), > 0 a warning (the result is usable).
 * - Arrays are row-major float64, frames along the first axis; quaternions are scalar-first.
 * - The library never prints, exits or aborts and keeps no global mutable state. Every
 *   function is safe to call from several threads on separate data.
 * - Diagnostics: a function that can fail for more than one reason takes an optional
 *   mlr_diag * (last, or before out/alloc where those come last) and fills it on every failure,
 *   allocation and overflow included, with a message that names the argument, the element or
 *   the option. The status functions without one are the getters of a handle (a NULL handle
 *   or a count other than the documented one), mlr_ik_from_to and mlr_motion_set_frame_time
 *   (one reason each).
 * - Options: a function with several tunables takes an array of {int key; double value;}
 *   (mlr_layers_option, mlr_guards_option, ...), keys pinned, a key at most once; one reader
 *   checks them all, and its messages name an option by the lower-case suffix of its key
 *   ("layers: option lam_c = -1 is not > 0" for MLR_LAYERS_OPT_LAM_C), which is also the
 *   Python keyword (lam_c) and, with '-' for '_', the command-line flag (--lam-c). Booleans
 *   of functions without tunables are flags in an unsigned bitmask (MLR_RESAMPLE_*), named in
 *   messages the same way ("allow_extreme"). The rule: flags for booleans, key/value options
 *   for tunables. See docs/OPTIONS.md.
 * - Matrix arguments: a strided matrix is (pointer, rows, leading dimension) followed by its
 *   column count; a count fixed by a handle or shared with an earlier matrix is left out
 *   (mlr_kmeans_fit(km, x, n, ldx, ...), mlr_lgs_solve(lgs, y, ldy, m, x, ldx, ...),
 *   mlr_grbf_basis(..., centers, n_centers, ldc, x, n, ldx, dim, ...)). Contiguous motion
 *   arrays (frames x joints x components) take their shape first (n_frames, n_joints, ...),
 *   then the arrays; flat element arrays are (pointer, count).
 */
#ifndef MLR_COMMON_H
#define MLR_COMMON_H

#include <stddef.h>

#if defined(_WIN32) && defined(MLR_BUILDING_DLL)
#define MLR_API __declspec(dllexport)
#elif defined(_WIN32) && !defined(MLR_STATIC)
#define MLR_API __declspec(dllimport)
#elif defined(__GNUC__)
#define MLR_API __attribute__((visibility("default")))
#else
#define MLR_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/** 0 ok; < 0 error, no result (out handles NULL); > 0 warning, result usable. */
typedef int mlr_status;

/* Values are pinned forever: new codes fill the gaps, none is ever renumbered. */
enum {
    MLR_OK = 0,
    MLR_E_INVALID_ARG = -10,
    MLR_E_NO_MEMORY = -20,
    MLR_E_OVERFLOW = -21,
    MLR_E_SINGULAR = -30,
    MLR_E_BAD_STATE = -40,
    MLR_E_UNSUPPORTED = -41,
    MLR_E_PARSE = -50,
    MLR_E_IO = -51,
    MLR_W_ILL_CONDITIONED = 10,
    MLR_W_MAX_ITER = 20
};

/** Symbolic name of a status, e.g. "MLR_E_SINGULAR"; "MLR_UNKNOWN" for other values. Never NULL. */
MLR_API const char *mlr_status_name(mlr_status s);
/** One sentence describing a status, static storage. Never NULL. */
MLR_API const char *mlr_status_string(mlr_status s);

/** Version of the library that is actually loaded, e.g. "0.2.0" (static storage). */
MLR_API const char *mlr_version_string(void);
/** MLR_VERSION_NUMBER of the loaded library: major*10000 + minor*100 + patch. */
MLR_API int mlr_version_number(void);

/**
 * Memory allocator. Pass NULL wherever an allocator is taken to get malloc/free.
 * allocate returns NULL on failure and memory aligned to at least align bytes (a power of two,
 * at most 64); release gets the size that was asked for.
 */
typedef struct mlr_allocator {
    void *(*allocate)(void *user, size_t size, size_t align);
    void (*release)(void *user, void *ptr, size_t size);
    void *user;
} mlr_allocator;

/** Optional details from parsers and validators; caller-owned, filled on error. */
typedef struct mlr_diag {
    size_t line, column;   /* 1-based; 0 when not applicable */
    char message[160];     /* always NUL-terminated */
} mlr_diag;

#ifdef __cplusplus
}
#endif

#endif /* MLR_COMMON_H */
