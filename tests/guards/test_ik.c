/* Two-bone IK (mlr_ik.h): random legs reach reachable targets exactly with the knee bent
 * forward about the hinge and bone lengths kept, unreachable targets stop on the hip-target line
 * at max extension (or at the fold), leg chains skip zero-length bones (against a plain walk
 * over rest positions), apply_leg through forward kinematics; bad input. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double dot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static double nrm(const double *a) { return sqrt(dot(a, a)); }
static void crs(const double *a, const double *b, double *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1], o[1] = a[2] * b[0] - a[0] * b[2],
    o[2] = a[0] * b[1] - a[1] * b[0];
}
static void sub(const double *a, const double *b, double *o)
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
/* rotate v by unit quaternion q, written out as the matrix (independent of the library's form) */
static void qrot(const double *q, const double *v, double *o)
{
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    const double m[9] = {
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
        2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
    for (int i = 0; i < 3; i++)
        o[i] = m[3 * i] * v[0] + m[3 * i + 1] * v[1] + m[3 * i + 2] * v[2];
}
static void rand_unit(mlr_test_rng *r, double *v)
{
    do {
        for (int k = 0; k < 3; k++)
            v[k] = mlr_test_rng_normal(r);
    } while (nrm(v) < 1e-3);
    const double n = nrm(v);
    v[0] /= n, v[1] /= n, v[2] /= n;
}

/* A random bent leg: hip a, knee b, end c, hinge n (unit, perpendicular to the thigh and shin),
   the knee's interior angle in (lo, hi) radians, bent forward: cross(c - b, a - b) along n. */
static void random_leg(mlr_test_rng *r, double *a, double *b, double *c, double *n, double *l1,
                       double *l2, double lo, double hi)
{
    double u[3], t[3];
    for (int k = 0; k < 3; k++)
        a[k] = 10.0 * (mlr_test_rng_uniform(r) - 0.5);
    *l1 = 0.5 + 1.5 * mlr_test_rng_uniform(r), *l2 = 0.5 + 1.5 * mlr_test_rng_uniform(r);
    rand_unit(r, u); /* thigh direction, knee -> hip is -u */
    do {
        rand_unit(r, t);
        crs(u, t, n);
    } while (nrm(n) < 0.1);
    const double nn = nrm(n);
    n[0] /= nn, n[1] /= nn, n[2] /= nn;
    for (int k = 0; k < 3; k++)
        b[k] = a[k] + *l1 * u[k];
    /* shin: the direction -u (toward the hip) turned by -theta about n (interior angle theta) */
    const double theta = lo + (hi - lo) * mlr_test_rng_uniform(r);
    const double h = -0.5 * theta, q[4] = {cos(h), sin(h) * n[0], sin(h) * n[1], sin(h) * n[2]};
    const double mu[3] = {-u[0], -u[1], -u[2]};
    double s[3];
    qrot(q, mu, s);
    for (int k = 0; k < 3; k++)
        c[k] = b[k] + *l2 * s[k];
    double cb[3], ab[3], x[3];
    sub(c, b, cb);
    sub(a, b, ab);
    crs(cb, ab, x);
    ck_assert(dot(x, n) > 0.0); /* the construction is bent forward */
}

/* The solved leg: new knee and end positions from the deltas (hip fixed). */
static void solved(const double *a, const double *b, const double *c, const double *rh,
                   const double *rk, double *b2, double *c2)
{
    double ab[3], bc[3], t[3], t2[3];
    sub(b, a, ab);
    sub(c, b, bc);
    qrot(rh, ab, t);
    qrot(rk, bc, t2);
    double t3[3];
    qrot(rh, t2, t3);
    for (int k = 0; k < 3; k++)
        b2[k] = a[k] + t[k], c2[k] = b2[k] + t3[k];
}

static double interior(const double *a, const double *b, const double *c)
{
    double x[3], y[3];
    sub(a, b, x);
    sub(c, b, y);
    double cr[3];
    crs(x, y, cr);
    return atan2(nrm(cr), dot(x, y));
}

START_TEST(reachable_targets_are_reached_with_lengths_kept_and_the_knee_forward)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 1801);
    enum { N = 400 };
    double *A = malloc(sizeof(double) * 3 * N * 5), *B = A + 3 * N, *Cc = B + 3 * N,
           *T = Cc + 3 * N, *Ax = T + 3 * N;
    double *RH = malloc(sizeof(double) * 8 * N), *RK = RH + 4 * N;
    double L1[N], L2[N], D[N];
    for (size_t f = 0; f < N; f++) {
        random_leg(&r, A + 3 * f, B + 3 * f, Cc + 3 * f, Ax + 3 * f, &L1[f], &L2[f], 0.3, 3.0);
        const double lo = fabs(L1[f] - L2[f]) + 0.01, hi = 0.999 * (L1[f] + L2[f]);
        D[f] = lo + (hi - lo) * mlr_test_rng_uniform(&r);
        double u[3];
        rand_unit(&r, u);
        for (int k = 0; k < 3; k++)
            T[3 * f + k] = A[3 * f + k] + D[f] * u[k];
    }
    mlr_diag d;
    for (int with_axis = 0; with_axis < 2; with_axis++) {
        ck_assert_int_eq(mlr_ik_two_bone(N, A, B, Cc, T, with_axis ? Ax : NULL,
                                         MLR_IK_MAX_EXTENSION, RH, RK, &d),
                         MLR_OK);
        for (size_t f = 0; f < N; f++) {
            const double *a = A + 3 * f, *t = T + 3 * f, *n = Ax + 3 * f;
            double b2[3], c2[3], e[3];
            for (int q = 0; q < 2; q++) {
                const double *qq = q ? RK + 4 * f : RH + 4 * f;
                ck_assert_double_eq_tol(
                    qq[0] * qq[0] + qq[1] * qq[1] + qq[2] * qq[2] + qq[3] * qq[3], 1.0, 1e-12);
            }
            solved(a, B + 3 * f, Cc + 3 * f, RH + 4 * f, RK + 4 * f, b2, c2);
            sub(c2, t, e);
            ck_assert_msg(nrm(e) < 1e-9, "frame %zu: end misses the target by %g", f, nrm(e));
            double x[3];
            sub(b2, a, x);
            ck_assert_double_eq_tol(nrm(x), L1[f], 1e-12);
            sub(c2, b2, x);
            ck_assert_double_eq_tol(nrm(x), L2[f], 1e-12);
            /* reference: the law of cosines gives the interior knee angle */
            const double ref =
                acos((L1[f] * L1[f] + L2[f] * L2[f] - D[f] * D[f]) / (2.0 * L1[f] * L2[f]));
            ck_assert_double_eq_tol(interior(a, b2, c2), ref, 1e-8);
            /* r_knee turns about the hinge (its vector part is along n) */
            const double *rk = RK + 4 * f;
            double cr[3];
            crs(rk + 1, n, cr);
            ck_assert_msg(nrm(cr) < 1e-12, "frame %zu: r_knee not about the hinge", f);
            /* bent forward about the hinge carried by the hip's turn */
            double n2[3], cb[3], ab[3];
            qrot(RH + 4 * f, n, n2);
            sub(c2, b2, cb);
            sub(a, b2, ab);
            crs(cb, ab, cr);
            ck_assert_msg(dot(cr, n2) > 0.0, "frame %zu: knee bent backwards", f);
        }
    }
    /* a target at the current distance leaves the forward-bent knee unchanged */
    for (size_t f = 0; f < N; f++) {
        double ac[3];
        sub(Cc + 3 * f, A + 3 * f, ac);
        for (int k = 0; k < 3; k++)
            T[3 * f + k] = Cc[3 * f + k];
    }
    ck_assert_int_eq(mlr_ik_two_bone(N, A, B, Cc, T, Ax, MLR_IK_MAX_EXTENSION, RH, RK, &d),
                     MLR_OK);
    for (size_t f = 0; f < N; f++) {
        ck_assert_double_eq_tol(fabs(RK[4 * f]), 1.0, 1e-12);
        ck_assert_double_eq_tol(fabs(RH[4 * f]), 1.0, 1e-12);
    }
    free(A);
    free(RH);
}
END_TEST

START_TEST(unreachable_targets_stop_on_the_hip_target_line)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 77);
    enum { N = 300 };
    double a[3 * N], b[3 * N], c[3 * N], n[3 * N], t[3 * N], rh[4 * N], rk[4 * N], L1[N], L2[N];
    const double ext = 0.95;
    for (size_t f = 0; f < N; f++) {
        random_leg(&r, a + 3 * f, b + 3 * f, c + 3 * f, n + 3 * f, &L1[f], &L2[f], 0.5, 2.5);
        double u[3];
        rand_unit(&r, u);
        /* every third frame too near (only a full fold would reach), the others too far */
        const double dist = f % 3 == 0 ? 0.5 * fabs(L1[f] - L2[f])
                                       : (1.0 + 2.0 * mlr_test_rng_uniform(&r)) * (L1[f] + L2[f]);
        for (int k = 0; k < 3; k++)
            t[3 * f + k] = a[3 * f + k] + dist * u[k];
    }
    mlr_diag d;
    ck_assert_int_eq(mlr_ik_two_bone(N, a, b, c, t, n, ext, rh, rk, &d), MLR_OK);
    for (size_t f = 0; f < N; f++) {
        double b2[3], c2[3], at[3], ac[3], cr[3];
        solved(a + 3 * f, b + 3 * f, c + 3 * f, rh + 4 * f, rk + 4 * f, b2, c2);
        sub(t + 3 * f, a + 3 * f, at);
        sub(c2, a + 3 * f, ac);
        crs(at, ac, cr);
        ck_assert_msg(nrm(cr) < 1e-9 * nrm(at) && dot(at, ac) > 0.0,
                      "frame %zu: end off the hip-target line", f);
        double ac0[3]; /* a leg already straighter than ext keeps its extension */
        sub(c + 3 * f, a + 3 * f, ac0);
        const double want =
            f % 3 == 0 ? fabs(L1[f] - L2[f]) : fmax(ext * (L1[f] + L2[f]), nrm(ac0));
        ck_assert_msg(fabs(nrm(ac) - want) < 1e-9, "frame %zu: end at %g from the hip, want %g", f,
                      nrm(ac), want);
    }
    /* a leg straighter than max_extension is not bent further */
    double A[3] = {0, 0, 0}, B[3] = {0, -1, 0}, Cc[3], T[3] = {0, -5, 0}, ax[3] = {1, 0, 0};
    const double ang = 0.01; /* nearly straight: |ac| / 2 = cos(ang / 2) > 0.95 */
    Cc[0] = 0, Cc[1] = -1 - cos(ang), Cc[2] = sin(ang);
    ck_assert_int_eq(mlr_ik_two_bone(1, A, B, Cc, T, ax, ext, rh, rk, &d), MLR_OK);
    double b2[3], c2[3], ac[3], ac0[3];
    solved(A, B, Cc, rh, rk, b2, c2);
    sub(c2, A, ac);
    sub(Cc, A, ac0);
    ck_assert_double_eq_tol(nrm(ac), nrm(ac0), 1e-12);
    ck_assert_double_eq_tol(ac[1] / nrm(ac), -1.0, 1e-12);
}
END_TEST

START_TEST(from_to_turns_u_onto_v)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 5);
    double u[3 * 4], v[3 * 4], q[4 * 4], o[3];
    for (int f = 0; f < 2; f++)
        rand_unit(&r, u + 3 * f), rand_unit(&r, v + 3 * f);
    for (int k = 0; k < 3; k++)
        u[6 + k] = u[k], v[6 + k] = -u[k], u[9 + k] = 0.0, v[9 + k] = v[k];
    ck_assert_int_eq(mlr_ik_from_to(4, u, v, q), MLR_OK);
    for (int f = 0; f < 3; f++) {
        qrot(q + 4 * f, u + 3 * f, o);
        for (int k = 0; k < 3; k++)
            ck_assert_double_eq_tol(o[k], v[3 * f + k], 1e-12);
    }
    ck_assert(q[12] == 1.0 && q[13] == 0.0 && q[14] == 0.0 &&
              q[15] == 0.0); /* zero vector: identity */
    ck_assert_int_eq(mlr_ik_from_to(1, NULL, v, q), MLR_E_INVALID_ARG);
}
END_TEST

/* reference: the nearest ancestor whose rest position differs from the joint's */
static int32_t ref_bone_parent(const int32_t *par, const double *rest, int32_t j)
{
    for (int32_t p = par[j]; p >= 0; p = par[p]) {
        double x[3];
        sub(rest + 3 * j, rest + 3 * p, x);
        if (nrm(x) > 1e-9)
            return p;
    }
    return -1;
}

START_TEST(leg_chains_skip_zero_length_bones)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 99);
    enum { J = 14 };
    int32_t par[J];
    double off[3 * J], rest[3 * J];
    const char *names[J] = {"j0", "j1", "j2", "j3",  "j4",  "j5",  "j6",
                            "j7", "j8", "j9", "j10", "j11", "j12", "j13"};
    int checked = 0, failed = 0;
    for (int trial = 0; trial < 200; trial++) {
        par[0] = -1;
        for (int j = 0; j < 3; j++)
            off[j] = 0.0;
        for (int j = 1; j < J; j++) {
            par[j] = (int32_t)(mlr_test_rng_u64(&r) % (uint64_t)j);
            const int zero = mlr_test_rng_uniform(&r) < 0.35;
            for (int k = 0; k < 3; k++)
                off[3 * j + k] = zero ? 0.0 : 0.2 + mlr_test_rng_uniform(&r);
        }
        for (int j = 0; j < J; j++)
            for (int k = 0; k < 3; k++)
                rest[3 * j + k] = off[3 * j + k] + (j ? rest[3 * par[j] + k] : 0.0);
        mlr_rig rig = {J, par, off, names, 0, NULL, 0, NULL, NULL};
        for (int32_t e = 0; e < J; e++) {
            const int32_t k = ref_bone_parent(par, rest, e);
            const int32_t h = k >= 0 ? ref_bone_parent(par, rest, k) : -1;
            int32_t hh = -7, kk = -7;
            mlr_diag d;
            const mlr_status st = mlr_ik_leg_chain(&rig, e, &hh, &kk, &d);
            if (h < 0) {
                ck_assert_int_eq(st, MLR_E_INVALID_ARG);
                ck_assert_ptr_nonnull(strstr(d.message, names[e]));
                failed++;
            } else {
                ck_assert_int_eq(st, MLR_OK);
                ck_assert_int_eq(kk, k);
                ck_assert_int_eq(hh, h);
                checked++;
            }
        }
    }
    ck_assert_int_gt(checked, 100);
    ck_assert_int_gt(failed, 100);
    /* CMU-like: Hips -> LHipJoint (zero) -> LeftUpLeg -> LeftLeg -> LeftFoot */
    const int32_t p5[5] = {-1, 0, 1, 2, 3};
    const double o5[15] = {0, 0, 0, 0, 0, 0, 1, -1, 0, 0, -4, 0, 0, -4, 0};
    const char *n5[5] = {"Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot"};
    mlr_rig cmu = {5, p5, o5, n5, 0, NULL, 0, NULL, NULL};
    int32_t h, k;
    mlr_diag d;
    ck_assert_int_eq(mlr_ik_leg_chain(&cmu, 4, &h, &k, &d), MLR_OK);
    ck_assert_int_eq(h, 2);
    ck_assert_int_eq(k, 3);
    ck_assert_int_eq(mlr_ik_leg_chain(&cmu, 2, &h, &k, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "'LeftUpLeg'"));
    ck_assert_ptr_nonnull(strstr(d.message, "two-bone chain"));
    cmu.names = NULL;
    ck_assert_int_eq(mlr_ik_leg_chain(&cmu, 2, &h, &k, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "joint 2"));
    ck_assert_int_eq(mlr_ik_leg_chain(&cmu, 5, &h, &k, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "outside [0, 5)"));
    ck_assert_int_eq(mlr_ik_leg_chain(&cmu, -1, &h, &k, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_ik_leg_chain(&cmu, 4, NULL, &k, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL output"));
    ck_assert_int_eq(mlr_ik_leg_chain(NULL, 4, &h, &k, &d), MLR_E_INVALID_ARG);
}
END_TEST

START_TEST(apply_leg_moves_the_end_onto_the_target_through_fk)
{
    /* root -> pelvis twist -> hip -> knee -> ankle, random local rotations */
    const int32_t par[5] = {-1, 0, 1, 2, 3};
    const double off[15] = {0, 0, 0, 0.3, 0.1, 0, 0.2, -0.2, 0.05, 0, -4, 0, 0, -3.5, 0};
    enum { N = 60, J = 5 };
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 2024);
    double root[3 * N], rot[4 * N * J], pos[3 * N * J], wrot[4 * N * J], tgt[3 * N];
    for (size_t f = 0; f < N; f++) {
        for (int k = 0; k < 3; k++)
            root[3 * f + k] = mlr_test_rng_normal(&r);
        for (size_t j = 0; j < J; j++) {
            double *q = rot + 4 * (f * J + j), n = 0.0;
            if (j == 3) { /* the knee: a hinge about its local x, bent 0.3 to 2 rad */
                const double h = 0.5 * (0.3 + 1.7 * mlr_test_rng_uniform(&r));
                q[0] = cos(h), q[1] = sin(h), q[2] = q[3] = 0.0;
                continue;
            }
            q[0] = 3.0;
            for (int k = 1; k < 4; k++)
                q[k] = 0.6 * mlr_test_rng_normal(&r);
            for (int k = 0; k < 4; k++)
                n += q[k] * q[k];
            for (int k = 0; k < 4; k++)
                q[k] /= sqrt(n);
        }
    }
    ck_assert_int_eq(
        mlr_fk_arrays(N, J, par, off, root, rot, 0, NULL, NULL, pos, wrot, NULL, NULL), MLR_OK);
    double L1 = 0, L2 = 0, x[3];
    sub(off + 9, (double[3]){0, 0, 0}, x), L1 = nrm(x);
    sub(off + 12, (double[3]){0, 0, 0}, x), L2 = nrm(x);
    for (size_t f = 0; f < N; f++) {
        double u[3];
        rand_unit(&r, u);
        const double dist = fabs(L1 - L2) + 0.1 +
                            (0.99 * (L1 + L2) - fabs(L1 - L2) - 0.1) * mlr_test_rng_uniform(&r);
        for (int k = 0; k < 3; k++)
            tgt[3 * f + k] = pos[3 * (f * J + 2) + k] + dist * u[k];
    }
    mlr_diag d;
    ck_assert_int_eq(mlr_ik_apply_leg(N, J, par, rot, pos, wrot, 2, 3, 4, tgt, NULL, &d), MLR_OK);
    double pos2[3 * N * J], wrot2[4 * N * J];
    ck_assert_int_eq(
        mlr_fk_arrays(N, J, par, off, root, rot, 0, NULL, NULL, pos2, wrot2, NULL, NULL), MLR_OK);
    for (size_t f = 0; f < N; f++) {
        sub(pos2 + 3 * (f * J + 4), tgt + 3 * f, x);
        ck_assert_msg(nrm(x) < 1e-9, "frame %zu: the ankle misses by %g", f, nrm(x));
        for (size_t j = 0; j < 3; j++) { /* joints above the hip untouched */
            sub(pos2 + 3 * (f * J + j), pos + 3 * (f * J + j), x);
            ck_assert(nrm(x) < 1e-12);
        }
    }
    /* bad input */
    ck_assert_int_eq(mlr_ik_apply_leg(N, J, par, rot, pos, wrot, 3, 2, 4, tgt, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "is not a hip, knee, end chain"));
    ck_assert_int_eq(mlr_ik_apply_leg(N, J, par, rot, pos, wrot, 2, 3, 5, tgt, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "joint 5 outside [0, 5)"));
    tgt[7] = NAN;
    ck_assert_int_eq(mlr_ik_apply_leg(N, J, par, rot, pos, wrot, 2, 3, 4, tgt, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NaN"));
    ck_assert_int_eq(mlr_ik_apply_leg(N, J, par, NULL, pos, wrot, 2, 3, 4, tgt, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL array"));
    ck_assert_int_eq(mlr_ik_rotate_to(N, J, par, rot, wrot, 7, tgt, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "joint 7 outside"));
}
END_TEST

/* mlr_ik_two_bone solves its frames by vectorized batches (the slow frames, the hinge along
   the shin and the degenerate arcs, one by one): a batch of frames gives each the same bits as
   that frame alone (the batch's remainder path), with and without a bend axis, on random legs
   mixed with degenerate ones (the target on the hip, the shin along the hinge, the end on the
   hip, a target antiparallel to the leg). */
START_TEST(batches_give_each_frame_the_bits_it_gets_alone)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 1803);
    enum { N = 203 }; /* batches of 16 and a remainder */
    double *A = malloc(sizeof(double) * 3 * N * 5), *B = A + 3 * N, *Cc = B + 3 * N,
           *T = Cc + 3 * N, *X = T + 3 * N;
    double *rh = malloc(sizeof(double) * 4 * N * 4), *rk = rh + 4 * N, *rh1 = rk + 4 * N,
           *rk1 = rh1 + 4 * N;
    ck_assert_ptr_nonnull(A);
    ck_assert_ptr_nonnull(rh);
    for (size_t f = 0; f < N; f++) {
        double *a = A + 3 * f, *b = B + 3 * f, *c = Cc + 3 * f, *t = T + 3 * f, *n = X + 3 * f;
        double l1, l2;
        random_leg(&r, a, b, c, n, &l1, &l2, 0.3, 3.0);
        for (int k = 0; k < 3; k++)
            t[k] = a[k] + (l1 + l2) * (mlr_test_rng_uniform(&r) - 0.5);
        switch (f % 9) {
        case 1:
            memcpy(t, a, sizeof(double) * 3);
            break; /* target on the hip */
        case 3: /* the hinge along the shin */
            for (int k = 0; k < 3; k++)
                n[k] = c[k] - b[k];
            break;
        case 5:
            memcpy(c, a, sizeof(double) * 3);
            break; /* the end on the hip */
        case 7: /* the target straight behind the hip, away from the end */
            for (int k = 0; k < 3; k++)
                t[k] = a[k] - 3.0 * (c[k] - a[k]);
            break;
        default:
            break;
        }
    }
    for (int with_axis = 0; with_axis < 2; with_axis++) {
        const double *axis = with_axis ? X : NULL;
        ck_assert_int_eq(mlr_ik_two_bone(N, A, B, Cc, T, axis, 0.999, rh, rk, NULL), MLR_OK);
        for (size_t f = 0; f < N; f++)
            ck_assert_int_eq(mlr_ik_two_bone(1, A + 3 * f, B + 3 * f, Cc + 3 * f, T + 3 * f,
                                             axis ? axis + 3 * f : NULL, 0.999, rh1 + 4 * f,
                                             rk1 + 4 * f, NULL),
                             MLR_OK);
        ck_assert_mem_eq(rh, rh1, sizeof(double) * 4 * N);
        ck_assert_mem_eq(rk, rk1, sizeof(double) * 4 * N);
        for (size_t i = 0; i < 4 * N; i++)
            ck_assert(isfinite(rh[i]) && isfinite(rk[i]));
    }
    free(rh);
    free(A);
}
END_TEST

START_TEST(bad_input_gets_the_right_status_and_message)
{
    double a[3] = {0, 0, 0}, b[3] = {0, -1, 0}, c[3] = {0, -2, 0.5}, t[3] = {0, -1.5, 0};
    double rh[4], rk[4];
    mlr_diag d;
    ck_assert_int_eq(mlr_ik_two_bone(1, NULL, b, c, t, NULL, 0.99, rh, rk, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL array"));
    ck_assert_int_eq(mlr_ik_two_bone(1, a, b, c, t, NULL, 0.99, rh, NULL, &d), MLR_E_INVALID_ARG);
    const double bad_ext[4] = {0.0, -0.5, 1.5, NAN};
    for (int i = 0; i < 4; i++) {
        ck_assert_int_eq(mlr_ik_two_bone(1, a, b, c, t, NULL, bad_ext[i], rh, rk, &d),
                         MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "max_extension"));
    }
    ck_assert_int_eq(mlr_ik_two_bone(1, a, b, c, t, NULL, 1.0, rh, rk, &d), MLR_OK);
    const char *names[5] = {"hip", "knee", "end", "target", "bend_axis"};
    for (int i = 0; i < 5; i++) {
        double arr[5][3];
        memcpy(arr[0], a, sizeof a), memcpy(arr[1], b, sizeof b), memcpy(arr[2], c, sizeof c);
        memcpy(arr[3], t, sizeof t);
        arr[4][0] = 1, arr[4][1] = 0, arr[4][2] = 0;
        arr[i][1] = i % 2 ? INFINITY : NAN;
        ck_assert_int_eq(
            mlr_ik_two_bone(1, arr[0], arr[1], arr[2], arr[3], arr[4], 0.99, rh, rk, &d),
            MLR_E_INVALID_ARG);
        char want[64];
        snprintf(want, sizeof want, "two_bone: %s contains NaN", names[i]);
        ck_assert_ptr_nonnull(strstr(d.message, want));
    }
    ck_assert_int_eq(mlr_ik_two_bone(0, NULL, NULL, NULL, NULL, NULL, 0.5, NULL, NULL, &d),
                     MLR_OK);
    double ax[3];
    ck_assert_int_eq(mlr_ik_bend_axis_local(1, 1, a, rh, 0, 0, 1, ax, NULL), MLR_E_INVALID_ARG);
}
END_TEST

static Suite *ik_suite(void)
{
    Suite *s = suite_create("ik");
    TCase *tc = tcase_create("ik");
    tcase_add_test(tc, reachable_targets_are_reached_with_lengths_kept_and_the_knee_forward);
    tcase_add_test(tc, unreachable_targets_stop_on_the_hip_target_line);
    tcase_add_test(tc, from_to_turns_u_onto_v);
    tcase_add_test(tc, leg_chains_skip_zero_length_bones);
    tcase_add_test(tc, apply_leg_moves_the_end_onto_the_target_through_fk);
    tcase_add_test(tc, batches_give_each_frame_the_bits_it_gets_alone);
    tcase_add_test(tc, bad_input_gets_the_right_status_and_message);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(ik_suite()); }
