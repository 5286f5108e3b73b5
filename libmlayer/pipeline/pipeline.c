/* The pipeline (mlr_pipeline.h): trim, up axis, body joint, layers, repair, guards, synthesis
 * and the guards applied, composed once with the defaults of mlayer.stylize. */
#include "pipeline/pipeline_internal.h"

#include "motion/bvh_internal.h"

#include <math.h>
#include <stdio.h>

#define PI 3.14159265358979323846

/* A buffer kept from run to run (from the caller's allocator), grown when a clip needs more. */
typedef struct buffer {
    void *ptr;
    size_t bytes;
} buffer;

typedef struct joint_alpha {
    char pattern[MLR_PIPELINE_MAX_PATTERN + 1];
    double alpha;         /* when n_keys is 0 */
    size_t key0, n_keys;  /* the keys (mlr_pipeline_set_alpha_keys): pairs key0.. in p->keys */
} joint_alpha;

struct mlr_pipeline {
    mlr_allocator user;    /* the caller's: the handle, the kept buffers, the results */
    pipeline__arena arena; /* over user: what the layers and the guards allocate */
    mlr_allocator mem;     /* serves from arena */

    /* parameters (mlr_pipeline_param) */
    double alpha, root_alpha;
    int root_alpha_set;
    int up, trim, guards, limits, floor, keep_contacts, robust, keep_memory;
    double units, floor_height, gamma, lam_c, sigma_c, lam_b, sigma_b, base_cutoff, body_height;
    size_t n_joint_alphas;
    buffer patterns; /* joint_alpha[], grown past its longest list so far */
    size_t n_keys; /* the (time, alpha) pairs in keys of every curve set since the last clear */
    buffer keys;
    size_t alpha_key0, n_alpha_keys; /* the curve of every group (replaces ALPHA), n 0: none */

    /* the prepared clip */
    int prepared, stale, synthesized;
    mlr_motion *input; /* the trimmed copy (grown when a clip is larger) */
    mlr_layers *own_layers;
    const mlr_layers *layers;
    mlr_guards *g;
    int up_used;
    int32_t body_joint;
    size_t trimmed;
    size_t ends[2]; /* the runs at the clip's ends passed through (mlr_layers_get_end_runs) */
    double height_used;

    /* kept buffers */
    buffer names, fk, body, rep_root, rep_rot, rep_trans, alphas, root, rot, trans, limited;
    buffer alpha_rows, alpha_col, alpha_src; /* N x (1 + J) alphas over time; 2 N of one
                                               curve; 1 + J curves (see alphas_of) */
    mlr_guards_report report;
};

/* ---- small helpers --------------------------------------------------------------------------- */

static void *grow(mlr_pipeline *p, buffer *b, size_t count, size_t elsize)
{
    size_t bytes;
    if (common__mul_size(count, elsize, &bytes) != MLR_OK)
        return NULL;
    if (bytes == 0)
        bytes = 16;
    if (b->bytes < bytes) {
        void *n = common__alloc(&p->user, bytes);
        if (!n)
            return NULL;
        common__free(&p->user, b->ptr, b->bytes);
        b->ptr = n;
        b->bytes = bytes;
    }
    return b->ptr;
}

static void drop(mlr_pipeline *p, buffer *b)
{
    common__free(&p->user, b->ptr, b->bytes);
    b->ptr = NULL;
    b->bytes = 0;
}

/* After a call: grow the arena for the next run (KEEP_MEMORY 1), or give the scratch back. */
static void keep_or_give_back(mlr_pipeline *p)
{
    if (p->keep_memory) {
        pipeline__arena_reserve(&p->arena);
        return;
    }
    buffer *scratch[] = {&p->names,      &p->fk,        &p->body,     &p->rep_root, &p->rep_rot,
                         &p->rep_trans,  &p->alphas,    &p->root,     &p->rot,      &p->trans,
                         &p->alpha_rows, &p->alpha_col, &p->alpha_src};
    for (size_t k = 0; k < MLR_COUNTOF(scratch); k++)
        drop(p, scratch[k]);
}

static void unprepare(mlr_pipeline *p)
{
    mlr_guards_destroy(p->g);
    p->g = NULL;
    mlr_layers_destroy(p->own_layers);
    p->own_layers = NULL;
    p->layers = NULL;
    p->prepared = p->stale = p->synthesized = 0;
    p->up_used = -1;
    p->body_joint = 0;
    p->trimmed = 0;
    p->height_used = NAN;
}

static int is_integer(double v) { return isfinite(v) && v == floor(v); }

static const char *param_name(int param)
{
    switch (param) {
    case MLR_PIPELINE_ALPHA:
        return "alpha";
    case MLR_PIPELINE_ROOT_ALPHA:
        return "root_alpha";
    case MLR_PIPELINE_UP:
        return "up";
    case MLR_PIPELINE_TRIM:
        return "trim";
    case MLR_PIPELINE_UNITS:
        return "units";
    case MLR_PIPELINE_GUARDS:
        return "guards";
    case MLR_PIPELINE_LIMITS:
        return "limits";
    case MLR_PIPELINE_FLOOR:
        return "floor";
    case MLR_PIPELINE_FLOOR_HEIGHT:
        return "floor_height";
    case MLR_PIPELINE_KEEP_CONTACTS:
        return "keep_contacts";
    case MLR_PIPELINE_ROBUST:
        return "robust";
    case MLR_PIPELINE_GAMMA:
        return "gamma";
    case MLR_PIPELINE_LAM_C:
        return "lam_c";
    case MLR_PIPELINE_SIGMA_C:
        return "sigma_c";
    case MLR_PIPELINE_LAM_B:
        return "lam_b";
    case MLR_PIPELINE_SIGMA_B:
        return "sigma_b";
    case MLR_PIPELINE_BASE_CUTOFF:
        return "base_cutoff";
    case MLR_PIPELINE_BODY_HEIGHT:
        return "body_height";
    case MLR_PIPELINE_KEEP_MEMORY:
        return "keep_memory";
    default:
        return NULL;
    }
}

/* ---- create, set, get -------------------------------------------------------------------- */

mlr_status mlr_pipeline_create(const mlr_allocator *alloc, mlr_pipeline **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_pipeline_create: out is NULL");
    *out = NULL;
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_pipeline *p = common__alloc(&a, sizeof *p);
    if (!p)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "mlr_pipeline_create: out of memory (the handle, %zu bytes)",
                                sizeof *p);
    memset(p, 0, sizeof *p);
    p->user = a;
    pipeline__arena_init(&p->arena, &p->user, &p->mem);
    p->alpha = 1.0;
    p->up = -1;
    p->guards = 1;
    p->limits = MLR_GUARDS_LIMITS_AUTO;
    p->floor = 1;
    p->keep_contacts = 1;
    p->robust = 1;
    p->keep_memory = 1;
    p->gamma = PI / 2;
    p->base_cutoff = 0.25;
    unprepare(p);
    *out = p;
    return MLR_OK;
}

/* Check value for param; MLR_OK or MLR_E_INVALID_ARG with the reason. */
static mlr_status check_value(int param, double v, mlr_diag *diag)
{
    const char *name = param_name(param);
    const char *why = NULL;
    switch (param) {
    case MLR_PIPELINE_ALPHA:
    case MLR_PIPELINE_ROOT_ALPHA:
    case MLR_PIPELINE_FLOOR_HEIGHT:
        if (!isfinite(v))
            why = "must be finite";
        break;
    case MLR_PIPELINE_UP:
        if (!(v == -1 || v == MLR_AXIS_X || v == MLR_AXIS_Y || v == MLR_AXIS_Z))
            why = "must be an mlr_axis (0, 1, 2) or -1 (detect)";
        break;
    case MLR_PIPELINE_TRIM:
        if (!is_integer(v) || v < -1 || v > 1e15)
            why = "must be a frame count >= 0 or -1 (the lead-in)";
        break;
    case MLR_PIPELINE_UNITS:
        if (!isfinite(v) || v < 0)
            why = "must be metres per unit > 0, or 0 (unknown)";
        break;
    case MLR_PIPELINE_GUARDS:
    case MLR_PIPELINE_KEEP_CONTACTS:
    case MLR_PIPELINE_ROBUST:
    case MLR_PIPELINE_KEEP_MEMORY:
        if (!(v == 0 || v == 1))
            why = "must be 0 or 1";
        break;
    case MLR_PIPELINE_LIMITS:
        if (!(v == MLR_GUARDS_LIMITS_OFF || v == MLR_GUARDS_LIMITS_AUTO ||
              v == MLR_GUARDS_LIMITS_ALWAYS))
            why = "must be an mlr_guards_limits_mode (0 off, 1 auto, 2 always)";
        break;
    case MLR_PIPELINE_FLOOR:
        if (!(v == 0 || v == 1 || v == 2))
            why = "must be 0 (off), 1 (from the contacts) or 2 (at floor_height)";
        break;
    case MLR_PIPELINE_GAMMA:
        if (!(v >= PI / 2 && v < PI))
            why = "must be in [pi/2, pi)";
        break;
    case MLR_PIPELINE_LAM_C:
    case MLR_PIPELINE_SIGMA_C:
    case MLR_PIPELINE_LAM_B:
    case MLR_PIPELINE_SIGMA_B:
    case MLR_PIPELINE_BASE_CUTOFF:
        if (!isfinite(v) || v < 0)
            why = "must be finite and > 0, or 0 (not given)";
        break;
    case MLR_PIPELINE_BODY_HEIGHT:
        if (!isfinite(v))
            why = "must be finite (> 0 given, 0 measured, < 0 none)";
        break;
    default:
        if (param >= MLR_PIPELINE_INFO_UP && param <= MLR_PIPELINE_INFO_BODY_HEIGHT)
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mlr_pipeline_set: parameter %d is read-only (an INFO key)",
                                    param);
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_pipeline_set: unknown parameter %d", param);
    }
    if (why)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_pipeline_set: option %s %s, got %.17g", name, why, v);
    return MLR_OK;
}

mlr_status mlr_pipeline_set(mlr_pipeline *p, mlr_pipeline_param param, double value,
                            mlr_diag *diag)
{
    if (!p)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_pipeline_set: p is NULL");
    mlr_status s = check_value((int)param, value, diag);
    if (s != MLR_OK)
        return s;
    double old = 0;
    mlr_pipeline_get(p, param, &old);
    switch ((int)param) {
    case MLR_PIPELINE_ALPHA:
        p->alpha = value;
        p->n_alpha_keys = 0; /* a constant again */
        return MLR_OK;
    case MLR_PIPELINE_ROOT_ALPHA:
        p->root_alpha = value;
        p->root_alpha_set = 1;
        return MLR_OK;
    case MLR_PIPELINE_UNITS:
        p->units = value;
        return MLR_OK;
    case MLR_PIPELINE_KEEP_MEMORY:
        p->keep_memory = (int)value;
        return MLR_OK;
    case MLR_PIPELINE_UP:
        p->up = (int)value;
        break;
    case MLR_PIPELINE_TRIM:
        p->trim = (int)value;
        break;
    case MLR_PIPELINE_GUARDS:
        p->guards = (int)value;
        break;
    case MLR_PIPELINE_LIMITS:
        p->limits = (int)value;
        break;
    case MLR_PIPELINE_FLOOR:
        p->floor = (int)value;
        break;
    case MLR_PIPELINE_FLOOR_HEIGHT:
        p->floor_height = value;
        break;
    case MLR_PIPELINE_KEEP_CONTACTS:
        p->keep_contacts = (int)value;
        break;
    case MLR_PIPELINE_ROBUST:
        p->robust = (int)value;
        break;
    case MLR_PIPELINE_GAMMA:
        p->gamma = value;
        break;
    case MLR_PIPELINE_LAM_C:
        p->lam_c = value;
        break;
    case MLR_PIPELINE_SIGMA_C:
        p->sigma_c = value;
        break;
    case MLR_PIPELINE_LAM_B:
        p->lam_b = value;
        break;
    case MLR_PIPELINE_SIGMA_B:
        p->sigma_b = value;
        break;
    case MLR_PIPELINE_BASE_CUTOFF:
        p->base_cutoff = value;
        break;
    case MLR_PIPELINE_BODY_HEIGHT:
        p->body_height = value;
        break;
    default:
        break; /* rejected by check_value */
    }
    if (p->prepared && old != value)
        p->stale = (int)param;
    return MLR_OK;
}

mlr_status mlr_pipeline_get(const mlr_pipeline *p, mlr_pipeline_param param, double *value)
{
    if (!p || !value)
        return MLR_E_INVALID_ARG;
    const double none = NAN;
    double v;
    switch ((int)param) {
    case MLR_PIPELINE_ALPHA:
        v = p->n_alpha_keys ? none : p->alpha;
        break;
    case MLR_PIPELINE_ROOT_ALPHA:
        v = p->root_alpha_set ? p->root_alpha : p->n_alpha_keys ? none : p->alpha;
        break;
    case MLR_PIPELINE_UP:
        v = p->up;
        break;
    case MLR_PIPELINE_TRIM:
        v = p->trim;
        break;
    case MLR_PIPELINE_UNITS:
        v = p->units;
        break;
    case MLR_PIPELINE_GUARDS:
        v = p->guards;
        break;
    case MLR_PIPELINE_LIMITS:
        v = p->limits;
        break;
    case MLR_PIPELINE_FLOOR:
        v = p->floor;
        break;
    case MLR_PIPELINE_FLOOR_HEIGHT:
        v = p->floor_height;
        break;
    case MLR_PIPELINE_KEEP_CONTACTS:
        v = p->keep_contacts;
        break;
    case MLR_PIPELINE_ROBUST:
        v = p->robust;
        break;
    case MLR_PIPELINE_GAMMA:
        v = p->gamma;
        break;
    case MLR_PIPELINE_LAM_C:
        v = p->lam_c;
        break;
    case MLR_PIPELINE_SIGMA_C:
        v = p->sigma_c;
        break;
    case MLR_PIPELINE_LAM_B:
        v = p->lam_b;
        break;
    case MLR_PIPELINE_SIGMA_B:
        v = p->sigma_b;
        break;
    case MLR_PIPELINE_BASE_CUTOFF:
        v = p->base_cutoff;
        break;
    case MLR_PIPELINE_BODY_HEIGHT:
        v = p->body_height;
        break;
    case MLR_PIPELINE_KEEP_MEMORY:
        v = p->keep_memory;
        break;
    case MLR_PIPELINE_INFO_UP:
        v = p->prepared ? p->up_used : none;
        break;
    case MLR_PIPELINE_INFO_TRIMMED:
        v = p->prepared ? (double)p->trimmed : none;
        break;
    case MLR_PIPELINE_INFO_FRAMES:
        v = p->prepared ? (double)mlr_motion_n_frames(p->input) : none;
        break;
    case MLR_PIPELINE_INFO_BODY_JOINT:
        v = p->prepared ? p->body_joint : none;
        break;
    case MLR_PIPELINE_INFO_BODY_HEIGHT:
        v = p->prepared ? p->height_used : none;
        break;
    default:
        return MLR_E_INVALID_ARG;
    }
    *value = v;
    return MLR_OK;
}

/* Check a pattern (fn: the function, for the diag). */
static mlr_status check_pattern(const char *pattern, const char *fn, mlr_diag *diag)
{
    const size_t len = strlen(pattern);
    if (len == 0 || len > MLR_PIPELINE_MAX_PATTERN)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: the pattern must have 1 to %d bytes, got %zu", fn,
                                MLR_PIPELINE_MAX_PATTERN, len);
    return MLR_OK;
}

/* Append a joint pattern with its constant alpha, or its keys (n_keys > 0 at key0). */
static mlr_status add_pattern(mlr_pipeline *p, const char *pattern, double alpha, size_t key0,
                              size_t n_keys, const char *fn, mlr_diag *diag)
{
    if ((p->n_joint_alphas + 1) * sizeof(joint_alpha) > p->patterns.bytes) { /* grow, keep */
        const size_t cap = p->n_joint_alphas < 8 ? 16 : 2 * p->n_joint_alphas;
        size_t bytes;
        void *n = common__mul_size(cap, sizeof(joint_alpha), &bytes) == MLR_OK
                      ? common__alloc(&p->user, bytes)
                      : NULL;
        if (!n)
            return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                    "%s: out of memory (%zu patterns)", fn, cap);
        if (p->n_joint_alphas)
            memcpy(n, p->patterns.ptr, p->n_joint_alphas * sizeof(joint_alpha));
        drop(p, &p->patterns);
        p->patterns.ptr = n;
        p->patterns.bytes = bytes;
    }
    joint_alpha *ja = (joint_alpha *)p->patterns.ptr + p->n_joint_alphas++;
    memcpy(ja->pattern, pattern, strlen(pattern) + 1);
    ja->alpha = alpha;
    ja->key0 = key0;
    ja->n_keys = n_keys;
    return MLR_OK;
}

mlr_status mlr_pipeline_set_joint_alpha(mlr_pipeline *p, const char *pattern, double alpha,
                                        mlr_diag *diag)
{
    static const char fn[] = "mlr_pipeline_set_joint_alpha";
    if (!p || !pattern)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: %s is NULL", fn,
                                p ? "pattern" : "p");
    mlr_status s = check_pattern(pattern, fn, diag);
    if (s != MLR_OK)
        return s;
    if (!isfinite(alpha))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "%s: the alpha of '%.60s' must be finite, got %g", fn, pattern,
                                alpha);
    return add_pattern(p, pattern, alpha, 0, 0, fn, diag);
}

mlr_status mlr_pipeline_set_alpha_keys(mlr_pipeline *p, const char *pattern, const double *times,
                                       const double *values, size_t n_keys, mlr_diag *diag)
{
    static const char fn[] = "mlr_pipeline_set_alpha_keys";
    if (!p)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "%s: p is NULL", fn);
    mlr_status s = pattern ? check_pattern(pattern, fn, diag) : MLR_OK;
    if (s != MLR_OK)
        return s;
    if ((s = mlr_alpha_keys_check(times, values, n_keys, diag)) != MLR_OK) {
        char who[MLR_PIPELINE_MAX_PATTERN + 64];
        snprintf(who, sizeof who, "%s (%s%.60s%s)", fn, pattern ? "'" : "every joint",
                 pattern ? pattern : "", pattern ? "'" : "");
        return common__diag_prefix(diag, s, who);
    }
    if (n_keys > SIZE_MAX / 4 - p->n_keys)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "%s: too many keys", fn);
    const size_t need = p->n_keys + n_keys;
    if (2 * need * sizeof(double) > p->keys.bytes) { /* grow, keep */
        const size_t cap = need < 64 ? 128 : 2 * need;
        size_t bytes;
        void *n = common__mul_size(2 * cap, sizeof(double), &bytes) == MLR_OK
                      ? common__alloc(&p->user, bytes)
                      : NULL;
        if (!n)
            return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "%s: out of memory (%zu keys)",
                                    fn, cap);
        if (p->n_keys)
            memcpy(n, p->keys.ptr, 2 * p->n_keys * sizeof(double));
        drop(p, &p->keys);
        p->keys.ptr = n;
        p->keys.bytes = bytes;
    }
    if (pattern && (s = add_pattern(p, pattern, NAN, p->n_keys, n_keys, fn, diag)) != MLR_OK)
        return s;
    double *k = (double *)p->keys.ptr + 2 * p->n_keys; /* times, then values */
    memcpy(k, times, n_keys * sizeof(double));
    memcpy(k + n_keys, values, n_keys * sizeof(double));
    if (!pattern) {
        p->alpha_key0 = p->n_keys;
        p->n_alpha_keys = n_keys;
    }
    p->n_keys = need;
    return MLR_OK;
}

void mlr_pipeline_clear_joint_alphas(mlr_pipeline *p)
{
    if (p) {
        p->n_joint_alphas = 0;
        p->root_alpha_set = 0;
        p->n_keys = p->n_alpha_keys = 0;
    }
}

/* ---- prepare ----------------------------------------------------------------------------- */

/* The rig view of a motion (names in p->names). */
static mlr_status rig_of(mlr_pipeline *p, const mlr_motion *m, mlr_rig *rig)
{
    const size_t J = mlr_motion_n_joints(m);
    const char **names = grow(p, &p->names, J, sizeof *names);
    if (!names)
        return MLR_E_NO_MEMORY;
    for (size_t j = 0; j < J; j++)
        names[j] = mlr_motion_joint_name(m, j);
    rig->n_joints = J;
    rig->parents = mlr_motion_parents(m);
    rig->offsets = mlr_motion_offsets(m);
    rig->names = names;
    rig->n_trans = mlr_motion_n_trans(m);
    rig->trans_joints = rig->n_trans ? mlr_motion_trans_joints(m) : NULL;
    rig->n_end_sites = mlr_motion_n_end_sites(m);
    rig->end_site_parents = rig->n_end_sites ? mlr_motion_end_site_parents(m) : NULL;
    rig->end_site_offsets = rig->n_end_sites ? mlr_motion_end_site_offsets(m) : NULL;
    return MLR_OK;
}

/* World positions of m's joints into p->fk (N x J x 3). */
static mlr_status positions(mlr_pipeline *p, const mlr_motion *m, const double **out,
                            mlr_diag *diag)
{
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
    size_t nj;
    if (common__mul_size(N, J, &nj) != MLR_OK)
        return MLR_E_OVERFLOW;
    double *pos = grow(p, &p->fk, nj, 3 * sizeof(double));
    if (!pos)
        return MLR_E_NO_MEMORY;
    const size_t P = mlr_motion_n_trans(m);
    mlr_status s =
        mlr_fk_arrays(N, J, mlr_motion_parents(m), mlr_motion_offsets(m), mlr_motion_root_pos(m),
                      mlr_motion_rot(m), P, P ? mlr_motion_trans_joints(m) : NULL,
                      P ? mlr_motion_trans(m) : NULL, pos, NULL, &p->mem, diag);
    *out = pos;
    return s;
}

/* The up axis of m as mlayer.Motion.up_axis gives it: the parameter, else detected (Y when the
 * detection is not sure). */
static mlr_status up_of(mlr_pipeline *p, const mlr_motion *m, const mlr_rig *rig, int *up,
                        mlr_diag *diag)
{
    if (p->up >= 0) {
        *up = p->up;
        return MLR_OK;
    }
    const double *pos;
    mlr_status s = positions(p, m, &pos, diag);
    if (s < 0)
        return s;
    mlr_up_guess g;
    s = mlr_rig_up_axis(rig, mlr_motion_n_frames(m), pos, &g, &p->mem, diag);
    if (s < 0)
        return s;
    *up = g.method != MLR_UP_NONE && g.confidence >= MLR_RIG_UP_SURE ? g.axis : MLR_AXIS_Y;
    return MLR_OK;
}

/* The frames to drop at the start of in. */
static mlr_status frames_to_trim(mlr_pipeline *p, const mlr_motion *in, size_t *n_drop,
                                 mlr_diag *diag)
{
    const size_t N = mlr_motion_n_frames(in);
    if (p->trim >= 0) {
        *n_drop = (size_t)p->trim;
    } else {
        mlr_rig rig;
        int up;
        mlr_status s = rig_of(p, in, &rig);
        if (s < 0)
            return s;
        s = up_of(p, in, &rig, &up, diag);
        if (s < 0)
            return s;
        mlr_trim_lead lead;
        s = mlr_trim_lead_in(&rig, N, mlr_motion_root_pos(in), mlr_motion_rot(in),
                             mlr_motion_trans(in), up, &lead, &p->mem, diag);
        if (s < 0)
            return s;
        *n_drop = lead.n_frames;
    }
    if (*n_drop >= N || N - *n_drop < 3)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "trim: %zu frames dropped from a clip of %zu leave fewer than 3",
                                *n_drop, N);
    return MLR_OK;
}

static size_t trans_slot(const mlr_motion *m, int32_t body)
{
    const size_t P = mlr_motion_n_trans(m);
    const int32_t *tj = mlr_motion_trans_joints(m);
    size_t slot = 0;
    while (slot < P && tj[slot] != body)
        slot++;
    return slot;
}

/* The body translation of m (N x 3): root_pos, or the position channels of joint body. */
static const double *body_translation(mlr_pipeline *p, const mlr_motion *m, int32_t body)
{
    if (body == 0)
        return mlr_motion_root_pos(m);
    const size_t N = mlr_motion_n_frames(m), P = mlr_motion_n_trans(m);
    const size_t slot = trans_slot(m, body);
    double *t = grow(p, &p->body, N, 3 * sizeof(double));
    if (!t)
        return NULL;
    const double *trans = mlr_motion_trans(m);
    for (size_t i = 0; i < N; i++)
        memcpy(t + 3 * i, trans + 3 * (i * P + slot), 3 * sizeof(double));
    return t;
}

static mlr_status decompose(mlr_pipeline *p, const mlr_motion *m, const mlr_rig *rig, int *up_used,
                            mlr_diag *diag)
{
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
    const double fps = 1.0 / mlr_motion_frame_time(m);
    mlr_layers_option opts[12];
    size_t n = 0;
    opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_GAMMA, p->gamma};
    if (p->lam_c > 0)
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_LAM_C, p->lam_c};
    if (p->sigma_c > 0)
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_SIGMA_C, p->sigma_c};
    if (p->lam_b > 0)
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_LAM_B, p->lam_b};
    if (p->sigma_b > 0)
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_SIGMA_B, p->sigma_b};
    if (p->base_cutoff > 0 && !(p->lam_b > 0) && !(p->sigma_b > 0)) {
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_FPS, fps};
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_BASE_CUTOFF, p->base_cutoff};
    }
    opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_ROBUST, (double)p->robust};
    if (p->robust) {
        double h = p->body_height;
        if (h == 0) { /* measured along up, as mlayer.metrics.body_height */
            if (*up_used < 0) {
                mlr_status s = up_of(p, m, rig, up_used, diag);
                if (s < 0)
                    return s;
            }
            const double *pos;
            mlr_status s = positions(p, m, &pos, diag);
            if (s < 0)
                return s;
            s = mlr_rig_body_height(N, J, pos, *up_used, &h, &p->mem, diag);
            if (s < 0)
                return s;
        }
        if (isfinite(h) && h > 0) {
            opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_BODY_HEIGHT, h};
            p->height_used = h;
        }
    }
    if (p->body_joint != 0)
        opts[n++] = (mlr_layers_option){MLR_LAYERS_OPT_BODY_JOINT, (double)p->body_joint};
    const double *root = body_translation(p, m, p->body_joint);
    if (!root)
        return MLR_E_NO_MEMORY;
    return mlr_layers_decompose(N, J, root, mlr_motion_rot(m), opts, n, &p->mem, &p->own_layers,
                                diag);
}

/* The input with its outlier frames repaired (mlr_layers_repair), into p->rep_*. */
static mlr_status repaired(mlr_pipeline *p, const mlr_motion *m, double **root, double **rot,
                           double **trans, mlr_diag *diag)
{
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m);
    size_t nj, np;
    if (common__mul_size(N, J, &nj) || common__mul_size(N, P, &np))
        return MLR_E_OVERFLOW;
    *root = grow(p, &p->rep_root, N, 3 * sizeof(double));
    *rot = grow(p, &p->rep_rot, nj, 4 * sizeof(double));
    *trans = P ? grow(p, &p->rep_trans, np, 3 * sizeof(double)) : NULL;
    double *body = grow(p, &p->body, N, 3 * sizeof(double));
    if (!*root || !*rot || (P && !*trans) || !body)
        return MLR_E_NO_MEMORY;
    memcpy(*root, mlr_motion_root_pos(m), 3 * N * sizeof(double));
    memcpy(*rot, mlr_motion_rot(m), 4 * nj * sizeof(double));
    if (P)
        memcpy(*trans, mlr_motion_trans(m), 3 * np * sizeof(double));
    const size_t slot = trans_slot(m, p->body_joint);
    if (p->body_joint == 0)
        memcpy(body, *root, 3 * N * sizeof(double));
    else
        for (size_t i = 0; i < N; i++)
            memcpy(body + 3 * i, *trans + 3 * (i * P + slot), 3 * sizeof(double));
    size_t n_repaired = 0;
    mlr_status s =
        mlr_layers_repair(p->layers, 0, N, body, 3 * N, *rot, 4 * nj, &n_repaired, diag);
    if (s < 0)
        return s;
    if (p->body_joint == 0)
        memcpy(*root, body, 3 * N * sizeof(double));
    else
        for (size_t i = 0; i < N; i++)
            memcpy(*trans + 3 * (i * P + slot), body + 3 * i, 3 * sizeof(double));
    return MLR_OK;
}

static mlr_status make_guards(mlr_pipeline *p, const mlr_motion *m, const mlr_rig *rig,
                              int *up_used, char *note, mlr_diag *diag)
{
    if (*up_used < 0) {
        mlr_status s = up_of(p, m, rig, up_used, diag);
        if (s < 0)
            return s;
    }
    double *root, *rot, *trans;
    mlr_status s = repaired(p, m, &root, &rot, &trans, diag);
    if (s < 0)
        return s;
    mlr_guards_option opts[5];
    size_t n = 0;
    opts[n++] = (mlr_guards_option){MLR_GUARDS_OPT_UP, (double)*up_used};
    opts[n++] = (mlr_guards_option){MLR_GUARDS_OPT_LIMITS, (double)p->limits};
    opts[n++] = (mlr_guards_option){MLR_GUARDS_OPT_KEEP_CONTACTS, (double)p->keep_contacts};
    opts[n++] = (mlr_guards_option){MLR_GUARDS_OPT_FLOOR, p->floor ? 1.0 : 0.0};
    if (p->floor == 2)
        opts[n++] = (mlr_guards_option){MLR_GUARDS_OPT_FLOOR_HEIGHT, p->floor_height};
    mlr_diag d = {0};
    const mlr_guards_input in = {rig, 1.0 / mlr_motion_frame_time(m),
                                 (mlr_frames){mlr_motion_n_frames(m), root, rot, trans}, opts, n};
    s = mlr_guards_create_from(&in, &p->mem, &p->g, &d);
    if (s < 0) {
        if (diag)
            *diag = d;
        return s;
    }
    memcpy(note, d.message, sizeof d.message);
    return MLR_OK;
}

mlr_status mlr_pipeline_prepare(mlr_pipeline *p, const mlr_motion *in, const mlr_layers *layers,
                                mlr_diag *diag)
{
    if (!p || !in)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_pipeline_prepare: %s is NULL",
                                p ? "in" : "p");
    unprepare(p);
    const size_t N = mlr_motion_n_frames(in), J = mlr_motion_n_joints(in);
    if (N < 3)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_pipeline_prepare: the clip needs at least 3 frames, got %zu",
                                N);
    char note[sizeof(((mlr_diag *)0)->message)] = "";
    size_t n_drop = 0;
    mlr_status s = frames_to_trim(p, in, &n_drop, diag);
    if (s < 0)
        return common__diag_prefix(diag, s, "mlr_pipeline_prepare");

    /* the pipeline's copy of the trimmed clip */
    const size_t n = N - n_drop, P = mlr_motion_n_trans(in);
    s = bvh_motion_fit(&p->input, in, n, &p->user);
    if (s < 0)
        return common__diag_set(diag, s, 0, 0, "mlr_pipeline_prepare: %s (a copy of %zu frames)",
                                s == MLR_E_NO_MEMORY ? "out of memory" : mlr_status_string(s), n);
    mlr_motion *m = p->input;
    memcpy(mlr_motion_root_pos_mut(m), mlr_motion_root_pos(in) + 3 * n_drop,
           3 * n * sizeof(double));
    memcpy(mlr_motion_rot_mut(m), mlr_motion_rot(in) + 4 * J * n_drop, 4 * J * n * sizeof(double));
    if (P)
        memcpy(mlr_motion_trans_mut(m), mlr_motion_trans(in) + 3 * P * n_drop,
               3 * P * n * sizeof(double));

    mlr_rig rig;
    int up_used = -1;
    s = rig_of(p, m, &rig);
    if (s >= 0)
        s = mlr_rig_body_translation_joint(&rig, n, mlr_motion_root_pos(m), mlr_motion_trans(m),
                                           &p->body_joint, diag);
    if (s >= 0) {
        if (layers) {
            if (mlr_layers_n_frames(layers) != n || mlr_layers_n_joints(layers) != J)
                s = common__diag_set(
                    diag, MLR_E_INVALID_ARG, 0, 0,
                    "layers: of %zu frames and %zu joints, the clip has %zu and %zu",
                    mlr_layers_n_frames(layers), mlr_layers_n_joints(layers), n, J);
            p->layers = layers;
        } else {
            s = decompose(p, m, &rig, &up_used, diag);
            p->layers = p->own_layers;
        }
    }
    p->ends[0] = p->ends[1] = 0;
    if (s >= 0) /* the end runs that the layers left out (mlr_layers_get_end_runs) */
        mlr_layers_get_end_runs(p->layers, &p->ends[0], &p->ends[1]);
    if (s >= 0 && p->guards)
        s = make_guards(p, m, &rig, &up_used, note, diag);
    if (s < 0) {
        const mlr_status r = s == MLR_E_NO_MEMORY && diag && !diag->message[0]
                                 ? common__diag_set(diag, s, 0, 0, "out of memory")
                                 : s;
        unprepare(p);
        return common__diag_prefix(diag, r, "mlr_pipeline_prepare");
    }
    p->up_used = up_used;
    p->trimmed = n_drop;
    p->prepared = 1;
    keep_or_give_back(p);
    if (diag) {
        memset(diag, 0, sizeof *diag);
        memcpy(diag->message, note, sizeof note);
    }
    return MLR_OK;
}

/* ---- synthesize -------------------------------------------------------------------------- */

/* The 1 + J alphas of the parameters and joint patterns, into a; src[g] is 0 where a[g] is the
   group's constant alpha, else where its curve is: 1 the curve of every group, 2 + k joint
   pattern k's (a[g] is then NaN). */
static mlr_status alphas_of(const mlr_pipeline *p, const mlr_motion *m, double *a, size_t *src,
                            mlr_diag *diag)
{
    const size_t J = mlr_motion_n_joints(m);
    for (size_t k = 0; k <= J; k++) {
        a[k] = p->n_alpha_keys ? NAN : p->alpha;
        src[k] = p->n_alpha_keys ? 1 : 0;
    }
    if (p->root_alpha_set)
        a[0] = p->root_alpha, src[0] = 0;
    for (size_t k = 0; k < p->n_joint_alphas; k++) {
        const joint_alpha *ja = (const joint_alpha *)p->patterns.ptr + k;
        size_t hits = 0;
        for (size_t j = 0; j < J; j++)
            if (pipeline__glob_match(ja->pattern, mlr_motion_joint_name(m, j))) {
                a[1 + j] = ja->alpha;
                src[1 + j] = ja->n_keys ? 2 + k : 0;
                hits++;
            }
        if (!hits) {
            common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                             "joint pattern '%.60s' matches no joint; joints: ", ja->pattern);
            if (diag) { /* as many names as fit */
                size_t len = strlen(diag->message);
                for (size_t j = 0; j < J && len + 1 < sizeof diag->message; j++) {
                    const int w = snprintf(diag->message + len, sizeof diag->message - len, "%s%s",
                                           j ? ", " : "", mlr_motion_joint_name(m, j));
                    if (w < 0)
                        break;
                    len += (size_t)w;
                    if (len >= sizeof diag->message)
                        len = sizeof diag->message - 1;
                }
            }
            return MLR_E_INVALID_ARG;
        }
    }
    return MLR_OK;
}

/* The alphas over time (src from alphas_of, some group with a curve): N x (1 + J) in
   p->alpha_rows, frame i at i frame_time seconds. a[g] becomes what the guards take for group
   g: its alpha of largest magnitude over the clip (the first such frame's; the constant of a
   group without a curve; just below 1 for a peak of 1 that is not 1 everywhere), so that
   they run as for that constant alpha (see "Alpha over time" in mlr_pipeline.h). */
static mlr_status alphas_over_time(mlr_pipeline *p, const mlr_motion *m, double *a, size_t *src,
                                   mlr_diag *diag)
{
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m);
    size_t n;
    if (common__mul_size(N, 1 + J, &n) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "alphas over time: overflow");
    double *rows = grow(p, &p->alpha_rows, n, sizeof(double));
    double *col = grow(p, &p->alpha_col, N, 2 * sizeof(double));
    if (!rows || !col)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "alphas over time: out of memory (%zu frames)", N);
    const double dt = mlr_motion_frame_time(m);
    double *t = col + N; /* the frame times; col the values of one curve */
    for (size_t i = 0; i < N; i++)
        t[i] = (double)i * dt;
    const double *keys = p->keys.ptr;
    const size_t done = (size_t)-1;
    for (size_t g = 0; g <= J; g++) {
        const size_t which = src[g];
        if (!which) {
            for (size_t i = 0; i < N; i++)
                rows[i * (1 + J) + g] = a[g];
            continue;
        }
        if (which == done) /* a curve evaluated for an earlier group */
            continue;
        size_t key0 = p->alpha_key0, nk = p->n_alpha_keys;
        if (which >= 2) {
            const joint_alpha *ja = (const joint_alpha *)p->patterns.ptr + (which - 2);
            key0 = ja->key0, nk = ja->n_keys;
        }
        mlr_status s =
            mlr_alpha_keys_eval(keys + 2 * key0, keys + 2 * key0 + nk, nk, t, N, col, diag);
        if (s < 0)
            return s;
        double peak = col[0];
        int ones = 1;
        for (size_t i = 1; i < N; i++)
            if (fabs(col[i]) > fabs(peak))
                peak = col[i];
        for (size_t i = 0; i < N; i++)
            ones &= col[i] == 1.0;
        if (peak == 1.0 && !ones) /* not a denoise for the guards; the limits read it as 1 */
            peak = nextafter(1.0, 0.0);
        for (size_t h = g; h <= J; h++) /* every group of this curve, once */
            if (src[h] == which) {
                for (size_t i = 0; i < N; i++)
                    rows[i * (1 + J) + h] = col[i];
                a[h] = peak;
                src[h] = h > g ? done : which;
            }
    }
    return MLR_OK;
}

mlr_status mlr_pipeline_synthesize(mlr_pipeline *p, mlr_motion **out, mlr_diag *diag)
{
    if (!p || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_pipeline_synthesize: %s is NULL", p ? "out" : "p");
    if (!p->prepared)
        return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                                "mlr_pipeline_synthesize: not prepared (mlr_pipeline_prepare)");
    if (p->stale)
        return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                                "mlr_pipeline_synthesize: %s changed since the prepare: prepare "
                                "again",
                                param_name(p->stale));
    if (*out == p->input)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_pipeline_synthesize: out is the pipeline's own clip");
    const mlr_motion *m = p->input;
    const size_t N = mlr_motion_n_frames(m), J = mlr_motion_n_joints(m), P = mlr_motion_n_trans(m);
    size_t nj, np;
    if (common__mul_size(N, J, &nj) || common__mul_size(N, P, &np))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "mlr_pipeline_synthesize: overflow");
    double *a = grow(p, &p->alphas, 1 + J, sizeof(double));
    double *root = grow(p, &p->root, N, 3 * sizeof(double));
    double *rot = grow(p, &p->rot, nj, 4 * sizeof(double));
    double *trans = P ? grow(p, &p->trans, np, 3 * sizeof(double)) : NULL;
    double *body = grow(p, &p->body, N, 3 * sizeof(double));
    size_t *limited = grow(p, &p->limited, J, sizeof(size_t));
    if (!a || !root || !rot || (P && !trans) || !body || !limited)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "mlr_pipeline_synthesize: out of memory (%zu frames)", N);
    size_t *src = grow(p, &p->alpha_src, 1 + J, sizeof(size_t));
    if (!src)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "mlr_pipeline_synthesize: out of memory (%zu joints)", J);
    mlr_status s = alphas_of(p, m, a, src, diag);
    if (s < 0)
        return common__diag_prefix(diag, s, "mlr_pipeline_synthesize");
    int over_time = 0;
    for (size_t g = 0; g <= J; g++)
        over_time |= src[g] != 0;

    /* Mb (+) alpha delta_c, the body translation where it rides */
    if (!over_time)
        s = mlr_layers_synthesize(p->layers, 0, N, a, 1 + J, body, 3 * N, rot, 4 * nj, diag);
    else if ((s = alphas_over_time(p, m, a, src, diag)) >= 0)
        s = mlr_layers_synthesize_frames(p->layers, 0, N, p->alpha_rows.ptr, N * (1 + J), body,
                                         3 * N, rot, 4 * nj, diag);
    if (s < 0)
        return common__diag_prefix(diag, s, "mlr_pipeline_synthesize");
    memcpy(root, mlr_motion_root_pos(m), 3 * N * sizeof(double));
    if (P)
        memcpy(trans, mlr_motion_trans(m), 3 * np * sizeof(double));
    if (p->body_joint == 0) {
        memcpy(root, body, 3 * N * sizeof(double));
    } else {
        const size_t slot = trans_slot(m, p->body_joint);
        for (size_t i = 0; i < N; i++)
            memcpy(trans + 3 * (i * P + slot), body + 3 * i, 3 * sizeof(double));
    }

    mlr_guards_report rep;
    memset(&rep, 0, sizeof rep);
    rep.floor_height = NAN;
    memset(limited, 0, J * sizeof(size_t));
    if (p->g) {
        mlr_guards_job job = {0};
        job.alpha = a, job.n_alpha = 1 + J;
        job.root_pos = root, job.rot = rot, job.trans = trans, job.body_on_trans = 1;
        job.limited = limited, job.n_limited = J, job.report = &rep;
        s = mlr_guards_run(p->g, &job, diag);
        if (s < 0)
            return common__diag_prefix(diag, s, "mlr_pipeline_synthesize");
    }

    /* the runs at the clip's ends that the robust decomposition left out (a converter's T-pose
       frame before the capture): as they are in a denoise, else the result's pose next to each
       held over it (pipeline_ends.c) */
    if (p->ends[0] || p->ends[1]) {
        int denoise = 1;
        for (size_t g = 0; g <= J; g++)
            denoise &= a[g] == 1.0;
        mlr_rig rig;
        s = rig_of(p, m, &rig);
        if (s >= 0)
            s = pipeline__fill_end_runs(&rig, N, p->ends, denoise, rep.floor_height, p->up_used,
                                        mlr_motion_root_pos(m), mlr_motion_rot(m),
                                        P ? mlr_motion_trans(m) : NULL, root, rot, trans, &p->mem);
        if (s < 0)
            return common__diag_set(diag, s, 0, 0, "mlr_pipeline_synthesize: %s (the end runs)",
                                    mlr_status_string(s));
    }

    /* the result, in the caller's motion when it is large enough */
    mlr_motion *res = *out;
    s = bvh_motion_fit(&res, m, N, &p->user);
    if (s < 0)
        return common__diag_set(diag, s, 0, 0,
                                "mlr_pipeline_synthesize: %s (the result, %zu frames)",
                                s == MLR_E_NO_MEMORY ? "out of memory" : mlr_status_string(s), N);
    memcpy(mlr_motion_root_pos_mut(res), root, 3 * N * sizeof(double));
    memcpy(mlr_motion_rot_mut(res), rot, 4 * nj * sizeof(double));
    if (P)
        memcpy(mlr_motion_trans_mut(res), trans, 3 * np * sizeof(double));
    *out = res;
    p->report = rep;
    p->synthesized = 1;
    keep_or_give_back(p);
    if (diag)
        memset(diag, 0, sizeof *diag);
    return MLR_OK;
}

mlr_status mlr_pipeline_run(mlr_pipeline *p, const mlr_motion *in, mlr_motion **out,
                            mlr_diag *diag)
{
    if (!p || !in || !out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_pipeline_run: %s is NULL",
                                !p    ? "p"
                                : !in ? "in"
                                      : "out");
    if (*out == in)
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "mlr_pipeline_run: out holds the input clip (give another motion)");
    char note[sizeof(((mlr_diag *)0)->message)] = "";
    mlr_status s = mlr_pipeline_prepare(p, in, NULL, diag);
    if (s < 0)
        return s;
    if (diag)
        memcpy(note, diag->message, sizeof note);
    s = mlr_pipeline_synthesize(p, out, diag);
    if (s >= 0 && diag)
        memcpy(diag->message, note, sizeof note);
    return s;
}

/* ---- results ----------------------------------------------------------------------------- */

mlr_status mlr_pipeline_report(const mlr_pipeline *p, mlr_guards_report *report, size_t *limited,
                               size_t n_limited)
{
    if (!p)
        return MLR_E_INVALID_ARG;
    if (!p->prepared || !p->synthesized)
        return MLR_E_BAD_STATE;
    const size_t J = mlr_motion_n_joints(p->input);
    if (limited && n_limited != J)
        return MLR_E_INVALID_ARG;
    if (report)
        *report = p->report;
    if (limited)
        memcpy(limited, p->limited.ptr, J * sizeof(size_t));
    return MLR_OK;
}

const mlr_layers *mlr_pipeline_layers(const mlr_pipeline *p)
{
    return p && p->prepared ? p->layers : NULL;
}

mlr_guards *mlr_pipeline_guards(mlr_pipeline *p) { return p && p->prepared ? p->g : NULL; }

void mlr_pipeline_destroy(mlr_pipeline *p)
{
    if (!p)
        return;
    unprepare(p);
    mlr_motion_destroy(p->input);
    drop(p, &p->patterns);
    drop(p, &p->keys);
    drop(p, &p->alpha_rows);
    drop(p, &p->alpha_col);
    drop(p, &p->alpha_src);
    buffer *bufs[] = {&p->names,  &p->fk,   &p->body, &p->rep_root, &p->rep_rot, &p->rep_trans,
                      &p->alphas, &p->root, &p->rot,  &p->trans,    &p->limited};
    for (size_t k = 0; k < MLR_COUNTOF(bufs); k++)
        drop(p, bufs[k]);
    pipeline__arena_free(&p->arena);
    mlr_allocator a = p->user;
    common__free(&a, p, sizeof *p);
}
