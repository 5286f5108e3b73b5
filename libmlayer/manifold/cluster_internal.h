/* Private building blocks shared by k-means (kmeans.c) and the SOM (som.c): a seeded
 * generator, packed centres with a nearest/second-nearest search, and the relocatable blob
 * format of trained models. Not installed. */
#ifndef MLR_CLUSTER_INTERNAL_H
#define MLR_CLUSTER_INTERNAL_H

#include "common/mlr_internal.h"
#include "common/parallel_internal.h"

#include <stdint.h>

/* The seeded generator mlr_rng (xoshiro256** seeded through splitmix64) is public:
 * mlr_markov.h. */

/* Centres packed for the search: blocks of 16, pc[(jb * dim + t) * 16 + l] is coordinate t of
 * centre 16 jb + l; cn[j] = ||c_j||^2, +inf for the padding centres (never chosen). */
#define MLR_PACK 16
typedef struct mlr_packed {
    double *pc, *cn;   /* kpad * dim and kpad doubles */
    size_t k, kpad, dim;
    int isa;           /* MLR_ISA_* level of the kernels that search it: cpu__isa(MLR_ISA_BEST),
                        * set with k, kpad and dim (tests set MLR_ISA_BASELINE too) */
} mlr_packed;
size_t cluster__packed_kpad(size_t k);
/* Pack c (k x dim, row stride ldc) into p (whose buffers the caller sized). */
void cluster__packed_fill(mlr_packed *p, const double *c, size_t ldc);
/* Overwrite centre j of p with c (dim values) and update its norm. */
void cluster__packed_set(mlr_packed *p, size_t j, const double *c);
/* Read centre j of p into c. */
void cluster__packed_get(const mlr_packed *p, size_t j, double *c);

/* For the m rows x + rows[r] * ldx (rows NULL: rows 0 .. m-1): index of the nearest centre
 * (lowest index among exact ties), its squared distance and the squared distance of the
 * second nearest (+inf when k == 1), computed as ||x||^2 - 2 x.c + ||c||^2 (clamped at 0) in
 * a fixed order: the same row gives the same result whatever m, rows and the thread are.
 * xn[r] (optional, NULL: computed) is ||x_r||^2. d2second and second (the index of the second
 * nearest, == best when k == 1) may be NULL. */
void cluster__nearest2(const mlr_packed *p, const double *x, size_t ldx, const size_t *rows,
                       size_t m, const double *xn, int32_t *best, double *d2best, double *d2second,
                       int32_t *second);

/* One online SOM step fused with the search for the next row, in a single pass over p (the
 * codebook, units in lattice order, unit u at row u / cols, column u % cols): every unit u with
 * h[u] != 0 moves to w_u + h[u] (x - w_u) (one fma per coordinate) and gets its norm updated
 * (other units are left exactly as they are); h holds kpad values, active[jb] != 0 marks the
 * blocks of 16 units holding a nonzero h. With xnext (NULL: no search), returns the unit
 * nearest to xnext in the updated codebook, lowest index among exact ties, and its value
 * ||c||^2 - 2 xnext.c in *best (optional; +inf and unit 0 without xnext). A unit's value does
 * not depend on whether it moved (with AVX-512 and in plain C the dot products are those of
 * cluster__nearest2 for a lone row, same fma sequence; on AVX2-only CPUs the search takes the plain C
 * dot products, the results are then reproducible but can differ from cluster__nearest2 in the last
 * bit).
 * Parts: only the groups of MLR_SWEEP_GROUP blocks g with g % n_parts == part are visited (part
 * 0 of 1: all), so n_parts threads can share one step on disjoint units; a unit's update and
 * value do not depend on the split, and the unit of the whole step is the part result with the
 * lowest (value, index). */
#define MLR_SWEEP_GROUP 4
int32_t cluster__packed_sweep(mlr_packed *p, const double *x, const double *h,
                              const unsigned char *active, const double *xnext, size_t part,
                              size_t n_parts, double *best);

/* ||a - b||^2 by direct differences (accurate near 0). */
double cluster__dist2(const double *a, const double *b, size_t dim, int isa);
/* ||a||^2. */
double cluster__norm2(const double *a, size_t dim);

/* First index of x (n rows, stride ldx, dim columns) that holds a NaN or an infinity, or n. */
size_t cluster__first_nonfinite_row(const double *x, size_t n, size_t dim, size_t ldx);

/* Relocatable blob of a trained model: a 64-byte header then the payload of doubles.
 *   0 tag[8]   "MLRSOM\0\0", "MLRKMN\0\0", ...      32 dims[3] (u64 each: model specific)
 *   8 u32 version, u32 byte-order mark 0x01020304   56 u64 FNV-1a hash of the payload bytes
 *  16 u64 total size in bytes, 24 u64 payload doubles
 * Values are in the writer's byte order; import refuses another byte order (MLR_E_PARSE). */
#define MLR_BLOB_HEADER 64
void cluster__blob_write(void *buf, const char tag[8], uint32_t version, const uint64_t dims[3],
                         const double *payload, size_t n_payload);
/* Checks tag, version, size, byte order and hash; fills dims and points *payload into buf
 * (doubles may be unaligned: read with memcpy). */
mlr_status cluster__blob_check(const void *buf, size_t size, const char tag[8], uint32_t version,
                               uint64_t dims[3], const unsigned char **payload, size_t *n_payload,
                               mlr_diag *diag);

#endif
