/* The product kernel of the GRBF evaluation (grbf.c) and of the lattice solves (grbf_lattice.c):
 * acc[p * lda + l] += sum_k a[p * sp + k * sk] b[k * ldb + l] for p < rows, l < 24 (PANEL),
 * k = 0 .. kc-1 in order. Static, so that each file that includes it gets its own copy, which
 * the compiler specializes for that file's strides (as when it lived in one file). Not
 * installed. */
#ifndef MLR_GRBF_PANEL_H
#define MLR_GRBF_PANEL_H

#include <stddef.h>
#include <string.h>

#include "common/cpu.h" /* MLR_X86_DISPATCH, cpu__isa */

#ifdef MLR_X86_DISPATCH
#include <immintrin.h>
#endif

#define PANEL 24

static void panel_generic(const double *a, size_t sp, size_t sk, size_t rows, size_t kc,
                          const double *b, size_t ldb, double *acc, size_t lda)
{
    for (size_t p = 0; p < rows; p++) {
        double s[PANEL];
        memcpy(s, acc + p * lda, sizeof s);
        for (size_t k = 0; k < kc; k++) {
            double v = a[p * sp + k * sk];
            const double *q = b + k * ldb;
            for (size_t l = 0; l < PANEL; l++)
                s[l] += v * q[l];
        }
        memcpy(acc + p * lda, s, sizeof s);
    }
}

#ifdef MLR_X86_DISPATCH
/* The same with fused multiply-adds: 8 rows x 24 columns in 24 registers, then single rows
 * (the same fma sequence per output). */
__attribute__((target("avx512f"))) static void panel_avx512(const double *a, size_t sp, size_t sk,
                                                            size_t rows, size_t kc,
                                                            const double *b, size_t ldb,
                                                            double *acc, size_t lda)
{
    size_t p0 = 0;
    for (; p0 + 8 <= rows; p0 += 8) {
        const double *ap = a + p0 * sp;
        double *o = acc + p0 * lda;
#define LOAD3(r)                                                                                \
    __m512d a##r##0 = _mm512_loadu_pd(o + r * lda), a##r##1 = _mm512_loadu_pd(o + r * lda + 8), \
            a##r##2 = _mm512_loadu_pd(o + r * lda + 16)
        LOAD3(0);
        LOAD3(1);
        LOAD3(2);
        LOAD3(3);
        LOAD3(4);
        LOAD3(5);
        LOAD3(6);
        LOAD3(7);
#undef LOAD3
        for (size_t k = 0; k < kc; k++) {
            const double *q = b + k * ldb, *ak = ap + k * sk;
            __m512d q0 = _mm512_loadu_pd(q), q1 = _mm512_loadu_pd(q + 8),
                    q2 = _mm512_loadu_pd(q + 16), v;
#define FMA3(r)                                \
    v = _mm512_set1_pd(ak[r * sp]);            \
    a##r##0 = _mm512_fmadd_pd(v, q0, a##r##0); \
    a##r##1 = _mm512_fmadd_pd(v, q1, a##r##1); \
    a##r##2 = _mm512_fmadd_pd(v, q2, a##r##2)
            FMA3(0);
            FMA3(1);
            FMA3(2);
            FMA3(3);
            FMA3(4);
            FMA3(5);
            FMA3(6);
            FMA3(7);
#undef FMA3
        }
#define STORE3(r)                               \
    _mm512_storeu_pd(o + r * lda, a##r##0);     \
    _mm512_storeu_pd(o + r * lda + 8, a##r##1); \
    _mm512_storeu_pd(o + r * lda + 16, a##r##2)
        STORE3(0);
        STORE3(1);
        STORE3(2);
        STORE3(3);
        STORE3(4);
        STORE3(5);
        STORE3(6);
        STORE3(7);
#undef STORE3
    }
    for (; p0 < rows; p0++) {
        const double *ap = a + p0 * sp;
        double *o = acc + p0 * lda;
        __m512d a0 = _mm512_loadu_pd(o), a1 = _mm512_loadu_pd(o + 8), a2 = _mm512_loadu_pd(o + 16);
        for (size_t k = 0; k < kc; k++) {
            const double *q = b + k * ldb;
            __m512d v = _mm512_set1_pd(ap[k * sk]);
            a0 = _mm512_fmadd_pd(v, _mm512_loadu_pd(q), a0);
            a1 = _mm512_fmadd_pd(v, _mm512_loadu_pd(q + 8), a1);
            a2 = _mm512_fmadd_pd(v, _mm512_loadu_pd(q + 16), a2);
        }
        _mm512_storeu_pd(o, a0);
        _mm512_storeu_pd(o + 8, a1);
        _mm512_storeu_pd(o + 16, a2);
    }
}
#endif

/* wide: 1 for the AVX-512 twin (the caller resolved cpu__isa once, grbf__cpu_wide), 0 for
 * panel_generic, its reference (tests/test_twins.c compares them). */
static void panel(int wide, const double *a, size_t sp, size_t sk, size_t rows, size_t kc,
                  const double *b, size_t ldb, double *acc, size_t lda)
{
#ifdef MLR_X86_DISPATCH
    if (wide) {
        panel_avx512(a, sp, sk, rows, kc, b, ldb, acc, lda);
        return;
    }
#endif
    (void)wide;
    panel_generic(a, sp, sk, rows, kc, b, ldb, acc, lda);
}

#endif
