#define _POSIX_C_SOURCE 200809L
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF /* the references round as the library does */
#endif
/* BVH reader and writer: the real clips of the shared mocap folder (counts from its README,
 * values against an independent Euler-matrix reference), round trips, malformed input with the
 * expected line, allocation failures, motions built from arrays. */
#include "mlr_test.h"

#include "common/mlr_internal.h" /* private: common__quat_from_euler_half, a bit-exact reference */
#include "math/sincosd.h" /* private: the reader's sines and cosines in degrees */

#include <errno.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- helpers ----------------------------------------------------------------------------- */

static char *slurp(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return NULL;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    ck_assert_ptr_nonnull(buf);
    ck_assert_uint_eq(fread(buf, 1, (size_t)n, fp), (size_t)n);
    fclose(fp);
    buf[n] = '\0';
    *len = (size_t)n;
    return buf;
}

/* The shared clip's path, or the bundled copy's (MLR_TEST_BUNDLED_CLIP); the test checked that
 * it is there. */
static char *clip_path(const char *name)
{
    static char buf[4096];
    ck_assert_msg(mlr_test_clip_path(name, buf, sizeof buf) != NULL, "%s is absent", name);
    return buf;
}

static mlr_motion *read_text(const char *text, mlr_diag *diag, mlr_status *status)
{
    mlr_motion *m = NULL;
    *status = mlr_bvh_read_memory(text, strlen(text), NULL, &m, diag);
    return m;
}

/* angle between two rotations given as (possibly sign-flipped) unit quaternions */
static double quat_angle(const double *a, const double *b)
{
    double d = fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]);
    double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3]);
    double nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3]);
    d /= na * nb;
    if (d > 1.0)
        d = 1.0;
    /* 2 acos(d) loses accuracy near 1: use the sine of the half difference instead */
    double s2 = 0.0;
    for (int k = 0; k < 4; k++) {
        double sa = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0 ? -1.0 : 1.0;
        double t = a[k] / na - sa * b[k] / nb;
        s2 += t * t;
    }
    return 4.0 * asin(fmin(1.0, 0.5 * sqrt(s2)));
}

/* 3x3 rotation matrix about axis (0 X, 1 Y, 2 Z) by deg degrees, row-major */
static void axis_matrix(int axis, double deg, double r[9])
{
    double a = deg * 3.14159265358979323846 / 180.0, c = cos(a), s = sin(a);
    for (int i = 0; i < 9; i++)
        r[i] = 0.0;
    int i = (axis + 1) % 3, j = (axis + 2) % 3;
    r[axis * 3 + axis] = 1.0;
    r[i * 3 + i] = c;
    r[i * 3 + j] = -s;
    r[j * 3 + i] = s;
    r[j * 3 + j] = c;
}

static void matmul3(const double a[9], const double b[9], double out[9])
{
    double t[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            t[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
    memcpy(out, t, sizeof t);
}

static void quat_matrix(const double *q, double r[9])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    r[0] = 1 - 2 * (y * y + z * z);
    r[1] = 2 * (x * y - w * z);
    r[2] = 2 * (x * z + w * y);
    r[3] = 2 * (x * y + w * z);
    r[4] = 1 - 2 * (x * x + z * z);
    r[5] = 2 * (y * z - w * x);
    r[6] = 2 * (x * z - w * y);
    r[7] = 2 * (y * z + w * x);
    r[8] = 1 - 2 * (x * x + y * y);
}

/* ---- the real clips ---------------------------------------------------------------------- */

typedef struct clip_info {
    const char *file;
    size_t frames, joints, end_sites, channels;
    double frame_time;
    size_t n_trans; /* non-root joints with position channels */
} clip_info;

static const clip_info clips[] = {
    {"cmu_01_01_playground_jumps.bvh", 2752, 31, 7, 96, 0.0083333, 0},
    {"cmu_131_01_mj_style_walk.bvh", 994, 31, 7, 96, 0.0083333, 0},
    {"cmu_10_01_soccer_kick.bvh", 802, 43, 14, 132, 0.00833333, 0},
    {"cmu_60_10_salsa_dance.bvh", 1197, 43, 14, 132, 0.008333, 0},
    {"cmu_02_03_run_jog_25fps.bvh", 174, 165, 47, 498, 0.04, 0},
    {"lafan1_clip_a.bvh", 7184, 22, 5, 69, 0.033333, 0},
    {"bandai1_walk_happy_001.bvh", 213, 22, 5, 132, 0.0333333, 21},
    {"ai4a_dog_D1_008_KAN01_002.bvh", 911, 21, 6, 66, 0.0166667, 0},
};

static mlr_motion *read_clip(const clip_info *ci)
{
    mlr_diag d;
    mlr_motion *m = NULL;
    mlr_status s = mlr_bvh_read_file(clip_path(ci->file), NULL, &m, &d);
    ck_assert_msg(s == MLR_OK, "%s: %s at line %zu: %s", ci->file, mlr_status_name(s), d.line,
                  d.message);
    return m;
}

/* Independent check of one frame: the motion line parsed with strtod, each joint's rotation
 * rebuilt as a product of axis matrices in channel order, translations replacing OFFSETs. */
static void check_frame_against_text(const mlr_motion *m, const char *text, size_t f)
{
    const char *p = strstr(text, "Frame Time:");
    ck_assert_ptr_nonnull(p);
    p = strchr(p, '\n') + 1;
    for (size_t k = 0; k < f; k++) {
        p = strchr(p, '\n');
        ck_assert_ptr_nonnull(p);
        p++;
    }
    size_t J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m);
    const double *rot = mlr_motion_rot(m) + 4 * J * f;
    const double *rp = mlr_motion_root_pos(m) + 3 * f;
    const double *tr = mlr_motion_trans(m);
    const int32_t *tj = mlr_motion_trans_joints(m);
    size_t slot = 0;
    for (size_t j = 0; j < J; j++) {
        unsigned char codes[6];
        size_t n = mlr_motion_joint_channel_codes(m, j, codes);
        double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3];
        memcpy(t, mlr_motion_offsets(m) + 3 * j, sizeof t);
        for (size_t k = 0; k < n; k++) {
            char *e;
            double v = strtod(p, &e);
            ck_assert_ptr_ne(e, p);
            p = e;
            if (codes[k] < 3) {
                t[codes[k]] = v;
            } else {
                double a[9];
                axis_matrix(codes[k] - 3, v, a);
                matmul3(r, a, r);
            }
        }
        double qr[9];
        quat_matrix(rot + 4 * j, qr);
        for (int i = 0; i < 9; i++)
            ck_assert_close(qr[i], r[i], 1e-12);
        const double *got = NULL;
        if (j == 0) {
            got = rp;
        } else if (slot < P && (size_t)tj[slot] == j) {
            got = tr + 3 * (P * f + slot);
            slot++;
        }
        if (got)
            for (int k = 0; k < 3; k++)
                ck_assert_double_eq(got[k], t[k]);
    }
}

/* Axes and parity of the Euler orders as mlr_quat.h numbers them (the library's tables are
 * private). */
static const unsigned char ref_axes[6][3] = {
    {0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0},
};
static const double ref_parity[6] = {1.0, -1.0, -1.0, 1.0, 1.0, -1.0};

/* Every frame of m against the text after its Frame Time line, bit for bit: each value read
 * with strtod; position channels replacing the OFFSET; each joint's quaternion rebuilt from its
 * angles (in channel order, missing ones zero) with the reader's arithmetic, the sine and
 * cosine of each half-angle (mlr_sincosd_kernel) and the product of common__quat_from_euler_half.
 * Blank lines between frames are allowed. */
static void assert_frames_are_strtods(const mlr_motion *m, const char *text, const char *what)
{
    const char *p = strstr(text, "Frame Time:");
    ck_assert_ptr_nonnull(p);
    p += strcspn(p, "\r\n");
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m);
    const int32_t *tj = mlr_motion_trans_joints(m);
    for (size_t f = 0; f < N; f++) {
        size_t slot = 0;
        for (size_t j = 0; j < J; j++) {
            unsigned char codes[6];
            const size_t n = mlr_motion_joint_n_channels(m, j);
            ck_assert_uint_eq(mlr_motion_joint_channel_codes(m, j, codes), n);
            double t[3], ang[3] = {0.0, 0.0, 0.0};
            memcpy(t, mlr_motion_offsets(m) + 3 * j, sizeof t);
            size_t na = 0;
            for (size_t k = 0; k < n; k++) {
                char *e;
                const double v = strtod(p, &e);
                ck_assert_msg(e != p, "%s: frame %zu: no number", what, f + 1);
                p = e;
                if (codes[k] < 3)
                    t[codes[k]] = v;
                else
                    ang[na++] = v;
            }
            const mlr_euler_order o = mlr_motion_joint_euler_order(m, j);
            double sn[3], cs[3];
            for (int k = 0; k < 3; k++) {
                const double h = 0.5 * ang[k];
                mlr_sincosd_kernel(fabs(h) < MLR_SINCOSD_LIMIT ? h : fmod(h, 360.0), &sn[k],
                                   &cs[k]);
            }
            mlr_quat q;
            common__quat_from_euler_half(cs[0], sn[0], cs[1], sn[1], cs[2], sn[2], ref_axes[o],
                                         ref_parity[o], &q);
            const double want[4] = {q.w, q.x, q.y, q.z};
            const double *got = mlr_motion_rot(m) + 4 * (J * f + j);
            ck_assert_msg(memcmp(want, got, sizeof want) == 0,
                          "%s: frame %zu joint %zu: quaternion (%.17g %.17g %.17g %.17g), "
                          "expected (%.17g %.17g %.17g %.17g)",
                          what, f + 1, j, got[0], got[1], got[2], got[3], want[0], want[1],
                          want[2], want[3]);
            const double *pos = NULL;
            if (j == 0)
                pos = mlr_motion_root_pos(m) + 3 * f;
            else if (slot < P && (size_t)tj[slot] == j)
                pos = mlr_motion_trans(m) + 3 * (P * f + slot++);
            if (pos)
                ck_assert_msg(memcmp(pos, t, sizeof t) == 0, "%s: frame %zu joint %zu position",
                              what, f + 1, j);
        }
    }
}

/* Bit-identical motions (same skeleton assumed). */
static void assert_same_frames(const mlr_motion *a, const mlr_motion *b, const char *what)
{
    const size_t N = mlr_motion_n_frames(a), J = mlr_motion_n_joints(a), P = mlr_motion_n_trans(a);
    ck_assert_uint_eq(mlr_motion_n_frames(b), N);
    ck_assert_msg(memcmp(mlr_motion_rot(a), mlr_motion_rot(b), 4 * N * J * sizeof(double)) == 0,
                  "%s: rotations differ", what);
    ck_assert_msg(memcmp(mlr_motion_root_pos(a), mlr_motion_root_pos(b), 3 * N * sizeof(double)) ==
                      0,
                  "%s: root positions differ", what);
    if (P)
        ck_assert_msg(
            memcmp(mlr_motion_trans(a), mlr_motion_trans(b), 3 * N * P * sizeof(double)) == 0,
            "%s: translations differ", what);
}

START_TEST(every_value_of_every_clip_is_strtods)
{
    const clip_info *ci = &clips[_i];
    MLR_TEST_NEED_CLIP(ci->file);
    size_t len;
    char *text = slurp(clip_path(ci->file), &len);
    ck_assert_ptr_nonnull(text);
    mlr_motion *m = read_clip(ci);
    assert_frames_are_strtods(m, text, ci->file);
    /* and on several threads, the same bits */
    static const size_t threads[] = {0, 2, 3, 8};
    for (size_t i = 0; i < MLR_COUNTOF(threads); i++) {
        mlr_motion *b = NULL;
        mlr_diag d;
        ck_assert_int_eq(mlr_bvh_read_memory_mt(text, len, threads[i], NULL, &b, &d), MLR_OK);
        assert_same_frames(m, b, ci->file);
        mlr_motion_destroy(b);
    }
    free(text);
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(every_clip_parses_with_readme_counts)
{
    const clip_info *ci = &clips[_i];
    MLR_TEST_NEED_CLIP(ci->file);
    mlr_motion *m = read_clip(ci);
    ck_assert_uint_eq(mlr_motion_n_frames(m), ci->frames);
    ck_assert_uint_eq(mlr_motion_n_joints(m), ci->joints);
    ck_assert_uint_eq(mlr_motion_n_end_sites(m), ci->end_sites);
    ck_assert_uint_eq(mlr_motion_n_channels(m), ci->channels);
    ck_assert_uint_eq(mlr_motion_n_trans(m), ci->n_trans);
    ck_assert_double_eq(mlr_motion_frame_time(m), ci->frame_time);
    size_t J = ci->joints, N = ci->frames, total = 0;
    const int32_t *par = mlr_motion_parents(m);
    ck_assert_int_eq(par[0], -1);
    for (size_t j = 0; j < J; j++) {
        total += mlr_motion_joint_n_channels(m, j);
        if (j)
            ck_assert(par[j] >= 0 && (size_t)par[j] < j);
        ck_assert_ptr_nonnull(mlr_motion_joint_name(m, j));
    }
    ck_assert_uint_eq(total, ci->channels);
    const double *rot = mlr_motion_rot(m);
    for (size_t i = 0; i < N * J; i++) {
        const double *q = rot + 4 * i;
        ck_assert_close(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
    }
    size_t len;
    char *text = slurp(clip_path(ci->file), &len);
    ck_assert_ptr_nonnull(text);
    check_frame_against_text(m, text, 0);
    check_frame_against_text(m, text, N / 2);
    check_frame_against_text(m, text, N - 1);
    free(text);
    mlr_motion_destroy(m);
}
END_TEST

/* The packed accessors give what the per-joint ones give, for every clip; a short buffer gets
 * nothing written; NULL motions give 0. */
START_TEST(packed_accessors_match_per_joint_ones)
{
    MLR_TEST_NEED_CLIP(clips[_i].file);
    mlr_motion *m = read_clip(&clips[_i]);
    const size_t J = mlr_motion_n_joints(m);
    for (int which = 0; which < 2; which++) {
        size_t (*packed)(const mlr_motion *, char *, size_t) =
            which ? mlr_motion_joint_channels_packed : mlr_motion_joint_names_packed;
        const char *(*one)(const mlr_motion *, size_t) =
            which ? mlr_motion_joint_channels : mlr_motion_joint_name;
        const size_t n = packed(m, NULL, 0);
        char *buf = malloc(n + 1);
        ck_assert_ptr_nonnull(buf);
        memset(buf, '#', n + 1);
        ck_assert_uint_eq(packed(m, buf, n - 1), n); /* too short: untouched */
        ck_assert_int_eq(buf[0], '#');
        ck_assert_uint_eq(packed(m, buf, n), n);
        ck_assert_int_eq(buf[n], '#');
        const char *q = buf;
        for (size_t j = 0; j < J; j++) {
            ck_assert_str_eq(q, one(m, j));
            q += strlen(q) + 1;
        }
        ck_assert_ptr_eq(q, buf + n);
        ck_assert_uint_eq(packed(NULL, buf, n), 0);
        free(buf);
    }
    int32_t *orders = malloc(J * sizeof *orders);
    ck_assert_ptr_nonnull(orders);
    ck_assert_uint_eq(mlr_motion_joint_euler_orders(m, orders), J);
    for (size_t j = 0; j < J; j++)
        ck_assert_int_eq(orders[j], (int32_t)mlr_motion_joint_euler_order(m, j));
    ck_assert_uint_eq(mlr_motion_joint_euler_orders(NULL, orders), 0);
    ck_assert_uint_eq(mlr_motion_joint_euler_orders(m, NULL), 0);
    free(orders);
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(per_joint_euler_orders)
{
    MLR_TEST_NEED_CLIP(clips[1].file);
    /* cmu_131_01: 19 ZYX (root included) and 12 ZXY joints; Daz files: root ZYX, rest ZXY */
    mlr_motion *m = read_clip(&clips[1]);
    size_t zyx = 0, zxy = 0;
    for (size_t j = 0; j < mlr_motion_n_joints(m); j++) {
        mlr_euler_order o = mlr_motion_joint_euler_order(m, j);
        zyx += o == MLR_EULER_ZYX;
        zxy += o == MLR_EULER_ZXY;
    }
    ck_assert_uint_eq(zyx, 19);
    ck_assert_uint_eq(zxy, 12);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 0), MLR_EULER_ZYX);
    mlr_motion_destroy(m);

    if (!MLR_TEST_HAVE_CLIP(clips[2].file))
        return;
    m = read_clip(&clips[2]);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 0), MLR_EULER_ZYX);
    for (size_t j = 1; j < mlr_motion_n_joints(m); j++)
        ck_assert_int_eq(mlr_motion_joint_euler_order(m, j), MLR_EULER_ZXY);
    ck_assert_str_eq(mlr_motion_joint_channels(m, 0),
                     "Xposition Yposition Zposition Zrotation Yrotation Xrotation");
    ck_assert_str_eq(mlr_motion_joint_channels(m, 1), "Zrotation Xrotation Yrotation");
    ck_assert_str_eq(mlr_motion_joint_name(m, 0), "hip");
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(bandai_position_channels_replace_offsets)
{
    MLR_TEST_NEED_CLIP(clips[6].file);
    mlr_motion *m = read_clip(&clips[6]);
    size_t J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m), N = mlr_motion_n_frames(m);
    ck_assert_uint_eq(P, J - 1);
    const int32_t *tj = mlr_motion_trans_joints(m);
    const double *tr = mlr_motion_trans(m), *off = mlr_motion_offsets(m);
    ck_assert_str_eq(mlr_motion_joint_name(m, 1), "Hips");
    ck_assert_int_eq(tj[0], 1);
    /* Hips moves (the body translation); the other joints' channels equal their OFFSET */
    double travel = fabs(tr[3 * (P * (N - 1))] - tr[0]) + fabs(tr[3 * (P * (N - 1)) + 2] - tr[2]);
    ck_assert(travel > 50.0);
    for (size_t f = 0; f < N; f += 17)
        for (size_t k = 1; k < P; k++)
            for (int c = 0; c < 3; c++)
                ck_assert_close(tr[3 * (P * f + k) + c], off[3 * (size_t)tj[k] + c], 1e-3);
    mlr_motion_destroy(m);
}
END_TEST

/* ---- round trips ------------------------------------------------------------------------- */

static void assert_same_motion(const mlr_motion *a, const mlr_motion *b, double rot_tol)
{
    size_t J = mlr_motion_n_joints(a), N = mlr_motion_n_frames(a), E = mlr_motion_n_end_sites(a),
           P = mlr_motion_n_trans(a);
    ck_assert_uint_eq(mlr_motion_n_joints(b), J);
    ck_assert_uint_eq(mlr_motion_n_frames(b), N);
    ck_assert_uint_eq(mlr_motion_n_end_sites(b), E);
    ck_assert_uint_eq(mlr_motion_n_trans(b), P);
    ck_assert_uint_eq(mlr_motion_n_channels(b), mlr_motion_n_channels(a));
    ck_assert_double_eq(mlr_motion_frame_time(b), mlr_motion_frame_time(a));
    for (size_t j = 0; j < J; j++) {
        ck_assert_str_eq(mlr_motion_joint_name(b, j), mlr_motion_joint_name(a, j));
        ck_assert_str_eq(mlr_motion_joint_channels(b, j), mlr_motion_joint_channels(a, j));
        ck_assert_int_eq(mlr_motion_parents(b)[j], mlr_motion_parents(a)[j]);
        for (int k = 0; k < 3; k++)
            ck_assert_double_eq(mlr_motion_offsets(b)[3 * j + k],
                                mlr_motion_offsets(a)[3 * j + k]);
    }
    for (size_t e = 0; e < E; e++) {
        ck_assert_int_eq(mlr_motion_end_site_parents(b)[e], mlr_motion_end_site_parents(a)[e]);
        for (int k = 0; k < 3; k++)
            ck_assert_double_eq(mlr_motion_end_site_offsets(b)[3 * e + k],
                                mlr_motion_end_site_offsets(a)[3 * e + k]);
    }
    for (size_t i = 0; i < 3 * N; i++)
        ck_assert_double_eq(mlr_motion_root_pos(b)[i], mlr_motion_root_pos(a)[i]);
    for (size_t i = 0; i < 3 * N * P; i++)
        ck_assert_double_eq(mlr_motion_trans(b)[i], mlr_motion_trans(a)[i]);
    double worst = 0.0;
    for (size_t i = 0; i < N * J; i++) {
        double d = quat_angle(mlr_motion_rot(a) + 4 * i, mlr_motion_rot(b) + 4 * i);
        if (d > worst)
            worst = d;
    }
    ck_assert_msg(worst <= rot_tol, "rotation differs by %.3g rad", worst);
}

static char *write_to_memory(const mlr_motion *m, size_t *len)
{
    ck_assert_int_eq(mlr_bvh_write_memory(m, NULL, 0, len, NULL), MLR_OK);
    char *buf = malloc(*len + 1);
    size_t len2 = 0;
    ck_assert_int_eq(mlr_bvh_write_memory(m, buf, *len, &len2, NULL), MLR_OK);
    ck_assert_uint_eq(len2, *len);
    buf[*len] = '\0';
    return buf;
}

START_TEST(round_trip_every_clip)
{
    MLR_TEST_NEED_CLIP(clips[_i].file);
    mlr_motion *a = read_clip(&clips[_i]);
    size_t len;
    char *text = write_to_memory(a, &len);
    mlr_motion *b = NULL;
    mlr_diag d;
    mlr_status s = mlr_bvh_read_memory(text, len, NULL, &b, &d);
    ck_assert_msg(s == MLR_OK, "re-read: line %zu: %s", d.line, d.message);
    assert_same_motion(a, b, 1e-6);
    /* a second generation is byte-identical to the first */
    size_t len2;
    char *text2 = write_to_memory(b, &len2);
    mlr_motion *c = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(text2, len2, NULL, &c, NULL), MLR_OK);
    assert_same_motion(b, c, 1e-6);
    free(text);
    free(text2);
    mlr_motion_destroy(a);
    mlr_motion_destroy(b);
    mlr_motion_destroy(c);
}
END_TEST

static char tmpdir[256];

static void make_tmpdir(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/mlr_test_bvh_XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(tmpdir));
}

static void remove_tmpdir(void)
{
    char cmd[512];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    ck_assert_int_eq(system(cmd), 0);
}

START_TEST(write_file_is_atomic_and_matches_memory)
{
    make_tmpdir();
    mlr_motion *a = read_clip(&clips[1]);
    char path[512];
    snprintf(path, sizeof path, "%s/out.bvh", tmpdir);
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_write_file(a, path, &d), MLR_OK);
    ck_assert_uint_eq(mlr_test_dir_entries(tmpdir), 1); /* no temporary left behind */
    size_t flen, mlen;
    char *ftext = slurp(path, &flen), *mtext = write_to_memory(a, &mlen);
    ck_assert_uint_eq(flen, mlen);
    ck_assert_int_eq(memcmp(ftext, mtext, flen), 0);
    mlr_motion *b = NULL;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &b, &d), MLR_OK);
    assert_same_motion(a, b, 1e-6);

    /* a failing write (non-finite value) leaves the old file untouched and no temporary */
    mlr_motion_rot_mut(b)[5] = NAN;
    ck_assert_int_eq(mlr_bvh_write_file(b, path, &d), MLR_E_INVALID_ARG);
    size_t flen2;
    char *ftext2 = slurp(path, &flen2);
    ck_assert_uint_eq(flen2, flen);
    ck_assert_int_eq(memcmp(ftext, ftext2, flen), 0);
    ck_assert_uint_eq(mlr_test_dir_entries(tmpdir), 1);
    mlr_motion_destroy(b);

    /* a missing directory is an I/O error */
    snprintf(path, sizeof path, "%s/no/such/dir/out.bvh", tmpdir);
    ck_assert_int_eq(mlr_bvh_write_file(a, path, &d), MLR_E_IO);
    ck_assert(strlen(d.message) > 0);
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &b, &d), MLR_E_IO);
    ck_assert_ptr_null(b);
    free(ftext);
    free(ftext2);
    free(mtext);
    mlr_motion_destroy(a);
    remove_tmpdir();
}
END_TEST

static int stop_after_first(void *user, const char *data, size_t len)
{
    (void)data;
    (void)len;
    return (*(int *)user)++ > 0;
}

START_TEST(write_memory_overflow_and_callback_stop)
{
    /* any clip: the dog, or the bundled walk when the shared clips are absent */
    char path[4096];
    mlr_motion *a =
        read_clip(mlr_test_clip_path(clips[7].file, path, sizeof path) ? &clips[7] : &clips[1]);
    size_t len, len2;
    ck_assert_int_eq(mlr_bvh_write_memory(a, NULL, 0, &len, NULL), MLR_OK);
    char small[100];
    ck_assert_int_eq(mlr_bvh_write_memory(a, small, sizeof small, &len2, NULL), MLR_E_OVERFLOW);
    ck_assert_uint_eq(len2, len);
    ck_assert_int_eq(memcmp(small, "HIERARCHY\n", 10), 0);
    int calls = 0;
    ck_assert_int_eq(mlr_bvh_write(a, stop_after_first, &calls, NULL), MLR_E_IO);
    ck_assert_int_eq(calls, 2);
    ck_assert_int_eq(mlr_bvh_write(NULL, stop_after_first, &calls, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_write_memory(a, NULL, 0, NULL, NULL), MLR_E_INVALID_ARG);
    /* a zero quaternion cannot be written */
    memset(mlr_motion_rot_mut(a), 0, 4 * sizeof(double));
    ck_assert_int_eq(mlr_bvh_write_memory(a, NULL, 0, &len, NULL), MLR_E_INVALID_ARG);
    mlr_motion_destroy(a);
}
END_TEST

START_TEST(copy_frames_slices)
{
    MLR_TEST_NEED_CLIP(clips[6].file); /* Bandai's 213 frames and position channels */
    mlr_motion *a = read_clip(&clips[6]), *b = NULL;
    size_t J = mlr_motion_n_joints(a), P = mlr_motion_n_trans(a);
    ck_assert_int_eq(mlr_motion_copy_frames(a, 10, 40, &b, NULL), MLR_OK);
    ck_assert_uint_eq(mlr_motion_n_frames(b), 40);
    ck_assert_int_eq(
        memcmp(mlr_motion_rot(b), mlr_motion_rot(a) + 4 * J * 10, 40 * 4 * J * sizeof(double)), 0);
    ck_assert_int_eq(
        memcmp(mlr_motion_trans(b), mlr_motion_trans(a) + 3 * P * 10, 40 * 3 * P * sizeof(double)),
        0);
    ck_assert_int_eq(
        memcmp(mlr_motion_root_pos(b), mlr_motion_root_pos(a) + 30, 40 * 3 * sizeof(double)), 0);
    ck_assert_str_eq(mlr_motion_joint_name(b, 3), mlr_motion_joint_name(a, 3));
    mlr_motion_destroy(b);
    b = (mlr_motion *)&b;
    ck_assert_int_eq(mlr_motion_copy_frames(a, 200, 14, &b, NULL), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(b);
    ck_assert_int_eq(mlr_motion_copy_frames(a, 213, 0, &b, NULL), MLR_OK);
    ck_assert_uint_eq(mlr_motion_n_frames(b), 0);
    ck_assert_ptr_null(mlr_motion_rot(b));
    mlr_motion_destroy(b);
    mlr_motion_destroy(a);
}
END_TEST

/* ---- whitespace, line ends, layouts ------------------------------------------------------ */

static const char small_bvh[] =
    "HIERARCHY\n"
    "ROOT Hips\n"
    "{\n"
    "  OFFSET 1 2 3\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  JOINT Spine\n"
    "  {\n"
    "    OFFSET 0 10 0\n"
    "    CHANNELS 3 Xrotation Yrotation Zrotation\n"
    "    End Site\n"
    "    {\n"
    "      OFFSET 0 5 0\n"
    "    }\n"
    "  }\n"
    "  JOINT Leg\n"
    "  {\n"
    "    OFFSET 2 -10 0\n"
    "    CHANNELS 6 Zrotation Yposition Xrotation Xposition Yrotation Zposition\n"
    "  }\n"
    "}\n"
    "MOTION\n"
    "Frames: 2\n"
    "Frame Time: 0.5\n"
    "1 2 3 10 20 30 40 50 60 70 80 90 7 8 9\n"
    "-1 -2 -3.5e0 0 0 0 0 0 0 0 0 0 0 0 0\n";

static char *replace_all(const char *s, const char *from, const char *to)
{
    size_t n = 0, fl = strlen(from), tl = strlen(to);
    for (const char *p = strstr(s, from); p; p = strstr(p + fl, from))
        n++;
    char *out = malloc(strlen(s) + n * tl + 1), *o = out;
    for (const char *p = s;;) {
        const char *q = strstr(p, from);
        if (!q) {
            strcpy(o, p);
            break;
        }
        memcpy(o, p, (size_t)(q - p));
        o += q - p;
        memcpy(o, to, tl);
        o += tl;
        p = q + fl;
    }
    return out;
}

static void check_small(const mlr_motion *m)
{
    ck_assert_uint_eq(mlr_motion_n_joints(m), 3);
    ck_assert_uint_eq(mlr_motion_n_frames(m), 2);
    ck_assert_uint_eq(mlr_motion_n_end_sites(m), 1);
    ck_assert_uint_eq(mlr_motion_n_trans(m), 1);
    ck_assert_int_eq(mlr_motion_trans_joints(m)[0], 2);
    ck_assert_str_eq(mlr_motion_joint_name(m, 2), "Leg");
    ck_assert_int_eq(mlr_motion_parents(m)[2], 0);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 0), MLR_EULER_ZXY);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 1), MLR_EULER_XYZ);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 2), MLR_EULER_ZXY);
    ck_assert_int_eq(mlr_motion_joint_has_position(m, 2), 1);
    ck_assert_int_eq(mlr_motion_joint_has_position(m, 1), 0);
    const double *t = mlr_motion_trans(m), *rp = mlr_motion_root_pos(m);
    /* Leg: Zrot=70 Ypos=80 Xrot=90 Xpos=7 Yrot=8 Zpos=9 */
    ck_assert_double_eq(t[0], 7.0);
    ck_assert_double_eq(t[1], 80.0);
    ck_assert_double_eq(t[2], 9.0);
    ck_assert_double_eq(rp[3], -1.0);
    ck_assert_double_eq(rp[5], -3.5);
    ck_assert_double_eq(mlr_motion_end_site_offsets(m)[1], 5.0);
}

START_TEST(whitespace_and_line_end_variants)
{
    static const char *const variants[][2] = {
        {"\n", "\r\n"},
        {"\n", "\r"},
        {"  ", "\t"},
        {" ", " \t \v\f "},
        {"HIERARCHY", "hierarchy"},
        {"CHANNELS", "channels"},
        {"Frames: ", "Frames:"},
        {"Frame Time: ", "Frame Time:\t"},
        {"}\n", "}\n\n\n"},
        {"Hips\n", "Hips {\n"},
    };
    char *base = NULL;
    for (size_t v = 0; v < MLR_COUNTOF(variants); v++) {
        char *text = replace_all(small_bvh, variants[v][0], variants[v][1]);
        if (v == 9) { /* brace on the name line: drop the brace line that follows */
            char *t2 = replace_all(text, "Hips {\n{\n", "Hips {\n");
            free(text);
            text = t2;
        }
        mlr_diag d;
        mlr_status s;
        mlr_motion *m = read_text(text, &d, &s);
        ck_assert_msg(s == MLR_OK, "variant %zu: line %zu: %s", v, d.line, d.message);
        check_small(m);
        mlr_motion_destroy(m);
        free(text);
    }
    /* a byte order mark and trailing NUL padding */
    base = malloc(sizeof small_bvh + 8);
    memcpy(base, "\xEF\xBB\xBF", 3);
    memcpy(base + 3, small_bvh, sizeof small_bvh - 1);
    memset(base + 3 + sizeof small_bvh - 1, 0, 4);
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(base, sizeof small_bvh + 6, NULL, &m, NULL), MLR_OK);
    check_small(m);
    mlr_motion_destroy(m);
    free(base);
}
END_TEST

START_TEST(small_file_round_trip_keeps_layout)
{
    mlr_status s;
    mlr_motion *a = read_text(small_bvh, NULL, &s);
    ck_assert_int_eq(s, MLR_OK);
    size_t len;
    char *text = write_to_memory(a, &len);
    ck_assert_ptr_nonnull(strstr(text, "CHANNELS 6 Zrotation Yposition Xrotation Xposition "
                                       "Yrotation Zposition\n"));
    ck_assert_ptr_nonnull(strstr(text, "Frame Time: 0.5\n"));
    ck_assert_ptr_nonnull(strstr(text, "\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 5 0\n\t\t}\n"));
    mlr_motion *b = read_text(text, NULL, &s);
    ck_assert_int_eq(s, MLR_OK);
    check_small(b);
    assert_same_motion(a, b, 1e-9);
    free(text);
    mlr_motion_destroy(a);
    mlr_motion_destroy(b);
}
END_TEST

START_TEST(partial_and_empty_channel_lists)
{
    static const char text[] =
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Yposition\n"
        "JOINT a\n{\nOFFSET 1 0 0\nCHANNELS 1 Yrotation\n"
        "JOINT b\n{\nOFFSET 1 0 0\nCHANNELS 0\n"
        "JOINT c\n{\nOFFSET 1 0 0\nCHANNELS 2 Xposition Zrotation\n}\n}\n}\n"
        "JOINT d\n{\nOFFSET 0 1 0\n}\n}\n"
        "MOTION\nFrames: 1\nFrame Time: 0.1\n5 90 3 45\n";
    mlr_diag d;
    mlr_status s;
    mlr_motion *m = read_text(text, &d, &s);
    ck_assert_msg(s == MLR_OK, "line %zu: %s", d.line, d.message);
    ck_assert_uint_eq(mlr_motion_n_channels(m), 4);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 1), MLR_EULER_YXZ);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 3), MLR_EULER_ZXY);
    ck_assert_str_eq(mlr_motion_joint_channels(m, 2), "");
    ck_assert_uint_eq(mlr_motion_joint_n_channels(m, 4), 0);
    const double *rp = mlr_motion_root_pos(m), *rot = mlr_motion_rot(m);
    ck_assert_double_eq(rp[0], 0.0);
    ck_assert_double_eq(rp[1], 5.0);
    ck_assert_close(rot[4 * 1 + 0], sqrt(0.5), 1e-15); /* 90 deg about Y */
    ck_assert_close(rot[4 * 1 + 2], sqrt(0.5), 1e-15);
    ck_assert_double_eq(rot[4 * 2 + 0], 1.0);
    const double *t = mlr_motion_trans(m);
    ck_assert_double_eq(t[0], 3.0);
    ck_assert_double_eq(t[1], 0.0);
    size_t len;
    char *out = write_to_memory(m, &len);
    ck_assert_ptr_nonnull(strstr(out, "CHANNELS 0\n"));
    ck_assert_ptr_nonnull(strstr(out, "\n5 90 3 45\n"));
    mlr_motion *b = read_text(out, NULL, &s);
    ck_assert_int_eq(s, MLR_OK);
    assert_same_motion(m, b, 1e-12);
    free(out);
    mlr_motion_destroy(b);
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(numbers_are_correctly_rounded)
{
    /* position channels carry values through untouched: compare with strtod bit for bit */
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 42);
    enum { N = 3000 };
    static char text[N * 3 * 48 + 512];
    size_t len = (size_t)sprintf(text,
                                 "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition "
                                 "Yposition Zposition\n}\nMOTION\nFrames: %d\nFrame Time: 1\n",
                                 N);
    static char tokens[N * 3][48];
    for (int i = 0; i < N * 3; i++) {
        char *t = tokens[i];
        int kind = (int)(mlr_test_rng_u64(&rng) % 5), n = 0;
        if (mlr_test_rng_u64(&rng) & 1)
            t[n++] = '-';
        int digits = 1 + (int)(mlr_test_rng_u64(&rng) % (kind == 4 ? 25 : 17));
        int dot = (int)(mlr_test_rng_u64(&rng) % (unsigned)(digits + 1));
        for (int k = 0; k < digits; k++) {
            if (k == dot && kind != 0)
                t[n++] = '.';
            t[n++] = (char)('0' + mlr_test_rng_u64(&rng) % 10);
        }
        if (kind >= 2)
            n += sprintf(t + n, "e%d", (int)(mlr_test_rng_u64(&rng) % 80) - 40);
        if (kind == 3)
            n = sprintf(t, "%.17g", mlr_test_rng_normal(&rng) * 1e3);
        t[n] = '\0';
        len += (size_t)sprintf(text + len, "%s%s", t, i % 3 == 2 ? "\n" : " ");
    }
    mlr_motion *m = NULL;
    mlr_diag d;
    mlr_status s = mlr_bvh_read_memory(text, len, NULL, &m, &d);
    ck_assert_msg(s == MLR_OK, "line %zu: %s", d.line, d.message);
    const double *v = mlr_motion_root_pos(m);
    for (int i = 0; i < N * 3; i++) {
        double ref = strtod(tokens[i], NULL);
        ck_assert_msg(memcmp(&ref, &v[i], sizeof ref) == 0, "'%s': %.17g vs %.17g", tokens[i],
                      v[i], ref);
    }
    /* and they are written back exactly */
    size_t wlen;
    char *w = write_to_memory(m, &wlen);
    mlr_motion *b = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(w, wlen, NULL, &b, NULL), MLR_OK);
    ck_assert_int_eq(memcmp(mlr_motion_root_pos(b), v, 3 * N * sizeof(double)), 0);
    free(w);
    mlr_motion_destroy(b);
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(number_fast_path_boundaries)
{
    /* The reader's fast path takes up to 7 integer and 7 fraction digits without exponent when
     * 18 bytes remain; each token here is read once in the middle of the file and once as the
     * file's last value (the general path), and must equal strtod bit for bit. */
    static const char *const tokens[] = {
        "0",
        "-0",
        "+0",
        "-0.0000000",
        "0.0000001",
        "-0.0000001",
        "5.",
        "-5.",
        ".5",
        "-.5",
        "+.25",
        "1234567",
        "-1234567",
        "12345678",
        "123456789",
        "1234567.1234567",
        "-9999999.9999999",
        "9999999.99999999",
        "1.12345678",
        "0.12345678901234567",
        "0.1",
        "0.2",
        "0.3",
        "-224.689499",
        "0.003093",
        "-0.000001",
        "77.536437",
        "1e5",
        "1.5E-3",
        "-2.5e+2",
        "123456.7e1",
        "0.1e0",
        "00000001.5",
        "0001234567.0000001",
        "4503599627370497",
        "9007199254740993",
        "0.9007199254740993",
        "1797693.1348623157",
        "3.0000000000000004",
        "1.00000000000000011102230246251565",
    };
    char text[4096];
    for (size_t i = 0; i < MLR_COUNTOF(tokens); i++) {
        int n = snprintf(text, sizeof text,
                         "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition "
                         "Zposition\n}\nMOTION\nFrames: 2\nFrame Time: 1\n%s 1 %s\r\n7 %s\t%s",
                         tokens[i], tokens[i], tokens[i], tokens[i]);
        ck_assert(n > 0 && (size_t)n < sizeof text);
        mlr_motion *m = NULL;
        mlr_diag d;
        mlr_status s = mlr_bvh_read_memory(text, (size_t)n, NULL, &m, &d);
        ck_assert_msg(s == MLR_OK, "'%s': line %zu: %s", tokens[i], d.line, d.message);
        const double ref = strtod(tokens[i], NULL), *v = mlr_motion_root_pos(m);
        const int at[4] = {0, 2, 4, 5};
        for (int k = 0; k < 4; k++)
            ck_assert_msg(memcmp(&ref, &v[at[k]], sizeof ref) == 0,
                          "'%s' (value %d): %.17g vs %.17g", tokens[i], at[k], v[at[k]], ref);
        mlr_motion_destroy(m);
    }
    /* not numbers, whatever the path */
    static const char *const bad[] = {"-",   "+",   ".",    "-.",  "1.2.3", "1-",  "1e",
                                      "1e+", "--1", "0x10", "1,5", "nan",   "inf", "1.5x"};
    for (size_t i = 0; i < 2 * MLR_COUNTOF(bad); i++) {
        const char *b = bad[i / 2];
        const int last = (int)(i % 2); /* in the middle (fast path), or the file's last value */
        int n = snprintf(text, sizeof text,
                         "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition "
                         "Zposition\n}\nMOTION\nFrames: 2\nFrame Time: 1\n1 2 3\n1 %s %s",
                         last ? "2" : b, last ? b : "2                   ");
        mlr_motion *m = NULL;
        mlr_diag d;
        ck_assert_msg(mlr_bvh_read_memory(text, (size_t)n, NULL, &m, &d) == MLR_E_PARSE,
                      "'%s' was accepted", b);
        ck_assert_uint_eq(d.line, 11);
        ck_assert_ptr_null(m);
    }
}
END_TEST

START_TEST(locale_with_decimal_comma)
{
    const char *names[] = {"de_DE.UTF-8", "de_DE.utf8", "fr_FR.UTF-8", "C.UTF-8"};
    const char *got = NULL;
    for (size_t i = 0; i < MLR_COUNTOF(names) && !got; i++)
        got = setlocale(LC_NUMERIC, names[i]);
    /* Even without such a locale the test checks the slow path (long numbers) still works. */
    static const char text[] = "HIERARCHY\nROOT r\n{\nOFFSET 0.5 0 0\nCHANNELS 3 Xposition "
                               "Yposition Zposition\n}\nMOTION\nFrames: 1\nFrame Time: 0.25\n"
                               "1.00000000000000000000001 2.5e-300 0.1234567890123456789\n";
    mlr_status s;
    mlr_diag d;
    mlr_motion *m = read_text(text, &d, &s);
    ck_assert_msg(s == MLR_OK, "line %zu: %s", d.line, d.message);
    ck_assert_double_eq(mlr_motion_root_pos(m)[0], 1.0);
    ck_assert_double_eq(mlr_motion_root_pos(m)[1], 2.5e-300);
    ck_assert_double_eq(mlr_motion_root_pos(m)[2], 0.1234567890123456789);
    size_t len;
    char *out = write_to_memory(m, &len);
    ck_assert_ptr_nonnull(strstr(out, "OFFSET 0.5 0 0\n"));
    ck_assert_ptr_nonnull(strstr(out, "Frame Time: 0.25\n"));
    ck_assert_ptr_null(strchr(out, ','));
    free(out);
    mlr_motion_destroy(m);
    setlocale(LC_NUMERIC, "C");
}
END_TEST

START_TEST(deep_nesting_needs_no_recursion)
{
    enum { DEPTH = 100000 };
    size_t cap = (size_t)DEPTH * 64 + 256, len = 0;
    char *text = malloc(cap);
    len += (size_t)sprintf(text + len, "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation "
                                       "Yrotation Zrotation\n");
    for (int i = 1; i < DEPTH; i++)
        len += (size_t)sprintf(text + len, "JOINT j%d\n{\nOFFSET 0 1 0\nCHANNELS 0\n", i);
    len += (size_t)sprintf(text + len, "End Site\n{\nOFFSET 0 1 0\n}\n");
    for (int i = 0; i < DEPTH; i++)
        text[len++] = '}', text[len++] = '\n';
    len += (size_t)sprintf(text + len, "MOTION\nFrames: 1\nFrame Time: 1\n90 0 0\n");
    mlr_motion *m = NULL;
    mlr_diag d;
    mlr_status s = mlr_bvh_read_memory(text, len, NULL, &m, &d);
    ck_assert_msg(s == MLR_OK, "line %zu: %s", d.line, d.message);
    ck_assert_uint_eq(mlr_motion_n_joints(m), DEPTH);
    ck_assert_int_eq(mlr_motion_parents(m)[DEPTH - 1], DEPTH - 2);
    size_t wlen;
    char *w = write_to_memory(m, &wlen);
    mlr_motion *b = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(w, wlen, NULL, &b, &d), MLR_OK);
    assert_same_motion(m, b, 1e-9);
    /* missing the last brace: an error at the end, not a crash */
    mlr_motion_destroy(b);
    char *mos = strstr(text, "}\nMOTION");
    if (mos == NULL)
        ck_abort_msg("no closing brace before MOTION");
    memmove(mos, mos + 2, strlen(mos + 2) + 1);
    s = mlr_bvh_read_memory(text, strlen(text), NULL, &b, &d);
    ck_assert_int_eq(s, MLR_E_PARSE);
    ck_assert_ptr_nonnull(strstr(d.message, "missing '}'"));
    free(w);
    free(text);
    mlr_motion_destroy(m);
}
END_TEST

/* ---- malformed input --------------------------------------------------------------------- */

static const char hier[] = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation "
                           "Zrotation\n}\nMOTION\n"; /* MOTION on line 7 */

static const struct bad_case {
    const char *text; /* "%H" at the start stands for hier */
    size_t line;
    const char *reason; /* substring of the message */
} bad_cases[] = {
    {"", 1, "empty input"},
    {"   \n\n", 3, "empty input"},
    {"HIERARCHY\n", 2, "expected 'ROOT'"},
    {"HIERARCH\nROOT r", 1, "expected HIERARCHY"},
    {"HIERARCHY\nROOT\n{", 2, "ROOT without a name"},
    {"HIERARCHY\nROOT r\nOFFSET 0 0 0", 3, "expected '{'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0\nCHANNELS 0\n}", 5, "a number in OFFSET"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 nan 0\n}", 4, "found 'nan'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 inf 0\n}", 4, "found 'inf'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 1e999 0\n}", 4, "found '1e999'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nOFFSET 0 0 0\n}", 5, "second OFFSET"},
    {"HIERARCHY\nROOT r\n{\nCHANNELS 0\n}\nMOTION", 5, "has no OFFSET"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 7 Xrotation", 5, "CHANNELS count"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS -1", 5, "CHANNELS count"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation\n}", 6,
     "lists only 2 channel names"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Wrotation\n}", 5,
     "unknown channel 'Wrotation'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation xrotation\n}", 5, "listed twice"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\nCHANNELS 0\n}", 6,
     "second CHANNELS"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nJOINT a\n{\nOFFSET 0 0 0\n}\n", 9,
     "in joint 'r' (missing '}')"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nJOINT a\n{\nOFFSET 0 0 0\nMOTION\n", 8,
     "MOTION inside joint 'a'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nROOT b\n", 5, "ROOT inside joint"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nFOO 1\n}", 5, "unexpected 'FOO' in joint 'r'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nEnd\n{\n}", 6, "expected 'Site'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nEnd Site\n{\n}\n}", 7, "expected 'OFFSET'"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nEnd Site\n{\nOFFSET 1 2 3\nOFFSET 1 2 3\n}", 8,
     "to close the End Site"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n}\n}\n", 6, "expected MOTION"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n}\n", 6, "expected MOTION"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n}\nROOT s\n", 6, "more than one ROOT"},
    {"HIERARCHY\nROOT r\n{\nOFF\x01SET 0 0 0\n}", 4, "control byte 0x01"},
    {"HIERARCHY\nROOT r\x02x\n{", 2, "control byte 0x02"},
    {"\x7f"
     "ELF\x02\x01\x01",
     1, "control byte 0x7f"},
    {"%H", 8, "expected 'Frames:'"},
    {"%HFrames: 1\n", 9, "expected 'Frame'"},
    {"%HFrames:\nFrame Time: 1\n", 8, "missing value"},
    {"%HFrames: x1\nFrame Time: 1\n", 8, "needs a whole number"},
    {"%HFrames: -1\nFrame Time: 1\n", 8, "needs a whole number"},
    {"%HFrames: 99999999999999999999999\nFrame Time: 1\n", 8, "out of range"},
    {"%HFrames: 1000000000\nFrame Time: 1\n0 0 0\n", 8, "hold at most 1 frames"},
    {"%HFrames: 1\nFrame Time: 0\n0 0 0\n", 9, "must be positive"},
    {"%HFrames: 1\nFrame Time: -0.1\n0 0 0\n", 9, "must be positive"},
    {"%HFrames: 1\nFrame Time: abc\n0 0 0\n", 9, "needs a number"},
    {"%HFrames: 1\nFrame Time: 1 2\n0 0 0\n", 9, "after Frame Time"},
    {"%HFrames: 2\nFrame Time: 1\n10 20 30\n1 2\n", 11, "frame 2 has 2 values, expected 3"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 2 3 4\n", 11, "frame 2 has more than 3 values"},
    {"%HFrames: 3\nFrame Time: 1\n10 20 30\n10 20 30\n", 12, "2 of 3 frames"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 2 3\n4 5 6\n", 12, "data after the 2 frames"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 nan 3\n", 11, "invalid number 'nan'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 -inf 3\n", 11, "invalid number '-inf'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 1e400 3\n", 11, "invalid number '1e400'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 1.2.3 3\n", 11, "invalid number '1.2.3'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 2,5 3\n", 11, "invalid number '2,5'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 0x10 3\n", 11, "invalid number '0x10'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 2e 3\n", 11, "invalid number '2e'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 . 3\n", 11, "invalid number '.'"},
    {"%HFrames: 2\nFrame Time: 1\n0 0 0\n1 \x03\x04 3\n", 11,
     "invalid number '?"
     "?'"},
    {"%HFrames: 1\nFrame Time: 1\n0 0 0\n\x01\x02\x03", 11, "data after the 1 frames"},
    {"HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 5\nFrame Time: 1\n", 7,
     "declares no channels"},
};

START_TEST(malformed_input_reports_line_and_reason)
{
    const struct bad_case *bc = &bad_cases[_i];
    char text[512];
    if (strncmp(bc->text, "%H", 2) == 0)
        snprintf(text, sizeof text, "%s%s", hier, bc->text + 2);
    else
        snprintf(text, sizeof text, "%s", bc->text);
    mlr_diag d;
    memset(&d, 0x55, sizeof d);
    static char sentinel;
    mlr_motion *m = (mlr_motion *)&sentinel;
    mlr_status s = mlr_bvh_read_memory(text, strlen(text), NULL, &m, &d);
    ck_assert_int_eq(s, MLR_E_PARSE);
    ck_assert_ptr_null(m);
    ck_assert_msg(memchr(d.message, '\0', sizeof d.message) != NULL, "message not terminated");
    ck_assert_msg(strstr(d.message, bc->reason) != NULL, "case %d: message '%s' lacks '%s'", _i,
                  d.message, bc->reason);
    ck_assert_msg(d.line == bc->line, "case %d ('%s'): line %zu, expected %zu", _i, d.message,
                  d.line, bc->line);
}
END_TEST

/* ---- lenient reading (mlr_bvh_read_memory_opts) -------------------------------------------- */

enum { LENIENT = 0, STRICT = 1, KEEP = 2 };

/* Frame line k holds "k 0 0" (Xrotation k degrees), so the frames read are known by angle. */
static const struct lenient_case {
    const char *text; /* "%H" stands for hier: MOTION on line 7, Frames: 8, the first
                                frame line 10 */
    int mode;
    mlr_status status;
    size_t n_frames; /* on MLR_OK; frames 1..n_frames */
    int codes[3]; /* warning codes in order, 0-terminated */
    size_t line; /* line of the first warning, or of the error */
    const char *reason; /* in the first warning, or in the error */
} lenient_cases[] = {
    /* one motion line more than Frames: (an assimp test file; Blender and bvhio read it) */
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0\n3 0 0\n",
     LENIENT,
     MLR_OK,
     3,
     {MLR_BVH_WARN_EXTRA_FRAMES},
     12,
     "3 frame lines, but Frames: declares 2"},
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0\n3 0 0\n",
     STRICT,
     MLR_E_PARSE,
     0,
     {0},
     12,
     "data after the 2 frames"},
    {"%HFrames: 1\nFrame Time: 1\n1 0 0\n2 0 0\n\n3 0 0\n4 0 0\n5 0 0\n",
     LENIENT,
     MLR_OK,
     5,
     {MLR_BVH_WARN_EXTRA_FRAMES},
     11,
     "all 5 are read"},
    {"%HFrames: 0\nFrame Time: 1\n1 0 0\n2 0 0\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_EXTRA_FRAMES},
     10,
     "declares 0"},
    /* missing lines: up to MLR_BVH_MAX_MISSING_FRAMES */
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_MISSING_FRAMES},
     12,
     "declares 3, but the file has 2 frame lines"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n",
     STRICT,
     MLR_E_PARSE,
     0,
     {0},
     8,
     "hold at most 2 frames"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n\n\n\n\n\n",
     STRICT,
     MLR_E_PARSE,
     0,
     {0},
     17,
     "2 of 3 frames"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n\n\n\n\n\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_MISSING_FRAMES},
     17,
     "declares 3"},
    {"%HFrames: 5\nFrame Time: 1\n1 0 0\n2 0 0\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_MISSING_FRAMES},
     12,
     "declares 5"},
    {"%HFrames: 6\nFrame Time: 1\n1 0 0\n2 0 0\n",
     LENIENT,
     MLR_E_PARSE,
     0,
     {0},
     12,
     "truncated file: 2 of 6 frames"},
    {"%HFrames: 6\nFrame Time: 1\n1 0 0\n2 0 0\n",
     KEEP,
     MLR_OK,
     2,
     {MLR_BVH_WARN_TRUNCATED},
     12,
     "kept the 2 complete frames of 6"},
    {"%HFrames: 1000000000\nFrame Time: 1\n1 0 0\n",
     LENIENT,
     MLR_E_PARSE,
     0,
     {0},
     11,
     "1 of 1000000000 frames"},
    {"%HFrames: 1000000000\nFrame Time: 1\n1 0 0\n",
     KEEP,
     MLR_OK,
     1,
     {MLR_BVH_WARN_TRUNCATED},
     11,
     "kept the 1 complete frames"},
    /* trailing data */
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0\nEND\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_TRAILING_DATA},
     12,
     "data after the last frame ('END')"},
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0\nEND\n",
     STRICT,
     MLR_E_PARSE,
     0,
     {0},
     12,
     "data after the 2 frames"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n# exported by X\n7 7 7\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_MISSING_FRAMES, MLR_BVH_WARN_TRAILING_DATA},
     12,
     "declares 3"},
    {"%HFrames: 1\nFrame Time: 1\n1 0 0\n2 0 0\nfoo bar\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_EXTRA_FRAMES, MLR_BVH_WARN_TRAILING_DATA},
     11,
     "declares 1"},
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0\n3 0\n",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_TRAILING_DATA},
     12,
     "('3 0')"},
    {"%HFrames: 1\nFrame Time: 1\n1 0 0\n\x01\x02\x03",
     LENIENT,
     MLR_OK,
     1,
     {MLR_BVH_WARN_TRAILING_DATA},
     11,
     "('?"
     "?"
     "?')"},
    /* the final line end */
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0",
     LENIENT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_NO_FINAL_NEWLINE},
     11,
     "no line end after the last frame line"},
    {"%HFrames: 2\nFrame Time: 1\n1 0 0\n2 0 0  \t",
     STRICT,
     MLR_OK,
     2,
     {MLR_BVH_WARN_NO_FINAL_NEWLINE},
     11,
     "no line end"},
    {"%HFrames: 2\r\nFrame Time: 1\r\n1 0 0\r\n2 0 0\r\n\r\n  \n\0\0",
     LENIENT,
     MLR_OK,
     2,
     {0},
     0,
     NULL},
    /* truncated: the last line incomplete, or frames missing and no final line end */
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n3 0",
     LENIENT,
     MLR_E_PARSE,
     0,
     {0},
     12,
     "frame 3 has 2 values, expected 3 (truncated file: 2 of 3 frames)"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n3 0",
     KEEP,
     MLR_OK,
     2,
     {MLR_BVH_WARN_TRUNCATED},
     12,
     "frame 3 has 2 values"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n3 0\n",
     KEEP,
     MLR_OK,
     2,
     {MLR_BVH_WARN_TRUNCATED},
     12,
     "kept the 2 complete frames of 3"},
    {"%HFrames: 4\nFrame Time: 1\n1 0 0\n2 0 0\n3 0 0",
     LENIENT,
     MLR_E_PARSE,
     0,
     {0},
     12,
     "truncated file: 3 of 4 frames"},
    {"%HFrames: 4\nFrame Time: 1\n1 0 0\n2 0 0\n3 0 0",
     KEEP,
     MLR_OK,
     3,
     {MLR_BVH_WARN_TRUNCATED},
     12,
     "kept the 3 complete frames of 4"},
    /* a malformed frame line with more after it stays an error in every mode */
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 x 0\n3 0 0\n",
     LENIENT,
     MLR_E_PARSE,
     0,
     {0},
     11,
     "invalid number 'x'"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0\n3 0 0\n",
     KEEP,
     MLR_E_PARSE,
     0,
     {0},
     11,
     "frame 2 has 2 values"},
    {"%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0 0\n3 0 0\n",
     LENIENT,
     MLR_E_PARSE,
     0,
     {0},
     11,
     "more than 3 values"},
};

static mlr_status read_lenient(const char *text, size_t len, size_t threads, int mode,
                               mlr_motion **m, mlr_bvh_warnings *w, mlr_diag *d)
{
    mlr_bvh_read_option o[1] = {
        {mode == STRICT ? MLR_BVH_OPT_STRICT : MLR_BVH_OPT_KEEP_TRUNCATED, 1.0}};
    return mlr_bvh_read_memory_opts(text, len, threads, o, mode == LENIENT ? 0 : 1, NULL, m, w, d);
}

START_TEST(lenient_reading_warns_and_strict_keeps_the_errors)
{
    const struct lenient_case *lc = &lenient_cases[_i];
    char text[512];
    size_t len;
    if (strncmp(lc->text, "%H", 2) == 0) {
        /* the cases may hold NUL bytes at the end: copy up to the end of the literal */
        len = strlen(hier);
        memcpy(text, hier, len);
        size_t n = strlen(lc->text + 2);
        memcpy(text + len, lc->text + 2, n);
        len += n;
        if (strstr(lc->text, "\r\n\r\n  \n")) { /* the NUL padding case */
            text[len++] = '\0';
            text[len++] = '\0';
        }
    } else {
        len = strlen(lc->text);
        memcpy(text, lc->text, len);
    }
    for (size_t threads = 1; threads <= 3; threads += 2) {
        mlr_diag d;
        mlr_bvh_warnings w;
        memset(&w, 0x55, sizeof w);
        mlr_motion *m = NULL;
        mlr_status s = read_lenient(text, len, threads, lc->mode, &m, &w, &d);
        ck_assert_msg(s == lc->status, "case %d: %s (%s), expected %s", _i, mlr_status_name(s),
                      d.message, mlr_status_name(lc->status));
        if (s != MLR_OK) {
            ck_assert_ptr_null(m);
            ck_assert_uint_eq(w.count, 0);
            ck_assert_msg(strstr(d.message, lc->reason) != NULL, "case %d: '%s' lacks '%s'", _i,
                          d.message, lc->reason);
            ck_assert_msg(d.line == lc->line, "case %d: line %zu, expected %zu", _i, d.line,
                          lc->line);
            continue;
        }
        ck_assert_uint_eq(d.line, 0);
        ck_assert_str_eq(d.message, "");
        ck_assert_uint_eq(mlr_motion_n_frames(m), lc->n_frames);
        const double *q = mlr_motion_rot(m);
        for (size_t f = 0; f < lc->n_frames; f++) /* frame f + 1 turns f + 1 degrees */
            ck_assert_double_eq_tol(q[4 * f], cos(0.5 * (double)(f + 1) * 0.017453292519943295),
                                    1e-15);
        size_t n_codes = 0;
        while (n_codes < 3 && lc->codes[n_codes])
            n_codes++;
        ck_assert_msg(w.count == n_codes, "case %d: %zu warnings (%s), expected %zu", _i, w.count,
                      w.count ? w.first[0].message : "", n_codes);
        for (size_t k = 0; k < n_codes; k++)
            ck_assert_int_eq(w.first[k].code, lc->codes[k]);
        if (n_codes) {
            ck_assert_msg(strstr(w.first[0].message, lc->reason) != NULL,
                          "case %d: '%s' lacks '%s'", _i, w.first[0].message, lc->reason);
            ck_assert_msg(w.first[0].line == lc->line,
                          "case %d: warning on line %zu, expected %zu", _i, w.first[0].line,
                          lc->line);
        }
        /* the strict reader of old says the same: OK without warnings, or an error */
        if (lc->mode == STRICT || n_codes == 0) {
            mlr_motion *m2 = NULL;
            ck_assert_int_eq(mlr_bvh_read_memory(text, len, NULL, &m2, &d), MLR_OK);
            mlr_motion_destroy(m2);
        } else if (lc->codes[0] != MLR_BVH_WARN_NO_FINAL_NEWLINE) {
            mlr_motion *m2 = NULL;
            ck_assert_int_eq(mlr_bvh_read_memory(text, len, NULL, &m2, &d), MLR_E_PARSE);
        }
        mlr_motion_destroy(m);
    }
}
END_TEST

START_TEST(lenient_options_are_checked)
{
    const char *text = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\n"
                       "Frames: 1\nFrame Time: 1\n5\n";
    mlr_motion *m = NULL;
    mlr_diag d;
    mlr_bvh_warnings w;
    const mlr_bvh_read_option unknown[1] = {{3, 1.0}}, twice[2] = {{1, 1.0}, {1, 0.0}},
                              half[1] = {{2, 0.5}};
    ck_assert_int_eq(mlr_bvh_read_memory_opts(text, strlen(text), 1, unknown, 1, NULL, &m, &w, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "unknown option key 3"));
    ck_assert_int_eq(mlr_bvh_read_memory_opts(text, strlen(text), 1, twice, 2, NULL, &m, &w, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "given twice"));
    ck_assert_int_eq(mlr_bvh_read_memory_opts(text, strlen(text), 1, half, 1, NULL, &m, &w, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "option keep_truncated = 0.5 is not 0 or 1"));
    ck_assert_int_eq(mlr_bvh_read_memory_opts(text, strlen(text), 1, NULL, 1, NULL, &m, &w, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_memory_opts(text, strlen(text), 1, NULL, 0, NULL, NULL, &w, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_memory_opts(NULL, 3, 1, NULL, 0, NULL, &m, &w, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_null(m);
    /* no diag and no warnings wanted: still lenient */
    const char *extra = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\n"
                        "Frames: 1\nFrame Time: 1\n5\n6\n";
    ck_assert_int_eq(
        mlr_bvh_read_memory_opts(extra, strlen(extra), 1, NULL, 0, NULL, &m, NULL, NULL), MLR_OK);
    ck_assert_uint_eq(mlr_motion_n_frames(m), 2);
    mlr_motion_destroy(m);
    const char *cut = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Yrotation\n}\n"
                      "MOTION\nFrames: 2\nFrame Time: 1\n5 1\n6";
    ck_assert_int_eq(mlr_bvh_read_memory_opts(cut, strlen(cut), 1, NULL, 0, NULL, &m, NULL, NULL),
                     MLR_E_PARSE);
    ck_assert_ptr_null(m);
    /* the file reader with options */
    mlr_test_temp tmp;
    mlr_test_temp_write(&tmp, "extra.bvh", extra, strlen(extra));
    const mlr_bvh_read_option strict[1] = {{MLR_BVH_OPT_STRICT, 1.0}};
    ck_assert_int_eq(mlr_bvh_read_file_opts(tmp.path, 2, strict, 1, NULL, &m, &w, &d),
                     MLR_E_PARSE);
    ck_assert_ptr_nonnull(strstr(d.message, "data after the 1 frames"));
    ck_assert_int_eq(mlr_bvh_read_file_opts(tmp.path, 2, NULL, 0, NULL, &m, &w, &d), MLR_OK);
    ck_assert_uint_eq(mlr_motion_n_frames(m), 2);
    ck_assert_uint_eq(w.count, 1);
    ck_assert_int_eq(w.first[0].code, MLR_BVH_WARN_EXTRA_FRAMES);
    ck_assert_uint_eq(w.first[0].line, 11);
    mlr_motion_destroy(m);
    mlr_test_temp_remove(&tmp);
    ck_assert_int_eq(mlr_bvh_read_file_opts("/nonexistent/x.bvh", 1, NULL, 0, NULL, &m, &w, &d),
                     MLR_E_IO);
}
END_TEST

/* A real clip with one motion line more than Frames: (its last line again, as in assimp's
 * test file) and cut inside its last line: on 1 and 2 threads the frames read are those of
 * the clean file. */
START_TEST(lenient_real_clip_extra_and_cut)
{
    size_t len;
    char *text = slurp(clip_path("cmu_131_01_mj_style_walk.bvh"), &len);
    ck_assert_ptr_nonnull(text);
    mlr_motion *ref = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_memory(text, len, NULL, &ref, &d), MLR_OK);
    const size_t N = mlr_motion_n_frames(ref), J = mlr_motion_n_joints(ref);
    /* the last line (CRLF), then the file with it twice */
    const char *last = text + len - 2;
    while (last > text && last[-1] != '\n')
        last--;
    const size_t last_len = (size_t)(text + len - last);
    char *more = malloc(len + last_len);
    memcpy(more, text, len);
    memcpy(more + len, last, last_len);
    size_t lines = 0; /* line of the extra frame */
    for (size_t i = 0; i < len; i++)
        lines += text[i] == '\n';
    for (size_t threads = 1; threads <= 2; threads++) {
        mlr_motion *m = NULL;
        mlr_bvh_warnings w;
        ck_assert_int_eq(read_lenient(more, len + last_len, threads, LENIENT, &m, &w, &d), MLR_OK);
        ck_assert_uint_eq(mlr_motion_n_frames(m), N + 1);
        ck_assert_uint_eq(w.count, 1);
        ck_assert_int_eq(w.first[0].code, MLR_BVH_WARN_EXTRA_FRAMES);
        ck_assert_uint_eq(w.first[0].line, lines + 1);
        ck_assert_mem_eq(mlr_motion_rot(m), mlr_motion_rot(ref), N * J * 4 * sizeof(double));
        ck_assert_mem_eq(mlr_motion_rot(m) + N * J * 4, mlr_motion_rot(ref) + (N - 1) * J * 4,
                         J * 4 * sizeof(double));
        ck_assert_mem_eq(mlr_motion_root_pos(m), mlr_motion_root_pos(ref), N * 3 * sizeof(double));
        mlr_motion_destroy(m);
        /* cut in the middle of the last line: an error, or N - 1 frames when kept */
        const size_t cut = len - last_len / 2;
        ck_assert_int_eq(read_lenient(text, cut, threads, LENIENT, &m, &w, &d), MLR_E_PARSE);
        ck_assert_ptr_nonnull(strstr(d.message, "truncated file"));
        ck_assert_uint_eq(d.line, lines);
        ck_assert_int_eq(read_lenient(text, cut, threads, KEEP, &m, &w, &d), MLR_OK);
        ck_assert_uint_eq(mlr_motion_n_frames(m), N - 1);
        ck_assert_int_eq(w.first[0].code, MLR_BVH_WARN_TRUNCATED);
        ck_assert_mem_eq(mlr_motion_rot(m), mlr_motion_rot(ref), (N - 1) * J * 4 * sizeof(double));
        mlr_motion_destroy(m);
    }
    free(more);
    free(text);
    mlr_motion_destroy(ref);
}
END_TEST

START_TEST(lenient_allocation_failures_are_clean)
{
    static const char *const texts[] = {
        "%HFrames: 1\nFrame Time: 1\n1 0 0\n2 0 0\n", /* extra: a bigger motion */
        "%HFrames: 3\nFrame Time: 1\n1 0 0\n2 0 0\n", /* missing: a smaller copy */
    };
    for (size_t c = 0; c < MLR_COUNTOF(texts); c++) {
        char text[256];
        snprintf(text, sizeof text, "%s%s", hier, texts[c] + 2);
        size_t fail_at;
        for (fail_at = 0;; fail_at++) {
            mlr_test_allocator ta;
            mlr_test_allocator_init(&ta, fail_at);
            mlr_motion *m = NULL;
            mlr_diag d;
            mlr_bvh_warnings w;
            mlr_status s =
                mlr_bvh_read_memory_opts(text, strlen(text), 1, NULL, 0, &ta.base, &m, &w, &d);
            mlr_motion_destroy(m);
            ck_assert_uint_eq(ta.live_blocks, 0);
            if (s == MLR_OK) {
                ck_assert_uint_eq(w.count, 1);
                break;
            }
            ck_assert_int_eq(s, MLR_E_NO_MEMORY);
            ck_assert_uint_eq(w.count, 0);
            ck_assert(fail_at < 1000);
        }
        ck_assert_uint_gt(fail_at, 0);
    }
}
END_TEST

START_TEST(every_truncation_and_mutation_is_handled)
{
    /* each prefix of a valid file, and seeded byte mutations: OK or PARSE, never a crash */
    size_t n = sizeof small_bvh - 1;
    for (size_t k = 0; k < n; k++) {
        mlr_motion *m = NULL;
        mlr_diag d;
        mlr_status s = mlr_bvh_read_memory(small_bvh, k, NULL, &m, &d);
        ck_assert_msg(s == MLR_E_PARSE || (s == MLR_OK && k >= n - 1), "prefix %zu: %s", k,
                      mlr_status_name(s));
        ck_assert(s != MLR_E_PARSE || d.line >= 1);
        mlr_motion_destroy(m);
    }
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 7);
    char buf[sizeof small_bvh];
    for (int it = 0; it < 20000; it++) {
        memcpy(buf, small_bvh, sizeof buf);
        int flips = 1 + (int)(mlr_test_rng_u64(&rng) % 4);
        for (int f = 0; f < flips; f++)
            buf[mlr_test_rng_u64(&rng) % n] = (char)(mlr_test_rng_u64(&rng) & 0xff);
        mlr_motion *m = NULL;
        mlr_status s = mlr_bvh_read_memory(buf, n, NULL, &m, NULL);
        ck_assert(s == MLR_OK || s == MLR_E_PARSE);
        if (s == MLR_OK) {
            size_t len;
            ck_assert_int_eq(mlr_bvh_write_memory(m, NULL, 0, &len, NULL), MLR_OK);
        }
        mlr_motion_destroy(m);
    }
}
END_TEST

START_TEST(null_arguments)
{
    mlr_motion *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_memory("x", 1, NULL, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_memory(NULL, 3, NULL, &m, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_memory(NULL, 0, NULL, &m, &d), MLR_E_PARSE);
    ck_assert_int_eq(mlr_bvh_read_file(NULL, NULL, &m, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_file("/nonexistent/x.bvh", NULL, &m, &d), MLR_E_IO);
    ck_assert_int_eq(d.line, 0);
    ck_assert_uint_eq(mlr_motion_n_joints(NULL), 0);
    ck_assert_ptr_null(mlr_motion_joint_name(NULL, 0));
    mlr_motion_destroy(NULL);
}
END_TEST

/* ---- allocation failures ----------------------------------------------------------------- */

/* ---- random layouts and threads ---------------------------------------------------------- */

enum { TXT_CRLF = 1, TXT_CR = 2, TXT_BLANK_LINES = 4, TXT_EXOTIC = 8, TXT_TABS = 16 };

/* A random BVH text: J joints (each the child of a random earlier one) with random channel lists
 * (0 to 6 kinds in random order), N frames of numbers in the forms motion files use (with
 * TXT_EXOTIC also exponents, '+' and 17 digits); line ends LF, CRLF or CR; blank lines between
 * frames on request. Returns a malloc'd NUL-terminated text. */
static char *random_bvh(mlr_test_rng *r, size_t J, size_t N, unsigned flags, size_t *len)
{
    static const char *const kinds[6] = {"Xposition", "Yposition", "Zposition",
                                         "Xrotation", "Yrotation", "Zrotation"};
    const char *eol = flags & TXT_CR ? "\r" : flags & TXT_CRLF ? "\r\n" : "\n";
    size_t cap = 4096 + J * 256 + N * (J * 6 * 26 + 8), n = 0, C = 0;
    char *t = malloc(cap);
    ck_assert_ptr_nonnull(t);
    int32_t *parent = malloc(J * sizeof *parent);
    ck_assert_ptr_nonnull(parent);
    n += (size_t)sprintf(t + n, "HIERARCHY%s", eol);
    /* joints in depth-first order: parent[j] is j-1 or one of its ancestors */
    size_t depth = 0;
    int32_t *stack = malloc((J + 1) * sizeof *stack);
    ck_assert_ptr_nonnull(stack);
    for (size_t j = 0; j < J; j++) {
        if (j > 0) {
            size_t up = (size_t)(mlr_test_rng_u64(r) % depth); /* close 0 .. depth-1 joints */
            for (size_t u = 0; u < up; u++)
                n += (size_t)sprintf(t + n, "}%s", eol);
            depth -= up;
        }
        parent[j] = j ? stack[depth - 1] : -1;
        stack[depth++] = (int32_t)j;
        n += (size_t)sprintf(t + n, "%s j%zu%s{%s\tOFFSET %.3f %.3f %.3f%s", j ? "JOINT" : "ROOT",
                             j, eol, eol, mlr_test_rng_normal(r), mlr_test_rng_normal(r),
                             mlr_test_rng_normal(r), eol);
        int perm[6] = {0, 1, 2, 3, 4, 5};
        for (int i = 5; i > 0; i--) {
            int k = (int)(mlr_test_rng_u64(r) % (uint64_t)(i + 1)), tmp = perm[i];
            perm[i] = perm[k];
            perm[k] = tmp;
        }
        /* mostly the usual layouts (three rotations, or three positions then three rotations),
         * some random */
        size_t nc = 3;
        const uint64_t pick = mlr_test_rng_u64(r) % 8;
        if (pick < 4) {
            perm[0] = 3 + (int)(mlr_test_rng_u64(r) % 3);
            perm[1] = 3 + (perm[0] - 3 + 1 + (int)(mlr_test_rng_u64(r) % 2)) % 3;
            perm[2] = 12 - perm[0] - perm[1];
        } else if (pick < 6) {
            nc = 6;
            for (int i = 0; i < 3; i++)
                perm[i] = i;
            for (int i = 3; i < 6; i++)
                perm[i] = 8 - i;
        } else {
            nc = (size_t)(mlr_test_rng_u64(r) % 7);
            if (j == 0 && nc == 0)
                nc = 1; /* at least one channel in the file */
        }
        n += (size_t)sprintf(t + n, "\tCHANNELS %zu", nc);
        for (size_t k = 0; k < nc; k++)
            n += (size_t)sprintf(t + n, " %s", kinds[perm[k]]);
        n += (size_t)sprintf(t + n, "%s", eol);
        C += nc;
    }
    while (depth--)
        n += (size_t)sprintf(t + n, "}%s", eol);
    n += (size_t)sprintf(t + n, "MOTION%sFrames: %zu%sFrame Time: 0.0333333%s", eol, N, eol, eol);
    for (size_t f = 0; f < N; f++) {
        if ((flags & TXT_BLANK_LINES) && mlr_test_rng_u64(r) % 50 == 0)
            n += (size_t)sprintf(t + n, "%s%s", mlr_test_rng_u64(r) % 2 ? " \t" : "", eol);
        for (size_t c = 0; c < C; c++) {
            const double v = mlr_test_rng_normal(r) * (c % 5 == 0 ? 300.0 : 40.0);
            const uint64_t form = mlr_test_rng_u64(r) % ((flags & TXT_EXOTIC) ? 12 : 8);
            const char *sep = c == 0 ? "" : (flags & TXT_TABS) && c % 3 == 0 ? "\t" : " ";
            if (form < 6)
                n += (size_t)sprintf(t + n, "%s%.*f", sep, (int)form + 1, v);
            else if (form == 6)
                n += (size_t)sprintf(t + n, "%s%d", sep, (int)v);
            else if (form == 7)
                n += (size_t)sprintf(t + n, "%s%.10f", sep, v * 1e-3);
            else if (form == 8)
                n += (size_t)sprintf(t + n, "%s%.5e", sep, v * 1e-9);
            else if (form == 9)
                n += (size_t)sprintf(t + n, "%s%.17g", sep, v);
            else if (form == 10)
                n += (size_t)sprintf(t + n, "%s+%g", sep, fabs(v));
            else
                n += (size_t)sprintf(t + n, "%s%.3E", sep, v);
        }
        n += (size_t)sprintf(t + n, "%s", eol);
        ck_assert(n + 4096 < cap);
    }
    free(stack);
    free(parent);
    *len = n;
    return t;
}

START_TEST(random_layouts_read_exactly_on_any_thread_count)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 1000 + (uint64_t)_i);
    const size_t J = 1 + (size_t)(mlr_test_rng_u64(&r) % 40);
    const size_t N = _i % 4 == 0 ? 3000 : 1 + (size_t)(mlr_test_rng_u64(&r) % 400);
    const unsigned flags = (unsigned)(mlr_test_rng_u64(&r) % 32);
    size_t len;
    char *text = random_bvh(&r, J, N, flags, &len);
    mlr_motion *m = NULL;
    mlr_diag d;
    mlr_status s = mlr_bvh_read_memory(text, len, NULL, &m, &d);
    ck_assert_msg(s == MLR_OK, "case %d: line %zu: %s", _i, d.line, d.message);
    char what[64];
    snprintf(what, sizeof what, "random layout %d (J %zu, N %zu, flags %u)", _i, J, N, flags);
    assert_frames_are_strtods(m, text, what);
    static const size_t threads[] = {0, 2, 3, 5, 16};
    for (size_t i = 0; i < MLR_COUNTOF(threads); i++) {
        mlr_motion *b = NULL;
        ck_assert_int_eq(mlr_bvh_read_memory_mt(text, len, threads[i], NULL, &b, &d), MLR_OK);
        assert_same_frames(m, b, what);
        mlr_motion_destroy(b);
    }
    free(text);
    mlr_motion_destroy(m);
}
END_TEST

/* Start of frame f's line (no blank lines in text). */
static char *frame_line(char *text, size_t f)
{
    char *p = strstr(text, "Frame Time:");
    ck_assert_ptr_nonnull(p);
    for (size_t k = 0; k <= f; k++) {
        p = strchr(p, '\n');
        ck_assert_ptr_nonnull(p);
        p++;
    }
    return p;
}

START_TEST(threads_report_the_first_error_as_one_thread_does)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 77);
    size_t len;
    char *base = random_bvh(&r, 6, 3000, TXT_CRLF, &len);
    char *t = malloc(len + 64);
    ck_assert_ptr_nonnull(t);
    for (int variant = 0; variant < 9; variant++) {
        memcpy(t, base, len + 1);
        size_t n = len;
        char *q;
        switch (variant) {
        case 0: /* a bad number late in the file */
            q = frame_line(t, 2500);
            q[0] = 'x';
            break;
        case 1: /* two: the first one counts */
            frame_line(t, 1200)[0] = '#';
            frame_line(t, 2900)[0] = 'x';
            break;
        case 2: /* cut inside frame 2000 */
            q = frame_line(t, 2000) + 5;
            n = (size_t)(q - t);
            break;
        case 3: /* one value too many, late */
            q = frame_line(t, 2600);
            memmove(q + 2, q, n + 1 - (size_t)(q - t));
            memcpy(q, "1 ", 2);
            n += 2;
            break;
        case 4: /* a control byte, late */
            frame_line(t, 1800)[3] = '\x01';
            break;
        case 5: /* a line missing, late: "Frames:" promises one frame more */
            q = frame_line(t, 2999);
            n = (size_t)(q - t);
            break;
        case 6: /* data after the last frame */
            n += (size_t)sprintf(t + n, "1 2 3\r\n");
            break;
        case 7: /* a blank line late, then an error: the error's line counts the blank line */
            q = frame_line(t, 2200);
            memmove(q + 2, q, n + 1 - (size_t)(q - t));
            memcpy(q, "\r\n", 2);
            n += 2;
            frame_line(t, 2700)[0] = 'y';
            break;
        default: /* CR-only line ends from frame 1000 on, then an error */
            for (q = frame_line(t, 1000); *q; q++)
                if (q[0] == '\r' && q[1] == '\n')
                    q[1] = ' ';
            q = strchr(frame_line(t, 998), '\r'); /* frame_line counts LFs: before frame 1000 */
            ck_assert_ptr_nonnull(q);
            for (int k = 0; k < 1700; k++) {
                q = strchr(q + 1, '\r');
                ck_assert_ptr_nonnull(q);
            }
            q[-1] = 'z';
            break;
        }
        mlr_motion *m = NULL;
        mlr_diag d1;
        const mlr_status s1 = mlr_bvh_read_memory(t, n, NULL, &m, &d1);
        ck_assert_msg(s1 == MLR_E_PARSE, "variant %d: %s", variant, mlr_status_name(s1));
        static const size_t threads[] = {0, 2, 3, 4, 7, 16};
        for (size_t i = 0; i < MLR_COUNTOF(threads); i++) {
            mlr_diag d;
            memset(&d, 0x55, sizeof d);
            const mlr_status s = mlr_bvh_read_memory_mt(t, n, threads[i], NULL, &m, &d);
            ck_assert_msg(s == s1 && m == NULL, "variant %d, %zu threads: %s", variant, threads[i],
                          mlr_status_name(s));
            ck_assert_msg(
                d.line == d1.line && d.column == d1.column && strcmp(d.message, d1.message) == 0,
                "variant %d, %zu threads: line %zu col %zu '%s', one thread: line %zu "
                "col %zu '%s'",
                variant, threads[i], d.line, d.column, d.message, d1.line, d1.column, d1.message);
        }
    }
    free(t);
    free(base);
}
END_TEST

/* Files of 1 MiB and more are read in parallel chunks and parsed in chunks of 128 KiB, each
 * placed by the line count of the chunks before it: with CR-only line ends in part of the file,
 * blank lines, or an error, the result (frames, or the error's line, column and reason) is that
 * of one thread reading from memory. */
START_TEST(parallel_file_reads_match_one_thread)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 4242);
    size_t len;
    char *t = random_bvh(&r, 12, 9000, TXT_CRLF | (_i == 1 ? TXT_BLANK_LINES : 0), &len);
    ck_assert_uint_gt(len, 3 * ((size_t)1 << 20) / 2);
    if (_i == 2) { /* CR-only line ends from frame 4000 to 6000 */
        char *a = frame_line(t, 4000), *b = frame_line(t, 6000);
        for (char *q = a; q < b; q++)
            if (q[0] == '\r' && q[1] == '\n')
                q[1] = ' ';
    }
    if (_i == 3)
        frame_line(t, 7000)[2] = 'x';
    mlr_motion *m1 = NULL, *m = NULL;
    mlr_diag d1, d;
    const mlr_status s1 = mlr_bvh_read_memory(t, len, NULL, &m1, &d1);
    ck_assert_int_eq(s1, _i == 3 ? MLR_E_PARSE : MLR_OK);
    mlr_test_temp tf;
    mlr_test_temp_write(&tf, "big.bvh", t, len);
    const char *path = tf.path;
    static const size_t threads[] = {0, 2, 3, 5};
    for (size_t i = 0; i < MLR_COUNTOF(threads); i++) {
        memset(&d, 0x55, sizeof d);
        const mlr_status s = mlr_bvh_read_file_mt(path, threads[i], NULL, &m, &d);
        ck_assert_msg(s == s1, "case %d, %zu threads: %s", _i, threads[i], mlr_status_name(s));
        if (s == MLR_OK) {
            assert_same_frames(m1, m, "parallel file read");
            mlr_motion_destroy(m);
        } else {
            ck_assert_msg(d.line == d1.line && d.column == d1.column &&
                              strcmp(d.message, d1.message) == 0,
                          "%zu threads: line %zu col %zu '%s', one thread: line %zu col %zu '%s'",
                          threads[i], d.line, d.column, d.message, d1.line, d1.column, d1.message);
        }
    }
    mlr_motion_destroy(m1);
    mlr_test_temp_remove(&tf);
    free(t);
}
END_TEST

/* Every clip on 0 (automatic), 2 and 3 threads: the files of 1 MiB or more are then also read
 * in parallel chunks. */
START_TEST(read_file_mt_matches_read_file)
{
    mlr_motion *b = NULL;
    mlr_diag d;
    for (size_t c = 0; c < MLR_COUNTOF(clips); c++) {
        if (!MLR_TEST_HAVE_CLIP(clips[c].file))
            continue;
        mlr_motion *a = read_clip(&clips[c]);
        const size_t counts[] = {0, 2, 3};
        for (size_t k = 0; k < MLR_COUNTOF(counts); k++) {
            ck_assert_int_eq(
                mlr_bvh_read_file_mt(clip_path(clips[c].file), counts[k], NULL, &b, &d), MLR_OK);
            assert_same_frames(a, b, clips[c].file);
            mlr_motion_destroy(b);
        }
        mlr_motion_destroy(a);
    }
    ck_assert_int_eq(mlr_bvh_read_file_mt(NULL, 2, NULL, &b, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_file_mt("/nonexistent/x.bvh", 0, NULL, &b, &d), MLR_E_IO);
    ck_assert_ptr_null(b);
    ck_assert_int_eq(mlr_bvh_read_file_mt("/nonexistent/x.bvh", 0, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_memory_mt(NULL, 5, 2, NULL, &b, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_bvh_read_memory_mt("x", 1, 2, NULL, NULL, &d), MLR_E_INVALID_ARG);
}
END_TEST

START_TEST(every_allocation_failure_is_clean_on_threads)
{
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 5);
    size_t len;
    char *text = random_bvh(&r, 4, 300, 0, &len);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_motion *m = NULL;
        mlr_diag d;
        mlr_status s = mlr_bvh_read_memory_mt(text, len, 3, &ta.base, &m, &d);
        if (s != MLR_OK)
            ck_assert_ptr_null(m);
        mlr_motion_destroy(m);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        ck_assert(fail_at < 1000);
    }
    free(text);
}
END_TEST

START_TEST(every_allocation_failure_is_clean)
{
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_motion *m = NULL, *c = NULL;
        mlr_diag d;
        mlr_status s = mlr_bvh_read_memory(small_bvh, sizeof small_bvh - 1, &ta.base, &m, &d);
        if (s != MLR_OK)
            ck_assert_ptr_null(m);
        if (s == MLR_OK) {
            s = mlr_motion_copy_frames(m, 1, 1, &c, NULL);
            if (s == MLR_OK)
                ck_assert_int_eq(mlr_motion_n_frames(c), 1);
        }
        mlr_motion_destroy(c);
        mlr_motion_destroy(m);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        ck_assert(fail_at < 1000);
    }
}
END_TEST

START_TEST(every_allocation_failure_is_clean_for_files)
{
    make_tmpdir();
    char path[512];
    snprintf(path, sizeof path, "%s/a.bvh", tmpdir);
    FILE *fp = fopen(path, "wb");
    fputs(small_bvh, fp);
    fclose(fp);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_motion *m = NULL;
        mlr_diag d;
        mlr_status s = mlr_bvh_read_file(path, &ta.base, &m, &d);
        if (s == MLR_OK)
            s = mlr_bvh_write_file(m, path, &d);
        mlr_motion_destroy(m);
        ck_assert_uint_eq(ta.live_blocks, 0);
        ck_assert_uint_eq(mlr_test_dir_entries(tmpdir), 1);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
    }
    remove_tmpdir();
}
END_TEST

/* ---- motions from arrays ----------------------------------------------------------------- */

START_TEST(create_from_arrays_writes_and_reads_back)
{
    const char *names[] = {"root", "spine", "head", "arm", "hand"};
    const int32_t parents[] = {-1, 0, 1, 1, 3};
    const double offsets[] = {0, 90, 0, 0, 10, 0, 0, 20, 0, 15, 15, 0, 25, 0, 0};
    const char *channels[] = {"Xposition Yposition Zposition Yrotation Xrotation Zrotation",
                              "Zrotation Xrotation Yrotation", "",
                              ("Xposition Yposition Zposition "
                               "Xrotation Yrotation Zrotation"),
                              "xrotation zrotation yrotation"};
    const int32_t end_parents[] = {2, 4};
    const double end_offsets[] = {0, 8, 0, 5, 0, 0};
    mlr_motion *m = NULL;
    mlr_diag d;
    mlr_status s = mlr_motion_create(5, names, parents, offsets, channels, 2, end_parents,
                                     end_offsets, 30, 1.0 / 60, NULL, &m, &d);
    ck_assert_msg(s == MLR_OK, "%s", d.message);
    ck_assert_uint_eq(mlr_motion_n_trans(m), 1);
    ck_assert_int_eq(mlr_motion_trans_joints(m)[0], 3);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 4), MLR_EULER_XZY);
    ck_assert_str_eq(mlr_motion_joint_channels(m, 4), "Xrotation Zrotation Yrotation");
    /* rest pose */
    ck_assert_double_eq(mlr_motion_root_pos(m)[1], 90.0);
    ck_assert_double_eq(mlr_motion_trans(m)[0], 15.0);
    ck_assert_double_eq(mlr_motion_rot(m)[0], 1.0);
    /* random rotations (joint 2 has no channels: stays identity) */
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 3);
    double *rot = mlr_motion_rot_mut(m), *rp = mlr_motion_root_pos_mut(m);
    for (size_t i = 0; i < 30 * 5; i++) {
        if (i % 5 == 2)
            continue;
        double q[4], n = 0;
        for (int k = 0; k < 4; k++) {
            q[k] = mlr_test_rng_normal(&rng);
            n += q[k] * q[k];
        }
        for (int k = 0; k < 4; k++)
            rot[4 * i + k] = q[k] / sqrt(n);
    }
    for (size_t i = 0; i < 90; i++)
        rp[i] = mlr_test_rng_normal(&rng) * 100;
    size_t len;
    char *text = write_to_memory(m, &len);
    mlr_motion *b = read_text(text, &d, &s);
    ck_assert_msg(s == MLR_OK, "line %zu: %s", d.line, d.message);
    assert_same_motion(m, b, 1e-7);
    free(text);
    mlr_motion_destroy(b);

    /* frame_time */
    ck_assert_int_eq(mlr_motion_set_frame_time(m, 0.0), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_motion_set_frame_time(m, 0.04), MLR_OK);
    ck_assert_double_eq(mlr_motion_frame_time(m), 0.04);
    mlr_motion_destroy(m);

    /* default channels */
    s = mlr_motion_create(5, names, parents, offsets, NULL, 0, NULL, NULL, 0, 0.1, NULL, &m, &d);
    ck_assert_int_eq(s, MLR_OK);
    ck_assert_uint_eq(mlr_motion_n_channels(m), 6 + 4 * 3);
    ck_assert_int_eq(mlr_motion_joint_euler_order(m, 3), MLR_EULER_ZYX);
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(create_rejects_bad_arrays)
{
    const char *names[] = {"a", "b", "c"};
    const char *bad_names[] = {"a", "b c ", "c"};
    const char *brace_names[] = {"a", "b{", "c"};
    const int32_t parents[] = {-1, 0, 1}, not_dfs[] = {-1, 0, 2}, two_roots[] = {-1, -1, 1};
    const int32_t sib[] = {-1, 0, 0};
    const double off[9] = {0}, bad_off[9] = {0, 0, NAN};
    const char *bad_ch[] = {"Xposition", "Xrotation Xrotation", ""};
    const char *unk_ch[] = {"Xposition", "Wrotation", ""};
    const int32_t ends_unsorted[] = {2, 1}, ends_bad[] = {3};
    const double end_off[6] = {0};
    mlr_motion *m = NULL;
    mlr_diag d;
#define REJECT(...)                                                                        \
    do {                                                                                   \
        m = (mlr_motion *)&d;                                                              \
        ck_assert_int_eq(mlr_motion_create(__VA_ARGS__, NULL, &m, &d), MLR_E_INVALID_ARG); \
        ck_assert_ptr_null(m);                                                             \
        ck_assert(strlen(d.message) > 0);                                                  \
    } while (0)
    REJECT(0, names, parents, off, NULL, 0, NULL, NULL, 1, 0.1);
    REJECT(3, bad_names, parents, off, NULL, 0, NULL, NULL, 1, 0.1);
    REJECT(3, brace_names, parents, off, NULL, 0, NULL, NULL, 1, 0.1);
    REJECT(3, names, not_dfs, off, NULL, 0, NULL, NULL, 1, 0.1);
    REJECT(3, names, two_roots, off, NULL, 0, NULL, NULL, 1, 0.1);
    REJECT(3, names, parents, bad_off, NULL, 0, NULL, NULL, 1, 0.1);
    REJECT(3, names, parents, off, bad_ch, 0, NULL, NULL, 1, 0.1);
    REJECT(3, names, parents, off, unk_ch, 0, NULL, NULL, 1, 0.1);
    REJECT(3, names, parents, off, NULL, 2, ends_unsorted, end_off, 1, 0.1);
    REJECT(3, names, parents, off, NULL, 1, ends_bad, end_off, 1, 0.1);
    REJECT(3, names, parents, off, NULL, 0, NULL, NULL, 1, 0.0);
    REJECT(3, names, parents, off, NULL, 0, NULL, NULL, 1, NAN);
    REJECT(3, NULL, parents, off, NULL, 0, NULL, NULL, 1, 0.1);
#undef REJECT
    ck_assert_int_eq(
        mlr_motion_create(3, names, sib, off, NULL, 0, NULL, NULL, 1, 0.1, NULL, &m, NULL),
        MLR_OK);
    mlr_motion_destroy(m);
    for (size_t fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_status s =
            mlr_motion_create(3, names, sib, off, NULL, 0, NULL, NULL, 5, 0.1, &ta.base, &m, NULL);
        mlr_motion_destroy(m);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (s == MLR_OK)
            break;
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
    }
}
END_TEST

static Suite *bvh_suite(void)
{
    Suite *s = suite_create("bvh");
    TCase *tc = tcase_create("clips");
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, every_clip_parses_with_readme_counts, 0, (int)MLR_COUNTOF(clips));
    tcase_add_loop_test(tc, every_value_of_every_clip_is_strtods, 0, (int)MLR_COUNTOF(clips));
    tcase_add_test(tc, per_joint_euler_orders);
    tcase_add_loop_test(tc, packed_accessors_match_per_joint_ones, 0, (int)MLR_COUNTOF(clips));
    tcase_add_test(tc, bandai_position_channels_replace_offsets);
    tcase_add_loop_test(tc, round_trip_every_clip, 0, (int)MLR_COUNTOF(clips));
    tcase_add_test(tc, write_file_is_atomic_and_matches_memory);
    tcase_add_test(tc, write_memory_overflow_and_callback_stop);
    tcase_add_test(tc, copy_frames_slices);
    tcase_add_test(tc, lenient_real_clip_extra_and_cut);
    suite_add_tcase(s, tc);

    TCase *syn = tcase_create("syntax");
    tcase_set_timeout(syn, 120);
    tcase_add_test(syn, whitespace_and_line_end_variants);
    tcase_add_test(syn, small_file_round_trip_keeps_layout);
    tcase_add_test(syn, partial_and_empty_channel_lists);
    tcase_add_test(syn, numbers_are_correctly_rounded);
    tcase_add_loop_test(syn, random_layouts_read_exactly_on_any_thread_count, 0, 24);
    tcase_add_test(syn, threads_report_the_first_error_as_one_thread_does);
    tcase_add_test(syn, read_file_mt_matches_read_file);
    tcase_add_loop_test(syn, parallel_file_reads_match_one_thread, 0, 4);
    tcase_add_test(syn, number_fast_path_boundaries);
    tcase_add_test(syn, locale_with_decimal_comma);
    tcase_add_test(syn, deep_nesting_needs_no_recursion);
    tcase_add_loop_test(syn, malformed_input_reports_line_and_reason, 0,
                        (int)MLR_COUNTOF(bad_cases));
    tcase_add_test(syn, every_truncation_and_mutation_is_handled);
    tcase_add_loop_test(syn, lenient_reading_warns_and_strict_keeps_the_errors, 0,
                        (int)MLR_COUNTOF(lenient_cases));
    tcase_add_test(syn, lenient_options_are_checked);
    tcase_add_test(syn, null_arguments);
    suite_add_tcase(s, syn);

    TCase *mem = tcase_create("memory");
    tcase_add_test(mem, every_allocation_failure_is_clean);
    tcase_add_test(mem, lenient_allocation_failures_are_clean);
    tcase_add_test(mem, every_allocation_failure_is_clean_on_threads);
    tcase_add_test(mem, every_allocation_failure_is_clean_for_files);
    tcase_add_test(mem, create_from_arrays_writes_and_reads_back);
    tcase_add_test(mem, create_rejects_bad_arrays);
    suite_add_tcase(s, mem);
    return s;
}

int main(void) { return mlr_test_run(bvh_suite()); }
