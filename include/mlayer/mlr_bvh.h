/*
 * BVH motion files: a reader and a writer of motion handles (mlr_motion.h).
 *
 * Data model of a motion read from BVH (DESIGN.md; the handle is in mlr_motion.h):
 * - J joints (ROOT and JOINT entries) in BVH depth-first order: joint 0 is the root and every
 *   joint's parent comes before it. parents[0] == -1.
 * - offsets: J x 3, the OFFSET of each joint as written in the file.
 * - root_pos: N x 3, the root's translation per frame. Position channels REPLACE the OFFSET
 *   component they name (they are absolute, as MotionBuilder and Blender read them); a root
 *   without position channels gets its OFFSET in every frame.
 * - rot: N x J x 4 unit quaternions, scalar first (w, x, y, z), local to the parent, converted
 *   from each joint's own Euler order (degrees in the file, intrinsic, as the CHANNELS line
 *   names the axes).
 * - trans: N x P x 3 translations of the P non-root joints that have position channels, again
 *   replacing their OFFSET (Bandai Namco clips put 6 channels on every joint).
 *   trans_joints lists those P joints in increasing order.
 * - End Sites (leaf markers without channels) are kept with their parent joint and OFFSET so
 *   that a written file has the same hierarchy. Forward kinematics ignores them.
 *
 * A joint with fewer than 3 rotation channels keeps the missing angles at zero; its Euler order
 * is the listed rotation axes followed by the missing ones in X, Y, Z order. When such a joint
 * is written, only the listed angles are written.
 *
 * Every function is thread-safe on separate handles; a handle may be read from several
 * threads at once while nobody modifies it.
 */
#ifndef MLR_BVH_H
#define MLR_BVH_H

#include <stdint.h>

#include "mlr_common.h"
#include "mlr_motion.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------------------------------- */
/* Reading                                                                                  */

/**
 * Parse BVH text from memory.
 * Accepts LF, CRLF or CR line ends, tabs and any whitespace, a UTF-8 byte order mark, keywords
 * in any case, 0 to 6 channels per joint in any order, position channels on any joint and a
 * different Euler order on every joint. One ROOT per file. Every frame is one line holding
 * exactly as many values as the hierarchy declares channels, and there are exactly as many as
 * "Frames:" declares (strict; mlr_bvh_read_memory_opts reads the usual deviations with
 * warnings).
 * Never allocates from an unchecked count: "Frames:" is bounded by the bytes that follow it.
 * @param text   [in] the file's bytes, need not be NUL-terminated; not kept
 * @param len    [in] number of bytes
 * @param alloc  [in] allocator, copied into the motion; NULL for malloc/free
 * @param out    [out] new motion, or NULL on failure; release with mlr_motion_destroy
 * @param diag   [out] optional: on MLR_E_PARSE the 1-based line and column and the reason
 * @return MLR_OK; MLR_E_PARSE (malformed input, details in diag); MLR_E_NO_MEMORY;
 *         MLR_E_OVERFLOW; MLR_E_INVALID_ARG (out NULL, text NULL with len > 0)
 * Allocates: yes. Threads: any.
 */
MLR_API mlr_status mlr_bvh_read_memory(const char *text, size_t len, const mlr_allocator *alloc,
                                       mlr_motion **out, mlr_diag *diag);

/**
 * Read and parse a BVH file (the whole file is read into memory first).
 * @param path   [in] file name, passed to fopen as is (bytes in the platform's encoding)
 * @return as mlr_bvh_read_memory, plus MLR_E_IO (cannot open or read; reason in diag with
 *         line 0)
 */
MLR_API mlr_status mlr_bvh_read_file(const char *path, const mlr_allocator *alloc,
                                     mlr_motion **out, mlr_diag *diag);

/**
 * mlr_bvh_read_memory with the frame lines parsed on several threads.
 * The MOTION text is cut at line ends into chunks of about 128 KiB (at least one per thread),
 * which the threads take in turn as they come free; the result, and on failure the status and
 * diag (the first bad line, as a single thread reports it), do not depend on n_threads:
 * bit-identical frames for every thread count. Files whose frame lines are not one per line
 * (blank lines, CR-only line ends) are still read correctly, partly on one thread.
 * @param n_threads [in] threads to use, the calling one included: 1 for the calling thread
 *                  only (as mlr_bvh_read_memory), 0 for automatic (one per 512 KiB of frame
 *                  text, at most the online processors and 8); values above 16 count as 16
 * @return as mlr_bvh_read_memory
 * Allocates: yes (the motion, per thread a scratch of a few KiB, and a few hundred bytes per
 * chunk). Threads: starts up to n_threads - 1 threads and joins them before returning (if one
 * cannot be started, the others take its chunks).
 */
MLR_API mlr_status mlr_bvh_read_memory_mt(const char *text, size_t len, size_t n_threads,
                                          const mlr_allocator *alloc, mlr_motion **out,
                                          mlr_diag *diag);

/**
 * mlr_bvh_read_file with the frame lines parsed on n_threads threads (see
 * mlr_bvh_read_memory_mt; 0 for automatic). A regular file of 1 MiB or more is first read by
 * several threads (n_threads, or for 0 one per MiB up to the online processors), in chunks of
 * 256 KiB with pread (POSIX systems); a file whose size changes meanwhile is read again by one
 * thread. Other files (pipes, devices) and smaller ones are read by one.
 */
MLR_API mlr_status mlr_bvh_read_file_mt(const char *path, size_t n_threads,
                                        const mlr_allocator *alloc, mlr_motion **out,
                                        mlr_diag *diag);

/* ---------------------------------------------------------------------------------------- */
/* Lenient reading with warnings                                                            */
/*                                                                                          */
/* The readers above are strict: any deviation from the layout is an MLR_E_PARSE. Files     */
/* from the wild often deviate in the MOTION section only; mlr_bvh_read_memory_opts and     */
/* mlr_bvh_read_file_opts read those and report each deviation as a warning:                */
/* - more frame lines than "Frames:" declares (any number): every complete frame line is    */
/*   read (as Blender's importer and bvhio do), MLR_BVH_WARN_EXTRA_FRAMES;                  */
/* - up to MLR_BVH_MAX_MISSING_FRAMES fewer frame lines, the file ending with a line end:   */
/*   the frames present are read, MLR_BVH_WARN_MISSING_FRAMES;                              */
/* - data after the frames that is not a frame line (a line that does not start with a     */
/*   number, or any line once all declared frames are read): ignored from that line on,    */
/*   MLR_BVH_WARN_TRAILING_DATA;                                                            */
/* - no line end after the last frame line: read, MLR_BVH_WARN_NO_FINAL_NEWLINE (also in    */
/*   strict mode, where it is not an error either).                                         */
/* A truncated file stays an error (MLR_E_PARSE, today's reason and "truncated file"): more */
/* than MLR_BVH_MAX_MISSING_FRAMES frames missing, or fewer frames than declared and the    */
/* last line incomplete or without a line end. With MLR_BVH_OPT_KEEP_TRUNCATED it gives    */
/* the complete frames instead, MLR_BVH_WARN_TRUNCATED. A malformed frame line followed by  */
/* more lines is an error in every mode, and so is anything wrong before the frames.        */

/** Option keys of mlr_bvh_read_memory_opts / mlr_bvh_read_file_opts (value 0 or 1 for the
 *  switches). Values pinned; new options get new values. */
typedef enum mlr_bvh_read_key {
    MLR_BVH_OPT_STRICT = 1,          /* 1: every deviation is an error, as mlr_bvh_read_memory;
                                        default 0 (lenient, with warnings) */
    MLR_BVH_OPT_KEEP_TRUNCATED = 2   /* 1: a truncated file gives its complete frames (with a
                                        warning); default 0 (an error). Ignored when strict. */
} mlr_bvh_read_key;

/** One option: key (an mlr_bvh_read_key) and its value. A frozen value type. */
typedef struct mlr_bvh_read_option {
    int key;
    double value;
} mlr_bvh_read_option;

/** Warning codes. Values pinned. */
typedef enum mlr_bvh_warning_code {
    MLR_BVH_WARN_EXTRA_FRAMES = 1,     /* more frame lines than Frames: declares; all read */
    MLR_BVH_WARN_MISSING_FRAMES = 2,   /* a few fewer; the frames present read */
    MLR_BVH_WARN_TRAILING_DATA = 3,    /* data after the frames, ignored */
    MLR_BVH_WARN_NO_FINAL_NEWLINE = 4, /* the last frame line has no line end */
    MLR_BVH_WARN_TRUNCATED = 5         /* KEEP_TRUNCATED: the complete frames of a cut file */
} mlr_bvh_warning_code;

/** Most frames that may be missing against "Frames:" without making the file truncated. */
#define MLR_BVH_MAX_MISSING_FRAMES 3
/** Warnings kept in an mlr_bvh_warnings (more are counted). */
#define MLR_BVH_WARNINGS_KEPT 8

/** One warning: its code, the 1-based line and column it refers to (column 0 for a whole
 *  line) and the reason, NUL-terminated. A frozen value type. */
typedef struct mlr_bvh_warning {
    int32_t code;
    size_t line, column;
    char message[160];
} mlr_bvh_warning;

/** The warnings of one read, in the order of the lines. A frozen value type. */
typedef struct mlr_bvh_warnings {
    size_t count;                                   /* warnings issued */
    mlr_bvh_warning first[MLR_BVH_WARNINGS_KEPT];   /* the first min(count, KEPT) */
} mlr_bvh_warnings;

/**
 * Parse BVH text from memory with options (see above): lenient by default.
 * @param text, len, n_threads, alloc, out  as mlr_bvh_read_memory_mt (n_threads 1 for the
 *                  calling thread only, 0 automatic); frames are bit-identical for every count
 * @param opts      [in] n_opts options; NULL when n_opts is 0. A key may appear once.
 * @param warnings  [out] optional: set on every return (count 0 on errors and clean files)
 * @param diag      [out] optional: as mlr_bvh_read_memory; on MLR_E_INVALID_ARG the bad option
 * @return MLR_OK (possibly with warnings); MLR_E_PARSE; MLR_E_NO_MEMORY; MLR_E_OVERFLOW;
 *         MLR_E_INVALID_ARG (as mlr_bvh_read_memory; an unknown or repeated key, a switch not
 *         0 or 1)
 * Allocates: as mlr_bvh_read_memory_mt; a file with extra or missing frames is copied once
 * into a motion of the right size. Threads: as mlr_bvh_read_memory_mt.
 */
MLR_API mlr_status mlr_bvh_read_memory_opts(const char *text, size_t len, size_t n_threads,
                                            const mlr_bvh_read_option *opts, size_t n_opts,
                                            const mlr_allocator *alloc, mlr_motion **out,
                                            mlr_bvh_warnings *warnings, mlr_diag *diag);

/**
 * mlr_bvh_read_file_mt with options and warnings (as mlr_bvh_read_memory_opts).
 * @return as mlr_bvh_read_memory_opts, plus MLR_E_IO (as mlr_bvh_read_file)
 */
MLR_API mlr_status mlr_bvh_read_file_opts(const char *path, size_t n_threads,
                                          const mlr_bvh_read_option *opts, size_t n_opts,
                                          const mlr_allocator *alloc, mlr_motion **out,
                                          mlr_bvh_warnings *warnings, mlr_diag *diag);

/* ---------------------------------------------------------------------------------------- */
/* Writing                                                                                  */

/**
 * Sink for mlr_bvh_write: receives the text in pieces, in order. Return 0 to go on, anything
 * else to stop writing (mlr_bvh_write then returns MLR_E_IO).
 */
typedef int (*mlr_bvh_write_fn)(void *user, const char *data, size_t len);

/**
 * Write the motion as BVH text: the same hierarchy, End Sites, channel layout and Euler orders,
 * LF line ends, tab indentation. OFFSETs and Frame Time are written with the fewest digits
 * that read back to the same double; position channels with 9 significant digits when that
 * reads back exactly, else 17; angles (in degrees, from the quaternions) with 9 significant
 * digits (an error of the order of 1e-8 rad). Output does not depend on the locale.
 * @param motion [in] the motion; rot need not be normalized
 * @param fn     [in] sink, called many times with pieces of at most a few KiB
 * @param user   [in] passed to fn
 * @param diag   [out] optional: the reason of a failure (the NULL argument; the array, frame
 *               and joint of the first value that cannot be written)
 * @return MLR_OK; MLR_E_IO (fn asked to stop); MLR_E_INVALID_ARG (NULL arguments; a
 *         non-finite value or a zero quaternion, checked before anything is written)
 * Allocates: never (works in a few KiB of stack). Threads: motion is only read.
 */
MLR_API mlr_status mlr_bvh_write(const mlr_motion *motion, mlr_bvh_write_fn fn, void *user,
                                 mlr_diag *diag);

/**
 * Write the BVH text into caller memory.
 * @param buf    [out] destination, or NULL to query the size only
 * @param cap    [in] bytes available at buf
 * @param len    [out] bytes the text takes (always set on MLR_OK and MLR_E_OVERFLOW); no NUL
 *               terminator is written or counted
 * @param diag   [out] optional: the reason of a failure, as mlr_bvh_write (cap and the size on
 *               MLR_E_OVERFLOW)
 * @return MLR_OK; MLR_E_OVERFLOW (buf is not NULL and cap < *len; buf holds the first cap
 *         bytes); MLR_E_INVALID_ARG (as mlr_bvh_write, or len NULL)
 * Allocates: never. Threads: motion is only read.
 */
MLR_API mlr_status mlr_bvh_write_memory(const mlr_motion *motion, char *buf, size_t cap,
                                        size_t *len, mlr_diag *diag);

/**
 * Write the motion to a BVH file atomically: the text goes to a new temporary file in the same
 * directory, which then replaces path by a rename. On any failure the temporary file is
 * removed and path is left as it was. A new file gets the mode a plain fopen gives it (0666
 * less the umask: 0644 under umask 022); a file that replaces an existing regular file takes
 * that file's mode (POSIX), so a 0600 output stays 0600.
 *
 * The temporary's name is part of this contract, so that a caller can clean up after a writer
 * that was killed: the temporary of DIR/NAME is
 *
 *     DIR/.NAME.tmp-HHHHHHHHHHHHHHHH
 *
 * where HHHHHHHHHHHHHHHH are 16 lowercase hexadecimal digits (random), created exclusively
 * (another writer's temporary is never reused). Other writers of the project follow the same
 * rule and may append an extension (a dot and 1 to 16 characters, none a dot or a path
 * separator) for libraries that choose a format by it; this function appends none. A
 * temporary exists only while a writer runs: one whose writer is gone may be removed (the
 * Python package's batch runs do, mlayer._files.stale_temporaries lists them). NAME must
 * leave room for the 22 characters added within the file system's name limit.
 * @param path   [in] the file to write; NUL-terminated, not ending with a path separator
 * @param diag   [out] optional: the reason of a failure (for a value that cannot be written,
 *               as mlr_bvh_write)
 * @return MLR_OK; MLR_E_IO (the temporary cannot be created, written or renamed);
 *         MLR_E_INVALID_ARG (motion or path NULL or empty, path ends with a separator, the
 *         motion holds a non-finite value or a zero quaternion); MLR_E_NO_MEMORY;
 *         MLR_E_OVERFLOW (path is longer than SIZE_MAX - 24)
 * Allocates: yes (a buffer for the temporary name, from the motion's allocator).
 * Threads: motion is only read.
 */
MLR_API mlr_status mlr_bvh_write_file(const mlr_motion *motion, const char *path, mlr_diag *diag);

#ifdef __cplusplus
}
#endif

#endif /* MLR_BVH_H */
