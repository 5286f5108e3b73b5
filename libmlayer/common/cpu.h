/* CPU dispatch: the one mechanism by which the C core runs wider vector code where the CPU has
 * it. The build assumes only the baseline ISA (x86-64: SSE2; elsewhere: the target's default).
 * Not installed.
 *
 * Two tools, one switch:
 *
 * 1. MLR_CLONES("avx512f", "avx2") before a function: the SAME source compiled once per ISA
 *    (GCC target_clones), the clone picked by the dynamic loader (ifunc). For loops the compiler
 *    vectorizes; there is no hand-written twin to keep in step.
 * 2. cpu__isa(most): the widest ISA level (MLR_ISA_*) this CPU runs, capped at most, for the
 *    hand-written kernels (intrinsics). A subject resolves it ONCE per call or per handle into a
 *    kernel table or an isa field (bvh_kernels_pick, mlr_packed.isa, grbf's wide flag) and passes
 *    the table down; the public functions pass MLR_ISA_BEST, the tests pass MLR_ISA_BASELINE too,
 *    so that every twin is compared with its baseline in one process (tests/test_twins.c).
 *
 * The switch that forces the baseline everywhere is the build option -Dforce_baseline=true
 * (MLR_FORCE_BASELINE): the clones are not made and cpu__isa answers MLR_ISA_BASELINE. Why not
 * an environment variable or an API call that sets a mode: that is global mutable state in a
 * library loaded into someone else's process (STYLE.md), read at an unknown time and racing
 * with calls on other threads. cpu__isa keeps no state of its own: it reads the feature bits
 * that libgcc/compiler-rt fill once, before main, in a constructor (__builtin_cpu_supports), so
 * it is a constant of the process, safe from every thread. The per-call cap is what tests use.
 *
 * The promise, per subject (what a test checks):
 * - the guards, the layers, forward kinematics, the rig, the quaternions, the band solves, the
 *   BVH reader: the same bits on every ISA. The clones run the same IEEE operations in the same
 *   order (ISO C, -ffp-contract=off: no FMA contraction, no reassociation), and the hand-written
 *   twins of these subjects (bvh_frames.c, quat.c's near-unit test) are written to the same
 *   order.
 * - clustering (k-means, the SOM: cluster.c) and the GRBF (grbf.c, grbf_lattice.c): the same
 *   result for the same input on one machine, whatever the threads; across ISAs within a
 *   tolerance (the AVX-512 kernels sum in another order and with fused multiply-adds), stated
 *   in tests/test_twins.c. A nearest centre may differ across ISAs only at a near tie. */
#ifndef MLR_CPU_H
#define MLR_CPU_H

/* x86 with GCC or Clang: the hand-written kernels with AVX2 or AVX-512 intrinsics exist (the
 * files that have them include <immintrin.h> under this). */
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define MLR_X86_DISPATCH 1
#endif

/* ISA levels, from the baseline up; each implies those below it. */
enum {
    MLR_ISA_BASELINE = 0, /* SSE2 on x86-64, the default ISA elsewhere */
    MLR_ISA_AVX2 = 1,     /* AVX2, FMA, BMI1/2, POPCNT (Haswell, Zen) */
    MLR_ISA_AVX512 = 2,   /* + AVX-512 F, BW, DQ, VL, CD (Skylake-X, Zen 4) */
    MLR_ISA_AVX512_VBMI2 = 3, /* + AVX-512 VBMI2 (Ice Lake, Zen 4) */
    MLR_ISA_BEST = MLR_ISA_AVX512_VBMI2
};

/* Compiler clones: GCC on x86-64 Linux (ifunc); not under ASan (its interceptors and ifuncs do
 * not mix); none when the baseline is forced. The arguments are target names of GCC's
 * target_clones ("avx2", "avx512f"); "default" is added. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(MLR_FORCE_BASELINE)
#define MLR_CLONES(...) __attribute__((target_clones(__VA_ARGS__, "default")))
#else
#define MLR_CLONES(...)
#endif

/* The widest level of MLR_ISA_* this CPU runs, at most most. Constant for the process, no
 * state, any thread; MLR_ISA_BASELINE when the baseline is forced or off x86. Resolve it once
 * per call (not per element): it tests several feature bits. */
static inline int cpu__isa(int most)
{
#if defined(MLR_X86_DISPATCH) && !defined(MLR_FORCE_BASELINE)
    int isa = MLR_ISA_BASELINE;
    if (most >= MLR_ISA_AVX2 && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
        __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2") &&
        __builtin_cpu_supports("popcnt"))
        isa = MLR_ISA_AVX2;
    if (isa == MLR_ISA_AVX2 && most >= MLR_ISA_AVX512 && __builtin_cpu_supports("avx512f") &&
        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
        __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512cd"))
        isa = MLR_ISA_AVX512;
    if (isa == MLR_ISA_AVX512 && most >= MLR_ISA_AVX512_VBMI2 &&
        __builtin_cpu_supports("avx512vbmi2"))
        isa = MLR_ISA_AVX512_VBMI2;
    return isa;
#else
    (void)most;
    return MLR_ISA_BASELINE;
#endif
}

#endif
