/*
 * Plausibility guards of a synthesized motion (see include/mlayer/mlr_guards.h): joint limits,
 * foot contacts and the floor, composed with the defaults of mlayer's Python package.
 */
#include "common/mlr_internal.h"
#include "guards/cleanup_internal.h"
#include "guards/contacts_internal.h"
#include "guards/depop_internal.h"
#include "guards/floor_chains_internal.h"
#include "guards/floor_lift_internal.h"
#include "guards/hinge_side_internal.h"
#include "guards/toe_tilt_internal.h"
#include "guards/upright_internal.h"
#include "guards/legs_swivel_internal.h"
#include "guards/limits_internal.h"
#include "math/quat_internal.h"
#include "common/options_internal.h"

#include <math.h>

/* the cleanup options an apply passes at most (cleanup_options) */
#define GUARDS_MAX_COPTS 12
/* leg lengths: MLR_CLEANUP_OPT_STRAIGHT_SLACK (CMU 01_03's straight climbing leg bent its knee
   0.58% of body height for a pin 0.03% closer to the hip) */
#define GUARDS_STRAIGHT_SLACK 0.002
/* leg lengths: MLR_CLEANUP_OPT_SOFT_REACH (a knee near full reach straightens smoothly) */
#define GUARDS_SOFT_REACH 0.02
#define GUARDS_ROOT_BOB 0.5 /* seconds: MLR_CLEANUP_OPT_ROOT_BOB when the body's alpha is not 1 */

/* The cleanup passes (of its default 2) whose IK's rotations are limited before the spread,
   and whose blends are limited after it. Limiting the IK's rotations of the second pass as
   well leaves the feet off their targets; not limiting the blends let the spread of the
   limited rotations take the dog's front paws (AI4Animation, alpha 3) 95 degrees past their
   swing range on the frames around the contacts, and limiting the first pass's only, 21. */
#define GUARDS_IK_LIMIT_PASSES 1
#define GUARDS_BLEND_LIMIT_PASSES 2
#ifndef GUARDS_KEEP_STILLER
#define GUARDS_KEEP_STILLER 1.25
#endif
/* The input as the stylized feet's reference is smoothed over this many seconds against its
   capture noise (the cleanup's default REF_SMOOTH); denoising follows it unsmoothed, the
   noise then left out of the corrections by the cleanup (PIN_DETAIL 1: the denoised feet keep
   their detail, the pinned ones take the input's slow path). */
#define GUARDS_REF_SMOOTH 0.02
#define GUARDS_LIMITS_SOFT 0.15 /* mlr_limits' default MLR_LIMITS_OPT_SOFT */
/* The floor's dead zone in body heights, the cleanup's (CLEANUP_FLOOR_SLACK, half a percent of
   the leg) for a leg of half the body's height */
#define GUARDS_FLOOR_SLACK 0.0025

struct mlr_guards {
    mlr_allocator alloc;
    /* the rig, copied */
    mlr_rig rig;
    int32_t *parents, *trans_joints, *end_site_parents;
    double *offsets, *end_site_offsets;
    char **names;
    const char **name_ptrs;
    /* the input, copied */
    double fps;
    size_t n_frames, n_joints, n_trans;
    double *root_pos, *rot, *trans;
    /* contacts */
    size_t n_points, n_public; /* the points the cleanup gets; the first n_public are the
                                  contact points (found or set), the others floor-only points
                                  (tips_of: the End Sites below them, the toe tips) */
    int32_t *joints, *end_sites;
    uint8_t *contacts;
    /* settings */
    int up, limits_mode, contacts_on, floor_on, floor_given, follow;
    double floor_height;
    double body_height; /* mlr_rig_body_height of the input (0 when it could not be measured) */
    int32_t body_joint, body_trans; /* the joint that carries the input's body translation
                                       (mlr_rig_body_translation_joint) and its index among the
                                       trans joints; body_trans -1 when it is the root */
    mlr_limits *learned;
    const mlr_limits *limits; /* learned or borrowed */
    /* the input's trajectories as the cleanup's reference (the pinned feet follow them):
       made at create (and again when the contacts change) when the feet follow the input */
    mlr_cleanup_ref *input_ref, *input_ref_raw; /* smoothed (stylize), unsmoothed (denoise) */
    /* the arms whose elbows are kept on the input's side of straight (hinge_side.c) */
    hinge_side arms[HINGE_SIDE_MAX];
    size_t n_arms;
    double *arms_ref; /* N x HINGE_SIDE_MAX: the input's signed flexion of each */
};

static mlr_status check_floor_given(const mlr_guards *g, const double *wpos, mlr_diag *diag);

/* 1 when joint j is one of the C points' joints (a point on the joint itself, no End Site). */
static int is_point_joint(size_t C, const int32_t *joints, const int32_t *end_sites, int32_t j)
{
    for (size_t c = 0; c < C; c++)
        if (joints[c] == j && end_sites[c] < 0)
            return 1;
    return 0;
}

/* The nearest of the points' joints at or above joint j, or -1. */
static int32_t point_above(const mlr_guards *g, size_t C, const int32_t *joints,
                           const int32_t *end_sites, int32_t j)
{
    for (; j >= 0; j = g->parents[j])
        if (is_point_joint(C, joints, end_sites, j))
            return j;
    return -1;
}

/* Most floor-only points taken below one point's joint (the cleanup places at most 16 points on
   a foot). */
#define GUARDS_TIPS_PER_JOINT 8

/* The tips below the C points' joints that are not points themselves, written to tj, te (NULL:
   counted only); returns how many. A tip is an End Site (the toe tip) or a joint with no child
   joint (Mixamo's Toe_End, below the ToeBase point) in the subtree of a point's joint, taken by
   the nearest point joint above it, End Sites first, at most GUARDS_TIPS_PER_JOINT each. They
   are the cleanup's floor-only points (no contact frame): the floor guard keeps them above the
   floor as it does the feet (toe tips sank 1-3.7% of body height at alpha 0.5-3 on CMU clips;
   Mixamo's Toe_End and its End Site 2-5% when only End Sites right below a point were taken). */
static size_t tips_of(const mlr_guards *g, size_t C, const int32_t *joints,
                      const int32_t *end_sites, int32_t *tj, int32_t *te)
{
    const size_t J = g->n_joints, E = g->rig.n_end_sites;
    size_t n = 0;
    for (size_t c = 0; c < C; c++) {
        const int32_t p = joints[c];
        if (end_sites[c] >= 0)
            continue;
        int first = 1; /* a joint listed by several points is taken once */
        for (size_t d = 0; d < c && first; d++)
            first = !(joints[d] == p && end_sites[d] < 0);
        if (!first)
            continue;
        size_t taken = 0;
        for (size_t e = 0; e < E && taken < GUARDS_TIPS_PER_JOINT; e++) {
            const int32_t q = g->rig.end_site_parents[e];
            if (point_above(g, C, joints, end_sites, q) != p)
                continue;
            int listed = 0;
            for (size_t d = 0; d < C && !listed; d++)
                listed = joints[d] == q && end_sites[d] == (int32_t)e;
            if (listed)
                continue;
            if (tj)
                tj[n] = q, te[n] = (int32_t)e;
            n++, taken++;
        }
        /* joints with no child joint, below p (its descendants follow it: depth-first order) */
        for (size_t k = (size_t)p + 1; k < J && taken < GUARDS_TIPS_PER_JOINT; k++) {
            int32_t a = g->parents[k];
            while (a > p)
                a = g->parents[a];
            if (a != p)
                break; /* past p's subtree */
            if (k + 1 < J && g->parents[k + 1] == (int32_t)k)
                continue; /* has a child joint */
            if (point_above(g, C, joints, end_sites, (int32_t)k) != p)
                continue;
            if (tj)
                tj[n] = (int32_t)k, te[n] = -1;
            n++, taken++;
        }
    }
    return n;
}

static void *alloc_array(const mlr_allocator *a, size_t count, size_t size, mlr_status *st)
{
    size_t bytes;
    if (*st != MLR_OK || count == 0)
        return NULL;
    if (common__mul_size(count, size, &bytes) != MLR_OK) {
        *st = MLR_E_OVERFLOW;
        return NULL;
    }
    void *p = common__alloc(a, bytes);
    if (!p)
        *st = MLR_E_NO_MEMORY;
    return p;
}

static void free_array(const mlr_allocator *a, void *p, size_t count, size_t size)
{
    if (p)
        common__free(a, p, count * size);
}

static void free_names(mlr_guards *g)
{
    if (!g->names)
        return;
    for (size_t j = 0; j < g->n_joints; j++)
        if (g->names[j])
            common__free(&g->alloc, g->names[j], strlen(g->names[j]) + 1);
    free_array(&g->alloc, g->names, g->n_joints, sizeof(char *));
    free_array(&g->alloc, g->name_ptrs, g->n_joints, sizeof(char *));
}

static void free_contacts(mlr_guards *g)
{
    free_array(&g->alloc, g->joints, g->n_points, sizeof(int32_t));
    free_array(&g->alloc, g->end_sites, g->n_points, sizeof(int32_t));
    free_array(&g->alloc, g->contacts, g->n_points * g->n_frames, 1);
    g->joints = g->end_sites = NULL;
    g->contacts = NULL;
    g->n_points = g->n_public = 0;
}

void mlr_guards_destroy(mlr_guards *g)
{
    if (!g)
        return;
    const size_t J = g->n_joints, N = g->n_frames, P = g->n_trans, E = g->rig.n_end_sites;
    free_names(g);
    free_array(&g->alloc, g->parents, J, sizeof(int32_t));
    free_array(&g->alloc, g->offsets, 3 * J, sizeof(double));
    free_array(&g->alloc, g->trans_joints, P, sizeof(int32_t));
    free_array(&g->alloc, g->end_site_parents, E, sizeof(int32_t));
    free_array(&g->alloc, g->end_site_offsets, 3 * E, sizeof(double));
    free_array(&g->alloc, g->root_pos, 3 * N, sizeof(double));
    free_array(&g->alloc, g->rot, 4 * N * J, sizeof(double));
    free_array(&g->alloc, g->trans, 3 * N * P, sizeof(double));
    free_contacts(g);
    cleanup__ref_destroy(g->input_ref);
    cleanup__ref_destroy(g->input_ref_raw);
    free_array(&g->alloc, g->arms_ref, HINGE_SIDE_MAX * g->n_frames, sizeof(double));
    mlr_limits_destroy(g->learned);
    mlr_allocator a = g->alloc;
    common__free(&a, g, sizeof *g);
}

/* Copy the rig's arrays into the handle; g->rig then points at the copies. */
static mlr_status copy_rig(mlr_guards *g, const mlr_rig *src)
{
    const size_t J = src->n_joints, P = src->n_trans, E = src->n_end_sites;
    mlr_status st = MLR_OK;
    const mlr_allocator *a = &g->alloc;
    g->parents = alloc_array(a, J, sizeof(int32_t), &st);
    g->offsets = alloc_array(a, 3 * J, sizeof(double), &st);
    g->trans_joints = alloc_array(a, P, sizeof(int32_t), &st);
    g->end_site_parents = alloc_array(a, E, sizeof(int32_t), &st);
    g->end_site_offsets = alloc_array(a, 3 * E, sizeof(double), &st);
    if (src->names) {
        g->names = alloc_array(a, J, sizeof(char *), &st);
        if (g->names)
            memset(g->names, 0, J * sizeof(char *));
        g->name_ptrs = alloc_array(a, J, sizeof(char *), &st);
        for (size_t j = 0; st == MLR_OK && j < J; j++) {
            const char *s = src->names[j] ? src->names[j] : "";
            const size_t n = strlen(s) + 1;
            g->names[j] = common__alloc(a, n);
            if (!g->names[j])
                st = MLR_E_NO_MEMORY;
            else
                memcpy(g->names[j], s, n);
            g->name_ptrs[j] = g->names[j];
        }
    }
    if (st != MLR_OK)
        return st;
    memcpy(g->parents, src->parents, J * sizeof(int32_t));
    memcpy(g->offsets, src->offsets, 3 * J * sizeof(double));
    if (P)
        memcpy(g->trans_joints, src->trans_joints, P * sizeof(int32_t));
    if (E) {
        memcpy(g->end_site_parents, src->end_site_parents, E * sizeof(int32_t));
        memcpy(g->end_site_offsets, src->end_site_offsets, 3 * E * sizeof(double));
    }
    g->rig = (mlr_rig){J,
                       g->parents,
                       g->offsets,
                       src->names ? (const char *const *)g->name_ptrs : NULL,
                       P,
                       P ? g->trans_joints : NULL,
                       E,
                       E ? g->end_site_parents : NULL,
                       E ? g->end_site_offsets : NULL};
    return MLR_OK;
}

static const mlr_opt_spec guards_opts[] = {
    {MLR_GUARDS_OPT_UP, "up", MLR_OPT_INT, 0.0, 2.0, 0, 0, MLR_AXIS_Y,
     "an up axis: 0 (X), 1 (Y) or 2 (Z)"},
    {MLR_GUARDS_OPT_LIMITS, "limits", MLR_OPT_INT, 0.0, 2.0, 0, 0, MLR_GUARDS_LIMITS_AUTO,
     "0 (off), 1 (auto) or 2 (always)"},
    {MLR_GUARDS_OPT_KEEP_CONTACTS, "keep_contacts", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
    {MLR_GUARDS_OPT_FLOOR, "floor", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
    {MLR_GUARDS_OPT_FLOOR_HEIGHT, "floor_height", MLR_OPT_DOUBLE, -INFINITY, INFINITY, 0, 0, NAN,
     NULL},
    {MLR_GUARDS_OPT_FOLLOW, "follow", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
};

static mlr_status read_options(mlr_guards *g, const mlr_guards_option *opts, size_t n_opts,
                               mlr_diag *diag)
{
    mlr_opt_values o;
    mlr_status st = MLR_OPTIONS_READ("guards", guards_opts, opts, n_opts, &o, diag);
    if (st != MLR_OK)
        return st;
    g->up = (int)o.v[MLR_GUARDS_OPT_UP];
    g->limits_mode = (int)o.v[MLR_GUARDS_OPT_LIMITS];
    g->contacts_on = (int)o.v[MLR_GUARDS_OPT_KEEP_CONTACTS];
    g->floor_on = (int)o.v[MLR_GUARDS_OPT_FLOOR];
    g->follow = (int)o.v[MLR_GUARDS_OPT_FOLLOW];
    g->floor_given = o.given[MLR_GUARDS_OPT_FLOOR_HEIGHT];
    if (g->floor_given)
        g->floor_height = o.v[MLR_GUARDS_OPT_FLOOR_HEIGHT];
    return MLR_OK;
}

static mlr_status estimate_floor(mlr_guards *g, mlr_diag *diag)
{
    if (g->floor_given)
        return MLR_OK;
    g->floor_height = NAN;
    if (g->n_points == 0)
        return MLR_OK;
    return mlr_cleanup_floor_height(&g->rig, g->n_frames, g->root_pos, g->rot, g->trans,
                                    g->n_points, g->joints, g->end_sites, g->contacts, g->up, 0.05,
                                    &g->floor_height, &g->alloc, diag);
}

/* estimate_floor from the input's world positions, which create has already computed. */
static mlr_status floor_from_positions(mlr_guards *g, const double *wpos, const double *wrot,
                                       mlr_diag *diag)
{
    if (g->floor_given || g->n_points == 0)
        return estimate_floor(g, diag);
    mlr_status st = MLR_OK;
    double *pts = alloc_array(&g->alloc, 3 * g->n_frames * g->n_points, sizeof(double), &st);
    if (st == MLR_OK)
        st = mlr_rig_point_positions(&g->rig, g->n_frames, wpos, wrot, g->n_points, g->joints,
                                     g->end_sites, pts, diag);
    if (st == MLR_OK)
        st = cleanup__floor_of_points(g->n_frames, g->n_points, pts, g->contacts, g->up, 0.05,
                                      &g->floor_height, &g->alloc);
    if (st == MLR_OK && isnan(g->floor_height)) {
        /* no contact frame (a clip of 14 frames, a jump in the air): the 5th percentile over
           frames of the feet's lowest point, so the feet still go no lower than the input's
           (toe tips went 3% of body height under it on 0.6 s clips, with no floor guard) */
        const size_t N = g->n_frames, C = g->n_points;
        for (size_t f = 0; f < N; f++) {
            double low = pts[3 * (f * C) + (size_t)g->up];
            for (size_t c = 1; c < C; c++)
                low = common__fmin(low, pts[3 * (f * C + c) + (size_t)g->up]);
            pts[f] = low; /* (row f's values are read before row f is written: f <= 3 f C) */
        }
        g->floor_height = cleanup__quantile_of(pts, N, 0.05);
    }
    free_array(&g->alloc, pts, 3 * g->n_frames * g->n_points, sizeof(double));
    return st == MLR_OK ? MLR_OK
                        : common__diag_set(diag, st, 0, 0, "guards: the floor: %s",
                                           st == MLR_E_NO_MEMORY ? "out of memory" : "bad points");
}

/* Feet by name and their contacts on the input; a rig without feet gets none. */
static mlr_status find_contacts(mlr_guards *g, const double *world_pos, const double *world_rot,
                                mlr_diag *diag)
{
    const size_t J = g->n_joints, N = g->n_frames;
    if (!g->rig.names)
        return MLR_OK;
    mlr_status st = MLR_OK;
    int32_t *fj = alloc_array(&g->alloc, 2 * J, sizeof(int32_t), &st);
    int32_t *fe = alloc_array(&g->alloc, 2 * J, sizeof(int32_t), &st);
    size_t n_feet = 0;
    if (st != MLR_OK)
        common__diag_set(diag, st, 0, 0, "guards: %s for the feet (2 x %zu joints)",
                         st == MLR_E_OVERFLOW ? "size overflow" : "out of memory", J);
    /* the body height, once for find_feet and detect; when it cannot be measured (a position
     * not finite) they measure it themselves and fail as they would */
    double H = 0.0;
    const double *height = NULL;
    if (st == MLR_OK) {
        st = mlr_rig_body_height(N, J, world_pos, g->up, &H, &g->alloc, NULL);
        if (st == MLR_OK)
            height = &H, g->body_height = H;
        else if (st == MLR_E_NO_MEMORY)
            common__diag_set(diag, st, 0, 0, "guards: out of memory for the body height");
        else
            st = MLR_OK;
    }
    if (st == MLR_OK) {
        mlr_diag quiet;
        st = contacts__find_feet(&g->rig, N, world_pos, g->up, J, fj, fe, &n_feet, &g->alloc,
                                 height, &quiet);
        if (st == MLR_E_INVALID_ARG) { /* no feet by name: nothing to pin */
            st = MLR_OK;
            n_feet = 0;
        } else if (st != MLR_OK) {
            common__diag_set(diag, st, 0, 0, "guards: finding the feet: %s", quiet.message);
        }
    }
    size_t C = 0;
    for (size_t k = 0; st == MLR_OK && k < 2 * n_feet; k++)
        if (fj[k] >= 0)
            fj[C] = fj[k], fe[C] = fe[k], C++;
    const size_t T = st == MLR_OK && C ? tips_of(g, C, fj, fe, NULL, NULL) : 0;
    if (st == MLR_OK && C) {
        g->joints = alloc_array(&g->alloc, C + T, sizeof(int32_t), &st);
        g->end_sites = alloc_array(&g->alloc, C + T, sizeof(int32_t), &st);
        g->contacts = alloc_array(&g->alloc, (C + T) * N, 1, &st);
        g->n_points = C + T, g->n_public = C;
        if (st != MLR_OK)
            common__diag_set(diag, st, 0, 0, "guards: %s for %zu contact points",
                             st == MLR_E_OVERFLOW ? "size overflow" : "out of memory", C);
        if (st == MLR_OK) {
            memcpy(g->joints, fj, C * sizeof(int32_t));
            memcpy(g->end_sites, fe, C * sizeof(int32_t));
            tips_of(g, C, fj, fe, g->joints + C, g->end_sites + C);
            /* the contacts of the C points (N x C), then spread to the N x (C + T) layout with
               the tips' columns 0 */
            st = contacts__detect(&g->rig, g->fps, g->up, N, world_pos, world_rot, C, g->joints,
                                  g->end_sites, NULL, 0, g->contacts, &g->alloc, height, diag);
            if (st == MLR_E_INVALID_ARG) /* a flat skeleton: no body size, nothing to pin */
                st = MLR_OK, free_contacts(g);
            else if (st == MLR_OK && T)
                for (size_t f = N; f-- > 0;) {
                    memmove(g->contacts + f * (C + T), g->contacts + f * C, C);
                    memset(g->contacts + f * (C + T) + C, 0, T);
                }
        }
    }
    free_array(&g->alloc, fj, 2 * J, sizeof(int32_t));
    free_array(&g->alloc, fe, 2 * J, sizeof(int32_t));
    return st;
}

/* The input's trajectories for C points (NULL when the feet do not follow the input or there
 * is no point, or more than the cleanup takes: apply then reports that). wpos, wrot: the
 * input's forward kinematics, or NULL. */
static mlr_status make_input_ref(const mlr_guards *g, size_t C, const int32_t *joints,
                                 const int32_t *end_sites, const double *wpos, const double *wrot,
                                 double seconds, mlr_cleanup_ref **out, mlr_diag *diag)
{
    *out = NULL;
    if (!g->follow || C == 0 || C > 64)
        return MLR_OK;
    mlr_diag d = {0, 0, ""};
    const mlr_cleanup_option smooth = {MLR_CLEANUP_OPT_REF_SMOOTH, seconds};
    const mlr_status st =
        cleanup__ref_create(&g->rig, g->n_frames, g->fps, g->up, g->root_pos, g->rot, g->trans,
                            wpos, wrot, C, joints, end_sites, &smooth, 1, &g->alloc, out, &d);
    if (st ==
        MLR_E_INVALID_ARG) /* points the cleanup refuses (over 16 on a foot): apply says so */
        return MLR_OK;
    return st == MLR_OK ? MLR_OK : common__diag_set(diag, st, 0, 0, "guards: %s", d.message);
}

static mlr_status check_finite(const double *x, size_t n, const char *what, mlr_diag *diag)
{
    const size_t k = common__first_nonfinite(x, n);
    if (k < n)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards: %s value %zu is not "
                                "finite",
                                what, k);
    return MLR_OK;
}

mlr_status mlr_guards_create(const mlr_rig *rig, double fps, size_t n_frames,
                             const double *root_pos, const double *rot, const double *trans,
                             const mlr_guards_option *opts, size_t n_opts,
                             const mlr_allocator *alloc, mlr_guards **out, mlr_diag *diag)
{
    if (!out)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards: out is NULL");
    *out = NULL;
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    const size_t J = rig->n_joints, N = n_frames, P = rig->n_trans;
    if (!(isfinite(fps) && fps > 0.0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards: fps must be finite and > 0, "
                                "got %g",
                                fps);
    if (N < 3)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards: need at least 3 frames, "
                                "got %zu",
                                N);
    if (!root_pos || !rot || (P && !trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards: NULL frames");
    size_t n_rot, n_pos;
    if (common__mul_size(4 * J, N, &n_rot) != MLR_OK ||
        common__mul_size(3 * J, N, &n_pos) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "guards: frames too large");
    /* rot is checked by its normalization below (the same message) */
    if ((st = check_finite(root_pos, 3 * N, "root_pos", diag)) != MLR_OK ||
        (P && (st = check_finite(trans, 3 * N * P, "trans", diag)) != MLR_OK))
        return st;

    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_guards *g = common__alloc(&a, sizeof *g);
    if (!g)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "guards: out of memory");
    memset(g, 0, sizeof *g);
    g->alloc = a;
    g->fps = fps;
    g->n_frames = N;
    g->n_joints = J;
    g->n_trans = P;
    g->rig.n_end_sites = 0; /* for destroy until the copy is made */
    g->up = MLR_AXIS_Y;
    g->limits_mode = MLR_GUARDS_LIMITS_AUTO;
    g->contacts_on = g->floor_on = g->follow = 1;
    g->floor_height = NAN;
    if ((st = read_options(g, opts, n_opts, diag)) != MLR_OK) {
        mlr_guards_destroy(g);
        return st;
    }
    g->rig.n_end_sites = rig->n_end_sites;
    st = copy_rig(g, rig);
    g->root_pos = alloc_array(&a, 3 * N, sizeof(double), &st);
    g->rot = alloc_array(&a, n_rot, sizeof(double), &st);
    g->trans = alloc_array(&a, 3 * N * P, sizeof(double), &st);
    double *wpos = alloc_array(&a, n_pos, sizeof(double), &st);
    double *wrot = alloc_array(&a, n_rot, sizeof(double), &st);
    if (st != MLR_OK) {
        common__diag_set(diag, st, 0, 0, "guards: out of memory");
        goto done;
    }
    memcpy(g->root_pos, root_pos, 3 * N * sizeof(double));
    if (P)
        memcpy(g->trans, trans, 3 * N * P * sizeof(double));
    g->body_trans = -1;
    if ((st = mlr_rig_body_translation_joint(&g->rig, N, g->root_pos, g->trans, &g->body_joint,
                                             diag)) != MLR_OK)
        goto done;
    size_t depth = 0; /* carry_body_shift walks the body joint's ancestors (at most 64) */
    for (int32_t j = g->parents[g->body_joint]; j >= 0; j = g->parents[j])
        depth++;
    for (size_t k = 0; k < P && depth <= 64; k++)
        if (g->trans_joints[k] == g->body_joint)
            g->body_trans = (int32_t)k;
    /* unit rotations, as the layers, the limits and the cleanup take them */
    st = quat__unit_array((const mlr_quat *)rot, N * J, (mlr_quat *)g->rot);
    if (st != MLR_OK) { /* the message of the first value not finite, else of a zero */
        if (check_finite(rot, n_rot, "rot", diag) == MLR_OK)
            common__diag_set(diag, st, 0, 0, "guards: a rotation of the input is zero");
        st = MLR_E_INVALID_ARG;
        goto done;
    }
    /* the positions of every joint (the body's size, the feet); the world rotations of the
       End Sites' parents only (the feet's points read them, to place an End Site) */
    size_t n_ends = 0;
    int32_t *ends = alloc_array(&a, J, sizeof(int32_t), &st);
    if (st != MLR_OK) {
        common__diag_set(diag, st, 0, 0, "guards: out of memory");
        goto done;
    }
    /* and of the elbows' parents (the arms' hinge axes live in their frames) */
    hinge_side arms[HINGE_SIDE_MAX];
    const size_t n_arms = g->limits_mode != MLR_GUARDS_LIMITS_OFF
                              ? hinge_side__chains(&g->rig, arms, HINGE_SIDE_MAX)
                              : 0;
    for (size_t e = 0; e < g->rig.n_end_sites + n_arms; e++) {
        const int32_t p = e < g->rig.n_end_sites ? g->rig.end_site_parents[e]
                                                 : g->parents[arms[e - g->rig.n_end_sites].middle];
        size_t i = 0;
        while (i < n_ends && ends[i] != p)
            i++;
        if (i == n_ends)
            ends[n_ends++] = p;
    }
    st = fk__arrays_rot_at(N, J, g->parents, g->offsets, g->root_pos, g->rot, P, g->trans_joints,
                           g->trans, wpos, wrot, ends, n_ends, &a);
    free_array(&a, ends, J, sizeof(int32_t));
    if (st != MLR_OK) {
        common__diag_set(diag, st, 0, 0, "guards: forward kinematics of the input failed");
        goto done;
    }
    if (n_arms) {
        g->arms_ref = alloc_array(&a, HINGE_SIDE_MAX * N, sizeof(double), &st);
        if (st != MLR_OK) {
            common__diag_set(diag, st, 0, 0, "guards: out of memory");
            goto done;
        }
    }
    for (size_t k = 0; k < n_arms; k++)
        if (hinge_side__learn(&g->rig, N, wpos, wrot, &arms[k], g->arms_ref + g->n_arms * N))
            g->arms[g->n_arms++] = arms[k];
    int upside_down = 0;
    if ((g->contacts_on || g->floor_on) &&
        (st = upright__upside_down(&g->rig, N, wpos, g->up, &a, &upside_down)) != MLR_OK) {
        common__diag_set(diag, st, 0, 0, "guards: out of memory");
        goto done;
    }
    if (g->floor_on && g->floor_given && (st = check_floor_given(g, wpos, diag)) != MLR_OK)
        goto done;
    if (g->contacts_on || g->floor_on)
        if ((st = find_contacts(g, wpos, wrot, diag)) != MLR_OK ||
            (st = floor_from_positions(g, wpos, wrot, diag)) != MLR_OK ||
            (st = make_input_ref(g, g->n_points, g->joints, g->end_sites, wpos, wrot,
                                 GUARDS_REF_SMOOTH, &g->input_ref, diag)) != MLR_OK ||
            (st = make_input_ref(g, g->n_points, g->joints, g->end_sites, wpos, wrot, 0.0,
                                 &g->input_ref_raw, diag)) != MLR_OK)
            goto done;
    if (g->limits_mode != MLR_GUARDS_LIMITS_OFF) {
        const mlr_limits_clip clip = {N, g->rot, P ? g->trans : NULL};
        st = limits__create_unit(&g->rig, &clip, 1, &a, &g->learned, diag);
        if (st != MLR_OK)
            goto done;
        g->limits = g->learned;
    }
done:
    free_array(&a, wpos, n_pos, sizeof(double));
    free_array(&a, wrot, n_rot, sizeof(double));
    if (st != MLR_OK) {
        mlr_guards_destroy(g);
        return common__diag_prefix(diag, st, "guards"); /* a nested call's message names guards */
    }
    *out = g;
    if (diag)
        diag->message[0] = '\0', diag->line = diag->column = 0;
    if ((g->contacts_on || g->floor_on) && g->n_points == 0)
        common__diag_set(
            diag, MLR_OK, 0, 0,
            "guards: no foot found (no joint named foot, ankle or toe, nor a hand that "
            "stays low): the contact and floor guards are skipped");
    else if (upside_down)
        common__diag_set(
            diag, MLR_OK, 0, 0,
            "guards: the body stands upside down along +%c (feet above the joints' mean; "
            "image y down?): the floor guards take its head as lowest; turn it upright",
            "XYZ"[g->up]);
    return MLR_OK;
}

size_t mlr_guards_n_points(const mlr_guards *g) { return g && g->contacts_on ? g->n_public : 0; }

mlr_status mlr_guards_get_contacts(const mlr_guards *g, int32_t *joints, int32_t *end_sites,
                                   uint8_t *contacts)
{
    if (!g)
        return MLR_E_INVALID_ARG;
    const size_t C = mlr_guards_n_points(g);
    if (C && joints)
        memcpy(joints, g->joints, C * sizeof(int32_t));
    if (C && end_sites)
        memcpy(end_sites, g->end_sites, C * sizeof(int32_t));
    for (size_t f = 0; C && contacts && f < g->n_frames; f++)
        memcpy(contacts + f * C, g->contacts + f * g->n_points, C);
    return MLR_OK;
}

mlr_status mlr_guards_set_contacts(mlr_guards *g, size_t n_points, const int32_t *joints,
                                   const int32_t *end_sites, const uint8_t *contacts,
                                   mlr_diag *diag)
{
    if (!g || (n_points && (!joints || !contacts)))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards: NULL argument");
    const size_t N = g->n_frames, C = n_points;
    for (size_t c = 0; c < C; c++) {
        const int32_t j = joints[c], e = end_sites ? end_sites[c] : -1;
        if (j < 0 || (size_t)j >= g->n_joints || e < -1 ||
            (e >= 0 && ((size_t)e >= g->rig.n_end_sites || g->rig.end_site_parents[e] != j)))
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "guards: contact point %zu (joint %d, End Site %d) names nothing "
                "in the rig",
                c, (int)j, (int)e);
        for (size_t d = 0; d < c; d++)
            if (joints[d] == j && (end_sites ? end_sites[d] : -1) == e)
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "guards: contact point %zu is listed twice", c);
    }
    mlr_status st = MLR_OK;
    int32_t *nj = alloc_array(&g->alloc, C, sizeof(int32_t), &st);
    int32_t *ne = alloc_array(&g->alloc, C, sizeof(int32_t), &st);
    if (st == MLR_OK)
        for (size_t c = 0; c < C; c++) {
            nj[c] = joints[c];
            ne[c] = end_sites ? end_sites[c] : -1;
        }
    const size_t T = st == MLR_OK && C ? tips_of(g, C, nj, ne, NULL, NULL) : 0, A = C + T;
    free_array(&g->alloc, nj, C, sizeof(int32_t));
    free_array(&g->alloc, ne, C, sizeof(int32_t));
    nj = alloc_array(&g->alloc, A, sizeof(int32_t), &st);
    ne = alloc_array(&g->alloc, A, sizeof(int32_t), &st);
    uint8_t *nc = alloc_array(&g->alloc, A * N, 1, &st);
    if (st != MLR_OK) {
        free_array(&g->alloc, nj, A, sizeof(int32_t));
        free_array(&g->alloc, ne, A, sizeof(int32_t));
        free_array(&g->alloc, nc, A * N, 1);
        return common__diag_set(diag, st, 0, 0, "guards: out of memory");
    }
    for (size_t c = 0; c < C; c++) {
        nj[c] = joints[c];
        ne[c] = end_sites ? end_sites[c] : -1;
    }
    if (T)
        tips_of(g, C, nj, ne, nj + C, ne + C);
    for (size_t f = 0; f < N; f++)
        for (size_t c = 0; c < A; c++)
            nc[f * A + c] = c < C && contacts[f * C + c] != 0;
    mlr_cleanup_ref *ref = NULL, *raw = NULL;
    if ((g->contacts_on || g->floor_on) &&
        ((st = make_input_ref(g, A, nj, ne, NULL, NULL, GUARDS_REF_SMOOTH, &ref, diag)) !=
             MLR_OK ||
         (st = make_input_ref(g, A, nj, ne, NULL, NULL, 0.0, &raw, diag)) != MLR_OK)) {
        cleanup__ref_destroy(ref);
        free_array(&g->alloc, nj, A, sizeof(int32_t));
        free_array(&g->alloc, ne, A, sizeof(int32_t));
        free_array(&g->alloc, nc, A * N, 1);
        return st;
    }
    free_contacts(g);
    cleanup__ref_destroy(g->input_ref);
    cleanup__ref_destroy(g->input_ref_raw);
    g->input_ref = ref, g->input_ref_raw = raw;
    g->joints = nj, g->end_sites = ne, g->contacts = nc, g->n_points = A, g->n_public = C;
    return estimate_floor(g, diag);
}

mlr_status mlr_guards_set_limits(mlr_guards *g, const mlr_limits *limits, mlr_diag *diag)
{
    if (!g)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards: NULL handle");
    if (limits && mlr_limits_n_joints(limits) != g->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards: limits for %zu joints, the rig has %zu",
                                mlr_limits_n_joints(limits), g->n_joints);
    g->limits = limits ? limits : g->learned;
    return MLR_OK;
}

/* The largest knee flexion the cleanup's IK may use while the limits are on: the knee point of
 * the fold side of the legs' hinges (hi - soft (hi - lo), the limits' default soft width),
 * where the limits' saturation begins, so the limits after the cleanup leave the IK's knees
 * as they are; pi when no leg of a contact point has a hinge knee. */
static double knee_fold_limit(const mlr_guards *g)
{
    double fold = 3.14159265358979323846;
    for (size_t c = 0; c < g->n_points; c++) {
        int32_t hip, knee;
        mlr_limits_range r;
        if (g->end_sites[c] >= 0 ||
            mlr_ik_leg_chain(&g->rig, g->joints[c], &hip, &knee, NULL) != MLR_OK ||
            mlr_limits_get_range(g->limits, (size_t)knee, &r) != MLR_OK ||
            r.kind != MLR_LIMITS_HINGE)
            continue;
        const double k = r.hi - GUARDS_LIMITS_SOFT * (r.hi - r.lo);
        if (k > 0.0 && k < fold)
            fold = k;
    }
    return fold;
}

/* The last word of the floor guard: where a foot point of the result is still below
 * min(floor, the reference's height of that point), or (whole_body) any joint or End Site below
 * min(floor, the input's height of that point), by more than the slack, the whole body is
 * raised along up by a smooth envelope of the shortfall (floor_lift.c: it covers the
 * shortfall, enters and leaves over ramps that grow with its size, and is zero far from it).
 * Joint angles do not change, so the limits stay met; a foot that the joint limits or IK could
 * not keep above the floor is lifted with the body, and so is what the cleanup's root shift,
 * pinning the feet, took below it (a rearing dog's head 21% of body height at alpha 3; the
 * chains that carry a foot cannot be blended without unpinning it). Adds the raised frames to
 * *raised. */
static mlr_status raise_to_floor(const mlr_guards *g, const mlr_cleanup_ref *ref, double *root,
                                 const double *rot, const double *trans, int whole_body,
                                 size_t *raised)
{
    const size_t N = g->n_frames, C = g->n_points, J = g->n_joints, E = g->rig.n_end_sites;
    const size_t B = whole_body ? J + E : 0; /* the body's points: every joint and End Site */
    mlr_status st = MLR_OK;
    double *hout = alloc_array(&g->alloc, 2 * N * C, sizeof(double), &st);
    double *hin = hout ? hout + N * C : NULL; /* the input's */
    double *need = alloc_array(&g->alloc, N, sizeof(double), &st);
    /* the result's heights of the body's points (N x B), then the input's at one frame (B) */
    double *hb = B ? alloc_array(&g->alloc, N * B + B, sizeof(double), &st) : NULL;
    /* the body's points: their joints (-1: not counted), End Sites, joints */
    int32_t *bj = B ? alloc_array(&g->alloc, 3 * B, sizeof(int32_t), &st) : NULL;
    if (st == MLR_OK)
        st = cleanup__point_heights(&g->rig, N, root, rot, trans, C, g->joints, g->end_sites,
                                    g->up, hout, &g->alloc);
    if (st == MLR_OK && B) { /* the body's points, in the input (hb) and in the result */
        for (size_t p = 0; p < B; p++) {
            bj[p] = bj[2 * B + p] = p < J ? (int32_t)p : g->rig.end_site_parents[p - J];
            bj[B + p] = p < J ? -1 : (int32_t)(p - J);
        }
        st = cleanup__point_heights(&g->rig, N, root, rot, trans, B, bj + 2 * B, bj + B, g->up, hb,
                                    &g->alloc);
        /* the joints above the one that carries the body stay where they are (the guards
           carry a root shift into the body's translation: carry_body_shift) */
        if (g->body_trans >= 0)
            for (int32_t a = g->parents[g->body_joint]; a >= 0; a = g->parents[a])
                for (size_t p = 0; p < B; p++)
                    if (p < J ? p == (size_t)a : g->rig.end_site_parents[p - J] == a)
                        bj[p] = -1;
    }
    if (st == MLR_OK) {
        int any = 0;
        for (size_t f = 0; f < N; f++) {
            double d = 0.0;
            for (size_t c = 0; c < C; c++) {
                /* no reference: the floor alone */
                const double lim =
                    ref ? common__fmin(g->floor_height, ref->h[f * C + c]) : g->floor_height;
                d = common__fmax(d, lim - hout[f * C + c] - GUARDS_FLOOR_SLACK * g->body_height);
            }
            /* the body's points: below the floor only as deep as the input there (its
               heights found for the frames where some point is below the floor at all) */
            const double low = g->floor_height - GUARDS_FLOOR_SLACK * g->body_height;
            int below = 0;
            for (size_t p = 0; p < B && !below; p++)
                below = bj[p] >= 0 && hb[f * B + p] < low;
            if (below) {
                double *hb_in = hb + N * B;
                const size_t P = g->n_trans;
                st = cleanup__point_heights(&g->rig, 1, g->root_pos + 3 * f, g->rot + 4 * J * f,
                                            P ? g->trans + 3 * P * f : NULL, B, bj + 2 * B, bj + B,
                                            g->up, hb_in, &g->alloc);
                if (st != MLR_OK)
                    break;
                for (size_t p = 0; p < B; p++) /* (Bandai's joint_Root, above the body: not) */
                    if (bj[p] >= 0)
                        d = common__fmax(d, common__fmin(g->floor_height, hb_in[p]) -
                                                hb[f * B + p] -
                                                GUARDS_FLOOR_SLACK * g->body_height);
            }
            need[f] = d;
            any |= d > 0.0;
        }
        if (any && st == MLR_OK) {
            for (size_t f = 0; f < N; f++)
                *raised += need[f] > 0.0;
            st = cleanup__point_heights(&g->rig, N, g->root_pos, g->rot, g->trans, C, g->joints,
                                        g->end_sites, g->up, hin, &g->alloc);
        }
        if (any && st == MLR_OK) {
            double a_ref = 0.0; /* the input's largest vertical second difference at its feet */
            for (size_t f = 1; f + 1 < N; f++)
                for (size_t c = 0; c < C; c++)
                    a_ref = common__fmax(a_ref, fabs(hin[(f + 1) * C + c] - 2.0 * hin[f * C + c] +
                                                     hin[(f - 1) * C + c]));
            st = floor_lift__smooth(N, g->fps, need, a_ref, g->up, root, &g->alloc);
        }
    } else if (st != MLR_E_NO_MEMORY && st != MLR_E_OVERFLOW) {
        st = MLR_E_INVALID_ARG;
    }
    free_array(&g->alloc, hout, 2 * N * C, sizeof(double));
    free_array(&g->alloc, need, N, sizeof(double));
    free_array(&g->alloc, hb, N * B + B, sizeof(double));
    free_array(&g->alloc, bj, 3 * B, sizeof(int32_t));
    return st;
}

/* A given floor height must meet the input's body: between its highest joint and its lowest
   less the span of its joints (both along up, over the clip). A floor far from the body
   raised the whole body to it (10^12 above the clip: a root at 10^12). */
static mlr_status check_floor_given(const mlr_guards *g, const double *wpos, mlr_diag *diag)
{
    const size_t n = g->n_frames * g->n_joints;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        const double h = wpos[3 * i + (size_t)g->up];
        lo = h < lo ? h : lo;
        hi = h > hi ? h : hi;
    }
    const double f = g->floor_height;
    if (f >= lo - (hi - lo) && f <= hi)
        return MLR_OK;
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "guards: floor height %.6g is not near the input's body (its joints "
                            "lie from %.6g to %.6g along up)",
                            f, lo, hi);
}

/* The given reference as the cleanup checks it (the same message). */
static mlr_status check_reference(const mlr_guards *g, const double *root, const double *rot,
                                  const double *trans, mlr_diag *diag)
{
    const size_t N = g->n_frames, J = g->n_joints, P = g->n_trans;
    for (size_t k = 0; k < 3 * N; k++)
        if (!isfinite(root[k]))
            goto bad;
    for (size_t k = 0; k < 4 * N * J; k++)
        if (!isfinite(rot[k]))
            goto bad;
    for (size_t k = 0; k < 3 * N * P; k++)
        if (!isfinite(trans[k]))
            goto bad;
    return MLR_OK;
bad:
    return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                            "reference contains NaN or infinite values");
}

static int limits_wanted(const mlr_guards *g, const double *alpha, size_t n_alpha)
{
    if (!g->limits || g->limits_mode == MLR_GUARDS_LIMITS_OFF)
        return 0;
    if (g->limits_mode == MLR_GUARDS_LIMITS_ALWAYS)
        return 1;
    for (size_t k = 0; k < n_alpha; k++)
        if (fabs(alpha[k]) > 1.0)
            return 1;
    return 0;
}

/* The arguments of mlr_guards_apply, checked. */
static mlr_status apply_check(const mlr_guards *g, const double *alpha, size_t n_alpha,
                              const double *ref_root_pos, const double *ref_rot,
                              const double *ref_trans, const double *root_pos, const double *rot,
                              const double *trans, const size_t *limited, size_t n_limited,
                              mlr_diag *diag)
{
    if (!g || !alpha || !root_pos || !rot || (g->n_trans && !trans))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards apply: NULL argument");
    const size_t N = g->n_frames, J = g->n_joints, P = g->n_trans;
    if (n_alpha != 1 && n_alpha != 1 + J)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards apply: %zu alphas, expected 1 or %zu", n_alpha, 1 + J);
    if (limited && n_limited != J)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards apply: limited holds %zu counts, expected %zu", n_limited,
                                J);
    const int has_ref = ref_root_pos || ref_rot || ref_trans;
    if (has_ref && (!ref_root_pos || !ref_rot || (P && !ref_trans)))
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "guards apply: give the whole reference (root_pos, rot and trans) or "
            "none");
    for (size_t k = 0; k < n_alpha; k++)
        if (!isfinite(alpha[k]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "guards apply: alpha %zu is not finite", k);
    /* with the limits on, rot is checked by their normalization (rot_error, the same
       messages) */
    mlr_status st;
    if ((st = check_finite(root_pos, 3 * N, "root_pos", diag)) != MLR_OK ||
        (!limits_wanted(g, alpha, n_alpha) &&
         (st = check_finite(rot, 4 * N * J, "rot", diag)) != MLR_OK) ||
        (P && (st = check_finite(trans, 3 * N * P, "trans", diag)) != MLR_OK))
        return st;
    return MLR_OK;
}

/* The message of mlr_guards_apply for rotations that its limits could not normalize: the first
   value not finite, as apply_check names it, else the zero quaternion, as the limits do. */
static mlr_status rot_error(const mlr_guards *g, const double *rot, mlr_diag *diag)
{
    mlr_status st = check_finite(rot, 4 * g->n_frames * g->n_joints, "rot", diag);
    if (st == MLR_OK)
        st = limits__rot_error(g->limits, g->n_frames, rot, diag);
    /* (a quaternion that fails the normalization is zero or not finite: one of the two) */
    return st != MLR_OK ? st
                        : common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                           "guards apply: a rotation is zero or not finite");
}

/* The reference the pinned feet follow: the input's trajectories (made at create), or those
   of the given reference, made here (*made, released by the caller);
   *ref NULL when the feet do not follow. */
static mlr_status apply_reference(const mlr_guards *g, const double *ref_root_pos,
                                  const double *ref_rot, const double *ref_trans, int denoising,
                                  const mlr_cleanup_ref **ref, mlr_cleanup_ref **made,
                                  mlr_diag *diag)
{
    const int has_ref = ref_root_pos || ref_rot || ref_trans;
    mlr_status st;
    if (g->follow && has_ref) {
        const mlr_cleanup_option smooth0 = {MLR_CLEANUP_OPT_REF_SMOOTH, 0.0};
        if ((st = check_reference(g, ref_root_pos, ref_rot, ref_trans, diag)) != MLR_OK ||
            (st = cleanup__ref_create(&g->rig, g->n_frames, g->fps, g->up, ref_root_pos, ref_rot,
                                      g->n_trans ? ref_trans : NULL, NULL, NULL, g->n_points,
                                      g->joints, g->end_sites, &smooth0, 1, &g->alloc, made,
                                      diag)) != MLR_OK)
            return common__diag_prefix(diag, st, "guards");
        *ref = *made;
    } else if (g->follow) {
        *ref = denoising ? g->input_ref_raw : g->input_ref;
        if (!*ref &&
            (st = make_input_ref(g, g->n_points, g->joints, g->end_sites, NULL, NULL,
                                 denoising ? 0.0 : GUARDS_REF_SMOOTH, made, diag)) != MLR_OK)
            return st;
        *ref = *ref ? *ref : *made;
    }
    return MLR_OK;
}

/* Whether every alpha is 1: denoise (the layers as they are), not a stylization. */
static int is_denoise(const double *alpha, size_t n_alpha)
{
    int ones = 1;
    for (size_t k = 0; k < n_alpha; k++)
        ones &= alpha[k] == 1.0;
    return ones;
}

/* The diag of a step of apply that runs forward kinematics of the result (st: its failure). */
static void fk_failure(mlr_status st, mlr_diag *diag)
{
    common__diag_set(diag, st, 0, 0, "guards apply: %s",
                     st == MLR_E_NO_MEMORY ? "out of memory"
                                           : "forward kinematics of the result failed");
}

/* The toe tips of the working frames above the floor by a tilt (toe_tilt.c), against the
   input; the diag set on failure. */
static mlr_status tilt_toes(const mlr_guards *g, const guards_input *in, const double *root,
                            double *rot, const double *trans, mlr_diag *diag)
{
    const mlr_status st = toe_tilt__apply(
        &g->rig, g->n_frames, g->fps, g->up, g->floor_height, GUARDS_FLOOR_SLACK * g->body_height,
        in, root, rot, trans, g->n_points, g->joints, g->end_sites, NULL, &g->alloc);
    if (st != MLR_OK)
        fk_failure(st, diag);
    return st;
}

/* The cleanup's options for this apply (at most GUARDS_MAX_COPTS, in copts); returns their
   count. */
static size_t cleanup_options(const mlr_guards *g, int has_ref, const double *alpha,
                              size_t n_alpha, int floor_on, int limits_applied,
                              mlr_cleanup_option copts[GUARDS_MAX_COPTS])
{
    size_t n_copts = 0;
    /* a given reference (the denoised motion) is followed as it is; the input is
     * smoothed against its capture noise first (the cleanup's default) */
    const int denoising = is_denoise(alpha, n_alpha);
    if (g->follow)
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_REF_SMOOTH,
                                                has_ref || denoising ? 0.0 : GUARDS_REF_SMOOTH};
    /* a contact whose synthesized foot slides no more than the reference's keeps its own
       trajectory; when denoising (every alpha 1) up to GUARDS_KEEP_STILLER times as much,
       so that an input that does not slide comes out of denoise as it went in (the
       denoised feet then differ from the input's by smoothing alone) */
    if (g->follow) {
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_KEEP_STILLER,
                                                denoising ? GUARDS_KEEP_STILLER : 1.0};
        /* ... but no more in all than the reference: the runs that slide most beyond it are
           pinned first (CMU 131_01 denoised slid 1.010x its input with every run within
           1.25x kept) */
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_KEEP_TOTAL, 1.0};
        /* denoising: the pinned feet keep the denoised detail, without the input's noise */
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_PIN_DETAIL, denoising ? 1.0 : 0.0};
        /* denoising: the ramps carry the edge's offset alone; following the reference's
           motion there (the denoised motion, followed as it is) changed clean captures more
           (a climbing CMU take 0.94% -> 2.4% of body height) for no fewer pops */
        if (denoising)
            copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_RAMP_TRACK, 0.0};
    }
    copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_FLOOR, floor_on ? 1.0 : 0.0};
    /* a body whose bob the synthesis scaled keeps it: the root's vertical shift over a gait
       cycle (off at alpha 1, where the bob is the input's: denoise, generated motion) */
    if (alpha[0] != 1.0)
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_ROOT_BOB, GUARDS_ROOT_BOB};
    if (limits_applied)
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_MAX_FOLD, knee_fold_limit(g)};
    if (floor_on)
        copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_FLOOR_HEIGHT, g->floor_height};
    copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_STRAIGHT_SLACK, GUARDS_STRAIGHT_SLACK};
    copts[n_copts++] = (mlr_cleanup_option){MLR_CLEANUP_OPT_SOFT_REACH, GUARDS_SOFT_REACH};
    return n_copts;
}

/* The working frames of one apply and the limits' counts (the largest per joint over the
   stages, and one stage's). */
typedef struct apply_work {
    double *rot, *root;
    size_t *counts, *counts2;
    double *before; /* N x n_legs x 4: the rotations of legs[] before the cleanup (compact,
                         so that the frames' legs are read from cache) */
    uint8_t *changed; /* N x J: the rotations the cleanup changed */
    const int32_t *legs; /* the hinges the cleanup can change: those among the contact
                            points' joints and their ancestors (the legs' knees) */
    size_t n_legs;
} apply_work;

/* A rotation the cleanup changed by less than this (in a quaternion's components, about
   half the angle) counts as unchanged: the spread's tails far from any contact are rounding,
   and whether rounding changed a rotation must not decide whether it is limited again (at
   1e-14 a clip turned to Z up came out 3e-4 body heights off the turned result; at 1e-12 and
   1e-10, 1e-13). */
#define GUARDS_CHANGED 1e-12

/* w->before = the rotations of w->legs (the only ones clamp_changed_hinges reads). */
static void keep_legs(const apply_work *w, size_t N, size_t J)
{
    for (size_t f = 0; f < N; f++)
        for (size_t i = 0; i < w->n_legs; i++) {
            memcpy(w->before + 4 * (f * w->n_legs + i), w->rot + 4 * (f * J + (size_t)w->legs[i]),
                   4 * sizeof(double));
        }
}

/* Mark the rotations of w that differ from w->before by more than GUARDS_CHANGED, with the
   sign of the quaternion ignored, at w->legs (the others are marked unchanged); returns how
   many. */
static size_t mark_changed(const apply_work *w, size_t N, size_t J)
{
    size_t n = 0;
    memset(w->changed, 0, N * J);
    for (size_t f = 0; f < N; f++)
        for (size_t l = 0; l < w->n_legs; l++) {
            const size_t i = f * J + (size_t)w->legs[l];
            const double *a = w->rot + 4 * i, *b = w->before + 4 * (f * w->n_legs + l);
            const double sg =
                a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0 ? -1.0 : 1.0;
            double d = 0.0;
            for (int k = 0; k < 4; k++) {
                const double e = fabs(a[k] - sg * b[k]);
                d = e > d ? e : d;
            }
            n += w->changed[i] = d > GUARDS_CHANGED;
        }
    return n;
}

/* Unit quaternions where mask (N x J) is set, at the n_joints joints (the only ones it
   marks); MLR_E_INVALID_ARG when one is not finite or zero. */
static mlr_status normalize_masked(double *rot, const uint8_t *mask, size_t N, size_t J,
                                   const int32_t *joints, size_t n_joints, mlr_diag *diag)
{
    for (size_t f = 0; f < N; f++)
        for (size_t l = 0; l < n_joints; l++) {
            const size_t i = f * J + (size_t)joints[l];
            if (!mask[i])
                continue;
            double *q = rot + 4 * i;
            const double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
            if (!isfinite(n2) || !(n2 > 0))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "limits: rot_in[%zu][%d] is %s", f, (int)joints[l],
                                        isfinite(n2) ? "zero" : "not finite");
            const double r = sqrt(n2);
            q[0] /= r, q[1] /= r, q[2] /= r, q[3] /= r;
        }
    return MLR_OK;
}

/* The limits of every kind (the soft saturation) on the rotations the cleanup's hook gives
   (the IK's before the spread, the blends' after it): the hook of clean_and_limit. */
typedef struct ik_limits {
    const mlr_guards *g;
    const double *alpha;
    size_t n_alpha;
    size_t *counts; /* per joint, zeroed by the caller */
} ik_limits;

static void limit_ik(void *ctx, size_t N, size_t J, double *rot, const uint8_t *mask,
                     const int32_t *joints, size_t n_joints, int count)
{
    const ik_limits *c = ctx;
    (void)J; /* (the IK's and the spread's rotations are unit to rounding) */
    for (int kind = MLR_LIMITS_HINGE; kind <= MLR_LIMITS_SWING_TWIST; kind++)
        limits__apply_kind_masked(c->g->limits, N, (mlr_quat *)rot, c->alpha, c->n_alpha,
                                  count ? c->counts : NULL, kind, mask, joints, n_joints, 0);
}

/* The hinges (knees, elbows: a rotation about the hinge axis each) that the cleanup took out
   of their range, back to the bound, on the rotations it changed only (the others were
   limited before it). The soft saturation would also move the in-range angles near a bound
   (a straight stance knee within the reversal margin), and with them the feet the cleanup
   pinned (LaFAN1 at alpha 3 slid 1.09x the input's with it, 0.99x without). */
static mlr_status clamp_changed_hinges(const mlr_guards *g, const apply_work *w,
                                       const double *alpha, size_t n_alpha, mlr_diag *diag)
{
    const size_t N = g->n_frames, J = g->n_joints;
    if (mark_changed(w, N, J) == 0)
        return MLR_OK;
    mlr_status st = normalize_masked(w->rot, w->changed, N, J, w->legs, w->n_legs, diag);
    if (st == MLR_OK)
        limits__apply_kind_masked(g->limits, N, (mlr_quat *)w->rot, alpha, n_alpha, w->counts2,
                                  MLR_LIMITS_HINGE, w->changed, w->legs, w->n_legs, 1);
    return st;
}

/* counts = the largest of counts and counts2, per joint. */
static void keep_largest(size_t *counts, const size_t *counts2, size_t J)
{
    for (size_t j = 0; j < J; j++)
        counts[j] = counts2[j] > counts[j] ? counts2[j] : counts[j];
}

/* The cleanup on the working frames, with the limits when they ran: IK may bend a knee or
   turn a hip past its range again (a foot pinned closer to the hip than the limited leg
   reaches), so within the cleanup's one call (the hook, limit_ik) the IK's rotations of the
   first pass are limited before they are spread and the frames of each pass's blends after
   it; the second pass pins the feet again from there, and the hinges it took out of range
   are clamped to it. This replaced two cleanup calls with the limits between them (two
   passes, the limits on every rotation the cleanup changed, one pass): 23 M instructions
   less per stylize of the bench clip, the same folds, reversals, floor and sliding on the
   shared clips (bench_plausibility.py), and the swing/twist excess of the IK down (the
   dog's at alpha 3 from 8.9 to 0.1 degrees). rep: root_shift_max, *crep the cleanup's
   report. */
static mlr_status clean_and_limit(const mlr_guards *g, const apply_work *w, const double *alpha,
                                  size_t n_alpha, const double *trans, const mlr_cleanup_ref *ref,
                                  const uint8_t *contacts, const mlr_cleanup_option *copts,
                                  size_t n_copts, mlr_guards_report *rep, mlr_cleanup_report *crep,
                                  mlr_diag *diag)
{
    const size_t N = g->n_frames, J = g->n_joints;
    const int limits = rep->limits_applied;
    ik_limits ctx = {g, alpha, n_alpha, w->counts2};
    mlr_status st = MLR_OK;
    /* the swing-twist joints' corrections cut to the cleanup's excess (run_hook's
       hook_excess); the hinges' stay whole (clamp_changed_hinges clamps them after) */
    uint8_t *excess = limits ? alloc_array(&g->alloc, J, 1, &st) : NULL;
    if (st != MLR_OK)
        return common__diag_set(diag, st, 0, 0, "guards: out of memory (%zu joints)", J);
    for (size_t j = 0; excess && j < J; j++)
        excess[j] = g->limits->joints[j].range.kind == MLR_LIMITS_SWING_TWIST;
    const mlr_cleanup_hook hook = {limit_ik, &ctx, GUARDS_IK_LIMIT_PASSES,
                                   GUARDS_BLEND_LIMIT_PASSES, excess};
    if (limits) {
        keep_legs(w, N, J);
        memset(w->counts2, 0, J * sizeof(size_t));
    }
    /* the reference's trajectories are made once: the input's at create, a given one in
       apply_reference; the rig and the points were checked at create, the motion by
       apply_check (the limits keep it finite), so the cleanup does not check them again */
    st = cleanup__contacts_ref(&g->rig, N, g->fps, g->up, w->root, w->rot, trans, ref, 1,
                               limits ? &hook : NULL, g->n_points, g->joints, g->end_sites,
                               contacts, copts, n_copts, w->root, w->rot, crep, &g->alloc, diag);
    free_array(&g->alloc, excess, J, 1);
    if (st != MLR_OK)
        return st;
    rep->root_shift_max = crep->root_shift_max;
    if (!limits)
        return MLR_OK;
    keep_largest(w->counts, w->counts2, J);
    memset(w->counts2, 0, J * sizeof(size_t));
    if ((st = clamp_changed_hinges(g, w, alpha, n_alpha, diag)) == MLR_OK)
        keep_largest(w->counts, w->counts2, J);
    return st;
}

/* The limits' corrections of rot (its limits in work) eased in time (limits__ease): a joint
   running into its bound is braked over 0.2 s instead of in the frames where it crosses the
   soft zone (the foot's acceleration was up to 3.7x the synthesis's on Xia's walks at alpha 2-3,
   0.7-0.9x after). A hinge swung from one bound to the other within that window can be left a
   little outside its range (CMU 01_01's elbow at alpha 2, 0.36 degrees): that excess, the
   hinges' hard clamp, is eased the same way in turn, and what is left of it clamped. */
static mlr_status ease_limits(const mlr_guards *g, const double *rot, double *work,
                              const double *alpha, size_t n_alpha, const size_t *counts)
{
    const size_t N = g->n_frames, J = g->n_joints;
    mlr_status st = limits__ease(rot, work, N, J, g->fps, counts, &g->alloc);
    if (st != MLR_OK)
        return st;
    double *clamped = alloc_array(&g->alloc, 4 * N * J, sizeof(double), &st);
    if (st != MLR_OK)
        return st;
    memcpy(clamped, work, 4 * N * J * sizeof(double));
    limits__apply_kind_masked(g->limits, N, (mlr_quat *)clamped, alpha, n_alpha, NULL,
                              MLR_LIMITS_HINGE, NULL, NULL, 0, 1);
    if ((st = limits__ease(work, clamped, N, J, g->fps, counts, &g->alloc)) == MLR_OK) {
        limits__apply_kind_masked(g->limits, N, (mlr_quat *)clamped, alpha, n_alpha, NULL,
                                  MLR_LIMITS_HINGE, NULL, NULL, 0, 1);
        memcpy(work, clamped, 4 * N * J * sizeof(double));
    }
    free_array(&g->alloc, clamped, 4 * N * J, sizeof(double));
    return st;
}

/* Where a static root stands above a moving pelvis (Bandai's joint_Root at the origin, the walk
   in the position channels of Hips), the body's shifts in root_pos (the cleanup lowering the
   body, the floor raising it) are carried by the body joint instead: its translation gets the
   shift in its parent's frame and the root keeps the synthesis's place. The body joint's
   subtree is where it was; the root (and any joint outside that subtree) no longer moves with
   the body: Bandai's joint_Root went 16% of body height under the floor at alpha 3. */
static void carry_body_shift(const mlr_guards *g, const double *root_in, double *work_root,
                             const double *rot, double *trans)
{
    const size_t N = g->n_frames, J = g->n_joints, P = g->n_trans;
    const int32_t b = g->body_joint;
    for (size_t f = 0; f < N; f++) {
        double d[3];
        for (int k = 0; k < 3; k++)
            d[k] = work_root[3 * f + k] - root_in[3 * f + k];
        if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0)
            continue;
        /* the world rotation of the body joint's parent: the product along its ancestors */
        mlr_quat w = {1.0, 0.0, 0.0, 0.0};
        int32_t chain[64];
        size_t n = 0;
        for (int32_t j = g->parents[b]; j >= 0 && n < 64; j = g->parents[j])
            chain[n++] = j;
        while (n > 0) {
            const mlr_quat *q = (const mlr_quat *)(rot + 4 * (f * J + (size_t)chain[--n]));
            common__quat_mul_inline(&w, q, &w);
        }
        const mlr_quat wc = {w.w, -w.x, -w.y, -w.z};
        double local[3];
        common__quat_rotate_inline(&wc, d, local);
        double *t = trans + 3 * (f * P + (size_t)g->body_trans);
        for (int k = 0; k < 3; k++) {
            t[k] += local[k];
            work_root[3 * f + k] = root_in[3 * f + k];
        }
    }
}

static mlr_status guards_apply(const mlr_guards *g, const double *alpha, size_t n_alpha,
                               const double *ref_root_pos, const double *ref_rot,
                               const double *ref_trans, double *root_pos, double *rot,
                               const double *trans, double *trans_out, size_t *limited,
                               size_t n_limited, mlr_guards_report *report, mlr_diag *diag)
{
    mlr_status st = apply_check(g, alpha, n_alpha, ref_root_pos, ref_rot, ref_trans, root_pos, rot,
                                trans, limited, n_limited, diag);
    if (st != MLR_OK)
        return st;
    const size_t N = g->n_frames, J = g->n_joints;
    const int has_ref = ref_root_pos || ref_rot || ref_trans;

    mlr_guards_report rep = {0, 0, 0, 0, 0, NAN, 0.0, 0};
    mlr_cleanup_ref *made_ref = NULL;
    const mlr_cleanup_ref *ref = NULL;
    st = MLR_OK;
    double *work = alloc_array(&g->alloc, 4 * N * J, sizeof(double), &st);
    double *work_root = alloc_array(&g->alloc, 3 * N, sizeof(double), &st);
    size_t *counts = alloc_array(&g->alloc, J, sizeof(size_t), &st);
    size_t *counts2 = alloc_array(&g->alloc, J, sizeof(size_t), &st);
    const int limits_on = limits_wanted(g, alpha, n_alpha);
    double *before = NULL; /* (made once the legs are known) */
    size_t n_before = 0;
    uint8_t *changed = limits_on ? alloc_array(&g->alloc, N * J, 1, &st) : NULL;
    int32_t *legs = limits_on ? alloc_array(&g->alloc, J, sizeof(int32_t), &st) : NULL;
    double *in_pos = NULL, *in_wrot = NULL; /* (made once the floor is known to be on) */
    if (st != MLR_OK) {
        common__diag_set(diag, st, 0, 0, "guards apply: out of memory");
        goto done;
    }
    memcpy(work_root, root_pos, 3 * N * sizeof(double));
    memset(counts, 0, J * sizeof(size_t));
    if (limits_on) {
        /* the limits take 1 or 1 + J alphas, as the layers' synthesis */
        if (limits__apply_normalized(g->limits, N, rot, work, alpha, n_alpha, counts) != MLR_OK) {
            st = rot_error(g, rot, diag);
            goto done;
        }
        if ((st = ease_limits(g, rot, work, alpha, n_alpha, counts)) != MLR_OK) {
            common__diag_set(diag, st, 0, 0, "guards apply: out of memory");
            goto done;
        }
        rep.limits_applied = 1;
    } else {
        memcpy(work, rot, 4 * N * J * sizeof(double));
    }
    const size_t C = g->contacts_on ? g->n_points : 0;
    const int floor_on = g->floor_on && isfinite(g->floor_height) && g->n_points > 0;
    const int denoising = is_denoise(alpha, n_alpha);
    if (floor_on) { /* the input's forward kinematics, once for the passes that compare with it */
        in_pos = alloc_array(&g->alloc, 3 * N * J, sizeof(double), &st);
        in_wrot = alloc_array(&g->alloc, 4 * N * J, sizeof(double), &st);
        if (st == MLR_OK)
            st = mlr_fk_arrays(N, J, g->parents, g->offsets, g->root_pos, g->rot, g->n_trans,
                               g->trans_joints, g->trans, in_pos, in_wrot, &g->alloc, NULL);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
    }
    const guards_input in = {g->root_pos, g->rot, g->trans, in_pos, in_wrot};
    if (rep.limits_applied && !denoising && g->n_arms) {
        /* elbows on the input's side of straight (hinge_side.c), a limit as the others are
           (so not at |alpha| <= 1 by default), before the floor's passes see the arms */
        size_t turned = 0;
        memset(changed, 0, N * J);
        st = hinge_side__apply(&g->rig, N, g->fps, g->arms, g->n_arms, g->arms_ref, work_root,
                               work, trans, changed, &turned, &g->alloc);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
        /* an elbow the limits bind as a hinge (about their own axis, which the input's bends
           give a little apart from this pass's) is clamped to it again where it was turned:
           CMU 60_10's forearm ended 0.006 degrees past it at alpha 3 */
        int32_t hinges[HINGE_SIDE_MAX];
        size_t n_hinges = 0;
        for (size_t k = 0; turned && k < g->n_arms; k++)
            if (g->limits->joints[g->arms[k].middle].range.kind == MLR_LIMITS_HINGE)
                hinges[n_hinges++] = g->arms[k].middle;
        if (n_hinges) {
            memset(counts2, 0, J * sizeof(size_t));
            limits__apply_kind_masked(g->limits, N, (mlr_quat *)work, alpha, n_alpha, counts2,
                                      MLR_LIMITS_HINGE, changed, hinges, n_hinges, 1);
            keep_largest(counts, counts2, J);
            memset(counts2, 0, J * sizeof(size_t));
        }
    }
    if (floor_on && !denoising) { /* the rest of the body above the floor (floor_chains.c),
                                    before the cleanup pins the feet of the result; not in
                                    denoise, where the input is the noisy capture (blending
                                    MediaPipe's toward it changed denoise by 47% of H) */
        size_t lifted = 0;
        st = floor_chains__apply(&g->rig, N, g->fps, g->up, g->floor_height,
                                 GUARDS_FLOOR_SLACK * g->body_height, &in, work_root, work, trans,
                                 g->body_trans, g->n_points, g->joints, 0, &lifted, &g->alloc);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
    }
    if (floor_on && (st = tilt_toes(g, &in, work_root, work, trans, diag)) != MLR_OK)
        goto done; /* toe tips above the floor by a tilt, before the cleanup would lift the
                      whole foot for them (toe_tilt.c) */
    if (C > 0 || floor_on) {
        if ((st = apply_reference(g, ref_root_pos, ref_rot, ref_trans, denoising, &ref, &made_ref,
                                  diag)) != MLR_OK)
            goto done;
        /* floor alone: the feet with no contact frame, so only the floor constrains them */
        uint8_t *none = NULL;
        if (C == 0) {
            none = alloc_array(&g->alloc, g->n_points * N, 1, &st);
            if (st != MLR_OK) {
                common__diag_set(diag, st, 0, 0, "guards apply: out of memory");
                goto done;
            }
            memset(none, 0, g->n_points * N);
        }
        mlr_cleanup_option copts[GUARDS_MAX_COPTS];
        const size_t n_copts =
            cleanup_options(g, has_ref, alpha, n_alpha, floor_on, rep.limits_applied, copts);
        mlr_cleanup_report crep;
        size_t n_legs = 0;
        if (changed) { /* the hinges among the contact points' joints and their ancestors
                          (marked in changed[0..J) first) */
            memset(changed, 0, J);
            for (size_t c = 0; c < g->n_points; c++)
                for (int32_t j = g->joints[c]; j >= 0 && !changed[j]; j = g->parents[j])
                    changed[j] = 1;
            for (size_t j = 0; j < J; j++)
                if (changed[j] && g->limits->joints[j].range.kind == MLR_LIMITS_HINGE)
                    legs[n_legs++] = (int32_t)j;
            n_before = 4 * N * n_legs;
            before = alloc_array(&g->alloc, n_before, sizeof(double), &st);
            if (st != MLR_OK) {
                free_array(&g->alloc, none, g->n_points * N, 1);
                common__diag_set(diag, st, 0, 0, "guards apply: out of memory");
                goto done;
            }
        }
        const apply_work w = {work, work_root, counts, counts2, before, changed, legs, n_legs};
        st = clean_and_limit(g, &w, alpha, n_alpha, trans, ref, C ? g->contacts : none, copts,
                             n_copts, &rep, &crep, diag);
        free_array(&g->alloc, none, g->n_points * N, 1);
        if (st != MLR_OK) {
            common__diag_prefix(diag, st, "guards"); /* the cleanup's message names guards */
            goto done;
        }
        rep.contact_frames = crep.contact_frames;
        rep.floor_frames = crep.floor_frames;
        rep.floor_height = floor_on ? crep.floor_height : NAN;
    }
    /* the toe tips once more, where the cleanup's IK and root shift took them under the floor,
       before the corners' smoothing: the last lift raised the whole body for them once a step
       (CMU 12_01 at alpha 0.5 kept 2.65 alpha of its bob) */
    if (floor_on && (st = tilt_toes(g, &in, work_root, work, trans, diag)) != MLR_OK)
        goto done;
    if (C > 0 || floor_on || rep.limits_applied) {
        /* the corners where guards meet, smoothed (depop.c); before the floor's last word */
        size_t smoothed = 0;
        st = depop__apply(&g->rig, N, g->fps, g->root_pos, g->rot, g->trans, root_pos, rot, trans,
                          g->n_points, g->joints, g->end_sites, C ? g->contacts : NULL,
                          rep.limits_applied ? g->limits : NULL, alpha, n_alpha, work_root, work,
                          &smoothed, &g->alloc);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
    }
    if (floor_on && C > 0 && !denoising) {
        /* what the cleanup's root shift took under the floor (a dog's tail where a hind leg
           could not reach: 2.6% of body height at alpha 3), lifted by the chains that carry no
           foot: the feet stay pinned */
        size_t lifted = 0;
        st = floor_chains__apply(&g->rig, N, g->fps, g->up, g->floor_height,
                                 GUARDS_FLOOR_SLACK * g->body_height, &in, work_root, work, trans,
                                 g->body_trans, g->n_points, g->joints, 1, &lifted, &g->alloc);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
    }
    if (floor_on && C > 0 && !denoising) {
        /* knees above the floor: each leg turned about its hip-ankle axis (legs_swivel.c) */
        size_t turned = 0;
        st = legs_swivel__apply(&g->rig, N, g->fps, g->up, g->floor_height,
                                GUARDS_FLOOR_SLACK * g->body_height, &in, work_root, work, trans,
                                g->n_points, g->joints, &turned, &g->alloc);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
    }
    if (floor_on) {
        st = raise_to_floor(g, ref, work_root, work, trans, 1, &rep.floor_raised);
        if (st != MLR_OK) {
            fk_failure(st, diag);
            goto done;
        }
    }
    for (size_t j = 0; j < J; j++) {
        rep.limited_joints += counts[j] > 0;
        rep.limited_frames = counts[j] > rep.limited_frames ? counts[j] : rep.limited_frames;
    }
    if (trans_out && g->body_trans >= 0)
        carry_body_shift(g, root_pos, work_root, work, trans_out);
    memcpy(root_pos, work_root, 3 * N * sizeof(double));
    memcpy(rot, work, 4 * N * J * sizeof(double));
    if (limited)
        memcpy(limited, counts, J * sizeof(size_t));
    if (report)
        *report = rep;
done:
    cleanup__ref_destroy(made_ref);
    free_array(&g->alloc, work, 4 * N * J, sizeof(double));
    free_array(&g->alloc, work_root, 3 * N, sizeof(double));
    free_array(&g->alloc, counts, J, sizeof(size_t));
    free_array(&g->alloc, counts2, J, sizeof(size_t));
    free_array(&g->alloc, before, n_before, sizeof(double));
    free_array(&g->alloc, changed, N * J, 1);
    free_array(&g->alloc, legs, J, sizeof(int32_t));
    free_array(&g->alloc, in_pos, 3 * N * J, sizeof(double));
    free_array(&g->alloc, in_wrot, 4 * N * J, sizeof(double));
    return st;
}

mlr_status mlr_guards_apply(const mlr_guards *g, const double *alpha, size_t n_alpha,
                            const double *ref_root_pos, const double *ref_rot,
                            const double *ref_trans, double *root_pos, double *rot,
                            const double *trans, size_t *limited, size_t n_limited,
                            mlr_guards_report *report, mlr_diag *diag)
{
    return guards_apply(g, alpha, n_alpha, ref_root_pos, ref_rot, ref_trans, root_pos, rot, trans,
                        NULL, limited, n_limited, report, diag);
}

mlr_status mlr_guards_apply_trans(const mlr_guards *g, const double *alpha, size_t n_alpha,
                                  const double *ref_root_pos, const double *ref_rot,
                                  const double *ref_trans, double *root_pos, double *rot,
                                  double *trans, size_t *limited, size_t n_limited,
                                  mlr_guards_report *report, mlr_diag *diag)
{
    return guards_apply(g, alpha, n_alpha, ref_root_pos, ref_rot, ref_trans, root_pos, rot, trans,
                        trans, limited, n_limited, report, diag);
}

mlr_status mlr_guards_create_from(const mlr_guards_input *input, const mlr_allocator *alloc,
                                  mlr_guards **out, mlr_diag *diag)
{
    if (!input) {
        if (out)
            *out = NULL;
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards: NULL input");
    }
    const mlr_frames *f = &input->frames;
    return mlr_guards_create(input->rig, input->fps, f->n_frames, f->root_pos, f->rot, f->trans,
                             input->opts, input->n_opts, alloc, out, diag);
}

/* The job's own fields: a handle and a job, a reference given for the handle's frames. */
static mlr_status job_check(const mlr_guards *g, const mlr_guards_job *job, mlr_diag *diag)
{
    if (!g || !job)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "guards job: NULL %s",
                                g ? "job" : "handle");
    const mlr_frames *r = &job->reference;
    const int any = r->root_pos || r->rot || r->trans;
    if (any ? r->n_frames != g->n_frames : r->n_frames != 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "guards job: job.reference.n_frames is %zu, expected %zu",
                                r->n_frames, any ? g->n_frames : (size_t)0);
    return MLR_OK;
}

mlr_status mlr_guards_job_validate(const mlr_guards *g, const mlr_guards_job *job, mlr_diag *diag)
{
    mlr_status st = job_check(g, job, diag);
    if (st != MLR_OK)
        return st;
    const mlr_frames *r = &job->reference;
    return apply_check(g, job->alpha, job->n_alpha, r->root_pos, r->rot, r->trans, job->root_pos,
                       job->rot, job->trans, job->limited, job->n_limited, diag);
}

mlr_status mlr_guards_run(const mlr_guards *g, const mlr_guards_job *job, mlr_diag *diag)
{
    mlr_status st = job_check(g, job, diag);
    if (st != MLR_OK)
        return st;
    const mlr_frames *r = &job->reference;
    return guards_apply(g, job->alpha, job->n_alpha, r->root_pos, r->rot, r->trans, job->root_pos,
                        job->rot, job->trans, job->body_on_trans ? job->trans : NULL, job->limited,
                        job->n_limited, job->report, diag);
}
