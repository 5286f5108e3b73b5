/* Check suite for libmlayer/math/quat.c: invariants and small independent references
 * (explicit rotation matrices, Rodrigues' formula, slerp as a * exp(t log(conj(a) b))). */
#include "mlr_test.h"
#include "math/sincosd.h" /* private: the BVH reader's sine and cosine in degrees */

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static const char *const order_names[6] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};

/* ---------------------------------------------------------------- helpers, independent of quat.c */

static mlr_quat random_unit(mlr_test_rng *r)
{
    mlr_quat q;
    double n;
    do {
        q.w = mlr_test_rng_normal(r);
        q.x = mlr_test_rng_normal(r);
        q.y = mlr_test_rng_normal(r);
        q.z = mlr_test_rng_normal(r);
        n = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    } while (n < 1e-3);
    q.w /= n;
    q.x /= n;
    q.y /= n;
    q.z /= n;
    return q;
}

static mlr_vec3 random_axis(mlr_test_rng *r)
{
    mlr_quat q = random_unit(r);
    double n = sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    mlr_vec3 v = {q.x / n, q.y / n, q.z / n};
    return v;
}

static double dot4(const mlr_quat *a, const mlr_quat *b)
{
    return a->w * b->w + a->x * b->x + a->y * b->y + a->z * b->z;
}

static double norm4(const mlr_quat *q) { return sqrt(dot4(q, q)); }

/* Angle of the rotation that takes b to a (0 when they are the same rotation, sign ignored). */
static double rot_dist(const mlr_quat *a, const mlr_quat *b)
{
    double s = dot4(a, b) < 0.0 ? -1.0 : 1.0;
    double dw = a->w - s * b->w, dx = a->x - s * b->x, dy = a->y - s * b->y, dz = a->z - s * b->z;
    double pw = a->w + s * b->w, px = a->x + s * b->x, py = a->y + s * b->y, pz = a->z + s * b->z;
    return 4.0 * atan2(sqrt(dw * dw + dx * dx + dy * dy + dz * dz),
                       sqrt(pw * pw + px * px + py * py + pz * pz));
}

static void quat_close(const mlr_quat *a, const mlr_quat *b, double tol)
{
    ck_assert_close(a->w, b->w, tol);
    ck_assert_close(a->x, b->x, tol);
    ck_assert_close(a->y, b->y, tol);
    ck_assert_close(a->z, b->z, tol);
}

typedef double mat3[3][3];

/* Rotation matrix of a unit quaternion (textbook formula). */
static void quat_matrix(const mlr_quat *q, mat3 m)
{
    double w = q->w, x = q->x, y = q->y, z = q->z;
    m[0][0] = 1 - 2 * (y * y + z * z);
    m[0][1] = 2 * (x * y - w * z);
    m[0][2] = 2 * (x * z + w * y);
    m[1][0] = 2 * (x * y + w * z);
    m[1][1] = 1 - 2 * (x * x + z * z);
    m[1][2] = 2 * (y * z - w * x);
    m[2][0] = 2 * (x * z - w * y);
    m[2][1] = 2 * (y * z + w * x);
    m[2][2] = 1 - 2 * (x * x + y * y);
}

/* Elementary rotation about axis 0 (X), 1 (Y) or 2 (Z). */
static void axis_matrix(int axis, double a, mat3 m)
{
    double c = cos(a), s = sin(a);
    memset(m, 0, sizeof(mat3));
    int i = (axis + 1) % 3, j = (axis + 2) % 3;
    m[axis][axis] = 1.0;
    m[i][i] = c;
    m[j][j] = c;
    m[j][i] = s;
    m[i][j] = -s;
}

static void mat_mul(mat3 a, mat3 b, mat3 out)
{
    mat3 t;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            t[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    memcpy(out, t, sizeof t);
}

static int order_axis(int order, int k)
{
    char c = order_names[order][k];
    return c - 'X';
}

/* R = R_{axis0}(a0) R_{axis1}(a1) R_{axis2}(a2): intrinsic order, the reference for from_euler. */
static void euler_matrix(int order, const double *a, mat3 m)
{
    mat3 r;
    axis_matrix(order_axis(order, 0), a[0], m);
    axis_matrix(order_axis(order, 1), a[1], r);
    mat_mul(m, r, m);
    axis_matrix(order_axis(order, 2), a[2], r);
    mat_mul(m, r, m);
}

/* Rodrigues: rotate p by the rotation vector v. */
static mlr_vec3 rodrigues(mlr_vec3 v, mlr_vec3 p)
{
    double th = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (th == 0.0)
        return p;
    double kx = v.x / th, ky = v.y / th, kz = v.z / th;
    double c = cos(th), s = sin(th);
    double cx = ky * p.z - kz * p.y, cy = kz * p.x - kx * p.z, cz = kx * p.y - ky * p.x;
    double kd = kx * p.x + ky * p.y + kz * p.z;
    mlr_vec3 out = {p.x * c + cx * s + kx * kd * (1 - c), p.y * c + cy * s + ky * kd * (1 - c),
                    p.z * c + cz * s + kz * kd * (1 - c)};
    return out;
}

/* ---------------------------------------------------------------- products */

START_TEST(mul_identity_and_associativity)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 1);
    const mlr_quat id = {1, 0, 0, 0};
    for (int n = 0; n < 200; n++) {
        mlr_quat a = random_unit(&r), b = random_unit(&r), c = random_unit(&r);
        mlr_quat t, ab, bc, l, rr;
        mlr_quat_mul(&a, &id, &t);
        quat_close(&t, &a, 0.0);
        mlr_quat_mul(&id, &a, &t);
        quat_close(&t, &a, 0.0);
        mlr_quat_mul(&a, &b, &ab);
        mlr_quat_mul(&ab, &c, &l);
        mlr_quat_mul(&b, &c, &bc);
        mlr_quat_mul(&a, &bc, &rr);
        quat_close(&l, &rr, 1e-15);
        ck_assert_close(norm4(&ab), 1.0, 1e-15);
    }
}
END_TEST

START_TEST(mul_matches_matrix_product)
{
    /* Hamilton convention: R(a b) = R(a) R(b). */
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 2);
    for (int n = 0; n < 100; n++) {
        mlr_quat a = random_unit(&r), b = random_unit(&r), ab;
        mat3 ma, mb, mab;
        mlr_quat_mul(&a, &b, &ab);
        quat_matrix(&a, ma);
        quat_matrix(&b, mb);
        mat_mul(ma, mb, ma);
        quat_matrix(&ab, mab);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                ck_assert_close(mab[i][j], ma[i][j], 1e-14);
    }
    /* i j = k */
    mlr_quat i = {0, 1, 0, 0}, j = {0, 0, 1, 0}, k;
    mlr_quat_mul(&i, &j, &k);
    ck_assert(k.w == 0 && k.x == 0 && k.y == 0 && k.z == 1);
}
END_TEST

START_TEST(mul_array_aliases)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 3);
    mlr_quat a[16], b[16], ref[16], c[16];
    for (int n = 0; n < 16; n++) {
        a[n] = random_unit(&r);
        b[n] = random_unit(&r);
        mlr_quat_mul(&a[n], &b[n], &ref[n]);
    }
    memcpy(c, a, sizeof a);
    mlr_quat_mul_array(c, b, 16, c); /* out == a */
    for (int n = 0; n < 16; n++)
        quat_close(&c[n], &ref[n], 0.0);
    memcpy(c, b, sizeof b);
    mlr_quat_mul_array(a, c, 16, c); /* out == b */
    for (int n = 0; n < 16; n++)
        quat_close(&c[n], &ref[n], 0.0);
    mlr_quat_mul_array(NULL, b, 16, c); /* no-op, no crash */
}
END_TEST

START_TEST(conj_is_inverse)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4);
    mlr_quat q[32], qc[32], p[32];
    const mlr_quat id = {1, 0, 0, 0};
    for (int n = 0; n < 32; n++)
        q[n] = random_unit(&r);
    mlr_quat_conj_array(q, 32, qc);
    mlr_quat_mul_array(q, qc, 32, p);
    for (int n = 0; n < 32; n++)
        quat_close(&p[n], &id, 1e-15);
    mlr_quat_mul_array(qc, q, 32, p);
    for (int n = 0; n < 32; n++)
        quat_close(&p[n], &id, 1e-15);
    mlr_quat_conj_array(qc, 32, qc); /* in place: conj(conj(q)) = q */
    for (int n = 0; n < 32; n++)
        quat_close(&qc[n], &q[n], 0.0);
}
END_TEST

START_TEST(rotate_matches_sandwich)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 5);
    for (int n = 0; n < 100; n++) {
        mlr_quat q = random_unit(&r), qc = {q.w, -q.x, -q.y, -q.z}, t;
        mlr_vec3 v = {mlr_test_rng_normal(&r), mlr_test_rng_normal(&r), mlr_test_rng_normal(&r)};
        mlr_quat pv = {0, v.x, v.y, v.z};
        mlr_quat_mul(&q, &pv, &t);
        mlr_quat_mul(&t, &qc, &t);
        mlr_quat_rotate(&q, &v, &v); /* out aliases v */
        ck_assert_close(v.x, t.x, 1e-14);
        ck_assert_close(v.y, t.y, 1e-14);
        ck_assert_close(v.z, t.z, 1e-14);
    }
}
END_TEST

START_TEST(normalize_unit_and_in_place)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 6);
    mlr_quat q[64], u[64];
    static const double scale[] = {1.0, 1e-200, 1e200, 3.5, 1e-310};
    for (int n = 0; n < 64; n++) {
        q[n] = random_unit(&r);
        double s = scale[n % MLR_COUNTOF(scale)];
        u[n] = q[n];
        q[n].w *= s;
        q[n].x *= s;
        q[n].y *= s;
        q[n].z *= s;
    }
    ck_assert_int_eq(mlr_quat_normalize_array(q, 64, q, NULL), MLR_OK);
    for (int n = 0; n < 64; n++) {
        ck_assert_close(norm4(&q[n]), 1.0, 1e-15);
        /* the subnormal scale loses digits in the input itself */
        quat_close(&q[n], &u[n], n % 5 == 4 ? 1e-9 : 1e-15);
    }
}
END_TEST

/* ---------------------------------------------------------------- exp and log */

START_TEST(exp_matches_rodrigues)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 7);
    for (int n = 0; n < 200; n++) {
        mlr_vec3 ax = random_axis(&r);
        double th = 3.0 * PI * mlr_test_rng_uniform(&r); /* beyond pi too */
        mlr_vec3 v = {ax.x * th, ax.y * th, ax.z * th};
        mlr_vec3 p = {mlr_test_rng_normal(&r), mlr_test_rng_normal(&r), mlr_test_rng_normal(&r)};
        mlr_quat q;
        ck_assert_int_eq(mlr_quat_exp_array(&v, 1, &q, NULL), MLR_OK);
        ck_assert_close(norm4(&q), 1.0, 1e-15);
        mlr_vec3 a = rodrigues(v, p), b;
        mlr_quat_rotate(&q, &p, &b);
        ck_assert_close(a.x, b.x, 1e-13);
        ck_assert_close(a.y, b.y, 1e-13);
        ck_assert_close(a.z, b.z, 1e-13);
    }
    mlr_vec3 zero = {0, 0, 0};
    mlr_quat q;
    ck_assert_int_eq(mlr_quat_exp_array(&zero, 1, &q, NULL), MLR_OK);
    ck_assert(q.w == 1 && q.x == 0 && q.y == 0 && q.z == 0);
}
END_TEST

/* Angles for the round trip, with the relative accuracy asked of log(exp(v)). */
static const struct {
    double angle, rel_tol;
} round_trip_angles[] = {
    {0.0, 0.0},         {1e-300, 1e-15},    {1e-12, 1e-15},      {1e-9, 1e-15}, {1e-6, 1e-15},
    {1e-4, 1e-15},      {0.3, 1e-15},       {1.0, 1e-15},        {2.5, 1e-15},  {PI - 1e-3, 1e-15},
    {PI - 1e-6, 1e-15}, {PI - 1e-9, 1e-15}, {PI - 1e-12, 1e-15},
};

START_TEST(log_exp_round_trip)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 8 + (uint64_t)_i);
    const double th = round_trip_angles[_i].angle, tol = round_trip_angles[_i].rel_tol;
    for (int n = 0; n < 50; n++) {
        mlr_vec3 ax = random_axis(&r);
        mlr_vec3 v = {ax.x * th, ax.y * th, ax.z * th}, back;
        mlr_quat q;
        ck_assert_int_eq(mlr_quat_exp_array(&v, 1, &q, NULL), MLR_OK);
        ck_assert_int_eq(mlr_quat_log_array(&q, 1, &back, NULL), MLR_OK);
        /* relative to the angle, plus 2 ulp of pi where w is rounded near the pole */
        double t = tol * th * 2.0 + (th > 3.0 ? 1e-15 : 0.0);
        ck_assert_close(back.x, v.x, t);
        ck_assert_close(back.y, v.y, t);
        ck_assert_close(back.z, v.z, t);
        /* log(-q) = log(q) */
        mlr_quat mq = {-q.w, -q.x, -q.y, -q.z};
        mlr_vec3 back2;
        ck_assert_int_eq(mlr_quat_log_array(&mq, 1, &back2, NULL), MLR_OK);
        ck_assert(back2.x == back.x && back2.y == back.y && back2.z == back.z);
    }
}
END_TEST

START_TEST(exp_log_round_trip_on_quaternions)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 9);
    mlr_quat q[256], back[256];
    mlr_vec3 v[256];
    for (int n = 0; n < 256; n++)
        q[n] = random_unit(&r);
    ck_assert_int_eq(mlr_quat_log_array(q, 256, v, NULL), MLR_OK);
    for (int n = 0; n < 256; n++) {
        double th = sqrt(v[n].x * v[n].x + v[n].y * v[n].y + v[n].z * v[n].z);
        ck_assert(th <= PI);
    }
    ck_assert_int_eq(mlr_quat_exp_array(v, 256, back, NULL), MLR_OK);
    for (int n = 0; n < 256; n++)
        ck_assert_msg(rot_dist(&q[n], &back[n]) < 1e-14, "n = %d: %g", n,
                      rot_dist(&q[n], &back[n]));
    /* log of a slightly unnormalized q is the log of its rotation */
    mlr_quat s = {q[0].w * 1.001, q[0].x * 1.001, q[0].y * 1.001, q[0].z * 1.001};
    mlr_vec3 vs;
    ck_assert_int_eq(mlr_quat_log_array(&s, 1, &vs, NULL), MLR_OK);
    ck_assert_close(vs.x, v[0].x, 1e-15);
    ck_assert_close(vs.y, v[0].y, 1e-15);
    ck_assert_close(vs.z, v[0].z, 1e-15);
}
END_TEST

START_TEST(log_at_pi)
{
    mlr_quat q = {0, 0, 0, 1}, mq = {0, 0, 0, -1};
    mlr_vec3 v;
    ck_assert_int_eq(mlr_quat_log_array(&q, 1, &v, NULL), MLR_OK);
    ck_assert_close(v.x, 0.0, 0.0);
    ck_assert_close(v.y, 0.0, 0.0);
    ck_assert_close(fabs(v.z), PI, 1e-15);
    ck_assert_int_eq(mlr_quat_log_array(&mq, 1, &v, NULL), MLR_OK);
    ck_assert_close(fabs(v.z), PI, 1e-15);
}
END_TEST

static double ulp_of(long double v);

/* The array kernels run blocks of common input through a vectorized path and blocks with any
 * unusual element (zero, non-finite, tiny or huge) element by element: both must give the
 * same bits for the same element. Block size in quat.c: 32; a bad element at index 40 sends
 * the block 32..63 down the scalar path. */
START_TEST(array_paths_agree)
{
    enum { N = 96, BAD = 40 };
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 31);
    static mlr_quat q[N], q2[N], e1[N], e2[N], n1[N], n2[N];
    static mlr_vec3 v[N], v2[N], l1[N], l2[N];
    for (int i = 0; i < N; i++) {
        q[i] = random_unit(&r);
        const double sc = (i % 3 == 0) ? 1e-3 : (i % 3 == 1) ? 0.3 : 2.0; /* series and atan */
        const double k = sc * (0.5 + mlr_test_rng_uniform(&r));
        q[i].x *= k, q[i].y *= k, q[i].z *= k;
        if (i % 7 == 0)
            q[i].w = -q[i].w;
        v[i] = (mlr_vec3){3.0 * mlr_test_rng_normal(&r), mlr_test_rng_normal(&r), 1e-6 * i};
    }
    memcpy(q2, q, sizeof q);
    memcpy(v2, v, sizeof v);
    q2[BAD].w = NAN;
    v2[BAD].x = INFINITY;
    ck_assert_int_eq(mlr_quat_log_array(q, N, l1, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_log_array(q2, N, l2, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_exp_array(v, N, e1, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_exp_array(v2, N, e2, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_normalize_array(q, N, n1, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_normalize_array(q2, N, n2, NULL), MLR_E_INVALID_ARG);
    for (int i = 0; i < N; i++) {
        if (i == BAD)
            continue;
        ck_assert_msg(memcmp(&l1[i], &l2[i], sizeof l1[i]) == 0, "log %d", i);
        ck_assert_msg(memcmp(&e1[i], &e2[i], sizeof e1[i]) == 0, "exp %d", i);
        ck_assert_msg(memcmp(&n1[i], &n2[i], sizeof n1[i]) == 0, "normalize %d", i);
    }
    ck_assert(l2[BAD].x == 0.0 && e2[BAD].w == 1.0 && n2[BAD].w == 1.0);
}
END_TEST

/* The radian kernel of the quaternion exp against long double sinl / cosl: within 2 ulp plus
 * the reduction's absolute error (below 1e-26 k for the quadrant k). */
START_TEST(sincos_radians_kernel)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 32);
    for (int i = 0; i < 200000; i++) {
        const double u = mlr_test_rng_uniform(&r);
        double x = i % 4 == 0   ? ldexp(u, -(int)(mlr_test_rng_u64(&r) % 60))
                   : i % 4 == 1 ? 8.0 * u
                   : i % 4 == 2 ? 1e4 * u
                                : 0.5 * MLR_SINCOS_LIMIT * u;
        if (i % 5 == 0)
            x = -x;
        double sn, cs;
        mlr_sincos_kernel(x, &sn, &cs);
        const long double rs = sinl((long double)x), rc = cosl((long double)x);
        const double slack = 1e-26 * (fabs(x) / 1.5 + 1.0);
        const double tol = LDBL_MANT_DIG >= 64 ? 2.0 : 3.0;
        ck_assert_msg((double)fabsl((long double)sn - rs) <= tol * ulp_of(rs) + slack,
                      "sin(%.17g) = %.17g", x, sn);
        ck_assert_msg((double)fabsl((long double)cs - rc) <= tol * ulp_of(rc) + slack,
                      "cos(%.17g) = %.17g", x, cs);
    }
    double sn, cs;
    mlr_sincos_kernel(0.0, &sn, &cs);
    ck_assert(sn == 0.0 && cs == 1.0);
}
END_TEST

/* ---------------------------------------------------------------- slerp */

/* Reference: a * exp(t * log(conj(a) * b)), with log taking the shorter arc. */
static mlr_quat slerp_reference(const mlr_quat *a, const mlr_quat *b, double t)
{
    mlr_quat ac = {a->w, -a->x, -a->y, -a->z}, d, e, out;
    mlr_vec3 v;
    mlr_quat_mul(&ac, b, &d);
    mlr_quat_log_array(&d, 1, &v, NULL);
    v.x *= t;
    v.y *= t;
    v.z *= t;
    mlr_quat_exp_array(&v, 1, &e, NULL);
    mlr_quat_mul(a, &e, &out);
    return out;
}

START_TEST(slerp_unit_endpoints_and_reference)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 10);
    enum { N = 200 };
    mlr_quat a[N], b[N], out[N];
    double t[N];
    for (int n = 0; n < N; n++) {
        a[n] = random_unit(&r);
        b[n] = random_unit(&r);
        t[n] = n % 10 == 0 ? 0.0 : n % 10 == 1 ? 1.0 : mlr_test_rng_uniform(&r);
    }
    ck_assert_int_eq(mlr_quat_slerp_array(a, b, t, N, out, NULL), MLR_OK);
    for (int n = 0; n < N; n++) {
        ck_assert_close(norm4(&out[n]), 1.0, 1e-15);
        if (t[n] == 0.0)
            ck_assert(rot_dist(&out[n], &a[n]) < 1e-15);
        if (t[n] == 1.0)
            ck_assert(rot_dist(&out[n], &b[n]) < 1e-15);
        mlr_quat ref = slerp_reference(&a[n], &b[n], t[n]);
        ck_assert_msg(rot_dist(&out[n], &ref) < 1e-14, "n = %d: %g", n, rot_dist(&out[n], &ref));
        /* constant speed: the angle from a is t times the whole angle */
        ck_assert_close(rot_dist(&a[n], &out[n]), t[n] * rot_dist(&a[n], &b[n]), 1e-13);
    }
}
END_TEST

START_TEST(slerp_sign_of_b_does_not_matter)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 11);
    for (int n = 0; n < 100; n++) {
        mlr_quat a = random_unit(&r), b = random_unit(&r), mb = {-b.w, -b.x, -b.y, -b.z};
        double t = mlr_test_rng_uniform(&r);
        mlr_quat o1, o2;
        ck_assert_int_eq(mlr_quat_slerp_array(&a, &b, &t, 1, &o1, NULL), MLR_OK);
        ck_assert_int_eq(mlr_quat_slerp_array(&a, &mb, &t, 1, &o2, NULL), MLR_OK);
        ck_assert(rot_dist(&o1, &o2) < 1e-15);
        /* and it is the shorter arc: no further from a than b is */
        ck_assert(rot_dist(&a, &o1) <= rot_dist(&a, &b) + 1e-15);
    }
}
END_TEST

START_TEST(slerp_nearly_equal_and_opposite)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 12);
    static const double gaps[] = {0.0, 1e-300, 1e-15, 1e-12, 1e-8, 1e-5};
    for (size_t g = 0; g < MLR_COUNTOF(gaps); g++) {
        for (int n = 0; n < 20; n++) {
            mlr_quat a = random_unit(&r), e, b, out;
            mlr_vec3 ax = random_axis(&r);
            mlr_vec3 v = {ax.x * gaps[g], ax.y * gaps[g], ax.z * gaps[g]};
            mlr_quat_exp_array(&v, 1, &e, NULL);
            mlr_quat_mul(&a, &e, &b);
            double t = mlr_test_rng_uniform(&r);
            for (int sign = 1; sign >= -1; sign -= 2) { /* b and then -b: a ~ -b */
                mlr_quat bs = {sign * b.w, sign * b.x, sign * b.y, sign * b.z};
                ck_assert_int_eq(mlr_quat_slerp_array(&a, &bs, &t, 1, &out, NULL), MLR_OK);
                ck_assert(isfinite(out.w) && isfinite(out.x));
                ck_assert_close(norm4(&out), 1.0, 1e-15);
                mlr_quat ref = slerp_reference(&a, &b, t);
                ck_assert(rot_dist(&out, &ref) < 1e-15);
            }
        }
    }
}
END_TEST

START_TEST(slerp_in_place)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 13);
    mlr_quat a[8], b[8], ref[8];
    double t[8];
    for (int n = 0; n < 8; n++) {
        a[n] = random_unit(&r);
        b[n] = random_unit(&r);
        t[n] = mlr_test_rng_uniform(&r);
    }
    ck_assert_int_eq(mlr_quat_slerp_array(a, b, t, 8, ref, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_slerp_array(a, b, t, 8, a, NULL), MLR_OK);
    for (int n = 0; n < 8; n++)
        quat_close(&a[n], &ref[n], 0.0);
}
END_TEST

/* ---------------------------------------------------------------- Euler angles */

START_TEST(from_euler_matches_matrix_product)
{
    const int order = _i;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 20 + (uint64_t)order);
    enum { N = 100 };
    double ang[3 * N];
    mlr_quat q[N];
    for (int k = 0; k < 3 * N; k++)
        ang[k] = (2.0 * mlr_test_rng_uniform(&r) - 1.0) * 4.0; /* beyond (-pi, pi] too */
    ck_assert_int_eq(mlr_quat_from_euler_array(ang, N, (mlr_euler_order)order, q, NULL), MLR_OK);
    for (int n = 0; n < N; n++) {
        mat3 ref, m;
        euler_matrix(order, &ang[3 * n], ref);
        quat_matrix(&q[n], m);
        ck_assert_close(norm4(&q[n]), 1.0, 1e-15);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                ck_assert_msg(fabs(m[i][j] - ref[i][j]) < 1e-14, "%s n=%d (%d,%d): %g vs %g",
                              order_names[order], n, i, j, m[i][j], ref[i][j]);
    }
}
END_TEST

static void check_euler_ranges(const double *a, int locked)
{
    ck_assert(a[0] > -PI && a[0] <= PI);
    ck_assert(a[1] >= -PI / 2 && a[1] <= PI / 2);
    ck_assert(a[2] > -PI && a[2] <= PI);
    if (locked)
        ck_assert(a[2] == 0.0);
}

START_TEST(to_euler_round_trip)
{
    const int order = _i;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 30 + (uint64_t)order);
    enum { N = 300 };
    mlr_quat q[N], back[N];
    double ang[3 * N];
    for (int n = 0; n < N; n++)
        q[n] = random_unit(&r);
    ck_assert_int_eq(mlr_quat_to_euler_array(q, N, (mlr_euler_order)order, ang, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_from_euler_array(ang, N, (mlr_euler_order)order, back, NULL),
                     MLR_OK);
    for (int n = 0; n < N; n++) {
        check_euler_ranges(&ang[3 * n], 0);
        ck_assert_msg(rot_dist(&q[n], &back[n]) < 2e-15, "%s n=%d: %g", order_names[order], n,
                      rot_dist(&q[n], &back[n]));
    }
    /* angles inside the canonical ranges come back unchanged */
    for (int n = 0; n < N; n++) {
        ang[3 * n] = (2.0 * mlr_test_rng_uniform(&r) - 1.0) * (PI - 1e-6);
        ang[3 * n + 1] = (2.0 * mlr_test_rng_uniform(&r) - 1.0) * (PI / 2 - 1e-3);
        ang[3 * n + 2] = (2.0 * mlr_test_rng_uniform(&r) - 1.0) * (PI - 1e-6);
    }
    double again[3 * N];
    ck_assert_int_eq(mlr_quat_from_euler_array(ang, N, (mlr_euler_order)order, q, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_to_euler_array(q, N, (mlr_euler_order)order, again, NULL), MLR_OK);
    for (int k = 0; k < 3 * N; k++)
        ck_assert_close(again[k], ang[k], 1e-12);
}
END_TEST

START_TEST(to_euler_gimbal_lock)
{
    const int order = _i;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 40 + (uint64_t)order);
    /* the middle angle at and near the poles, in radians and from degrees */
    static const double middle[] = {
        PI / 2,         -PI / 2,        90.0 * (PI / 180.0), -90.0 * (PI / 180.0), PI / 2 - 1e-15,
        PI / 2 - 1e-12, -PI / 2 + 1e-9, PI / 2 - 1e-7,       -PI / 2 + 1e-5};
    for (size_t m = 0; m < MLR_COUNTOF(middle); m++) {
        for (int n = 0; n < 40; n++) {
            double ang[3] = {(2.0 * mlr_test_rng_uniform(&r) - 1.0) * PI, middle[m],
                             (2.0 * mlr_test_rng_uniform(&r) - 1.0) * PI};
            double out[3];
            mlr_quat q, back;
            ck_assert_int_eq(mlr_quat_from_euler_array(ang, 1, (mlr_euler_order)order, &q, NULL),
                             MLR_OK);
            ck_assert_int_eq(mlr_quat_to_euler_array(&q, 1, (mlr_euler_order)order, out, NULL),
                             MLR_OK);
            ck_assert_int_eq(
                mlr_quat_from_euler_array(out, 1, (mlr_euler_order)order, &back, NULL), MLR_OK);
            check_euler_ranges(out, m < 5);
            ck_assert_msg(rot_dist(&q, &back) < 1e-12, "%s middle %.17g n=%d: %g",
                          order_names[order], middle[m], n, rot_dist(&q, &back));
            ck_assert_close(out[1], middle[m], 1e-12);
        }
    }
}
END_TEST

START_TEST(to_euler_scale_and_sign_invariant)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 50);
    for (int order = 0; order < 6; order++) {
        for (int n = 0; n < 30; n++) {
            mlr_quat q = random_unit(&r);
            mlr_quat s[2] = {{3.7 * q.w, 3.7 * q.x, 3.7 * q.y, 3.7 * q.z},
                             {-q.w, -q.x, -q.y, -q.z}};
            double a[3], b[6];
            ck_assert_int_eq(mlr_quat_to_euler_array(&q, 1, (mlr_euler_order)order, a, NULL),
                             MLR_OK);
            ck_assert_int_eq(mlr_quat_to_euler_array(s, 2, (mlr_euler_order)order, b, NULL),
                             MLR_OK);
            for (int k = 0; k < 3; k++) {
                ck_assert_close(b[k], a[k], 1e-14);
                /* a wrapped angle near +-pi may come back as the other end */
                double d = fabs(b[3 + k] - a[k]);
                ck_assert(d < 1e-14 || fabs(d - 2 * PI) < 1e-14);
            }
        }
    }
}
END_TEST

START_TEST(euler_order_parse_names)
{
    static const char *const variants[][3] = {
        {"XYZ", "xyz", "xYz"}, {"XZY", "xzy", "XzY"}, {"YXZ", "yxz", "Yxz"},
        {"YZX", "yzx", "yZX"}, {"ZXY", "zxy", "zXy"}, {"ZYX", "zyx", "ZYx"},
    };
    for (int o = 0; o < 6; o++) {
        for (int v = 0; v < 3; v++) {
            mlr_euler_order out = (mlr_euler_order)99;
            ck_assert_int_eq(mlr_euler_order_parse(variants[o][v], &out, NULL), MLR_OK);
            ck_assert_int_eq((int)out, o);
        }
    }
    ck_assert_int_eq(MLR_EULER_ZXY, 4); /* pinned values */
    static const char *const bad[] = {"", "X", "XY", "XYZW", "XXY", "XYX", "ABC", "XY ", " XYZ"};
    for (size_t b = 0; b < MLR_COUNTOF(bad); b++) {
        mlr_euler_order out = MLR_EULER_ZYX;
        ck_assert_int_eq(mlr_euler_order_parse(bad[b], &out, NULL), MLR_E_INVALID_ARG);
        ck_assert_int_eq((int)out, MLR_EULER_ZYX); /* untouched */
    }
    mlr_euler_order out;
    ck_assert_int_eq(mlr_euler_order_parse(NULL, &out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_euler_order_parse("XYZ", NULL, NULL), MLR_E_INVALID_ARG);
}
END_TEST

/* ---------------------------------------------------------------- continuity */

START_TEST(make_continuous_flips_per_track)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 60);
    enum { F = 50, T = 3 };
    mlr_quat smooth[F * T], q[F * T];
    for (int j = 0; j < T; j++) {
        mlr_quat a = random_unit(&r);
        mlr_vec3 ax = random_axis(&r);
        for (int f = 0; f < F; f++) { /* a rotation turning 0.2 rad per frame */
            mlr_vec3 v = {ax.x * 0.2 * f, ax.y * 0.2 * f, ax.z * 0.2 * f};
            mlr_quat e;
            mlr_quat_exp_array(&v, 1, &e, NULL);
            mlr_quat_mul(&a, &e, &smooth[f * T + j]);
        }
    }
    for (int k = 0; k < F * T; k++) { /* random flips, the first frame of track 1 too */
        double s = (mlr_test_rng_uniform(&r) < 0.5 || k == 1) ? -1.0 : 1.0;
        q[k].w = s * smooth[k].w;
        q[k].x = s * smooth[k].x;
        q[k].y = s * smooth[k].y;
        q[k].z = s * smooth[k].z;
    }
    mlr_quat first[T];
    memcpy(first, q, sizeof first);
    mlr_quat_make_continuous(q, F, T);
    for (int j = 0; j < T; j++) {
        quat_close(&q[j], &first[j], 0.0); /* the first frame is kept */
        double s = dot4(&q[j], &smooth[j]) < 0 ? -1.0 : 1.0;
        for (int f = 0; f < F; f++) {
            mlr_quat *c = &q[f * T + j], *o = &smooth[f * T + j];
            mlr_quat ref = {s * o->w, s * o->x, s * o->y, s * o->z};
            quat_close(c, &ref, 0.0);
            if (f > 0)
                ck_assert(dot4(c, &q[(f - 1) * T + j]) >= 0.0);
        }
    }
    mlr_quat_make_continuous(NULL, F, T); /* no-op */
    mlr_quat_make_continuous(q, 0, T);
    mlr_quat_make_continuous(q, 1, T);
}
END_TEST

/* ---------------------------------------------------------------- bad input */

START_TEST(bad_input_is_rejected)
{
    const double qnan = NAN, pinf = INFINITY;
    mlr_quat q[3] = {{1, 2, 3, 4}, {0, 0, 0, 0}, {qnan, 0, 0, 0}}, out[3];
    ck_assert_int_eq(mlr_quat_normalize_array(q, 3, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_close(norm4(&out[0]), 1.0, 1e-15); /* the good one is still normalized */
    ck_assert(out[1].w == 1 && out[1].x == 0 && out[2].w == 1 && out[2].z == 0);
    mlr_quat qi = {pinf, 0, 0, 0};
    ck_assert_int_eq(mlr_quat_normalize_array(&qi, 1, out, NULL), MLR_E_INVALID_ARG);

    mlr_vec3 v[2] = {{0.1, 0.2, 0.3}, {0, pinf, 0}}, vo[3];
    ck_assert_int_eq(mlr_quat_exp_array(v, 2, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_close(norm4(&out[0]), 1.0, 1e-15);
    ck_assert(out[1].w == 1);
    ck_assert_int_eq(mlr_quat_log_array(q, 3, vo, NULL), MLR_E_INVALID_ARG);
    ck_assert(vo[1].x == 0 && vo[2].x == 0 && vo[2].y == 0);
    ck_assert_int_eq(mlr_quat_log_array(&qi, 1, vo, NULL), MLR_E_INVALID_ARG);

    mlr_quat a = {1, 0, 0, 0}, b = {0, 1, 0, 0};
    double t[3] = {0.5, qnan, pinf};
    ck_assert_int_eq(mlr_quat_slerp_array(&a, &b, &t[1], 1, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_slerp_array(&a, &b, &t[2], 1, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_slerp_array(&a, &q[1], &t[0], 1, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_slerp_array(&q[2], &b, &t[0], 1, out, NULL), MLR_E_INVALID_ARG);

    double ang[6] = {0.1, 0.2, 0.3, 0.1, qnan, 0.3}, ao[9];
    ck_assert_int_eq(mlr_quat_from_euler_array(ang, 2, (mlr_euler_order)6, out, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_from_euler_array(ang, 2, (mlr_euler_order)-1, out, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_from_euler_array(ang, 2, MLR_EULER_XYZ, out, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_close(norm4(&out[0]), 1.0, 1e-15);
    ck_assert(out[1].w == 1);
    ck_assert_int_eq(mlr_quat_to_euler_array(q, 1, (mlr_euler_order)7, ao, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_to_euler_array(q, 3, MLR_EULER_ZXY, ao, NULL), MLR_E_INVALID_ARG);
    for (int k = 3; k < 9; k++)
        ck_assert(ao[k] == 0.0);

    /* NULL with a count is an error; a zero count accepts anything */
    ck_assert_int_eq(mlr_quat_normalize_array(NULL, 1, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_normalize_array(q, 1, NULL, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_exp_array(NULL, 1, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_log_array(q, 1, NULL, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_slerp_array(&a, &b, NULL, 1, out, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_from_euler_array(NULL, 1, MLR_EULER_XYZ, out, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_to_euler_array(q, 1, MLR_EULER_XYZ, NULL, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_quat_normalize_array(NULL, 0, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_exp_array(NULL, 0, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_log_array(NULL, 0, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_slerp_array(NULL, NULL, NULL, 0, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_from_euler_array(NULL, 0, MLR_EULER_XYZ, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_quat_to_euler_array(NULL, 0, MLR_EULER_XYZ, NULL, NULL), MLR_OK);
}
END_TEST

/* ---------------------------------------------------------------- sincosd.h (degrees) */

/* Reference in long double: exact reduction by fmodl and remainderl (r in [-45, 45]) and its
 * quadrant, then sinl / cosl of r in radians with a long double pi. */
static void sincosd_reference(double x, long double *s, long double *c)
{
    const long double y = fmodl((long double)x, 360.0L); /* exact, |y| < 360 */
    const long double r = remainderl(y, 90.0L);          /* exact */
    const int q = ((int)((y - r) / 90.0L) + 8) % 4;          /* (y - r) / 90 in -4 .. 4 */
    const long double t = r * (3.14159265358979323846264338327950288L / 180.0L);
    const long double sr = sinl(t), cr = cosl(t);
    switch (q) {
    case 0:
        *s = sr, *c = cr;
        break;
    case 1:
        *s = cr, *c = -sr;
        break;
    case 2:
        *s = -sr, *c = -cr;
        break;
    default:
        *s = -cr, *c = sr;
        break;
    }
}

static double ulp_of(long double v)
{
    double a = fabs((double)v);
    return a == 0.0 ? 0x1p-1074 : nextafter(a, INFINITY) - a;
}

/* A batch of angles: random in several ranges plus edges (multiples of 45 and their
 * neighbours, zeros, the reduction's limits, huge values). */
static size_t sincosd_angles(mlr_test_rng *r, size_t batch, double *x, size_t n)
{
    static const double edges[] = {0.0,
                                   -0.0,
                                   45.0,
                                   -45.0,
                                   90.0,
                                   -90.0,
                                   135.0,
                                   180.0,
                                   -180.0,
                                   270.0,
                                   360.0,
                                   -360.0,
                                   720.0,
                                   22.5,
                                   67.5,
                                   1e-300,
                                   -4.9e-324,
                                   0x1p50,
                                   -0x1p50,
                                   0x1p50 - 1.0,
                                   0x1p52 + 2.0,
                                   1e15,
                                   1e17,
                                   1e300,
                                   -DBL_MAX,
                                   89.999999999999986,
                                   45.000000000000007};
    size_t k = 0;
    if (batch == 0)
        for (; k < MLR_COUNTOF(edges) && k < n; k++)
            x[k] = edges[k];
    for (; k < n; k++) {
        const double u = mlr_test_rng_uniform(r) - 0.5;
        switch ((batch + k) % 6) {
        case 0:
            x[k] = 360.0 * u;
            break;                                  /* BVH half-angles */
        case 1:
            x[k] = 1e6 * u;
            break;
        case 2:
            x[k] = ldexp(u, (int)(mlr_test_rng_u64(r) % 120) - 60);
            break;
        case 3:
            x[k] = 45.0 * (double)((int64_t)(mlr_test_rng_u64(r) % 33) - 16); /* n 45 + tiny */
            x[k] = nextafter(x[k], (u > 0) ? INFINITY : -INFINITY);
            if (mlr_test_rng_u64(r) & 1)
                x[k] += 1e-9 * u;
            break;
        case 4:
            x[k] = ldexp(u, 30 + (int)(mlr_test_rng_u64(r) % 21));
            break; /* to 2^50 */
        default:
            x[k] = ldexp(u, 50 + (int)(mlr_test_rng_u64(r) % 900));
            break; /* fmod path */
        }
    }
    return n;
}

START_TEST(sincosd_is_within_two_ulp)
{
    /* Against a long double reference: at most 2 ulp (about 1.6 measured; with a long double
     * no wider than double the reference itself may be 1 ulp off). Against libm's sin/cos of
     * the angle in radians, for |x| <= 720: within 2 ulp plus what the two roundings of
     * x * (pi / 180) move libm's own argument (up to |x pi / 180| 2^-52; near the zeros of sin
     * and cos that is many of their ulps). */
    const double tol = LDBL_MANT_DIG >= 64 ? 2.0 : 3.0;
    enum { BATCH = 4096, BATCHES = 512 }; /* 2 million angles */
    static double x[BATCH], sn[BATCH], cs[BATCH];
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 7);
    double worst = 0.0, worst_x = 0.0, worst_libm = 0.0;
    for (size_t b = 0; b < BATCHES; b++) {
        sincosd_angles(&r, b, x, BATCH);
        mlr_sincosd_array(x, BATCH, sn, cs);
        for (size_t i = 0; i < BATCH; i++) {
            long double rs, rc;
            sincosd_reference(x[i], &rs, &rc);
            const double es = (double)fabsl((long double)sn[i] - rs) / ulp_of(rs);
            const double ec = (double)fabsl((long double)cs[i] - rc) / ulp_of(rc);
            if (es > worst || ec > worst)
                worst = es > ec ? es : ec, worst_x = x[i];
            if (fabs(x[i]) <= 720.0) {
                const double xr = x[i] * (PI / 180.0);
                const double slack = fabs(xr) * 0x1p-52;
                const double ds = fabs(sn[i] - sin(xr)), dc = fabs(cs[i] - cos(xr));
                ck_assert_msg(ds <= 2 * ulp_of(sin(xr)) + slack &&
                                  dc <= 2 * ulp_of(cos(xr)) + slack,
                              "x = %.17g: sin %.17g vs libm %.17g, cos %.17g vs %.17g", x[i],
                              sn[i], sin(xr), cs[i], cos(xr));
                if (fmax(ds, dc) > worst_libm)
                    worst_libm = fmax(ds, dc);
            }
        }
    }
    ck_assert_msg(worst <= tol, "max error %.3f ulp at x = %.17g", worst, worst_x);
    if (getenv("MLR_TEST_VERBOSE"))
        printf("sincosd: max %.3f ulp from the long double reference (x = %.17g), at most %.3g "
               "from libm for |x| <= 720\n",
               worst, worst_x, worst_libm);
    /* exact values where they exist */
    static const double xs[] = {0.0, 90.0, -90.0, 180.0, 270.0, 360.0, -720.0};
    static const double se[] = {0.0, 1.0, -1.0, 0.0, -1.0, 0.0, 0.0};
    static const double ce[] = {1.0, 0.0, 0.0, -1.0, 0.0, 1.0, 1.0};
    double s7[7], c7[7];
    mlr_sincosd_array(xs, 7, s7, c7);
    for (int i = 0; i < 7; i++) {
        ck_assert_msg(s7[i] == se[i] && c7[i] == ce[i], "x = %g: %g %g", xs[i], s7[i], c7[i]);
    }
    /* NaN and infinities give NaN */
    const double bad[3] = {NAN, INFINITY, -INFINITY};
    double sb[3], cb[3];
    mlr_sincosd_array(bad, 3, sb, cb);
    for (int i = 0; i < 3; i++)
        ck_assert(isnan(sb[i]) && isnan(cb[i]));
}
END_TEST

static Suite *quat_suite(void)
{
    Suite *s = suite_create("quat");

    TCase *prod = tcase_create("products");
    tcase_add_test(prod, mul_identity_and_associativity);
    tcase_add_test(prod, mul_matches_matrix_product);
    tcase_add_test(prod, mul_array_aliases);
    tcase_add_test(prod, conj_is_inverse);
    tcase_add_test(prod, rotate_matches_sandwich);
    tcase_add_test(prod, normalize_unit_and_in_place);
    suite_add_tcase(s, prod);

    TCase *el = tcase_create("exp_log");
    tcase_add_test(el, exp_matches_rodrigues);
    tcase_add_loop_test(el, log_exp_round_trip, 0, (int)MLR_COUNTOF(round_trip_angles));
    tcase_add_test(el, exp_log_round_trip_on_quaternions);
    tcase_add_test(el, log_at_pi);
    tcase_add_test(el, array_paths_agree);
    suite_add_tcase(s, el);

    TCase *sl = tcase_create("slerp");
    tcase_add_test(sl, slerp_unit_endpoints_and_reference);
    tcase_add_test(sl, slerp_sign_of_b_does_not_matter);
    tcase_add_test(sl, slerp_nearly_equal_and_opposite);
    tcase_add_test(sl, slerp_in_place);
    suite_add_tcase(s, sl);

    TCase *eu = tcase_create("euler");
    tcase_add_loop_test(eu, from_euler_matches_matrix_product, 0, 6);
    tcase_add_loop_test(eu, to_euler_round_trip, 0, 6);
    tcase_add_loop_test(eu, to_euler_gimbal_lock, 0, 6);
    tcase_add_test(eu, to_euler_scale_and_sign_invariant);
    tcase_add_test(eu, euler_order_parse_names);
    suite_add_tcase(s, eu);

    TCase *deg = tcase_create("sincosd"); /* 2 million angles: slow under the sanitizers */
    tcase_add_test(deg, sincosd_is_within_two_ulp);
    tcase_add_test(deg, sincos_radians_kernel);
    tcase_set_timeout(deg, 120);
    suite_add_tcase(s, deg);

    TCase *misc = tcase_create("misc");
    tcase_add_test(misc, make_continuous_flips_per_track);
    tcase_add_test(misc, bad_input_is_rejected);
    suite_add_tcase(s, misc);
    return s;
}

int main(void) { return mlr_test_run(quat_suite()); }
