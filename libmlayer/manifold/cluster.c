/* Shared building blocks of k-means and the SOM: generator, packed centres and the
 * nearest/second-nearest search, blobs. See cluster_internal.h. */
#include "manifold/cluster_internal.h"

#include <math.h>

#ifdef MLR_X86_DISPATCH
#include <immintrin.h>
#endif

/* ---- generator ---------------------------------------------------------------------------- */

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

void mlr_rng_seed(mlr_rng *r, uint64_t seed)
{
    for (int i = 0; i < 4; i++)
        r->s[i] = splitmix64(&seed);
}

static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

uint64_t mlr_rng_u64(mlr_rng *r)
{
    uint64_t *s = r->s;
    uint64_t out = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return out;
}

double mlr_rng_uniform(mlr_rng *r) { return (double)(mlr_rng_u64(r) >> 11) * 0x1.0p-53; }

size_t mlr_rng_below(mlr_rng *r, size_t n)
{
    if (n == 0)
        return 0;
    uint64_t lim = UINT64_MAX - UINT64_MAX % (uint64_t)n, v;
    do
        v = mlr_rng_u64(r);
    while (v >= lim);
    return (size_t)(v % (uint64_t)n);
}

/* ---- packed centres ----------------------------------------------------------------------- */

size_t cluster__packed_kpad(size_t k) { return (k + MLR_PACK - 1) / MLR_PACK * MLR_PACK; }

/* Same eight-way order as cluster__dist2. */
double cluster__norm2(const double *a, size_t dim)
{
    double acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    size_t t = 0;
    for (; t + 8 <= dim; t += 8)
        for (size_t l = 0; l < 8; l++)
            acc[l] += a[t + l] * a[t + l];
    for (size_t l = 0; t + l < dim; l++)
        acc[l] += a[t + l] * a[t + l];
    return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

#ifdef MLR_X86_DISPATCH
/* 16 partial sums in two registers (the tail through masked loads), then a fixed reduction. */
__attribute__((target("avx512f"))) static double dist2_avx512(const double *a, const double *b,
                                                              size_t dim)
{
    __m512d s0 = _mm512_setzero_pd(), s1 = s0;
    size_t t = 0;
    for (; t + 16 <= dim; t += 16) {
        __m512d e0 = _mm512_sub_pd(_mm512_loadu_pd(a + t), _mm512_loadu_pd(b + t));
        __m512d e1 = _mm512_sub_pd(_mm512_loadu_pd(a + t + 8), _mm512_loadu_pd(b + t + 8));
        s0 = _mm512_fmadd_pd(e0, e0, s0);
        s1 = _mm512_fmadd_pd(e1, e1, s1);
    }
    for (; t < dim; t += 8) {
        __mmask8 m = dim - t >= 8 ? (__mmask8)0xff : (__mmask8)((1u << (dim - t)) - 1u);
        __m512d e =
            _mm512_sub_pd(_mm512_maskz_loadu_pd(m, a + t), _mm512_maskz_loadu_pd(m, b + t));
        s0 = _mm512_fmadd_pd(e, e, s0);
    }
    return _mm512_reduce_add_pd(_mm512_add_pd(s0, s1));
}
#endif

/* Eight partial sums (coordinate t goes to sum t % 8) added pairwise at the end: independent
 * chains the compiler vectorizes; the order is fixed, so a pair always gives the same value
 * (with AVX-512: 16 sums, also in a fixed order). */
double cluster__dist2(const double *a, const double *b, size_t dim, int isa)
{
#ifdef MLR_X86_DISPATCH
    if (isa >= MLR_ISA_AVX512)
        return dist2_avx512(a, b, dim);
#else
    (void)isa;
#endif
    double acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    size_t t = 0;
    for (; t + 8 <= dim; t += 8)
        for (size_t l = 0; l < 8; l++) {
            double e = a[t + l] - b[t + l];
            acc[l] += e * e;
        }
    for (size_t l = 0; t + l < dim; l++) {
        double e = a[t + l] - b[t + l];
        acc[l] += e * e;
    }
    return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

void cluster__packed_set(mlr_packed *p, size_t j, const double *c)
{
    double *blk = p->pc + (j / MLR_PACK) * p->dim * MLR_PACK + j % MLR_PACK;
    for (size_t t = 0; t < p->dim; t++)
        blk[t * MLR_PACK] = c[t];
    p->cn[j] = cluster__norm2(c, p->dim);
}

void cluster__packed_get(const mlr_packed *p, size_t j, double *c)
{
    const double *blk = p->pc + (j / MLR_PACK) * p->dim * MLR_PACK + j % MLR_PACK;
    for (size_t t = 0; t < p->dim; t++)
        c[t] = blk[t * MLR_PACK];
}

void cluster__packed_fill(mlr_packed *p, const double *c, size_t ldc)
{
    for (size_t j = 0; j < p->k; j++)
        cluster__packed_set(p, j, c + j * ldc);
    for (size_t j = p->k; j < p->kpad; j++) {
        double *blk = p->pc + (j / MLR_PACK) * p->dim * MLR_PACK + j % MLR_PACK;
        for (size_t t = 0; t < p->dim; t++)
            blk[t * MLR_PACK] = 0.0;
        p->cn[j] = INFINITY;
    }
}

/* ---- the search ----------------------------------------------------------------------------
 * Dot products of G rows with one block of 16 centres: out[r * 16 + l] = x_r . c_l, summed
 * over t in increasing order, one accumulator per (r, l): the result of a row does not depend
 * on the other rows of the group. One kernel is chosen per CPU (AVX-512, AVX2 + FMA or plain
 * C), so results are reproducible on a machine, not across instruction sets. */
#define MAX_G 8

static void dot_generic(const double *const *xr, const double *blk, size_t dim, double *out)
{
    double acc[4 * MLR_PACK] = {0};
    for (size_t t = 0; t < dim; t++) {
        const double *b = blk + t * MLR_PACK;
        for (int r = 0; r < 4; r++) {
            double xv = xr[r][t];
            for (int l = 0; l < MLR_PACK; l++)
                acc[r * MLR_PACK + l] += xv * b[l];
        }
    }
    memcpy(out, acc, sizeof acc);
}

#ifdef MLR_X86_DISPATCH
__attribute__((target("avx2,fma"))) static void dot_avx2_half(const double *const *xr,
                                                              const double *blk, size_t dim,
                                                              double *out)
{
    __m256d a00 = _mm256_setzero_pd(), a01 = a00, a10 = a00, a11 = a00, a20 = a00, a21 = a00,
            a30 = a00, a31 = a00;
    const double *x0 = xr[0], *x1 = xr[1], *x2 = xr[2], *x3 = xr[3];
    for (size_t t = 0; t < dim; t++) {
        __m256d b0 = _mm256_loadu_pd(blk + t * MLR_PACK),
                b1 = _mm256_loadu_pd(blk + t * MLR_PACK + 4);
        __m256d v = _mm256_broadcast_sd(x0 + t);
        a00 = _mm256_fmadd_pd(v, b0, a00);
        a01 = _mm256_fmadd_pd(v, b1, a01);
        v = _mm256_broadcast_sd(x1 + t);
        a10 = _mm256_fmadd_pd(v, b0, a10);
        a11 = _mm256_fmadd_pd(v, b1, a11);
        v = _mm256_broadcast_sd(x2 + t);
        a20 = _mm256_fmadd_pd(v, b0, a20);
        a21 = _mm256_fmadd_pd(v, b1, a21);
        v = _mm256_broadcast_sd(x3 + t);
        a30 = _mm256_fmadd_pd(v, b0, a30);
        a31 = _mm256_fmadd_pd(v, b1, a31);
    }
    _mm256_storeu_pd(out + 0 * MLR_PACK, a00);
    _mm256_storeu_pd(out + 0 * MLR_PACK + 4, a01);
    _mm256_storeu_pd(out + 1 * MLR_PACK, a10);
    _mm256_storeu_pd(out + 1 * MLR_PACK + 4, a11);
    _mm256_storeu_pd(out + 2 * MLR_PACK, a20);
    _mm256_storeu_pd(out + 2 * MLR_PACK + 4, a21);
    _mm256_storeu_pd(out + 3 * MLR_PACK, a30);
    _mm256_storeu_pd(out + 3 * MLR_PACK + 4, a31);
}

__attribute__((target("avx2,fma"))) static void dot_avx2(const double *const *xr,
                                                         const double *blk, size_t dim,
                                                         double *out)
{
    dot_avx2_half(xr, blk, dim, out);
    dot_avx2_half(xr, blk + 8, dim, out + 8);
}

__attribute__((target("avx512f"))) static void dot_avx512(const double *const *xr,
                                                          const double *blk, size_t dim,
                                                          double *out)
{
    __m512d a00 = _mm512_setzero_pd(), a01 = a00, a10 = a00, a11 = a00, a20 = a00, a21 = a00,
            a30 = a00, a31 = a00, a40 = a00, a41 = a00, a50 = a00, a51 = a00;
    const double *x0 = xr[0], *x1 = xr[1], *x2 = xr[2], *x3 = xr[3], *x4 = xr[4], *x5 = xr[5];
    for (size_t t = 0; t < dim; t++) {
        __m512d b0 = _mm512_loadu_pd(blk + t * MLR_PACK),
                b1 = _mm512_loadu_pd(blk + t * MLR_PACK + 8);
        __m512d v = _mm512_set1_pd(x0[t]);
        a00 = _mm512_fmadd_pd(v, b0, a00);
        a01 = _mm512_fmadd_pd(v, b1, a01);
        v = _mm512_set1_pd(x1[t]);
        a10 = _mm512_fmadd_pd(v, b0, a10);
        a11 = _mm512_fmadd_pd(v, b1, a11);
        v = _mm512_set1_pd(x2[t]);
        a20 = _mm512_fmadd_pd(v, b0, a20);
        a21 = _mm512_fmadd_pd(v, b1, a21);
        v = _mm512_set1_pd(x3[t]);
        a30 = _mm512_fmadd_pd(v, b0, a30);
        a31 = _mm512_fmadd_pd(v, b1, a31);
        v = _mm512_set1_pd(x4[t]);
        a40 = _mm512_fmadd_pd(v, b0, a40);
        a41 = _mm512_fmadd_pd(v, b1, a41);
        v = _mm512_set1_pd(x5[t]);
        a50 = _mm512_fmadd_pd(v, b0, a50);
        a51 = _mm512_fmadd_pd(v, b1, a51);
    }
    _mm512_storeu_pd(out + 0 * MLR_PACK, a00);
    _mm512_storeu_pd(out + 0 * MLR_PACK + 8, a01);
    _mm512_storeu_pd(out + 1 * MLR_PACK, a10);
    _mm512_storeu_pd(out + 1 * MLR_PACK + 8, a11);
    _mm512_storeu_pd(out + 2 * MLR_PACK, a20);
    _mm512_storeu_pd(out + 2 * MLR_PACK + 8, a21);
    _mm512_storeu_pd(out + 3 * MLR_PACK, a30);
    _mm512_storeu_pd(out + 3 * MLR_PACK + 8, a31);
    _mm512_storeu_pd(out + 4 * MLR_PACK, a40);
    _mm512_storeu_pd(out + 4 * MLR_PACK + 8, a41);
    _mm512_storeu_pd(out + 5 * MLR_PACK, a50);
    _mm512_storeu_pd(out + 5 * MLR_PACK + 8, a51);
}

/* One row against 4 consecutive blocks (64 centres): the same fma sequence per (row, centre)
 * as dot_avx512, so a row gets bit-identical values whichever kernel served it. */
__attribute__((target("avx512f"))) static void dot1x4_avx512(const double *x, const double *blk,
                                                             size_t dim, double *out)
{
    const size_t bs = dim * MLR_PACK;
    const double *b0 = blk, *b1 = blk + bs, *b2 = blk + 2 * bs, *b3 = blk + 3 * bs;
    __m512d a0 = _mm512_setzero_pd(), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0, a6 = a0,
            a7 = a0;
    for (size_t t = 0; t < dim; t++) {
        __m512d v = _mm512_set1_pd(x[t]);
        size_t o = t * MLR_PACK;
        a0 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b0 + o), a0);
        a1 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b0 + o + 8), a1);
        a2 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b1 + o), a2);
        a3 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b1 + o + 8), a3);
        a4 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b2 + o), a4);
        a5 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b2 + o + 8), a5);
        a6 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b3 + o), a6);
        a7 = _mm512_fmadd_pd(v, _mm512_loadu_pd(b3 + o + 8), a7);
    }
    _mm512_storeu_pd(out, a0);
    _mm512_storeu_pd(out + 8, a1);
    _mm512_storeu_pd(out + 16, a2);
    _mm512_storeu_pd(out + 24, a3);
    _mm512_storeu_pd(out + 32, a4);
    _mm512_storeu_pd(out + 40, a5);
    _mm512_storeu_pd(out + 48, a6);
    _mm512_storeu_pd(out + 56, a7);
}
#endif

typedef void (*dot_fn)(const double *const *xr, const double *blk, size_t dim, double *out);

static dot_fn pick_dot(int isa, size_t *group)
{
#ifdef MLR_X86_DISPATCH
    if (isa >= MLR_ISA_AVX512) {
        *group = 6;
        return dot_avx512;
    }
    if (isa >= MLR_ISA_AVX2) {
        *group = 4;
        return dot_avx2;
    }
#else
    (void)isa;
#endif
    *group = 4;
    return dot_generic;
}

/* ---- running minima ------------------------------------------------------------------------
 * Per row and lane l of the blocks: the smallest and second smallest of the values
 * ||c_j||^2 - 2 x.c_j seen so far for the centres j = l, 16 + l, 32 + l, ... (fed in increasing
 * j: a strict < keeps the lowest index among exact ties), with their indices (as doubles, exact,
 * so one blend serves values and indices; -1 for none). A merge over the lanes at the end gives
 * the nearest and second nearest of the row. The values are the same whichever code folds them:
 * cn - 2 o rounds once, as fnmadd(2, o, cn) does (2 o is exact). */
typedef struct lane_min {
    double b1[MLR_PACK], b2[MLR_PACK], i1[MLR_PACK], i2[MLR_PACK];
} lane_min;

typedef void (*fold_fn)(const double *o, const double *cn, double j0, lane_min *s);

static void lane_init(lane_min *s)
{
    for (int l = 0; l < MLR_PACK; l++) {
        s->b1[l] = s->b2[l] = INFINITY;
        s->i1[l] = s->i2[l] = -1.0;
    }
}

static void fold_generic(const double *o, const double *cn, double j0, lane_min *s)
{
    for (int l = 0; l < MLR_PACK; l++) { /* branch-free: the compiler vectorizes it */
        double v = cn[l] - 2.0 * o[l], j = j0 + (double)l;
        double b1 = s->b1[l], b2 = s->b2[l], i1 = s->i1[l], i2 = s->i2[l];
        int lt1 = v < b1, lt2 = v < b2;
        s->b2[l] = lt1 ? b1 : (lt2 ? v : b2);
        s->i2[l] = lt1 ? i1 : (lt2 ? j : i2);
        s->b1[l] = lt1 ? v : b1;
        s->i1[l] = lt1 ? j : i1;
    }
}

#ifdef MLR_X86_DISPATCH
__attribute__((target("avx512f"))) static void fold_avx512(const double *o, const double *cn,
                                                           double j0, lane_min *s)
{
    const __m512d two = _mm512_set1_pd(2.0);
    const __m512d lane = _mm512_set_pd(7, 6, 5, 4, 3, 2, 1, 0);
    for (int h = 0; h < MLR_PACK; h += 8) {
        __m512d v = _mm512_fnmadd_pd(two, _mm512_loadu_pd(o + h), _mm512_loadu_pd(cn + h));
        __m512d j = _mm512_add_pd(_mm512_set1_pd(j0 + (double)h), lane);
        __m512d b1 = _mm512_loadu_pd(s->b1 + h), b2 = _mm512_loadu_pd(s->b2 + h);
        __m512d i1 = _mm512_loadu_pd(s->i1 + h), i2 = _mm512_loadu_pd(s->i2 + h);
        __mmask8 lt1 = _mm512_cmp_pd_mask(v, b1, _CMP_LT_OQ);
        __mmask8 lt2 = _mm512_cmp_pd_mask(v, b2, _CMP_LT_OQ);
        b2 = _mm512_mask_blend_pd(lt1, _mm512_mask_blend_pd(lt2, b2, v), b1);
        i2 = _mm512_mask_blend_pd(lt1, _mm512_mask_blend_pd(lt2, i2, j), i1);
        b1 = _mm512_mask_blend_pd(lt1, b1, v);
        i1 = _mm512_mask_blend_pd(lt1, i1, j);
        _mm512_storeu_pd(s->b1 + h, b1);
        _mm512_storeu_pd(s->b2 + h, b2);
        _mm512_storeu_pd(s->i1 + h, i1);
        _mm512_storeu_pd(s->i2 + h, i2);
    }
}
#endif

static fold_fn pick_fold(int isa)
{
#ifdef MLR_X86_DISPATCH
    if (isa >= MLR_ISA_AVX512)
        return fold_avx512;
#else
    (void)isa;
#endif
    return fold_generic;
}

/* Nearest (lowest index among equal values) and second nearest over the lanes. */
static void lane_merge(const lane_min *s, double *bv, int32_t *bi, double *sv, int32_t *si)
{
    int w = -1;
    for (int l = 0; l < MLR_PACK; l++)
        if (s->i1[l] >= 0 &&
            (w < 0 || s->b1[l] < s->b1[w] || (s->b1[l] == s->b1[w] && s->i1[l] < s->i1[w])))
            w = l;
    if (w < 0) { /* only possible with overflowing values */
        *bv = *sv = INFINITY;
        *bi = 0;
        *si = -1;
        return;
    }
    double v2 = s->b2[w], j2 = s->i2[w];
    for (int l = 0; l < MLR_PACK; l++)
        if (l != w && s->i1[l] >= 0 &&
            (s->b1[l] < v2 || (s->b1[l] == v2 && (j2 < 0 || s->i1[l] < j2)))) {
            v2 = s->b1[l];
            j2 = s->i1[l];
        }
    *bv = s->b1[w];
    *bi = (int32_t)s->i1[w];
    *sv = v2;
    *si = (int32_t)j2;
}

#ifdef MLR_X86_DISPATCH
/* lane_merge with vector reductions (min is exact, so the result is the same). */
__attribute__((target("avx512f"))) static void lane_merge_avx512(const lane_min *s, double *bv,
                                                                 int32_t *bi, double *sv,
                                                                 int32_t *si)
{
    const __m512d inf = _mm512_set1_pd(INFINITY);
    __m512d b1a = _mm512_loadu_pd(s->b1), b1b = _mm512_loadu_pd(s->b1 + 8);
    __m512d i1a = _mm512_loadu_pd(s->i1), i1b = _mm512_loadu_pd(s->i1 + 8);
    double v = _mm512_reduce_min_pd(_mm512_min_pd(b1a, b1b));
    if (!(v < INFINITY)) {
        lane_merge(s, bv, bi, sv, si);
        return;
    }
    __m512d V = _mm512_set1_pd(v);
    __mmask8 ea = _mm512_cmp_pd_mask(b1a, V, _CMP_EQ_OQ),
             eb = _mm512_cmp_pd_mask(b1b, V, _CMP_EQ_OQ);
    double j = _mm512_reduce_min_pd(
        _mm512_min_pd(_mm512_mask_blend_pd(ea, inf, i1a), _mm512_mask_blend_pd(eb, inf, i1b)));
    __m512d J = _mm512_set1_pd(j);
    __mmask8 wa = _mm512_cmp_pd_mask(i1a, J, _CMP_EQ_OQ),
             wb = _mm512_cmp_pd_mask(i1b, J, _CMP_EQ_OQ);
    __m512d ca = _mm512_mask_blend_pd(wa, b1a, _mm512_loadu_pd(s->b2));
    __m512d cb = _mm512_mask_blend_pd(wb, b1b, _mm512_loadu_pd(s->b2 + 8));
    __m512d ja = _mm512_mask_blend_pd(wa, i1a, _mm512_loadu_pd(s->i2));
    __m512d jb = _mm512_mask_blend_pd(wb, i1b, _mm512_loadu_pd(s->i2 + 8));
    double v2 = _mm512_reduce_min_pd(_mm512_min_pd(ca, cb)), j2 = -1.0;
    if (v2 < INFINITY) {
        __m512d V2 = _mm512_set1_pd(v2);
        __mmask8 qa = _mm512_cmp_pd_mask(ca, V2, _CMP_EQ_OQ),
                 qb = _mm512_cmp_pd_mask(cb, V2, _CMP_EQ_OQ);
        j2 = _mm512_reduce_min_pd(
            _mm512_min_pd(_mm512_mask_blend_pd(qa, inf, ja), _mm512_mask_blend_pd(qb, inf, jb)));
    }
    *bv = v;
    *bi = (int32_t)j;
    *sv = v2;
    *si = (int32_t)j2;
}
#endif

typedef void (*merge_fn)(const lane_min *s, double *bv, int32_t *bi, double *sv, int32_t *si);

static merge_fn pick_merge(int isa)
{
#ifdef MLR_X86_DISPATCH
    if (isa >= MLR_ISA_AVX512)
        return lane_merge_avx512;
#else
    (void)isa;
#endif
    return lane_merge;
}

void cluster__nearest2(const mlr_packed *p, const double *x, size_t ldx, const size_t *rows,
                       size_t m, const double *xn, int32_t *best, double *d2best, double *d2second,
                       int32_t *second)
{
    size_t G;
    dot_fn dot = pick_dot(p->isa, &G);
    fold_fn fold = pick_fold(p->isa);
    merge_fn merge = pick_merge(p->isa);
#ifdef MLR_X86_DISPATCH
    const int wide1 = dot == dot_avx512; /* a lone row takes 64 centres per pass */
#else
    const int wide1 = 0;
#endif
    const size_t dim = p->dim, nb = p->kpad / MLR_PACK;
    double out[4 * MLR_PACK > MAX_G * MLR_PACK ? 4 * MLR_PACK : MAX_G * MLR_PACK];
    lane_min st[MAX_G];
    for (size_t r0 = 0; r0 < m; r0 += G) {
        const double *xr[MAX_G];
        size_t cnt = m - r0 < G ? m - r0 : G;
        for (size_t r = 0; r < G; r++) {
            size_t rr = r0 + (r < cnt ? r : cnt - 1);
            xr[r] = x + (rows ? rows[rr] : rr) * ldx;
        }
        for (size_t r = 0; r < cnt; r++)
            lane_init(&st[r]);
        size_t jb = 0;
#ifdef MLR_X86_DISPATCH
        if (cnt == 1 && wide1) {
            for (; jb + 4 <= nb; jb += 4) {
                dot1x4_avx512(xr[0], p->pc + jb * dim * MLR_PACK, dim, out);
                for (size_t q = 0; q < 4; q++)
                    fold(out + q * MLR_PACK, p->cn + (jb + q) * MLR_PACK,
                         (double)((jb + q) * MLR_PACK), &st[0]);
            }
        }
#endif
        for (; jb < nb; jb++) {
            dot(xr, p->pc + jb * dim * MLR_PACK, dim, out);
            for (size_t r = 0; r < cnt; r++)
                fold(out + r * MLR_PACK, p->cn + jb * MLR_PACK, (double)(jb * MLR_PACK), &st[r]);
        }
        for (size_t r = 0; r < cnt; r++) {
            double bv, sv;
            int32_t bi, si;
            merge(&st[r], &bv, &bi, &sv, &si);
            double xx = xn ? xn[r0 + r] : cluster__norm2(xr[r], dim);
            double b = bv + xx, s = sv + xx;
            best[r0 + r] = bi;
            d2best[r0 + r] = b > 0 ? b : 0;
            if (d2second)
                d2second[r0 + r] = s > 0 ? s : 0;
            if (second)
                second[r0 + r] = si >= 0 ? si : bi;
        }
    }
}

/* ---- fused online SOM step ------------------------------------------------------------------ */

static void sweep_block_generic(double *blk, size_t dim, const double *x, const double *h,
                                const double *xn, double *nn, double *dot)
{
    double n[MLR_PACK] = {0}, d[MLR_PACK] = {0};
    for (size_t t = 0; t < dim; t++) {
        double *b = blk + t * MLR_PACK, xt = x[t], yt = xn ? xn[t] : 0.0;
        for (int l = 0; l < MLR_PACK; l++) {
            double v = b[l] + h[l] * (xt - b[l]);
            b[l] = v;
            n[l] += v * v;
            d[l] += yt * v;
        }
    }
    memcpy(nn, n, sizeof n);
    memcpy(dot, d, sizeof d);
}

static void dot1_generic(const double *x, const double *blk, size_t dim, double *out)
{
    double acc[MLR_PACK] = {0};
    for (size_t t = 0; t < dim; t++) {
        double xv = x[t];
        for (int l = 0; l < MLR_PACK; l++)
            acc[l] += xv * blk[t * MLR_PACK + l];
    }
    memcpy(out, acc, sizeof acc);
}

#ifdef MLR_X86_DISPATCH
__attribute__((target("avx512f"))) static void sweep_block_avx512(double *blk, size_t dim,
                                                                  const double *x, const double *h,
                                                                  const double *xn, double *nn,
                                                                  double *dot)
{
    const __m512d h0 = _mm512_loadu_pd(h), h1 = _mm512_loadu_pd(h + 8);
    __m512d n0 = _mm512_setzero_pd(), n1 = n0, d0 = n0, d1 = n0;
    for (size_t t = 0; t < dim; t++) {
        double *b = blk + t * MLR_PACK;
        __m512d xt = _mm512_set1_pd(x[t]), b0 = _mm512_loadu_pd(b), b1 = _mm512_loadu_pd(b + 8);
        __m512d v0 = _mm512_fmadd_pd(h0, _mm512_sub_pd(xt, b0), b0);
        __m512d v1 = _mm512_fmadd_pd(h1, _mm512_sub_pd(xt, b1), b1);
        _mm512_storeu_pd(b, v0);
        _mm512_storeu_pd(b + 8, v1);
        n0 = _mm512_fmadd_pd(v0, v0, n0);
        n1 = _mm512_fmadd_pd(v1, v1, n1);
        if (xn) { /* the fma sequence of dot1x4_avx512 */
            __m512d y = _mm512_set1_pd(xn[t]);
            d0 = _mm512_fmadd_pd(y, v0, d0);
            d1 = _mm512_fmadd_pd(y, v1, d1);
        }
    }
    _mm512_storeu_pd(nn, n0);
    _mm512_storeu_pd(nn + 8, n1);
    _mm512_storeu_pd(dot, d0);
    _mm512_storeu_pd(dot + 8, d1);
}

__attribute__((target("avx512f"))) static void dot1_avx512(const double *x, const double *blk,
                                                           size_t dim, double *out)
{
    __m512d a0 = _mm512_setzero_pd(), a1 = a0;
    for (size_t t = 0; t < dim; t++) {
        __m512d v = _mm512_set1_pd(x[t]);
        a0 = _mm512_fmadd_pd(v, _mm512_loadu_pd(blk + t * MLR_PACK), a0);
        a1 = _mm512_fmadd_pd(v, _mm512_loadu_pd(blk + t * MLR_PACK + 8), a1);
    }
    _mm512_storeu_pd(out, a0);
    _mm512_storeu_pd(out + 8, a1);
}
#endif

int32_t cluster__packed_sweep(mlr_packed *p, const double *x, const double *h,
                              const unsigned char *active, const double *xnext, size_t part,
                              size_t n_parts, double *best)
{
    const size_t dim = p->dim, nb = p->kpad / MLR_PACK;
#ifdef MLR_X86_DISPATCH
    const int wide = p->isa >= MLR_ISA_AVX512;
#else
    const int wide = 0;
#endif
    fold_fn fold = pick_fold(p->isa);
    lane_min st;
    lane_init(&st);
    double out[4 * MLR_PACK], nn[MLR_PACK];
    for (size_t g0 = part * MLR_SWEEP_GROUP; g0 < nb; g0 += n_parts * MLR_SWEEP_GROUP) {
        const size_t g1 = g0 + MLR_SWEEP_GROUP < nb ? g0 + MLR_SWEEP_GROUP : nb;
        size_t jb = g0;
        while (jb < g1) {
            const size_t o = jb * MLR_PACK;
            double *blk = p->pc + o * dim;
            if (active[jb]) {
#ifdef MLR_X86_DISPATCH
                if (wide)
                    sweep_block_avx512(blk, dim, x, h + o, xnext, nn, out);
                else
#endif
                    sweep_block_generic(blk, dim, x, h + o, xnext, nn, out);
                for (int l = 0; l < MLR_PACK; l++)
                    if (h[o + (size_t)l] != 0.0)
                        p->cn[o + (size_t)l] = nn[l];
                if (xnext)
                    fold(out, p->cn + o, (double)o, &st);
                jb++;
                continue;
            }
            if (!xnext) {
                jb++;
                continue;
            }
#ifdef MLR_X86_DISPATCH
            if (wide && jb + 4 <= g1 && !active[jb + 1] && !active[jb + 2] && !active[jb + 3]) {
                dot1x4_avx512(xnext, blk, dim, out);
                for (size_t q = 0; q < 4; q++)
                    fold(out + q * MLR_PACK, p->cn + o + q * MLR_PACK, (double)(o + q * MLR_PACK),
                         &st);
                jb += 4;
                continue;
            }
            if (wide)
                dot1_avx512(xnext, blk, dim, out);
            else
#endif
                dot1_generic(xnext, blk, dim, out);
            fold(out, p->cn + o, (double)o, &st);
            jb++;
        }
    }
    double bv = INFINITY, sv;
    int32_t bi = 0, si;
    if (xnext)
        pick_merge(p->isa)(&st, &bv, &bi, &sv, &si);
    if (best)
        *best = bv;
    return bi;
}

size_t cluster__first_nonfinite_row(const double *x, size_t n, size_t dim, size_t ldx)
{
    for (size_t i = 0; i < n; i++) {
        const double *r = x + i * ldx;
        double acc[8] = {0, 0, 0, 0, 0, 0, 0, 0}; /* independent sums: not latency-bound */
        size_t t = 0;
        for (; t + 8 <= dim; t += 8)
            for (size_t l = 0; l < 8; l++)
                acc[l] += r[t + l] * 0.0; /* NaN for a NaN or an infinity, 0 otherwise */
        for (size_t l = 0; t + l < dim; l++)
            acc[l] += r[t + l] * 0.0;
        double s =
            ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
        if (s != 0.0 || s != s)
            return i;
    }
    return n;
}

/* ---- blobs ------------------------------------------------------------------------------------ */

static uint64_t fnv1a(const unsigned char *b, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

void cluster__blob_write(void *buf, const char tag[8], uint32_t version, const uint64_t dims[3],
                         const double *payload, size_t n_payload)
{
    unsigned char *b = buf;
    uint32_t bom = 0x01020304u;
    uint64_t total = MLR_BLOB_HEADER + (uint64_t)n_payload * 8, np = n_payload;
    memset(b, 0, MLR_BLOB_HEADER);
    memcpy(b, tag, 8);
    memcpy(b + 8, &version, 4);
    memcpy(b + 12, &bom, 4);
    memcpy(b + 16, &total, 8);
    memcpy(b + 24, &np, 8);
    memcpy(b + 32, dims, 24);
    if (n_payload)
        memcpy(b + MLR_BLOB_HEADER, payload, n_payload * 8);
    uint64_t h = fnv1a(b + MLR_BLOB_HEADER, n_payload * 8);
    memcpy(b + 56, &h, 8);
}

mlr_status cluster__blob_check(const void *buf, size_t size, const char tag[8], uint32_t version,
                               uint64_t dims[3], const unsigned char **payload, size_t *n_payload,
                               mlr_diag *diag)
{
    const unsigned char *b = buf;
    if (!buf)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "blob is NULL");
    if (size < MLR_BLOB_HEADER)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "blob of %zu bytes is shorter than its header", size);
    if (memcmp(b, tag, 8) != 0)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0, "blob tag is not %.6s", tag);
    uint32_t ver, bom;
    uint64_t total, np, h;
    memcpy(&ver, b + 8, 4);
    memcpy(&bom, b + 12, 4);
    memcpy(&total, b + 16, 8);
    memcpy(&np, b + 24, 8);
    memcpy(dims, b + 32, 24);
    memcpy(&h, b + 56, 8);
    if (bom != 0x01020304u)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0, "blob written with another byte order");
    if (ver != version)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0, "blob version %u, this library reads %u",
                                (unsigned)ver, (unsigned)version);
    if (total != size || np > (size - MLR_BLOB_HEADER) / 8 || MLR_BLOB_HEADER + np * 8 != total)
        return common__diag_set(
            diag, MLR_E_PARSE, 0, 0,
            "blob size %zu does not match its header (%llu bytes, %llu values)", size,
            (unsigned long long)total, (unsigned long long)np);
    if (fnv1a(b + MLR_BLOB_HEADER, (size_t)np * 8) != h)
        return common__diag_set(diag, MLR_E_PARSE, 0, 0,
                                "blob hash mismatch: the data is corrupt");
    *payload = b + MLR_BLOB_HEADER;
    *n_payload = (size_t)np;
    return MLR_OK;
}
