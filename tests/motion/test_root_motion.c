/* Root motion: the track of a figure whose path and heading are known (turning three times,
 * bowing 80 degrees), the LGS smoothing against a dense solve, the same figure stood on Z,
 * the position mode, the inverse (to rounding, in place too); every shared clip: round trip,
 * a continuous heading, the in-place body near the origin on the walks; bad input;
 * allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define PI 3.14159265358979323846

/* ---- a figure on a known path ------------------------------------------------------------ */

enum { FJ = 4 };
static const char *const f_names[FJ] = {"Hips", "LeftUpLeg", "RightUpLeg", "Spine"};
static const int32_t f_parents[FJ] = {-1, 0, 0, 0};
static const double f_offsets[3 * FJ] = {0, 90, 0, 9, -5, 0, -9, -5, 0, 0, 10, 0};

static mlr_rig figure(void)
{
    return (mlr_rig){FJ, f_parents, f_offsets, f_names, 0, NULL, 0, NULL, NULL};
}

static void qmul(const double *a, const double *b, double *o)
{
    const double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    const double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    const double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    const double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    o[0] = w, o[1] = x, o[2] = y, o[3] = z;
}

/* The figure walks a circle of radius 300 three times round (heading = its yaw theta(t),
 * which grows past 2 pi), bowing up to 80 degrees about its left-right axis; its legs swing.
 * Y-up. theta holds the true heading per frame. */
static void circle(size_t N, double fps, double *root, double *rot, double *theta)
{
    for (size_t n = 0; n < N; n++) {
        const double t = (double)n / fps, T = (double)(N - 1) / fps;
        const double th = 0.1 + 6.0 * PI * t / T;
        const double bow = 80.0 * PI / 180.0 * sin(PI * t / T) * sin(PI * t / T);
        theta[n] = th;
        /* facing (sin th, 0, cos th): the centre to the left */
        root[3 * n] = 300.0 * (1.0 - cos(th)) + 2.0 * sin(7.0 * t);
        root[3 * n + 1] = 90.0 + 3.0 * sin(11.0 * t);
        root[3 * n + 2] = 300.0 * sin(th);
        const double yaw[4] = {cos(th / 2), 0, sin(th / 2), 0};
        const double pitch[4] = {cos(bow / 2), sin(bow / 2), 0, 0};
        qmul(yaw, pitch, rot + 4 * FJ * n);
        for (size_t j = 1; j < FJ; j++) {
            const double a = 0.6 * sin(5.0 * t + (double)j);
            double *q = rot + 4 * (FJ * n + j);
            q[0] = cos(a / 2), q[1] = sin(a / 2) * 0.6, q[2] = 0.0, q[3] = sin(a / 2) * 0.8;
        }
    }
}

static double track_error(const double *a, const double *b, size_t n)
{
    double e = 0.0;
    for (size_t k = 0; k < n; k++)
        e = fmax(e, fabs(a[k] - b[k]));
    return e;
}

START_TEST(the_track_is_the_ground_path_and_the_heading_of_a_known_figure)
{
    const mlr_rig r = figure();
    enum { N = 400 };
    const double fps = 50.0;
    static double root[3 * N], rot[4 * FJ * N], theta[N], tp[3 * N], th[N], ip[3 * N], irot[4 * N];
    circle(N, fps, root, rot, theta);
    const mlr_root_motion_option none[1] = {{MLR_ROOT_MOTION_OPT_SMOOTH, 0.0}};
    mlr_diag d;
    ck_assert_msg(mlr_root_motion_extract(&r, fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root,
                                          rot, NULL, none, 1, tp, th, ip, irot, 4, NULL,
                                          &d) == MLR_OK,
                  "%s", d.message);
    for (size_t n = 0; n < N; n++) {
        /* the heading: the yaw, unwrapped over three turns, whatever the bow */
        ck_assert_close(th[n], theta[n], 1e-12);
        ck_assert_double_eq(tp[3 * n + 1], 0.0);
        ck_assert_double_eq(tp[3 * n], root[3 * n]);
        ck_assert_double_eq(tp[3 * n + 2], root[3 * n + 2]);
        /* in place: the root over the origin, facing +Z (only the bow is left) */
        ck_assert_close(ip[3 * n], 0.0, 1e-9);
        ck_assert_close(ip[3 * n + 1], root[3 * n + 1], 1e-9);
        ck_assert_close(ip[3 * n + 2], 0.0, 1e-9);
        ck_assert_close(irot[4 * n + 2], 0.0, 1e-12);
        ck_assert_close(irot[4 * n + 3], 0.0, 1e-12);
    }
    /* the inverse gives the input back to rounding, in place too */
    static double back[3 * N], brot[4 * FJ * N];
    memcpy(brot, rot, sizeof brot);
    ck_assert_int_eq(
        mlr_root_motion_apply(MLR_AXIS_Y, N, tp, th, ip, irot, 4, back, brot, 4 * FJ, &d), MLR_OK);
    ck_assert_double_le(track_error(back, root, 3 * N), 1e-12 * 600.0);
    ck_assert_double_le(track_error(brot, rot, 4 * FJ * N), 1e-15 * 8.0);
    static double root2[3 * N], rot2[4 * FJ * N];
    memcpy(root2, root, sizeof root2);
    memcpy(rot2, rot, sizeof rot2);
    ck_assert_int_eq(mlr_root_motion_extract(&r, fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root2,
                                             rot2, NULL, none, 1, tp, th, root2, rot2, 4 * FJ,
                                             NULL, &d),
                     MLR_OK);
    for (size_t n = 0; n < N; n++) {
        ck_assert_mem_eq(root2 + 3 * n, ip + 3 * n, 3 * sizeof(double));
        ck_assert_mem_eq(rot2 + 4 * FJ * n, irot + 4 * n, 4 * sizeof(double));
        ck_assert_mem_eq(rot2 + 4 * FJ * n + 4, rot + 4 * FJ * n + 4, 12 * sizeof(double));
    }
    ck_assert_int_eq(
        mlr_root_motion_apply(MLR_AXIS_Y, N, tp, th, root2, rot2, 4 * FJ, root2, rot2, 4 * FJ, &d),
        MLR_OK);
    ck_assert_double_le(track_error(root2, root, 3 * N), 1e-12 * 600.0);
    ck_assert_double_le(track_error(rot2, rot, 4 * FJ * N), 1e-15 * 8.0);
}
END_TEST

START_TEST(the_smoothing_is_the_lgs_of_the_given_period)
{
    const mlr_rig r = figure();
    enum { N = 60 };
    const double fps = 30.0, smooth = 0.5;
    static double root[3 * N], rot[4 * FJ * N], theta[N], raw_p[3 * N], raw_h[N], tp[3 * N], th[N],
        ip[3 * N], irot[4 * N];
    circle(N, fps, root, rot, theta);
    const mlr_root_motion_option none[1] = {{MLR_ROOT_MOTION_OPT_SMOOTH, 0.0}};
    const mlr_root_motion_option some[1] = {{MLR_ROOT_MOTION_OPT_SMOOTH, smooth}};
    ck_assert_int_eq(mlr_root_motion_extract(&r, fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root,
                                             rot, NULL, none, 1, raw_p, raw_h, ip, irot, 4, NULL,
                                             NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_root_motion_extract(&r, fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root,
                                             rot, NULL, some, 1, tp, th, ip, irot, 4, NULL, NULL),
                     MLR_OK);
    /* dense reference: (I + s D2^T D2) x = y, s from the half-power period */
    const double g = 2.0 * sin(PI / (smooth * fps)), s = 1.0 / (g * g * g * g);
    static double A[N * N], y[N * 3];
    memset(A, 0, sizeof A);
    for (size_t i = 0; i + 2 < N; i++) {
        const double c[3] = {1.0, -2.0, 1.0};
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                A[(i + (size_t)a) * N + i + (size_t)b] += s * c[a] * c[b];
    }
    for (size_t i = 0; i < N; i++) {
        A[i * N + i] += 1.0;
        y[3 * i] = raw_p[3 * i], y[3 * i + 1] = raw_p[3 * i + 2], y[3 * i + 2] = raw_h[i];
    }
    mlr_test_cholesky(N, A);
    mlr_test_cholesky_solve(N, A, y, 3);
    for (size_t i = 0; i < N; i++) {
        ck_assert_close(tp[3 * i], y[3 * i], 1e-8);
        ck_assert_close(tp[3 * i + 2], y[3 * i + 1], 1e-8);
        ck_assert_close(th[i], y[3 * i + 2], 1e-10);
    }
    /* the default is 1 s: a different (smoother) track */
    double tp1[3 * N], th1[N];
    ck_assert_int_eq(mlr_root_motion_extract(&r, fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root,
                                             rot, NULL, NULL, 0, tp1, th1, ip, irot, 4, NULL,
                                             NULL),
                     MLR_OK);
    ck_assert_double_gt(track_error(tp1, tp, 3 * N), 1e-3);
}
END_TEST

/* The cyclic turn (x, y, z) -> (z, x, y), a proper rotation taking Y-up to Z-up (and the
 * ground axes Z, X to X, Y): q = (1 + i + j + k) / 2. */
static void cyc(const double *v, double *o) { o[0] = v[2], o[1] = v[0], o[2] = v[1]; }

START_TEST(a_z_up_clip_gives_the_same_heading_and_the_turned_track)
{
    const mlr_rig r = figure();
    enum { N = 200 };
    const double fps = 60.0;
    static double root[3 * N], rot[4 * FJ * N], theta[N], zroot[3 * N], zrot[4 * FJ * N];
    circle(N, fps, root, rot, theta);
    static const double qc[4] = {0.5, 0.5, 0.5, 0.5};
    memcpy(zrot, rot, sizeof zrot);
    for (size_t n = 0; n < N; n++) {
        cyc(root + 3 * n, zroot + 3 * n);
        qmul(qc, rot + 4 * FJ * n, zrot + 4 * FJ * n);
    }
    static double tp[3 * N], th[N], ip[3 * N], irot[4 * N];
    static double ztp[3 * N], zth[N], zip[3 * N], zirot[4 * N];
    ck_assert_int_eq(mlr_root_motion_extract(&r, fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root,
                                             rot, NULL, NULL, 0, tp, th, ip, irot, 4, NULL, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_root_motion_extract(&r, fps, MLR_AXIS_Z, MLR_ROOT_MOTION_GROUND, N, zroot,
                                             zrot, NULL, NULL, 0, ztp, zth, zip, zirot, 4, NULL,
                                             NULL),
                     MLR_OK);
    for (size_t n = 0; n < N; n++) {
        double c[3];
        ck_assert_close(zth[n], th[n], 1e-10);
        cyc(tp + 3 * n, c);
        for (int k = 0; k < 3; k++)
            ck_assert_close(ztp[3 * n + (size_t)k], c[k], 1e-8);
        ck_assert_double_eq(ztp[3 * n + 2], 0.0);
        cyc(ip + 3 * n, c);
        for (int k = 0; k < 3; k++)
            ck_assert_close(zip[3 * n + (size_t)k], c[k], 1e-8);
        double q[4];
        qmul(qc, irot + 4 * n, q);
        for (int k = 0; k < 4; k++)
            ck_assert_close(zirot[4 * n + (size_t)k], q[k], 1e-12);
    }
}
END_TEST

START_TEST(the_position_mode_leaves_the_rotations_alone)
{
    const mlr_rig r = figure();
    enum { N = 100 };
    static double root[3 * N], rot[4 * FJ * N], theta[N], tp[3 * N], th[N], ip[3 * N], irot[4 * N];
    circle(N, 30.0, root, rot, theta);
    mlr_diag d;
    ck_assert_int_eq(mlr_root_motion_extract(&r, 30.0, MLR_AXIS_Y, MLR_ROOT_MOTION_POSITION, N,
                                             root, rot, NULL, NULL, 0, tp, th, ip, irot, 4, NULL,
                                             &d),
                     MLR_OK);
    for (size_t n = 0; n < N; n++) {
        ck_assert_double_eq(th[n], 0.0);
        ck_assert_mem_eq(irot + 4 * n, rot + 4 * FJ * n, 4 * sizeof(double));
        ck_assert_double_eq(ip[3 * n], root[3 * n] - tp[3 * n]);
        ck_assert_double_eq(ip[3 * n + 1], root[3 * n + 1]);
        ck_assert_double_eq(ip[3 * n + 2], root[3 * n + 2] - tp[3 * n + 2]);
    }
    /* the track follows another joint when asked: the Spine's path is the root's */
    const mlr_root_motion_option spine[2] = {{MLR_ROOT_MOTION_OPT_BODY_JOINT, 3},
                                             {MLR_ROOT_MOTION_OPT_SMOOTH, 0}};
    ck_assert_int_eq(mlr_root_motion_extract(&r, 30.0, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N, root,
                                             rot, NULL, spine, 2, tp, th, ip, irot, 4, NULL, &d),
                     MLR_OK);
    /* bowed 80 degrees: the spine leans 10 sin(80 deg) ahead of the hips */
    ck_assert_close(hypot(tp[3 * 50] - root[3 * 50], tp[3 * 50 + 2] - root[3 * 50 + 2]),
                    10.0 * sin(80.0 * PI / 180.0 * pow(sin(PI * 50.0 / 99.0), 2.0)), 1e-9);
}
END_TEST

/* ---- bad input ----------------------------------------------------------------------------- */

static void expect(mlr_status st, const mlr_diag *d, const char *text)
{
    ck_assert_int_eq(st, MLR_E_INVALID_ARG);
    ck_assert_msg(strstr(d->message, text) != NULL, "'%s' not in '%s'", text, d->message);
}

START_TEST(bad_input_says_why)
{
    const mlr_rig r = figure();
    enum { N = 20 };
    static double root[3 * N], rot[4 * FJ * N], theta[N], tp[3 * N], th[N], ip[3 * N], irot[4 * N];
    circle(N, 30.0, root, rot, theta);
    mlr_diag d;
#define EX(fps, up, mode, n, opts, n_opts, ld, text)                                            \
    expect(mlr_root_motion_extract(&r, fps, up, mode, n, root, rot, NULL, opts, n_opts, tp, th, \
                                   ip, irot, ld, NULL, &d),                                     \
           &d, text)
    EX(0.0, 1, 0, N, NULL, 0, 4, "fps 0 is not finite and > 0");
    EX(NAN, 1, 0, N, NULL, 0, 4, "fps");
    EX(30.0, 3, 0, N, NULL, 0, 4, "up axis 3");
    EX(30.0, 1, 2, N, NULL, 0, 4, "mode 2 is not 0 (ground) or 1 (position)");
    EX(30.0, 1, 0, 0, NULL, 0, 4, "no frames");
    EX(30.0, 1, 0, N, NULL, 0, 3, "ld_out_rot 3 is below 4");
    EX(30.0, 1, 0, N, NULL, 1, 4, "root motion: opts is NULL but n_opts is 1");
    const mlr_root_motion_option neg[1] = {{MLR_ROOT_MOTION_OPT_SMOOTH, -1.0}};
    EX(30.0, 1, 0, N, neg, 1, 4, "root motion: option smooth = -1 is not >= 0");
    const mlr_root_motion_option big[1] = {{MLR_ROOT_MOTION_OPT_BODY_JOINT, 4.0}};
    EX(30.0, 1, 0, N, big, 1, 4, "option body_joint = 4 is not -1 or below 4 joints");
    const mlr_root_motion_option twice[2] = {{MLR_ROOT_MOTION_OPT_SMOOTH, 1.0},
                                             {MLR_ROOT_MOTION_OPT_SMOOTH, 2.0}};
    EX(30.0, 1, 0, N, twice, 2, 4, "option smooth given twice");
    const mlr_root_motion_option unknown[1] = {{9, 1.0}};
    EX(30.0, 1, 0, N, unknown, 1, 4, "unknown option key 9");
    root[3 * 7 + 1] = NAN;
    EX(30.0, 1, 0, N, NULL, 0, 4, "root_pos[7][1] is not finite");
    root[3 * 7 + 1] = 1.0;
    rot[4 * (FJ * 5 + 2) + 3] = INFINITY;
    EX(30.0, 1, 0, N, NULL, 0, 4, "rot[5][2] is not finite");
    rot[4 * (FJ * 5 + 2) + 3] = 0.0;
#undef EX
    expect(mlr_root_motion_extract(&r, 30.0, 1, 0, N, root, rot, NULL, NULL, 0, NULL, th, ip, irot,
                                   4, NULL, &d),
           &d, "an output is NULL");
    expect(mlr_root_motion_extract(&r, 30.0, 1, 0, N, NULL, rot, NULL, NULL, 0, tp, th, ip, irot,
                                   4, NULL, &d),
           &d, "root_pos, rot or trans is NULL");
    static const int32_t trans_joints[1] = {3};
    mlr_rig rt = r;
    rt.n_trans = 1;
    rt.trans_joints = trans_joints;
    expect(mlr_root_motion_extract(&rt, 30.0, 1, 0, N, root, rot, NULL, NULL, 0, tp, th, ip, irot,
                                   4, NULL, &d),
           &d, "root_pos, rot or trans is NULL");
    expect(mlr_root_motion_extract(NULL, 30.0, 1, 0, N, root, rot, NULL, NULL, 0, tp, th, ip, irot,
                                   4, NULL, &d),
           &d, "rig");

    ck_assert_int_eq(mlr_root_motion_extract(&r, 30.0, 1, 0, N, root, rot, NULL, NULL, 0, tp, th,
                                             ip, irot, 4, NULL, &d),
                     MLR_OK);
    double back[3 * N], brot[4 * N];
    expect(mlr_root_motion_apply(-1, N, tp, th, ip, irot, 4, back, brot, 4, &d), &d, "up axis -1");
    expect(mlr_root_motion_apply(1, N, tp, th, ip, irot, 3, back, brot, 4, &d), &d,
           "rotation strides 3 and 4 must be >= 4");
    expect(mlr_root_motion_apply(1, N, NULL, th, ip, irot, 4, back, brot, 4, &d), &d,
           "NULL argument with 20 frames");
    th[4] = NAN;
    expect(mlr_root_motion_apply(1, N, tp, th, ip, irot, 4, back, brot, 4, &d), &d,
           "track heading[4] is not finite");
    th[4] = 0.0;
    tp[3 * 6 + 2] = INFINITY;
    expect(mlr_root_motion_apply(1, N, tp, th, ip, irot, 4, back, brot, 4, &d), &d,
           "track position[6][2] is not finite");
    ck_assert_int_eq(mlr_root_motion_apply(1, 0, NULL, NULL, NULL, NULL, 4, NULL, NULL, 4, &d),
                     MLR_OK);
}
END_TEST

START_TEST(every_allocation_failure_is_no_memory_without_leaks)
{
    const mlr_rig r = figure();
    enum { N = 50 };
    static double root[3 * N], rot[4 * FJ * N], theta[N], tp[3 * N], th[N], ip[3 * N], irot[4 * N],
        rtp[3 * N], rth[N];
    circle(N, 30.0, root, rot, theta);
    ck_assert_int_eq(mlr_root_motion_extract(&r, 30.0, 1, 0, N, root, rot, NULL, NULL, 0, rtp, rth,
                                             ip, irot, 4, NULL, NULL),
                     MLR_OK);
    size_t fails = 0;
    for (size_t at = 0;; at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, at);
        mlr_diag d;
        const mlr_status st = mlr_root_motion_extract(&r, 30.0, 1, 0, N, root, rot, NULL, NULL, 0,
                                                      tp, th, ip, irot, 4, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        ck_assert_uint_eq(ta.live_bytes, 0);
        if (st == MLR_OK) {
            ck_assert_mem_eq(tp, rtp, sizeof tp);
            ck_assert_mem_eq(th, rth, sizeof th);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_msg(strstr(d.message, "out of memory") != NULL, "%s", d.message);
        fails++;
    }
    /* the pairs, the name index and buffer, the track, the LGS handle's allocations */
    ck_assert_uint_ge(fails, 5u);
}
END_TEST

/* ---- the shared clips ---------------------------------------------------------------------- */

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

START_TEST(every_shared_clip_round_trips_with_a_continuous_heading)
{
    static const struct {
        const char *file;
        int walk; /* moves along a path: the in-place body stays near the origin */
    } clips[] = {
        {"cmu_01_01_playground_jumps.bvh", 1}, {"cmu_131_01_mj_style_walk.bvh", 1},
        {"cmu_10_01_soccer_kick.bvh", 0},      {"cmu_60_10_salsa_dance.bvh", 0},
        {"cmu_02_03_run_jog_25fps.bvh", 1},    {"lafan1_clip_a.bvh", 1},
        {"bandai1_walk_happy_001.bvh", 1},     {"ai4a_dog_D1_008_KAN01_002.bvh", 1},
    };
    for (size_t k = 0; k < MLR_COUNTOF(clips); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(clips[k].file))
            continue;
        ck_assert(mlr_test_clip_load(clips[k].file, &c));
        const size_t N = c.n, J = c.j;
        const double *root = mlr_motion_root_pos(c.m), *rot = mlr_motion_rot(c.m);
        const double *trans = mlr_motion_trans(c.m);
        double *tp = malloc(3 * N * 8), *th = malloc(N * 8), *ip = malloc(3 * N * 8);
        double *irot = malloc(4 * N * J * 8), *back = malloc(3 * N * 8);
        double *pos = malloc(3 * N * J * 8), *pos_b = malloc(3 * N * J * 8);
        ck_assert_ptr_nonnull(pos_b);
        memcpy(irot, rot, 4 * N * J * 8);
        mlr_diag d;
        const double t0 = now();
        ck_assert_msg(mlr_root_motion_extract(&c.rig, c.fps, MLR_AXIS_Y, MLR_ROOT_MOTION_GROUND, N,
                                              root, rot, trans, NULL, 0, tp, th, ip, irot, 4 * J,
                                              NULL, &d) == MLR_OK,
                      "%s: %s", clips[k].file, d.message);
        const double t1 = now();
        /* the in-place world positions, then the inverse */
        ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, ip, irot, c.rig.n_trans,
                                       c.rig.trans_joints, trans, pos_b, NULL, NULL, NULL),
                         MLR_OK);
        int32_t b;
        ck_assert_int_eq(mlr_rig_body_translation_joint(&c.rig, N, root, trans, &b, NULL), MLR_OK);
        double max_in_place = 0.0, path = 0.0, max_step = 0.0;
        for (size_t n = 0; n < N; n++) {
            const double *p = pos_b + 3 * (J * n + (size_t)b);
            max_in_place = fmax(max_in_place, hypot(p[0], p[2]));
            if (n)
                max_step = fmax(max_step, fabs(th[n] - th[n - 1]));
        }
        ck_assert_int_eq(
            mlr_root_motion_apply(MLR_AXIS_Y, N, tp, th, ip, irot, 4 * J, back, irot, 4 * J, &d),
            MLR_OK);
        ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, root, rot,
                                       c.rig.n_trans, c.rig.trans_joints, trans, pos, NULL, NULL,
                                       NULL),
                         MLR_OK);
        for (size_t n = 1; n < N; n++) {
            const double *p = pos + 3 * (J * n + (size_t)b), *q = p - 3 * J;
            path += hypot(p[0] - q[0], p[2] - q[2]);
        }
        ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, back, irot,
                                       c.rig.n_trans, c.rig.trans_joints, trans, pos_b, NULL, NULL,
                                       NULL),
                         MLR_OK);
        double height;
        ck_assert_int_eq(mlr_rig_body_height(N, J, pos, MLR_AXIS_Y, &height, NULL, NULL), MLR_OK);
        const double err = track_error(pos, pos_b, 3 * N * J);
        fprintf(stderr,
                "test_root_motion: %s: round trip %.2g body heights; in-place body "
                "within %.3f body heights of the origin, path %.1f; heading steps <= %.2f deg; "
                "%.3f ms per 1000 frames\n",
                clips[k].file, err / height, max_in_place / height, path / height,
                max_step * 180.0 / PI, (t1 - t0) * 1e6 / (double)N);
        ck_assert_msg(err <= 1e-9 * height, "%s: %g", clips[k].file, err / height);
        ck_assert_msg(max_step < 10.0 * PI / 180.0, "%s: heading step %g", clips[k].file,
                      max_step);
        if (clips[k].walk)
            ck_assert_msg(max_in_place <= 0.15 * height && path >= 2.0 * height,
                          "%s: in place %g, path %g", clips[k].file, max_in_place / height,
                          path / height);
        free(tp);
        free(th);
        free(ip);
        free(irot);
        free(back);
        free(pos);
        free(pos_b);
        mlr_test_clip_unload(&c);
    }
}
END_TEST

static Suite *root_motion_suite(void)
{
    Suite *s = suite_create("root_motion");
    TCase *tc = tcase_create("core");
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, the_track_is_the_ground_path_and_the_heading_of_a_known_figure);
    tcase_add_test(tc, the_smoothing_is_the_lgs_of_the_given_period);
    tcase_add_test(tc, a_z_up_clip_gives_the_same_heading_and_the_turned_track);
    tcase_add_test(tc, the_position_mode_leaves_the_rotations_alone);
    tcase_add_test(tc, bad_input_says_why);
    tcase_add_test(tc, every_allocation_failure_is_no_memory_without_leaks);
    tcase_add_test(tc, every_shared_clip_round_trips_with_a_continuous_heading);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(root_motion_suite()); }
