/* Sine and cosine of angles in degrees, for arrays, in a form compilers vectorize (and a radian
 * kernel for small angles, mlr_sincos_kernel, used by the quaternion exp). Not
 * installed; static inline so that the tests can check the kernel directly.
 *
 * Method. Angles in degrees reduce exactly: for |x| < 2^50, k = nearest integer to x / 90
 * (from the 1.5 * 2^52 rounding trick) and r = x - 90 k are both exact (90 k is an integer
 * below 2^53 and r, a multiple of ulp(x) no larger than |x|, is representable), so r lies in
 * [-45, 45] (a hair beyond when x / 90 rounds across a half) with no reduction error, unlike a
 * reduction by an inexact pi / 2 in radians. Then t = r * pi / 180 (one rounding, relative
 * error below 2^-53, which moves sin(t) by at most that relative amount and cos(t) by less),
 * and the fdlibm kernels __kernel_sin / __kernel_cos on |t| <= pi / 4 (polynomial error below
 * 2^-58; coefficients below, from FreeBSD msun k_sin.c and k_cos.c:
 *   Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 *   Developed at SunSoft, a Sun Microsystems, Inc. business.
 *   Permission to use, copy, modify, and distribute this software is freely granted, provided
 *   that this notice is preserved.)
 * Finally the quadrant k mod 4 swaps sine and cosine and sets their signs. Measured against a
 * long double reference (tests/math/test_quat.c) the error stays within about 1 ulp.
 *
 * Larger angles (|x| >= 2^50 degrees) are first reduced with fmod(x, 360), which is exact. NaN
 * gives NaN, infinities give NaN. */
#ifndef MLR_SINCOSD_H
#define MLR_SINCOSD_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define MLR_SINCOSD_LIMIT 0x1p50

/* The fdlibm coefficients (macros, so that a vector kernel can use the same ones). */
#define MLR_SINCOS_S1 -1.66666666666666324348e-01
#define MLR_SINCOS_S2 8.33333333332248946124e-03
#define MLR_SINCOS_S3 -1.98412698298579493134e-04
#define MLR_SINCOS_S4 2.75573137070700676789e-06
#define MLR_SINCOS_S5 -2.50507602534068634195e-08
#define MLR_SINCOS_S6 1.58969099521155010221e-10
#define MLR_SINCOS_C1 4.16666666666666019037e-02
#define MLR_SINCOS_C2 -1.38888888888741095749e-03
#define MLR_SINCOS_C3 2.48015872894767294178e-05
#define MLR_SINCOS_C4 -2.75573143513906633035e-07
#define MLR_SINCOS_C5 2.08757232129817482790e-09
#define MLR_SINCOS_C6 -1.13596475577881948265e-11
/* Degrees to radians, as rounded */
#define MLR_DEG_TO_RAD 0.017453292519943295769

/* sin and cos of t + k pi/2 for |t| <= pi/4 (a hair beyond is fine) and the quadrant k in the
 * low bits of kbits: the fdlibm kernels and the quadrant swap; no branches. */
static inline void mlr_sincos_quadrant(double t, uint64_t kbits, double *s_out, double *c_out)
{
    const double S1 = MLR_SINCOS_S1, S2 = MLR_SINCOS_S2, S3 = MLR_SINCOS_S3, S4 = MLR_SINCOS_S4,
                 S5 = MLR_SINCOS_S5, S6 = MLR_SINCOS_S6;
    const double C1 = MLR_SINCOS_C1, C2 = MLR_SINCOS_C2, C3 = MLR_SINCOS_C3, C4 = MLR_SINCOS_C4,
                 C5 = MLR_SINCOS_C5, C6 = MLR_SINCOS_C6;
    const double z = t * t;
    /* sin(t) = t + t^3 (S1 + z P(z)) */
    const double ps = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    const double sn = t + (z * t) * (S1 + z * ps);
    /* cos(t) = 1 - z/2 + z^2 Q(z), with the 1 - z/2 rounding error carried */
    const double qc = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    const double hz = 0.5 * z, w = 1.0 - hz;
    const double cs = w + (((1.0 - w) - hz) + z * qc);
    /* quadrant q = k mod 4: (sin, cos) = (sn, cs), (cs, -sn), (-sn, -cs), (-cs, sn) */
    const uint64_t q = kbits & 3u;
    const uint64_t swap = (uint64_t)0 - (q & 1u); /* all ones when q is odd */
    const uint64_t sign_s = (q & 2u) << 62, sign_c = ((q + 1u) & 2u) << 62;
    uint64_t sb, cb;
    memcpy(&sb, &sn, sizeof sb);
    memcpy(&cb, &cs, sizeof cb);
    const uint64_t so = ((sb & ~swap) | (cb & swap)) ^ sign_s;
    const uint64_t co = ((cb & ~swap) | (sb & swap)) ^ sign_c;
    memcpy(s_out, &so, sizeof so);
    memcpy(c_out, &co, sizeof co);
}

/* sin and cos of x degrees for |x| < MLR_SINCOSD_LIMIT (or NaN); no branches. */
static inline void mlr_sincosd_kernel(double x, double *s_out, double *c_out)
{
    const double shifter = 0x1.8p52; /* adding it rounds to an integer, kept in the low bits */
    const double kq = x * (1.0 / 90.0) + shifter;
    const double k = kq - shifter;
    uint64_t kbits;
    memcpy(&kbits, &kq, sizeof kbits);
    const double r = x - k * 90.0; /* exact */
    mlr_sincos_quadrant(r * MLR_DEG_TO_RAD, kbits, s_out, c_out);
}

/* Radians. The limit of mlr_sincos_kernel: k pi/2 with the 33-bit head of pi/2 stays exact. */
#define MLR_SINCOS_LIMIT 0x1p19

/* sin and cos of x radians for |x| < MLR_SINCOS_LIMIT (or NaN); no branches. Reduction by
 * k pi/2 in two parts (the fdlibm pio2_1, 33 bits, whose multiples below 2^20 are exact, and
 * its tail pio2_1t): the reduced angle carries an absolute error below about 1e-26 k, which
 * moves sin and cos by as much in absolute terms (not relative near their zeros). */
static inline void mlr_sincos_kernel(double x, double *s_out, double *c_out)
{
    static const double PIO2_1 = 1.57079632673412561417e+00, PIO2_1T = 6.07710050650619224932e-11;
    const double shifter = 0x1.8p52;
    const double kq = x * 6.36619772367581382433e-01 + shifter;
    const double k = kq - shifter;
    uint64_t kbits;
    memcpy(&kbits, &kq, sizeof kbits);
    const double r = (x - k * PIO2_1) - k * PIO2_1T;
    mlr_sincos_quadrant(r, kbits, s_out, c_out);
}

/* s[i] = sin(x[i] degrees), c[i] = cos(x[i] degrees) for i < n. x must not overlap s or c. */
static inline void mlr_sincosd_array(const double *restrict x, size_t n, double *restrict s,
                                     double *restrict c)
{
    int big = 0;
    for (size_t i = 0; i < n; i++)
        big |= !(fabs(x[i]) < MLR_SINCOSD_LIMIT);
    if (!big) {
        for (size_t i = 0; i < n; i++)
            mlr_sincosd_kernel(x[i], s + i, c + i);
        return;
    }
    for (size_t i = 0; i < n; i++)
        mlr_sincosd_kernel(fabs(x[i]) < MLR_SINCOSD_LIMIT ? x[i] : fmod(x[i], 360.0), s + i,
                           c + i);
}

#endif
