/* Twin tests: computations the library writes in two forms (a vectorized batch and the scalar
 * one frame at a time, or a hand-written ISA kernel and its baseline) compared, the library's
 * sources compiled in here so that the internal forms are in reach. Each runs on random inputs
 * mixed with degenerate ones, at every ISA level this CPU has (cpu__isa, common/cpu.h: the
 * baseline always), by the promise of common/cpu.h: bit for bit for the guards and the layers,
 * within a stated tolerance for clustering and the GRBF.
 * - two-bone IK: ik__two_bone_lanes (the batch the cleanup and mlr_ik_two_bone use) against
 *   ik__two_bone_1 (the one mlr_ik_apply_leg uses), frame by frame, on every frame the batch
 *   does not flag slow; and mlr_ik_two_bone (batch plus the slow frames' fallback) against
 *   ik__two_bone_1 on every frame.
 * - the limits blocks (limit_block: inside_block and the runs it passes over, the lazy angle):
 *   limits__apply_kind(_masked) and limits__apply_normalized against limit_joint frame by
 *   frame with its own unwrapping state, bit for bit, on a real clip pushed past its limits.
 * - displace_block (mlr_layers_synthesize): against base * exp(alpha v) (alpha v saturated
 *   below a half turn, quat__scale_turn) one quaternion at a time through the public
 *   quaternion functions, bit for bit.
 * - clustering (cluster.c): cluster__dist2 and cluster__nearest2 at every ISA level against the
 *   baseline: the same nearest centre except at a near tie, distances within 1e-12 relative;
 *   the fused online SOM step (cluster__packed_sweep) likewise, its moved centres within 1e-14.
 * - the GRBF product panel (grbf_panel.h): the AVX-512 panel against panel_generic, within
 *   1e-13 of the sum of the magnitudes of the terms.
 * - k-means++ (kmeans.c): with its triangle-inequality bounds against the plain search (no
 *   bound table), at every ISA level: the same centres, closest distances and labels, bit for
 *   bit. */
#include "mlr_test.h"

#include "common/common.c" /* common__diag_set, which ik.c reports through */
#include "guards/ik.c"
#define lane_min cluster_lane_min /* a static name of ik.c too */
#include "manifold/cluster.c"
#undef lane_min
#include "manifold/grbf_panel.h"
#define dot3 limits_dot3 /* static names of ik.c too */
#define norm3 limits_norm3
#include "guards/limits.c"
#undef dot3
#undef norm3
#include "common/options.c" /* what limits.c calls */
#undef DEG
#include "guards/limits_human.c"
#define norm3 quat_norm3
#include "math/quat.c"
#undef norm3
#include "common/parallel.c" /* what kmeans.c runs its tasks through */
#include "manifold/kmeans.c" /* kmeans_pp, with and without its bounds */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A random leg (hip a, knee b, end c, bend axis n, target t) at scale s, or one of the
   degenerate cases by k % 10. */
static void twin_leg(mlr_test_rng *r, size_t k, double s, double *a, double *b, double *c,
                     double *n, double *t)
{
    for (int i = 0; i < 3; i++) {
        a[i] = s * (mlr_test_rng_uniform(r) - 0.5);
        b[i] = a[i] + s * (mlr_test_rng_uniform(r) - 0.5);
        c[i] = b[i] + s * (mlr_test_rng_uniform(r) - 0.5);
        n[i] = s * mlr_test_rng_normal(r); /* at the leg's scale, as a bend axis is */
        t[i] = a[i] + 1.5 * s * (mlr_test_rng_uniform(r) - 0.5);
    }
    switch (k % 10) {
    case 1: /* the target on the hip */
        memcpy(t, a, 3 * sizeof(double));
        break;
    case 2: /* the hinge along the shin */
        for (int i = 0; i < 3; i++)
            n[i] = c[i] - b[i];
        break;
    case 3: /* the end on the hip */
        memcpy(c, a, 3 * sizeof(double));
        break;
    case 4: /* the target straight behind the hip, away from the end */
        for (int i = 0; i < 3; i++)
            t[i] = a[i] - 3.0 * (c[i] - a[i]);
        break;
    case 5: /* a zero-length thigh */
        memcpy(b, a, 3 * sizeof(double));
        break;
    case 6: /* the target on the end (reached as it is) */
        memcpy(t, c, 3 * sizeof(double));
        break;
    case 7: /* a straight leg, the target far beyond it */
        for (int i = 0; i < 3; i++)
            c[i] = b[i] + (b[i] - a[i]), t[i] = a[i] + 10.0 * (b[i] - a[i]);
        break;
    case 8: /* a zero bend axis */
        n[0] = n[1] = n[2] = 0.0;
        break;
    default:
        break;
    }
}

START_TEST(ik_lanes_give_the_bits_of_two_bone_1)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4040);
    const double scales[] = {1.0, 1e-6, 1e6};
    enum { N = 16 * 40 + 7 };
    double *buf = malloc(sizeof(double) * N * (5 * 3 + 4 * 4));
    ck_assert_ptr_nonnull(buf);
    double *A = buf, *B = A + 3 * N, *C = B + 3 * N, *X = C + 3 * N, *T = X + 3 * N;
    double *rh = T + 3 * N, *rk = rh + 4 * N, *rh1 = rk + 4 * N, *rk1 = rh1 + 4 * N;
    for (size_t si = 0; si < MLR_COUNTOF(scales); si++) {
        for (size_t f = 0; f < N; f++)
            twin_leg(&r, f, scales[si], A + 3 * f, B + 3 * f, C + 3 * f, X + 3 * f, T + 3 * f);
        for (int with_axis = 0; with_axis < 2; with_axis++) {
            const double *axis = with_axis ? X : NULL;
            size_t n_fast = 0;
            for (size_t f0 = 0; f0 < N; f0 += MLR_IK_LANES) {
                const size_t m = N - f0 < MLR_IK_LANES ? N - f0 : MLR_IK_LANES;
                mlr_ik_lanes L;
                for (size_t i = 0; i < m; i++)
                    for (int k = 0; k < 3; k++) {
                        const size_t q = 3 * (f0 + i) + (size_t)k;
                        L.a[k][i] = A[q], L.b[k][i] = B[q], L.c[k][i] = C[q], L.t[k][i] = T[q];
                        L.axis[k][i] = axis ? axis[q] : 0.0;
                    }
                ik__two_bone_lanes(&L, m, axis != NULL, MLR_IK_MAX_EXTENSION);
                for (size_t i = 0; i < m; i++) {
                    const size_t f = f0 + i;
                    double h1[4], k1[4];
                    ik__two_bone_1(A + 3 * f, B + 3 * f, C + 3 * f, T + 3 * f,
                                   axis ? axis + 3 * f : NULL, MLR_IK_MAX_EXTENSION, h1, k1);
                    if (L.slow[i])
                        continue;
                    n_fast++;
                    for (int k = 0; k < 4; k++) {
                        ck_assert_msg(memcmp(&L.r_hip[k][i], &h1[k], sizeof(double)) == 0,
                                      "scale %g axis %d frame %zu r_hip[%d]: %.17g vs %.17g",
                                      scales[si], with_axis, f, k, L.r_hip[k][i], h1[k]);
                        ck_assert_msg(memcmp(&L.r_knee[k][i], &k1[k], sizeof(double)) == 0,
                                      "scale %g axis %d frame %zu r_knee[%d]: %.17g vs %.17g",
                                      scales[si], with_axis, f, k, L.r_knee[k][i], k1[k]);
                    }
                }
            }
            /* the random legs (7 in 10, and some degenerate ones) take the batch */
            ck_assert_uint_ge(n_fast, N / 2);
            /* the public entry point: batch plus fallback, every frame as two_bone_1 */
            ck_assert_int_eq(
                mlr_ik_two_bone(N, A, B, C, T, axis, MLR_IK_MAX_EXTENSION, rh, rk, NULL), MLR_OK);
            for (size_t f = 0; f < N; f++)
                ik__two_bone_1(A + 3 * f, B + 3 * f, C + 3 * f, T + 3 * f,
                               axis ? axis + 3 * f : NULL, MLR_IK_MAX_EXTENSION, rh1 + 4 * f,
                               rk1 + 4 * f);
            ck_assert_mem_eq(rh, rh1, sizeof(double) * 4 * N);
            ck_assert_mem_eq(rk, rk1, sizeof(double) * 4 * N);
        }
    }
    free(buf);
}
END_TEST

/* ---- CPU dispatch ------------------------------------------------------------------------ */

START_TEST(cpu_levels_are_capped_and_forced)
{
    ck_assert_int_eq(cpu__isa(MLR_ISA_BASELINE), MLR_ISA_BASELINE);
    for (int most = MLR_ISA_BASELINE; most <= MLR_ISA_BEST; most++) {
        ck_assert_int_le(cpu__isa(most), most);
        ck_assert_int_ge(cpu__isa(MLR_ISA_BEST), cpu__isa(most));
    }
#ifdef MLR_FORCE_BASELINE
    ck_assert_int_eq(cpu__isa(MLR_ISA_BEST), MLR_ISA_BASELINE); /* the one switch */
#endif
    fprintf(stderr, "twins: this CPU runs ISA level %d of %d\n", cpu__isa(MLR_ISA_BEST),
            MLR_ISA_BEST);
}
END_TEST

/* ---- the limits blocks ------------------------------------------------------------------- */

/* limit_joint frame by frame along each joint of kind, each with its own unwrapping state: what
 * limit_block does with its fast paths (inside_block, the runs it passes over, the angle it
 * reads lazily). mask as limits__apply_kind_masked's (NULL: every frame). */
static void limits_reference(const mlr_limits *lim, size_t n, mlr_quat *rot, double alpha,
                             size_t *counts, int kind, const uint8_t *mask, int hard)
{
    const size_t J = lim->n_joints;
    for (size_t j = 0; j < J; j++) {
        const mlr_limits_joint *g = &lim->joints[j];
        if (g->range.kind != kind)
            continue;
        const joint_bounds b = bounds_of(lim, g, alpha, hard);
        prev_angle prev = {NAN, 0, {1, 0, 0, 0}, NULL};
        for (size_t f = 0; f < n; f++) {
            if (mask && !mask[f * J + j]) {
                prev = (prev_angle){NAN, 0, {1, 0, 0, 0}, NULL};
                continue;
            }
            if (limit_joint(g, &b, &rot[f * J + j], &prev) && counts)
                counts[j]++;
        }
    }
}

/* The clip's rotations with runs of 16 frames turned by random rotations (past the limits) and
 * degenerate ones: the identity, -q, half turns, a rotation repeated. */
static void limits_input(const mlr_quat *clip, size_t n, size_t J, mlr_test_rng *r, mlr_quat *q)
{
    for (size_t f = 0; f < n; f++) {
        const int run = (int)((f / 16) % 4); /* 0: as read, 1, 2: turned, 3: degenerate */
        for (size_t j = 0; j < J; j++) {
            const mlr_quat c = clip[f * J + j];
            mlr_quat *o = &q[f * J + j];
            if (run == 0) {
                *o = c;
            } else if (run < 3) {
                const mlr_vec3 v = {run * 0.5 * mlr_test_rng_normal(r),
                                    run * 0.5 * mlr_test_rng_normal(r),
                                    run * 0.5 * mlr_test_rng_normal(r)};
                mlr_quat e;
                mlr_quat_exp_array(&v, 1, &e, NULL);
                mlr_quat_mul(&c, &e, o);
            } else {
                switch ((f + j) % 5) {
                case 0:
                    *o = (mlr_quat){1, 0, 0, 0};
                    break;
                case 1:
                    *o = (mlr_quat){-c.w, -c.x, -c.y, -c.z};
                    break;
                case 2:
                    *o = (mlr_quat){0, 0, 1, 0};
                    break;
                case 3:
                    *o = (mlr_quat){0, c.x, c.y, c.z};
                    break; /* a half turn (or zero: below) */
                default:
                    *o = f > 0 ? q[(f - 1) * J + j] : c;
                    break;
                }
                const double n2 = o->w * o->w + o->x * o->x + o->y * o->y + o->z * o->z;
                if (n2 == 0.0)
                    *o = (mlr_quat){1, 0, 0, 0};
                else if (n2 != 1.0)
                    mlr_quat_normalize_array(o, 1, o, NULL);
            }
        }
    }
}

START_TEST(limits_blocks_give_the_bits_of_limit_joint)
{
    mlr_test_clip c;
    ck_assert(mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, &c));
    const size_t N = c.n, J = c.j;
    mlr_limits_clip lc = {N, mlr_motion_rot(c.m), mlr_motion_trans(c.m)};
    mlr_limits *lim = NULL;
    mlr_diag d;
    ck_assert_msg(mlr_limits_create(&c.rig, &lc, 1, NULL, 0, NULL, &lim, &d) == MLR_OK, "%s",
                  d.message);
    mlr_quat *in = malloc(sizeof(mlr_quat) * N * J * 3);
    size_t *cnt = calloc(2 * J, sizeof(size_t));
    uint8_t *mask = malloc(N * J);
    ck_assert(in && cnt && mask);
    mlr_quat *got = in + N * J, *want = got + N * J;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4041);
    limits_input((const mlr_quat *)(const void *)mlr_motion_rot(c.m), N, J, &r, in);
    for (size_t i = 0; i < N * J; i++)
        mask[i] = (i / J / 7 + i) % 3 != 0; /* runs of frames limited, others not */
    size_t limited = 0, seen = 0;
    const double alphas[] = {1.0, 2.5};
    for (size_t ai = 0; ai < MLR_COUNTOF(alphas); ai++)
        for (int masked = 0; masked < 2; masked++)
            for (int hard = 0; hard <= masked; hard++)
                for (int kind = MLR_LIMITS_HINGE; kind <= MLR_LIMITS_SWING_TWIST; kind++) {
                    const uint8_t *mk = masked ? mask : NULL;
                    memcpy(got, in, sizeof(mlr_quat) * N * J);
                    memcpy(want, in, sizeof(mlr_quat) * N * J);
                    memset(cnt, 0, 2 * J * sizeof(size_t));
                    limits__apply_kind_masked(lim, N, got, &alphas[ai], 1, cnt, kind, mk, NULL, 0,
                                              hard);
                    limits_reference(lim, N, want, alphas[ai], cnt + J, kind, mk, hard);
                    for (size_t i = 0; i < N * J; i++)
                        ck_assert_msg(memcmp(&got[i], &want[i], sizeof(mlr_quat)) == 0,
                                      "alpha %g masked %d hard %d kind %d frame %zu joint %zu: "
                                      "%.17g %.17g %.17g %.17g vs %.17g %.17g %.17g %.17g",
                                      alphas[ai], masked, hard, kind, i / J, i % J, got[i].w,
                                      got[i].x, got[i].y, got[i].z, want[i].w, want[i].x,
                                      want[i].y, want[i].z);
                    ck_assert_mem_eq(cnt, cnt + J, J * sizeof(size_t));
                    for (size_t j = 0; j < J; j++)
                        limited += cnt[j], seen += lim->joints[j].range.kind == kind ? N : 0;
                }
    /* both paths ran: many rotations limited, many left as they are */
    ck_assert_uint_gt(limited, seen / 50);
    ck_assert_uint_lt(limited, seen / 2);

    /* the fused path: normalized by blocks, the hinges then the swing-twist joints */
    for (size_t i = 0; i < N * J; i += 3) /* not unit: normalized first */
        in[i].w *= 1.5, in[i].x *= 1.5, in[i].y *= 1.5, in[i].z *= 1.5;
    for (size_t ai = 0; ai < MLR_COUNTOF(alphas); ai++) {
        memset(cnt, 0, 2 * J * sizeof(size_t));
        ck_assert_int_eq(
            limits__apply_normalized(lim, N, &in[0].w, &got[0].w, &alphas[ai], 1, cnt), MLR_OK);
        ck_assert_int_eq(quat__unit_array_isa(in, N * J, want, MLR_ISA_BASELINE), MLR_OK);
        for (int kind = MLR_LIMITS_HINGE; kind <= MLR_LIMITS_SWING_TWIST; kind++)
            limits_reference(lim, N, want, alphas[ai], cnt + J, kind, NULL, 0);
        ck_assert_mem_eq(got, want, sizeof(mlr_quat) * N * J);
        ck_assert_mem_eq(cnt, cnt + J, J * sizeof(size_t));
    }
    /* the near-unit kernel at every level: the same bits as the baseline */
    for (int isa = MLR_ISA_AVX2; isa <= cpu__isa(MLR_ISA_BEST); isa++) {
        ck_assert_int_eq(quat__unit_array_isa(in, N * J, got, isa), MLR_OK);
        ck_assert_int_eq(quat__unit_array_isa(in, N * J, want, MLR_ISA_BASELINE), MLR_OK);
        ck_assert_mem_eq(got, want, sizeof(mlr_quat) * N * J);
    }
    free(in), free(cnt), free(mask);
    mlr_limits_destroy(lim);
    mlr_test_clip_unload(&c);
}
END_TEST

/* ---- displace_block ---------------------------------------------------------------------- */

START_TEST(displace_block_gives_the_bits_of_one_at_a_time)
{
    mlr_test_clip c;
    ck_assert(mlr_test_clip_load(MLR_TEST_BUNDLED_CLIP, &c));
    const size_t N = c.n, J = c.j, ld = 3 * (1 + J);
    mlr_layers *L;
    mlr_diag d;
    const mlr_layers_option o = {MLR_LAYERS_OPT_FPS, c.fps};
    ck_assert_msg(mlr_layers_decompose(N, J, mlr_motion_root_pos(c.m), mlr_motion_rot(c.m), &o, 1,
                                       NULL, &L, &d) == MLR_OK,
                  "%s", d.message);
    double *base = malloc(sizeof(double) * 4 * N * J * 3), *ctl = malloc(sizeof(double) * ld * N);
    double *alpha = malloc(sizeof(double) * (1 + J));
    ck_assert(base && ctl && alpha);
    double *got = base + 4 * N * J, *want = got + 4 * N * J;
    ck_assert_int_eq(mlr_layers_get_base(L, NULL, 0, base, 4 * N * J), MLR_OK);
    ck_assert_int_eq(mlr_layers_get_control(L, ctl, ld * N), MLR_OK);
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4042);
    for (int trial = 0; trial < 4; trial++) {
        for (size_t g = 0; g <= J; g++) /* random, zero, negative, large (the slow exp) */
            alpha[g] = g % 7 == 3   ? 0.0
                       : g % 7 == 5 ? 40.0 * trial
                                    : 6.0 * (mlr_test_rng_uniform(&r) - 0.5);
        const size_t begin = trial == 3 ? N / 3 : 0, count = N - begin;
        ck_assert_int_eq(mlr_layers_synthesize(L, begin, count, alpha, 1 + J, NULL, 0, got,
                                               4 * count * J, NULL),
                         MLR_OK);
        for (size_t f = 0; f < count; f++)
            for (size_t k = 0; k < J; k++) {
                const double *v = ctl + (begin + f) * ld + 3 + 3 * k, ak = alpha[1 + k];
                const double *b = base + 4 * ((begin + f) * J + k);
                const mlr_vec3 av = quat__scale_turn((mlr_vec3){v[0], v[1], v[2]}, ak);
                mlr_quat e, q;
                mlr_quat_exp_array(&av, 1, &e, NULL);
                mlr_quat_mul((const mlr_quat *)(const void *)b, &e, &q);
                const double sgn =
                    q.w * b[0] + q.x * b[1] + q.y * b[2] + q.z * b[3] < 0.0 ? -1.0 : 1.0;
                double *w = want + 4 * (f * J + k);
                w[0] = sgn * q.w, w[1] = sgn * q.x, w[2] = sgn * q.y, w[3] = sgn * q.z;
            }
        for (size_t i = 0; i < count * J; i++)
            ck_assert_msg(memcmp(got + 4 * i, want + 4 * i, 4 * sizeof(double)) == 0,
                          "trial %d frame %zu joint %zu: %.17g vs %.17g", trial, i / J, i % J,
                          got[4 * i], want[4 * i]);
    }
    free(base), free(ctl), free(alpha);
    mlr_layers_destroy(L);
    mlr_test_clip_unload(&c);
}
END_TEST

/* ---- clustering and the GRBF --------------------------------------------------------------- */

START_TEST(cluster_kernels_agree_with_the_baseline)
{
    static const size_t dims[] = {1, 3, 7, 16, 33}, ks[] = {1, 5, 37, 70};
    enum { M = 61 };
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4043);
    const int top = cpu__isa(MLR_ISA_BEST);
    size_t n_checked = 0;
    for (size_t di = 0; di < MLR_COUNTOF(dims); di++)
        for (size_t ki = 0; ki < MLR_COUNTOF(ks); ki++) {
            const size_t dim = dims[di], k = ks[ki], kpad = cluster__packed_kpad(k);
            double *c = malloc(sizeof(double) * (k * dim + M * dim + kpad * dim + kpad + 4 * M));
            int32_t *ib = malloc(sizeof(int32_t) * 4 * M);
            ck_assert(c && ib);
            double *x = c + k * dim, *pc = x + M * dim, *cn = pc + kpad * dim, *db = cn + kpad;
            double *ds = db + M, *db0 = ds + M, *ds0 = db0 + M;
            int32_t *bi = ib, *si = bi + M, *bi0 = si + M, *si0 = bi0 + M;
            for (size_t i = 0; i < k * dim; i++)
                c[i] = 10.0 * mlr_test_rng_normal(&r);
            if (k > 2) /* an exact tie: the lowest index wins at every level */
                memcpy(c + 2 * dim, c + dim, dim * sizeof(double));
            for (size_t i = 0; i < M; i++)
                for (size_t t = 0; t < dim; t++)
                    x[i * dim + t] = i % 4 == 1   ? c[(i % k) * dim + t] /* on a centre */
                                     : i % 4 == 2 ? 0.5 * (c[t] + c[(k - 1) * dim + t])
                                                  : 12.0 * mlr_test_rng_normal(&r);
            mlr_packed p = {pc, cn, k, kpad, dim, MLR_ISA_BASELINE};
            cluster__packed_fill(&p, c, dim);
            cluster__nearest2(&p, x, dim, NULL, M, NULL, bi0, db0, ds0, si0);
            for (int isa = MLR_ISA_AVX2; isa <= top; isa++) {
                p.isa = isa;
                cluster__nearest2(&p, x, dim, NULL, M, NULL, bi, db, ds, si);
                for (size_t i = 0; i < M; i++) {
                    const double *xi = x + i * dim;
                    const double scale = cluster__norm2(xi, dim) + 400.0 * dim;
                    const double tol = 1e-12 * scale;
                    ck_assert_msg(fabs(db[i] - db0[i]) <= tol,
                                  "isa %d dim %zu k %zu row %zu: %.17g vs %.17g", isa, dim, k, i,
                                  db[i], db0[i]);
                    ck_assert_msg(k == 1 || fabs(ds[i] - ds0[i]) <= tol, "second: %.17g vs %.17g",
                                  ds[i], ds0[i]);
                    if (bi[i] != bi0[i]) /* only at a near tie */
                        ck_assert_msg(fabs(mlr_test_dist2(xi, c + (size_t)bi[i] * dim, dim) -
                                           mlr_test_dist2(xi, c + (size_t)bi0[i] * dim, dim)) <=
                                          tol,
                                      "isa %d row %zu: centre %d vs %d", isa, i, bi[i], bi0[i]);
                    /* and both the nearest by the naive distance */
                    double dmin = INFINITY;
                    for (size_t j = 0; j < k; j++) {
                        const double dj = mlr_test_dist2(xi, c + j * dim, dim);
                        dmin = dj < dmin ? dj : dmin;
                        const double e =
                            fabs(cluster__dist2(xi, c + j * dim, dim, isa) -
                                 cluster__dist2(xi, c + j * dim, dim, MLR_ISA_BASELINE));
                        ck_assert_msg(e <= 1e-13 * (dj + 1e-300), "dist2 isa %d: off by %g", isa,
                                      e);
                    }
                    ck_assert_msg(fabs(db[i] - dmin) <= tol, "row %zu: %.17g vs naive %.17g", i,
                                  db[i], dmin);
                    n_checked++;
                }
            }
            free(c), free(ib);
        }
    if (top >= MLR_ISA_AVX2)
        ck_assert_uint_gt(n_checked, 0);
}
END_TEST

START_TEST(som_sweep_agrees_with_the_baseline)
{
    static const size_t dims[] = {2, 9, 33}, ks[] = {16, 70, 200};
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4045);
    const int top = cpu__isa(MLR_ISA_BEST);
    for (size_t di = 0; di < MLR_COUNTOF(dims); di++)
        for (size_t ki = 0; ki < MLR_COUNTOF(ks); ki++) {
            const size_t dim = dims[di], k = ks[ki], kpad = cluster__packed_kpad(k),
                         nb = kpad / MLR_PACK;
            double *c = malloc(sizeof(double) *
                               (k * dim + 2 * dim + 2 * kpad * (dim + 1) + kpad + k * dim));
            unsigned char *active = malloc(nb);
            ck_assert(c && active);
            double *x = c + k * dim, *xnext = x + dim, *pc0 = xnext + dim, *pc1 = pc0 + kpad * dim;
            double *cn0 = pc1 + kpad * dim, *cn1 = cn0 + kpad, *h = cn1 + kpad, *moved = h + kpad;
            for (size_t i = 0; i < k * dim; i++)
                c[i] = 5.0 * mlr_test_rng_normal(&r);
            for (size_t t = 0; t < dim; t++)
                x[t] = 5.0 * mlr_test_rng_normal(&r), xnext[t] = 5.0 * mlr_test_rng_normal(&r);
            for (size_t b = 0; b < nb; b++) /* runs of inactive blocks (the 4-block path) */
                active[b] = (b / 5) % 2 == 0 && b % 5 != 3;
            for (size_t j = 0; j < kpad; j++)
                h[j] =
                    j < k && active[j / MLR_PACK] && j % 3 ? 0.5 * mlr_test_rng_uniform(&r) : 0.0;
            for (size_t j = 0; j < k; j++) /* the naive update */
                for (size_t t = 0; t < dim; t++)
                    moved[j * dim + t] = c[j * dim + t] + h[j] * (x[t] - c[j * dim + t]);
            mlr_packed p0 = {pc0, cn0, k, kpad, dim, MLR_ISA_BASELINE};
            cluster__packed_fill(&p0, c, dim);
            double v0, v1;
            const int32_t u0 = cluster__packed_sweep(&p0, x, h, active, xnext, 0, 1, &v0);
            double dmin = INFINITY;
            for (size_t j = 0; j < k; j++) {
                const double dj = mlr_test_dist2(xnext, moved + j * dim, dim);
                dmin = dj < dmin ? dj : dmin;
            }
            const double tol = 1e-12 * (cluster__norm2(xnext, dim) + 100.0 * dim);
            ck_assert_msg(fabs(mlr_test_dist2(xnext, moved + (size_t)u0 * dim, dim) - dmin) <= tol,
                          "baseline: unit %d is not the nearest", u0);
            for (int isa = MLR_ISA_AVX2; isa <= top; isa++) {
                mlr_packed p1 = {pc1, cn1, k, kpad, dim, isa};
                cluster__packed_fill(&p1, c, dim);
                const int32_t u1 = cluster__packed_sweep(&p1, x, h, active, xnext, 0, 1, &v1);
                for (size_t i = 0; i < kpad * dim; i++)
                    ck_assert_msg(fabs(pc1[i] - pc0[i]) <= 1e-14 * (fabs(pc0[i]) + 1.0),
                                  "isa %d dim %zu k %zu: centre value %zu %.17g vs %.17g", isa,
                                  dim, k, i, pc1[i], pc0[i]);
                for (size_t j = 0; j < k; j++)
                    ck_assert_msg(fabs(cn1[j] - cn0[j]) <= 1e-13 * cn0[j], "norm %zu", j);
                ck_assert_msg(fabs(v1 - v0) <= tol, "isa %d value %.17g vs %.17g", isa, v1, v0);
                if (u1 != u0) /* only at a near tie */
                    ck_assert_msg(fabs(mlr_test_dist2(xnext, moved + (size_t)u1 * dim, dim) -
                                       mlr_test_dist2(xnext, moved + (size_t)u0 * dim, dim)) <=
                                      tol,
                                  "isa %d unit %d vs %d", isa, u1, u0);
            }
            free(c), free(active);
        }
}
END_TEST

START_TEST(grbf_panel_agrees_with_the_generic_panel)
{
    static const size_t rows_[] = {1, 7, 8, 9, 17}, kcs[] = {1, 5, 64};
    const int wide = cpu__isa(MLR_ISA_BEST) >= MLR_ISA_AVX512;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4044);
    for (size_t ri = 0; ri < MLR_COUNTOF(rows_); ri++)
        for (size_t ki = 0; ki < MLR_COUNTOF(kcs); ki++) {
            const size_t rows = rows_[ri], kc = kcs[ki];
            double *a = malloc(sizeof(double) * (rows * kc + kc * PANEL + 4 * rows * PANEL));
            ck_assert_ptr_nonnull(a);
            double *b = a + rows * kc, *acc0 = b + kc * PANEL, *acc1 = acc0 + rows * PANEL;
            double *ref = acc1 + rows * PANEL, *mag = ref + rows * PANEL;
            for (size_t i = 0; i < rows * kc; i++)
                a[i] = i % 11 == 4 ? 0.0 : mlr_test_rng_normal(&r);
            for (size_t i = 0; i < kc * PANEL; i++)
                b[i] = i % 13 == 6 ? 1e8 : mlr_test_rng_normal(&r);
            for (size_t i = 0; i < rows * PANEL; i++)
                acc0[i] = acc1[i] = ref[i] = mlr_test_rng_normal(&r), mag[i] = fabs(ref[i]);
            for (size_t p = 0; p < rows; p++) /* the naive product, the generic panel's order */
                for (size_t k = 0; k < kc; k++)
                    for (size_t l = 0; l < PANEL; l++)
                        ref[p * PANEL + l] += a[p * kc + k] * b[k * PANEL + l],
                            mag[p * PANEL + l] += fabs(a[p * kc + k] * b[k * PANEL + l]);
            panel(0, a, kc, 1, rows, kc, b, PANEL, acc0, PANEL);
            ck_assert_mem_eq(acc0, ref, sizeof(double) * rows * PANEL);
            if (wide) {
                panel(1, a, kc, 1, rows, kc, b, PANEL, acc1, PANEL);
                for (size_t i = 0; i < rows * PANEL; i++)
                    ck_assert_msg(fabs(acc1[i] - acc0[i]) <= 1e-13 * mag[i],
                                  "rows %zu kc %zu element %zu: %.17g vs %.17g", rows, kc, i,
                                  acc1[i], acc0[i]);
            }
            free(a);
        }
}
END_TEST

/* k-means++ seeded the same way twice, without and with the bound table: clustered rows, exact
 * duplicates (rows whose closest distance becomes 0), coordinates over 12 orders of magnitude. */
static void pp_run(const double *x, size_t n, size_t d, size_t k, uint64_t seed, int isa,
                   int bounded, double *c, double *u, int32_t *lab)
{
    mlr_kmeans km;
    memset(&km, 0, sizeof km);
    km.n_threads = 3;
    fit_ws w;
    memset(&w, 0, sizeof w);
    w.km = &km;
    w.x = x;
    w.n = n;
    w.ldx = d;
    w.dim = d;
    w.k = k;
    w.u = u;
    w.lab = lab;
    w.c = c;
    w.l = malloc(n * sizeof(double));
    w.pinert = malloc(((n + PP_BLOCK - 1) / PP_BLOCK) * 32 * sizeof(double));
    w.ppd = bounded ? malloc(32 * k * sizeof(double)) : NULL;
    w.pk.isa = isa;
    mlr_rng rng;
    mlr_rng_seed(&rng, seed);
    kmeans_pp(&w, &rng);
    free(w.l);
    free(w.pinert);
    free(w.ppd);
}

START_TEST(kmeanspp_bounds_give_the_bits_of_the_plain_search)
{
    const size_t cases[][4] = {
        {5000, 7, 40, 1}, {2400, 93, 64, 2}, {640, 3, 80, 3}, {900, 2, 9, 4}};
    for (size_t q = 0; q < MLR_COUNTOF(cases); q++) {
        const size_t n = cases[q][0], d = cases[q][1], k = cases[q][2];
        mlr_test_rng r;
        mlr_test_rng_seed(&r, 100 + q);
        double *x = malloc(n * d * sizeof *x), *mu = malloc(12 * d * sizeof *mu);
        for (size_t t = 0; t < 12 * d; t++)
            mu[t] = 10.0 * mlr_test_rng_normal(&r);
        for (size_t i = 0; i < n; i++) {
            if (i % 5 == 4) { /* an exact duplicate of an earlier row */
                memcpy(x + i * d, x + (size_t)(mlr_test_rng_u64(&r) % i) * d, d * sizeof *x);
                continue;
            }
            const size_t j = (size_t)(mlr_test_rng_u64(&r) % 12);
            for (size_t t = 0; t < d; t++)
                x[i * d + t] =
                    (mu[j * d + t] + 0.3 * mlr_test_rng_normal(&r)) * (t % 3 == 0   ? 1e6
                                                                       : t % 3 == 1 ? 1.0
                                                                                    : 1e-6);
        }
        double *c0 = malloc(k * d * sizeof *c0), *c1 = malloc(k * d * sizeof *c1);
        double *u0 = malloc(n * sizeof *u0), *u1 = malloc(n * sizeof *u1);
        int32_t *l0 = malloc(n * sizeof *l0), *l1 = malloc(n * sizeof *l1);
        const int isas[] = {MLR_ISA_BASELINE, cpu__isa(MLR_ISA_BEST)};
        for (size_t s = 0; s < 2; s++) {
            pp_run(x, n, d, k, 7 + q, isas[s], 0, c0, u0, l0);
            pp_run(x, n, d, k, 7 + q, isas[s], 1, c1, u1, l1);
            ck_assert_msg(memcmp(c0, c1, k * d * sizeof *c0) == 0, "case %zu isa %d: centres", q,
                          isas[s]);
            ck_assert_msg(memcmp(u0, u1, n * sizeof *u0) == 0, "case %zu: distances", q);
            ck_assert_msg(memcmp(l0, l1, n * sizeof *l0) == 0, "case %zu: labels", q);
            /* the labels name the closest chosen centre, at the distance kept */
            size_t zeros = 0;
            for (size_t i = 0; i < n; i++) {
                ck_assert(l1[i] >= 0 && (size_t)l1[i] < k);
                ck_assert(cluster__dist2(x + i * d, c1 + (size_t)l1[i] * d, d, isas[s]) == u1[i]);
                zeros += u1[i] == 0;
            }
            ck_assert(zeros >= k); /* the chosen rows, and duplicates of them */
        }
        free(x);
        free(mu);
        free(c0);
        free(c1);
        free(u0);
        free(u1);
        free(l0);
        free(l1);
    }
}
END_TEST

static Suite *twins_suite(void)
{
    Suite *s = suite_create("twins");
    TCase *tc = tcase_create("twins");
    tcase_add_test(tc, cpu_levels_are_capped_and_forced);
    tcase_add_test(tc, ik_lanes_give_the_bits_of_two_bone_1);
    tcase_add_test(tc, limits_blocks_give_the_bits_of_limit_joint);
    tcase_add_test(tc, displace_block_gives_the_bits_of_one_at_a_time);
    tcase_add_test(tc, cluster_kernels_agree_with_the_baseline);
    tcase_add_test(tc, som_sweep_agrees_with_the_baseline);
    tcase_add_test(tc, grbf_panel_agrees_with_the_generic_panel);
    tcase_add_test(tc, kmeanspp_bounds_give_the_bits_of_the_plain_search);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(twins_suite()); }
