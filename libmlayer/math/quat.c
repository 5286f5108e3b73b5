/* Batched quaternions: Hamilton product, scalar-first (w, x, y, z), and the exp, log, slerp and
 * normalize arrays. Rotation vectors are axis times the full angle. Euler angles are in euler.c,
 * sign continuity in quat_continuity.c. Nothing here allocates, prints or keeps state. */
#include "math/quat_internal.h"
#include "math/sincosd.h"

#include <math.h>

#ifdef MLR_X86_DISPATCH
#include <immintrin.h>
#endif

/* Below this, sinc and atan(r)/r use their Taylor series (error of the first dropped term is
 * below 1e-24 relative). */
#define SMALL_ARG 1e-4
/* log uses a longer series for r = |xyz| / w below this (error below 1e-19 relative). */
#define LOG_SERIES_ARG 0.05

/* |(x, y, z)| without spurious overflow or underflow, for finite input. */
static double norm3(double x, double y, double z)
{
    double m = quat__max4_abs(x, y, z, 0.0);
    if (m == 0.0)
        return 0.0;
    if (m < SAFE_LO || m > SAFE_HI) {
        x /= m;
        y /= m;
        z /= m;
        return m * sqrt(x * x + y * y + z * z);
    }
    return sqrt(x * x + y * y + z * z);
}

/* sin(x) / x, 1 at 0. */
static double sinc(double x)
{
    if (fabs(x) < SMALL_ARG) {
        double x2 = x * x;
        return 1.0 - x2 * (1.0 / 6.0) * (1.0 - x2 * (1.0 / 20.0));
    }
    return sin(x) / x;
}

void mlr_quat_mul(const mlr_quat *a, const mlr_quat *b, mlr_quat *out)
{
    if (!a || !b || !out)
        return;
    common__quat_mul_inline(a, b, out);
}

void mlr_quat_rotate(const mlr_quat *q, const mlr_vec3 *v, mlr_vec3 *out)
{
    if (!q || !v || !out)
        return;
    const double vv[3] = {v->x, v->y, v->z};
    double o[3];
    common__quat_rotate_inline(q, vv, o);
    out->x = o[0], out->y = o[1], out->z = o[2];
}

void mlr_quat_mul_array(const mlr_quat *a, const mlr_quat *b, size_t count, mlr_quat *out)
{
    if (!a || !b || !out)
        return;
    for (size_t i = 0; i < count; i++)
        common__quat_mul_inline(&a[i], &b[i], &out[i]);
}

void mlr_quat_conj_array(const mlr_quat *q, size_t count, mlr_quat *out)
{
    if (!q || !out)
        return;
    for (size_t i = 0; i < count; i++) {
        out[i].w = q[i].w;
        out[i].x = -q[i].x;
        out[i].y = -q[i].y;
        out[i].z = -q[i].z;
    }
}

/*
 * Array kernels. The arrays are processed by blocks of QBLK: the block is checked for the
 * common case (every component finite, the largest magnitude of each element within
 * [FAST_LO, FAST_HI], so that sums of squares neither overflow nor lose precision), and then
 * runs through a branch-free loop over structure-of-arrays copies that compilers vectorize;
 * a block with any other element takes the scalar path of each element (which scales the
 * element first). Both paths use the same formulas.
 * With GCC on x86-64 the vector loops get an AVX2 clone chosen at load time.
 */
#define QBLK 32
#define PAD4(m) \
    (((m) + 3) & ~(size_t)3) /* vector loops run over whole vectors: lanes past m
                                            hold identities (never stored) */
#define FAST_LO 0x1p-250
#define FAST_HI 0x1p+250

/* Larger of two (a NaN may be dropped: callers test for NaN apart, see finite4). */
static inline double vmax(double a, double b) { return a > b ? a : b; }

/* 1 when a, b, c, d are all finite (0 * inf and NaN give NaN), without branches. */
static inline int finite4(double a, double b, double c, double d)
{
    return a * 0.0 + b * 0.0 + c * 0.0 + d * 0.0 == 0.0;
}

/* The m quaternions at q into SoA copies w, x, y, z; 1 when every component is finite and the
 * largest |component| of every quaternion lies in [lo, hi]. */
static inline int block_load(const mlr_quat *restrict q, size_t m, double *restrict w,
                             double *restrict x, double *restrict y, double *restrict z, double lo,
                             double hi)
{
    int bad = 0;
    for (size_t i = 0; i < m; i++) {
        w[i] = q[i].w, x[i] = q[i].x, y[i] = q[i].y, z[i] = q[i].z;
        const double mx = vmax(vmax(fabs(w[i]), fabs(x[i])), vmax(fabs(y[i]), fabs(z[i])));
        bad |= !((mx >= lo) & (mx <= hi) & finite4(w[i], x[i], y[i], z[i]));
    }
    for (size_t i = m; i < PAD4(m); i++)
        w[i] = 1.0, x[i] = y[i] = z[i] = 0.0;
    return !bad;
}

MLR_CLONES("avx2")
static int normalize_fast(const mlr_quat *q, size_t m, mlr_quat *out)
{
    double w[QBLK], x[QBLK], y[QBLK], z[QBLK];
    if (!block_load(q, m, w, x, y, z, FAST_LO, FAST_HI))
        return 0;
    for (size_t i = 0; i < PAD4(m); i++) {
        const double n = sqrt(w[i] * w[i] + x[i] * x[i] + y[i] * y[i] + z[i] * z[i]);
        w[i] /= n, x[i] /= n, y[i] /= n, z[i] /= n;
    }
    for (size_t i = 0; i < m; i++)
        out[i].w = w[i], out[i].x = x[i], out[i].y = y[i], out[i].z = z[i];
    return 1;
}

/* The diag of an array function that met n_bad bad elements of arg, the first at index first:
 * "quat log: q: 1 of 40 quaternions zero, NaN or infinite, the first at index 7". */
mlr_status quat__bad_elements(mlr_diag *diag, const char *fn, const char *arg, const char *what,
                              size_t first, size_t n_bad, size_t count)
{
    return common__diag_set(
        diag, MLR_E_INVALID_ARG, 0, 0, "%s: %s: %zu of %zu %s %s, the first at index %zu", fn, arg,
        n_bad, count, what,
        strcmp(what, "quaternions") ? "NaN or infinite" : "zero, NaN or infinite", first);
}

mlr_status mlr_quat_normalize_array(const mlr_quat *q, size_t count, mlr_quat *out, mlr_diag *diag)
{
    if (count == 0)
        return MLR_OK;
    if (!q || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "quat normalize: q or out is NULL");
    size_t n_bad = 0, first = 0;
    for (size_t i0 = 0; i0 < count; i0 += QBLK) {
        const size_t m = count - i0 < QBLK ? count - i0 : QBLK;
        if (normalize_fast(q + i0, m, out + i0))
            continue;
        for (size_t i = i0; i < i0 + m; i++) {
            if (!quat__unit(&q[i], &out[i])) {
                out[i] = mlr__quat_identity;
                first = n_bad++ ? first : i;
            }
        }
    }
    if (n_bad)
        return quat__bad_elements(diag, "quat normalize", "q", "quaternions", first, n_bad, count);
    return MLR_OK;
}

/* Are the m quaternions q all unit to rounding (|q|^2 within MLR_NEAR_UNIT2 of 1), as
 * quat__unit_array decides each (the same sum: the same bits)? NaN is not. Vectorized. */
MLR_CLONES("avx2")
static int near_unit_block(const mlr_quat *q, size_t m)
{
    long far = 0;
    for (size_t i = 0; i < m; i++) {
        far |= !ik__near_unit2(ik__quat_norm2_wxyz(q[i].w, q[i].x, q[i].y, q[i].z));
    }
    return far == 0;
}

#ifdef MLR_X86_DISPATCH
/* near_unit_block of m (a multiple of 4) quaternions, copied to out as they are on the way
 * (out may be q; where the answer is no, the caller writes out again): four at a time, their
 * squares transposed so that each |q|^2 is summed in near_unit_block's order (the same bits). */
__attribute__((target("avx2"))) static int near_unit_copy_avx2(const mlr_quat *q, size_t m,
                                                               mlr_quat *out)
{
    const __m256d one = _mm256_set1_pd(1.0), tol = _mm256_set1_pd(MLR_NEAR_UNIT2),
                  nosign = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
    __m256d ok = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    const double *p = &q[0].w;
    double *o = &out[0].w;
    for (size_t i = 0; i < 4 * m; i += 16) {
        const __m256d a = _mm256_loadu_pd(p + i), b = _mm256_loadu_pd(p + i + 4),
                      c = _mm256_loadu_pd(p + i + 8), d = _mm256_loadu_pd(p + i + 12);
        const __m256d sa = _mm256_mul_pd(a, a), sb = _mm256_mul_pd(b, b), sc = _mm256_mul_pd(c, c),
                      sd = _mm256_mul_pd(d, d);
        const __m256d t0 = _mm256_unpacklo_pd(sa, sb), t1 = _mm256_unpackhi_pd(sa, sb),
                      t2 = _mm256_unpacklo_pd(sc, sd), t3 = _mm256_unpackhi_pd(sc, sd);
        const __m256d w = _mm256_permute2f128_pd(t0, t2, 0x20),
                      x = _mm256_permute2f128_pd(t1, t3, 0x20),
                      y = _mm256_permute2f128_pd(t0, t2, 0x31),
                      z = _mm256_permute2f128_pd(t1, t3, 0x31);
        const __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(w, x), y), z);
        const __m256d e = _mm256_and_pd(_mm256_sub_pd(s, one), nosign);
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(e, tol, _CMP_LE_OQ));
        _mm256_storeu_pd(o + i, a), _mm256_storeu_pd(o + i + 4, b);
        _mm256_storeu_pd(o + i + 8, c), _mm256_storeu_pd(o + i + 12, d);
    }
    return _mm256_movemask_pd(ok) == 0xf;
}
#endif

/* Are the m quaternions q all unit to rounding? Then they are copied to out as they are.
 * avx2: the caller's cpu__isa(...) >= MLR_ISA_AVX2, resolved once per array. */
static int near_unit_copy(const mlr_quat *q, size_t m, mlr_quat *out, int avx2)
{
#ifdef MLR_X86_DISPATCH
    if (avx2 && m % 4 == 0)
        return near_unit_copy_avx2(q, m, out);
#else
    (void)avx2;
#endif
    if (!near_unit_block(q, m))
        return 0;
    if (out != q)
        memcpy(out, q, m * sizeof *q);
    return 1;
}

/* One quaternion of quat__unit_array; 0 when it is zero or not finite (identity). */
static int unit_one(const mlr_quat *q, mlr_quat *out)
{
    const mlr_quat p = *q;
    if (ik__near_unit2(ik__quat_norm2_wxyz(p.w, p.x, p.y, p.z))) { /* unit to rounding: as is */
        *out = p;
        return 1;
    }
    if (quat__unit(&p, out))
        return 1;
    *out = mlr__quat_identity;
    return 0;
}

mlr_status quat__unit_array_isa(const mlr_quat *q, size_t count, mlr_quat *out, int most)
{
    const int avx2 = cpu__isa(most < MLR_ISA_AVX2 ? most : MLR_ISA_AVX2) >= MLR_ISA_AVX2;
    int bad = 0;
    for (size_t i0 = 0; i0 < count; i0 += QBLK) {
        const size_t m = count - i0 < QBLK ? count - i0 : QBLK;
        if (near_unit_copy(q + i0, m, out + i0, avx2)) /* every one unit to rounding: as it is */
            continue;
        for (size_t i = i0; i < i0 + m; i++)
            bad |= !unit_one(&q[i], &out[i]);
    }
    return bad ? MLR_E_INVALID_ARG : MLR_OK;
}

mlr_status quat__unit_array(const mlr_quat *q, size_t count, mlr_quat *out)
{
    return quat__unit_array_isa(q, count, out, MLR_ISA_BEST);
}

/* exp of m rotation vectors whose components are all finite and below MLR_SINCOS_LIMIT / 2
 * in magnitude; 0 (nothing written) otherwise. */
MLR_CLONES("avx2")
static int exp_fast(const mlr_vec3 *v, size_t m, mlr_quat *out)
{
    double x[QBLK], y[QBLK], z[QBLK], c[QBLK], k[QBLK];
    int bad = 0;
    for (size_t i = 0; i < m; i++) {
        x[i] = v[i].x, y[i] = v[i].y, z[i] = v[i].z;
        const double mx = vmax(vmax(fabs(x[i]), fabs(y[i])), fabs(z[i]));
        bad |= !((mx <= 0.5 * MLR_SINCOS_LIMIT) & finite4(x[i], y[i], z[i], 0.0));
    }
    if (bad)
        return 0;
    for (size_t i = m; i < PAD4(m); i++)
        x[i] = y[i] = z[i] = 0.0;
    for (size_t i = 0; i < PAD4(m); i++) {
        /* squares of components below 1e-154 may underflow: the angle is then too small to
         * change cos or sin(angle / 2) / angle = 1/2 */
        const double angle = sqrt(x[i] * x[i] + y[i] * y[i] + z[i] * z[i]);
        double sn, cs;
        mlr_sincos_kernel(0.5 * angle, &sn, &cs);
        /* a nonzero angle is above 1e-162 */
        const double ratio = sn / vmax(angle, 0x1p-600);
        c[i] = cs;
        k[i] = common__select_bits(angle > 0.0, ratio, 0.5); /* sin(angle / 2) / angle */
    }
    for (size_t i = 0; i < m; i++) {
        out[i].w = c[i];
        out[i].x = k[i] * x[i];
        out[i].y = k[i] * y[i];
        out[i].z = k[i] * z[i];
    }
    return 1;
}

mlr_status mlr_quat_exp_array(const mlr_vec3 *v, size_t count, mlr_quat *out, mlr_diag *diag)
{
    if (count == 0)
        return MLR_OK;
    if (!v || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "quat exp: v or out is NULL");
    size_t n_bad = 0, first = 0;
    for (size_t i0 = 0; i0 < count; i0 += QBLK) {
        const size_t m = count - i0 < QBLK ? count - i0 : QBLK;
        if (exp_fast(v + i0, m, out + i0))
            continue;
        for (size_t i = i0; i < i0 + m; i++) {
            const double x = v[i].x, y = v[i].y, z = v[i].z;
            if (!(isfinite(x) && isfinite(y) && isfinite(z))) {
                out[i] = mlr__quat_identity;
                first = n_bad++ ? first : i;
                continue;
            }
            const double angle = norm3(x, y, z);
            const double half = 0.5 * angle;
            double k, c; /* k = sin(angle / 2) / angle */
            if (half < MLR_SINCOS_LIMIT) { /* as exp_fast */
                double sn;
                mlr_sincos_kernel(half, &sn, &c);
                k = angle > 0.0 ? sn / angle : 0.5;
            } else {
                k = 0.5 * sinc(half);
                c = cos(half);
            }
            out[i].w = c;
            out[i].x = k * x;
            out[i].y = k * y;
            out[i].z = k * z;
        }
    }
    if (n_bad)
        return quat__bad_elements(diag, "quat exp", "v", "rotation vectors", first, n_bad, count);
    return MLR_OK;
}

/* 2 atan(r) / (r w) for r = s / w below LOG_SERIES_ARG: Taylor in r to r^12, the first
 * dropped term below 1e-19 relative. It spares the atan for the small angles that dominate
 * motion displacements (below about 5.7 degrees). */
static inline double log_series(double s, double w)
{
    const double r = s / w, r2 = r * r;
    const double t = 1.0 / 11.0 - r2 * (1.0 / 13.0);
    const double u = 1.0 / 7.0 - r2 * (1.0 / 9.0 - r2 * t);
    return (2.0 / w) * (1.0 - r2 * (1.0 / 3.0 - r2 * (1.0 / 5.0 - r2 * u)));
}

/*
 * atan2(s, w) for s, w >= 0, not both 0, without branches: fdlibm's atan (s_atan.c,
 *   Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 *   Developed at SunSoft, a Sun Microsystems, Inc. business.
 *   Permission to use, copy, modify, and distribute this software is freely granted, provided
 *   that this notice is preserved.)
 * on x = min / max in [0, 1], reduced to |t| <= 7/16 around 0, 1/2 or 1, and
 * atan2 = pi/2 - atan(w / s) when s > w (the constants of pi/2 - atan(c) in two parts).
 * Within about an ulp of atan2.
 */
static inline double atan2_pos(double s, double w)
{
    static const double T0 = 3.33333333333329318027e-01, T1 = -1.99999999998764832476e-01,
                        T2 = 1.42857142725034663711e-01, T3 = -1.11111104054623557880e-01,
                        T4 = 9.09088713343650656196e-02, T5 = -7.69187620504482999495e-02,
                        T6 = 6.66107313738753120669e-02, T7 = -5.83357013379057348645e-02,
                        T8 = 4.97687799461593236017e-02, T9 = -3.65315727442169155270e-02,
                        T10 = 1.62858201153657823623e-02;
    const int big = s > w;
    /* the selects are bit masks so that the divisions stay unconditional (vectorizable) */
    const double x = common__select_bits(big, w, s) / common__select_bits(big, s, w);
    const int i0 = x >= 0.4375, i1 = x >= 0.6875;
    /* t = (x - c) / (1 + c x) for c = 0, 1/2, 1 with exact numerators */
    const double n1 = x - 1.0, d1 = x + 1.0, n0 = 2.0 * x - 1.0, d0 = 2.0 + x;
    const double t = common__select_bits(i1, n1, common__select_bits(i0, n0, x)) /
                     common__select_bits(i1, d1, common__select_bits(i0, d0, 1.0));
    /* atan(c) (or pi/2 - atan(c) when big) as hi + lo */
    const double hi = big ? (i1   ? 7.85398163397448278999e-01
                             : i0 ? 1.10714871779409040897e+00
                                  : 1.57079632679489655800e+00)
                          : (i1   ? 7.85398163397448278999e-01
                             : i0 ? 4.63647609000806093515e-01
                                  : 0.0);
    const double lo = big ? (i1   ? 3.06161699786838301793e-17
                             : i0 ? 9.40447137356637995390e-17
                                  : 6.12323399573676603587e-17)
                          : (i1   ? 3.06161699786838301793e-17
                             : i0 ? 2.26987774529616870924e-17
                                  : 0.0);
    const double u = big ? -t : t;
    const double z = t * t, w2 = z * z;
    const double s1 = z * (T0 + w2 * (T2 + w2 * (T4 + w2 * (T6 + w2 * (T8 + w2 * T10)))));
    const double s2 = w2 * (T1 + w2 * (T3 + w2 * (T5 + w2 * (T7 + w2 * T9))));
    return hi - ((u * (s1 + s2) - lo) - u);
}

/* log of m quaternions in SoA copies, each of the common case (see block_load), the copies
 * padded to PAD4(m). */
static inline void log_soa(const double *restrict w, const double *restrict x,
                           const double *restrict y, const double *restrict z, size_t m,
                           mlr_vec3 *restrict out)
{
    double k[QBLK];
    for (size_t i = 0; i < PAD4(m); i++) {
        /* q and -q are the same rotation; take the angle in [0, pi] */
        const double sg = w[i] < 0.0 ? -1.0 : 1.0, aw = sg * w[i];
        const double s = sqrt(x[i] * x[i] + y[i] * y[i] + z[i] * z[i]);
        /* both forms computed, one kept (the other may be 0/0 there) */
        const double ks = log_series(s, aw), ka = 2.0 * atan2_pos(s, aw) / s;
        k[i] = sg * common__select_bits(s < LOG_SERIES_ARG * aw, ks, ka);
    }
    for (size_t i = 0; i < m; i++) {
        out[i].x = k[i] * x[i];
        out[i].y = k[i] * y[i];
        out[i].z = k[i] * z[i];
    }
}

/* log of one quaternion in the scalar path: any input; MLR_E_INVALID_ARG (and 0) for a zero
 * or non-finite one. */
static mlr_status log_one(const mlr_quat *q, mlr_vec3 *out)
{
    mlr_quat p = *q;
    if (!quat__is_finite(&p) || !quat__prescale(&p)) {
        out->x = out->y = out->z = 0.0;
        return MLR_E_INVALID_ARG;
    }
    if (p.w < 0.0) { /* q and -q are the same rotation; take the angle in [0, pi] */
        p.w = -p.w;
        p.x = -p.x;
        p.y = -p.y;
        p.z = -p.z;
    }
    /* angle = 2 atan2(s, w); the vector is angle * (x, y, z) / s. The scale is invariant to
     * |q|, so a slightly unnormalized q gives the log of its normalized rotation. */
    const double s = norm3(p.x, p.y, p.z);
    const double k = s < LOG_SERIES_ARG * p.w ? log_series(s, p.w) : 2.0 * atan2_pos(s, p.w) / s;
    out->x = k * p.x;
    out->y = k * p.y;
    out->z = k * p.z;
    return MLR_OK;
}

/* log of m quaternions of block_load's common case; 0 (nothing written) otherwise. */
MLR_CLONES("avx2")
static int log_fast(const mlr_quat *q, size_t m, mlr_vec3 *out)
{
    double w[QBLK], x[QBLK], y[QBLK], z[QBLK];
    if (!block_load(q, m, w, x, y, z, FAST_LO, FAST_HI))
        return 0;
    log_soa(w, x, y, z, m, out);
    return 1;
}

mlr_status mlr_quat_log_array(const mlr_quat *q, size_t count, mlr_vec3 *out, mlr_diag *diag)
{
    if (count == 0)
        return MLR_OK;
    if (!q || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "quat log: q or out is NULL");
    size_t n_bad = 0, first = 0;
    for (size_t i0 = 0; i0 < count; i0 += QBLK) {
        const size_t m = count - i0 < QBLK ? count - i0 : QBLK;
        if (log_fast(q + i0, m, out + i0))
            continue;
        for (size_t i = i0; i < i0 + m; i++)
            if (log_one(&q[i], &out[i]) != MLR_OK)
                first = n_bad++ ? first : i;
    }
    if (n_bad)
        return quat__bad_elements(diag, "quat log", "q", "quaternions", first, n_bad, count);
    return MLR_OK;
}

/* prod = conj(a) b (conj_b 0) or a conj(b) (conj_b 1), out = log(prod) for m <= QBLK
 * quaternions; the SoA path when the products are of the common case. The conjugate is a
 * product by -1, exact: both forms give the bits of a negated copy. */
MLR_CLONES("avx2")
static void conj_mul_log_block(const mlr_quat *a, const mlr_quat *b, size_t m, int conj_b,
                               mlr_quat *prod, mlr_vec3 *out)
{
    double w[QBLK], x[QBLK], y[QBLK], z[QBLK];
    const double sa = conj_b ? 1.0 : -1.0, sb = conj_b ? -1.0 : 1.0;
    int bad = 0;
    for (size_t i = 0; i < m; i++) {
        const double aw = a[i].w, ax = sa * a[i].x, ay = sa * a[i].y, az = sa * a[i].z;
        const double bw = b[i].w, bx = sb * b[i].x, by = sb * b[i].y, bz = sb * b[i].z;
        const mlr_quat r = common__qmul_wxyz(aw, ax, ay, az, bw, bx, by, bz);
        w[i] = r.w, x[i] = r.x, y[i] = r.y, z[i] = r.z;
        const double mx = vmax(vmax(fabs(w[i]), fabs(x[i])), vmax(fabs(y[i]), fabs(z[i])));
        bad |= !((mx >= FAST_LO) & (mx <= FAST_HI) & finite4(w[i], x[i], y[i], z[i]));
    }
    for (size_t i = 0; i < m; i++)
        prod[i].w = w[i], prod[i].x = x[i], prod[i].y = y[i], prod[i].z = z[i];
    for (size_t i = m; i < PAD4(m); i++)
        w[i] = 1.0, x[i] = y[i] = z[i] = 0.0;
    if (!bad) {
        log_soa(w, x, y, z, m, out);
        return;
    }
    for (size_t i = 0; i < m; i++)
        log_one(&prod[i], &out[i]);
}

void common__quat_conj_mul_log(const mlr_quat *a, const mlr_quat *b, size_t count, int conj_b,
                               mlr_quat *prod, mlr_vec3 *out)
{
    for (size_t i0 = 0; i0 < count; i0 += QBLK) {
        const size_t m = count - i0 < QBLK ? count - i0 : QBLK;
        conj_mul_log_block(a + i0, b + i0, m, conj_b, prod + i0, out + i0);
    }
}

mlr_status mlr_quat_slerp_array(const mlr_quat *a, const mlr_quat *b, const double *t,
                                size_t count, mlr_quat *out, mlr_diag *diag)
{
    if (count == 0)
        return MLR_OK;
    if (!a || !b || !t || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "quat slerp: a, b, t or out is NULL");
    size_t n_bad = 0, first = 0;
    const char *what = "";
    for (size_t i = 0; i < count; i++) {
        mlr_quat p, r;
        const double ti = t[i];
        const char *bad = !isfinite(ti)            ? "t is NaN or infinite"
                          : !quat__unit(&a[i], &p) ? "a is a zero, NaN or infinite quaternion"
                          : !quat__unit(&b[i], &r) ? "b is a zero, NaN or infinite quaternion"
                                                   : NULL;
        if (bad) {
            out[i] = mlr__quat_identity;
            if (!n_bad++)
                first = i, what = bad;
            continue;
        }
        if (p.w * r.w + p.x * r.x + p.y * r.y + p.z * r.z < 0.0) { /* shorter arc */
            r.w = -r.w;
            r.x = -r.x;
            r.y = -r.y;
            r.z = -r.z;
        }
        /* theta: the angle between p and r on the 4-sphere, in [0, pi/2], accurate even when
         * p ~ r. The weights sin((1-t) theta) / sin(theta) and sin(t theta) / sin(theta) are
         * written with sinc so that they tend to the lerp weights as theta -> 0 (no 0/0). */
        const double dw = p.w - r.w, dx = p.x - r.x, dy = p.y - r.y, dz = p.z - r.z;
        const double sw = p.w + r.w, sx = p.x + r.x, sy = p.y + r.y, sz = p.z + r.z;
        const double theta = 2.0 * atan2(sqrt(dw * dw + dx * dx + dy * dy + dz * dz),
                                         sqrt(sw * sw + sx * sx + sy * sy + sz * sz));
        const double u = 1.0 - ti;
        const double sinc_theta = sinc(theta);
        const double ka = u * sinc(u * theta) / sinc_theta;
        const double kb = ti * sinc(ti * theta) / sinc_theta;
        mlr_quat m = {ka * p.w + kb * r.w, ka * p.x + kb * r.x, ka * p.y + kb * r.y,
                      ka * p.z + kb * r.z};
        if (!quat__unit(&m, &out[i])) { /* only for a t far outside [0, 1] */
            out[i] = mlr__quat_identity;
            if (!n_bad++)
                first = i, what = "t is too far outside [0, 1]";
        }
    }
    return n_bad ? common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "quat slerp: %zu of %zu bad, the first at index %zu: %s",
                                    n_bad, count, first, what)
                 : MLR_OK;
}
