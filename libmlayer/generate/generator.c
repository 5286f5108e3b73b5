/* Frames of a generated motion one at a time (mlr_generate.h). A segment of `frames` frames is
 * computed (the walk, the knots, the spline, the GRBF, the smoothing) into one of two sets of
 * buffers; its frames are then finished one by one (rotations renormalized, heading and body
 * position integrated). The first segment is computed in the first call; each later one is
 * computed ahead, in equal parts over the calls of the segment before it (its walk and spline,
 * then its GRBF rows one by one, then its smoothing a few columns at a time), so no call does a
 * whole segment's work. The parts are the same computations in the same order (the GRBF rows
 * and the smoothing's columns are independent sums), so the frames do not change. The steps and
 * their order are those of PrimitiveModel.generate and motion_along
 * (bindings/python/mlayer/primitives.py). */
#include "common/options_internal.h"
#include "generate/gen_internal.h"
#include "guards/limits_internal.h"
#include "manifold/grbf_eval_internal.h"
#include "mlayer/mlr_fk.h"
#include "mlayer/mlr_generate.h"
#include "mlayer/mlr_ik.h"
#include "mlayer/mlr_rig.h"

#include <math.h>

#define STIFFNESS 1e-3 /* PrimitiveModel.spline's lam^2 sigma^2 */
#define MAX_FRAMES 10000000
#define SMOOTH_COLS 16 /* outputs smoothed per part of a segment computed ahead */
#define GRBF_ROWS 4    /* GRBF rows per part */
#define GEN_MAX_FEET 8 /* feet pinned at run time */
/* a foot touches: its lowest point within PIN_HEIGHT leg lengths of the floor and its ankle
   slower than PIN_SPEED leg lengths a second; a pinned foot is let go over PIN_RELEASE s */
#ifndef PIN_HEIGHT
#define PIN_HEIGHT 0.08
#endif
#ifndef PIN_SPEED
#define PIN_SPEED 0.6
#endif
#define PIN_RELEASE 0.2

/* One segment's walk, knots, manifold points and outputs. */
typedef struct segment {
    int64_t *path;           /* frames + 3: the distinct states of the walk */
    size_t path_len;
    double *knots, *times;   /* (frames + 3) x 2, frames + 3 */
    size_t n_knots;          /* knots used */
    double *traj;            /* frames x 2 */
    double *y;               /* frames x n_out */
} segment;

struct mlr_generator {
    mlr_allocator alloc;
    const mlr_gen_model *model;
    mlr_rng rng;
    /* options */
    size_t frames;
    int64_t start_frame_opt, start_opt;
    int rank, allow_unseen;
    double smooth, noise;
    uint64_t seed;
    mlr_markov *perturbed;   /* the chain with noise, or NULL */
    const mlr_markov *mk;    /* the chain walked */
    /* state */
    int started, broken;
    uint64_t produced;
    size_t f;                /* frame within the segment */
    int64_t start_frame;
    double yaw, x, z;        /* heading and body position of the next frame */
    double point[2];
    segment seg[2];          /* the current segment (cur) and the next, computed ahead */
    int cur;
    size_t knot;             /* the current segment's knot the current frame moves toward */
    size_t parts, done;      /* parts of the next segment, parts computed */
    size_t grbf_parts;       /* parts of the GRBF rows */
    mlr_status ahead_st;     /* a failure computing the next segment, reported at its start */
    mlr_diag ahead_diag;
    grbf_eval_plan plan;     /* the model's GRBF, packed once */
    mlr_lgs *smoother;       /* the outputs' LGS, made once */
    size_t bytes;
    void *block;
    /* the per-frame guards (mlr_generator_set_guards), all borrowed but gbuf */
    int guarded;
    const mlr_rig *rig;
    const mlr_limits *limits;
    size_t n_floor;          /* floor points (the model's contact points), 0: no floor guard */
    size_t body_slot;        /* the body joint's slot among the rig's trans joints */
    double *g_root, *g_trans, *g_wpos, *g_wrot, *g_pts; /* 3, 3 P, 3 J, 4 J, 3 C */
    int32_t *g_joint, *g_end, *g_foot;                   /* C, C, C (a point's foot or -1) */
    size_t gbytes;
    void *gbuf;
    /* the feet pinned at run time (MLR_GEN_OPT_PIN_FEET): ankle, hip, knee, the foot's points
       (ankle, toe: joint or End Site, -1 for none), the leg's length; per foot the state */
    int pin_feet;
    size_t n_feet;
    int32_t ft_ankle[GEN_MAX_FEET], ft_hip[GEN_MAX_FEET], ft_knee[GEN_MAX_FEET];
    double ft_leg[GEN_MAX_FEET];
    int ft_pinned[GEN_MAX_FEET], ft_have_prev;
    double ft_held[GEN_MAX_FEET][3], ft_release[GEN_MAX_FEET], ft_prev[GEN_MAX_FEET][3];
    double ft_from[GEN_MAX_FEET][3]; /* where a released foot's target starts */
};

static const mlr_opt_spec generate_opts[] = {
    {MLR_GEN_OPT_FRAMES, "frames", MLR_OPT_INT, 2.0, MAX_FRAMES, 0, 0, 300.0,
     "an integer in 2 .. 10000000"},
    {MLR_GEN_OPT_START_FRAME, "start_frame", MLR_OPT_INT, -1.0, INFINITY, 0, 0, -1.0, NULL},
    {MLR_GEN_OPT_START, "start", MLR_OPT_INT, -1.0, INFINITY, 0, 0, -1.0, NULL},
    {MLR_GEN_OPT_RANK, "rank", MLR_OPT_INT, 0.0, 2.0, 0, 0, 0.0,
     "0 (sampled), 1 (most likely) or 2 (second most likely)"},
    {MLR_GEN_OPT_SMOOTH, "smooth", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 2.0, NULL},
    {MLR_GEN_OPT_NOISE, "noise", MLR_OPT_DOUBLE, 0.0, INFINITY, 0, 0, 0.0, NULL},
    {MLR_GEN_OPT_ALLOW_UNSEEN, "allow_unseen", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 0.0, NULL},
    {MLR_GEN_OPT_PIN_FEET, "pin_feet", MLR_OPT_BOOL, 0.0, 1.0, 0, 0, 1.0, NULL},
};

mlr_status mlr_generator_create(const mlr_allocator *alloc, const mlr_gen_model *model,
                                uint64_t seed, const mlr_generate_option *opts, size_t n_opts,
                                mlr_generator **out, mlr_diag *diag)
{
    if (!out || !model)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "generate: %s is NULL",
                                out ? "model" : "out");
    *out = NULL;
    mlr_opt_values v;
    mlr_status st = MLR_OPTIONS_READ("generate", generate_opts, opts, n_opts, &v, diag);
    if (st)
        return st;
    if (v.v[MLR_GEN_OPT_START_FRAME] >= (double)model->n_points)
        return options__reject(diag, "generate", "start_frame", v.v[MLR_GEN_OPT_START_FRAME],
                               "in -1 .. %zu (the model's training frames)", model->n_points - 1);
    if (v.v[MLR_GEN_OPT_START] >= (double)model->k)
        return options__reject(diag, "generate", "start", v.v[MLR_GEN_OPT_START],
                               "in -1 .. %zu (the model's primitives)", model->k - 1);
    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    mlr_generator *g = common__alloc(&a, sizeof *g);
    if (!g)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "generate: out of memory");
    memset(g, 0, sizeof *g);
    g->alloc = a;
    g->model = model;
    mlr_rng_seed(&g->rng, seed);
    g->seed = seed;
    g->frames = (size_t)v.v[MLR_GEN_OPT_FRAMES];
    g->start_frame_opt = (int64_t)v.v[MLR_GEN_OPT_START_FRAME];
    g->start_opt = (int64_t)v.v[MLR_GEN_OPT_START];
    g->rank = (int)v.v[MLR_GEN_OPT_RANK];
    g->smooth = v.v[MLR_GEN_OPT_SMOOTH];
    g->noise = v.v[MLR_GEN_OPT_NOISE];
    g->pin_feet = v.v[MLR_GEN_OPT_PIN_FEET] != 0.0;
    g->allow_unseen = v.v[MLR_GEN_OPT_ALLOW_UNSEEN] != 0.0;
    g->start_frame = -1;
    g->point[0] = g->point[1] = NAN;
    *out = g;
    return MLR_OK;
}

/* The buffers of two segments and the GRBF's plan, at the first frame. */
static mlr_status allocate(mlr_generator *g, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    size_t n = g->frames, cap = n + 3, total, ny;
    /* per segment: path (cap int64), knots (2 cap), times (cap), traj (2 n), y (n n_out); then
     * the plan (a multiple of 8 bytes) */
    const size_t plan = grbf__eval_plan_bytes(m->n_centers, 2, m->n_out);
    if (common__mul_size(n, m->n_out, &ny) || ny > SIZE_MAX / 16 - 4 * cap - 2 * n || plan == 0 ||
        plan > SIZE_MAX - 16 * (4 * cap + 2 * n + ny))
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "mlr_generator_next: sizes overflow");
    const size_t per = 4 * cap + 2 * n + ny;
    total = 2 * per * 8 + plan;
    unsigned char *b = common__alloc(&g->alloc, total);
    if (!b)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "mlr_generator_next: out of memory "
                                "(%zu bytes for %zu frames)",
                                total, n);
    g->block = b;
    g->bytes = total;
    for (int k = 0; k < 2; k++) {
        segment *sg = &g->seg[k];
        unsigned char *p = b + (size_t)k * per * 8;
        sg->path = (int64_t *)(void *)p;
        sg->knots = (double *)(void *)(p + 8 * cap);
        sg->times = sg->knots + 2 * cap;
        sg->traj = sg->times + cap;
        sg->y = sg->traj + 2 * n;
    }
    grbf__eval_plan_init(&g->plan, m->kernel, m->kernel ? m->width : 1.0, m->grbf_centers,
                         m->n_centers, 2, m->grbf_coef, m->n_out, m->n_out, 2,
                         (double *)(void *)(b + 2 * per * 8));
    g->mk = m->markov;
    if (g->noise > 0 || g->allow_unseen) {
        mlr_rng r;
        mlr_rng_seed(&r, g->seed ^ MLR_GEN_NOISE_SEED_XOR);
        mlr_status st = mlr_markov_perturb(m->markov, g->noise, g->allow_unseen, &r, &g->alloc,
                                           &g->perturbed, diag);
        if (st)
            return common__diag_prefix(diag, st, "mlr_generator_next");
        g->mk = g->perturbed;
    }
    if (g->smooth > 0 && n > 2) {
        mlr_status st = mlr_lgs_create(n, 2, g->smooth, 1.0, NULL, n, MLR_LGS_BANDED, &g->alloc,
                                       &g->smoother, diag);
        if (st < 0)
            return common__diag_prefix(diag, st, "mlr_generator_next");
    }
    /* a segment in parts: the walk and spline, the GRBF rows, the smoothing's column groups */
    g->grbf_parts = (n + GRBF_ROWS - 1) / GRBF_ROWS;
    g->parts = 1 + g->grbf_parts + (g->smoother ? (m->n_out + SMOOTH_COLS - 1) / SMOOTH_COLS : 0);
    return MLR_OK;
}

/* The knots and times of the segment from its walk (path[0 .. path_len-1], the first knot
 * given), cut at the last frame: PrimitiveModel.generate's. first_step: the frames of the first
 * step (a continuation's remainder), < 0 for the whole step. */
static void knots_from_path(const mlr_generator *g, segment *s, const double *p0,
                            double first_step)
{
    const mlr_gen_model *m = g->model;
    size_t L = s->path_len;
    s->knots[0] = p0[0];
    s->knots[1] = p0[1];
    s->times[0] = 0.0;
    for (size_t i = 1; i < L; i++) {
        const double *c = m->centers + 2 * (size_t)s->path[i];
        s->knots[2 * i] = c[0];
        s->knots[2 * i + 1] = c[1];
        double step = mlr_markov_step_frames(g->mk, s->path[i - 1], s->path[i]);
        if (i == 1 && first_step >= 0)
            step = first_step;
        s->times[i] = s->times[i - 1] + step;
    }
    s->n_knots = L;
    double last = (double)(g->frames - 1);
    if (s->times[L - 1] > last) {
        size_t i = 0; /* np.searchsorted(times, last): the first time >= last */
        while (s->times[i] < last)
            i++;
        double a = (last - s->times[i - 1]) / (s->times[i] - s->times[i - 1]);
        double *k0 = s->knots + 2 * (i - 1), *k1 = s->knots + 2 * i;
        double e0 = k0[0] + a * (k1[0] - k0[0]), e1 = k0[1] + a * (k1[1] - k0[1]);
        k1[0] = e0;
        k1[1] = e1;
        s->times[i] = last;
        s->n_knots = i + 1;
    }
}

/* The first segment: the start frame, the walk, its knots. */
static mlr_status first_walk(mlr_generator *g, segment *s, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    g->start_frame = g->start_frame_opt >= 0 ? g->start_frame_opt
                                             : (int64_t)mlr_rng_below(&g->rng, m->n_points);
    int64_t first = g->start_opt >= 0 ? g->start_opt : m->labels[g->start_frame];
    mlr_status st = mlr_markov_path(g->mk, NULL, 0, first, g->frames, g->rank, &g->rng, s->path,
                                    g->frames + 1, &s->path_len, diag);
    if (st)
        return common__diag_prefix(diag, st, "mlr_generator_next");
    knots_from_path(g, s, m->points + 2 * (size_t)g->start_frame, -1.0);
    return MLR_OK;
}

/* A continuation of segment pv: from its last point, through the state it was heading to (the
 * rest of that step), then on along the walk. */
static mlr_status next_walk(mlr_generator *g, const segment *pv, segment *s, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    const double *p0 = pv->traj + 2 * (g->frames - 1); /* the last frame's point */
    if (pv->n_knots < 2) { /* a walk of one state (a ranked walk on one primitive) */
        s->path[0] = pv->path[0];
        s->path_len = 1;
        knots_from_path(g, s, p0, -1.0);
        return MLR_OK;
    }
    size_t i = pv->n_knots - 1; /* the last knot (maybe cut) */
    int64_t from = pv->path[i - 1], to = pv->path[i];
    double full = mlr_markov_step_frames(g->mk, from, to);
    double done = pv->times[i] - pv->times[i - 1];
    double span =
        pv->knots[2 * i] != m->centers[2 * to] || pv->knots[2 * i + 1] != m->centers[2 * to + 1]
            ? full - done
            : -1.0;
    int64_t hist[MLR_MARKOV_MAX_ORDER];
    size_t nh = 0;
    for (size_t j = i >= MLR_MARKOV_MAX_ORDER ? i - MLR_MARKOV_MAX_ORDER + 1 : 0; j < i; j++)
        hist[nh++] = pv->path[j];
    if (span > 0) {
        /* path: from (the state left), to, then the walk on from to */
        size_t len = 0;
        mlr_status st = mlr_markov_path(g->mk, hist, nh, to, g->frames, g->rank, &g->rng,
                                        s->path + 1, g->frames + 1, &len, diag);
        if (st)
            return common__diag_prefix(diag, st, "mlr_generator_next");
        s->path[0] = from;
        s->path_len = len + 1;
        knots_from_path(g, s, p0, span);
    } else {
        /* the last knot was the centre itself: the walk goes on from it */
        hist[nh++] = to;
        size_t len = 0;
        int64_t start = to;
        mlr_status st = mlr_markov_path(g->mk, hist, nh - 1, start, g->frames, g->rank, &g->rng,
                                        s->path, g->frames + 1, &len, diag);
        if (st)
            return common__diag_prefix(diag, st, "mlr_generator_next");
        s->path_len = len;
        knots_from_path(g, s, p0, -1.0);
    }
    return MLR_OK;
}

/* Part 0 of a segment: the walk (pv: the segment before, NULL for the first), the spline
 * through the knots, the clip to the bounds. */
static mlr_status walk_and_spline(mlr_generator *g, const segment *pv, segment *s, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    size_t n = g->frames;
    mlr_status st = pv ? next_walk(g, pv, s, diag) : first_walk(g, s, diag);
    if (st)
        return st;
    for (size_t i = 1; i < s->n_knots; i++)
        if (!(s->times[i] > s->times[i - 1]))
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mlr_generator_next: knots at "
                                    "the same frame");
    if (s->n_knots == 1) {
        for (size_t f = 0; f < n; f++) {
            s->traj[2 * f] = s->knots[0];
            s->traj[2 * f + 1] = s->knots[1];
        }
    } else {
        mlr_lgs *sp = NULL;
        st = mlr_lgs_create(n, 2, sqrt(STIFFNESS), 1.0, s->times, s->n_knots, MLR_LGS_BANDED,
                            &g->alloc, &sp, diag);
        if (st < 0)
            return common__diag_prefix(diag, st, "mlr_generator_next: spline");
        st = mlr_lgs_solve(sp, s->knots, 2, 2, s->traj, 2, diag);
        mlr_lgs_destroy(sp);
        if (st < 0)
            return common__diag_prefix(diag, st, "mlr_generator_next: spline");
    }
    for (size_t f = 0; f < n; f++)
        for (int j = 0; j < 2; j++) {
            double v = s->traj[2 * f + j], lo = m->bounds[2 * j], hi = m->bounds[2 * j + 1];
            s->traj[2 * f + j] = v < lo ? lo : v > hi ? hi : v; /* np.clip */
        }
    return MLR_OK;
}

/* Parts [from, to) of segment s (pv the one before it, NULL for the first): part 0 the walk
 * and the spline, parts 1 .. G the GRBF rows, GRBF_ROWS per part, then the smoothing of
 * SMOOTH_COLS outputs per part. Runs of rows and of columns are computed together (the same
 * sums). */
static mlr_status compute_parts(mlr_generator *g, const segment *pv, segment *s, size_t from,
                                size_t to, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    const size_t n = g->frames, no = m->n_out, G = g->grbf_parts;
    if (from == 0 && to > 0) {
        mlr_status st = walk_and_spline(g, pv, s, diag);
        if (st)
            return st;
        from = 1;
    }
    if (from < to && from <= G) { /* the GRBF rows of parts from .. p1 - 1 */
        const size_t p1 = to < G + 1 ? to : G + 1;
        const size_t r0 = (from - 1) * GRBF_ROWS, r1 = (p1 - 1) * GRBF_ROWS;
        grbf__eval_plan_rows(&g->plan, s->traj + 2 * r0, (r1 < n ? r1 : n) - r0, 2, s->y + r0 * no,
                             no);
        from = p1;
    }
    if (from < to) { /* the smoothing's columns */
        const size_t c0 = (from - 1 - G) * SMOOTH_COLS, c1 = (to - 1 - G) * SMOOTH_COLS;
        const size_t cols = (c1 < no ? c1 : no) - c0;
        mlr_status st = mlr_lgs_solve(g->smoother, s->y + c0, no, cols, s->y + c0, no, diag);
        if (st < 0)
            return common__diag_prefix(diag, st, "mlr_generator_next: smoothing");
    }
    return MLR_OK;
}

/* After frame f (0 .. frames-1) of the current segment: the next segment's parts up to
 * ceil((f + 1) parts / frames), so they are all done after the last frame. A failure is kept
 * for the start of the next segment. */
static void compute_ahead(mlr_generator *g, size_t f)
{
    if (g->ahead_st)
        return;
    const size_t n = g->frames;
    size_t target = (size_t)(((unsigned long long)(f + 1) * g->parts + n - 1) / n);
    target = target < g->parts ? target : g->parts;
    if (target > g->done) {
        g->ahead_st = compute_parts(g, &g->seg[g->cur], &g->seg[1 - g->cur], g->done, target,
                                    &g->ahead_diag);
        g->done = target;
    }
}

/* A rig with the model's joints (names and parents), in the diag the first that differs. */
static mlr_status same_joints(const mlr_gen_model *m, const mlr_rig *rig, mlr_diag *diag)
{
    if (rig->n_joints != m->n_joints)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_generator_set_guards: rig: %zu joints, the model has %zu",
                                rig->n_joints, m->n_joints);
    for (size_t j = 0; j < m->n_joints; j++) {
        const char *b = rig->names ? rig->names[j] : NULL;
        if (!b || strcmp(m->name_at[j], b) != 0 || rig->parents[j] != m->parents[j])
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "mlr_generator_set_guards: rig: joint %zu is '%.40s' (parent "
                                    "%d), the model's is '%.40s' (parent %d)",
                                    j, b ? b : "", (int)rig->parents[j], m->name_at[j],
                                    (int)m->parents[j]);
    }
    return MLR_OK;
}

mlr_status mlr_generator_set_guards(mlr_generator *g, const mlr_rig *rig, const double *rest,
                                    const mlr_limits *limits, mlr_diag *diag)
{
    if (!g || !rig)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "mlr_generator_set_guards: %s is NULL", g ? "rig" : "gen");
    if (g->started || g->guarded)
        return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0, "mlr_generator_set_guards: %s",
                                g->guarded
                                    ? "the guards are set already"
                                    : "frames were generated already (set the guards before "
                                      "the first mlr_generator_next)");
    const mlr_gen_model *m = g->model;
    mlr_status st = mlr_rig_check(rig, diag);
    if (st)
        return common__diag_prefix(diag, st, "mlr_generator_set_guards: rig");
    st = same_joints(m, rig, diag);
    if (st)
        return st;
    const size_t J = m->n_joints, P = rig->n_trans, C = m->n_contacts;
    size_t slot = 0;
    if (m->body_joint != 0) {
        while (slot < P && (size_t)rig->trans_joints[slot] != m->body_joint)
            slot++;
        if (slot == P)
            return common__diag_set(
                diag, MLR_E_INVALID_ARG, 0, 0,
                "mlr_generator_set_guards: rig: the body joint %zu '%.40s' has "
                "no position channels (not one of the rig's trans joints)",
                m->body_joint, m->name_at[m->body_joint]);
    }
    if (limits && mlr_limits_n_joints(limits) != J)
        return common__diag_set(
            diag, MLR_E_INVALID_ARG, 0, 0,
            "mlr_generator_set_guards: limits of %zu joints for a model of %zu",
            mlr_limits_n_joints(limits), J);
    if (rest)
        for (size_t i = 0; i < 3 + 3 * P; i++)
            if (!isfinite(rest[i]))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "mlr_generator_set_guards: rest[%zu] is NaN or infinite",
                                        i);
    const size_t nc = isnan(m->floor_height) ? 0 : C;
    /* doubles 3 + 3 P + 7 J + 3 C, then 3 C int32 (sizes bounded by the rig's and the file's) */
    const size_t nd = 3 + 3 * P + 7 * J + 3 * nc, bytes = nd * 8 + 3 * nc * sizeof(int32_t);
    unsigned char *b = common__alloc(&g->alloc, bytes);
    if (!b)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0,
                                "mlr_generator_set_guards: out of memory (%zu bytes)", bytes);
    double *d = (double *)(void *)b;
    g->g_root = d, d += 3;
    g->g_trans = d, d += 3 * P;
    g->g_wpos = d, d += 3 * J;
    g->g_wrot = d, d += 4 * J;
    g->g_pts = d, d += 3 * nc;
    g->g_joint = (int32_t *)(void *)d;
    g->g_end = g->g_joint + nc;
    g->g_foot = g->g_end + nc;
    /* the floor points: the model's contact points, by name on the rig */
    const char *name = m->contact_names;
    for (size_t c = 0; c < nc; c++, name += strlen(name) + 1) {
        st = mlr_rig_find_point(rig, name, &g->g_joint[c], &g->g_end[c], diag);
        if (st) {
            common__free(&g->alloc, b, bytes);
            return common__diag_prefix(diag, st,
                                       "mlr_generator_set_guards: the model's contact point");
        }
    }
    for (int a = 0; a < 3; a++)
        g->g_root[a] = rest ? rest[a] : 0.0;
    for (size_t p = 0; p < 3 * P; p++) /* Python's rest_trans: the offsets without clips */
        g->g_trans[p] =
            rest ? rest[3 + p] : rig->offsets[3 * (size_t)rig->trans_joints[p / 3] + p % 3];
    /* the feet: the model's contact points that are joints with no other contact joint above
       them (the ankles, the paws), each with the contact points at or below it; a foot whose
       leg has no two-bone chain is not pinned */
    g->n_feet = 0;
    for (size_t c = 0; c < nc; c++)
        g->g_foot[c] = -1;
    for (size_t c = 0; g->pin_feet && c < nc && g->n_feet < GEN_MAX_FEET; c++) {
        const int32_t j = g->g_joint[c];
        int top = g->g_end[c] < 0 && g->g_foot[c] < 0;
        for (size_t c2 = 0; top && c2 < nc; c2++)
            for (int32_t a = rig->parents[j]; top && a >= 0; a = rig->parents[a])
                top = !(g->g_end[c2] < 0 && g->g_joint[c2] == a);
        int32_t hip, knee;
        mlr_diag quiet;
        if (!top || mlr_ik_leg_chain(rig, j, &hip, &knee, &quiet) != MLR_OK)
            continue;
        const size_t k = g->n_feet++;
        g->ft_ankle[k] = j, g->ft_hip[k] = hip, g->ft_knee[k] = knee;
        for (size_t c2 = 0; c2 < nc; c2++)
            for (int32_t a = g->g_joint[c2]; a >= 0; a = rig->parents[a])
                if (a == j) {
                    g->g_foot[c2] = (int32_t)k;
                    break;
                }
        const double *ok = rig->offsets + 3 * (size_t)knee, *oa = rig->offsets + 3 * (size_t)j;
        g->ft_leg[k] = sqrt(ok[0] * ok[0] + ok[1] * ok[1] + ok[2] * ok[2]) +
                       sqrt(oa[0] * oa[0] + oa[1] * oa[1] + oa[2] * oa[2]);
        g->ft_pinned[k] = 0, g->ft_release[k] = INFINITY;
    }
    g->ft_have_prev = 0;
    g->gbuf = b;
    g->gbytes = bytes;
    g->rig = rig;
    g->limits = limits;
    g->n_floor = nc;
    g->body_slot = slot;
    g->guarded = 1;
    return MLR_OK;
}

static double smoothstep(double x)
{
    x = x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
    return x * x * (3.0 - 2.0 * x);
}

/* The feet of a frame (its forward kinematics in g_wpos, g_wrot) pinned: a foot whose lowest
 * point is near the floor and whose ankle moves slowly (from the frame before, as generated)
 * keeps the ankle's position from its touch-down, by two-bone IK on its leg; a foot that lifts
 * or moves on is let go over PIN_RELEASE. *moved: some leg was turned. */
static mlr_status pin_feet(mlr_generator *g, double *pose, int *moved, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    const mlr_rig *rig = g->rig;
    const size_t J = m->n_joints, F = g->n_feet;
    const double dt = m->frame_time;
    double ankle[GEN_MAX_FEET][3], low[GEN_MAX_FEET];
    mlr_status st = mlr_rig_point_positions(rig, 1, g->g_wpos, g->g_wrot, g->n_floor, g->g_joint,
                                            g->g_end, g->g_pts, diag);
    if (st)
        return st;
    for (size_t f = 0; f < F; f++) {
        memcpy(ankle[f], g->g_wpos + 3 * (size_t)g->ft_ankle[f], sizeof ankle[f]);
        low[f] = INFINITY;
    }
    for (size_t c = 0; c < g->n_floor; c++)
        if (g->g_foot[c] >= 0)
            low[g->g_foot[c]] = fmin(low[g->g_foot[c]], g->g_pts[3 * c + 1]);
    *moved = 0;
    for (size_t f = 0; f < F; f++) {
        const double L = g->ft_leg[f];
        double speed = INFINITY;
        if (g->ft_have_prev) {
            const double dx = ankle[f][0] - g->ft_prev[f][0], dz = ankle[f][2] - g->ft_prev[f][2];
            speed = sqrt(dx * dx + dz * dz) / dt;
        }
        const int touch = low[f] <= m->floor_height + PIN_HEIGHT * L && speed <= PIN_SPEED * L;
        double target[3], w;
        if (touch) {
            if (!g->ft_pinned[f]) /* touch-down: held where the foot is (or where a release
                                     was taking it) */
                memcpy(g->ft_held[f], g->ft_release[f] < PIN_RELEASE ? g->ft_from[f] : ankle[f],
                       sizeof g->ft_held[f]);
            g->ft_pinned[f] = 1;
            w = 1.0;
        } else {
            if (g->ft_pinned[f]) { /* let go: from the held position */
                g->ft_pinned[f] = 0;
                g->ft_release[f] = 0.0;
            }
            if (!(g->ft_release[f] < PIN_RELEASE))
                continue;
            g->ft_release[f] += dt;
            w = 1.0 - smoothstep(g->ft_release[f] / PIN_RELEASE);
        }
        for (int k = 0; k < 3; k++)
            target[k] = ankle[f][k] + w * (g->ft_held[f][k] - ankle[f][k]);
        memcpy(g->ft_from[f], target, sizeof target);
        st = mlr_ik_apply_leg(1, J, rig->parents, pose + 3, g->g_wpos, g->g_wrot, g->ft_hip[f],
                              g->ft_knee[f], g->ft_ankle[f], target, NULL, diag);
        if (st)
            return st;
        *moved = 1;
    }
    for (size_t f = 0; f < F; f++)
        memcpy(g->ft_prev[f], ankle[f], sizeof ankle[f]);
    g->ft_have_prev = 1;
    return MLR_OK;
}

/* The per-frame guards on a finished frame: the joint limits (alpha 1), the feet pinned
 * (pin_feet) and the limits again on what the IK turned, then the body lifted by how far the lowest floor point is below the model's floor
 * (y up), nothing when none is. */
static mlr_status guard_frame(mlr_generator *g, double *pose, mlr_diag *diag)
{
    const mlr_gen_model *m = g->model;
    const mlr_rig *rig = g->rig;
    if (g->limits)
        limits__apply_frame(g->limits, (mlr_quat *)(void *)(pose + 3), NULL, 1, NULL);
    if (!g->n_floor)
        return MLR_OK;
    const size_t P = rig->n_trans;
    double *body = m->body_joint == 0 ? g->g_root : g->g_trans + 3 * g->body_slot;
    memcpy(body, pose, 3 * sizeof(double));
    mlr_status st = mlr_fk_arrays(1, m->n_joints, rig->parents, rig->offsets, g->g_root, pose + 3,
                                  P, rig->trans_joints, P ? g->g_trans : NULL, g->g_wpos,
                                  g->g_wrot, &g->alloc, diag);
    if (st == MLR_OK && g->n_feet) {
        int moved = 0;
        st = pin_feet(g, pose, &moved, diag);
        if (st == MLR_OK && moved && g->limits) /* the legs the IK turned, within the limits */
            limits__apply_frame(g->limits, (mlr_quat *)(void *)(pose + 3), NULL, 1, NULL);
        if (st == MLR_OK && moved)
            st = mlr_fk_arrays(1, m->n_joints, rig->parents, rig->offsets, g->g_root, pose + 3, P,
                               rig->trans_joints, P ? g->g_trans : NULL, g->g_wpos, g->g_wrot,
                               &g->alloc, diag);
    }
    if (st == MLR_OK)
        st = mlr_rig_point_positions(rig, 1, g->g_wpos, g->g_wrot, g->n_floor, g->g_joint,
                                     g->g_end, g->g_pts, diag);
    if (st)
        return common__diag_prefix(diag, st, "mlr_generator_next: guards");
    double lift = 0.0;
    for (size_t c = 0; c < g->n_floor; c++) {
        const double below = m->floor_height - g->g_pts[3 * c + 1];
        lift = below > lift ? below : lift;
    }
    pose[1] += lift;
    return MLR_OK;
}

mlr_status mlr_generator_next(mlr_generator *g, double *pose, mlr_diag *diag)
{
    if (!g || !pose)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "mlr_generator_next: %s is NULL",
                                g ? "pose" : "gen");
    if (g->broken)
        return common__diag_set(diag, MLR_E_BAD_STATE, 0, 0,
                                "mlr_generator_next: a segment failed "
                                "before; destroy the generator");
    const mlr_gen_model *m = g->model;
    mlr_status st;
    if (!g->started) {
        g->started = 1;
        st = allocate(g, diag);
        if (st) {
            g->broken = 1;
            return st;
        }
    }
    if (g->produced == 0) { /* the first segment, whole */
        st = compute_parts(g, NULL, &g->seg[0], 0, g->parts, diag);
        if (st) {
            g->broken = 1;
            return st;
        }
        g->f = 0;
        g->knot = 1;
    } else if (g->f == g->frames) { /* the next segment, computed ahead */
        if (g->ahead_st) {
            g->broken = 1;
            if (diag)
                *diag = g->ahead_diag;
            return g->ahead_st;
        }
        g->cur = 1 - g->cur;
        g->done = 0;
        g->f = 0;
        g->knot = 1;
    }
    size_t f = g->f, J = m->n_joints;
    const segment *cs = &g->seg[g->cur];
    const double *y = cs->y + f * m->n_out;
    /* motion_along: rotations renormalized (_split), the body joint's turned by the heading */
    double c = cos(g->yaw), s = sin(g->yaw);
    double vx = y[1], vz = y[2];
    pose[0] = g->x;
    pose[1] = y[0];
    pose[2] = g->z;
    mlr_quat *o = (mlr_quat *)(void *)(pose + 3);
    for (size_t j = 0; j < J; j++) {
        const double *q = y + 4 + 4 * j;
        /* _split: q / np.linalg.norm(q) */
        double nq = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        o[j].w = q[0] / nq;
        o[j].x = q[1] / nq;
        o[j].y = q[2] / nq;
        o[j].z = q[3] / nq;
    }
    const mlr_quat head = {cos(g->yaw / 2), 0.0, sin(g->yaw / 2), 0.0}; /* heading_quat */
    mlr_quat_mul(&head, &o[m->body_joint], &o[m->body_joint]);
    st = mlr_quat_normalize_array(o, J, o, diag); /* quat.normalize */
    if (st < 0) {
        g->broken = 1;
        return common__diag_prefix(diag, st, "mlr_generator_next");
    }
    if (g->guarded) {
        st = guard_frame(g, pose, diag);
        if (st) {
            g->broken = 1;
            return st;
        }
    }
    g->point[0] = cs->traj[2 * f];
    g->point[1] = cs->traj[2 * f + 1];
    while (g->knot + 1 < cs->n_knots && cs->times[g->knot] < (double)f)
        g->knot++;
    /* the next frame's heading and position */
    g->x += c * vx + s * vz;
    g->z += -s * vx + c * vz;
    g->yaw += y[3];
    g->f++;
    g->produced++;
    compute_ahead(g, f);
    return MLR_OK;
}

uint64_t mlr_generator_frame(const mlr_generator *g) { return g ? g->produced : 0; }

void mlr_generator_point(const mlr_generator *g, double point[2])
{
    if (!point)
        return;
    point[0] = g ? g->point[0] : NAN;
    point[1] = g ? g->point[1] : NAN;
}

int64_t mlr_generator_primitive(const mlr_generator *g)
{
    if (!g || !g->produced)
        return -1;
    const segment *s = &g->seg[g->cur];
    return s->path[g->knot < s->path_len ? g->knot : s->path_len - 1];
}

int64_t mlr_generator_start_frame(const mlr_generator *g) { return g ? g->start_frame : -1; }

void mlr_generator_destroy(mlr_generator *g)
{
    if (!g)
        return;
    mlr_allocator a = g->alloc;
    mlr_lgs_destroy(g->smoother);
    mlr_markov_destroy(g->perturbed);
    if (g->block)
        common__free(&a, g->block, g->bytes);
    if (g->gbuf)
        common__free(&a, g->gbuf, g->gbytes);
    common__free(&a, g, sizeof *g);
}
