/* Plausibility guards (mlr_guards.h): contacts, floor and joint limits of a real clip applied to
 * its stylized frames; switches; bad input; allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef mlr_test_clip clip;

/* The first max_frames frames of a real clip (0 when it is absent). */
static int load(const char *file, size_t max_frames, clip *c)
{
    if (!mlr_test_clip_load(file, c))
        return 0;
    if (c->n > max_frames)
        c->n = max_frames;
    return 1;
}

static void unload(clip *c) { mlr_test_clip_unload(c); }

static mlr_guards *guards_of(const clip *c, const mlr_guards_option *opts, size_t n_opts)
{
    mlr_guards *g;
    mlr_diag d;
    ck_assert_msg(mlr_guards_create(&c->rig, c->fps, c->n, mlr_motion_root_pos(c->m),
                                    mlr_motion_rot(c->m), mlr_motion_trans(c->m), opts, n_opts,
                                    NULL, &g, &d) == MLR_OK,
                  "%s", d.message);
    return g;
}

/* Frames of the clip synthesized at alpha (root translation group 0 is the root here). */
static void stylized(const clip *c, double alpha, double *root, double *rot)
{
    mlr_layers *L;
    mlr_diag d;
    const mlr_layers_option o = {MLR_LAYERS_OPT_FPS, c->fps};
    ck_assert_msg(mlr_layers_decompose(c->n, c->j, mlr_motion_root_pos(c->m), mlr_motion_rot(c->m),
                                       &o, 1, NULL, &L, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_int_eq(
        mlr_layers_synthesize(L, 0, c->n, &alpha, 1, root, 3 * c->n, rot, 4 * c->n * c->j, NULL),
        MLR_OK);
    mlr_layers_destroy(L);
}

/* Flexion (degrees) of the chain a-b-c at frame f of world positions p (J x 3 per frame). */
static double flexion(const double *p, size_t J, size_t f, int a, int b, int c)
{
    const double *pa = p + 3 * (f * J + (size_t)a), *pb = p + 3 * (f * J + (size_t)b);
    const double *pc = p + 3 * (f * J + (size_t)c);
    double u[3], v[3], uu = 0, vv = 0, uv = 0;
    for (int k = 0; k < 3; k++) {
        u[k] = pb[k] - pa[k], v[k] = pc[k] - pb[k];
        uu += u[k] * u[k], vv += v[k] * v[k], uv += u[k] * v[k];
    }
    double cs = uv / sqrt(uu * vv);
    cs = cs > 1 ? 1 : cs < -1 ? -1 : cs;
    return acos(cs) * (45.0 / atan(1.0));
}

static int joint_named(const clip *c, const char *name)
{
    for (size_t j = 0; j < c->j; j++)
        if (strcmp(c->names[j], name) == 0)
            return (int)j;
    ck_abort_msg("no joint %s", name);
    return -1;
}

START_TEST(stylized_knees_stay_within_the_fold_limit_and_feet_above_the_floor)
{
    clip c;
    MLR_TEST_NEED_CLIP("cmu_131_01_mj_style_walk.bvh");
    ck_assert(load("cmu_131_01_mj_style_walk.bvh", 994, &c));
    const size_t N = c.n, J = c.j;
    double *root = malloc(3 * N * sizeof(double)), *rot = malloc(4 * N * J * sizeof(double));
    double *ref_root = malloc(3 * N * sizeof(double));
    double *ref_rot = malloc(4 * N * J * sizeof(double));
    double *pos = malloc(3 * N * J * sizeof(double));
    stylized(&c, 3.0, root, rot);
    stylized(&c, 1.0, ref_root, ref_rot);
    const int hip = joint_named(&c, "RightHip"), knee = joint_named(&c, "RightKnee");
    const int ankle = joint_named(&c, "RightAnkle");
    /* the raw synthesis folds the knee past 150 degrees (the input does not) */
    double in_max = 0, raw_max = 0, out_max = 0;
    ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, mlr_motion_root_pos(c.m),
                                   mlr_motion_rot(c.m), 0, NULL, NULL, pos, NULL, NULL, NULL),
                     MLR_OK);
    for (size_t f = 0; f < N; f++)
        in_max = fmax(in_max, flexion(pos, J, f, hip, knee, ankle));
    ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, root, rot, 0, NULL, NULL,
                                   pos, NULL, NULL, NULL),
                     MLR_OK);
    for (size_t f = 0; f < N; f++)
        raw_max = fmax(raw_max, flexion(pos, J, f, hip, knee, ankle));
    ck_assert_double_lt(in_max, 150.0);
    ck_assert_double_gt(raw_max, 160.0);

    mlr_guards *g = guards_of(&c, NULL, 0);
    ck_assert_uint_eq(mlr_guards_n_points(g), 4); /* two ankles, two toes */
    size_t *limited = malloc(J * sizeof(size_t));
    mlr_guards_report rep;
    mlr_diag d;
    const double alpha = 3.0;
    ck_assert_msg(mlr_guards_apply(g, &alpha, 1, ref_root, ref_rot, NULL, root, rot, NULL, limited,
                                   J, &rep, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_int_eq(rep.limits_applied, 1);
    ck_assert_uint_gt(limited[knee], 0);
    ck_assert_uint_gt(rep.contact_frames, N / 2);
    ck_assert(isfinite(rep.floor_height));
    ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, root, rot, 0, NULL, NULL,
                                   pos, NULL, NULL, NULL),
                     MLR_OK);
    double lowest = INFINITY, height;
    ck_assert_int_eq(mlr_rig_body_height(N, J, pos, MLR_AXIS_Y, &height, NULL, &d), MLR_OK);
    for (size_t f = 0; f < N; f++) {
        out_max = fmax(out_max, flexion(pos, J, f, hip, knee, ankle));
        lowest = fmin(lowest, pos[3 * (f * J + (size_t)ankle) + 1]);
    }
    ck_assert_double_le(out_max, 150.0);
    ck_assert_double_ge(lowest, rep.floor_height - 0.005 * height);
    /* bone lengths: the thigh keeps its length in every frame */
    const double *o = c.rig.offsets + 3 * knee;
    const double thigh = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    for (size_t f = 0; f < N; f += 37) {
        const double *a = pos + 3 * (f * J + (size_t)hip), *b = pos + 3 * (f * J + (size_t)knee);
        ck_assert_double_eq_tol(hypot(hypot(b[0] - a[0], b[1] - a[1]), b[2] - a[2]), thigh,
                                1e-9 * thigh);
    }
    mlr_guards_destroy(g);
    free(limited), free(pos), free(root), free(rot), free(ref_root), free(ref_rot);
    unload(&c);
}
END_TEST

/* Horizontal path (metres per frame pair, summed) of the C points of pos on the frames where
   a point and the next frame are both in contact. */
static double sliding(const clip *c, const double *root, const double *rot, size_t C,
                      const int32_t *joints, const int32_t *end_sites, const uint8_t *contacts)
{
    const size_t N = c->n, J = c->j;
    double *pos = malloc(3 * N * J * sizeof(double)), *wrot = malloc(4 * N * J * sizeof(double));
    double *pts = malloc(3 * N * C * sizeof(double));
    ck_assert_int_eq(mlr_fk_arrays(N, J, c->rig.parents, c->rig.offsets, root, rot, 0, NULL, NULL,
                                   pos, wrot, NULL, NULL),
                     MLR_OK);
    ck_assert_int_eq(
        mlr_rig_point_positions(&c->rig, N, pos, wrot, C, joints, end_sites, pts, NULL), MLR_OK);
    double len = 0.0;
    for (size_t f = 0; f + 1 < N; f++)
        for (size_t k = 0; k < C; k++)
            if (contacts[f * C + k] && contacts[(f + 1) * C + k]) {
                const double *a = pts + 3 * (f * C + k), *b = pts + 3 * ((f + 1) * C + k);
                len += hypot(b[0] - a[0], b[2] - a[2]); /* Y up */
            }
    free(pos), free(wrot), free(pts);
    return len;
}

/* LaFAN1 at alpha 3 with every guard on: the feet slide no more than the input's on its
   contacts (the last limits pass leaves the knees IK put within their range as they are: when
   it also softened the straight stance knees within the reversal margin, they slid 1.09x the
   input's), and no knee folds past 150 degrees. */
START_TEST(stylized_feet_slide_no_more_than_the_inputs)
{
    clip c;
    MLR_TEST_NEED_CLIP("lafan1_clip_a.bvh");
    ck_assert(load("lafan1_clip_a.bvh", 3000, &c));
    const size_t N = c.n, J = c.j;
    double *root = malloc(3 * N * sizeof(double)), *rot = malloc(4 * N * J * sizeof(double));
    stylized(&c, 3.0, root, rot);
    mlr_guards *g = guards_of(&c, NULL, 0);
    const size_t C = mlr_guards_n_points(g);
    ck_assert_uint_eq(C, 4);
    int32_t joints[4], end_sites[4];
    uint8_t *contacts = malloc(N * C);
    ck_assert_int_eq(mlr_guards_get_contacts(g, joints, end_sites, contacts), MLR_OK);
    const double s_in =
        sliding(&c, mlr_motion_root_pos(c.m), mlr_motion_rot(c.m), C, joints, end_sites, contacts);
    const double s_raw = sliding(&c, root, rot, C, joints, end_sites, contacts);
    const double alpha = 3.0;
    mlr_guards_report rep;
    mlr_diag d;
    ck_assert_msg(mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, &rep,
                                   &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_int_eq(rep.limits_applied, 1);
    const double s_out = sliding(&c, root, rot, C, joints, end_sites, contacts);
    ck_assert_double_gt(s_raw, 5.0 * s_in); /* the raw synthesis skates */
    ck_assert_double_le(s_out, s_in);
    /* the knees stay within the fold bound (150 degrees; the input's largest is below it) */
    double *pos = malloc(3 * N * J * sizeof(double));
    ck_assert_int_eq(mlr_fk_arrays(N, J, c.rig.parents, c.rig.offsets, root, rot, 0, NULL, NULL,
                                   pos, NULL, NULL, NULL),
                     MLR_OK);
    const int legs[2][3] = {
        {joint_named(&c, "LeftUpLeg"), joint_named(&c, "LeftLeg"), joint_named(&c, "LeftFoot")},
        {joint_named(&c, "RightUpLeg"), joint_named(&c, "RightLeg"),
         joint_named(&c, "RightFoot")}};
    for (size_t f = 0; f < N; f++)
        for (int l = 0; l < 2; l++)
            ck_assert_double_le(flexion(pos, J, f, legs[l][0], legs[l][1], legs[l][2]), 150.0);
    free(pos);
    mlr_guards_destroy(g);
    free(contacts), free(root), free(rot);
    unload(&c);
}
END_TEST

/* World positions (N x J x 3) of frames on the clip's rig. */
static void world_of(const clip *c, const double *root, const double *rot, const double *trans,
                     double *pos)
{
    ck_assert_int_eq(mlr_fk_arrays(c->n, c->j, c->rig.parents, c->rig.offsets, root, rot,
                                   c->rig.n_trans, c->rig.trans_joints, trans, pos, NULL, NULL,
                                   NULL),
                     MLR_OK);
}

/* Bandai keeps joint_Root at the origin and walks in the position channels of Hips. With its
 * body 8 cm up, the planted feet are out of reach and the guards lower the body:
 * mlr_guards_apply through root_pos (joint_Root leaves the origin with it),
 * mlr_guards_apply_trans through Hips' translation (joint_Root stays); every other joint ends in
 * the same place either way. On a rig whose root carries the body (the root moving), the two
 * give the same bits and trans is untouched. */
START_TEST(the_body_shift_rides_on_the_joint_that_carries_the_body)
{
    clip c;
    MLR_TEST_NEED_CLIP("bandai1_walk_happy_001.bvh");
    ck_assert(load("bandai1_walk_happy_001.bvh", 120, &c));
    const size_t N = c.n, J = c.j, P = c.rig.n_trans;
    ck_assert_uint_gt(P, 0);
    const int hips = joint_named(&c, "Hips");
    size_t kh = P;
    for (size_t k = 0; k < P; k++)
        if (c.rig.trans_joints[k] == hips)
            kh = k;
    ck_assert_uint_lt(kh, P);
    double *root1 = malloc(3 * N * sizeof(double)), *root2 = malloc(3 * N * sizeof(double));
    double *rot1 = malloc(4 * N * J * sizeof(double)), *rot2 = malloc(4 * N * J * sizeof(double));
    double *trans1 = malloc(3 * N * P * sizeof(double));
    double *trans2 = malloc(3 * N * P * sizeof(double));
    double *pos1 = malloc(3 * N * J * sizeof(double)), *pos2 = malloc(3 * N * J * sizeof(double));
    memcpy(root1, mlr_motion_root_pos(c.m), 3 * N * sizeof(double));
    memcpy(rot1, mlr_motion_rot(c.m), 4 * N * J * sizeof(double));
    memcpy(trans1, mlr_motion_trans(c.m), 3 * N * P * sizeof(double));
    for (size_t f = 0; f < N; f++)
        trans1[3 * (f * P + kh) + 1] += 8.0; /* the body 8 cm up: planted feet out of reach */
    memcpy(root2, root1, 3 * N * sizeof(double));
    memcpy(rot2, rot1, 4 * N * J * sizeof(double));
    memcpy(trans2, trans1, 3 * N * P * sizeof(double));
    mlr_guards *g = guards_of(&c, NULL, 0);
    const double alpha = 2.0;
    mlr_diag d;
    ck_assert_msg(mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, root1, rot1, trans1, NULL, 0,
                                   NULL, &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_msg(mlr_guards_apply_trans(g, &alpha, 1, NULL, NULL, NULL, root2, rot2, trans2, NULL,
                                         0, NULL, &d) == MLR_OK,
                  "%s", d.message);
    double moved = 0.0, root_moved = 0.0, diff = 0.0;
    for (size_t i = 0; i < 3 * N; i++) {
        moved = fmax(moved, fabs(root1[i] - mlr_motion_root_pos(c.m)[i]));
        root_moved = fmax(root_moved, fabs(root2[i] - mlr_motion_root_pos(c.m)[i]));
    }
    ck_assert_double_gt(moved, 3.0); /* the body was lowered, through root_pos */
    ck_assert_double_eq(root_moved, 0.0);
    ck_assert_mem_eq(rot1, rot2, 4 * N * J * sizeof(double));
    world_of(&c, root1, rot1, trans1, pos1);
    world_of(&c, root2, rot2, trans2, pos2);
    for (size_t f = 0; f < N; f++)
        for (size_t j = 1; j < J; j++)
            for (int k = 0; k < 3; k++)
                diff = fmax(diff, fabs(pos1[3 * (f * J + j) + k] - pos2[3 * (f * J + j) + k]));
    ck_assert_double_lt(diff, 1e-9);
    mlr_guards_destroy(g);

    /* the root carries the body (it moves): the same bits as mlr_guards_apply, trans as it was */
    for (size_t f = 0; f < N; f++) {
        root1[3 * f] = mlr_motion_root_pos(c.m)[3 * f] + 0.5 * (double)f;
        root1[3 * f + 1] = mlr_motion_root_pos(c.m)[3 * f + 1];
        root1[3 * f + 2] = mlr_motion_root_pos(c.m)[3 * f + 2];
    }
    memcpy(rot1, mlr_motion_rot(c.m), 4 * N * J * sizeof(double));
    memcpy(trans1, mlr_motion_trans(c.m), 3 * N * P * sizeof(double));
    ck_assert_msg(
        mlr_guards_create(&c.rig, c.fps, N, root1, rot1, trans1, NULL, 0, NULL, &g, &d) == MLR_OK,
        "%s", d.message);
    for (size_t f = 0; f < N; f++)
        trans1[3 * (f * P + kh) + 1] += 8.0;
    memcpy(root2, root1, 3 * N * sizeof(double));
    memcpy(rot2, rot1, 4 * N * J * sizeof(double));
    memcpy(trans2, trans1, 3 * N * P * sizeof(double));
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, root1, rot1, trans1, NULL, 0, NULL, NULL),
        MLR_OK);
    ck_assert_int_eq(mlr_guards_apply_trans(g, &alpha, 1, NULL, NULL, NULL, root2, rot2, trans2,
                                            NULL, 0, NULL, NULL),
                     MLR_OK);
    ck_assert_mem_eq(root1, root2, 3 * N * sizeof(double));
    ck_assert_mem_eq(rot1, rot2, 4 * N * J * sizeof(double));
    ck_assert_mem_eq(trans1, trans2, 3 * N * P * sizeof(double));
    mlr_guards_destroy(g);
    unload(&c);
    free(root1), free(root2), free(rot1), free(rot2), free(trans1), free(trans2), free(pos1),
        free(pos2);
}
END_TEST

START_TEST(every_guard_switched_off_leaves_the_frames_alone)
{
    clip c;
    MLR_TEST_NEED_CLIP("cmu_131_01_mj_style_walk.bvh");
    ck_assert(load("cmu_131_01_mj_style_walk.bvh", 300, &c));
    const size_t N = c.n, J = c.j;
    double *root = malloc(3 * N * sizeof(double)), *rot = malloc(4 * N * J * sizeof(double));
    double *root0 = malloc(3 * N * sizeof(double)), *rot0 = malloc(4 * N * J * sizeof(double));
    stylized(&c, 2.0, root, rot);
    memcpy(root0, root, 3 * N * sizeof(double));
    memcpy(rot0, rot, 4 * N * J * sizeof(double));
    const mlr_guards_option off[3] = {
        {MLR_GUARDS_OPT_LIMITS, 0}, {MLR_GUARDS_OPT_KEEP_CONTACTS, 0}, {MLR_GUARDS_OPT_FLOOR, 0}};
    mlr_guards *g = guards_of(&c, off, 3);
    ck_assert_uint_eq(mlr_guards_n_points(g), 0);
    mlr_guards_report rep;
    const double alpha = 2.0;
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, &rep, NULL),
        MLR_OK);
    ck_assert_int_eq(rep.limits_applied, 0);
    ck_assert(isnan(rep.floor_height));
    ck_assert_int_eq(memcmp(root, root0, 3 * N * sizeof(double)), 0);
    ck_assert_int_eq(memcmp(rot, rot0, 4 * N * J * sizeof(double)), 0);
    mlr_guards_destroy(g);
    /* limits on by default, but only when some |alpha| > 1 */
    const mlr_guards_option only_limits[2] = {{MLR_GUARDS_OPT_KEEP_CONTACTS, 0},
                                              {MLR_GUARDS_OPT_FLOOR, 0}};
    g = guards_of(&c, only_limits, 2);
    const double half = 0.5;
    ck_assert_int_eq(
        mlr_guards_apply(g, &half, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, &rep, NULL),
        MLR_OK);
    ck_assert_int_eq(rep.limits_applied, 0);
    ck_assert_int_eq(memcmp(rot, rot0, 4 * N * J * sizeof(double)), 0);
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, &rep, NULL),
        MLR_OK);
    ck_assert_int_eq(rep.limits_applied, 1);
    ck_assert_int_ne(memcmp(rot, rot0, 4 * N * J * sizeof(double)), 0);
    ck_assert_int_eq(memcmp(root, root0, 3 * N * sizeof(double)), 0);
    mlr_guards_destroy(g);
    free(root), free(rot), free(root0), free(rot0);
    unload(&c);
}
END_TEST

START_TEST(bad_input_gets_the_right_status_and_message)
{
    clip c;
    MLR_TEST_NEED_CLIP("cmu_131_01_mj_style_walk.bvh");
    ck_assert(load("cmu_131_01_mj_style_walk.bvh", 120, &c));
    const size_t N = c.n, J = c.j;
    mlr_guards *g = NULL;
    mlr_diag d;
    const double *r = mlr_motion_root_pos(c.m), *q = mlr_motion_rot(c.m);
    ck_assert_int_eq(mlr_guards_create(&c.rig, 0.0, N, r, q, NULL, NULL, 0, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "fps"));
    ck_assert_ptr_null(g);
    ck_assert_int_eq(mlr_guards_create(&c.rig, c.fps, 2, r, q, NULL, NULL, 0, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    const mlr_guards_option bad_key = {99, 1}, bad_up = {MLR_GUARDS_OPT_UP, 3},
                            nan_floor = {MLR_GUARDS_OPT_FLOOR_HEIGHT, NAN};
    ck_assert_int_eq(mlr_guards_create(&c.rig, c.fps, N, r, q, NULL, &bad_key, 1, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "unknown"));
    ck_assert_int_eq(mlr_guards_create(&c.rig, c.fps, N, r, q, NULL, &bad_up, 1, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "up axis"));
    ck_assert_int_eq(mlr_guards_create(&c.rig, c.fps, N, r, q, NULL, &nan_floor, 1, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "not finite"));
    double *rot = malloc(4 * N * J * sizeof(double)), *root = malloc(3 * N * sizeof(double));
    memcpy(rot, q, 4 * N * J * sizeof(double));
    memcpy(root, r, 3 * N * sizeof(double));
    rot[4 * J * 7 + 1] = NAN;
    ck_assert_int_eq(mlr_guards_create(&c.rig, c.fps, N, root, rot, NULL, NULL, 0, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "guards: rot value"));
    ck_assert_ptr_nonnull(strstr(d.message, "not finite"));
    ck_assert_ptr_null(g);
    memset(rot + 4 * J * 7, 0, 4 * sizeof(double)); /* a zero quaternion */
    ck_assert_int_eq(mlr_guards_create(&c.rig, c.fps, N, root, rot, NULL, NULL, 0, NULL, &g, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "zero"));
    ck_assert_ptr_null(g);
    memcpy(rot, q, 4 * N * J * sizeof(double));
    g = guards_of(&c, NULL, 0);
    /* apply with the limits on (alpha 2): a rotation not finite, then a zero one, named as
       such, and nothing written */
    {
        const double a2 = 2.0;
        double *rot2 = malloc(4 * N * J * sizeof(double));
        rot[4 * (J * 11 + 3) + 2] = NAN;
        memcpy(rot2, rot, 4 * N * J * sizeof(double));
        ck_assert_int_eq(
            mlr_guards_apply(g, &a2, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, NULL, &d),
            MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "rot value"));
        ck_assert_ptr_nonnull(strstr(d.message, "not finite"));
        ck_assert_int_eq(memcmp(rot, rot2, 4 * N * J * sizeof(double)), 0);
        memset(rot + 4 * (J * 11 + 3), 0, 4 * sizeof(double));
        memcpy(rot2, rot, 4 * N * J * sizeof(double));
        ck_assert_int_eq(
            mlr_guards_apply(g, &a2, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, NULL, &d),
            MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "rot_in[11][3] is zero"));
        ck_assert_int_eq(memcmp(rot, rot2, 4 * N * J * sizeof(double)), 0);
        /* a quaternion whose squared norm overflows is normalized, as create does */
        memcpy(rot, q, 4 * N * J * sizeof(double));
        for (int k = 0; k < 4; k++)
            rot[4 * (J * 11 + 3) + k] *= 1e200;
        memcpy(rot2, root, 3 * N * sizeof(double));
        ck_assert_int_eq(
            mlr_guards_apply(g, &a2, 1, NULL, NULL, NULL, rot2, rot, NULL, NULL, 0, NULL, &d),
            MLR_OK);
        const double *u = rot + 4 * (J * 11 + 3);
        ck_assert_double_eq_tol(u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + u[3] * u[3], 1.0, 1e-12);
        free(rot2);
        memcpy(rot, q, 4 * N * J * sizeof(double));
    }
    const double alpha = 2.0, bad_alpha = INFINITY;
    ck_assert_int_eq(
        mlr_guards_apply(g, &bad_alpha, 1, NULL, NULL, NULL, root, rot, NULL, NULL, 0, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "alpha"));
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 5, NULL, NULL, NULL, root, rot, NULL, NULL, 0, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, root, NULL, NULL, root, rot, NULL, NULL, 0, NULL, &d),
        MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "reference"));
    /* contacts that name nothing, limits of another rig: nothing changes */
    const int32_t joints[2] = {0, (int32_t)J + 3};
    const uint8_t *contacts = calloc(2 * N, 1);
    const size_t before = mlr_guards_n_points(g);
    ck_assert_int_eq(mlr_guards_set_contacts(g, 2, joints, NULL, contacts, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "names nothing"));
    ck_assert_uint_eq(mlr_guards_n_points(g), before);
    const int32_t twice[2] = {3, 3};
    ck_assert_int_eq(mlr_guards_set_contacts(g, 2, twice, NULL, contacts, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "twice"));
    ck_assert_int_eq(mlr_guards_set_limits(NULL, NULL, &d), MLR_E_INVALID_ARG);
    mlr_guards_destroy(g);
    mlr_guards_destroy(NULL);
    free((void *)contacts), free(rot), free(root);
    unload(&c);
}
END_TEST

START_TEST(every_allocation_failure_returns_no_memory_without_leaks)
{
    clip c;
    MLR_TEST_NEED_CLIP("cmu_131_01_mj_style_walk.bvh");
    ck_assert(load("cmu_131_01_mj_style_walk.bvh", 120, &c));
    const size_t N = c.n, J = c.j;
    double *root = malloc(3 * N * sizeof(double)), *rot = malloc(4 * N * J * sizeof(double));
    stylized(&c, 2.5, root, rot);
    const double alpha = 2.5;
    size_t failures = 0;
    for (size_t k = 0;; k++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        mlr_guards *g = NULL;
        mlr_status st = mlr_guards_create(&c.rig, c.fps, N, mlr_motion_root_pos(c.m),
                                          mlr_motion_rot(c.m), NULL, NULL, 0, &ta.base, &g, NULL);
        if (st == MLR_OK) {
            double *r2 = malloc(3 * N * sizeof(double)), *q2 = malloc(4 * N * J * sizeof(double));
            memcpy(r2, root, 3 * N * sizeof(double));
            memcpy(q2, rot, 4 * N * J * sizeof(double));
            st = mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, r2, q2, NULL, NULL, 0, NULL,
                                  NULL);
            if (st != MLR_OK) {
                /* a failed apply leaves the frames as they were */
                ck_assert_int_eq(memcmp(r2, root, 3 * N * sizeof(double)), 0);
                ck_assert_int_eq(memcmp(q2, rot, 4 * N * J * sizeof(double)), 0);
            }
            free(r2), free(q2);
            mlr_guards_destroy(g);
        }
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (k >= ta.n_calls) { /* the k-th allocation was never reached: all done */
            ck_assert_int_eq(st, MLR_OK);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        failures++;
    }
    ck_assert_uint_gt(failures, 10);
    free(root), free(rot);
    unload(&c);
}
END_TEST

/* The input's trajectories (the default reference) are made at create from the input's forward
 * kinematics, and again by set_contacts through the cleanup's own: the same points and contacts
 * set again give the same motion bit for bit. A given reference is made once per apply for
 * both rounds: its allocation failures, and set_contacts', are clean too. */
/* The guards as a job (mlr_guards_input, mlr_guards_job): the same bits as the long forms,
   with and without a reference, with the body's shift in root_pos or in trans; the job's own
   field errors named. */
START_TEST(a_job_gives_the_long_forms_bits)
{
    clip c;
    MLR_TEST_NEED_CLIP("cmu_131_01_mj_style_walk.bvh");
    ck_assert(load("cmu_131_01_mj_style_walk.bvh", 240, &c));
    const size_t N = c.n, J = c.j;
    double *root = malloc(3 * N * sizeof(double)), *rot = malloc(4 * N * J * sizeof(double));
    double *r1 = malloc(3 * N * sizeof(double)), *q1 = malloc(4 * N * J * sizeof(double));
    double *r2 = malloc(3 * N * sizeof(double)), *q2 = malloc(4 * N * J * sizeof(double));
    double *rr = malloc(3 * N * sizeof(double)), *rq = malloc(4 * N * J * sizeof(double));
    size_t *l1 = malloc(J * sizeof(size_t)), *l2 = malloc(J * sizeof(size_t));
    stylized(&c, 2.5, root, rot);
    stylized(&c, 1.0, rr, rq);
    const double alpha = 2.5;
    mlr_guards *g = guards_of(&c, NULL, 0), *h = NULL;
    mlr_diag d;
    const mlr_guards_input in = {
        &c.rig, c.fps,
        (mlr_frames){N, mlr_motion_root_pos(c.m), mlr_motion_rot(c.m), mlr_motion_trans(c.m)},
        NULL, 0};
    ck_assert_msg(mlr_guards_create_from(&in, NULL, &h, &d) == MLR_OK, "%s", d.message);
    for (int with_ref = 0; with_ref < 2; with_ref++)
        for (int body = 0; body < 2; body++) {
            mlr_guards_report rep1, rep2;
            memcpy(r1, root, 3 * N * sizeof(double)), memcpy(q1, rot, 4 * N * J * sizeof(double));
            memcpy(r2, root, 3 * N * sizeof(double)), memcpy(q2, rot, 4 * N * J * sizeof(double));
            const double *a = with_ref ? rr : NULL, *b = with_ref ? rq : NULL;
            ck_assert_int_eq(body ? mlr_guards_apply_trans(g, &alpha, 1, a, b, NULL, r1, q1, NULL,
                                                           l1, J, &rep1, NULL)
                                  : mlr_guards_apply(g, &alpha, 1, a, b, NULL, r1, q1, NULL, l1, J,
                                                     &rep1, NULL),
                             MLR_OK);
            mlr_guards_job job = {0};
            job.alpha = &alpha, job.n_alpha = 1;
            if (with_ref)
                job.reference = (mlr_frames){N, rr, rq, NULL};
            job.root_pos = r2, job.rot = q2, job.body_on_trans = body;
            job.limited = l2, job.n_limited = J, job.report = &rep2;
            ck_assert_int_eq(mlr_guards_job_validate(h, &job, &d), MLR_OK);
            ck_assert_msg(mlr_guards_run(h, &job, &d) == MLR_OK, "%s", d.message);
            ck_assert_int_eq(memcmp(r1, r2, 3 * N * sizeof(double)), 0);
            ck_assert_int_eq(memcmp(q1, q2, 4 * N * J * sizeof(double)), 0);
            ck_assert_int_eq(memcmp(l1, l2, J * sizeof(size_t)), 0);
            ck_assert_uint_eq(rep1.contact_frames, rep2.contact_frames);
            ck_assert(rep1.floor_height == rep2.floor_height);
            /* the job's own fields */
            job.reference.n_frames = with_ref ? N - 1 : 2;
            ck_assert_int_eq(mlr_guards_job_validate(h, &job, &d), MLR_E_INVALID_ARG);
            ck_assert_ptr_nonnull(strstr(d.message, "job.reference.n_frames"));
            ck_assert_int_eq(mlr_guards_run(h, &job, &d), MLR_E_INVALID_ARG);
            job.reference.n_frames = with_ref ? N : 0;
            job.n_alpha = 5; /* what the long form refuses, with its message */
            ck_assert_int_eq(mlr_guards_job_validate(h, &job, &d), MLR_E_INVALID_ARG);
            ck_assert_ptr_nonnull(strstr(d.message, "5 alphas"));
        }
    ck_assert_int_eq(mlr_guards_run(h, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL job"));
    ck_assert_int_eq(mlr_guards_job_validate(NULL, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL handle"));
    mlr_guards *none = (mlr_guards *)&d;
    ck_assert_int_eq(mlr_guards_create_from(NULL, NULL, &none, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_null(none);
    mlr_guards_destroy(g), mlr_guards_destroy(h);
    free(root), free(rot), free(r1), free(q1), free(r2), free(q2), free(rr), free(rq);
    free(l1), free(l2);
    unload(&c);
}
END_TEST

START_TEST(reference_trajectories_are_the_same_however_made)
{
    clip c;
    MLR_TEST_NEED_CLIP("cmu_131_01_mj_style_walk.bvh");
    ck_assert(load("cmu_131_01_mj_style_walk.bvh", 240, &c));
    const size_t N = c.n, J = c.j;
    double *root = malloc(3 * N * sizeof(double)), *rot = malloc(4 * N * J * sizeof(double));
    double *r1 = malloc(3 * N * sizeof(double)), *q1 = malloc(4 * N * J * sizeof(double));
    double *r2 = malloc(3 * N * sizeof(double)), *q2 = malloc(4 * N * J * sizeof(double));
    double *rr = malloc(3 * N * sizeof(double)), *rq = malloc(4 * N * J * sizeof(double));
    stylized(&c, 2.5, root, rot);
    stylized(&c, 1.0, rr, rq);
    const double alpha = 2.5;
    mlr_guards *g = guards_of(&c, NULL, 0);
    const size_t C = mlr_guards_n_points(g);
    ck_assert_uint_gt(C, 0);
    int32_t *pj = malloc(C * sizeof(int32_t)), *pe = malloc(C * sizeof(int32_t));
    uint8_t *pc = malloc(N * C);
    ck_assert_int_eq(mlr_guards_get_contacts(g, pj, pe, pc), MLR_OK);
    memcpy(r1, root, 3 * N * sizeof(double)), memcpy(q1, rot, 4 * N * J * sizeof(double));
    mlr_guards_report rep1, rep2;
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, r1, q1, NULL, NULL, 0, &rep1, NULL),
        MLR_OK);
    ck_assert_uint_gt(rep1.contact_frames, 0);
    mlr_diag d;
    ck_assert_msg(mlr_guards_set_contacts(g, C, pj, pe, pc, &d) == MLR_OK, "%s", d.message);
    memcpy(r2, root, 3 * N * sizeof(double)), memcpy(q2, rot, 4 * N * J * sizeof(double));
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, NULL, NULL, NULL, r2, q2, NULL, NULL, 0, &rep2, NULL),
        MLR_OK);
    ck_assert_int_eq(memcmp(r1, r2, 3 * N * sizeof(double)), 0);
    ck_assert_int_eq(memcmp(q1, q2, 4 * N * J * sizeof(double)), 0);
    ck_assert_uint_eq(rep1.contact_frames, rep2.contact_frames);
    /* a given reference is followed as it is: another motion than the input's default */
    memcpy(r2, root, 3 * N * sizeof(double)), memcpy(q2, rot, 4 * N * J * sizeof(double));
    ck_assert_int_eq(
        mlr_guards_apply(g, &alpha, 1, rr, rq, NULL, r2, q2, NULL, NULL, 0, &rep2, NULL), MLR_OK);
    ck_assert_int_ne(memcmp(r1, r2, 3 * N * sizeof(double)), 0);
    mlr_guards_destroy(g);
    /* allocation failures: create, set_contacts, apply with a given reference */
    size_t failures = 0;
    for (size_t k = 0;; k++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        mlr_guards *h = NULL;
        mlr_status st = mlr_guards_create(&c.rig, c.fps, N, mlr_motion_root_pos(c.m),
                                          mlr_motion_rot(c.m), NULL, NULL, 0, &ta.base, &h, NULL);
        if (st == MLR_OK)
            st = mlr_guards_set_contacts(h, C, pj, pe, pc, NULL);
        if (st == MLR_OK) {
            memcpy(r2, root, 3 * N * sizeof(double)), memcpy(q2, rot, 4 * N * J * sizeof(double));
            st = mlr_guards_apply(h, &alpha, 1, rr, rq, NULL, r2, q2, NULL, NULL, 0, NULL, NULL);
            if (st != MLR_OK) {
                ck_assert_int_eq(memcmp(r2, root, 3 * N * sizeof(double)), 0);
                ck_assert_int_eq(memcmp(q2, rot, 4 * N * J * sizeof(double)), 0);
            }
        }
        mlr_guards_destroy(h);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (k >= ta.n_calls) {
            ck_assert_int_eq(st, MLR_OK);
            break;
        }
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        failures++;
    }
    ck_assert_uint_gt(failures, 10);
    /* a non-finite reference is refused before anything is written */
    rq[4 * J * 7 + 2] = NAN;
    memcpy(r2, root, 3 * N * sizeof(double)), memcpy(q2, rot, 4 * N * J * sizeof(double));
    g = guards_of(&c, NULL, 0);
    ck_assert_int_eq(mlr_guards_apply(g, &alpha, 1, rr, rq, NULL, r2, q2, NULL, NULL, 0, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "reference contains NaN"));
    ck_assert_int_eq(memcmp(q2, rot, 4 * N * J * sizeof(double)), 0);
    mlr_guards_destroy(g);
    free(pj), free(pe), free(pc);
    free(root), free(rot), free(r1), free(q1), free(r2), free(q2), free(rr), free(rq);
    unload(&c);
}
END_TEST

static Suite *guards_suite(void)
{
    Suite *s = suite_create("guards");
    TCase *tc = tcase_create("guards");
    tcase_add_test(tc, stylized_knees_stay_within_the_fold_limit_and_feet_above_the_floor);
    tcase_add_test(tc, stylized_feet_slide_no_more_than_the_inputs);
    tcase_add_test(tc, the_body_shift_rides_on_the_joint_that_carries_the_body);
    tcase_add_test(tc, every_guard_switched_off_leaves_the_frames_alone);
    tcase_add_test(tc, bad_input_gets_the_right_status_and_message);
    tcase_add_test(tc, every_allocation_failure_returns_no_memory_without_leaks);
    tcase_add_test(tc, reference_trajectories_are_the_same_however_made);
    tcase_add_test(tc, a_job_gives_the_long_forms_bits);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(guards_suite()); }
