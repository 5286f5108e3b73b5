/* Elbows kept on their own side of straight (libmlayer/guards/hinge_side.c, compiled in here):
 * the arm's axis and range are learned from the input; a synthesis that bends the elbow the
 * other way, or folds it past its range, is turned back within them on every frame, smoothly,
 * and the frames far from the correction keep their bits; an input that bends both ways far
 * has no side and is left alone. The signed flexion is measured here from the forward
 * kinematics' positions, not with the pass's own plane. */
#include "guards/hinge_side.c"
#include "guards/limits_ease.c"
#include "common/common.c" /* the allocator helpers */
#include "common/values.c" /* common__median, for rig.c */
#include "motion/rig.c"     /* common__name_matches */

#include "mlr_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { N = 240, J = 4 };
static const double FPS = 60.0;
static const double DEGR = 3.14159265358979323846 / 180.0;

static const int32_t parents[J] = {-1, 0, 1, 2};
static const double offsets[3 * J] = {0, 0, 0, 10, 0, 0, 30, 0, 0, 25, 0, 0};
static const char *const names[J] = {"Hips", "LeftArm", "LeftForeArm", "LeftHand"};

static mlr_rig arm_rig(void)
{
    return (mlr_rig){J, parents, offsets, names, 0, NULL, 0, NULL, NULL};
}

/* rotation about z by a, then about x (the bone) by twist */
static void elbow_rot(double a, double twist, double *q)
{
    const double z[4] = {cos(0.5 * a), 0, 0, sin(0.5 * a)};
    const double x[4] = {cos(0.5 * twist), sin(0.5 * twist), 0, 0};
    ik__qmul4(z, x, q);
}

/* a motion whose elbow bends by bend[f] (radians) about z, the upper arm swinging about y */
static void motion(const double *bend, double twist, double *root, double *rot)
{
    memset(root, 0, 3 * N * sizeof(double));
    for (size_t f = 0; f < N; f++) {
        double *q = rot + 4 * J * f;
        for (size_t j = 0; j < J; j++)
            q[4 * j] = 1.0, q[4 * j + 1] = q[4 * j + 2] = q[4 * j + 3] = 0.0;
        const double s = 0.3 * sin(2.0 * 3.14159265358979323846 * (double)f / 80.0);
        q[4] = cos(0.5 * s), q[6] = sin(0.5 * s);
        elbow_rot(bend[f], twist * sin((double)f / 7.0), q + 8);
    }
}

/* the signed flexion (degrees) of every frame about world z carried by the upper arm: its
   frame turns about y only, which leaves z where it is */
static void measure(const double *root, const double *rot, double *deg)
{
    const mlr_rig r = arm_rig();
    static double pos[3 * N * J], wrot[4 * N * J];
    ck_assert_int_eq(
        mlr_fk_arrays(N, J, r.parents, r.offsets, root, rot, 0, NULL, NULL, pos, wrot, NULL, NULL),
        MLR_OK);
    for (size_t f = 0; f < N; f++) {
        const double *p = pos + 3 * J * f;
        double u[3], w[3], c[3];
        sub3(p + 6, p + 3, u);
        sub3(p + 9, p + 6, w);
        common__cross3(u, w, c);
        deg[f] = atan2(c[2], common__dot3(u, w)) / DEGR;
    }
}

static hinge_side learned(const double *bend_in, double twist, int *ok, double *ref)
{
    const mlr_rig r = arm_rig();
    static double root[3 * N], rot[4 * N * J], pos[3 * N * J], wrot[4 * N * J];
    motion(bend_in, twist, root, rot);
    ck_assert_int_eq(
        mlr_fk_arrays(N, J, r.parents, r.offsets, root, rot, 0, NULL, NULL, pos, wrot, NULL, NULL),
        MLR_OK);
    hinge_side h[HINGE_SIDE_MAX];
    ck_assert_uint_eq(hinge_side__chains(&r, h, HINGE_SIDE_MAX), 1);
    ck_assert_int_eq(h[0].upper, 1);
    ck_assert_int_eq(h[0].middle, 2);
    ck_assert_int_eq(h[0].end, 3);
    *ok = hinge_side__learn(&r, N, pos, wrot, &h[0], ref);
    return h[0];
}

START_TEST(the_axis_and_the_range_come_from_the_input)
{
    double bend[N], ref[N];
    for (size_t f = 0; f < N; f++)
        bend[f] = (50.0 + 40.0 * sin((double)f / 9.0)) * DEGR; /* 10 to 90 degrees */
    int ok = 0;
    const hinge_side h = learned(bend, 0.0, &ok, ref);
    ck_assert(ok);
    /* the upper arm turns about y, so the elbow's z stays z in its frame */
    ck_assert_double_eq_tol(h.axis[2], 1.0, 1e-12);
    ck_assert(h.lo == 0.0);                          /* never bent back */
    ck_assert_double_eq_tol(h.hi, HINGE_SIDE_FOLD * DEGR, 1e-12);     /* the fold bound */
    for (size_t f = 0; f < N; f++)
        ck_assert_double_eq_tol(ref[f], bend[f], 1e-9);
}
END_TEST

START_TEST(an_input_bent_far_both_ways_has_no_side)
{
    double bend[N], ref[N];
    for (size_t f = 0; f < N; f++)
        bend[f] = 80.0 * sin((double)f / 9.0) * DEGR;
    int ok = 1;
    (void)learned(bend, 0.0, &ok, ref);
    ck_assert(!ok);
}
END_TEST

START_TEST(a_bend_the_other_way_and_a_fold_are_turned_back_smoothly)
{
    double bend_in[N], ref[N], bend[N];
    for (size_t f = 0; f < N; f++) {
        bend_in[f] = (50.0 + 40.0 * sin((double)f / 9.0)) * DEGR;
        double bump = 0.0;
        /* where the input is nearly straight, the other way: 50 degrees at the deepest;
           where it is bent most, folded past 180 degrees: 200 at the deepest */
        if (f >= 89 && f < 109)
            bump = -60.0 * sin(3.14159265358979323846 * (double)(f - 89) / 20.0);
        if (f >= 117 && f < 137)
            bump = 110.0 * sin(3.14159265358979323846 * (double)(f - 117) / 20.0);
        bend[f] = bend_in[f] + bump * DEGR;
    }
    int ok = 0;
    const hinge_side h = learned(bend_in, 0.25, &ok, ref);
    ck_assert(ok);
    const mlr_rig r = arm_rig();
    static double root[3 * N], rot[4 * N * J], before[4 * N * J];
    motion(bend, 0.25, root, rot);
    memcpy(before, rot, sizeof rot);
    double syn[N], deg[N];
    measure(root, rot, syn);
    double lowest = 0.0, wrapped = 0.0;
    for (size_t f = 89; f < 109; f++)
        lowest = fmin(lowest, syn[f]);
    for (size_t f = 117; f < 137; f++)
        wrapped = fmin(wrapped, syn[f]);
    ck_assert(lowest < -40.0 && wrapped < -150.0); /* what the pass meets (200 reads -160) */
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    size_t turned = 0;
    static uint8_t mask[N * J];
    memset(mask, 0, sizeof mask);
    ck_assert_int_eq(
        hinge_side__apply(&r, N, FPS, &h, 1, ref, root, rot, NULL, mask, &turned, &ta.base),
        MLR_OK);
    for (size_t f = 0; f < N; f++) /* the mask marks the elbow where it was turned, alone */
        for (size_t j = 0; j < J; j++)
            ck_assert_int_eq(mask[f * J + j],
                             j == 2 && memcmp(rot + 4 * (J * f + j), before + 4 * (J * f + j),
                                              4 * sizeof(double)) != 0);
    ck_assert_uint_eq(turned, 1);
    ck_assert_uint_eq(ta.live_blocks, 0);
    measure(root, rot, deg);
    double peak = 0.0, step = 0.0, prev = 0.0;
    for (size_t f = 0; f < N; f++) {
        ck_assert_msg(deg[f] >= h.lo / DEGR - 0.5 && deg[f] <= h.hi / DEGR + 0.5,
                      "frame %zu: %.2f degrees", f, deg[f]);
        const int far = f < 74 || f > 152; /* 0.25 s away */
        ck_assert(!far ||
                  memcmp(rot + 4 * J * f, before + 4 * J * f, 4 * J * sizeof(double)) == 0);
        double c = deg[f] - syn[f]; /* the turn (below a half turn) */
        c -= 360.0 * round(c / 360.0);
        peak = fmax(peak, fabs(c));
        if (f)
            step = fmax(step, fabs(c - prev));
        prev = c;
    }
    /* eased: the turn never steps by more than a fifth of its peak in a frame (0.16 here;
       turned by each frame's own shortfall it steps by 0.27 of it as the bump enters) */
    ck_assert_msg(step <= 0.2 * peak, "step %.2f, peak %.2f", step, peak);
}
END_TEST

START_TEST(no_memory_leaves_the_motion_as_it_was)
{
    double bend_in[N], ref[N], bend[N];
    for (size_t f = 0; f < N; f++) {
        bend_in[f] = (50.0 + 40.0 * sin((double)f / 9.0)) * DEGR;
        bend[f] = f >= 60 && f < 80 ? -40.0 * DEGR : bend_in[f];
    }
    int ok = 0;
    const hinge_side h = learned(bend_in, 0.0, &ok, ref);
    const mlr_rig r = arm_rig();
    static double root[3 * N], rot[4 * N * J], before[4 * N * J];
    motion(bend, 0.0, root, rot);
    memcpy(before, rot, sizeof rot);
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    ck_assert_int_eq(
        hinge_side__apply(&r, N, FPS, &h, 1, ref, root, rot, NULL, NULL, NULL, &ta.base),
        MLR_E_NO_MEMORY);
    ck_assert(memcmp(rot, before, sizeof rot) == 0);
}
END_TEST

/* The eased limits' running maximum (limits_ease.c, compiled in here for the pass): the
   deque gives the scan's values to the bit, the first of equal ones (+0 before -0 and after),
   for windows narrower and wider than the clip and past the deque's size. */
START_TEST(the_running_maximum_is_the_scans)
{
    enum { M = 700 };
    static double x[M], got[M];
    mlr_test_rng s;
    mlr_test_rng_seed(&s, 2024);
    for (size_t i = 0; i < M; i++) {
        const double u = mlr_test_rng_uniform(&s);
        x[i] = u < 0.3 ? 0.0 : u < 0.4 ? -0.0 : u < 0.6 ? (double)(int)(4.0 * u) : u - 0.5;
    }
    const size_t radii[] = {0, 1, 3, 12, 400, 600, 1000};
    for (size_t t = 0; t < sizeof radii / sizeof radii[0]; t++) {
        const size_t r = radii[t];
        running_max(x, M, r, got);
        for (size_t f = 0; f < M; f++) {
            const size_t a = f > r ? f - r : 0, b = f + r < M ? f + r : M - 1;
            double m = x[a];
            for (size_t i = a + 1; i <= b; i++)
                m = x[i] > m ? x[i] : m;
            ck_assert_msg(memcmp(&m, &got[f], sizeof m) == 0, "r %zu frame %zu", r, f);
        }
    }
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("hinge_side");
    TCase *tc = tcase_create("core");
    tcase_add_test(tc, the_axis_and_the_range_come_from_the_input);
    tcase_add_test(tc, an_input_bent_far_both_ways_has_no_side);
    tcase_add_test(tc, a_bend_the_other_way_and_a_fold_are_turned_back_smoothly);
    tcase_add_test(tc, no_memory_leaves_the_motion_as_it_was);
    tcase_add_test(tc, the_running_maximum_is_the_scans);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(suite()); }
