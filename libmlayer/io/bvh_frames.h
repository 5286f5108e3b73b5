/* Kernels of the BVH reader's MOTION section (bvh_read.c): a whole-line number parser and the
 * per-frame conversion (channels to root positions, translations and quaternions). Not
 * installed.
 *
 * Three sets, picked at run time: portable C (no line parser: the careful one in bvh_read.c
 * reads every line), and on x86-64 AVX2 (with FMA, BMI2) and AVX-512 (F, BW, DQ, VL, BMI2).
 * All give bit-identical results: the line parsers are exact (every value is the correctly
 * rounded double, as strtod gives) and the conversions run the same IEEE operations in the same
 * order (no contraction into FMA). */
#ifndef MLR_BVH_FRAMES_H
#define MLR_BVH_FRAMES_H

#include "common/cpu.h"

#include <stddef.h>
#include <stdint.h>

/* How the values of one frame line become a frame, shared read-only by all threads. Joints
 * are padded to Jp = J rounded up to 8 in the per-slot arrays. A thread's row holds the C values
 * at [0, C), then up to R = C rounded up to 8 room for the line kernel's stores, then four
 * zeros at [R, R + 4) and from R + 4 on 3 + 3P constants: the root's OFFSET and each translated
 * joint's. */
typedef struct bvh_conv {
    size_t C, J, Jp, P, R;
    const uint32_t *src;      /* 3 + 3P + 3Jp row indices: root x y z, then each translated
                               * joint's x y z, then at 3 + 3P + k Jp + j the angle of slot k (0,
                               * 1, 2: place in the joint's Euler order) of joint j, R when no
                               * channel fills it or j >= J */
    const uint32_t *tri;      /* Jp: row index of joint j's first angle when its three angles
                               * are consecutive channels (slot k at tri[j] + k), R for j >= J */
    const unsigned char *tri_ok; /* Jp / 8: whether every joint of the group of 8 has tri */
    const unsigned char *sel; /* 3 Jp: at a Jp + j the slot whose component is joint j's axis a
                               * (x, y, z) in its quaternion (0 for j >= J) */
    const double *par;        /* Jp: parity of each joint's Euler order (+1 cyclic, -1
                               * anticyclic; 1 for j >= J) */
} bvh_conv;

/* Doubles of a thread's row: the values, room, zeros and the constants. */
static inline size_t bvh_frame_row_size(const bvh_conv *cv) { return cv->R + 7 + 3 * cv->P; }

/* Doubles of a thread's tmp: half-angles, sines and cosines (the portable and AVX2 kernels;
 * the AVX-512 one keeps them in registers). */
static inline size_t bvh_frame_tmp_size(const bvh_conv *cv) { return 9 * cv->Jp; }

/* Per-thread scratch of the frame loop. */
typedef struct bvh_scratch {
    double *row;           /* bvh_frame_row_size(cv) */
    double *tmp;           /* bvh_frame_tmp_size(cv) */
    const char **ends;     /* C + 16 token ends (the line parser) */
} bvh_scratch;

/* Parse one frame line starting at p: the C values into row[0, C) (row has room up to C
 * rounded up to 8) and *line_end at the line's end-of-line byte (or end). Returns 0 when the
 * line is not C numbers separated by spaces or tabs, nothing else (a blank line, a count
 * off, a bad number, a control byte, ...): the caller then parses it the careful way, which
 * reports the error. p must be at least 16 bytes past the start of the text (the kernel reads
 * up to 16 bytes before each token's end, never at or past end). */
typedef int (*bvh_line_fn)(const char *p, const char *end, size_t C, const char **ends,
                           double *row, const char **line_end);

/* Convert row (values of frame f, constants in place) into the frame's outputs:
 * rp (3 doubles), tr (3 P), q (4 J). tmp as in bvh_scratch. */
typedef void (*bvh_frame_fn)(const bvh_conv *cv, const double *row, double *tmp, double *rp,
                             double *tr, double *q);

typedef struct bvh_kernels {
    bvh_line_fn line;      /* NULL when no whole-line parser suits this CPU */
    bvh_frame_fn frame;
    size_t (*count_newlines)(const char *p, const char *end); /* '\n' bytes in [p, end) */
} bvh_kernels;

/* Kernel sets, from the portable one up: ISA levels of common/cpu.h (the one dispatch). */
enum {
    BVH_KERNELS_PORTABLE = MLR_ISA_BASELINE,
    BVH_KERNELS_AVX2 = MLR_ISA_AVX2,
    BVH_KERNELS_AVX512 = MLR_ISA_AVX512,
    BVH_KERNELS_BEST = MLR_ISA_BEST
};

/* The fastest kernels this CPU runs, up to the set most (BVH_KERNELS_BEST in the library; the
 * others let tests and the fuzz target compare them). */
void bvh_kernels_pick(bvh_kernels *k, int most);

#endif
