/* Every failure fills the diag: one table of bad inputs through the functions that report a
 * status, each with the status it must return and words its message must contain (the
 * argument, the element or the option it names). The options of layers, guards, limits,
 * contacts and cleanup are walked in their own suites (test_SUBJECT.c); here the shared format
 * of the option reader is checked on the layers and the BVH reader. The allocation failures
 * of every allocating function, the size overflows and the NULL arguments of every function
 * are swept in test_diag_alloc.c. */
#include "mlr_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef mlr_status (*diag_call)(mlr_diag *d);

typedef struct diag_case {
    const char *name;
    diag_call call;
    mlr_status want;
    const char *says; /* a substring of the message */
} diag_case;

static const mlr_quat unit_q = {1, 0, 0, 0}, zero_q = {0, 0, 0, 0};

/* ---- quaternions ------------------------------------------------------------------------- */

static mlr_status normalize_zero(mlr_diag *d)
{
    const mlr_quat q[3] = {unit_q, zero_q, zero_q};
    mlr_quat out[3];
    return mlr_quat_normalize_array(q, 3, out, d);
}

static mlr_status normalize_null(mlr_diag *d)
{
    mlr_quat out[1];
    return mlr_quat_normalize_array(NULL, 1, out, d);
}

static mlr_status exp_nan(mlr_diag *d)
{
    const mlr_vec3 v[2] = {{0, 0, 0}, {0.1, NAN, 0}};
    mlr_quat out[2];
    return mlr_quat_exp_array(v, 2, out, d);
}

static mlr_status log_inf(mlr_diag *d)
{
    const mlr_quat q[2] = {{INFINITY, 0, 0, 0}, unit_q};
    mlr_vec3 out[2];
    return mlr_quat_log_array(q, 2, out, d);
}

static mlr_status slerp_t_nan(mlr_diag *d)
{
    const double t[2] = {0.5, NAN};
    const mlr_quat a[2] = {unit_q, unit_q};
    mlr_quat out[2];
    return mlr_quat_slerp_array(a, a, t, 2, out, d);
}

static mlr_status slerp_b_zero(mlr_diag *d)
{
    const double t[1] = {0.5};
    mlr_quat out[1];
    return mlr_quat_slerp_array(&unit_q, &zero_q, t, 1, out, d);
}

static mlr_status from_euler_order(mlr_diag *d)
{
    const double a[3] = {0, 0, 0};
    mlr_quat out[1];
    return mlr_quat_from_euler_array(a, 1, (mlr_euler_order)9, out, d);
}

static mlr_status from_euler_nan(mlr_diag *d)
{
    const double a[6] = {0, 0, 0, 0, NAN, 0};
    mlr_quat out[2];
    return mlr_quat_from_euler_array(a, 2, MLR_EULER_ZXY, out, d);
}

static mlr_status to_euler_zero(mlr_diag *d)
{
    double out[3];
    return mlr_quat_to_euler_array(&zero_q, 1, MLR_EULER_XYZ, out, d);
}

static mlr_status order_repeated(mlr_diag *d)
{
    mlr_euler_order o;
    return mlr_euler_order_parse("XYX", &o, d);
}

static mlr_status order_short(mlr_diag *d)
{
    mlr_euler_order o;
    return mlr_euler_order_parse("XY", &o, d);
}

static mlr_status order_long(mlr_diag *d)
{
    mlr_euler_order o;
    return mlr_euler_order_parse("XYZW", &o, d);
}

/* ---- LGS ---------------------------------------------------------------------------------- */

static mlr_lgs *small_lgs(void)
{
    mlr_lgs *g = NULL;
    ck_assert_int_eq(mlr_lgs_create(5, 2, 1.0, 1.0, NULL, 5, MLR_LGS_BANDED, NULL, &g, NULL),
                     MLR_OK);
    return g;
}

static mlr_status lgs_y_nan(mlr_diag *d)
{
    mlr_lgs *g = small_lgs();
    double y[10] = {0}, x[10];
    y[2 * 2 + 1] = NAN;
    const mlr_status s = mlr_lgs_solve(g, y, 2, 2, x, 2, d);
    mlr_lgs_destroy(g);
    return s;
}

static mlr_status lgs_stride(mlr_diag *d)
{
    mlr_lgs *g = small_lgs();
    double y[10] = {0}, x[10];
    const mlr_status s = mlr_lgs_solve_mt(g, y, 1, 2, x, 2, 1, d);
    mlr_lgs_destroy(g);
    return s;
}

static mlr_status lgs_variance_count(mlr_diag *d)
{
    mlr_lgs *g = small_lgs();
    double v[5];
    const mlr_status s = mlr_lgs_variance(g, v, 4, d);
    mlr_lgs_destroy(g);
    return s;
}

static mlr_status lgs_no_memory(mlr_diag *d)
{
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    mlr_lgs *g = NULL;
    const mlr_status s = mlr_lgs_create(5, 2, 1.0, 1.0, NULL, 5, MLR_LGS_BANDED, &ta.base, &g, d);
    ck_assert_uint_eq(ta.live_blocks, 0);
    return s;
}

static mlr_status lgs_no_memory_later(mlr_diag *d)
{
    /* every allocation of create in turn: each failure says so, none leaks */
    mlr_status last = MLR_OK;
    for (size_t k = 0; k < 16; k++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, k);
        mlr_lgs *g = NULL;
        const double t[3] = {0.0, 2.0, 4.0};
        mlr_diag here = {0};
        const mlr_status s =
            mlr_lgs_create(5, 2, 1.0, 1.0, t, 3, MLR_LGS_BANDED, &ta.base, &g, &here);
        if (s == MLR_OK) {
            mlr_lgs_destroy(g);
            break;
        }
        ck_assert_int_eq(s, MLR_E_NO_MEMORY);
        ck_assert_msg(strstr(here.message, "out of memory"), "allocation %zu: '%s'", k,
                      here.message);
        ck_assert_uint_eq(ta.live_blocks, 0);
        *d = here;
        last = s;
    }
    return last;
}

/* ---- streams ------------------------------------------------------------------------------ */

static mlr_stream *small_stream(void)
{
    mlr_stream *st = NULL;
    ck_assert_int_eq(mlr_stream_create(1, 1, 0, 1.0, 1.0, 2, NULL, &st, NULL), MLR_OK);
    return st;
}

static mlr_status stream_nan(mlr_diag *d)
{
    mlr_stream *st = small_stream();
    const double f[7] = {0, 0, 0, 1, 0, NAN, 0};
    double out[7];
    size_t ready;
    const mlr_status s = mlr_stream_push(st, f, 7, out, 7, &ready, d);
    ck_assert_uint_eq(mlr_stream_n_pushed(st), 0);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_size(mlr_diag *d)
{
    mlr_stream *st = small_stream();
    const double f[7] = {0, 0, 0, 1, 0, 0, 0};
    double out[7];
    size_t ready;
    const mlr_status s = mlr_stream_push(st, f, 6, out, 7, &ready, d);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_flushed(mlr_diag *d)
{
    mlr_stream *st = small_stream();
    const double f[7] = {0, 0, 0, 1, 0, 0, 0};
    double out[7];
    size_t n;
    ck_assert_int_eq(mlr_stream_flush(st, out, 7, &n, NULL), MLR_OK);
    const mlr_status s = mlr_stream_push(st, f, 7, out, 7, &n, d);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_flush_room(mlr_diag *d)
{
    mlr_stream *st = small_stream();
    const double f[7] = {0, 0, 0, 1, 0, 0, 0};
    double out[14];
    size_t n;
    ck_assert_int_eq(mlr_stream_push(st, f, 7, out, 7, &n, NULL), MLR_OK);
    ck_assert_int_eq(mlr_stream_push(st, f, 7, out, 7, &n, NULL), MLR_OK);
    const mlr_status s = mlr_stream_flush(st, out, 7, &n, d);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_alpha_plain(mlr_diag *d)
{
    mlr_stream *st = small_stream();
    const double a[1] = {2.0};
    const mlr_status s = mlr_stream_set_alpha(st, 1.0, a, 1, d);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_alpha_nan(mlr_diag *d)
{
    mlr_stream *st = NULL;
    ck_assert_int_eq(mlr_stream_create_layered(1, 1, 0, 1.0, 1.0, 10.0, 1.0, 2, NULL, &st, NULL),
                     MLR_OK);
    const double a[1] = {NAN};
    const mlr_status s = mlr_stream_set_alpha(st, 1.0, a, 1, d);
    mlr_stream_destroy(st);
    return s;
}

static mlr_status stream_limits_null(mlr_diag *d) { return mlr_stream_set_limits(NULL, NULL, d); }

/* ---- forward kinematics -------------------------------------------------------------------- */

static mlr_status fk_parent(mlr_diag *d)
{
    const int32_t parents[3] = {-1, 0, 5};
    const double offsets[9] = {0}, rot[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    double wp[9];
    return mlr_fk_arrays(1, 3, parents, offsets, NULL, rot, 0, NULL, NULL, wp, NULL, NULL, d);
}

static mlr_status fk_trans_joint(mlr_diag *d)
{
    const int32_t parents[2] = {-1, 0}, tj[1] = {0};
    const double offsets[6] = {0}, rot[8] = {1, 0, 0, 0, 1, 0, 0, 0}, tr[3] = {0};
    double wp[6];
    return mlr_fk_arrays(1, 2, parents, offsets, NULL, rot, 1, tj, tr, wp, NULL, NULL, d);
}

static mlr_status fk_no_memory(mlr_diag *d)
{
    enum { J = 300 }; /* above the stack scratch: world rotations come from the allocator */
    int32_t *parents = malloc(J * sizeof *parents);
    double *offsets = calloc(3 * J, sizeof(double)), *rot = calloc(4 * J, sizeof(double));
    double *wp = malloc(3 * J * sizeof(double));
    for (size_t j = 0; j < J; j++)
        parents[j] = (int32_t)j - 1, rot[4 * j] = 1.0;
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 0);
    const mlr_status s =
        mlr_fk_arrays(1, J, parents, offsets, NULL, rot, 0, NULL, NULL, wp, NULL, &ta.base, d);
    ck_assert_uint_eq(ta.live_blocks, 0);
    free(parents), free(offsets), free(rot), free(wp);
    return s;
}

static const char tiny_bvh[] = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
                               "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
                               "Yrotation\n  End Site\n  {\n    OFFSET 0 1 0\n  }\n}\n"
                               "MOTION\nFrames: 2\nFrame Time: 0.04\n0 0 0 0 0 0\n1 0 0 0 0 0\n";

static mlr_status fk_motion_range(mlr_diag *d)
{
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(tiny_bvh, strlen(tiny_bvh), NULL, &m, NULL), MLR_OK);
    double wp[9];
    const mlr_status s = mlr_fk_motion(m, 1, 3, wp, NULL, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status copy_range(mlr_diag *d)
{
    mlr_motion *m = NULL, *c = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(tiny_bvh, strlen(tiny_bvh), NULL, &m, NULL), MLR_OK);
    const mlr_status s = mlr_motion_copy_frames(m, 2, 1, &c, d);
    ck_assert_ptr_null(c);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status copy_no_memory(mlr_diag *d)
{
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, SIZE_MAX);
    mlr_motion *m = NULL, *c = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(tiny_bvh, strlen(tiny_bvh), &ta.base, &m, NULL), MLR_OK);
    ta.fail_at = ta.n_calls; /* the copy's first allocation (the copy takes src's allocator) */
    const mlr_status s = mlr_motion_copy_frames(m, 0, 2, &c, d);
    ck_assert_ptr_null(c);
    mlr_motion_destroy(m);
    ck_assert_uint_eq(ta.live_blocks, 0);
    return s;
}

/* ---- banded solver ------------------------------------------------------------------------ */

static mlr_status band_create_shape(mlr_diag *d)
{
    mlr_band *b = NULL;
    return mlr_band_create(3, 3, NULL, &b, d);
}

static mlr_status band_create_overflow(mlr_diag *d)
{
    mlr_band *b = NULL;
    return mlr_band_create(SIZE_MAX / 2, 3, NULL, &b, d);
}

static mlr_status band_create_no_memory(mlr_diag *d)
{
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 1); /* the handle is allocated, the factor's storage is not */
    mlr_band *b = NULL;
    const mlr_status s = mlr_band_create(8, 2, &ta.base, &b, d);
    ck_assert_ptr_null(b);
    ck_assert_uint_eq(ta.live_blocks, 0);
    return s;
}

/* A factor call on a new 3 x 3 handle of bandwidth 1 with the given band (ldab 2). */
static mlr_status band_factor_with(const double *ab, size_t ldab, mlr_diag *d)
{
    mlr_band *b = NULL;
    ck_assert_int_eq(mlr_band_create(3, 1, NULL, &b, NULL), MLR_OK);
    const mlr_status s = mlr_band_factor(b, ab, ldab, d);
    mlr_band_destroy(b);
    return s;
}

static mlr_status band_factor_ldab(mlr_diag *d)
{
    const double ab[6] = {2, -1, 2, -1, 2, 0};
    return band_factor_with(ab, 1, d);
}

static mlr_status band_factor_singular(mlr_diag *d)
{
    const double ab[6] = {1, 1, 1, 1, 2, 0}; /* [[1 1 0] [1 1 1] [0 1 2]]: row 1's pivot is 0 */
    return band_factor_with(ab, 2, d);
}

static mlr_status band_solve_unfactored(mlr_diag *d)
{
    mlr_band *b = NULL;
    ck_assert_int_eq(mlr_band_create(3, 1, NULL, &b, NULL), MLR_OK);
    double x[3] = {1, 2, 3};
    const mlr_status s = mlr_band_solve(b, x, 1, 1, d);
    mlr_band_destroy(b);
    return s;
}

/* A solve or an inverse diagonal on a factored 3 x 3 handle (ldx 1, m 2 for the solve). */
static mlr_status band_factored_call(int inverse, size_t n, mlr_diag *d)
{
    const double ab[6] = {2, -1, 2, -1, 2, 0};
    mlr_band *b = NULL;
    ck_assert_int_eq(mlr_band_create(3, 1, NULL, &b, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_factor(b, ab, 2, NULL), MLR_OK);
    double x[6] = {0};
    const mlr_status s =
        inverse ? mlr_band_inverse_diagonal(b, x, n, d) : mlr_band_solve(b, x, 1, 2, d);
    mlr_band_destroy(b);
    return s;
}

static mlr_status band_solve_ldx(mlr_diag *d) { return band_factored_call(0, 3, d); }
static mlr_status band_inverse_n(mlr_diag *d) { return band_factored_call(1, 4, d); }

static mlr_status band_inverse_no_memory(mlr_diag *d)
{
    const double ab[6] = {2, -1, 2, -1, 2, 0};
    mlr_test_allocator ta;
    mlr_test_allocator_init(&ta, 2); /* the handle and its storage, then the workspace fails */
    mlr_band *b = NULL;
    ck_assert_int_eq(mlr_band_create(3, 1, &ta.base, &b, NULL), MLR_OK);
    ck_assert_int_eq(mlr_band_factor(b, ab, 2, NULL), MLR_OK);
    double var[3];
    const mlr_status s = mlr_band_inverse_diagonal(b, var, 3, d);
    mlr_band_destroy(b);
    ck_assert_uint_eq(ta.live_blocks, 0);
    return s;
}

/* ---- BVH writer ---------------------------------------------------------------------------- */

/* The two frames of tiny_bvh. */
static mlr_motion *tiny_motion(void)
{
    mlr_motion *m = NULL;
    ck_assert_int_eq(mlr_bvh_read_memory(tiny_bvh, strlen(tiny_bvh), NULL, &m, NULL), MLR_OK);
    return m;
}

static int sink_stop(void *user, const char *data, size_t len)
{
    (void)user, (void)data, (void)len;
    return 1;
}

static mlr_status bvh_write_null_fn(mlr_diag *d)
{
    mlr_motion *m = tiny_motion();
    const mlr_status s = mlr_bvh_write(m, NULL, NULL, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_write_sink_stops(mlr_diag *d)
{
    mlr_motion *m = tiny_motion();
    const mlr_status s = mlr_bvh_write(m, sink_stop, NULL, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_write_zero_quat(mlr_diag *d)
{
    mlr_motion *m = tiny_motion();
    double *rot = mlr_motion_rot_mut(m);
    rot[4] = rot[5] = rot[6] = rot[7] = 0.0; /* frame 1 */
    size_t len;
    const mlr_status s = mlr_bvh_write_memory(m, NULL, 0, &len, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_write_root_nan(mlr_diag *d)
{
    mlr_motion *m = tiny_motion();
    mlr_motion_root_pos_mut(m)[4] = NAN; /* frame 1, y */
    const mlr_status s = mlr_bvh_write(m, sink_stop, NULL, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_write_memory_cap(mlr_diag *d)
{
    mlr_motion *m = tiny_motion();
    char buf[16];
    size_t len;
    const mlr_status s = mlr_bvh_write_memory(m, buf, sizeof buf, &len, d);
    mlr_motion_destroy(m);
    return s;
}

static mlr_status bvh_write_memory_len(mlr_diag *d)
{
    mlr_motion *m = tiny_motion();
    const mlr_status s = mlr_bvh_write_memory(m, NULL, 0, NULL, d);
    mlr_motion_destroy(m);
    return s;
}

/* ---- IK -------------------------------------------------------------------------------------- */

static mlr_status bend_axis_knee(mlr_diag *d)
{
    const double pos[9] = {0}, rot[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    double axis[3];
    return mlr_ik_bend_axis_local(1, 3, pos, rot, 0, 3, 2, axis, d);
}

static mlr_status bend_axis_null(mlr_diag *d)
{
    const double rot[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    double axis[3];
    return mlr_ik_bend_axis_local(1, 3, NULL, rot, 0, 1, 2, axis, d);
}

/* ---- options: the one reader's format ------------------------------------------------------ */

static mlr_status bvh_option_twice(mlr_diag *d)
{
    const mlr_bvh_read_option o[2] = {{MLR_BVH_OPT_STRICT, 1}, {MLR_BVH_OPT_STRICT, 1}};
    mlr_motion *m = NULL;
    return mlr_bvh_read_memory_opts(tiny_bvh, strlen(tiny_bvh), 1, o, 2, NULL, &m, NULL, d);
}

static mlr_status bvh_option_value(mlr_diag *d)
{
    const mlr_bvh_read_option o[1] = {{MLR_BVH_OPT_STRICT, 2}};
    mlr_motion *m = NULL;
    return mlr_bvh_read_memory_opts(tiny_bvh, strlen(tiny_bvh), 1, o, 1, NULL, &m, NULL, d);
}

static mlr_status bvh_option_null(mlr_diag *d)
{
    mlr_motion *m = NULL;
    return mlr_bvh_read_memory_opts(tiny_bvh, strlen(tiny_bvh), 1, NULL, 1, NULL, &m, NULL, d);
}

/* 8 frames of 2 joints at rest */
static double layer_rot[8 * 2 * 4];

static mlr_status decompose_with(const mlr_layers_option *o, size_t n, mlr_layers **out,
                                 mlr_diag *d)
{
    for (size_t i = 0; i < 16; i++)
        layer_rot[4 * i] = 1.0, layer_rot[4 * i + 1] = 0.01 * (double)i;
    return mlr_layers_decompose(8, 2, NULL, layer_rot, o, n, NULL, out, d);
}

static mlr_status layers_option_range(mlr_diag *d)
{
    const mlr_layers_option o[1] = {{MLR_LAYERS_OPT_LAM_C, -1.0}};
    mlr_layers *L = NULL;
    return decompose_with(o, 1, &L, d);
}

static mlr_status layers_option_int(mlr_diag *d)
{
    const mlr_layers_option o[1] = {{MLR_LAYERS_OPT_BODY_JOINT, 2.0}};
    mlr_layers *L = NULL;
    return decompose_with(o, 1, &L, d);
}

static mlr_status layers_option_unknown(mlr_diag *d)
{
    const mlr_layers_option o[1] = {{40, 1.0}};
    mlr_layers *L = NULL;
    return decompose_with(o, 1, &L, d);
}

static mlr_status synthesize_with(const double *alpha, size_t n_alpha, size_t begin, size_t count,
                                  mlr_diag *d)
{
    mlr_layers *L = NULL;
    ck_assert_int_eq(decompose_with(NULL, 0, &L, NULL), MLR_OK);
    double root[24], rot[64];
    const mlr_status s =
        mlr_layers_synthesize(L, begin, count, alpha, n_alpha, root, 3 * count, rot, 8 * count, d);
    mlr_layers_destroy(L);
    return s;
}

static mlr_status synthesize_alpha_nan(mlr_diag *d)
{
    const double a[3] = {1.0, 1.0, NAN};
    return synthesize_with(a, 3, 0, 8, d);
}

static mlr_status synthesize_alpha_count(mlr_diag *d)
{
    const double a[2] = {1.0, 1.0};
    return synthesize_with(a, 2, 0, 8, d);
}

static mlr_status synthesize_range(mlr_diag *d)
{
    const double a[1] = {1.0};
    return synthesize_with(a, 1, 6, 3, d);
}

static mlr_status reconstruct_null(mlr_diag *d)
{
    double root[3], rot[8];
    return mlr_layers_reconstruct(NULL, 0, 1, root, 3, rot, 8, d);
}

static const diag_case cases[] = {
    {"normalize zero", normalize_zero, MLR_E_INVALID_ARG,
     "q: 2 of 3 quaternions zero, NaN or infinite, the first at index 1"},
    {"normalize NULL", normalize_null, MLR_E_INVALID_ARG, "q or out is NULL"},
    {"exp NaN", exp_nan, MLR_E_INVALID_ARG,
     "v: 1 of 2 rotation vectors NaN or infinite, the first at index 1"},
    {"log inf", log_inf, MLR_E_INVALID_ARG, "q: 1 of 2 quaternions zero, NaN or infinite"},
    {"slerp t", slerp_t_nan, MLR_E_INVALID_ARG, "index 1: t is NaN or infinite"},
    {"slerp b", slerp_b_zero, MLR_E_INVALID_ARG, "b is a zero, NaN or infinite quaternion"},
    {"from_euler order", from_euler_order, MLR_E_INVALID_ARG, "order 9 is not an mlr_euler_order"},
    {"from_euler NaN", from_euler_nan, MLR_E_INVALID_ARG, "angles: 1 of 2 angle triples"},
    {"to_euler zero", to_euler_zero, MLR_E_INVALID_ARG, "q: 1 of 1 quaternions zero"},
    {"order XYX", order_repeated, MLR_E_INVALID_ARG, "\"XYX\" repeats an axis"},
    {"order XY", order_short, MLR_E_INVALID_ARG, "not three of the letters"},
    {"order XYZW", order_long, MLR_E_INVALID_ARG, "longer than three letters"},
    {"lgs y NaN", lgs_y_nan, MLR_E_INVALID_ARG, "y[2][1] is NaN or infinite"},
    {"lgs stride", lgs_stride, MLR_E_INVALID_ARG, "ldy 1 or ldx 2 is below m = 2"},
    {"lgs variance", lgs_variance_count, MLR_E_INVALID_ARG, "n_out is 4, the handle has 5"},
    {"lgs no memory", lgs_no_memory, MLR_E_NO_MEMORY, "out of memory"},
    {"lgs no memory later", lgs_no_memory_later, MLR_E_NO_MEMORY, "out of memory"},
    {"stream NaN", stream_nan, MLR_E_INVALID_ARG, "frame[5] is NaN or infinite"},
    {"stream size", stream_size, MLR_E_INVALID_ARG, "n_values is 6, a frame has 7"},
    {"stream flushed", stream_flushed, MLR_E_BAD_STATE, "was flushed; reset it"},
    {"stream flush room", stream_flush_room, MLR_E_OVERFLOW, "below 2 pending frames"},
    {"stream alpha plain", stream_alpha_plain, MLR_E_BAD_STATE, "no base layer"},
    {"stream alpha NaN", stream_alpha_nan, MLR_E_INVALID_ARG, "alpha[0] is NaN or infinite"},
    {"stream limits NULL", stream_limits_null, MLR_E_INVALID_ARG, "st is NULL"},
    {"fk parent", fk_parent, MLR_E_INVALID_ARG, "parents[2] is 5, not in [0, 2)"},
    {"fk trans joint", fk_trans_joint, MLR_E_INVALID_ARG, "trans_joints[0] is 0"},
    {"fk no memory", fk_no_memory, MLR_E_NO_MEMORY, "fk: out of memory"},
    {"fk motion range", fk_motion_range, MLR_E_INVALID_ARG, "frames [1, 1 + 3) are not within"},
    {"copy range", copy_range, MLR_E_INVALID_ARG, "frames [2, 2 + 1) are not within the 2"},
    {"copy no memory", copy_no_memory, MLR_E_NO_MEMORY, "motion copy: 2 frames of 1 joints"},
    {"bvh option twice", bvh_option_twice, MLR_E_INVALID_ARG, "option strict given twice"},
    {"bvh option value", bvh_option_value, MLR_E_INVALID_ARG, "option strict = 2 is not 0 or 1"},
    {"bvh option NULL", bvh_option_null, MLR_E_INVALID_ARG, "opts is NULL but n_opts is 1"},
    {"layers option range", layers_option_range, MLR_E_INVALID_ARG,
     "layers: option lam_c = -1 is not > 0"},
    {"layers option int", layers_option_int, MLR_E_INVALID_ARG,
     "layers: option body_joint = 2 is not a joint index in [0, 2)"},
    {"layers option unknown", layers_option_unknown, MLR_E_INVALID_ARG,
     "layers: unknown option key 40"},
    {"synthesize alpha NaN", synthesize_alpha_nan, MLR_E_INVALID_ARG,
     "alpha[2] is NaN or infinite"},
    {"synthesize alpha count", synthesize_alpha_count, MLR_E_INVALID_ARG,
     "2 alphas (NULL: 0), not 1 or 1 + J = 3"},
    {"synthesize range", synthesize_range, MLR_E_INVALID_ARG, "frames [6, 6 + 3) are not within"},
    {"reconstruct NULL", reconstruct_null, MLR_E_INVALID_ARG, "the handle is NULL"},
    {"band create shape", band_create_shape, MLR_E_INVALID_ARG,
     "n 3, kd 3: needs n >= 1 and kd < n"},
    {"band create overflow", band_create_overflow, MLR_E_OVERFLOW, "overflow a size_t"},
    {"band create no memory", band_create_no_memory, MLR_E_NO_MEMORY,
     "out of memory for the factor"},
    {"band factor ldab", band_factor_ldab, MLR_E_INVALID_ARG, "ldab 1 < kd + 1 = 2"},
    {"band factor singular", band_factor_singular, MLR_E_SINGULAR, "the pivot of row 1"},
    {"band solve unfactored", band_solve_unfactored, MLR_E_BAD_STATE, "band is not factored"},
    {"band solve ldx", band_solve_ldx, MLR_E_INVALID_ARG, "ldx 1 < m 2"},
    {"band inverse n", band_inverse_n, MLR_E_INVALID_ARG, "n 4 is not the order 3 of band"},
    {"band inverse no memory", band_inverse_no_memory, MLR_E_NO_MEMORY,
     "out of memory for the workspace"},
    {"bvh write NULL fn", bvh_write_null_fn, MLR_E_INVALID_ARG, "bvh write: fn is NULL"},
    {"bvh write sink stops", bvh_write_sink_stops, MLR_E_IO, "fn returned nonzero"},
    {"bvh write zero quaternion", bvh_write_zero_quat, MLR_E_INVALID_ARG,
     "rot: frame 1, joint 'Hips' is a zero, NaN or infinite quaternion"},
    {"bvh write root NaN", bvh_write_root_nan, MLR_E_INVALID_ARG, "root_pos: frame 1 is NaN"},
    {"bvh write_memory cap", bvh_write_memory_cap, MLR_E_OVERFLOW, "cap 16 < the"},
    {"bvh write_memory len", bvh_write_memory_len, MLR_E_INVALID_ARG, "len is NULL"},
    {"bend axis knee", bend_axis_knee, MLR_E_INVALID_ARG, "knee joint 3 outside [0, 3)"},
    {"bend axis NULL", bend_axis_null, MLR_E_INVALID_ARG, "world_pos is NULL"},
};

START_TEST(every_failure_fills_the_diag)
{
    for (size_t i = 0; i < MLR_COUNTOF(cases); i++) {
        mlr_diag d;
        memset(&d, 0, sizeof d);
        const mlr_status s = cases[i].call(&d);
        ck_assert_msg(s == cases[i].want, "%s: status %s, expected %s", cases[i].name,
                      mlr_status_name(s), mlr_status_name(cases[i].want));
        ck_assert_msg(d.message[0] != '\0', "%s: empty diag", cases[i].name);
        ck_assert_msg(strstr(d.message, cases[i].says), "%s: '%s' lacks '%s'", cases[i].name,
                      d.message, cases[i].says);
    }
}
END_TEST

START_TEST(a_null_diag_is_fine)
{
    for (size_t i = 0; i < MLR_COUNTOF(cases); i++)
        if (cases[i].call != lgs_no_memory_later) /* it copies into the diag it is given */
            ck_assert_int_eq(cases[i].call(NULL), cases[i].want);
}
END_TEST

static Suite *diag_suite(void)
{
    Suite *s = suite_create("diag");
    TCase *tc = tcase_create("diag");
    tcase_add_test(tc, every_failure_fills_the_diag);
    tcase_add_test(tc, a_null_diag_is_fine);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(diag_suite()); }
