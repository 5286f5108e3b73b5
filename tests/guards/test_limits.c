/* Joint limits: hinges found on the real clips, the soft saturation is C1 and bounded, inputs
 * within range are unchanged, stylized real clips have no folds or reversals after limits,
 * user ranges, widening, streams, bad input, allocation failures. */
#include "mlr_test.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
#define DEG (PI / 180.0)

/* Hips -> LeftUpLeg -> LeftLeg -> LeftFoot (End Site ahead): a leg along -Y, knee about X. */
static const int32_t leg_parents[4] = {-1, 0, 1, 2};
static const double leg_offsets[12] = {0, 10, 0, 1, -0.5, 0, 0, -4, 0, 0, -4, 0};
static const char *const leg_names[4] = {"Hips", "LeftUpLeg", "LeftLeg", "LeftFoot"};
static const int32_t leg_end_parents[1] = {3};
static const double leg_end_offsets[3] = {0, 0, 2};

static mlr_rig leg_rig(void)
{
    mlr_rig r = {4,    leg_parents, leg_offsets,     leg_names,      0,
                 NULL, 1,           leg_end_parents, leg_end_offsets};
    return r;
}

static void set_axis_angle(double *q, double x, double y, double z, double angle)
{
    const double n = sqrt(x * x + y * y + z * z), s = sin(0.5 * angle) / n;
    q[0] = cos(0.5 * angle), q[1] = x * s, q[2] = y * s, q[3] = z * s;
}

/* N frames of a walking-like leg: hip swings +-25 deg about X, knee flexes 5..65 deg about -X
 * (the knee bends backwards: the shin rotates about -X), foot +-10 deg. */
static double *leg_clip(size_t n, mlr_test_rng *rng)
{
    double *rot = malloc(n * 16 * sizeof(double));
    for (size_t f = 0; f < n; f++) {
        const double t = 2.0 * PI * (double)f / 40.0;
        double *q = rot + 16 * f;
        set_axis_angle(q, 0, 1, 0, 0.1 * sin(0.3 * t));
        set_axis_angle(q + 4, 1, 0.02 * mlr_test_rng_normal(rng), 0, 25 * DEG * sin(t));
        set_axis_angle(q + 8, -1, 0.01 * mlr_test_rng_normal(rng), 0.01, (35 + 30 * sin(t)) * DEG);
        set_axis_angle(q + 12, 1, 0, 0, 10 * DEG * cos(t));
    }
    return rot;
}

/* The signed hinge angle of rotation q from the geometry (independent of limits.c). */
static double phi_of(const mlr_limits *lim, size_t j, const double *q)
{
    double ax[3], a[3], b[3];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, j, NULL, ax, a, b, NULL), MLR_OK);
    const mlr_quat qq = {q[0], q[1], q[2], q[3]};
    const mlr_vec3 bv = {b[0], b[1], b[2]};
    mlr_vec3 s;
    mlr_quat_rotate(&qq, &bv, &s);
    const double cx = a[1] * s.z - a[2] * s.y, cy = a[2] * s.x - a[0] * s.z,
                 cz = a[0] * s.y - a[1] * s.x;
    const double y = ax[0] * cx + ax[1] * cy + ax[2] * cz;
    const double an = a[0] * ax[0] + a[1] * ax[1] + a[2] * ax[2];
    const double sn = s.x * ax[0] + s.y * ax[1] + s.z * ax[2];
    const double x = a[0] * s.x + a[1] * s.y + a[2] * s.z - an * sn;
    return atan2(y, x);
}

static mlr_limits *leg_limits(size_t n, double **rot_out, const mlr_limits_option *opts,
                              size_t n_opts)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 7);
    double *rot = leg_clip(n, &rng);
    mlr_rig r = leg_rig();
    mlr_limits_clip c = {n, rot, NULL};
    mlr_limits *lim = NULL;
    mlr_diag d;
    ck_assert_msg(mlr_limits_create(&r, &c, 1, opts, n_opts, NULL, &lim, &d) == MLR_OK, "%s",
                  d.message);
    if (rot_out)
        *rot_out = rot;
    else
        free(rot);
    return lim;
}

START_TEST(the_knee_of_a_synthetic_leg_is_a_hinge_about_its_axis)
{
    double *rot;
    mlr_limits *lim = leg_limits(400, &rot, NULL, 0);
    mlr_limits_range r;
    ck_assert_int_eq(mlr_limits_get_range(lim, 0, &r), MLR_OK);
    ck_assert_int_eq(r.kind, MLR_LIMITS_FREE);
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &r), MLR_OK);
    ck_assert_int_eq(r.kind, MLR_LIMITS_HINGE);
    ck_assert_int_eq(mlr_limits_get_range(lim, 1, &r), MLR_OK);
    ck_assert_int_eq(r.kind, MLR_LIMITS_SWING_TWIST);
    double ax[3], st[4];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 2, NULL, ax, NULL, NULL, st), MLR_OK);
    /* the shin rotates about -X: the learned axis is -X, so the input bends the + way */
    ck_assert_double_gt(fabs(ax[0]), 0.999);
    ck_assert_close(st[0], 5 * DEG, 1.5 * DEG);
    ck_assert_close(st[1], 65 * DEG, 1.5 * DEG);
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &r), MLR_OK);
    ck_assert_double_eq(r.lo, 0.0);
    ck_assert_close(r.hi, 150 * DEG, 1e-12);
    /* not human by itself (no arms): ranges from the input, widened */
    ck_assert_int_eq(mlr_limits_is_human(lim), 0);
    ck_assert_int_eq(mlr_limits_get_range(lim, 1, &r), MLR_OK);
    ck_assert_int_eq(r.source, MLR_LIMITS_SOURCE_INPUT);
    ck_assert_int_ne(r.widen, 0);
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 1, NULL, NULL, NULL, NULL, st), MLR_OK);
    ck_assert_close(r.swing, st[2] / 0.85, 1e-9); /* the input's extent at the knee point */
    ck_assert_close(st[2], 25 * DEG, 2 * DEG);
    /* the hinge angles are measured on the hinge candidates only (named hinges with an axis):
       0 on the hip (which has an axis) and on the root */
    ck_assert_double_eq(st[0], 0.0);
    ck_assert_double_eq(st[1], 0.0);
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 0, NULL, NULL, NULL, NULL, st), MLR_OK);
    ck_assert_double_eq(st[0], 0.0);
    ck_assert_double_eq(st[1], 0.0);
    mlr_limits_destroy(lim);
    free(rot);
}
END_TEST

/* A knee that also twists about its shin by up to +-80 degrees (a forearm's pronation, a
 * capture's twist noise) turns about another axis as a whole; its swing still turns about
 * the hinge axis, and it is found as a hinge. */
START_TEST(a_hinge_that_twists_about_its_bone_is_still_a_hinge)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 11);
    const size_t n = 400;
    double *rot = leg_clip(n, &rng);
    for (size_t f = 0; f < n; f++) {
        double *q = rot + 16 * f + 8, tw[4], o[4];
        set_axis_angle(tw, 0, -1, 0, 80 * DEG * sin(2.0 * PI * (double)f / 57.0));
        /* q * twist: the twist about the shin (the knee frame's -Y), then the bend */
        o[0] = q[0] * tw[0] - q[1] * tw[1] - q[2] * tw[2] - q[3] * tw[3];
        o[1] = q[0] * tw[1] + q[1] * tw[0] + q[2] * tw[3] - q[3] * tw[2];
        o[2] = q[0] * tw[2] - q[1] * tw[3] + q[2] * tw[0] + q[3] * tw[1];
        o[3] = q[0] * tw[3] + q[1] * tw[2] - q[2] * tw[1] + q[3] * tw[0];
        memcpy(q, o, sizeof o);
    }
    mlr_rig r = leg_rig();
    mlr_limits_clip c = {n, rot, NULL};
    mlr_limits *lim = NULL;
    mlr_diag d;
    ck_assert_msg(mlr_limits_create(&r, &c, 1, NULL, 0, NULL, &lim, &d) == MLR_OK, "%s",
                  d.message);
    mlr_limits_range g;
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &g), MLR_OK);
    ck_assert_int_eq(g.kind, MLR_LIMITS_HINGE);
    double ax[3];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 2, NULL, ax, NULL, NULL, NULL), MLR_OK);
    ck_assert_double_gt(fabs(ax[0]), 0.99);
    mlr_limits_destroy(lim);
    /* without a hinge name the same joint needs the whole rotation's concentration: not a
       hinge here (the hinge test by name is what admits the twist) */
    const char *const plain[4] = {"a", "b", "c", "d"};
    r.names = plain;
    ck_assert_msg(mlr_limits_create(&r, &c, 1, NULL, 0, NULL, &lim, &d) == MLR_OK, "%s",
                  d.message);
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &g), MLR_OK);
    ck_assert_int_ne(g.kind, MLR_LIMITS_HINGE);
    mlr_limits_destroy(lim);
    free(rot);
}
END_TEST

/* Sweep the knee angle through and past the bounds: phi' is phi up to the knee point, below
 * hi and above lo everywhere, increasing, and its first differences change smoothly (C1). */
START_TEST(the_soft_saturation_is_c1_bounded_and_identity_inside)
{
    mlr_limits *lim = leg_limits(400, NULL, NULL, 0);
    mlr_limits_range r;
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &r), MLR_OK);
    double ax[3];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 2, NULL, ax, NULL, NULL, NULL), MLR_OK);
    const size_t n = 4003; /* no sample on a knee point */
    const double from = -60 * DEG, to = 240 * DEG, h = (to - from) / (double)(n - 1);
    double *in = malloc(n * 16 * sizeof(double)), *out = malloc(n * 16 * sizeof(double));
    double *y = malloc(n * sizeof(double));
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < 4; j++)
            set_axis_angle(in + 16 * i + 4 * j, 1, 0, 0, 0.0);
        set_axis_angle(in + 16 * i + 8, ax[0], ax[1], ax[2], from + h * (double)i);
    }
    size_t counts[4];
    ck_assert_int_eq(mlr_limits_apply(lim, n, in, out, NULL, 0, counts, 4, NULL), MLR_OK);
    size_t changed = 0;
    for (size_t i = 0; i < n; i++) {
        const double x = from + h * (double)i;
        y[i] = phi_of(lim, 2, out + 16 * i + 8);
        if (y[i] < r.lo - 1e-9)
            y[i] += 2 * PI; /* read in the excluded arc's frame for the check */
        ck_assert_double_gt(y[i], r.lo);
        ck_assert_double_lt(y[i], r.hi);
        if (x > 10 * DEG + 1e-9 && x < 150 * DEG * 0.85 - 1e-9) /* inside the knee points */
            ck_assert_close(y[i], x, 1e-12);
        else
            changed++;
    }
    ck_assert_uint_eq(counts[2], changed);
    ck_assert_uint_eq(counts[0] + counts[1] + counts[3], 0);
    /* C1: first differences continuous and positive, away from the wrap point
     * phi = mid - 2 pi (= -105 deg) which the sweep does not reach */
    double worst = 0;
    for (size_t i = 1; i + 1 < n; i++) {
        const double d1 = y[i] - y[i - 1], d2 = y[i + 1] - y[i];
        ck_assert_double_gt(d2, 0.0);
        worst = fmax(worst, fabs(d2 - d1));
    }
    /* the second derivative of w tanh(x / w) is at most 0.77 / w; w >= 10 deg */
    ck_assert_double_le(worst, 0.8 / (10 * DEG) * h * h * 1.01);
    ck_assert_double_gt(worst, 0.1 / (10 * DEG) * h * h); /* it does bend */
    free(in), free(out), free(y);
    mlr_limits_destroy(lim);
}
END_TEST

START_TEST(swing_is_saturated_smoothly_and_widened_with_alpha)
{
    mlr_limits *lim = leg_limits(400, NULL, NULL, 0);
    mlr_limits_range r;
    ck_assert_int_eq(mlr_limits_get_range(lim, 1, &r), MLR_OK);
    double c[4];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 1, c, NULL, NULL, NULL, NULL), MLR_OK);
    const size_t n = 2001;
    const double h = PI * 0.95 / (double)(n - 1);
    double *in = calloc(n * 16, sizeof(double)), *out = malloc(n * 16 * sizeof(double));
    for (int widen = 0; widen < 2; widen++) {
        const double alpha = widen ? 2.0 : 1.0;
        const double bound = fmin(PI, r.swing * alpha);
        double prev = 0, prev_d = 0, worst = 0;
        for (size_t i = 0; i < n; i++) {
            for (size_t j = 0; j < 4; j++)
                set_axis_angle(in + 16 * i + 4 * j, 1, 0, 0, 0.0);
            /* a pure swing about Z (normal to the bone, -Y) from the centre: q = c R(z, x) */
            double s[4];
            set_axis_angle(s, 0, 0, 1, h * (double)i);
            const mlr_quat cq = {c[0], c[1], c[2], c[3]}, sq = {s[0], s[1], s[2], s[3]};
            mlr_quat q;
            mlr_quat_mul(&cq, &sq, &q);
            memcpy(in + 16 * i + 4, &q, sizeof q);
        }
        ck_assert_int_eq(mlr_limits_apply(lim, n, in, out, &alpha, 1, NULL, 0, NULL), MLR_OK);
        for (size_t i = 0; i < n; i++) {
            const mlr_quat cq = {c[0], -c[1], -c[2], -c[3]};
            mlr_quat q, d;
            memcpy(&q, out + 16 * i + 4, sizeof q);
            mlr_quat_mul(&cq, &q, &d);
            const double ang = 2 * atan2(sqrt(d.x * d.x + d.y * d.y + d.z * d.z), fabs(d.w));
            ck_assert_double_le(ang, bound); /* = bound only where tanh rounds to 1 */
            if (h * (double)i < bound * 0.85 - 1e-9)
                ck_assert_close(ang, h * (double)i, 1e-9);
            if (i >= 1) {
                const double dd = ang - prev;
                ck_assert_double_ge(dd, -1e-15);
                if (i >= 2)
                    worst = fmax(worst, fabs(dd - prev_d));
                prev_d = dd;
            }
            prev = ang;
        }
        ck_assert_double_le(worst, 0.8 / (0.15 * bound) * h * h * 1.01);
    }
    free(in), free(out);
    mlr_limits_destroy(lim);
}
END_TEST

START_TEST(the_input_itself_is_unchanged_inside_the_knee_points)
{
    double *rot;
    mlr_limits *lim = leg_limits(400, &rot, NULL, 0);
    double *out = malloc(400 * 16 * sizeof(double));
    size_t counts[4];
    ck_assert_int_eq(mlr_limits_apply(lim, 400, rot, out, NULL, 0, counts, 4, NULL), MLR_OK);
    /* hip and foot: inside their input-derived ranges; knee: 5..65 deg, inside [10, 127.5] but
     * for the frames under 10 degrees (the reversal side's soft zone) */
    ck_assert_uint_eq(counts[0] + counts[1] + counts[3], 0);
    size_t knee_soft = 0;
    for (size_t f = 0; f < 400; f++) {
        const double phi = phi_of(lim, 2, rot + 16 * f + 8);
        if (phi < 10 * DEG)
            knee_soft++;
        else
            for (int k = 0; k < 4; k++)
                ck_assert_close(out[16 * f + 8 + k], rot[16 * f + 8 + k], 1e-15);
        for (int k = 0; k < 4; k++)
            ck_assert_close(out[16 * f + 4 + k], rot[16 * f + 4 + k], 1e-15);
    }
    ck_assert_uint_eq(counts[2], knee_soft);
    ck_assert_uint_gt(knee_soft, 0);
    /* in place gives the same */
    ck_assert_int_eq(mlr_limits_apply(lim, 400, rot, rot, NULL, 0, NULL, 0, NULL), MLR_OK);
    ck_assert_mem_eq(rot, out, 400 * 16 * sizeof(double));
    free(rot), free(out);
    mlr_limits_destroy(lim);
}
END_TEST

START_TEST(unit_rotations_pass_bit_for_bit_and_others_come_out_normalized)
{
    double *rot;
    mlr_limits *lim = leg_limits(400, &rot, NULL, 0);
    double *out = malloc(400 * 16 * sizeof(double));
    /* the hip (joint 1) lies inside its range: a rotation unit to rounding is copied as it is,
       one scaled by 3 comes out as its unit quaternion */
    for (size_t f = 0; f < 400; f += 2)
        for (int k = 0; k < 4; k++)
            rot[16 * f + 4 + k] *= 3.0;
    ck_assert_int_eq(mlr_limits_apply(lim, 400, rot, out, NULL, 0, NULL, 0, NULL), MLR_OK);
    size_t copied = 0;
    for (size_t f = 0; f < 400; f++) {
        const double *q = rot + 16 * f + 4, *o = out + 16 * f + 4;
        const double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
        if (fabs(n2 - 1.0) <= 4 * DBL_EPSILON) {
            ck_assert_mem_eq(o, q, 4 * sizeof(double));
            copied++;
        } else {
            ck_assert(f % 2 == 0); /* only the scaled ones are not unit */
            const double n = sqrt(n2);
            for (int k = 0; k < 4; k++)
                ck_assert_close(o[k], q[k] / n, 1e-15);
        }
    }
    ck_assert_uint_eq(copied, 200);
    free(rot), free(out);
    mlr_limits_destroy(lim);
}
END_TEST

START_TEST(user_ranges_replace_the_learned_ones)
{
    mlr_limits *lim = leg_limits(200, NULL, NULL, 0);
    mlr_limits_range r;
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &r), MLR_OK);
    r.hi = 90 * DEG;
    mlr_diag d;
    ck_assert_int_eq(mlr_limits_set_range(lim, 2, &r, &d), MLR_OK);
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &r), MLR_OK);
    ck_assert_int_eq(r.source, MLR_LIMITS_SOURCE_USER);
    double ax[3], q[16];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 2, NULL, ax, NULL, NULL, NULL), MLR_OK);
    for (int j = 0; j < 4; j++)
        set_axis_angle(q + 4 * j, 1, 0, 0, 0);
    set_axis_angle(q + 8, ax[0], ax[1], ax[2], 120 * DEG);
    ck_assert_int_eq(mlr_limits_apply(lim, 1, q, q, NULL, 0, NULL, 0, NULL), MLR_OK);
    const double phi = phi_of(lim, 2, q + 8);
    ck_assert_double_lt(phi, 90 * DEG);
    ck_assert_double_gt(phi, 75 * DEG);
    /* freeing a joint: nothing changes */
    r.kind = MLR_LIMITS_FREE;
    ck_assert_int_eq(mlr_limits_set_range(lim, 2, &r, &d), MLR_OK);
    set_axis_angle(q + 8, ax[0], ax[1], ax[2], 200 * DEG);
    double q2[16];
    memcpy(q2, q, sizeof q);
    ck_assert_int_eq(mlr_limits_apply(lim, 1, q, q, NULL, 0, NULL, 0, NULL), MLR_OK);
    for (int k = 0; k < 4; k++)
        ck_assert_close(q[8 + k], q2[8 + k], 1e-15);
    /* bad ranges: nothing changed, reason given */
    mlr_limits_range bad = r;
    bad.kind = 7;
    ck_assert_int_eq(mlr_limits_set_range(lim, 2, &bad, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "kind"));
    bad.kind = MLR_LIMITS_HINGE, bad.lo = 1.0, bad.hi = 0.5;
    ck_assert_int_eq(mlr_limits_set_range(lim, 2, &bad, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "lo < hi"));
    bad.lo = 0, bad.hi = NAN;
    ck_assert_int_eq(mlr_limits_set_range(lim, 2, &bad, &d), MLR_E_INVALID_ARG);
    bad.kind = MLR_LIMITS_SWING_TWIST, bad.swing = 0.0, bad.twist = 1.0;
    ck_assert_int_eq(mlr_limits_set_range(lim, 1, &bad, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "swing"));
    {   /* a joint without a shin cannot be a hinge */
        static const int32_t tp[2] = {-1, 0};
        static const double to[6] = {0, 0, 0, 0, 1, 0};
        static const char *const tn[2] = {"Hips", "Tip"};
        const mlr_rig tr = {2, tp, to, tn, 0, NULL, 0, NULL, NULL};
        double tq[8] = {1, 0, 0, 0, 0.9, 0.1, 0, 0};
        mlr_limits_clip tc = {1, tq, NULL};
        mlr_limits *tl;
        ck_assert_int_eq(mlr_limits_create(&tr, &tc, 1, NULL, 0, NULL, &tl, &d), MLR_OK);
        bad.kind = MLR_LIMITS_HINGE, bad.lo = 0, bad.hi = 1;
        ck_assert_int_eq(mlr_limits_set_range(tl, 1, &bad, &d), MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "thigh"));
        mlr_limits_destroy(tl);
    }
    ck_assert_int_eq(mlr_limits_set_range(lim, 4, &r, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "out of range"));
    ck_assert_int_eq(mlr_limits_get_range(lim, 2, &r), MLR_OK);
    ck_assert_int_eq(r.kind, MLR_LIMITS_FREE);
    mlr_limits_destroy(lim);
}
END_TEST

START_TEST(bad_input_gets_the_right_status_and_message)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 3);
    double *rot = leg_clip(50, &rng);
    mlr_rig r = leg_rig();
    mlr_limits_clip c = {50, rot, NULL};
    mlr_limits *lim = (mlr_limits *)&r;
    mlr_diag d;
    ck_assert_int_eq(mlr_limits_create(NULL, &c, 1, NULL, 0, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(lim);
    ck_assert_int_eq(mlr_limits_create(&r, &c, 0, NULL, 0, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "no clips"));
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, NULL, 0, NULL, NULL, &d), MLR_E_INVALID_ARG);
    mlr_limits_clip c0 = {0, rot, NULL};
    ck_assert_int_eq(mlr_limits_create(&r, &c0, 1, NULL, 0, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "no frames"));
    rot[4 * 37 + 2] = NAN;
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, NULL, 0, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "rot[9][1] is not finite"));
    memset(rot + 4 * 37, 0, 4 * sizeof(double));
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, NULL, 0, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "zero"));
    set_axis_angle(rot + 4 * 37, 1, 0, 0, 0.1);
    mlr_limits_option o[2] = {{MLR_LIMITS_OPT_FOLD, 4.0}, {99, 1.0}};
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, o, 1, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "limits: option fold = 4 is not in (0, pi]"));
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, o + 1, 1, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "unknown option"));
    mlr_limits_option rep[2] = {{MLR_LIMITS_OPT_SOFT, 0.2}, {MLR_LIMITS_OPT_SOFT, 0.3}};
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, rep, 2, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "option soft given twice"));
    mlr_limits_option hum = {MLR_LIMITS_OPT_HUMAN, 0.5};
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, &hum, 1, NULL, &lim, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_limits_create(&r, &c, 1, NULL, 0, NULL, &lim, &d), MLR_OK);
    /* apply */
    double out[16 * 50], alpha[5] = {1, 1, 1, 1, 1};
    size_t counts[4];
    ck_assert_int_eq(mlr_limits_apply(NULL, 50, rot, out, NULL, 0, NULL, 0, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_limits_apply(lim, 50, rot, out, alpha, 4, NULL, 0, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "1 + J = 5"));
    alpha[3] = INFINITY;
    ck_assert_int_eq(mlr_limits_apply(lim, 50, rot, out, alpha, 5, NULL, 0, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "alpha[3]"));
    alpha[3] = 1;
    ck_assert_int_eq(mlr_limits_apply(lim, 50, rot, out, alpha, 5, counts, 3, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "counts"));
    ck_assert_int_eq(mlr_limits_apply(lim, 50, NULL, out, NULL, 0, NULL, 0, &d),
                     MLR_E_INVALID_ARG);
    rot[4 * 41] = NAN;
    ck_assert_int_eq(mlr_limits_apply(lim, 50, rot, out, NULL, 0, NULL, 0, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "rot_in[10][1]"));
    ck_assert_int_eq(mlr_limits_apply(lim, 0, NULL, NULL, NULL, 0, NULL, 0, &d), MLR_OK);
    mlr_limits_range rg;
    ck_assert_int_eq(mlr_limits_get_range(lim, 4, &rg), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_limits_get_geometry(lim, 4, NULL, NULL, NULL, NULL, NULL),
                     MLR_E_INVALID_ARG);
    ck_assert_uint_eq(mlr_limits_n_joints(lim), 4);
    ck_assert_uint_eq(mlr_limits_n_joints(NULL), 0);
    mlr_limits_destroy(lim);
    mlr_limits_destroy(NULL);
    free(rot);
}
END_TEST

START_TEST(every_allocation_failure_returns_no_memory_without_leaks)
{
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 5);
    double *rot = leg_clip(60, &rng);
    mlr_rig r = leg_rig();
    mlr_limits_clip c = {60, rot, NULL};
    size_t fail_at = 0;
    for (;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_limits *lim = NULL;
        const mlr_status st = mlr_limits_create(&r, &c, 1, NULL, 0, &ta.base, &lim, NULL);
        if (st == MLR_OK) {
            mlr_limits_destroy(lim);
            ck_assert_uint_eq(ta.live_blocks, 0);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_ptr_null(lim);
        ck_assert_uint_eq(ta.live_blocks, 0);
    }
    ck_assert_uint_ge(fail_at, 3);
    free(rot);
}
END_TEST

/* A layered stream with limits gives mlr_limits_apply of the same stream's output without. */
START_TEST(streams_apply_the_limits_to_every_output_frame)
{
    double *rot;
    mlr_limits *lim = leg_limits(300, &rot, NULL, 0);
    mlr_stream *a, *b;
    ck_assert_int_eq(mlr_stream_create_layered(4, 0, 0, 1, 1, 10, 10, 5, NULL, &a, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_create_layered(4, 0, 0, 1, 1, 10, 10, 5, NULL, &b, NULL), MLR_OK);
    const double alpha[4] = {3, 3, 3, 3};
    ck_assert_int_eq(mlr_stream_set_alpha(a, 1, alpha, 4, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_set_alpha(b, 1, alpha, 4, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_set_limits(a, lim, NULL), MLR_OK);
    double *xa = malloc(300 * 16 * sizeof(double)), *xb = malloc(300 * 16 * sizeof(double));
    size_t done = 0, ready, w;
    for (size_t f = 0; f < 300; f++) {
        ck_assert_int_eq(mlr_stream_push(a, rot + 16 * f, 16, xa + 16 * done, 16, &ready, NULL),
                         MLR_OK);
        ck_assert_int_eq(mlr_stream_push(b, rot + 16 * f, 16, xb + 16 * done, 16, &ready, NULL),
                         MLR_OK);
        done += ready;
    }
    ck_assert_int_eq(mlr_stream_flush(a, xa + 16 * done, 16 * (300 - done), &w, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_flush(b, xb + 16 * done, 16 * (300 - done), &w, NULL), MLR_OK);
    size_t counts[4];
    const double alpha5 = 3.0;
    ck_assert_int_eq(mlr_limits_apply(lim, 300, xb, xb, &alpha5, 1, counts, 4, NULL), MLR_OK);
    ck_assert_uint_gt(counts[2], 0); /* alpha 3 does push the knee into the soft zones */
    for (size_t i = 0; i < 300 * 16; i++)
        ck_assert_close(xa[i], xb[i], 1e-15);
    /* wrong joint count, detach */
    mlr_stream *c;
    ck_assert_int_eq(mlr_stream_create(3, 0, 0, 1, 1, 2, NULL, &c, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_set_limits(c, lim, NULL), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_stream_set_limits(c, NULL, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_set_limits(NULL, NULL, NULL), MLR_E_INVALID_ARG);
    mlr_stream_destroy(a), mlr_stream_destroy(b), mlr_stream_destroy(c);
    free(xa), free(xb), free(rot);
    mlr_limits_destroy(lim);
}
END_TEST

/* ---- real clips ------------------------------------------------------------------------- */

typedef mlr_test_clip real;
#define load(file, r) mlr_test_clip_load(file, r)
#define unload(r) mlr_test_clip_unload(r)

static mlr_limits *real_limits(const real *r)
{
    mlr_limits_clip c = {r->n, mlr_motion_rot(r->m), mlr_motion_trans(r->m)};
    mlr_limits *lim;
    mlr_diag d;
    ck_assert_msg(mlr_limits_create(&r->rig, &c, 1, NULL, 0, NULL, &lim, &d) == MLR_OK, "%s",
                  d.message);
    return lim;
}

static int is_hinge_name(const char *s)
{
    static const char *const words[] = {"Leg",   "Knee",     "Shin", "ForeArm",
                                        "Elbow", "LowerArm", "knee", "elbow"};
    for (size_t i = 0; i < MLR_COUNTOF(words); i++)
        if (strstr(s, words[i]) && !strstr(s, "Up") && !strstr(s, "Upper"))
            return 1;
    return 0;
}

START_TEST(hinges_are_found_on_the_knees_and_elbows_of_the_shared_clips)
{
    static const char *const files[] = {
        "cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",
        "cmu_10_01_soccer_kick.bvh",      "cmu_60_10_salsa_dance.bvh",
        "cmu_02_03_run_jog_25fps.bvh",    "lafan1_clip_a.bvh",
        "bandai1_walk_happy_001.bvh",     "ai4a_dog_D1_008_KAN01_002.bvh"};
    size_t loaded = 0;
    for (size_t k = 0; k < MLR_COUNTOF(files); k++) {
        real r;
        if (!MLR_TEST_HAVE_CLIP(files[k]))
            continue;
        ck_assert(load(files[k], &r));
        loaded++;
        mlr_limits *lim = real_limits(&r);
        const int dog = strstr(files[k], "dog") != NULL;
        ck_assert_int_eq(mlr_limits_is_human(lim), !dog);
        size_t hinges = 0;
        for (size_t j = 0; j < r.j; j++) {
            mlr_limits_range g;
            ck_assert_int_eq(mlr_limits_get_range(lim, j, &g), MLR_OK);
            if (g.kind != MLR_LIMITS_HINGE)
                continue;
            hinges++;
            ck_assert_msg(is_hinge_name(r.names[j]), "%s: %s", files[k], r.names[j]);
            double st[4];
            ck_assert_int_eq(mlr_limits_get_geometry(lim, j, NULL, NULL, NULL, NULL, st), MLR_OK);
            ck_assert_msg(st[1] > 30 * DEG, "%s %s flexes %g", files[k], r.names[j], st[1]);
            ck_assert_double_le(g.lo, 0.0);
            ck_assert_double_ge(g.hi, 150 * DEG - 1e-12);
        }
        /* 4 on people (2 knees, 2 elbows) and on the dog (its knees, and its front legs'
           elbows, which twist about their bones by up to 103 degrees in this capture) */
        ck_assert_msg(hinges == 4u, "%s: %zu hinges", files[k], hinges);
        mlr_limits_destroy(lim);
        unload(&r);
    }
    ck_assert_uint_ge(loaded, 1); /* the bundled walk at least */
}
END_TEST

/* Independent knee angles from forward kinematics: flexion (thigh vs shin) and the signed
 * angle about the hinge axis in world space. */
static void hinge_world(const real *r, const mlr_limits *lim, size_t j, const double *pos,
                        const double *wrot, size_t f, double *flex, double *signed_angle)
{
    const int32_t p = r->rig.parents[j];
    int32_t c = -1;
    double best = 0;
    for (size_t k = 0; k < r->j; k++)
        if (r->rig.parents[k] == (int32_t)j) {
            const double *o = r->rig.offsets + 3 * k;
            const double l = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
            if (l > best)
                best = l, c = (int32_t)k;
        }
    ck_assert_int_ge(c, 0);
    const size_t J = r->j;
    double th[3], sh[3];
    for (int i = 0; i < 3; i++) {
        th[i] = pos[3 * (f * J + j) + i] - pos[3 * (f * J + p) + i];
        sh[i] = pos[3 * (f * J + c) + i] - pos[3 * (f * J + j) + i];
    }
    const double d = th[0] * sh[0] + th[1] * sh[1] + th[2] * sh[2];
    const double nt = sqrt(th[0] * th[0] + th[1] * th[1] + th[2] * th[2]);
    const double ns = sqrt(sh[0] * sh[0] + sh[1] * sh[1] + sh[2] * sh[2]);
    *flex = acos(fmax(-1.0, fmin(1.0, d / (nt * ns))));
    double ax[3];
    ck_assert_int_eq(mlr_limits_get_geometry(lim, j, NULL, ax, NULL, NULL, NULL), MLR_OK);
    const double *wq = wrot + 4 * (f * J + p);
    const mlr_quat q = {wq[0], wq[1], wq[2], wq[3]};
    const mlr_vec3 a = {ax[0], ax[1], ax[2]};
    mlr_vec3 n;
    mlr_quat_rotate(&q, &a, &n);
    const double cx = th[1] * sh[2] - th[2] * sh[1], cy = th[2] * sh[0] - th[0] * sh[2],
                 cz = th[0] * sh[1] - th[1] * sh[0];
    const double tn = th[0] * n.x + th[1] * n.y + th[2] * n.z;
    const double sn = sh[0] * n.x + sh[1] * n.y + sh[2] * n.z;
    *signed_angle = atan2(n.x * cx + n.y * cy + n.z * cz, d - tn * sn);
}

static void count_violations(const real *r, const mlr_limits *lim, const double *rot,
                             const double *in_max, const double *in_min, size_t *fold, size_t *rev)
{
    const size_t N = r->n, J = r->j;
    double *pos = malloc(N * J * 3 * sizeof(double)), *wr = malloc(N * J * 4 * sizeof(double));
    ck_assert_int_eq(mlr_fk_arrays(N, J, r->rig.parents, r->rig.offsets, mlr_motion_root_pos(r->m),
                                   rot, r->rig.n_trans, r->rig.trans_joints,
                                   mlr_motion_trans(r->m), pos, wr, NULL, NULL),
                     MLR_OK);
    *fold = *rev = 0;
    for (size_t f = 0; f < N; f++) {
        int bad_f = 0, bad_r = 0;
        for (size_t j = 0; j < J; j++) {
            mlr_limits_range g;
            ck_assert_int_eq(mlr_limits_get_range(lim, j, &g), MLR_OK);
            if (g.kind != MLR_LIMITS_HINGE)
                continue;
            double fl, sg;
            hinge_world(r, lim, j, pos, wr, f, &fl, &sg);
            bad_f |= fl > fmax(150 * DEG, in_max[j] + 10 * DEG);
            bad_r |= sg < fmin(0.0, in_min[j]);
        }
        *fold += (size_t)bad_f;
        *rev += (size_t)bad_r;
    }
    free(pos), free(wr);
}

START_TEST(a_stylized_real_clip_at_alpha_3_neither_folds_nor_reverses_after_limits)
{
    static const char *const files[] = {"cmu_131_01_mj_style_walk.bvh",
                                        "bandai1_walk_happy_001.bvh"};
    for (size_t k = 0; k < MLR_COUNTOF(files); k++) {
        real r;
        if (!MLR_TEST_HAVE_CLIP(files[k]))
            continue;
        ck_assert(load(files[k], &r));
        const size_t N = r.n, J = r.j;
        mlr_limits *lim = real_limits(&r);
        /* the input's own angles, measured the same way */
        double *in_max = calloc(J, sizeof(double)), *in_min = calloc(J, sizeof(double));
        {
            double *pos = malloc(N * J * 3 * sizeof(double)), *wr = malloc(N * J * 32);
            ck_assert_int_eq(mlr_fk_arrays(N, J, r.rig.parents, r.rig.offsets,
                                           mlr_motion_root_pos(r.m), mlr_motion_rot(r.m),
                                           r.rig.n_trans, r.rig.trans_joints,
                                           mlr_motion_trans(r.m), pos, wr, NULL, NULL),
                             MLR_OK);
            for (size_t j = 0; j < J; j++) {
                mlr_limits_range g;
                ck_assert_int_eq(mlr_limits_get_range(lim, j, &g), MLR_OK);
                if (g.kind != MLR_LIMITS_HINGE)
                    continue;
                in_max[j] = -1e300, in_min[j] = 1e300;
                for (size_t f = 0; f < N; f++) {
                    double fl, sg;
                    hinge_world(&r, lim, j, pos, wr, f, &fl, &sg);
                    in_max[j] = fmax(in_max[j], fl), in_min[j] = fmin(in_min[j], sg);
                }
            }
            free(pos), free(wr);
        }
        mlr_layers *lay;
        ck_assert_int_eq(mlr_layers_decompose(N, J, mlr_motion_root_pos(r.m), mlr_motion_rot(r.m),
                                              NULL, 0, NULL, &lay, NULL),
                         MLR_OK);
        double *syn = malloc(N * J * 4 * sizeof(double));
        const double alpha = 3.0;
        ck_assert_int_eq(
            mlr_layers_synthesize(lay, 0, N, &alpha, 1, NULL, 0, syn, N * J * 4, NULL), MLR_OK);
        size_t fold0, rev0, fold1, rev1;
        count_violations(&r, lim, syn, in_max, in_min, &fold0, &rev0);
        size_t *counts = malloc(J * sizeof(size_t));
        ck_assert_int_eq(mlr_limits_apply(lim, N, syn, syn, &alpha, 1, counts, J, NULL), MLR_OK);
        count_violations(&r, lim, syn, in_max, in_min, &fold1, &rev1);
        /* the unlimited synthesis does break the limits, the limited one never */
        ck_assert_msg(fold0 + rev0 > N / 10, "%s: %zu fold, %zu reversal frames unlimited",
                      files[k], fold0, rev0);
        ck_assert_msg(fold1 == 0 && rev1 == 0, "%s: %zu fold, %zu reversal frames limited",
                      files[k], fold1, rev1);
        free(counts), free(syn), free(in_max), free(in_min);
        mlr_layers_destroy(lay);
        mlr_limits_destroy(lim);
        unload(&r);
    }
}
END_TEST

static Suite *limits_suite(void)
{
    Suite *s = suite_create("limits");
    TCase *t = tcase_create("core");
    tcase_add_test(t, the_knee_of_a_synthetic_leg_is_a_hinge_about_its_axis);
    tcase_add_test(t, a_hinge_that_twists_about_its_bone_is_still_a_hinge);
    tcase_add_test(t, the_soft_saturation_is_c1_bounded_and_identity_inside);
    tcase_add_test(t, swing_is_saturated_smoothly_and_widened_with_alpha);
    tcase_add_test(t, the_input_itself_is_unchanged_inside_the_knee_points);
    tcase_add_test(t, unit_rotations_pass_bit_for_bit_and_others_come_out_normalized);
    tcase_add_test(t, user_ranges_replace_the_learned_ones);
    tcase_add_test(t, bad_input_gets_the_right_status_and_message);
    tcase_add_test(t, every_allocation_failure_returns_no_memory_without_leaks);
    tcase_add_test(t, streams_apply_the_limits_to_every_output_frame);
    tcase_add_test(t, hinges_are_found_on_the_knees_and_elbows_of_the_shared_clips);
    tcase_add_test(t, a_stylized_real_clip_at_alpha_3_neither_folds_nor_reverses_after_limits);
    suite_add_tcase(s, t);
    return s;
}

int main(void) { return mlr_test_run(limits_suite()); }
