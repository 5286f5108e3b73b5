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
static const double f_offsets[3 * FJ] = {
    0, 0,    0,    0, 0.3,  0, 0, 0.3,   0, 0.2, 0.2, 0,     -0.2, 0.2, 0,     0.1, -0.1,
    0, -0.1, -0.1, 0, 0.55, 0, 0, -0.55, 0, 0,   0,   -0.85, 0,    0,   -0.85, 0};
static const char *const f_names[FJ] = {"Hips",      "Spine",     "Head",       "LeftArm",
                                        "RightArm",  "LeftUpLeg", "RightUpLeg", "LeftHand",
                                        "RightHand", "LeftFoot",  "RightFoot"};
static const int32_t f_end_parents[FE] = {9, 10};
static const double f_end_offsets[3 * FE] = {0, -0.05, 0.15, 0, -0.05, 0.15};
static const mlr_rig f_rig = {FJ,   f_parents, f_offsets,     f_names,      0,
                              NULL, FE,        f_end_parents, f_end_offsets};

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
    const mlr_status s = mlr_bvh_read_memory_mt(three_bvh, strlen(three_bvh), 2, &ta->base, &m, d);
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
    const mlr_status s = mlr_bvh_read_memory_opts(cut, strlen(cut), 1, o, 2, &ta->base, &m, &w, d);
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
    /* depth-first: hips, spine, head; the left leg and foot */
    static const char *const names[5] = {"Hips", "Spine", "Head", "LeftUpLeg", "LeftFoot"};
    static const int32_t parents[5] = {-1, 0, 1, 0, 3}, end_parents[2] = {2, 4};
    mlr_motion *m = NULL;
    const mlr_status s = mlr_motion_create(5, names, parents, f_offsets, NULL, 2, end_parents,
                                           f_end_offsets, 4, 1.0 / 60.0, &ta->base, &m, d);
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
    return mlr_fk_arrays(1, BIG_J, big_parents, big_offsets, NULL, big_rot, 0, NULL, NULL, big_wp,
                         NULL, &ta->base, d);
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
    ck_assert_int_eq(mlr_motion_create(BIG_J, names, big_parents, big_offsets, NULL, 0, NULL, NULL,
                                       1, 1.0 / 30.0, &ta->base, &m, NULL),
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
    return mlr_cleanup_contacts(&f_rig, FN, 60.0, MLR_AXIS_Y, f_root, f_rot, NULL, f_root, f_rot,
                                NULL, 2, f_points, f_no_end, f_contacts, NULL, 0, oroot, orot,
                                &rep, &ta->base, d);
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
    const mlr_status s =
        mlr_guards_apply(g, alpha, 1, f_root, f_rot, NULL, root, rot, NULL, NULL, 0, &rep, d);
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
    const mlr_status s = mlr_lgs_create(5, 2, 1.0, 1.0, t, 3, MLR_LGS_BANDED, &ta->base, &g, d);
    mlr_lgs_destroy(g);
    return s;
}

static mlr_status depth_first_order_call(mlr_test_allocator *ta, mlr_diag *d)
{
    static const int32_t parents[5] = {2, -1, 1, 2, 0}; /* not depth-first: needs the walk */
    int32_t order[5];
    return mlr_rig_depth_first_order(5, parents, NULL, order, &ta->base, d);
}

static mlr_status resample_call(mlr_test_allocator *ta, mlr_diag *d)
{
    enum { M = 71 };
    static double ro[3 * M], qo[4 * FJ * M], var[M];
    return mlr_resample_arrays(FN, FJ, 0, f_root, f_rot, NULL, NULL, M, MLR_RESAMPLE_AUTO, 1.0, 0,
                               ro, qo, NULL, var, &ta->base, d);
}

static mlr_status resample_open_end_call(mlr_test_allocator *ta, mlr_diag *d)
{
    /* a time map past the last output frame: the hidden frame's grid */
    enum { M = 30 };
    static double t[FN], ro[3 * M], qo[4 * FJ * M], var[M];
    for (size_t i = 0; i < FN; i++)
        t[i] = 29.5 * (double)i / (FN - 1);
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
    return mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1.0, xs, XN, XD, xs, XN, XD, XD, 1, 1, out, XN + 4,
                          &ta->base, d);
}

static mlr_status grbf_eval_call(mlr_test_allocator *ta, mlr_diag *d)
{
    double coef[(XN + 4) * 2], out[XN * 2];
    for (size_t i = 0; i < (XN + 4) * 2; i++)
        coef[i] = 0.01 * (double)i;
    return mlr_grbf_eval(MLR_GRBF_GAUSSIAN, 1.0, xs, XN, XD, coef, 2, 2, xs, XN, XD, XD, 1, out, 2,
                         &ta->base, d);
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
    {"decompose", layers_decompose_call},
    {"lgs", lgs_create_call},
    {"depth-first order", depth_first_order_call},
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
        ck_assert_msg(s == MLR_E_NO_MEMORY, "%s, allocation %zu: status %s ('%s')", c->what, k,
                      mlr_status_name(s), d.message);
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
    ck_assert_msg(n > 0, "%s (case %d): made no allocation, the sweep tests nothing", c->what, _i);
    mlr_test_temp_remove(&bvh_file);
}
END_TEST

/* ---- size overflows reachable from the arguments ------------------------------------------- */

/* The handles a refused call does not create (shared by the tables below). */
static struct {
    mlr_motion *m;
    mlr_band *band;
    mlr_lgs *lgs;
    mlr_layers *layers;
    mlr_kmeans *km;
    mlr_som *som;
    mlr_stream *st;
    mlr_guards *g;
    mlr_limits *lim;
} no;

/* Call i with sizes whose product overflows a size_t (n_overflow_calls of them). */
enum { n_overflow_calls = 8 };
static mlr_status overflow_call(int i, mlr_diag *d)
{
    static const int32_t parents[1] = {-1};
    static const double offsets[3] = {0}, rot[4] = {1, 0, 0, 0};
    double out[8], h;
    switch (i) {
    case 0:
        return mlr_band_create(SIZE_MAX / 2, 3, NULL, &no.band, d);
    case 1:
        return mlr_stream_create(SIZE_MAX / 8, 1, 0, 1.0, 1.0, 2, NULL, &no.st, d);
    case 2: { /* n_out near SIZE_MAX: the observation map's size */
        const double t[2] = {0.0, 1.0};
        return mlr_lgs_create(SIZE_MAX / 4, 1, 0.0, 1.0, t, 2, MLR_LGS_BANDED, NULL, &no.lgs, d);
    }
    case 3:
        return mlr_fk_arrays(SIZE_MAX / 2, 1, parents, offsets, NULL, rot, 0, NULL, NULL, out,
                             NULL, NULL, d);
    case 4:
        return mlr_rig_body_height(SIZE_MAX / 2, 2, f_wp, MLR_AXIS_Y, &h, NULL, d);
    case 5:
        return mlr_resample_arrays(2, SIZE_MAX / 8, 0, f_root, f_rot, NULL, NULL, 2, 1.0, 1.0, 0,
                                   out, out, NULL, NULL, NULL, d);
    case 6:
        return mlr_layers_decompose(SIZE_MAX / 8, 4, f_root, f_rot, NULL, 0, NULL, &no.layers, d);
    case 7:
        return mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1.0, xs, SIZE_MAX / 4, XD, xs, 1, XD, XD, 0, 1,
                              out, SIZE_MAX / 4, NULL, d);
    default:
        break;
    }
    ck_abort_msg("no call %d", i);
    return MLR_OK;
}

/* Call i of a table refuses with want (or any error when want is MLR_OK) and a message that
 * contains says (any message when says is NULL); the same status with a NULL diag. */
static void refused(mlr_status (*call)(int, mlr_diag *), int i, mlr_status want, const char *says)
{
    mlr_diag d;
    memset(&d, 0, sizeof d);
    const mlr_status s = call(i, &d);
    ck_assert_msg(want == MLR_OK ? s < 0 : s == want, "call %d: status %s ('%s')", i,
                  mlr_status_name(s), d.message);
    ck_assert_msg(d.message[0] != '\0', "call %d: %s with an empty diag", i, mlr_status_name(s));
    ck_assert_msg(!says || strstr(d.message, says), "call %d: '%s' lacks '%s'", i, d.message,
                  says);
    ck_assert_int_eq(call(i, NULL), s);
}

START_TEST(a_size_overflow_says_what_overflowed)
{
    figure_init();
    points_init();
    refused(overflow_call, _i, MLR_E_OVERFLOW, "overflow");
}
END_TEST

/* ---- a NULL required pointer or a zero size: a status and a message ------------------------ */

static double buf_a[4096], buf_b[4096];
static int32_t ibuf[64];

/* Call i of the public functions with one required pointer NULL (or a size 0 where that is
 * refused); the other arguments are valid where it matters. n_null_calls of them. */
enum { n_null_calls = 87 };
static mlr_status null_call(int i, mlr_diag *d)
{
    double *a = buf_a, *b = buf_b;
    int32_t *ij = ibuf;
    size_t n;
    mlr_up_guess up;
    mlr_trim_lead lead;
    mlr_euler_order order;
    switch (i) {
    case 0:
        return mlr_band_create(4, 1, NULL, NULL, d);
    case 1:
        return mlr_band_factor(NULL, a, 2, d);
    case 2:
        return mlr_band_solve(NULL, a, 1, 1, d);
    case 3:
        return mlr_band_inverse_diagonal(NULL, a, 3, d);
    case 4:
        return mlr_bvh_read_memory(NULL, 10, NULL, &no.m, d);
    case 5:
        return mlr_bvh_read_memory(three_bvh, strlen(three_bvh), NULL, NULL, d);
    case 6:
        return mlr_bvh_read_file(NULL, NULL, &no.m, d);
    case 7:
        return mlr_bvh_read_memory_mt(NULL, 10, 2, NULL, &no.m, d);
    case 8:
        return mlr_bvh_read_file_mt(NULL, 2, NULL, &no.m, d);
    case 9:
        return mlr_bvh_read_memory_opts(NULL, 10, 1, NULL, 0, NULL, &no.m, NULL, d);
    case 10:
        return mlr_bvh_read_file_opts(NULL, 1, NULL, 0, NULL, &no.m, NULL, d);
    case 11:
        return mlr_bvh_write(NULL, NULL, NULL, d);
    case 12:
        return mlr_bvh_write_memory(NULL, NULL, 0, &n, d);
    case 13:
        return mlr_bvh_write_file(NULL, "x.bvh", d);
    case 14:
        return mlr_cleanup_floor_height(NULL, FN, f_root, f_rot, NULL, 2, f_points, f_no_end,
                                        f_contacts, 1, 0.5, a, NULL, d);
    case 15:
        return mlr_cleanup_contacts(NULL, FN, 60.0, 1, f_root, f_rot, NULL, NULL, NULL, NULL, 2,
                                    f_points, f_no_end, f_contacts, NULL, 0, a, b, NULL, NULL, d);
    case 16:
        return mlr_contacts_find_feet(NULL, FN, f_wp, 1, 4, ij, ij + 8, &n, NULL, d);
    case 17:
        return mlr_contacts_detect(NULL, 60.0, 1, FN, f_wp, f_wr, 2, f_points, f_no_end, NULL, 0,
                                   (uint8_t *)a, NULL, d);
    case 18:
        return mlr_fk_arrays(1, 2, NULL, a, NULL, a, 0, NULL, NULL, b, NULL, NULL, d);
    case 19:
        return mlr_fk_motion(NULL, 0, 1, a, NULL, d);
    case 20:
        return mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1.0, NULL, 4, 2, a, 4, 2, 2, 0, 1, b, 4, NULL,
                              d);
    case 21:
        return mlr_grbf_eval(MLR_GRBF_THIN_PLATE, 1.0, NULL, 4, 2, a, 1, 1, a, 4, 2, 2, 1, b, 1,
                             NULL, d);
    case 22:
        return mlr_grbf_fit_lattice(MLR_GRBF_THIN_PLATE, 1.0, NULL, 3, a, 3, a, 1, 1, 1, b, 1,
                                    NULL, d);
    case 23:
        return mlr_guards_create(NULL, 60.0, FN, f_root, f_rot, NULL, NULL, 0, NULL, &no.g, d);
    case 24:
        return mlr_guards_set_contacts(NULL, 0, NULL, NULL, NULL, d);
    case 25:
        return mlr_guards_set_limits(NULL, NULL, d);
    case 26:
        return mlr_guards_apply(NULL, a, 1, NULL, NULL, NULL, a, b, NULL, NULL, 0, NULL, d);
    case 27:
        return mlr_ik_two_bone(1, NULL, a, a, a, a, 1.0, a, b, d);
    case 28:
        return mlr_ik_leg_chain(NULL, 9, ij, ij + 1, d);
    case 29:
        return mlr_ik_bend_axis_local(1, 3, NULL, a, 0, 1, 2, b, d);
    case 30:
        return mlr_ik_rotate_to(1, 2, NULL, a, b, 1, a, d);
    case 31:
        return mlr_ik_apply_leg(1, 3, NULL, a, a, a, 0, 1, 2, a, a, d);
    case 32:
        return mlr_kmeans_create(3, 2, NULL, NULL, d);
    case 33:
        return mlr_kmeans_set(NULL, 1, 1.0, d);
    case 34:
        return mlr_kmeans_fit(NULL, a, 4, 2, NULL, 0, ij, d);
    case 35:
        return mlr_kmeans_predict(NULL, a, 4, 2, ij, NULL, d);
    case 36:
        return mlr_kmeans_set_centers(NULL, a, 2, d);
    case 37:
        return mlr_layers_decompose(8, 2, NULL, NULL, NULL, 0, NULL, &no.layers, d);
    case 38:
        return mlr_layers_repair(NULL, 0, 1, a, 3, b, 8, &n, d);
    case 39:
        return mlr_layers_synthesize(NULL, 0, 1, NULL, 0, a, 3, b, 8, d);
    case 40:
        return mlr_layers_reconstruct(NULL, 0, 1, a, 3, b, 8, d);
    case 41:
        return mlr_lgs_create(5, 2, 1.0, 1.0, NULL, 5, MLR_LGS_BANDED, NULL, NULL, d);
    case 42:
        return mlr_lgs_solve(NULL, a, 1, 1, b, 1, d);
    case 43:
        return mlr_lgs_solve_mt(NULL, a, 1, 1, b, 1, 2, d);
    case 44:
        return mlr_lgs_variance(NULL, a, 5, d);
    case 45:
        return mlr_limits_create(NULL, NULL, 0, NULL, 0, NULL, &no.lim, d);
    case 46:
        return mlr_limits_set_range(NULL, 0, NULL, d);
    case 47:
        return mlr_limits_apply(NULL, 1, a, b, NULL, 0, NULL, 0, d);
    case 48:
        return mlr_motion_create(3, NULL, ij, a, NULL, 0, NULL, NULL, 1, 0.1, NULL, &no.m, d);
    case 49:
        return mlr_motion_copy_frames(NULL, 0, 1, &no.m, d);
    case 50:
        return mlr_quat_normalize_array(NULL, 1, (mlr_quat *)a, d);
    case 51:
        return mlr_quat_exp_array(NULL, 1, (mlr_quat *)a, d);
    case 52:
        return mlr_quat_log_array(NULL, 1, (mlr_vec3 *)a, d);
    case 53:
        return mlr_quat_slerp_array(NULL, (const mlr_quat *)a, b, 1, (mlr_quat *)a, d);
    case 54:
        return mlr_quat_from_euler_array(NULL, 1, MLR_EULER_XYZ, (mlr_quat *)a, d);
    case 55:
        return mlr_quat_to_euler_array(NULL, 1, MLR_EULER_XYZ, a, d);
    case 56:
        return mlr_euler_order_parse(NULL, &order, d);
    case 57:
        return mlr_resample_n_out(10, 30.0, 60.0, 0, NULL, d);
    case 58:
        return mlr_resample_rate_map(10, 30.0, 60.0, 0, NULL, &n, d);
    case 59:
        return mlr_timemap_validate(NULL, 10, 10, 0, d);
    case 60:
        return mlr_resample_arrays(4, 1, 0, NULL, a, NULL, NULL, 8, 1.0, 1.0, 0, b, b, NULL, NULL,
                                   NULL, d);
    case 61:
        return mlr_slerp_resample_arrays(4, 1, 0, NULL, a, NULL, NULL, 8, 0, b, b, NULL, d);
    case 62:
        return mlr_timewarp_speed(10, 1, NULL, NULL, NULL, 1.0, a, d);
    case 63:
        return mlr_timewarp_map(10, 1, NULL, NULL, NULL, 1.0, 0.5, 4.0, 10, 0, a, NULL, d);
    case 64:
        return mlr_rig_check(NULL, d);
    case 65:
        return mlr_rig_find_point(NULL, "Hips", ij, ij + 1, d);
    case 66:
        return mlr_rig_point_positions(NULL, 1, a, a, 1, ij, ij, b, d);
    case 67:
        return mlr_rig_body_height(1, 1, NULL, 1, a, NULL, d);
    case 68:
        return mlr_rig_body_translation_joint(NULL, 1, a, NULL, ij, d);
    case 69:
        return mlr_rig_up_axis(NULL, 1, a, &up, NULL, d);
    case 70:
        return mlr_som_create(3, 3, 2, NULL, NULL, d);
    case 71:
        return mlr_som_set(NULL, 1, 1.0, d);
    case 72:
        return mlr_som_init_random(NULL, a, 4, 2, d);
    case 73:
        return mlr_som_train(NULL, a, 4, 2, 1, MLR_SOM_BATCH, d);
    case 74:
        return mlr_som_bmu(NULL, a, 4, 2, ij, NULL, NULL, d);
    case 75:
        return mlr_som_errors(NULL, a, 4, 2, a, b, d);
    case 76:
        return mlr_som_set_codebook(NULL, a, 2, d);
    case 77:
        return mlr_som_export(NULL, a, 64, d);
    case 78:
        return mlr_som_import(NULL, 64, NULL, &no.som, d);
    case 79:
        return mlr_stream_create(1, 1, 0, 1.0, 1.0, 2, NULL, NULL, d);
    case 80:
        return mlr_stream_create_layered(1, 1, 0, 1.0, 1.0, 10.0, 1.0, 2, NULL, NULL, d);
    case 81:
        return mlr_stream_push(NULL, a, 7, b, 7, &n, d);
    case 82:
        return mlr_stream_flush(NULL, a, 7, &n, d);
    case 83:
        return mlr_stream_set_alpha(NULL, 1.0, a, 1, d);
    case 84:
        return mlr_stream_set_limits(NULL, NULL, d);
    case 85:
        return mlr_trim_lead_in(NULL, FN, f_root, f_rot, NULL, 1, &lead, NULL, d);
    case 86:
        return mlr_rig_depth_first_order(2, NULL, NULL, NULL, NULL, d);
    default:
        break;
    }
    ck_abort_msg("no call %d", i);
    return MLR_OK;
}

START_TEST(a_null_required_pointer_leaves_a_message)
{
    figure_init();
    contacts_init();
    refused(null_call, _i, MLR_OK, "NULL");
}
END_TEST

/* Call i with a size 0 that the function refuses (n_zero_calls of them). */
enum { n_zero_calls = 14 };
static mlr_status zero_call(int i, mlr_diag *d)
{
    double *a = buf_a, *b = buf_b;
    double h;
    size_t n;
    switch (i) {
    case 0:
        return mlr_band_create(0, 0, NULL, &no.band, d);
    case 1:
        return mlr_lgs_create(0, 2, 1.0, 1.0, NULL, 0, MLR_LGS_BANDED, NULL, &no.lgs, d);
    case 2:
        return mlr_kmeans_create(0, 2, NULL, &no.km, d);
    case 3:
        return mlr_kmeans_create(2, 0, NULL, &no.km, d);
    case 4:
        return mlr_som_create(0, 3, 2, NULL, &no.som, d);
    case 5:
        return mlr_som_create(3, 3, 0, NULL, &no.som, d);
    case 6:
        return mlr_stream_create(0, 0, 0, 1.0, 1.0, 2, NULL, &no.st, d);
    case 7:
        return mlr_motion_create(0, f_names, f_parents, f_offsets, NULL, 0, NULL, NULL, 1, 0.1,
                                 NULL, &no.m, d);
    case 8:
        return mlr_rig_body_height(0, 2, a, 1, &h, NULL, d);
    case 9:
        return mlr_resample_arrays(0, 1, 0, a, a, NULL, NULL, 8, 1.0, 1.0, 0, b, b, NULL, NULL,
                                   NULL, d);
    case 10:
        return mlr_resample_n_out(0, 30.0, 60.0, 0, &n, d);
    case 11:
        return mlr_grbf_basis(MLR_GRBF_THIN_PLATE, 1.0, a, 0, 2, a, 4, 2, 2, 0, 1, b, 4, NULL, d);
    case 12:
        return mlr_layers_decompose(0, 2, NULL, a, NULL, 0, NULL, &no.layers, d);
    case 13:
        return mlr_som_train(NULL, a, 0, 2, 1, MLR_SOM_BATCH, d);
    default:
        break;
    }
    ck_abort_msg("no call %d", i);
    return MLR_OK;
}

START_TEST(a_refused_zero_size_leaves_a_message) { refused(zero_call, _i, MLR_OK, NULL); }
END_TEST

static Suite *diag_alloc_suite(void)
{
    Suite *s = suite_create("diag_alloc");
    TCase *tc = tcase_create("alloc");
    tcase_add_loop_test(tc, every_allocation_of_every_allocating_function_fails_with_a_message, 0,
                        (int)MLR_COUNTOF(alloc_cases));
    tcase_add_loop_test(tc, a_size_overflow_says_what_overflowed, 0, n_overflow_calls);
    tcase_add_loop_test(tc, a_null_required_pointer_leaves_a_message, 0, n_null_calls);
    tcase_add_loop_test(tc, a_refused_zero_size_leaves_a_message, 0, n_zero_calls);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(diag_alloc_suite()); }
