/* Foot contacts: feet by name, detection against a straightforward reference and on motion with
 * known contacts, the real clips, bad input, allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_d0(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ---- feet by name ---------------------------------------------------------------------- */

/* A rig from names and parents; offsets all (0, -1, 0) except where given. */
typedef struct test_rig {
    mlr_rig rig;
    int32_t parents[32];
    double offsets[96];
    const char *names[32];
    int32_t end_parents[8];
    double end_offsets[24];
} test_rig;

static void make_rig(test_rig *t, size_t J, const char *const *names, const int32_t *parents)
{
    memset(t, 0, sizeof *t);
    for (size_t j = 0; j < J; j++) {
        t->names[j] = names[j];
        t->parents[j] = parents[j];
        t->offsets[3 * j + 1] = j ? -1.0 : 0.0;
    }
    t->rig.n_joints = J;
    t->rig.parents = t->parents;
    t->rig.offsets = t->offsets;
    t->rig.names = t->names;
    t->rig.end_site_parents = t->end_parents;
    t->rig.end_site_offsets = t->end_offsets;
}

static void add_end_site(test_rig *t, int32_t parent)
{
    t->end_parents[t->rig.n_end_sites] = parent;
    t->end_offsets[3 * t->rig.n_end_sites + 2] = 1.0;
    t->rig.n_end_sites++;
}

START_TEST(feet_are_ankles_with_their_toes_or_end_sites)
{
    /* CMU-like: both legs with toes, the toe of the right one behind a zero-length joint, a
     * nested "LeftFootRoll" below LeftFoot (not a second foot) */
    const char *names[] = {"Hips",         "LeftUpLeg",    "LeftLeg",    "LeftFoot",
                           "LeftFootRoll", "LeftToeBase",  "RightUpLeg", "RightLeg",
                           "RightFoot",    "RightFootAux", "RightToe",   "Spine"};
    const int32_t parents[] = {-1, 0, 1, 2, 3, 3, 0, 6, 7, 8, 9, 0};
    test_rig t;
    make_rig(&t, 12, names, parents);
    t.offsets[3 * 9 + 1] = 0.0; /* RightFootAux has zero length */
    int32_t jt[24], es[24];
    size_t F;
    mlr_diag d;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 12, jt, es, &F, NULL, &d),
                     MLR_OK);
    ck_assert_uint_eq(F, 2);
    const int32_t want_j[4] = {3, 5, 8, 10}, want_e[4] = {-1, -1, -1, -1};
    for (int i = 0; i < 4; i++) {
        ck_assert_int_eq(jt[i], want_j[i]);
        ck_assert_int_eq(es[i], want_e[i]);
    }
    /* when the zero-length joint has length, the toe behind it no longer counts: End Site */
    t.offsets[3 * 9 + 1] = -1e-6;
    add_end_site(&t, 8);
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 12, jt, es, &F, NULL, &d),
                     MLR_OK);
    ck_assert_int_eq(jt[2], 8);
    ck_assert_int_eq(jt[3], 8);
    ck_assert_int_eq(es[3], 0);
    /* without the End Site, no toe */
    t.rig.n_end_sites = 0;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 12, jt, es, &F, NULL, &d),
                     MLR_OK);
    ck_assert_int_eq(jt[3], -1);
    ck_assert_int_eq(es[3], -1);
    /* capacity too small */
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 1, jt, es, &F, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "2 feet found, room for 1"));
}
END_TEST

START_TEST(the_longest_toe_wins_and_names_fold_case)
{
    /* MakeHuman-like five toes of different lengths below "lfoot"; an upper-case "ANKLE" with a
     * Kelvin sign (U+212A) for its K, and "Ball" toes */
    const char *names[] = {"root",   "lfoot",   "toe1",  "toe2",
                           "toe3",   "toe4",    "toe5",  "R_AN\xE2\x84\xAALE",
                           "r_Ball", "R_BALL2", "pelvis"};
    const int32_t parents[] = {-1, 0, 1, 1, 1, 1, 1, 0, 7, 7, 0};
    test_rig t;
    make_rig(&t, 11, names, parents);
    const double len[] = {0, 0, 1.0, 2.5, 3.0, 3.0, 0.5, 1, 2.0, 1.0, 1};
    for (int j = 0; j < 11; j++)
        t.offsets[3 * j + 1] = 0, t.offsets[3 * j + 2] = len[j];
    int32_t jt[22], es[22];
    size_t F;
    mlr_diag d;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 11, jt, es, &F, NULL, &d),
                     MLR_OK);
    ck_assert_uint_eq(F, 2);
    ck_assert_int_eq(jt[0], 1);
    ck_assert_int_eq(jt[1], 4); /* toe3 and toe4 tie at 3.0: the first */
    ck_assert_int_eq(jt[2], 7);
    ck_assert_int_eq(jt[3], 8);
    /* substrings in any case; an interrupted "ank_le" is not one */
    const char *n2[] = {"root", "hoOF", "anKle_not", "paWx", "ank_le"};
    const int32_t p2[] = {-1, 0, 0, 0, 0};
    make_rig(&t, 5, n2, p2);
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 5, jt, es, &F, NULL, &d),
                     MLR_OK);
    ck_assert_uint_eq(F, 3);
}
END_TEST

START_TEST(no_feet_names_the_patterns)
{
    const char *names[] = {"root", "a", "b"};
    const int32_t parents[] = {-1, 0, 1};
    test_rig t;
    make_rig(&t, 3, names, parents);
    int32_t jt[6], es[6];
    size_t F = 7;
    mlr_diag d;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 3, jt, es, &F, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_uint_eq(F, 0);
    ck_assert_ptr_nonnull(strstr(d.message, "no feet found"));
    ck_assert_ptr_nonnull(strstr(d.message, "foot, ankle, paw or hoof"));
    ck_assert_ptr_nonnull(strstr(d.message, "toe or ball"));
    t.rig.names = NULL;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, MLR_AXIS_Y, 3, jt, es, &F, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "no joint names"));
    t.rig.names = t.names;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, 3, 3, jt, es, &F, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 2, NULL, MLR_AXIS_Y, 3, jt, es, &F, NULL, &d),
                     MLR_E_INVALID_ARG);
}
END_TEST

/* A quadruped: hands are feet when they stay low, along the given up axis. */
static void dog_positions(double *pos, size_t N, int up, double hand_height)
{
    /* joints: 0 Hips, 1 LeftFoot, 2 Spine, 3 LeftHand, 4 Head; one coordinate along up */
    const double h[5] = {6, 0, 6, 0, 8};
    for (size_t f = 0; f < N; f++)
        for (int j = 0; j < 5; j++) {
            double *p = pos + 3 * (5 * f + (size_t)j);
            p[0] = p[1] = p[2] = 0.1 * (double)j + 0.01 * (double)f;
            p[up] = j == 3 ? hand_height + 0.1 * (double)(f % 3) : h[j];
        }
}

START_TEST(hands_that_stay_low_are_feet)
{
    const char *names[] = {"Hips", "LeftFoot", "Spine", "LeftHand", "Head"};
    const int32_t parents[] = {-1, 0, 0, 2, 2};
    test_rig t;
    make_rig(&t, 5, names, parents);
    enum { N = 9 };
    double pos[N * 5 * 3];
    int32_t jt[10], es[10];
    size_t F;
    mlr_diag d;
    /* H = 8, the foot on the ground: a hand whose median height is up to 0.2 H = 1.6 is a
     * foot (the hand's median is hand_height + 0.1) */
    for (int up = 0; up < 3; up++) {
        dog_positions(pos, N, up, 1.4);
        ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, N, pos, up, 5, jt, es, &F, NULL, &d),
                         MLR_OK);
        ck_assert_uint_eq(F, 2);
        ck_assert_int_eq(jt[0], 1);
        ck_assert_int_eq(jt[2], 3);
        ck_assert_int_eq(jt[3], -1);
        /* along another axis the hand is 0.3 above the lowest joint, the foot 0.1, the extent
         * 0.4 + 0: 0.3 > 0.1 + 0.08, a hand */
        ck_assert_int_eq(
            mlr_contacts_find_feet(&t.rig, N, pos, (up + 1) % 3, 5, jt, es, &F, NULL, &d), MLR_OK);
        ck_assert_uint_eq(F, 1);
        dog_positions(pos, N, up, 1.6); /* median 1.7 > 1.6: a hand, not a foot */
        ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, N, pos, up, 5, jt, es, &F, NULL, &d),
                         MLR_OK);
        ck_assert_uint_eq(F, 1);
    }
    /* no positions: hands are never feet */
    dog_positions(pos, N, 1, 0.0);
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, 0, NULL, 1, 5, jt, es, &F, NULL, &d), MLR_OK);
    ck_assert_uint_eq(F, 1);
    pos[3 * 7 + 1] = NAN;
    ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, N, pos, 1, 5, jt, es, &F, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "not finite"));
    /* every allocation failure */
    dog_positions(pos, N, 1, 0.0);
    size_t fails = 0;
    for (size_t k = 0;; k++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        mlr_status st = mlr_contacts_find_feet(&t.rig, N, pos, 1, 5, jt, es, &F, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (st == MLR_OK) {
            ck_assert_uint_eq(F, 2);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        fails++;
    }
    ck_assert_uint_eq(fails, 3); /* flags, body height, medians */
}
END_TEST

/* The hand rule on random heights (many ties, odd and even counts): the same decision as
 * medians by sorting. */
static double sorted_median(double *v, size_t n)
{
    qsort(v, n, sizeof(double), cmp_d0);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

START_TEST(the_hand_rule_equals_medians_by_sorting)
{
    const char *names[] = {"Hips", "LeftFoot", "RightAnkle", "Spine", "LeftHand", "RightWrist"};
    const int32_t parents[] = {-1, 0, 0, 0, 3, 3};
    test_rig t;
    make_rig(&t, 6, names, parents);
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 7);
    size_t seen[2] = {0, 0};
    for (int trial = 0; trial < 300; trial++) {
        const size_t N = 1 + (size_t)(mlr_test_rng_uniform(&rng) * 200);
        const int up = trial % 3, coarse = trial % 2; /* coarse: values on a grid of 0.5 */
        double *pos = malloc(3 * N * 6 * sizeof(double)), *ext = malloc(N * sizeof(double));
        double *g = malloc(N * sizeof(double)), *rel = malloc(2 * N * sizeof(double));
        double *hr = malloc(N * sizeof(double));
        for (size_t i = 0; i < 3 * N * 6; i++) {
            double x = 10 * mlr_test_rng_uniform(&rng);
            pos[i] = coarse ? 0.5 * floor(2 * x) : x;
        }
        for (size_t f = 0; f < N; f++) {
            double lo = INFINITY, hi = -INFINITY;
            for (size_t j = 0; j < 6; j++) {
                const double y = pos[3 * (6 * f + j) + up];
                lo = y < lo ? y : lo, hi = y > hi ? y : hi;
            }
            ext[f] = hi - lo, g[f] = lo;
            rel[2 * f] = pos[3 * (6 * f + 1) + up] - lo;
            rel[2 * f + 1] = pos[3 * (6 * f + 2) + up] - lo;
        }
        double H = sorted_median(ext, N);
        H = H == 0.0 ? 1.0 : H;
        const double foot_h = sorted_median(rel, 2 * N);
        int want[2];
        for (int h = 0; h < 2; h++) {
            for (size_t f = 0; f < N; f++)
                hr[f] = pos[3 * (6 * f + 4 + (size_t)h) + up] - g[f];
            want[h] = sorted_median(hr, N) <= foot_h + 0.2 * H;
            seen[want[h]]++;
        }
        int32_t jt[12], es[12];
        size_t F;
        mlr_diag d;
        ck_assert_int_eq(mlr_contacts_find_feet(&t.rig, N, pos, up, 6, jt, es, &F, NULL, &d),
                         MLR_OK);
        ck_assert_uint_eq(F, 2 + (size_t)want[0] + (size_t)want[1]);
        size_t f = 2;
        for (int h = 0; h < 2; h++)
            if (want[h])
                ck_assert_int_eq(jt[2 * f++], 4 + h);
        free(pos), free(ext), free(g), free(rel), free(hr);
    }
    ck_assert_uint_gt(seen[0], 20); /* both decisions are exercised */
    ck_assert_uint_gt(seen[1], 50);
}
END_TEST

/* ---- detection ------------------------------------------------------------------------ */

/* Straightforward reference: direct window minima, plain loops. */
static size_t ref_round(double x)
{
    double r = floor(x + 0.5);
    if (r - x == 0.5 && fmod(r, 2.0) != 0.0)
        r -= 1.0;
    return (size_t)r;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void ref_detect(size_t N, size_t C, const double *p, double fps, int up, double speed,
                       double height, double min_dur, double H, uint8_t *out)
{
    size_t k = ref_round(fps / 60.0);
    k = k < 1 ? 1 : k;
    const long half = (long)ref_round(0.75 * fps);
    const size_t gap = ref_round(0.05 * fps);
    size_t shortest = ref_round(min_dur * fps);
    shortest = shortest < 2 ? 2 : shortest;
    for (size_t c = 0; c < C; c++) {
        int state = 0;
        for (size_t t = 0; t < N; t++) {
            size_t t0, t1;
            double dt;
            if (N > 2 * k) {
                size_t u = t < k ? k : t > N - k - 1 ? N - k - 1 : t;
                t0 = u - k, t1 = u + k, dt = (double)(2 * k) / fps;
            } else {
                t0 = 0, t1 = N - 1, dt = (double)(N - 1) / fps;
            }
            double s2 = 0;
            for (int a = 0; a < 3; a++) {
                double x = p[3 * (t1 * C + c) + a] - p[3 * (t0 * C + c) + a];
                s2 += x * x;
            }
            double v = sqrt(s2) / dt, lo = INFINITY;
            for (long u = (long)t - half; u <= (long)t + half; u++)
                if (u >= 0 && u < (long)N && p[3 * ((size_t)u * C + c) + up] < lo)
                    lo = p[3 * ((size_t)u * C + c) + up];
            double h = p[3 * (t * C + c) + up] - lo;
            if (v < speed * H && h < height * H)
                state = 1;
            else if (v > 2.0 * speed * H || h > 1.5 * height * H)
                state = 0;
            out[t * C + c] = (uint8_t)state;
        }
        /* close the short gaps, then drop the short contacts */
        uint8_t *col = malloc(N);
        for (size_t t = 0; t < N; t++)
            col[t] = out[t * C + c];
        for (size_t a = 1; a < N; a++) {
            if (col[a] || !col[a - 1])
                continue;
            size_t b = a;
            while (b < N && !col[b])
                b++;
            if (b < N && b - a <= gap)
                memset(col + a, 1, b - a);
        }
        for (size_t a = 0; a < N; a++) {
            if (!col[a] || (a && col[a - 1]))
                continue;
            size_t b = a;
            while (b < N && col[b])
                b++;
            if (b - a < shortest)
                memset(col + a, 0, b - a);
        }
        for (size_t t = 0; t < N; t++)
            out[t * C + c] = col[t];
        free(col);
    }
}

static double ref_height(size_t N, size_t J, const double *pos, int up)
{
    double *e = malloc(N * sizeof(double));
    for (size_t f = 0; f < N; f++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t j = 0; j < J; j++) {
            double y = pos[3 * (f * J + j) + up];
            lo = y < lo ? y : lo;
            hi = y > hi ? y : hi;
        }
        e[f] = hi - lo;
    }
    qsort(e, N, sizeof(double), cmp_d);
    double h = N % 2 ? e[N / 2] : 0.5 * (e[N / 2 - 1] + e[N / 2]);
    free(e);
    return h;
}

/* Known contacts: 4 joints (Hips at 10, Head at 20, a stationary RightFoot at 0 so that the
 * body height is exactly 20, and a LeftFoot that steps) at 60 fps, along up axis `up`:
 * LeftFoot stands still on frames [10, 40) with a 1-frame blip to 1.0 at frame 25, and on
 * [60, 64); elsewhere it moves 1 unit per frame at height 3. */
enum { KN = 90, KJ = 4 };
static void stepping_positions(double *pos, int up)
{
    const int side = (up + 1) % 3, fwd = (up + 2) % 3;
    for (size_t f = 0; f < KN; f++) {
        const double lift[KJ] = {10, 20, 0, 3};
        for (size_t j = 0; j < KJ; j++) {
            double *p = pos + 3 * (KJ * f + j);
            p[up] = lift[j];
            p[side] = (double)j;
            p[fwd] = j == 3 ? (double)f : 0.0;
        }
        double *foot = pos + 3 * (KJ * f + 3);
        if ((f >= 10 && f < 40) || (f >= 60 && f < 64)) {
            foot[up] = f == 25 ? 1.0 : 0.0;
            foot[fwd] = f < 40 ? 10.0 : 60.0;
        }
    }
}

START_TEST(known_contacts_of_a_stepping_foot_on_every_up_axis)
{
    const char *names[] = {"Hips", "Head", "RightFoot", "LeftFoot"};
    const int32_t parents[] = {-1, 0, 0, 0};
    test_rig t;
    make_rig(&t, KJ, names, parents);
    double *pos = malloc(3 * KN * KJ * sizeof(double));
    const int32_t pts[2] = {3, 2};
    uint8_t c[2 * KN];
    mlr_diag d;
    for (int up = 0; up < 3; up++) {
        stepping_positions(pos, up);
        ck_assert_int_eq(mlr_contacts_detect(&t.rig, 60.0, up, KN, pos, NULL, 2, pts, NULL, NULL,
                                             0, c, NULL, &d),
                         MLR_OK);
        /* the first stance: frames 11..38 (frames 10 and 39 see the jump in their central
         * difference; the blip at 25 leaves 24 and 26 out, a 1-frame gap each, closed); the
         * second stance of 4 frames gives 2 frames of contact, shorter than 0.08 s: dropped */
        for (size_t f = 0; f < KN; f++) {
            ck_assert_msg(c[2 * f] == (f >= 11 && f < 39), "up %d frame %zu: %d", up, f, c[2 * f]);
            ck_assert_int_eq(c[2 * f + 1], 1);
        }
        /* with a 1-frame minimum (2 frames: the floor) the second stance stays */
        mlr_contacts_option o = {MLR_CONTACTS_OPT_MIN_DURATION, 1.0 / 60};
        ck_assert_int_eq(
            mlr_contacts_detect(&t.rig, 60.0, up, KN, pos, NULL, 2, pts, NULL, &o, 1, c, NULL, &d),
            MLR_OK);
        for (size_t f = 40; f < KN; f++)
            ck_assert_int_eq(c[2 * f], f == 61 || f == 62);
        /* a stricter height (enter below 0.8, leave above 1.2): the blip frame (1.0) no longer
         * enters by itself, but the 3-frame gap 24..26 is closed all the same */
        mlr_contacts_option o2 = {MLR_CONTACTS_OPT_HEIGHT, 0.04};
        ck_assert_int_eq(mlr_contacts_detect(&t.rig, 60.0, up, KN, pos, NULL, 2, pts, NULL, &o2, 1,
                                             c, NULL, &d),
                         MLR_OK);
        for (size_t f = 0; f < 40; f++)
            ck_assert_int_eq(c[2 * f], f >= 11 && f < 39);
        /* a lax speed, 5 body heights/s (enter below 100 units/s, leave above 200): frame 10
         * (95 units/s, on the floor) enters; the swing (60 units/s) is slow but high */
        mlr_contacts_option o3 = {MLR_CONTACTS_OPT_SPEED, 5.0};
        ck_assert_int_eq(mlr_contacts_detect(&t.rig, 60.0, up, KN, pos, NULL, 2, pts, NULL, &o3, 1,
                                             c, NULL, &d),
                         MLR_OK);
        for (size_t f = 0; f < 40; f++)
            ck_assert_int_eq(c[2 * f], f >= 10 && f < 39);
    }
    free(pos);
}
END_TEST

/* Random smooth motion of a few points, at several frame rates and options: equal to the
 * straightforward reference, bit for bit. */
START_TEST(detection_equals_the_reference_on_random_motion)
{
    const char *names[] = {"Hips", "Head", "LeftFoot", "RightFoot", "LeftToe"};
    const int32_t parents[] = {-1, 0, 0, 0, 2};
    test_rig t;
    make_rig(&t, 5, names, parents);
    add_end_site(&t, 3);
    const double fps_list[] = {24.0, 25.0, 30.0, 59.94, 60.0, 120.0, 2.0, 1000.0};
    mlr_test_rng rng;
    mlr_test_rng_seed(&rng, 18);
    size_t agreements = 0, total_contacts = 0;
    for (size_t trial = 0; trial < 24; trial++) {
        const double fps = fps_list[trial % MLR_COUNTOF(fps_list)];
        const size_t N = 3 + (size_t)(mlr_test_rng_uniform(&rng) * 400);
        const int up = (int)(trial % 3);
        double *pos = malloc(3 * N * 5 * sizeof(double)),
               *rot = malloc(4 * N * 5 * sizeof(double));
        double ph[5], fr[5];
        for (int j = 0; j < 5; j++)
            ph[j] = 6.28 * mlr_test_rng_uniform(&rng),
            fr[j] = 0.5 + 2 * mlr_test_rng_uniform(&rng);
        for (size_t f = 0; f < N; f++) {
            const double time = (double)f / fps;
            for (int j = 0; j < 5; j++) {
                double *p = pos + 3 * (5 * f + (size_t)j);
                const double s = sin(6.283185307179586 * fr[j] * time + ph[j]);
                const int a1 = (up + 1) % 3, a2 = (up + 2) % 3;
                /* feet: planted (with noise) where s <= 0.2, else moving at 200 units/s and
                 * lifted up to 12 */
                const int planted = j > 1 && s <= 0.2;
                p[a1] = (planted ? 40 * (double)j : 200 * time) +
                        0.3 * mlr_test_rng_normal(&rng) * (j > 1);
                p[a2] = 3 * (double)j + 0.3 * mlr_test_rng_normal(&rng) * (j > 1);
                p[up] = j == 0   ? 100
                        : j == 1 ? 170
                                 : 15 * (s > 0.2 ? s - 0.2 : 0) + 0.2 * mlr_test_rng_normal(&rng);
                double *q = rot + 4 * (5 * f + (size_t)j);
                const double a = 0.5 * s;
                q[0] = cos(a), q[1] = sin(a), q[2] = 0, q[3] = 0;
            }
        }
        const int32_t jt[4] = {2, 3, 4, 3}, es[4] = {-1, -1, -1, 0};
        mlr_contacts_option o[3] = {
            {MLR_CONTACTS_OPT_SPEED, 0.1 + mlr_test_rng_uniform(&rng)},
            {MLR_CONTACTS_OPT_MIN_DURATION, 0.2 * mlr_test_rng_uniform(&rng) + 1e-3},
            {MLR_CONTACTS_OPT_HEIGHT, 0.02 + 0.1 * mlr_test_rng_uniform(&rng)}};
        const size_t n_opts = trial % 4;
        uint8_t *c = malloc(4 * N), *r = malloc(4 * N);
        mlr_diag d;
        ck_assert_int_eq(
            mlr_contacts_detect(&t.rig, fps, up, N, pos, rot, 4, jt, es, o, n_opts, c, NULL, &d),
            MLR_OK);
        double p[4 * 3 * 403];
        ck_assert_int_eq(mlr_rig_point_positions(&t.rig, N, pos, rot, 4, jt, es, p, &d), MLR_OK);
        const double H = ref_height(N, 5, pos, up);
        ref_detect(N, 4, p, fps, up, n_opts > 0 ? o[0].value : 0.25,
                   n_opts > 2 ? o[2].value : 0.06, n_opts > 1 ? o[1].value : 0.08, H, r);
        ck_assert_int_eq(memcmp(c, r, 4 * N), 0);
        for (size_t i = 0; i < 4 * N; i++)
            total_contacts += c[i];
        agreements++;
        free(pos);
        free(rot);
        free(c);
        free(r);
    }
    ck_assert_uint_eq(agreements, 24);
    ck_assert_uint_gt(total_contacts, 1000); /* the comparison saw contacts */
}
END_TEST

START_TEST(bad_input_says_why)
{
    const char *names[] = {"Hips", "Head", "RightFoot", "LeftFoot"};
    const int32_t parents[] = {-1, 0, 0, 0};
    test_rig t;
    make_rig(&t, KJ, names, parents);
    add_end_site(&t, 3);
    double *pos = malloc(3 * KN * KJ * sizeof(double));
    stepping_positions(pos, 1);
    int32_t pts[2] = {3, 2}, es[2] = {-1, -1};
    uint8_t c[2 * KN];
    mlr_diag d;
#define DETECT(fps, up, n, wr, np, jt, e, o, no) \
    mlr_contacts_detect(&t.rig, fps, up, n, pos, wr, np, jt, e, o, no, c, NULL, &d)
#define EXPECT(call, text)                                                                  \
    do {                                                                                    \
        ck_assert_int_eq(call, MLR_E_INVALID_ARG);                                          \
        ck_assert_msg(strstr(d.message, text) != NULL, "'%s' lacks '%s'", d.message, text); \
    } while (0)
    EXPECT(DETECT(0.0, 1, KN, NULL, 2, pts, NULL, NULL, 0), "fps");
    EXPECT(DETECT(NAN, 1, KN, NULL, 2, pts, NULL, NULL, 0), "fps");
    EXPECT(DETECT(60.0, 3, KN, NULL, 2, pts, NULL, NULL, 0), "up axis 3");
    EXPECT(DETECT(60.0, 1, 2, NULL, 2, pts, NULL, NULL, 0), "at least 3 frames, got 2");
    EXPECT(DETECT(60.0, 1, KN, NULL, 0, pts, NULL, NULL, 0), "no contact points");
    pts[1] = 4;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, NULL, NULL, 0), "joint 4 outside");
    pts[1] = 3;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, NULL, NULL, 0), "points 0 and 1 are the same");
    es[1] = 0;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, NULL, 0), "world_rot is needed");
    pts[1] = 2;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, NULL, 0), "is not below joint");
    es[1] = -1;
    mlr_contacts_option o[2] = {{MLR_CONTACTS_OPT_SPEED, INFINITY}, {9, 1.0}};
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, o, 1),
           "contacts: option speed = inf is not finite");
    o[0].value = -1;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, o, 1), "option speed = -1 is not > 0");
    o[0].key = MLR_CONTACTS_OPT_HEIGHT, o[0].value = NAN;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, o, 1), "option height = nan is not finite");
    o[0].key = MLR_CONTACTS_OPT_MIN_DURATION, o[0].value = 0;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, o, 1), "option min_duration = 0 is not > 0");
    o[0].value = 0.1;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, o, 2), "unknown option key 9");
    o[1] = o[0];
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, o, 2), "min_duration given twice");
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, NULL, 1), "opts is NULL");
    /* a flat skeleton: nothing along the up axis (all at 0 along X) */
    for (size_t i = 0; i < KN * KJ; i++)
        pos[3 * i] = 0.0;
    EXPECT(DETECT(60.0, 0, KN, NULL, 2, pts, es, NULL, 0), "no extent along the up axis");
    stepping_positions(pos, 1);
    pos[3 * (KJ * 5 + 3) + 2] = NAN; /* a horizontal coordinate of a point */
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, NULL, 0), "not finite");
    stepping_positions(pos, 1);
    int32_t bad_parents[KJ] = {-1, 0, 3, 0};
    t.rig.parents = bad_parents;
    EXPECT(DETECT(60.0, 1, KN, NULL, 2, pts, es, NULL, 0), "parents[2]");
    t.rig.parents = t.parents;
    ck_assert_int_eq(
        mlr_contacts_detect(&t.rig, 60.0, 1, KN, NULL, NULL, 2, pts, es, NULL, 0, c, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_int_eq(
        mlr_contacts_detect(NULL, 60.0, 1, KN, pos, NULL, 2, pts, es, NULL, 0, c, NULL, &d),
        MLR_E_INVALID_ARG);
    /* the names, End Site offsets and the rest stay usable: a valid call still works */
    ck_assert_int_eq(DETECT(60.0, 1, KN, NULL, 2, pts, es, NULL, 0), MLR_OK);
    free(pos);
#undef DETECT
#undef EXPECT
}
END_TEST

START_TEST(every_allocation_failure_is_no_memory_without_leaks)
{
    const char *names[] = {"Hips", "Head", "RightFoot", "LeftFoot"};
    const int32_t parents[] = {-1, 0, 0, 0};
    test_rig t;
    make_rig(&t, KJ, names, parents);
    double *pos = malloc(3 * KN * KJ * sizeof(double));
    stepping_positions(pos, 2);
    const int32_t pts[2] = {3, 2};
    uint8_t c[2 * KN], ref[2 * KN];
    mlr_diag d;
    ck_assert_int_eq(
        mlr_contacts_detect(&t.rig, 60.0, 2, KN, pos, NULL, 2, pts, NULL, NULL, 0, ref, NULL, &d),
        MLR_OK);
    size_t fails = 0;
    for (size_t k = 0;; k++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        mlr_status st = mlr_contacts_detect(&t.rig, 60.0, 2, KN, pos, NULL, 2, pts, NULL, NULL, 0,
                                            c, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (st == MLR_OK) {
            ck_assert_int_eq(memcmp(c, ref, sizeof c), 0);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_ptr_nonnull(strstr(d.message, "out of memory"));
        fails++;
    }
    ck_assert_uint_eq(fails, 2); /* body height, the scratch block */
    free(pos);
}
END_TEST

/* ---- the real clips --------------------------------------------------------------------- */

static const char *const clip_files[] = {"cmu_131_01_mj_style_walk.bvh",
                                         "bandai1_walk_happy_001.bvh",
                                         "lafan1_clip_a.bvh",
                                         "ai4a_dog_D1_008_KAN01_002.bvh",
                                         "cmu_01_01_playground_jumps.bvh",
                                         "cmu_02_03_run_jog_25fps.bvh",
                                         "cmu_10_01_soccer_kick.bvh",
                                         "cmu_60_10_salsa_dance.bvh"};
/* the points find_feet gives in Python, "" for clips the pytest suite does not pin */
static const char *const clip_feet[] = {
    "LeftAnkle LeftToe RightAnkle RightToe",
    "Foot_L Toes_L Foot_R Toes_R",
    "LeftFoot LeftToe RightFoot RightToe",
    "LeftHand LeftHand/End RightHand RightHand/End LeftFoot LeftFoot/End RightFoot "
    "RightFoot/End",
    "LeftFoot LeftToeBase RightFoot RightToeBase",
    "",
    "rFoot rFoot/End lFoot lFoot/End",
    ""};

START_TEST(real_clips_feet_and_contacts)
{
    char path[4096];
    MLR_TEST_NEED_CLIP(clip_files[_i]);
    mlr_test_clip_path(clip_files[_i], path, sizeof path);
    mlr_motion *m = NULL;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &m, &d), MLR_OK);
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
    const char **names = malloc(J * sizeof(char *));
    for (size_t j = 0; j < J; j++)
        names[j] = mlr_motion_joint_name(m, j);
    mlr_rig rig = {J,
                   mlr_motion_parents(m),
                   mlr_motion_offsets(m),
                   names,
                   mlr_motion_n_trans(m),
                   mlr_motion_trans_joints(m),
                   mlr_motion_n_end_sites(m),
                   mlr_motion_end_site_parents(m),
                   mlr_motion_end_site_offsets(m)};
    double *wp = malloc(3 * N * J * sizeof(double)), *wr = malloc(4 * N * J * sizeof(double));
    ck_assert_int_eq(mlr_fk_motion(m, 0, N, wp, wr, NULL), MLR_OK);
    int32_t *jt = malloc(2 * J * sizeof(int32_t)), *es = malloc(2 * J * sizeof(int32_t));
    size_t F;
    ck_assert_int_eq(mlr_contacts_find_feet(&rig, N, wp, MLR_AXIS_Y, J, jt, es, &F, NULL, &d),
                     MLR_OK);
    /* compact the points (every foot of these clips has a toe or an End Site) and name them */
    char listed[512] = "";
    size_t C = 0;
    for (size_t i = 0; i < 2 * F; i++) {
        if (jt[i] < 0)
            continue;
        jt[C] = jt[i], es[C] = es[i], C++;
        snprintf(listed + strlen(listed), sizeof listed - strlen(listed), "%s%s%s",
                 C > 1 ? " " : "", names[jt[i]], es[i] >= 0 ? "/End" : "");
    }
    if (clip_feet[_i][0])
        ck_assert_str_eq(listed, clip_feet[_i]);
    const double fps = 1.0 / mlr_motion_frame_time(m);
    uint8_t *c = malloc(N * C), *r = malloc(N * C);
    ck_assert_int_eq(
        mlr_contacts_detect(&rig, fps, MLR_AXIS_Y, N, wp, wr, C, jt, es, NULL, 0, c, NULL, &d),
        MLR_OK);
    /* every point touches the ground somewhere, and is off it somewhere */
    for (size_t p = 0; p < C; p++) {
        size_t on = 0;
        for (size_t f = 0; f < N; f++)
            on += c[f * C + p];
        ck_assert_msg(on > 0 && on < N, "%s: point %zu in contact on %zu of %zu frames",
                      clip_files[_i], p, on, N);
    }
    /* the reference, on the same positions */
    double *p = malloc(3 * N * C * sizeof(double));
    ck_assert_int_eq(mlr_rig_point_positions(&rig, N, wp, wr, C, jt, es, p, &d), MLR_OK);
    ref_detect(N, C, p, fps, MLR_AXIS_Y, 0.25, 0.06, 0.08, ref_height(N, J, wp, MLR_AXIS_Y), r);
    ck_assert_int_eq(memcmp(c, r, N * C), 0);
    free(p);
    free(c);
    free(r);
    free(jt);
    free(es);
    free(wp);
    free(wr);
    free(names);
    mlr_motion_destroy(m);
}
END_TEST

static Suite *contacts_suite(void)
{
    Suite *s = suite_create("contacts");
    TCase *tc = tcase_create("contacts");
    tcase_add_test(tc, feet_are_ankles_with_their_toes_or_end_sites);
    tcase_add_test(tc, the_longest_toe_wins_and_names_fold_case);
    tcase_add_test(tc, no_feet_names_the_patterns);
    tcase_add_test(tc, hands_that_stay_low_are_feet);
    tcase_add_test(tc, the_hand_rule_equals_medians_by_sorting);
    tcase_add_test(tc, known_contacts_of_a_stepping_foot_on_every_up_axis);
    tcase_add_test(tc, detection_equals_the_reference_on_random_motion);
    tcase_add_test(tc, bad_input_says_why);
    tcase_add_test(tc, every_allocation_failure_is_no_memory_without_leaks);
    tcase_add_loop_test(tc, real_clips_feet_and_contacts, 0, (int)MLR_COUNTOF(clip_files));
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(contacts_suite()); }
