/* Mirroring: joint pairs by every naming rule and explicit pairs, the auto plane, reflected
 * rotations against rotation matrices (M R M), the mirrored motion's positions against the
 * reflected, side-swapped positions of the input (an asymmetric synthetic rig with position
 * channels and End Sites, and every shared clip), mirroring twice, in place, keeping the
 * skeleton; bad input; allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- naming rules ------------------------------------------------------------------------ */

/* Every joint a child of the root, so that any pairing keeps the hierarchy. */
static const char *const rule_names[] = {
    "Root",
    "LeftUpLeg",
    "RightUpLeg",
    "mixamorig:LeftArm",
    "mixamorig:RightArm",
    "Hand_L",
    "Hand_R",
    "upperarm_l",
    "upperarm_r",
    "Eye.L",
    "Eye.R",
    "L_Foot",
    "R_Foot",
    "lHip",
    "rHip",
    "LHipJoint",
    "RHipJoint",
    "lcollar",
    "rcollar",
    "Bip01 L Thigh",
    "Bip01 R Thigh",
    "LEFT_EYE",
    "RIGHT_EYE",
    "leftEye",
    "rightEye",
    "LowerBack",
    "lowerback",
    "Spine",
    "Lumbar",
    "ns|rThumb",
    "ns|lThumb",
};
#define RJ (sizeof rule_names / sizeof rule_names[0])

static int32_t rule_parents[RJ];
static double rule_offsets[3 * RJ];

static mlr_rig rule_rig(void)
{
    for (size_t j = 0; j < RJ; j++) {
        rule_parents[j] = j ? 0 : -1;
        /* the left joints at +x, the right ones at -x (by the expected side) */
        rule_offsets[3 * j] = 0.0;
        rule_offsets[3 * j + 1] = (double)j;
        rule_offsets[3 * j + 2] = 0.5;
    }
    return (mlr_rig){RJ, rule_parents, rule_offsets, rule_names, 0, NULL, 0, NULL, NULL};
}

static size_t idx(const char *const *names, size_t n, const char *name)
{
    for (size_t j = 0; j < n; j++)
        if (strcmp(names[j], name) == 0)
            return j;
    ck_abort_msg("no joint %s", name);
    return 0;
}

START_TEST(every_naming_rule_pairs_its_joints_and_tells_the_side)
{
    const mlr_rig r = rule_rig();
    static const char *const pairs[][2] = {
        {"LeftUpLeg", "RightUpLeg"},
        {"mixamorig:LeftArm", "mixamorig:RightArm"},
        {"Hand_L", "Hand_R"},
        {"upperarm_l", "upperarm_r"},
        {"Eye.L", "Eye.R"},
        {"L_Foot", "R_Foot"},
        {"lHip", "rHip"},
        {"LHipJoint", "RHipJoint"},
        {"lcollar", "rcollar"},
        {"Bip01 L Thigh", "Bip01 R Thigh"},
        {"LEFT_EYE", "RIGHT_EYE"},
        {"leftEye", "rightEye"},
        {"ns|lThumb", "ns|rThumb"},
    };
    static const char *const mid[] = {"Root", "LowerBack", "lowerback", "Spine", "Lumbar"};
    int32_t partner[RJ];
    int8_t side[RJ];
    size_t n_pairs = 0;
    mlr_diag d;
    ck_assert_msg(mlr_mirror_pairs(&r, NULL, 0, 0, partner, side, &n_pairs, NULL, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_uint_eq(n_pairs, MLR_COUNTOF(pairs));
    for (size_t k = 0; k < MLR_COUNTOF(pairs); k++) {
        const size_t a = idx(rule_names, RJ, pairs[k][0]), b = idx(rule_names, RJ, pairs[k][1]);
        ck_assert_msg(partner[a] == (int32_t)b && partner[b] == (int32_t)a, "%s: partner %d",
                      pairs[k][0], (int)partner[a]);
        ck_assert_msg(side[a] == 1 && side[b] == -1, "%s: sides %d %d", pairs[k][0], side[a],
                      side[b]);
    }
    for (size_t k = 0; k < MLR_COUNTOF(mid); k++) {
        const size_t a = idx(rule_names, RJ, mid[k]);
        ck_assert_msg(partner[a] == (int32_t)a && side[a] == 0, "%s paired with %d", mid[k],
                      (int)partner[a]);
    }
    /* side and n_pairs are optional */
    int32_t again[RJ];
    ck_assert_int_eq(mlr_mirror_pairs(&r, NULL, 0, 0, again, NULL, NULL, NULL, NULL), MLR_OK);
    ck_assert_mem_eq(again, partner, sizeof partner);
}
END_TEST

START_TEST(explicit_pairs_override_the_names_or_replace_them)
{
    const mlr_rig r = rule_rig();
    int32_t partner[RJ];
    int8_t side[RJ];
    size_t n_pairs;
    mlr_diag d;
    /* LeftUpLeg with lHip: their name partners are left without one (mid-plane) */
    static const char *const given[] = {"LeftUpLeg", "lHip", "Spine", "Lumbar"};
    ck_assert_msg(mlr_mirror_pairs(&r, given, 2, 0, partner, side, &n_pairs, NULL, &d) == MLR_OK,
                  "%s", d.message);
    const size_t lu = idx(rule_names, RJ, "LeftUpLeg"), lh = idx(rule_names, RJ, "lHip");
    const size_t ru = idx(rule_names, RJ, "RightUpLeg"), rh = idx(rule_names, RJ, "rHip");
    const size_t sp = idx(rule_names, RJ, "Spine"), lb = idx(rule_names, RJ, "Lumbar");
    ck_assert_int_eq(partner[lu], (int32_t)lh);
    ck_assert_int_eq(partner[sp], (int32_t)lb);
    ck_assert_int_eq(partner[ru], (int32_t)ru);
    ck_assert_int_eq(partner[rh], (int32_t)rh);
    ck_assert_int_eq(side[lu], 0); /* no rule turns LeftUpLeg into lHip */
    ck_assert_int_eq(side[sp], 0);
    ck_assert_uint_eq(n_pairs, 2 + 11); /* the given two and the 11 other name pairs */
    /* a given pair that a rule also finds tells its side */
    static const char *const swapped[] = {"Hand_R", "Hand_L"};
    ck_assert_int_eq(
        mlr_mirror_pairs(&r, swapped, 1, MLR_MIRROR_GIVEN_ONLY, partner, side, &n_pairs, NULL, &d),
        MLR_OK);
    ck_assert_uint_eq(n_pairs, 1);
    ck_assert_int_eq(side[idx(rule_names, RJ, "Hand_R")], -1);
    ck_assert_int_eq(side[idx(rule_names, RJ, "Hand_L")], 1);
    for (size_t j = 0; j < RJ; j++)
        if (strcmp(rule_names[j], "Hand_R") && strcmp(rule_names[j], "Hand_L"))
            ck_assert_int_eq(partner[j], (int32_t)j);
    /* GIVEN_ONLY with nothing given: every joint on the mid-plane, names not needed */
    mlr_rig anon = r;
    anon.names = NULL;
    ck_assert_int_eq(
        mlr_mirror_pairs(&anon, NULL, 0, MLR_MIRROR_GIVEN_ONLY, partner, side, &n_pairs, NULL, &d),
        MLR_OK);
    ck_assert_uint_eq(n_pairs, 0);
}
END_TEST

/* ---- an asymmetric humanoid ---------------------------------------------------------------- */

enum { HJ = 11, HE = 3, HP = 3 };
static const char *const h_names[HJ] = {"Hips",       "LeftUpLeg", "LeftLeg",   "LeftFoot",
                                        "RightUpLeg", "RightLeg",  "RightFoot", "Spine",
                                        "Arm_L",      "Arm_R",     "Head"};
static const int32_t h_parents[HJ] = {-1, 0, 1, 2, 0, 4, 5, 0, 7, 7, 7};
/* left at +x; the right side is not its mirror image (bones up to 7% longer, tilted) */
static const double h_offsets[3 * HJ] = {0.3,   95.0,  -1.0, 9.0,   -5.0, 0.3, 0.2,  -40.0, 0.5,
                                         0.0,   -40.0, 1.0,  -10.0, -5.1, 0.1, -0.1, -42.8, 0.3,
                                         0.4,   -39.0, 2.0,  0.1,   10.0, 0.0, 15.0, 30.0,  -1.0,
                                         -14.2, 31.0,  0.5,  0.0,   18.0, 2.0};
static const int32_t h_trans[HP] = {2, 5, 7};
static const int32_t h_end_parents[HE] = {3, 10, 6};
static const double h_end_offsets[3 * HE] = {0.0, -5.0, 12.0, 0.0, 14.0, 1.0, 0.5, -4.0, 13.0};

static mlr_rig human(void)
{
    return (mlr_rig){HJ,      h_parents, h_offsets,     h_names,      HP,
                     h_trans, HE,        h_end_parents, h_end_offsets};
}

typedef struct clip {
    size_t n;
    double *root, *rot, *trans;
} clip;

static clip random_clip(size_t n, uint64_t seed)
{
    mlr_test_rng g;
    mlr_test_rng_seed(&g, seed);
    clip c = {n, malloc(3 * n * sizeof(double)), malloc(4 * HJ * n * sizeof(double)),
              malloc(3 * HP * n * sizeof(double))};
    ck_assert_ptr_nonnull(c.root);
    ck_assert_ptr_nonnull(c.rot);
    ck_assert_ptr_nonnull(c.trans);
    for (size_t k = 0; k < 3 * n; k++)
        c.root[k] = 50.0 * mlr_test_rng_normal(&g);
    for (size_t k = 0; k < HJ * n; k++) {
        double q[4], s = 0.0;
        for (int i = 0; i < 4; i++)
            q[i] = mlr_test_rng_normal(&g), s += q[i] * q[i];
        for (int i = 0; i < 4; i++)
            c.rot[4 * k + (size_t)i] = q[i] / sqrt(s);
    }
    for (size_t k = 0; k < 3 * HP * n; k++)
        c.trans[k] = 20.0 * mlr_test_rng_normal(&g);
    return c;
}

static void free_clip(clip *c)
{
    free(c->root);
    free(c->rot);
    free(c->trans);
}

/* 3 x 3 rotation matrix of a unit quaternion (w, x, y, z). */
static void quat_matrix(const double *q, double m[9])
{
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    m[0] = 1 - 2 * (y * y + z * z), m[1] = 2 * (x * y - w * z), m[2] = 2 * (x * z + w * y);
    m[3] = 2 * (x * y + w * z), m[4] = 1 - 2 * (x * x + z * z), m[5] = 2 * (y * z - w * x);
    m[6] = 2 * (x * z - w * y), m[7] = 2 * (y * z + w * x), m[8] = 1 - 2 * (x * x + y * y);
}

START_TEST(reflected_rotations_are_m_r_m)
{
    /* A one-joint rig: the root's rotation is the only rotation; mirror_motion's output
     * quaternion must be the rotation M R M for the reflection M = I - 2 e_a e_a^T. */
    static const int32_t par[1] = {-1};
    static const double off[3] = {0, 0, 0};
    const mlr_rig r = {1, par, off, NULL, 0, NULL, 0, NULL, NULL};
    const int32_t partner[1] = {0};
    mlr_test_rng g;
    mlr_test_rng_seed(&g, 11);
    for (int a = 0; a < 3; a++)
        for (int trial = 0; trial < 50; trial++) {
            double q[4], s = 0.0, p[3], qo[4], po[3];
            for (int i = 0; i < 4; i++)
                q[i] = mlr_test_rng_normal(&g), s += q[i] * q[i];
            for (int i = 0; i < 4; i++)
                q[i] /= sqrt(s);
            for (int i = 0; i < 3; i++)
                p[i] = mlr_test_rng_normal(&g);
            ck_assert_int_eq(mlr_mirror_motion(&r, partner, a, 0, 1, p, q, NULL, po, qo, NULL,
                                               NULL, NULL, NULL),
                             MLR_OK);
            double R[9], Ro[9], MRM[9];
            quat_matrix(q, R);
            quat_matrix(qo, Ro);
            for (int i = 0; i < 3; i++)
                for (int k = 0; k < 3; k++)
                    MRM[3 * i + k] = R[3 * i + k] * (i == a ? -1 : 1) * (k == a ? -1 : 1);
            for (int i = 0; i < 9; i++)
                ck_assert_close(Ro[i], MRM[i], 1e-14);
            for (int i = 0; i < 3; i++)
                ck_assert_double_eq(po[i], i == a ? -p[i] : p[i]);
        }
}
END_TEST

/* Positions (and world rotations) of a clip on a rig, by forward kinematics. */
static void fk(const mlr_rig *r, const double *offsets, size_t n, const double *root,
               const double *rot, const double *trans, double *pos, double *wrot)
{
    mlr_diag d;
    ck_assert_msg(mlr_fk_arrays(n, r->n_joints, r->parents, offsets, root, rot, r->n_trans,
                                r->trans_joints, trans, pos, wrot, NULL, &d) == MLR_OK,
                  "%s", d.message);
}

/* max over frames and joints of |pos_m[j] - M pos[partner[j]]|. */
static double mirror_error(size_t n, size_t J, const double *pos, const double *pos_m,
                           const int32_t *partner, int a)
{
    double worst = 0.0;
    for (size_t f = 0; f < n; f++)
        for (size_t j = 0; j < J; j++)
            for (int c = 0; c < 3; c++) {
                const double ref = pos[3 * (J * f + (size_t)partner[j]) + (size_t)c];
                const double e = fabs(pos_m[3 * (J * f + j) + (size_t)c] - (c == a ? -ref : ref));
                worst = e > worst ? e : worst;
            }
    return worst;
}

START_TEST(the_mirror_is_the_reflected_input_with_the_sides_swapped)
{
    const mlr_rig r = human();
    const size_t N = 40;
    clip c = random_clip(N, 5);
    int32_t partner[HJ];
    size_t n_pairs;
    mlr_diag d;
    ck_assert_msg(mlr_mirror_pairs(&r, NULL, 0, 0, partner, NULL, &n_pairs, NULL, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_uint_eq(n_pairs, 4);
    int a = -2;
    ck_assert_int_eq(mlr_mirror_plane(&r, partner, MLR_MIRROR_PLANE_AUTO, &a, &d), MLR_OK);
    ck_assert_int_eq(a, MLR_AXIS_X);
    double *root = malloc(3 * N * sizeof *root), *rot = malloc(4 * HJ * N * sizeof *rot);
    double *trans = malloc(3 * HP * N * sizeof *trans), off[3 * HJ], ends[3 * HE];
    double *pos = malloc(3 * HJ * N * sizeof *pos), *pos_m = malloc(3 * HJ * N * sizeof *pos);
    double *wr = malloc(4 * HJ * N * sizeof *wr), *wr_m = malloc(4 * HJ * N * sizeof *wr);
    ck_assert_ptr_nonnull(pos_m);
    ck_assert_ptr_nonnull(wr_m);
    for (int axis = 0; axis < 3; axis++) {
        ck_assert_msg(mlr_mirror_motion(&r, partner, axis, 0, N, c.root, c.rot, c.trans, root, rot,
                                        trans, off, ends, &d) == MLR_OK,
                      "%s", d.message);
        fk(&r, h_offsets, N, c.root, c.rot, c.trans, pos, wr);
        fk(&r, off, N, root, rot, trans, pos_m, wr_m);
        ck_assert_double_le(mirror_error(N, HJ, pos, pos_m, partner, axis), 1e-12 * 100.0);
        /* world rotations: W'_j = M W_partner(j) M, as rotation matrices */
        for (size_t k = 0; k < N * HJ; k++) {
            const size_t f = k / HJ, j = k % HJ;
            double R[9], Rm[9];
            quat_matrix(wr + 4 * (HJ * f + (size_t)partner[j]), R);
            quat_matrix(wr_m + 4 * k, Rm);
            for (int i = 0; i < 3; i++)
                for (int m = 0; m < 3; m++)
                    ck_assert_close(Rm[3 * i + m],
                                    R[3 * i + m] * (i == axis ? -1 : 1) * (m == axis ? -1 : 1),
                                    1e-12);
        }
        /* End Sites: LeftFoot's takes RightFoot's, reflected */
        ck_assert_double_eq(ends[0], axis == 0 ? -h_end_offsets[6] : h_end_offsets[6]);
        ck_assert_double_eq(ends[6 + 2], axis == 2 ? -h_end_offsets[2] : h_end_offsets[2]);
        ck_assert_double_eq(ends[3 + 1], axis == 1 ? -h_end_offsets[4] : h_end_offsets[4]);
        /* twice: the input, bit for bit */
        double *root2 = malloc(3 * N * sizeof *root2), *rot2 = malloc(4 * HJ * N * sizeof *rot2);
        double *trans2 = malloc(3 * HP * N * sizeof *trans2), off2[3 * HJ], ends2[3 * HE];
        ck_assert_ptr_nonnull(trans2);
        mlr_rig rm = r;
        rm.offsets = off;
        rm.end_site_offsets = ends;
        ck_assert_int_eq(mlr_mirror_motion(&rm, partner, axis, 0, N, root, rot, trans, root2, rot2,
                                           trans2, off2, ends2, &d),
                         MLR_OK);
        ck_assert_mem_eq(root2, c.root, 3 * N * sizeof *root2);
        ck_assert_mem_eq(rot2, c.rot, 4 * HJ * N * sizeof *rot2);
        ck_assert_mem_eq(trans2, c.trans, 3 * HP * N * sizeof *trans2);
        ck_assert_mem_eq(off2, h_offsets, sizeof off2);
        ck_assert_mem_eq(ends2, h_end_offsets, sizeof ends2);
        /* in place: the same result */
        memcpy(root2, c.root, 3 * N * sizeof *root2);
        memcpy(rot2, c.rot, 4 * HJ * N * sizeof *rot2);
        memcpy(trans2, c.trans, 3 * HP * N * sizeof *trans2);
        memcpy(off2, h_offsets, sizeof off2);
        memcpy(ends2, h_end_offsets, sizeof ends2);
        rm.offsets = off2;
        rm.end_site_offsets = ends2;
        ck_assert_int_eq(mlr_mirror_motion(&rm, partner, axis, 0, N, root2, rot2, trans2, root2,
                                           rot2, trans2, off2, ends2, &d),
                         MLR_OK);
        ck_assert_mem_eq(root2, root, 3 * N * sizeof *root2);
        ck_assert_mem_eq(rot2, rot, 4 * HJ * N * sizeof *rot2);
        ck_assert_mem_eq(trans2, trans, 3 * HP * N * sizeof *trans2);
        ck_assert_mem_eq(off2, off, sizeof off2);
        ck_assert_mem_eq(ends2, ends, sizeof ends2);
        free(root2);
        free(rot2);
        free(trans2);
    }
    free(root);
    free(rot);
    free(trans);
    free(pos);
    free(pos_m);
    free(wr);
    free(wr_m);
    free_clip(&c);
}
END_TEST

START_TEST(keeping_the_skeleton_mirrors_only_the_motion)
{
    const mlr_rig r = human();
    const size_t N = 30;
    clip c = random_clip(N, 9);
    int32_t partner[HJ];
    ck_assert_int_eq(mlr_mirror_pairs(&r, NULL, 0, 0, partner, NULL, NULL, NULL, NULL), MLR_OK);
    double *root = malloc(3 * N * sizeof *root), *rot = malloc(4 * HJ * N * sizeof *rot);
    double *trans = malloc(3 * HP * N * sizeof *trans), off[3 * HJ], ends[3 * HE];
    double *root_e = malloc(3 * N * sizeof *root), *rot_e = malloc(4 * HJ * N * sizeof *rot);
    double *trans_e = malloc(3 * HP * N * sizeof *trans), off_e[3 * HJ], ends_e[3 * HE];
    ck_assert_ptr_nonnull(trans_e);
    ck_assert_int_eq(mlr_mirror_motion(&r, partner, MLR_AXIS_X, MLR_MIRROR_KEEP_SKELETON, N,
                                       c.root, c.rot, c.trans, root, rot, trans, off, ends, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_mirror_motion(&r, partner, MLR_AXIS_X, 0, N, c.root, c.rot, c.trans,
                                       root_e, rot_e, trans_e, off_e, ends_e, NULL),
                     MLR_OK);
    /* the skeleton is the input's, the motion that of the exact mirror */
    ck_assert_mem_eq(off, h_offsets, sizeof off);
    ck_assert_mem_eq(ends, h_end_offsets, sizeof ends);
    ck_assert_mem_eq(root, root_e, 3 * N * sizeof *root);
    ck_assert_mem_eq(rot, rot_e, 4 * HJ * N * sizeof *rot);
    ck_assert_mem_eq(trans, trans_e, 3 * HP * N * sizeof *trans);
    /* a symmetric skeleton is its own mirror image: there keeping it changes nothing */
    double sym[3 * HJ]; /* the left side's bones, reflected for the right side */
    for (size_t j = 0; j < HJ; j++) {
        const size_t p = (size_t)partner[j], left = p < j ? p : j;
        for (int k = 0; k < 3; k++) {
            const double v = h_offsets[3 * left + (size_t)k];
            sym[3 * j + (size_t)k] = (p < j && k == 0) ? -v : v;
        }
        if (p == j)
            sym[3 * j] = 0.0;
    }
    mlr_rig rs = r;
    rs.offsets = sym;
    ck_assert_int_eq(mlr_mirror_motion(&rs, partner, MLR_AXIS_X, 0, 0, NULL, NULL, NULL, NULL,
                                       NULL, NULL, off_e, NULL, NULL),
                     MLR_OK);
    for (size_t k = 0; k < 3 * HJ; k++)
        ck_assert_double_eq(off_e[k], sym[k]); /* (-0.0 for 0.0 on the mid-plane) */
    free(root);
    free(rot);
    free(trans);
    free(root_e);
    free(rot_e);
    free(trans_e);
    free_clip(&c);
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
    const mlr_rig r = rule_rig();
    int32_t partner[RJ];
    mlr_diag d;
    static const char *const unknown[] = {"LeftUpLeg", "Nope"};
    expect(mlr_mirror_pairs(&r, unknown, 1, 0, partner, NULL, NULL, NULL, &d), &d,
           "no joint named 'Nope'");
    static const char *const twice[] = {"Hand_L", "Hand_L"};
    expect(mlr_mirror_pairs(&r, twice, 1, 0, partner, NULL, NULL, NULL, &d), &d,
           "'Hand_L' is paired with itself");
    static const char *const two_pairs[] = {"Hand_L", "Hand_R", "Eye.L", "Hand_L"};
    expect(mlr_mirror_pairs(&r, two_pairs, 2, 0, partner, NULL, NULL, NULL, &d), &d,
           "'Hand_L' is in two pairs");
    static const char *const null_name[] = {"Hand_L", NULL};
    expect(mlr_mirror_pairs(&r, null_name, 1, 0, partner, NULL, NULL, NULL, &d), &d, "NULL name");
    static const char *const rooted_pair[] = {"Root", "Spine"};
    expect(mlr_mirror_pairs(&r, rooted_pair, 1, 0, partner, NULL, NULL, NULL, &d), &d,
           "root Root cannot be paired");
    expect(mlr_mirror_pairs(&r, NULL, 1, 0, partner, NULL, NULL, NULL, &d), &d, "NULL");
    expect(mlr_mirror_pairs(&r, NULL, 0, 4u, partner, NULL, NULL, NULL, &d), &d, "unknown flags");
    expect(mlr_mirror_pairs(&r, NULL, 0, 0, NULL, NULL, NULL, NULL, &d), &d, "partner is NULL");
    expect(mlr_mirror_pairs(NULL, NULL, 0, 0, partner, NULL, NULL, NULL, &d), &d, "rig");
    mlr_rig anon = r;
    anon.names = NULL;
    expect(mlr_mirror_pairs(&anon, NULL, 0, 0, partner, NULL, NULL, NULL, &d), &d,
           "no joint names");

    /* a joint on one side only (a prop in the right hand, as Xsens exports with a Prop1) */
    static const char *const prop_names[] = {"Hips", "LeftHand", "RightHand", "Prop1"};
    static const int32_t prop_parents[] = {-1, 0, 0, 2};
    static const double prop_offsets[12] = {0, 1, 0, 1, 0, 0, -1, 0, 0, -0.2, 0, 0};
    const mlr_rig prop = {4, prop_parents, prop_offsets, prop_names, 0, NULL, 0, NULL, NULL};
    int32_t pp[4];
    expect(mlr_mirror_pairs(&prop, NULL, 0, 0, pp, NULL, NULL, NULL, &d), &d,
           "Prop1 has no partner but hangs under RightHand, which has one (LeftHand)");

    /* the hierarchy, the position channels and the End Sites must map onto themselves */
    const mlr_rig h = human();
    int32_t hp[HJ];
    static const char *const cross[] = {"LeftLeg", "Arm_R"};
    expect(mlr_mirror_pairs(&h, cross, 1, MLR_MIRROR_GIVEN_ONLY, hp, NULL, NULL, NULL, &d), &d,
           "LeftLeg pairs with Arm_R, but their parents LeftUpLeg and Spine are not partners");
    static const int32_t one_trans[2] = {2, 7};
    mlr_rig ht = h;
    ht.n_trans = 2;
    ht.trans_joints = one_trans;
    expect(mlr_mirror_pairs(&ht, NULL, 0, 0, hp, NULL, NULL, NULL, &d), &d,
           "LeftLeg pairs with RightLeg, but only one of them has position channels");
    mlr_rig he = h;
    he.n_end_sites = 2; /* LeftFoot and Head: RightFoot has none */
    expect(mlr_mirror_pairs(&he, NULL, 0, 0, hp, NULL, NULL, NULL, &d), &d,
           "different numbers of End Sites");

    /* the plane */
    int a;
    ck_assert_int_eq(mlr_mirror_pairs(&h, NULL, 0, 0, hp, NULL, NULL, NULL, &d), MLR_OK);
    expect(mlr_mirror_plane(&h, hp, 3, &a, &d), &d, "plane 3 is not -1 (auto), 0 (x), 1 (y)");
    expect(mlr_mirror_plane(&h, hp, -2, &a, &d), &d, "plane -2");
    expect(mlr_mirror_plane(&h, hp, 0, NULL, &d), &d, "axis is NULL");
    expect(mlr_mirror_plane(&h, NULL, MLR_MIRROR_PLANE_AUTO, &a, &d), &d, "partner is NULL");
    ck_assert_int_eq(mlr_mirror_plane(&h, NULL, MLR_AXIS_Z, &a, &d), MLR_OK);
    ck_assert_int_eq(a, MLR_AXIS_Z);
    int32_t none[HJ];
    for (size_t j = 0; j < HJ; j++)
        none[j] = (int32_t)j;
    expect(mlr_mirror_plane(&h, none, MLR_MIRROR_PLANE_AUTO, &a, &d), &d,
           "no left/right joint pairs");
    double flat[3 * HJ] = {0};
    mlr_rig hf = h;
    hf.offsets = flat;
    expect(mlr_mirror_plane(&hf, hp, MLR_MIRROR_PLANE_AUTO, &a, &d), &d,
           "the same rest positions");
    int32_t broken[HJ];
    memcpy(broken, hp, sizeof broken);
    broken[1] = 2;
    expect(mlr_mirror_plane(&h, broken, MLR_MIRROR_PLANE_AUTO, &a, &d), &d, "partner[1] = 2");

    /* the motion */
    clip c = random_clip(3, 1);
    double root[9], rot[4 * HJ * 3], trans[3 * HP * 3];
    expect(mlr_mirror_motion(&h, hp, 3, 0, 3, c.root, c.rot, c.trans, root, rot, trans, NULL, NULL,
                             &d),
           &d, "axis 3");
    expect(mlr_mirror_motion(&h, hp, 0, 1u, 3, c.root, c.rot, c.trans, root, rot, trans, NULL,
                             NULL, &d),
           &d, "unknown flags");
    expect(mlr_mirror_motion(&h, NULL, 0, 0, 3, c.root, c.rot, c.trans, root, rot, trans, NULL,
                             NULL, &d),
           &d, "partner is NULL");
    expect(mlr_mirror_motion(&h, hp, 0, 0, 3, c.root, NULL, c.trans, root, rot, trans, NULL, NULL,
                             &d),
           &d, "NULL with 3 frames");
    expect(
        mlr_mirror_motion(&h, hp, 0, 0, 3, c.root, c.rot, NULL, root, rot, trans, NULL, NULL, &d),
        &d, "trans or out_trans is NULL");
    expect(mlr_mirror_motion(&h, broken, 0, 0, 3, c.root, c.rot, c.trans, root, rot, trans, NULL,
                             NULL, &d),
           &d, "partner[1] = 2");
    int32_t rooted[HJ];
    memcpy(rooted, none, sizeof rooted);
    rooted[0] = 7, rooted[7] = 0;
    expect(mlr_mirror_motion(&h, rooted, 0, 0, 3, c.root, c.rot, c.trans, root, rot, trans, NULL,
                             NULL, &d),
           &d, "the root Hips cannot be paired (with Spine)");
    free_clip(&c);
}
END_TEST

START_TEST(every_allocation_failure_is_no_memory_without_leaks)
{
    const mlr_rig r = rule_rig();
    int32_t ref[RJ], partner[RJ];
    ck_assert_int_eq(mlr_mirror_pairs(&r, NULL, 0, 0, ref, NULL, NULL, NULL, NULL), MLR_OK);
    size_t fails = 0;
    for (size_t at = 0;; at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, at);
        mlr_diag d;
        const mlr_status st = mlr_mirror_pairs(&r, NULL, 0, 0, partner, NULL, NULL, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        ck_assert_uint_eq(ta.live_bytes, 0);
        if (st == MLR_OK) {
            ck_assert_mem_eq(partner, ref, sizeof ref);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_ptr_nonnull(strstr(d.message, "mirror: out of memory"));
        fails++;
    }
    ck_assert_uint_eq(fails, 2u); /* the name index and the candidate buffer */
}
END_TEST

/* ---- the shared clips ---------------------------------------------------------------------- */

START_TEST(every_shared_clip_mirrors_exactly)
{
    static const struct {
        const char *file;
        size_t pairs;
    } clips[] = {
        {"cmu_01_01_playground_jumps.bvh", 12}, {"cmu_131_01_mj_style_walk.bvh", 12},
        {"cmu_10_01_soccer_kick.bvh", 19},      {"cmu_60_10_salsa_dance.bvh", 19},
        {"cmu_02_03_run_jog_25fps.bvh", 71},    {"lafan1_clip_a.bvh", 8},
        {"bandai1_walk_happy_001.bvh", 8},      {"ai4a_dog_D1_008_KAN01_002.bvh", 7},
    };
    for (size_t k = 0; k < MLR_COUNTOF(clips); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(clips[k].file))
            continue;
        ck_assert(mlr_test_clip_load(clips[k].file, &c));
        const size_t N = c.n, J = c.j, P = c.rig.n_trans, E = c.rig.n_end_sites;
        int32_t *partner = malloc(J * sizeof *partner);
        int8_t *side = malloc(J);
        size_t n_pairs;
        mlr_diag d;
        ck_assert_msg(mlr_mirror_pairs(&c.rig, NULL, 0, 0, partner, side, &n_pairs, NULL, &d) ==
                          MLR_OK,
                      "%s: %s", clips[k].file, d.message);
        ck_assert_msg(n_pairs == clips[k].pairs, "%s: %zu pairs", clips[k].file, n_pairs);
        for (size_t j = 0; j < J; j++) /* every pair has a left and a right */
            ck_assert(side[j] == -side[partner[j]] && (side[j] != 0) == (partner[j] != (int)j));
        int a;
        ck_assert_int_eq(mlr_mirror_plane(&c.rig, partner, MLR_MIRROR_PLANE_AUTO, &a, &d), MLR_OK);
        const double *root = mlr_motion_root_pos(c.m), *rot = mlr_motion_rot(c.m);
        const double *trans = mlr_motion_trans(c.m);
        double *root_m = malloc(3 * N * sizeof(double)), *rot_m = malloc(4 * N * J * 8);
        double *trans_m = malloc((3 * N * P + 1) * sizeof(double));
        double *off = malloc(3 * J * sizeof(double)), *ends = malloc((3 * E + 1) * 8);
        double *pos = malloc(3 * N * J * 8), *pos_m = malloc(3 * N * J * 8);
        ck_assert_ptr_nonnull(pos_m);
        ck_assert_int_eq(mlr_mirror_motion(&c.rig, partner, a, 0, N, root, rot, trans, root_m,
                                           rot_m, trans_m, off, ends, &d),
                         MLR_OK);
        fk(&c.rig, c.rig.offsets, N, root, rot, trans, pos, NULL);
        fk(&c.rig, off, N, root_m, rot_m, trans_m, pos_m, NULL);
        double height;
        ck_assert_int_eq(mlr_rig_body_height(N, J, pos, MLR_AXIS_Y, &height, NULL, NULL), MLR_OK);
        const double err = mirror_error(N, J, pos, pos_m, partner, a);
        fprintf(stderr,
                "test_mirror: %s: %zu pairs, plane %c, positions within %.2g body "
                "heights of the reflected swapped input\n",
                clips[k].file, n_pairs, "xyz"[a], err / height);
        ck_assert_msg(err <= 1e-9 * height, "%s: %g", clips[k].file, err / height);
        /* twice: the input bit for bit */
        mlr_rig rm = c.rig;
        rm.offsets = off;
        rm.end_site_offsets = ends;
        ck_assert_int_eq(mlr_mirror_motion(&rm, partner, a, 0, N, root_m, rot_m, trans_m, root_m,
                                           rot_m, trans_m, off, ends, &d),
                         MLR_OK);
        ck_assert(memcmp(root_m, root, 3 * N * sizeof(double)) == 0);
        ck_assert(memcmp(rot_m, rot, 4 * N * J * sizeof(double)) == 0);
        ck_assert(P == 0 || memcmp(trans_m, trans, 3 * N * P * sizeof(double)) == 0);
        ck_assert(memcmp(off, c.rig.offsets, 3 * J * sizeof(double)) == 0);
        ck_assert(E == 0 || memcmp(ends, c.rig.end_site_offsets, 3 * E * sizeof(double)) == 0);
        free(partner);
        free(side);
        free(root_m);
        free(rot_m);
        free(trans_m);
        free(off);
        free(ends);
        free(pos);
        free(pos_m);
        mlr_test_clip_unload(&c);
    }
}
END_TEST

static Suite *mirror_suite(void)
{
    Suite *s = suite_create("mirror");
    TCase *tc = tcase_create("core");
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, every_naming_rule_pairs_its_joints_and_tells_the_side);
    tcase_add_test(tc, explicit_pairs_override_the_names_or_replace_them);
    tcase_add_test(tc, reflected_rotations_are_m_r_m);
    tcase_add_test(tc, the_mirror_is_the_reflected_input_with_the_sides_swapped);
    tcase_add_test(tc, keeping_the_skeleton_mirrors_only_the_motion);
    tcase_add_test(tc, bad_input_says_why);
    tcase_add_test(tc, every_allocation_failure_is_no_memory_without_leaks);
    tcase_add_test(tc, every_shared_clip_mirrors_exactly);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(mirror_suite()); }
