/* Retargeting: the humanoid roles of every shared human rig, a rig onto itself (the input back
 * to rounding), the direction of every matched bone against the source's (forward kinematics
 * of both, the body frames' rotation G applied) for every pair of shared human rigs, the legs'
 * top scaled by the leg lengths, a synthetic rig turned Z-up and put in an A-pose, bad input with
 * nothing written, allocation failures, the feet planted with the upper body kept, the feet on
 * the ground where the source's sink below it. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static const char *const human_clips[] = {
    "cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh", "cmu_10_01_soccer_kick.bvh",
    "cmu_60_10_salsa_dance.bvh",      "cmu_02_03_run_jog_25fps.bvh",  "lafan1_clip_a.bvh",
    "bandai1_walk_happy_001.bvh",
};

/* The frames of a clip with the position channels of every joint but the one carrying the
 * body translation set to their OFFSETs: Bandai's repeat the OFFSETs with float noise (about
 * 1e-7), which a retarget does not carry (the target's keep their OFFSETs). */
static double *clean_trans(const mlr_test_clip *c, size_t N)
{
    const size_t P = c->rig.n_trans;
    if (!P)
        return NULL;
    int32_t body;
    ck_assert_int_eq(mlr_rig_body_translation_joint(&c->rig, c->n, mlr_motion_root_pos(c->m),
                                                    mlr_motion_trans(c->m), &body, NULL),
                     MLR_OK);
    double *t = malloc(N * P * 3 * sizeof(double));
    memcpy(t, mlr_motion_trans(c->m), N * P * 3 * sizeof(double));
    for (size_t f = 0; f < N; f++)
        for (size_t i = 0; i < P; i++)
            if (c->rig.trans_joints[i] != body)
                memcpy(t + 3 * (f * P + i), c->rig.offsets + 3 * (size_t)c->rig.trans_joints[i],
                       3 * sizeof(double));
    return t;
}

static int32_t joint_named(const mlr_test_clip *c, const char *name)
{
    for (size_t j = 0; j < c->j; j++)
        if (strcmp(c->names[j], name) == 0)
            return (int32_t)j;
    return -1;
}

/* ---- roles ---------------------------------------------------------------------------------- */

START_TEST(every_shared_human_rig_has_its_roles)
{
    static const struct {
        const char *file;
        const char *hips, *spine0, *head, *lshoulder, *luparm, *lhand, *rupleg, *rfoot, *rtoes;
        int n_spine, n_neck;
    } want[] = {
        {"cmu_01_01_playground_jumps.bvh", "Hips", "LowerBack", "Head", "LeftShoulder", "LeftArm",
         "LeftHand", "RightUpLeg", "RightFoot", "RightToeBase", 3, 2},
        {"cmu_131_01_mj_style_walk.bvh", "Hips", "lowerback", "Head", "LeftCollar", "LeftShoulder",
         "LeftWrist", "RightHip", "RightAnkle", "RightToe", 3, 2},
        {"cmu_10_01_soccer_kick.bvh", "hip", "abdomen", "head", "lCollar", "lShldr", "lHand",
         "rThigh", "rFoot", NULL, 2, 1},
        {"lafan1_clip_a.bvh", "Hips", "Spine", "Head", "LeftShoulder", "LeftArm", "LeftHand",
         "RightUpLeg", "RightFoot", "RightToe", 3, 1},
        {"bandai1_walk_happy_001.bvh", "Hips", "Spine", "Head", "Shoulder_L", "UpperArm_L",
         "Hand_L", "UpperLeg_R", "Foot_R", "Toes_R", 2, 1},
    };
    for (size_t k = 0; k < MLR_COUNTOF(want); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(want[k].file))
            continue;
        ck_assert(mlr_test_clip_load(want[k].file, &c));
        int32_t role[MLR_ROLE_COUNT];
        mlr_diag d;
        ck_assert_msg(mlr_retarget_roles(&c.rig, role, NULL, &d) == MLR_OK, "%s: %s", want[k].file,
                      d.message);
        const struct {
            int role;
            const char *name;
        } checks[] = {
            {MLR_ROLE_HIPS, want[k].hips},
            {MLR_ROLE_SPINE, want[k].spine0},
            {MLR_ROLE_HEAD, want[k].head},
            {MLR_ROLE_LEFT_SHOULDER, want[k].lshoulder},
            {MLR_ROLE_LEFT_UPPER_ARM, want[k].luparm},
            {MLR_ROLE_LEFT_HAND, want[k].lhand},
            {MLR_ROLE_RIGHT_UPPER_LEG, want[k].rupleg},
            {MLR_ROLE_RIGHT_FOOT, want[k].rfoot},
            {MLR_ROLE_RIGHT_TOES, want[k].rtoes},
        };
        for (size_t i = 0; i < MLR_COUNTOF(checks); i++) {
            const int32_t j = role[checks[i].role];
            if (!checks[i].name)
                ck_assert_msg(j == -1, "%s: %s is %d", want[k].file, mlr_role_name(checks[i].role),
                              j);
            else
                ck_assert_msg(j == joint_named(&c, checks[i].name), "%s: %s is %s, not %s",
                              want[k].file, mlr_role_name(checks[i].role),
                              j >= 0 ? c.names[j] : "none", checks[i].name);
        }
        int n_spine = 0, n_neck = 0;
        for (int i = 0; i < MLR_RETARGET_MAX_SPINE; i++)
            n_spine += role[MLR_ROLE_SPINE + i] >= 0;
        for (int i = 0; i < MLR_RETARGET_MAX_NECK; i++)
            n_neck += role[MLR_ROLE_NECK + i] >= 0;
        ck_assert_msg(n_spine == want[k].n_spine && n_neck == want[k].n_neck,
                      "%s: %d spine, %d neck", want[k].file, n_spine, n_neck);
        /* the legs hang from the hips, the lower leg from the upper, the foot from the lower */
        ck_assert_int_eq(c.rig.parents[role[MLR_ROLE_LEFT_FOOT]], role[MLR_ROLE_LEFT_LOWER_LEG]);
        ck_assert_int_eq(c.rig.parents[role[MLR_ROLE_LEFT_LOWER_LEG]],
                         role[MLR_ROLE_LEFT_UPPER_LEG]);
        mlr_test_clip_unload(&c);
    }
    ck_assert_str_eq(mlr_role_name(MLR_ROLE_LEFT_UPPER_ARM), "LeftUpperArm");
    ck_assert_str_eq(mlr_role_name(MLR_ROLE_SPINE + 2), "Spine2");
    ck_assert_ptr_null(mlr_role_name(MLR_ROLE_COUNT));
    ck_assert_ptr_null(mlr_role_name(-1));
}
END_TEST

/* ---- a rig onto itself ------------------------------------------------------------------------ */

START_TEST(a_rig_onto_itself_gives_the_input_back)
{
    for (size_t k = 0; k < MLR_COUNTOF(human_clips); k++) {
        mlr_test_clip c;
        if (!MLR_TEST_HAVE_CLIP(human_clips[k]))
            continue;
        ck_assert(mlr_test_clip_load(human_clips[k], &c));
        const size_t N = c.n < 400 ? c.n : 400, J = c.j, P = c.rig.n_trans;
        const double *rp = mlr_motion_root_pos(c.m), *rot = mlr_motion_rot(c.m);
        double *tr = clean_trans(&c, N);
        double *orp = malloc(N * 3 * sizeof(double)), *orot = malloc(N * J * 4 * sizeof(double));
        double *otr = P ? malloc(N * P * 3 * sizeof(double)) : NULL;
        mlr_retarget_info info;
        mlr_diag d;
        ck_assert_msg(mlr_retarget(&c.rig, N, rp, rot, tr, &c.rig, MLR_RETARGET_UP_REST,
                                   MLR_RETARGET_UP_REST, NULL, 0, orp, orot, otr, &info, NULL,
                                   &d) == MLR_OK,
                      "%s: %s", human_clips[k], d.message);
        ck_assert_double_eq_tol(info.scale, 1.0, 1e-15);
        ck_assert_uint_eq(info.n_matched, J);
        double worst = 0.0;
        for (size_t i = 0; i < N * J * 4; i++)
            worst = fmax(worst, fabs(orot[i] - rot[i]));
        ck_assert_msg(worst < 1e-9, "%s: rotations differ by %g", human_clips[k], worst);
        for (size_t i = 0; i < N * 3; i++)
            ck_assert_msg(fabs(orp[i] - rp[i]) < 1e-9 * (1.0 + fabs(rp[i])), "%s: root_pos",
                          human_clips[k]);
        for (size_t i = 0; i < N * P * 3; i++)
            ck_assert_msg(fabs(otr[i] - tr[i]) < 1e-9 * (1.0 + fabs(tr[i])), "%s: trans",
                          human_clips[k]);
        free(orp), free(orot), free(otr), free(tr);
        mlr_test_clip_unload(&c);
    }
}
END_TEST

/* ---- bone directions ------------------------------------------------------------------------ */

/* The roles whose bones are checked (their joint and the joint the bone ends at); chains and
 * the hands, head and toes (whose ends differ between rigs) are not. */
static const int bone_roles[][2] = {
    {MLR_ROLE_LEFT_UPPER_LEG, MLR_ROLE_LEFT_LOWER_LEG},
    {MLR_ROLE_LEFT_LOWER_LEG, MLR_ROLE_LEFT_FOOT},
    {MLR_ROLE_RIGHT_UPPER_LEG, MLR_ROLE_RIGHT_LOWER_LEG},
    {MLR_ROLE_RIGHT_LOWER_LEG, MLR_ROLE_RIGHT_FOOT},
    {MLR_ROLE_LEFT_UPPER_ARM, MLR_ROLE_LEFT_LOWER_ARM},
    {MLR_ROLE_LEFT_LOWER_ARM, MLR_ROLE_LEFT_HAND},
    {MLR_ROLE_RIGHT_UPPER_ARM, MLR_ROLE_RIGHT_LOWER_ARM},
    {MLR_ROLE_RIGHT_LOWER_ARM, MLR_ROLE_RIGHT_HAND},
    {MLR_ROLE_LEFT_SHOULDER, MLR_ROLE_LEFT_UPPER_ARM},
    {MLR_ROLE_RIGHT_SHOULDER, MLR_ROLE_RIGHT_UPPER_ARM},
};

static void unit_dir(const double *a, const double *b, double *out)
{
    double n = 0.0;
    for (int c = 0; c < 3; c++)
        out[c] = b[c] - a[c], n += out[c] * out[c];
    n = sqrt(n);
    for (int c = 0; c < 3; c++)
        out[c] /= n;
}

START_TEST(every_matched_bone_points_as_the_source_s)
{
    for (size_t a = 0; a < MLR_COUNTOF(human_clips); a++)
        for (size_t b = 0; b < MLR_COUNTOF(human_clips); b++) {
            mlr_test_clip s, t;
            if (a == b || !MLR_TEST_HAVE_CLIP(human_clips[a]) ||
                !MLR_TEST_HAVE_CLIP(human_clips[b]))
                continue;
            ck_assert(mlr_test_clip_load(human_clips[a], &s));
            ck_assert(mlr_test_clip_load(human_clips[b], &t));
            const size_t N = s.n < 60 ? s.n : 60, Js = s.j, Jt = t.j, Pt = t.rig.n_trans;
            double *orp = malloc(N * 3 * sizeof(double));
            double *orot = malloc(N * Jt * 4 * sizeof(double));
            double *otr = Pt ? malloc(N * Pt * 3 * sizeof(double)) : NULL;
            mlr_retarget_info info;
            mlr_diag d;
            double *st = clean_trans(&s, N);
            ck_assert_msg(mlr_retarget(&s.rig, N, mlr_motion_root_pos(s.m), mlr_motion_rot(s.m),
                                       st, &t.rig, MLR_RETARGET_UP_REST, MLR_RETARGET_UP_REST,
                                       NULL, 0, orp, orot, otr, &info, NULL, &d) == MLR_OK,
                          "%s -> %s: %s", human_clips[a], human_clips[b], d.message);
            int32_t rs[MLR_ROLE_COUNT], rt[MLR_ROLE_COUNT];
            ck_assert_int_eq(mlr_retarget_roles(&s.rig, rs, NULL, NULL), MLR_OK);
            ck_assert_int_eq(mlr_retarget_roles(&t.rig, rt, NULL, NULL), MLR_OK);
            double *ps = malloc(N * Js * 3 * sizeof(double)),
                   *pt = malloc(N * Jt * 3 * sizeof(double));
            ck_assert_int_eq(mlr_fk_arrays(N, Js, s.rig.parents, s.rig.offsets,
                                           mlr_motion_root_pos(s.m), mlr_motion_rot(s.m),
                                           s.rig.n_trans, s.rig.trans_joints, st, ps, NULL, NULL,
                                           NULL),
                             MLR_OK);
            ck_assert_int_eq(mlr_fk_arrays(N, Jt, t.rig.parents, t.rig.offsets, orp, orot, Pt,
                                           t.rig.trans_joints, otr, pt, NULL, NULL, NULL),
                             MLR_OK);
            const double *G = info.to_source;
            double worst = 0.0;
            for (size_t f = 0; f < N; f++)
                for (size_t i = 0; i < MLR_COUNTOF(bone_roles); i++) {
                    const int r0 = bone_roles[i][0], r1 = bone_roles[i][1];
                    if (rs[r0] < 0 || rt[r0] < 0)
                        continue;
                    double ds[3], dt[3], gdt[3];
                    unit_dir(ps + 3 * (f * Js + (size_t)rs[r0]),
                             ps + 3 * (f * Js + (size_t)rs[r1]), ds);
                    unit_dir(pt + 3 * (f * Jt + (size_t)rt[r0]),
                             pt + 3 * (f * Jt + (size_t)rt[r1]), dt);
                    for (int r = 0; r < 3; r++) /* target world to source world */
                        gdt[r] = G[3 * r] * dt[0] + G[3 * r + 1] * dt[1] + G[3 * r + 2] * dt[2];
                    for (int c = 0; c < 3; c++)
                        worst = fmax(worst, fabs(gdt[c] - ds[c]));
                }
            ck_assert_msg(worst < 1e-9, "%s -> %s: bones differ by %g", human_clips[a],
                          human_clips[b], worst);
            /* the middle of the upper legs where the scaled source's is, up to one lift along
             * up for the soles (the same in every frame, a few % of a leg at most) */
            double lift0[3] = {0, 0, 0}, leg = 0.0;
            for (size_t f = 0; f < N; f++) {
                double x[3], m[3], lift[3];
                for (int c = 0; c < 3; c++) {
                    x[c] = 0.5 *
                           (pt[3 * (f * Jt + (size_t)rt[MLR_ROLE_LEFT_UPPER_LEG]) + (size_t)c] +
                            pt[3 * (f * Jt + (size_t)rt[MLR_ROLE_RIGHT_UPPER_LEG]) + (size_t)c]);
                    m[c] = 0.5 *
                           (ps[3 * (f * Js + (size_t)rs[MLR_ROLE_LEFT_UPPER_LEG]) + (size_t)c] +
                            ps[3 * (f * Js + (size_t)rs[MLR_ROLE_RIGHT_UPPER_LEG]) + (size_t)c]);
                }
                for (int r = 0; r < 3; r++)
                    lift[r] = G[3 * r] * x[0] + G[3 * r + 1] * x[1] + G[3 * r + 2] * x[2] -
                              info.scale * m[r];
                if (f == 0) {
                    memcpy(lift0, lift, sizeof lift);
                    const double *k = pt + 3 * (size_t)rt[MLR_ROLE_LEFT_UPPER_LEG];
                    const double *n = pt + 3 * (size_t)rt[MLR_ROLE_LEFT_LOWER_LEG];
                    leg = sqrt((k[0] - n[0]) * (k[0] - n[0]) + (k[1] - n[1]) * (k[1] - n[1]) +
                               (k[2] - n[2]) * (k[2] - n[2]));
                }
                for (int r = 0; r < 3; r++)
                    ck_assert_msg(fabs(lift[r] - lift0[r]) < 1e-9 * (1.0 + fabs(m[r])),
                                  "%s -> %s: legs", human_clips[a], human_clips[b]);
            }
            ck_assert_msg(sqrt(lift0[0] * lift0[0] + lift0[1] * lift0[1] + lift0[2] * lift0[2]) <
                              0.2 * leg,
                          "%s -> %s: lift %g %g %g", human_clips[a], human_clips[b], lift0[0],
                          lift0[1], lift0[2]);
            free(ps), free(pt), free(orp), free(orot), free(otr), free(st);
            mlr_test_clip_unload(&s);
            mlr_test_clip_unload(&t);
        }
}
END_TEST

/* ---- a synthetic pair: Y-up T-pose, and the same body Z-up in an A-pose, other names ------- */

/* Two legs need a right one: the rig of 15 joints with it. */
enum { TJ = 15 };
static const char *const y_names[TJ] = {"Hips",        "Spine",     "Head",     "LeftArm",
                                        "LeftForeArm", "LeftHand",  "RightArm", "RightForeArm",
                                        "RightHand",   "LeftUpLeg", "LeftLeg",  "LeftFoot",
                                        "RightUpLeg",  "RightLeg",  "RightFoot"};
static const char *const z_names[TJ] = {"pelvis",     "spine_01", "head",       "upperarm_l",
                                        "lowerarm_l", "hand_l",   "upperarm_r", "lowerarm_r",
                                        "hand_r",     "thigh_l",  "calf_l",     "foot_l",
                                        "thigh_r",    "calf_r",   "foot_r"};
static const int32_t y_parents[TJ] = {-1, 0, 1, 1, 3, 4, 1, 6, 7, 0, 9, 10, 0, 12, 13};
/* Y-up, facing +z, left = +x, T-pose */
static const double y_offsets[3 * TJ] = {
    0, 0,   0, 0, 10, 0,  0, 10, 0,   5, 8, 0,   10, 0,  0,  10, 0, 0,   -5, 8, 0,   -10, 0,
    0, -10, 0, 0, 3,  -2, 0, 0,  -15, 0, 0, -15, 0,  -3, -2, 0,  0, -15, 0,  0, -15, 0};

/* The z rig: the y rig's geometry scaled by 1.2, turned Z-up (y -> z, z -> -y) and with the
 * arms lowered 40 degrees (an A-pose). */
static void z_offsets(double *o)
{
    const double c = cos(40.0 * M_PI / 180.0), s = sin(40.0 * M_PI / 180.0);
    for (size_t j = 0; j < TJ; j++) {
        double x = y_offsets[3 * j], y = y_offsets[3 * j + 1], z = y_offsets[3 * j + 2];
        if (j == 4 || j == 5 || j == 7 || j == 8) { /* forearm and hand bones: lowered */
            const double nx = c * x, ny = -s * fabs(x);
            x = nx, y = ny;
        }
        o[3 * j] = 1.2 * x, o[3 * j + 1] = -1.2 * z, o[3 * j + 2] = 1.2 * y;
    }
}

static void random_pose(mlr_test_rng *g, size_t N, size_t J, double *rp, double *rot)
{
    for (size_t f = 0; f < N; f++) {
        rp[3 * f] = mlr_test_rng_normal(g), rp[3 * f + 1] = 30 + mlr_test_rng_normal(g),
               rp[3 * f + 2] = mlr_test_rng_normal(g);
        for (size_t j = 0; j < J; j++) {
            double q[4], n = 0.0;
            for (int c = 0; c < 4; c++)
                q[c] = (c == 0 ? 3.0 : 0.0) + mlr_test_rng_normal(g), n += q[c] * q[c];
            for (int c = 0; c < 4; c++)
                rot[4 * (f * J + j) + (size_t)c] = q[c] / sqrt(n);
        }
    }
}

START_TEST(a_z_up_a_pose_rig_takes_the_bone_directions)
{
    double zo[3 * TJ];
    z_offsets(zo);
    const mlr_rig ry = {TJ, y_parents, y_offsets, y_names, 0, NULL, 0, NULL, NULL};
    const mlr_rig rz = {TJ, y_parents, zo, z_names, 0, NULL, 0, NULL, NULL};
    enum { N = 20 };
    double rp[3 * N], rot[4 * N * TJ], orp[3 * N], orot[4 * N * TJ], back_rp[3 * N],
        back[4 * N * TJ];
    mlr_test_rng g;
    mlr_test_rng_seed(&g, 44);
    random_pose(&g, N, TJ, rp, rot);
    mlr_retarget_info info;
    mlr_diag d;
    ck_assert_msg(mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST,
                               MLR_RETARGET_UP_REST, NULL, 0, orp, orot, NULL, &info, NULL,
                               &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_double_eq_tol(info.scale, 1.2, 1e-12);
    ck_assert_uint_eq(info.n_matched, TJ);
    /* G turns Z-up into Y-up: the target's +z is the source's +y */
    ck_assert_double_eq_tol(info.to_source[3 * 1 + 2], 1.0, 1e-12);
    /* the positions of the z rig are the y rig's turned and scaled: every bone here has a
     * role and both rigs are the same body, so the whole pose must agree */
    double py[3 * N * TJ], pz[3 * N * TJ];
    ck_assert_int_eq(
        mlr_fk_arrays(N, TJ, y_parents, y_offsets, rp, rot, 0, NULL, NULL, py, NULL, NULL, NULL),
        MLR_OK);
    ck_assert_int_eq(
        mlr_fk_arrays(N, TJ, y_parents, zo, orp, orot, 0, NULL, NULL, pz, NULL, NULL, NULL),
        MLR_OK);
    for (size_t i = 0; i < N * TJ; i++) {
        const double *a = py + 3 * i, *b = pz + 3 * i;
        /* z rig (x, y, z) is y rig (x, -z, y) * 1.2 */
        ck_assert_msg(fabs(b[0] - 1.2 * a[0]) < 1e-9 && fabs(b[1] + 1.2 * a[2]) < 1e-9 &&
                          fabs(b[2] - 1.2 * a[1]) < 1e-9,
                      "joint %zu: (%g %g %g) vs (%g %g %g)", i % TJ, b[0], b[1], b[2], a[0], a[1],
                      a[2]);
    }
    /* and back: the input again */
    ck_assert_int_eq(mlr_retarget(&rz, N, orp, orot, NULL, &ry, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, NULL, 0, back_rp, back, NULL, NULL, NULL,
                                  NULL),
                     MLR_OK);
    for (size_t i = 0; i < 3 * N; i++)
        ck_assert_double_eq_tol(back_rp[i], rp[i], 1e-9);
    for (size_t f = 0; f < N * TJ; f++) {
        double dot = 0.0;
        for (int c = 0; c < 4; c++)
            dot += back[4 * f + (size_t)c] * rot[4 * f + (size_t)c];
        ck_assert_double_eq_tol(fabs(dot), 1.0, 1e-9);
    }
}
END_TEST

/* ---- bad input ---------------------------------------------------------------------------- */

START_TEST(bad_input_names_the_joint_and_writes_nothing)
{
    double zo[3 * TJ];
    z_offsets(zo);
    const mlr_rig ry = {TJ, y_parents, y_offsets, y_names, 0, NULL, 0, NULL, NULL};
    const mlr_rig rz = {TJ, y_parents, zo, z_names, 0, NULL, 0, NULL, NULL};
    /* a chain of joints without humanoid names */
    static const char *const chain_names[4] = {"base", "link1", "link2", "tip"};
    static const int32_t chain_parents[4] = {-1, 0, 1, 2};
    static const double chain_offsets[12] = {0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
    const mlr_rig rc = {4, chain_parents, chain_offsets, chain_names, 0, NULL, 0, NULL, NULL};
    enum { N = 3 };
    double rp[3 * N] = {0}, rot[4 * N * TJ], orp[3 * N], orot[4 * N * TJ];
    for (size_t i = 0; i < N * TJ; i++)
        rot[4 * i] = 1, rot[4 * i + 1] = rot[4 * i + 2] = rot[4 * i + 3] = 0;
    for (size_t i = 0; i < 3 * N; i++)
        orp[i] = 7.0;
    mlr_diag d;
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rc, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, NULL, 0, orp, orot, NULL, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "target: no humanoid LeftFoot"));
    ck_assert_double_eq(orp[0], 7.0); /* nothing written */
    int32_t role[MLR_ROLE_COUNT];
    ck_assert_int_eq(mlr_retarget_roles(&rc, role, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "LeftFoot"));

    const char *unknown_t[2] = {"LeftFoot", "no_such_foot"};
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, unknown_t, 1, orp, orot, NULL, NULL, NULL,
                                  &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "the target has no joint 'no_such_foot'"));
    const char *unknown_s[2] = {"Lefty", "foot_l"};
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, unknown_s, 1, orp, orot, NULL, NULL, NULL,
                                  &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "the source has no joint 'Lefty'"));
    const char *twice[4] = {"LeftFoot", "foot_l", "RightFoot", "foot_l"};
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, twice, 2, orp, orot, NULL, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "'foot_l' is named twice"));
    ck_assert_double_eq(orp[0], 7.0);

    /* a map rescues a target whose feet are not named so: the chain rig's joints can take
     * roles only by the map; here the z rig with its feet renamed */
    static const char *const odd_names[TJ] = {"pelvis",     "spine_01", "head",       "upperarm_l",
                                              "lowerarm_l", "hand_l",   "upperarm_r", "lowerarm_r",
                                              "hand_r",     "thigh_l",  "calf_l",     "paw_a",
                                              "thigh_r",    "calf_r",   "paw_b"};
    const mlr_rig ro = {TJ, y_parents, zo, odd_names, 0, NULL, 0, NULL, NULL};
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &ro, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, NULL, 0, orp, orot, NULL, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "target: no humanoid"));
    const char *paws[4] = {"LeftFoot", "paw_a", "RightFoot", "paw_b"};
    ck_assert_msg(mlr_retarget(&ry, N, rp, rot, NULL, &ro, MLR_RETARGET_UP_REST,
                               MLR_RETARGET_UP_REST, paws, 2, orp, orot, NULL, NULL, NULL,
                               &d) == MLR_OK,
                  "%s", d.message);

    /* non-finite input */
    rot[5] = NAN;
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, NULL, 0, orp, orot, NULL, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "rot: a value of frame 0 is not finite"));
}
END_TEST

/* ---- what is not a humanoid, and humanoids the names alone do not tell -------------------- */

/* A quadruped with a humanoid's names (the AI4Animation dog is so named): Y-up, the spine along
 * +z, the front legs ("arms") hanging from the chest as long as the hind legs from the hips. */
START_TEST(a_quadruped_is_refused_naming_its_limbs)
{
    /* y_names' tree: Hips, Spine (the chest), Head, the arms from the Spine, the legs from the
     * Hips */
    static const double dog[3 * TJ] = {0, 0,  0, 0,  0,  14, 0,  3,  5, 2, 0,  0, 0, -6, 0,
                                       0, -6, 0, -2, 0,  0,  0,  -6, 0, 0, -6, 0, 2, 0,  0,
                                       0, -6, 0, 0,  -6, 0,  -2, 0,  0, 0, -6, 0, 0, -6, 0};
    const mlr_rig rd = {TJ, y_parents, dog, y_names, 0, NULL, 0, NULL, NULL};
    int32_t role[MLR_ROLE_COUNT];
    mlr_diag d;
    ck_assert_int_eq(mlr_retarget_roles(&rd, role, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_msg(strstr(d.message,
                         "rig: not a humanoid: arms (LeftArm, RightArm) 1.00 and torso "
                         "(Hips-arms) 1.17 of the legs: a quadruped's (humanoid: arms < ") != NULL,
                  "%s", d.message);
    /* and so as a target: nothing written */
    const mlr_rig ry = {TJ, y_parents, y_offsets, y_names, 0, NULL, 0, NULL, NULL};
    enum { N = 2 };
    double rp[3 * N] = {0}, rot[4 * N * TJ], orp[3 * N], orot[4 * N * TJ];
    for (size_t i = 0; i < N * TJ; i++)
        rot[4 * i] = 1, rot[4 * i + 1] = rot[4 * i + 2] = rot[4 * i + 3] = 0;
    orp[0] = 7.0;
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rd, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, NULL, 0, orp, orot, NULL, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "retarget: target: not a humanoid"));
    ck_assert_double_eq(orp[0], 7.0);
    /* the same tree as a humanoid (the y rig) passes; without arms it is refused by name */
    ck_assert_int_eq(mlr_retarget_roles(&ry, role, NULL, &d), MLR_OK);
    static const char *const no_hands[TJ] = {
        "Hips",    "Spine",    "Head",         "LeftArm",  "LeftForeArm",
        "LeftPaw", "RightArm", "RightForeArm", "RightPaw", "LeftUpLeg",
        "LeftLeg", "LeftFoot", "RightUpLeg",   "RightLeg", "RightFoot"};
    const mlr_rig rn = {TJ, y_parents, y_offsets, no_hands, 0, NULL, 0, NULL, NULL};
    ck_assert_int_eq(mlr_retarget_roles(&rn, role, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_msg(strstr(d.message, "rig: no humanoid LeftHand") != NULL, "%s", d.message);
}
END_TEST

/* MakeHuman's tree: the root carries the spine and a pelvis joint named Hips that carries the
 * legs; and a head that is not named so (video2bvh's Neck1) */
START_TEST(the_hips_carry_the_upper_body_and_the_head_ends_the_neck)
{
    enum { MK = 18 };
    static const char *const mk_names[MK] = {"Root",    "Spine1",  "Spine2",  "Neck",    "Neck1",
                                             "UpArm_L", "LoArm_L", "Hand_L",  "UpArm_R", "LoArm_R",
                                             "Hand_R",  "Hips",    "UpLeg_L", "LoLeg_L", "Foot_L",
                                             "UpLeg_R", "LoLeg_R", "Foot_R"};
    static const int32_t mk_parents[MK] = {-1, 0, 1, 2,  3,  2,  5,  6,  2,
                                           8,  9, 0, 11, 12, 13, 11, 15, 16};
    static const double mk_off[3 * MK] = {0, 0,   0,  0,  8,  0, 0,  8,   0, 0,  3,   0, 0,   4,
                                          0, 4,   0,  0,  8,  0, 0,  8,   0, 0,  -4,  0, 0,   -8,
                                          0, 0,   -8, 0,  0,  0, -1, 0,   2, -2, 0,   0, -15, 0,
                                          0, -15, 0,  -2, -2, 0, 0,  -15, 0, 0,  -15, 0};
    const mlr_rig rm = {MK, mk_parents, mk_off, mk_names, 0, NULL, 0, NULL, NULL};
    int32_t role[MLR_ROLE_COUNT];
    mlr_diag d;
    ck_assert_msg(mlr_retarget_roles(&rm, role, NULL, &d) == MLR_OK, "%s", d.message);
    ck_assert_int_eq(role[MLR_ROLE_HIPS], 0);                      /* Root, not the pelvis */
    ck_assert_int_eq(role[MLR_ROLE_HEAD], 4);                      /* Neck1: the chain's end */
    ck_assert_int_eq(role[MLR_ROLE_NECK], 3);
    ck_assert_int_eq(role[MLR_ROLE_SPINE], 1);
    ck_assert_int_eq(role[MLR_ROLE_SPINE + 1], 2);
    ck_assert_int_eq(role[MLR_ROLE_LEFT_UPPER_LEG], 12);
}
END_TEST

START_TEST(every_allocation_failure_is_no_memory_without_leaks)
{
    double zo[3 * TJ];
    z_offsets(zo);
    const mlr_rig ry = {TJ, y_parents, y_offsets, y_names, 0, NULL, 0, NULL, NULL};
    const mlr_rig rz = {TJ, y_parents, zo, z_names, 0, NULL, 0, NULL, NULL};
    enum { N = 4 };
    double rp[3 * N], rot[4 * N * TJ], orp[3 * N], orot[4 * N * TJ], ref[4 * N * TJ];
    mlr_test_rng g;
    mlr_test_rng_seed(&g, 7);
    random_pose(&g, N, TJ, rp, rot);
    ck_assert_int_eq(mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST,
                                  MLR_RETARGET_UP_REST, NULL, 0, orp, ref, NULL, NULL, NULL, NULL),
                     MLR_OK);
    size_t fails = 0;
    for (size_t at = 0;; at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, at);
        mlr_diag d;
        const mlr_status st =
            mlr_retarget(&ry, N, rp, rot, NULL, &rz, MLR_RETARGET_UP_REST, MLR_RETARGET_UP_REST,
                         NULL, 0, orp, orot, NULL, NULL, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (st == MLR_OK) {
            ck_assert_mem_eq(orot, ref, sizeof ref);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        fails++;
    }
    ck_assert_uint_ge(fails, 3u);
}
END_TEST

/* ---- the feet ------------------------------------------------------------------------------ */

START_TEST(the_feet_are_planted_and_the_upper_body_kept)
{
    mlr_test_clip s, t;
    if (!MLR_TEST_HAVE_CLIP("cmu_131_01_mj_style_walk.bvh") ||
        !MLR_TEST_HAVE_CLIP("bandai1_walk_happy_001.bvh"))
        return;
    ck_assert(mlr_test_clip_load("cmu_131_01_mj_style_walk.bvh", &s));
    ck_assert(mlr_test_clip_load("bandai1_walk_happy_001.bvh", &t));
    const size_t N = 240, Jt = t.j, Pt = t.rig.n_trans;
    double *rp = malloc(N * 3 * sizeof(double)), *rot = malloc(N * Jt * 4 * sizeof(double));
    double *tr = malloc(N * Pt * 3 * sizeof(double));
    ck_assert_int_eq(mlr_retarget(&s.rig, N, mlr_motion_root_pos(s.m), mlr_motion_rot(s.m), NULL,
                                  &t.rig, MLR_AXIS_Y, MLR_AXIS_Y, NULL, 0, rp, rot, tr, NULL, NULL,
                                  NULL),
                     MLR_OK);
    double *rot0 = malloc(N * Jt * 4 * sizeof(double));
    memcpy(rot0, rot, N * Jt * 4 * sizeof(double));
    mlr_cleanup_report rep;
    mlr_diag d;
    ck_assert_msg(mlr_retarget_feet(&s.rig, N, s.fps, MLR_AXIS_Y, mlr_motion_root_pos(s.m),
                                    mlr_motion_rot(s.m), NULL, &t.rig, MLR_AXIS_Y, NULL, 0, rp,
                                    rot, tr, &rep, NULL, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_uint_gt(rep.contact_frames, N / 4);
    /* Bandai's bind pose lies along x; with its world up given (y) the character stands: the
     * head above the hips along y in every frame */
    {
        double *pos = malloc(N * Jt * 3 * sizeof(double));
        ck_assert_int_eq(mlr_fk_arrays(N, Jt, t.rig.parents, t.rig.offsets, rp, rot, Pt,
                                       t.rig.trans_joints, tr, pos, NULL, NULL, NULL),
                         MLR_OK);
        int32_t rr[MLR_ROLE_COUNT];
        ck_assert_int_eq(mlr_retarget_roles(&t.rig, rr, NULL, NULL), MLR_OK);
        for (size_t f = 0; f < N; f++) {
            const double *h = pos + 3 * (f * Jt + (size_t)rr[MLR_ROLE_HIPS]);
            const double *e = pos + 3 * (f * Jt + (size_t)rr[MLR_ROLE_HEAD]);
            const double d[3] = {e[0] - h[0], e[1] - h[1], e[2] - h[2]};
            ck_assert(d[1] > 0.8 * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
        }
        free(pos);
    }
    ck_assert(isfinite(rep.floor_height));
    /* the arms and the head keep their local rotations; the legs changed */
    int32_t role[MLR_ROLE_COUNT];
    ck_assert_int_eq(mlr_retarget_roles(&t.rig, role, NULL, NULL), MLR_OK);
    const int kept[] = {MLR_ROLE_LEFT_UPPER_ARM, MLR_ROLE_RIGHT_LOWER_ARM, MLR_ROLE_HEAD};
    for (size_t f = 0; f < N; f++)
        for (size_t i = 0; i < MLR_COUNTOF(kept); i++)
            for (int c = 0; c < 4; c++) {
                const size_t k = 4 * (f * Jt + (size_t)role[kept[i]]) + (size_t)c;
                ck_assert_double_eq(rot[k], rot0[k]);
            }
    double moved = 0.0;
    for (size_t f = 0; f < N; f++)
        for (int c = 0; c < 4; c++) {
            const size_t k = 4 * (f * Jt + (size_t)role[MLR_ROLE_LEFT_LOWER_LEG]) + (size_t)c;
            moved = fmax(moved, fabs(rot[k] - rot0[k]));
        }
    ck_assert(moved > 1e-4);
    ck_assert_int_eq(mlr_retarget_feet(&s.rig, N, s.fps, 3, mlr_motion_root_pos(s.m),
                                       mlr_motion_rot(s.m), NULL, &t.rig, MLR_RETARGET_UP_REST,
                                       NULL, 0, rp, rot, tr, NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "up 3 is not an axis"));
    free(rp), free(rot), free(rot0), free(tr);
    mlr_test_clip_unload(&s);
    mlr_test_clip_unload(&t);
}
END_TEST

/* The lowest foot point of each frame along y: the ankles, the toes and their End Sites. */
static void lowest_feet(const mlr_rig *rig, size_t N, const double *pos, const double *wrot,
                        double *out)
{
    const size_t J = rig->n_joints;
    int32_t role[MLR_ROLE_COUNT];
    ck_assert_int_eq(mlr_retarget_roles(rig, role, NULL, NULL), MLR_OK);
    const int32_t pts[4] = {role[MLR_ROLE_LEFT_FOOT], role[MLR_ROLE_RIGHT_FOOT],
                            role[MLR_ROLE_LEFT_TOES], role[MLR_ROLE_RIGHT_TOES]};
    for (size_t f = 0; f < N; f++) {
        double lo = INFINITY;
        for (int i = 0; i < 4; i++) {
            if (pts[i] < 0)
                continue;
            const size_t j = (size_t)pts[i];
            lo = fmin(lo, pos[3 * (f * J + j) + 1]);
            for (size_t e = 0; e < rig->n_end_sites; e++) {
                if (rig->end_site_parents[e] != pts[i])
                    continue;
                const double *q = wrot + 4 * (f * J + j), *v = rig->end_site_offsets + 3 * e;
                /* y of q v q*: the second row of q's matrix */
                const double w = q[0], x = q[1], y = q[2], z = q[3];
                const double vy = 2 * (x * y + w * z) * v[0] + (1 - 2 * (x * x + z * z)) * v[1] +
                                  2 * (y * z - w * x) * v[2];
                lo = fmin(lo, pos[3 * (f * J + j) + 1] + vy);
            }
        }
        out[f] = lo;
    }
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

START_TEST(the_feet_stay_on_the_ground_where_the_source_s_sink)
{
    /* LaFAN1's walk with its root lowered by 3% of its height over 0.4 s: its feet go under
     * its floor there. The target's (CMU 131_01's rig) went as deep (no deeper than the
     * source did); now no foot point of it is below its ground elsewhere (the 5th percentile
     * of its lowest foot point over the other frames) by more than 0.1% of its height */
    mlr_test_clip s, t;
    if (!MLR_TEST_HAVE_CLIP("lafan1_clip_a.bvh") ||
        !MLR_TEST_HAVE_CLIP("cmu_131_01_mj_style_walk.bvh"))
        return;
    ck_assert(mlr_test_clip_load("lafan1_clip_a.bvh", &s));
    ck_assert(mlr_test_clip_load("cmu_131_01_mj_style_walk.bvh", &t));
    const size_t N = 300, Js = s.j, Jt = t.j;
    ck_assert_uint_ge(s.n, N);
    double *srp = malloc(N * 3 * sizeof(double));
    memcpy(srp, mlr_motion_root_pos(s.m), N * 3 * sizeof(double));
    double *spos = malloc(N * Js * 3 * sizeof(double));
    ck_assert_int_eq(mlr_fk_arrays(N, Js, s.rig.parents, s.rig.offsets, srp, mlr_motion_rot(s.m),
                                   0, NULL, NULL, spos, NULL, NULL, NULL),
                     MLR_OK);
    double hs = 0.0;
    for (size_t j = 0; j < Js; j++)
        for (size_t k = 0; k < Js; k++)
            hs = fmax(hs, spos[3 * j + 1] - spos[3 * k + 1]);
    const size_t n = (size_t)lround(0.4 * s.fps), f0 = N / 2 - n / 2;
    for (size_t k = 0; k < n; k++)
        srp[3 * (f0 + k) + 1] -=
            0.03 * hs * 0.5 * (1 - cos(2 * M_PI * (double)k / (double)(n - 1)));
    double *rp = malloc(N * 3 * sizeof(double)), *rot = malloc(N * Jt * 4 * sizeof(double));
    mlr_diag d;
    ck_assert_int_eq(mlr_retarget(&s.rig, N, srp, mlr_motion_rot(s.m), NULL, &t.rig, MLR_AXIS_Y,
                                  MLR_AXIS_Y, NULL, 0, rp, rot, NULL, NULL, NULL, NULL),
                     MLR_OK);
    ck_assert_msg(mlr_retarget_feet(&s.rig, N, s.fps, MLR_AXIS_Y, srp, mlr_motion_rot(s.m), NULL,
                                    &t.rig, MLR_AXIS_Y, NULL, 0, rp, rot, NULL, NULL, NULL,
                                    &d) == MLR_OK,
                  "%s", d.message);
    double *pos = malloc(N * Jt * 3 * sizeof(double)), *wrot = malloc(N * Jt * 4 * sizeof(double));
    ck_assert_int_eq(mlr_fk_arrays(N, Jt, t.rig.parents, t.rig.offsets, rp, rot, 0, NULL, NULL,
                                   pos, wrot, NULL, NULL),
                     MLR_OK);
    double ht = 0.0;
    for (size_t j = 0; j < Jt; j++)
        for (size_t k = 0; k < Jt; k++)
            ht = fmax(ht, pos[3 * j + 1] - pos[3 * k + 1]);
    double *low = malloc(N * sizeof(double)), *other = malloc(N * sizeof(double));
    lowest_feet(&t.rig, N, pos, wrot, low);
    size_t m = 0;
    double deepest = INFINITY;
    for (size_t f = 0; f < N; f++) {
        if (f < f0 || f >= f0 + n)
            other[m++] = low[f];
        else
            deepest = fmin(deepest, low[f]);
    }
    qsort(other, m, sizeof(double), cmp_double);
    const double ground = other[(size_t)(0.05 * (double)(m - 1))];
    ck_assert_msg((ground - deepest) / ht < 1e-3, "%g%% of its height below its ground",
                  100 * (ground - deepest) / ht);
    free(srp), free(spos), free(rp), free(rot), free(pos), free(wrot), free(low), free(other);
    mlr_test_clip_unload(&s);
    mlr_test_clip_unload(&t);
}
END_TEST

static Suite *retarget_suite(void)
{
    Suite *s = suite_create("retarget");
    TCase *tc = tcase_create("core");
    tcase_add_test(tc, every_shared_human_rig_has_its_roles);
    tcase_add_test(tc, a_rig_onto_itself_gives_the_input_back);
    tcase_add_test(tc, every_matched_bone_points_as_the_source_s);
    tcase_add_test(tc, a_z_up_a_pose_rig_takes_the_bone_directions);
    tcase_add_test(tc, bad_input_names_the_joint_and_writes_nothing);
    tcase_add_test(tc, a_quadruped_is_refused_naming_its_limbs);
    tcase_add_test(tc, the_hips_carry_the_upper_body_and_the_head_ends_the_neck);
    tcase_add_test(tc, every_allocation_failure_is_no_memory_without_leaks);
    tcase_add_test(tc, the_feet_are_planted_and_the_upper_body_kept);
    tcase_add_test(tc, the_feet_stay_on_the_ground_where_the_source_s_sink);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(retarget_suite()); }
