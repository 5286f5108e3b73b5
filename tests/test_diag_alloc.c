/* Every public function that takes an mlr_allocator (and every one that allocates through a
 * handle's allocator) fails each of its allocations in turn with MLR_E_NO_MEMORY, a message
 * that names the function and says "out of memory", and no leak; a size overflow reachable
 * from the arguments says what overflowed; and a NULL required pointer or a zero size leaves a
 * message, never an empty diag. One table each. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- a small figure: 11 joints (hips, spine, head, arms, legs, hands, feet), 2 End Sites,
 * a walk of FN frames at 60 fps; world positions and rotations by forward kinematics -------- */

enum { FJ = 11, FN = 48, FE = 2 };
static const int32_t f_parents[FJ] = {-1, 0, 1, 1, 1, 0, 0, 3, 4, 5, 6};
static const double f_offsets[3 * FJ] = {0, 0, 0,  0, 0.3, 0,  0, 0.3, 0,  0.2, 0.2, 0,
                                         -0.2, 0.2, 0,  0.1, -0.1, 0,  -0.1, -0.1, 0,
                                         0.55, 0, 0,  -0.55, 0, 0,  0, -0.85, 0,  0, -0.85, 0};
static const char *const f_names[FJ] = {"Hips",    "Spine",    "Head",     "LeftArm",
                                        "RightArm", "LeftUpLeg", "RightUpLeg", "LeftHand",
                                        "RightHand", "LeftFoot", "RightFoot"};
static const int32_t f_end_parents[FE] = {9, 10};
static const double f_end_offsets[3 * FE] = {0, -0.05, 0.15, 0, -0.05, 0.15};
static const mlr_rig f_rig = {FJ, f_parents, f_offsets, f_names, 0, NULL,
                              FE, f_end_parents, f_end_offsets};

static double f_root[3 * FN], f_rot[4 * FJ * FN], f_wp[3 * FJ * FN], f_wr[4 * FJ * FN];

static void axis_angle(double *q, int axis, double angle)
{
    q[0] = cos(angle / 2), q[1] = q[2] = q[3] = 0.0;
    q[1 + axis] = sin(angle / 2);
}

static void figure_init(void)
{
    for (size_t i = 0; i < FN; i++) {
        const double t = (double)i / 60.0, ph = 2 * 3.14159265358979323846 * 1.1 * t;
        double *q = f_rot + 4 * FJ * i;
        for (size_t j = 0; j < FJ; j++)
            axis_angle(q + 4 * j, 0, 0.0);
        axis_angle(q, 1, 0.3 * t);
        axis_angle(q + 4 * 3, 2, -1.2);
        axis_angle(q + 4 * 4, 2, 1.2);
        axis_angle(q + 4 * 5, 0, 0.5 * sin(ph));
        axis_angle(q + 4 * 6, 0, -0.5 * sin(ph));
        f_root[3 * i] = 0.02 * sin(ph);
        f_root[3 * i + 1] = 1.0 + 0.02 * cos(2 * ph);
        f_root[3 * i + 2] = 1.3 * t;
    }
    ck_assert_int_eq(mlr_fk_arrays(FN, FJ, f_parents, f_offsets, f_root, f_rot, 0, NULL, NULL,
                                   f_wp, f_wr, NULL, NULL),
                     MLR_OK);
}

/* the two feet as contact points, in contact in the frames where they are low */
static const int32_t f_points[2] = {9, 10}, f_no_end[2] = {-1, -1};
static uint8_t f_contacts[FN * 2];

static void contacts_init(void)
{
    for (size_t f = 0; f < FN; f++)
        for (size_t c = 0; c < 2; c++)
            f_contacts[2 * f + c] = (f / 8 + c) % 2 == 0;
}

/* A BVH text of three joints with names longer than the reader's first buffers, 6 frames. */
static const char three_bvh[] =
    "HIERARCHY\nROOT HipsOfAFigureWithALongName\n{\n  OFFSET 0 0 0\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  JOINT SpineOfAFigureWithALongName\n  {\n    OFFSET 0 1 0\n"
    "    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    JOINT HeadOfAFigureWithALongName\n    {\n      OFFSET 0 1 0\n"
    "      CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "      End Site\n      {\n        OFFSET 0 0.5 0\n      }\n    }\n  }\n}\n"
    "MOTION\nFrames: 6\nFrame Time: 0.04\n"
    "0 1 0 0 0 0 0 0 0 0 0 0\n0 1 0 1 0 0 2 0 0 3 0 0\n0 1 0 2 0 0 4 0 0 6 0 0\n"
    "0 1 0 3 0 0 6 0 0 9 0 0\n0 1 0 4 0 0 8 0 0 12 0 0\n0 1 0 5 0 0 10 0 0 15 0 0\n";

static mlr_test_temp bvh_file;

/* ---- the allocation sweep ------------------------------------------------------------------ */

/* One call of the function under test; ta->fail_at is the index of the allocation of that
 * call to fail (a call that first makes a handle disarms the allocator for it, then arms it
 * for the call: arm()). */
typedef mlr_status (*alloc_call)(mlr_test_allocator *ta, mlr_diag *d);

typedef struct alloc_case {
    const char *what; /* the name every message must contain */
    alloc_call call;
} alloc_case;

static size_t disarm(mlr_test_allocator *ta)
{
    const size_t k = ta->fail_at;
    ta->fail_at = SIZE_MAX;
    return k;
}

static void arm(mlr_test_allocator *ta, size_t k) { ta->fail_at = ta->n_calls + k; }

static mlr_status band_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_band *b = NULL;
    const mlr_status s = mlr_band_create(8, 2, &ta->base, &b, d);
    mlr_band_destroy(b);
    return s;
}

static mlr_status band_inverse_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const double ab[6] = {2, -1, 2, -1, 2, 0};
    const size_t k = disarm(ta);
    mlr_band *b = NULL;
    ck_assert_int_eq(mlr_band_create(3, 1, &ta->base, &b, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_factor(b, ab, 2, NULL), MLR_OK);
    double var[3];
    arm(ta, k);
    const mlr_status s = mlr_band_inverse_diagonal(b, var, 3, d);
    mlr_band_destroy(b);
    return s;
}

static mlr_status bvh_read_memory_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_motion *m = NULL;
    const mlr_status s = mlr_bvh_read_memory(three_bvh, strlen(three_bvh), &ta->base, &m, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_read_memory_mt_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_motion *m = NULL;
    const mlr_status s =
        mlr_bvh_read_memory_mt(three_bvh, strlen(three_bvh), 2, &ta->base, &m, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_read_memory_opts_call(mlr_test_allocator *ta, mlr_diag *d)
{
    /* lenient, keeping a truncated clip: 6 frames declared, 5 there */
    static const char cut[] = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 "
                              "Xposition Yposition Zposition\n  End Site\n  {\n    OFFSET 0 1 "
                              "0\n  }\n}\nMOTION\nFrames: 6\nFrame Time: 0.04\n0 0 0\n1 0 0\n"
                              "2 0 0\n3 0 0\n4 0 0\n";
    const mlr_bvh_read_option o[2] = {{MLR_BVH_OPT_STRICT, 0}, {MLR_BVH_OPT_KEEP_TRUNCATED, 1}};
    mlr_motion *m = NULL;
    mlr_bvh_warnings w;
    const mlr_status s =
        mlr_bvh_read_memory_opts(cut, strlen(cut), 1, o, 2, &ta->base, &m, &w, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_read_file_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_motion *m = NULL;
    const mlr_status s = mlr_bvh_read_file(bvh_file.path, &ta->base, &m, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_read_file_mt_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_motion *m = NULL;
    const mlr_status s = mlr_bvh_read_file_mt(bvh_file.path, 2, &ta->base, &m, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_read_file_opts_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const mlr_bvh_read_option o[1] = {{MLR_BVH_OPT_STRICT, 0}};
    mlr_motion *m = NULL;
    mlr_bvh_warnings w;
    const mlr_status s = mlr_bvh_read_file_opts(bvh_file.path, 1, o, 1, &ta->base, &m, &w, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_write_file_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const size_t k = disarm(ta);
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(three_bvh, strlen(three_bvh), &ta->base, &m, NULL),
                     MLR_OK);
    arm(ta, k);
    const mlr_status s = mlr_bvh_write_file(m, bvh_file.path, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status motion_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_motion *m = NULL;
    const mlr_status s = mlr_motion_create(FJ, f_names, f_parents, f_offsets, NULL, FE,
                                           f_end_parents, f_end_offsets, 4, 1.0 / 60.0,
                                           &ta->base, &m, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status motion_copy_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const size_t k = disarm(ta);
    mlr_motion *m = NULL, *c = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(three_bvh, strlen(three_bvh), &ta->base, &m, NULL),
                     MLR_OK);
    arm(ta, k);
    const mlr_status s = mlr_motion_copy_frames(m, 1, 3, &c, d);
    mlr_motion_destroy(c);
    mlr_motion_destroy(m);
    return s;
}

enum { BIG_J = 300 }; /* above forward kinematics' stack scratch */
static int32_t big_parents[BIG_J];
static double big_offsets[3 * BIG_J], big_rot[4 * BIG_J], big_wp[3 * BIG_J];

static mlr_status fk_arrays_call(mlr_test_allocator *ta, mlr_diag *d)
{
    return mlr_fk_arrays(1, BIG_J, big_parents, big_offsets, NULL, big_rot, 0, NULL, NULL,
                         big_wp, NULL, &ta->base, d);
}

static mlr_status fk_motion_call(mlr_test_allocator *ta, mlr_diag *d)
{
    static const char *names[BIG_J];
    static char buf[BIG_J][8];
    for (size_t j = 0; j < BIG_J; j++) {
        snprintf(buf[j], sizeof buf[j], "J%zu", j);
        names[j] = buf[j];
    }
    const size_t k = disarm(ta);
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_motion_create(BIG_J, names, big_parents, big_offsets, NULL, 0, NULL,
                                       NULL, 1, 1.0 / 30.0, &ta->base, &m, NULL),
                     MLR_OK);
    arm(ta, k);
    const mlr_status s = mlr_fk_motion(m, 0, 1, big_wp, NULL, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status rig_body_height_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double h;
    return mlr_rig_body_height(FN, FJ, f_wp, MLR_AXIS_Y, &h, &ta->base, d);
}

static mlr_status rig_up_axis_call(mlr_test_allocator *ta, mlr_diag *d)
{
    /* no names: no feet, the floor rule (its own allocation) */
    const mlr_rig r = {FJ, f_parents, f_offsets, NULL, 0, NULL, 0, NULL, NULL};
    mlr_up_guess g;
    return mlr_rig_up_axis(&r, FN, f_wp, &g, &ta->base, d);
}

static mlr_status rig_up_axis_feet_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_up_guess g;
    return mlr_rig_up_axis(&f_rig, FN, f_wp, &g, &ta->base, d);
}

static mlr_status trim_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_trim_lead lead;
    return mlr_trim_lead_in(&f_rig, FN, f_root, f_rot, NULL, MLR_AXIS_Y, &lead, &ta->base, d);
}

static mlr_status find_feet_call(mlr_test_allocator *ta, mlr_diag *d)
{
    int32_t j[8], e[8];
    size_t n;
    return mlr_contacts_find_feet(&f_rig, FN, f_wp, MLR_AXIS_Y, 4, j, e, &n, &ta->base, d);
}

static mlr_status contacts_detect_call(mlr_test_allocator *ta, mlr_diag *d)
{
    uint8_t c[FN * 2];
    return mlr_contacts_detect(&f_rig, 60.0, MLR_AXIS_Y, FN, f_wp, f_wr, 2, f_points, f_no_end,
                               NULL, 0, c, &ta->base, d);
}

static mlr_status cleanup_floor_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double h;
    return mlr_cleanup_floor_height(&f_rig, FN, f_root, f_rot, NULL, 2, f_points, f_no_end,
                                    f_contacts, MLR_AXIS_Y, 0.5, &h, &ta->base, d);
}

static mlr_status cleanup_contacts_call(mlr_test_allocator *ta, mlr_diag *d)
{
    static double oroot[3 * FN], orot[4 * FJ * FN];
    mlr_cleanup_report rep;
    return mlr_cleanup_contacts(&f_rig, FN, 60.0, MLR_AXIS_Y, f_root, f_rot, NULL, f_root,
                                f_rot, NULL, 2, f_points, f_no_end, f_contacts, NULL, 0, oroot,
                                orot, &rep, &ta->base, d);
}

static mlr_status guards_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_guards *g = NULL;
    const mlr_status s =
        mlr_guards_create(&f_rig, 60.0, FN, f_root, f_rot, NULL, NULL, 0, &ta->base, &g, d);
    mlr_guards_destroy(g);
    return s;
}

static mlr_status guards_apply_call(mlr_test_allocator *ta, mlr_diag *d)
{
    static double root[3 * FN], rot[4 * FJ * FN];
    const size_t k = disarm(ta);
    mlr_guards *g = NULL;
    ck_assert_int_eq(
        mlr_guards_create(&f_rig, 60.0, FN, f_root, f_rot, NULL, NULL, 0, &ta->base, &g, NULL),
        MLR_OK);
    memcpy(root, f_root, sizeof root);
    memcpy(rot, f_rot, sizeof rot);
    const double alpha[1] = {2.0};
    arm(ta, k);
    mlr_guards_report rep;
    const mlr_status s = mlr_guards_apply(g, alpha, 1, f_root, f_rot, NULL, root, rot, NULL,
                                          NULL, 0, &rep, d);
    mlr_guards_destroy(g);
    return s;
}

static mlr_status limits_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const mlr_limits_clip clip = {FN, f_rot, NULL};
    mlr_limits *l = NULL;
    const mlr_status s = mlr_limits_create(&f_rig, &clip, 1, NULL, 0, &ta->base, &l, d);
    mlr_limits_destroy(l);
    return s;
}

static mlr_status limits_apply_call(mlr_test_allocator *ta, mlr_diag *d)
{
    static double rot[4 * FJ * FN];
    const mlr_limits_clip clip = {FN, f_rot, NULL};
    const size_t k = disarm(ta);
    mlr_limits *l = NULL;
    ck_assert_int_eq(mlr_limits_create(&f_rig, &clip, 1, NULL, 0, &ta->base, &l, NULL), MLR_OK);
    arm(ta, k);
    const mlr_status s = mlr_limits_apply(l, FN, f_rot, rot, NULL, 0, NULL, 0, d);
    mlr_limits_destroy(l);
    return s;
}

static mlr_status layers_decompose_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_layers *L = NULL;
    const mlr_status s = mlr_layers_decompose(FN, FJ, f_root, f_rot, NULL, 0, &ta->base, &L, d);
    mlr_layers_destroy(L);
    return s;
}

static mlr_status lgs_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const double t[3] = {0.0, 2.0, 4.0};
    mlr_lgs *g = NULL;
    const mlr_status s =
        mlr_lgs_create(5, 2, 1.0, 1.0, t, 3, MLR_LGS_BANDED, &ta->base, &g, d);
    mlr_lgs_destroy(g);
    return s;
}

static mlr_status resample_call(mlr_test_allocator *ta, mlr_diag *d)
{
    enum { M = 71 };
    static double ro[3 * M], qo[4 * FJ * M], var[M];
    return mlr_resample_arrays(FN, FJ, 0, f_root, f_rot, NULL, NULL, M, MLR_RESAMPLE_AUTO, 1.0,
                               0, ro, qo, NULL, var, &ta->base, d);
}

static mlr_status resample_open_end_call(mlr_test_allocator *ta, mlr_diag *d)
{
    /* a time map past the last output frame: the hidden frame's grid */
    enum { M = 30 };
    static double t[FN], ro[3 * M], qo[4 * FJ * M], var[M];
    for (size_t i = 0; i < FN; i++)
        t[i] = 0.65 * (double)i;
    return mlr_resample_arrays(FN, FJ, 0, f_root, f_rot, NULL, t, M, 1.0, 1.0,
                               MLR_RESAMPLE_OPEN_END, ro, qo, NULL, var, &ta->base, d);
}

static mlr_status timewarp_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double t[FN];
    return mlr_timewarp_map(FN, FJ, f_root, f_rot, NULL, 1.0, 0.5, 4.0, 40, 0, t, &ta->base, d);
}

static mlr_status stream_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_stream *st = NULL;
    const mlr_status s = mlr_stream_create(2, 1, 0, 1.0, 1.0, 4, &ta->base, &st, d);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_layered_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_stream *st = NULL;
    const mlr_status s =
        mlr_stream_create_layered(2, 1, 1, 1.0, 1.0, 10.0, 1.0, 4, &ta->base, &st, d);
    mlr_stream_destroy(st);
    return s;
}

/* 40 points in 3 dimensions, on a spiral */
enum { XN = 40, XD = 3 };
static double xs[XN * XD];

static void points_init(void)
{
    for (size_t i = 0; i < XN; i++) {
        xs[XD * i] = cos(0.7 * (double)i);
        xs[XD * i + 1] = sin(0.7 * (double)i);
        xs[XD * i + 2] = 0.05 * (double)i;
    }
}

static mlr_status kmeans_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_kmeans *km = NULL;
    const mlr_status s = mlr_kmeans_create(3, XD, &ta->base, &km, d);
    mlr_kmeans_destroy(km);
    return s;
}

static mlr_status kmeans_fit_call(mlr_test_allocator *ta, mlr_diag *d)
{
    const size_t k = disarm(ta);
    mlr_kmeans *km = NULL;
    ck_assert_int_eq(mlr_kmeans_create(3, XD, &ta->base, &km, NULL), MLR_OK);
    arm(ta, k);
    int32_t labels[XN];
    const mlr_status s = mlr_kmeans_fit(km, xs, XN, XD, NULL, 0, labels, d);
    mlr_kmeans_destroy(km);
    return s;
}

static mlr_status som_create_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_som *som = NULL;
    const mlr_status s = mlr_som_create(3, 4, XD, &ta->base, &som, d);
    mlr_som_destroy(som);
    return s;
}

static mlr_status som_train_with(mlr_test_allocator *ta, int mode, mlr_diag *d)
{
    const size_t k = disarm(ta);
    mlr_som *som = NULL;
    ck_assert_int_eq(mlr_som_create(3, 4, XD, &ta->base, &som, NULL), MLR_OK);
    arm(ta, k);
    const mlr_status s = mlr_som_train(som, xs, XN, XD, 2, mode, d);
    mlr_som_destroy(som);
    return s;
}

static mlr_status som_train_batch_call(mlr_test_allocator *ta, mlr_diag *d)
{
    return som_train_with(ta, MLR_SOM_BATCH, d);
}

static mlr_status som_train_online_call(mlr_test_allocator *ta, mlr_diag *d)
{
    return som_train_with(ta, MLR_SOM_ONLINE, d);
}

static mlr_status som_import_call(mlr_test_allocator *ta, mlr_diag *d)
{
    mlr_som *som = NULL;
    ck_assert_int_eq(mlr_som_create(3, 4, XD, NULL, &som, NULL), MLR_OK);
    ck_assert_int_eq(mlr_som_train(som, xs, XN, XD, 1, MLR_SOM_BATCH, NULL), MLR_OK);
    const size_t size = mlr_som_export_size(som);
    void *blob = malloc(size);
    ck_assert_int_eq(mlr_som_export(som, blob, size, NULL), MLR_OK);
    mlr_som_destroy(som);
    som = NULL;
    const mlr_status s = mlr_som_import(blob, size, &ta->base, &som, d);
    mlr_som_destroy(som);
    free(blob);
    return s;
}

/* a 6 x 5 regular lattice in [0, 1] x [0, 2] and one of its points moved off it */
enum { LR = 6, LC = 5 };

static mlr_status grbf_basis_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double out[XN * (XN + 4)];
    return mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1.0, xs, XN, XD, xs, XN, XD, XD, 1, 1, out,
                          XN + 4, &ta->base, d);
}

static mlr_status grbf_eval_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double coef[(XN + 4) * 2], out[XN * 2];
    for (size_t i = 0; i < (XN + 4) * 2; i++)
        coef[i] = 0.01 * (double)i;
    return mlr_grbf_eval(MLR_GRBF_GAUSSIAN, 1.0, xs, XN, XD, coef, 2, 2, xs, XN, XD, XD, 1, out,
                         2, &ta->base, d);
}

static mlr_status grbf_lattice_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double lx[LR], ly[LC], y[LR * LC], coef[LR * LC + 3];
    for (size_t r = 0; r < LR; r++)
        lx[r] = (double)r / (LR - 1);
    for (size_t c = 0; c < LC; c++)
        ly[c] = 2.0 * (double)c / (LC - 1);
    for (size_t u = 0; u < LR * LC; u++)
        y[u] = sin(0.3 * (double)u);
    return mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 1.0, lx, LR, ly, LC, y, 1, 1, 1, coef, 1,
                                &ta->base, d);
}

static const alloc_case alloc_cases[] = {
    {"band create", band_create_call},
    {"band inverse_diagonal", band_inverse_call},
    {"bvh read", bvh_read_memory_call},
    {"bvh read", bvh_read_memory_mt_call},
    {"bvh read", bvh_read_memory_opts_call},
    {"bvh read", bvh_read_file_call},
    {"bvh read", bvh_read_file_mt_call},
    {"bvh read", bvh_read_file_opts_call},
    {"bvh write", bvh_write_file_call},
    {"motion create", motion_create_call},
    {"motion copy", motion_copy_call},
    {"fk", fk_arrays_call},
    {"fk", fk_motion_call},
    {"body_height", rig_body_height_call},
    {"up axis", rig_up_axis_call},
    {"up axis", rig_up_axis_feet_call},
    {"lead_in", trim_call},
    {"find_feet", find_feet_call},
    {"contacts", contacts_detect_call},
    {"floor_height", cleanup_floor_call},
    {"cleanup", cleanup_contacts_call},
    {"guards", guards_create_call},
    {"guards", guards_apply_call},
    {"limits", limits_create_call},
    {"limits", limits_apply_call},
    {"decompose", layers_decompose_call},
    {"lgs", lgs_create_call},
    {"resample", resample_call},
    {"resample", resample_open_end_call},
    {"timewarp", timewarp_call},
    {"stream", stream_call},
    {"stream", stream_layered_call},
    {"kmeans create", kmeans_create_call},
    {"kmeans fit", kmeans_fit_call},
    {"som create", som_create_call},
    {"som train", som_train_batch_call},
    {"som train", som_train_online_call},
    {"som import", som_import_call},
    {"grbf basis", grbf_basis_call},
    {"grbf eval", grbf_eval_call},
    {"grbf fit_lattice", grbf_lattice_call},
};

enum { MAX_ALLOCATIONS = 400 };

/* Fails allocation k of the call for k = 0, 1, ... until the call succeeds; returns how many
 * allocations it made. Every failure: MLR_E_NO_MEMORY, "out of memory" and the function's
 * name in the message (the same status with a NULL diag), no block left. */
static size_t every_allocation_fails_with_a_message(const alloc_case *c)
{
    for (size_t k = 0; k < MAX_ALLOCATIONS; k++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        mlr_diag d;
        memset(&d, 0, sizeof d);
        const mlr_status s = c->call(&ta, &d);
        ck_assert_msg(ta.live_blocks == 0, "%s, allocation %zu: %zu blocks leaked", c->what, k,
                      ta.live_blocks);
        if (s == MLR_OK)
            return k;
        ck_assert_msg(s == MLR_E_NO_MEMORY, "%s, allocation %zu: status %s", c->what, k,
                      mlr_status_name(s));
        ck_assert_msg(strstr(d.message, "out of memory") && strstr(d.message, c->what),
                      "%s, allocation %zu: '%s'", c->what, k, d.message);
        mlr_test_allocator_init(&ta, k);
        ck_assert_int_eq(c->call(&ta, NULL), MLR_E_NO_MEMORY);
        ck_assert_uint_eq(ta.live_blocks, 0);
    }
    ck_abort_msg("%s: still failing after %d allocations", c->what, MAX_ALLOCATIONS);
    return 0;
}

START_TEST(every_allocation_of_every_allocating_function_fails_with_a_message)
{
    figure_init();
    contacts_init();
    points_init();
    for (size_t j = 0; j < BIG_J; j++)
        big_parents[j] = (int32_t)j - 1, big_rot[4 * j] = 1.0;
    mlr_test_temp_write(&bvh_file, "three.bvh", three_bvh, strlen(three_bvh));
    const alloc_case *c = &alloc_cases[_i];
    const size_t n = every_allocation_fails_with_a_message(c);
    ck_assert_msg(n > 0, "%s (case %d): made no allocation, the sweep tests nothing", c->what,
                  _i);
    mlr_test_temp_remove(&bvh_file);
}
END_TEST

/* ---- size overflows reachable from the arguments ------------------------------------------- */

typedef mlr_status (*diag_call)(mlr_diag *d);

typedef struct diag_case {
    const char *name;
    diag_call call;
    mlr_status want;
    const char *says; /* a substring of the message */
} diag_case;

static mlr_status overflow_band(mlr_diag *d)
{
    mlr_band *b = NULL;
    return mlr_band_create(SIZE_MAX / 2, 3, NULL, &b, d);
}

static mlr_status overflow_kmeans(mlr_diag *d)
{
    mlr_kmeans *km = NULL;
    return mlr_kmeans_create(SIZE_MAX / 4, 16, NULL, &km, d);
}

static mlr_status overflow_som(mlr_diag *d)
{
    mlr_som *som = NULL;
    return mlr_som_create(SIZE_MAX / 8, 8, 4, NULL, &som, d);
}

static mlr_status overflow_stream(mlr_diag *d)
{
    mlr_stream *st = NULL;
    return mlr_stream_create(SIZE_MAX / 8, 1, 0, 1.0, 1.0, 2, NULL, &st, d);
}

static mlr_status overflow_lgs(mlr_diag *d)
{
    /* n_out near SIZE_MAX: the observation map's size (t of 2 positions, both 0) */
    const double t[2] = {0.0, 1.0};
    mlr_lgs *g = NULL;
    return mlr_lgs_create(SIZE_MAX / 4, 1, 0.0, 1.0, t, 2, MLR_LGS_BANDED, NULL, &g, d);
}

static mlr_status overflow_fk(mlr_diag *d)
{
    const int32_t parents[1] = {-1};
    const double offsets[3] = {0}, rot[4] = {1, 0, 0, 0};
    double wp[3];
    return mlr_fk_arrays(SIZE_MAX / 2, 1, parents, offsets, NULL, rot, 0, NULL, NULL, wp, NULL,
                         NULL, d);
}

static mlr_status overflow_body_height(mlr_diag *d)
{
    double h;
    return mlr_rig_body_height(SIZE_MAX / 2, 2, f_wp, MLR_AXIS_Y, &h, NULL, d);
}

static mlr_status overflow_resample(mlr_diag *d)
{
    double ro[6], qo[8];
    return mlr_resample_arrays(2, SIZE_MAX / 8, 0, f_root, f_rot, NULL, NULL, 2, 1.0, 1.0, 0,
                               ro, qo, NULL, NULL, NULL, d);
}

static mlr_status overflow_decompose(mlr_diag *d)
{
    mlr_layers *L = NULL;
    return mlr_layers_decompose(SIZE_MAX / 8, 4, f_root, f_rot, NULL, 0, NULL, &L, d);
}

static mlr_status overflow_grbf_basis(mlr_diag *d)
{
    double out[4];
    return mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1.0, xs, SIZE_MAX / 4, XD, xs, 1, XD, XD, 0, 1,
                          out, SIZE_MAX / 4, NULL, d);
}

static const diag_case overflow_cases[] = {
    {"band", overflow_band, MLR_E_OVERFLOW, "overflow"},
    {"kmeans", overflow_kmeans, MLR_E_OVERFLOW, "overflow"},
    {"som", overflow_som, MLR_E_OVERFLOW, "overflow"},
    {"stream", overflow_stream, MLR_E_OVERFLOW, "overflow"},
    {"lgs", overflow_lgs, MLR_E_OVERFLOW, "overflow"},
    {"fk", overflow_fk, MLR_E_OVERFLOW, "overflow"},
    {"body_height", overflow_body_height, MLR_E_OVERFLOW, "overflow"},
    {"resample", overflow_resample, MLR_E_OVERFLOW, "overflow"},
    {"decompose", overflow_decompose, MLR_E_OVERFLOW, "overflow"},
    {"grbf basis", overflow_grbf_basis, MLR_E_OVERFLOW, "overflow"},
};

static void run_diag_case(const diag_case *c)
{
    mlr_diag d;
    memset(&d, 0, sizeof d);
    const mlr_status s = c->call(&d);
    ck_assert_msg(s == c->want, "%s: status %s, expected %s ('%s')", c->name,
                  mlr_status_name(s), mlr_status_name(c->want), d.message);
    ck_assert_msg(d.message[0] != '\0', "%s: empty diag", c->name);
    ck_assert_msg(strstr(d.message, c->says), "%s: '%s' lacks '%s'", c->name, d.message,
                  c->says);
    ck_assert_int_eq(c->call(NULL), c->want);
}

START_TEST(a_size_overflow_says_what_overflowed)
{
    figure_init();
    points_init();
    run_diag_case(&overflow_cases[_i]);
}
END_TEST

static Suite *diag_alloc_suite(void)
{
    Suite *s = suite_create("diag_alloc");
    TCase *tc = tcase_create("alloc");
    tcase_add_loop_test(tc, every_allocation_of_every_allocating_function_fails_with_a_message,
                        0, (int)MLR_COUNTOF(alloc_cases));
    tcase_add_loop_test(tc, a_size_overflow_says_what_overflowed, 0,
                        (int)MLR_COUNTOF(overflow_cases));
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return mlr_test_run(diag_alloc_suite());
}
