/* Kernels of the BVH reader's MOTION section: see bvh_frames.h.
 *
 * The whole-line parser works in two steps on a frame line.
 * 1. Structure, 64 bytes at a time: masks of token bytes (visible ASCII), blanks (space, tab)
 *    and line ends; any other byte sends the line to the careful parser. The end of each token
 *    (the blank or line end after it) goes into ends[]; there must be exactly C.
 * 2. Numbers, four 16-byte lanes at a time (one AVX-512 register, or two AVX2 ones): lane i
 *    holds the 16 bytes before ends[i], byte-reversed, so the token starts at byte 0 with its
 *    last character and its own bytes are those below the first blank (byte <= 0x20) of the
 *    lane. Scalar arithmetic on the lanes' 16-bit fields of the byte masks checks the simple
 *    form: 1 to 15 bytes of digits with at most one '.', a '-' only as the first character,
 *    at least one digit. The digits, shifted down over the dot by one byte shuffle, form an
 *    integer M < 10^15 < 2^53 (units at byte 0); with f fraction digits the value is M / 10^f,
 *    an exact integer over an exact power of ten: its correctly rounded quotient (Clinger's
 *    fast path) is the double strtod returns. It is computed without a division (see
 *    line_avx512), the sign as a bit ("-0" gives -0.0, as strtod). A lane in another form (an
 *    exponent, a '+', 16 bytes or more, or no number) is read by mlr_parse_decimal, which must
 *    take the whole token; if it does not, the line goes to the careful parser, which reports
 *    the error. Nothing is guessed. */
/* All builds must round alike: no contraction into FMA (the build passes -ffp-contract=off;
 * clang also gets the pragma, before the inline code of sincosd.h is read) */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

#include "io/bvh_frames.h"

#include "io/numparse.h"
#include "math/sincosd.h"

#include <string.h>

#include "common/cpu.h"

#ifdef MLR_X86_DISPATCH
#define BVH_X86 1
#include <immintrin.h>
#endif

/* ---- per-frame conversion ------------------------------------------------------------------ */

/* Root and joint translations of one frame row into rp, tr; returns the row offsets of the
 * Euler angles (3 per padded joint). */
static inline const uint32_t *gather_translations(const bvh_conv *cv, const double *restrict row,
                                                  double *restrict rp, double *restrict tr)
{
    const size_t P = cv->P;
    const uint32_t *restrict src = cv->src;
    for (size_t k = 0; k < 3; k++)
        rp[k] = row[src[k]];
    for (size_t k = 0; k < 3 * P; k++)
        tr[k] = row[src[3 + k]];
    return src + 3 + 3 * P;
}

/* Portable: gathers, sines and cosines of the half-angles, and q = q_i(a0) q_j(a1) q_k(a2) in
 * the same operations as common__quat_from_euler_half. */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void frame_body(const bvh_conv *cv, const double *restrict row, double *restrict tmp,
                              double *restrict rp, double *restrict tr, double *restrict q)
{
    const size_t J = cv->J, Jp = cv->Jp;
    const uint32_t *restrict g = gather_translations(cv, row, rp, tr);
    double *restrict half = tmp, *restrict sn = tmp + 3 * Jp, *restrict cs = tmp + 6 * Jp;
    for (size_t k = 0; k < 3 * Jp; k++)
        half[k] = 0.5 * row[g[k]];
    mlr_sincosd_array(half, 3 * Jp, sn, cs);
    const double *restrict par = cv->par;
    const unsigned char *restrict sel = cv->sel;
    for (size_t j = 0; j < J; j++) {
        const double ca = cs[j], sa = sn[j], cb = cs[Jp + j], sb = sn[Jp + j], cc = cs[2 * Jp + j],
                     sc = sn[2 * Jp + j], p = par[j];
        double c[3];
        q[4 * j] = ca * cb * cc - p * sa * sb * sc;
        c[0] = sa * cb * cc + p * ca * sb * sc;
        c[1] = ca * sb * cc - p * sa * cb * sc;
        c[2] = ca * cb * sc + p * sa * sb * cc;
        q[4 * j + 1] = c[sel[j]];
        q[4 * j + 2] = c[sel[Jp + j]];
        q[4 * j + 3] = c[sel[2 * Jp + j]];
    }
}

static void frame_portable(const bvh_conv *cv, const double *row, double *tmp, double *rp,
                           double *tr, double *q)
{
    frame_body(cv, row, tmp, rp, tr, q);
}

static size_t count_newlines_portable(const char *p, const char *end)
{
    size_t n = 0;
    for (; p < end; p++)
        n += *p == '\n';
    return n;
}

#ifdef BVH_X86
#define AVX512 \
    __attribute__((target("avx512f,avx512bw,avx512dq,avx512vl,avx512cd,bmi,bmi2,popcnt")))

/* frame_portable compiled for AVX2 (4 doubles a vector): the same operations, so the same bits
 * (no FMA: GCC does not contract in ISO C mode, clang is told not to above). */
__attribute__((target("avx2"))) static void frame_avx2(const bvh_conv *cv, const double *row,
                                                       double *tmp, double *rp, double *tr,
                                                       double *q)
{
    frame_body(cv, row, tmp, rp, tr, q);
}

/* mlr_sincosd_kernel on 8 angles: the same operations in the same order (no FMA), so the
 * same bits. */
AVX512 static inline void sincosd8(__m512d x, __m512d *s_out, __m512d *c_out)
{
#define K(v) _mm512_set1_pd(v)
    const __m512d shifter = K(0x1.8p52);
    const __m512d kq = _mm512_add_pd(_mm512_mul_pd(x, K(1.0 / 90.0)), shifter);
    const __m512d k = _mm512_sub_pd(kq, shifter);
    const __m512d t =
        _mm512_mul_pd(_mm512_sub_pd(x, _mm512_mul_pd(k, K(90.0))), K(MLR_DEG_TO_RAD));
    const __m512d z = _mm512_mul_pd(t, t);
#define STEP(c, acc) _mm512_add_pd(K(c), _mm512_mul_pd(z, acc))
    const __m512d ps =
        STEP(MLR_SINCOS_S2,
             STEP(MLR_SINCOS_S3, STEP(MLR_SINCOS_S4, STEP(MLR_SINCOS_S5, K(MLR_SINCOS_S6)))));
    const __m512d sn =
        _mm512_add_pd(t, _mm512_mul_pd(_mm512_mul_pd(z, t), STEP(MLR_SINCOS_S1, ps)));
    const __m512d qc = _mm512_mul_pd(
        z, STEP(MLR_SINCOS_C1,
                STEP(MLR_SINCOS_C2,
                     STEP(MLR_SINCOS_C3,
                          STEP(MLR_SINCOS_C4, STEP(MLR_SINCOS_C5, K(MLR_SINCOS_C6)))))));
#undef STEP
    const __m512d hz = _mm512_mul_pd(K(0.5), z), w = _mm512_sub_pd(K(1.0), hz);
    const __m512d cs = _mm512_add_pd(
        w, _mm512_add_pd(_mm512_sub_pd(_mm512_sub_pd(K(1.0), w), hz), _mm512_mul_pd(z, qc)));
#undef K
    /* quadrant q = k mod 4: (sin, cos) = (sn, cs), (cs, -sn), (-sn, -cs), (-cs, sn) */
    const __m512i q = _mm512_and_si512(_mm512_castpd_si512(kq), _mm512_set1_epi64(3));
    const __mmask8 swap = _mm512_test_epi64_mask(q, _mm512_set1_epi64(1));
    const __m512i two = _mm512_set1_epi64(2);
    const __m512i sign_s = _mm512_slli_epi64(_mm512_and_si512(q, two), 62);
    const __m512i sign_c =
        _mm512_slli_epi64(_mm512_and_si512(_mm512_add_epi64(q, _mm512_set1_epi64(1)), two), 62);
    *s_out = _mm512_castsi512_pd(
        _mm512_xor_si512(_mm512_castpd_si512(_mm512_mask_blend_pd(swap, sn, cs)), sign_s));
    *c_out = _mm512_castsi512_pd(
        _mm512_xor_si512(_mm512_castpd_si512(_mm512_mask_blend_pd(swap, cs, sn)), sign_c));
}

/* As frame_portable, 8 joints at a time in registers: the same operations in the same order,
 * so the same results. */
AVX512 static void frame_avx512(const bvh_conv *cv, const double *restrict row,
                                double *restrict tmp, double *restrict rp, double *restrict tr,
                                double *restrict q)
{
    (void)tmp;
    const size_t J = cv->J, Jp = cv->Jp;
    const uint32_t *restrict g = gather_translations(cv, row, rp, tr);
    const __m512d h = _mm512_set1_pd(0.5);
    const __m512d limit = _mm512_set1_pd(MLR_SINCOSD_LIMIT);
    const __m512i lo = _mm512_setr_epi64(0, 4, 1, 5, 8, 12, 9, 13);
    const __m512i hi = _mm512_setr_epi64(2, 6, 3, 7, 10, 14, 11, 15);
    const __m128i zero = _mm_setzero_si128(), one = _mm_set1_epi8(1);
    for (size_t j = 0; j < J; j += 8) {
        __m512d a[3]; /* the half-angles of the joints' three rotations */
        if (cv->tri_ok[j / 8]) {
            /* 8 joints whose angles are three consecutive channels: 4 doubles from each
             * joint's first angle, transposed (the fourth is not used) */
            const uint32_t *t = cv->tri + j;
#define LD2(a, b)                                                           \
    _mm512_insertf64x4(_mm512_castpd256_pd512(_mm256_loadu_pd(row + t[a])), \
                       _mm256_loadu_pd(row + t[b]), 1)
            const __m512d z0 = LD2(0, 1), z1 = LD2(2, 3), z2 = LD2(4, 5), z3 = LD2(6, 7);
#undef LD2
            const __m512d e0 = _mm512_unpacklo_pd(z0, z1), e1 = _mm512_unpackhi_pd(z0, z1);
            const __m512d e2 = _mm512_unpacklo_pd(z2, z3), e3 = _mm512_unpackhi_pd(z2, z3);
            a[0] = _mm512_mul_pd(h, _mm512_permutex2var_pd(e0, lo, e2));
            a[1] = _mm512_mul_pd(h, _mm512_permutex2var_pd(e1, lo, e3));
            a[2] = _mm512_mul_pd(h, _mm512_permutex2var_pd(e0, hi, e2));
        } else {
            double v[8];
            for (size_t k = 0; k < 3; k++) {
                for (size_t i = 0; i < 8; i++)
                    v[i] = 0.5 * row[g[k * Jp + j + i]];
                a[k] = _mm512_loadu_pd(v);
            }
        }
        __m512d sn[3], cs[3];
        const __mmask8 big = _mm512_cmp_pd_mask(_mm512_abs_pd(a[0]), limit, _CMP_NLT_UQ) |
                             _mm512_cmp_pd_mask(_mm512_abs_pd(a[1]), limit, _CMP_NLT_UQ) |
                             _mm512_cmp_pd_mask(_mm512_abs_pd(a[2]), limit, _CMP_NLT_UQ);
        if (!big) {
            for (size_t k = 0; k < 3; k++)
                sincosd8(a[k], &sn[k], &cs[k]);
        } else { /* an angle of 2^50 degrees or more, or NaN: as mlr_sincosd_array does */
            double x[8], sv[8], cv8[8];
            for (size_t k = 0; k < 3; k++) {
                _mm512_storeu_pd(x, a[k]);
                for (size_t i = 0; i < 8; i++)
                    mlr_sincosd_kernel(fabs(x[i]) < MLR_SINCOSD_LIMIT ? x[i] : fmod(x[i], 360.0),
                                       sv + i, cv8 + i);
                sn[k] = _mm512_loadu_pd(sv);
                cs[k] = _mm512_loadu_pd(cv8);
            }
        }
        const __m512d ca = cs[0], sa = sn[0], cb = cs[1], sb = sn[1], cc = cs[2], sc = sn[2];
        const __m512d p = _mm512_loadu_pd(cv->par + j);
#define MUL3(a, b, c) _mm512_mul_pd(_mm512_mul_pd(a, b), c)
#define MUL4(a, b, c, d) _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(a, b), c), d)
        const __m512d w = _mm512_sub_pd(MUL3(ca, cb, cc), MUL4(p, sa, sb, sc));
        const __m512d c0 = _mm512_add_pd(MUL3(sa, cb, cc), MUL4(p, ca, sb, sc));
        const __m512d c1 = _mm512_sub_pd(MUL3(ca, sb, cc), MUL4(p, sa, cb, sc));
        const __m512d c2 = _mm512_add_pd(MUL3(ca, cb, sc), MUL4(p, sa, sb, cc));
#undef MUL3
#undef MUL4
        __m512d xyz[3];
        for (size_t k = 0; k < 3; k++) {
            const __m128i s =
                _mm_loadl_epi64((const __m128i *)(const void *)(cv->sel + k * Jp + j));
            const __mmask8 is0 = (__mmask8)_mm_cmpeq_epi8_mask(s, zero);
            const __mmask8 is1 = (__mmask8)_mm_cmpeq_epi8_mask(s, one);
            xyz[k] = _mm512_mask_mov_pd(_mm512_mask_mov_pd(c2, is0, c0), is1, c1);
        }
        /* (w, x, y, z) of 8 joints to 8 quaternions in a row */
        const __m512d t0 = _mm512_unpacklo_pd(w, xyz[0]), t1 = _mm512_unpackhi_pd(w, xyz[0]);
        const __m512d t2 = _mm512_unpacklo_pd(xyz[1], xyz[2]);
        const __m512d t3 = _mm512_unpackhi_pd(xyz[1], xyz[2]);
        const __m512d u0 = _mm512_shuffle_f64x2(t0, t2, 0x44);
        const __m512d u1 = _mm512_shuffle_f64x2(t1, t3, 0x44);
        const __m512d v0 = _mm512_shuffle_f64x2(t0, t2, 0xEE);
        const __m512d v1 = _mm512_shuffle_f64x2(t1, t3, 0xEE);
        const __m512d o[4] = {
            _mm512_shuffle_f64x2(u0, u1, 0x88), _mm512_shuffle_f64x2(u0, u1, 0xDD),
            _mm512_shuffle_f64x2(v0, v1, 0x88), _mm512_shuffle_f64x2(v0, v1, 0xDD)};
        double *qj = q + 4 * j;
        if (j + 8 <= J) {
            for (int i = 0; i < 4; i++)
                _mm512_storeu_pd(qj + 8 * i, o[i]);
        } else {
            const size_t left = 4 * (J - j); /* doubles */
            for (size_t i = 0; i < 4 && 8 * i < left; i++) {
                const size_t n = left - 8 * i < 8 ? left - 8 * i : 8;
                _mm512_mask_storeu_pd(qj + 8 * i, (__mmask8)((1u << n) - 1u), o[i]);
            }
        }
    }
}

/* A token for unused lanes: "0" after blanks; lanes read the 16 bytes before its end. */
static const char zero_token[16] = {' ', ' ', ' ', ' ', ' ', ' ', ' ', ' ',
                                    ' ', ' ', ' ', ' ', ' ', ' ', ' ', '0'};

/* Step 1: token ends of the line at p into ends; returns their count (stops early, returning
 * more than C, once there are too many), 0 with *ok = 0 on a byte that is neither visible
 * ASCII nor a blank or line end. CLASSIFY(q, &tok, &blank, &eol) gives the masks of the 64
 * bytes at q; EXTRACT(o, p, e, cnt) writes p + the positions of the cnt set bits of e to
 * o[0 .. cnt), and may write up to o[cnt rounded up to 8]. */
#define DEFINE_SCAN_LINE(NAME, ATTR, CLASSIFY, EXTRACT)                                        \
    ATTR static size_t NAME(const char *p, const char *end, size_t C, const char **ends,       \
                            const char **line_end, int *ok)                                    \
    {                                                                                          \
        uint64_t carry = 0; /* the byte before the block is a token byte */                    \
        size_t n = 0;                                                                          \
        for (;;) {                                                                             \
            uint64_t tok, blank, eol;                                                          \
            if (end - p >= 64) {                                                               \
                CLASSIFY(p, &tok, &blank, &eol);                                               \
            } else { /* the tail, padded with line ends: the end of the input ends the line */ \
                char buf[64];                                                                  \
                memset(buf, '\n', sizeof buf);                                                 \
                memcpy(buf, p, (size_t)(end - p));                                             \
                CLASSIFY(buf, &tok, &blank, &eol);                                             \
            }                                                                                  \
            const uint64_t lim = eol ? _blsmsk_u64(eol) : ~(uint64_t)0; /* to the first eol */ \
            if (~(tok | blank | eol) & lim) {                                                  \
                *ok = 0;                                                                       \
                return 0;                                                                      \
            }                                                                                  \
            uint64_t e = ~tok & ((tok << 1) | carry) & lim;                                    \
            carry = tok >> 63;                                                                 \
            const size_t cnt = (size_t)_mm_popcnt_u64(e);                                      \
            if (n + cnt > C)                                                                   \
                return n + cnt;                                                                \
            EXTRACT(ends + n, p, e, cnt); /* ends has room for 8 past C */                     \
            n += cnt;                                                                          \
            if (eol) {                                                                         \
                const char *le = p + _tzcnt_u64(eol);                                          \
                *line_end = le < end ? le : end;                                               \
                return n;                                                                      \
            }                                                                                  \
            p += 64;                                                                           \
        }                                                                                      \
    }

AVX512 static inline void classify_avx512(const char *q, uint64_t *tok, uint64_t *blank,
                                          uint64_t *eol)
{
    const __m512i b = _mm512_loadu_si512((const void *)q);
    *tok =
        _mm512_cmplt_epu8_mask(_mm512_sub_epi8(b, _mm512_set1_epi8(0x21)), _mm512_set1_epi8(0x5E));
    *blank = _mm512_cmpeq_epi8_mask(b, _mm512_set1_epi8(' ')) |
             _mm512_cmpeq_epi8_mask(b, _mm512_set1_epi8('\t'));
    *eol = _mm512_cmpeq_epi8_mask(b, _mm512_set1_epi8('\n')) |
           _mm512_cmpeq_epi8_mask(b, _mm512_set1_epi8('\r'));
}

/* 8 at a time without a branch per token */
#define EXTRACT_BITS(o, p, e, cnt)                         \
    do {                                                   \
        uint64_t e_ = (e);                                 \
        for (size_t k = 0;; k += 8) {                      \
            for (int i = 0; i < 8; i++) {                  \
                (o)[k + (size_t)i] = (p) + _tzcnt_u64(e_); \
                e_ = _blsr_u64(e_);                        \
            }                                              \
            if (k + 8 >= (cnt))                            \
                break;                                     \
        }                                                  \
    } while (0)

/* The same with AVX-512 VBMI2: the positions compressed into bytes, widened 8 at a time */
#define AVX512V     \
    __attribute__(( \
        target("avx512f,avx512bw,avx512dq,avx512vl,avx512cd,avx512vbmi2,bmi,bmi2,popcnt")))

AVX512V static inline void extract_compress(const char **o, const char *p, uint64_t e, size_t cnt)
{
    static const unsigned char iota64[64] = {
        0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21,
        22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43,
        44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63};
    unsigned char pos[64];
    _mm512_storeu_si512((void *)pos,
                        _mm512_maskz_compress_epi8(e, _mm512_loadu_si512((const void *)iota64)));
    const __m512i base = _mm512_set1_epi64((long long)(uintptr_t)p);
    for (size_t k = 0;; k += 8) {
        const __m128i b8 = _mm_loadl_epi64((const __m128i *)(const void *)(pos + k));
        _mm512_storeu_si512((void *)(o + k), _mm512_add_epi64(base, _mm512_cvtepu8_epi64(b8)));
        if (k + 8 >= cnt)
            break;
    }
}

DEFINE_SCAN_LINE(scan_line, AVX512, classify_avx512, EXTRACT_BITS)
DEFINE_SCAN_LINE(scan_line_vbmi2, AVX512V, classify_avx512, extract_compress)

#define BMI __attribute__((target("bmi,bmi2,popcnt")))

/* Bit i set when 16-bit field i of x is not zero. */
BMI static inline unsigned fields_nonzero(uint64_t x)
{
    const uint64_t LO = 0x7FFF7FFF7FFF7FFFu, HI = 0x8000800080008000u;
    return (unsigned)_pext_u64((((x & LO) + LO) | x) & HI, HI);
}

/* The scalar part of step 2 for four lanes (16-bit fields of 64-bit masks) from the byte-
 * reversed lanes' masks of blanks (bytes <= 0x20), digits, dots and '-': the token's digits,
 * the bytes below its dot (bytes 0-14 without a dot) and its first character if it is a '-'.
 * Returns the lanes (bits 0-3) that do not hold a simple token: their results are meaningless. */
typedef struct lane_bits {
    uint64_t dig, below, neg;
} lane_bits;

BMI static inline unsigned lane_check(uint64_t ks, uint64_t kd, uint64_t kp, uint64_t km,
                                      lane_bits *lb)
{
    const uint64_t ONE = 0x0001000100010001u, HI = 0x8000800080008000u;
    const uint64_t tok = (ks - ONE) & ~ks; /* the token: bytes below the first blank */
    uint64_t bad = tok & ~(kd | kp | km);
    const uint64_t top = tok & ~(tok >> 1); /* its first character */
    bad |= km & tok & ~top;
    const uint64_t y = (kp & tok) | HI; /* dots, with a sentinel at byte 15 */
    bad |= y & (y - ONE) & ~HI;         /* a second dot */
    lb->dig = kd & tok;
    bad |= (lb->dig - ONE) & ~lb->dig & HI; /* no digit (may also flag the lanes above) */
    lb->below = (y - ONE) & ~y;
    lb->neg = km & top;
    /* a lane without a blank holds a token of 16 bytes or more, and the borrow of ks - ONE
     * spoils the lanes above it: all four go to the scalar parser */
    return (ks - ONE) & ~ks & HI ? 0xFu : fields_nonzero(bad);
}

/* Step 2 for four lanes: the integer M in the low qword of each lane (m), the lane's count of
 * fraction digits, 15 for none (f), the lanes with a '-' (bits 0-3 of *neg); returns the lanes
 * that do not hold a simple token (as lane_check). */
AVX512 static inline unsigned lanes4(__m512i w, __m512i *m, __m512i *f, unsigned *neg)
{
    const __m512i rev = _mm512_broadcast_i32x4(
        _mm_setr_epi8(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0));
    const __m512i iota = _mm512_broadcast_i32x4(
        _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
    const __m512i r = _mm512_shuffle_epi8(w, rev);
    lane_bits lb;
    const unsigned bad = lane_check(
        _mm512_cmple_epu8_mask(r, _mm512_set1_epi8(0x20)),
        _mm512_cmplt_epu8_mask(_mm512_sub_epi8(r, _mm512_set1_epi8('0')), _mm512_set1_epi8(10)),
        _mm512_cmpeq_epi8_mask(r, _mm512_set1_epi8('.')),
        _mm512_cmpeq_epi8_mask(r, _mm512_set1_epi8('-')), &lb);
    const uint64_t above = ~lb.below & ~0x8000800080008000u; /* from the dot up: next byte */
    __m512i t = _mm512_maskz_sub_epi8(lb.dig, r, _mm512_set1_epi8('0'));
    t = _mm512_shuffle_epi8(t, _mm512_mask_add_epi8(iota, above, iota, _mm512_set1_epi8(1)));
    /* byte k has weight 10^k: pairs, quads, then the low and high 8 digits */
    const __m512i a = _mm512_maddubs_epi16(t, _mm512_set1_epi16(0x0A01));
    const __m512i b = _mm512_madd_epi16(a, _mm512_set1_epi32(0x00640001));
    const __m512i c = _mm512_packus_epi32(b, b);
    const __m512i d = _mm512_madd_epi16(c, _mm512_set1_epi32(0x27100001));
    *m = _mm512_add_epi64(_mm512_mul_epu32(_mm512_srli_epi64(d, 32), _mm512_set1_epi64(100000000)),
                          _mm512_and_si512(d, _mm512_set1_epi64(0xFFFFFFFF)));
    const __m512i cnt =
        _mm512_sad_epu8(_mm512_maskz_set1_epi8(lb.below, 1), _mm512_setzero_si512());
    *f = _mm512_add_epi64(cnt, _mm512_shuffle_epi32(cnt, _MM_PERM_BADC));
    *neg = fields_nonzero(lb.neg);
    return bad;
}

AVX512 static inline __m512i windows4(const char *const *e)
{
    __m512i w =
        _mm512_castsi128_si512(_mm_loadu_si128((const __m128i *)(const void *)(e[0] - 16)));
    w = _mm512_inserti32x4(w, _mm_loadu_si128((const __m128i *)(const void *)(e[1] - 16)), 1);
    w = _mm512_inserti32x4(w, _mm_loadu_si128((const __m128i *)(const void *)(e[2] - 16)), 2);
    return _mm512_inserti32x4(w, _mm_loadu_si128((const __m128i *)(const void *)(e[3] - 16)), 3);
}

/* Step 2 for eight tokens of at most 8 bytes (most tokens of files written with 4 decimals),
 * all eight at once, one per 64-bit lane. A token is that short when its end lies at most 9
 * bytes after the previous token's end (e[-1] for the first of the eight; for the line's first
 * token the byte before the line stands for that end): the 8 bytes up to its end then hold
 * the token and, unless it has 8 bytes, the blank before it. Those bytes, reversed (the last
 * character in byte 0), up to the first blank, are checked as lanes4 does (digits, at most
 * one dot, a '-' only first, a digit at least), the dot taken out, the digits summed by
 * weight and M / 10^f formed as line_avx512_body does. Returns 0, having stored nothing, when
 * a token of the first n (1 to 8; the others are padding) may be longer or is not simple: the
 * caller then takes the group the general way. */
AVX512 static inline int short8(const char *const *e, unsigned n, double *out)
{
    const __m512i ev = _mm512_loadu_si512((const void *)e);
    const __m512i gap = _mm512_sub_epi64(ev, _mm512_loadu_si512((const void *)(e - 1)));
    if (_mm512_mask_cmpgt_epu64_mask((__mmask8)(0xFFu >> (8 - n)), gap, _mm512_set1_epi64(9)))
        return 0;
    const __m512i rev = _mm512_broadcast_i32x4(
        _mm_setr_epi8(7, 6, 5, 4, 3, 2, 1, 0, 15, 14, 13, 12, 11, 10, 9, 8));
#define LD2(a, b)                                                                     \
    _mm_castpd_si128(_mm_loadh_pd(                                                    \
        _mm_castsi128_pd(_mm_loadl_epi64((const __m128i *)(const void *)(e[a] - 8))), \
        (const double *)(const void *)(e[b] - 8)))
    const __m256i lo = _mm256_inserti128_si256(_mm256_castsi128_si256(LD2(0, 1)), LD2(2, 3), 1);
    const __m256i hi = _mm256_inserti128_si256(_mm256_castsi128_si256(LD2(4, 5)), LD2(6, 7), 1);
#undef LD2
    /* byte k: the k-th last byte */
    const __m512i w =
        _mm512_shuffle_epi8(_mm512_inserti64x4(_mm512_castsi256_si512(lo), hi, 1), rev);
    /* the token's bytes: those below the lowest blank (byte <= 0x20; all 8 without one), and
     * its first character, the top one */
    const __m512i bl = _mm512_movm_epi8(_mm512_cmple_epu8_mask(w, _mm512_set1_epi8(0x20)));
    const __m512i tm = _mm512_sub_epi64(
        _mm512_and_si512(bl, _mm512_sub_epi64(_mm512_setzero_si512(), bl)), _mm512_set1_epi64(1));
    const __mmask64 tok = _mm512_movepi8_mask(tm);
    const __mmask64 first = _mm512_movepi8_mask(_mm512_andnot_si512(_mm512_srli_epi64(tm, 8), tm));
    const __m512i t = _mm512_sub_epi8(w, _mm512_set1_epi8('0'));
    const __mmask64 dg = _mm512_mask_cmplt_epu8_mask(tok, t, _mm512_set1_epi8(10));
    const __mmask64 dt = _mm512_mask_cmpeq_epi8_mask(tok, w, _mm512_set1_epi8('.'));
    const __mmask64 mn = _mm512_mask_cmpeq_epi8_mask(tok, w, _mm512_set1_epi8('-'));
    /* a byte that is none of these, or a '-' not first; no digit; a second dot */
    const __mmask64 badb = _kor_mask64(_kandn_mask64(_kor_mask64(_kor_mask64(dg, dt), mn), tok),
                                       _kandn_mask64(first, mn));
    const __m512i dots = _mm512_maskz_set1_epi8(dt, 1);
    const __mmask8 has_dot = _mm512_test_epi64_mask(dots, dots);
    const __m512i dm1 = _mm512_sub_epi64(dots, _mm512_set1_epi64(1));
    if (_mm512_test_epi64_mask(_mm512_movm_epi8(badb), _mm512_movm_epi8(badb)) |
        (__mmask8)~_mm512_test_epi64_mask(_mm512_movm_epi8(dg), _mm512_movm_epi8(dg)) |
        _mm512_test_epi64_mask(dots, dm1))
        return 0;
    /* bytes below the dot (none without one); the digits with the dot taken out: byte k has
     * weight 10^k */
    const __m512i below = _mm512_maskz_mov_epi64(has_dot, dm1);
    const __m512i d = _mm512_maskz_mov_epi8(dg, t);
    const __m512i dd = _mm512_ternarylogic_epi64(
        below, d, _mm512_mask_srli_epi64(d, has_dot, d, 8), 0xCA); /* below ? d : shifted */
    const __m512i a = _mm512_maddubs_epi16(dd, _mm512_set1_epi16(0x0A01));
    const __m512i b = _mm512_madd_epi16(a, _mm512_set1_epi32(0x00640001));
    const __m512i m =
        _mm512_add_epi64(_mm512_mul_epu32(_mm512_srli_epi64(b, 32), _mm512_set1_epi64(10000)),
                         _mm512_and_si512(b, _mm512_set1_epi64(0xFFFFFFFF)));
    /* f = bytes below the dot = (64 - leading zeros of below) / 8 */
    const __m512i f =
        _mm512_srli_epi64(_mm512_sub_epi64(_mm512_set1_epi64(64), _mm512_lzcnt_epi64(below)), 3);
    const __m512d p10 = _mm512_setr_pd(1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7);
    const __m512d r10 = _mm512_setr_pd(1e0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7);
    const __m512d md = _mm512_cvtepu64_pd(m);
    const __m512d y = _mm512_permutexvar_pd(f, r10);
    const __m512d q0 = _mm512_mul_pd(md, y);
    const __m512d r = _mm512_fnmadd_pd(q0, _mm512_permutexvar_pd(f, p10), md);
    const __m512d v = _mm512_fmadd_pd(r, y, q0);
    const __mmask8 neg = _mm512_test_epi64_mask(_mm512_movm_epi8(mn), _mm512_movm_epi8(mn));
    _mm512_storeu_si512((void *)out,
                        _mm512_mask_or_epi64(_mm512_castpd_si512(v), neg, _mm512_castpd_si512(v),
                                             _mm512_set1_epi64((long long)0x8000000000000000u)));
    return 1;
}

/* A token the lanes do not take (exponent, '+', 16 bytes or more, or no number at all):
 * mlr_parse_decimal on it, which must take all of it. */
static int token_slow(const char *line, const char *e, double *out)
{
    const char *s = e;
    while (s > line && s[-1] != ' ' && s[-1] != '\t')
        s--;
    return mlr_parse_decimal(s, e, out) == (size_t)(e - s);
}

/* Steps 1 and 2 on a line; the body of line_avx512 and line_vbmi2, which differ in step 1. */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
AVX512 static inline int line_avx512_body(const char *p, const char *const *ends, size_t C,
                                          double *row, int try_short)
{
    /* 10^f for f = 0 .. 14, 1 for the "no dot" count 15; and their reciprocals, rounded */
    const __m512d p10a = _mm512_setr_pd(1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7);
    const __m512d p10b = _mm512_setr_pd(1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e0);
    const __m512d r10a = _mm512_setr_pd(1e0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7);
    const __m512d r10b = _mm512_setr_pd(1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14, 1e0);
    const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
    const __m512i sign = _mm512_set1_epi64((long long)0x8000000000000000u);
    for (size_t i = 0; i < C; i += 8) {
        if (try_short && short8(ends + i, C - i < 8 ? (unsigned)(C - i) : 8u, row + i))
            continue;
        __m512i ma, fa, mb, fb;
        unsigned na, nb;
        unsigned bad = lanes4(windows4(ends + i), &ma, &fa, &na);
        bad |= lanes4(windows4(ends + i + 4), &mb, &fb, &nb) << 4;
        const __m512i m = _mm512_permutex2var_epi64(ma, even, mb);
        const __m512i f = _mm512_permutex2var_epi64(fa, even, fb);
        /* M / 10^f without a division: q0 = M * RN(10^-f) is within 2 ulps of the quotient,
         * r = M - q0 10^f is exact (one FMA), and q0 + r RN(10^-f) lands within 2^-51 ulp of
         * M / 10^f, which is never within 2^-47 ulp of a midpoint between doubles (M < 2^53,
         * f <= 14): the same double as the division (Markstein's correction) */
        const __m512d md = _mm512_cvtepu64_pd(m);
        const __m512d y = _mm512_permutex2var_pd(r10a, f, r10b);
        const __m512d q0 = _mm512_mul_pd(md, y);
        const __m512d r = _mm512_fnmadd_pd(q0, _mm512_permutex2var_pd(p10a, f, p10b), md);
        const __m512d v = _mm512_fmadd_pd(r, y, q0);
        const __m512i s = _mm512_mask_or_epi64(_mm512_castpd_si512(v), (__mmask8)(na | (nb << 4)),
                                               _mm512_castpd_si512(v), sign);
        _mm512_storeu_si512((void *)(row + i), s);
        for (; bad; bad &= bad - 1) {
            const size_t c = i + (size_t)_tzcnt_u32(bad);
            if (c < C && !token_slow(p, ends[c], row + c))
                return 0;
        }
    }
    return 1;
}

/* The whole-line kernel around step 1 SCAN: ends[0] stands for the end before the first token
 * (short8 reads it), the token ends follow from ends[1], then padding tokens for the last
 * group of eight. */
#define DEFINE_LINE(NAME, ATTR, SCAN)                                                        \
    ATTR static int NAME(const char *p, const char *end, size_t C, const char **ends,        \
                         double *row, const char **line_end)                                 \
    {                                                                                        \
        int ok = 1;                                                                          \
        ends[0] = p - 1;                                                                     \
        ends++;                                                                              \
        if (SCAN(p, end, C, ends, line_end, &ok) != C || !ok)                                \
            return 0;                                                                        \
        for (size_t i = 0; i < 8; i++)                                                       \
            ends[C + i] = zero_token + 16;                                                   \
        /* short tokens come 9 bytes apart at most: a longer line has too few to look for */ \
        return line_avx512_body(p, ends, C, row, (size_t)(*line_end - p) <= 9 * C);          \
    }

DEFINE_LINE(line_avx512, AVX512, scan_line)
DEFINE_LINE(line_vbmi2, AVX512V, scan_line_vbmi2)

/* ---- the same line kernel for AVX2: two lanes per register, four numbers per step ---------- */

#define AVX2 __attribute__((target("avx2,fma,bmi,bmi2,popcnt")))

AVX2 static inline void classify_avx2(const char *q, uint64_t *tok, uint64_t *blank, uint64_t *eol)
{
    uint64_t m[3] = {0, 0, 0};
    for (int h = 0; h < 2; h++) {
        const __m256i b = _mm256_loadu_si256((const __m256i *)(const void *)(q + 32 * h));
        /* visible ASCII 0x21 .. 0x7e: as signed bytes, above 0x20 and below 0x7f */
        const __m256i vis = _mm256_and_si256(_mm256_cmpgt_epi8(b, _mm256_set1_epi8(0x20)),
                                             _mm256_cmpgt_epi8(_mm256_set1_epi8(0x7f), b));
        const __m256i bl = _mm256_or_si256(_mm256_cmpeq_epi8(b, _mm256_set1_epi8(' ')),
                                           _mm256_cmpeq_epi8(b, _mm256_set1_epi8('\t')));
        const __m256i el = _mm256_or_si256(_mm256_cmpeq_epi8(b, _mm256_set1_epi8('\n')),
                                           _mm256_cmpeq_epi8(b, _mm256_set1_epi8('\r')));
        m[0] |= (uint64_t)(uint32_t)_mm256_movemask_epi8(vis) << (32 * h);
        m[1] |= (uint64_t)(uint32_t)_mm256_movemask_epi8(bl) << (32 * h);
        m[2] |= (uint64_t)(uint32_t)_mm256_movemask_epi8(el) << (32 * h);
    }
    *tok = m[0], *blank = m[1], *eol = m[2];
}

DEFINE_SCAN_LINE(scan_line_avx2, AVX2, classify_avx2, EXTRACT_BITS)

/* 10^f (f = 0 .. 14; 1 for the count 15 that means no dot) and RN(10^-f), then both negated:
 * index f + 16 for a '-' (the sign rides through the exact correction unchanged). */
static const double pow10_signed[32] = {
    1e0,  1e1,  1e2,  1e3,  1e4,   1e5,   1e6,   1e7,   1e8,   1e9,  1e10,
    1e11, 1e12, 1e13, 1e14, 1e0,   -1e0,  -1e1,  -1e2,  -1e3,  -1e4, -1e5,
    -1e6, -1e7, -1e8, -1e9, -1e10, -1e11, -1e12, -1e13, -1e14, -1e0,
};
static const double pow10_signed_inv[32] = {
    1e0,   1e-1,  1e-2,  1e-3,  1e-4,   1e-5,   1e-6,   1e-7,   1e-8,   1e-9,  1e-10,
    1e-11, 1e-12, 1e-13, 1e-14, 1e0,    -1e0,   -1e-1,  -1e-2,  -1e-3,  -1e-4, -1e-5,
    -1e-6, -1e-7, -1e-8, -1e-9, -1e-10, -1e-11, -1e-12, -1e-13, -1e-14, -1e0,
};

/* The 32-bit mask of bytes x[i] <= lim[i] as unsigned. */
AVX2 static inline uint32_t le_mask(__m256i x, __m256i lim)
{
    return (uint32_t)_mm256_movemask_epi8(_mm256_cmpeq_epi8(_mm256_min_epu8(x, lim), x));
}

/* Step 2 for four numbers (two lanes in each of two registers): their integers M in order (m)
 * and table indices (f + 16 for a '-') in idx; returns the lanes that do not hold a simple token
 * (as lane_check). */
AVX2 static inline unsigned lanes4_avx2(const char *const *e, __m256i *m, unsigned idx[4])
{
    const __m256i rev = _mm256_broadcastsi128_si256(
        _mm_setr_epi8(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0));
    const __m256i iota = _mm256_broadcastsi128_si256(
        _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
    const __m256i one = _mm256_set1_epi8(1), zero = _mm256_set1_epi8('0');
    __m256i r[2], t[2];
    uint64_t ks = 0, kd = 0, kp = 0, km = 0;
    for (int h = 0; h < 2; h++) {
        const __m256i w = _mm256_inserti128_si256(
            _mm256_castsi128_si256(
                _mm_loadu_si128((const __m128i *)(const void *)(e[2 * h] - 16))),
            _mm_loadu_si128((const __m128i *)(const void *)(e[2 * h + 1] - 16)), 1);
        r[h] = _mm256_shuffle_epi8(w, rev);
        t[h] = _mm256_sub_epi8(r[h], zero);
        const int sh = 32 * h;
        ks |= (uint64_t)le_mask(r[h], _mm256_set1_epi8(0x20)) << sh;
        kd |= (uint64_t)le_mask(t[h], _mm256_set1_epi8(9)) << sh;
        kp |= (uint64_t)(uint32_t)_mm256_movemask_epi8(
                  _mm256_cmpeq_epi8(r[h], _mm256_set1_epi8('.')))
              << sh;
        km |= (uint64_t)(uint32_t)_mm256_movemask_epi8(
                  _mm256_cmpeq_epi8(r[h], _mm256_set1_epi8('-')))
              << sh;
    }
    lane_bits lb;
    const unsigned bad = lane_check(ks, kd, kp, km, &lb);
    unsigned f[4], dn[4];
    for (int i = 0; i < 4; i++) {
        f[i] = (unsigned)_mm_popcnt_u64((lb.below >> (16 * i)) & 0xFFFF);
        dn[i] = (unsigned)_mm_popcnt_u64((lb.dig >> (16 * i)) & 0xFFFF);
        idx[i] = f[i] + (((lb.neg >> (16 * i)) & 0xFFFF) ? 16u : 0u);
    }
    __m256i mv[2];
    for (int h = 0; h < 2; h++) {
        /* byte k takes byte k below the dot and k + 1 from it up; zero from the digit count on
         * (there sits the '-', if any, and what lies before the token) */
        const __m256i v = _mm256_set1_epi32(
            (int)(f[2 * h] | f[2 * h + 1] << 8 | dn[2 * h] << 16 | dn[2 * h + 1] << 24));
        const __m256i fv = _mm256_shuffle_epi8(v, _mm256_setr_epi8(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                                                   0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1,
                                                                   1, 1, 1, 1, 1, 1, 1, 1, 1, 1));
        const __m256i dv = _mm256_shuffle_epi8(v, _mm256_setr_epi8(2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2,
                                                                   2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3,
                                                                   3, 3, 3, 3, 3, 3, 3, 3, 3, 3));
        const __m256i iota1 = _mm256_add_epi8(iota, one);
        const __m256i from = _mm256_or_si256(_mm256_sub_epi8(iota, _mm256_cmpgt_epi8(iota1, fv)),
                                             _mm256_cmpgt_epi8(iota1, dv));
        const __m256i d8 = _mm256_shuffle_epi8(t[h], from);
        /* byte k has weight 10^k: pairs, quads, then the low and high 8 digits */
        const __m256i a = _mm256_maddubs_epi16(d8, _mm256_set1_epi16(0x0A01));
        const __m256i b = _mm256_madd_epi16(a, _mm256_set1_epi32(0x00640001));
        const __m256i c = _mm256_packus_epi32(b, b);
        const __m256i d = _mm256_madd_epi16(c, _mm256_set1_epi32(0x27100001));
        mv[h] = _mm256_add_epi64(
            _mm256_mul_epu32(_mm256_srli_epi64(d, 32), _mm256_set1_epi64x(100000000)),
            _mm256_and_si256(d, _mm256_set1_epi64x(0xFFFFFFFF)));
    }
    /* the low qword of each lane: (M0, M2 | M1, M3) -> M0 M1 M2 M3 */
    *m = _mm256_permute4x64_epi64(_mm256_unpacklo_epi64(mv[0], mv[1]), 0xD8);
    return bad;
}

AVX2 static int line_avx2(const char *p, const char *end, size_t C, const char **ends, double *row,
                          const char **line_end)
{
    int ok = 1;
    const size_t n = scan_line_avx2(p, end, C, ends, line_end, &ok);
    if (!ok || n != C)
        return 0;
    for (size_t i = 0; i < 8; i++)
        ends[C + i] = zero_token + 16;
    const __m256i magic = _mm256_set1_epi64x(0x4330000000000000); /* 2^52 */
    for (size_t i = 0; i < C; i += 4) {
        __m256i m;
        unsigned idx[4];
        unsigned bad = lanes4_avx2(ends + i, &m, idx);
        /* M < 10^15 < 2^52: the double 2^52 + M, minus 2^52, is M exactly */
        const __m256d md = _mm256_sub_pd(_mm256_castsi256_pd(_mm256_or_si256(m, magic)),
                                         _mm256_castsi256_pd(magic));
        /* M / 10^f with the sign, as line_avx512 does */
        const __m256d y = _mm256_setr_pd(pow10_signed_inv[idx[0]], pow10_signed_inv[idx[1]],
                                         pow10_signed_inv[idx[2]], pow10_signed_inv[idx[3]]);
        const __m256d p10 = _mm256_setr_pd(pow10_signed[idx[0]], pow10_signed[idx[1]],
                                           pow10_signed[idx[2]], pow10_signed[idx[3]]);
        const __m256d q0 = _mm256_mul_pd(md, y);
        const __m256d v = _mm256_fmadd_pd(_mm256_fnmadd_pd(q0, p10, md), y, q0);
        _mm256_storeu_pd(row + i, v);
        for (; bad; bad &= bad - 1) {
            const size_t c = i + (size_t)_tzcnt_u32(bad);
            if (c < C && !token_slow(p, ends[c], row + c))
                return 0;
        }
    }
    return 1;
}

AVX512 static size_t count_newlines_avx512(const char *p, const char *end)
{
    const __m512i lf = _mm512_set1_epi8('\n');
    size_t n = 0;
    for (; end - p >= 64; p += 64)
        n += (size_t)_mm_popcnt_u64(
            _mm512_cmpeq_epi8_mask(_mm512_loadu_si512((const void *)p), lf));
    return n + count_newlines_portable(p, end);
}
#endif

void bvh_kernels_pick(bvh_kernels *k, int most)
{
    k->line = NULL;
    k->frame = frame_portable;
    k->count_newlines = count_newlines_portable;
#ifdef BVH_X86
    const int isa = cpu__isa(most);
    if (isa >= MLR_ISA_AVX512) {
        k->line = isa >= MLR_ISA_AVX512_VBMI2 ? line_vbmi2 : line_avx512;
        k->frame = frame_avx512;
        k->count_newlines = count_newlines_avx512;
    } else if (isa >= MLR_ISA_AVX2) {
        k->line = line_avx2;
        k->frame = frame_avx2;
    }
#else
    (void)most;
#endif
}
